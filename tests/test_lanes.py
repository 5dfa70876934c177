"""The lane kernel (eight environments per SIMD register) against the per-environment kernel: same
trajectories to rounding for every term, lock set and aerodynamic model, the same blow-up handling, and
vectorised code; its table look-up against numpy's."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import llvmlite.binding as llvm
import numpy as np
import pytest
from numba import njit

from rig_env.params import RigParams, param_batch
from rig_env.physics import aero as A
from rig_env.physics import integrator as I
from rig_env.physics import lanes as LN
from rig_env.physics import layout as L

ALL = L.F_AERO | L.F_FRICTION | L.F_STOPS | L.F_SERVO
LOCK_SETS = [(0, 1, 2, 3, 4), (0, 3), (1, 3), (2, 4), (0, 2, 3, 4), (3,)]


def batch(n: int, free: tuple[int, ...], seed: int):
    """Random healthy states, per-environment parameters, delays and the arrays both kernels take."""
    rng = np.random.default_rng(seed)
    P = param_batch(
        RigParams.default(), n,
        {"mass.hawk_mass": rng.uniform(0.8, 1.5, n), "hawk_aero.CMalpha": rng.uniform(-0.7, -0.4, n),
         "friction.rig_roll.Fc": rng.uniform(0.02, 0.05, n), "geometry.hawk_cg_x": rng.uniform(-0.02, 0.02, n)},
    )  # fmt: skip
    X = np.zeros((n, L.N_STATE))
    X[:, L.X_Q : L.X_Q + 5] = rng.uniform(-0.3, 0.3, (n, 5))
    X[:, L.X_QD : L.X_QD + 5] = rng.uniform(-1.0, 1.0, (n, 5))
    X[:, L.X_Z : L.X_Z + 5] = rng.uniform(-1e-4, 1e-4, (n, 5))
    locked = [j for j in range(5) if j not in free]
    X[:, [L.X_QD + j for j in locked]] = 0.0
    X[:, [L.X_Z + j for j in locked]] = 0.0
    delay = rng.integers(0, 4, (n, 2)).astype(np.int64)
    dbuf = np.zeros((n, 8, 7))
    return X, P, delay, dbuf, np.array(free, dtype=np.int64)


def run_both(X, P, delay, dbuf, free_idx, flags, steps, rng, h=0.0025, n_sub=5, tabs=None):
    """Both kernels over ``steps`` control steps from the same states, inputs and tables (default: the default rig's)."""
    n = X.shape[0]
    Xa, Xb, da, db = X.copy(), X.copy(), dbuf.copy(), dbuf.copy()
    sa, sb = np.zeros(n, np.int8), np.zeros(n, np.int8)
    Wk, MW = I.new_work(n)
    S = LN.new_work(n, n_sub)
    tabs = RigParams.default().tables() if tabs is None else tabs
    step, lit = LN.kernel(flags, True), LN.literal_args(tabs, flags)
    for k in range(steps):
        U = np.zeros((n, L.N_INPUTS))
        U[:, :6] = rng.uniform(-0.5, 0.5, (n, 6))  # surface commands, rad
        U[:, L.U_GUST : L.U_GUST + 3] = rng.normal(0.0, 0.5, (n, 3))
        U[:, L.U_AIRSPEED] = rng.uniform(15.0, 25.0, n)
        U[:, L.U_GUST_COMP : L.U_GUST_COMP + 3] = rng.normal(0.0, 0.5, (n, 3))
        I.step_serial(Xa, da, k * n_sub, delay, P, U, flags, free_idx, len(free_idx), tabs, h, n_sub, sa, Wk, MW)
        step(Xb, db, k * n_sub, delay, P, U, flags, free_idx, len(free_idx), tabs, h, n_sub, sb, S, k == 0, *lit)  # P packed once
    return Xa, Xb, sa, sb, da, db


@pytest.mark.parametrize("free", LOCK_SETS)
def test_lanes_follow_the_per_environment_kernel_with_every_term_on(free):
    """19 environments (two full blocks and a partial one), random commands, gusts and airspeeds every
    control step, 100 control steps (1.25 s): every state equal to 1e-10."""
    X, P, delay, dbuf, free_idx = batch(19, free, seed=sum(free))
    Xa, Xb, sa, sb, da, db = run_both(X, P, delay, dbuf, free_idx, ALL, 100, np.random.default_rng(1))
    assert np.all(sa == 0) and np.all(sb == 0)
    moved = np.abs(Xa - X).max()
    assert moved > 0.1  # the rig moved
    assert np.abs(Xb - Xa).max() < 1e-10
    assert np.array_equal(da, db)  # the same demands entered the delay lines
    locked = [j for j in range(5) if j not in free]
    assert np.array_equal(Xb[:, locked], X[:, locked])  # locked joints stay put


@pytest.mark.parametrize("flags", [0, L.F_AERO, L.F_FRICTION | L.F_STOPS, L.F_AERO | L.F_SERVO, ALL & ~L.F_SERVO])
def test_lanes_follow_the_per_environment_kernel_with_terms_off(flags):
    X, P, delay, dbuf, free_idx = batch(11, (0, 1, 3), seed=flags)
    Xa, Xb, sa, sb, *_ = run_both(X, P, delay, dbuf, free_idx, flags, 60, np.random.default_rng(2))
    assert np.all(sa == 0) and np.all(sb == 0)
    assert np.abs(Xb - Xa).max() < 1e-10


def test_a_blown_up_environment_is_flagged_and_frozen_the_others_carry_on():
    X, P, delay, dbuf, free_idx = batch(12, (0, 1, 2, 3, 4), seed=7)
    P[3, L.P_MASS_HAWK_MASS] = np.nan  # non-finite from the first step
    X[9, L.X_QD + 2] = 2.0 * L.RUNAWAY_RATE  # a runaway rate, which the friction and aero terms turn into NaN within the step
    Xa, Xb, sa, sb, *_ = run_both(X, P, delay, dbuf, free_idx, ALL, 20, np.random.default_rng(3))
    assert sa[3] == sb[3] == L.S_NONFINITE and sb[9] != L.S_OK and sa[9] == sb[9]
    assert np.array_equal(Xb[[3, 9]], X[[3, 9]])  # frozen at the last healthy state
    healthy = [i for i in range(12) if i not in (3, 9)]
    assert np.all(sb[healthy] == 0) and np.abs(Xb[healthy] - Xa[healthy]).max() < 1e-10


TABLES = ALL | L.F_NONLINEAR
UNSTEADY = ALL | L.F_NONLINEAR | L.F_UNSTEADY


def lopsided_tables() -> tuple[np.ndarray, ...]:
    """The default tables with the compensator's normal force no longer odd (a tenth more on the positive
    side, as a cambered section would have): the lane kernel looks it up over the whole table."""
    tabs = RigParams.default().tables()
    cn = np.where(tabs[3] > 0.0, 1.1 * tabs[4], tabs[4])
    return (*tabs[:4], cn)


@pytest.mark.parametrize("comp_table", ["odd", "lopsided"])
@pytest.mark.parametrize("flags", [TABLES, UNSTEADY], ids=["tables", "unsteady"])
@pytest.mark.parametrize("free", [(0, 1, 2, 3, 4), (0, 3, 4)])
def test_lanes_follow_the_per_environment_kernel_with_the_high_incidence_models(flags, free, comp_table):
    """The high-incidence tables and the flow-separation states on the lane kernel (tables as tuples, looked
    up as a sum over segments; the default compensator table, odd, over its non-negative half, a lopsided one
    over the whole table) against the per-environment kernel (binary search): 19 environments, random
    commands, gusts and airspeeds, 100 control steps with the rig swinging through the stall (joint angles up
    to 0.3 rad, rates up to 1 rad/s), every state, the five separation states included, equal to 1e-10."""
    tabs = RigParams.default().tables() if comp_table == "odd" else lopsided_tables()
    assert LN.literal_args(tabs, flags)[2] == (9 if comp_table == "odd" else 0)  # the form the lane kernel compiles
    X, P, delay, dbuf, free_idx = batch(19, free, seed=5)
    X[:, L.X_SEP : L.X_SEP + L.N_SEP] = 1.0  # attached flow at the start: the states must move
    Xa, Xb, sa, sb, da, db = run_both(X, P, delay, dbuf, free_idx, flags, 100, np.random.default_rng(4), tabs=tabs)
    assert np.all(sa == 0) and np.all(sb == 0)
    assert np.abs(Xa - X).max() > 0.1
    sep = Xa[:, L.X_SEP : L.X_SEP + L.N_SEP]
    if flags & L.F_UNSTEADY:
        assert sep.min() < 0.5  # some lifting surface separated on the way
    else:
        assert np.all(sep == 1.0)  # held without the unsteady model
    assert np.abs(Xb - Xa).max() < 1e-10
    assert np.array_equal(da, db)


def test_every_model_runs_on_lanes_in_the_environments():
    """The environments choose the lane kernel whatever the aerodynamic model (the tasks' defaults included:
    departure recovery flies the tables)."""
    from rig_env.envs import RigVectorEnv

    for model in ("linear", "tables", "unsteady"):
        env = RigVectorEnv(2, task="pull_up_push_over", aero_model=model)
        assert env.physics.kernel.kind == "lanes", model
    assert RigVectorEnv(2, task="departure_recovery").physics.kernel.kind == "lanes"


def test_lane_shape_names_the_model_the_tables_lengths_and_the_compensator_tables_form():
    tabs = RigParams.default().tables()
    nh, nc = tabs[0].size, tabs[3].size
    assert LN.lane_shape(tabs, ALL) == (0, 0, 0, 0)
    assert LN.lane_shape(tabs, TABLES) == (1, nh, nc, (nc + 1) // 2)  # the default compensator table is odd
    assert LN.lane_shape(tabs, UNSTEADY) == (2, nh, nc, (nc + 1) // 2)
    assert LN.lane_shape(lopsided_tables(), UNSTEADY) == (2, nh, nc, 0)
    assert LN.literal_args(tabs, ALL) == () and LN.literal_args(tabs, UNSTEADY) == (nh, nc, (nc + 1) // 2)
    assert LN.kernel(ALL, True) is LN.step_lanes and LN.kernel(TABLES, False) is LN.step_lanes_tables_serial
    assert LN.kernel(UNSTEADY, True) is LN.step_lanes_unsteady
    assert LN.model_of(LN.lane_tables(tabs, *LN.lane_shape(tabs, UNSTEADY))) == 2
    assert LN.model_of(LN.lane_tables(tabs, *LN.lane_shape(tabs, TABLES))) == 1
    assert LN.model_of(tabs) == 0
    odd = LN.lane_tables(tabs, *LN.lane_shape(tabs, TABLES))
    assert odd[3] == tuple(tabs[3][nc // 2 :]) and odd[4][2] is A.ODD  # the non-negative half, marked
    full = LN.lane_tables(tabs, 1, nh, nc, 0)  # an odd table may still be looked up whole
    assert full[3] == tuple(tabs[3]) and len(full[4]) == 2
    with pytest.raises(ValueError, match="breakpoints"):
        LN.lane_tables(tabs, 1, nh + 1, nc, 0)
    with pytest.raises(ValueError, match="comp_half"):
        LN.lane_tables(lopsided_tables(), 1, nh, nc, (nc + 1) // 2)


@njit(cache=False)
def _lookup(x, xs, ys):
    """A.interp at every x, compiled for the tables' form (arrays: the search; tuples: the sum)."""
    out = np.empty(x.size)
    for i in range(x.size):
        out[i] = A.interp(x[i], xs, ys)
    return out


@pytest.mark.parametrize("which", [(0, 1), (0, 2), (3, 4)], ids=["hawk_CL", "hawk_CM", "comp_CN"])
def test_the_sum_over_segments_is_the_piecewise_linear_table(which):
    """The lane kernel's look-up (the sum form: a sum over the segments) against numpy's interp and the
    per-environment kernel's binary search: at every breakpoint, midway between, at random points and beyond
    both ends (end values held), to 1e-14; the interpolant is piecewise linear (exact on a straight segment)."""
    tabs = RigParams.default().tables()
    xs, ys = tabs[which[0]], tabs[which[1]]
    rng = np.random.default_rng(0)
    x = np.concatenate([xs, 0.5 * (xs[1:] + xs[:-1]), rng.uniform(xs[0] - 0.5, xs[-1] + 0.5, 2000), [xs[0] - 3.0, xs[-1] + 3.0]])
    want = np.interp(x, xs, ys)
    xt, form = A.table_sum_form(xs, ys)
    got_t = _lookup(x, xt, form)
    got_a = _lookup(x, xs, ys)
    np.testing.assert_allclose(got_t, want, rtol=0.0, atol=1e-14)
    np.testing.assert_allclose(got_a, want, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose([A.interp(v, xt, form) for v in x[:50]], want[:50], rtol=0.0, atol=1e-14)  # Python twins
    assert A.interp(float(xs[0]) - 1.0, xs, ys) == ys[0] and A.interp(float(xs[-1]) + 1.0, xs, ys) == ys[-1]


def test_the_odd_form_is_the_whole_odd_table():
    """The compensator's normal force is odd (CN(-alpha) = -CN(alpha)); the lane kernel looks it up as
    sign(x) f+(|x|), f+ the sum over its non-negative half (aero.table_odd_form, aero.odd_table).  Against
    numpy's interp on the whole table: over a dense grid from -150 to 150 deg (end values held beyond +-90),
    exactly 0 and -0, every breakpoint and midway between them, compiled and in Python, to 1e-12 (it is
    within a few 1e-16)."""
    tabs = RigParams.default().tables()
    xs, ys = tabs[3], tabs[4]
    assert A.odd_half(xs, ys) == 9
    xt, form = A.table_odd_form(xs, ys)
    assert xt == tuple(xs[8:]) and xt[0] == 0.0 and len(form[1]) == 8 and form[2] is A.ODD
    x = np.concatenate([np.radians(np.linspace(-150.0, 150.0, 30001)), [0.0, -0.0], xs, 0.5 * (xs[1:] + xs[:-1]), -xs, [-4.0, 4.0]])
    want = np.interp(x, xs, ys)
    got = _lookup(x, xt, form)
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose([A.interp(v, xt, form) for v in x[::97]], want[::97], rtol=0.0, atol=1e-12)  # Python twin
    np.testing.assert_allclose(got, -_lookup(-x, xt, form), rtol=0.0, atol=0.0)  # odd to the last bit
    assert _lookup(np.array([-4.0, 4.0]), xt, form) == pytest.approx([ys[0], ys[-1]], abs=1e-14)  # end values held


def test_a_table_odd_only_nearly_or_on_lopsided_breakpoints_takes_the_full_form():
    """aero.odd_half: odd to the last bit, breakpoints symmetric about 0 with 0 among them, or not odd; a
    table that is not odd is refused the odd form and looked up whole, still numpy's interp."""
    tabs = RigParams.default().tables()
    xs, ys = tabs[3], tabs[4]
    nudged = ys.copy()
    nudged[-2] = np.nextafter(nudged[-2], 2.0)  # one ulp off odd
    shifted = xs.copy()
    shifted[-2] += 1e-3  # breakpoints no longer symmetric
    even = np.radians([-60.0, -10.0, 10.0, 60.0]), np.array([-1.0, -1.154, 1.154, 1.0])  # symmetric and odd, but 0 no breakpoint
    assert A.odd_half(xs, nudged) == A.odd_half(shifted, ys) == A.odd_half(*even) == 0
    assert A.odd_half(tabs[0], tabs[1]) == 0  # the Hawk's lift (cambered)
    cn = lopsided_tables()[4]
    assert A.odd_half(xs, cn) == 0
    with pytest.raises(ValueError, match="not odd"):
        A.table_odd_form(xs, cn)
    x = np.concatenate([np.radians(np.linspace(-150.0, 150.0, 3001)), [0.0], xs])
    xt, form = A.table_sum_form(xs, cn)
    np.testing.assert_allclose(_lookup(x, xt, form), np.interp(x, xs, cn), rtol=0.0, atol=1e-14)


def cached_object(kernel, literals: tuple[int, ...]) -> bytes:
    """The ELF object numba's disk cache holds for ``kernel`` compiled with the literal arguments ``literals``
    (:func:`rig_env.physics.lanes.literal_args`; none for the linear kernel): its index maps each signature to a
    data file."""
    from numba.core import types

    want = tuple(types.literal(v) for v in literals)
    cache = kernel._cache
    index = cache._cache_file._load_index()
    names = [name for key, name in index.items() if not want or tuple(key[0][-len(want):]) == want]
    assert names, f"{kernel} was not cached for {literals}"
    data = (Path(cache._cache_path) / names[0]).read_bytes()
    return data[data.index(b"\x7fELF") :]


@pytest.mark.parametrize("flags", [ALL, TABLES, UNSTEADY], ids=["linear", "tables", "unsteady"])
def test_the_lane_loops_are_vectorised(tmp_path, flags):
    """The point of the kernel: its loops over the lanes compiled to packed (vector) instructions, for every
    aerodynamic model.  A change that brings a library call, a loop or an unanalysable memory access into
    them falls back to scalar code silently; this catches it (rig_env.physics.lanes lists the rules).  Reads
    the machine code of step_lanes_serial (everything it calls linked in) from numba's disk cache, where it
    is an ELF object, and counts the instructions of the physics step's own symbol."""
    objdump = shutil.which("objdump")
    if objdump is None:
        pytest.skip("needs objdump (Debian package binutils)")
    if "+avx2" not in llvm.get_host_cpu_features().flatten():
        pytest.skip("no 256-bit vectors on this processor (AVX2): the lane kernel runs scalar here")
    X, P, delay, dbuf, free_idx = batch(8, (0, 3), seed=0)
    S, U, st = LN.new_work(8, 5), np.zeros((8, L.N_INPUTS)), np.zeros(8, np.int8)
    tabs = RigParams.default().tables()
    step, lit = LN.kernel(flags, False), LN.literal_args(tabs, flags)
    step(X, dbuf, 0, delay, P, U, flags, free_idx, 2, tabs, 0.0025, 5, st, S, True, *lit)
    obj = tmp_path / "step_lanes_serial.o"
    obj.write_bytes(cached_object(step, lit))
    asm = subprocess.run([objdump, "-d", str(obj)], capture_output=True, text=True, check=True).stdout
    # the physics step's own machine code (its loops over the lanes): the packing, the delay lines and the
    # checks around it are scalar by design and would dilute the count
    parts = re.split(r"^[0-9a-f]+ <([^>]+)>:$", asm, flags=re.M)
    step = "".join(body for name, body in zip(parts[1::2], parts[2::2]) if "physics_step" in name)
    assert step, "no physics_step symbol in step_lanes_serial's object"
    packed = len(re.findall(r"\bv\w+pd\s+[^\n]*%[yz]mm", step))  # double-precision ops on 256/512-bit registers
    scalar = len(re.findall(r"\bv\w+sd\s+[^\n]*%xmm", step))  # ... on one double
    # measured on a Zen 4 (AVX-512): linear 4593 packed, 236 scalar
    assert packed > 2000, (packed, scalar, step.count("vdivsd"))
    assert packed > 5 * scalar, (packed, scalar)


@pytest.mark.parametrize("n_sub, n_buf", [(5, 13), (1, 4), (7, 3)])
def test_delay_lines_staged_once_per_control_step_read_what_the_per_environment_kernel_reads(n_sub, n_buf):
    """The lane kernel fills its delay lines once per control step (the commands are held over it); the
    per-environment kernel pushes and reads them physics step by physics step.  With the buffer as short
    as the longest delay allows (n_buf = max delay + 1, so the oldest slot is read just before it is
    overwritten) and delays from 0 to beyond a control step, both read the same demands: the delay lines
    end equal bit for bit and the states to rounding."""
    n = 11
    X, P, _, _, free_idx = batch(n, (0, 3), seed=n_sub)
    delay = np.random.default_rng(n_buf).integers(0, n_buf, (n, 2)).astype(np.int64)
    delay[0] = n_buf - 1, 0
    dbuf = np.zeros((n, n_buf, 7))
    Xa, Xb, sa, sb, da, db = run_both(X, P, delay, dbuf, free_idx, ALL, 30, np.random.default_rng(4), h=0.0125 / n_sub, n_sub=n_sub)
    assert np.all(sa == 0) and np.all(sb == 0)
    assert np.array_equal(da, db)
    assert np.abs(Xb - Xa).max() < 1e-10


def test_a_scratch_too_short_for_the_control_step_is_an_error():
    X, P, delay, dbuf, free_idx = batch(8, (0, 3), seed=0)
    S, U, st = LN.new_work(8, 4), np.zeros((8, L.N_INPUTS)), np.zeros(8, np.int8)
    with pytest.raises(ValueError, match="n_sub"):
        LN.step_lanes_serial(X, dbuf, 0, delay, P, U, ALL, free_idx, 2, RigParams.default().tables(), 0.0025, 5, st, S, True)
    with pytest.raises(ValueError, match="n_sub"):
        LN.new_work(8, 0)


@pytest.mark.parametrize("n", [1, 9, 64, 1024, 3000])
def test_the_scratch_is_zeroed_and_every_lane_group_is_cache_line_aligned(n):
    S = LN.new_work(n, 5)
    assert S.shape == ((n + LN.W - 1) // LN.W, LN.row_length(5)) and S.flags.c_contiguous
    assert not S.any()
    # each quantity's W lanes are one 64-byte line: the start, and every row, on a line boundary
    assert S.ctypes.data % 64 == 0 and S.strides[1] * LN.W == 64 and S.strides[0] % 64 == 0

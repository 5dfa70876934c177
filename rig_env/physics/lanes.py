"""The joint-space integrator with eight environments side by side in SIMD lanes.

Same model, same integration scheme and same interface as :mod:`rig_env.physics.integrator` (Strang
splitting of the LuGre bristles around one classical RK4 step per physics step, servo limits after
it, per-environment delay lines, blow-up detection and freezing), computed for a block of ``W = 8``
environments at a time so that LLVM turns every floating-point operation into one 512-bit vector
operation over the eight.  The right-hand side is the one :mod:`rig_env.physics.joint_space` gives
(:func:`~rig_env.physics.joint_space.mass_matrix_terms`, :func:`~rig_env.physics.joint_space.forces`,
:func:`~rig_env.physics.joint_space.solve_free`): no second copy of the dynamics.

Why the layout is what it is (each rule was found by making a probe's loop fail without it;
``benchmarks/RESULTS.md``): LLVM vectorises a loop over environments only when

1. every memory access in it is ``row[k * W + lane]`` of one flat array with constant ``k`` (two arrays,
   or a strided view, need run-time pointer checks and the cost model then declines), so each block's
   state, parameters, inputs and RK stages live in one row of the scratch ``S`` (lanes innermost);
2. it calls no library function (sines, exponentials and arctangents come from
   :mod:`rig_env.physics.vmath`) and contains no loop of its own (the compensator's panels are written
   out: ``forces(..., unrolled=True)``);
3. it branches on nothing but values (every per-environment choice is a select; the model's flags are
   the same for every lane).

A choice that is the same for every lane still costs both sides inside such a loop (the vectoriser
turns it into a select).  So the joints' friction and bristle updates, the costliest part of the
right-hand side per joint (friction's exponentials), run in loops of their own, one per
joint, entered only for the free joints (:func:`stage_torques`, :func:`bristles`): a locked joint's
friction is never computed.  With two free joints (velocity-vector roll) that made the lane kernel
about 12 % faster (median of four alternating A/B runs, ``benchmarks/RESULTS.md``).

The delay lines index each environment's own buffer by its own delay, which no loop over the lanes can
vectorise, so they are served once per control step rather than once per physics step
(:func:`stage_demands`): the commands are held over the control step, so each environment's limited demand
is computed once and the delayed demands of all its physics steps are staged in the block's row
(``row_length(n_sub)`` floats; the per-environment kernel computes the demand every physics step).  The
buffers end bit for bit as the per-environment kernel leaves them (``tests/test_lanes.py``).

The high-incidence tables (``aero_model="tables"``, ``F_NONLINEAR``) and the flow-separation states
(``"unsteady"``, ``F_UNSTEADY``) run here too.  A table search per evaluation is a loop whose trip count
differs from lane to lane; the kernel takes the tables as tuples of floats instead (:func:`lane_tables`),
looked up as a sum over the segments with no branch (:func:`rig_env.physics.aero.sum_table`); an odd
compensator table (the default's normal force, CN(-alpha) = -CN(alpha)) as the sum over its non-negative
half, sign restored (:func:`rig_env.physics.aero.odd_table`: half the segments, for the strips' eight
look-ups per RK stage and the panels' four per physics step).  Which model a kernel runs is known when it
is compiled, from the tables' type (:func:`model_of`: arrays for the linear model, which never reads them),
so the linear kernel's loops carry none of the tables' work and each model is its own compiled kernel;
so is the compensator table's form (:func:`lane_shape`).  The separation states are split around the RK4
step as the bristles are, relaxed exactly over h/2 on either side (the two halves inside a control step
merged into one over h, as :func:`rig_env.physics.integrator.physics_step` does).  Each physics step's opening
relaxation runs in RK stage 0's loop over the lanes (:func:`rk_stage`), at the state that stage starts from, so that
the arm's kinematics and air the two share are computed once; only the control step's closing half has a loop of
its own.

Results equal :mod:`rig_env.physics.integrator`'s to rounding (``tests/test_lanes.py``: 2e-13 rad
after 100 control steps with every term on, every lock set), not bit for bit: the order of some
floating-point operations differs.  On a processor without AVX-512 the same code runs in two 256-bit
halves (AVX2) or scalar: correct either way, fast only with vectors.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from numba import literally, njit, prange, types
from numba.core import cgutils
from numba.extending import intrinsic, overload, register_jitable

from rig_env.physics import friction as fr
from rig_env.physics.aero import odd_half, table_odd_form, table_sum_form
from rig_env.physics import layout as L
from rig_env.physics import servo as sv
from rig_env.physics.integrator import N_Y, RK_C, RK_W, limited_demands
from rig_env.physics.joint_space import (
    ATTACHED, fixture_torque, forces, free_mask, friction_torque, mass_matrix_terms, separation_step, solve_free_rank1,
)  # fmt: skip
from rig_env.physics.llvm_inline import inlined
from rig_env.physics.vmath import FASTMATH

W = 8
"""Environments per block: the lanes of a 512-bit register of float64."""

_JIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=False)
_JIT_BATCH = dict(cache=True, error_model="numpy", fastmath=FASTMATH)
_GENERATED = dict(_JIT, inline="always", cache=False)  # source made by exec has no file to cache against; inlined into cached callers

# one block's row of the scratch S: each quantity k of lane l at row[OFF_... + k * W + l]
OFF_X = 0  # state (layout.X_...), N_STATE
OFF_P = OFF_X + L.N_STATE * W  # parameters, N_PARAMS
OFF_U = OFF_P + L.N_PARAMS * W  # inputs, N_INPUTS
OFF_UD = OFF_U + L.N_INPUTS * W  # delayed, limited actuator demands of the physics step, 7
OFF_Y0 = OFF_UD + 7 * W  # RK state at the start of the physics step, N_Y
OFF_K = OFF_Y0 + N_Y * W  # the last stage's derivative, N_Y
OFF_ACC = OFF_K + N_Y * W  # the stages' weighted sum, N_Y
OFF_DECAY = OFF_ACC + N_Y * W  # each joint's bristle decay (a, g) over h/2 at the rates of the last half step, 10
OFF_FRIC = OFF_DECAY + 10 * W  # each joint's friction and fixture torque at the current RK stage, 5
BLOCK = OFF_FRIC + 5 * W
"""Floats of a block's row before the staged demands (see :func:`row_length`)."""
OFF_STAGE = BLOCK  # the delayed demands of every physics step of the control step, n_sub x 7
_ZERO_Y = (0.0,) * N_Y


MODELS = ("linear", "tables", "unsteady")
"""The aerodynamic models of :func:`model_of`, in its numbering."""


def lane_shape(tabs: tuple[np.ndarray, ...], flags: int) -> tuple[int, int, int, int]:
    """What the lane kernel needs to know of the model with ``flags`` and tables ``tabs`` (``RigParams.tables()``)
    when it is compiled: (model, n_hawk, n_comp, comp_half), model 0 linear, 1 the high-incidence tables
    (F_NONLINEAR), 2 with the flow-separation states too (F_UNSTEADY); n_hawk and n_comp the breakpoints of
    the Hawk's and the compensator's tables; comp_half the breakpoints of the compensator table's
    non-negative half when the table is odd (:func:`rig_env.physics.aero.odd_half`: then looked up over that
    half alone), else 0 (all 0 for the linear model, which never reads the tables).  Each model has its own
    kernel (:func:`kernel`), compiled for the last three (numba's ``literally``): :func:`lane_tables`."""
    model = model_number(flags)
    if model == 0:
        return 0, 0, 0, 0
    return model, int(np.size(tabs[0])), int(np.size(tabs[3])), odd_half(tabs[3], tabs[4])


def model_number(flags: int) -> int:
    """0 for the linear model, 1 the high-incidence tables (F_NONLINEAR), 2 with the separation states (F_UNSTEADY)."""
    return 0 if not flags & L.F_NONLINEAR else (2 if flags & L.F_UNSTEADY else 1)


def lane_tables(tabs: tuple[np.ndarray, ...], model: int, n_hawk: int, n_comp: int, comp_half: int) -> tuple:
    """The tables as the lane kernel's loops read them (:func:`lane_shape` gives the other arguments):
    ``tabs`` unchanged for the linear model (never read); otherwise the Hawk's and the compensator's
    breakpoints as tuples of floats and each table's values in their sum form (c, w) (looked up without
    a search: :func:`rig_env.physics.aero.sum_table`), in ``tabs``' order, and for the unsteady model a sixth,
    empty tuple that marks it (:func:`model_of`).  With comp_half > 0 the compensator's table is odd and
    comes as its non-negative half, comp_half breakpoints, with its values (c, w, ODD)
    (:func:`rig_env.physics.aero.table_odd_form`: looked up at half the cost).  In compiled code the tuples'
    lengths must be constants, so the kernel takes them as literal arguments and builds the tuples from the
    arrays once per block and control step (:func:`_lane_tables`; numba cannot pass tuples into a parallel
    loop); ValueError here if the arguments do not fit the tables."""
    if model == 0:
        return tabs
    sizes = (n_hawk, n_hawk, n_hawk, n_comp, n_comp)
    if tuple(np.size(t) for t in tabs[:5]) != sizes:
        raise ValueError(f"tables of {tuple(np.size(t) for t in tabs[:5])} breakpoints, not {sizes}")
    if comp_half not in (0, odd_half(tabs[3], tabs[4])):
        raise ValueError(f"comp_half = {comp_half}: the compensator's table has {odd_half(tabs[3], tabs[4])} (lane_shape)")
    xh, cl = table_sum_form(tabs[0], tabs[1])
    cm = table_sum_form(tabs[0], tabs[2])[1]
    xc, cn = table_odd_form(tabs[3], tabs[4]) if comp_half else table_sum_form(tabs[3], tabs[4])
    out = (xh, cl, cm, xc, cn)
    return (*out, ()) if model == 2 else out


def entry_point(kernel: Any, *literals: int) -> Callable[..., None] | None:
    """The compiled ``kernel`` (a high-incidence model's, :data:`KERNELS`) for its literal arguments (the tables'
    lengths, :func:`literal_args`) once it has been called with them, else None (and None for a kernel
    without literal arguments: its dispatcher is fast).

    The dispatcher of a function with literal arguments matches a call's plain integers to no compiled
    signature and resolves the literal one in Python, about 7 ms a call (against about 20 us for the whole
    control step of eight environments); :class:`rig_env.physics.pipeline.PhysicsBatch` calls this entry
    point directly instead (the same machine code)."""
    if not literals:
        return None
    want = tuple(types.literal(v) for v in literals)
    for sig, cres in kernel.overloads.items():
        if tuple(sig[-len(want):]) == want:
            return cres.entry_point
    return None


@overload(lane_tables, inline="always")
def _lane_tables(tabs, model, n_hawk, n_comp, comp_half):
    """:func:`lane_tables` in compiled code, written out for the literal model, lengths and compensator form
    (the breakpoints from index n_comp - comp_half on, its odd table's non-negative half, when comp_half > 0)."""
    if not all(isinstance(a, types.IntegerLiteral) for a in (model, n_hawk, n_comp, comp_half)):
        return None
    m, nh, nc, half = model.literal_value, n_hawk.literal_value, n_comp.literal_value, comp_half.literal_value
    if m == 0:
        return lambda tabs, model, n_hawk, n_comp, comp_half: tabs

    def grid(t: int, k0: int, n: int) -> str:  # breakpoints tabs[t][k0:k0 + n]
        return "(" + ", ".join(f"tabs[{t}][{k}]" for k in range(k0, k0 + n)) + ",)"

    def sum_form(g: int, t: int, k0: int, n: int, odd: bool) -> str:
        """(c, w) of values tabs[t] on breakpoints tabs[g][k0:k0 + n] (aero.table_sum_form), (c, w, ODD) if odd."""
        s = [f"((tabs[{t}][{k + 1}] - tabs[{t}][{k}]) / (tabs[{g}][{k + 1}] - tabs[{g}][{k}]))" for k in range(k0, k0 + n - 1)]
        w = [s[0]] + [f"({s[j]} - {s[j - 1]})" for j in range(1, n - 1)]
        c = f"tabs[{t}][{k0 + n - 1}] - {s[-1]} * tabs[{g}][{k0 + n - 1}]"
        return f"({c}, (" + ", ".join(w) + ",)" + (", ()" if odd else "") + ")"  # the empty tuple: aero.ODD

    k0, nk = (nc - half, half) if half else (0, nc)
    parts = [grid(0, 0, nh), sum_form(0, 1, 0, nh, False), sum_form(0, 2, 0, nh, False), grid(3, k0, nk), sum_form(3, 4, k0, nk, half > 0)]
    body = ", ".join(parts) + (", ()" if m == 2 else "")
    ns: dict = {}
    exec(f"def build(tabs, model, n_hawk, n_comp, comp_half):\n    return ({body})\n", ns)
    return ns["build"]


def model_of(tabs: tuple) -> int:
    """The aerodynamic model the lane kernel runs with tables ``tabs`` (:func:`lane_tables`): 0 linear (arrays),
    1 the high-incidence tables (five tuples), 2 with the flow-separation states (six).  A constant when
    compiled (:func:`_model_of`), so the lanes' loops hold the chosen model's work only."""
    if isinstance(tabs[0], np.ndarray):
        return 0
    return 2 if len(tabs) == 6 else 1


@overload(model_of, inline="always")
def _model_of(tabs):
    """:func:`model_of` from the tables' type: a constant in the compiled kernel."""
    if isinstance(tabs, types.BaseTuple) and len(tabs) in (5, 6):
        kind = 0 if isinstance(tabs[0], types.Array) else (2 if len(tabs) == 6 else 1)
        return lambda tabs: kind
    return None


@register_jitable
def row_length(n_sub: int) -> int:
    """Floats in a block's row for control steps of n_sub physics steps: BLOCK, then the delayed demands of
    each physics step of the control step (staged once per control step, :func:`stage_demands`).  Plain
    Python from Python, compiled inline in the kernels (numba's register_jitable)."""
    return BLOCK + n_sub * 7 * W


@register_jitable
def check_work(S, n_sub):
    """ValueError unless the scratch S has rows long enough for n_sub physics steps per control step."""
    if S.shape[1] < row_length(n_sub):
        raise ValueError("S: too short a row for n_sub physics steps per control step (lanes.new_work(n_envs, n_sub))")


ALIGN = 64
"""Bytes: the scratch starts on a cache-line boundary (one 512-bit register is W floats = 64 bytes)."""


def new_work(n_envs: int, n_sub: int) -> np.ndarray:
    """Scratch of a batch stepped n_sub physics steps per control step: one row per block of W environments.

    The array starts on a 64-byte boundary, and a row is a whole number of W floats, so every access
    ``row[k * W : (k + 1) * W]`` of the lane kernel is one aligned 512-bit load or store.  ``np.zeros``
    of a large array starts 16 bytes past a page boundary (the allocator's header), where every such
    access straddles two cache lines: 1-3 % of the physics at 1024 environments (``benchmarks/RESULTS.md``)."""
    if n_sub < 1:
        raise ValueError(f"n_sub = {n_sub}: must be an integer >= 1")
    shape = ((n_envs + W - 1) // W, row_length(n_sub))
    size = shape[0] * shape[1]
    buf = np.zeros(size + ALIGN // 8)
    start = (-buf.ctypes.data % ALIGN) // 8  # float64 arrays start on 8-byte boundaries at least
    return buf[start : start + size].reshape(shape)


def _loader(n: int):
    """``load(row, off, lane)``: the n-tuple row[off + k * W + lane], k < n (written out: a tuple of
    loads, of which LLVM keeps only the ones used)."""
    ns: dict = {}
    exec("def load(row, off, lane):\n    return (" + ", ".join(f"row[off + {k * W} + lane]" for k in range(n)) + ",)\n", ns)
    return njit(**_GENERATED)(ns["load"])


def _storer(n: int):
    """``store(row, off, lane, t)``: row[off + k * W + lane] = t[k], k < n."""
    ns: dict = {}
    exec("def store(row, off, lane, t):\n" + "".join(f"    row[off + {k * W} + lane] = t[{k}]\n" for k in range(n)), ns)
    return njit(**_GENERATED)(ns["store"])


load5, load7, load10, load24, load_params = _loader(5), _loader(7), _loader(10), _loader(N_Y), _loader(L.N_PARAMS)
load_inputs = _loader(L.N_INPUTS)
store5, store7, store10, store24 = _storer(5), _storer(7), _storer(10), _storer(N_Y)


@intrinsic
def _pointer(typingctx, address):
    """The integer ``address`` as a void pointer (for numba.carray)."""

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return types.voidptr(address), codegen


@inlined(**_JIT)
def rhs_values(y, fric, xs, ud, u, p, flags, free, tabs):
    """Time derivative (N_Y-tuple) of the RK state y (q 5, qd 5, servo positions 7, servo rates 7), with the
    joints' friction torques fric (at y's rates and the held bristle states), the flow-separation states xs
    (5-tuple, read by the unsteady model only) and the delayed demands ud held; locked joints do not move.
    The aerodynamic model is the tables' (:func:`model_of`, a compile-time constant)."""
    q = y[0:5]
    qd = y[5:10]
    flaps = y[10:17] if flags & L.F_SERVO else ud
    model = model_of(tabs)
    fl = (flags | L.F_UNSTEADY) if model == 2 else (flags & ~L.F_UNSTEADY)  # the model's flag a constant, as model is
    Mt, ht, kin = mass_matrix_terms(q, qd, p)
    Qt, D, Gv = forces(q, qd, fric, xs, flaps, u, p, fl, tabs, kin, model > 0, True)
    qdd = solve_free_rank1(Mt, (Qt[0] - ht[0], Qt[1] - ht[1], Qt[2] - ht[2], Qt[3] - ht[3], Qt[4] - ht[4]), D, Gv, free)
    servo = (flags & L.F_SERVO) != 0
    return (
        qd[0] if free[0] else 0.0, qd[1] if free[1] else 0.0, qd[2] if free[2] else 0.0,
        qd[3] if free[3] else 0.0, qd[4] if free[4] else 0.0,
        qdd[0], qdd[1], qdd[2], qdd[3], qdd[4],
        y[17] if servo else 0.0, y[18] if servo else 0.0, y[19] if servo else 0.0, y[20] if servo else 0.0,
        y[21] if servo else 0.0, y[22] if servo else 0.0, y[23] if servo else 0.0,
        sv.accel(p, 0, ud[0], y[10], y[17]) if servo else 0.0,
        sv.accel(p, 1, ud[1], y[11], y[18]) if servo else 0.0,
        sv.accel(p, 2, ud[2], y[12], y[19]) if servo else 0.0,
        sv.accel(p, 3, ud[3], y[13], y[20]) if servo else 0.0,
        sv.accel(p, 4, ud[4], y[14], y[21]) if servo else 0.0,
        sv.accel(p, 5, ud[5], y[15], y[22]) if servo else 0.0,
        sv.accel(p, 6, ud[6], y[16], y[23]) if servo else 0.0,
    )  # fmt: skip


@inlined(**_JIT)
def joint_bristles(row, j, dt, reuse):
    """Every lane: joint j's bristle state over dt = h/2 at the lane's joint rate (exact, eq. 19), in place.

    The decay (a, g) depends on the joint rate only, and the rate at the end of one physics step is the
    rate at the start of the next, bit for bit: with ``reuse`` (a compile-time constant wherever this is
    inlined) the decay the previous half step stored in the row is taken rather than recomputed, as
    :func:`rig_env.physics.integrator.half_bristle_step` does.  Without it the decay is computed and stored.
    """
    for lane in range(W):
        v = row[OFF_X + (L.X_QD + j) * W + lane]
        z = row[OFF_X + (L.X_Z + j) * W + lane]
        if reuse:
            a = row[OFF_DECAY + 2 * j * W + lane]
            g = row[OFF_DECAY + (2 * j + 1) * W + lane]
        else:
            a, g = fr.bristle_decay(load_params(row, OFF_P, lane), j, v, dt)
            row[OFF_DECAY + 2 * j * W + lane] = a
            row[OFF_DECAY + (2 * j + 1) * W + lane] = g
        row[OFF_X + (L.X_Z + j) * W + lane] = fr.advance_bristle_decay(v, z, a, g)


@inlined(**_JIT)
def bristles(row, free, h, reuse):
    """The free joints' bristle states over h/2 (call with friction on only).  One loop over the lanes per
    free joint, chosen outside the loops: a locked joint costs nothing (inside a loop over the lanes a
    choice, even one that is the same for every lane, becomes a select that computes both sides)."""
    dt = 0.5 * h
    if free[0]:
        joint_bristles(row, 0, dt, reuse)
    if free[1]:
        joint_bristles(row, 1, dt, reuse)
    if free[2]:
        joint_bristles(row, 2, dt, reuse)
    if free[3]:
        joint_bristles(row, 3, dt, reuse)
    if free[4]:
        joint_bristles(row, 4, dt, reuse)


@inlined(**_JIT)
def joint_torque(row, j, c, first, friction):
    """Every lane: joint j's friction torque (with ``friction``, a compile-time constant wherever this is
    inlined) at the RK stage's rate and the held bristle state, plus its test fixture's torque at the stage's
    angle (stage values: start value + c times the last stage's derivative, as the stage state is formed),
    into row[OFF_FRIC]."""
    for lane in range(W):
        v0 = row[OFF_Y0 + (5 + j) * W + lane]
        v = v0 if first else v0 + c * row[OFF_K + (5 + j) * W + lane]
        q0 = row[OFF_Y0 + j * W + lane]
        qj = q0 if first else q0 + c * row[OFF_K + j * W + lane]
        p = load_params(row, OFF_P, lane)
        fix = fixture_torque(j, qj, p)
        if friction:
            z = row[OFF_X + (L.X_Z + j) * W + lane]
            row[OFF_FRIC + j * W + lane] = friction_torque(j, v, z, p, L.F_FRICTION) + fix
        else:
            row[OFF_FRIC + j * W + lane] = fix


@inlined(**_JIT)
def stage_torques(row, free, c, first, friction):
    """The free joints' friction and fixture torques at one RK stage (as :func:`bristles`: one loop per free
    joint, a locked joint costs nothing)."""
    if free[0]:
        joint_torque(row, 0, c, first, friction)
    if free[1]:
        joint_torque(row, 1, c, first, friction)
    if free[2]:
        joint_torque(row, 2, c, first, friction)
    if free[3]:
        joint_torque(row, 3, c, first, friction)
    if free[4]:
        joint_torque(row, 4, c, first, friction)


@inlined(**_JIT)
def axpy24(a, x, y):
    """y + a x for 24-tuples."""
    return (
        y[0] + a * x[0], y[1] + a * x[1], y[2] + a * x[2], y[3] + a * x[3], y[4] + a * x[4], y[5] + a * x[5],
        y[6] + a * x[6], y[7] + a * x[7], y[8] + a * x[8], y[9] + a * x[9], y[10] + a * x[10], y[11] + a * x[11],
        y[12] + a * x[12], y[13] + a * x[13], y[14] + a * x[14], y[15] + a * x[15], y[16] + a * x[16],
        y[17] + a * x[17], y[18] + a * x[18], y[19] + a * x[19], y[20] + a * x[20], y[21] + a * x[21],
        y[22] + a * x[22], y[23] + a * x[23],
    )  # fmt: skip


@inlined(**_JIT)
def start_step(row, free, friction, h, reuse_decay):
    """Bristles over h/2, then every lane's RK start state (reuse_decay: see :func:`joint_bristles`; a
    compile-time constant at each call site, so the loops have no branch)."""
    if friction:
        bristles(row, free, h, reuse_decay)
    for lane in range(W):
        store24(row, OFF_Y0, lane, load10(row, OFF_X, lane) + load7(row, OFF_X + L.X_SERVO * W, lane) + load7(row, OFF_X + L.X_SERVO_RATE * W, lane))


def relax_separation(row: np.ndarray, tabs: tuple, dt: float) -> None:
    """Every lane's flow-separation states over dt at the lane's joint state and inputs, their targets held
    (:func:`rig_env.physics.joint_space.separation_step`), in place; nothing unless the tables are the
    unsteady model's (:func:`model_of`).  Compiled code only (:func:`_relax_separation`)."""
    raise TypeError("relax_separation runs inside the lane kernel only")


@overload(relax_separation, inline="always")
def _relax_separation(row, tabs, dt):
    """:func:`relax_separation` for the unsteady model's tables; for the others a function that does nothing,
    so that the linear and tables kernels never compile the separation step."""
    if isinstance(tabs, types.BaseTuple) and len(tabs) == 6:
        return lambda row, tabs, dt: _relax_lanes(row, tabs, dt)
    return lambda row, tabs, dt: None


@inlined(**_JIT)
def _relax_lanes(row, tabs, dt):
    """:func:`relax_separation`'s loop over the lanes."""
    for lane in range(W):
        x = load10(row, OFF_X, lane)
        servo = load7(row, OFF_X + L.X_SERVO * W, lane)
        xs = separation_step(x[0:5], x[5:10], load_inputs(row, OFF_U, lane), load_params(row, OFF_P, lane),
                             load7(row, OFF_X + L.X_SEP * W, lane), (servo[4], servo[5], servo[6]), dt, tabs)
        store7(row, OFF_X + L.X_SEP * W, lane, xs)


def relaxed(y, xs, u, p, dt, tabs):
    """The flow-separation states xs (7-tuple) relaxed over dt at the RK state y's joint state and the Hawk's
    surfaces (the servo positions y[14:17]), inputs u, parameters p (:func:`rig_env.physics.joint_space.separation_step`):
    what :func:`relax_separation` does to one lane, for the RK stage that opens a physics step.  The unsteady
    model's tables only (:func:`model_of`); for the others xs unchanged.  Compiled code only."""
    raise TypeError("relaxed runs inside the lane kernel only")


@overload(relaxed, inline="always")
def _relaxed(y, xs, u, p, dt, tabs):
    """:func:`relaxed` for the unsteady model's tables; for the others the identity, so that the linear and tables
    kernels never compile the separation step."""
    if isinstance(tabs, types.BaseTuple) and len(tabs) == 6:
        return lambda y, xs, u, p, dt, tabs: separation_step(y[0:5], y[5:10], u, p, xs, (y[14], y[15], y[16]), dt, tabs)
    return lambda y, xs, u, p, dt, tabs: xs


@inlined(**_JIT)
def rk_stage(row, flags, free, tabs, c, wgt, first, relax, dt):
    """One RK stage of every lane: the stage state (y0 + c k, or y0 ``first``), its derivative into row[OFF_K] and,
    weighted by ``wgt``, into row[OFF_ACC].  ``relax`` (the unsteady model's opening stage): the separation states
    are first relaxed over dt at the stage state, which is the physics step's start (:func:`relaxed`), in the same
    loop, so that the arm's kinematics and air that the relaxation and the derivative both need are computed once.
    ``friction`` (flags' F_FRICTION), ``first`` and ``relax`` are compile-time constants at every call site, so
    the loops have no branch."""
    friction = (flags & L.F_FRICTION) != 0
    unsteady = model_of(tabs) == 2
    f0, f1, f2, f3, f4 = free
    # the free joints' friction and fixture torques, each in a loop of its own (a locked joint's are never
    # computed); branched here so that the loops have no branch
    if friction:
        stage_torques(row, free, c, first, True)
    else:
        stage_torques(row, free, c, first, False)
    for lane in range(W):
        y0 = load24(row, OFF_Y0, lane)
        yt = y0 if first else axpy24(c, load24(row, OFF_K, lane), y0)
        t = load5(row, OFF_FRIC, lane)
        fric = (t[0] if f0 else 0.0, t[1] if f1 else 0.0, t[2] if f2 else 0.0, t[3] if f3 else 0.0, t[4] if f4 else 0.0)
        u = load_inputs(row, OFF_U, lane)
        p = load_params(row, OFF_P, lane)
        xs = load7(row, OFF_X + L.X_SEP * W, lane) if unsteady else ATTACHED
        if relax:
            xs = relaxed(yt, xs, u, p, dt, tabs)
            store7(row, OFF_X + L.X_SEP * W, lane, xs)
        k = rhs_values(yt, fric, xs, load7(row, OFF_UD, lane), u, p, flags, free, tabs)
        store24(row, OFF_K, lane, k)
        acc = load24(row, OFF_ACC, lane)
        store24(row, OFF_ACC, lane, axpy24(wgt, k, _ZERO_Y if first else acc))


@njit(**_JIT)
def physics_step(row, flags, free, tabs, h, reuse_decay, last):
    """Every lane of one block over one physics step h (in place); row[OFF_UD] holds the delayed demands.
    reuse_decay: the row holds the bristle decay of the previous physics step's end (False on the first
    physics step of a control step: the caller may have changed states or parameters since).  With the
    unsteady model (:func:`model_of`) the separation states relax over h/2 before the RK4 step on the first
    physics step of the control step and over h/2 after it on the ``last``; between physics steps over h, the
    closing half of one merged with the opening half of the next, as the per-environment kernel does.  Each
    opening relaxation runs in stage 0's loop (:func:`rk_stage`), whose state is the one it relaxes at.

    The stages' derivatives are accumulated with the RK4 weights as they come (in the order
    integrator.physics_step sums them), so every access of the loops below is at a constant offset."""
    friction = (flags & L.F_FRICTION) != 0
    servo = (flags & L.F_SERVO) != 0
    unsteady = model_of(tabs) == 2
    if reuse_decay:  # branched here, outside the loops over the lanes, so that each loop has none
        start_step(row, free, friction, h, True)
    else:
        start_step(row, free, friction, h, False)
    if unsteady:  # the separation states' opening relaxation fused into stage 0 (rk_stage): over h/2 on the first
        # physics step of the control step, else over h (the previous step's closing half merged in)
        rk_stage(row, flags, free, tabs, 0.0, RK_W[0], True, True, h if reuse_decay else 0.5 * h)
    for s in range(1 if unsteady else 0, 4):  # the stages, one loop over the lanes each (one copy of the
        # right-hand side in the code for the linear and tables models; the unsteady model's stage 0 is a second)
        rk_stage(row, flags, free, tabs, RK_C[s] * h, RK_W[s], s == 0, False, 0.0)
    for lane in range(W):  # the RK4 step and servo limits; then the bristles over the second h/2
        p = load_params(row, OFF_P, lane)
        y = axpy24(h, load24(row, OFF_ACC, lane), load24(row, OFF_Y0, lane))
        store10(row, OFF_X, lane, y[0:10])
        ud = load7(row, OFF_UD, lane)
        s0, s1, s2, s3 = sv.project(p, 0, y[10], y[17]), sv.project(p, 1, y[11], y[18]), sv.project(p, 2, y[12], y[19]), sv.project(p, 3, y[13], y[20])
        s4, s5, s6 = sv.project(p, 4, y[14], y[21]), sv.project(p, 5, y[15], y[22]), sv.project(p, 6, y[16], y[23])
        store7(row, OFF_X + L.X_SERVO * W, lane, (
            s0[0] if servo else ud[0], s1[0] if servo else ud[1], s2[0] if servo else ud[2], s3[0] if servo else ud[3],
            s4[0] if servo else ud[4], s5[0] if servo else ud[5], s6[0] if servo else ud[6],
        ))  # fmt: skip
        store7(row, OFF_X + L.X_SERVO_RATE * W, lane, (
            s0[1] if servo else 0.0, s1[1] if servo else 0.0, s2[1] if servo else 0.0, s3[1] if servo else 0.0,
            s4[1] if servo else 0.0, s5[1] if servo else 0.0, s6[1] if servo else 0.0,
        ))  # fmt: skip
    if unsteady and last:  # the closing half of the control step's last physics step (the others': in the next stage 0)
        relax_separation(row, tabs, 0.5 * h)
    if friction:
        bristles(row, free, h, False)


@njit(**_JIT)
def stage_demands(row, i0, n, dbuf, k0, delay_steps, P, U, n_sub):
    """The delay lines of block row's environments (i0 ..) over one control step of n_sub physics steps, at
    once: the limited demands of U go into the slots of physics steps k0 .. k0 + n_sub - 1 and the delayed
    ones each physics step reads are staged in row[OFF_STAGE] (step s's at OFF_STAGE + s * 7 * W).

    The commands are held over the control step, so the demand is computed once (not once per physics
    step) and pushed n_sub times, each push before the read of its own physics step, as the per-environment
    kernel does (a delay of up to n_buf - 1 steps reads a slot a later push overwrites); the slots move by
    one per physics step, wrapped by comparison rather than an integer division per step.  Lanes past the
    end of the batch repeat lane 0's demands."""
    n_buf = dbuf.shape[1]
    slot0 = k0 % n_buf
    for lane in range(W):
        i = i0 + lane
        if i >= n:
            for s in range(n_sub):
                for a in range(7):
                    row[OFF_STAGE + (7 * s + a) * W + lane] = row[OFF_STAGE + (7 * s + a) * W]
            continue
        d = limited_demands(U[i], P[i])
        slot = slot0
        read_comp = (k0 - delay_steps[i, 0]) % n_buf
        read_hawk = (k0 - delay_steps[i, 1]) % n_buf
        for s in range(n_sub):
            for a in range(7):
                dbuf[i, slot, a] = d[a]
            for a in range(7):
                row[OFF_STAGE + (7 * s + a) * W + lane] = dbuf[i, read_comp if a < 4 else read_hawk, a]
            slot = slot + 1 if slot + 1 < n_buf else 0
            read_comp = read_comp + 1 if read_comp + 1 < n_buf else 0
            read_hawk = read_hawk + 1 if read_hawk + 1 < n_buf else 0


@njit(**_JIT_BATCH)  # with NRT: numba.carray's implementation returns an array
def advance_block(b, X, dbuf, k0, delay_steps, P, U, flags, free, tabs, h, n_sub, status, S, pack_params):
    """Block b's environments over one control step: packed into the block's row, stepped, checked and
    written back.  Lanes past the end of the batch repeat the block's first environment and are
    discarded; environments already flagged are stepped and discarded (they stay frozen).  The
    parameters are packed only with ``pack_params`` (they stay in the row from one step to the next)."""
    n = X.shape[0]
    # row b of S as an array whose strides LLVM sees as constants (a view S[b] keeps them as run-time values,
    # and the loops over the lanes are then not vectorised)
    m = S.shape[1]
    row = numba.carray(_pointer(S.ctypes.data + b * m * 8), (m,), np.float64)
    i0 = b * W
    for lane in range(W):
        i = i0 + lane if i0 + lane < n else i0
        for k in range(L.N_STATE):
            row[OFF_X + k * W + lane] = X[i, k]
        if pack_params:
            for k in range(L.N_PARAMS):
                row[OFF_P + k * W + lane] = P[i, k]
        for k in range(L.N_INPUTS):
            row[OFF_U + k * W + lane] = U[i, k]
    stage_demands(row, i0, n, dbuf, k0, delay_steps, P, U, n_sub)  # the delay lines: lane-dependent indices, scalar
    for s in range(n_sub):
        for lane in range(W):  # physics step s's delayed demands to the constant offset the step's loops read
            store7(row, OFF_UD, lane, load7(row, OFF_STAGE + 7 * W * s, lane))
        physics_step(row, flags, free, tabs, h, s > 0, s == n_sub - 1)
    for lane in range(W):
        i = i0 + lane
        if i >= n or status[i] != L.S_OK:
            continue
        st = L.S_OK
        for k in range(L.N_STATE):
            if not np.isfinite(row[OFF_X + k * W + lane]):
                st = L.S_NONFINITE
        if st == L.S_OK:
            for j in range(5):
                if abs(row[OFF_X + (L.X_QD + j) * W + lane]) > L.RUNAWAY_RATE:
                    st = L.S_RUNAWAY
        if st == L.S_OK:
            for k in range(L.N_STATE):
                X[i, k] = row[OFF_X + k * W + lane]
        else:
            status[i] = st  # X[i] keeps its state from the start of the control step (written only when healthy)


# Each model is its own pair of functions, and each serial twin a separate function: numba's disk cache names an
# entry after the function (see integrator) and keeps one index file per function, which two processes
# compiling two signatures of one function at once (rig_env.precompile's children: the linear and the tables
# kernel) would each rewrite, losing the other's entry.  The high-incidence models take the tables' lengths and
# the compensator table's form as literal arguments (:func:`lane_shape`); the linear model reads no table and
# takes none.


@njit(parallel=True, **_JIT_BATCH)
def step_lanes(X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, S, pack_params):
    """Advance all environments by one control step of n_sub physics steps, blocks of W in parallel (the linear
    aerodynamics; :func:`kernel` chooses the model's kernel).

    Arguments as :func:`rig_env.physics.integrator.step_batch`, with S the scratch of :func:`new_work`
    in place of its W, MW.  pack_params: copy P into S; False reuses the parameters S
    holds from the previous call, for a caller that knows P has not changed since (RigVectorEnv: P
    changes only at a reset).
    """
    check_work(S, n_sub)
    free = free_mask(free_idx, n_free)
    for b in prange(S.shape[0]):
        # b as int64, the serial twin's type: the parallel loop's index is unsigned, and advance_block would be compiled
        # a second time for it (the whole physics linked and optimised again: seconds of a cold compile)
        advance_block(np.int64(b), X, dbuf, k0, delay_steps, P, U, flags, free, tabs, h, n_sub, status, S, pack_params)


@njit(**_JIT_BATCH)
def step_lanes_serial(X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, S, pack_params):
    """Serial twin of :func:`step_lanes` (one block, or batches too small for a parallel launch)."""
    check_work(S, n_sub)
    free = free_mask(free_idx, n_free)
    for b in range(S.shape[0]):
        advance_block(b, X, dbuf, k0, delay_steps, P, U, flags, free, tabs, h, n_sub, status, S, pack_params)


@njit(parallel=True, **_JIT_BATCH)
def step_lanes_tables(X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, S, pack_params, n_hawk, n_comp, comp_half):
    """:func:`step_lanes` with the high-incidence tables (flags' F_NONLINEAR); n_hawk, n_comp, comp_half: the
    tables' breakpoints and the compensator table's form (:func:`lane_shape`, of these tables), constants of
    the compiled kernel (numba's ``literally``)."""
    literally(n_hawk)
    literally(n_comp)
    literally(comp_half)
    check_work(S, n_sub)
    free = free_mask(free_idx, n_free)
    for b in prange(S.shape[0]):
        lt = lane_tables(tabs, 1, n_hawk, n_comp, comp_half)  # built inside the loop: numba passes no tuple into it
        advance_block(np.int64(b), X, dbuf, k0, delay_steps, P, U, flags, free, lt, h, n_sub, status, S, pack_params)


@njit(**_JIT_BATCH)
def step_lanes_tables_serial(X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, S, pack_params, n_hawk, n_comp, comp_half):
    """Serial twin of :func:`step_lanes_tables`."""
    literally(n_hawk)
    literally(n_comp)
    literally(comp_half)
    check_work(S, n_sub)
    free = free_mask(free_idx, n_free)
    lt = lane_tables(tabs, 1, n_hawk, n_comp, comp_half)
    for b in range(S.shape[0]):
        advance_block(b, X, dbuf, k0, delay_steps, P, U, flags, free, lt, h, n_sub, status, S, pack_params)


@njit(parallel=True, **_JIT_BATCH)
def step_lanes_unsteady(X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, S, pack_params, n_hawk, n_comp, comp_half):
    """:func:`step_lanes_tables` with the flow-separation states too (flags' F_UNSTEADY)."""
    literally(n_hawk)
    literally(n_comp)
    literally(comp_half)
    check_work(S, n_sub)
    free = free_mask(free_idx, n_free)
    for b in prange(S.shape[0]):
        lt = lane_tables(tabs, 2, n_hawk, n_comp, comp_half)
        advance_block(np.int64(b), X, dbuf, k0, delay_steps, P, U, flags, free, lt, h, n_sub, status, S, pack_params)


@njit(**_JIT_BATCH)
def step_lanes_unsteady_serial(X, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, S, pack_params, n_hawk, n_comp, comp_half):
    """Serial twin of :func:`step_lanes_unsteady`."""
    literally(n_hawk)
    literally(n_comp)
    literally(comp_half)
    check_work(S, n_sub)
    free = free_mask(free_idx, n_free)
    lt = lane_tables(tabs, 2, n_hawk, n_comp, comp_half)
    for b in range(S.shape[0]):
        advance_block(b, X, dbuf, k0, delay_steps, P, U, flags, free, lt, h, n_sub, status, S, pack_params)


KERNELS = {
    0: (step_lanes_serial, step_lanes),
    1: (step_lanes_tables_serial, step_lanes_tables),
    2: (step_lanes_unsteady_serial, step_lanes_unsteady),
}
"""(serial, parallel) kernel of each model of :func:`lane_shape`."""


def kernel(flags: int, parallel: bool) -> Any:
    """The lane kernel for a model with ``flags`` (serial or parallel); it takes the tables' lengths and the
    compensator table's form after ``pack_params`` when the model has the tables (:func:`literal_args`)."""
    return KERNELS[model_number(flags)][1 if parallel else 0]


def literal_args(tabs: tuple[np.ndarray, ...], flags: int) -> tuple[int, ...]:
    """The arguments a model's lane kernel takes after ``pack_params``: none for the linear model, the tables'
    breakpoints and the compensator table's form (n_hawk, n_comp, comp_half) for the others (:func:`lane_shape`)."""
    model, *lengths = lane_shape(tabs, flags)
    return () if model == 0 else tuple(lengths)

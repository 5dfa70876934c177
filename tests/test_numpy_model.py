"""The numba right-hand side against an independent plain-numpy implementation of the same model.

rig_env.numpy_model writes the joint-space model again from the equations (explicit body Jacobians
and their time derivatives, loads applied at their points through J^T, each compensator strip at its
own station, numpy.linalg.solve), sharing nothing with the kernel but the parameter vector and the
state layout.  Its mechanics are first checked against theory (Lagrange's equations by finite
differences of its own mass matrix, gravity as the gradient of the potential energy), then the
kernel's dy/dt (rig_env.reference.continuous_rhs) must equal it to 1e-10 relative over random states,
lock sets, surface deflections, gusts and airspeeds, with linear and nonlinear aerodynamics, friction
and stops (states reach beyond the stops).  Two implementations of the same formulas agree to
rounding, about 1e-14; any modelling difference shows at 1e-3 or more.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from rig_env import JOINTS, RigParams
from rig_env import numpy_model as nm
from rig_env.physics import layout as L
from rig_env.reference import N_WORK, continuous_rhs, env_steps_per_s_scipy_numpy
from rig_env.simulate import flags_of

RTOL = 1e-10  # max |numba - numpy| over the largest |dy/dt| component of the state
LOCK_SETS = (
    JOINTS,
    ("rig_roll", "model_pitch"),
    ("model_pitch",),
    ("rig_roll",),
    ("rig_pitch", "rig_yaw", "model_pitch", "model_yaw"),
    ("model_pitch", "model_yaw"),
)
AERO_CASES = ("linear", "nonlinear", "wind_off")
N_STATES = 3  # per lock set, aero case and parameter set: 6 x 3 x 2 x 3 = 108 states


# the default rig has parameters at zero (a symmetric Hawk and arm, a symmetric compensator
# section); this variant gives each a value so that its terms are compared too
NONZERO = {
    "geometry.hawk_cg_x": 0.02,
    "geometry.arm_cg_y": 0.01,
    "geometry.comp_cg_y": -0.015,
    "mass.hawk_Ixz": 0.002,
    "comp_aero.CL0": 0.05,
    "comp_aero.alpha0": 0.02,
    "comp_aero.CM0": -0.01,
    "geometry.comp_cg_z": 0.01,
    "hawk_aero.alpha0": 0.02,
    # the issue-21 terms, off in the default rig: the alpha-dot split, fin blanking, Clbeta with lift
    "hawk_aero.alphadot_fraction": 0.37,
    "hawk_aero.blanked_fraction": 0.25,
    "hawk_aero.Clbeta_CL": -0.167,
    "hawk_aero.sep_cp_travel": 0.1,  # read by the unsteady model only (tests/test_unsteady.py compares it)
    "hawk_aero.Cnbeta_body": -0.05,
}
PARAM_SETS = {"default": RigParams.default(), "no-zero-parameters": RigParams.default().replace(**NONZERO)}


@pytest.fixture(scope="module")
def p() -> np.ndarray:
    """The parameter vector with no zero mass, geometry or aero entry."""
    return PARAM_SETS["no-zero-parameters"].to_vector()


def random_state(rng: np.random.Generator, p: np.ndarray, free_idx: np.ndarray) -> np.ndarray:
    """y = [q, qd, z]: angles to +-40 deg (past every stop), rates to +-3 rad/s, bristles within their
    sticking range Fs / sigma0; locked joints at rest."""
    y = np.zeros(15)
    y[0:5] = rng.uniform(-0.7, 0.7, 5)
    y[5 + free_idx] = rng.uniform(-3.0, 3.0, len(free_idx))
    for j in range(5):
        b = nm.FRICTION_BASE[j]
        y[10 + j] = rng.uniform(-1.0, 1.0) * p[b] / p[b + 4]
    return y


def random_inputs(rng: np.random.Generator, case: str) -> tuple[np.ndarray, np.ndarray]:
    """(flaps (7,) rad, u (N_INPUTS,)): servo positions to +-40 deg, gusts to +-4 m/s (the Hawk's and the compensator's)."""
    flaps = rng.uniform(-0.7, 0.7, 7)
    u = np.zeros(L.N_INPUTS)
    if case != "wind_off":
        u[L.U_AIRSPEED] = rng.uniform(5.0, 35.0)
        u[L.U_GUST : L.U_GUST + 3] = rng.uniform(-4.0, 4.0, 3)
        u[L.U_GUST_COMP : L.U_GUST_COMP + 3] = rng.uniform(-4.0, 4.0, 3)  # the compensator's own gust, independent
    return flaps, u


def both(y, flaps, u, p, flags, free_idx, tabs) -> tuple[np.ndarray, np.ndarray]:
    kernel = continuous_rhs(0.0, y, flaps, u, p, flags, free_idx, tabs, np.zeros((5, 5)), np.zeros(N_WORK))
    return kernel, nm.rhs(0.0, y, flaps, u, p, flags, free_idx, tabs)


# ------------------------------------------------------------------ the numpy model against theory
def test_jacobian_derivatives_are_time_derivatives(p):
    """dJ_v, dJ_w from the rotation derivatives equal central differences of J along the motion."""
    rng = np.random.default_rng(1)
    for _ in range(10):
        q, qd = rng.uniform(-1.0, 1.0, 5), rng.uniform(-2.0, 2.0, 5)
        eps = 1e-6
        _, bs = nm.bodies(q, qd, p)
        _, bp = nm.bodies(q + eps * qd, qd, p)
        _, bm = nm.bodies(q - eps * qd, qd, p)
        for b, b_plus, b_minus in zip(bs, bp, bm):
            for key in ("Jv", "Jw"):
                fd = (b_plus[key] - b_minus[key]) / (2 * eps)
                np.testing.assert_allclose(b["d" + key], fd, atol=1e-8 * max(1.0, np.abs(fd).max()), err_msg=f"{b['name']} d{key}")


def test_mechanics_satisfy_lagranges_equations(p):
    """h = dM/dt qd - 1/2 d(qd^T M qd)/dq (Lagrange, M by finite differences) and Q_g = -dV/dq."""
    rng = np.random.default_rng(2)
    eps = 1e-6

    def M_at(q):
        _, bs = nm.bodies(q, np.zeros(5), p)
        return nm.mass_matrix_and_bias(bs, np.zeros(5))[0]

    def potential(q):
        _, bs = nm.bodies(q, np.zeros(5), p)
        return -p[L.P_ENVIRONMENT_GRAVITY] * sum(b["m"] * b["r"][2] for b in bs)  # z down

    for _ in range(10):
        q, qd = rng.uniform(-1.0, 1.0, 5), rng.uniform(-2.0, 2.0, 5)
        _, bs = nm.bodies(q, qd, p)
        M, h = nm.mass_matrix_and_bias(bs, qd)
        np.testing.assert_allclose(M, M.T, atol=1e-15)
        assert np.all(np.linalg.eigvalsh(M) > 0)
        E = np.eye(5) * eps
        dM_dt = (M_at(q + eps * qd) - M_at(q - eps * qd)) / (2 * eps)
        dT_dq = np.array([qd @ (M_at(q + E[k]) - M_at(q - E[k])) @ qd / (4 * eps) for k in range(5)])
        np.testing.assert_allclose(h, dM_dt @ qd - dT_dq, atol=1e-7 * np.abs(h).max())
        dV_dq = np.array([(potential(q + E[k]) - potential(q - E[k])) / (2 * eps) for k in range(5)])
        np.testing.assert_allclose(nm.gravity_force(bs, p), -dV_dq, atol=1e-7 * np.abs(dV_dq).max())


# ------------------------------------------------------------------ the kernel against the numpy model
@pytest.mark.parametrize("param_set", PARAM_SETS)
@pytest.mark.parametrize("case", AERO_CASES)
@pytest.mark.parametrize("free", LOCK_SETS, ids=lambda f: "+".join(f))
def test_kernel_rhs_equals_numpy_model(free, case, param_set):
    params = PARAM_SETS[param_set]
    p, tabs = params.to_vector(), params.tables()
    assert param_set == "default" or np.count_nonzero(p[: L.P_FRICTION_RIG_ROLL_FS] == 0) == 0
    free_idx = np.array([JOINTS.index(j) for j in free], dtype=np.int64)
    flags = flags_of(aero=True, friction=True, stops=True, servo=False, nonlinear_aero=case == "nonlinear")
    rng = np.random.default_rng(zlib.crc32(f"{free}{case}{param_set}".encode()))
    for _ in range(N_STATES):
        y = random_state(rng, p, free_idx)
        flaps, u = random_inputs(rng, case)
        kernel, numpy_ = both(y, flaps, u, p, flags, free_idx, tabs)
        scale = np.abs(numpy_).max()
        assert np.all(np.isfinite(kernel)) and scale > 0
        err = np.abs(kernel - numpy_).max() / scale
        assert err < RTOL, f"{free} {case}: |kernel - numpy| / max|dy/dt| = {err:.2e}\nkernel {kernel}\nnumpy  {numpy_}"
        locked = np.setdiff1d(np.arange(5), free_idx)
        assert np.all(kernel[locked] == 0) and np.all(kernel[5 + locked] == 0) and np.all(kernel[10 + locked] == 0)


def test_every_term_is_exercised(p):
    """Each force term (aero, friction, stops past their limits, the stall tables) changes dy/dt by
    far more than the comparison's tolerance, so the comparison would see an error in any of them."""
    params = RigParams.default()
    tabs = params.tables()
    free_idx = np.arange(5, dtype=np.int64)
    rng = np.random.default_rng(3)
    y = random_state(rng, p, free_idx)
    y[1], y[3] = 0.6, -0.6  # rig pitch and model pitch past their +-25 deg stops
    flaps, u = random_inputs(rng, "linear")
    full = nm.rhs(0.0, y, flaps, u, p, flags_of(True, True, True, False, False), free_idx, tabs)
    for off in ({"aero": False}, {"friction": False}, {"stops": False}, {"nonlinear_aero": True}):
        kw = dict(aero=True, friction=True, stops=True, servo=False, nonlinear_aero=False) | off
        flags = flags_of(**kw)
        other = nm.rhs(0.0, y, flaps, u, p, flags, free_idx, tabs)
        assert np.abs(other - full).max() > 1e-3 * np.abs(full).max(), off
        kernel, numpy_ = both(y, flaps, u, p, flags, free_idx, tabs)
        assert np.abs(kernel - numpy_).max() < RTOL * np.abs(numpy_).max(), off


def test_numpy_peer_rate_counts_whole_env_steps():
    """The benchmark peer integrates whole env-steps with the numpy right-hand side and reports a rate."""
    rate = env_steps_per_s_scipy_numpy(RigParams.default(), env_steps=2, method="RK45")
    assert 0 < rate < 1e4
    for bad in (0, 1.5, True):
        with pytest.raises(ValueError, match="env_steps"):
            env_steps_per_s_scipy_numpy(RigParams.default(), env_steps=bad)

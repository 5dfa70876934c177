"""The joint-space model against MuJoCo, an independent implementation of the same mechanism.

rig_env.mjcf writes the three bodies and five hinges as MJCF; MuJoCo derives its own mass matrix,
bias forces and RK4 trajectories from that tree (composite rigid body and recursive Newton-Euler), so
agreement checks rig_env.physics.joint_space's derivation, not a copy of it.  Aerodynamics, friction
and stops are off on both sides (MuJoCo has none of them).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")  # optional dependency (extra "test")
from mujoco import rollout  # noqa: E402

import rig_env  # noqa: E402
from rig_env import JOINTS, mjcf  # noqa: E402
from rig_env.physics import integrator as I  # noqa: E402
from rig_env.physics import joint_space as js  # noqa: E402
from rig_env.physics import layout as L  # noqa: E402

H = 0.0025  # physics step, s
N_SUB = 5  # physics steps per 12.5 ms control step
T_END = 2.0  # s of simulated time in the trajectory test

# lock sets: a locked joint between two free ones in each (arm gimbal, model gimbal)
LOCK_SETS = [
    pytest.param(JOINTS, {}, id="all-free"),
    pytest.param(("rig_pitch", "rig_yaw", "model_yaw"), {"rig_roll": 0.3, "model_pitch": -0.2}, id="lock-roll-mpitch"),
    pytest.param(("rig_roll", "model_pitch"), {"rig_pitch": 0.4, "rig_yaw": -0.3, "model_yaw": 0.7}, id="lock-pitch-yaw-myaw"),
    pytest.param(("rig_roll", "rig_yaw", "model_yaw"), {"rig_pitch": -0.25, "model_pitch": 0.35}, id="lock-pitch-mpitch"),
    pytest.param(("rig_yaw", "model_pitch"), {"rig_pitch": 0.2, "rig_roll": -0.6, "model_yaw": -0.4}, id="lock-pitch-roll-myaw"),
]


@pytest.fixture(scope="module")
def params() -> rig_env.RigParams:
    """The default rig with every off-axis term switched on, so that no term of M or h is zero."""
    return rig_env.RigParams.default().replace(
        **{
            "mass.hawk_Ixz": 0.003,
            "geometry.hawk_cg_x": 0.02,
            "geometry.arm_cg_y": 0.03,
            "geometry.comp_cg_y": -0.02,
        }
    )


def _random_states(rng: np.random.Generator, n: int, free: tuple[str, ...], angles: np.ndarray, q_span: float, qd_span: float):
    """(n, 5) angles and rates; locked joints at their angle and at rest."""
    q = rng.uniform(-q_span, q_span, (n, 5))
    qd = rng.uniform(-qd_span, qd_span, (n, 5))
    for k, j in enumerate(JOINTS):
        if j not in free:
            q[:, k] = angles[k]
            qd[:, k] = 0.0
    return q, qd


def _rig_env_dynamics(q: np.ndarray, qd: np.ndarray, P: np.ndarray, tabs) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple]:
    """rig_env's M (5, 5), h (5) and gravity force Q_g (5) (flags = 0: gravity only) at one state."""
    M = np.zeros((5, 5))
    h = np.zeros(5)
    Qg = np.zeros(5)
    kin = js.mass_matrix_and_bias(q, qd, P, M, h, np.zeros(45))
    js.generalized_forces(q, qd, np.zeros(5), np.zeros(7), np.zeros(L.N_INPUTS), P, 0, tabs, kin, Qg)
    return M, h, Qg, kin


# ---------------------------------------------------------------------------------------- (1) M and h
@pytest.mark.parametrize("free, locked", LOCK_SETS)
def test_mass_matrix_and_bias_match_mujoco(params, free, locked):
    """M(q) vs mj_fullM and h(q, qd) - Q_gravity vs qfrc_bias (= C qd + g term) at 200 random states."""
    model = mjcf.mujoco_model(params, free, locked)
    data = mujoco.MjData(model)
    P, tabs = params.to_vector(), params.tables()
    idx = np.array([JOINTS.index(j) for j in free])
    dof = mjcf.joint_addresses(model)[1][idx]
    rng = np.random.default_rng(1234)
    q_all, qd_all = _random_states(rng, 200, free, mjcf.locked_angles(model), 1.2, 2.0)
    err_m = 0.0
    d_bias, bias_all = [], []
    Mmj = np.zeros((model.nv, model.nv))
    for q, qd in zip(q_all, qd_all):
        M, h, Qg, kin = _rig_env_dynamics(q, qd, P, tabs)
        mjcf.set_state(model, data, q, qd)
        mujoco.mj_fullM(model, data, Mmj)
        Mr = M[np.ix_(idx, idx)]
        err_m = max(err_m, np.abs(Mr - Mmj[np.ix_(dof, dof)]).max() / np.abs(Mr).max())
        bias = (h - Qg)[idx]
        bias_all.append(bias)
        d_bias.append(bias - data.qfrc_bias[dof])
        # kinematics: MuJoCo's hawk c.g. is rig_env's R_a = A_s [l_f 0 0] + A_a l_cga, in world axes as
        # joint_space.frames gives it (the drawings and the DAE) and in arm axes as the dynamics use it
        As, _, _, G, rho = js.frames(q, P)[:5]
        np.testing.assert_allclose(data.body("hawk").xipos, np.add(G, rho), rtol=0, atol=1e-14)
        rho_arm = kin[4]
        r_a = np.reshape(As, (3, 3)) @ (np.array([P[L.P_GEOMETRY_ARM_LENGTH], 0.0, 0.0]) + rho_arm)
        np.testing.assert_allclose(data.body("hawk").xipos, r_a, rtol=0, atol=1e-14)
    # bias relative to its largest value over the sample (single states can have a bias near zero)
    err_h = np.abs(d_bias).max() / np.abs(bias_all).max()
    print(f"\n{'/'.join(free)}: max rel. error M {err_m:.2e}, bias {err_h:.2e}")
    assert err_m < 1e-12
    assert err_h < 1e-12


# ---------------------------------------------------------------------------------------- (2) trajectories
def _rig_env_trajectory(params, free, q0, qd0, n_ctrl):
    """rig_env integrator, flags = 0: (n_ctrl + 1, n, 5) joint angles at every control step."""
    n = q0.shape[0]
    P = rig_env.param_batch(params, n)
    X = np.zeros((n, L.N_STATE))
    X[:, L.X_Q : L.X_Q + 5] = q0
    X[:, L.X_QD : L.X_QD + 5] = qd0
    dbuf = np.zeros((n, 8, 7))
    delay = np.zeros((n, 2), np.int64)
    U = np.zeros((n, L.N_INPUTS))
    free_idx = np.array([JOINTS.index(j) for j in free] + [0] * (5 - len(free)), np.int64)
    W, MW = I.new_work(n)
    status = np.zeros(n, np.int8)
    out = [X[:, :5].copy()]
    for k in range(n_ctrl):
        I.step_batch(X, dbuf, N_SUB * k, delay, P, U, 0, free_idx, len(free), params.tables(), H, N_SUB, status, W, MW)
        out.append(X[:, :5].copy())
    assert not status.any(), status
    return np.array(out)


def _mujoco_trajectory(model, q0, qd0, n_ctrl):
    """MuJoCo RK4 at the same step: (n_ctrl + 1, n, 5) joint angles at every control step."""
    data = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    size = mujoco.mj_stateSize(model, spec)
    init = np.empty((q0.shape[0], size))
    for i in range(q0.shape[0]):
        mujoco.mj_resetData(model, data)
        mjcf.set_state(model, data, q0[i], qd0[i])
        mujoco.mj_getState(model, data, init[i], spec)
    state, _ = rollout.rollout(model, data, init, nstep=N_SUB * n_ctrl)
    qpos = state[:, N_SUB - 1 :: N_SUB, 1 : 1 + model.nq]  # after each control step (state[0] = time)
    q = mjcf.from_qpos(model, qpos)  # (n, n_ctrl, 5)
    return np.concatenate([mjcf.from_qpos(model, mjcf.to_qpos(model, q0))[None], q.transpose(1, 0, 2)])


@pytest.mark.parametrize("free, locked", LOCK_SETS)
def test_trajectories_match_mujoco_rk4(params, free, locked):
    """rig_env's integrator (flags = 0) vs MuJoCo RK4 at 2.5 ms over 2 s from random states.

    Angles +-0.5 rad (rig pitch +-0.6), rates +-1 rad/s.  The same classical RK4 on the same equations
    agrees to round-off (measured about 1e-13 rad), so the bound is 1e-9 rad rather than the 1e-4 rad
    that would still pass a model with a small error in M.
    """
    model = mjcf.mujoco_model(params, free, locked, timestep=H)
    rng = np.random.default_rng(99)
    n = 8
    q0, qd0 = _random_states(rng, n, free, mjcf.locked_angles(model), 0.5, 1.0)
    if "rig_pitch" in free:
        q0[:, 1] = rng.uniform(-0.6, 0.6, n)
    n_ctrl = round(T_END / (H * N_SUB))
    ours = _rig_env_trajectory(params, free, q0, qd0, n_ctrl)
    ref = _mujoco_trajectory(model, q0, qd0, n_ctrl)
    err = np.abs(ours - ref).max()
    travel = np.abs(ours - ours[0]).max()
    print(f"\n{'/'.join(free)}: max |q - q_mujoco| over {T_END} s = {err:.2e} rad (largest excursion {travel:.2f} rad)")
    assert travel > 0.05  # the states actually move
    locked_idx = [k for k, j in enumerate(JOINTS) if j not in free]
    assert np.all(ours[:, :, locked_idx] == q0[None, :, locked_idx])  # locked joints stay put
    assert err < 1e-9  # brief: 1e-4 rad; the same RK4 on the same equations agrees to round-off (about 1e-13)


# ---------------------------------------------------------------------------------------- (3) the MJCF itself
@pytest.mark.parametrize("free, locked", LOCK_SETS)
def test_mjcf_parses_with_the_free_joints(params, free, locked):
    xml = mjcf.to_mjcf(params, free, locked)
    model = mujoco.MjModel.from_xml_string(xml)
    names = [model.joint(i).name for i in range(model.njnt)]
    assert names == [j for j in mjcf.CHAIN if j in free]
    assert model.nq == model.nv == len(free)
    assert all(model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)
    assert np.all(model.dof_armature == 0) and np.all(model.dof_damping == 0) and np.all(model.dof_frictionloss == 0)
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert model.opt.timestep == 0.0025
    np.testing.assert_array_equal(model.opt.gravity, [0.0, 0.0, params.environment.gravity])
    m = params.mass
    # the three bodies with exactly their masses, nothing added anywhere
    assert model.body("compensator").mass[0] == m.comp_mass
    assert model.body("arm").mass[0] == m.arm_mass
    assert model.body("hawk").mass[0] == m.hawk_mass
    assert model.body_mass.sum() == pytest.approx(m.comp_mass + m.arm_mass + m.hawk_mass, rel=1e-15)
    np.testing.assert_allclose(np.sort(model.body("compensator").inertia), np.sort([m.comp_Ixx, m.comp_Iyy, m.comp_Izz]), rtol=1e-15)
    # the locked angles travel with the model
    expected = np.array([locked.get(j, 0.0) if j not in free else 0.0 for j in JOINTS])
    np.testing.assert_array_equal(mjcf.locked_angles(model), expected)


def test_state_helpers_round_trip(params):
    free = ("rig_roll", "model_yaw")
    model = mjcf.mujoco_model(params, free, {"rig_pitch": 0.1})
    q = np.array([0.3, 0.1, 0.0, 0.0, -0.4])
    qd = np.array([1.0, 0.0, 0.0, 0.0, 2.0])
    data = mujoco.MjData(model)
    mjcf.set_state(model, data, q, qd)
    np.testing.assert_array_equal(data.qpos, [0.3, -0.4])  # chain order: rig_roll before model_yaw
    q2, qd2 = mjcf.get_state(model, data)
    np.testing.assert_array_equal(q2, q)
    np.testing.assert_array_equal(qd2, qd)
    batch = np.tile(q, (3, 4, 1))
    np.testing.assert_array_equal(mjcf.from_qpos(model, mjcf.to_qpos(model, batch)), batch)
    with pytest.raises(ValueError, match="q:"):
        mjcf.to_qpos(model, np.zeros(4))


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(free_dofs=("rig_roll", "wing_flap")), "free_dofs"),
        (dict(free_dofs=()), "free_dofs"),
        (dict(free_dofs="rig_roll"), "free_dofs"),
        (dict(free_dofs=("rig_roll", "rig_roll")), "free_dofs"),
        (dict(free_dofs=("rig_roll",), locked={"rig_ptich": 0.1}), "locked"),
        (dict(free_dofs=("rig_roll",), locked={"rig_roll": 0.1}), "locked"),
        (dict(free_dofs=("rig_roll",), locked={"rig_pitch": math.nan}), "locked"),
        (dict(free_dofs=("rig_roll",), locked={"rig_pitch": "steep"}), "locked"),
        (dict(timestep=0.0), "timestep"),
        (dict(timestep=-1e-3), "timestep"),
    ],
)
def test_bad_inputs_raise(params, kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}:"):
        mjcf.to_mjcf(params, **kwargs)
    with pytest.raises(ValueError, match=f"^{field}:"):
        mjcf.mujoco_model(params, **kwargs)


def test_params_must_be_rig_params():
    with pytest.raises(ValueError, match="^params:"):
        mjcf.to_mjcf({"mass": 1.0})  # type: ignore[arg-type]

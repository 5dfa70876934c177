"""The paper's DAE (rig_env.physics.dae) against the literal dense system of eq. (1) and against the
independent joint-space model (rig_env.physics.integrator), plus its invariants.

Physics step h = 2.5 ms, 5 steps per control step, throughout.
"""

from __future__ import annotations

import numpy as np
import pytest

import rig_env
from rig_env.physics import dae as D
from rig_env.physics import dae_reference as R
from rig_env.physics import integrator as I
from rig_env.physics import layout as L

H = 0.0025
N_SUB = 5
ALL_ON = L.F_AERO | L.F_FRICTION | L.F_STOPS


@pytest.fixture(scope="module")
def rig():
    p = rig_env.RigParams.default()
    return p, p.tables()


def free_of(locked: list[int]) -> np.ndarray:
    return np.array([j for j in range(5) if j not in locked], dtype=np.int64)


def random_joint_states(rng, n, angle, rate, locked=()):
    X = np.zeros((n, L.N_STATE))
    X[:, L.X_Q : L.X_Q + 5] = rng.uniform(-angle, angle, (n, 5))
    X[:, L.X_QD : L.X_QD + 5] = rng.uniform(-rate, rate, (n, 5))
    for j in locked:
        X[:, L.X_QD + j] = 0.0
    return X


def run_both(rig, X0, locked, flags, seconds, airspeed=20.0):
    """Integrate joint-space and DAE side by side; returns per-control-step joint angles of both,
    the max constraint residual, and both status arrays."""
    p, tabs = rig
    n = X0.shape[0]
    P = rig_env.param_batch(p, n)
    free = free_of(locked)
    X = X0.copy()
    XD = X0.copy()
    Y = np.zeros((n, D.N_DAE))
    D.from_joint_state(X, P, Y)
    dbuf_j = np.zeros((n, 8, 7))
    dbuf_d = np.zeros((n, 8, 7))
    delay = np.zeros((n, 2), np.int64)
    U = np.zeros((n, L.N_INPUTS))
    U[:, L.U_AIRSPEED] = airspeed
    st_j = np.zeros(n, np.int8)
    st_d = np.zeros(n, np.int8)
    W, MW = I.new_work(n)
    WD = D.new_work_dae(n)
    res = np.zeros(n)
    D.constraint_residual_batch(Y, P, free, len(free), res)
    res_max = res.max()
    qj, qd = [], []
    for k in range(int(round(seconds / (H * N_SUB)))):
        I.step_batch(X, dbuf_j, N_SUB * k, delay, P, U, flags, free, len(free), tabs, H, N_SUB, st_j, W, MW)
        D.step_batch_dae(Y, dbuf_d, N_SUB * k, delay, P, U, flags, free, len(free), tabs, H, N_SUB, st_d, *WD)
        D.to_joint_state(Y, P, XD)
        D.constraint_residual_batch(Y, P, free, len(free), res)
        res_max = max(res_max, res.max())
        qj.append(X[:, :5].copy())
        qd.append(XD[:, :5].copy())
    return np.array(qj), np.array(qd), res_max, st_j, st_d, Y, P


# ---------------------------------------------------------------------- (1) literal eq. (1)
def test_structured_solve_equals_literal_paper_system(rig):
    """The Schur-complement Newton-Euler solve gives the accelerations of the dense 17-coordinate
    augmented system [[M, C_q^T], [C_q, 0]] of eq. (1) at 200 random states (all loads on)."""
    p, tabs = rig
    rng = np.random.default_rng(1)
    lock_sets = ([], [L.J_RIG_YAW], [L.J_RIG_ROLL, L.J_MODEL_YAW], [L.J_RIG_PITCH, L.J_RIG_YAW, L.J_MODEL_PITCH])
    n = 50
    worst = 0.0
    for locked in lock_sets:
        P = rig_env.param_batch(p, n)
        X = np.zeros((n, L.N_STATE))
        X[:, L.X_Q + 0] = rng.uniform(-3.0, 3.0, n)
        X[:, L.X_Q + 1] = rng.uniform(-1.2, 1.2, n)
        X[:, L.X_Q + 2:L.X_Q + 5] = rng.uniform(-3.0, 3.0, (n, 3))
        X[:, L.X_QD : L.X_QD + 5] = rng.uniform(-2.0, 2.0, (n, 5))
        X[:, L.X_Z : L.X_Z + 5] = rng.uniform(-2e-4, 2e-4, (n, 5))
        X[:, L.X_SERVO : L.X_SERVO + 7] = rng.uniform(-0.3, 0.3, (n, 7))
        for j in locked:
            X[:, L.X_QD + j] = 0.0
        Y = np.zeros((n, D.N_DAE))
        D.from_joint_state(X, P, Y)
        U = np.zeros((n, L.N_INPUTS))
        U[:, L.U_AIRSPEED] = 20.0
        U[:, L.U_GUST : L.U_GUST + 3] = rng.normal(0.0, 1.0, (n, 3))
        U[:, L.U_GUST_COMP : L.U_GUST_COMP + 3] = rng.normal(0.0, 1.0, (n, 3))
        free = free_of(locked)
        acc = np.zeros((n, 15))
        loads = np.zeros((n, 15))
        D.accelerations_batch(Y, U, P, ALL_ON, free, len(free), tabs, acc, loads)
        for i in range(n):
            q, qd = R.coordinates_from_dae_state(Y[i])
            qdd, _ = R.paper_accelerations(q, qd, loads[i], P[i], locked, Y[i, D.Y_TARGET : D.Y_TARGET + 5])
            ref = R.body_accelerations(q, qd, qdd)
            worst = max(worst, np.max(np.abs(ref - acc[i])) / max(1.0, np.max(np.abs(ref))))
    print(f"literal vs structured: max relative difference {worst:.2e}")
    assert worst < 1e-9


def test_conversions_round_trip_and_unwrap(rig):
    p, _ = rig
    rng = np.random.default_rng(2)
    n = 20
    P = rig_env.param_batch(p, n)
    X = random_joint_states(rng, n, 1.0, 2.0)
    X[:, L.X_Q + L.J_RIG_ROLL] += 2 * np.pi * rng.integers(-3, 4, n)  # several turns
    X[:, L.X_Q + L.J_MODEL_YAW] += 2 * np.pi * rng.integers(-3, 4, n)
    Y = np.zeros((n, D.N_DAE))
    D.from_joint_state(X, P, Y)
    res = np.zeros(n)
    D.constraint_residual_batch(Y, P, np.arange(5), 5, res)
    assert res.max() < 1e-14
    X2 = X.copy()
    X2[:, :10] += 1e-3  # previous state near, not equal
    D.to_joint_state(Y, P, X2)
    np.testing.assert_allclose(X2, X, rtol=0, atol=1e-12)


# ---------------------------------------------------------------------- (2), (4), (6) mechanism only
@pytest.mark.parametrize("locked", [[], [L.J_RIG_YAW, L.J_MODEL_YAW]])
def test_mechanism_matches_joint_space(rig, locked):
    """Aero, friction and stops off: DAE and joint-space angles agree to 1e-6 rad over 5 s, the
    constraint residual stays below 1e-8 and locked joints do not move."""
    rng = np.random.default_rng(3)
    X0 = random_joint_states(rng, 4, 0.5, 0.5, locked)
    qj, qd, res_max, st_j, st_d, Y, P = run_both(rig, X0, locked, 0, 5.0)
    err = np.abs(qd - qj).max()
    print(f"mechanism, locked {locked}: max angle difference {err:.2e} rad, residual {res_max:.2e}")
    assert not st_j.any() and not st_d.any()
    assert np.abs(qj[:, :, 1]).max() < 1.3  # away from the rig gimbal's singularity at +-90 deg pitch
    assert err < 1e-6
    assert res_max < 1e-8
    for j in locked:
        drift = np.abs(qd[:, :, j] - X0[None, :, j]).max()
        print(f"locked joint {rig_env.JOINTS[j]}: max drift {drift:.2e} rad")
        assert drift < 1e-10


# ---------------------------------------------------------------------- (3) aero and friction on
@pytest.mark.parametrize("locked", [[L.J_RIG_PITCH, L.J_RIG_YAW, L.J_MODEL_YAW], []])
def test_aero_friction_matches_joint_space(rig, locked):
    """Aero, LuGre friction and stops on at 20 m/s from small states around level: angles agree to
    1e-5 rad over 5 s (free DOFs {rig_roll, model_pitch}, then all five)."""
    rng = np.random.default_rng(4)
    X0 = random_joint_states(rng, 4, 0.2, 0.5, locked)
    qj, qd, res_max, st_j, st_d, _, _ = run_both(rig, X0, locked, ALL_ON, 5.0)
    err = np.abs(qd - qj).max()
    print(f"aero + friction, locked {locked}: max angle difference {err:.2e} rad, residual {res_max:.2e}")
    assert not st_j.any() and not st_d.any()
    assert err < 1e-5
    assert res_max < 1e-8
    for j in locked:
        assert np.abs(qd[:, :, j] - X0[None, :, j]).max() < 1e-10


# ---------------------------------------------------------------------- (5) energy
def test_energy_conserved_without_dissipation(rig):
    """Aero, friction and stops off, all joints free: total energy drifts by less than 1e-6 of the
    initial kinetic energy over 10 s."""
    p, tabs = rig
    rng = np.random.default_rng(5)
    n = 4
    P = rig_env.param_batch(p, n)
    X = random_joint_states(rng, n, 0.5, 0.5)
    Y = np.zeros((n, D.N_DAE))
    D.from_joint_state(X, P, Y)
    E0 = np.zeros(n)
    D.energy_batch_dae(Y, P, E0)
    Yk = Y.copy()
    Yk[:, D.Y_RA : D.Y_VA] = 0.0  # kinetic part only: zero potential with positions at the pivot
    Yk[:, D.Y_QA] = 1.0
    Yk[:, D.Y_QS] = 1.0
    T0 = np.zeros(n)
    D.energy_batch_dae(Yk, P, T0)
    free = np.arange(5, dtype=np.int64)
    dbuf = np.zeros((n, 8, 7))
    delay = np.zeros((n, 2), np.int64)
    U = np.zeros((n, L.N_INPUTS))
    st = np.zeros(n, np.int8)
    WD = D.new_work_dae(n)
    E = np.zeros(n)
    drift = 0.0
    for k in range(int(round(10.0 / (H * N_SUB)))):
        D.step_batch_dae(Y, dbuf, N_SUB * k, delay, P, U, 0, free, 5, tabs, H, N_SUB, st, *WD)
        D.energy_batch_dae(Y, P, E)
        drift = max(drift, np.max(np.abs(E - E0) / T0))
    print(f"energy drift over 10 s: {drift:.2e} of the initial kinetic energy")
    assert not st.any()
    assert drift < 1e-6


# ---------------------------------------------------------------------- status handling
def test_blow_up_is_flagged_and_frozen(rig):
    p, tabs = rig
    n = 2
    P = rig_env.param_batch(p, n)
    X = np.zeros((n, L.N_STATE))
    Y = np.zeros((n, D.N_DAE))
    D.from_joint_state(X, P, Y)
    Y[1, D.Y_WS] = np.nan
    before = Y.copy()
    st = np.zeros(n, np.int8)
    free = np.arange(5, dtype=np.int64)
    D.step_batch_dae(
        Y, np.zeros((n, 8, 7)), 0, np.zeros((n, 2), np.int64), P, np.zeros((n, L.N_INPUTS)), 0, free, 5, tabs, H,
        N_SUB, st, *D.new_work_dae(n),
    )
    assert st[0] == L.S_OK and st[1] == L.S_NONFINITE
    np.testing.assert_array_equal(np.isnan(Y[1]), np.isnan(before[1]))
    np.testing.assert_array_equal(Y[1][~np.isnan(Y[1])], before[1][~np.isnan(before[1])])

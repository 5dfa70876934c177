"""Invariants of the joint-space model: energy, locked joints, stops, blow-up reporting."""

import warnings

import numpy as np
import pytest

import rig_env
from rig_env import JOINTS

LOCK_SETS = [
    JOINTS,
    ("rig_roll", "model_pitch"),
    ("rig_pitch", "model_pitch"),
    ("rig_roll", "rig_yaw", "model_pitch", "model_yaw"),
    ("model_yaw",),
]


def random_state(rng, free, n):
    q = rng.uniform(-0.5, 0.5, (n, len(free)))
    qd = rng.uniform(-1.0, 1.0, (n, len(free)))
    return q, qd


@pytest.mark.parametrize("free", LOCK_SETS, ids=lambda f: "+".join(f))
def test_energy_conserved_without_dissipation(params, rng, free):
    q0, qd0 = random_state(rng, free, 6)
    r = rig_env.simulate(params, q0, qd0, 10.0, free_dofs=free, aero=False, friction=False, stops=False)
    assert not r.failed.any()
    ke0 = np.array([
        rig_env.simulate(params, q0[i:i + 1], qd0[i:i + 1], 1 / 80, free_dofs=free, aero=False, friction=False,
                         stops=False).energy[0, 0] for i in range(1)
    ])
    drift = np.abs(r.energy - r.energy[:, :1]).max(axis=1)
    # kinetic energy at t = 0: total minus potential at rest
    r_rest = rig_env.simulate(params, q0, np.zeros_like(qd0), 1 / 80, free_dofs=free, aero=False, friction=False, stops=False)
    kinetic0 = r.energy[:, 0] - r_rest.energy[:, 0]
    assert np.all(kinetic0 > 0) and ke0.size == 1
    assert np.all(drift < 1e-6 * kinetic0), drift / kinetic0


def test_energy_decreases_with_friction(params, rng):
    q0, qd0 = random_state(rng, JOINTS, 4)
    r = rig_env.simulate(params, q0, qd0, 5.0, free_dofs=JOINTS, aero=False, friction=True, stops=False)
    dE = np.diff(r.energy, axis=1)
    assert np.all(dE < 1e-9)  # LuGre is passive (eq. 21 with v_d; Ref. 13)
    assert np.all(r.energy[:, -1] < r.energy[:, 0])


@pytest.mark.parametrize("free", [("rig_roll", "model_pitch"), ("rig_yaw",), ("rig_pitch", "rig_yaw", "model_yaw")])
def test_locked_joints_do_not_move(params, free):
    q_full = np.array([0.3, 0.1, -0.2, 0.05, 0.4])
    r = rig_env.simulate(params, q_full, np.zeros(5), 3.0, free_dofs=free, controls={"comp_aileron": 10.0})
    locked = [k for k, j in enumerate(JOINTS) if j not in free]
    assert np.all(r.q_all[:, locked] == q_full[locked])
    assert np.all(r.qd_all[:, locked] == 0.0)
    assert r.q.shape == (len(r.t), len(free))


@pytest.mark.parametrize("joint", ["rig_pitch", "rig_yaw", "model_pitch"])
def test_stops_hold_and_integrator_survives(params, joint):
    """Thrown into its stop at 3 rad/s the joint bounces off, loses energy and stays within the limits."""
    st = getattr(params.stops, joint)
    q0 = np.radians(st.upper_deg - 2.0)
    r = rig_env.simulate(params, [q0], [3.0], 3.0, free_dofs=[joint], aero=False)
    assert not r.failed.any()
    deg = np.degrees(r.q[:, 0])
    assert deg.max() > st.upper_deg  # it reached the stop (penalty contact penetrates a little)
    assert deg.max() < st.upper_deg + 3.0 and deg.min() > st.lower_deg - 3.0
    assert np.any(r.qd[:, 0] < -0.3)  # it bounced
    assert r.energy[-1] < r.energy[0]


def test_unlimited_joints_are_unwrapped(params):
    r = rig_env.simulate(params, [0.0, 0.0], [0.0, 0.0], 5.0, free_dofs=["rig_roll", "model_pitch"], controls={"comp_aileron": 20.0})
    assert r.q[-1, 0] > 4 * np.pi  # several revolutions, counted continuously
    assert np.all(np.abs(np.diff(r.q[:, 0])) < 0.5)


def test_blow_up_is_reported_per_environment(params):
    # environment 1 starts deep inside a stop with an absurd stiffness and a coarse step: it diverges
    P = [params, params.replace(**{"stops.model_pitch.stiffness": 1e7, "stops.model_pitch.damping": 0.0})]
    q0 = np.array([[0.1], [0.6]])
    with pytest.warns(RuntimeWarning, match="1 of 2 environment"):
        r = rig_env.simulate(P, q0, np.zeros((2, 1)), 2.0, free_dofs=["model_pitch"], physics_dt=1 / 80)
    assert list(r.status) == [0, rig_env.physics.layout.S_RUNAWAY] or r.status[1] != 0
    assert r.status[0] == 0 and np.isnan(r.fail_time[0]) and r.fail_time[1] > 0
    assert np.all(np.isfinite(r.q)) and np.all(np.isfinite(r.energy))
    assert r.q[0, -1, 0] != r.q[0, 0, 0]  # the healthy environment carried on
    assert r.status_text()[1] != "ok"


def test_deterministic(params, rng):
    q0, qd0 = random_state(rng, JOINTS, 3)
    kw = dict(free_dofs=JOINTS, controls={"comp_aileron": lambda t: 10 * np.sin(t)})
    a = rig_env.simulate(params, q0, qd0, 2.0, **kw)
    b = rig_env.simulate(params, q0, qd0, 2.0, **kw)
    assert np.array_equal(a.q, b.q)


def test_batch_equals_single(params, rng):
    q0, qd0 = random_state(rng, JOINTS, 3)
    batch = rig_env.simulate(params, q0, qd0, 1.0, free_dofs=JOINTS, gust=[0.0, 1.0, -0.5])
    one = rig_env.simulate(params, q0[1], qd0[1], 1.0, free_dofs=JOINTS, gust=[0.0, 1.0, -0.5])
    assert one.q.shape == (81, 5)
    np.testing.assert_array_equal(batch.q[1], one.q)


def test_per_environment_overrides_change_only_their_environment(params):
    q0 = np.zeros((2, 1)) + 0.1
    r = rig_env.simulate(params, q0, np.zeros((2, 1)), 2.0, free_dofs=["model_pitch"], overrides={"mass.hawk_Iyy": [0.017, 0.022]})
    assert not np.allclose(r.q[0], r.q[1])
    r0 = rig_env.simulate(params, q0[0], np.zeros(1), 2.0, free_dofs=["model_pitch"])
    np.testing.assert_array_equal(r.q[0], r0.q)

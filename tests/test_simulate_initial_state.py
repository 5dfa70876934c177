"""``simulate`` refuses physically impossible initial states (issue 24, item 9) before any kernel runs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rig_env import RigParams
from rig_env.params import param_batch
from rig_env.physics import layout as L
from rig_env.simulate import STOP_MARGIN_DEG, check_initial_state, simulate

FREE = ("rig_roll", "model_pitch")


@pytest.mark.parametrize("q, match", [
    ([0.0, 100.0, 0.0, 0.0, 0.0], "rig_pitch"),  # a locked joint at 100 rad
    ([0.0, 0.0, 0.0, math.radians(120.0), 0.0], "model_pitch"),  # model pitch far past its stop
    ([2e4, 0.0, 0.0, 0.0, 0.0], "rig_roll"),
])
def test_simulate_refuses_impossible_initial_angles(q, match):
    with pytest.raises(ValueError, match=match):
        simulate(RigParams.default(), q, None, 1.0, free_dofs=FREE)


def test_simulate_refuses_a_runaway_initial_rate():
    with pytest.raises(ValueError, match="runaway"):
        simulate(RigParams.default(), [0.0, 0.0], [2000.0, 0.0], 1.0, free_dofs=FREE)


def test_the_stop_margin_is_measured_from_the_parameters_own_stops():
    P = param_batch(RigParams.default(), 1)
    hi = math.degrees(P[0, L.P_STOPS_MODEL_PITCH_UPPER_DEG])  # the row holds rad
    assert hi == pytest.approx(RigParams.default().stops.model_pitch.upper_deg)
    X = np.zeros((1, L.N_STATE))
    X[0, L.X_Q + 3] = math.radians(hi + STOP_MARGIN_DEG - 0.01)  # inside the margin: a stop's spring compressed, accepted
    check_initial_state(X, P)
    X[0, L.X_Q + 3] = math.radians(hi + STOP_MARGIN_DEG + 0.01)
    with pytest.raises(ValueError, match="model_pitch"):
        check_initial_state(X, P)


@pytest.mark.parametrize("formulation", ["joint", "dae"])
def test_a_blow_up_mid_run_is_reported_and_frozen_in_both_formulations(formulation):
    """A gust of 1e6 m/s from t = 0.5 s overflows the aerodynamic loads: the environment is flagged
    non-finite and holds its last healthy state; the trajectory has no NaN (the DAE once returned NaN)."""
    p = RigParams.default()
    with pytest.warns(RuntimeWarning, match="blew up and were frozen"):
        r = simulate(p, [0.0, 0.3], [0.0, 0.0], 1.0, free_dofs=["rig_roll", "model_pitch"], formulation=formulation,
                     gust=lambda t: [0.0, 0.0, 1e6] if t > 0.5 else [0.0, 0.0, 0.0])
    assert int(np.ravel(r.status)[0]) == L.S_NONFINITE
    q = np.asarray(r.q).reshape(-1, 2)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(np.asarray(r.qd)))
    k = int(np.argmax(np.asarray(r.t) > 0.52))
    np.testing.assert_array_equal(q[k:], np.broadcast_to(q[k], q[k:].shape))  # frozen from the blow-up on

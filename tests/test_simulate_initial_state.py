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

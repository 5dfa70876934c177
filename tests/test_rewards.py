"""The tasks' rewards against hand computations: the wide term that ranks actions at large errors, the
rate terms on the success criterion's scale, the control-rate and saturation costs (rig_env.envs.tasks.base).

Every expected value below is worked out by hand from the formula in the docstrings, with the numbers
written out, not read back from the code."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rig_env.envs.tasks import TASKS, DepartureRecovery, VelocityVectorRoll

D = math.pi / 180.0
DT = 0.0125  # the 80 Hz control period


def _vvr(n: int = 1) -> VelocityVectorRoll:
    return VelocityVectorRoll(n, ("rig_roll", "model_pitch"), DT, 8.0)


def _state(n: int, roll: float = 0.0, rate: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    q, qd = np.zeros((n, 5)), np.zeros((n, 5))
    q[:, 0], qd[:, 0] = roll, rate
    return q, qd


def test_control_rate_cost_by_hand():
    """a = (0.5, 0, 0) after (0.3, 0, 0), tracking exact, a fresh episode (activity 0): rate 0.2 / 0.0125 s
    = 16 /s = 4 units of 4 /s, squared 16; the activity m = 0 + (0.0125 / 0.25)(16 - 0) = 0.8; c_u = 0.25 * 0.25
    + 0.2 * 0.8 = 0.2225, r = exp(-0.2225) = 0.800515.  The same action again (rate 0): m = 0.8 * 0.95 = 0.76,
    c_u = 0.0625 + 0.152 = 0.2145, r = 0.806945; a new episode (conditions) starts from m = 0 again."""
    task = _vvr()
    q, qd = _state(1)
    ref, a, a0 = np.zeros((1, 2)), np.array([[0.5, 0.0, 0.0]]), np.array([[0.3, 0.0, 0.0]])
    assert task.reward(q, qd, ref, a, a0)[0] == pytest.approx(0.800515, abs=1e-6)
    assert task.reward(q, qd, ref, a, a)[0] == pytest.approx(0.806945, abs=1e-6)
    from rig_env.physics import layout

    task.conditions(np.array([0]), np.array([20.0]), np.ones((1, layout.N_PARAMS)))
    assert task.reward(q, qd, ref, a, a0)[0] == pytest.approx(0.800515, abs=1e-6)


def test_saturation_cost_by_hand():
    """A surface held at full deflection (a = 1, unchanged): c_u = 0.25 + 0.3 * ((1 - 0.9) / 0.1)^2 = 0.55;
    at 0.95: 0.25 * 0.9025 + 0.3 * 0.25 = 0.300625; at 0.9 and below no saturation charge (0.25 * 0.81)."""
    task = _vvr(3)
    q, qd = _state(3)
    a = np.array([[1.0, 0, 0], [0.95, 0, 0], [0.9, 0, 0]])
    r = task.reward(q, qd, np.zeros((3, 2)), a, a)
    np.testing.assert_allclose(r, np.exp(-np.array([0.55, 0.300625, 0.2025])), rtol=1e-12)


def test_chatter_earns_less_than_a_smooth_command_with_equal_tracking():
    """Same states (exact tracking) over 4 s: a 2.5 Hz +-0.75 aileron sine (the old shipped policy's
    chatter) earns less than half of what holding still earns, a +-0.75 square wave (bang-bang, the same
    frequency) far less than that.  By hand: the rate's amplitude is 0.75 * 2 pi 2.5 = 11.78 /s = 2.945
    units, its square averages 4.337, which the 0.25 s activity average holds to within 2 % of its mean
    after the first second (a 2.5 Hz ripple at 5 Hz through a 0.64 Hz low pass); with 0.25 * 0.75^2 / 2 for
    the size: c_u = 0.0703 + 0.2 * 4.337 = 0.9377 and exp(-0.9377) = 0.3915."""
    task = _vvr()
    q, qd = _state(1)
    ref = np.zeros((1, 2))
    t = np.arange(321) * DT
    sine = 0.75 * np.sin(2 * np.pi * 2.5 * t)
    square = 0.75 * np.sign(np.sin(2 * np.pi * 2.5 * t + 0.1))

    def total(u: np.ndarray) -> float:
        task.activity[:] = 0.0
        r = [task.reward(q, qd, ref, np.array([[u[k], 0, 0]]), np.array([[u[k - 1], 0, 0]]))[0] for k in range(1, u.size)]
        return float(np.mean(r[80:]))  # after the first second

    still, smooth, chatter = total(np.zeros_like(t)), total(sine), total(square)
    assert still == 1.0
    # the discrete rate (per 12.5 ms step) of a sine is its derivative to within 1 %, the ripple about 2 %
    assert smooth == pytest.approx(0.3915, rel=0.03)
    assert chatter < 0.1 * smooth


def test_wide_term_ranks_actions_at_large_errors():
    """Roll errors of 60 and 90 deg (reference spinning, rate exact): the fine term exp(-36), exp(-81) is
    nil, the wide one 0.3 exp(-6/6) = 0.11036 and 0.3 exp(-9/6) = 0.06694: a policy halving a large error
    still gains."""
    task = _vvr(2)
    q, qd = _state(2, rate=2.0)
    q[:, 0] = [-60 * D, -90 * D]
    ref = np.array([[0.0, 2.0], [0.0, 2.0]])
    a = np.zeros((2, 3))
    r = task.reward(q, qd, ref, a, a)
    np.testing.assert_allclose(r, [0.3 * math.exp(-1.0) + 0.7 * math.exp(-36.0), 0.3 * math.exp(-1.5) + 0.7 * math.exp(-81.0)], rtol=1e-12)
    assert r[0] - r[1] > 0.04


def test_roll_rate_counts_on_the_success_scale_once_the_reference_stops():
    """A 20 deg/s roll-rate error (the success bound): c = 1 at rest, r = 0.7 e^-1 + 0.3 e^(-1/6) = 0.51146;
    while the reference still moves (60 deg/s scale) c = 1/9, r = 0.7 e^(-1/9) + 0.3 e^(-1/18) = 0.91013."""
    task = _vvr(2)
    q, qd = _state(2)
    qd[:, 0] = [-20 * D, 1.0 - 20 * D]
    ref = np.array([[0.0, 0.0], [0.0, 1.0]])
    a = np.zeros((2, 3))
    r = task.reward(q, qd, ref, a, a)
    np.testing.assert_allclose(r, [0.51146, 0.91013], atol=5e-5)


def test_departure_rates_count_on_the_recovery_scale():
    """Level rig, alpha 0, one free joint rate of 30 deg/s (the recovery bound): c = 1, r = 0.51146 (on the
    old 60 deg/s scale it was e^(-1/4) = 0.78, most of the reward for a rig not yet recovered)."""
    task = DepartureRecovery(1, ("rig_roll", "rig_pitch", "model_pitch", "model_yaw"), DT, 8.0)
    q, qd = np.zeros((1, 5)), np.zeros((1, 5))
    qd[0, 0] = 30 * D
    a = np.zeros((1, 3))
    assert task.reward(q, qd, np.zeros((1, 1)), a, a)[0] == pytest.approx(0.51146, abs=5e-5)


@pytest.mark.parametrize("name", sorted(TASKS))
def test_every_task_rewards_in_unit_interval_and_smoother_actions_never_earn_less(name):
    """Each task's reward lies in (0, 1] over random states and actions, and smoother actions never earn
    less: the same states with the action changed by less per step never score lower."""
    from rig_env.envs import RigVectorEnv

    env = RigVectorEnv(16, task=name)
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    task = env.task
    q = env.X[:, :5] + rng.normal(0, 0.3, (16, 5))
    qd = rng.normal(0, 1.0, (16, 5))
    ref = task.reference(np.full(16, 2.0))
    a_prev = rng.uniform(-1, 1, (16, 3))
    a = rng.uniform(-1, 1, (16, 3))
    m0 = task.activity.copy()
    r = task.reward(q, qd, ref, a, a_prev)
    assert np.all((r > 0.0) & (r <= 1.0))
    task.activity[:] = m0  # the same command history before the step
    r_smoother = task.reward(q, qd, ref, a, a_prev + 0.5 * (a - a_prev))
    assert np.all(r_smoother >= r)


def _ffe(n: int = 1):
    from rig_env.envs.tasks.freeflight import FreeFlightEmulation

    task = FreeFlightEmulation(n, ("rig_pitch", "model_pitch"), DT, 6.0)
    task.V[:] = 20.0
    return task


def test_free_flight_rate_cost_is_a_tenth_by_hand():
    """Free-flight emulation's command-activity weight is 0.02 (its docstring): the case of
    test_control_rate_cost_by_hand, at rest before the input (settle cost 0), m = 0.8: c_u = 0.25 * 0.25 + 0.02 * 0.8
    = 0.0785, r = exp(-0.0785) = 0.924502; the same action again, m = 0.76: c_u = 0.0777, r = 0.925242."""
    task = _ffe()
    q, qd, ref = np.zeros((1, 5)), np.zeros((1, 5)), np.zeros((1, 6))
    a, a0 = np.array([[0.0, 0.5, 0.0]]), np.array([[0.0, 0.3, 0.0]])
    assert task.reward(q, qd, ref, a, a0)[0] == pytest.approx(0.924502, abs=1e-6)
    assert task.reward(q, qd, ref, a, a)[0] == pytest.approx(0.925242, abs=1e-6)


def test_free_flight_error_at_the_criterions_limit_costs_one_per_term():
    """From the input on, an alpha error of half the episode's alpha RMS (the criterion's limit) costs c = 1: with
    s_alpha = 2 deg, alpha_ff = 1 deg and the rig at rest at its baseline, no command: r = 0.7 exp(-1) + 0.3
    exp(-1 / 6) = 0.511460; a quarter of the RMS (alpha_ff = 0.5 deg): c = 0.25, r = 0.7 exp(-0.25) + 0.3
    exp(-0.5 / 6) = 0.821174."""
    task = _ffe(2)
    task.s_alpha[:] = 2.0 * D
    q, qd = np.zeros((2, 5)), np.zeros((2, 5))
    ref = np.zeros((2, 6))
    ref[:, 0], ref[:, 4] = np.array([1.0, 0.5]) * D, 1.0
    a = np.zeros((2, 3))
    np.testing.assert_allclose(task.reward(q, qd, ref, a, a), [0.511460, 0.821174], atol=1e-6)

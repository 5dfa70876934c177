"""Servo model: delay, second-order lag, rate and position limits."""

import math

import numpy as np
import pytest

import rig_env


def flap_history(params, command, t_final=1.0, rate=400.0, **kw):
    r = rig_env.simulate(params, [0.0], [0.0], t_final, free_dofs=["model_pitch"], aero=False, friction=False,
                         controls={"hawk_elevator": command}, control_rate=rate, **kw)
    return r.t, r.flaps[:, 4]  # SERVOS order: hawk_elevator is actuator 4


def test_small_step_is_a_delayed_second_order_response(params):
    s = params.servos.hawk
    t, x = flap_history(params, lambda t: 1.0 if t >= 0.1 else 0.0)
    delay = round(s.delay_s / (1 / 400)) / 400
    wn, z = 2 * math.pi * s.natural_freq_hz, s.damping
    wd = wn * math.sqrt(1 - z * z)
    tau = np.clip(t - 0.1 - delay, 0.0, None)
    ref = 1.0 - np.exp(-z * wn * tau) * (np.cos(wd * tau) + z / math.sqrt(1 - z * z) * np.sin(wd * tau))
    assert np.all(x[t <= 0.1 + delay] == 0.0)  # nothing moves before the delay has elapsed
    assert np.abs(x - ref).max() < 2e-3  # deg, RK4 at 2.5 ms on a 6 Hz lag


def test_rate_and_position_limits(params):
    s = params.servos.hawk
    t, x = flap_history(params, lambda t: 60.0 if t >= 0.1 else -60.0, t_final=1.5)
    assert x.max() <= s.limit_deg + 1e-9 and x.min() >= -s.limit_deg - 1e-9
    assert x[-1] == pytest.approx(s.limit_deg, abs=1e-6)  # demand beyond the limit is held at the limit
    rates = np.diff(x) / np.diff(t)
    assert rates.max() <= s.rate_limit_deg_s * (1 + 1e-9)
    assert rates.max() > 0.95 * s.rate_limit_deg_s  # a 80 deg swing is rate limited


def test_ideal_servo_option_follows_the_delayed_command(params):
    t, x = flap_history(params, lambda t: 5.0 if t >= 0.1 else 0.0, servo=False)
    delay = round(params.servos.hawk.delay_s * 400) / 400
    assert np.all(x[t > 0.1 + delay + 1e-9] == pytest.approx(5.0))


def test_compensator_flaps_are_mixed(params):
    r = rig_env.simulate(params, [0.0], [0.0], 0.5, free_dofs=["model_pitch"], aero=False,
                         controls={"comp_aileron": 5.0, "comp_elevator": 2.0, "comp_rudder": 1.0})
    np.testing.assert_allclose(r.flaps[-1, :4], [5 + 2 - 1, 5 - 2 - 1, 5 - 2 + 1, 5 + 2 + 1], atol=1e-3)

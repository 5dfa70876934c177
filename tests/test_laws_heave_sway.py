"""Heave/sway laws (controllers.laws.heave_sway): designs against theory, the reference parser against the
task's true reference, the registry, and closed-loop success rates (slow)."""

from __future__ import annotations

import math
from dataclasses import replace

import control
import numpy as np
import pytest

from controllers import LoopSpec, make_controller
from controllers.design.heave_sway import (
    axis_point,
    design_heave_sway_lqr,
    design_heave_sway_pid,
    lqr_margins,
    lqr_point,
    pid_margins_as_flown,
    static_table,
    tune_driven,
)
from controllers.evaluation.evaluate import GUSTY, NOMINAL, evaluate
from controllers.laws.heave_sway import HeaveSwayLQR, HeaveSwayPID
from controllers.design.lqr import augmented
from controllers.laws.lqr import LQRLaw
from controllers.design.model import loop_elements
from controllers.laws.pid import PIDLaw
from controllers.laws.references import DrivenReference
from controllers.design.signals import reference_constants
from rig_env import RigParams
from rig_env.envs import RigVectorEnv

DT = 1.0 / 80.0
PITCH = ("rig_pitch", "model_pitch")
YAW = ("rig_yaw", "model_yaw")
CASES = [("pull_up_push_over", {}), ("forced_oscillation", {"axis": "heave_pitch"}), ("forced_oscillation", {"axis": "sway_yaw"}),
         ("free_flight_emulation", {})]


@pytest.fixture(scope="module")
def params() -> RigParams:
    return RigParams.default()


def _spec(task: str, opts: dict, n: int = 2) -> tuple[RigVectorEnv, LoopSpec]:
    env = RigVectorEnv(n, task=task, task_options=opts, airspeed=(20.0, 20.0))
    return env, LoopSpec.from_env(env)


# --------------------------------------------------------------------------------------------- design
@pytest.mark.parametrize("fd, joint", [(PITCH, "rig_pitch"), (YAW, "rig_yaw")])
def test_pid_loops_meet_the_stated_margins_with_servo_and_delay(params, fd, joint):
    """Rebuild both loops from the tuned gains and the linear model (servo, Pade delay and rate sensor
    in the loop, as tuning.py) and read python-control's margins directly: inner PI PM >= 50 deg,
    GM >= 8 dB; outer P PM >= 60 deg, GM >= 10 dB."""
    _, sys = axis_point(params, fd, 20.0)
    t = tune_driven(params, sys, joint, 20.0, DT)
    k_in, k_out = {"rig_pitch": 1, "rig_yaw": 2}[joint], sys.output_labels.index(f"{joint}_rate")
    P = control.ss2tf(control.ss(sys.A, sys.B[:, [k_in]], sys.C[[k_out], :], 0.0))
    el = loop_elements(params, DT)
    s = control.tf("s")
    C = t.kp + t.ki / s
    L_in = C * el["servo"] * el["delay"] * P * el["rate_sensor"]
    gm, pm = control.stability_margins(L_in)[:2]
    assert np.all(np.real(control.feedback(L_in, 1).poles()) < 1e-8)  # (the rate plant's zero cancels the PI's pole)
    assert 20 * math.log10(gm) >= 8.0 - 1e-6 and pm >= 50.0 - 1e-6
    T_r = control.feedback(C * el["servo"] * el["delay"] * P, el["rate_sensor"])
    L_out = t.k_angle * T_r / s
    gm_o, pm_o = control.stability_margins(L_out)[:2]
    assert np.all(np.real(control.feedback(L_out, 1).poles()) < 1e-8)
    assert 20 * math.log10(gm_o) >= 10.0 - 1e-6 and pm_o >= 60.0 - 1e-6


HEAVE_PID_SHORT = ("the default rig's heave PID falls short (README, 'Not done yet'): its decoupling of the passive model "
                   "pitch acts across the lightly damped heave mode (6.9 rad/s, damping 0.035, the alpha-dot split making heave "
                   "drive the Hawk's pitch); as flown GM 5.3 dB at 20 m/s (3.9 at 25), success 21 and 19 of 32 below; without the decoupling GM 16 dB but 16 and 17 of 32")


@pytest.mark.parametrize("rig, fd, joint", [
    pytest.param("default", PITCH, "rig_pitch", marks=pytest.mark.xfail(strict=True, reason=HEAVE_PID_SHORT)),
    ("default", YAW, "rig_yaw"), ("paper", PITCH, "rig_pitch"), ("paper", YAW, "rig_yaw")])
def test_pid_law_broken_at_the_surface_command_keeps_margins(rig, fd, joint):
    """The whole PID law (cascade and decoupling) broken at the actuator: the closed loop is stable and
    PM >= 30 deg, GM >= 6 dB (servo and delay in).  Decoupling adds phase: PM with it >= PM without."""
    params = getattr(RigParams, rig)()
    _, sys = axis_point(params, fd, 20.0)
    t = tune_driven(params, sys, joint, 20.0, DT)
    gm, pm, wc = pid_margins_as_flown(params, sys, joint, t, DT)
    _, pm0, _ = pid_margins_as_flown(params, sys, joint, t, DT, decouple=None)
    assert gm >= 6.0 and pm >= 30.0 and np.isfinite(wc)
    assert pm >= pm0


@pytest.mark.parametrize("fd, joint, hold", [(PITCH, "rig_pitch", True), (YAW, "rig_yaw", True), (PITCH, "rig_pitch", False)])
def test_lqr_poles_and_margins(params, fd, joint, hold):
    """Closed-loop poles of the augmented model are the ones lqr reports; loop broken at the driven
    input with servo and delay: GM >= 6 dB, PM >= 45 deg (as flown: passive gains zeroed when hold=False)."""
    q, sys = axis_point(params, fd, 20.0)
    d = lqr_point(q, sys, fd, 20.0)
    Aa, Ba, _ = augmented(d.A, d.B, fd)
    eig = np.sort_complex(np.linalg.eigvals(Aa - Ba @ d.K))
    np.testing.assert_allclose(eig, np.sort_complex(d.poles), rtol=1e-6, atol=1e-8)
    gm, pm, wc = lqr_margins(d, joint, params, DT, hold_passive=hold)
    assert gm >= 6.0 and pm >= 45.0 and np.isfinite(wc)


@pytest.mark.parametrize("task, opts", CASES)
def test_lqr_law_as_built_meets_its_margin_targets(task, opts):
    """The law's weight search keeps GM >= 6 dB and PM >= 45 deg at every design airspeed, and the
    next tighter candidate would not (so the search did tighten as far as the targets allow)."""
    from controllers.laws.heave_sway import ANGLE_MAX_DEG, LQR_TARGETS
    _, spec = _spec(task, opts)
    law = HeaveSwayLQR(spec, 1, tables=design_heave_sway_lqr(spec))
    j = law.joint
    for point in law.describe()["points"]:
        assert point[j]["gm_db"] >= LQR_TARGETS["gm_db"] and point[j]["pm_deg"] >= LQR_TARGETS["pm_deg"]
    chosen = math.degrees(law.max_deviation[j])
    tighter = [a for a in ANGLE_MAX_DEG if a < chosen - 1e-9]
    if tighter:
        md = {j: math.radians(tighter[0]), f"{j}_rate": math.radians(30.0), f"int_{j}": math.radians(tighter[0])}
        worst = [(p[j]["gm_db"], p[j]["pm_deg"]) for p in HeaveSwayLQR(spec, 1, tables=design_heave_sway_lqr(spec, max_deviation=md)).describe()["points"]]
        assert any(gm < LQR_TARGETS["gm_db"] or pm < LQR_TARGETS["pm_deg"] for gm, pm in worst)


@pytest.mark.parametrize("fd, joint, k_in", [(PITCH, "rig_pitch", 1), (YAW, "rig_yaw", 2)])
def test_static_curve_slope_equals_the_linear_quasi_static_stiffness(params, fd, joint, k_in):
    """Trim (nonlinear, every joint settled) against linearisation: at the zero-input trim the static
    gain of the linear model, dq = -A_q^-1 B du, gives du/dtheta = 1 / (-A_q^-1 B)_j."""
    _, sys = axis_point(params, fd, 20.0)
    th, u = static_table(params, fd, joint, 20.0)
    i0 = int(np.argmin(np.abs(u)))
    slope = (u[i0 + 1] - u[i0 - 1]) / (th[i0 + 1] - th[i0 - 1])
    A, B = np.asarray(sys.A), np.asarray(sys.B)
    G = -np.linalg.solve(A[2:, :2], B[2:, k_in])
    assert slope == pytest.approx(1.0 / G[0], rel=0.02)


# --------------------------------------------------------------------------------------------- reference parser
@pytest.mark.parametrize("task, opts", CASES[:3])
def test_reference_parser_matches_the_task_reference(task, opts):
    """e + measured angle and w_ref against the environment's true reference (angle noise and
    quantisation, 0.1 deg); a_ref against the derivative of the true reference rate."""
    env, spec = _spec(task, opts, 4)
    law = make_controller("pid", spec, 4)  # flies the rig
    parser = DrivenReference(spec, 4, reference_constants(spec, RigParams.default()))  # under test, on the same observations
    obs, _ = env.reset(seed=3)
    law.reset()
    refs, rates, accs = [], [], []
    for _ in range(int(4.0 / env.dt)):
        e, w, a = parser(obs)
        th, _ = parser.theta(obs)
        refs.append((th + e, env.reference()[:, 0]))
        rates.append((w, env.reference()[:, 1]))
        accs.append(a)
        obs, *_ = env.step(law.act(obs))
    got, true = (np.array(x) for x in zip(*refs))
    np.testing.assert_allclose(got, true, atol=math.radians(0.1))
    w_got, w_true = (np.array(x) for x in zip(*rates))
    if task == "pull_up_push_over":
        np.testing.assert_allclose(w_got, w_true, atol=1e-3)
    else:  # rate error + measured (filtered) rate: exact up to the filter's float rounding
        np.testing.assert_allclose(w_got, w_true, atol=1e-6)
    a_num = np.gradient(np.array(w_true), env.dt, axis=0)
    a = np.array(accs)
    assert np.sqrt(np.mean((a - a_num) ** 2)) < 0.05 * max(1.0, np.sqrt(np.mean(a_num**2)))


# --------------------------------------------------------------------------------------------- registry
@pytest.mark.parametrize("task, opts", CASES)
def test_make_controller_builds_the_heave_sway_laws(task, opts):
    """The heave/sway laws, except free-flight emulation's LQR: the model-following one (controllers.laws.emulation) comes first."""
    from controllers.laws.emulation import EmulationLQR
    _, spec = _spec(task, opts)
    assert type(make_controller("pid", spec, 2)) is HeaveSwayPID
    assert type(make_controller("lqr", spec, 2)) is (EmulationLQR if task == "free_flight_emulation" else HeaveSwayLQR)


@pytest.mark.parametrize("task", ["velocity_vector_roll", "bank_to_bank", "departure_recovery"])
def test_make_controller_keeps_the_roll_laws_for_roll_tasks(task):
    """rig_roll free: the roll laws, registered first, fly it (departure recovery included)."""
    _, spec = _spec(task, {})
    assert type(make_controller("pid", spec, 2)) is PIDLaw
    assert type(make_controller("lqr", spec, 2)) is LQRLaw


def test_laws_refuse_a_locked_driven_joint():
    env = RigVectorEnv(2, task="forced_oscillation", task_options={"axis": "heave_pitch"}, free_dofs=("rig_pitch",))
    spec = replace(LoopSpec.from_env(env), task_options={"axis": "sway_yaw"})
    from controllers.laws.base import UnsupportedTask
    with pytest.raises(UnsupportedTask, match="rig_yaw"):
        HeaveSwayPID(spec, 2, tables=design_heave_sway_pid(spec))


# --------------------------------------------------------------------------------------------- closed loop
GUSTS_OFF = replace(NOMINAL, airspeed=(20.0, 20.0), turbulence=0.0)
# Thresholds: the rate measured on these 32 seeded episodes (seed 0) minus 10-15 points, so that a
# change of law or model that loses a few episodes is caught but float-level noise is not:
# pull-up PID 21/32, LQR 32/32 (on the paper's model, before the consistent set became the default, 32/32 each;
# 27/32 each before its holds were drawn within the compensator's trim authority); heave oscillation PID 19/32
# (32/32 on the paper's model), LQR 32/32; sway PID 32/32, LQR 32/32.  The heave PID's shortfall is
# HEAVE_PID_SHORT's: held to the threshold as an expected failure until its design is mended.
# (With 1 % gusts, a wind tunnel's turbulence level: 26/32, 32/32; 31/32, 32/32; 32/32, 32/32.)
# Free-flight emulation is not reached by these laws (median emulation error 0.82 PID, 1.20 heave/sway LQR
# > 0.5) and has no threshold here; the model-following LQR that does is tested in test_laws_emulation.py.
THRESHOLDS = {
    ("pull_up_push_over", ""): {"pid": 0.85, "lqr": 0.85},
    ("forced_oscillation", "heave_pitch"): {"pid": 0.85, "lqr": 0.85},
    ("forced_oscillation", "sway_yaw"): {"pid": 0.85, "lqr": 0.85},
}


@pytest.mark.parametrize("task, axis, kind", [
    pytest.param(*k, kind, marks=pytest.mark.xfail(strict=True, reason=HEAVE_PID_SHORT)) if kind == "pid" and k[1] != "sway_yaw" else (*k, kind)
    for k in THRESHOLDS for kind in ("pid", "lqr")])
def test_success_rates_at_20_m_s_without_gusts(task, axis, kind):
    """Success at 20 m/s, NOMINAL parameter spread and sensors, gusts off.  With 5 % gusts (GUSTY) the
    rig's lightly damped heave-pitch mode (open loop 7 deg RMS on the pull-up) keeps the error above
    the tasks' 0.5 deg settling band and 0.3 A oscillation limit for every law here, so the
    thresholds are stated without gusts (as the tasks' own "within reach" claims are)."""
    res = evaluate({kind: kind}, task, n_episodes=32, seed=0, conditions=GUSTS_OFF,
                   env_overrides={"task_options": {"axis": axis}} if axis else None)
    rate, thr = float(np.mean(res.metrics[kind]["success"])), THRESHOLDS[(task, axis)][kind]
    assert rate >= thr, f"{kind} on {task} {axis}: success {rate:.2f} < {thr}"


def test_lqr_flies_the_heave_oscillation_through_strong_gusts():
    """5 % gusts (the comparison's "gusty" stress mode) at 20 m/s: the heave LQR (estimator, model-joint
    feedback) keeps the oscillation within 0.3 A in 27 of 32 episodes (threshold 0.70); the PID, 4 of 32, is not held to it."""
    res = evaluate({"lqr": "lqr"}, "forced_oscillation", n_episodes=32, seed=0, conditions=replace(GUSTY, airspeed=(20.0, 20.0)))
    assert float(np.mean(res.metrics["lqr"]["success"])) >= 0.70

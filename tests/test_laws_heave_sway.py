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
from controllers.design.tuning import margins
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
def _law_row(sys, joint: str, el: dict, kp: float = 0.0, ki: float = 0.0, k_angle: float = 0.0) -> control.StateSpace:
    """The heave/sway PID's feedback of the model's states as a (1, 2 nq) row (cascade kp, ki, k_angle on the driven
    joint; the decoupling A_jp / b, A'_jp H / b on the passive ones), built here from the linear model's matrices:
    u = -row . x.  With kp = ki = k_angle = 0 the decoupling alone."""
    s = control.tf("s")
    nq = len(sys.state_labels) // 2
    k = sys.state_labels.index(joint)
    A = np.asarray(sys.A)
    b = float(sys.B[nq + k, {"rig_pitch": 1, "rig_yaw": 2}[joint]])
    C = kp + ki / s
    H = el["rate_sensor"]
    row = []
    for i in range(2 * nq):
        if i % nq == k:
            row.append(C * k_angle if i < nq else C * H)
        else:
            row.append(A[nq + k, i] / b * (1 + 0 * s) if i < nq else A[nq + k, i] / b * H)
    Z = control.append(*(control.tf2ss(r) for r in row))  # the entries side by side, then summed
    ones = np.ones((1, 2 * nq))
    return control.ss(Z.A, Z.B, ones @ Z.C, ones @ Z.D)


def _plant_states(sys, joint: str) -> control.StateSpace:
    """Every state of the linear model per unit input of the driven joint's axis (2 nq outputs)."""
    k_in = {"rig_pitch": 1, "rig_yaw": 2}[joint]
    n = len(sys.state_labels)
    return control.ss(sys.A, sys.B[:, [k_in]], np.eye(n), np.zeros((n, 1)))


@pytest.mark.parametrize("rig, fd, joint", [("default", PITCH, "rig_pitch"), ("default", YAW, "rig_yaw"), ("paper", PITCH, "rig_pitch")])
def test_pid_loops_meet_the_stated_margins_with_servo_and_delay(rig, fd, joint):
    """Rebuild both loops from the tuned gains and the linear model (servo, Pade delay and rate sensor
    in the loop, as tuning.py), the cascade's plant the one the decoupling leaves it (its loop closed by
    state-space interconnection here), and read python-control's margins directly: inner PI PM >= 50 deg,
    GM >= 8 dB; outer P PM >= 60 deg, GM >= 10 dB."""
    params = getattr(RigParams, rig)()
    _, sys = axis_point(params, fd, 20.0)
    t = tune_driven(params, sys, joint, 20.0, DT)
    el = loop_elements(params, DT)
    s = control.tf("s")
    SD = control.tf2ss(el["servo"] * el["delay"])
    G = _plant_states(sys, joint) * SD  # every state per unit command, servo and delay in
    nq = len(fd)
    closed = control.feedback(G, _law_row(sys, joint, el))  # the decoupling's loop closed
    P = control.ss2tf(closed[nq + fd.index(joint), 0])  # the driven joint's rate per unit command of the cascade
    C = t.kp + t.ki / s
    L_in = C * P * el["rate_sensor"]
    gm, pm = control.stability_margins(L_in)[:2]
    assert np.all(np.real(control.feedback(L_in, 1).poles()) < 1e-8)  # (the rate plant's zero cancels the PI's pole)
    assert 20 * math.log10(gm) >= 8.0 - 1e-6 and pm >= 50.0 - 1e-6
    T_r = control.feedback(C * P, el["rate_sensor"])
    L_out = t.k_angle * T_r / s
    gm_o, pm_o = control.stability_margins(L_out)[:2]
    assert np.all(np.real(control.feedback(L_out, 1).poles()) < 1e-8)
    assert 20 * math.log10(gm_o) >= 10.0 - 1e-6 and pm_o >= 60.0 - 1e-6


@pytest.mark.parametrize("rig, fd, joint", [("default", PITCH, "rig_pitch"), ("default", YAW, "rig_yaw"), ("paper", PITCH, "rig_pitch"),
                                           ("paper", YAW, "rig_yaw")])
def test_pid_law_broken_at_the_surface_command_keeps_margins(rig, fd, joint):
    """The whole PID law (cascade and decoupling) broken at the actuator, built here by state-space
    interconnection: the closed loop is stable and PM >= 30 deg, GM >= 6 dB (servo and delay in), the design's
    own report (pid_margins_as_flown) the same.  The decoupling is part of what keeps them: the same gains without it
    keep less gain margin on every axis (pitch 9.2 against 5.7 dB on the default rig); on the yaw axes it adds phase
    too, on the pitch axes the design spends some (30.3 against 31.9 deg).  On the default rig, where heave drives
    the Hawk's pitch across the lightly damped heave mode, the cascade shaped without the decoupling in its plant (the
    design before) kept less than 6 dB."""
    params = getattr(RigParams, rig)()
    _, sys = axis_point(params, fd, 20.0)
    t = tune_driven(params, sys, joint, 20.0, DT)
    el = loop_elements(params, DT)
    SD = control.tf2ss(el["servo"] * el["delay"])
    L = _law_row(sys, joint, el, t.kp, t.ki, t.k_angle) * _plant_states(sys, joint) * SD
    gm, pm, wc = margins(L)
    assert gm >= 6.0 and pm >= 30.0 and np.isfinite(wc)
    assert (gm, pm, wc) == pytest.approx(pid_margins_as_flown(params, sys, joint, t, DT), rel=1e-6)
    gm0, pm0, _ = pid_margins_as_flown(params, sys, joint, t, DT, decouple=None)
    assert gm > gm0
    if joint == "rig_yaw":
        assert pm >= pm0
    if rig == "default" and joint == "rig_pitch":
        before = tune_driven(params, sys, joint, 20.0, DT, decouple=None)
        L0 = _law_row(sys, joint, el, before.kp, before.ki, before.k_angle) * _plant_states(sys, joint) * SD
        assert margins(L0)[0] < 6.0


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
# pull-up PID 32/32, LQR 32/32; heave oscillation PID 32/32, LQR 32/32; sway PID 32/32, LQR 32/32.  (The heave PID
# shaped without its decoupling in the plant, before: 21/32 and 19/32 on the default rig, 32/32 each on the paper's model.)
# (With 1 % gusts, a wind tunnel's turbulence level: 26/32, 32/32; 32/32, 32/32; 32/32, 32/32.)
# Free-flight emulation is not reached by these laws (median emulation error 0.82 PID, 1.20 heave/sway LQR
# > 0.5) and has no threshold here; the model-following LQR that does is tested in test_laws_emulation.py.
THRESHOLDS = {
    ("pull_up_push_over", ""): {"pid": 0.85, "lqr": 0.85},
    ("forced_oscillation", "heave_pitch"): {"pid": 0.85, "lqr": 0.85},
    ("forced_oscillation", "sway_yaw"): {"pid": 0.85, "lqr": 0.85},
}


@pytest.mark.parametrize("task, axis, kind", [
    (*k, kind) for k in THRESHOLDS for kind in ("pid", "lqr")])
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
    feedback) keeps the oscillation within 0.3 A in 27 of 32 episodes (threshold 0.70); the PID, 8 of 32, is not held to it."""
    res = evaluate({"lqr": "lqr"}, "forced_oscillation", n_episodes=32, seed=0, conditions=replace(GUSTY, airspeed=(20.0, 20.0)))
    assert float(np.mean(res.metrics["lqr"]["success"])) >= 0.70

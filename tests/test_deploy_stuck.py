"""The loop's stuck-sensor watchdog (controllers/deploy/stuck.py) on synthetic frame sequences, and inside ``RigLoop``.

Frames are built as the sim rig builds them: true angle + N(0, sigma) noise, quantised to the converter's
lsb (12-bit pot over 360 deg: 0.088 deg), sent as float32.  The flight against the sim rig is in
tests/test_deploy.py (``test_stuck_sensor_latches_fault_naming_the_joint``); the HIL flights there run
with the watchdog on at its defaults and assert no fault (normal flight, 6 s and 20 s).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from controllers.laws import artefact as A
from controllers.deploy import protocol as pr
from controllers.design.linear import roll_tracking
from controllers.deploy.loop import ACTIVE, F_STUCK, FAULT, LoopConfig, RigLoop
from controllers.deploy.stuck import U_REF, StuckDetector
from rig_env.params import JOINTS

POT_LSB = 2.0 * math.pi / 2**12
SIGMA = math.radians(0.05)  # RigEnvConfig.angle_noise_deg default
N = 32  # LoopConfig.stuck_frames default
SPAN = math.radians(2.0)  # LoopConfig.stuck_cmd_deg default


def readings(true: np.ndarray, rng: np.random.Generator, sigma: float = SIGMA, lsb: float = POT_LSB) -> np.ndarray:
    """What the rig sends for true angles (frames, n_j) rad: noisy, quantised, float32 on the wire."""
    m = np.rint((true + sigma * rng.standard_normal(true.shape)) / lsb) * lsb
    return m.astype(np.float32).astype(np.float64)


def run(det: StuckDetector, angles: np.ndarray, commands: np.ndarray, airspeed: float = U_REF) -> np.ndarray:
    """The detector's answer on every frame, (frames,) int."""
    return np.array([det.update(a, c, airspeed) for a, c in zip(angles, commands)])


def wiggle(frames: int, amplitude: float) -> np.ndarray:
    """A command (frames, 6) rad moving as a 1 Hz sine of ``amplitude`` rad on the aileron (80 Hz frames)."""
    c = np.zeros((frames, 6))
    c[:, 0] = amplitude * np.sin(2 * np.pi * np.arange(frames) / 80.0)
    return c


# ---------------------------------------------------------------------- the rule
def test_frozen_driven_joint_trips_exactly_after_the_bound_and_names_it():
    rng = np.random.default_rng(1)
    t = np.arange(600) / 80.0
    true = np.stack([np.radians(30.0) * np.sin(t), np.radians(5.0) * np.sin(2 * t)], axis=1)  # rig_roll, model_pitch moving
    ang = readings(true, rng)
    t0 = 300
    ang[t0:, 0] = ang[t0, 0]  # rig_roll frozen from frame t0 on, as the sim rig's --stuck
    det = StuckDetector(("rig_roll", "model_pitch"), N, SPAN, 6)
    out = run(det, ang, wiggle(600, math.radians(10.0)))
    first = int(np.flatnonzero(out >= 0)[0])
    assert first == t0 + N  # N repeats of the frame-t0 value, no earlier
    assert out[first] == 0 and det.joints[out[first]] == "rig_roll"
    assert np.all(out[first:] == 0)


def test_still_noisy_joint_repeat_rate_matches_theory_and_default_bound_never_trips():
    """A still pot at a code's centre: code c is read with probability p_c = P((c - 1/2) lsb < sigma z < (c + 1/2) lsb).

    Theory: consecutive frames repeat with probability sum p_c^2, and a run of k repeats ends on a frame with
    probability sum p_c^(k+1) <= p_0^k, p_0 = 0.62 (the docstring's bound); at the default 32 that is 2.3e-7, so
    100,000 driven frames must not trip.
    """
    rng = np.random.default_rng(2)
    n = 100_000
    true = np.full((n, 1), 100 * POT_LSB)  # worst case: the true angle at a code's centre
    ang = readings(true, rng)
    def phi(x: float) -> float:
        return 0.5 * (1.0 + math.erf(x / math.sqrt(2)))

    pc = np.array([phi((c + 0.5) * POT_LSB / SIGMA) - phi((c - 0.5) * POT_LSB / SIGMA) for c in range(-6, 7)])
    assert abs(pc.sum() - 1.0) < 1e-12 and abs(pc[6] - 0.62) < 0.005
    rep = np.mean(ang[1:, 0] == ang[:-1, 0])
    q = float(np.sum(pc**2))
    assert abs(rep - q) < 4 * math.sqrt(q * (1 - q) / n)
    cmd = np.zeros((n, 6))
    cmd[1::2, 0] = 1.5 * SPAN  # moving by more than the span on every frame: the gate is always open
    k = 6
    frac = np.mean(run(StuckDetector(("rig_roll",), k, SPAN, 6), ang, cmd) >= 0)
    expect = float(np.sum(pc ** (k + 1)))
    assert abs(frac - expect) < 5 * math.sqrt(expect / n)  # tripping frames come in runs: a loose bound on the count
    assert expect <= pc[6] ** k and pc[6] ** N < 2.5e-7
    assert np.all(run(StuckDetector(("rig_roll",), N, SPAN, 6), ang, cmd) < 0)


def test_still_rig_without_noise_never_trips_unless_the_command_moves():
    """A joint at rest read by a noise-free converter repeats forever: no trip under a constant or a small command."""
    ang = readings(np.full((2000, 2), np.radians(3.0)), np.random.default_rng(3), sigma=0.0)
    joints = ("rig_roll", "model_pitch")
    assert np.all(run(StuckDetector(joints, N, SPAN, 6), ang, np.zeros((2000, 6))) < 0)  # zero command (DISARMED, FAULT)
    held = np.tile(np.radians([12.0, -3.0, 0.0, 0, 0, 0]), (2000, 1))
    assert np.all(run(StuckDetector(joints, N, SPAN, 6), ang, held) < 0)  # a law holding a steady output
    assert np.all(run(StuckDetector(joints, N, SPAN, 6), ang, wiggle(2000, 0.45 * SPAN)) < 0)  # moving 0.9 x the span
    # the same readings with the command moving by more than the span: a frozen channel cannot be told from it
    out = run(StuckDetector(joints, N, SPAN, 6), ang, wiggle(2000, math.radians(10.0)))
    assert np.flatnonzero(out >= 0)[0] == N


def test_evidence_scales_with_dynamic_pressure():
    """The span asked for is cmd_span (U_REF / U)^2: 2 deg at 18 m/s, 8 deg at 9 m/s, nothing with the wind off."""
    ang = np.zeros((400, 1))
    joints = ("rig_roll",)
    for u, amp_deg, trips in ((U_REF, 1.1, True), (9.0, 1.1, False), (9.0, 4.2, True), (0.0, 40.0, False)):
        out = run(StuckDetector(joints, N, SPAN, 6), ang, wiggle(400, math.radians(amp_deg)), airspeed=u)  # span 2 x amp over a run
        assert (out >= 0).any() == trips, (u, amp_deg)
    assert (run(StuckDetector(joints, N, 0.0, 6), ang, np.zeros((400, 6)), airspeed=0.0) >= 0).any()  # cmd_span 0: any run


def test_disabled_detector_never_trips():
    ang = np.zeros((500, 1))
    for frames in (None, 0):
        assert np.all(run(StuckDetector(("rig_roll",), frames, 0.0, 6), ang, wiggle(500, 1.0)) < 0)


# ---------------------------------------------------------------------- configuration
@pytest.mark.parametrize("field, value", [("stuck_frames", -1), ("stuck_frames", 1), ("stuck_frames", 2.5), ("stuck_frames", True),
                                          ("stuck_frames", "40"), ("stuck_frames", 2_000_000), ("stuck_cmd_deg", -0.1),
                                          ("stuck_cmd_deg", float("nan")), ("stuck_cmd_deg", 81.0), ("stuck_cmd_deg", "2")])
def test_config_refuses_bad_stuck_settings_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        LoopConfig(rig=("127.0.0.1", 1), rate_hz=80.0, **{field: value})


def test_config_accepts_disabled_and_range_ends():
    for kw in ({"stuck_frames": None}, {"stuck_frames": 0}, {"stuck_frames": 2}, {"stuck_cmd_deg": 0.0}, {"stuck_cmd_deg": 80.0}):
        LoopConfig(rig=("127.0.0.1", 1), rate_hz=80.0, **kw)


# ---------------------------------------------------------------------- inside the loop (no network)
class FedLoop(RigLoop):
    """``RigLoop`` whose frames come from a list instead of the socket (``_drain`` replaced), driven tick by tick."""

    def feed(self, angles: np.ndarray, command: np.ndarray) -> None:
        self._next = angles
        self.limits.cmd[:] = command  # as if the loop had sent it last tick

    def _drain(self) -> bool:
        self.seq += 1
        self.rig_time, self.airspeed, self.status = self.seq / 80.0, 20.0, pr.STATUS_SIMULATED
        self.angles[:] = self._next
        return True


@pytest.fixture(scope="module")
def vvr_law(tmp_path_factory):
    """The demonstration roll-tracking law for velocity_vector_roll, as a file."""
    from controllers.laws.base import LoopSpec
    from rig_env.envs import RigVectorEnv

    spec = LoopSpec.from_env(RigVectorEnv(1, task="velocity_vector_roll"))
    sensors = {"rate_filter_hz": 10.0, "link_delay_steps": 0, "quantise": True, "pot_bits": 12, "encoder_bits": 13}
    path = tmp_path_factory.mktemp("stuck") / "law.json"
    A.save(A.from_controller(roll_tracking(spec), sensors, A.default_limits(spec, 350.0), source="test"), path)
    return path


@pytest.fixture(scope="module")
def vvr_artefact(vvr_law):
    return A.load(vvr_law)


def test_run_command_refuses_bad_stuck_frames(vvr_law, capsys):
    from controllers.deploy.cli import EXIT_REFUSED, main

    assert main(["run", "--law", str(vvr_law), "--rig", "udp://127.0.0.1:9", "--stuck-frames", "1"]) == EXIT_REFUSED
    assert "stuck_frames = 1" in capsys.readouterr().err


def fly_frames(art, angles: np.ndarray, commands: np.ndarray, **cfg) -> FedLoop:
    loop = FedLoop(art, LoopConfig(rig=("127.0.0.1", 1), rate_hz=80.0, **cfg))
    loop.t0 = time.perf_counter()
    for k, (a, c) in enumerate(zip(angles, commands)):
        loop.feed(a, c)
        loop._sense(k, 0.0)
        if k == 0:
            loop.state = ACTIVE  # armed at the first frame
    return loop


def test_loop_latches_stuck_fault_on_a_free_joint_and_ignores_locked_ones(vvr_artefact):
    """velocity_vector_roll: rig_roll and model_pitch free; the locked joints' readings are constant (the true angle)."""
    assert vvr_artefact.spec.free_dofs == ("rig_roll", "model_pitch")
    rng = np.random.default_rng(4)
    n, t0 = 400, 200
    ang = np.zeros((n, 5))
    ang[:, [JOINTS.index("rig_pitch"), JOINTS.index("rig_yaw"), JOINTS.index("model_yaw")]] = np.radians([1.5, -0.7, 2.0])  # locked
    t = np.arange(n) / 80.0
    free = readings(np.stack([np.radians(20.0) * np.sin(t), np.radians(2.0) * np.sin(3 * t)], axis=1), rng)
    ang[:, JOINTS.index("rig_roll")], ang[:, JOINTS.index("model_pitch")] = free[:, 0], free[:, 1]
    cmd = wiggle(n, math.radians(8.0))
    healthy = fly_frames(vvr_artefact, ang[:t0], cmd[:t0])
    assert healthy.state == ACTIVE and healthy.fault == 0  # locked channels constant for 200 driven frames: not watched
    mp = JOINTS.index("model_pitch")
    ang[t0:, mp] = ang[t0, mp]
    start = int(np.flatnonzero(ang[:t0, mp] != ang[t0, mp])[-1]) + 1  # the frozen value's run may begin a frame or two early
    assert t0 - 5 < start <= t0
    loop = fly_frames(vvr_artefact, ang, cmd)
    assert loop.state == FAULT and loop.fault == F_STUCK
    (ev,) = [e for e in loop.events if e["event"] == "fault"]
    assert ev["fault"] == "stuck_sensor" and ev["tick"] == start + N and ev["detail"].startswith("model_pitch reading")
    off = fly_frames(vvr_artefact, ang, cmd, stuck_frames=None)
    assert off.state == ACTIVE and off.fault == 0


# ---------------------------------------------------------------------- the default span, against the model
def test_default_span_is_more_than_roll_friction_can_hold():
    """stuck_cmd_deg = 2 deg at 18 m/s: more than the command change the rig roll's breakaway friction can hold still.

    Friction holds the rig through a moment change of at most 2 Fs; on the smallest roll inertia (0.14 kg m^2,
    docs/PARAMETERS.md, without the model) that is an acceleration of 2 Fs / 0.14, which one rad of compensator aileron
    matches with B = d(roll acceleration)/d(aileron) from the linear model at rest.  The evidence is scaled by
    (18 / U)^2, so the margin is the same at every airspeed if B grows as U^2 (checked at 12 m/s).
    """
    from rig_env.linear import linearize, trim
    from rig_env.params import RigParams

    p = RigParams.default()
    fs = p.friction.rig_roll.Fs
    assert 0.058 <= fs <= 0.061  # docs/PARAMETERS.md: Coulomb 0.058-0.060 N m, breakaway / Coulomb 1.01
    for u in (18.0, 12.0):
        b = float(linearize(p, trim(p, free_dofs=("rig_roll",), airspeed=u)).B[1, 0])  # rad/s^2 per rad of comp_aileron
        held = 2.0 * fs / 0.14 / b  # rad
        need = SPAN * (U_REF / u) ** 2
        print(f"{u} m/s: B = {b:.2f} rad/s^2/rad; friction holds {math.degrees(held):.2f} deg; the watchdog asks {math.degrees(need):.2f} deg")
        assert need > 2.5 * held

"""Deployment: protocol, artefact, numpy runtime, and the real-time loop flying the simulated rig.

Every network test runs over loopback (127.0.0.1) with the sim rig in a subprocess
(``scripts/deploy.py sim-rig --port 0``) and the loop in a thread of the test; each run is bounded by
its ``duration`` and by timeouts.  Timing numbers are printed (``-s``), asserted only where the issue
states a bound (deadline misses under 1 % at 80 Hz).
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

from controllers.laws.base import LAWS, LoopSpec, register
from controllers.laws import artefact as A
from controllers.deploy import protocol as pr
from controllers.deploy.framelog import read_log
from controllers.laws.linear import LinearLaw
from controllers.deploy.loop import ACTIVE, F_STUCK, FAULT, LoopConfig, RigLoop
from controllers.deploy.simrig import fly_offline

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = str(ROOT / "scripts" / "deploy.py")
TASK = "velocity_vector_roll"
ENV = dict(os.environ, PYTHONPATH=str(ROOT))


# ---------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def law_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("law") / "law.json"
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", "linear", "--task", TASK, "--out", str(out)],
                       env=ENV, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return out


def _spec() -> LoopSpec:
    from rig_env.envs import RigVectorEnv

    return LoopSpec.from_env(RigVectorEnv(1, task=TASK))


def _rechecksum(doc: dict) -> dict:
    body = {k: doc[k] for k in A._BODY_KEYS}
    doc["sha256"] = hashlib.sha256(A.canonical(body)).hexdigest()
    return doc


class SimRigProcess:
    """``scripts/deploy.py sim-rig`` in a subprocess on an ephemeral loopback port."""

    def __init__(self, tmp: Path, duration: float, *args: str, rate: float = 80.0) -> None:
        self.record, self.summary_path = tmp / "rig.npz", tmp / "rig.json"
        cmd = [sys.executable, SCRIPT, "sim-rig", "--port", "0", "--task", TASK, "--rate", str(rate), "--duration", str(duration),
               "--record", str(self.record), "--summary", str(self.summary_path), *args]
        self.p = subprocess.Popen(cmd, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self.p.stdout.readline()
        if not line:
            raise RuntimeError(f"sim rig did not start: {self.p.stderr.read()}")
        self.port = json.loads(line)["listening"][1]

    def finish(self, timeout: float = 30.0) -> dict:
        self.p.wait(timeout=timeout)
        self.p.stdout.close()
        self.p.stderr.close()
        return json.loads(self.summary_path.read_text())

    def kill(self) -> None:
        if self.p.poll() is None:
            self.p.kill()
            self.p.wait(timeout=10)


def fly(tmp: Path, law_file: Path, duration: float, rig_args: tuple[str, ...] = (), rate: float = 80.0, during=None, realtime: bool = True, **loop_kw):
    """Run the sim rig and the loop for ``duration`` s; returns (loop summary, rig summary, rig record, log records).

    realtime: both sides under SCHED_FIFO when the privilege is there (as docs/DEPLOY.md recommends for the
    rig computer; the machine running the tests is shared), else normal scheduling (printed).
    """
    rig = SimRigProcess(tmp, duration, *rig_args, *(("--realtime",) if realtime else ()), rate=rate)
    try:
        art = A.load(law_file)
        log = tmp / "loop.log"
        cfg = LoopConfig(rig=("127.0.0.1", rig.port), rate_hz=rate, bind=("127.0.0.1", 0), duration=duration, arm=True, log_path=str(log),
                         realtime=realtime, **loop_kw)
        loop = RigLoop(art, cfg)
        loop.open()
        out: dict = {}
        th = threading.Thread(target=lambda: out.update(loop.run()), daemon=True)
        th.start()
        if during is not None:
            during(loop)
        th.join(timeout=duration + 30)
        assert not th.is_alive(), "loop did not stop by itself"
        rs = rig.finish()
    finally:
        rig.kill()
    with np.load(rig.record, allow_pickle=False) as z:
        rec = {k: z[k] for k in z.files}
    fifo = realtime and not any(e["event"] == "realtime_refused" for e in out["events"]) and "realtime_refused" not in rs["counts"]
    print(f"\nscheduling: {'SCHED_FIFO' if fifo else 'normal'}\nloop: {json.dumps({k: v for k, v in out.items() if k != 'events'})}\nrig: {json.dumps(rs)}")
    out["events"] = [e for e in out["events"] if e["event"] != "realtime_refused"]
    return out, rs, rec, read_log(log)[1]


# ---------------------------------------------------------------------- protocol
def test_protocol_round_trip_and_sequence_order():
    b = bytearray(pr.SENSOR_SIZE)
    ang, flaps = [0.1, -0.2, 0.3, -0.4, 12.5], [0.01, -0.02, 0.03, -0.04]
    pr.pack_sensor_into(b, 2**32 + 7, 1.2345, ang, flaps, 19.5, pr.STATUS_SIMULATED)
    seq, t, a, f, v, st, ack, session, reserved = pr.unpack_sensor(b)
    assert (seq, t, v, st, ack, session, reserved) == (7, 1.2345, 19.5, pr.STATUS_SIMULATED, pr.NO_ECHO, 0, 0)
    np.testing.assert_array_equal(a, np.float32(ang))  # float32 on the wire: exact to float32
    np.testing.assert_array_equal(f, np.float32(flaps))
    c = bytearray(pr.COMMAND_SIZE)
    pr.pack_command_into(c, 5, pr.NO_ECHO, [0.1, -0.2, 0.3], pr.MODE_SAFE)
    assert pr.unpack_command(c) == (5, pr.NO_ECHO, tuple(np.float32([0.1, -0.2, 0.3, 0, 0, 0]).tolist()), pr.MODE_SAFE, 0)
    assert pr.newer(0, 0xFFFFFFFF) and pr.newer(5, 4) and not pr.newer(4, 5) and not pr.newer(4, 4)


def test_protocol_rejects_every_single_bit_error_and_bad_fields():
    b = bytearray(pr.SENSOR_SIZE)
    pr.pack_sensor_into(b, 1, 0.5, [0.0] * 5, [0.0] * 4, 20.0)
    for i in range(pr.SENSOR_SIZE * 8):  # CRC-32 detects every single-bit error (and magic catches its own bytes)
        bad = bytearray(b)
        bad[i // 8] ^= 1 << (i % 8)
        with pytest.raises(pr.FrameError):
            pr.unpack_sensor(bad)
    with pytest.raises(pr.FrameError, match="length"):
        pr.unpack_sensor(b[:-1])
    n = pr.SENSOR_SIZE - 4  # the CRC covers everything before it
    v2 = bytearray(b)
    struct.pack_into("<H", v2, 4, 1)
    struct.pack_into("<I", v2, n, zlib.crc32(v2[:n]))
    with pytest.raises(pr.FrameError, match="version"):
        pr.unpack_sensor(v2)
    nan = bytearray(b)
    struct.pack_into("<f", nan, 20, float("nan"))
    struct.pack_into("<I", nan, n, zlib.crc32(nan[:n]))
    with pytest.raises(pr.FrameError, match="nonfinite"):
        pr.unpack_sensor(nan)
    c = bytearray(pr.COMMAND_SIZE)
    pr.pack_command_into(c, 1, 1, [0.0], 7)
    with pytest.raises(pr.FrameError, match="mode"):
        pr.unpack_command(c)


# ---------------------------------------------------------------------- the shared observation builder
@pytest.mark.parametrize("task", ["velocity_vector_roll", "bank_to_bank"])
def test_loop_reference_and_observation_are_the_envs(task):
    """task_for_seed draws the env's reference; observe() on the env's own sensors gives the env's observation."""
    from rig_env.envs import RigVectorEnv
    from rig_env.envs.observation import observe, task_for_seed

    env = RigVectorEnv(1, task=task)
    obs, _ = env.reset(seed=11)
    loop_task = task_for_seed(task, env.free_dofs, env.dt, env.episode_seconds, 11)
    t = np.linspace(0.0, env.episode_seconds, 97)
    for tk in t:
        np.testing.assert_array_equal(loop_task.reference(np.array([tk])), env.task.reference(np.array([tk])))
    for _ in range(5):
        obs, *_ = env.step(np.full((1, 3), 0.3))
        np.testing.assert_array_equal(observe(env.sensors, loop_task, env.t), obs)


# ---------------------------------------------------------------------- artefact and runtime
def test_artefact_round_trip_runtime_parity_and_signature(tmp_path):
    spec = _spec()
    rng = np.random.default_rng(1)
    law = LinearLaw(spec, 1, K=rng.normal(size=(spec.n_actions, spec.obs_dim)), obs0=rng.normal(size=spec.obs_dim) * 0.1,
                    u0=np.array([0.1, -0.1, 0.0]), rate_limit=np.array([5.0, 8.0, 3.0]))
    sensors = {"rate_filter_hz": 10.0, "link_delay_steps": 0, "quantise": True, "pot_bits": 12, "encoder_bits": 13}
    art = A.from_controller(law, sensors, source="test")
    key = b"0123456789abcdef-shared"
    A.save(art, tmp_path / "a.json", key=key)
    back = A.load(tmp_path / "a.json", key=key, require_signature=True)
    assert back.kind == "linear" and back.spec == spec and back.sensors == sensors
    run = back.controller()
    law.reset(), run.reset()
    obs = rng.uniform(-1.5, 1.5, size=(200, 1, spec.obs_dim)).astype(np.float32)
    a_mem = np.array([law.act(o) for o in obs])
    a_rt = np.array([run.act(o) for o in obs])
    assert np.max(np.abs(a_mem - a_rt)) <= 1e-5  # the parity bound (identical here: same numbers, same code)
    # independent check of the law's equation and its rate limit on the first steps
    v = np.clip(law.K @ (obs[0, 0].astype(np.float64) - law.obs0) + law.u0, -1, 1)
    np.testing.assert_allclose(a_rt[0, 0], np.clip(v, -law.rate_limit * spec.dt, law.rate_limit * spec.dt), atol=1e-12)
    assert np.all(np.abs(np.diff(a_rt[:, 0], axis=0)) <= law.rate_limit * spec.dt + 1e-12)
    with pytest.raises(A.ArtefactError, match="signature does not match"):
        A.load(tmp_path / "a.json", key=b"another-key-of-16-bytes")
    A.save(art, tmp_path / "u.json")
    with pytest.raises(A.ArtefactError, match="signature missing"):
        A.load(tmp_path / "u.json", key=key)


def test_linear_form_export_of_another_law(tmp_path):
    """A static law linear in its observation (an LQR) exports to kind "linear" through linear_form()."""
    from controllers.laws.base import Controller

    spec = _spec()
    K = np.random.default_rng(2).normal(size=(spec.n_actions, spec.obs_dim)) * 0.1
    obs0 = np.linspace(-0.2, 0.2, spec.obs_dim)

    class StaticGain(Controller):
        kind, artefact_kind = "static_gain_test", "linear"

        def reset(self, mask=None):
            pass

        def act(self, obs):
            return np.clip((self._check_obs(obs) - obs0) @ K.T, -1, 1)

        def linear_form(self):
            return {"K": K, "obs0": obs0, "rate_limit": np.full(spec.n_actions, 1e3)}

    law = StaticGain(spec)
    A.save(A.from_controller(law, {"rate_filter_hz": 10.0, "link_delay_steps": 0, "quantise": True, "pot_bits": 12, "encoder_bits": 13}), tmp_path / "s.json")
    run = A.load(tmp_path / "s.json").controller()
    run.reset()
    for o in np.random.default_rng(3).uniform(-0.5, 0.5, (20, 1, spec.obs_dim)):
        np.testing.assert_allclose(run.act(o), law.act(o), atol=1e-12)


def _tampered(law_file: Path, tmp: Path) -> dict[str, tuple[Path, str]]:
    doc = json.loads(law_file.read_text())
    out: dict[str, tuple[Path, str]] = {}

    def write(name: str, text: str, expect: str) -> None:
        p = tmp / f"{name}.json"
        p.write_text(text)
        out[name] = (p, expect)

    d = json.loads(law_file.read_text())
    raw = bytearray(base64.b64decode(d["arrays"]["K"]["data"]))
    raw[8 * 10 + 7] ^= 0x40  # one gain changed, checksum kept
    d["arrays"]["K"]["data"] = base64.b64encode(bytes(raw)).decode()
    write("tampered_gain", json.dumps(d), "checksum mismatch")
    d = json.loads(law_file.read_text())
    d["spec"]["dt"] = 0.004
    write("tampered_spec", json.dumps(d), "checksum mismatch")
    text = law_file.read_text()
    write("truncated", text[: len(text) // 2], "not a valid JSON")
    d = _rechecksum(dict(json.loads(law_file.read_text()), format_version=2))
    write("wrong_version", json.dumps(d), "format_version 2")
    d = json.loads(law_file.read_text())
    d["arrays"]["K"]["data"] = base64.b64encode(np.full(3 * 13, np.nan).tobytes()).decode()
    write("nan_gain", json.dumps(_rechecksum(d)), "non-finite")
    d = json.loads(law_file.read_text())
    d["arrays"]["K"]["shape"] = [13, 3]
    write("wrong_shape", json.dumps(_rechecksum(d)), "K: expected shape")
    d = json.loads(law_file.read_text())
    d["arrays"]["K"]["data"] = base64.b64encode(np.zeros(5).tobytes()).decode()
    write("short_array", json.dumps(_rechecksum(d)), "truncated")
    d = json.loads(law_file.read_text())
    d["arrays"]["K"]["dtype"] = "|O"
    write("object_dtype", json.dumps(_rechecksum(d)), "dtype")
    del doc
    return out


def test_tampered_truncated_wrong_version_refused(law_file, tmp_path):
    for name, (path, expect) in _tampered(law_file, tmp_path).items():
        with pytest.raises(A.ArtefactError, match=expect):
            A.load(path)
        print(name, "->", expect)


def test_scripts_exit_nonzero_on_refused_artefact(law_file, tmp_path):
    cases = _tampered(law_file, tmp_path)
    for name in ("tampered_gain", "truncated"):
        path, expect = cases[name]
        for cmd in (["verify", "--law", str(path)], ["run", "--law", str(path), "--rig", "udp://127.0.0.1:9", "--duration", "1"]):
            r = subprocess.run([sys.executable, SCRIPT, *cmd], env=ENV, capture_output=True, text=True, timeout=60)
            assert r.returncode == 2 and "artefact refused" in r.stderr and expect in r.stderr, (name, r.stderr)
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", "no_such_law", "--task", TASK, "--out", str(tmp_path / "x.json")],
                       env=ENV, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "not available" in r.stderr


def test_runtime_imports_no_torch_nor_sb3(law_file):
    """Loading and running a law never imports torch or stable-baselines3 (the other heavy modules are reported)."""
    code = ("import sys, json; from controllers.laws.artefact import load; import controllers.laws.linear; "
            f"law = load({str(law_file)!r}).controller(); import numpy as np; law.act(np.zeros((1, law.spec.obs_dim))); "
            "print(json.dumps(sorted({m.split('.')[0] for m in sys.modules} & {'torch', 'stable_baselines3', 'gymnasium', 'numba', 'rig_env', 'scipy'})))")
    r = subprocess.run([sys.executable, "-c", code], env=ENV, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    heavy = json.loads(r.stdout)
    print("heavy modules imported by the runtime:", heavy)
    assert not {"torch", "stable_baselines3"} & set(heavy)
    code = "import sys, controllers.deploy.loop; print(sorted({m.split('.')[0] for m in sys.modules} & {'torch', 'stable_baselines3'}))"
    r = subprocess.run([sys.executable, "-c", code], env=ENV, capture_output=True, text=True, timeout=120)
    assert r.stdout.strip() == "[]", r.stderr


# ---------------------------------------------------------------------- hardware in the loop
def _compare(rec: dict, offline: dict) -> tuple[float, float]:
    n = min(len(rec["q"]), len(offline["q"]))
    d = np.degrees(np.abs(rec["q"][:n] - offline["q"][:n]))
    return float(d[:, 0].max()), float(d.max())


def _hil(tmp_path, law_file, duration):
    loop, rig, rec, log = fly(tmp_path, law_file, duration)
    off = fly_offline(A.load(law_file), TASK, 80.0, duration, seed=0)
    roll, worst = _compare(rec, off)
    fr, fo = rig["final_info"], off["final_info"]
    print(f"HIL {duration} s: max |roll - offline| = {roll:.4f} deg, any joint {worst:.4f} deg; rms error {fr['rms_error']:.3f} vs {fo['rms_error']:.3f} deg; "
          f"missed frames {loop['counts']['missed']}, deadline misses {loop['deadline_misses']}/{loop['ticks']}; latency p50/p99/max "
          f"{loop['latency']['p50_ms']:.2f}/{loop['latency']['p99_ms']:.2f}/{loop['latency']['max_ms']:.2f} ms")
    assert loop["final_state"] == "ACTIVE" and not loop["faults"]
    # Tolerance: with every frame in time the two differ only by float32 on the wire (measured 0.0001-0.005 deg over 6 s);
    # a frame the loaded machine delivers late is bridged by extrapolation and perturbs the spin (measured up to
    # 0.65 deg for 2 bridged frames in 20 s, decaying: the loop is stable).  1.5 deg bounds that; the task metrics agree.
    assert roll < 1.5 and worst < 1.5
    assert abs(fr["rms_error"] - fo["rms_error"]) < 0.25
    assert fr["success"] == fo["success"] == 1.0
    assert loop["deadline_miss_fraction"] < 0.01
    assert np.all(log["state"][log["seq"] >= 0] == ACTIVE)


def test_hil_matches_offline_simulation_short(tmp_path, law_file):
    _hil(tmp_path, law_file, 6.0)


@pytest.mark.slow
def test_hil_matches_offline_simulation_20s(tmp_path, law_file):
    _hil(tmp_path, law_file, 20.0)


def test_output_limits_always_applied(tmp_path, law_file):
    loop, rig, rec, log = fly(tmp_path, law_file, 3.0)
    art = A.load(law_file)
    du = np.radians(art.limits["rate_deg_s"]) / 80.0
    cmd = log["command"][:, :3]
    assert np.all(np.abs(cmd) <= np.radians(art.limits["position_deg"]) + 1e-12)
    assert np.all(np.abs(np.diff(cmd, axis=0)) <= du + 1e-12)


def test_test_input_is_added_to_the_laws_command_from_arming(tmp_path, law_file):
    """A 3-2-1-1 on the Hawk elevator (a surface the roll law does not command): every command sent carries
    schedule(t) at the reference clock's step time (t = 0 at arming) beside the law's own output."""
    from controllers.deploy.loop import OutputLimits
    from rig_env.signals import InputSchedule, ThreeTwoOneOne

    sched = InputSchedule({"hawk_elevator": ThreeTwoOneOne(2.0, start_s=0.5)})  # 2.46 s long
    loop, rig, rec, log = fly(tmp_path, law_file, 3.0, test_input=sched)
    art, dt = A.load(law_file), 1 / 80
    on = log["mode"] == pr.MODE_ACTIVE
    assert loop["final_state"] == "ACTIVE" and on.sum() > 200
    t_in = np.round(log["obs_t"] / dt) * dt
    assert t_in[on][0] == 0.0  # armed at the first frame: the input's clock starts there
    expect = np.where(on, np.radians(sched.value("hawk_elevator", t_in)), 0.0)
    np.testing.assert_allclose(log["command"][:, 3], expect, rtol=0, atol=1e-12)  # within the limits: sent as scheduled
    assert log["command"][:, 3].max() == pytest.approx(np.radians(2.0)) and log["command"][:, 3].min() == pytest.approx(np.radians(-2.0))
    # the whole command is the output limits applied to the law's target plus the input, tick by tick
    lim = OutputLimits(art, dt, {3: (40.0, 350.0)})
    for i in range(len(log)):
        target = np.zeros(6)
        if on[i]:
            target[:3] = log["action"][i, :3] * np.radians(art.spec.action_scale_deg)
            target[3] = np.radians(sched.value("hawk_elevator", t_in[i]))
        np.testing.assert_array_equal(lim.apply(target), log["command"][i])
    ends = [e for e in loop["events"] if e["event"] == "test_input_end"]
    assert len(ends) == 1 and ends[0]["t_input"] == pytest.approx(sched.duration, abs=dt)


def test_run_refuses_a_bad_test_input_file(law_file, tmp_path):
    bad = tmp_path / "input.json"
    bad.write_text(json.dumps({"format": "rig_env.InputSchedule", "version": 1, "surfaces": {"hawk_elevator": [{"kind": "sawtooth"}]}}))
    for path, expect in ((bad, "unknown shape kind 'sawtooth'"), (tmp_path / "missing.json", "No such file")):
        r = subprocess.run([sys.executable, SCRIPT, "run", "--law", str(law_file), "--rig", "udp://127.0.0.1:9", "--duration", "1",
                            "--test-input", str(path)], env=ENV, capture_output=True, text=True, timeout=60)
        assert r.returncode == 2 and expect in r.stderr and "Traceback" not in r.stderr, r.stderr


# ---------------------------------------------------------------------- faults
def test_ten_percent_packet_loss_still_completes(tmp_path, law_file):
    loop, rig, rec, log = fly(tmp_path, law_file, 8.0, ("--loss", "0.1", "--cmd-loss", "0.1", "--fault-seed", "3"))
    off = fly_offline(A.load(law_file), TASK, 80.0, 8.0, seed=0)
    print(f"loss: dropped {rig['counts'].get('dropped')} of {rig['counts']['frames']} frames; rms {rig['final_info']['rms_error']:.3f} vs offline {off['final_info']['rms_error']:.3f}")
    assert rig["counts"]["dropped"] > 0.05 * rig["counts"]["frames"]
    assert loop["final_state"] == "ACTIVE" and not loop["faults"]
    assert rig["final_info"]["success"] == 1.0
    assert abs(rig["final_info"]["rms_error"] - off["final_info"]["rms_error"]) < 1.0
    # the command loss is visible to the loop: a dropped command leaves the next frame's ack behind (unless that frame
    # is lost too, 10 %), so about 0.9 of the rig's dropped commands show as unapplied frames; 0.7 leaves the binomial scatter
    assert loop["counts"]["unapplied"] >= 0.7 * rig["counts"]["cmd_dropped"] > 0


def test_blackout_safe_within_three_frames_and_latched_until_rearmed(tmp_path, law_file):
    t_blackout, t_rearm = 2.0, 3.5

    def rearm(loop):
        # re-arm on the rig's own clock, as an operator would after seeing frames come back: a wall-clock
        # sleep depended on how long the sim rig took to start (0.3 s on a quiet machine, about 0.9 s in
        # one CI run, which left only 34 frames before the re-arm)
        end = time.monotonic() + 20.0
        while not (loop.state == FAULT and loop.rig_time >= t_rearm) and time.monotonic() < end:
            time.sleep(0.002)
        loop.arm()

    loop, rig, rec, log = fly(tmp_path, law_file, 5.0, ("--blackout", str(t_blackout), "0.5"), during=rearm)
    last = np.flatnonzero((log["fresh"] == 1) & (log["rig_time"] < t_blackout))[-1]  # the last frame before the blackout
    after = log[last + 1 :]
    safe = np.flatnonzero(after["mode"] != pr.MODE_ACTIVE)[0]
    assert safe < 3, f"safe state {safe + 1} ticks after the last frame"  # within 3 frames
    assert np.all(after["command"][safe:][:1, 0] * log["command"][last, 0] >= 0)  # moving towards neutral, never past it
    resumed = np.flatnonzero((after["fresh"] == 1))[0]
    armed = np.flatnonzero(after["state"][resumed:] == ACTIVE)[0] + resumed
    between = after[resumed:armed]
    assert between.size > 40  # frames came back ~1 s before the re-arm ...
    assert np.all(between["state"] == FAULT) and np.all(between["mode"] == pr.MODE_SAFE)  # ... and it stayed safe
    assert np.all(np.abs(between["command"][-10:]) < 1e-12)  # the surfaces were driven to neutral
    # re-armed, the law flies as long as the rig sends frames.  After 1.8 s of neutral flaps the roll
    # reference is 70 deg ahead, and on some runs (it depends on the instant of the re-arm) the law's
    # catch-up drives a joint past its stop, the sim rig ends its episode and stops sending: the loop
    # must then fault stale again, which is checked too
    events = [e["event"] for e in loop["events"]]
    assert events[:3] == ["arm", "fault", "arm"] and loop["events"][1]["fault"] == "stale"
    last_frame = np.flatnonzero(after["fresh"] == 1)[-1]
    assert last_frame - armed > 10 and np.all(after["state"][armed : last_frame + 1] == ACTIVE)
    if rig["final_info"]["stop_exceeded"]:
        assert events == ["arm", "fault", "arm", "fault"] and loop["events"][3]["fault"] == "stale"
    else:
        assert events == ["arm", "fault", "arm"] and loop["final_state"] == "ACTIVE"


def test_short_gap_holds_safe_then_resumes_without_fault(tmp_path, law_file):
    loop, rig, rec, log = fly(tmp_path, law_file, 3.0, ("--blackout", "1.0", "0.05"))  # 4 frames lost
    assert rig["counts"]["blackout"] == 4
    gap = log[(log["rig_time"] > 0.9) & (log["rig_time"] < 1.2)]
    assert 3 <= gap["missed"].max() < 8  # past the hold bound, short of the latch bound
    assert np.all(gap["mode"][gap["missed"] >= 3] == pr.MODE_SAFE) and np.all(gap["state"] == ACTIVE)
    assert loop["final_state"] == "ACTIVE" and not loop["faults"] and log["mode"][-1] == pr.MODE_ACTIVE


def _repeats(fresh_log: np.ndarray, joint: int) -> np.ndarray:
    """For each fresh frame, how many frames in a row before it gave the same reading of ``joint`` (the detector's ``run``)."""
    a = fresh_log["angles"][:, joint]
    run = np.zeros(a.size, dtype=np.int64)
    for i in range(1, a.size):
        run[i] = run[i - 1] + 1 if a[i] == a[i - 1] else 0
    return run


def test_stuck_sensor_latches_fault_naming_the_joint(tmp_path, law_file):
    """rig_roll frozen by the sim rig at 2 s while the law spins the rig: FAULT stuck_sensor after 40 repeats, then SAFE."""
    t0, n = 2.0, LoopConfig.stuck_frames
    loop, rig, _rec, log = fly(tmp_path, law_file, 4.0, ("--stuck", "rig_roll", str(t0), "1.5"))
    assert rig["counts"]["stuck"] > 0
    faults = [e for e in loop["events"] if e["event"] == "fault"]
    assert [e["fault"] for e in faults] == ["stuck_sensor"] and faults[0]["detail"].startswith("rig_roll reading")
    assert loop["final_state"] == "FAULT" and loop["faults"] == ["stuck_sensor"]
    fresh = log[(log["fresh"] == 1) & (log["seq"] >= 0)]
    hit = int(np.flatnonzero(fresh["fault"] & F_STUCK)[0])
    assert _repeats(fresh, 0)[hit] == n  # the tick of the n-th repeat, not earlier, not later
    first_stuck = np.flatnonzero(fresh["rig_time"] >= t0)[0]
    print(f"stuck at {t0} s: FAULT at rig time {fresh['rig_time'][hit]:.4f} s, {hit - first_stuck} fresh frames after the first frozen one")
    assert t0 + (n - 2) / 80.0 <= fresh["rig_time"][hit] <= t0 + (n + 4) / 80.0  # within the bound (a late frame skipped adds one)
    assert np.all(fresh["state"][:hit] == ACTIVE)
    after = log[log["tick"] >= fresh["tick"][hit]]
    assert np.all(after["mode"] == pr.MODE_SAFE) and np.all(after["state"] == FAULT)


def test_stuck_watchdog_quiet_on_a_still_noise_free_rig(tmp_path):
    """A law commanding nothing on a rig without sensor noise: readings repeat far past the bound, no evidence of drive, no trip."""
    law = tmp_path / "zero.json"
    r = subprocess.run([sys.executable, SCRIPT, "export", "--controller", "linear", "--task", TASK, "--out", str(law), "--gains", "0", "0", "0"],
                       env=ENV, capture_output=True, text=True, timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    loop, _rig, _rec, log = fly(tmp_path, law, 4.0, ("--no-noise",))
    fresh = log[(log["fresh"] == 1) & (log["seq"] >= 0)]
    longest = [int(_repeats(fresh, j).max()) for j in range(5)]
    print(f"still rig, no noise: longest runs of repeated readings per joint {longest} frames")
    assert np.all(np.abs(log["command"]) == 0.0)
    assert max(longest[0], longest[3]) > 2 * LoopConfig.stuck_frames  # a free joint repeated: a pure flatline rule would trip
    assert loop["final_state"] == "ACTIVE" and not loop["faults"]


def test_corrupted_duplicated_reordered_and_foreign_frames_ignored_and_counted(tmp_path, law_file):
    n_foreign = 150

    def foreign(loop):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", 0))  # another loopback port: a valid frame from the wrong address
        b = bytearray(pr.SENSOR_SIZE)
        time.sleep(1.0)
        for i in range(n_foreign):
            pr.pack_sensor_into(b, 10**6 + i, 0.0, [3.0] * 5, [1.0] * 4, 99.0)  # out of range: would fault if accepted
            s.sendto(b, ("127.0.0.1", loop.port))
            time.sleep(0.01)
        s.close()

    args = ("--corrupt", "0.1", "--duplicate", "0.05", "--reorder", "0.05", "--fault-seed", "5")
    loop, rig, rec, log = fly(tmp_path, law_file, 8.0, args, during=foreign)
    c, rc = loop["counts"], rig["counts"]
    assert c["foreign"] == n_foreign
    assert c["corrupt"] == rc["sent_corrupt"] >= rc["corrupted"] > 0  # a duplicated corrupted frame arrives twice
    assert c["old"] == rc["sent_old"] > 0 and rc["duplicated"] > 0 and rc["reordered"] > 0
    assert loop["final_state"] == "ACTIVE" and not loop["faults"]
    assert rig["final_info"]["success"] == 1.0


@pytest.mark.parametrize("failure, fault", [("raise", "controller"), ("nan", "controller"), ("slow", "overrun")])
def test_controller_failure_faults_and_latches(tmp_path, law_file, failure, fault):
    class Failing(LinearLaw):
        artefact_kind = f"test_{failure}"
        calls = 0

        def act(self, obs):
            Failing.calls += 1
            if Failing.calls > 40:
                if failure == "raise":
                    raise RuntimeError("boom")
                if failure == "nan":
                    return np.full((1, self.spec.n_actions), np.nan)
                time.sleep(0.8 * self.spec.dt)  # longer than half a period: an overrun
            return super().act(obs)

    register(Failing.artefact_kind)(Failing)  # a registered law with its own artefact_kind is loadable (LinearLaw's to_data / from_data)
    try:
        base = A.load(law_file)
        A.save(A.from_controller(Failing(base.spec, 1, K=base.data["K"]), base.sensors, base.limits), tmp_path / "bad.json")
        Failing.calls = 0
        loop, rig, rec, log = fly(tmp_path, tmp_path / "bad.json", 2.0)
    finally:
        LAWS.pop(Failing.artefact_kind)  # no test law left for the comparison's kinds
    assert loop["final_state"] == "FAULT" and loop["faults"] == [fault]
    k = np.flatnonzero(log["state"] == FAULT)[0]
    last = 42 + (2 if failure == "slow" else 0)  # the overrun watchdog trips on the 3rd slow tick in a row (controllers/deploy/overrun.py)
    assert 40 <= k <= last and log["mode"][k] == pr.MODE_SAFE and np.all(log["state"][k:] == FAULT)
    assert np.all(np.abs(log["command"][-5:]) < 1e-12)  # surfaces back to neutral
    assert np.all(np.isfinite(log["command"]))


def test_log_survives_a_crash_losing_at_most_a_second(tmp_path, law_file):
    rig = SimRigProcess(tmp_path, 10.0)
    log = tmp_path / "crash.log"
    try:
        p = subprocess.Popen([sys.executable, SCRIPT, "run", "--law", str(law_file), "--rig", f"udp://127.0.0.1:{rig.port}", "--arm",
                              "--duration", "10", "--log", str(log), "--bind", "127.0.0.1"], env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        t_start = time.time()
        while not log.exists() and time.time() - t_start < 30:
            time.sleep(0.05)
        time.sleep(3.0)
        p.send_signal(signal.SIGKILL)  # a crash: no cleanup, no final flush
        t_kill = time.time()
        p.wait(timeout=10)
    finally:
        rig.kill()
    header, recs = read_log(log)
    assert header["format"] == "rig-loop-log" and recs.size > 0
    mtime = log.stat().st_mtime
    assert t_kill - mtime <= 1.0 + 0.2  # the last flush was less than a second before the crash
    assert np.all(np.diff(recs["tick"].astype(np.int64)) >= 1)
    assert recs["send"][-1] >= recs["send"][0]

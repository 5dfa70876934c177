"""The authenticated link (protocol v2), frame plausibility and the overrun rule (issue 24, items 3, 4, 7).

Most tests craft frames on loopback and hand them to a real :class:`RigLoop`'s socket (no rig, no
scheduling): each refusal class is counted exactly.  One flight against the sim rig (a subprocess,
loopback, 2.4 s) checks the rest end to end: with a link key on both sides the loop flies, a stray
sender (no key; and the key but another session) cannot fly the rig, a single 8 ms stall of the law
does not fault, and when the rig stops applying commands the loop latches FAULT ``command_ack``.
"""

from __future__ import annotations

import os
import select
import socket
import struct
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

from controllers.deploy import protocol as pr
from controllers.deploy.loop import ACTIVE, F_IMPLAUSIBLE, FAULT, LoopConfig, RigLoop
from controllers.deploy.overrun import OverrunWatchdog
from controllers.deploy.plausibility import JOINT_RATE_MAX, Plausibility
from controllers.laws import artefact as A
from controllers.laws.base import LAWS, register
from controllers.laws.linear import LinearLaw

TASK = "velocity_vector_roll"
KEY = bytes(range(32))
T = 1.0 / 80.0


@pytest.fixture(scope="module")
def artefact() -> A.Artefact:
    from controllers.design.linear import roll_tracking
    from controllers.laws.base import LoopSpec
    from rig_env.envs import RigVectorEnv

    env = RigVectorEnv(1, task=TASK)
    spec = LoopSpec.from_env(env)
    return A.from_controller(roll_tracking(spec), A.sensors_of(env.config), A.default_limits(spec))


class Bench:
    """A RigLoop on loopback and a socket posing as its rig: ``send`` frames, ``drain`` them into the loop."""

    def __init__(self, artefact: A.Artefact, key: bytes | None = KEY, **cfg) -> None:
        self.rig = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.rig.bind(("127.0.0.1", 0))
        self.loop = RigLoop(artefact, LoopConfig(rig=self.rig.getsockname(), rate_hz=80.0, bind=("127.0.0.1", 0), link_key=key, **cfg))
        self.loop.open()
        self.loop.t0 = time.perf_counter()
        self.buf = bytearray(pr.SENSOR_SIZE)

    def frame(self, seq: int, t: float | None = None, angles=(0.0, 0.0, 0.0, 0.05, 0.0), status: int = pr.STATUS_SIMULATED, reserved: int = 0,
              key: bytes | None = KEY, session: int | None = None) -> bytes:
        pr.pack_sensor_into(self.buf, seq, seq * T if t is None else t, angles, (0.0,) * 4, 20.0, status, pr.NO_ECHO,
                            self.loop.session if session is None else session, key, reserved)
        return bytes(self.buf)

    def send(self, *frames: bytes) -> bool:
        """Send the frames to the loop and let it read them; True if one was accepted as new."""
        for f in frames:
            self.rig.sendto(f, ("127.0.0.1", self.loop.port))
        select.select([self.loop.sock], [], [], 1.0)
        return self.loop._drain()

    def close(self) -> None:
        self.loop.sock.close()
        self.rig.close()


@pytest.fixture
def bench(artefact):
    b = Bench(artefact)
    yield b
    b.close()


# ---------------------------------------------------------------------- protocol and key file
def test_mac_refuses_wrong_key_missing_mac_and_any_changed_bit():
    b, c = bytearray(pr.SENSOR_SIZE), bytearray(pr.COMMAND_SIZE)
    pr.pack_sensor_into(b, 3, 0.5, [0.1] * 5, [0.0] * 4, 20.0, pr.STATUS_SIMULATED, 7, 99, KEY)
    pr.pack_command_into(c, 4, 3, [0.1, 0.2], pr.MODE_ACTIVE, 99, KEY)
    assert pr.unpack_sensor(b, KEY)[:2] == (3, 0.5) and pr.unpack_sensor(b, KEY).ack == 7
    assert pr.unpack_command(c, KEY).session == 99
    other = bytes(32)
    for frame, unpack in ((b, pr.unpack_sensor), (c, pr.unpack_command)):
        with pytest.raises(pr.FrameError, match="mac"):
            unpack(frame, other)  # another key
        with pytest.raises(pr.FrameError, match="mac"):
            unpack(frame)  # a keyed frame at a receiver without a key: the misconfiguration shows at once
        n = len(frame) - 4
        for i in range(n * 8):  # any bit changed by someone who can recompute the CRC, but has no key
            bad = bytearray(frame)
            bad[i // 8] ^= 1 << (i % 8)
            struct.pack_into("<I", bad, n, zlib.crc32(bad[:n]))
            with pytest.raises(pr.FrameError, match="mac|magic|version|mode|nonfinite"):
                unpack(bad, KEY)
    plain = bytearray(pr.COMMAND_SIZE)
    pr.pack_command_into(plain, 4, 3, [0.1], pr.MODE_ACTIVE, 99)
    assert bytes(plain[44:60]) == bytes(16) and pr.unpack_command(plain).seq == 4  # keyless: MAC field zero, interoperable
    with pytest.raises(pr.FrameError, match="mac"):
        pr.unpack_command(plain, KEY)  # a keyed rig refuses an unauthenticated command


def test_link_key_file_hex_or_raw_refused_when_short_missing_or_readable(tmp_path):
    hexf, raw, short, loose = tmp_path / "hex", tmp_path / "raw", tmp_path / "short", tmp_path / "loose"
    hexf.write_text(KEY.hex() + "\n")
    raw.write_bytes(b"\xff" + KEY)
    short.write_text("00" * 15)
    loose.write_text(KEY.hex())
    for p in (hexf, raw, short):
        os.chmod(p, 0o600)
    os.chmod(loose, 0o644)
    assert pr.read_link_key(hexf) == KEY and pr.read_link_key(raw) == b"\xff" + KEY
    with pytest.raises(ValueError, match="15 bytes of key, need at least 16"):
        pr.read_link_key(short)
    with pytest.raises(ValueError, match="readable by group or others.*chmod 600"):
        pr.read_link_key(loose)
    with pytest.raises(ValueError, match="cannot read"):
        pr.read_link_key(tmp_path / "absent")


# ---------------------------------------------------------------------- the loop's reception
def test_loop_refuses_wrong_mac_other_session_and_replays(bench):
    c = bench.loop.counts
    assert bench.send(bench.frame(5))
    assert not bench.send(bench.frame(6, key=bytes(32)), bench.frame(7, key=None)) and c["auth"] == 2
    assert not bench.send(bench.frame(8, session=bench.loop.session ^ 1)) and c["session"] == 1  # an earlier run's, or another client's
    assert not bench.send(bench.frame(5), bench.frame(4), bench.frame(5 - 2**20)) and c["old"] == 3  # replays: not newer than the last accepted
    assert bench.loop.seq == 5 and c["corrupt"] == 0
    assert bench.send(bench.frame(9)) and bench.loop.seq == 9  # the link goes on (gap 4: within 4 periods per step)


# each bad-frame class of the issue, sent after an accepted frame at seq 10 (rig time 0.125 s)
BAD = {
    "time backwards": ("time", dict(t=0.05)),
    "time 1e300": ("time", dict(t=1e300)),
    "time stalled": ("time", dict(t=10 * T)),
    "joint jump 9000 rad": ("joint_rate", dict(angles=(9000.0, 0.0, 0.0, 0.05, 0.0))),
    "unknown status bit": ("status", dict(status=pr.STATUS_SIMULATED | 0x80)),
    "reserved non-zero": ("reserved", dict(reserved=1)),
}


@pytest.mark.parametrize("case", list(BAD))
def test_each_implausible_frame_class_is_dropped_and_counted(bench, case):
    reason, kw = BAD[case]
    c = bench.loop.counts
    assert bench.send(bench.frame(10))
    assert not bench.send(bench.frame(11, **kw))
    assert c["implausible"] == c[f"implausible_{reason}"] == 1 and bench.loop.seq == 10 and bench.loop.rig_time == 10 * T
    assert bench.send(bench.frame(12))  # the next sane frame is taken (two periods after the reference)
    assert bench.loop.implausible_run == 0 and bench.loop.fault == 0


def test_joint_rate_bound_follows_the_elapsed_time():
    p = Plausibility(T)
    p.accept(0, 0.0, np.zeros(5))
    step = JOINT_RATE_MAX * T  # the bound after one period, less the 0.01 rad slack
    assert p.check(1, T, np.array([step, 0, 0, 0, 0]), 0, 0) is None
    assert p.check(1, T, np.array([0, 0, 0, 0, -(step + 0.02)]), 0, 0) == "joint_rate"
    assert p.check(3, 3 * T, np.array([2.9 * step, 0, 0, 0, 0]), 0, 0) is None  # two frames lost: three periods' worth
    assert p.check(3, 0.2 * 3 * T, np.zeros(5), 0, 0) == "time" and p.check(3, 4.1 * 3 * T, np.zeros(5), 0, 0) == "time"


def test_persistent_implausibility_latches_fault(bench):
    assert bench.send(bench.frame(1))
    assert not bench.send(bench.frame(2, reserved=1), bench.frame(3, reserved=1))  # two in a row: dropped, no latch yet
    bench.loop._sense(0, time.perf_counter())
    assert bench.loop.fault == 0
    assert not bench.send(bench.frame(4, status=0x100))  # the third in a row
    bench.loop._sense(1, time.perf_counter())
    assert bench.loop.state == FAULT and bench.loop.fault == F_IMPLAUSIBLE
    assert bench.loop.events[-1]["fault"] == "implausible" and "reserved 2, status 1" in bench.loop.events[-1]["detail"]


# ---------------------------------------------------------------------- the overrun rule
def test_overrun_rule_tolerates_one_preemption_and_catches_a_slow_law():
    budget = 0.5 * T
    w = OverrunWatchdog(budget)
    quiet = [0.0002] * 200
    assert all(w.update(x) is None for x in quiet[:100] + [0.008] + quiet[100:])  # one 8 ms preemption against 0.2 ms
    assert all(w.update(x) is None for x in [0.008, 0.008] + quiet)  # even one spanning two ticks
    w.reset()
    trips = [w.update(0.8 * T) for _ in range(3)]  # always slow: the 3rd tick trips
    assert trips[:2] == [None, None] and "3 consecutive" in trips[2]
    w.reset()
    alternating = [w.update(0.8 * T if i % 2 == 0 else 0.0002) for i in range(40)]
    first = next(i for i, r in enumerate(alternating) if r is not None)
    assert first == 16 and "9 of the last 100" in alternating[first]  # slow every other tick: its 9th slow tick
    rng = np.random.default_rng(0)
    w.reset()
    assert all(w.update(0.008 if rng.random() < 0.01 else 0.0002) is None for _ in range(20_000))  # 1 % random preemptions


# ---------------------------------------------------------------------- one flight on the sim rig
class SpikeOnce(LinearLaw):
    """The linear law, stalled once for 8 ms (0.64 period at 80 Hz: an OS preemption) at its 40th call."""

    artefact_kind = "test_spike_once"
    calls = 0

    def act(self, obs):
        SpikeOnce.calls += 1
        if SpikeOnce.calls == 40:
            time.sleep(0.008)
        return super().act(obs)


def test_keyed_flight_ignores_a_stray_sender_survives_a_spike_and_faults_when_commands_are_not_acknowledged(tmp_path, artefact):
    from test_deploy import fly

    key_file = tmp_path / "link.key"
    key_file.write_text(KEY.hex())
    os.chmod(key_file, 0o600)
    register(SpikeOnce.artefact_kind)(SpikeOnce)
    try:
        law = tmp_path / "spike.json"
        A.save(A.from_controller(SpikeOnce(artefact.spec, 1, K=artefact.data["K"]), artefact.sensors, artefact.limits), law)
        SpikeOnce.calls = 0
        sent = {"plain": 0, "keyed": 0}
        stray_deg = 34.0

        def stray(loop):  # a stray process flies the rig's port at 34 deg: without the key, and with it but its own session
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.bind(("127.0.0.1", 0))
            b = bytearray(pr.COMMAND_SIZE)
            for i in range(60):
                pr.pack_command_into(b, 10**6 + i, pr.NO_ECHO, [np.radians(stray_deg)] * 6, pr.MODE_ACTIVE, 1234)
                s.sendto(b, loop.rig)
                pr.pack_command_into(b, 10**6 + i, pr.NO_ECHO, [np.radians(stray_deg)] * 6, pr.MODE_ACTIVE, 1234, KEY)
                s.sendto(b, loop.rig)
                sent["plain"] += 1
                sent["keyed"] += 1
                time.sleep(0.02)
            s.close()

        loop, rig, rec, log = fly(tmp_path, law, 2.4, ("--link-key-file", str(key_file), "--cmd-blackout", "1.5", "5"), during=stray,
                                  link_key=KEY)
    finally:
        LAWS.pop(SpikeOnce.artefact_kind)
    c, rc = loop["counts"], rig["counts"]
    # authenticated link: the loop's own frames fly, nothing refused on its side
    assert c["auth"] == c["session"] == c["corrupt"] == 0 and c["fresh"] > 100
    # the stray's 120 commands: all ignored and counted, none applied.  Once the loop's hello made the session, the rig
    # ignores other addresses (cmd_foreign); one arriving before it is refused by its MAC (cmd_auth) or, keyed, because a
    # session starts only with a neutral command, never an ACTIVE one (cmd_foreign)
    assert sent == {"plain": 60, "keyed": 60} and rc.get("cmd_auth", 0) + rc["cmd_foreign"] == 120
    assert not np.any(np.isclose(rec["cmd"], np.radians(stray_deg), atol=1e-6))
    # the 8 ms stall at the 40th call: counted as an overrun, no fault
    assert SpikeOnce.calls >= 100 and c["overrun"] >= 1
    # commands dropped from rig time 1.5 s: acknowledged until then, FAULT command_ack within ack_frames (8) ticks + the link's 1-2
    assert loop["faults"] == ["command_ack"] and loop["final_state"] == "FAULT"
    k = np.flatnonzero(log["state"] == FAULT)[0]
    i0 = np.flatnonzero(log["seq"] >= 0)[0]
    assert np.all(log["state"][i0:k] == ACTIVE)
    assert 1.5 + 7 * T <= log["rig_time"][k] <= 1.5 + 11 * T, log["rig_time"][k]
    assert rc["cmd_blackout"] > 0 and c["unapplied"] >= 8  # the frames that showed the commands unapplied are counted


def test_cli_refuses_a_bad_link_key_file_with_exit_2(tmp_path, artefact, capsys):
    from controllers.deploy.cli import main

    law = tmp_path / "law.json"
    A.save(artefact, law)
    loose = tmp_path / "link.key"
    loose.write_text(KEY.hex())
    os.chmod(loose, 0o644)
    assert main(["run", "--law", str(law), "--rig", "udp://127.0.0.1:9", "--link-key-file", str(loose)]) == 2
    assert f"link key file {loose}: readable by group or others" in capsys.readouterr().err
    assert main(["sim-rig", "--port", "0", "--link-key-file", str(tmp_path / "absent.key")]) == 2
    assert "absent.key: cannot read" in capsys.readouterr().err


def test_keyless_rig_is_not_captured_by_a_stray_that_starts_flying_first(tmp_path, artefact):
    """The issue's incident without a key: a stray sends ACTIVE 34 deg commands before the loop starts; the rig waits for a hello."""
    from test_deploy import SimRigProcess

    law = tmp_path / "law.json"
    A.save(artefact, law)
    rig = SimRigProcess(tmp_path, 1.5)
    try:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", 0))
        b = bytearray(pr.COMMAND_SIZE)
        for i in range(20):
            pr.pack_command_into(b, i, pr.NO_ECHO, [np.radians(34.0)] * 6, pr.MODE_ACTIVE, 1234)
            s.sendto(b, ("127.0.0.1", rig.port))
        time.sleep(0.2)
        loop = RigLoop(A.load(law), LoopConfig(rig=("127.0.0.1", rig.port), rate_hz=80.0, bind=("127.0.0.1", 0), duration=1.5, arm=True))
        out = loop.run()
        for i in range(20, 40):  # and once the loop holds the session
            pr.pack_command_into(b, i, pr.NO_ECHO, [np.radians(34.0)] * 6, pr.MODE_ACTIVE, 1234)
            s.sendto(b, ("127.0.0.1", rig.port))
        s.close()
        rs = rig.finish()
    finally:
        rig.kill()
    with np.load(rig.record, allow_pickle=False) as z:
        cmd = z["cmd"]
    assert rs["counts"]["cmd_foreign"] >= 20 and out["counts"]["fresh"] > 80 and out["counts"]["session"] == 0
    assert out["final_state"] == "ACTIVE" and not out["faults"], out["faults"]
    assert not np.any(np.isclose(cmd, np.radians(34.0), atol=1e-6))

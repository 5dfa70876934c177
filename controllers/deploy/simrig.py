"""``SimRig``: the numba rig model in real time behind the rig protocol on UDP, with fault injection.

The model is :class:`rig_env.envs.RigVectorEnv` as a batch of one (the same physics, task, sensor
noise and converter quantisation as training; ``link_delay_steps = 0``: the network is the delay).
The rig waits (bounded) for its client's session: the first valid command frame in a neutral mode
(DISARMED, the loop's hello, or SAFE; authenticated when the rig has a link key) fixes the client's address and session id for
the run.  Commands from any other address or session, and with a key any command without the right MAC,
are counted and ignored (a sender that starts with an ACTIVE command never becomes the client); of the
session's commands only a seq newer than the last applied is taken (replays are counted as old).  Each
sensor frame carries the client's session id and ``ack``, the seq of the newest command applied before
it.  Then, on absolute deadlines ``start + k / rate``:

    tick 0:  send sensor frame 0 (the state after ``reset(seed)``)
    tick k:  read commands (newest seq wins), step the physics one control step with it,
             send sensor frame k (the state after the step)

so a command answering frame ``k - 1`` that arrives before tick ``k`` acts exactly like an action in
``env.step`` (same-step semantics, :func:`fly_offline` reproduces it).  No valid command for
``cmd_timeout`` s: the rig drives the flaps to neutral by itself (its on-board watchdog).

| fault (``Faults``) | meaning |
|---|---|
| loss | probability a sensor frame is dropped |
| cmd_loss | probability a received command is dropped |
| delay | s added to every sensor frame |
| duplicate | probability a frame is sent twice |
| reorder | probability a frame is held back and sent after the next one |
| corrupt | probability one byte of a frame is flipped |
| blackout | (t0, duration) s of rig time: no sensor frames at all |
| cmd_blackout | (t0, duration) s of rig time: every command of the session dropped (none applied nor acknowledged) |
| stuck | (joint, t0, duration): that joint's angle frozen in the frames |

Fault draws come from ``numpy.random.default_rng(faults.seed)`` (reproducible).  The run ends after
``duration`` s (the env's episode length, so the env's own metrics and success are in the summary).
"""

from __future__ import annotations

import collections
import math
import os
import select
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.deploy import protocol as pr
from controllers.deploy.loop import MAX_SEED
from rig_env.envs.vector_env import ACTION_SCALE_DEG, RigVectorEnv
from rig_env.params import JOINTS


@dataclass(frozen=True)
class Faults:
    """Fault injection settings (see the module table); probabilities in [0, 1]."""

    loss: float = 0.0
    cmd_loss: float = 0.0
    delay: float = 0.0
    duplicate: float = 0.0
    reorder: float = 0.0
    corrupt: float = 0.0
    blackout: tuple[float, float] | None = None
    cmd_blackout: tuple[float, float] | None = None
    stuck: tuple[str, float, float] | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        for k in ("loss", "cmd_loss", "duplicate", "reorder", "corrupt"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and 0.0 <= v <= 1.0):
                raise ValueError(f"{k} = {v!r}: allowed range [0, 1]")
        if not (math.isfinite(self.delay) and 0.0 <= self.delay <= 1.0):
            raise ValueError(f"delay = {self.delay!r} s: allowed range [0, 1] s")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or not 0 <= self.seed <= MAX_SEED:
            raise ValueError(f"fault seed = {self.seed!r}: an integer in [0, {MAX_SEED}]")
        for k in ("blackout", "cmd_blackout"):
            v = getattr(self, k)
            if v is not None and not (v[0] >= 0 and v[1] > 0):
                raise ValueError(f"{k} = {v!r}: need (t0 >= 0, duration > 0) s")
        if self.stuck is not None:
            if self.stuck[0] not in JOINTS:
                raise ValueError(f"stuck joint {self.stuck[0]!r}: valid names {list(JOINTS)}")
            if not (self.stuck[1] >= 0 and self.stuck[2] > 0):
                raise ValueError(f"stuck = {self.stuck!r}: need (joint, t0 >= 0, duration > 0 s)")


def make_env(task: str, rate_hz: float, duration: float, **fields: Any) -> RigVectorEnv:
    """The rig model: a batch of one, episode = the run, no link delay unless ``fields`` (RigEnvConfig overrides) say so."""
    return RigVectorEnv(1, **dict({"task": task, "control_rate": rate_hz, "link_delay_steps": 0, "episode_seconds": duration}, **fields))


def frame_values(env: RigVectorEnv) -> tuple[np.ndarray, np.ndarray, float]:
    """(angles (5,) rad with the measured free joints and the true locked ones, flaps (4,) rad, airspeed m/s)."""
    ang = env.joint_angles[0]
    ang[env.free_idx] = env.sensors.angles[0]
    return ang, env.sensors.flaps[0].copy(), float(env.sensors.airspeed[0])


class SimRig:
    """The simulated rig server; :meth:`run` serves one client for ``duration`` s and returns a summary."""

    def __init__(self, port: int, task: str, rate_hz: float = 80.0, duration: float = 20.0, seed: int = 0, faults: Faults = Faults(),
                 host: str = "127.0.0.1", cmd_timeout: float = 0.25, wait_timeout: float = 30.0, realtime: bool = False,
                 link_key: bytes | None = None, **fields: Any) -> None:
        if not (math.isfinite(duration) and duration > 0):
            raise ValueError(f"duration = {duration}: must be > 0 s")
        if link_key is not None and len(link_key) < pr.KEY_MIN_BYTES:
            raise ValueError(f"link_key: at least {pr.KEY_MIN_BYTES} bytes")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
            raise ValueError(f"seed = {seed!r}: an integer in [0, {MAX_SEED}]")
        self.key = link_key
        self.sock = pr.bind_udp(host, port)  # first: a refused address costs no model build (BindError: host or port)
        try:
            self.env = make_env(task, rate_hz, duration, **fields)
            warm = make_env(task, rate_hz, duration, **fields)  # a separate env: load the numba cache (or compile) outside the run
            warm.reset(seed=seed)
            warm.step(np.zeros((1, len(warm.action_names))))
        except BaseException:
            self.sock.close()
            raise
        self.seed, self.faults, self.cmd_timeout, self.wait_timeout, self.realtime = seed, faults, cmd_timeout, wait_timeout, realtime
        self.period = self.env.dt
        self.n_steps = self.env.max_steps
        self.port = self.sock.getsockname()[1]
        self.rng = np.random.default_rng(faults.seed)
        self.stop_flag = False
        self.counts = collections.Counter()

    def stop(self) -> None:
        self.stop_flag = True

    def run(self) -> dict[str, Any]:
        env, n_a = self.env, len(self.env.action_names)
        if self.realtime:
            try:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(50))
            except (AttributeError, PermissionError, OSError):
                self.counts["realtime_refused"] += 1
        env.reset(seed=self.seed)
        n = self.n_steps
        rec = {"t": np.zeros(n + 1), "q": np.zeros((n + 1, 5)), "qd": np.zeros((n + 1, 5)), "cmd": np.zeros((n + 1, 6)), "mode": np.zeros(n + 1, np.int8)}
        self.client, self.session, self.cmd_seq, self.cmd, self.mode = None, 0, -1, np.zeros(6), pr.MODE_DISARMED
        self.rig_time = 0.0
        self.applied = pr.NO_ECHO  # seq of the newest command applied (the frames' ack)
        self.queue: collections.deque = collections.deque()
        self.held: tuple[bytes, int, bool] | None = None
        self.sent_seq = -1
        self.txbuf, self.rxbuf = bytearray(pr.SENSOR_SIZE), bytearray(2048)
        end = time.perf_counter() + self.wait_timeout
        while self.client is None and time.perf_counter() < end and not self.stop_flag:
            select.select([self.sock], [], [], 0.05)
            self._read_commands(time.perf_counter())
        if self.client is None:
            self.sock.close()
            return {"error": "no client", "counts": dict(self.counts)}
        start = time.perf_counter()
        self.last_cmd = start
        lateness = np.zeros(n + 1)
        final: dict[str, Any] = {}
        self.applied = self.cmd_seq if self.cmd_seq >= 0 else pr.NO_ECHO  # the hello: neutral, applied
        self._record(rec, 0)
        self._emit(0, 0.0, start)
        k = 0
        try:
            while k < n and not self.stop_flag:
                k += 1
                deadline = start + k * self.period
                while True:  # sleep, flushing delayed frames on time
                    now = time.perf_counter()
                    self._flush_queue(now)
                    nxt = min(deadline, self.queue[0][0]) if self.queue else deadline
                    if now >= deadline:
                        break
                    time.sleep(max(0.0, min(nxt - now, 0.002)))
                now = time.perf_counter()
                lateness[k] = now - deadline
                self.rig_time = (k - 1) * self.period  # the commands read now answer frame k - 1
                self._read_commands(now)
                if now - self.last_cmd > self.cmd_timeout:
                    self.cmd[:] = 0.0
                    self.counts["cmd_timeout_ticks"] += 1
                a = np.clip(self.cmd[:n_a] / math.radians(ACTION_SCALE_DEG), -1.0, 1.0)[None]
                self.applied = self.cmd_seq if self.cmd_seq >= 0 else pr.NO_ECHO  # the newest command read (after a timeout: still the last)
                self._record_cmd(rec, k - 1, a)
                _, _, term, trunc, info = env.step(a)
                if term[0] or trunc[0]:
                    fi = info["final_info"]
                    final = {key: float(v[0]) for key, v in fi.items() if not key.startswith("_")}
                    break  # the env has reset: frames 0..k-1 were sent, the last state is not kept
                self._record(rec, k)
                self._emit(k, k * self.period, now)
            t_end = time.perf_counter() + self.faults.delay + 0.01
            while self.queue and time.perf_counter() < t_end:
                self._flush_queue(time.perf_counter())
        finally:
            self.sock.close()
        frames = k if final else k + 1
        self.rec = {key: v[:frames] for key, v in rec.items()}  # frames 0..frames-1 and the commands that followed them
        lat = lateness[1 : k + 1]
        return {"steps": k, "frames": frames, "rate_hz": 1.0 / self.period, "final_info": final, "counts": dict(self.counts),
                "tick_lateness_ms": {"p50": float(np.percentile(lat, 50) * 1e3) if lat.size else 0.0,
                                     "p99": float(np.percentile(lat, 99) * 1e3) if lat.size else 0.0,
                                     "max": float(lat.max() * 1e3) if lat.size else 0.0}}

    def save_record(self, path: str, overwrite: bool = False) -> None:
        """Write the state / command record (``t`` s, ``q``/``qd`` (N, 5) rad, rad/s, ``cmd`` (N, 6) rad) as .npz to
        exactly ``path`` (``np.savez`` would add ``.npz`` to another name); an existing file only with ``overwrite``."""
        with open(path, "wb" if overwrite else "xb") as f:
            np.savez(f, **self.rec)

    # ------------------------------------------------------------------ internals
    def _record(self, rec: dict[str, np.ndarray], k: int) -> None:
        rec["t"][k] = k * self.period
        rec["q"][k] = self.env.joint_angles[0]
        rec["qd"][k] = self.env.joint_rates[0]

    def _record_cmd(self, rec: dict[str, np.ndarray], k: int, a: np.ndarray) -> None:
        rec["cmd"][k, : a.shape[1]] = a[0] * math.radians(ACTION_SCALE_DEG)
        rec["mode"][k] = self.mode

    def _read_commands(self, now: float) -> None:
        for _ in range(64):
            try:
                nb, addr = self.sock.recvfrom_into(self.rxbuf)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                continue
            if self.client is not None and addr != self.client:
                self.counts["cmd_foreign"] += 1
                continue
            try:
                c = pr.unpack_command(memoryview(self.rxbuf)[:nb], self.key)
            except pr.FrameError as e:
                self.counts["cmd_auth" if e.reason == "mac" else "cmd_corrupt"] += 1
                continue
            if self.client is None:
                if c.mode == pr.MODE_ACTIVE or c.session == 0:  # a session starts with a neutral command (a hello), never a flying one
                    self.counts["cmd_foreign"] += 1
                    continue
                self.client, self.session = addr, c.session
            elif c.session != self.session:
                self.counts["cmd_foreign"] += 1
                continue
            f = self.faults
            if f.cmd_loss and self.rng.random() < f.cmd_loss:
                self.counts["cmd_dropped"] += 1
                continue
            if f.cmd_blackout is not None and f.cmd_blackout[0] <= self.rig_time < f.cmd_blackout[0] + f.cmd_blackout[1]:
                self.counts["cmd_blackout"] += 1
                continue
            self.counts["cmd_received"] += 1
            if self.cmd_seq >= 0 and not pr.newer(c.seq, self.cmd_seq):
                self.counts["cmd_old"] += 1
                continue
            self.cmd_seq, self.mode, self.last_cmd = c.seq, c.mode, now
            self.cmd[:] = c.surfaces

    def _emit(self, k: int, rig_time: float, now: float) -> None:
        f, rng = self.faults, self.rng
        if f.blackout is not None and f.blackout[0] <= rig_time < f.blackout[0] + f.blackout[1]:
            self.counts["blackout"] += 1
            return
        ang, flaps, air = frame_values(self.env)
        if f.stuck is not None:
            j, t0, dur = f.stuck
            ji = JOINTS.index(j)
            if t0 <= rig_time < t0 + dur:
                if not hasattr(self, "_stuck_value"):
                    self._stuck_value = ang[ji]
                ang[ji] = self._stuck_value
                self.counts["stuck"] += 1
        pr.pack_sensor_into(self.txbuf, k, rig_time, ang, flaps, air, pr.STATUS_SIMULATED, self.applied, self.session, self.key)
        self.counts["frames"] += 1
        if f.loss and rng.random() < f.loss:
            self.counts["dropped"] += 1
            return
        data = bytearray(self.txbuf)
        if f.corrupt and rng.random() < f.corrupt:
            data[int(rng.integers(pr.SENSOR_SIZE))] ^= 1 << int(rng.integers(8))
            self.counts["corrupted"] += 1
        bad = bool(f.corrupt) and bytes(data) != bytes(self.txbuf)
        out = [(bytes(data), k, bad)]
        if f.duplicate and rng.random() < f.duplicate:
            out.append(out[0])
            self.counts["duplicated"] += 1
        if self.held is not None:  # the held frame goes after this one: reordered
            out.append(self.held)
            self.held = None
        elif f.reorder and rng.random() < f.reorder:
            self.held, out = out[0], out[1:]
            self.counts["reordered"] += 1
        for d, seq, bad in out:
            self.queue.append((now + f.delay, d, seq, bad))
        self._flush_queue(time.perf_counter())

    def _flush_queue(self, now: float) -> None:
        while self.queue and self.queue[0][0] <= now:
            _, d, seq, bad = self.queue.popleft()
            # what a receiver must make of this datagram (loopback keeps the order): corrupt, old, or new
            if bad:
                self.counts["sent_corrupt"] += 1
            elif self.sent_seq >= 0 and not pr.newer(seq, self.sent_seq):
                self.counts["sent_old"] += 1
            else:
                self.sent_seq = seq
            try:
                self.sock.sendto(d, self.client)
            except OSError:
                self.counts["tx_error"] += 1


def fly_offline(artefact: Any, task: str, rate_hz: float, duration: float, seed: int = 0, **fields: Any) -> dict[str, Any]:
    """The same closed loop without a network: the sim rig's env, the artefact's runtime and the loop's output limits.

    Returns ``{"t", "q", "qd", "cmd"}`` arrays (as :meth:`SimRig.save_record`, frames 0..N-1) and ``final_info``.
    """
    from controllers.deploy.loop import OutputLimits

    env = make_env(task, rate_hz, duration, **fields)
    obs, _ = env.reset(seed=seed)
    law = artefact.controller()
    law.reset()
    lim = OutputLimits(artefact, env.dt)
    n, n_a = env.max_steps, len(env.action_names)
    out = {"t": np.zeros(n), "q": np.zeros((n, 5)), "qd": np.zeros((n, 5)), "cmd": np.zeros((n, 6))}
    final: dict[str, Any] = {}
    scale = math.radians(artefact.spec.action_scale_deg)
    for k in range(n):
        out["t"][k], out["q"][k], out["qd"][k] = k * env.dt, env.joint_angles[0], env.joint_rates[0]
        target = np.zeros(6)
        target[:n_a] = law.act(obs.astype(np.float64))[0] * scale
        cmd = lim.apply(target)
        out["cmd"][k] = cmd
        obs, _, term, trunc, info = env.step(np.clip(cmd[:n_a] / math.radians(ACTION_SCALE_DEG), -1.0, 1.0)[None])
        if term[0] or trunc[0]:
            final = {key: float(v[0]) for key, v in info["final_info"].items() if not key.startswith("_")}
            break
    return dict(out, final_info=final)

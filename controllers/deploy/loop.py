"""``RigLoop``: the fixed-rate real-time loop that flies a deployed law on the rig over UDP, with watchdogs.

Lifecycle (the state is in every log record and the command frame's ``mode``)::

    DISARMED --arm()--> ACTIVE --watchdog--> FAULT (latched) --arm()--> ACTIVE
        ^                  |                   |
        +----disarm()------+-------disarm()----+

DISARMED: telemetry only, neutral commands (mode 0).  ACTIVE: the law flies (mode 1).  FAULT:
neutral commands (mode 2) until ``arm()`` (``--arm`` arms at the first frame; SIGUSR1 arms, SIGUSR2
disarms in ``scripts/deploy.py run``).  ``arm()`` is refused while no fresh frame has arrived.

Scheduling: tick ``k`` has the absolute deadline ``start + k / rate`` (``time.perf_counter``; no relative
sleeps); ``start`` is the first sensor frame's arrival plus ``phase`` periods, so each tick finds the
rig's newest frame waiting.  The loop sleeps to ``deadline - spin_s`` and spins the rest.  Socket reads
are non-blocking (a tick reads what is queued, at most 64 datagrams); when no new frame is queued the
tick waits for one at most ``frame_wait`` periods (``select`` with a timeout), never longer.
If the loop wakes more than a period late, it skips to the current tick (skipped ticks are misses).

Per tick: read frames (others' addresses: ``n_foreign``; bad length / magic / version / CRC / non-finite:
``n_corrupt``; wrong MAC for the link key: ``auth``; another session: ``session``; not newer than the last:
``n_old``; implausible: ``implausible`` and ``implausible_<reason>``; fresh frames whose ``ack`` is not the
newest command sent: ``unapplied``), update :class:`rig_env.envs.sensors.Sensors`
(``noise=None``, ``quantise=False``, ``delay_steps=0``) and build the observation with
:func:`rig_env.envs.observation.observe` (the environments' own builder), call the law, apply the
output position and rate limits (always, in every state), send the command, log the record.  A missing
frame is bridged by extrapolating the angles with the estimated rates (``angle + rate dt``) for up to
``stale_frames - 1`` ticks.

Imports: numpy, the standard library, the deployed runtime (protocol, artefact, log, watchdogs, the
laws) and the observation builder (:mod:`rig_env.envs.observation`, which imports neither gymnasium nor
numba).  The sensors' and the task's kernels run in the process's :mod:`rig_env.physics.jit` mode:
``rig-deploy run`` runs it inside :func:`rig_env.physics.jit.python_mode`, so the rig process never
imports numba and gives the same observations bit for bit; a loop built inside a process that runs the
environments (the tests) uses their compiled kernels.

| watchdog | bound (default) | action |
|---|---|---|
| stale / missing frames | ``stale_frames`` (3) consecutive ticks without a new frame | neutral target at once, mode SAFE; resumes if frames return |
| stale / missing frames | ``fault_frames`` (8) consecutive ticks | FAULT (latched) |
| sensor range | non-finite (refused by the CRC/finite check); limited joints beyond +-90 deg, unlimited beyond +-1e4 rad, flaps beyond +-60 deg, airspeed outside [0, 45] m/s | FAULT |
| rig status | RIG_FAULT bit set | FAULT |
| controller | exception or non-finite output | FAULT |
| overrun | the law's ``act`` longer than ``overrun_s`` (half a period) on ``overrun_ticks`` (3) consecutive ticks, or on more than 8 of the last 100 (:mod:`controllers.deploy.overrun`) | FAULT |
| command acknowledgement | the rig's frames acknowledge none of the last ``ack_frames`` (8) commands sent (:meth:`RigLoop.ack_lag`) | FAULT ``command_ack`` while ACTIVE; arming refused |
| implausible frames | ``implausible_frames`` (3) consecutive frames refused by :mod:`controllers.deploy.plausibility` | FAULT ``implausible`` |
| stuck sensor (ACTIVE only) | a free joint's reading bit-identical for ``stuck_frames`` (32) consecutive fresh frames while a commanded surface moved by ``stuck_cmd_deg`` (2 deg at 18 m/s, scaled by (18 / U)^2) or more over them (:mod:`controllers.deploy.stuck`) | FAULT, naming the joint |

Why two stale bounds: a single 3-frame latch trips on random 10 % packet loss about once every
1000 ticks (0.1^3), i.e. ~1.4 times in 20 s at 80 Hz; a 3-frame neutral hold with an 8-frame latch
(0.1 s at 80 Hz; 0.1^8 per tick) keeps the safe state within 3 frames and the latch for real outages.
Setting ``fault_frames = stale_frames`` gives the strict single bound.

Why 32 frames for a stuck sensor: a still joint read through the default rig's converters (0.05 deg
noise, 1 sigma; 12-bit pots, lsb 0.088 deg; 13-bit encoders, 0.044 deg) repeats its code on a frame
with probability at most P(|z| < 0.044 / 0.05) = 0.62 (pot, true angle at a code's centre; 0.34 for
an encoder), so ``stuck_frames`` repeats happen by chance with probability at most 0.62^32 = 2.3e-7
per tick: once in 15 h of 80 Hz ticks (5 h at 244 Hz) for a pot held still at the worst angle while
the command moves (which the rig roll's friction cannot do at any airspeed: :mod:`controllers.deploy.stuck`);
0.34^32 = 1e-15 for an encoder.  The delay is 0.4 s at 80 Hz (0.13 s at 244 Hz): measured on the sim
rig, a rig_roll reading frozen during velocity_vector_roll's spin lets the demonstration law wind up
until the model pitch passes its stop 37 frames later (40 frames was too late).  The rule and why it
needs the command's movement: :mod:`controllers.deploy.stuck`.

Log failure (``F_LOG``, ``log_write``): the log's writer thread records a failed write
(:attr:`controllers.deploy.framelog.FrameLog.error`); the loop checks it after every tick, latches FAULT
and ends the run (``LoopConfig.allow_unlogged``: an event ``log_lost`` instead, and the flight goes on).
End of run: :meth:`RigLoop._wind_down` sends neutral targets through the output limits once per period
(mode SAFE) until every command is 0, then three DISARMED neutral commands; the summary's
``final_state`` is the last tick's state, ``end`` the state after the wind-down (DISARMED).

Output limits: ``command = prev + clip(clip(target, -pos, pos) - prev, -rate dt, rate dt)`` with the
artefact's ``limits`` (default +-40 deg and the servos' 350 deg/s): the safe target is commanded at
once and the surfaces reach neutral at the servos' own slew rate.

Test input (``LoopConfig.test_input``, a :class:`rig_env.signals.InputSchedule`; ``rig-deploy run
--test-input FILE.json``): while ACTIVE and the law's output is accepted, ``schedule(t)`` (deg -> rad) is
added to the law's target before the output limits, so the command sent (the log's ``command``) is the
law's output plus the test input.  t is the task reference's clock rounded to the control grid,
``round(obs_t / dt) dt`` (rig time since the arming frame, plus the frame's age ``link_delay_steps`` and
any bridged frames): t = 0 at arming (with the default ``link_delay_steps = 0``), the same step times
at which :func:`rig_env.simulate` and the environments evaluate a schedule, so the loop flies the same
samples.  Every arming restarts it; from ``t >= schedule.duration`` it adds nothing (event
``test_input_end``); SAFE, FAULT and DISARMED send neutral targets without it.  A surface the law does
not command but the test input drives is limited at the default rig's servo limits (+-40 deg,
350 deg/s); :meth:`rig_env.signals.InputSchedule.check` tells beforehand whether the limits will cut it.
"""

from __future__ import annotations

import gc
import math
import os
import secrets
import select
import socket
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controllers.deploy import protocol as pr
from controllers.laws.artefact import Artefact
from controllers.deploy.framelog import FrameLog
from controllers.deploy.overrun import OverrunWatchdog
from controllers.deploy.plausibility import REASONS as IMPLAUSIBLE_REASONS, Plausibility
from controllers.deploy.stuck import StuckDetector
from rig_env.envs.ranges import CONTROL_RATE_HZ, MAX_SEED
from rig_env.envs.observation import labels, observe, task_for_seed
from rig_env.envs.sensors import UNLIMITED, Sensors
from rig_env.params import JOINTS, SURFACES, RigParams, param_batch
from rig_env.signals import InputSchedule

DISARMED, ACTIVE, FAULT = 0, 1, 2
STATES = ("DISARMED", "ACTIVE", "FAULT")
F_STALE, F_SENSOR, F_RIG, F_CONTROLLER, F_OVERRUN, F_STUCK, F_LINK, F_IMPLAUSIBLE, F_LOG = 1, 2, 4, 8, 16, 32, 64, 128, 256
FAULTS = {F_STALE: "stale", F_SENSOR: "sensor_range", F_RIG: "rig_status", F_CONTROLLER: "controller", F_OVERRUN: "overrun",
          F_STUCK: "stuck_sensor", F_LINK: "command_ack", F_IMPLAUSIBLE: "implausible", F_LOG: "log_write"}
MAX_DURATION_S = 1.0e6
"""Longest ``duration`` accepted, s (11.6 days): a bound on the tick counter, not on memory (below)."""
STATS_CAP = 1 << 18
"""Per-tick timing statistics (latency, wake jitter, law time) keep the last ``STATS_CAP`` ticks (a ring of
3 x 2 MiB; 55 min at 80 Hz): memory stays bounded whatever the duration."""
WIND_DOWN_MAX_S = 1.0
"""Longest wind-down at the end of a run, s: neutral targets through the output limits until the commands are 0."""
LIMITED_MAX = math.radians(90.0)
UNLIMITED_MAX = 1.0e4
FLAP_MAX = math.radians(60.0)
AIRSPEED_RANGE = (0.0, 45.0)


@dataclass(frozen=True)
class LoopConfig:
    """Settings of :class:`RigLoop` (addresses are (host, port); ``duration`` None: until ``stop()``).

    rate_hz: loop rate, must equal the law's ``1 / spec.dt``.  seed: draws the task's reference as
    ``RigVectorEnv.reset(seed=seed)`` does, [0, :data:`MAX_SEED`].  episode_seconds: the task's horizon (None: the task's).
    phase: tick offset after the rig's frame, periods, [0, 0.9].  spin_s: busy-wait before a deadline, s.
    overrun_s: None = half a period.  frame_wait: when the tick finds no new frame, wait up to this many
    periods for it (select, bounded), [0, 0.5].  miss_fraction: a tick whose command leaves later than this many
    periods after its deadline is a deadline miss (None: ``1 - phase``, i.e. the command missed the rig's
    next tick and the rig applies the previous one).  realtime: run the loop thread under SCHED_FIFO
    (Linux; needs the privilege, else an event "realtime_refused" and normal scheduling).
    link_delay_steps: age of a frame when the loop gets it, control steps (the environments'
    ``link_delay_steps``): the task reference is taken at ``rig_time + link_delay_steps dt``, so with
    that delay on the link the law sees what it saw in ``RigVectorEnv(link_delay_steps=...)``, [0, 50].
    stuck_frames: repeats of a free joint's reading that, with the command moving, latch FAULT
    ``stuck_sensor`` (module docstring); None or 0 disables the watchdog, else an integer in [2, 1e6].
    stuck_cmd_deg: the command movement (deg, max - min of any surface over the repeats) that shows the
    rig is driven at 18 m/s (scaled by (18 / U)^2 at airspeed U), [0, 80] deg (0: any repeat run of
    ``stuck_frames`` trips, wind or not).
    test_input: surface test inputs added to the law's command from each arming (module docstring), or None.
    link_key: the shared link key (>= 16 bytes, :func:`controllers.deploy.protocol.read_link_key`): every frame
    carries its MAC and a frame without the right one is refused (``auth``); None: no key, MACs all zero.
    ack_frames: FAULT ``command_ack`` while ACTIVE (and arming refused) when the rig's frames acknowledge none
    of the last ``ack_frames`` commands sent, [1, 1000].  implausible_frames: consecutive implausible frames
    that latch FAULT ``implausible`` (:mod:`controllers.deploy.plausibility`), [1, 1000].  overrun_ticks:
    consecutive overruns of ``overrun_s`` that latch FAULT ``overrun`` (:mod:`controllers.deploy.overrun`), [1, 100].
    allow_unlogged: keep flying when the log cannot be written (event ``log_lost``); by default a log
    write failure latches FAULT ``log_write`` and ends the run (neutral commands, wind-down).
    """

    rig: tuple[str, int]
    rate_hz: float
    bind: tuple[str, int] = ("0.0.0.0", 0)
    duration: float | None = None
    arm: bool = False
    log_path: str | None = None
    seed: int = 0
    episode_seconds: float | None = None
    stale_frames: int = 3
    fault_frames: int = 8
    phase: float = 0.25
    spin_s: float = 0.001
    overrun_s: float | None = None
    miss_fraction: float | None = None
    frame_wait: float = 0.25
    realtime: bool = False
    link_delay_steps: int = 0
    connect_timeout: float = 5.0
    stuck_frames: int | None = 32
    stuck_cmd_deg: float = 2.0
    test_input: InputSchedule | None = None
    link_key: bytes | None = field(default=None, repr=False)
    ack_frames: int = 8
    implausible_frames: int = 3
    overrun_ticks: int = 3
    allow_unlogged: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_hz) and CONTROL_RATE_HZ[0] <= self.rate_hz <= CONTROL_RATE_HZ[1]):
            raise ValueError(f"rate_hz = {self.rate_hz}: allowed range [{CONTROL_RATE_HZ[0]:g}, {CONTROL_RATE_HZ[1]:g}] Hz")
        if self.duration is not None and not (isinstance(self.duration, (int, float)) and math.isfinite(self.duration) and 0 < self.duration <= MAX_DURATION_S):
            raise ValueError(f"duration = {self.duration}: allowed range (0, {MAX_DURATION_S:g}] s")
        if not (isinstance(self.stale_frames, int) and 1 <= self.stale_frames <= self.fault_frames <= 1000):
            raise ValueError(f"stale_frames = {self.stale_frames}, fault_frames = {self.fault_frames}: need 1 <= stale_frames <= fault_frames <= 1000")
        if not 0.0 <= self.phase <= 0.9:
            raise ValueError(f"phase = {self.phase}: allowed range [0, 0.9] periods")
        if not (isinstance(self.seed, (int, np.integer)) and not isinstance(self.seed, bool) and 0 <= self.seed <= MAX_SEED):
            raise ValueError(f"seed = {self.seed!r}: an integer in [0, {MAX_SEED}]")
        if not (isinstance(self.link_delay_steps, int) and 0 <= self.link_delay_steps <= 50):
            raise ValueError(f"link_delay_steps = {self.link_delay_steps!r}: an integer in [0, 50]")
        if not 0.0 <= self.frame_wait <= 0.5:
            raise ValueError(f"frame_wait = {self.frame_wait}: allowed range [0, 0.5] periods")
        if self.miss_fraction is not None and not 0.0 < self.miss_fraction <= 1.0:
            raise ValueError(f"miss_fraction = {self.miss_fraction}: allowed range (0, 1]")
        sf = self.stuck_frames
        if sf is not None and not (isinstance(sf, int) and not isinstance(sf, bool) and (sf == 0 or 2 <= sf <= 1_000_000)):
            raise ValueError(f"stuck_frames = {sf!r}: None or 0 (disabled), else an integer in [2, 1000000] frames")
        if not (isinstance(self.stuck_cmd_deg, (int, float)) and math.isfinite(self.stuck_cmd_deg) and 0.0 <= self.stuck_cmd_deg <= 80.0):
            raise ValueError(f"stuck_cmd_deg = {self.stuck_cmd_deg!r}: allowed range [0, 80] deg")
        if self.test_input is not None and not isinstance(self.test_input, InputSchedule):
            raise ValueError(f"test_input = {self.test_input!r}: must be a rig_env.signals.InputSchedule or None")
        if self.link_key is not None and not (isinstance(self.link_key, bytes) and len(self.link_key) >= pr.KEY_MIN_BYTES):
            raise ValueError(f"link_key: bytes of length >= {pr.KEY_MIN_BYTES} or None")
        for name, hi in (("ack_frames", 1000), ("implausible_frames", 1000), ("overrun_ticks", 100)):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= hi):
                raise ValueError(f"{name} = {v!r}: an integer in [1, {hi}]")


class OutputLimits:
    """Position and rate limits of the surface commands (rad), applied in every state of the loop.

    ``apply(target)``: ``cmd = cmd + clip(clip(target, -pos, pos) - cmd, -rate dt, rate dt)``; target
    (6,) rad; returns the (6,) command (a view of the internal state: copy to keep it).  The law's
    surfaces take the artefact's limits; ``more`` gives others {surface index: (position deg, rate
    deg/s)} (a test input's); the rest stay at 0.
    """

    def __init__(self, artefact: Artefact, dt: float, more: dict[int, tuple[float, float]] | None = None) -> None:
        na = artefact.spec.n_actions
        self.pos, self.du, self.cmd = np.zeros(pr.N_SURFACES), np.zeros(pr.N_SURFACES), np.zeros(pr.N_SURFACES)
        self.pos[:na] = np.radians(artefact.limits["position_deg"])
        self.du[:na] = np.radians(artefact.limits["rate_deg_s"]) * dt
        for j, (pos_deg, rate_deg_s) in (more or {}).items():
            if j >= na:
                self.pos[j], self.du[j] = math.radians(pos_deg), math.radians(rate_deg_s) * dt
        self._t = np.zeros(pr.N_SURFACES)

    def apply(self, target: np.ndarray) -> np.ndarray:
        np.clip(target, -self.pos, self.pos, out=self._t)
        self.cmd += np.clip(self._t - self.cmd, -self.du, self.du)
        return self.cmd


class RigLoop:
    """Fly ``artefact`` on the rig at ``config.rig``; :meth:`run` returns the summary dict (see ``summary``)."""

    def __init__(self, artefact: Artefact, config: LoopConfig) -> None:
        spec, cfg = artefact.spec, config
        if abs(cfg.rate_hz * spec.dt - 1.0) > 1e-6:
            raise ValueError(f"rate = {cfg.rate_hz} Hz: the law was designed for {1.0 / spec.dt:g} Hz (spec.dt = {spec.dt} s)")
        self.art, self.cfg, self.spec = artefact, cfg, spec
        self.period = 1.0 / cfg.rate_hz
        self.law = artefact.controller()
        self.sensors = Sensors(1, spec.free_dofs, spec.dt, rate_filter_hz=float(artefact.sensors["rate_filter_hz"]), delay_steps=0, quantise=False)
        ep = self._ep = cfg.episode_seconds or 600.0
        params = RigParams.default()
        self._params_row = param_batch(params, 1)  # loaded once: arming must not wait 13 ms for it
        self.task = task_for_seed(spec.task, spec.free_dofs, spec.dt, ep, cfg.seed, airspeed=float(np.mean(spec.airspeed_range)),
                                  options=dict(spec.task_options), params_row=self._params_row)
        built = labels(self.sensors, self.task)
        if built != spec.obs_labels:
            raise ValueError(f"observation layout: the law expects {list(spec.obs_labels)}, this loop builds {list(built)}")
        self.free = np.array([JOINTS.index(j) for j in spec.free_dofs])
        self.lim_max = np.array([UNLIMITED_MAX if j in UNLIMITED else LIMITED_MAX for j in JOINTS])
        self.scale = math.radians(spec.action_scale_deg)
        # the test input: its surfaces' columns in the command, their limits where the law has none (the servos')
        self.test = cfg.test_input
        self._test_cols = [] if self.test is None else [(SURFACES.index(s), s) for s in self.test.surfaces]
        self._test_end = 0.0 if self.test is None else self.test.duration
        self._test_over = True
        servos = {j: params.servos.compensator if s.startswith("comp_") else params.servos.hawk for j, s in self._test_cols}
        more = {j: (sv.limit_deg, sv.rate_limit_deg_s) for j, sv in servos.items()}
        self.limits = OutputLimits(artefact, self.period, more)
        self.stuck = StuckDetector(spec.free_dofs, cfg.stuck_frames, math.radians(cfg.stuck_cmd_deg), pr.N_SURFACES)
        self.overrun_s = cfg.overrun_s if cfg.overrun_s is not None else 0.5 * self.period
        self.overrun = OverrunWatchdog(self.overrun_s, cfg.overrun_ticks)
        # the link: this run's session id (non-zero), the key, the frame plausibility checks, the newest acknowledged command
        self.session, self.key = secrets.randbits(32) or 1, cfg.link_key
        self.plaus = Plausibility(self.period)
        self.implausible_run, self.acked = 0, -1
        self.miss_s = (cfg.miss_fraction if cfg.miss_fraction is not None else 1.0 - cfg.phase) * self.period
        self.rig = (socket.gethostbyname(cfg.rig[0]), int(cfg.rig[1]))
        # preallocated per-tick buffers
        self.rx, self.tx = bytearray(2048), bytearray(pr.COMMAND_SIZE)
        self.angles, self.flaps = np.zeros(5), np.zeros(4)
        self.airspeed, self.rig_time, self.status = 0.0, 0.0, 0
        self.action, self.target = np.zeros(pr.N_SURFACES), np.zeros(pr.N_SURFACES)
        self.t_arr = np.zeros(1)
        self.q5, self.qd5 = np.zeros(5), np.zeros(5)
        # lifecycle and counters
        self.state, self.fault, self.missed = DISARMED, 0, 0
        self.seq, self.cmd_seq, self.have_frame, self.t_origin, self._first = -1, 0, False, 0.0, False
        self._arm_req, self._disarm_req, self._stop = False, False, False
        self.counts = {k: 0 for k in ("fresh", "missed", "foreign", "corrupt", "old", "resync", "tx_error", "arm_refused", "deadline_miss", "skipped",
                                      "auth", "session", "implausible", *(f"implausible_{r}" for r in IMPLAUSIBLE_REASONS), "overrun", "unapplied")}
        self.corrupt_reasons: dict[str, int] = {}
        self.events: list[dict[str, Any]] = []
        self.sock: socket.socket | None = None
        self.port = 0
        self.log_error: str | None = None
        self.flight_state: int | None = None  # the state on the last tick flown, set when run() ends
        self.wind_down_ticks = 0

    # ------------------------------------------------------------------ operator
    def arm(self) -> None:
        """Request ACTIVE at the next tick (clears a latched fault); refused without a fresh frame."""
        self._arm_req = True

    def disarm(self) -> None:
        self._disarm_req = True

    def stop(self) -> None:
        self._stop = True

    def open(self) -> int:
        """Bind the socket (before :meth:`run` when the caller needs the port); returns the local port.

        Raises :class:`controllers.deploy.protocol.BindError` (an OSError saying whether the host or the port
        of ``config.bind`` was refused)."""
        if self.sock is None:
            self.sock = pr.bind_udp(*self.cfg.bind)
            self.port = self.sock.getsockname()[1]
        return self.port

    # ------------------------------------------------------------------ run
    def run(self) -> dict[str, Any]:
        """Fly until ``duration`` or :meth:`stop`, then wind down to neutral and disarm; returns :meth:`summary`.

        Raises :class:`controllers.deploy.protocol.BindError` (the socket cannot be bound: no log is created),
        :class:`controllers.deploy.framelog.LogPathError` (an existing log path) or OSError (the log cannot be
        created) before any frame is sent."""
        cfg = self.cfg
        if cfg.realtime:
            try:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(50))
            except (AttributeError, PermissionError, OSError) as e:
                self.events.append({"tick": 0, "event": "realtime_refused", "detail": str(e)})
        header = {"artefact_sha256": self.art.sha256, "kind": self.art.kind, "task": self.spec.task, "rate_hz": cfg.rate_hz,
                  "free_dofs": list(self.spec.free_dofs),
                  "rig": list(self.rig), "seed": cfg.seed, "stale_frames": cfg.stale_frames, "fault_frames": cfg.fault_frames,
                  "stuck_frames": cfg.stuck_frames, "stuck_cmd_deg": cfg.stuck_cmd_deg,
                  "link": {"keyed": self.key is not None, "session": self.session, "ack_frames": cfg.ack_frames,
                           "protocol_version": pr.VERSION}}
        self.open()  # first: a socket that cannot be bound leaves no log file behind
        try:
            self.log = FrameLog(cfg.log_path, cfg.rate_hz, header)
        except BaseException:
            if self.sock is not None:
                self.sock.close()
            self.sock = None
            raise
        n_ticks = None if cfg.duration is None else int(round(cfg.duration * cfg.rate_hz))
        self.lat = np.zeros(min(n_ticks or STATS_CAP, STATS_CAP))  # a ring: statistics of the last STATS_CAP ticks
        self.jit = np.zeros_like(self.lat)
        self.comp = np.zeros_like(self.lat)
        self.n = 0
        gc.collect()
        gc.freeze()  # objects alive now never enter a collection again: no long gen-2 pauses inside a tick
        try:
            t_first = self._connect()
            self.t0 = time.perf_counter()
            start = (t_first if t_first is not None else self.t0) + cfg.phase * self.period
            k = 0
            while not self._stop and (n_ticks is None or k < n_ticks):
                deadline = start + k * self.period
                self._sleep_until(deadline)
                wake = time.perf_counter()
                late = int((wake - deadline) / self.period)
                if late >= 1:  # woke a whole period late: skip to the current tick
                    self.counts["skipped"] += late
                    self.counts["deadline_miss"] += late
                    k += late
                    deadline = start + k * self.period
                self._tick(k, deadline, wake)
                if self.log.due(wake - self.t0):
                    self.log.flush(wake - self.t0)
                if self.log.error is not None and self.log_error is None:
                    self._log_failed(k)
                k += 1
        finally:
            self.flight_state = self.state
            self._wind_down()
            gc.unfreeze()
            self.log.close()
            if self.log.error is not None and self.log_error is None:
                self.log_error = self.log.error
            self.sock.close()
            self.sock = None
        return self.summary()

    def _log_failed(self, k: int) -> None:
        """The log writer failed: FAULT ``log_write`` and stop (neutral from this tick on), unless ``allow_unlogged``."""
        self.log_error = self.log.error
        if self.cfg.allow_unlogged:
            self.events.append({"tick": k, "t": time.perf_counter() - self.t0, "event": "log_lost", "detail": self.log_error})
            return
        self._latch(F_LOG, k, self.log_error)
        self._stop = True

    def _connect(self) -> float | None:
        """Send hellos (neutral DISARMED commands) until the rig's first frame arrives; its arrival time or None."""
        end = time.perf_counter() + self.cfg.connect_timeout
        while time.perf_counter() < end and not self._stop:
            self._send(np.zeros(pr.N_SURFACES), pr.MODE_DISARMED, pr.NO_ECHO)
            r, _, _ = select.select([self.sock], [], [], min(0.1, max(0.0, end - time.perf_counter())))
            if r and self._drain():
                self._first = True
                return time.perf_counter()
        return None

    def _sleep_until(self, deadline: float) -> None:
        rest = deadline - time.perf_counter() - self.cfg.spin_s
        if rest > 0:
            time.sleep(rest)
        while time.perf_counter() < deadline:
            pass

    def _drain(self) -> bool:
        """Read every queued datagram; keep the newest valid frame from the rig. True if one was new."""
        fresh = False
        for _ in range(64):
            try:
                n, addr = self.sock.recvfrom_into(self.rx)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:  # e.g. ICMP port unreachable reported on a later recv
                continue
            if addr[0] != self.rig[0] or addr[1] != self.rig[1]:
                self.counts["foreign"] += 1
                continue
            try:
                fr = pr.unpack_sensor(memoryview(self.rx)[:n], self.key)
            except pr.FrameError as e:
                if e.reason == "mac":  # intact, but not from a holder of the link key (or a key on one side only)
                    self.counts["auth"] += 1
                    continue
                self.counts["corrupt"] += 1
                self.corrupt_reasons[e.reason] = self.corrupt_reasons.get(e.reason, 0) + 1
                continue
            seq = fr.seq
            if fr.session != self.session:  # the rig serves another client (or a frame of an earlier run)
                self.counts["session"] += 1
                continue
            if self.seq >= 0 and not pr.newer(seq, self.seq):
                if self.missed < self.cfg.fault_frames:
                    self.counts["old"] += 1
                    continue
                self.counts["resync"] += 1  # stale past the latch bound (so FAULT or DISARMED): a restarted rig's new count
                self.plaus.reset()
            why = self.plaus.check(seq, fr.rig_time, fr.angles, fr.status, fr.reserved)
            if why is not None:  # dropped like a corrupt frame; _sense latches after implausible_frames in a row
                self.counts["implausible"] += 1
                self.counts[f"implausible_{why}"] += 1
                self.implausible_run += 1
                continue
            self.plaus.accept(seq, fr.rig_time, fr.angles)
            self.implausible_run = 0
            if fr.ack != pr.NO_ECHO and (self.acked < 0 or pr.newer(fr.ack, self.acked)):
                self.acked = fr.ack
            self.seq, self.rig_time, self.airspeed, self.status = seq, fr.rig_time, fr.airspeed, fr.status
            self.angles[:], self.flaps[:] = fr.angles, fr.flaps
            fresh = True
        return fresh

    def ack_lag(self) -> int:
        """Commands sent since the newest one the rig acknowledged (all sent when none was; 2**32 for an ack of an unsent seq)."""
        if self.acked < 0:
            return self.cmd_seq
        d = (self.cmd_seq - 1 - self.acked) & 0xFFFFFFFF
        return d if d < 0x80000000 else 1 << 32

    def _latch(self, bit: int, tick: int, detail: str) -> None:
        if not self.fault & bit:
            self.events.append({"tick": tick, "t": time.perf_counter() - self.t0, "event": "fault", "fault": FAULTS[bit], "detail": detail})
        self.state, self.fault = FAULT, self.fault | bit

    def _tick(self, k: int, deadline: float, wake: float) -> None:
        """One period: sense, lifecycle, control, limits, send, record."""
        fresh, bad_now = self._sense(k, deadline)
        self._lifecycle(k, wake, fresh, bad_now)
        mode, compute, obs_t = self._control(k)
        cmd = self.limits.apply(self.target)
        self._send(cmd, mode, self.seq if self.seq >= 0 else pr.NO_ECHO)
        send = time.perf_counter()
        i = self.n % self.lat.size
        self.lat[i], self.jit[i], self.comp[i] = send - deadline, wake - deadline, compute
        self.n += 1
        if send - deadline > self.miss_s:
            self.counts["deadline_miss"] += 1
        r = self.log.next()
        r["tick"], r["deadline"], r["wake"], r["send"], r["compute"] = k, deadline - self.t0, wake - self.t0, send - self.t0, compute
        r["state"], r["mode"], r["fault"], r["fresh"], r["missed"] = self.state, mode, self.fault, fresh, self.missed
        r["seq"], r["rig_time"], r["angles"], r["flaps"], r["airspeed"] = self.seq, self.rig_time, self.angles, self.flaps, self.airspeed
        r["obs_t"], r["action"], r["command"] = obs_t, self.action, cmd
        r["n_foreign"], r["n_corrupt"], r["n_old"] = self.counts["foreign"], self.counts["corrupt"], self.counts["old"]

    def _sense(self, k: int, deadline: float) -> tuple[bool, bool]:
        """Read frames (bounded wait), feed the estimator, run the sensor watchdogs; (fresh frame, frame out of range)."""
        s = self.sensors
        fresh = self._drain() or self._first
        self._first = False
        if not fresh and self.have_frame and self.cfg.frame_wait > 0.0:  # the rig is late: wait, bounded
            limit = deadline + self.cfg.frame_wait * self.period
            while not fresh and (rest := limit - time.perf_counter()) > 0.0:
                if select.select([self.sock], [], [], rest)[0]:
                    fresh = self._drain()
        if self.implausible_run >= self.cfg.implausible_frames:
            self._latch(F_IMPLAUSIBLE, k, f"{self.implausible_run} implausible frames in a row (counts: "
                                          + ", ".join(f"{r} {self.counts['implausible_' + r]}" for r in IMPLAUSIBLE_REASONS) + ")")
        if not fresh:
            self.counts["missed"] += 1
            self.missed += 1
            if self.have_frame and self.missed < self.cfg.stale_frames:  # bridge a lost frame
                s.update(s.angles + s.rates * self.spec.dt, s.flaps.copy(), s.airspeed.copy())
            if self.state == ACTIVE and self.missed >= self.cfg.fault_frames:
                self._latch(F_STALE, k, f"{self.missed} ticks without a sensor frame")
            return False, False
        self.counts["fresh"] += 1
        self.missed = 0
        a_free = self.angles[self.free][None]
        if not self.have_frame:  # first frame: the estimator starts from it (rates 0), as an env reset
            s.reset(np.zeros(1, dtype=np.int64), a_free, self.flaps[None], np.array([self.airspeed]))
            self.have_frame = True
            self._arm_req = self._arm_req or self.cfg.arm
        else:
            s.update(a_free, self.flaps[None], np.array([self.airspeed]))
        bad = False
        if np.any(np.abs(self.angles) > self.lim_max) or np.any(np.abs(self.flaps) > FLAP_MAX) or not AIRSPEED_RANGE[0] <= self.airspeed <= AIRSPEED_RANGE[1]:
            bad = True
            self._latch(F_SENSOR, k, f"angles {np.round(np.degrees(self.angles), 1).tolist()} deg, flaps {np.round(np.degrees(self.flaps), 1).tolist()} deg, airspeed {self.airspeed:.1f} m/s")
        if self.status & pr.STATUS_RIG_FAULT:
            bad = True
            self._latch(F_RIG, k, f"rig status 0x{self.status:x}")
        lag = self.ack_lag()
        self.counts["unapplied"] += lag > 0  # the newest command sent was not applied before this frame: lost, late or flooded out
        if lag >= self.cfg.ack_frames:  # the rig applies none of our commands: no arming, and FAULT if flying
            bad = True
            if self.state == ACTIVE:
                self._latch(F_LINK, k, f"the rig acknowledged none of the last {min(lag, self.cmd_seq)} commands (newest ack {self.acked})")
        j = self.stuck.update(self.angles[self.free], self.limits.cmd, self.airspeed)  # the last command sent, in effect on the rig
        if j >= 0 and self.state == ACTIVE:
            st = self.stuck
            self._latch(F_STUCK, k, f"{st.joints[j]} reading {math.degrees(st.value[j]):.4f} deg unchanged for {st.run[j]} frames "
                                    f"while the commands moved {math.degrees(st.span[j]):.1f} deg")
        return True, bad

    def _lifecycle(self, k: int, wake: float, fresh: bool, bad_now: bool) -> None:
        """Apply operator requests: disarm always; arm only on a fresh, in-range frame (it resets the law and the reference clock)."""
        if self._disarm_req:
            self._disarm_req, self._arm_req = False, False
            self.state, self.fault = DISARMED, 0
            self.events.append({"tick": k, "event": "disarm"})
        if self._arm_req:
            self._arm_req = False
            if fresh and not bad_now:
                self.state, self.fault, self.t_origin = ACTIVE, 0, self.rig_time
                self.law.reset()
                self.overrun.reset()
                # the task's reference restarts at arming, for the measured airspeed (as an env reset draws it)
                self.task = task_for_seed(self.spec.task, self.spec.free_dofs, self.spec.dt, self._ep, self.cfg.seed, airspeed=self.airspeed, options=dict(self.spec.task_options),
                                         params_row=self._params_row)
                self.events.append({"tick": k, "t": wake - self.t0, "event": "arm", "seq": self.seq})
                self._test_over = self.test is None  # a test input restarts at every arming
            else:
                self.counts["arm_refused"] += 1
                self.events.append({"tick": k, "event": "arm_refused"})

    def _control(self, k: int) -> tuple[int, float, float]:
        """Set ``self.target`` (rad) and ``self.action``; run the law's watchdogs. (mode, law time s, reference time s)."""
        spec = self.spec
        compute = 0.0
        self.action[:] = 0.0
        self.target[:] = 0.0
        mode = pr.MODE_DISARMED if self.state == DISARMED else pr.MODE_SAFE
        obs_t = self.rig_time - self.t_origin + (self.missed + self.cfg.link_delay_steps) * spec.dt
        if self.state != ACTIVE or self.missed >= self.cfg.stale_frames:
            return mode, compute, obs_t
        self.t_arr[0] = obs_t
        # tasks with internal states (the free-Hawk reference model) advance on the measured joints; the tunnel's
        # gusts are not measured on the rig, so Task.air is never called here and the reference flies in calm air
        self.q5[self.free] = self.sensors.angles[0]
        self.qd5[self.free] = self.sensors.rates[0]
        self.task.advance(self.t_arr, self.q5[None], self.qd5[None])
        obs = observe(self.sensors, self.task, self.t_arr)
        c0 = time.perf_counter()
        try:
            a = self.law.act(obs)[0]
        except Exception as e:  # noqa: BLE001 - any failure of the law is a fault, never a crash
            self._latch(F_CONTROLLER, k, f"{type(e).__name__}: {e}")
            return mode, time.perf_counter() - c0, obs_t
        compute = time.perf_counter() - c0
        slow = self.overrun.update(compute)
        self.counts["overrun"] += compute > self.overrun_s
        if not np.all(np.isfinite(a)):
            self._latch(F_CONTROLLER, k, "non-finite action")
        elif slow is not None:
            self._latch(F_OVERRUN, k, slow)
        else:
            self.action[: spec.n_actions] = a
            self.target[: spec.n_actions] = a * self.scale
            mode = pr.MODE_ACTIVE
            if not self._test_over:
                self._add_test_input(k, round(obs_t / spec.dt) * spec.dt)
        return mode, compute, obs_t

    def _add_test_input(self, k: int, t: float) -> None:
        """Add the test input at its time t (s since arming, on the control grid) to ``self.target``, rad."""
        if t >= self._test_end:
            self._test_over = True
            self.events.append({"tick": k, "event": "test_input_end", "t_input": t})
            return
        for j, s in self._test_cols:
            self.target[j] += math.radians(float(self.test.value(s, t)))

    def _send(self, cmd: np.ndarray, mode: int, echo: int) -> None:
        pr.pack_command_into(self.tx, self.cmd_seq, echo, cmd, mode, self.session, self.key)
        self.cmd_seq += 1
        try:
            self.sock.sendto(self.tx, self.rig)
        except OSError:
            self.counts["tx_error"] += 1

    def _wind_down(self) -> None:
        """End of run: neutral targets through the output limits, one per period (mode SAFE), until every
        command is 0 (at most ``WIND_DOWN_MAX_S``), then three DISARMED neutral commands; state DISARMED.

        The surfaces thus return to neutral at the artefact's rate limit (350 deg/s by default: 40 deg in
        0.11 s), the slew the servos would apply anyway, and the rig's last command is neutral and disarmed."""
        self.state = DISARMED
        if self.sock is None:
            return
        zero = np.zeros(pr.N_SURFACES)
        n, t = 0, time.perf_counter()
        while np.any(self.limits.cmd != 0.0) and n < WIND_DOWN_MAX_S * self.cfg.rate_hz:
            t += self.period
            self._sleep_until(t)
            self._send(self.limits.apply(zero), pr.MODE_SAFE, pr.NO_ECHO)
            n += 1
        for _ in range(3):
            self._send(zero, pr.MODE_DISARMED, pr.NO_ECHO)
        self.wind_down_ticks = n

    # ------------------------------------------------------------------ summary
    def summary(self) -> dict[str, Any]:
        """Counts, deadline misses, latency (command sent - deadline) and jitter (wake - deadline) statistics, faults.

        ``final_state``: the state on the last tick flown; ``end``: after the wind-down (DISARMED, the last
        command sent, rad); ``log``: its path and the write failure, if any (None)."""
        n = min(self.n, self.lat.size)
        lat, jit, comp = self.lat[:n], self.jit[:n], self.comp[:n]
        called = comp[comp > 0]

        def stats(x: np.ndarray) -> dict[str, float]:
            if x.size == 0:
                return {"p50_ms": float("nan"), "p99_ms": float("nan"), "max_ms": float("nan")}
            return {"p50_ms": float(np.percentile(x, 50) * 1e3), "p99_ms": float(np.percentile(x, 99) * 1e3), "max_ms": float(x.max() * 1e3)}

        ticks = self.n + self.counts["skipped"]
        return {
            "ticks": ticks, "rate_hz": self.cfg.rate_hz, "final_state": STATES[self.state if self.flight_state is None else self.flight_state],
            "end": {"state": STATES[self.state], "wind_down_ticks": self.wind_down_ticks, "command_rad": self.limits.cmd.tolist()},
            "log": {"path": self.cfg.log_path, "error": self.log_error},
            "faults": [FAULTS[b] for b in FAULTS if self.fault & b],
            "deadline_misses": self.counts["deadline_miss"], "deadline_miss_fraction": self.counts["deadline_miss"] / max(ticks, 1),
            "latency": stats(lat), "wake_jitter": dict(stats(np.abs(jit)), std_ms=float(np.std(jit) * 1e3) if n else float("nan")),
            "compute": stats(called), "counts": dict(self.counts), "corrupt_reasons": dict(self.corrupt_reasons),
            "events": self.events, "artefact_sha256": self.art.sha256,
        }

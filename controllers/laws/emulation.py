"""Model-following LQR for free-flight emulation: fly the compensator so that the Hawk on the rig feels what the free Hawk would.

Task (:class:`rig_env.envs.tasks.freeflight.FreeFlightEmulation`): after a 3-2-1-1 on the Hawk elevator,
the model's angle of attack and pitch rate on the heave-pitch rig should follow those of the free
aircraft (its short period and heave, :class:`rig_env.envs.tasks.freeflight.FreeHawkShortPeriod`).
The rig's own heave-pitch mode rings instead (open loop, emulation error about 1.5; criterion 0.5).

This is *explicit model following* (Stevens & Lewis, *Aircraft Control and Simulation*, model-following
LQ design; Kaufman's "model-following" tracker): the rig and the reference model are put side by side
in one linear system and a discrete LQR minimises the difference between them.  Design model
(:mod:`controllers.design.emulation`), per airspeed of a grid over the loop's airspeed range:

| states | from |
|---|---|
| ``rig_pitch``, ``model_pitch`` and their rates (from the zero-input trim) | ``rig_env.trim`` / ``rig_env.linearize`` (viscous friction kept), as :func:`controllers.design.heave_sway.axis_point` |
| ``flap``, ``flap_rate``: the compensator's heave input through its servo | second-order servo, ``servos.compensator`` |
| ``alpha_ff``, ``q_ff``: the free Hawk's short period | the task's own reference model (``FreeHawkShortPeriod.matrices``) |
| ``hawk_elevator``, ``hawk_elevator_rate``: the Hawk elevator through its servo | ``servos.hawk``; it drives the rig's Hawk (``linearize``'s ``hawk_elevator`` column) and the free Hawk alike |
| ``pilot_cmd``: the pilot's elevator command | held, decaying with :data:`TAU_PILOT` (a step input's model; keeps it stabilisable) |
| ``gust_alpha``: the vertical gust's angle of attack -w_g / V, rad | first-order Gauss-Markov (:data:`GUST_TAU`, :data:`SIGMA_GUST`); it drives the rig (``rig_env.linearize``'s uniform ``gust_z`` column) and the free Hawk (``FreeHawkShortPeriod.gust_column``) alike |
| ``u_1`` .. ``u_d``: the last ``d`` heave commands | the loop's delay line |

The loop's delay (servo delay + the telemetry delay of ``link_delay_steps`` control periods, the latter
moved from the measurement to the input, which leaves the loop gain unchanged) is discretised exactly
with the zero-order hold (Astrom & Wittenmark, *Computer-Controlled Systems*, sampling a system with a
time delay), so the gains see the servo and the delay the rig has.  Cost (Bryson):

    J = sum e_alpha^2 / a_max^2 + e_q^2 / q_max^2 + (rig_pitch - trim)^2 / th_max^2 + u^2 / u_max(V)^2

with ``e_alpha = alpha_ff - alpha`` (the rig's alpha linearised: rig pitch + model pitch - l cos(theta) rig
pitch rate / V), ``e_q = q_ff - (rig pitch rate + model pitch rate)``; the maxima start from the scales
the task reward had before it took each episode's own (:data:`MAX_DEVIATION`: 1.5 deg, 15 deg/s, about the
free Hawk's response RMS to a 1 deg input, and 15 deg of rig pitch, its stop margin)
and the input's 0.5 (20 deg of flap) at 20 m/s, scaled ``20 / V`` as the other LQRs' (:data:`MAX_INPUT`);
the e_alpha and e_q maxima are then tightened by the largest factor of :data:`WEIGHT_SCALES` whose loop
as flown keeps :data:`TARGETS` (GM 6 dB, PM 45 deg) at every design airspeed.

Runtime (numpy only; this module): ``heave = -K(V) x`` clipped to +-1, with ``K`` interpolated linearly
in the measured airspeed, and ``x`` built from the observation:

* every other state from a steady-state Kalman filter on the design model's rows (:data:`ESTIMATED`: the rig's
  angles from the trim and their rates, the heave flap's position and rate, the free Hawk's alpha_ff and q_ff,
  the gust; the Hawk servo, pilot and delay-line states are known to the law), correcting with
  :data:`MEASURED`: the measured angles (potentiometer/encoder) and the heave flap unmixed from the four flap
  encoders, all as old as the telemetry (the design's delayed state), and the task's ``q_ref`` and
  ``accel_ref`` entries; noise :data:`SIGMA_A`, :data:`SIGMA_F`, :data:`SIGMA_Z`, :data:`SIGMA_ZF`,
  :data:`SIGMA_REF`, :data:`SIGMA_ZR`, the gust's :data:`SIGMA_GUST`; started from the measurements and the
  loop's filtered rates, in calm air.  The free Hawk's normal acceleration holds its lift, a_n / V = Za
  (alpha_ff + alpha_g) + Zq q_ff + Zd delta (+ Zad alpha_ff' with the alpha-dot split), and alpha_ff follows from q_ff through the reference's
  dynamics, so the gust is read from the reference almost at once (in the comparison's 1 % gusts the
  estimate correlates 0.99 with the true gust of the step before, at 0.85 of its RMS);
* ``pilot_cmd`` = the ``elevator_cmd`` entry;
* the Hawk servo's states from the pilot command through the servo model and its delay (as the task's
  reference model is driven), and the delay line from the law's own past commands.

No integrator: the rig's heave is meant to wash out, not to hold.  ``law.describe()``: closed-loop poles
and, per design airspeed, the margins of the loop as flown, broken at the heave command: the law with its
estimator and delay line, the rig with servo and delay (:func:`controllers.design.emulation.loop_as_flown`; default rig, 15-25 m/s: GM 10.4-12.4 dB, PM 48-50 deg,
delay margin 0.15-0.26 s, with the weights tightened to 0.5 of the reward's scales; the paper's model: GM 9.2-11.0 dB, PM 45-47 deg).

Why the gust: the task's reference flies in the rig's air, so the rig must answer a gust as the free Hawk
would.  Without the gust state (and with the reference meeting the gusts from the input's start only) the
law met the criterion in 77 % of the comparison's 64 nominal episodes; with it, and the reference flying
in the gusts from the episode's start, in all 64 (benchmarks/RESULTS.md, "Free-flight emulation").
Artefact kind ``"lqr_emulation"`` (:meth:`EmulationTables.to_data`; :mod:`controllers.laws.artefact`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.laws.base import LoopSpec, TabledLaw, UnsupportedTask, register
from controllers.laws.signals import SignalScales, table_array


TASK = "free_flight_emulation"
FREE_DOFS = ("rig_pitch", "model_pitch")
MAX_DEVIATION = {"alpha_error": math.radians(1.5), "q_error": math.radians(15.0), "rig_pitch": math.radians(15.0)}
"""Bryson maxima (rad, rad/s, rad): the task reward's scales of e_alpha and e_q and its rig-pitch stop margin."""
WEIGHT_SCALES = (1.0, 0.85, 0.7, 0.6, 0.5)
"""Candidate factors on the e_alpha and e_q maxima of :data:`MAX_DEVIATION`, loosest first: the design keeps the
tightest whose loop as flown meets :data:`TARGETS` at every design airspeed (as the heave/sway LQR's weight search)."""
TARGETS = {"gm_db": 6.0, "pm_deg": 45.0}
MAX_INPUT = 0.5
"""Normalised heave input (1 = 40 deg) at :data:`V_REF`; ``u_max(V) = MAX_INPUT V_REF / V``."""
V_REF = 20.0
SIGMA_A = (0.5, 2.0)
"""Process noise of the estimator: white accelerations of rig_pitch and model_pitch, rad/s^2 (what the linear
model misses: gusts, LuGre friction beyond its viscous term).  A trade between tracking and command noise,
chosen on the comparison's nominal conditions (32 episodes): with the roll LQR's (10, 40) the flap activity
doubles (control rate 18 /s against 3-5 /s) for no gain in emulation error; feeding the loop's
filtered-difference rates to the gains instead of an estimate gave 9.5 /s."""
SIGMA_Z = math.radians(0.1)
"""Angle measurement noise of the estimator, rad: 0.05 deg noise and 0.088 deg potentiometer quantisation."""
SIGMA_F = 10.0
"""Process noise of the estimator's flap: white acceleration, normalised/s^2 (the servo model's error: its rate
limit, and the comparison's spread of servo bandwidth 5-8 Hz and delay 10-20 ms)."""
SIGMA_ZF = 0.002
"""Measurement noise of the heave flap unmixed from the four encoders, normalised (0.08 deg; each encoder 0.05 deg
noise and 0.044 deg steps)."""
TAU_PILOT = 1.0
"""Time constant (s) of the pilot command's model in the design (a held step that decays)."""
V_STEP = 2.5
"""m/s between design airspeeds."""
BASE_STATES = ("rig_pitch", "model_pitch", "rig_pitch_rate", "model_pitch_rate", "flap", "flap_rate",
               "alpha_ff", "q_ff", "hawk_elevator", "hawk_elevator_rate", "pilot_cmd", "gust_alpha")
ESTIMATED = ("rig_pitch", "model_pitch", "rig_pitch_rate", "model_pitch_rate", "flap", "flap_rate", "alpha_ff", "q_ff", "gust_alpha")
"""The states the estimator estimates (the Hawk servo, the pilot command and the delay line are known to the law), in its order."""
MEASURED = ("rig_pitch", "model_pitch", "flap", "q_ref", "accel_ref")
"""The estimator's measurements: the two angles from the trim (rad), the heave flap (normalised), the free Hawk's
pitch rate (rad/s) and its normal acceleration over the airspeed (a_n / V, rad/s), the last two from the task's entries."""
GUST_TAU = 0.2
"""s: correlation time of the design's vertical gust (first-order Gauss-Markov), the environments' default
``turbulence_tau``."""
SIGMA_GUST = 0.01
"""rad: RMS of the design's gust angle of attack -w_g / V, the comparison's nominal turbulence (1 % of the airspeed)."""
SIGMA_REF = (0.03, 0.3)
"""Process noise of the estimator's free-Hawk states: white rates of alpha_ff (rad/s) and q_ff (rad/s^2), what its
model misses of the task's reference (whose derivatives follow each episode's mass and air, the law's the default)."""
SIGMA_ZR = (1e-3, 1e-3)
"""Measurement noise of q_ref (rad/s) and a_n / V (rad/s): the task computes them (no sensor), so only rounding."""
REF_ENTRIES = ("q_ref", "accel_ref", "elevator_cmd")
_ARRAYS = ("airspeeds", "K", "q_op", "hawk_phi", "hawk_gamma", "ref_scales", "est_rows", "est_input", "meas_rows", "kalman_gain")
"""Task entries of the observation the law reads (their units per normalised value are stored in the tables)."""


def check_emulation(spec: LoopSpec) -> None:
    """UnsupportedTask unless ``spec`` is free-flight emulation on the heave-pitch rig (rig_pitch, model_pitch free, the rest locked)."""
    if spec.task != TASK:
        raise UnsupportedTask(f"task {spec.task!r}: the model-following LQR flies {TASK!r} only")
    if tuple(spec.free_dofs) != FREE_DOFS:
        raise UnsupportedTask(f"free_dofs = {list(spec.free_dofs)}: the model-following LQR is designed for {list(FREE_DOFS)}")
    missing = [e for e in REF_ENTRIES if e not in spec.obs_labels]
    if missing:
        raise UnsupportedTask(f"observation lacks {missing}: the model-following LQR reads them")


def state_labels(n_delay: int) -> tuple[str, ...]:
    """Names of the design model's states (the columns of ``K``): :data:`BASE_STATES` then the delay line ``u_1..u_d``."""
    return BASE_STATES + tuple(f"u_{k}" for k in range(1, n_delay + 1))


@dataclass(frozen=True)
class EmulationTables:
    """Everything :class:`EmulationLQR` executes, as plain numbers.  ``nv`` design airspeeds, ``d`` delay steps.

    | field | shape | unit |
    |---|---|---|
    | airspeeds | (nv,) | m/s, increasing (> 1) |
    | K | (nv, 12 + d) | normalised input per state (:func:`state_labels` order; rad, rad/s, normalised) |
    | q_op | (nv, 2) | rad: zero-input trim of rig_pitch, model_pitch |
    | hawk_phi, hawk_gamma | (2, 2), (2,) | the Hawk servo over one period (zero-order hold) |
    | hawk_delay_steps | int | periods between the pilot command and the Hawk servo's input, as the task's reference model |
    | ref_scales | (3,) | units per normalised value of :data:`REF_ENTRIES` |
    | est_rows, est_input | (nv, 9, 12 + d), (nv, 9) | the :data:`ESTIMATED` states' rows of the discrete design model: ``p+ = est_rows x + est_input u`` |
    | meas_rows | (nv, 5, 12 + d) | the :data:`MEASURED` quantities as rows of the design state: ``z = meas_rows x`` |
    | kalman_gain | (nv, 9, 5) | the estimator's correction per unit innovation of each measurement |
    | scales | :class:`SignalScales` | the observation's normalisation |
    | design | dict | provenance: weights, grid, delays, poles and margins per airspeed |
    """

    airspeeds: np.ndarray
    K: np.ndarray
    q_op: np.ndarray
    hawk_phi: np.ndarray
    hawk_gamma: np.ndarray
    hawk_delay_steps: int
    ref_scales: np.ndarray
    est_rows: np.ndarray
    est_input: np.ndarray
    meas_rows: np.ndarray
    kalman_gain: np.ndarray
    scales: SignalScales
    design: dict[str, Any]

    @property
    def n_delay(self) -> int:
        return self.K.shape[1] - len(BASE_STATES)

    def to_data(self) -> dict[str, Any]:
        """Artefact entries: numpy arrays and JSON values."""
        arrays = {k: np.array(getattr(self, k), dtype=np.float64) for k in _ARRAYS}
        return {**arrays, "hawk_delay_steps": int(self.hawk_delay_steps),
                **self.scales.to_data(), "design": dict(self.design)}

    @classmethod
    def from_data(cls, d: Mapping[str, Any], spec: LoopSpec) -> EmulationTables:
        """Check ``d`` (from the design or an artefact); a ValueError names the entry, UnsupportedTask a wrong spec."""
        name = "lqr_emulation"
        check_emulation(spec)
        keys = (*_ARRAYS, "hawk_delay_steps", "design")
        missing = [k for k in keys if k not in d]
        if missing:
            raise ValueError(f"{name}: missing entries {missing}")
        V = table_array(d, "airspeeds", owner=name, shape=None)
        if V.ndim != 1 or V.size < 1 or V[0] <= 1.0 or np.any(np.diff(V) <= 0):
            raise ValueError(f"{name}: airspeeds must be increasing and > 1 m/s, got {V.tolist() if V.ndim == 1 else V.shape}")
        nv = V.size
        nb = len(BASE_STATES)
        K = table_array(d, "K", owner=name, shape=None)
        if K.ndim != 2 or K.shape[0] != nv or not nb <= K.shape[1] <= nb + 100:
            raise ValueError(f"{name}: K: expected shape ({nv}, {nb} + d) with d in [0, 100], got {K.shape}"
                             + (" (tables made before the law estimated the gust: design the law again)" if K.ndim == 2 and K.shape[1] < nb else ""))
        nx = K.shape[1]
        ne, nm = len(ESTIMATED), len(MEASURED)
        hd = d["hawk_delay_steps"]
        if isinstance(hd, bool) or not isinstance(hd, int) or not 0 <= hd <= 100:
            raise ValueError(f"{name}: hawk_delay_steps = {hd!r}: an integer in [0, 100]")
        if type(d["design"]) is not dict:
            raise ValueError(f"{name}: design must be an object")
        rs = table_array(d, "ref_scales", owner=name, shape=(len(REF_ENTRIES),))
        if np.any(rs <= 0):
            raise ValueError(f"{name}: ref_scales must be > 0")
        return cls(V, K, table_array(d, "q_op", owner=name, shape=(nv, 2)), table_array(d, "hawk_phi", owner=name, shape=(2, 2)),
                   table_array(d, "hawk_gamma", owner=name, shape=(2,)), int(hd), rs,
                   table_array(d, "est_rows", owner=name, shape=(nv, ne, nx)), table_array(d, "est_input", owner=name, shape=(nv, ne)),
                   table_array(d, "meas_rows", owner=name, shape=(nv, nm, nx)), table_array(d, "kalman_gain", owner=name, shape=(nv, ne, nm)),
                   SignalScales.from_data(d, spec), dict(d["design"]))


@register("lqr")
class EmulationLQR(TabledLaw):
    """Model-following LQR of free-flight emulation (module docstring).

    ``tables``: the design (:class:`EmulationTables` or its data), made by
    :func:`controllers.design.emulation.design_emulation_lqr` (or read from an artefact).
    """

    artefact_kind = "lqr_emulation"

    @classmethod
    def supports(cls, spec: LoopSpec) -> str | None:
        try:
            check_emulation(spec)
        except UnsupportedTask as exc:
            return str(exc)
        return None

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, tables: EmulationTables | Mapping[str, Any]) -> None:
        check_emulation(spec)
        super().__init__(spec, num_envs)
        t = self.tables = tables if isinstance(tables, EmulationTables) else EmulationTables.from_data(tables, spec)
        ix, sc, n = spec.index, t.scales, self.num_envs
        self._ca, self._cm = ix("rig_pitch_angle"), ix("model_pitch_angle")
        self._ra, self._rm = ix("rig_pitch_rate"), ix("model_pitch_rate")
        self._air = ix("airspeed")
        self._ref = [ix(e) for e in REF_ENTRIES]
        self._rate_scale = np.array(sc.rate_scale, dtype=np.float64)
        self.nd = t.n_delay
        self._est = [BASE_STATES.index(k) for k in ESTIMATED]
        self._known = [BASE_STATES.index(k) for k in ("hawk_elevator", "hawk_elevator_rate", "pilot_cmd")]
        self._alpha_ff, self._q_ff = ESTIMATED.index("alpha_ff"), ESTIMATED.index("q_ff")  # their columns in est
        self.a_ff = np.zeros(n)  # the free Hawk's alpha as last estimated (rad; diagnostics)
        self.x = np.zeros((n, len(BASE_STATES) + self.nd))  # the last state vector (state_labels order)
        self.hawk = np.zeros((n, 2))  # Hawk servo (position, rate), rad
        self.pilot = np.zeros((n, t.hawk_delay_steps + 2))  # pilot commands, newest first
        self.u_past = np.zeros((n, self.nd))  # u(k-1) .. u(k-d)
        self.est = np.zeros((n, len(ESTIMATED)))  # the estimator's prediction (ESTIMATED order)
        self.fresh = np.ones(n, dtype=bool)  # start the estimator from the measurement
        self._flaps = [ix(f"flap{k}") for k in range(1, 5)]
        self._unmix = sc.unmix[1] * sc.flap_scale / math.radians(spec.action_scale_deg)  # heave flap, normalised, per flap unit

    def reset(self, mask: np.ndarray | None = None) -> None:
        m = self._mask(mask)
        for a in (self.hawk, self.pilot, self.u_past, self.est):
            a[m] = 0
        self.fresh |= m

    def _at(self, table: np.ndarray, V: np.ndarray) -> np.ndarray:
        """Linear interpolation in airspeed of a table (nv, ...) at V (n,), clamped to the grid."""
        Vg = self.tables.airspeeds
        if Vg.size == 1:
            return np.broadcast_to(table[0], (V.size,) + table.shape[1:]).copy()
        x = np.clip(np.interp(V, Vg, np.arange(Vg.size)), 0, Vg.size - 1 - 1e-9)
        i = np.floor(x).astype(np.int64)
        w = (x - i).reshape((-1,) + (1,) * (table.ndim - 1))
        return (1 - w) * table[i] + w * table[i + 1]

    def _full(self, est: np.ndarray, cmd: np.ndarray) -> np.ndarray:
        """(n, 12 + d): the design state from the estimated states (n, 9) and the law's known ones."""
        x = np.empty((self.num_envs, len(BASE_STATES) + self.nd))
        x[:, self._est] = est
        x[:, self._known] = np.column_stack([self.hawk, cmd])
        x[:, len(BASE_STATES):] = self.u_past
        return x

    def state(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x (n, 12 + d) in :func:`state_labels` order, airspeed (n,)) from the observation; advances the Hawk servo
        model and the estimator's correction (its prediction is made in :meth:`act`, which knows the command)."""
        t, o = self.tables, obs
        sc = t.scales
        V = np.maximum(o[:, self._air] * sc.airspeed_scale, 5.0)
        th, ph = o[:, self._ca] * sc.angle_scale, o[:, self._cm] * sc.angle_scale
        thd, phd = o[:, self._ra] * self._rate_scale[0], o[:, self._rm] * self._rate_scale[1]
        q_ref, a_n, cmd = (o[:, c] * s for c, s in zip(self._ref, t.ref_scales))
        self.pilot = np.roll(self.pilot, 1, axis=1)
        self.pilot[:, 0] = cmd
        self.hawk = self.hawk @ t.hawk_phi.T + np.outer(self.pilot[:, t.hawk_delay_steps + 1], t.hawk_gamma)
        q_op = self._at(t.q_op, V)
        z = np.stack([th - q_op[:, 0], ph - q_op[:, 1], o[:, self._flaps] @ self._unmix, q_ref, a_n / V], axis=1)
        f = self.fresh
        if np.any(f):  # start from the measured angles, the loop's filtered rates, the measured flap and q_ref, in calm air
            self.est[f] = 0.0
            self.est[f, :5] = np.stack([z[:, 0], z[:, 1], thd, phd, z[:, 2]], axis=1)[f]
            self.est[f, self._q_ff] = q_ref[f]
            self.fresh[:] = False
        innovation = z - np.einsum("nij,nj->ni", self._at(t.meas_rows, V), self._full(self.est, cmd))
        est = self.est + np.einsum("nij,nj->ni", self._at(t.kalman_gain, V), innovation)
        x = self._full(est, cmd)
        self.a_ff = est[:, self._alpha_ff]
        return x, V

    def act(self, obs: np.ndarray) -> np.ndarray:
        o = self._check_obs(obs)
        t = self.tables
        x, V = self.state(o)
        self.x = x  # the state the gains acted on (diagnostics, logging)
        u = np.clip(-np.einsum("nj,nj->n", self._at(t.K, V), x), -1.0, 1.0)
        # the estimator's prediction one period on: its states' rows of the design model
        self.est = np.einsum("nij,nj->ni", self._at(t.est_rows, V), x) + self._at(t.est_input, V) * u[:, None]
        if self.nd:
            self.u_past = np.concatenate([u[:, None], self.u_past[:, :-1]], axis=1)
        a = np.zeros((self.num_envs, self.spec.n_actions))
        a[:, self.spec.action_index("comp_elevator")] = u
        return a

    def describe(self) -> dict[str, Any]:
        """Closed-loop poles (as [re, im]) and margins (servo and delay in the loop) at every design airspeed, as computed by the design."""
        return {"points": [dict(p) for p in self.tables.design["points"]]}

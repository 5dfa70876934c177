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

* the rig's angles (from the trim) and rates and the heave flap's position and rate: a steady-state Kalman
  filter on the design model's rows (the Hawk-elevator and delay-line states known to the law), correcting
  with the measured angles (potentiometer/encoder) and the heave flap unmixed from the four flap encoders,
  all as old as the telemetry (the design's delayed state); noise :data:`SIGMA_A`, :data:`SIGMA_F`,
  :data:`SIGMA_Z`, :data:`SIGMA_ZF`; started from the measurements and the loop's filtered rates;
* ``alpha_ff = alpha_error + (alpha - alpha_b)``: the task's ``alpha_error`` entry plus the measured
  alpha (:func:`rig_alpha` of the measured angles and rates) relative to ``alpha_b``, the measured alpha
  latched when ``input_active`` rises (the task's baseline); 0 before;
* ``q_ff`` = the ``q_ref`` entry; ``pilot_cmd`` = the ``elevator_cmd`` entry;
* the Hawk servo's states from the pilot command through the servo model and its delay (as the task's
  reference model is driven), and the delay line from the law's own past commands.

No integrator: the rig's heave is meant to wash out, not to hold.  ``law.describe()``: closed-loop poles
and, per design airspeed, the margins of the loop as flown, broken at the heave command: the law with its
estimator and delay line, the rig with servo and delay (:func:`controllers.design.emulation.loop_as_flown`; default rig, 15-25 m/s: GM 12.4-12.9 dB, PM 48-49 deg,
delay margin 0.16-0.27 s, with the weights tightened to 0.6 of the reward's scales).
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
               "alpha_ff", "q_ff", "hawk_elevator", "hawk_elevator_rate", "pilot_cmd")
REF_ENTRIES = ("alpha_error", "q_ref", "elevator_cmd", "input_active")
_ARRAYS = ("airspeeds", "K", "q_op", "hawk_phi", "hawk_gamma", "ref_scales", "est_rows", "est_input", "kalman_gain")
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


def rig_alpha(theta: np.ndarray, phi: np.ndarray, theta_rate: np.ndarray, V: np.ndarray, l: float) -> np.ndarray:
    """The model's angle of attack on the heave-pitch rig, rad: ``theta + phi - atan2(l theta' cos theta, V - l theta' sin theta)``.

    As the task computes it (``rig_env.envs.tasks.freeflight.rig_alpha``; the gimbal moves at ``l theta'`` on
    its arc), here from measured values."""
    return theta + phi - np.arctan2(l * theta_rate * np.cos(theta), V - l * theta_rate * np.sin(theta))


@dataclass(frozen=True)
class EmulationTables:
    """Everything :class:`EmulationLQR` executes, as plain numbers.  ``nv`` design airspeeds, ``d`` delay steps.

    | field | shape | unit |
    |---|---|---|
    | airspeeds | (nv,) | m/s, increasing (> 1) |
    | K | (nv, 11 + d) | normalised input per state (:func:`state_labels` order; rad, rad/s, normalised) |
    | q_op | (nv, 2) | rad: zero-input trim of rig_pitch, model_pitch |
    | hawk_phi, hawk_gamma | (2, 2), (2,) | the Hawk servo over one period (zero-order hold) |
    | hawk_delay_steps | int | periods between the pilot command and the Hawk servo's input, as the task's reference model |
    | arm_length | scalar | m, pivot to model gimbal |
    | ref_scales | (4,) | units per normalised value of :data:`REF_ENTRIES` |
    | est_rows, est_input | (nv, 6, 11 + d), (nv, 6) | the estimated states' rows of the discrete design model (rig angles and rates, flap and its rate): ``p+ = est_rows x + est_input u`` |
    | kalman_gain | (nv, 6, 3) | the estimator's correction per unit innovation of the two angles and the flap |
    | scales | :class:`SignalScales` | the observation's normalisation |
    | design | dict | provenance: weights, grid, delays, poles and margins per airspeed |
    """

    airspeeds: np.ndarray
    K: np.ndarray
    q_op: np.ndarray
    hawk_phi: np.ndarray
    hawk_gamma: np.ndarray
    hawk_delay_steps: int
    arm_length: float
    ref_scales: np.ndarray
    est_rows: np.ndarray
    est_input: np.ndarray
    kalman_gain: np.ndarray
    scales: SignalScales
    design: dict[str, Any]

    @property
    def n_delay(self) -> int:
        return self.K.shape[1] - len(BASE_STATES)

    def to_data(self) -> dict[str, Any]:
        """Artefact entries: numpy arrays and JSON values."""
        arrays = {k: np.array(getattr(self, k), dtype=np.float64) for k in _ARRAYS}
        return {**arrays, "hawk_delay_steps": int(self.hawk_delay_steps), "arm_length": float(self.arm_length),
                **self.scales.to_data(), "design": dict(self.design)}

    @classmethod
    def from_data(cls, d: Mapping[str, Any], spec: LoopSpec) -> EmulationTables:
        """Check ``d`` (from the design or an artefact); a ValueError names the entry, UnsupportedTask a wrong spec."""
        name = "lqr_emulation"
        check_emulation(spec)
        keys = (*_ARRAYS, "hawk_delay_steps", "arm_length", "design")
        missing = [k for k in keys if k not in d]
        if missing:
            raise ValueError(f"{name}: missing entries {missing}")
        V = table_array(d, "airspeeds", owner=name, shape=None)
        if V.ndim != 1 or V.size < 1 or V[0] <= 1.0 or np.any(np.diff(V) <= 0):
            raise ValueError(f"{name}: airspeeds must be increasing and > 1 m/s, got {V.tolist() if V.ndim == 1 else V.shape}")
        nv = V.size
        K = table_array(d, "K", owner=name, shape=None)
        if K.ndim != 2 or K.shape[0] != nv or not len(BASE_STATES) <= K.shape[1] <= len(BASE_STATES) + 100:
            raise ValueError(f"{name}: K: expected shape ({nv}, {len(BASE_STATES)} + d) with d in [0, 100], got {K.shape}")
        nx = K.shape[1]
        hd = d["hawk_delay_steps"]
        if isinstance(hd, bool) or not isinstance(hd, int) or not 0 <= hd <= 100:
            raise ValueError(f"{name}: hawk_delay_steps = {hd!r}: an integer in [0, 100]")
        arm = d["arm_length"]
        if isinstance(arm, bool) or not isinstance(arm, (int, float)) or not math.isfinite(arm) or arm <= 0:
            raise ValueError(f"{name}: arm_length = {arm!r}: must be a finite number > 0")
        if type(d["design"]) is not dict:
            raise ValueError(f"{name}: design must be an object")
        rs = table_array(d, "ref_scales", owner=name, shape=(len(REF_ENTRIES),))
        if np.any(rs <= 0):
            raise ValueError(f"{name}: ref_scales must be > 0")
        return cls(V, K, table_array(d, "q_op", owner=name, shape=(nv, 2)), table_array(d, "hawk_phi", owner=name, shape=(2, 2)),
                   table_array(d, "hawk_gamma", owner=name, shape=(2,)), int(hd), float(arm), rs,
                   table_array(d, "est_rows", owner=name, shape=(nv, 6, nx)), table_array(d, "est_input", owner=name, shape=(nv, 6)),
                   table_array(d, "kalman_gain", owner=name, shape=(nv, 6, 3)), SignalScales.from_data(d, spec), dict(d["design"]))


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
        self.alpha_b = np.zeros(n)  # measured alpha when the input began
        self.a_ff = np.zeros(n)  # the free Hawk's alpha as last reconstructed (rad; diagnostics)
        self.x = np.zeros((n, len(BASE_STATES) + self.nd))  # the last state vector (state_labels order)
        self.active = np.zeros(n, dtype=bool)
        self.hawk = np.zeros((n, 2))  # Hawk servo (position, rate), rad
        self.pilot = np.zeros((n, t.hawk_delay_steps + 2))  # pilot commands, newest first
        self.u_past = np.zeros((n, self.nd))  # u(k-1) .. u(k-d)
        self.est = np.zeros((n, 6))  # the estimator's prediction: rig angles - trim, rates; flap, flap rate
        self.fresh = np.ones(n, dtype=bool)  # start the estimator from the measurement
        self._flaps = [ix(f"flap{k}") for k in range(1, 5)]
        self._unmix = sc.unmix[1] * sc.flap_scale / math.radians(spec.action_scale_deg)  # heave flap, normalised, per flap unit

    def reset(self, mask: np.ndarray | None = None) -> None:
        m = self._mask(mask)
        for a in (self.alpha_b, self.active, self.hawk, self.pilot, self.u_past, self.est):
            a[m] = 0
        self.fresh |= m

    def _at(self, table: np.ndarray, V: np.ndarray) -> np.ndarray:
        """Linear interpolation in airspeed of a table (nv, k) at V (n,), clamped to the grid."""
        Vg = self.tables.airspeeds
        if Vg.size == 1:
            return np.broadcast_to(table[0], (V.size,) + table.shape[1:]).copy()
        x = np.clip(np.interp(V, Vg, np.arange(Vg.size)), 0, Vg.size - 1 - 1e-9)
        i = np.floor(x).astype(np.int64)
        w = (x - i)[:, None]
        return (1 - w) * table[i] + w * table[i + 1]

    def state(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x (n, 11 + d) in :func:`state_labels` order, airspeed (n,)) from the observation; advances the latches, the Hawk
        servo model and the estimator's correction (its prediction is made in :meth:`act`, which knows the command)."""
        t, o = self.tables, obs
        sc = t.scales
        V = np.maximum(o[:, self._air] * sc.airspeed_scale, 5.0)
        th, ph = o[:, self._ca] * sc.angle_scale, o[:, self._cm] * sc.angle_scale
        thd, phd = o[:, self._ra] * self._rate_scale[0], o[:, self._rm] * self._rate_scale[1]
        e_a, q_ff, cmd = (o[:, c] * s for c, s in zip(self._ref[:3], t.ref_scales[:3]))
        on = o[:, self._ref[3]] > 0.5
        alpha = rig_alpha(th, ph, thd, V, t.arm_length)
        self.alpha_b = np.where(on & ~self.active, alpha, self.alpha_b)
        self.active = on
        a_ff = self.a_ff = np.where(on, e_a + alpha - self.alpha_b, 0.0)
        self.pilot = np.roll(self.pilot, 1, axis=1)
        self.pilot[:, 0] = cmd
        self.hawk = self.hawk @ t.hawk_phi.T + np.outer(self.pilot[:, t.hawk_delay_steps + 1], t.hawk_gamma)
        q_op = self._at(t.q_op, V)
        z = np.stack([th - q_op[:, 0], ph - q_op[:, 1], o[:, self._flaps] @ self._unmix], axis=1)
        f = self.fresh
        if np.any(f):  # start from the measured angles, the loop's filtered rates and the measured flap, at rest
            self.est[f] = np.stack([z[:, 0], z[:, 1], thd, phd, z[:, 2], np.zeros(len(z))], axis=1)[f]
            self.fresh[:] = False
        Lk = self._at(t.kalman_gain.reshape(t.airspeeds.size, 18), V).reshape(-1, 6, 3)
        est = self.est + np.einsum("nij,nj->ni", Lk, z - self.est[:, [0, 1, 4]])
        x = np.concatenate([est, np.stack([a_ff, q_ff, self.hawk[:, 0], self.hawk[:, 1], cmd], axis=1), self.u_past], axis=1)
        return x, V

    def act(self, obs: np.ndarray) -> np.ndarray:
        o = self._check_obs(obs)
        t = self.tables
        x, V = self.state(o)
        self.x = x  # the state the gains acted on (diagnostics, logging)
        u = np.clip(-np.einsum("nj,nj->n", self._at(t.K, V), x), -1.0, 1.0)
        # the estimator's prediction one period on: its states' rows of the design model
        nx = x.shape[1]
        rows = self._at(t.est_rows.reshape(t.airspeeds.size, 6 * nx), V).reshape(-1, 6, nx)
        self.est = np.einsum("nij,nj->ni", rows, x) + self._at(t.est_input, V) * u[:, None]
        if self.nd:
            self.u_past = np.concatenate([u[:, None], self.u_past[:, :-1]], axis=1)
        a = np.zeros((self.num_envs, self.spec.n_actions))
        a[:, self.spec.action_index("comp_elevator")] = u
        return a

    def describe(self) -> dict[str, Any]:
        """Closed-loop poles (as [re, im]) and margins (servo and delay in the loop) at every design airspeed, as computed by the design."""
        return {"points": [dict(p) for p in self.tables.design["points"]]}

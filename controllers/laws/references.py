"""``DrivenReference``: the driven rig joint's reference (angle error, rate, acceleration) read off a heave/sway task's observation.

The heave and sway laws (:mod:`controllers.laws.heave_sway`) drive one rig joint (rig_pitch or rig_yaw)
with rig_roll locked.  Each task states its reference differently (its class docstring gives the
entries; its ``ref_scales`` declares each entry's unit per normalised value); this parser turns them
into the same three signals, batched.  Every task entry is read by name and multiplied by the scale
the task declares for it (stored in :attr:`ReferenceConstants.scales`); ``T_RAMP`` and ``G0`` below are
the tasks' named constants, stored likewise:

| task | driven joint | e = theta_ref - theta (rad) | w_ref (rad/s) | a_ref (rad/s^2) |
|---|---|---|---|---|
| pull_up_push_over | rig_pitch | heave_error | heave_rate_ref | accel_ref / (l cos theta_ref) (h = l sin theta, the task's geometry) |
| forced_oscillation | rig_pitch (heave_pitch) or rig_yaw (sway_yaw) | osc_error | osc_rate_error + measured rate | A ((e'' - e w^2) sin(phi) + 2 e' w cos(phi)), A = osc_amplitude, w = 2 pi osc_frequency, envelope e(t) over the task's ``T_RAMP`` (its smooth step x^2 (3 - 2 x)) from the parser's own clock since osc_sin/osc_cos turned on |
| free_flight_emulation | rig_pitch | theta_ref - theta; theta_ref' = w_ref - (theta_ref - theta_0) / T_w from theta_0, the measured angle at reset | washed-out integral of a_ref, minus (V / l) c_alpha alpha_error | accel_ref / (l cos theta) |

The acceleration formulas are the laws' own: each is derived from the task's reference definition
(its class docstring) and uses only the constants the task declares.

Free-flight emulation: the rig matches the free Hawk's flight path when the model gimbal's vertical
acceleration is the free Hawk's a_n (``h = l sin theta``, so ``theta'' = a_n / (l cos theta)``); its
stroke is +-0.34 m, so the rate and angle references wash out with time constant :data:`WASHOUT_S`
(the free Hawk's short period is far faster, so alpha, the scored signal, is little affected).  The
alpha the model feels is ``Theta - gamma`` with ``gamma = l theta' / V``, so a measured alpha
error ``e_a`` is corrected by ``-c_alpha V e_a / l`` on the rate reference (:data:`C_ALPHA`).
Arm length ``l`` is the design parameters' (``geometry.arm_length``).

Runtime and design are apart (as :class:`controllers.laws.signals.SignalScales`):
:func:`controllers.design.signals.reference_constants` reads every number the parser needs from
``rig_env`` (the driven joint, the sensors' scales, the task's entry scales, ``G0``, the
oscillation's ramp time, the arm length) into :class:`ReferenceConstants`, plain numbers;
:class:`DrivenReference` parses with numpy alone from them, so a deployed heave/sway law stores them
(``ref_*`` entries) and never imports ``rig_env``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.laws.base import LoopSpec, UnsupportedTask


D = math.pi / 180.0
WASHOUT_S = 1.0
"""Time constant of the free-flight emulation's heave washout, s."""
C_ALPHA = 2.0
"""Gain of the alpha-error correction on the rate reference, in units of V / l (hand-searched over 0.5-4 on 12 episodes, gusts off: 2 gave the lowest median emulation error, 0.72)."""
TASKS = ("pull_up_push_over", "forced_oscillation", "free_flight_emulation")
DRIVEN = ("rig_pitch", "rig_yaw")
ENTRIES = {"pull_up_push_over": ("heave_error", "heave_rate_ref", "accel_ref"),
           "forced_oscillation": ("osc_error", "osc_rate_error", "osc_sin", "osc_cos", "osc_amplitude", "osc_frequency"),
           "free_flight_emulation": ("alpha_error", "accel_ref", "input_active")}
"""Task entries the parser reads, per task (their scales are the task's declared ``ref_scales``)."""
ANGLES = frozenset({"heave_error", "osc_error", "osc_amplitude", "alpha_error"})
"""Entries in rad: applied as ``x * degrees(scale) * D`` (the unit the tasks state, deg, then to rad): the
same rounding as the tasks' ``/ 10 deg`` stated in degrees, so the parse is bit for bit that of a
parser with the literal degrees."""


def check_task(spec: LoopSpec, joint: str) -> None:
    """UnsupportedTask unless ``spec`` is a heave/sway task with rig_roll locked and ``joint`` free (numpy only)."""
    if spec.task not in TASKS:
        raise UnsupportedTask(f"task {spec.task!r}: the heave/sway laws fly {list(TASKS)}")
    if "rig_roll" in spec.free_dofs:
        raise UnsupportedTask(f"free_dofs = {list(spec.free_dofs)}: the heave/sway laws need rig_roll locked")
    if joint not in spec.free_dofs:
        raise UnsupportedTask(f"free_dofs = {list(spec.free_dofs)}: task {spec.task!r} drives {joint}, which is locked")




@dataclass(frozen=True)
class ReferenceConstants:
    """Every number :class:`DrivenReference` needs, for one :class:`LoopSpec`.

    | field | unit |
    |---|---|
    | joint | the driven rig joint (rig_pitch or rig_yaw) |
    | angle_scale | rad per ``<joint>_angle`` unit |
    | rate_scale | rad/s per ``<joint>_rate`` unit |
    | airspeed_scale | m/s per ``airspeed`` unit |
    | g0 | m/s^2, the tasks' standard gravity ``G0`` (``rig_env.envs.tasks.base``): the load-factor unit, recorded (the parser scales ``accel_ref`` by its declared scale, ``G0`` in every task) |
    | t_ramp | s, forced oscillation's amplitude ramp (``ForcedOscillation.T_RAMP``) |
    | arm_length | m, the design parameters' ``geometry.arm_length`` |
    | scales | task entry name -> its unit per normalised value (the task's ``ref_scales``), for every entry of :data:`ENTRIES` |
    """

    joint: str
    angle_scale: float
    rate_scale: float
    airspeed_scale: float
    g0: float
    t_ramp: float
    arm_length: float
    scales: Mapping[str, float]

    def to_data(self) -> dict[str, Any]:
        """Artefact entries (``ref_*``), JSON values (``ref_scales``: an object name -> number)."""
        return {f"ref_{k}": (dict(getattr(self, k)) if k == "scales" else getattr(self, k)) for k in self.__dataclass_fields__}

    @classmethod
    def from_data(cls, d: Mapping[str, Any], spec: LoopSpec) -> ReferenceConstants:
        """Inverse of :meth:`to_data`; a ValueError names a missing or invalid entry, UnsupportedTask a wrong spec."""
        missing = [f"ref_{k}" for k in cls.__dataclass_fields__ if f"ref_{k}" not in d]
        if missing:
            raise ValueError(f"reference constants: missing {missing}")
        joint = d["ref_joint"]
        if joint not in DRIVEN:
            raise ValueError(f"ref_joint = {joint!r}: allowed {list(DRIVEN)}")
        check_task(spec, joint)
        vals = {}
        for k in ("angle_scale", "rate_scale", "airspeed_scale", "g0", "t_ramp", "arm_length"):
            v = d[f"ref_{k}"]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"ref_{k} = {v!r}: must be a finite number > 0")
            vals[k] = float(v)
        scales = d["ref_scales"]
        need = ENTRIES[spec.task]
        if not isinstance(scales, Mapping) or any(k not in scales for k in need):
            raise ValueError(f"ref_scales: expected an object with the scales of {list(need)}, got {scales!r}")
        for k in need:
            v = scales[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"ref_scales[{k!r}] = {v!r}: must be a finite number > 0")
        return cls(joint, **vals, scales={k: float(scales[k]) for k in need})




def ramp_envelope(x: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forced oscillation's amplitude envelope at ``x`` = time since onset / ramp time ``T`` (s): (e, e' 1/s, e'' 1/s^2).

    The task's envelope is its smooth step over ``T_RAMP``: ``e = s^2 (3 - 2 s)``, ``s = clip(x, 0, 1)``
    (zero slope at both ends); the derivatives are those of that polynomial, zero for x >= 1.
    """
    s = np.clip(x, 0.0, 1.0)
    e = s * s * (3.0 - 2.0 * s)
    return e, np.where(x < 1.0, 6.0 * x * (1.0 - x), 0.0) / T, np.where(x < 1.0, 6.0 * (1.0 - 2.0 * x), 0.0) / T**2


class DrivenReference:
    """Parser built once per law; :meth:`__call__` returns ``(e, w_ref, a_ref)`` (n,) each, rad, rad/s, rad/s^2.

    ``constants``: its numbers (:func:`controllers.design.signals.reference_constants` reads them from
    ``rig_env`` at design time).  Numpy only.
    """

    def __init__(self, spec: LoopSpec, num_envs: int, constants: ReferenceConstants) -> None:
        self.constants = c = constants
        self.spec, self.n, self.dt = spec, int(num_envs), float(spec.dt)
        self.joint = c.joint
        ix = spec.index
        self._angle = ix(f"{self.joint}_angle")
        self._rate = ix(f"{self.joint}_rate")
        self._air = ix("airspeed")
        self.l = c.arm_length
        self._scale = (c.angle_scale, c.rate_scale, c.airspeed_scale)
        self._t_ramp = c.t_ramp
        self._c = {name: ix(name) for name in ENTRIES[spec.task]}
        self._k = {name: (math.degrees(c.scales[name]) if name in ANGLES else c.scales[name]) for name in ENTRIES[spec.task]}
        self.clock = np.zeros(self.n)  # forced oscillation: time since the oscillation started, s
        self.w_ref = np.zeros(self.n)  # free-flight emulation: washed-out references
        self.th_ref = np.zeros(self.n)
        self.th_base = np.zeros(self.n)  # angle at reset, rad
        self.fresh = np.ones(self.n, dtype=bool)
        self.c_alpha = C_ALPHA

    def reset(self, mask: np.ndarray) -> None:
        self.clock[mask] = 0.0
        self.w_ref[mask] = 0.0
        self.fresh |= mask

    def theta(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(measured angle, measured filtered rate) of the driven joint, rad and rad/s."""
        return obs[:, self._angle] * self._scale[0], obs[:, self._rate] * self._scale[1]

    def __call__(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        th, rate = self.theta(obs)
        c, k = self._c, self._k
        if self.spec.task == "pull_up_push_over":
            e = obs[:, c["heave_error"]] * k["heave_error"] * D
            w = obs[:, c["heave_rate_ref"]] * k["heave_rate_ref"]
            a = obs[:, c["accel_ref"]] * k["accel_ref"] / (self.l * np.cos(th + e))
        elif self.spec.task == "forced_oscillation":
            e = obs[:, c["osc_error"]] * k["osc_error"] * D
            w = obs[:, c["osc_rate_error"]] * k["osc_rate_error"] + rate
            sn, cs = obs[:, c["osc_sin"]] * k["osc_sin"], obs[:, c["osc_cos"]] * k["osc_cos"]
            on = (sn != 0.0) | (cs != 0.0)
            amp, om = obs[:, c["osc_amplitude"]] * k["osc_amplitude"] * D, 2.0 * math.pi * (obs[:, c["osc_frequency"]] * k["osc_frequency"])
            env, denv, ddenv = ramp_envelope(self.clock / self._t_ramp, self._t_ramp)
            a = np.where(on, amp * ((ddenv - env * om**2) * sn + 2.0 * denv * om * cs), 0.0)
            self.clock = np.where(on, self.clock + self.dt, 0.0)
        else:
            V = np.maximum(obs[:, self._air] * self._scale[2], 5.0)
            self.th_ref = np.where(self.fresh, th, self.th_ref)
            self.th_base = np.where(self.fresh, th, self.th_base)
            on = obs[:, c["input_active"]] * k["input_active"] > 0.5
            a = np.where(on, obs[:, c["accel_ref"]] * k["accel_ref"] / (self.l * np.cos(th)), 0.0)
            self.w_ref = self.w_ref + self.dt * (a - self.w_ref / WASHOUT_S)
            w = self.w_ref - self.c_alpha * (V / self.l) * obs[:, c["alpha_error"]] * k["alpha_error"] * D
            e = self.th_ref - th
            self.th_ref = self.th_ref + self.dt * (w - (self.th_ref - self.th_base) / WASHOUT_S)
        self.fresh[:] = False
        return e, w, a

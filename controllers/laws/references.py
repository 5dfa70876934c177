"""``DrivenReference``: the driven rig joint's reference (angle error, rate, acceleration) read off a heave/sway task's observation.

The heave and sway laws (:mod:`controllers.laws.heave_sway`) drive one rig joint (rig_pitch or rig_yaw)
with rig_roll locked.  Each task states its reference differently (its class docstring gives the
entries and their normalisations); this parser turns them into the same three signals, batched:

| task | driven joint | e = theta_ref - theta (rad) | w_ref (rad/s) | a_ref (rad/s^2) |
|---|---|---|---|---|
| pull_up_push_over | rig_pitch | heave_error x 10 deg | heave_rate_ref x 5 | accel_ref g / (l cos theta_ref) (h = l sin theta) |
| forced_oscillation | rig_pitch (heave_pitch) or rig_yaw (sway_yaw) | osc_error x 10 deg | osc_rate_error x 5 + measured rate | A ((e'' - e w^2) sin(phi) + 2 e' w cos(phi)), envelope e(t) (the task's smooth ramp) from the parser's own clock since osc_sin/osc_cos turned on |
| free_flight_emulation | rig_pitch | theta_ref - theta; theta_ref' = w_ref - (theta_ref - theta_0) / T_w from theta_0, the measured angle at reset | washed-out integral of a_ref, minus (V / l) c_alpha alpha_error | accel_ref g / (l cos theta) |

Free-flight emulation: the rig matches the free Hawk's flight path when the model gimbal's vertical
acceleration is the free Hawk's a_n (``h = l sin theta``, so ``theta'' = a_n / (l cos theta)``); its
stroke is +-0.34 m, so the rate and angle references wash out with time constant :data:`WASHOUT_S`
(the free Hawk's short period is far faster, so alpha, the scored signal, is little affected).  The
alpha the model feels is ``Theta - gamma`` with ``gamma = l theta' / V``, so a measured alpha
error ``e_a`` is corrected by ``-c_alpha V e_a / l`` on the rate reference (:data:`C_ALPHA`).
Arm length ``l`` is the design parameters' (``geometry.arm_length``).

Runtime and design are apart (as :class:`controllers.laws.signals.SignalScales`):
:func:`reference_constants` reads every number the parser needs from ``rig_env`` (the driven joint,
the sensors' scales, ``g``, the oscillation's ramp time, the arm length) into
:class:`ReferenceConstants`, plain numbers; :class:`DrivenReference` parses with numpy alone from
them, so a deployed heave/sway law stores them (``ref_*`` entries) and never imports ``rig_env``.
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
    | g0 | m/s^2, the tasks' ``accel_ref`` unit |
    | t_ramp | s, forced oscillation's amplitude ramp (``ForcedOscillation.T_RAMP``) |
    | arm_length | m, the design parameters' ``geometry.arm_length`` |
    """

    joint: str
    angle_scale: float
    rate_scale: float
    airspeed_scale: float
    g0: float
    t_ramp: float
    arm_length: float

    def to_data(self) -> dict[str, Any]:
        """Artefact entries (``ref_*``), JSON values."""
        return {f"ref_{k}": getattr(self, k) for k in self.__dataclass_fields__}

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
        return cls(joint, **vals)




def smooth_ramp(x: np.ndarray) -> np.ndarray:
    """0 for x <= 0, 1 for x >= 1, ``x^2 (3 - 2 x)`` between: the tasks' ramp (``rig_env.envs.tasks.base.smooth_ramp``)."""
    s = np.clip(x, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


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
        self._g0, self._t_ramp = c.g0, c.t_ramp
        cols = {"pull_up_push_over": ("heave_error", "heave_rate_ref", "accel_ref"),
                "forced_oscillation": ("osc_error", "osc_rate_error", "osc_sin", "osc_cos", "osc_amplitude", "osc_frequency"),
                "free_flight_emulation": ("alpha_error", "accel_ref", "input_active")}[spec.task]
        self._c = {name: ix(name) for name in cols}
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
        c = self._c
        if self.spec.task == "pull_up_push_over":
            e = obs[:, c["heave_error"]] * 10.0 * D
            w = obs[:, c["heave_rate_ref"]] * 5.0
            a = obs[:, c["accel_ref"]] * self._g0 / (self.l * np.cos(th + e))
        elif self.spec.task == "forced_oscillation":
            e = obs[:, c["osc_error"]] * 10.0 * D
            w = obs[:, c["osc_rate_error"]] * 5.0 + rate
            sn, cs = obs[:, c["osc_sin"]], obs[:, c["osc_cos"]]
            on = (sn != 0.0) | (cs != 0.0)
            amp, om = obs[:, c["osc_amplitude"]] * 10.0 * D, 2.0 * math.pi * obs[:, c["osc_frequency"]]
            T = self._t_ramp
            x = self.clock / T
            env, denv = smooth_ramp(x), np.where(x < 1.0, 6.0 * x * (1.0 - x), 0.0) / T
            ddenv = np.where(x < 1.0, 6.0 * (1.0 - 2.0 * x), 0.0) / T**2
            a = np.where(on, amp * ((ddenv - env * om**2) * sn + 2.0 * denv * om * cs), 0.0)
            self.clock = np.where(on, self.clock + self.dt, 0.0)
        else:
            V = np.maximum(obs[:, self._air] * self._scale[2], 5.0)
            self.th_ref = np.where(self.fresh, th, self.th_ref)
            self.th_base = np.where(self.fresh, th, self.th_base)
            on = obs[:, c["input_active"]] > 0.5
            a = np.where(on, obs[:, c["accel_ref"]] * self._g0 / (self.l * np.cos(th)), 0.0)
            self.w_ref = self.w_ref + self.dt * (a - self.w_ref / WASHOUT_S)
            w = self.w_ref - self.c_alpha * (V / self.l) * obs[:, c["alpha_error"]] * 5.0 * D
            e = self.th_ref - th
            self.th_ref = self.th_ref + self.dt * (w - (self.th_ref - self.th_base) / WASHOUT_S)
        self.fresh[:] = False
        return e, w, a

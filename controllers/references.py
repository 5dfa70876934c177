"""``DrivenReference``: the driven rig joint's reference (angle error, rate, acceleration) read off a heave/sway task's observation.

The heave and sway laws (:mod:`controllers.heave_sway`) drive one rig joint (rig_pitch or rig_yaw)
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
"""

from __future__ import annotations

import math

import numpy as np

from controllers.base import LoopSpec, UnsupportedTask
from rig_env.envs.sensors import AIRSPEED_SCALE, ANGLE_SCALE, RATE_SCALE
from rig_env.envs.tasks.base import G0, smooth_ramp
from rig_env.envs.tasks.oscillation import AXES as OSC_AXES, ForcedOscillation
from rig_env.params import RigParams

D = math.pi / 180.0
WASHOUT_S = 1.0
"""Time constant of the free-flight emulation's heave washout, s."""
C_ALPHA = 2.0
"""Gain of the alpha-error correction on the rate reference, in units of V / l (hand-searched over 0.5-4 on 12 episodes, gusts off: 2 gave the lowest median emulation error, 0.72)."""
TASKS = ("pull_up_push_over", "forced_oscillation", "free_flight_emulation")


def driven_joint(spec: LoopSpec) -> str:
    """The rig joint the task drives; UnsupportedTask for other tasks or with rig_roll free."""
    if spec.task not in TASKS:
        raise UnsupportedTask(f"task {spec.task!r}: the heave/sway laws fly {list(TASKS)}")
    if "rig_roll" in spec.free_dofs:
        raise UnsupportedTask(f"free_dofs = {list(spec.free_dofs)}: the heave/sway laws need rig_roll locked")
    j = OSC_AXES[spec.task_options.get("axis", "heave_pitch")][0] if spec.task == "forced_oscillation" else "rig_pitch"
    if j not in spec.free_dofs:
        raise UnsupportedTask(f"free_dofs = {list(spec.free_dofs)}: task {spec.task!r} drives {j}, which is locked")
    return j


class DrivenReference:
    """Parser built once per law; :meth:`__call__` returns ``(e, w_ref, a_ref)`` (n,) each, rad, rad/s, rad/s^2."""

    def __init__(self, spec: LoopSpec, num_envs: int, params: RigParams) -> None:
        self.spec, self.n, self.dt = spec, int(num_envs), float(spec.dt)
        self.joint = driven_joint(spec)
        ix = spec.index
        self._angle = ix(f"{self.joint}_angle")
        self._rate = ix(f"{self.joint}_rate")
        self._air = ix("airspeed")
        self.l = float(params.geometry.arm_length)
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
        return obs[:, self._angle] * ANGLE_SCALE, obs[:, self._rate] * RATE_SCALE[self.joint]

    def __call__(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        th, rate = self.theta(obs)
        c = self._c
        if self.spec.task == "pull_up_push_over":
            e = obs[:, c["heave_error"]] * 10.0 * D
            w = obs[:, c["heave_rate_ref"]] * 5.0
            a = obs[:, c["accel_ref"]] * G0 / (self.l * np.cos(th + e))
        elif self.spec.task == "forced_oscillation":
            e = obs[:, c["osc_error"]] * 10.0 * D
            w = obs[:, c["osc_rate_error"]] * 5.0 + rate
            sn, cs = obs[:, c["osc_sin"]], obs[:, c["osc_cos"]]
            on = (sn != 0.0) | (cs != 0.0)
            amp, om = obs[:, c["osc_amplitude"]] * 10.0 * D, 2.0 * math.pi * obs[:, c["osc_frequency"]]
            x = self.clock / ForcedOscillation.T_RAMP
            T = ForcedOscillation.T_RAMP
            env, denv = smooth_ramp(x), np.where(x < 1.0, 6.0 * x * (1.0 - x), 0.0) / T
            ddenv = np.where(x < 1.0, 6.0 * (1.0 - 2.0 * x), 0.0) / T**2
            a = np.where(on, amp * ((ddenv - env * om**2) * sn + 2.0 * denv * om * cs), 0.0)
            self.clock = np.where(on, self.clock + self.dt, 0.0)
        else:
            V = np.maximum(obs[:, self._air] * AIRSPEED_SCALE, 5.0)
            self.th_ref = np.where(self.fresh, th, self.th_ref)
            self.th_base = np.where(self.fresh, th, self.th_base)
            on = obs[:, c["input_active"]] > 0.5
            a = np.where(on, obs[:, c["accel_ref"]] * G0 / (self.l * np.cos(th)), 0.0)
            self.w_ref = self.w_ref + self.dt * (a - self.w_ref / WASHOUT_S)
            w = self.w_ref - self.c_alpha * (V / self.l) * obs[:, c["alpha_error"]] * 5.0 * D
            e = self.th_ref - th
            self.th_ref = self.th_ref + self.dt * (w - (self.th_ref - self.th_base) / WASHOUT_S)
        self.fresh[:] = False
        return e, w, a

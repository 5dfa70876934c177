"""Forced heave-pitch or sway-yaw oscillation (Table 1): drive the rig at a commanded amplitude and frequency."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from rig_env.envs.tasks.base import D, Task, smooth_ramp
from rig_env.params import JOINTS

AXES: dict[str, tuple[str, tuple[str, ...], tuple[float, float]]] = {
    # axis: (driven joint, default free joints, base angle range in deg)
    "heave_pitch": ("rig_pitch", ("rig_pitch", "model_pitch"), (1.0, 7.0)),
    "sway_yaw": ("rig_yaw", ("rig_yaw", "model_yaw"), (-3.0, 3.0)),
}


class ForcedOscillation(Task):
    """Drive a heave (rig pitch) or sway (rig yaw) oscillation at a commanded amplitude and frequency.

    Option ``axis`` (``task_options={"axis": ...}``): ``"heave_pitch"`` (default; drives rig_pitch,
    the model free in pitch) or ``"sway_yaw"`` (drives rig_yaw, the model free in yaw).

    Reference (per episode: amplitude A ~ U(2, 6) deg, frequency f ~ U(0.25, 1.0) Hz, base angle
    theta_b ~ U(1, 7) deg for heave (around the rig's zero-input trim of about 4 deg: the oscillation spans
    -5 to 13 deg, about ``PullUpPushOver.HOLDABLE_DEG``; the paper's model trims at 7 deg) or U(-3, 3) deg
    for sway):

        theta_ref(t) = theta_b + A e(t) sin(phi),  phi = 2 pi f (t - 0.5 s),
        e(t) = smooth_ramp((t - 0.5 s) / 1 s)      (0 before 0.5 s, 1 after 1.5 s, C1)

    and its exact derivative theta_ref'.  The peak acceleration A (2 pi f)^2 stays below 4.2 rad/s^2.

    | appended observation | meaning | normalisation |
    |---|---|---|
    | osc_error | theta_ref - measured driven angle | / 10 deg, clipped to +-5 |
    | osc_rate_error | theta_ref' - estimated driven rate | / 5 rad/s, clipped to +-5 |
    | osc_sin, osc_cos | sin phi, cos phi of the commanded oscillation (0 before it starts) | - |
    | osc_amplitude | A | / 10 deg |
    | osc_frequency | f | / 1 Hz |

    Reward (the form of :mod:`.base`): tracking cost ``c = (e / 2 deg)^2 + (e_rate / 15 deg/s)^2``.
    Metrics: RMS error of the driven angle, deg; an oscillation has no step, so rise time, settling
    time and overshoot are NaN (segment id -1 throughout).  Over the steady part (t >= 1.5 s) the
    driven angle is fitted by least squares with ``theta_b + c0 + a sin(phi) + b cos(phi)``:
    ``amplitude_ratio`` = hypot(a, b) / A and ``phase_lag_deg`` = atan2(-b, a) (response behind the
    command, deg) are added to the episode's info (NaN with fewer than 3 samples).  Success: reached the time limit with RMS
    error below 0.3 A.  Defaults: free joints of the axis (the driven one required), airspeed
    U(18, 22) m/s, 10 s.  Initial state: driven joint theta_b +- 1 deg, the others +- 3 deg, at rest.
    The criterion is within reach: a PID on osc_error / osc_rate_error (compensator elevator for heave,
    rudder for sway; three hand-searched gains) succeeded in 31 of 32 heave and 24 of 32 sway episodes.
    """

    name = "forced_oscillation"
    default_free_dofs = AXES["heave_pitch"][1]
    default_airspeed = (18.0, 22.0)
    default_episode_seconds = 10.0
    ref_labels = ("osc_error", "osc_rate_error", "osc_sin", "osc_cos", "osc_amplitude", "osc_frequency")
    ref_scales = {"osc_error": 10.0 * D, "osc_rate_error": 5.0, "osc_sin": 1.0, "osc_cos": 1.0, "osc_amplitude": 10.0 * D,
                  "osc_frequency": 1.0}
    """Units (rad, rad/s, -, rad, Hz) per normalised value of the appended entries (the table above); the
    observation divides by them."""
    n_draws = 3 + 5
    T_LEAD, T_RAMP = 0.5, 1.0
    """s: the oscillation starts T_LEAD after the episode's start and its envelope e(t) rises over T_RAMP
    (``smooth_ramp``); a law rebuilding theta_ref'' from osc_sin / osc_cos times the envelope from their onset."""

    @classmethod
    def check_options(cls, options: Mapping[str, Any]) -> dict[str, Any]:
        unknown = sorted(set(options) - {"axis"})
        if unknown:
            raise ValueError(f"task_options: unknown name(s) {unknown} for task {cls.name!r}; valid: ['axis']")
        axis = options.get("axis", "heave_pitch")
        if not isinstance(axis, str) or axis not in AXES:
            raise ValueError(f"task_options['axis'] = {axis!r}: allowed {sorted(AXES)}")
        return {"axis": axis}

    @classmethod
    def free_dofs_for(cls, options: Mapping[str, Any]) -> tuple[str, ...]:
        return AXES[cls.check_options(options)["axis"]][1]

    @classmethod
    def driven_joint(cls, options: Mapping[str, Any]) -> str:
        """rig_pitch for ``axis="heave_pitch"`` (the default), rig_yaw for ``"sway_yaw"``."""
        return AXES[cls.check_options(options)["axis"]][0]

    def __init__(self, n_envs: int, free_dofs: tuple[str, ...], dt: float, episode_seconds: float, **options: Any) -> None:
        super().__init__(n_envs, free_dofs, dt, episode_seconds, **options)
        self.axis = self.options["axis"]
        driven, _, self.base_deg = AXES[self.axis]
        if driven not in free_dofs:
            raise ValueError(f"task {self.name!r} (axis {self.axis!r}) needs free joint(s) {[driven]}; free_dofs = {list(free_dofs)}")
        self.j, self.c = JOINTS.index(driven), self.col(driven)
        self.display_label = f"{driven.replace('_', ' ')}, deg"
        self.display_joint, self.display_rate = self.j, (self.j, 1)
        self.A, self.f, self.theta_b = np.zeros(n_envs), np.ones(n_envs), np.zeros(n_envs)
        self.sums = np.zeros((n_envs, 9))  # least-squares sums: 1, s, c, s^2, s c, c^2, y, y s, y c

    def reset(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.base_deg
        self.A[idx] = (2.0 + 4.0 * u[:, 0]) * D
        self.f[idx] = 0.25 + 0.75 * u[:, 1]
        self.theta_b[idx] = (lo + (hi - lo) * u[:, 2]) * D
        self.sums[idx] = 0.0
        q0, qd0 = self.initial_state(idx, u[:, 3:])
        q0[:, self.j] = self.theta_b[idx] + q0[:, self.j] / 3.0
        return q0, qd0

    def reference(self, t: np.ndarray) -> np.ndarray:
        """(n, 5): theta_ref (rad), theta_ref' (rad/s), phase phi (rad), A (rad), f (Hz)."""
        w = 2.0 * math.pi * self.f
        tau = t - self.T_LEAD
        x = np.clip(tau / self.T_RAMP, 0.0, 1.0)
        e = smooth_ramp(x)
        de = 6.0 * x * (1.0 - x) / self.T_RAMP
        phi = w * np.maximum(tau, 0.0)
        th = self.theta_b + self.A * e * np.sin(phi)
        thd = self.A * (de * np.sin(phi) + e * w * np.cos(phi))
        return np.stack([th, thd, phi, self.A, self.f], axis=1)

    def advance(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> None:
        """Accumulate the least-squares sums of the steady part (envelope 1)."""
        steady = t >= self.T_LEAD + self.T_RAMP - 1e-9
        phi = 2.0 * math.pi * self.f * (t - self.T_LEAD)
        sn, cs, y = np.sin(phi), np.cos(phi), q[:, self.j] - self.theta_b
        terms = np.stack([np.ones_like(y), sn, cs, sn * sn, sn * cs, cs * cs, y, y * sn, y * cs], axis=1)
        self.sums += np.where(steady[:, None], terms, 0.0)

    def episode_metrics(self, idx: np.ndarray) -> dict[str, np.ndarray]:
        """``amplitude_ratio`` (-) and ``phase_lag_deg`` of the steady response of envs idx."""
        S = self.sums[idx]
        G = np.stack([S[:, [0, 1, 2]], S[:, [1, 3, 4]], S[:, [2, 4, 5]]], axis=1)  # normal equations (m, 3, 3)
        ok = S[:, 0] >= 3.0
        G[~ok] = np.eye(3)
        c = np.linalg.solve(G, S[:, 6:9][:, :, None])[:, :, 0]
        ratio = np.where(ok, np.hypot(c[:, 1], c[:, 2]) / self.A[idx], np.nan)
        lag = np.where(ok, np.degrees(np.arctan2(-c[:, 2], c[:, 1])), np.nan)
        return {"amplitude_ratio": ratio, "phase_lag_deg": lag}

    def observation(self, ref: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        on = ref[:, 2] > 0.0
        sc = self.ref_scales
        obs = np.stack([
            (ref[:, 0] - angles[:, self.c]) / sc["osc_error"],
            (ref[:, 1] - rates[:, self.c]) / sc["osc_rate_error"],
            np.where(on, np.sin(ref[:, 2]), 0.0) / sc["osc_sin"],
            np.where(on, np.cos(ref[:, 2]), 0.0) / sc["osc_cos"],
            ref[:, 3] / sc["osc_amplitude"],
            ref[:, 4] / sc["osc_frequency"],
        ], axis=1)
        return np.clip(obs, self.obs_low, self.obs_high)

    def reward(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        c = ((ref[:, 0] - q[:, self.j]) / (2.0 * D)) ** 2 + ((ref[:, 1] - qd[:, self.j]) / (15.0 * D)) ** 2
        return self.shaped_reward(c, a, a_prev)

    def tracked(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, ...]:
        y = q[:, self.j]
        return np.full(self.n, -1), y, ref[:, 0], (ref[:, 0] - y) / D, np.full(self.n, 0.5 * D)

    def success(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, metrics: dict[str, np.ndarray]) -> np.ndarray:
        return metrics["rms_error"] * D < 0.3 * ref[:, 3]

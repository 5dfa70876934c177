"""Pull-up / push-over (Table 1): a rig-pitch (heave) profile that gives the model a commanded normal-acceleration history."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from rig_env.envs.tasks.base import G0, D, Task, sign_of


def pulse_heave(tau: np.ndarray, T: np.ndarray, A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One-period sine of normal acceleration and its integrals: (a, v, x) at time tau (n,) into the pulse.

    a(tau) = A sin(w tau) on [0, T] (w = 2 pi / T), zero outside; v and x are its first and second
    integrals from tau = 0: v = (A / w)(1 - cos w tau) -> 0 at tau = T, x = (A / w)(tau - sin(w tau) / w)
    -> A T^2 / (2 pi) at tau = T.  Units: A m/s^2, T s; a m/s^2, v m/s, x m.
    """
    w = 2.0 * math.pi / T
    s = np.clip(tau, 0.0, T)
    a = np.where((tau > 0.0) & (tau < T), A * np.sin(w * s), 0.0)
    v = (A / w) * (1.0 - np.cos(w * s))
    x = (A / w) * (s - np.sin(w * s) / w)  # v = 0 after the pulse: x holds
    return a, v, x


class PullUpPushOver(Task):
    """Fly the rig's heave (rig pitch) so that the model feels a pull-up / push-over normal-acceleration history.

    Target normal acceleration (vertical, up positive, increment over the 1 g of steady flight): per
    episode a base rig pitch theta_b ~ U(1, 7) deg (about the rig's zero-input trim of 4 deg), a heave step
    of rig pitch dtheta ~ U(4, min(10, room)) deg with a random sign s, room being the distance from theta_b
    to the end of ``HOLDABLE_DEG`` in that direction (5-11 deg), a manoeuvre time T ~ U(0.7, 1.4) s and a
    hold T_h ~ U(1, 2) s.  The held rig pitch theta_1 = theta_b + s dtheta stays within HOLDABLE_DEG =
    [-4, 12] deg, where the compensator can hold the arm: the trim at the ends needs 72-81 % of its 40 deg
    heave deflection at 15-25 m/s (``rig_env.trim`` holding rig_pitch with comp_elevator as the unknown,
    default rig: -4 deg 80-81 %, 12 deg 81 % at 15 m/s, 72 % at 25 m/s), leaving a fifth of the authority to
    regulate with; 15 deg needs more than all of it.  (The paper's model, ``RigParams.paper()``, trims at
    7 deg and held [-1, 15] deg with these shares.)  Holds out of reach fail every law: with the steps drawn
    U(4, 10) deg either way, theta_1 spanned [-6, 20] deg, and in 7 of the comparison's 64 nominal episodes
    every law (LQR, PID, PPO) held the flap on its stop through the hold and missed the band by 0.6-3 deg.
    With l the arm length (pivot to model gimbal), H = l (sin(theta_b + s dtheta) - sin theta_b) and A = 2 pi H / T^2:

        a_n(t) = A sin(2 pi (t - t1) / T)   on [t1, t1 + T],  t1 = 1 s        (pull-up then push-over, s > 0)
               - A sin(2 pi (t - t2) / T)   on [t2, t2 + T],  t2 = t1 + T + T_h (the reverse, back to theta_b)
               0 elsewhere.

    The model gimbal sits at height h = l sin(theta) above the pivot (rig_pitch theta, positive nose
    of the arm up), so its vertical acceleration is d2/dt2 (l sin theta).  Integrating a_n twice from
    h_b = l sin(theta_b) at rest gives h_ref(t) (:func:`pulse_heave`) and the rig-pitch reference

        theta_ref = asin(h_ref / l),   theta_ref' = h_ref' / (l cos theta_ref),

    exact for the vertical acceleration of the gimbal (the component along the flight path,
    angle atan(h' / V) below 1.5 deg here, is neglected).  Peak |a_n| = 2 pi |H| / T^2: 0.018-0.18 g;
    rig pitch stays within [-4, 12] deg (stops +-25 deg).

    | appended observation | meaning | normalisation |
    |---|---|---|
    | heave_error | theta_ref - measured rig pitch | / 10 deg, clipped to +-5 |
    | heave_rate_ref | theta_ref' | / 5 rad/s |
    | heave_rate_error | theta_ref' - estimated rig-pitch rate | / 5 rad/s, clipped to +-5 |
    | accel_ref | a_n | / 9.81 m/s^2 (load-factor increment) |
    | heave_error_int | integral of heave_error (measured) from the episode's start, held within +-5 deg s | / 1 deg s |

    ``heave_error_int`` is the integral action a law needs to hold theta_1 within the band: the trim
    deflection of a hold depends on what the observation does not show (the Hawk's mass, +-10 % under the
    comparison's nominal conditions, friction), and a policy, a static map of its observation, cannot
    integrate.  Without the entry the PPO policy held 0.5-0.8 deg off in 9 of the comparison's 64 nominal
    episodes (its hold error followed the Hawk's mass, 0.23 deg per 10 %, correlation -0.81); the designed
    LQR integrates the same error (its integral state).  Summed once per control step (an autoreset's second
    observation within a step adds nothing), zeroed at reset.

    Reward (the form of :mod:`.base`): tracking cost ``c = (e_theta / 0.5 deg)^2 + (e_rate / 15 deg/s)^2``
    (``ANGLE_SCALE``): the angle on the settling band's own scale, so that a hold outside the band costs the
    precision term more than 60 %.  A 2.5 deg scale left 0.5-1 deg errors, which fail the criterion, with
    96-99 % of the precision term (trained policies settled outside the band in 78 % of episodes); twice the
    band (1 deg) still paid 60-78 % for the 0.5-0.7 deg steady hold errors that were then most of the
    failures (policy success 78 % on the comparison's 64 nominal episodes; 86 % with 0.5 deg).
    Metrics: segment 0 the first manoeuvre (rig pitch to theta_b + s dtheta), segment 1 the return to
    theta_b, band 0.5 deg; RMS error is the rig-pitch error, deg.  Success: reached the time limit,
    both segments settled, final |rig-pitch error| < 1 deg.
    Defaults: free rig_pitch and model_pitch (rig_pitch required), airspeed U(18, 22) m/s, 8 s.
    Initial state: rig pitch theta_b +- 1 deg, model pitch +- 3 deg, at rest.
    The criterion is within reach: a PID on heave_error / heave_rate_error driving the compensator
    elevator (three gains, hand-searched) succeeded in 27 of 32 episodes; zero action in none (the paper's
    model).  On the default rig, with the holds within the compensator's authority, the designed LQR succeeds
    in 95 % of the comparison's 64 nominal episodes (98 % on the paper's model), the PPO policy in 94 %, the
    designed PID in 80 % (48 % before its cascade was shaped with its decoupling in the plant; 67 % on the paper's model).
    """

    name = "pull_up_push_over"
    display_label, display_joint, display_rate = "rig pitch (heave), deg", 1, (1, 1)
    default_free_dofs = ("rig_pitch", "model_pitch")
    default_airspeed = (18.0, 22.0)
    default_episode_seconds = 8.0
    required = ("rig_pitch",)
    ref_labels = ("heave_error", "heave_rate_ref", "heave_rate_error", "accel_ref", "heave_error_int")
    ref_scales = {"heave_error": 10.0 * D, "heave_rate_ref": 5.0, "heave_rate_error": 5.0, "accel_ref": G0, "heave_error_int": 1.0 * D}
    """Units (rad, rad/s, m/s^2) per normalised value of the appended entries (the table above); the observation
    divides by them.  A law rebuilding theta_ref'' = a_n / (l cos theta_ref) from ``accel_ref`` uses the
    gimbal's geometry ``h = l sin theta`` of the class docstring."""
    n_draws = 5 + 5
    T_LEAD = 1.0
    ANGLE_SCALE = 0.5 * D
    """rad: the reward's rig-pitch error scale (class docstring)."""
    HOLDABLE_DEG = (-4.0, 12.0)
    """deg: the rig pitch range the held target theta_1 is drawn in (the compensator's trim authority, class docstring)."""

    @classmethod
    def driven_joint(cls, options: Mapping[str, Any]) -> str:
        """rig_pitch: the heave joint."""
        return "rig_pitch"

    REACH_SHARE = 0.85
    """The most of the heave flap's travel a hold at an end of ``HOLDABLE_DEG`` may need (the check of a rig's reach,
    :mod:`controllers.evaluation.reach`): a fifth left to
    regulate with, less a margin for the mass spread (the default rig: 72-81 % at 15-25 m/s, the class docstring)."""

    def __init__(self, n_envs: int, free_dofs: tuple[str, ...], dt: float, episode_seconds: float) -> None:
        super().__init__(n_envs, free_dofs, dt, episode_seconds)
        z = np.zeros(n_envs)
        self.theta_b, self.theta_1, self.A, self.Tm, self.Th = z.copy(), z.copy(), z.copy(), np.ones(n_envs), np.ones(n_envs)
        self.rp = self.col("rig_pitch")
        self.e_int = z.copy()  # integral of the measured heave error, rad s
        self._steps, self._integrated = 0, 0  # control steps advanced / integrated into e_int (once per step)

    def reset(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        l = self.l[idx]
        tb = (1.0 + 6.0 * u[:, 0]) * D
        s = sign_of(u[:, 1])
        lo, hi = self.HOLDABLE_DEG
        room = np.where(s > 0.0, hi * D - tb, tb - lo * D)
        t1 = tb + s * (4.0 * D + (np.minimum(10.0 * D, room) - 4.0 * D) * u[:, 2])
        T = 0.7 + 0.7 * u[:, 3]
        self.theta_b[idx], self.theta_1[idx], self.Tm[idx] = tb, t1, T
        self.Th[idx] = 1.0 + 1.0 * u[:, 4]
        self.A[idx] = 2.0 * math.pi * l * (np.sin(t1) - np.sin(tb)) / T**2
        self.e_int[idx] = 0.0
        q0, qd0 = self.initial_state(idx, u[:, 5:])
        q0[:, 1] = tb + q0[:, 1] / 3.0
        return q0, qd0

    def advance(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> None:
        """Counts the control step: the next observation adds it to the error integral."""
        self._steps += 1

    def t_return(self) -> np.ndarray:
        """(n,) start of the return manoeuvre, s."""
        return self.T_LEAD + self.Tm + self.Th

    def reference(self, t: np.ndarray) -> np.ndarray:
        """(n, 3): theta_ref (rad), theta_ref' (rad/s), a_n (m/s^2)."""
        a1, v1, x1 = pulse_heave(t - self.T_LEAD, self.Tm, self.A)
        a2, v2, x2 = pulse_heave(t - self.t_return(), self.Tm, self.A)
        h = self.l * np.sin(self.theta_b) + x1 - x2
        th = np.arcsin(np.clip(h / self.l, -1.0, 1.0))
        return np.stack([th, (v1 - v2) / (self.l * np.cos(th)), a1 - a2], axis=1)

    def observation(self, ref: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        sc = self.ref_scales
        e = (ref[:, 0] - angles[:, self.rp]) / sc["heave_error"]
        er = (ref[:, 1] - rates[:, self.rp]) / sc["heave_rate_error"]
        if self._integrated != self._steps:  # once per control step (an autoreset observes again within the step)
            lim = self.obs_high[-1] * sc["heave_error_int"]
            self.e_int = np.clip(self.e_int + self.dt * e * sc["heave_error"], -lim, lim)
            self._integrated = self._steps
        obs = np.stack([e, ref[:, 1] / sc["heave_rate_ref"], er, ref[:, 2] / sc["accel_ref"], self.e_int / sc["heave_error_int"]], axis=1)
        return np.clip(obs, self.obs_low, self.obs_high)

    def reward(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        c = ((ref[:, 0] - q[:, 1]) / self.ANGLE_SCALE) ** 2 + ((ref[:, 1] - qd[:, 1]) / (15.0 * D)) ** 2
        return self.shaped_reward(c, a, a_prev)

    def tracked(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, ...]:
        seg = np.where(t <= self.T_LEAD, -1, np.where(t <= self.t_return(), 0, 1))
        target = np.where(seg == 0, self.theta_1, self.theta_b)
        return seg, q[:, 1], target, (ref[:, 0] - q[:, 1]) / D, np.full(self.n, 0.5 * D)

    def success(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, metrics: dict[str, np.ndarray]) -> np.ndarray:
        both = (metrics["segments"] == 2) & (metrics["segments_settled"] == 2)
        return both & (np.abs(ref[:, 0] - q[:, 1]) < 1.0 * D)

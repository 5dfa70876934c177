"""Departure recovery (Table 1, high-incidence departures; paper Sec. VII, Fig. 8): bring the rig back to level."""

from __future__ import annotations

import numpy as np

from rig_env.envs.tasks.base import D, Task

ALPHA_RECOVERED = 10.0 * D  # rad: below the Hawk's CL break (CLmax at 13 deg, RigParams.high_incidence)
RATE_RECOVERED = 30.0 * D  # rad/s: twice the trimmed rig's median peak rate in 1 % turbulence (DepartureRecovery)
# "recovered": every ratio below 1 (rig roll, rig pitch, |alpha|, largest free joint rate)
RECOVERY_SCALES = (10.0 * D, 10.0 * D, 12.0 * D, RATE_RECOVERED)
T_RECOVER = 3.0  # s after the pilot releases the elevator


def static_alpha(q: np.ndarray) -> np.ndarray:
    """(n,) angle of attack, rad, of the model in the tunnel flow at joint angles q (n, 5), joint rates ignored.

    A_a = Rz(rig_yaw) Ry(rig_pitch) Rx(rig_roll) Rz(model_yaw) Ry(model_pitch) (rig_env.physics.
    joint_space); the flow seen by the body is V A_a^T e_x, so alpha = atan2(A_a[0, 2], A_a[0, 0]).
    Only the first row of A_a is needed: written out below.
    """
    cf, sf = np.cos(q[:, 0]), np.sin(q[:, 0])
    ct, st = np.cos(q[:, 1]), np.sin(q[:, 1])
    cp, sp = np.cos(q[:, 2]), np.sin(q[:, 2])
    r0, r1, r2 = cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf  # first row of the arm's rotation
    cy, sy = np.cos(q[:, 4]), np.sin(q[:, 4])
    x, z = r0 * cy + r1 * sy, r2  # times Rz(model_yaw)
    ca, sa = np.cos(q[:, 3]), np.sin(q[:, 3])
    return np.arctan2(x * sa + z * ca, x * ca - z * sa)  # times Ry(model_pitch): columns 2 and 0


def wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-pi, pi)."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


class DepartureRecovery(Task):
    """Bring the rig back to level after a Hawk departure at high angle of attack (nonlinear aerodynamics).

    Uses the high-incidence tables (``aero_model`` defaults to "tables" for this task): the Hawk's lift
    breaks at 13 deg and its pitching moment flattens there.  ``aero_model="unsteady"`` flies the same
    tables through the Hawk's flow-separation state (docs/MODEL.md 3.1.1), whose lag damps the
    post-stall pitch motion: without control all 64 episodes (seed 1, calm air) then recover within 3 s
    of the release (quartiles 2.12, 2.19, 2.36 s against 3.22, 3.49, 3.81 s and none on the tables), so the deadline
    below, measured on the tables, would not discriminate; the default stays on the tables until the
    task's deadline is re-derived for that model and its laws re-validated.  Departure (per episode, uniform):

    | quantity | initial value |
    |---|---|
    | rig roll, rate | +-30 deg, +-60 deg/s |
    | rig pitch, rate | 4-10 deg (about the paper's model's 7 deg trim; the default rig's is 4.4 deg), +-20 deg/s |
    | model pitch, rate | 16-22 deg (past the stall break), +-30 deg/s |
    | model yaw, rate | +-20 deg, +-60 deg/s |

    plus a pilot disturbance (:meth:`pilot_inputs`): the Hawk elevator held nose-up at U(-12, -6) deg
    until U(0.5, 1.5) s, then released to 0.  Locked joints take their locked angle.

    Level error (deg): ``E = sqrt(phi^2 + theta^2 + max(|alpha| - 10 deg, 0)^2)`` with phi the rig roll
    wrapped to +-180 deg, theta the rig pitch and alpha :func:`static_alpha` (joint rates ignored).
    Recovery distance ``r = max(|phi| / 10 deg, |theta| / 10 deg, |alpha| / 12 deg, max_free |qdot_j| /
    30 deg/s)``: recovered while r < 1.  The rate bound sits above the rig's own response to the tunnel's
    turbulence: trimmed at 20 m/s (tables aerodynamics, no control) in 1 % gusts (Gauss-Markov, 0.2 s), the
    largest free joint rate over 6 s peaked at 14-20 deg/s (medians of 16 and 32 runs, the default rig, rig pitch
    4.4 deg; above 30 deg/s in 1 of the 48, 33 deg/s; the paper's model, rig pitch 7.2 deg: 15-17 deg/s, none above).  The earlier 20 deg/s bound was set in calm air; under the
    comparison's 1 % gusts it failed recovered rigs on gust peaks (the PID's failures had roll and pitch
    within 0.2 and 3.4 deg and model-yaw peaks of 21-29 deg/s after the deadline).  30 deg/s is twice the
    median peak and half the departure's initial rates (60 deg/s).

    | appended observation | meaning | normalisation |
    |---|---|---|
    | alpha_est | alpha from the measured angles (locked joints taken at 0) | / 30 deg |
    | alpha_excess | max(|alpha_est| - 10 deg, 0) | / 10 deg |
    | level_error | sqrt(phi^2 + theta^2) from the measured angles | / 30 deg |
    | elevator_cmd | pilot elevator command now | / 10 deg |

    Reward (the form of :mod:`.base`): tracking cost ``c = (phi / 20 deg)^2 + (theta / 15 deg)^2 +
    (max(|alpha| - 10 deg, 0) / 5 deg)^2 + sum_free (qdot_j / 30 deg/s)^2``: the rates on the recovery
    criterion's scale (every free joint rate below 30 deg/s), where a 60 deg/s scale left a rig still
    ringing near the bound, not recovered, with most of the reward; the wide term ranks actions through
    the departure itself (rates up to 60 deg/s, roll up to 30 deg).
    Metrics: one segment from the start with r as the tracked signal, target 0, band 1: the settling
    time is the recovery time (from then on r < 1); overshoot is 0 by construction (r >= 0); RMS
    error is E, deg; ``release_time`` the pilot's release, s.  Success: reached the time limit,
    recovered (settled) within 3 s of the release and stayed recovered.  Without control the rig's lightly damped heave-pitch oscillation
    after the release usually keeps the rates above the bound past that deadline.
    Defaults: free rig_roll, rig_pitch, model_pitch, model_yaw (Fig. 8's roll, model pitch and yaw,
    plus heave so the compensator can act on alpha; model_pitch required), airspeed U(18, 22) m/s, 8 s.
    The deadline discriminates: without control the paper's model recovered 3.2-3.8 s after the release
    (quartiles of 32 episodes in calm air, none within 3 s; 7 of 32 within 3 s in 1 % gusts, which
    sometimes damp the ringing early), the default rig in none of 32 in calm air and 1 of 32 in 1 % gusts
    (seed 1).  Under the comparison's nominal conditions the designed PID recovers 77 % in time on the default
    rig (97 % on the paper's model; 81 % there with the 20 deg/s bound, all of its failures gust peaks after
    recovery), the LQR 92 %, the PPO policy 100 %.
    """

    name = "departure_recovery"
    display_label = "level error E, deg"
    default_free_dofs = ("rig_roll", "rig_pitch", "model_pitch", "model_yaw")
    default_airspeed = (18.0, 22.0)
    default_episode_seconds = 8.0
    default_aero_model = "tables"
    required = ("model_pitch",)
    ref_labels = ("alpha_est", "alpha_excess", "level_error", "elevator_cmd")
    ref_scales = {"alpha_est": 30.0 * D, "alpha_excess": 10.0 * D, "level_error": 30.0 * D, "elevator_cmd": 10.0 * D}
    """Units (rad) per normalised value of the appended entries (the table above); the observation divides by them."""
    n_draws = 8 + 2
    # (low, high) of the initial angle and rate draws, deg and deg/s, JOINTS order
    IC_ANGLE = ((-30.0, 30.0), (4.0, 10.0), (0.0, 0.0), (16.0, 22.0), (-20.0, 20.0))
    IC_RATE = ((-60.0, 60.0), (-20.0, 20.0), (0.0, 0.0), (-30.0, 30.0), (-60.0, 60.0))

    def __init__(self, n_envs: int, free_dofs: tuple[str, ...], dt: float, episode_seconds: float) -> None:
        super().__init__(n_envs, free_dofs, dt, episode_seconds)
        self.de, self.t_rel = np.zeros(n_envs), np.zeros(n_envs)
        self._pilot = np.zeros((n_envs, 3))
        self.rate_cols = self.free_idx

    def reset(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q0, qd0 = np.zeros((idx.size, 5)), np.zeros((idx.size, 5))
        draw = iter(range(8))
        for j in (0, 1, 3, 4):
            (alo, ahi), (rlo, rhi) = self.IC_ANGLE[j], self.IC_RATE[j]
            q0[:, j] = (alo + (ahi - alo) * u[:, next(draw)]) * D
            qd0[:, j] = (rlo + (rhi - rlo) * u[:, next(draw)]) * D
        self.de[idx] = (-12.0 + 6.0 * u[:, 8]) * D
        self.t_rel[idx] = 0.5 + 1.0 * u[:, 9]
        return q0, qd0

    def pilot_inputs(self, t: np.ndarray) -> np.ndarray:
        self._pilot[:, 0] = np.where(t < self.t_rel, self.de, 0.0)
        return self._pilot

    def reference(self, t: np.ndarray) -> np.ndarray:
        """(n, 1): the pilot's elevator command, rad (the target, level, is constant)."""
        return np.where(t < self.t_rel, self.de, 0.0)[:, None]

    def episode_metrics(self, idx: np.ndarray) -> dict[str, np.ndarray]:
        """``release_time``: when the pilot let go of the elevator, s."""
        return {"release_time": self.t_rel[idx].copy()}

    def _angles(self, angles: np.ndarray) -> np.ndarray:
        """(n, 5) joint angles from the measured free ones, locked joints at 0."""
        q = np.zeros((angles.shape[0], 5))
        q[:, self.free_idx] = angles
        return q

    def observation(self, ref: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        q = self._angles(angles)
        alpha = static_alpha(q)
        level = np.hypot(wrap(q[:, 0]), q[:, 1])
        excess = np.maximum(np.abs(alpha) - ALPHA_RECOVERED, 0.0)
        sc = self.ref_scales
        obs = np.stack([alpha / sc["alpha_est"], excess / sc["alpha_excess"], level / sc["level_error"], ref[:, 0] / sc["elevator_cmd"]], axis=1)
        return np.clip(obs, self.obs_low, self.obs_high)

    @staticmethod
    def level_error(q: np.ndarray) -> np.ndarray:
        """(n,) E, rad, of joint angles q (n, 5)."""
        excess = np.maximum(np.abs(static_alpha(q)) - ALPHA_RECOVERED, 0.0)
        return np.sqrt(wrap(q[:, 0]) ** 2 + q[:, 1] ** 2 + excess**2)

    def recovery_distance(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """(n,) r of joint angles and rates (n, 5); recovered while r < 1."""
        s_roll, s_pitch, s_alpha, s_rate = RECOVERY_SCALES
        ratios = (np.abs(wrap(q[:, 0])) / s_roll, np.abs(q[:, 1]) / s_pitch, np.abs(static_alpha(q)) / s_alpha,
                  np.max(np.abs(qd[:, self.rate_cols]), axis=1) / s_rate)
        return np.maximum.reduce(ratios)

    def reward(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        excess = np.maximum(np.abs(static_alpha(q)) - ALPHA_RECOVERED, 0.0)
        c = (wrap(q[:, 0]) / (20.0 * D)) ** 2 + (q[:, 1] / (15.0 * D)) ** 2 + (excess / (5.0 * D)) ** 2
        c = c + np.sum((qd[:, self.rate_cols] / RATE_RECOVERED) ** 2, axis=1)
        return self.shaped_reward(c, a, a_prev)

    def tracked(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, ...]:
        r = self.recovery_distance(q, qd)
        return np.zeros(self.n, dtype=np.int64), r, np.zeros(self.n), self.level_error(q) / D, np.ones(self.n)

    def display(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(level error E, 0), deg: the recovery's target is level."""
        return self.level_error(q) / D, np.zeros(self.n)

    def success(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, metrics: dict[str, np.ndarray]) -> np.ndarray:
        settled = metrics["segments_settled"] == 1
        in_time = metrics["settling_time"] <= metrics["release_time"] + T_RECOVER
        return settled & in_time & (self.recovery_distance(q, qd) < 1.0)

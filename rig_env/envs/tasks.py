"""Tasks: reference generator, reward, termination, initial conditions and success, vectorised over envs.

A task never integrates anything; the environment (:mod:`rig_env.envs.vector_env`) owns the physics
batch and calls the task with (n, ...) arrays at the control rate.  Choose a task by name
(``TASKS``).  Every reward is ``exp(-cost)`` with ``cost >= 0``, so it lies in (0, 1]; a step that
ends the episode by failure (blow-up or a joint beyond its stop margin) earns 0.  Episodes run to
their time limit otherwise, so ending early never pays.

Angles in rad and rates in rad/s inside; the ``*_deg`` names and the metrics' display units are deg.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from rig_env.params import JOINTS, LIMITED_JOINTS
from rig_env.physics import layout as L

D = math.pi / 180.0
STOP_MARGIN = 2.0 * D  # beyond a stop by more than this: terminated
_STOP_COL = {j: getattr(L, f"P_STOPS_{j.upper()}_LOWER_DEG") for j in LIMITED_JOINTS}


class Task:
    """Base class.  Subclasses set the class constants and implement the five vectorised hooks.

    n_draws: uniforms consumed per reset.  ref_labels: names of the observation entries the task
    appends (bounds ``obs_low``/``obs_high``).  band: absolute settling band of the metrics (unit of
    the tracked signal).  required: joints that must be free.
    """

    name: ClassVar[str]
    default_free_dofs: ClassVar[tuple[str, ...]]
    default_airspeed: ClassVar[tuple[float, float]]
    default_episode_seconds: ClassVar[float]
    required: ClassVar[tuple[str, ...]] = ("rig_roll",)
    ref_labels: ClassVar[tuple[str, ...]]
    n_draws: ClassVar[int]
    reward_range: ClassVar[tuple[float, float]] = (0.0, 1.0)

    def __init__(self, n_envs: int, free_dofs: tuple[str, ...], dt: float, episode_seconds: float) -> None:
        missing = [j for j in self.required if j not in free_dofs]
        if missing:
            raise ValueError(f"task {self.name!r} needs free joint(s) {missing}; free_dofs = {list(free_dofs)}")
        self.n, self.free, self.dt, self.T = n_envs, free_dofs, dt, episode_seconds
        self.free_idx = np.array([JOINTS.index(j) for j in free_dofs])
        self.meas_roll = free_dofs.index("rig_roll")  # column of rig_roll in the measured joints
        self.limited = np.array([JOINTS.index(j) for j in free_dofs if j in LIMITED_JOINTS], dtype=np.int64)
        self.obs_low = -np.full(len(self.ref_labels), 5.0)
        self.obs_high = np.full(len(self.ref_labels), 5.0)

    # ------------------------------------------------------------------ shared pieces
    def initial_state(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(m, 5) angles and rates: free joints other than rig_roll uniform in +-3 deg, at rest."""
        q = np.zeros((idx.size, 5))
        q[:, self.free_idx] = (2.0 * u[:, : len(self.free_idx)] - 1.0) * 3.0 * D
        return q, np.zeros((idx.size, 5))

    def limits(self, q: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(on a stop, beyond a stop by more than STOP_MARGIN), each (n,) bool, free limited joints."""
        on = np.zeros(q.shape[0], dtype=bool)
        beyond = np.zeros(q.shape[0], dtype=bool)
        for j in self.limited:
            col = _STOP_COL[JOINTS[j]]
            lo, hi = P[:, col], P[:, col + 1]  # rad (to_vector converts *_deg)
            on |= (q[:, j] <= lo) | (q[:, j] >= hi)
            beyond |= (q[:, j] < lo - STOP_MARGIN) | (q[:, j] > hi + STOP_MARGIN)
        return on, beyond

    @staticmethod
    def _control_cost(a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        return 0.05 * np.mean(a**2, axis=1) + 0.05 * np.mean((a - a_prev) ** 2, axis=1)

    # ------------------------------------------------------------------ hooks
    def reset(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Draw references and initial states of envs idx from uniforms u (m, n_draws); returns (q0, qd0)."""
        raise NotImplementedError

    def reference(self, t: np.ndarray) -> np.ndarray:
        """(n, k) reference signals at times t (n,), s."""
        raise NotImplementedError

    def observation(self, ref: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        """(n, len(ref_labels)) from the reference and the measured angles/rates of the free joints."""
        raise NotImplementedError

    def reward(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, a: np.ndarray, a_prev: np.ndarray) -> np.ndarray:
        """(n,) in (0, 1] from the true state (q, qd: (n, 5)) and normalised actions."""
        raise NotImplementedError

    def tracked(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, ...]:
        """(segment id, y, segment target, error in display units, settling band) for the metrics."""
        raise NotImplementedError

    def success(self, q: np.ndarray, qd: np.ndarray, ref: np.ndarray, metrics: dict[str, np.ndarray]) -> np.ndarray:
        """(m,) bool for envs that reached their time limit (rows of q, qd, ref, metrics)."""
        raise NotImplementedError


class VelocityVectorRoll(Task):
    """Spin the rig up to a commanded roll rate, hold it, then stop at a commanded angle.

    Reference (per episode: start angle phi0 ~ U(-10, 10) deg, rate R ~ +-U(90, 360) deg/s with a
    random sign, hold T_h ~ U(1, 3) s, stop ramp T_d ~ U(0.5, 1.5) s): roll rate 0 until 0.5 s, a
    0.5 s linear ramp to R, R for T_h, a linear ramp to 0 over T_d, then 0; the roll-angle reference
    is its integral from phi0, so the stop angle is phi0 + R (0.25 + T_h + T_d / 2).

    | appended observation | meaning | normalisation |
    |---|---|---|
    | roll_error | reference - measured roll angle | / 45 deg, clipped to +-5 |
    | roll_rate_ref | reference roll rate | / 12 rad/s |
    | roll_rate_error | reference - estimated roll rate | / 12 rad/s, clipped to +-5 |

    Reward ``exp(-(e_phi / 10 deg)^2 - (e_p / 60 deg/s)^2 - 0.05 mean(a^2) - 0.05 mean(da^2))``.
    Metrics: segment 0 the spin-up (roll rate to R, band 5 deg/s), segment 1 the stop (roll angle to
    the stop angle, band 2 deg); RMS error is the roll-angle error, deg.  Success: reached the time
    limit with |roll error| < 5 deg and |roll rate| < 20 deg/s.
    """

    name = "velocity_vector_roll"
    default_free_dofs = ("rig_roll", "model_pitch")
    default_airspeed = (18.0, 22.0)
    default_episode_seconds = 8.0
    ref_labels = ("roll_error", "roll_rate_ref", "roll_rate_error")
    n_draws = 5 + 5  # 4 reference draws (+1 spare), 5 initial angles
    T_START, T_RAMP = 0.5, 0.5

    def __init__(self, n_envs: int, free_dofs: tuple[str, ...], dt: float, episode_seconds: float) -> None:
        super().__init__(n_envs, free_dofs, dt, episode_seconds)
        self.phi0, self.R, self.Th, self.Td = np.zeros(n_envs), np.zeros(n_envs), np.ones(n_envs), np.ones(n_envs)

    def reset(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.phi0[idx] = (20.0 * u[:, 0] - 10.0) * D
        self.R[idx] = np.where(u[:, 1] < 0.5, -1.0, 1.0) * (90.0 + 270.0 * u[:, 2]) * D
        self.Th[idx] = 1.0 + 2.0 * u[:, 3]
        self.Td[idx] = 0.5 + 1.0 * u[:, 4]
        q0, qd0 = self.initial_state(idx, u[:, 5:])
        q0[:, 0] = self.phi0[idx]
        return q0, qd0

    def _phases(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        t1 = self.T_START + self.T_RAMP + self.Th
        s1 = np.clip(t - self.T_START, 0.0, self.T_RAMP)
        s2 = np.clip(t - self.T_START - self.T_RAMP, 0.0, self.Th)
        s3 = np.clip(t - t1, 0.0, self.Td)
        return s1, s2, s3, t1

    def reference(self, t: np.ndarray) -> np.ndarray:
        s1, s2, s3, t1 = self._phases(t)
        phi = self.phi0 + self.R * (s1**2 / (2 * self.T_RAMP) + s2 + s3 - s3**2 / (2 * self.Td))
        p = self.R * np.where(t < self.T_START + self.T_RAMP, s1 / self.T_RAMP, np.where(t < t1, 1.0, 1.0 - s3 / self.Td))
        return np.stack([phi, p], axis=1)

    def stop_angle(self) -> np.ndarray:
        return self.phi0 + self.R * (0.5 * self.T_RAMP + self.Th + 0.5 * self.Td)

    def observation(self, ref: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        e = (ref[:, 0] - angles[:, self.meas_roll]) / (45.0 * D)
        ep = (ref[:, 1] - rates[:, self.meas_roll]) / 12.0
        return np.clip(np.stack([e, ref[:, 1] / 12.0, ep], axis=1), self.obs_low, self.obs_high)

    def reward(self, q, qd, ref, a, a_prev):
        c = ((ref[:, 0] - q[:, 0]) / (10 * D)) ** 2 + ((ref[:, 1] - qd[:, 0]) / (60 * D)) ** 2
        return np.exp(-(c + self._control_cost(a, a_prev)))

    def tracked(self, t, q, qd, ref):
        t1 = self.T_START + self.T_RAMP + self.Th
        seg = np.where(t <= self.T_START, -1, np.where(t <= t1, 0, 1))
        y = np.where(seg == 0, qd[:, 0], q[:, 0])
        r = np.where(seg == 0, self.R, self.stop_angle())
        band = np.where(seg == 0, 5.0 * D, 2.0 * D)
        return seg, y, r, (ref[:, 0] - q[:, 0]) / D, band

    def success(self, q, qd, ref, metrics):
        return (np.abs(ref[:, 0] - q[:, 0]) < 5 * D) & (np.abs(qd[:, 0]) < 20 * D)


class BankToBank(Task):
    """Roll-angle steps between banks: the paper's 4-DOF set (rig roll, rig yaw, model pitch, model yaw).

    Reference: phi0 ~ U(-5, 5) deg until 1 s, then every 4 s a step to the next bank: magnitudes
    U(30, 90) deg, signs alternating from a random first sign.  Airspeed U(15, 20) m/s.

    | appended observation | meaning | normalisation |
    |---|---|---|
    | roll_error | reference - measured roll angle | / 45 deg, clipped to +-5 |
    | roll_ref | reference bank angle | / 90 deg |

    Reward ``exp(-(e_phi / 15 deg)^2 - 0.25 (rig_yaw / 20 deg)^2 - 0.05 mean(a^2) - 0.05 mean(da^2))``
    (rig_yaw term only when it is free).  Metrics: one segment per bank step (band 2 deg); RMS error is
    the roll-angle error, deg.  Success: reached the time limit, every step settled, final |error| < 5 deg.
    """

    name = "bank_to_bank"
    default_free_dofs = ("rig_roll", "rig_yaw", "model_pitch", "model_yaw")
    default_airspeed = (15.0, 20.0)
    default_episode_seconds = 17.0
    ref_labels = ("roll_error", "roll_ref")
    T_START, T_SEG = 1.0, 4.0
    N_SEG = 8  # enough for 33 s; later steps repeat the last bank
    n_draws = 2 + N_SEG + 5

    def __init__(self, n_envs: int, free_dofs: tuple[str, ...], dt: float, episode_seconds: float) -> None:
        super().__init__(n_envs, free_dofs, dt, episode_seconds)
        self.phi0 = np.zeros(n_envs)
        self.banks = np.zeros((n_envs, self.N_SEG))
        self.yaw = "rig_yaw" in free_dofs

    def reset(self, idx: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.phi0[idx] = (10.0 * u[:, 0] - 5.0) * D
        first = np.where(u[:, 1] < 0.5, -1.0, 1.0)
        alt = first[:, None] * (-1.0) ** np.arange(self.N_SEG)[None, :]
        self.banks[idx] = alt * (30.0 + 60.0 * u[:, 2 : 2 + self.N_SEG]) * D
        q0, qd0 = self.initial_state(idx, u[:, 2 + self.N_SEG :])
        q0[:, 0] = self.phi0[idx]
        return q0, qd0

    def _segment(self, t: np.ndarray) -> np.ndarray:
        k = np.floor((t - self.T_START) / self.T_SEG + 1e-9).astype(np.int64)
        return np.where(t < self.T_START - 1e-9, -1, np.minimum(k, self.N_SEG - 1))

    def reference(self, t: np.ndarray) -> np.ndarray:
        k = self._segment(t)
        bank = self.banks[np.arange(self.n), np.maximum(k, 0)]
        return np.where(k < 0, self.phi0, bank)[:, None]

    def observation(self, ref: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> np.ndarray:
        e = (ref[:, 0] - angles[:, self.meas_roll]) / (45.0 * D)
        return np.clip(np.stack([e, ref[:, 0] / (90.0 * D)], axis=1), self.obs_low, self.obs_high)

    def reward(self, q, qd, ref, a, a_prev):
        c = ((ref[:, 0] - q[:, 0]) / (15 * D)) ** 2
        if self.yaw:
            c = c + 0.25 * (q[:, 2] / (20 * D)) ** 2
        return np.exp(-(c + self._control_cost(a, a_prev)))

    def tracked(self, t, q, qd, ref):
        # a step segment starts on the step; the metrics' segment clock starts one step earlier
        seg = self._segment(t - self.dt)
        target = np.where(seg < 0, self.phi0, self.banks[np.arange(self.n), np.maximum(seg, 0)])
        return seg, q[:, 0], target, (ref[:, 0] - q[:, 0]) / D, np.full(self.n, 2.0 * D)

    def success(self, q, qd, ref, metrics):
        every = (metrics["segments"] > 0) & (metrics["segments_settled"] == metrics["segments"])
        return every & (np.abs(ref[:, 0] - q[:, 0]) < 5 * D)


TASKS: dict[str, type[Task]] = {cls.name: cls for cls in (VelocityVectorRoll, BankToBank)}

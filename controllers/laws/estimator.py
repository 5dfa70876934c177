"""``DelayedKalman``: joint angles and rates from delayed angle measurements and the linear model (batched).

The observation carries the joint angles (quantised, noisy, ``d`` control periods old) and a
filtered backward-difference rate; a state-feedback law wants the present angles and rates.  Per
free joint, with ``x = (angle, rate)`` and the control period ``dt``:

    predict   x_{k+1} = F x_k + G a_k,   F = [[1, dt], [0, 1]],  G = [dt^2 / 2, dt]
              a_k     = model acceleration: A_q (q - q_op) + A_w w + B (s - u_trim)     (linear model at the
                        scheduled operating point; s the measured surface positions, normalised)
    update    x      += K (z - angle)          (z the measured angle; rig_roll innovations wrapped to +-pi)
    forward   d steps of ``predict`` from the measurement's time to now, with the latest surfaces

``K`` is the steady-state Kalman gain of the kinematic model with white acceleration noise
``sigma_a`` (rad/s^2, the model error) and measurement noise ``sigma_z`` (rad: sensor noise and
quantisation), from the discrete Riccati equation: :func:`controllers.design.estimator.kalman_gain`
(scipy, design time); the filter itself is numpy, so a deployed law runs it with the gains as data.  The measured surfaces are as old as the
angles, so the update step runs at the measurement's time with the surfaces the rig really had; the
forward prediction over the last ``d`` periods uses the latest measured surfaces.

| array | shape | unit |
|---|---|---|
| ``q``, ``w`` | (n, n_joints) | rad, rad/s (the present estimate, rig_roll unwrapped) |
| ``A_q``, ``A_w`` | (n, n_joints, n_joints) | 1/s^2, 1/s |
| ``B`` | (n, n_joints, 3) | rad/s^2 per normalised virtual input |
"""

from __future__ import annotations

import math

import numpy as np


class DelayedKalman:
    """The filter of the module docstring for ``n`` environments and joints ``joints`` (``wrap``: unlimited ones)."""

    def __init__(self, n: int, dt: float, wrap: np.ndarray, gains: np.ndarray, delay_steps: int) -> None:
        if delay_steps < 0 or int(delay_steps) != delay_steps:
            raise ValueError(f"delay_steps = {delay_steps!r}: must be a non-negative integer")
        self.n, self.dt, self.d = n, float(dt), int(delay_steps)
        self.wrap = np.asarray(wrap, dtype=bool)
        self.K = np.asarray(gains, dtype=np.float64)  # (n_joints, 2)
        nj = self.wrap.size
        # a gain table of another joint count broadcast or failed deep inside step() (IndexError / shape mismatch)
        if self.K.shape != (nj, 2) or not np.all(np.isfinite(self.K)):
            raise ValueError(f"gains: shape {self.K.shape}; allowed finite numbers of shape ({nj}, 2), one (angle, rate) pair per joint of wrap")
        self.q_m = np.zeros((n, nj))  # estimate at the measurement's time
        self.w_m = np.zeros((n, nj))
        self.q = np.zeros((n, nj))
        self.w = np.zeros((n, nj))
        self.s_prev = np.zeros((n, 3))
        self.fresh = np.ones(n, dtype=bool)

    def reset(self, mask: np.ndarray) -> None:
        self.fresh |= mask

    def _accel(self, q, w, q_op, A_q, A_w, B, s, u_trim) -> np.ndarray:
        dq = q - q_op
        dq[:, self.wrap] = (dq[:, self.wrap] + math.pi) % (2 * math.pi) - math.pi
        return np.einsum("nij,nj->ni", A_q, dq) + np.einsum("nij,nj->ni", A_w, w) + np.einsum("nij,nj->ni", B, s - u_trim)

    def step(self, z: np.ndarray, w_meas: np.ndarray, s: np.ndarray, model: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Advance one period with measured angles z, filtered rates w_meas (start-up only), surfaces s (n, 3).

        model: (q_op, A_q, A_w, B, u_trim) at the scheduled point.  Returns the present (q, w).
        """
        dt = self.dt
        f = self.fresh
        if np.any(f):  # start from the measurement, at rest as the sensor says
            self.q_m[f], self.w_m[f], self.s_prev[f] = z[f], w_meas[f], s[f]
        a = self._accel(self.q_m, self.w_m, *model[:4], self.s_prev, model[4])
        q_pred = self.q_m + dt * self.w_m + 0.5 * dt * dt * a
        w_pred = self.w_m + dt * a
        q_pred, w_pred = np.where(f[:, None], z, q_pred), np.where(f[:, None], w_meas, w_pred)
        innov = z - q_pred
        innov[:, self.wrap] = (innov[:, self.wrap] + math.pi) % (2 * math.pi) - math.pi
        self.q_m = q_pred + self.K[:, 0] * innov
        self.w_m = w_pred + self.K[:, 1] * innov
        self.s_prev = s.copy()
        q, w = self.q_m.copy(), self.w_m.copy()
        for _ in range(self.d):
            a = self._accel(q, w, *model[:4], s, model[4])
            q, w = q + dt * w + 0.5 * dt * dt * a, w + dt * a
        self.q, self.w = q, w
        self.fresh[:] = False
        return q, w

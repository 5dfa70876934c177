"""The steady-state Kalman gain of :class:`controllers.laws.estimator.DelayedKalman` (design time: scipy).

The filter runs in the law (numpy, the gains as data); the gain is designed here, from the discrete
Riccati equation of the kinematic model ``x = (angle, rate)`` with white acceleration noise ``sigma_a``
(rad/s^2) and measurement noise ``sigma_z`` (rad).
"""

from __future__ import annotations

import numpy as np


def kalman_gain(dt: float, sigma_a: float, sigma_z: float) -> np.ndarray:
    """(2,) steady-state gain (angle, rate) of the kinematic model x = (angle, rate)."""
    if not (dt > 0 and sigma_a > 0 and sigma_z > 0):
        raise ValueError(f"dt, sigma_a, sigma_z = {dt}, {sigma_a}, {sigma_z}: must be positive")
    from scipy.linalg import solve_discrete_are

    F = np.array([[1.0, dt], [0.0, 1.0]])
    G = np.array([[0.5 * dt * dt], [dt]])
    H = np.array([[1.0, 0.0]])
    Qn = sigma_a**2 * (G @ G.T)
    P = solve_discrete_are(F.T, H.T, Qn, np.array([[sigma_z**2]]))  # a priori covariance
    return (P @ H.T / (H @ P @ H.T + sigma_z**2)).ravel()

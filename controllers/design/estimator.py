"""The steady-state Kalman gain of :class:`controllers.laws.estimator.DelayedKalman` (design time: scipy).

The filter runs in the law (numpy, the gains as data); the gain is designed here, from the discrete
Riccati equation of the kinematic model ``x = (angle, rate)`` with white acceleration noise ``sigma_a``
(rad/s^2) and measurement noise ``sigma_z`` (rad).
"""

from __future__ import annotations

import numpy as np


def kalman_gain(dt: float, sigma_a: float, sigma_z: float) -> np.ndarray:
    """(2,) steady-state gain (angle, rate) of the kinematic model x = (angle, rate).

    ValueError naming the argument unless ``dt`` (s), ``sigma_a`` (rad/s^2) and ``sigma_z`` (rad) are finite numbers > 0.
    """
    from scipy.linalg import solve_discrete_are

    from controllers.design.model import check_positive

    # each checked by name: an inf reached scipy ("array must not contain infs or NaNs"), a string a TypeError
    dt, sigma_a, sigma_z = (check_positive(k, v) for k, v in (("dt", dt), ("sigma_a", sigma_a), ("sigma_z", sigma_z)))

    F = np.array([[1.0, dt], [0.0, 1.0]])
    G = np.array([[0.5 * dt * dt], [dt]])
    H = np.array([[1.0, 0.0]])
    Qn = sigma_a**2 * (G @ G.T)
    P = solve_discrete_are(F.T, H.T, Qn, np.array([[sigma_z**2]]))  # a priori covariance
    return (P @ H.T / (H @ P @ H.T + sigma_z**2)).ravel()

"""Riccati solutions the laws' designs and the identification can trust: each checked by its residual, and solved again
without balancing when it fails (``controllers.design``: the LQRs and Kalman filters; ``rig_env.sysid.filter_error``: the
filter-error method's steady-state gains).

python-control's ``lqr``/``dlqr`` and scipy's ``solve_continuous_are``/``solve_discrete_are`` balance the
Hamiltonian pencil before the Schur decomposition by default.  On the model-following design's
augmented model (the rig beside the free Hawk's short period, the pilot command and the gust: states
whose weights differ by ten orders of magnitude, exogenous modes just inside the unit circle) the
balanced solution of the discrete equation came back with a relative residual of 2.5e-2 at 24 m/s,
and its gain on the pilot's command jumped between -232 and +33 within 0.3 m/s while the accurate
solution moves smoothly from 19.9 to 19.7 (residual 1e-13, found without balancing).  The scheduled
law interpolated those gains, and the emulation error of the 3-2-1-1 response grew with airspeed.

So every Riccati solution of the designs is checked: the relative residual

    discrete:   ||A' X A - X - A' X B (R + B' X B)^-1 B' X A + Q|| / max(||X||, ||Q||)
    continuous: ||A' X + X A - X B R^-1 B' X + Q|| / max(||X||, ||Q||)

(Frobenius norms) must be below :data:`RETRY_TOL`, else the equation is solved again without
balancing and the better of the two is kept; if that is still above :data:`ACCEPT_TOL` the design
stops with an error naming the equation.  Where the first solution is accurate it is returned as it
is, so accurate designs are bit for bit what they were.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sl

RETRY_TOL = 1e-10
"""Relative residual above which a Riccati solution is solved again without balancing."""
ACCEPT_TOL = 1e-8
"""Relative residual above which no solution is accepted (ArithmeticError)."""


def are_residual(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, X: np.ndarray, *, discrete: bool) -> float:
    """The relative residual of ``X`` in the control Riccati equation of ``(A, B, Q, R)`` (module docstring)."""
    A, B, Q, R, X = (np.atleast_2d(np.asarray(m, dtype=np.float64)) for m in (A, B, Q, R, X))
    if discrete:
        r = A.T @ X @ A - X - A.T @ X @ B @ np.linalg.solve(R + B.T @ X @ B, B.T @ X @ A) + Q
    else:
        r = A.T @ X + X @ A - X @ B @ np.linalg.solve(R, B.T @ X) + Q
    scale = max(float(np.linalg.norm(X)), float(np.linalg.norm(Q)), 1e-300)
    return float(np.linalg.norm(r)) / scale


def solve_are(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, *, discrete: bool, what: str) -> np.ndarray:
    """``X`` of the Riccati equation (scipy's solver, balanced first), checked as the module docstring says.
    ``what`` names the equation in the error."""
    solver = sl.solve_discrete_are if discrete else sl.solve_continuous_are
    X = np.asarray(solver(A, B, Q, R))
    return _checked(A, B, Q, R, X, discrete, what)[0]


def lqr(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, *, discrete: bool, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(K, X, poles)`` of python-control's ``lqr`` (``dlqr`` if ``discrete``), checked as the module docstring says:
    u = -K x; X the Riccati solution; poles the closed loop's eigenvalues.  ``what`` names the design in the error."""
    import control  # python-control: the designs' solver (imported here, so that identification need not load it)

    K, X, E = (np.asarray(m) for m in (control.dlqr if discrete else control.lqr)(A, B, Q, R))
    X, replaced = _checked(A, B, Q, R, X, discrete, what)
    if replaced:  # the gain and the poles of the accurate solution
        B2, R2 = np.atleast_2d(B), np.atleast_2d(R)
        K = np.linalg.solve(R2 + B2.T @ X @ B2, B2.T @ X @ A) if discrete else np.linalg.solve(R2, B2.T @ X)
        E = np.linalg.eigvals(A - B2 @ K)
    return K, X, E


def _checked(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, X: np.ndarray, discrete: bool, what: str) -> tuple[np.ndarray, bool]:
    """``(X, replaced)``: X as it is when its residual is below RETRY_TOL, else the better of it and the unbalanced
    solution (replaced: the latter); ArithmeticError if the better is above ACCEPT_TOL."""
    res = are_residual(A, B, Q, R, X, discrete=discrete)
    replaced = False
    if res > RETRY_TOL:
        solver = sl.solve_discrete_are if discrete else sl.solve_continuous_are
        X2: np.ndarray | None
        try:
            X2 = np.asarray(solver(A, B, Q, R, balanced=False))
        except (np.linalg.LinAlgError, ValueError):  # no stabilising solution found this way: the first stands or falls alone
            X2 = None
        res2 = are_residual(A, B, Q, R, X2, discrete=discrete) if X2 is not None else np.inf
        if X2 is not None and res2 < res:
            X, res, replaced = X2, res2, True
    _accept(res, what)
    return X, replaced


def _accept(res: float, what: str) -> None:
    if not res <= ACCEPT_TOL:
        raise ArithmeticError(f"{what}: no Riccati solution with a relative residual below {ACCEPT_TOL:g} (best {res:.2g}, "
                              "balanced and unbalanced): the weights or the model are too ill-conditioned to design on")


__all__ = ["ACCEPT_TOL", "RETRY_TOL", "are_residual", "lqr", "solve_are"]

"""Derive the von Karman mixture of ``rig_env.turbulence``: ``python scripts/von_karman_fit.py``.

Prints VON_KARMAN_SCALES and VON_KARMAN_WEIGHTS (10 significant digits) and the fit's largest relative
error.  The von Karman spectra are matched by a sum of Dryden spectra of scales lambda_i L and variances
w_i sigma^2 (the module docstring of rig_env.turbulence): in units of T = L / V,

    minimise over lambda (Nelder-Mead on log lambda, the mean |e|^q to the power 1/q, q = 2, 8, 32, 128 in turn)
    the relative errors e = sum_i w_i Phi_Dryden(lambda_i, x) / Phi_vK(x) - 1 of u and of v at 301 log-spaced
    x = T omega in [1e-3, 100], the weights w >= 0 for given lambda by non-negative least squares of the
    same errors with the equalities sum w = 1 (the variance) and sum w lambda = 1 (the integral scale) as
    rows weighted 1e6.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize

from rig_env.turbulence import dryden_psd, von_karman_psd

N_TERMS = 5
X = np.logspace(-3.0, 2.0, 301)  # T omega
EQUALITY_WEIGHT = 1e6


def weights(lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(w (M,), relative errors (2 len(X),) of u then v) for scales lam (M,), per unit T."""
    rows = [np.stack([dryden_psd(c, X, 1.0, s, 1.0) for s in lam], axis=1) / von_karman_psd(c, X, 1.0, 1.0, 1.0)[:, None] for c in "uv"]
    A = np.vstack(rows)
    big = EQUALITY_WEIGHT
    w, _ = optimize.nnls(np.vstack([A, big * np.ones(lam.size), big * lam]), np.concatenate([np.ones(A.shape[0]), [big, big]]))
    return w, A @ w - 1.0


def fit() -> tuple[np.ndarray, np.ndarray, float]:
    """(scales lambda (N_TERMS,), weights w (N_TERMS,), largest relative error on X)."""
    def norm(p: np.ndarray, q: float) -> float:
        return float(np.mean(np.abs(weights(np.exp(p))[1]) ** q) ** (1.0 / q))

    p = np.log(1.25 * 4.0 ** -np.arange(N_TERMS))
    for q in (2, 8, 32, 128):
        p = optimize.minimize(norm, p, args=(q,), method="Nelder-Mead", options={"maxiter": 40000, "maxfev": 40000, "xatol": 1e-10, "fatol": 1e-15}).x
    lam = np.exp(p)
    w, e = weights(lam)
    return lam, w, float(np.abs(e).max())


if __name__ == "__main__":
    lam, w, err = fit()
    print("VON_KARMAN_SCALES = (" + ", ".join(f"{v:.10g}" for v in lam) + ")")
    print("VON_KARMAN_WEIGHTS = (" + ", ".join(f"{v:.10g}" for v in w) + ")")
    print(f"largest relative error on the grid: {err:.5f}; sum w - 1 = {w.sum() - 1:.1e}, sum w lambda - 1 = {w @ lam - 1:.1e}")

"""Cramer-Rao bounds of a maximum-likelihood fit, and their correction for coloured residuals.

The uncorrected bound is the inverse of the Fisher information ``F = sum_k S_k' R^-1 S_k`` (S_k: the
outputs' sensitivities at sample k, R: the measurement-noise covariance), valid when the residuals are
white.  Real residuals are coloured (unmodelled dynamics, turbulence) and then F^-1 is too small; the
correction of Morelli and Klein replaces it by

    Cov = F^-1 [ sum_i sum_j S_i' R^-1 Rvv(i - j) R^-1 S_j ] F^-1

with ``Rvv(tau) = 1/N sum_k v_(k+tau) v_k'`` the residuals' sample autocorrelation.  Summed over every
lag, that estimate collapses for a parameter whose sensitivity is nearly constant (a moment offset acts
as a bias, and the residuals of a fit sum to nearly zero: the sum over all lags of their biased
autocorrelation is (sum v)^2 / N), so the sum is taken with Bartlett weights ``1 - |tau| / (L + 1)``
up to a lag L (the Newey-West estimator, positive semi-definite): L is twice the lag at which every
channel's autocorrelation first falls inside its 95 % band 1.96 / sqrt(N), and at least the Newey-West
rule ``4 (N / 100)^(2/9)``.  For white residuals Cov returns to about F^-1.  The double sum is a Toeplitz
product per pair of output channels, done by FFT.
"""

from __future__ import annotations

import numpy as np


def cross_correlation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) ``r(tau) = 1/N sum_k a[k + tau] b[k]`` for tau = 0..N-1 (the biased estimator), by FFT."""
    n = a.size
    m = 1 << int(np.ceil(np.log2(2 * n)))
    fa = np.fft.rfft(a, m)
    fb = np.fft.rfft(b, m)
    full = np.fft.irfft(fa * np.conj(fb), m)
    return full[:n] / n


def fisher_information(S: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(n_p, n_p) ``sum_k S_k' R^-1 S_k``; S (n_t, n_out, n_p), R (n_out, n_out)."""
    Ri = np.linalg.inv(R)
    return np.einsum("kip,ij,kjq->pq", S, Ri, S)


def bandwidth(V: np.ndarray) -> int:
    """The lag window L of :func:`coloured_middle` for residuals V (n_t, n_out) (see the module docstring)."""
    n = V.shape[0]
    band = 1.96 / np.sqrt(n)
    first = 1
    for a in range(V.shape[1]):
        r = cross_correlation(V[:, a], V[:, a])
        rho = r / r[0] if r[0] > 0 else np.zeros_like(r)
        inside = np.flatnonzero(np.abs(rho[1:]) < band)
        first = max(first, int(inside[0]) + 1 if inside.size else n)
    return int(min(max(2 * first, int(np.ceil(4.0 * (n / 100.0) ** (2.0 / 9.0)))), n - 1))


def coloured_middle(S: np.ndarray, V: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(n_p, n_p) ``sum_i sum_j S_i' R^-1 w(i - j) Rvv(i - j) R^-1 S_j`` of one record, Bartlett weights w.

    S: (n_t, n_out, n_p) sensitivities; V: (n_t, n_out) residuals; R: (n_out, n_out) noise covariance."""
    from scipy.linalg import matmul_toeplitz

    Ri = np.linalg.inv(R)
    W = np.einsum("ij,kjp->kip", Ri, S)  # R^-1 S_k, (n_t, n_out, n_p)
    n_out = V.shape[1]
    L = bandwidth(V)
    w = np.clip(1.0 - np.arange(V.shape[0]) / (L + 1.0), 0.0, None)
    out = np.zeros((S.shape[2], S.shape[2]))
    for a in range(n_out):
        for b in range(n_out):
            r_ab = w * cross_correlation(V[:, a], V[:, b])  # E[v_a(k + tau) v_b(k)]
            r_ba = w * cross_correlation(V[:, b], V[:, a])
            TW = matmul_toeplitz((r_ab, r_ba), W[:, b, :], check_finite=False)  # T[i, j] = Rvv_ab(i - j)
            out += W[:, a, :].T @ TW
    return 0.5 * (out + out.T)


def covariances(F: np.ndarray, middles: list[np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
    """(white, coloured) parameter covariances: F^-1 and F^-1 (sum of middles) F^-1 (middles None: both F^-1)."""
    Fi = np.linalg.pinv(F, hermitian=True)
    if not middles:
        return Fi, Fi
    M = sum(middles)
    C = Fi @ M @ Fi
    return Fi, 0.5 * (C + C.T)


def correlation(C: np.ndarray) -> np.ndarray:
    """Correlation matrix of a covariance (zero rows where the variance is zero)."""
    d = np.sqrt(np.clip(np.diag(C), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = C / np.outer(d, d)
    out[~np.isfinite(out)] = 0.0
    np.fill_diagonal(out, 1.0)
    return out

"""Residual diagnostics of a fit: whiteness per output and fit measures, on plain arrays.

Residuals are ``(n_t, n_out)`` arrays (measured minus predicted, one column per output, in the
output's unit); every statistic here is dimensionless except the RMS, which has the output's unit.

Whiteness (a fitted model whose residuals are white has left nothing predictable in the data):

* normalised autocorrelation ``r_k = c_k / c_0`` with ``c_k = (1/N) sum_t e_t e_{t+k}`` (mean removed),
  k = 0..L;  for white noise ``r_k`` (k >= 1) is about N(0, 1/N), so 95 % of the lags fall inside the
  band ``+-1.96 / sqrt(N)``, and the number outside is about Binomial(L, 0.05);
* the Ljung-Box statistic ``Q = N (N + 2) sum_{k=1..L} r_k^2 / (N - k)``, chi-squared with L degrees of
  freedom for white noise; its p-value is uniform on [0, 1] then, and small for coloured residuals.

Fit measures per output: ``R^2 = 1 - sum e^2 / sum (y - mean y)^2``, the normalised RMS
``rms(e) / std(y)`` and Theil's inequality coefficient ``U = rms(e) / (rms(y) + rms(y_hat))`` (0: a
perfect fit, 1: no agreement).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import stats

BAND_Z = 1.959963984540054
"""The two-sided 95 % point of the standard normal distribution."""


def default_max_lag(n: int) -> int:
    """Lags tested by default for ``n`` samples: ``min(25, n // 5)``, at least 1."""
    return max(1, min(25, n // 5))


def _columns(a: np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(a, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.shape[0] < 3:
        raise ValueError(f"{name}: expected (n_t, n_out) with n_t >= 3, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: non-finite values")
    return x


def autocorrelation(residuals: np.ndarray, max_lag: int) -> np.ndarray:
    """Normalised autocorrelation ``r_k``, k = 0..max_lag, of each column (mean removed).

    residuals: (n_t,) or (n_t, n_out).  Returns (max_lag + 1, n_out); ``r_0 = 1`` (0 for a constant
    column, whose lags are all 0 too).  Biased estimator (divides by N), as the band assumes.
    """
    e = _columns(residuals, "residuals")
    n = e.shape[0]
    if not isinstance(max_lag, (int, np.integer)) or not 1 <= max_lag < n:
        raise ValueError(f"max_lag = {max_lag!r}: must be an integer in [1, n_t - 1 = {n - 1}]")
    e = e - e.mean(axis=0)
    c0 = np.einsum("ij,ij->j", e, e) / n
    out = np.zeros((max_lag + 1, e.shape[1]))
    for k in range(max_lag + 1):
        out[k] = np.einsum("ij,ij->j", e[: n - k], e[k:]) / n
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(c0 > 0, out / np.where(c0 > 0, c0, 1.0), 0.0)
    return r


@dataclass(frozen=True)
class Whiteness:
    """Whiteness of one output's residual.

    acf: (max_lag + 1,) normalised autocorrelation; band: the 95 % half-width 1.96 / sqrt(n);
    fraction_outside: of lags 1..max_lag with |r_k| > band (about 0.05 for white noise);
    outside_range: the central 95 % range of that fraction for white noise (Binomial(L, 0.05) / L);
    q, dof, p_value: the Ljung-Box statistic, its degrees of freedom (L) and p-value.
    """

    output: str
    n: int
    max_lag: int
    acf: np.ndarray
    band: float
    fraction_outside: float
    outside_range: tuple[float, float]
    q: float
    dof: int
    p_value: float

    def is_white(self, alpha: float = 0.05) -> bool:
        """Ljung-Box does not reject whiteness at level ``alpha``."""
        return self.p_value >= alpha


def ljung_box(acf: np.ndarray, n: int) -> tuple[float, float]:
    """(Q, p-value) of the Ljung-Box test from a normalised autocorrelation ``acf`` (lags 0..L) of n samples."""
    r = np.asarray(acf, dtype=np.float64)[1:]
    lags = np.arange(1, r.size + 1)
    q = float(n * (n + 2) * np.sum(r**2 / (n - lags)))
    return q, float(stats.chi2.sf(q, r.size))


def whiteness(residuals: np.ndarray, names: Sequence[str] | None = None, max_lag: int | None = None) -> list[Whiteness]:
    """Whiteness of every column of ``residuals`` (n_t, n_out); ``names`` label the outputs (default y0, y1...)."""
    e = _columns(residuals, "residuals")
    n, m = e.shape
    names = [f"y{k}" for k in range(m)] if names is None else list(names)
    if len(names) != m:
        raise ValueError(f"names: {len(names)} given for {m} residual columns")
    lag = default_max_lag(n) if max_lag is None else max_lag
    acf = autocorrelation(e, lag)
    band = BAND_Z / math.sqrt(n)
    lo, hi = (float(v) / lag for v in stats.binom.interval(0.95, lag, 0.05))
    out = []
    for k, name in enumerate(names):
        q, p = ljung_box(acf[:, k], n)
        frac = float(np.mean(np.abs(acf[1:, k]) > band))
        out.append(Whiteness(name, n, lag, acf[:, k].copy(), band, frac, (lo, hi), q, lag, p))
    return out


@dataclass(frozen=True)
class FitMeasure:
    """How well one output is fitted: ``r2``, ``nrms`` = rms(e) / std(y), ``theil_u`` in [0, 1], ``rms`` (output unit)."""

    output: str
    r2: float
    nrms: float
    theil_u: float
    rms: float


def fit_measures(predicted: np.ndarray, residuals: np.ndarray, names: Sequence[str] | None = None) -> list[FitMeasure]:
    """Fit measures per output; the measured output is ``predicted + residuals`` (both (n_t, n_out))."""
    yh = _columns(predicted, "predicted")
    e = _columns(residuals, "residuals")
    if yh.shape != e.shape:
        raise ValueError(f"predicted {yh.shape} and residuals {e.shape} must have the same shape")
    names = [f"y{k}" for k in range(e.shape[1])] if names is None else list(names)
    if len(names) != e.shape[1]:
        raise ValueError(f"names: {len(names)} given for {e.shape[1]} output columns")
    y = yh + e
    out = []
    for k, name in enumerate(names):
        rms_e = float(np.sqrt(np.mean(e[:, k] ** 2)))
        var_y = float(np.var(y[:, k]))
        r2 = 1.0 - rms_e**2 / var_y if var_y > 0 else float("nan")
        nrms = rms_e / math.sqrt(var_y) if var_y > 0 else float("nan")
        den = float(np.sqrt(np.mean(y[:, k] ** 2)) + np.sqrt(np.mean(yh[:, k] ** 2)))
        u = rms_e / den if den > 0 else float("nan")
        out.append(FitMeasure(name, r2, nrms, u, rms_e))
    return out

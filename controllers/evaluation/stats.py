"""The interval arithmetic of the comparison's report: Wilson intervals, bootstrap intervals, a command's spectrum.

Every statistic the report prints carries a 95 % interval:

| statistic | interval | function |
|---|---|---|
| a success rate, k of n episodes | Wilson score interval (below) | :func:`wilson` |
| the median of a metric over episodes | percentile bootstrap, :data:`N_BOOT` resamples of the episodes, seeded | :func:`bootstrap_ci` |
| a law's score (a mean over episodes) | the same bootstrap of the mean | :func:`bootstrap_ci` |

Wilson's interval for k successes in n trials at ``z`` (1.959964 for 95 %), with ``p = k / n``:
``(p + z^2 / (2 n) +- z sqrt(p (1 - p) / n + z^2 / (4 n^2))) / (1 + z^2 / n)``.  Unlike the normal
approximation ``p +- z sqrt(p (1 - p) / n)``, it is not a single point at 0/n or n/n (12/12 gives
[75.8 %, 100 %]: twelve successes do not prove a law never fails).

The bootstrap resamples whole episodes with replacement (the same resample indices for every metric of
one law, seeded, so a comparison is reproducible), takes the statistic of each resample and returns the
2.5 and 97.5 percentiles.  Episodes where a metric is undefined (NaN: a rise time where the signal
never rose) are dropped first; with none left the interval is (NaN, NaN).

:func:`dominant_frequency`: the frequency of the largest peak of a command's amplitude spectrum (its
mean removed), refined between bins by a parabola through the peak and its neighbours, and the
amplitude of that component; 0 Hz and zero amplitude for a constant command.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

Z95 = 1.959963984540054
"""The standard normal's 97.5 % quantile: a two-sided 95 % interval."""
N_BOOT = 2000
"""Bootstrap resamples per interval."""


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a success probability from ``k`` successes in ``n`` trials, as fractions in [0, 1].

    ValueError unless ``0 <= k <= n`` and ``n >= 1`` (integers)."""
    if not (isinstance(k, (int, np.integer)) and isinstance(n, (int, np.integer))) or n < 1 or not 0 <= k <= n:
        raise ValueError(f"wilson: k = {k!r} successes of n = {n!r} trials; need integers with 0 <= k <= n and n >= 1")
    p = k / n
    den = 1.0 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1.0 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, mid - half), min(1.0, mid + half)


def resample_indices(n: int, seed: int, n_boot: int = N_BOOT) -> np.ndarray:
    """(n_boot, n) episode indices drawn with replacement from a generator seeded with ``seed``."""
    return np.random.default_rng(seed).integers(0, n, size=(n_boot, n))


def bootstrap_ci(x: np.ndarray, stat: Callable[..., np.ndarray] = np.median, *, seed: int = 0, n_boot: int = N_BOOT,
                 level: float = 0.95, idx: np.ndarray | None = None) -> tuple[float, float]:
    """Percentile bootstrap interval of ``stat`` (a reduction taking ``axis=``) of the finite values of ``x`` (n,).

    ``idx``: resample indices (``resample_indices(len(x), ...)``) to share between metrics; then NaN
    entries of ``x`` are dropped from each resample.  (NaN, NaN) when ``x`` has no finite value."""
    x = np.asarray(x, dtype=float)
    if not 0.0 < level < 1.0:
        raise ValueError(f"level = {level!r}: must lie in (0, 1)")
    if idx is None:
        x = x[np.isfinite(x)]
        if x.size == 0:
            return math.nan, math.nan
        samples = x[resample_indices(x.size, seed, n_boot)]
        vals = stat(samples, axis=1)
    else:
        if not np.any(np.isfinite(x)):
            return math.nan, math.nan
        samples = x[idx]
        if np.all(np.isfinite(x)):
            vals = stat(samples, axis=1)
        else:  # a resample of only undefined episodes has no value: drop it
            nan_stat = {np.median: np.nanmedian, np.mean: np.nanmean}.get(stat, stat)
            ok = np.any(np.isfinite(samples), axis=1)
            vals = nan_stat(samples[ok], axis=1)
    a = 100.0 * (1.0 - level) / 2.0
    lo, hi = np.percentile(vals, [a, 100.0 - a])
    return float(lo), float(hi)


def dominant_frequency(u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Dominant oscillation of signals ``u`` (..., T) sampled every ``dt`` s: (frequency, Hz; amplitude) each (...).

    The amplitude spectrum ``|FFT(u - mean u)| * 2 / T`` over the bins 1 .. T/2; its largest bin ``k``
    refined by the vertex of the parabola through bins ``k - 1, k, k + 1``; the amplitude is the
    spectrum's value at the peak bin, in the unit of ``u`` (a sinusoid's amplitude when its frequency is
    a bin's).  Signals with fewer than 4 samples, or constant ones, give 0 Hz and 0."""
    u = np.asarray(u, dtype=float)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt = {dt!r} s: must be positive")
    T = u.shape[-1]
    shape = u.shape[:-1]
    if T < 4:
        return np.zeros(shape), np.zeros(shape)
    spec = np.abs(np.fft.rfft(u - u.mean(axis=-1, keepdims=True), axis=-1)) * (2.0 / T)
    spec = spec[..., : T // 2 + 1]
    spec[..., 0] = 0.0
    k = np.argmax(spec, axis=-1)
    amp = np.take_along_axis(spec, k[..., None], axis=-1)[..., 0]
    km, kp = np.clip(k - 1, 0, spec.shape[-1] - 1), np.clip(k + 1, 0, spec.shape[-1] - 1)
    a, b, c = (np.take_along_axis(spec, j[..., None], axis=-1)[..., 0] for j in (km, k, kp))
    den = a - 2.0 * b + c
    inner = (k > 1) & (k < spec.shape[-1] - 1) & (den < 0.0)
    shift = np.where(inner, 0.5 * (a - c) / np.where(inner, den, 1.0), 0.0)
    f = (k + shift) / (T * dt)
    quiet = amp <= 1e-12
    return np.where(quiet, 0.0, f), np.where(quiet, 0.0, amp)

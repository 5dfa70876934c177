"""``StepMetrics``: control-engineering metrics of a batch of episodes, updated once per control step.

An episode is cut by the task into *segments*, each a step of the tracked signal ``y`` from its
value ``y0`` at the segment's start towards a target ``r`` (a bank angle, a roll rate, a stop angle).
Segments with a negative id are not evaluated.  Per segment of step size ``d = r - y0``:

| metric | definition |
|---|---|
| rise time, s | time from 10 % to 90 % of ``d`` (NaN if 90 % is never reached) |
| settling time, s | time from the segment start until ``y`` stays within ``max(5 % |d|, band)`` (band from the task) of ``r`` (NaN if not settled when the segment ends) |
| overshoot, % | ``100 max(0, max sign(d) (y - r)) / |d|`` |

The episode values are means over the evaluated segments that produced a value.  Over the whole
episode: RMS tracking error (of the task's primary error, in the task's display unit), control
effort (RMS of the normalised action), control rate (RMS of its change per second, 1/s) and the
number of control steps with a constraint violation (a joint on a stop); the number of evaluated
segments and of those that settled.

The per-step accounting of every environment is one numba pass (:func:`_accumulate`, compiled on first
use and cached on disk; ``tests/test_env_kernels.py`` checks it against the numpy formulas); opening
and closing segments, which happens a few times per episode, stays numpy.
"""

from __future__ import annotations

import math

import numpy as np

from rig_env.physics.jit import kernel

_JIT = {"cache": True, "error_model": "numpy", "_nrt": False}  # allocation-free kernels, compiled lazily

METRIC_NAMES = (
    "rms_error",
    "rise_time",
    "settling_time",
    "overshoot_pct",
    "control_effort",
    "control_rate",
    "constraint_violations",
    "episode_time",
    "segments",
    "segments_settled",
)



@kernel(**_JIT)
def _maximum(a, b):
    """``np.maximum`` of two floats (a NaN in either gives NaN)."""
    if a >= b or math.isnan(a):
        return a
    return b


@kernel(**_JIT)
def _accumulate(t, seg, y, r_in, err, band_abs, action, prev_action, violation, dt,
                r, y0, t10, t90, t_out, peak, err2, a2, da2, viol, n):
    """One control step of :meth:`StepMetrics.update` after new segments were opened, in place.

    Inputs (n,) unless noted: t s, seg, y, r_in (the segment target, used where seg >= 0), err
    (display units), band_abs, action and prev_action (n, k) normalised, violation bool, dt s.
    Per environment (formulas of the module docstring; d = r - y0, s = sign d):
    t10/t90 = t at the first step with (y - y0) / d >= 0.1 / 0.9 (frac = 1 when |d| <= 1e-12);
    t_out = t while |y - r| > max(0.05 |d|, band_abs); peak = max(peak, s (y - r));
    err2 += err^2; a2 += mean(action^2); da2 += mean(((action - prev_action) / dt)^2); viol += violation; n += 1.
    """
    k = action.shape[1]
    for i in range(t.shape[0]):
        if seg[i] >= 0:
            r[i] = r_in[i]
        d = r[i] - y0[i]
        if abs(d) > 1e-12:
            frac = (y[i] - y0[i]) / d
        else:
            frac = 1.0
        if math.isnan(t10[i]) and frac >= 0.1:
            t10[i] = t[i]
        if math.isnan(t90[i]) and frac >= 0.9:
            t90[i] = t[i]
        if abs(y[i] - r[i]) > _maximum(0.05 * abs(d), band_abs[i]):
            t_out[i] = t[i]
        peak[i] = _maximum(peak[i], np.sign(d) * (y[i] - r[i]))
        err2[i] += err[i] * err[i]
        sa, sda = 0.0, 0.0
        for j in range(k):
            sa += action[i, j] * action[i, j]
            v = (action[i, j] - prev_action[i, j]) / dt
            sda += v * v
        a2[i] += sa / k
        da2[i] += sda / k
        viol[i] += violation[i]
        n[i] += 1.0


class StepMetrics:
    """Per-environment accumulators; all methods act on index arrays or the whole batch at once."""

    def __init__(self, n_envs: int, dt: float) -> None:
        self.dt = float(dt)
        z = lambda: np.zeros(n_envs)  # noqa: E731
        self.seg = np.full(n_envs, -1, dtype=np.int64)
        self.y0, self.r, self.t0, self.t10, self.t90, self.t_out, self.peak = (z() for _ in range(7))
        self.sums = {k: z() for k in ("rise", "settle", "over")}
        self.n_seg = z()
        self.counts = {k: z() for k in ("rise", "settle", "over")}
        self.err2, self.a2, self.da2, self.viol, self.n = z(), z(), z(), z(), z()

    def reset(self, idx: np.ndarray) -> None:
        self.seg[idx] = -1
        for arr in (self.err2, self.a2, self.da2, self.viol, self.n, self.n_seg, *self.sums.values(), *self.counts.values()):
            arr[idx] = 0.0

    def _close(self, idx: np.ndarray, t: np.ndarray) -> None:
        """Fold the current segment of envs idx into the episode sums."""
        idx = idx[self.seg[idx] >= 0]
        if idx.size == 0:
            return
        self.n_seg[idx] += 1
        d = np.abs(self.r[idx] - self.y0[idx])
        ok = d > 1e-12
        rise = self.t90[idx] - self.t10[idx]
        settled = self.t_out[idx] < t[idx] - 0.5 * self.dt  # in the band at the segment's end
        settle = np.where(settled, np.maximum(self.t_out[idx] + self.dt - self.t0[idx], 0.0), np.nan)
        over = np.where(ok, 100.0 * np.maximum(self.peak[idx], 0.0) / np.where(ok, d, 1.0), np.nan)
        for key, v in (("rise", np.where(ok, rise, np.nan)), ("settle", settle), ("over", over)):
            good = np.isfinite(v)
            self.sums[key][idx] += np.where(good, v, 0.0)
            self.counts[key][idx] += good

    def update(self, t: np.ndarray, seg: np.ndarray, y: np.ndarray, r: np.ndarray, err: np.ndarray,
               band_abs: np.ndarray, action: np.ndarray, prev_action: np.ndarray, violation: np.ndarray) -> None:
        """Account one control step ending at time t (n,) for every environment.

        seg: (n,) segment id (new id: a new step starts from the current y); y, r: (n,) tracked signal
        and its segment target; err: (n,) tracking error in display units; band_abs: (n,) absolute
        settling band in the unit of y; action, prev_action: (n, k)
        normalised; violation: (n,) bool.
        """
        new = seg != self.seg
        if np.any(new):
            idx = np.flatnonzero(new)
            self._close(idx, t - self.dt)  # the old segment's last step ended one step ago
            self.seg[idx] = seg[idx]
            self.y0[idx], self.r[idx], self.t0[idx] = y[idx], r[idx], t[idx] - self.dt
            self.t10[idx] = self.t90[idx] = np.nan
            self.t_out[idx] = t[idx] - self.dt
            self.peak[idx] = -np.inf
        _accumulate(t, seg, y, r, err, band_abs, action, prev_action, violation, self.dt, self.r, self.y0, self.t10,
                    self.t90, self.t_out, self.peak, self.err2, self.a2, self.da2, self.viol, self.n)

    def finish(self, idx: np.ndarray, t: np.ndarray) -> dict[str, np.ndarray]:
        """Episode metrics of envs idx (arrays of len(idx)); closes their current segment."""
        self._close(idx, t)
        self.seg[idx] = -1
        n = np.maximum(self.n[idx], 1.0)
        mean = lambda k: np.where(self.counts[k][idx] > 0, self.sums[k][idx] / np.maximum(self.counts[k][idx], 1.0), np.nan)  # noqa: E731
        return {
            "rms_error": np.sqrt(self.err2[idx] / n),
            "rise_time": mean("rise"),
            "settling_time": mean("settle"),
            "overshoot_pct": mean("over"),
            "control_effort": np.sqrt(self.a2[idx] / n),
            "control_rate": np.sqrt(self.da2[idx] / n),
            "constraint_violations": self.viol[idx].astype(np.int64),
            "episode_time": self.n[idx] * self.dt,
            "segments": self.n_seg[idx].astype(np.int64),
            "segments_settled": self.counts["settle"][idx].astype(np.int64),
        }

"""Per-episode metrics the environment does not count: read off the per-step records of every episode.

:func:`controllers.evaluation.evaluate.evaluate` records, for every environment of its batch until its
first episode ends, the normalised command ``a`` (T, N, n_a), the task's tracking error (T, N) deg and
segment id (T, N) (``Task.tracked``), and which steps were live (T, N).  :func:`trace_metrics` turns
them into (N,) arrays, all numpy over the whole batch:

| name | unit | definition |
|---|---|---|
| ``saturation`` | fraction of the episode | control steps with some command within 2 % of its limit (``abs(a) >= SAT_LEVEL``) |
| ``cmd_rate_rms`` | deg/s | RMS of the command's change per control period over the episode, of the surface where it is largest |
| ``cmd_freq`` | Hz | dominant oscillation frequency of the command (:func:`controllers.evaluation.stats.dominant_frequency`) of the surface with the largest RMS variation |
| ``cmd_osc_amp`` | deg | that oscillation's amplitude |
| ``hold_error`` | deg | RMS tracking error over the second half of every step segment (``segment >= 0``), after the step's transient: what the RMS over a stepped reference (dominated by the steps themselves) hides; NaN for a task without step segments |

``a`` is normalised to +-1 for +-``scale_deg`` (the surfaces' +-40 deg).
"""

from __future__ import annotations

import numpy as np

from controllers.evaluation.stats import dominant_frequency

SAT_LEVEL = 0.98
"""A command at or beyond this fraction of its limit counts as saturated."""
HOLD_FRACTION = 0.5
"""The hold error counts the last (1 - HOLD_FRACTION) of each step segment."""
TRACE_NAMES = ("saturation", "cmd_rate_rms", "cmd_freq", "cmd_osc_amp", "hold_error")


def _hold_mask(seg: np.ndarray, live: np.ndarray) -> np.ndarray:
    """(T, N) bool: live steps of a segment >= 0 in the last (1 - HOLD_FRACTION) of their run of equal segment id.

    A task reports a new segment one step after the reference stepped (``StepMetrics`` starts the segment's
    clock one step earlier), so step k belongs to the segment the task names at step k + 1."""
    T = seg.shape[0]
    seg = np.concatenate([seg[1:], seg[-1:]], axis=0)
    t = np.arange(T)[:, None]
    new = np.ones_like(live)
    new[1:] = (seg[1:] != seg[:-1]) | (live[1:] != live[:-1])
    start = np.maximum.accumulate(np.where(new, t, 0), axis=0)
    last = np.ones_like(live)
    last[:-1] = new[1:]
    end = np.minimum.accumulate(np.where(last, t, T - 1)[::-1], axis=0)[::-1]
    pos = (t - start) / (end - start + 1)
    return live & (seg >= 0) & (pos >= HOLD_FRACTION)


def trace_metrics(action: np.ndarray, err: np.ndarray, seg: np.ndarray, live: np.ndarray, dt: float,
                  scale_deg: float) -> dict[str, np.ndarray]:
    """The table of the module docstring, each (N,), from action (T, N, n_a), err (T, N) deg, seg (T, N), live (T, N) bool.

    ``dt``: control period, s; ``scale_deg``: the command per unit of ``a``, deg."""
    a = np.asarray(action, dtype=float)
    live = np.asarray(live, dtype=bool)
    if a.ndim != 3 or err.shape != a.shape[:2] or seg.shape != a.shape[:2] or live.shape != a.shape[:2]:
        raise ValueError(f"trace_metrics: action (T, N, n_a) {a.shape}, err {err.shape}, seg {seg.shape}, live {live.shape} must agree")
    n_live = live.sum(axis=0)
    denom = np.maximum(n_live, 1)
    sat = (np.abs(np.where(live[..., None], a, 0.0)) >= SAT_LEVEL).any(axis=2).sum(axis=0) / denom
    both = live[1:] & live[:-1]
    da = np.where(both[..., None], np.diff(a, axis=0), 0.0) * (scale_deg / dt)
    rate = np.sqrt((da**2).sum(axis=0) / np.maximum(both.sum(axis=0), 1)[:, None]).max(axis=1)
    a_live = np.where(live[..., None], a, 0.0)
    mean = a_live.sum(axis=0) / denom[:, None]  # (N, n_a)
    centred = np.where(live[..., None], a - mean, 0.0)  # the steps after the episode's end add nothing
    var = (centred**2).sum(axis=0) / denom[:, None]
    k = np.argmax(var, axis=1)  # the surface that moves most
    u = np.take_along_axis(centred, k[None, :, None], axis=2)[..., 0].T  # (N, T)
    freq, amp = dominant_frequency(u, dt)
    amp = amp * a.shape[0] / denom * scale_deg  # the spectrum was scaled by T, the episode lasted n_live steps
    hold = _hold_mask(np.asarray(seg), live)
    n_hold = hold.sum(axis=0)
    e2 = np.where(hold, np.asarray(err, dtype=float), 0.0) ** 2
    hold_err = np.where(n_hold > 0, np.sqrt(e2.sum(axis=0) / np.maximum(n_hold, 1)), np.nan)
    none = n_live == 0
    out = {"saturation": sat, "cmd_rate_rms": rate, "cmd_freq": freq, "cmd_osc_amp": amp, "hold_error": hold_err}
    return {key: np.where(none, np.nan, v) for key, v in out.items()}

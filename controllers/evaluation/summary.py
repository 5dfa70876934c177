"""What a comparison measured: the metrics and their units, the per-law rows with intervals, the text tables.

:mod:`controllers.evaluation.compare` fills :class:`Comparison`; :mod:`controllers.evaluation.report`
draws and writes it; :mod:`controllers.evaluation.schema` writes ``summary.json`` and ``summary.csv``.

A row (:func:`rows_of`) holds one law on one task in one mode: ``episodes``, ``success`` (fraction)
with its Wilson ``success_ci95``, for every metric of :data:`METRICS` (and the task's own,
:data:`TASK_METRICS`) its ``median`` over episodes with a bootstrap ``ci95``
(:mod:`controllers.evaluation.stats`), and the ``score`` with its interval (:mod:`controllers.evaluation.score`).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from controllers.evaluation.evaluate import EvalResult
from controllers.evaluation.score import DEFAULT_RULE, ScoreRule, law_score
from controllers.evaluation.stats import bootstrap_ci, resample_indices, wilson


@dataclass(frozen=True)
class Metric:
    """One reported metric: its key, table header, unit, number format, the factor from the per-episode value, meaning."""

    key: str
    header: str
    unit: str
    fmt: str
    source: str
    scale: float
    meaning: str


METRICS = (
    Metric("rms_error", "RMS err", "deg", "{:.2f}", "rms_error", 1.0, "RMS of the task's tracking error over the episode (steps of the reference included)"),
    Metric("hold_error", "hold err", "deg", "{:.2f}", "hold_error", 1.0, "RMS tracking error over the second half of every step segment, after the step's transient (tasks with step segments)"),
    Metric("rise_time", "rise", "s", "{:.2f}", "rise_time", 1.0, "10-90 % rise time, mean over the episode's step segments"),
    Metric("settling_time", "settle", "s", "{:.2f}", "settling_time", 1.0, "time to stay within the task's band of each step's target, mean over segments"),
    Metric("overshoot_pct", "overshoot", "%", "{:.1f}", "overshoot_pct", 1.0, "overshoot of each step, % of the step, mean over segments"),
    Metric("cmd_rms", "RMS cmd", "deg", "{:.1f}", "cmd_rms", 1.0, "RMS surface command over the episode and the law's surfaces"),
    Metric("cmd_rate_rms", "cmd rate", "deg/s", "{:.0f}", "cmd_rate_rms", 1.0, "RMS rate of the command of the busiest surface"),
    Metric("saturation", "saturated", "%", "{:.1f}", "saturation", 100.0, "share of the episode's control steps with a command within 2 % of its +-40 deg limit"),
    Metric("cmd_freq", "cmd freq", "Hz", "{:.2f}", "cmd_freq", 1.0, "dominant frequency of the command of the surface that moves most (about 1 / episode length, 0.1 Hz, when the command follows the manoeuvre's slow steps rather than oscillating)"),
    Metric("cmd_osc_amp", "osc amp", "deg", "{:.1f}", "cmd_osc_amp", 1.0, "amplitude of that dominant command component"),
    Metric("stop_time", "on stop", "s", "{:.2f}", "stop_time", 1.0, "time some joint spent on a stop"),
)
TASK_METRICS = (  # the tasks' own episode metrics (Task.episode_metrics), reported when present
    Metric("emulation_error", "emulation err", "1", "{:.2f}", "emulation_error", 1.0, "free-flight emulation: RMS alpha error / RMS free-Hawk alpha (success below 0.5)"),
    Metric("amplitude_ratio", "amp ratio", "1", "{:.2f}", "amplitude_ratio", 1.0, "forced oscillation: response amplitude / commanded amplitude"),
    Metric("phase_lag_deg", "phase lag", "deg", "{:.1f}", "phase_lag_deg", 1.0, "forced oscillation: phase lag of the response"),
)
TRACKING = ("rms_error", "hold_error", "rise_time", "settling_time", "overshoot_pct")
COMMAND = ("cmd_rms", "cmd_rate_rms", "saturation", "cmd_freq", "cmd_osc_amp", "stop_time")
BY_KEY = {m.key: m for m in METRICS + TASK_METRICS}


@dataclass
class Comparison:
    """Everything :func:`compare` measured: ``rows`` (:func:`rows_of`), ``recommendations[task][mode]``
    (:func:`controllers.evaluation.score.recommend`), the designed laws' ``margins``, ``skipped`` laws,
    the evaluation ``results`` (per-episode metrics, histories) and the wall time."""

    settings: dict[str, Any]
    rows: list[dict[str, Any]] = field(default_factory=list)
    recommendations: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)
    margins: dict[str, dict[str, Any]] = field(default_factory=dict)
    skipped: list[dict[str, str]] = field(default_factory=list)
    results: list[EvalResult] = field(default_factory=list)
    seconds: float = 0.0
    rule: ScoreRule = DEFAULT_RULE
    backend: dict[str, Any] = field(default_factory=dict)
    """How it ran (``summary.json`` timing.backend): ``{"backend": "local"}`` or the Ray backend's chunks, nodes
    and retries per batch (:class:`controllers.evaluation.ray_backend.RayRun`)."""


def stream_seed(seed: int, *names: str) -> int:
    """A bootstrap seed for one (task, mode, law): the comparison's seed and a stable hash of the names."""
    return (int(seed) * 1_000_003 + zlib.crc32("/".join(names).encode())) % 2**32


def rows_of(res: EvalResult, rule: ScoreRule = DEFAULT_RULE) -> list[dict[str, Any]]:
    """One row per law of ``res`` (module docstring); the intervals' resamples are seeded by ``res.seed``."""
    rows = []
    for name, m in res.metrics.items():
        n = res.n_episodes
        k = int(np.sum(np.asarray(m["success"], dtype=bool)))
        seed = stream_seed(res.seed, res.task, res.conditions, name)
        idx = resample_indices(n, seed)
        metrics: dict[str, dict[str, Any]] = {}
        for met in METRICS + tuple(t for t in TASK_METRICS if t.source in m):
            v = np.asarray(m[met.source], dtype=float) * met.scale
            v = np.where(np.isfinite(v), v, np.nan)  # an undefined value (inf: the input never began) counts as undefined
            med = float(np.nanmedian(v)) if np.any(np.isfinite(v)) else math.nan
            metrics[met.key] = {"median": med, "ci95": list(bootstrap_ci(v, np.median, idx=idx))}
        score, score_ci = law_score(m, rule, seed=seed)
        stop = np.asarray(m["stop_time"], dtype=float)
        failed = (np.asarray(m["status"]) != 0) | np.asarray(m["stop_exceeded"]).astype(bool)
        rows.append({"mode": res.conditions, "task": res.task, "law": name, "episodes": n, "success": k / n,
                     "success_ci95": list(wilson(k, n)), "metrics": metrics, "score": score, "score_ci95": list(score_ci),
                     "stop_episodes": int(np.sum(stop > 0)), "stop_time_max": float(np.max(stop, initial=0.0)),
                     "failures": int(np.sum(failed)), "segments": float(np.median(m["segments"])) if "segments" in m else 0.0})
    return rows


def _num(x: float, fmt: str) -> str:
    return "-" if x is None or not np.isfinite(x) else fmt.format(x)


def cell(stat: dict[str, Any], fmt: str) -> str:
    """``median [low, high]`` of a metric (``-`` where undefined)."""
    if stat["median"] is None or not np.isfinite(stat["median"]):
        return "-"
    lo, hi = stat["ci95"]
    return f"{_num(stat['median'], fmt)} [{_num(lo, fmt)}, {_num(hi, fmt)}]"


def success_cell(r: dict[str, Any]) -> str:
    lo, hi = r["success_ci95"]
    return f"{100 * r['success']:.0f} [{100 * lo:.0f}, {100 * hi:.0f}]"


def score_cell(r: dict[str, Any]) -> str:
    lo, hi = r["score_ci95"]
    return f"{r['score']:.2f} [{lo:.2f}, {hi:.2f}]"


def table_cells(rows: Sequence[dict[str, Any]], which: str) -> tuple[list[str], list[list[str]]]:
    """Header (with units) and body of the ``"tracking"`` or ``"command"`` table of rows of one task and mode."""
    if which == "tracking":
        extra = [t.key for t in TASK_METRICS if any(t.key in r["metrics"] for r in rows)]
        keys = list(TRACKING) + extra
        head = ["law", "success, %"] + [f"{BY_KEY[k].header}, {BY_KEY[k].unit}" for k in keys]
        body = [[r["law"], success_cell(r)] + [cell(r["metrics"][k], BY_KEY[k].fmt) if k in r["metrics"] else "-" for k in keys]
                for r in rows]
    elif which == "command":
        head = ["law"] + [f"{BY_KEY[k].header}, {BY_KEY[k].unit}" for k in COMMAND] + ["score (1 best)"]
        body = [[r["law"]] + [cell(r["metrics"][k], BY_KEY[k].fmt) for k in COMMAND] + [score_cell(r)] for r in rows]
    else:
        raise ValueError(f"which = {which!r}: 'tracking' or 'command'")
    return head, body


def format_table(rows: Sequence[dict[str, Any]], title: str) -> str:
    """Plain-text tables of rows, per task: tracking, then command and score; medians over episodes [95 % interval]."""
    out = [title, "medians over episodes [95 % interval]; success: Wilson interval; score: module controllers.evaluation.score"]
    for task in dict.fromkeys(r["task"] for r in rows):
        rs = [r for r in rows if r["task"] == task]
        out.append(f"\n{task}")
        for which in ("tracking", "command"):
            head, body = table_cells(rs, which)
            w = [max(len(str(x)) for x in col) for col in zip(head, *body)]
            line = "  " + "  ".join("-" * x for x in w)
            fmt = lambda cells: "  " + "  ".join(str(c).ljust(w[0]) if i == 0 else str(c).rjust(w[i]) for i, c in enumerate(cells))  # noqa: E731
            out += [fmt(head), line, *(fmt(b) for b in body)]
    return "\n".join(out)

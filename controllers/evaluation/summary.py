"""What a comparison measured: the table's columns, the result object, per-law aggregation and the text table.

:mod:`controllers.evaluation.compare` fills :class:`Comparison`; :mod:`controllers.evaluation.report`
draws and writes it.  Both import this module and neither imports the other's caller.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from controllers.evaluation.evaluate import EvalResult

COLUMNS = (  # (key, header, unit, format)
    ("success_rate", "success", "%", "{:.0f}"),
    ("rms_error", "RMS err", "task unit", "{:.2f}"),
    ("rise_time", "rise", "s", "{:.2f}"),
    ("settling_time", "settle", "s", "{:.2f}"),
    ("overshoot_pct", "overshoot", "%", "{:.1f}"),
    ("control_effort", "effort", "RMS a", "{:.3f}"),
    ("control_rate", "rate", "RMS da/dt, 1/s", "{:.2f}"),
    ("constraint_violations", "on stop", "steps", "{:.1f}"),
    ("failures", "failed", "episodes", "{:.0f}"),
)


@dataclass
class Comparison:
    """Everything :func:`compare` measured; ``rows``: one dict per (mode, task, law) with :data:`COLUMNS`."""

    settings: dict[str, Any]
    rows: list[dict[str, Any]] = field(default_factory=list)
    margins: dict[str, dict[str, Any]] = field(default_factory=dict)
    skipped: list[dict[str, str]] = field(default_factory=list)
    results: list[EvalResult] = field(default_factory=list)
    seconds: float = 0.0


def aggregate(res: EvalResult) -> list[dict[str, Any]]:
    """One row per law of ``res``: means over episodes (NaN-aware for rise, settling, overshoot)."""
    rows = []
    for name, m in res.metrics.items():
        failed = (m["status"] != 0) | m["stop_exceeded"].astype(bool)
        row: dict[str, Any] = {"mode": res.conditions, "task": res.task, "controller": name, "episodes": res.n_episodes,
                               "success_rate": 100.0 * float(np.mean(m["success"])), "failures": int(np.sum(failed))}
        for key in ("rms_error", "rise_time", "settling_time", "overshoot_pct", "control_effort", "control_rate", "constraint_violations"):
            v = np.asarray(m[key], dtype=float)
            row[key] = float(np.nanmean(v)) if np.any(np.isfinite(v)) else math.nan
        rows.append(row)
    return rows


def format_table(rows: Sequence[dict[str, Any]], title: str) -> str:
    """Plain-text table of rows (task, law, :data:`COLUMNS`)."""
    head = ["task", "law"] + [h for _, h, _, _ in COLUMNS]
    body = [[r["task"], r["controller"]] + [("-" if not np.isfinite(r[k]) else f.format(r[k])) for k, _, _, f in COLUMNS] for r in rows]
    w = [max(len(str(x)) for x in col) for col in zip(head, *body)]
    line = "  ".join("-" * x for x in w)
    fmt = lambda cells: "  ".join(str(c).ljust(w[0]) if i == 0 else str(c).rjust(w[i]) for i, c in enumerate(cells))
    return "\n".join([title, line, fmt(head), line, *(fmt(b) for b in body), line])

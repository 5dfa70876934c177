"""``summary.json`` and ``summary.csv`` of a comparison: the documented, stable machine-readable result.

``summary.json`` (``schema_version`` :data:`SCHEMA_VERSION`; a change to a key's name or meaning raises
it).  Undefined numbers (a rise time where nothing rose) are ``null``; every interval is a 95 % one,
``[low, high]``.

| key | type | meaning |
|---|---|---|
| ``schema_version`` | int | :data:`SCHEMA_VERSION` |
| ``settings`` | object | ``command`` (the ``rig compare`` line that reproduces it), ``tasks``, ``laws`` (registered kinds), ``policies`` (name -> ``{path, sha256, kind, task}`` of every ``--policy`` artefact), ``episodes``, ``seed``, ``quick``, ``modes``, ``conditions`` (mode -> the environment settings it flies), ``params_file``, ``reach`` (with ``params_file``: task -> the lines of :func:`controllers.evaluation.reach.reach`, draws beyond that rig's reach), ``airspeed`` (task -> [low, high] m/s where a task's floor, ``Task.min_airspeed``, raised the conditions' draw), ``score`` (the rule's numbers), ``files`` (the files written into the output folder: a later comparison there replaces or removes these and nothing else) |
| ``metrics`` | object | metric key -> ``{unit, meaning}``: every metric the results carry |
| ``score`` | object | ``definition`` (the formula in words) and the rule's numbers (:class:`controllers.evaluation.score.ScoreRule`) |
| ``results`` | object | task -> mode -> ``{"laws": {law: LAW}, "recommendation": REC}`` |
| ``margins`` | object | task -> law -> the designed loop's gain and phase margins (model-based laws) |
| ``skipped`` | list | ``{task, controller, reason}`` of every law that could not fly a task |
| ``timing`` | object | ``seconds`` (the whole comparison), ``machine``, ``batches`` (``{task, mode, seconds, build_seconds}``), ``backend`` (``{"backend": "local"}``, or with ``--backend ray`` per batch its chunks, each chunk's attempts (node, pid) and the ``retries``: :class:`controllers.evaluation.ray_backend.RayRun`): the only part that differs between two runs of the same command |

LAW, one law on one task in one mode (a law is named by its kind, a ``--policy`` artefact by its file's stem):

| key | type | meaning |
|---|---|---|
| ``episodes`` | int | episodes flown (the same, paired episodes for every law) |
| ``success`` | float | fraction of the episodes that met the task's success criterion, 0..1 |
| ``success_ci95`` | [float, float] | Wilson interval of ``success`` |
| ``metrics`` | object | metric key (``metrics`` above) -> ``{median, ci95}``: the median over episodes and its bootstrap interval, in the metric's unit |
| ``score`` | float | the law's score (1 best; :mod:`controllers.evaluation.score`) |
| ``score_ci95`` | [float, float] | its bootstrap interval |
| ``stop_episodes``, ``stop_time_max`` | int, float | episodes with a joint on a stop; the longest such time, s |
| ``failures`` | int | episodes that ended early (a blow-up, or a joint beyond its stop) |

REC, the recommendation for a task and mode (:func:`controllers.evaluation.score.recommend`):

| key | type | meaning |
|---|---|---|
| ``law`` | str or null | the recommended law; null when no law meets the criterion, or on a tie |
| ``score``, ``score_ci95`` | float, [float, float] or null | the top eligible law's score and interval (null when none is eligible) |
| ``tied`` | list of str | eligible laws whose score intervals overlap the top one's, the top one first (empty: no tie) |
| ``criterion`` | str | the eligibility criterion, e.g. ``"success >= 80 %"`` |
| ``ranking`` | list | every law, ranked: ``{law, success, score, score_ci95, eligible}`` |
| ``caveats`` | list of str | what a reader must know before flying the law (the first says "no law meets the criterion" when none does) |
| ``shared_failures`` | object or null | the episodes every law failed (two or more laws): ``{laws, episodes, airspeed_m_s}`` (:func:`controllers.evaluation.score.shared_failures`); null when there are none |

``summary.csv``: one line per (mode, task, law): ``success_pct`` with ``success_pct_lo``/``_hi``,
``score`` with ``score_lo``/``_hi``, and for every metric ``<key>_<unit>`` (the median; the key alone
when it names its unit or the metric is a ratio) with ``_lo`` and ``_hi``; the recommendation's ``recommended`` (1 for the recommended law, else 0).
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from controllers.evaluation.summary import BY_KEY, METRICS, TASK_METRICS, Comparison

SCHEMA_VERSION = 1
_UNIT_SLUG = {"%": "pct", "deg/s": "deg_s", "Hz": "hz", "1": ""}


def json_safe(x: Any) -> Any:
    """``x`` as strict JSON data: numpy scalars to Python, tuples to lists, NaN and infinities to null."""
    if isinstance(x, dict):
        return {str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [json_safe(v) for v in list(x)]
    if isinstance(x, (np.integer, np.bool_)):
        return x.item()
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, complex):
        return [json_safe(x.real), json_safe(x.imag)]
    return x


def document(cmp: Comparison) -> dict[str, Any]:
    """The ``summary.json`` document of a comparison (module docstring)."""
    results: dict[str, dict[str, Any]] = {}
    for r in cmp.rows:
        slot = results.setdefault(r["task"], {}).setdefault(r["mode"], {"laws": {}, "recommendation": None})
        slot["laws"][r["law"]] = {k: r[k] for k in ("episodes", "success", "success_ci95", "metrics", "score", "score_ci95",
                                                      "stop_episodes", "stop_time_max", "failures")}
    for task, modes in cmp.recommendations.items():
        for mode, rec in modes.items():
            results.setdefault(task, {}).setdefault(mode, {"laws": {}, "recommendation": None})["recommendation"] = rec
    present = {k for r in cmp.rows for k in r["metrics"]}
    settings = {k: v for k, v in cmp.settings.items() if k != "machine"}
    timing = {"seconds": cmp.seconds, "machine": cmp.settings.get("machine", ""),
              "batches": [{"task": r.task, "mode": r.conditions, "seconds": r.seconds, "build_seconds": r.build_seconds} for r in cmp.results],
              "backend": cmp.backend or {"backend": "local"}}
    return json_safe({
        "schema_version": SCHEMA_VERSION,
        "settings": {**settings, "score": cmp.rule.to_dict()},
        "metrics": {m.key: {"unit": m.unit, "meaning": m.meaning} for m in METRICS + TASK_METRICS if m.key in present},
        "score": {"definition": cmp.rule.describe(), **cmp.rule.to_dict()},
        "results": results,
        "margins": cmp.margins,
        "skipped": cmp.skipped,
        "timing": timing,
    })


def csv_column(key: str) -> str:
    """A metric's CSV column: its key and unit, e.g. ``rms_error_deg``, ``cmd_rate_rms_deg_s``, ``overshoot_pct``."""
    slug = _UNIT_SLUG.get(BY_KEY[key].unit, BY_KEY[key].unit)
    return key if not slug or key.endswith("_" + slug) else f"{key}_{slug}"


def write(cmp: Comparison, out: Path) -> None:
    """``summary.json`` and ``summary.csv`` into ``out``."""
    (out / "summary.json").write_text(json.dumps(document(cmp), indent=1, allow_nan=False) + "\n")
    keys = [m.key for m in METRICS + TASK_METRICS if any(m.key in r["metrics"] for r in cmp.rows)]
    head = ["mode", "task", "law", "episodes", "success_pct", "success_pct_lo", "success_pct_hi", "score", "score_lo", "score_hi",
            "recommended"]
    for k in keys:
        c = csv_column(k)
        head += [c, f"{c}_lo", f"{c}_hi"]
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(head)
        for r in cmp.rows:
            rec = cmp.recommendations.get(r["task"], {}).get(r["mode"], {})
            lo, hi = r["success_ci95"]
            line = [r["mode"], r["task"], r["law"], r["episodes"], 100 * r["success"], 100 * lo, 100 * hi, r["score"], *r["score_ci95"],
                    int(rec.get("law") == r["law"])]
            for k in keys:
                s = r["metrics"].get(k, {"median": math.nan, "ci95": [math.nan, math.nan]})
                line += [s["median"], *s["ci95"]]
            w.writerow(["" if isinstance(v, float) and not math.isfinite(v) else v for v in line])

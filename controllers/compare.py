"""The comparison: every control law on every task, nominal and robust, summarised in control terms.

:func:`compare` runs :func:`controllers.evaluate.evaluate` for each task in each mode (one batch per
task and mode, all laws in it on paired conditions), aggregates the episode metrics
(:data:`COLUMNS`), prints the tables, and writes into ``out_dir``: ``summary.json`` (settings,
rows, loop margins, skipped laws, timings), ``summary.csv`` (the rows), the plots and
``report.md`` (:mod:`controllers.report`).  Laws are the registered kinds
(``controllers.base.CONTROLLERS``); a kind that cannot be built for a task (an RL kind without a
shipped policy raises ``FileNotFoundError``; a law that cannot fly the task raises
``controllers.base.UnsupportedTask``) is skipped with a printed note.
"""

from __future__ import annotations

import csv
import json
import math
import platform
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence, TextIO

import numpy as np

import controllers
from controllers.base import CONTROLLERS, Controller, LoopSpec, UnsupportedTask, make_controller
from controllers.evaluate import MODES, EvalResult, evaluate
from controllers.tuning import plain
from rig_env.envs import TASKS, RigVectorEnv

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
QUICK_EPISODES, FULL_EPISODES = 12, 64
PREFERRED_ORDER = ("pid", "lqr", "ppo", "sac")


@dataclass
class Comparison:
    """Everything :func:`compare` measured; ``rows``: one dict per (mode, task, law) with :data:`COLUMNS`."""

    settings: dict[str, Any]
    rows: list[dict[str, Any]] = field(default_factory=list)
    margins: dict[str, dict[str, Any]] = field(default_factory=dict)
    skipped: list[dict[str, str]] = field(default_factory=list)
    results: list[EvalResult] = field(default_factory=list)
    seconds: float = 0.0


def default_kinds() -> list[str]:
    """Registered kinds, the preferred ones first."""
    _ = controllers  # importing the package registered the built-in laws
    kinds = sorted(CONTROLLERS, key=lambda k: (PREFERRED_ORDER.index(k) if k in PREFERRED_ORDER else len(PREFERRED_ORDER), k))
    return kinds


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


def _build(kinds: Sequence[str], task: str, n: int, fields: dict[str, Any], out: TextIO) -> tuple[dict[str, Controller], list[dict[str, str]]]:
    spec = LoopSpec.from_env(RigVectorEnv(1, task=task, **fields))
    laws, skipped = {}, []
    for kind in kinds:
        try:
            laws[kind] = make_controller(kind, spec, n)
        except (FileNotFoundError, UnsupportedTask) as exc:
            skipped.append({"task": task, "controller": kind, "reason": str(exc)})
            out.write(f"  note: {kind} skipped on {task}: {exc}\n")
    return laws, skipped


def compare(
    *,
    tasks: Sequence[str] | None = None,
    kinds: Sequence[str] | None = None,
    episodes: int | None = None,
    seed: int = 0,
    quick: bool = False,
    modes: Sequence[str] = ("nominal", "robust"),
    out_dir: str | Path | None = "out/compare",
    record: int = 3,
    stream: TextIO | None = None,
    progress: bool | TextIO = True,
) -> Comparison:
    """Run the comparison and write its files (none when ``out_dir`` is None); returns the numbers.

    ``stream``: where the notes and tables go (default stdout); ``progress``: True for a progress
    display on stderr, False for none, or a stream.
    """
    stream = stream if stream is not None else sys.stdout
    prog: TextIO | None = sys.stderr if progress is True else (None if progress is False else progress)
    tasks = list(tasks) if tasks else list(TASKS)
    kinds = list(kinds) if kinds else default_kinds()
    bad_t = [t for t in tasks if t not in TASKS]
    if bad_t:
        raise ValueError(f"tasks: unknown {bad_t}; valid names: {sorted(TASKS)}")
    bad_k = [k for k in kinds if k not in CONTROLLERS]
    if bad_k:
        raise ValueError(f"controllers: unknown {bad_k}; valid kinds: {sorted(CONTROLLERS)}")
    bad_m = [m for m in modes if m not in MODES]
    if bad_m:
        raise ValueError(f"modes: unknown {bad_m}; valid: {sorted(MODES)}")
    n = episodes if episodes is not None else (QUICK_EPISODES if quick else FULL_EPISODES)
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"episodes = {n!r}: must be a positive integer")
    settings = {"tasks": tasks, "controllers": kinds, "episodes": n, "seed": seed, "quick": quick, "modes": list(modes),
                "conditions": {m: {**MODES[m].env_fields(), "randomise": {k: list(v) for k, v in MODES[m].randomise.items()}} for m in modes},
                "machine": f"{platform.machine()} {platform.system()}, python {platform.python_version()}"}
    cmd = ["rig compare"] + (["--quick"] if quick else []) + [f"--episodes {n}", f"--seed {seed}"]
    cmd += [f"--tasks {' '.join(tasks)}"] if tasks != list(TASKS) else []
    cmd += [f"--controllers {' '.join(kinds)}"] if kinds != default_kinds() else []
    cmd += [f"--modes {' '.join(modes)}"] if list(modes) != ["nominal", "robust"] else []
    settings["command"] = " ".join(cmd)
    cmp = Comparison(settings)
    t0 = time.perf_counter()
    for task in tasks:
        laws, skipped = _build(kinds, task, n, MODES[modes[0]].env_fields(), stream)
        cmp.skipped += skipped
        if not laws:
            continue
        for law_name, law in laws.items():
            if hasattr(law, "describe"):
                cmp.margins.setdefault(task, {})[law_name] = plain(law.describe())
        for mode in modes:
            res = evaluate(laws, task, n_episodes=n, seed=seed, conditions=MODES[mode], record=record, progress=prog)
            cmp.results.append(res)
            cmp.rows += aggregate(res)
    cmp.seconds = time.perf_counter() - t0
    for mode in modes:
        rows = [r for r in cmp.rows if r["mode"] == mode]
        stream.write("\n" + format_table(rows, f"{mode}: {n} episodes per law and task, seed {seed} ({_mode_note(mode)})") + "\n")
    stream.write(f"\ncompared in {cmp.seconds:.0f} s\n")
    if out_dir is not None:
        write_files(cmp, Path(out_dir), stream)
    stream.flush()
    return cmp


def _mode_note(mode: str) -> str:
    return {"nominal": "airspeed 15-25 m/s, 1 % gusts, sensor noise, parameter spread",
            "robust": "as nominal plus +-20 % on aerodynamic derivatives and friction",
            "gusty": "as nominal with 5 % gusts (atmospheric, a stress case)"}.get(mode, mode)


def write_files(cmp: Comparison, out: Path, stream: TextIO) -> None:
    """summary.json, summary.csv, plots and report.md into ``out``."""
    from controllers import report

    out.mkdir(parents=True, exist_ok=True)
    summary = {"settings": cmp.settings, "rows": cmp.rows, "margins": cmp.margins, "skipped": cmp.skipped,
               "seconds": cmp.seconds, "timing": [{"task": r.task, "mode": r.conditions, "seconds": r.seconds, "paired": r.paired,
                                                    "build_seconds": r.build_seconds} for r in cmp.results]}
    (out / "summary.json").write_text(json.dumps(plain(summary), indent=1))
    keys = ["mode", "task", "controller", "episodes"] + [k for k, *_ in COLUMNS]
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in cmp.rows:
            w.writerow({k: r[k] for k in keys})
    files = report.write(cmp, out)
    stream.write(f"wrote {out}/summary.json, summary.csv, report.md and {len(files)} plots\n")

"""The comparison: every control law on every task, nominal and robust, summarised in control terms.

:func:`compare` runs :func:`controllers.evaluation.evaluate.evaluate` for each task in each mode (one batch per
task and mode, all laws in it on paired conditions), aggregates the episode metrics
(:data:`COLUMNS`), prints the tables, and writes into ``out_dir``: ``summary.json`` (settings,
rows, loop margins, skipped laws, timings), ``summary.csv`` (the rows), the plots and
``report.md`` (:mod:`controllers.evaluation.report`).  ``params_file`` (``rig compare --params``): a rig
parameter file, e.g. an identified one: the model-based laws are designed on it, the environments fly
it, and the randomised conditions' spreads are centred on its values (:func:`controllers.design.conditions.modes_for`);
the trained (RL) laws fly it as they were trained.  Laws are the registered kinds
(``controllers.laws.base.CONTROLLERS``); a kind that cannot be built for a task (an RL kind without a
shipped policy raises ``FileNotFoundError``; a law that cannot fly the task raises
``controllers.laws.base.UnsupportedTask``) is skipped with a printed note.
"""

from __future__ import annotations

import csv
import json
import platform
import sys
import time
from pathlib import Path
from typing import Any, Sequence, TextIO


from controllers import CONTROLLERS, Controller, LoopSpec, UnsupportedTask, make_controller
from controllers.evaluation import report
from controllers.evaluation.summary import COLUMNS, Comparison, aggregate, format_table
from controllers.evaluation.evaluate import MODES, evaluate
from controllers.design import DESIGNS
from controllers.design.conditions import modes_for
from controllers.design.tuning import plain
from controllers.laws import law_for
from rig_env.envs import TASKS, RigVectorEnv
from rig_env.params import RigParams

QUICK_EPISODES, FULL_EPISODES = 12, 64
PREFERRED_ORDER = ("pid", "lqr", "ppo", "sac")


def default_kinds() -> list[str]:
    """Registered kinds that build from a loop spec alone (not "linear": it takes its gains), the preferred ones first."""
    kinds = sorted((k for k, classes in CONTROLLERS.items() if any(c.built_from_spec for c in classes)), key=lambda k: (PREFERRED_ORDER.index(k) if k in PREFERRED_ORDER else len(PREFERRED_ORDER), k))
    return kinds


def _build(kinds: Sequence[str], task: str, n: int, fields: dict[str, Any], out: TextIO,
           params: RigParams | None = None) -> tuple[dict[str, Controller], list[dict[str, str]]]:
    spec = LoopSpec.from_env(RigVectorEnv(1, task=task, **fields))
    laws, skipped = {}, []
    for kind in kinds:
        try:
            designed = params is not None and law_for(kind, spec) in DESIGNS  # trained laws have no design to redo
            laws[kind] = make_controller(kind, spec, n, params=params) if designed else make_controller(kind, spec, n)
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
    params_file: str | Path | None = None,
) -> Comparison:
    """Run the comparison and write its files (none when ``out_dir`` is None); returns the numbers.

    ``stream``: where the notes and tables go (default stdout); ``progress``: True for a progress
    display on stderr, False for none, or a stream; ``params_file``: the rig's parameter file (None:
    the default rig; a missing or invalid file is a ValueError naming it), see the module docstring.
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
    params = None if params_file is None else RigParams.from_toml(params_file)  # ParameterError (a ValueError) names the file
    conditions = MODES if params is None else modes_for(params)
    env_params = {} if params_file is None else {"params_file": str(params_file)}
    n = episodes if episodes is not None else (QUICK_EPISODES if quick else FULL_EPISODES)
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"episodes = {n!r}: must be a positive integer")
    settings = {"tasks": tasks, "controllers": kinds, "episodes": n, "seed": seed, "quick": quick, "modes": list(modes),
                "conditions": {m: {**conditions[m].env_fields(), "randomise": {k: list(v) for k, v in conditions[m].randomise.items()}} for m in modes},
                "params_file": None if params_file is None else str(params_file),
                "machine": f"{platform.machine()} {platform.system()}, python {platform.python_version()}"}
    cmd = ["rig compare"] + (["--quick"] if quick else []) + [f"--episodes {n}", f"--seed {seed}"]
    cmd += [f"--tasks {' '.join(tasks)}"] if tasks != list(TASKS) else []
    cmd += [f"--controllers {' '.join(kinds)}"] if kinds != default_kinds() else []
    cmd += [f"--modes {' '.join(modes)}"] if list(modes) != ["nominal", "robust"] else []
    cmd += [f"--params {params_file}"] if params_file is not None else []
    settings["command"] = " ".join(cmd)
    cmp = Comparison(settings)
    t0 = time.perf_counter()
    for task in tasks:
        laws, skipped = _build(kinds, task, n, {**conditions[modes[0]].env_fields(), **env_params}, stream, params)
        cmp.skipped += skipped
        if not laws:
            continue
        for law_name, law in laws.items():
            if hasattr(law, "describe"):
                cmp.margins.setdefault(task, {})[law_name] = plain(law.describe())
        for mode in modes:
            res = evaluate(laws, task, n_episodes=n, seed=seed, conditions=conditions[mode], record=record, env_overrides=env_params,
                           progress=prog)
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

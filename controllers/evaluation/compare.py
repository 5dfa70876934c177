"""The comparison: every control law on every task, nominal and robust, summarised in control terms.

:func:`compare` runs :func:`controllers.evaluation.evaluate.evaluate` for each task in each mode (one batch per
task and mode, all laws in it on paired conditions), summarises each law's episodes as medians and
intervals (:func:`controllers.evaluation.summary.rows_of`), recommends a law per task and mode
(:func:`controllers.evaluation.score.recommend`), prints the tables and the recommendations, and writes
into ``out_dir``: ``summary.json`` and ``summary.csv`` (:mod:`controllers.evaluation.schema`, which
documents them), the plots and ``report.md`` (:mod:`controllers.evaluation.report`).  ``params_file`` (``rig compare --params``): a rig
parameter file, e.g. an identified one: the model-based laws are designed on it, the environments fly
it, and the randomised conditions' spreads are centred on its values (:func:`controllers.design.conditions.modes_for`);
the trained (RL) laws fly it as they were trained.  Laws are the registered kinds
(``controllers.laws.base.CONTROLLERS``); a kind that cannot be built for a task (an RL kind without a
shipped policy raises ``FileNotFoundError``; a law that cannot fly the task raises
``controllers.laws.base.UnsupportedTask``) is skipped with a printed note.  Law artefacts join as
contenders named after their files (``policies``, :mod:`controllers.evaluation.contenders`).

``backend="ray"`` (``rig compare --backend ray [--address ADDR] [--chunk-size N]``) runs each batch's episodes
in chunks on a Ray cluster (:mod:`controllers.evaluation.ray_backend`; a local one on this machine unless
``address``): the same numbers as ``backend="local"`` for the same seed; the chunks, nodes and retries are in
``summary.json`` (``timing.backend``).
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from dataclasses import fields, replace
from pathlib import Path
from typing import Any, Mapping, Sequence, TextIO

from controllers import CONTROLLERS, Controller, LoopSpec, UnsupportedTask, make_controller
from controllers.evaluation import figures, report, schema
from controllers.evaluation.config import MAX_EPISODES
from controllers.evaluation.contenders import load_contenders
from controllers.evaluation.reach import reach
from controllers.evaluation.score import DEFAULT_RULE, ScoreRule, recommend, shared_failures
from controllers.evaluation.summary import Comparison, format_table, rows_of
from controllers.evaluation.evaluate import MAX_SEED, MODES, evaluate
from controllers.design import DESIGNS
from controllers.design.conditions import modes_for
from controllers.design.tuning import plain
from controllers.laws import law_for
from rig_env.compile_watch import compile_watch
from rig_env.envs import TASKS, RigVectorEnv
from rig_env.precompile import precompile
from rig_env.params import RigParams
from rig_env.paths import check_out_folder

QUICK_EPISODES, FULL_EPISODES = 12, 64
"""Episodes per law, task and mode: ``--quick``, default; ``--episodes`` allows 1..:data:`MAX_EPISODES`."""
PREFERRED_ORDER = ("pid", "lqr", "ppo", "sac")


def default_kinds() -> list[str]:
    """Registered kinds that build from a loop spec alone (not "linear": it takes its gains), the preferred ones first."""
    kinds = sorted((k for k, classes in CONTROLLERS.items() if any(c.built_from_spec for c in classes)), key=lambda k: (PREFERRED_ORDER.index(k) if k in PREFERRED_ORDER else len(PREFERRED_ORDER), k))
    return kinds


def _check_kinds(kinds: Sequence[str]) -> None:
    """ValueError for a kind no class of which builds from the task alone ("linear": its gains are arguments), saying
    how such a law joins a comparison: as a law file (``rig-deploy export``) passed with ``--policy``."""
    for k in kinds:
        if not any(c.built_from_spec for c in CONTROLLERS[k]):
            raise ValueError(f"--controllers {k}: this law takes its gains, which rig compare cannot design; write it to a law "
                             f"file (rig-deploy export --controller {k} --task TASK --gains KP KD KFF --out FILE.json) and pass "
                             "that with --policy FILE.json")


def _name_list(option: str, names: Sequence[str] | None, what: str) -> list[str] | None:
    """``names`` as a list, or a ValueError naming ``option``: a bare string (it would be read letter by letter), an
    empty list (the API's None is "the default"; an empty list would silently mean all, or crash) or a name given
    twice (it would fly twice: duplicated rows, tables and work)."""
    if names is None:
        return None
    if isinstance(names, str):
        raise ValueError(f"{option} {names!r}: must be a list of {what}, e.g. [{names!r}]")
    out = list(names)
    if not out:
        raise ValueError(f"{option}: an empty list; give at least one of the {what} (or None for the default)")
    twice = sorted({n for n in out if out.count(n) > 1})
    if twice:
        raise ValueError(f"{option} {' '.join(map(str, out))}: {', '.join(map(str, twice))} given more than once; give each once")
    return out


def _known(option: str, names: Sequence[str], allowed: list[str]) -> None:
    """A ValueError naming ``option`` and the first unknown name, with the closest known one (a misspelt task or kind
    is the usual cause) and every allowed name."""
    from rig_env.params_io import did_you_mean

    for name in names:
        if name not in allowed:
            raise ValueError(f"{option} {name}: unknown{did_you_mean(str(name), allowed, cutoff=0.6)}; allowed: {', '.join(allowed)}")


def check_conditions(conditions: Mapping[str, Any] | None) -> dict[str, Any]:
    """``conditions`` (overrides of every mode) checked as ``--config``'s ``[conditions]`` table is
    (:data:`controllers.evaluation.config.CONDITION_FIELDS`): a one-line ValueError naming the key and its range,
    not a TypeError from deep inside for a misspelt key; ``airspeed`` may be a tuple or a list."""
    from controllers.evaluation.config import _conditions

    if conditions is None:
        return {}
    if not isinstance(conditions, Mapping):
        return _conditions("conditions", conditions)  # refuses it, naming the allowed keys
    given = {k: list(v) if k == "airspeed" and isinstance(v, tuple) else v for k, v in conditions.items()}
    return _conditions("conditions", given)


def check_rule(rule: ScoreRule | Mapping[str, float]) -> ScoreRule:
    """``rule`` as a :class:`ScoreRule`: a mapping (``--config``'s ``[score]`` table) is read as its fields; a misspelt key
    or a value out of range is a one-line ValueError naming it (not an AttributeError when the tables are scored)."""
    if isinstance(rule, ScoreRule):
        return rule
    allowed = [f.name for f in fields(ScoreRule)]
    if not isinstance(rule, Mapping):
        raise ValueError(f"rule = {rule!r}: must be a ScoreRule or a mapping with keys from {allowed}")
    bad = sorted(set(rule) - set(allowed))
    if bad:
        raise ValueError(f"score: unknown key(s) {bad}; allowed: {allowed}")
    return ScoreRule(**rule)  # ScoreRule names a value out of range (score.KEY = V: must be ...)


def check_options(tasks: Sequence[str] | None, kinds: Sequence[str] | None, episodes: int | None, seed: int, quick: bool,
                  modes: Sequence[str], policies: Sequence[str | Path],
                  conditions: Mapping[str, Any] | None = None, record: int = 3) -> tuple[list[str], list[str], int]:
    """The tasks, kinds and episodes per law after the defaults, or a one-line ValueError naming the option: unknown,
    repeated or no names (:func:`_name_list`), a kind that needs its gains (:func:`_check_kinds`), ``--episodes`` outside
    [1, :data:`MAX_EPISODES`], ``--seed`` outside [0, :data:`MAX_SEED`] (episode ``i`` is seeded ``seed + i``), a bad
    ``conditions`` key or value (:func:`check_conditions`) and a ``record`` that is not a count.  Nothing is built before."""
    tasks = _name_list("--tasks", tasks, "task names")
    kinds = _name_list("--controllers", kinds, "law kinds") if kinds is None or len(kinds) else list(kinds)  # []: only --policy laws
    modes = _name_list("--modes", modes, "modes")
    if isinstance(policies, (str, Path)):  # a bare path would be read character by character ("/": not a file)
        raise ValueError(f"--policy {str(policies)!r}: must be a list of law files, e.g. [{str(policies)!r}]")
    tasks = tasks if tasks is not None else list(TASKS)
    kinds = kinds if kinds is not None else default_kinds()
    _known("--tasks", tasks, sorted(TASKS))
    _known("--controllers", kinds, sorted(CONTROLLERS))
    _check_kinds(kinds)
    _known("--modes", modes, sorted(MODES))
    if not kinds and not policies:
        raise ValueError("--controllers: none given; give at least one law kind or one --policy file")
    n = episodes if episodes is not None else (QUICK_EPISODES if quick else FULL_EPISODES)
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_EPISODES:
        raise ValueError(f"--episodes = {n!r}: must be an integer in [1, {MAX_EPISODES}]")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"--seed = {seed!r}: must be an integer in [0, {MAX_SEED}]")
    check_conditions(conditions)
    if isinstance(record, bool) or not isinstance(record, int) or record < 0:
        raise ValueError(f"record = {record!r}: must be an integer >= 0 (episodes per law whose time histories are kept)")
    return tasks, kinds, n


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
    policies: Sequence[str | Path] = (),
    conditions: Mapping[str, Any] | None = None,
    rule: ScoreRule | Mapping[str, float] = DEFAULT_RULE,
    overwrite: bool = False,
    command: str | None = None,
    backend: str = "local",
    address: str | None = None,
    chunk_size: int | None = None,
) -> Comparison:
    """Run the comparison and write its files (none when ``out_dir`` is None); returns the numbers.

    ``stream``: where the notes and tables go (default stdout); ``progress``: True for a progress
    display on stderr, False for none, or a stream; ``params_file``: the rig's parameter file (None:
    the default rig; a missing or invalid file is a ValueError naming it), see the module docstring;
    ``policies``: law artefact files, each a contender on its task named after its file
    (:mod:`controllers.evaluation.contenders`); ``conditions``: overrides of every mode's
    conditions (:data:`controllers.evaluation.config.CONDITION_FIELDS`, checked as ``--config``'s); ``rule``: the score and
    the criterion (a :class:`ScoreRule`, or a mapping of its fields as ``--config``'s ``[score]``); ``overwrite``: replace files in ``out_dir`` that an earlier comparison did not write
    (see :func:`check_out_dir`); ``command``: the command line to record (default: built from the arguments);
    ``backend``: "local" (one process) or "ray" (chunks of ``chunk_size`` episodes as Ray tasks on the cluster at
    ``address``, default a local one; :mod:`controllers.evaluation.ray_backend`), the same numbers either way.
    """
    from rig_env import distributed

    check_options(tasks, kinds, episodes, seed, quick, modes, policies, conditions, record)  # before a Ray session or anything else starts
    rule = check_rule(rule)
    if out_dir is not None and not str(out_dir).strip():  # Path("") is ".": the files would land in the working folder
        raise ValueError(f"--out {str(out_dir)!r}: an empty folder name; give a folder (e.g. out/compare, or . for this one)")
    if out_dir is not None and record < 1:  # history_<task>.png draws recorded episode 0: an IndexError after the whole run
        raise ValueError(f"record = {record!r}: the history figures need at least one recorded episode; give record >= 1, "
                         "or out_dir=None for no files")
    distributed.check_backend(backend, address)
    distributed.check_chunk_size(chunk_size)
    if chunk_size == 1:
        raise ValueError("--chunk-size = 1: must be an integer in [2, 100000] (a batch of one rounds differently from the local run's)")
    if chunk_size is not None and backend != "ray":
        raise ValueError(f"--chunk-size {chunk_size}: only with --backend ray")
    if backend == "ray":
        with distributed.session(address):
            return _compare(tasks, kinds, episodes, seed, quick, modes, out_dir, record, stream, progress, params_file,
                            policies, conditions, rule, overwrite, command, backend, chunk_size)
    return _compare(tasks, kinds, episodes, seed, quick, modes, out_dir, record, stream, progress, params_file,
                    policies, conditions, rule, overwrite, command, backend, chunk_size)


def _compare(tasks: Sequence[str] | None, kinds: Sequence[str] | None, episodes: int | None, seed: int, quick: bool,
             modes: Sequence[str], out_dir: str | Path | None, record: int, stream: TextIO | None, progress: bool | TextIO,
             params_file: str | Path | None, policies: Sequence[str | Path], conditions: Mapping[str, Any] | None,
             rule: ScoreRule, overwrite: bool, command: str | None, backend: str, chunk_size: int | None) -> Comparison:
    stream = stream if stream is not None else sys.stdout
    prog: TextIO | None = sys.stderr if progress is True else (None if progress is False else progress)
    tasks, kinds, n = check_options(tasks, kinds, episodes, seed, quick, modes, policies, conditions, record)
    modes = list(modes)
    earlier: list[str] = []
    if out_dir is not None:
        earlier = check_out_dir(Path(out_dir), overwrite, stream, tasks)
    contenders = load_contenders(policies, kinds)
    for c in contenders:
        if c.task not in tasks:
            stream.write(f"  note: {c.name} ({c.path}) flies {c.task}, which this comparison does not include\n")
    params = None if params_file is None else _load_params(params_file)
    given = conditions
    base = MODES if params is None else modes_for(params)
    conditions = {m: replace(base[m], **check_conditions(conditions)) for m in MODES}
    env_params = {} if params_file is None else {"params_file": str(params_file)}
    settings = {"tasks": tasks, "laws": kinds, "policies": {c.name: c.describe() for c in contenders}, "episodes": n, "seed": seed,
                "quick": quick, "modes": list(modes),
                "conditions": {m: {**conditions[m].env_fields(), "randomise": {k: list(v) for k, v in conditions[m].randomise.items()}} for m in modes},
                "params_file": None if params_file is None else str(params_file),
                "machine": f"{platform.machine()} {platform.system()}, python {platform.python_version()}"}
    settings["command"] = command or _command(quick, n, seed, tasks, kinds, modes, params_file, policies, check_conditions(given), rule)
    cmp = Comparison(settings, rule=rule)
    fields0 = {**conditions[modes[0]].env_fields(), **env_params}
    # the kernels, side by side, on a fresh installation; matplotlib is imported meanwhile (the report needs it)
    precompile(tasks, fields0, design=True, stream=prog, while_waiting=figures.preload if out_dir is not None else None,
               batch_sizes=_batch_sizes(tasks, kinds, contenders, n) if backend == "local" else None)  # ray: chunks of other sizes
    t0 = time.perf_counter()
    with compile_watch(prog):  # anything left to compile is announced while it compiles
        for task in tasks:
            floor = {m: conditions[m].env_fields(task)["airspeed"] for m in modes}
            if any(tuple(floor[m]) != tuple(conditions[m].airspeed) for m in modes):
                a = floor[modes[0]]
                stream.write(f"  note: {task} flies at {a[0]:g}-{a[1]:g} m/s: below {TASKS[task].min_airspeed:g} m/s the default "
                             "rig cannot hold what the task draws (Task.min_airspeed)\n")
                cmp.settings.setdefault("airspeed", {})[task] = [float(a[0]), float(a[1])]
            laws, skipped = _build(kinds, task, n, {**conditions[modes[0]].env_fields(task), **env_params}, stream, params)
            spec = LoopSpec.from_env(RigVectorEnv(1, task=task, **{**conditions[modes[0]].env_fields(task), **env_params}))
            for c in (c for c in contenders if c.task == task):
                try:
                    c.check(spec)
                    laws[c.name] = c.build  # a factory: evaluate builds it for each batch
                except UnsupportedTask as exc:
                    skipped.append({"task": task, "controller": c.name, "reason": str(exc)})
                    stream.write(f"  note: {c.name} skipped on {task}: {exc}\n")
            cmp.skipped += skipped
            if not laws:
                continue
            if params is not None:  # an identified (or other) rig: do the task's draws stay within its reach?
                lo, hi = min(floor[m][0] for m in modes), max(floor[m][1] for m in modes)
                beyond = reach(task, params, (lo, hi))
                for line in beyond:
                    stream.write(f"  note: {line}\n")
                cmp.settings.setdefault("reach", {})[task] = beyond
            for law_name, law in laws.items():
                if hasattr(law, "describe"):
                    cmp.margins.setdefault(task, {})[law_name] = plain(law.describe())
            for mode in modes:
                if backend == "ray":
                    from controllers.evaluation.ray_backend import evaluate_ray, factory_of

                    factories = {name: factory_of(law, name, params) for name, law in laws.items()}
                    res, run = evaluate_ray(factories, task, n_episodes=n, seed=seed, conditions=conditions[mode], record=record,
                                            env_overrides=env_params, chunk_size=chunk_size, progress=prog, ledger_name=f"{task}-{mode}")
                    cmp.backend.setdefault("backend", "ray")
                    cmp.backend.setdefault("batches", []).append(run.to_dict())
                    cmp.backend["retries"] = cmp.backend.get("retries", 0) + run.retries
                else:
                    res = evaluate(laws, task, n_episodes=n, seed=seed, conditions=conditions[mode], record=record, env_overrides=env_params,
                                   progress=prog)
                cmp.results.append(res)
                rows = rows_of(res, rule)
                cmp.rows += rows
                cmp.recommendations.setdefault(task, {})[mode] = recommend({r["law"]: r for r in rows}, rule, shared_failures(res.metrics))
    cmp.seconds = time.perf_counter() - t0
    if not cmp.rows:  # every law skipped: no table, and the figures would fail on no data after a half-written folder
        who = " ".join([*kinds, *(c.name for c in contenders)])
        raise ValueError(f"--controllers {who}: no law could fly {', '.join(tasks)} (every one skipped, the notes above say why); "
                         "nothing written; choose other --controllers or pass a law file with --policy")
    for mode in modes:
        rows = [r for r in cmp.rows if r["mode"] == mode]
        stream.write("\n" + format_table(rows, f"{mode}: {n} episodes per law and task, seed {seed} ({_mode_note(mode, conditions[mode])})") + "\n")
    stream.write("\n" + "\n".join(report.verdict(cmp)) + "\n")
    stream.write(f"\ncompared in {cmp.seconds:.0f} s\n")
    if cmp.backend:
        nodes = sorted({n for b in cmp.backend["batches"] for n in b["nodes"]})
        chunks = sum(len(b["chunks"]) for b in cmp.backend["batches"])
        stream.write(f"ray backend: {chunks} chunks on {len(nodes)} node(s), {cmp.backend['retries']} retried "
                     "(a lost worker or node; every episode accounted for)\n")
    if out_dir is not None:
        write_files(cmp, Path(out_dir), stream, earlier)
    stream.flush()
    return cmp


def _batch_sizes(tasks: Sequence[str], kinds: Sequence[str], contenders: Sequence[Any], n: int) -> dict[str, int]:
    """Each task's batch size (n episodes per law) as far as it is known before any law is built, for the precompiler,
    which then compiles only the version of the physics kernel (serial or parallel) each batch runs: the kinds and the
    task's contenders, less the trained kinds without a shipped policy for the task (skipped, see :func:`_build`).  A law
    found unable to fly the task only when it is built (``UnsupportedTask``) is counted: a batch that turns out smaller
    may then run the other version, compiled when first used (and announced), not wrongly."""
    from controllers.laws.rl import MLPPolicy, policy_path

    def skipped(kind: str, task: str) -> bool:
        return all(issubclass(c, MLPPolicy) for c in CONTROLLERS[kind]) and not policy_path(task, kind).is_file()

    return {t: n * max(1, sum(not skipped(k, t) for k in kinds) + sum(c.task == t for c in contenders)) for t in tasks}


def _command(quick: bool, n: int, seed: int, tasks: list[str], kinds: list[str], modes: Sequence[str],
             params_file: str | Path | None, policies: Sequence[str | Path], conditions: Mapping[str, Any] | None = None,
             rule: ScoreRule = DEFAULT_RULE) -> str:
    """The command line of an API call.  Conditions and a score rule have no options, only ``--config`` tables: they are
    named after the line (the TOML that reproduces them), or the line would claim to reproduce a run it does not."""
    cmd = ["rig compare"] + (["--quick"] if quick else []) + [f"--episodes {n}", f"--seed {seed}"]
    cmd += [f"--tasks {' '.join(tasks)}"] if tasks != list(TASKS) else []
    cmd += [f"--controllers {' '.join(kinds)}"] if kinds != default_kinds() else []
    cmd += [f"--modes {' '.join(modes)}"] if list(modes) != ["nominal", "robust"] else []
    cmd += [f"--params {params_file}"] if params_file is not None else []
    cmd += [f"--policy {' '.join(str(p) for p in policies)}"] if policies else []
    toml = lambda v: f"[{v[0]!r}, {v[1]!r}]" if isinstance(v, (tuple, list)) else repr(v)  # noqa: E731
    tables = ([f"[conditions] {', '.join(f'{k} = {toml(v)}' for k, v in conditions.items())}"] if conditions else [])
    changed = {k: v for k, v in rule.to_dict().items() if v != DEFAULT_RULE.to_dict()[k]}
    tables += [f"[score] {', '.join(f'{k} = {v!r}' for k, v in changed.items())}"] if changed else []
    return " ".join(cmd) + (f" --config FILE.toml (FILE.toml: {'; '.join(tables)})" if tables else "")


OUR_FILES = ("summary.json", "summary.csv", "report.md", "metrics.png")
OUR_PATTERNS = ("history_*.png", "distributions_*.png")


def _task_files(tasks: Sequence[str]) -> list[str]:
    """The figures a comparison of ``tasks`` draws (:func:`controllers.evaluation.report.write`): a task's history and
    distributions (only for a task some law flew)."""
    return [f"{kind}_{t}.png" for t in tasks for kind in ("history", "distributions")]


def _earlier_files(earlier: Any) -> list[str] | None:
    """The files an earlier comparison wrote, from its ``summary.json`` document: its ``settings.files`` (recorded since
    that key exists), else exactly the names this code writes for the tasks in its ``results``; only plain names of
    the comparison's kinds (never a path).  None when the document is not a rig compare summary."""
    settings = earlier.get("settings") if isinstance(earlier, dict) else None
    if not isinstance(settings, dict) or not str(settings.get("command", "")).startswith("rig compare"):
        return None
    files = settings.get("files")
    if isinstance(files, list) and all(isinstance(f, str) for f in files):
        names = files
    else:  # an older summary: what this code would have written for it
        results = earlier.get("results")
        names = [*OUR_FILES, *_task_files([t for t in results if isinstance(t, str)] if isinstance(results, dict) else [])]
    return sorted({f for f in names if f == Path(f).name and f not in ("", ".", "..")
                   and (f in OUR_FILES or any(Path(f).match(pat) for pat in OUR_PATTERNS))})


def check_out_dir(out: Path, overwrite: bool, stream: TextIO, tasks: Sequence[str] = ()) -> list[str]:
    """The files of an earlier comparison in ``out`` (its ``summary.json`` lists them, :func:`_earlier_files`), which
    this one replaces or removes with a note naming them; a ValueError (before anything runs) when ``out`` holds a
    file this comparison of ``tasks`` would write that the earlier one did not, unless ``overwrite``: nothing a user
    wrote is replaced silently, and a file of no comparison's name (or of a task not compared now) is left alone."""
    check_out_folder("--out", out)  # a file, or a folder under one: refused before anything runs
    if not out.exists():
        _check_creatable(out)
        return []
    if not os.access(out, os.W_OK | os.X_OK):
        raise ValueError(f"--out {out}: not writable; give a folder you can write")
    try:
        earlier = _earlier_files(json.loads((out / "summary.json").read_text()))
    except (OSError, ValueError):
        earlier = None
    ours = [f for f in earlier or [] if (out / f).is_file()]
    clash = [f for f in dict.fromkeys([*OUR_FILES, *_task_files(tasks)]) if (out / f).exists() and f not in ours]
    if clash and not overwrite:
        raise ValueError(f"--out {out}: holds {', '.join(clash[:4])}{' ...' if len(clash) > 4 else ''}, "
                         "not written by an earlier rig compare; choose another --out or pass --overwrite")
    if clash:
        stream.write(f"  note: --overwrite: replacing {', '.join(clash)} in {out}, not written by an earlier rig compare\n")
    if ours:
        stream.write(f"  note: replacing the earlier comparison in {out}: its files {', '.join(ours)} are rewritten or removed "
                     "(nothing else there is touched)\n")
    return ours


def _load_params(params_file: str | Path) -> RigParams:
    """The ``--params`` file, or a one-line ValueError naming the option (ParameterError names only the file)."""
    try:
        return RigParams.from_toml(params_file)
    except ValueError as exc:
        msg = str(exc)
        msg = msg[len(f"{params_file}: "):] if msg.startswith(f"{params_file}: ") else msg
        raise ValueError(f"--params {params_file}: {msg}") from None


def _check_creatable(out: Path) -> None:
    """A ValueError naming ``--out`` when the folder cannot be made (no permission, a read-only or virtual file system):
    found now, by making it and removing it again, not by ``mkdir`` after the whole comparison has run."""
    missing = [p for p in (out, *out.parents) if not p.exists()]  # deepest first: the order to remove them in
    try:
        out.mkdir(parents=True)
    except OSError as exc:
        raise ValueError(f"--out {out}: cannot be created ({exc.strerror}); give a folder you can write") from None
    for p in missing:
        p.rmdir()


def _mode_note(mode: str, c: Any = None) -> str:
    """The table's heading: the conditions as flown (``c``, with the ``[conditions]`` overrides), not the defaults."""
    c = c if c is not None else MODES.get(mode)
    if c is None:
        return mode
    a = f"airspeed {c.airspeed[0]:g}-{c.airspeed[1]:g} m/s, {100 * c.turbulence:g} % gusts"
    return {"nominal": f"{a}, sensor noise, parameter spread",
            "robust": f"{a}, sensor noise, parameter spread, plus +-20 % on aerodynamic derivatives and friction",
            "gusty": f"{a} (atmospheric, a stress case), sensor noise, parameter spread"}.get(mode, mode)


def write_files(cmp: Comparison, out: Path, stream: TextIO, earlier: Sequence[str] = ()) -> None:
    """Plots, report.md, summary.json and summary.csv (:mod:`controllers.evaluation.schema`) into ``out``; the names of
    the files written are in summary.json (``settings.files``).  ``earlier``: the files an earlier comparison wrote
    there (:func:`check_out_dir`); those this one does not rewrite (figures of tasks not flown now) are removed, and
    no other file."""
    out.mkdir(parents=True, exist_ok=True)
    # summary.json first, listing the files about to be drawn: a run stopped while drawing (Ctrl-C, a full disk) then
    # leaves a folder the next rig compare recognises as its own, not one it refuses as holding a user's files
    first = cmp.settings["modes"][0]
    cmp.settings["files"] = sorted({*OUR_FILES, *(f"history_{r.task}.png" for r in cmp.results if r.conditions == first),
                                    *(f"distributions_{r['task']}.png" for r in cmp.rows)})
    schema.write(cmp, out)
    files = report.write(cmp, out, progress=stream)
    drawn = sorted({*OUR_FILES, *(p.name for p in files)})
    if drawn != cmp.settings["files"]:  # the plan above missed or added a figure: record what was written
        cmp.settings["files"] = drawn
        schema.write(cmp, out)
    for stale in sorted(set(earlier) - set(cmp.settings["files"])):  # an earlier run's figures of tasks not flown now
        (out / stale).unlink(missing_ok=True)
    stream.write(f"wrote {out}/summary.json, summary.csv, report.md and {len(files)} plots\n")

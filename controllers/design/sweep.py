"""Training sweeps on Ray Tune: ``rig sweep CONFIG.toml`` and ``rig train --seeds ... --backend ray``.

Every trial is one ``rig train`` run (:func:`controllers.design.rl_train._train`, the same code as a local run)
of one (task, seed, hyperparameter point) of the grid, seeded by its own seed (its row names it; no two trials
share task, point and seed; the grid's points share the listed seeds on purpose, so that two settings are
compared on the same seeds' randomness), never by the worker or the order it ran in; Tune schedules the trials on the
cluster (one CPU each), keeps their checkpoints under the storage path, restarts a lost trial from its last
checkpoint (``FailureConfig(max_failures)``) and resumes a stopped sweep (``rig sweep CONFIG --resume``:
``Tuner.restore``; finished trials are kept, unfinished ones continue from their checkpoints).  The results are
folded into one table; the best trial's policy is exported as a plain-data law artefact ready for
``rig compare --policy``.

The configuration (every key optional except ``algo`` and ``tasks``; paths relative to the file):

```toml
algo = "ppo"                       # ppo | sac
tasks = ["bank_to_bank"]           # rig_env.envs.TASKS
seeds = [0, 1, 2]                  # every trial is seeded by its own seed (default [0])
timesteps = 200_000                # per trial (default: the settings file's)
hyperparams = "my_ppo.toml"        # the base settings file (default: controllers/design/hyperparams/<algo>.toml)
conditions = "nominal"             # as rig train --conditions
storage = "runs/sweeps"            # Tune's storage path: checkpoints and state (a shared folder or bucket on a cluster)
name = "b2b_lr"                    # the sweep's folder under the storage path
metric = "success_rate"            # the best trial's criterion: success_rate (max), rms_error_deg (min), mean_return (max)
checkpoint_every = 50_000          # timesteps between checkpoints (what a lost trial resumes from)
eval_every = 50_000                # timesteps between evaluations (default: the settings file's)
eval_episodes = 32
final_episodes = 64                # the exported policy's final evaluation
max_failures = 3                   # restarts of a lost trial
stop_at_target = false             # true: a trial stops at --target-success like rig train (default: the whole budget)

[env]                              # RigEnvConfig fields, as rig train --env
turbulence = 0.02

[grid]                             # each key a list of values (dotted: nested settings); trials = tasks x seeds x grid
num_envs = [64, 256]
"algo.learning_rate" = [1e-4, 3e-4]
```

Outputs in ``<storage>/<name>/summary/``:

| file | content |
|---|---|
| ``sweep.csv`` | one row per trial: task, seed, the grid's values, ``success_rate`` (fraction of the final evaluation's episodes), ``rms_error_deg`` (deg), ``mean_return``, ``timesteps``, ``wall_time_s`` (s), ``attempt`` (1 + restarts), ``status`` |
| ``sweep.json`` | the rows, the mean and spread over seeds per (task, point), the best trial, the retries (trial, error) |
| ``sweep.png`` | success rate (%) and RMS error (deg) per grid point, every seed a dot, the seeds' mean a bar |
| ``best_policy.json`` | the best trial's policy (plain data, :mod:`controllers.laws.artefact`): ``rig compare --policy`` flies it |

Progress: a line every few seconds with the trials done, running and retried (:class:`Books`).

``rig sweep`` exits 0 when every trial finished, 1 when some did not (``--resume`` runs them again), 2 on a bad
configuration or folder, refused before Ray starts.  It writes into a new or empty folder or one of its own sweeps
(the folder holds its ``sweep.toml.json``); ``--overwrite`` replaces such a sweep, removing only what a sweep writes
there (entries of other origin stay), and never touches a folder that is not a sweep.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import math
import re
import shutil
import sys
import tempfile
import time
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence, TextIO

from controllers.design.rl_hyperparams import ALGOS, HyperparamError, settings
from rig_env import distributed
from rig_env.paths import check_out_folder

METRICS = {"success_rate": "max", "rms_error_deg": "min", "mean_return": "max"}
CONDITIONS = ("nominal", "robust", "gusty", "none")
BOOKS_FILE = "books.json"
CONFIG_FILE = "sweep.toml.json"  # the sweep's configuration, written first into its folder: what marks it a sweep
SUMMARY_FILES = ("sweep.csv", "sweep.json", "sweep.png", "best_policy.json")
TUNE_FILES = ("tuner.pkl", ".validate_storage_marker", "experiment_state-*.json", "basic-variant-state-*.json",
              "search_gen_state-*.json")  # Tune's state of the experiment in its folder
TRIAL_DIR = re.compile(r"trial_[0-9a-f]{5}_[0-9]{5,}_")  # a Tune trial's folder of the trainable ``trial``


class SweepError(ValueError):
    """A sweep configuration or state that cannot be used; the message names the key or the folder."""


@dataclass(frozen=True)
class SweepConfig:
    """A parsed sweep (see the module docstring); ``storage`` absolute."""

    algo: str
    tasks: list[str]
    seeds: list[int] = field(default_factory=lambda: [0])
    grid: dict[str, list[Any]] = field(default_factory=dict)
    timesteps: int | None = None
    hyperparams: str | None = None
    conditions: str = "nominal"
    env: dict[str, Any] = field(default_factory=dict)
    storage: str = str(Path("runs/sweeps").resolve())
    name: str = "sweep"
    metric: str = "success_rate"
    checkpoint_every: int = 50_000
    eval_every: int | None = None
    eval_episodes: int = 32
    final_episodes: int = 64
    max_failures: int = 3
    stop_at_target: bool = False
    target_success: float = 0.95

    @property
    def folder(self) -> Path:
        return Path(self.storage) / self.name

    def points(self) -> list[dict[str, Any]]:
        """The grid's points (the product of its lists; one empty point for an empty grid)."""
        keys = list(self.grid)
        return [dict(zip(keys, vals)) for vals in itertools.product(*(self.grid[k] for k in keys))]

    def n_trials(self) -> int:
        return len(self.tasks) * len(self.seeds) * len(self.points())


def _int(where: str, v: Any, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise SweepError(f"{where} = {v!r}: must be an integer in [{lo}, {hi}]")
    return v


def _same(a: Any, b: Any) -> bool:
    return a == b and isinstance(a, bool) == isinstance(b, bool)  # true is not 1


def _check_env(cfg: SweepConfig, task: str, file_env: dict[str, Any], where: str) -> None:
    """The trial's environment settings as rig train builds them (``--conditions``, then the settings file's ``env``
    table, then ``[env]``: :func:`controllers.design.rl_train.training_overrides`) checked by RigEnvConfig."""
    from controllers.design.conditions import MODES
    from rig_env.envs.config import RigEnvConfig

    base = dict(MODES[cfg.conditions].env_fields(task)) if cfg.conditions != "none" else {}
    base.update(file_env)
    try:
        RigEnvConfig(task=task).with_overrides(**base)
    except (ValueError, TypeError) as exc:
        raise SweepError(f"{where}: conditions = {cfg.conditions!r} with the settings file's env table {file_env} "
                         f"(task {task}): {exc}") from None
    try:
        RigEnvConfig(task=task).with_overrides(**{**base, **{k: json.loads(json.dumps(v)) for k, v in cfg.env.items()}})
    except (ValueError, TypeError) as exc:  # as a trial reads it: --env KEY=JSON
        raise SweepError(f"{where}: [env] {exc}") from None


def check(cfg: SweepConfig, where: str = "sweep") -> SweepConfig:
    """Every field in range, every grid point a valid settings override for every task, the environment settings
    valid and the folders usable (SweepError naming it); a warning on stderr if a trial would take no checkpoint."""
    from rig_env.envs.tasks import TASKS

    if cfg.algo not in ALGOS:
        raise SweepError(f"{where}: algo = {cfg.algo!r}: allowed {list(ALGOS)}")
    if not cfg.tasks or any(t not in TASKS for t in cfg.tasks) or len(set(cfg.tasks)) != len(cfg.tasks):
        raise SweepError(f"{where}: tasks = {cfg.tasks!r}: distinct names from {sorted(TASKS)}")
    if not cfg.seeds or len(set(cfg.seeds)) != len(cfg.seeds):
        raise SweepError(f"{where}: seeds = {cfg.seeds!r}: a non-empty list of distinct integers >= 0")
    for s in cfg.seeds:
        _int(f"{where}: seeds[...]", s, 0, 2**31 - 1)
    if cfg.conditions not in CONDITIONS:
        raise SweepError(f"{where}: conditions = {cfg.conditions!r}: allowed {list(CONDITIONS)}")
    if cfg.metric not in METRICS:
        raise SweepError(f"{where}: metric = {cfg.metric!r}: allowed {list(METRICS)}")
    if not cfg.name or "/" in cfg.name or cfg.name in (".", ".."):
        raise SweepError(f"{where}: name = {cfg.name!r}: a folder name (no '/')")
    if cfg.timesteps is not None:
        _int(f"{where}: timesteps", cfg.timesteps, 1, 10**10)
    if cfg.eval_every is not None:
        _int(f"{where}: eval_every", cfg.eval_every, 1, 10**10)
    _int(f"{where}: checkpoint_every", cfg.checkpoint_every, 1, 10**10)
    _int(f"{where}: eval_episodes", cfg.eval_episodes, 1, 100_000)
    _int(f"{where}: final_episodes", cfg.final_episodes, 1, 100_000)
    _int(f"{where}: max_failures", cfg.max_failures, 0, 100)
    ts = cfg.target_success
    if isinstance(ts, bool) or not isinstance(ts, (int, float)) or not 0.0 < ts <= 1.0:
        raise SweepError(f"{where}: target_success = {ts!r}: must be a number in the range (0, 1]")
    for k, vals in cfg.grid.items():
        if not isinstance(vals, list) or not vals:
            raise SweepError(f"{where}: grid.{k} = {vals!r}: must be a non-empty list of values")
        for i, v in enumerate(vals):
            if any(_same(v, w) for w in vals[:i]):
                raise SweepError(f"{where}: grid.{k} = {vals!r}: the value {v!r} is listed twice; list each value once")
    if "task" in cfg.env:
        raise SweepError(f"{where}: [env] task: not an environment setting here; the tasks are the key tasks")
    for k, v in cfg.env.items():
        try:
            json.dumps(v)
        except (TypeError, ValueError):
            raise SweepError(f"{where}: [env] {k} = {v!r}: must be a number, string, boolean, list or table") from None
    shortest: tuple[int, str] | None = None
    envs: set[tuple[str, str]] = set()
    for task in cfg.tasks:
        for point in cfg.points():
            try:
                hp = settings(cfg.algo, task, Path(cfg.hyperparams) if cfg.hyperparams else None, point)
            except HyperparamError as exc:
                raise SweepError(f"{where}: grid point {point}: {exc}") from None
            steps = cfg.timesteps or hp.timesteps  # as rig train: --timesteps, else the settings'
            if shortest is None or steps < shortest[0]:
                shortest = (steps, "" if cfg.timesteps else f" (the settings' for {task}{f' at {point}' if point else ''})")
            key = (task, json.dumps(hp.env, sort_keys=True, default=str))
            if key not in envs:  # a grid of other settings shares the file's env table: check it once
                envs.add(key)
                _check_env(cfg, task, dict(hp.env), where)
    try:
        check_out_folder(f"{where}: storage", cfg.storage)
        check_out_folder(f"{where}: name", cfg.folder)
    except ValueError as exc:
        raise SweepError(str(exc)) from None
    if shortest is not None and cfg.checkpoint_every >= shortest[0]:
        sys.stderr.write(f"{where}: warning: checkpoint_every = {cfg.checkpoint_every} >= timesteps = {shortest[0]}"
                         f"{shortest[1]}: no checkpoint before a trial's end, so a lost trial restarts from scratch; "
                         "give checkpoint_every < timesteps\n")
    return cfg


def parse(path: str | Path) -> SweepConfig:
    """Read and check a sweep file (SweepError naming the file and the key)."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text())
    except OSError as e:
        raise SweepError(f"{p}: cannot read ({e.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise SweepError(f"{p}: not valid TOML ({e})") from None
    known = [f for f in SweepConfig.__dataclass_fields__]
    bad = sorted(set(data) - set(known))
    if bad:
        raise SweepError(f"{p}: unknown key(s) {bad}; allowed: {known}")
    for k in ("algo", "tasks"):
        if k not in data:
            raise SweepError(f"{p}: {k} is required")
    kinds: dict[str, type | tuple[type, ...]] = {"algo": str, "tasks": list, "seeds": list, "grid": dict, "hyperparams": str, "conditions": str, "env": dict,
             "storage": str, "name": str, "metric": str, "stop_at_target": bool, "target_success": (int, float)}
    for k, t in kinds.items():
        if k in data and not isinstance(data[k], t):
            raise SweepError(f"{p}: {k} = {data[k]!r}: must be a {getattr(t, '__name__', 'number')}")
    d = dict(data)
    base = p.parent
    d["storage"] = str((base / d.get("storage", "runs/sweeps")).resolve())
    if "hyperparams" in d:
        d["hyperparams"] = str((base / d["hyperparams"]).resolve())
    return check(SweepConfig(**d), str(p))


# ----------------------------------------------------------------- one trial (on a worker)
def _argv(cfg: SweepConfig, task: str, seed: int, out: Path) -> list[str]:
    a = ["--algo", cfg.algo, "--task", task, "--seed", str(seed), "--out", str(out), "--conditions", cfg.conditions,
         "--checkpoint-every", str(cfg.checkpoint_every), "--eval-episodes", str(cfg.eval_episodes),
         "--final-episodes", str(cfg.final_episodes), "--target-success", str(cfg.target_success), "--no-progress",
         "--threads", "1"]
    a += ["--timesteps", str(cfg.timesteps)] if cfg.timesteps else []
    a += ["--eval-every", str(cfg.eval_every)] if cfg.eval_every else []
    a += ["--hyperparams", cfg.hyperparams] if cfg.hyperparams else []
    a += [] if cfg.stop_at_target else ["--no-stop"]
    for k, v in cfg.env.items():
        a += ["--env", f"{k}={json.dumps(v)}"]
    return a


def _report_callback(freq: int, report: Any) -> Any:
    from stable_baselines3.common.callbacks import BaseCallback

    class ReportCheckpoint(BaseCallback):  # type: ignore[misc]
        """After SB3's CheckpointCallback (same frequency, later in the list): hand the checkpoint to Tune."""

        def _on_step(self) -> bool:
            if self.n_calls % freq == 0:
                report(int(self.num_timesteps))
            return True

    return ReportCheckpoint()


def _copy_checkpoint(run: Path, dest: Path, n: int) -> None:
    (dest / "checkpoints").mkdir(parents=True, exist_ok=True)
    for name in (f"rl_model_{n}_steps.zip", f"rl_model_vecnormalize_{n}_steps.pkl", f"rl_model_replay_buffer_{n}_steps.pkl"):
        if (run / "checkpoints" / name).is_file():
            shutil.copy2(run / "checkpoints" / name, dest / "checkpoints" / name)
    for name in ("run.json", "curve.json"):
        if (run / name).is_file():
            shutil.copy2(run / name, dest / name)


TrainTrial = Callable[[list[str], dict[str, Any], "Path | None", Any], None]
"""``(argv, hp_overrides, resume_dir, extra_callbacks) -> None``: one ``rig train`` run
(:func:`controllers.design.rl_train.train_trial`; handed in, so that this module never imports the trainer, which
imports this one for ``--backend ray``)."""


RESULT_FILE = "result.json"  # Tune's log of what a trial reported, one JSON line per result, in the trial's folder


def recorded_final(trial_dir: Path) -> dict[str, Any] | None:
    """The first final result in ``trial_dir``'s result.json (Tune logged it: the trial is done), or None.

    This, not the state Tune saves, is what says a trial finished: Tune logs a result (result.json, the trial's
    last result) as soon as it arrives but takes in the result's checkpoint only when a separate save call
    returns, so a sweep stopped in between is saved with the trial running and its previous checkpoint."""
    path = trial_dir / RESULT_FILE
    if not path.is_file():
        return None
    for line in path.read_text().splitlines():
        try:
            result = json.loads(line)
        except ValueError:  # a line being written
            continue
        if isinstance(result, dict) and result.get("final"):
            return result
    return None


def final_policy(trial_dir: Path, final: dict[str, Any] | None = None) -> Path | None:
    """The policy.json of the checkpoint reported with the trial's final result (``final``, or read with
    :func:`recorded_final`), or None."""
    final = final if final is not None else recorded_final(trial_dir)
    path = trial_dir / str(final.get("checkpoint_dir_name")) / "policy.json" if final is not None else None
    return path if path is not None and path.is_file() else None


def _persisted_final(trial_dir: Path) -> tuple[Path, dict[str, Any]] | None:
    """A whole final checkpoint in ``trial_dir`` (its trial.json holds the final result, its policy.json reads)
    and its trial.json; None if there is none.  Tune writes a reported checkpoint to storage before the result
    goes to the driver, so one can be there although its result never reached result.json."""
    for d in sorted(trial_dir.glob("checkpoint_*"), reverse=True):
        try:
            book = json.loads((d / "trial.json").read_text())
            json.loads((d / "policy.json").read_text())  # copied file by file: a stop mid-copy leaves it short
        except (OSError, ValueError):
            continue
        if isinstance(book, dict) and book.get("final") and isinstance(book.get("metrics"), dict):
            return d, book
    return None


def trial(config: dict[str, Any], sweep: dict[str, Any], train: TrainTrial) -> None:
    """One Tune trial: ``rig train`` of ``config`` (task, seed, hp) resumed from Tune's checkpoint if any.

    A trial that finished before a stop is never trained again when Tune restarts it (it does when the stop came
    before Tune took in the final checkpoint, or before the trial function returned): its final result stands."""
    where = distributed.node_setup()
    import torch
    from ray import tune

    torch.set_num_threads(1)  # one CPU per trial

    cfg = SweepConfig(**sweep)
    folder = cfg.folder / Path(tune.get_context().get_trial_dir()).name  # this trial's folder under the storage path
    run = Path(tempfile.mkdtemp(prefix="rig-trial-"))
    ckpt = tune.get_checkpoint()
    attempt, resumed = 1, None
    book: dict[str, Any] = {}
    if ckpt is not None:
        ckpt.to_directory(str(run))
        book = json.loads((run / "trial.json").read_text())
    if book.get("final") or recorded_final(folder) is not None:
        # Restored from its final checkpoint, or from an earlier one although result.json holds its final result
        # (stopped before Tune took in the final checkpoint).  Nothing is left to run, and reporting again would
        # append a second final line: return, and the sweep's table takes the trial's row from result.json.
        shutil.rmtree(run, ignore_errors=True)
        return
    done = _persisted_final(folder)
    if done is not None:
        # its final checkpoint reached storage but its result never reached Tune: report that result, not a new one
        shutil.rmtree(run, ignore_errors=True)
        with tempfile.TemporaryDirectory() as d:
            shutil.copytree(done[0], d, dirs_exist_ok=True)
            tune.report(dict(done[1]["metrics"]), checkpoint=tune.Checkpoint.from_directory(d))
        return
    if ckpt is not None:
        attempt, resumed = int(book["attempt"]) + 1, int(book["timesteps"])
    argv = _argv(cfg, config["task"], int(config["seed"]), run)
    who = {"attempt": attempt, "resumed_from": resumed, "node": where["node"], "pid": where["pid"]}

    def report(n: int) -> None:
        with tempfile.TemporaryDirectory() as d:
            _copy_checkpoint(run, Path(d), n)
            (Path(d) / "trial.json").write_text(json.dumps({"attempt": attempt, "timesteps": n, **where}))
            tune.report({"timesteps": n, "final": False, **who}, checkpoint=tune.Checkpoint.from_directory(d))

    t0 = time.perf_counter()
    train(argv, dict(config["hp"]), run if resumed is not None else None, lambda out, freq: [_report_callback(freq, report)])
    prov = json.loads((run / "policy.json").read_text())["provenance"]
    fe = prov["final_eval"]
    final = {"success_rate": float(fe["success_rate"]), "rms_error_deg": float(fe["rms_error_deg"]),
             "mean_return": float(fe["mean_return"]), "timesteps": int(prov["timesteps"]),
             "wall_time_s": float(prov["wall_time_s"]), "trial_seconds": time.perf_counter() - t0, "final": True, **who}
    with tempfile.TemporaryDirectory() as d:
        for name in ("policy.json", "curve.json", "curve.png"):
            if (run / name).is_file():
                shutil.copy2(run / name, Path(d) / name)
        # the result rides with its checkpoint, so that a restart that finds the checkpoint can report it again
        (Path(d) / "trial.json").write_text(json.dumps({"attempt": attempt, "timesteps": prov["timesteps"], "final": True,
                                                        **where, "metrics": final}))
        tune.report(final, checkpoint=tune.Checkpoint.from_directory(d))
    shutil.rmtree(run, ignore_errors=True)


# ----------------------------------------------------------------- the books (on the driver)
_BOOKS: list[type] = []


def make_books(total: int, folder: str | Path, quiet: bool = False, every: float = distributed.PROGRESS_EVERY_S) -> Any:
    """A Tune callback (``Books``) counting the trials done, running and retried, printing a progress line to
    stderr every ``every`` seconds (unless ``quiet``) and keeping the retries in ``folder/books.json`` (across a
    stop and a resume: Tune saves its callbacks with the sweep's state; they pickle as this call)."""
    if not _BOOKS:
        from ray.tune import Callback

        class Books(Callback):  # type: ignore[misc]
            def __init__(self, total: int, folder: str, quiet: bool, every: float) -> None:
                self.args = (total, folder, quiet, every)
                self.total, self.quiet, self.every = total, quiet, every
                self.path = Path(folder) / BOOKS_FILE
                old = json.loads(self.path.read_text()) if self.path.is_file() else {}
                self.retries: list[dict[str, Any]] = list(old.get("retries", []))
                self.runs = int(old.get("runs", 0)) + 1
                self.t0 = self.last = time.perf_counter()

            def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
                return make_books, self.args

            def _save(self) -> None:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self.path.write_text(json.dumps({"retries": self.retries, "runs": self.runs}, indent=1))

            def on_trial_recover(self, iteration: int, trials: list[Any], trial: Any, **info: Any) -> None:
                self.retries.append({"trial": trial.trial_id, "task": trial.config["task"], "seed": trial.config["seed"],
                                     "hp": trial.config["hp"], "run": self.runs})
                self._save()
                if not self.quiet:
                    sys.stderr.write(f"  ray sweep: trial {trial.trial_id} (task {trial.config['task']}, seed {trial.config['seed']}) "
                                     "lost its worker: restarting from its last checkpoint\n")

            def on_step_end(self, iteration: int, trials: list[Any], **info: Any) -> None:
                now = time.perf_counter()
                if self.quiet or now - self.last < self.every:
                    return
                self.last = now
                st = [t.status for t in trials]
                sys.stderr.write(f"  ray sweep: {st.count('TERMINATED')}/{self.total} trials done, {st.count('RUNNING')} running, "
                                 f"{st.count('PENDING')} pending, {len(self.retries)} retried, {now - self.t0:.0f} s\n")
                sys.stderr.flush()

            def on_experiment_end(self, trials: list[Any], **info: Any) -> None:
                self._save()

        _BOOKS.append(Books)
    return _BOOKS[0](total, str(folder), quiet, every)


def read_books(folder: Path) -> list[dict[str, Any]]:
    """The retries the sweep in ``folder`` recorded (every run of it: a stop and a resume keep them)."""
    path = folder / BOOKS_FILE
    return list(json.loads(path.read_text()).get("retries", [])) if path.is_file() else []


# ----------------------------------------------------------------- the sweep (on the driver)
def _sweep_entries(folder: Path) -> list[Path]:
    """What a sweep wrote in ``folder``: its configuration and books, Tune's state and trial folders, the summary's
    files (not the summary folder: it can hold other files)."""
    found = [folder / n for n in (CONFIG_FILE, BOOKS_FILE)]
    found += [f for pattern in TUNE_FILES for f in folder.glob(pattern)]
    found += [d for d in folder.iterdir() if d.is_dir() and not d.is_symlink() and TRIAL_DIR.match(d.name)]
    found += [folder / "summary" / n for n in SUMMARY_FILES]
    return [f for f in found if f.is_file() or f.is_dir()]


def _replace(folder: Path, out: TextIO) -> None:
    """``--overwrite``: remove the sweep in ``folder`` (what :func:`_sweep_entries` finds), keep everything else."""
    for f in _sweep_entries(folder):
        if f.is_dir():
            shutil.rmtree(f)
        else:
            f.unlink()
    summary = folder / "summary"
    if summary.is_dir() and not any(summary.iterdir()):
        summary.rmdir()
    kept = sorted(str(f.relative_to(folder)) for f in [*folder.iterdir(), *(summary.iterdir() if summary.is_dir() else ())]
                  if f != summary)
    out.write(f"replaced the sweep in {folder}" + (f"; kept what it did not write: {kept}\n" if kept else "\n"))


def _check_folder(folder: Path, *, resume: bool, overwrite: bool, state: bool) -> None:
    """Refuse a ``folder`` that cannot take this sweep (SweepError naming it): ``--resume`` without a sweep's state,
    a folder that is not a sweep (files of other origin), a sweep without ``--resume`` or ``--overwrite``."""
    if resume:
        if not state:
            raise SweepError(f"--resume: {folder} holds no sweep to resume")
        return
    if not folder.is_dir() or not any(folder.iterdir()):
        return
    if not (folder / CONFIG_FILE).is_file():
        held = sorted(f.name for f in folder.iterdir())
        shown = ", ".join(held[:5]) + (f" and {len(held) - 5} more" if len(held) > 5 else "")
        raise SweepError(f"{folder}: not a sweep (no {CONFIG_FILE}; it holds {shown}): rig sweep writes only into a new or "
                         "empty folder or one of its own sweeps; choose another name or storage")
    if not overwrite:
        what = "holds a sweep; --resume continues it, " if state else "holds a sweep that never started (no Tune state); "
        raise SweepError(f"{folder}: {what}--overwrite replaces it, or choose another name")


def run_sweep(cfg: SweepConfig, *, train: TrainTrial, address: str | None = None, resume: bool = False, overwrite: bool = False,
              stream: TextIO | None = None, progress: bool = True) -> dict[str, Any]:
    """Run (or with ``resume`` continue) the sweep ``cfg`` on the Ray cluster at ``address`` (default: a local one,
    or the session already connected); fold the results (module docstring) and return ``sweep.json``'s content.
    ``train``: one trial's run (:func:`controllers.design.rl_train.train_trial`).
    ``stream``: the notes and the table (default stdout); ``progress``: a line on stderr every few seconds."""
    out = stream if stream is not None else sys.stdout
    distributed.require_ray()
    from ray import tune

    folder = cfg.folder
    try:
        check_out_folder("storage", cfg.storage)
        check_out_folder("name", folder)
    except ValueError as exc:
        raise SweepError(str(exc)) from None
    state = folder.is_dir() and tune.Tuner.can_restore(str(folder))
    _check_folder(folder, resume=resume, overwrite=overwrite, state=state)
    if not resume and (folder / CONFIG_FILE).is_file():
        _replace(folder, out)
    trainable = tune.with_resources(tune.with_parameters(trial, sweep=asdict(cfg), train=train), {"cpu": 1})
    books = make_books(cfg.n_trials(), folder, quiet=progress is False)
    with distributed.session(address):
        if resume:
            out.write(f"resuming the sweep in {folder}\n")
            # the books come back with the saved state (make_books again: the retries so far from books.json)
            tuner = tune.Tuner.restore(str(folder), trainable=trainable, resume_unfinished=True, resume_errored=True)
        else:
            folder.mkdir(parents=True, exist_ok=True)
            (folder / CONFIG_FILE).write_text(json.dumps(asdict(cfg), indent=1))
            tuner = tune.Tuner(
                trainable,
                param_space={"task": tune.grid_search(cfg.tasks), "seed": tune.grid_search(cfg.seeds), "hp": tune.grid_search(cfg.points())},
                tune_config=tune.TuneConfig(reuse_actors=False),
                run_config=tune.RunConfig(name=cfg.name, storage_path=cfg.storage, verbose=0, callbacks=[books],
                                          failure_config=tune.FailureConfig(max_failures=cfg.max_failures),
                                          checkpoint_config=tune.CheckpointConfig(num_to_keep=2)),
            )
        out.write(f"sweep {cfg.name}: {cfg.n_trials()} trials ({len(cfg.tasks)} task(s) x {len(cfg.seeds)} seed(s) x "
                  f"{len(cfg.points())} point(s)) of {cfg.algo} on Ray, storage {folder}\n")
        out.flush()
        grid = tuner.fit()
    return fold(cfg, grid, read_books(folder), out)


def _status(r: Any, final: dict[str, Any] | None) -> str:
    if final is not None:  # its result stands whatever happened to the trial after it
        return "done"
    return "error" if r.error is not None else "stopped"


def fold(cfg: SweepConfig, grid: Any, retries: list[dict[str, Any]], out: TextIO) -> dict[str, Any]:
    """The trials as one table (``sweep.csv``, ``sweep.json``, ``sweep.png``) and the best policy exported."""
    keys = list(cfg.grid)
    rows: list[dict[str, Any]] = []
    best: tuple[Path, dict[str, Any]] | None = None
    sign = 1.0 if METRICS[cfg.metric] == "max" else -1.0
    for r in grid:
        # a trial's result is the first final one in its result.json, not Tune's last result and checkpoint, which
        # can be an earlier one's (recorded_final); a restart that ran it again must not replace it either
        final, c = recorded_final(Path(r.path)), r.config
        m = final or r.metrics or {}
        row = {"task": c["task"], "seed": c["seed"], **{k: c["hp"].get(k) for k in keys},
               "success_rate": m.get("success_rate"), "rms_error_deg": m.get("rms_error_deg"), "mean_return": m.get("mean_return"),
               "timesteps": m.get("timesteps"), "wall_time_s": m.get("wall_time_s"), "attempt": m.get("attempt"),
               "status": _status(r, final), "trial": Path(r.path).name}
        rows.append(row)
        policy = final_policy(Path(r.path), final) if final is not None else None
        if policy is not None:
            score = (sign * row[cfg.metric], -row["rms_error_deg"])
            if best is None or score > best[1]["_score"]:
                best = (policy, {**row, "_score": score})
    rows.sort(key=lambda r: (r["task"], [str(r[k]) for k in keys], r["seed"]))
    summary = folder_out = cfg.folder / "summary"
    folder_out.mkdir(parents=True, exist_ok=True)
    with open(summary / "sweep.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else ["task"])
        w.writeheader()
        w.writerows(rows)
    points = []
    for (task, *vals), group in itertools.groupby(sorted(rows, key=lambda r: (r["task"], *[json.dumps(r[k]) for k in keys])),
                                                  key=lambda r: (r["task"], *[json.dumps(r[k]) for k in keys])):
        g = [r for r in group if r["status"] == "done"]
        sr = [r["success_rate"] for r in g]
        rm = [r["rms_error_deg"] for r in g]
        points.append({"task": task, **{k: json.loads(v) for k, v in zip(keys, vals)}, "seeds": len(g),
                       "success_rate_mean": _mean(sr), "success_rate_std": _std(sr),
                       "rms_error_deg_mean": _mean(rm), "rms_error_deg_std": _std(rm)})
    result: dict[str, Any] = {"trials": len(rows), "done": sum(r["status"] == "done" for r in rows), "rows": rows, "points": points,
                              "retries": retries, "metric": cfg.metric, "best": None}
    if best is not None:
        src, row = best
        dest = summary / "best_policy.json"
        shutil.copy2(src, dest)
        result["best"] = {k: v for k, v in row.items() if k != "_score"} | {"policy": str(dest)}
    (summary / "sweep.json").write_text(json.dumps(result, indent=1, default=str) + "\n")
    _plot(rows, keys, summary / "sweep.png", f"{cfg.algo.upper()} sweep {cfg.name}")
    out.write(f"sweep {cfg.name}: {result['done']}/{len(rows)} trials done, {len(retries)} retried (lost workers or nodes, "
              f"resumed from their checkpoints)\n")
    for p in points:
        label = ", ".join(f"{k}={p[k]}" for k in keys) or "settings file"
        out.write(f"  {p['task']} [{label}]: success {_pct(p['success_rate_mean'])} +- {_pct(p['success_rate_std'])} over "
                  f"{p['seeds']} seed(s), RMS error {_num(p['rms_error_deg_mean'])} deg\n")
    if result["best"]:
        out.write(f"best ({cfg.metric}): {result['best']['task']} seed {result['best']['seed']} -> {result['best']['policy']}\n"
                  f"  rig compare --tasks {result['best']['task']} --policy {result['best']['policy']}\n")
    out.write(f"wrote {summary}/sweep.csv, sweep.json, sweep.png\n")
    out.flush()
    return result


def _mean(v: list[float]) -> float | None:
    return float(sum(v) / len(v)) if v else None


def _std(v: list[float]) -> float | None:
    if len(v) < 2:
        return None
    m = sum(v) / len(v)
    return float(math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)))


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.0f} %"


def _num(v: float | None) -> str:
    return "-" if v is None else f"{v:.2f}"


def _plot(rows: list[dict[str, Any]], keys: list[str], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = sorted({(r["task"], *[json.dumps(r[k]) for k in keys]) for r in rows})
    fig, axes = plt.subplots(1, 2, figsize=(max(6.0, 1.2 * len(labels) + 3), 4.0))
    for ax, key, scale, ylabel in ((axes[0], "success_rate", 100.0, "final success rate, %"),
                                   (axes[1], "rms_error_deg", 1.0, "final RMS tracking error, deg")):
        for i, lab in enumerate(labels):
            ys = [scale * r[key] for r in rows if (r["task"], *[json.dumps(r[k]) for k in keys]) == lab and r[key] is not None]
            if ys:
                ax.bar(i, sum(ys) / len(ys), color="C0", alpha=0.35)
                ax.plot([i] * len(ys), ys, "o", color="C0")
        ax.set_xticks(range(len(labels)))
        ax.set_xticklabels(["\n".join([lab[0], *[f"{k}={v}" for k, v in zip(keys, lab[1:])]]) for lab in labels], fontsize=7)
        ax.set_ylabel(ylabel)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(f"{title}: every seed a dot, the seeds' mean a bar")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ----------------------------------------------------------------- command line
def main(argv: Sequence[str] | None, train: TrainTrial) -> int:
    """``rig sweep CONFIG.toml [--address ADDR] [--resume] [--overwrite]`` (``rig_cli.main`` hands in ``train``,
    :func:`controllers.design.rl_train.train_trial`); exit 2 with one line on a bad input."""
    p = argparse.ArgumentParser(prog="rig sweep", description=__doc__.split("\n")[0])
    p.add_argument("config", metavar="CONFIG.toml", help="the sweep (controllers.design.sweep: algo, tasks, seeds, [grid], storage, name ...)")
    p.add_argument("--address", default=None, metavar="ADDR", help="the Ray cluster (auto, HOST:PORT; default: a local cluster)")
    p.add_argument("--resume", action="store_true", help="continue the stopped sweep in <storage>/<name> (Tuner.restore)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an earlier sweep of the same name (only what a sweep writes; never a folder that is not one)")
    a = p.parse_args(list(sys.argv[1:] if argv is None else argv))
    try:
        cfg = parse(a.config)
        result = run_sweep(cfg, train=train, address=a.address, resume=a.resume, overwrite=a.overwrite)
    except ValueError as exc:  # SweepError, BackendError: one line
        print(f"rig sweep: error: {exc}", file=sys.stderr)
        return 2
    if result["done"] < result["trials"]:
        what = "no trial" if result["done"] == 0 else f"only {result['done']} of the {result['trials']} trials"
        print(f"rig sweep: error: {what} finished (the status column of {cfg.folder / 'summary' / 'sweep.csv'}, the errors in "
              "the trials' error.txt); --resume runs the unfinished ones again", file=sys.stderr)
        return 1
    return 0

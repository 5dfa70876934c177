"""Train PPO or SAC on a rig task over the native batch and export the policy as plain data.

    rig train --algo ppo --task velocity_vector_roll              # the settings file's settings, nominal conditions
    rig train --algo ppo --task bank_to_bank --timesteps 300000 --seed 1 --out runs/b2b
    rig train --algo ppo --task velocity_vector_roll --ship       # also into controllers/policies/
    rig train --algo ppo --task pull_up_push_over --conditions none --env turbulence=0.02
    rig train --algo ppo --task bank_to_bank --seeds 0 1 2         # three seeds and their spread
    rig train --algo ppo --task bank_to_bank --hyperparams my.toml # a user's own settings file
    rig train --resume runs/bank_to_bank_ppo_s0 --timesteps 6000000  # continue from the last checkpoint
    rig train --algo ppo --task free_flight_emulation --warm-start lqr  # clone the designed LQR first, then PPO

Settings per (algorithm, task): ``controllers/design/hyperparams/<algo>.toml`` (read and checked by
:mod:`controllers.design.rl_hyperparams`; ``--hyperparams FILE`` for another file of the same shape).
The reward is the task's own, training and evaluation alike (the tasks' docstrings define it).  The batch
is one :class:`rig_env.envs.sb3.RigSB3VecEnv` (no per-environment Python objects), wrapped in
``VecMonitor``, the file's optional curriculum (``error_reset``: a training episode ends once an error entry
passes a bound, :class:`controllers.design.rl_callbacks.ErrorReset`; ``--no-error-reset`` drops it) and,
where the file says so, ``VecNormalize`` of observations (its statistics are shipped with the policy; rewards
are not normalised).  An ``EvalCallback`` runs every ``eval_every`` timesteps on a separate batch seeded
``seed + 10000``, reseeded before every evaluation (the same episodes each time, so the curve compares like
with like); training stops once its success rate reaches ``--target-success`` (the task's per-episode
success criterion met in that share of episodes; ``--no-stop`` trains on).  Output folder:

| file | content |
|---|---|
| ``policy.json`` | the policy as a rig-law artefact (:mod:`controllers.laws.artefact`, kind ``ppo`` / ``sac``; runtime :mod:`controllers.laws.rl`); its provenance is the training record: command, settings, environment settings, curve, final evaluation, time split, versions |
| ``run.json`` | the command that started the run (what ``--resume`` continues) |
| ``curve.json``, ``curve.png`` | evaluation points: timesteps, wall time s, mean return, success rate (``curve.json`` after every evaluation) |
| ``evaluations.npz``, ``best_model.zip`` | SB3's EvalCallback output (pickle-based zip: for training use only) |
| ``checkpoints/`` | SB3 checkpoints + VecNormalize statistics (+ SAC's replay buffer) every ``--checkpoint-every`` steps |
| ``tb/`` | TensorBoard logs (``tensorboard --logdir OUT/tb``) when tensorboard is installed |

An ``--out`` folder that already holds a run is refused unless ``--overwrite`` (or ``--resume`` it).
``--resume RUN_DIR`` reloads the last checkpoint (model, optimiser, VecNormalize statistics, timesteps done)
and trains on to the budget (``--timesteps`` of the resuming command, else the run's own), the curve
continuing where it stopped.

``--warm-start LAW`` (PPO): before training, the task's designed law (``lqr``, ``pid``) flies the training batch for
``--warm-start-samples`` steps and the policy's deterministic action is regressed on its command, the value
function on its returns (:mod:`controllers.design.rl_warmstart`); recorded as ``warm_start`` in the provenance.

Training conditions: the comparison's randomised conditions ``--conditions`` (default ``nominal``,
:data:`controllers.design.conditions.MODES`: airspeed 15-25 m/s, gusts, sensor noise and delay, parameter
spread, so that the policy meets in training what the comparison flies it in; ``none``: the task's own
defaults), then the settings file's ``env`` table, then each ``--env KEY=VALUE`` (a
:class:`rig_env.envs.RigEnvConfig` field; the value is read as JSON when it parses, e.g.
``airspeed=[15,25]``, else as a string); an unknown field or a value out of range exits with the
configuration's error.  The result is recorded in the policy's provenance (``env_overrides``) and the
final evaluation runs under it.

``--seeds S1 S2 ...`` trains one run per seed (``OUT/s<seed>/``, default ``OUT = runs/<task>_<algo>_seeds``)
and writes ``OUT/seeds.json`` (each seed's final metrics, their mean and standard deviation) and
``OUT/seeds.png`` (every seed's evaluation curve): one seed is an anecdote.
``--backend ray [--address ADDR]`` trains the seeds as a Ray Tune sweep instead (:mod:`controllers.design.sweep`:
one trial per seed on the cluster, checkpointed under ``OUT``, a lost trial resumed from its last checkpoint),
then writes ``OUT/s<seed>/policy.json`` and ``OUT/seeds.json`` as above.

The final metrics are those of the exported file, loaded back and run by numpy
(:func:`controllers.design.rl_export.evaluate`, ``--final-episodes`` episodes seeded ``seed + 20000``).
Progress: a tqdm bar (a line every 10 s without tqdm or with ``--no-progress``) with steps/s and the
wall time split into environment, policy (the rest of the rollouts), learner and evaluation; the split is
recorded (``time_split_s``).  Threads: torch and numba use ``--threads`` (default 1: the machine is
shared).  Optional packages: ``pip install -e .[train]`` (tensorboard, tqdm).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import shlex
import sys
import time
from pathlib import Path
from typing import Any

EVAL_SEED_OFFSET, FINAL_SEED_OFFSET = 10_000, 20_000
CONDITIONS = ("nominal", "robust", "gusty", "none")
RUN_FILE = "run.json"  # the command that started a run (what --resume continues)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="rig train", description=__doc__.split("\n")[0])
    p.add_argument("--algo", choices=["ppo", "sac"], default=None, help="required unless --resume")
    p.add_argument("--task", default=None, help="task name (rig_env.envs.TASKS); required unless --resume")
    p.add_argument("--hyperparams", type=Path, default=None, metavar="FILE",
                   help="a settings file of the shape of controllers/design/hyperparams/<algo>.toml (default: that file)")
    p.add_argument("--timesteps", type=int, default=None, help="training budget (default: the settings file's)")
    seeds = p.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=int, default=0)
    seeds.add_argument("--seeds", type=int, nargs="+", default=None, help="train one run per seed and summarise their spread")
    p.add_argument("--conditions", choices=CONDITIONS, default="nominal",
                   help="the comparison's randomised conditions to train under (controllers.design.conditions.MODES; "
                        "default nominal); none: the task's defaults")
    p.add_argument("--env", action="append", default=[], metavar="KEY=VALUE",
                   help="an environment setting (a RigEnvConfig field; JSON value), repeatable; applied last")
    p.add_argument("--out", type=Path, default=None, help="output folder (default runs/<task>_<algo>_s<seed>)")
    p.add_argument("--resume", type=Path, default=None, metavar="RUN_DIR",
                   help="continue RUN_DIR's run from its last checkpoint (model, normalisation statistics, timesteps done)")
    p.add_argument("--overwrite", action="store_true", help="replace the run in an existing --out folder")
    p.add_argument("--num-envs", type=int, default=None, help="environments in the training batch (default: the settings file's)")
    p.add_argument("--threads", type=int, default=1, help="torch and numba threads (default 1: the machine is shared)")
    p.add_argument("--eval-every", type=int, default=None, help="timesteps between evaluations (default: the settings file's)")
    p.add_argument("--eval-episodes", type=int, default=64)
    p.add_argument("--final-episodes", type=int, default=100)
    p.add_argument("--target-success", type=float, default=0.95, help="stop when the eval success rate reaches this")
    p.add_argument("--no-stop", action="store_true", help="train the whole budget even after reaching the target")
    p.add_argument("--no-error-reset", action="store_true", help="no lost-track curriculum even where the settings file has one (ablation)")
    p.add_argument("--checkpoint-every", type=int, default=200_000, help="timesteps between checkpoints")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (a line every 10 s instead)")
    p.add_argument("--ship", action="store_true", help="copy policy.json and curve.png into controllers/policies/")
    from controllers.design.rl_warmstart import WARM_START_LAWS

    p.add_argument("--warm-start", choices=WARM_START_LAWS, default=None, metavar="LAW",
                   help="PPO only: before training, behaviour-clone the task's designed LAW (lqr, pid) into the policy "
                        "(controllers.design.rl_warmstart)")
    p.add_argument("--warm-start-samples", type=int, default=500_000, help="environment steps the law flies for --warm-start")
    p.add_argument("--backend", choices=["local", "ray"], default="local",
                   help="local (one process, seed after seed) or ray: the seeds as a Ray Tune sweep, one trial per seed, "
                        "checkpointed under OUT (controllers.design.sweep; pip install -e \".[ray]\")")
    p.add_argument("--address", default=None, metavar="ADDR", help="with --backend ray: the cluster (auto, HOST:PORT; default: a local one)")
    a = p.parse_args(argv)
    if a.resume is None:
        for name in ("algo", "task"):
            if getattr(a, name) is None:
                p.error(f"--{name} is required (unless --resume RUN_DIR)")
    elif a.seeds is not None or a.out is not None:
        p.error("--resume RUN_DIR continues one run in RUN_DIR: no --seeds or --out")
    if a.warm_start is not None and (a.algo == "sac" or a.resume is not None):
        p.error("--warm-start: PPO only, and not with --resume (the resumed run keeps its own start)")
    for name in ("timesteps", "num_envs", "eval_every", "threads", "eval_episodes", "final_episodes", "checkpoint_every",
                 "warm_start_samples"):
        v = getattr(a, name)
        if v is not None and v < 1:
            p.error(f"--{name.replace('_', '-')} = {v}: must be a positive integer")
    cpus = os.cpu_count() or 1
    if a.threads is not None and a.threads > cpus:
        p.error(f"--threads = {a.threads}: allowed range [1, {cpus}] (this machine's CPUs; more only oversubscribes them)")
    if a.task is not None:
        from rig_env.envs.tasks import TASKS
        from rig_env.params_io import did_you_mean

        if a.task not in TASKS:
            p.error(f"--task {a.task!r}: unknown{did_you_mean(a.task, sorted(TASKS))}; valid names: {sorted(TASKS)}")
    if a.out is not None:
        from rig_env.paths import check_out_folder

        try:
            check_out_folder("--out", a.out)
        except ValueError as exc:
            p.error(str(exc))
    if a.seed < 0 or any(x < 0 for x in a.seeds or ()):
        p.error(f"--seed/--seeds = {a.seeds or a.seed}: must be >= 0")
    if a.seeds is not None and len(set(a.seeds)) != len(a.seeds):
        p.error(f"--seeds = {a.seeds}: repeated seed")
    if a.seeds is not None and a.ship:
        p.error("--ship takes one --seed: pick the seed to ship from seeds.json and train it with --seed")
    if a.address is not None and a.backend != "ray":
        p.error(f"--address {a.address}: only with --backend ray")
    if a.backend == "ray" and (a.resume is not None or a.ship or a.no_error_reset or a.warm_start is not None):
        p.error("--backend ray trains --seeds as a sweep: no --resume (rig sweep --resume continues a sweep), --ship, "
                "--no-error-reset or --warm-start")
    a.env_kv = {}
    for item in a.env:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            p.error(f"--env {item!r}: expected KEY=VALUE")
        try:
            a.env_kv[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            a.env_kv[key.strip()] = value
    if not 0.0 < a.target_success <= 1.0:
        p.error(f"--target-success = {a.target_success}: allowed range (0, 1]")
    return a


def resume_args(argv: list[str]) -> tuple[argparse.Namespace, list[str]]:
    """The arguments of the run in ``--resume RUN_DIR`` (its ``run.json``), with ``--timesteps``, ``--threads``,
    ``--no-progress`` and ``--ship`` of the resuming command taking over; and the argv recorded for provenance."""
    now = parse_args(argv)
    run_dir = now.resume
    rec = run_dir / RUN_FILE
    if not rec.is_file():
        raise SystemExit(f"rig train: --resume {run_dir}: no {RUN_FILE} there (not a rig train run folder)")
    old_argv = json.loads(rec.read_text())["argv"]
    old = parse_args(old_argv)
    old.out, old.resume, old.seeds = run_dir, run_dir, None
    for name in ("threads", "ship", "no_progress"):
        setattr(old, name, getattr(now, name))
    if now.timesteps is not None:
        old.timesteps = now.timesteps
    return old, old_argv


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    if args.resume is not None:
        args, argv = resume_args(argv)
    if "numba" not in sys.modules:  # a fresh process: size the thread pools before they start
        os.environ["NUMBA_NUM_THREADS"] = str(args.threads)
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):  # numpy's BLAS, before numpy loads
            os.environ.setdefault(var, str(args.threads))
    # called in-process (tests, notebooks): never change the environment numba reads its config from
    # (a later compile would find NUMBA_NUM_THREADS changed and refuse); set the running pools and restore them
    import numba
    import torch

    saved = (numba.get_num_threads(), torch.get_num_threads())
    numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    torch.set_num_threads(args.threads)
    try:
        if args.backend == "ray":
            return _train_on_ray(args)
        if args.seeds is None:
            return _train(args, argv)
        from controllers.design.rl_seeds import summarise

        root = args.out or Path("runs") / f"{args.task}_{args.algo}_seeds"
        for seed in args.seeds:  # refuse before the first seed trains, not after
            _check_out(root / f"s{seed}", args.overwrite)
        runs = []
        for k, seed in enumerate(args.seeds):
            print(f"=== seed {seed} ({k + 1} of {len(args.seeds)})", flush=True)
            one = argparse.Namespace(**{**vars(args), "seed": seed, "seeds": None, "out": root / f"s{seed}"})
            one_argv = [*_without_seeds(argv), "--seed", str(seed), "--out", str(root / f"s{seed}")]
            _train(one, one_argv)
            runs.append(root / f"s{seed}" / "policy.json")
        summarise(runs, root, f"{args.algo.upper()} on {args.task}", args.target_success)
        return 0
    finally:
        numba.set_num_threads(saved[0])
        torch.set_num_threads(saved[1])


def train_trial(argv: list[str], hp_overrides: dict[str, Any], resume: Path | None, extra_callbacks: Any) -> None:
    """One trial of a sweep (:mod:`controllers.design.sweep`, which is handed this function: it never imports this
    module): the run ``argv`` describes, with the grid point's settings ``hp_overrides`` over the settings file's,
    continued from the checkpoint in ``resume`` if given; ``extra_callbacks(out, checkpoint_freq)``: SB3 callbacks
    after the checkpoint's (the trial's report to Tune)."""
    args = parse_args(argv)
    args.hp_overrides = dict(hp_overrides)
    if resume is not None:
        args.resume = resume
    args.extra_callbacks = extra_callbacks
    _train(args, argv)


def _train_on_ray(args: argparse.Namespace) -> int:
    """``--backend ray``: the seeds as a Ray Tune sweep (:mod:`controllers.design.sweep`) in OUT (default
    ``runs/<task>_<algo>_seeds``), each seed's policy then in ``OUT/s<seed>/policy.json`` and their spread in
    ``OUT/seeds.json`` as a local ``--seeds`` run writes them."""
    from controllers.design.rl_seeds import summarise
    from controllers.design.sweep import (
        SweepConfig,
        SweepError,
        check,
        final_policy,
        run_sweep,
    )

    root = (args.out or Path("runs") / f"{args.task}_{args.algo}_seeds").resolve()
    seeds = args.seeds if args.seeds is not None else [args.seed]
    try:
        cfg = check(SweepConfig(
            algo=args.algo, tasks=[args.task], seeds=list(seeds), grid={"num_envs": [args.num_envs]} if args.num_envs else {},
            timesteps=args.timesteps, hyperparams=str(args.hyperparams.resolve()) if args.hyperparams else None,
            conditions=args.conditions, env=dict(args.env_kv), storage=str(root.parent), name=root.name,
            checkpoint_every=args.checkpoint_every, eval_every=args.eval_every, eval_episodes=args.eval_episodes,
            final_episodes=args.final_episodes, stop_at_target=not args.no_stop, target_success=args.target_success), "rig train")
        result = run_sweep(cfg, train=train_trial, address=args.address, overwrite=args.overwrite, progress=not args.no_progress)
    except (SweepError, ValueError) as exc:  # a bad setting, Ray missing (BackendError names the extra): exit 2
        print(f"rig train: error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    import shutil

    runs = []
    for row in result["rows"]:
        policy = final_policy(root / row["trial"])  # the row's result's policy (a trial's folder can hold others)
        if row["status"] != "done" or policy is None:
            continue
        dest = root / f"s{row['seed']}" / "policy.json"
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(policy, dest)
        runs.append(dest)
    if runs:
        summarise(runs, root, f"{args.algo.upper()} on {args.task}", args.target_success)
    return 0 if len(runs) == len(seeds) else 1


def _without_seeds(argv: list[str]) -> list[str]:
    """argv less ``--seeds S1 S2 ...`` and ``--out DIR`` (one seed's run records its own)."""
    out: list[str] = []
    it = iter(argv)
    skipping = False
    for a in it:
        if a == "--out":
            next(it, None)
            skipping = False
        elif a == "--seeds":
            skipping = True
        elif skipping and not a.startswith("--"):
            continue
        else:
            skipping = False
            out.append(a)
    return out


def _check_out(out: Path, overwrite: bool) -> None:
    """Refuse an --out folder that holds a run unless --overwrite (then its checkpoints go: a later --resume
    must not find the old run's)."""
    held = [n for n in (RUN_FILE, "policy.json", "checkpoints", "curve.json") if (out / n).exists()]
    if not held:
        return
    if not overwrite:
        raise SystemExit(f"rig train: --out {out} already holds a run ({', '.join(held)}): --resume {out} continues it, "
                         "--overwrite replaces it, or choose another --out")
    import shutil

    shutil.rmtree(out / "checkpoints", ignore_errors=True)
    for n in (RUN_FILE, "curve.json", "policy.json"):
        (out / n).unlink(missing_ok=True)


def training_overrides(args: argparse.Namespace, table: dict[str, Any]) -> dict[str, Any]:
    """The environment settings of the run: the comparison's ``--conditions`` (default nominal), then the settings
    file's ``env`` table, then ``--env``; checked by RigEnvConfig (SystemExit naming the field and its range otherwise)."""
    from controllers.design.conditions import MODES
    from rig_env.envs.config import RigEnvConfig

    out: dict[str, Any] = {}
    if args.conditions not in (None, "none"):
        out.update(MODES[args.conditions].env_fields(args.task))
    out.update(table)
    out.update(getattr(args, "env_kv", {}))
    if "task" in out:
        raise SystemExit("rig train: --env task=...: the task is --task")
    try:
        RigEnvConfig(task=args.task).with_overrides(**out)
    except (ValueError, TypeError) as exc:
        raise SystemExit(f"rig train: environment settings {sorted(out)}: {exc}") from None
    # JSON-able (the policy file records them): ranges as lists
    return json.loads(json.dumps(out))


def last_checkpoint(run_dir: Path) -> tuple[Path, Path | None, Path | None, int]:
    """(model zip, VecNormalize statistics or None, replay buffer or None, timesteps) of RUN_DIR's latest checkpoint."""
    found = []
    for f in (run_dir / "checkpoints").glob("rl_model_*_steps.zip"):
        try:
            found.append((int(f.stem.split("_")[-2]), f))
        except ValueError:
            continue
    if not found:
        raise SystemExit(f"rig train: --resume {run_dir}: no checkpoint in {run_dir / 'checkpoints'} (the run stopped "
                         "before its first --checkpoint-every)")
    n, f = max(found)
    vn = run_dir / "checkpoints" / f"rl_model_vecnormalize_{n}_steps.pkl"
    rb = run_dir / "checkpoints" / f"rl_model_replay_buffer_{n}_steps.pkl"
    return f, vn if vn.is_file() else None, rb if rb.is_file() else None, n


def _train(args: argparse.Namespace, argv: list[str]) -> int:
    from rig_env.envs.tasks import TASKS

    if args.task not in TASKS:
        raise SystemExit(f"rig train: --task {args.task!r}: unknown; valid names: {sorted(TASKS)}")
    import numpy as np
    import torch
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from controllers import LoopSpec, make_controller
    from dataclasses import replace

    from controllers.laws.artefact import save
    from controllers.laws.rl import policy_path
    from controllers.design.rl_export import evaluate, export_sb3
    from controllers.design.rl_hyperparams import HyperparamError, settings
    from rig_env.envs.sb3 import RigSB3VecEnv
    from controllers.laws.axes import acting_surfaces
    from controllers.design.rl_callbacks import (
        ActionSubset,
        EnvTimer,
        ErrorReset,
        SuccessInfo,
        build_callbacks,
        plot_curve,
    )

    try:
        hp = settings(args.algo, args.task, args.hyperparams, getattr(args, "hp_overrides", None))
    except HyperparamError as exc:
        raise SystemExit(f"rig train: {exc}") from None
    timesteps = args.timesteps or hp.timesteps
    num_envs = args.num_envs or hp.num_envs
    eval_every = args.eval_every or hp.eval_every
    out = args.out or Path("runs") / f"{args.task}_{args.algo}_s{args.seed}"
    resuming = args.resume is not None
    if not resuming:
        _check_out(out, args.overwrite)
    overrides = training_overrides(args, dict(hp.env))
    out.mkdir(parents=True, exist_ok=True)
    kwargs = hp.sb3_kwargs()
    timer: list[EnvTimer] = []

    def kept_surfaces(vec: Any) -> tuple[int, ...] | None:
        """The actions the policy commands: the surfaces that move a free rig joint (the settings'
        acting_surfaces; not with the Hawk's surfaces in the action); None: all.  The others stay neutral
        and export as zero rows."""
        keep = acting_surfaces(vec.free_dofs) if hp.acting_surfaces and len(vec.action_names) == 3 else None
        return None if keep is None or len(keep) == 3 else keep

    def make_env(n: int, seed: int, training: bool) -> tuple[Any, Any]:
        base = RigSB3VecEnv(n, task=args.task, **overrides)
        base.seed(seed)
        # the curriculum on the training batch only; the eval batch gets the same wrappers as identities,
        # so that both stacks match (SB3's sync_envs_normalization walks them in step)
        reset_at = hp.error_reset if training and not args.no_error_reset else None
        if reset_at is not None and reset_at[0] not in base.vec.obs_labels:
            raise SystemExit(f"rig train: settings {hp.file} [{args.task}].error_reset.entry = {reset_at[0]!r}: not an "
                             f"observation entry; entries: {list(base.vec.obs_labels)}")
        inner: Any = ErrorReset(base, *(reset_at or (None, np.inf)))
        keep = kept_surfaces(base.vec)
        if keep is not None:
            inner = ActionSubset(inner, keep)
        env = EnvTimer(SuccessInfo(VecMonitor(inner)))
        if training:
            timer.append(env)
        return base, env

    base, env = make_env(num_envs, args.seed, True)
    spec = LoopSpec.from_env(base)
    _, eval_env = make_env(args.eval_episodes, args.seed + EVAL_SEED_OFFSET, False)
    algo_cls = {"ppo": PPO, "sac": SAC}[args.algo]
    have_tb = importlib.util.find_spec("tensorboard") is not None
    have_bar = importlib.util.find_spec("tqdm") is not None and not args.no_progress
    if not have_tb:
        print("tensorboard is not installed (pip install -e .[train]): no TensorBoard logs", flush=True)
    tb = str(out / "tb") if have_tb else None
    points, wall_before, resumed_from, warm = [], 0.0, None, None
    if resuming:
        ckpt, vn_path, rb_path, n_done = last_checkpoint(out)
        if hp.normalize:
            if vn_path is None:
                raise SystemExit(f"rig train: --resume {out}: checkpoint {ckpt.name} has no VecNormalize statistics beside it")
            env = VecNormalize.load(str(vn_path), env)
            env.training = True
            eval_env = VecNormalize(eval_env, training=False, norm_obs=True, norm_reward=False, clip_obs=hp.clip_obs)
        model = algo_cls.load(str(ckpt), env=env, device="cpu", tensorboard_log=tb)
        if rb_path is not None and hasattr(model, "load_replay_buffer"):
            model.load_replay_buffer(str(rb_path))
        if (out / "curve.json").is_file():
            points = [p for p in json.loads((out / "curve.json").read_text()) if p["timesteps"] <= n_done]
            wall_before = points[-1]["wall_s"] if points else 0.0
        resumed_from = {"checkpoint": str(ckpt), "timesteps": int(model.num_timesteps)}
        print(f"resuming {out} from {ckpt.name}: {model.num_timesteps} timesteps done", flush=True)
    else:
        if hp.normalize:
            env = VecNormalize(env, training=True, norm_obs=True, norm_reward=False, clip_obs=hp.clip_obs)
            eval_env = VecNormalize(eval_env, training=False, norm_obs=True, norm_reward=False, clip_obs=hp.clip_obs)
        model = algo_cls("MlpPolicy", env, seed=args.seed, device="cpu", verbose=0, tensorboard_log=tb, **kwargs)
        if getattr(args, "warm_start", None) is not None:
            warm = _warm_start(args, model, env, spec, base, kept_surfaces(base.vec), num_envs, overrides, out, hp.normalize)
        (out / RUN_FILE).write_text(json.dumps({"argv": argv, "algo": args.algo, "task": args.task, "seed": args.seed}, indent=1) + "\n")
    callbacks, tracker, progress = build_callbacks(
        eval_env, out, eval_seed=args.seed + EVAL_SEED_OFFSET, eval_freq=max(eval_every // num_envs, 1),
        n_eval=args.eval_episodes, checkpoint_freq=max(args.checkpoint_every // num_envs, 1),
        target=None if args.no_stop else args.target_success, total=timesteps, env_timer=timer[0], bar=have_bar,
        save_replay_buffer=args.algo == "sac", points=points, wall_offset=wall_before,
    )
    extra = getattr(args, "extra_callbacks", None)  # a sweep's: (out, checkpoint_freq) -> callbacks after the checkpoint's
    if extra is not None:
        from stable_baselines3.common.callbacks import CallbackList

        callbacks = CallbackList([callbacks, *extra(out, max(args.checkpoint_every // num_envs, 1))])
    print(f"training {args.algo} on {args.task}: {num_envs} envs, up to {timesteps} timesteps, seed {args.seed}, "
          f"{args.threads} thread(s), load average {os.getloadavg()[0]:.1f}, settings {hp.file}, out {out}", flush=True)
    if overrides:
        print(f"environment settings (--conditions {args.conditions}, then the file's, then --env): {json.dumps(overrides)}", flush=True)
    t0 = time.perf_counter()
    remaining = max(timesteps - int(model.num_timesteps), 0)
    model.learn(total_timesteps=remaining, callback=callbacks, progress_bar=False, tb_log_name=f"{args.algo}_s{args.seed}",
                reset_num_timesteps=not resuming)
    wall = time.perf_counter() - t0 + wall_before

    # export, load the file back, and measure what ships (numpy runtime, not the torch model)
    art = export_sb3(model, spec, env if hp.normalize else None, env_overrides=overrides, action_index=kept_surfaces(base.vec))
    path = out / "policy.json"
    save(art, path)
    law = make_controller(args.algo, spec, args.final_episodes, path=path)
    final = evaluate(law, overrides, seed=args.seed + FINAL_SEED_OFFSET)
    curve = tracker.curve()
    record = {
        "command": shlex.join(["rig", "train", *argv]),
        "algo": args.algo, "task": args.task, "seed": args.seed, "num_envs": num_envs, "threads": args.threads,
        "conditions": args.conditions,
        "timesteps": int(model.num_timesteps), "timesteps_budget": timesteps, "wall_time_s": round(wall, 1),
        "time_split_s": progress.split(), "resumed_from": resumed_from, "warm_start": warm,
        "target_success": args.target_success, "target_reached_at": tracker.reached,
        "hyperparameters": hp.record(),
        "eval_during_training": {"episodes": args.eval_episodes, "seed": args.seed + EVAL_SEED_OFFSET, "curve": curve},
        "final_eval": final,
        "versions": {"python": platform.python_version(), "stable_baselines3": _version("stable_baselines3"),
                     "torch": torch.__version__, "numpy": np.__version__, "gymnasium": _version("gymnasium")},
        "machine": {"cpus": os.cpu_count(), "load_average_1_5_15_min_at_end": [round(x, 2) for x in os.getloadavg()],
                    "platform": platform.platform()},
    }
    save(replace(art, provenance={**art.provenance, **record}), path)  # the same law, now with its training record
    (out / "curve.json").write_text(json.dumps(curve, indent=1) + "\n")
    plot_curve(curve, out / "curve.png", f"{args.algo.upper()} on {args.task} (seed {args.seed})", args.target_success)
    print(f"done in {wall:.0f} s, {model.num_timesteps} timesteps; target reached at: {tracker.reached}", flush=True)
    print(f"final eval of the exported policy ({final['episodes']} episodes, seed {final['seed']}): success "
          f"{final['success_rate']:.2f}, RMS error {final['rms_error_deg']:.2f} deg, return {final['mean_return']:.1f} "
          f"of {final['max_return']:.0f}", flush=True)
    print(f"policy: {path}", flush=True)
    if args.ship:
        dest = policy_path(args.task, args.algo)
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_bytes(path.read_bytes())
        dest.with_name(dest.stem + "_curve.png").write_bytes((out / "curve.png").read_bytes())
        print(f"shipped: {dest}", flush=True)
    return 0


def _warm_start(args: argparse.Namespace, model: Any, env: Any, spec: Any, base: Any, keep: tuple[int, ...] | None,
                num_envs: int, overrides: dict[str, Any], out: Path, normalize: bool) -> dict[str, Any]:
    """``--warm-start LAW``: the task's designed law behaviour-cloned into ``model`` on the training stack ``env``
    (:func:`controllers.design.rl_warmstart.warm_start`), the batch reseeded after it; the clone is exported to
    ``out/warm_start.json`` and evaluated on the evaluation episodes (the curve's point before PPO).  Returns the
    provenance record (law, samples, fit, the clone's evaluation)."""
    from controllers import make_controller
    from controllers.design.rl_export import evaluate, export_sb3
    from controllers.design.rl_warmstart import warm_start
    from controllers.laws.artefact import save

    law = make_controller(args.warm_start, spec, num_envs)
    t0 = time.perf_counter()
    base.seed(args.seed)
    rec = warm_start(model, env, law, keep, args.warm_start_samples, seed=args.seed)
    base.seed(args.seed)  # PPO's learn resets the batch: the same first episodes as without the warm start
    save(export_sb3(model, spec, env if normalize else None, env_overrides=overrides, action_index=keep), out / "warm_start.json")
    clone = evaluate(make_controller("ppo", spec, args.eval_episodes, path=out / "warm_start.json"), overrides,
                     seed=args.seed + EVAL_SEED_OFFSET)
    rec = {"kind": args.warm_start, **rec, "clone_eval": clone, "wall_s": round(time.perf_counter() - t0, 1)}
    print(f"warm start: {rec['law']} flew {rec['samples']} steps; action MSE {rec['action_mse_before']:.4f} -> "
          f"{rec['action_mse_after']:.4f}; the clone: return {clone['mean_return']:.1f}, success "
          f"{clone['success_rate']:.2f} ({clone['episodes']} eval episodes); {rec['wall_s']} s", flush=True)
    return rec


def _version(pkg: str) -> str:
    from importlib.metadata import version

    return version(pkg)


def _jsonable(d: dict[str, Any]) -> dict[str, Any]:
    """Hyperparameters as JSON (classes by name)."""
    return json.loads(json.dumps(d, default=lambda o: getattr(o, "__name__", repr(o))))


if __name__ == "__main__":
    sys.exit(main())

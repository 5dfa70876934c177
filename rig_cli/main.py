"""The ``rig`` command: the controller comparison, demonstrations and pictures of the rig model.

    rig compare [--quick] [--out DIR] [--episodes N] [--seed S] [--tasks T ...] [--controllers K ...] [--modes M ...]
                [--params FILE] [--policy FILE ...] [--config FILE.toml] [--overwrite]
                [--backend local|ray] [--address ADDR] [--chunk-size N]
        every control law on every task, nominal and robust (controllers.evaluation.compare): prints the
        tables and the recommendation per task, writes summary.json, summary.csv, plots and report.md into
        DIR (default out/compare); --params: a parameter file (an identified one) for the laws' design and
        the environments; --policy: law artefacts as further contenders; --config: all of it as a file
        (controllers.evaluation.config; options given on the command line win)
    rig demo [--out DIR] [--t-final S] [--airspeed M/S] [--aileron DEG] [--no-plot] [--quiet]
        velocity-vector roll (paper Sec. VI, Fig. 7): rig roll and model pitch free, compensator
        aileron ramped to +20 deg over 1 s and held; prints a summary, writes DIR/demo_roll.png
    rig draw [--out DIR] [--q DEG DEG DEG DEG DEG] [--flaps DEG DEG DEG DEG]
        the rig picture with its frames (DIR/rig_frames.png)
    rig continuation --free JOINT ... --parameter NAME --values FIRST LAST POINTS [--aero-model M] [--airspeed M/S]
                     [--control SURFACE=DEG ...] [--set NAME=VALUE ...] [--lift-break DEG DEPTH] [--params FILE]
                     [--no-orbits] [--physics-dt S] [--state JOINT] [--sweep NAME FIRST LAST POINTS] [--out DIR] [--overwrite]
        equilibria over a parameter with their stability, folds, Hopf points and limit cycles
        (rig_env.continuation; rig_cli.continuation): prints the special points and orbit families, writes
        branch.csv, special_points.csv, orbits.csv and bifurcation.png into DIR (default out/continuation);
        --sweep: a second parameter swept, the folds' and Hopf points' loci in loci.csv and sweep.png
    rig --version
        the installed version (importlib.metadata; rig_env.__version__ when not installed)
    rig identify CONFIG.toml --out DIR [--overwrite]
        fit the rig's parameters to recorded runs (rig_env.sysid; the configuration: rig_cli.identify):
        writes DIR/report.md with its figures and DIR/identified.toml, a parameter file for --params
    rig train --algo ppo|sac --task NAME [...]
        train a PPO or SAC law on the native batch and export it as a law artefact
        (controllers.design.rl_train; ``rig train --help`` lists the options); ``--seeds S ... --backend ray``:
        the seeds as a Ray Tune sweep
    rig sweep CONFIG.toml [--address ADDR] [--resume]
        Ray Tune over hyperparameters x seeds x tasks: one table, a plot, the best policy exported
        (controllers.design.sweep)

This package sits above both ``rig_env`` (the model and environments) and ``controllers`` (the laws,
their design, the comparison); neither imports it.  ``scripts/compare.py``, ``scripts/train.py`` and
``scripts/demo_roll.py`` are thin wrappers over this command.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence, TextIO

import numpy as np

from rig_env.paths import check_out_folder
from rig_env.params import RigParams
from rig_env.simulate import SimResult, check_static_controls, simulate

DEMO_FREE = ("rig_roll", "model_pitch")
SETTLE_S = 5.0
"""Statistics of the steady roll are taken over t >= SETTLE_S (the spin-up lasts about 3 s)."""
DEMO_MAX_S = 3600.0
"""s: rig demo's longest run (under a minute of computing here; 1e5 s ran 17 minutes, silent with --quiet)."""


@dataclass(frozen=True)
class RollSummary:
    """Velocity-vector roll figures (deg, deg/s, J, s); rates and pitch over t >= ``window_start``."""

    t_final: float
    airspeed: float
    aileron_deg: float
    total_roll_deg: float
    mean_rate_run: float
    window_start: float
    mean_rate: float
    min_rate: float
    max_rate: float
    model_pitch_min: float
    model_pitch_max: float
    energy_start: float
    energy_end: float
    energy_min: float
    energy_max: float
    compile_s: float
    run_s: float
    status: str

    def table(self) -> str:
        w = self.window_start
        rows = [
            ("airspeed", f"{self.airspeed:.1f}", "m/s"),
            ("compensator aileron (held)", f"{self.aileron_deg:+.1f}", "deg"),
            ("simulated time", f"{self.t_final:.1f}", "s"),
            ("total roll angle", f"{self.total_roll_deg:+.0f}", "deg"),
            ("mean roll rate, whole run", f"{self.mean_rate_run:+.1f}", "deg/s"),
            (f"mean roll rate, t >= {w:g} s", f"{self.mean_rate:+.1f}", "deg/s"),
            (f"min / max roll rate, t >= {w:g} s", f"{self.min_rate:+.1f} / {self.max_rate:+.1f}", "deg/s"),
            (f"model pitch range, t >= {w:g} s", f"{self.model_pitch_min:+.1f} .. {self.model_pitch_max:+.1f}", "deg"),
            ("energy (kinetic + gravity) start / end", f"{self.energy_start:+.3f} / {self.energy_end:+.3f}", "J"),
            ("energy min / max", f"{self.energy_min:+.3f} / {self.energy_max:+.3f}", "J"),
            ("compile (numba JIT, incl. cache load)", f"{self.compile_s:.2f}", "s"),
            ("compute time of the run", f"{self.run_s:.2f}", f"s ({self.t_final / self.run_s:.1f}x real time)"),
            ("status", self.status, ""),
        ]
        k = max(len(r[0]) for r in rows)
        v = max(len(r[1]) for r in rows)
        line = "-" * (k + v + 12)
        body = "\n".join(f"  {a:<{k}}  {b:>{v}}  {c}" for a, b, c in rows)
        return f"velocity-vector roll (rig_roll + model_pitch free)\n{line}\n{body}\n{line}"


class _Progress:
    """Progress bar driven by the control schedule, which simulate() evaluates once per control step."""

    def __init__(self, t_final: float, stream: TextIO | None, width: int = 32):
        self.t_final, self.stream, self.width = t_final, stream, width
        self.tty = bool(stream is not None and getattr(stream, "isatty", lambda: False)())
        self.last = -1

    def __call__(self, t: float) -> None:
        if self.stream is None:
            return
        frac = min(1.0, max(0.0, t / self.t_final))
        step = int(frac * 100) if self.tty else int(frac * 10) * 10  # every 1 % on a terminal, else 10 %
        if step == self.last:
            return
        self.last = step
        n = int(round(frac * self.width))
        bar = "#" * n + "." * (self.width - n)
        msg = f"  simulating [{bar}] {step:3d} %  t = {t:5.1f} / {self.t_final:.1f} s"
        self.stream.write(("\r" + msg) if self.tty else (msg + "\n"))
        self.stream.flush()

    def done(self) -> None:
        if self.stream is not None and self.tty:
            self.stream.write("\n")
            self.stream.flush()


def run_roll(
    params: RigParams | None = None,
    *,
    t_final: float = 25.0,
    airspeed: float = 20.0,
    aileron_deg: float = 20.0,
    ramp_s: float = 1.0,
    progress: TextIO | None = None,
) -> tuple[SimResult, RollSummary]:
    """Simulate the velocity-vector roll and summarise it.

    From rest at every joint angle zero, rig roll and model pitch free (the others locked), the
    compensator aileron ramps linearly from 0 to ``aileron_deg`` over ``ramp_s`` and is held; 80 Hz
    control, 2.5 ms physics steps, friction, stops and servos on.  ``progress``: stream for a progress
    bar (None: silent).  The kernels are compiled (or loaded from numba's cache) by a one-step run
    first, timed apart from the run itself.
    """
    p = RigParams.default() if params is None else params
    if not (math.isfinite(t_final) and t_final > SETTLE_S):
        raise ValueError(f"t_final = {t_final} s must exceed the {SETTLE_S} s spin-up window")
    if not (math.isfinite(ramp_s) and ramp_s > 0.0):
        raise ValueError(f"ramp_s = {ramp_s} s must be positive")
    check_static_controls({"comp_aileron": aileron_deg}, p, "aileron_deg")  # held: within the flaps' travel
    bar = _Progress(t_final, progress)

    def aileron(t: float) -> float:
        bar(t)
        return aileron_deg * min(1.0, t / ramp_s)

    kw = dict(free_dofs=DEMO_FREE, airspeed=airspeed)
    if progress is not None:
        progress.write("  compiling / loading the numba kernels ...\n")
        progress.flush()
    t0 = time.perf_counter()
    simulate(p, [0.0, 0.0], None, 1.0 / 80.0, controls={"comp_aileron": 0.0}, **kw)
    t1 = time.perf_counter()
    res = simulate(p, [0.0, 0.0], None, t_final, controls={"comp_aileron": aileron}, **kw)
    t2 = time.perf_counter()
    bar(t_final)
    bar.done()
    roll = np.degrees(res.q[:, 0])
    rate = np.degrees(res.qd[:, 0])
    pitch = np.degrees(res.q[:, 1])
    w = res.t >= SETTLE_S
    summary = RollSummary(
        t_final=t_final,
        airspeed=airspeed,
        aileron_deg=aileron_deg,
        total_roll_deg=float(roll[-1] - roll[0]),
        mean_rate_run=float((roll[-1] - roll[0]) / t_final),
        window_start=SETTLE_S,
        mean_rate=float((roll[w][-1] - roll[w][0]) / (res.t[w][-1] - res.t[w][0])),
        min_rate=float(rate[w].min()),
        max_rate=float(rate[w].max()),
        model_pitch_min=float(pitch[w].min()),
        model_pitch_max=float(pitch[w].max()),
        energy_start=float(res.energy[0]),
        energy_end=float(res.energy[-1]),
        energy_min=float(res.energy.min()),
        energy_max=float(res.energy.max()),
        compile_s=t1 - t0,
        run_s=t2 - t1,
        status=", ".join(res.status_text()),
    )
    return res, summary


def demo_roll(
    out_dir: str | Path = "out",
    *,
    t_final: float = 25.0,
    airspeed: float = 20.0,
    aileron_deg: float = 20.0,
    plot: bool = True,
    quiet: bool = False,
    stream: TextIO | None = None,
    overwrite: bool = False,
) -> RollSummary:
    """``rig demo``: run the velocity-vector roll, print the summary table, write the plot (an earlier
    ``demo_roll.png`` there is refused before the run unless ``overwrite``)."""
    out = stream if stream is not None else sys.stdout
    if not (math.isfinite(t_final) and SETTLE_S < t_final <= DEMO_MAX_S):
        raise ValueError(f"--t-final {t_final:g}: the simulated time must lie in ({SETTLE_S:g}, {DEMO_MAX_S:g}] s (after the "
                         f"{SETTLE_S:g} s spin-up window; longer runs: rig_env.simulate)")
    if not (math.isfinite(airspeed) and 0.0 <= airspeed <= 60.0):
        raise ValueError(f"--airspeed {airspeed:g}: the tunnel speed must lie in [0, 60] m/s")
    try:
        check_static_controls({"comp_aileron": aileron_deg}, RigParams.default(), "--aileron")
    except ValueError as exc:
        raise ValueError(f"--aileron {aileron_deg:g}: {str(exc).split(': ', 2)[-1]}") from None
    if plot:
        _refuse_existing(check_out_folder("--out", out_dir) / "demo_roll.png", overwrite)
    res, summary = run_roll(t_final=t_final, airspeed=airspeed, aileron_deg=aileron_deg, progress=None if quiet else sys.stderr)
    out.write(summary.table() + "\n")
    if plot:
        from rig_env.plotting import plot_trajectory

        path = Path(out_dir) / "demo_roll.png"
        plot_trajectory(
            res,
            path,
            f"Velocity-vector roll, {airspeed:g} m/s, compensator aileron ramped to {aileron_deg:+g} deg over 1 s",
        )
        out.write(f"plot: {path}\n")
    out.flush()
    return summary


def _refuse_existing(path: Path, overwrite: bool) -> None:
    if path.exists() and not overwrite:
        raise ValueError(f"--out: {path} is already there; give --overwrite to replace it, or another --out")


def draw(out_dir: str | Path = "out", q_deg: Sequence[float] | None = None, flaps_deg: Sequence[float] | None = None,
         overwrite: bool = False) -> Path:
    """``rig draw``: the rig picture (zero position and a posed example, or the given pose).  ValueError naming
    the option for angles that are not finite or beyond +-360 deg, flaps beyond +-40 deg or given without
    ``--q``, an ``--out`` that is a file, and an earlier ``rig_frames.png`` there unless ``overwrite``."""
    from rig_env.plotting import rig_figure

    if q_deg is not None and not all(math.isfinite(a) and abs(a) <= 360.0 for a in q_deg):
        raise ValueError(f"--q {' '.join(f'{a:g}' for a in q_deg)}: joint angles must be finite and within +-360 deg")
    params = RigParams.default()
    if flaps_deg is not None:
        if q_deg is None:
            raise ValueError("--flaps: give the pose with --q too (the flaps are drawn on that pose only)")
        travel = params.servos.compensator.limit_deg
        if not all(math.isfinite(a) and abs(a) <= travel for a in flaps_deg):
            raise ValueError(f"--flaps {' '.join(f'{a:g}' for a in flaps_deg)}: flap deflections must be finite and within +-{travel:g} deg")
    path = check_out_folder("--out", out_dir) / "rig_frames.png"
    _refuse_existing(path, overwrite)
    q = None if q_deg is None else np.radians(np.asarray(q_deg, dtype=np.float64))
    rig_figure(params, q=q, path=path, flaps_deg=flaps_deg)
    return path


def version() -> str:
    """The installed distribution's version (``importlib.metadata``), else ``rig_env.__version__``."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version("rig_env")
    except PackageNotFoundError:
        import rig_env

        return rig_env.__version__


def _parser() -> argparse.ArgumentParser:
    from controllers import LAWS
    from controllers.design.conditions import MODES
    from controllers.evaluation.compare import default_kinds
    from rig_env.envs.tasks import TASKS

    tasks, kinds, default = sorted(TASKS), sorted(LAWS), default_kinds()
    ap = argparse.ArgumentParser(prog="rig", description="Bristol 5-DOF manoeuvre rig model (AIAA 2009-5727).")
    ap.add_argument("--version", action="version", version=f"rig {version()}", help="print the version and exit")
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")
    c = sub.add_parser("compare", help="every control law on every task, nominal and robust; tables, plots, report",
                       description="Fly every law on every task over the same seeded episodes; print the tables and the "
                                   "recommendation per task; write summary.json (schema: README, 'The comparison'), summary.csv, "
                                   "plots and report.md.")
    c.add_argument("--quick", action="store_true", default=None, help="12 episodes per law, task and mode (default 64)")
    c.add_argument("--out", default="out/compare", metavar="DIR", help="output folder (default: out/compare)")
    c.add_argument("--episodes", type=int, default=None, metavar="N", help="episodes per law, task and mode, 1..100000 (default 64, --quick 12)")
    c.add_argument("--seed", type=int, default=None, metavar="S", help="seed of the episodes, 0..4294967295 (default 0)")
    # tasks and kinds are listed, not argparse choices: compare checks them (one-line error) and knows kinds registered later
    c.add_argument("--tasks", nargs="+", default=None, metavar="T", help=f"task names: {', '.join(tasks)} (default: all)")
    gains = [k for k in kinds if k not in default]  # "linear": refused here, it joins as a --policy law file
    c.add_argument("--controllers", nargs="+", default=None, metavar="K",
                   help=f"law kinds: {', '.join(kinds)} (default: every kind built from the task alone: {', '.join(default)})"
                        + (f"; {', '.join(gains)} takes its gains: export it (rig-deploy export) and pass the file with --policy" if gains else ""))
    c.add_argument("--modes", nargs="+", default=None, choices=list(MODES), metavar="M",
                   help="conditions: nominal (the rig as modelled), robust (+-20 %% aerodynamic derivatives and friction), "
                        "gusty (5 %% gusts, a stress case) (default: nominal robust)")
    c.add_argument("--params", default=None, metavar="FILE.toml",
                   help="rig parameter file (e.g. rig identify's identified.toml) the laws are designed on and fly (default: the default rig)")
    c.add_argument("--policy", nargs="+", default=None, metavar="FILE",
                   help="law artefact files (a trained policy.json, a rig-deploy export, controllers/policies/*.json): each flies "
                        "its task as a further contender, named after its file")
    c.add_argument("--config", default=None, metavar="FILE.toml",
                   help="the comparison as a file: tasks, laws, policies, episodes, seed, quick, modes, params, backend, address, "
                        "chunk_size, [conditions], [score] "
                        "(controllers.evaluation.config); options on the command line win")
    c.add_argument("--overwrite", action="store_true", help="replace files in DIR that an earlier rig compare did not write")
    c.add_argument("--backend", default=None, metavar="B",
                   help="local (one process, default) or ray: the episodes in chunks as Ray tasks, the same numbers "
                        "(pip install -e \".[ray]\"; controllers.evaluation.ray_backend)")
    c.add_argument("--address", default=None, metavar="ADDR",
                   help="with --backend ray: the cluster (auto, HOST:PORT, ray://HOST:PORT; default: a local cluster on this machine)")
    c.add_argument("--chunk-size", type=int, default=None, metavar="N",
                   help="with --backend ray: episodes per Ray task, 2..100000 (default: about two chunks per cluster CPU)")
    d = sub.add_parser("demo", help="velocity-vector roll at 20 m/s with the compensator ailerons (paper Fig. 7)")
    d.add_argument("--out", default="out", metavar="DIR", help="directory for demo_roll.png (default: out)")
    d.add_argument("--t-final", type=float, default=25.0, metavar="S", help="simulated time, s (default 25; 5 to 3600)")
    d.add_argument("--airspeed", type=float, default=20.0, metavar="M/S", help="tunnel speed, m/s (default 20)")
    d.add_argument("--aileron", type=float, default=20.0, metavar="DEG", help="held compensator aileron, deg (default 20)")
    d.add_argument("--no-plot", action="store_true", help="do not write the plot (only the summary table: deg, deg/s, J, s)")
    d.add_argument("--quiet", action="store_true", help="no progress bar")
    d.add_argument("--overwrite", action="store_true", help="replace an earlier demo_roll.png in DIR")
    r = sub.add_parser("draw", help="picture of the rig with its frames and joints")
    r.add_argument("--out", default="out", metavar="DIR", help="directory for rig_frames.png (default: out)")
    r.add_argument("--q", type=float, nargs=5, metavar="DEG",
                   help="joint angles, deg: rig_roll rig_pitch rig_yaw model_pitch model_yaw (default: zero and an example pose)")
    r.add_argument("--flaps", type=float, nargs=4, metavar="DEG", help="compensator flaps 1-4 deflections, deg, within +-40 (with --q)")
    r.add_argument("--overwrite", action="store_true", help="replace an earlier rig_frames.png in DIR")
    i = sub.add_parser("identify", help="fit the rig's parameters to recorded runs; report and identified parameter file")
    i.add_argument("config", metavar="CONFIG.toml", help="records, base parameters, parameters to estimate, method (README: Identification)")
    i.add_argument("--out", required=True, metavar="DIR", help="folder for report.md, its figures and identified.toml")
    i.add_argument("--overwrite", action="store_true", help="replace report.md and identified.toml if DIR holds them")
    k = sub.add_parser("continuation", help="equilibria over a parameter: stability, folds, Hopf points, limit cycles; tables and a diagram",
                       description="Continue the rig's equilibria over one parameter (rig_env.continuation): print the folds, Hopf "
                                   "points and limit-cycle families; write branch.csv, special_points.csv, orbits.csv, bifurcation.png.")
    k.add_argument("--free", nargs="+", required=True, metavar="JOINT", help="the free joints (rig_roll rig_pitch rig_yaw model_pitch model_yaw)")
    k.add_argument("--parameter", required=True, metavar="NAME",
                   help="a surface (deg), airspeed (m/s) or a dotted rig parameter name (its file unit, e.g. hawk_aero.sep_cp_travel)")
    k.add_argument("--values", nargs=3, type=float, required=True, metavar=("FIRST", "LAST", "POINTS"),
                   help="the range, traced from FIRST towards LAST, sampled at POINTS evenly spaced values (2..2001)")
    k.add_argument("--aero-model", default="linear", metavar="M", help="linear (default), tables or unsteady")
    k.add_argument("--airspeed", type=float, default=None, metavar="M/S", help="tunnel speed when it is not the parameter (default 20)")
    k.add_argument("--control", nargs="+", default=None, metavar="SURFACE=DEG", help="other surfaces held, deg (e.g. hawk_rudder=2)")
    k.add_argument("--set", nargs="+", default=None, metavar="NAME=VALUE", help="rig parameters changed, file units (e.g. hawk_aero.sep_cp_travel=0.1)")
    k.add_argument("--lift-break", nargs=2, type=float, default=None, metavar=("DEG", "DEPTH"),
                   help="a local loss of the Hawk's lift: DEPTH of CL at DEG, between two table breakpoints (RigParams.with_lift_break)")
    k.add_argument("--params", default=None, metavar="FILE.toml", help="rig parameter file (default: the default rig)")
    k.add_argument("--no-orbits", action="store_true", help="equilibria only: no periodic orbits from the Hopf points")
    k.add_argument("--physics-dt", type=float, default=1e-3, metavar="S",
                   help="the orbits' RK4 step, s (default 0.001; smaller: more accurate multipliers of orbits through the tables' kinks, slower)")
    k.add_argument("--q-guess", type=float, nargs=5, default=None, metavar="DEG",
                   help="joint angles, deg (rig_roll rig_pitch rig_yaw model_pitch model_yaw): the locked joints' angles and where "
                        "the first equilibrium is looked for (default: all zero)")
    k.add_argument("--state", default=None, metavar="JOINT", help="the free joint the diagram shows (default: the first)")
    k.add_argument("--sweep", nargs=4, default=None, metavar=("NAME", "FIRST", "LAST", "POINTS"),
                   help="a second parameter swept (a surface, airspeed or a rig parameter): the loci of the folds and Hopf points "
                        "in loci.csv and sweep.png instead of one branch")
    k.add_argument("--out", default="out/continuation", metavar="DIR", help="output folder (default: out/continuation)")
    k.add_argument("--overwrite", action="store_true", help="replace the outputs of an earlier run in DIR")
    sub.add_parser("train", help="train PPO or SAC on a task and export the law (rig train --help)", add_help=False)
    sub.add_parser("sweep", help="Ray Tune sweep of rig train over hyperparameters x seeds x tasks (rig sweep --help)", add_help=False)
    return ap


def run_compare(args: argparse.Namespace, argv: Sequence[str]) -> None:
    """``rig compare``: the options, over the ``--config`` file's values where given (ValueError naming a bad field)."""
    from controllers import CONTROLLERS
    from controllers.design.conditions import MODES
    from controllers.evaluation.compare import compare
    from controllers.evaluation.config import CompareConfig, parse
    from rig_env.envs.tasks import TASKS

    cfg = parse(args.config, sorted(TASKS), sorted(CONTROLLERS), list(MODES)) if args.config else CompareConfig()
    pick = lambda cli, file, default: cli if cli is not None else (file if file is not None else default)  # noqa: E731
    rule = {"rule": cfg.score} if cfg.score is not None else {}
    # --backend local over a file's backend = "ray": the file's Ray settings (address, chunk_size) go with its backend,
    # not refused as "--address ...: only with --backend ray", options the user did not give
    ray_file = not (args.backend == "local" and cfg.backend == "ray")
    file_address, file_chunk = (cfg.address, cfg.chunk_size) if ray_file else (None, None)
    compare(tasks=pick(args.tasks, cfg.tasks, None), kinds=pick(args.controllers, cfg.laws, None), episodes=pick(args.episodes, cfg.episodes, None),
            seed=pick(args.seed, cfg.seed, 0), quick=bool(pick(args.quick, cfg.quick, False)), modes=pick(args.modes, cfg.modes, ["nominal", "robust"]),
            out_dir=args.out, params_file=pick(args.params, cfg.params, None), policies=pick(args.policy, cfg.policies or None, ()),
            conditions=cfg.conditions, overwrite=args.overwrite, command=_recorded(argv),
            backend=pick(args.backend, cfg.backend, "local"), address=pick(args.address, file_address, None),
            chunk_size=pick(args.chunk_size, file_chunk, None), **rule)


def _sweep_arg(items: Sequence[str] | None) -> tuple[str, float, float, float] | None:
    """``--sweep NAME FIRST LAST POINTS`` as (name, first, last, points); ValueError naming the option."""
    if items is None:
        return None
    name, *numbers = items
    try:
        first, last, n = (float(v) for v in numbers)
    except ValueError:
        raise ValueError(f"--sweep {' '.join(items)}: FIRST, LAST and POINTS must be numbers") from None
    return name, first, last, n


def _recorded(argv: Sequence[str]) -> str:
    """The command line as summary.json records it: without --out and --overwrite (where, not what, was compared)."""
    kept, skip = [], False
    for a in argv:
        if skip:
            skip = False
        elif a == "--out":
            skip = True
        elif not (a.startswith("--out=") or a == "--overwrite"):
            kept.append(a)
    return " ".join(["rig", *kept])


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point ``rig`` (pyproject: rig = "rig_cli.main:main")."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] in (["train"], ["sweep"]):
        try:
            if argv[:1] == ["train"]:  # its own parser: every option after "train" is the trainer's
                from controllers.design.rl_train import main as train

                return train(argv[1:])
            from controllers.design.rl_train import train_trial  # its own parser too (controllers.design.sweep)
            from controllers.design.sweep import main as sweep

            return sweep(argv[1:], train=train_trial)
        except SystemExit as exc:  # the trainer's refusals (SystemExit with the message): one line, exit 2 as the others'
            if isinstance(exc.code, str):
                print(exc.code, file=sys.stderr)
                return 2
            raise
    args = _parser().parse_args(argv)
    try:
        if args.command == "compare":
            run_compare(args, argv)
        elif args.command == "identify":
            from rig_cli.identify import run

            try:
                run(args.config, args.out, overwrite=args.overwrite)
            except (OSError, RuntimeError) as exc:  # outputs already there, unreadable files, a failed fit
                raise ValueError(str(exc)) from exc
        elif args.command == "demo":
            demo_roll(args.out, t_final=args.t_final, airspeed=args.airspeed, aileron_deg=args.aileron,
                      plot=not args.no_plot, quiet=args.quiet, overwrite=args.overwrite)
        elif args.command == "draw":
            print(f"wrote {draw(args.out, args.q, args.flaps, overwrite=args.overwrite)}")
        elif args.command == "continuation":
            from rig_cli.continuation import run as continue_branch

            continue_branch(args.out, free=args.free, parameter=args.parameter, values=args.values, aero_model=args.aero_model,
                            airspeed=args.airspeed, controls=args.control, sets=args.set, lift_break=args.lift_break,
                            params_file=args.params, orbits=not args.no_orbits, physics_dt=args.physics_dt, state=args.state, sweep=_sweep_arg(args.sweep),
                            q_guess_deg=args.q_guess, overwrite=args.overwrite)
    except (ValueError, OSError) as exc:  # bad argument values, an unwritable --out: one line, no traceback
        print(f"rig {args.command}: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

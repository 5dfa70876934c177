"""Env-step throughput of the three aerodynamic models, measured in one run (ratios are the figures to quote).

    python benchmarks/bench_aero_models.py [--envs 64 1024] [--seconds 2] [--rounds 3] [--serial] [--kinds lanes joint] [--json]
    python benchmarks/bench_aero_models.py --envs 1024 --sandwich 60 [--window 0.25]

The harness of ``bench_step.py`` (``rate``: wall and CPU env-steps/s over a window, after a warm-up call
that compiles or loads the kernel, so compile time is never in the rate), the cases taking turns window by
window for ``--rounds`` rounds, each case's best wall rate and best rate per CPU-second kept (the CPU rate,
which other jobs on a shared machine do not inflate, is the one to quote there): one env-step = one 80 Hz control step
= 5 physics steps of 2.5 ms, all physics on (aero at 20 m/s, LuGre friction, stops, servos), all five
joints free, states near trim.  Kernels (``rig_env.physics.pipeline.choose_kernel``):

* ``linear``, ``tables``, ``unsteady`` on lanes: the lane kernel (eight environments per SIMD register),
  what the environments run; the tables as tuples looked up without a search (``lanes.lane_tables``; the
  default compensator table, odd, over its non-negative half: ``aero.odd_table``);
* the same three on the per-environment kernel (``joint``), for reference.

``--kinds lanes``: the lane kernels only (each round then also prints its own unsteady / linear ratio: on a
shared machine the per-round ratios and their median say more than the ratio of the best rates).
``--sandwich N``: instead of the rounds, N short windows (``--window``, 0.25 s) of linear, unsteady, linear on
the one-thread lane kernels, each unsteady rate divided by the mean of the two linear windows around it; the
median and the interquartile range of those N ratios.  A window of a quarter second sees much the same
machine as its neighbours, so on a VM whose speed drifts by tens of per cent from second to second (steal
time shows as CPU time too) this ratio moves by about 0.005 from run to run where the rounds' median moves
by 0.03.
``--serial``: every kernel's one-thread version whatever the batch size (on a machine other jobs share, the
parallel kernels' rendezvous waits for a busy core and the rates of a parallel run move by tens of per
cent from window to window; one thread's rate per CPU-second does not).

Ratios: ``unsteady_over_linear_lanes`` (the issue's target: the lane kernel with the unsteady model against
it without, at least 0.8), ``tables_over_linear_lanes``, and ``lanes_over_joint`` per model (what the lanes
bring each model).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.bench_step import AIRSPEED, H, N_SUB, machine_line, rate  # noqa: E402
from rig_env import RigParams, param_batch  # noqa: E402
from rig_env.physics import layout as L  # noqa: E402
from rig_env.physics.pipeline import PhysicsBatch, flags_of  # noqa: E402

MODELS = ("linear", "tables", "unsteady")
CASES = tuple((m, k) for k in ("lanes", "joint") for m in MODELS)


def stepper(params: RigParams, n: int, aero_model: str, kind: str, seed: int = 0, parallel: bool | None = None):
    """One env-step of n environments near trim on the kernel of ``kind`` with ``aero_model`` (the kernel that runs;
    parallel: its prange version, None from the batch size)."""
    rng = np.random.default_rng(seed)
    flags = flags_of(True, True, True, True, aero_model)
    batch = PhysicsBatch(param_batch(params, n), params.tables(), np.arange(5, dtype=np.int64), flags, H, N_SUB, kind=kind,
                         parallel=parallel)
    batch.U[:, L.U_AIRSPEED] = AIRSPEED
    batch.reset(np.arange(n), rng.uniform(-0.2, 0.2, (n, 5)), rng.uniform(-0.5, 0.5, (n, 5)))
    return batch.step, batch.kernel.kind


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--envs", type=int, nargs="+", default=[64, 1024])
    ap.add_argument("--seconds", type=float, default=2.0, help="timing window per case, batch size and round")
    ap.add_argument("--rounds", type=int, default=3, help="rounds of the cases taking turns")
    ap.add_argument("--serial", action="store_true", help="one-thread kernels at every batch size")
    ap.add_argument("--kinds", nargs="+", choices=("lanes", "joint"), default=["lanes", "joint"])
    ap.add_argument("--sandwich", type=int, default=0, metavar="N",
                    help="N linear-unsteady-linear window triples on the lane kernels instead of the rounds")
    ap.add_argument("--window", type=float, default=0.25, help="seconds of CPU time per window of --sandwich")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    for name in ("sandwich", "rounds"):
        if getattr(args, name) < 0:
            ap.error(f"--{name} = {getattr(args, name)}: expected a count >= 0")
    for name in ("seconds", "window"):
        if not getattr(args, name) > 0.0:
            ap.error(f"--{name} = {getattr(args, name)}: expected seconds > 0")
    params = RigParams.default()
    out: dict = {"machine": machine_line(), "serial": args.serial, "rates": {}}
    if args.sandwich:
        return sandwich(params, args.envs, args.sandwich, args.window, args.json, out)
    for n in args.envs:
        steps = {f"{model}/{kind}/{n}": stepper(params, n, model, kind, parallel=False if args.serial else None)
                 for model, kind in CASES if kind in args.kinds}
        for key, (step, ran) in steps.items():
            out["rates"][key] = {"kernel": ran, "env_steps_per_s": 0.0, "env_steps_per_cpu_s": 0.0}
        rounds = []
        for k in range(args.rounds):
            this = {}
            for key, (step, _) in steps.items():
                wall, cpu = rate(step, n, args.seconds, repeats=1)
                this[key] = cpu
                r = out["rates"][key]
                r["env_steps_per_s"], r["env_steps_per_cpu_s"] = max(r["env_steps_per_s"], wall), max(r["env_steps_per_cpu_s"], cpu)
            if f"linear/lanes/{n}" in this:
                rounds.append(this[f"unsteady/lanes/{n}"] / this[f"linear/lanes/{n}"])
                if not args.json:
                    print(f"round {k + 1}, {n} envs: env-steps per CPU-second " + ", ".join(f"{key} {v:,.0f}" for key, v in this.items())
                          + f"; unsteady / linear (lanes) {rounds[-1]:.3f}", flush=True)
        if rounds:
            out[f"unsteady_over_linear_lanes_cpu_per_round/{n}"] = rounds
            out[f"unsteady_over_linear_lanes_cpu_median/{n}"] = float(np.median(rounds))
        for unit in ("env_steps_per_s", "env_steps_per_cpu_s"):
            r = {k.rsplit("/", 1)[0]: v[unit] for k, v in out["rates"].items() if k.endswith(f"/{n}")}
            tag = "" if unit == "env_steps_per_s" else "_cpu"
            if "linear/lanes" in r:
                out[f"unsteady_over_linear_lanes{tag}/{n}"] = r["unsteady/lanes"] / r["linear/lanes"]
                out[f"tables_over_linear_lanes{tag}/{n}"] = r["tables/lanes"] / r["linear/lanes"]
            for m in MODELS:
                if f"{m}/lanes" in r and f"{m}/joint" in r:
                    out[f"{m}_lanes_over_joint{tag}/{n}"] = r[f"{m}/lanes"] / r[f"{m}/joint"]
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        print(out["machine"])
        print(f"{'model':10s} {'asked':6s} {'ran':6s} {'envs':>6s} {'env-steps/s':>12s} {'per CPU-s':>12s}")
        for k, v in out["rates"].items():
            model, kind, n = k.split("/")
            print(f"{model:10s} {kind:6s} {v['kernel']:6s} {n:>6s} {v['env_steps_per_s']:12,.0f} {v['env_steps_per_cpu_s']:12,.0f}")
        for k, v in out.items():
            if "_over_" in k and not isinstance(v, list):
                print(f"{k}: {v:.3f}")
    return out


def cpu_window(step, n: int, seconds: float) -> float:
    """Env-steps per CPU-second of ``step`` (n envs per call) over about ``seconds`` of this process's CPU time."""
    c0 = time.process_time()
    calls = 0
    while True:
        step()
        calls += 1
        used = time.process_time() - c0
        if used >= seconds:
            return calls * n / used


def sandwich(params: RigParams, envs: list[int], triples: int, seconds: float, as_json: bool, out: dict) -> dict:
    """``--sandwich``: per batch size, ``triples`` ratios unsteady / mean(linear before, linear after) on the
    one-thread lane kernels, their median and quartiles in ``out``."""
    for n in envs:
        lin, _ = stepper(params, n, "linear", "lanes", parallel=False)
        uns, _ = stepper(params, n, "unsteady", "lanes", parallel=False)
        lin(), uns()  # compile or load both before the first window
        ratios = []
        before = cpu_window(lin, n, seconds)
        for _ in range(triples):
            middle = cpu_window(uns, n, seconds)
            after = cpu_window(lin, n, seconds)
            ratios.append(middle / (0.5 * (before + after)))
            before = after
        q25, q50, q75 = (float(v) for v in np.percentile(ratios, [25, 50, 75]))
        out[f"unsteady_over_linear_lanes_sandwich/{n}"] = {"median": q50, "q25": q25, "q75": q75, "ratios": ratios}
        if not as_json:
            print(f"{n} envs, {triples} windows of {seconds} s: unsteady / linear (lanes, one thread) median {q50:.3f}, "
                  f"interquartile {q25:.3f}-{q75:.3f}", flush=True)
    if as_json:
        print(json.dumps(out, indent=1))
    else:
        print(out["machine"])
    return out


if __name__ == "__main__":
    main()

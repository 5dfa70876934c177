"""Env-step throughput of the three aerodynamic models, measured in one run (ratios are the figures to quote).

    python benchmarks/bench_aero_models.py [--envs 64 1024] [--seconds 3] [--json]

The harness of ``bench_step.py`` (``rate``: the best wall rate of three windows, after a warm-up call that
compiles or loads the kernel, so compile time is never in the rate): one env-step = one 80 Hz control step
= 5 physics steps of 2.5 ms, all physics on (aero at 20 m/s, LuGre friction, stops, servos), all five
joints free, states near trim.  Kernels (``rig_env.physics.pipeline.choose_kernel``):

* ``linear``, lanes: the lane kernel (eight environments per SIMD register), what the environments run;
* ``linear``, joint: the per-environment kernel on the same model;
* ``tables``, joint and ``unsteady``, joint: the high-incidence tables, static and through the five
  flow-separation states.  The lane kernel does not run the tables (a table search per evaluation, which
  no lane can share), so both fall back to the per-environment kernel, as the environments do.

Ratios: ``unsteady / tables`` (the cost of the separation states on the kernel that runs them) and
``unsteady / linear lanes`` (what a switch from the default model to the unsteady one costs an environment).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.bench_step import AIRSPEED, H, N_SUB, machine_line, rate  # noqa: E402
from rig_env import RigParams, param_batch  # noqa: E402
from rig_env.physics import layout as L  # noqa: E402
from rig_env.physics.pipeline import PhysicsBatch, flags_of  # noqa: E402

CASES = (("linear", "lanes"), ("linear", "joint"), ("tables", "joint"), ("unsteady", "joint"))


def stepper(params: RigParams, n: int, aero_model: str, kind: str, seed: int = 0):
    """One env-step of n environments near trim on the kernel of ``kind`` with ``aero_model`` (the kernel that runs)."""
    rng = np.random.default_rng(seed)
    flags = flags_of(True, True, True, True, aero_model)
    batch = PhysicsBatch(param_batch(params, n), params.tables(), np.arange(5, dtype=np.int64), flags, H, N_SUB, kind=kind)
    batch.U[:, L.U_AIRSPEED] = AIRSPEED
    batch.reset(np.arange(n), rng.uniform(-0.2, 0.2, (n, 5)), rng.uniform(-0.5, 0.5, (n, 5)))
    return batch.step, batch.kernel.kind


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--envs", type=int, nargs="+", default=[64, 1024])
    ap.add_argument("--seconds", type=float, default=3.0, help="timing window per case and batch size")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    params = RigParams.default()
    out: dict = {"machine": machine_line(), "rates": {}}
    for n in args.envs:
        for model, kind in CASES:
            step, ran = stepper(params, n, model, kind)
            out["rates"][f"{model}/{kind}/{n}"] = {"kernel": ran, "env_steps_per_s": rate(step, n, args.seconds)[0]}
        r = {k.split("/")[0] + "/" + k.split("/")[1]: v["env_steps_per_s"] for k, v in out["rates"].items() if k.endswith(f"/{n}")}
        out[f"unsteady_over_tables/{n}"] = r["unsteady/joint"] / r["tables/joint"]
        out[f"unsteady_over_linear_lanes/{n}"] = r["unsteady/joint"] / r["linear/lanes"]
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        print(out["machine"])
        print(f"{'model':10s} {'asked':6s} {'ran':6s} {'envs':>6s} {'env-steps/s':>12s}")
        for k, v in out["rates"].items():
            model, kind, n = k.split("/")
            print(f"{model:10s} {kind:6s} {v['kernel']:6s} {n:>6s} {v['env_steps_per_s']:12,.0f}")
        for k, v in out.items():
            if "_over_" in k:
                print(f"{k}: {v:.3f}")
    return out


if __name__ == "__main__":
    main()

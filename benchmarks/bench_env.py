"""Environment throughput: RigVectorEnv (make_vec) vs SyncVectorEnv of RigEnv vs the raw physics batch.

    python benchmarks/bench_env.py [--sizes 1 64 1024] [--seconds 2]

All three in the same run (the machines are shared and noisy: compare ratios).  Compile and cache
load happen in a warm-up before timing.  Steps/s counts environment control steps (80 Hz, 4 physics
substeps each) per wall-clock second.  The raw batch is ``integrator.step_batch``/``step_serial`` on the
environment's own arrays: the cost of the physics alone.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import gymnasium as gym
import numpy as np

import rig_env.envs  # noqa: F401  (registers the ids)
from rig_env.envs import RigEnv, RigVectorEnv

ENV_ID = "rig_env/VelocityVectorRoll-v0"


def _rate(step, n_envs: int, seconds: float) -> float:
    for _ in range(5):
        step()
    k, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        for _ in range(10):
            step()
        k += 10
    return k * n_envs / (time.perf_counter() - t0)


def bench(n: int, seconds: float, sync_max: int) -> dict[str, float]:
    rng = np.random.default_rng(0)
    out: dict[str, float] = {}
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    a = rng.uniform(-1, 1, (n, 3))
    out["RigVectorEnv"] = _rate(lambda: venv.step(a), n, seconds)
    v: RigVectorEnv = venv

    def raw() -> None:
        v._kernel(v.X, v.dbuf, v._k0, v.delay_steps, v.P, v.U, v.flags, v.free_idx, len(v.free_idx), v.tabs, v.h, v.n_sub, v.status, v.W, v.MW)
        v._k0 += v.n_sub

    out["raw physics"] = _rate(raw, n, seconds)
    if n <= sync_max:
        sync = gym.vector.SyncVectorEnv([lambda: RigEnv() for _ in range(n)], autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
        sync.reset(seed=0)
        out["SyncVectorEnv(RigEnv)"] = _rate(lambda: sync.step(a), n, seconds)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 64, 1024])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--sync-max", type=int, default=256, help="largest batch for the SyncVectorEnv comparison")
    args = ap.parse_args()
    t0 = time.perf_counter()
    RigVectorEnv(1).reset(seed=0)
    RigVectorEnv(64).reset(seed=0)
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, numpy {np.__version__}; setup {time.perf_counter() - t0:.2f} s")
    print("| n_envs | RigVectorEnv steps/s | SyncVectorEnv(RigEnv) steps/s | raw physics steps/s | vector / sync | vector / raw |")
    print("|---|---|---|---|---|---|")
    for n in args.sizes:
        r = bench(n, args.seconds, args.sync_max)
        s = r.get("SyncVectorEnv(RigEnv)", float("nan"))
        print(f"| {n} | {r['RigVectorEnv']:.0f} | {s:.0f} | {r['raw physics']:.0f} | {r['RigVectorEnv'] / s:.1f} | {r['RigVectorEnv'] / r['raw physics']:.2f} |")


if __name__ == "__main__":
    main()

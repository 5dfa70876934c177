"""Environment throughput: RigVectorEnv (make_vec) vs SyncVectorEnv of RigEnv vs the raw physics batch.

    python benchmarks/bench_env.py [--sizes 1 64 1024] [--seconds 2]

All three in the same run (the machines are shared and noisy: compare ratios).  Compile and cache
load happen before timing (their time is printed apart).  Steps/s counts environment control steps (80 Hz, 5 physics
substeps each) per wall-clock second.  The raw batch is ``RigVectorEnv.advance_physics`` (the lane kernel,
``rig_env.physics.lanes``) on the environment's own arrays: the cost of the physics alone; "env overhead" is the wall time per batch step of
RigVectorEnv minus that of the raw batch (the environment's own bookkeeping: sensors, noise, task, metrics).
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

    out["raw physics"] = _rate(v.advance_physics, n, seconds)
    if n <= sync_max:
        sync = gym.vector.SyncVectorEnv([lambda: RigEnv() for _ in range(n)], autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
        sync.reset(seed=0)
        out["SyncVectorEnv(RigEnv)"] = _rate(lambda: sync.step(a), n, seconds)
    return out


def first_step_seconds(n: int) -> float:
    """Wall time of the first step of a fresh batch: numba compile, or cache load when the cache is warm."""
    env = RigVectorEnv(n)
    env.reset(seed=0)
    t0 = time.perf_counter()
    env.step(np.zeros((n, 3)))
    return time.perf_counter() - t0


def render_ms(frames: int = 40) -> float:
    """Median wall time of one ``rgb_array`` frame of a RigEnv (after the first, which builds the figure)."""
    env = RigEnv(render_mode="rgb_array")
    env.reset(seed=0)
    env.render()
    times = []
    for _ in range(frames):
        env.step(np.full(3, 0.5))
        t0 = time.perf_counter()
        env.render()
        times.append(time.perf_counter() - t0)
    env.close()
    return 1e3 * float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 64, 1024])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--sync-max", type=int, default=1024, help="largest batch for the SyncVectorEnv comparison")
    args = ap.parse_args()
    load = open("/proc/loadavg").read().split()[0] if os.path.exists("/proc/loadavg") else "?"
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, numpy {np.__version__}, load average {load}")
    print(f"# first step (numba compile or cache load): serial kernel {first_step_seconds(1):.2f} s, "
          f"parallel kernel {first_step_seconds(64):.2f} s; not included in the rates below")
    print("| n_envs | RigVectorEnv steps/s | SyncVectorEnv(RigEnv) steps/s | raw physics steps/s | vector / sync | vector / raw | env overhead ms/step |")
    print("|---|---|---|---|---|---|---|")
    for n in args.sizes:
        r = bench(n, args.seconds, args.sync_max)
        s = r.get("SyncVectorEnv(RigEnv)", float("nan"))
        overhead_ms = 1e3 * n * (1.0 / r["RigVectorEnv"] - 1.0 / r["raw physics"])
        print(f"| {n} | {r['RigVectorEnv']:.0f} | {s:.0f} | {r['raw physics']:.0f} | {r['RigVectorEnv'] / s:.1f} | "
              f"{r['RigVectorEnv'] / r['raw physics']:.2f} | {overhead_ms:.3f} |")
    print(f"# rendering: {render_ms():.1f} ms per rgb_array frame (median of 40, 448 x 1024)")


if __name__ == "__main__":
    main()

"""Environment throughput: RigVectorEnv (make_vec) vs SyncVectorEnv of RigEnv vs the raw physics batch.

    python benchmarks/bench_env.py [--sizes 1 64 1024] [--seconds 2]

All in the same run (the machines are shared and noisy: compare ratios).  Compile and cache
load happen before timing (their time is printed apart).  Steps/s counts environment control steps (80 Hz, 5 physics
substeps each) per wall-clock second.  The raw batch is ``RigVectorEnv.advance_physics`` (its
``rig_env.physics.pipeline.PhysicsBatch`` on the lane kernel, ``rig_env.physics.lanes``) on the environment's own arrays: the cost of the physics alone; "env overhead" is the wall time per batch step of
RigVectorEnv minus that of the raw batch (the environment's own bookkeeping: sensors, noise, task, metrics).
"raw / sync" is the ceiling of "vector / sync": the ratio were that bookkeeping free (the scalar env's
step is mostly per-call Python and one block of the lane kernel, so the ratio cannot exceed it; see
``benchmarks/RESULTS.md`` on why a faster shared per-call path lowers the ratio).

Two more scalar contenders, for information: ``make_vec(..., vectorization_mode="sync")`` (what a user
gets by asking gymnasium for a SyncVectorEnv of the registered id: ``RigEnv`` inside gymnasium's standard
wrappers) and a ``SyncVectorEnv`` of ``RigEnv`` switched to the per-environment kernel
(``rig_env.physics.integrator``: one environment, no idle lanes; not what ``RigEnv`` runs, which is the
batch of one on the lane kernel, seven lanes idle, so that it equals environment i of a batch bit for bit).

Each rate is measured ``--repeats`` times, the contenders taking turns window by window, so that a
slow spell of the shared machine falls on all of them alike; the table gives the median rate of each and
the range of the per-round ratio vector / sync (the figure the issue's 50x target is about).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import rig_env.envs  # noqa: E402, F401  (registers the ids)
from benchmarks.bench_step import at_least_one, machine_line  # noqa: E402
from rig_env.envs import RigEnv, RigVectorEnv  # noqa: E402

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


def per_env_kernel_rig_env() -> RigEnv:
    """A RigEnv whose batch of one runs the per-environment kernel (``integrator.step_serial``) rather than
    the lane kernel: the fastest scalar environment this code could make, for the table's information column."""
    env = RigEnv()
    env.vec.physics.select_kernel("joint")
    return env


def bench(n: int, seconds: float, sync_max: int, repeats: int) -> dict[str, list[float]]:
    """Rates (steps/s) of each contender, one per round; the contenders alternate within a round."""
    rng = np.random.default_rng(0)
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    a = rng.uniform(-1, 1, (n, 3))
    v: RigVectorEnv = venv
    steps = {"RigVectorEnv": lambda: venv.step(a), "raw physics": v.advance_physics}
    if n <= sync_max:
        sync = gym.vector.SyncVectorEnv([lambda: RigEnv() for _ in range(n)], autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
        sync.reset(seed=0)
        steps["SyncVectorEnv(RigEnv)"] = lambda: sync.step(a)
        made = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="sync")
        made.reset(seed=0)
        steps["make_vec sync"] = lambda: made.step(a)
        per_env = gym.vector.SyncVectorEnv([per_env_kernel_rig_env for _ in range(n)], autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
        per_env.reset(seed=0)
        steps["SyncVectorEnv(per-env kernel)"] = lambda: per_env.step(a)
    out: dict[str, list[float]] = {k: [] for k in steps}
    for _ in range(repeats):
        for k, step in steps.items():
            out[k].append(_rate(step, n, seconds))
    return out


def _ratio(r: dict[str, list[float]], sync: str) -> str:
    """'median [min, max]' of the per-round ratios RigVectorEnv / ``sync``; '-' when ``sync`` was not run."""
    if sync not in r:
        return "-"
    ratios = np.array(r["RigVectorEnv"]) / np.array(r[sync])
    return f"{np.median(ratios):.1f} [{ratios.min():.1f}, {ratios.max():.1f}]"


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
    ap.add_argument("--repeats", type=at_least_one, default=3, help="rounds of timing windows (contenders alternate within a round)")
    args = ap.parse_args()
    print(f"# {machine_line()}, numpy {np.__version__}")
    print(f"# first step (numba compile or cache load): serial kernel {first_step_seconds(1):.2f} s, "
          f"parallel kernel {first_step_seconds(64):.2f} s; not included in the rates below")
    print(f"# median of {args.repeats} rounds of {args.seconds:g} s windows; vector / sync: median [min, max] of the per-round ratios")
    print("# raw / sync: the ceiling of vector / sync, were the environment's own work (sensors, task, metrics) free")
    print("# for information: vector / make_vec(sync) and vector / SyncVectorEnv of RigEnv on the per-environment kernel, same rounds")
    print("| n_envs | RigVectorEnv steps/s | SyncVectorEnv(RigEnv) steps/s | raw physics steps/s | vector / sync | raw / sync | vector / raw "
          "| env overhead ms/step | vector / make_vec sync | vector / per-env-kernel sync |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        r = bench(n, args.seconds, args.sync_max, args.repeats)
        vec, raw = float(np.median(r["RigVectorEnv"])), float(np.median(r["raw physics"]))
        vs, vm, vp = (_ratio(r, k) for k in ("SyncVectorEnv(RigEnv)", "make_vec sync", "SyncVectorEnv(per-env kernel)"))
        s = float(np.median(r["SyncVectorEnv(RigEnv)"])) if "SyncVectorEnv(RigEnv)" in r else float("nan")
        overhead_ms = 1e3 * n * (1.0 / vec - 1.0 / raw)
        print(f"| {n} | {vec:.0f} | {s:.0f} | {raw:.0f} | {vs} | {raw / s:.1f} | {vec / raw:.2f} | {overhead_ms:.3f} | {vm} | {vp} |", flush=True)
    print(f"# rendering: {render_ms():.1f} ms per rgb_array frame (median of 40, 448 x 1024)")


if __name__ == "__main__":
    main()

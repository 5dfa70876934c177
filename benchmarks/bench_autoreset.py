"""RigVectorEnv step throughput in its two autoreset modes: next-step / same-step, in one process.

Short episodes (``--episode-seconds``, 1 s = 80 control steps by default) so that the autoresets are part
of the timing; zero actions, so every environment ends on the same step (the worst case for the reset
work of a step).  The contenders alternate within a round, in a rotating order; the ratio is the median
of the per-round ratios.  ``python benchmarks/bench_autoreset.py --sizes 1024 4096``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.bench_step import at_least_one, machine_line  # noqa: E402
from gymnasium.vector import AutoresetMode  # noqa: E402
from rig_env.envs import RigVectorEnv  # noqa: E402


def bench(n: int, episode_seconds: float, seconds: float, rounds: int) -> dict[str, list[float]]:
    """env-steps/s of each mode, one value per round."""
    envs = {m: RigVectorEnv(n, autoreset_mode=m, episode_seconds=episode_seconds) for m in (AutoresetMode.SAME_STEP, AutoresetMode.NEXT_STEP)}
    a = np.zeros((n, 3))
    for e in envs.values():
        e.reset(seed=0)
        for _ in range(100):  # compile or cache load, and warm caches
            e.step(a)
    out: dict[str, list[float]] = {m.value: [] for m in envs}
    modes = list(envs)
    for r in range(rounds):
        for m in modes[r % 2:] + modes[: r % 2]:
            t0, c = time.perf_counter(), 0
            while time.perf_counter() - t0 < seconds:
                envs[m].step(a)
                c += 1
            out[m.value].append(c * n / (time.perf_counter() - t0))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096])
    ap.add_argument("--episode-seconds", type=float, default=1.0, help="episode length, s (80 control steps a second)")
    ap.add_argument("--seconds", type=float, default=1.0, help="timing window, s")
    ap.add_argument("--rounds", type=at_least_one, default=9)
    args = ap.parse_args()
    print(f"# {machine_line()}, numpy {np.__version__}")
    print("| n_envs | same-step env-steps/s | next-step env-steps/s | next / same, median [min, max] |")
    print("|---|---|---|---|")
    for n in args.sizes:
        r = bench(n, args.episode_seconds, args.seconds, args.rounds)
        ratio = np.array(r["NextStep"]) / np.array(r["SameStep"])
        print(f"| {n} | {np.median(r['SameStep']):,.0f} | {np.median(r['NextStep']):,.0f} | "
              f"{np.median(ratio):.2f} [{ratio.min():.2f}, {ratio.max():.2f}] |")


if __name__ == "__main__":
    main()

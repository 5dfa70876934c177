"""Cold numba compile of each kernel, with and without the inliner fix (rig_env.physics.fast_inline).

    python benchmarks/bench_compile.py [--kernels lanes joint dae] [--rounds 1]

Each measurement is a fresh interpreter with an empty numba cache (``bench_step.compile_times``: the
first call of the parallel kernel on 64 environments, which compiles it and everything it calls), then
a second interpreter on the cache it left.  With the fix (the default) and without it
(``RIG_ENV_FAST_INLINE=0``) alternate kernel by kernel in one run, so both see the same machine; the
ratio is the figure to quote.  A kernel's compile includes that of the functions it calls (the
right-hand side, aerodynamics, friction), so the kernels' times are not additive: a user's first
``rig compare`` compiles the lane kernel, the per-environment kernel (for the high-incidence tables)
and the environment's bookkeeping kernels.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.bench_step import at_least_one, compile_times, machine_line  # noqa: E402

STEPPERS = {"lanes": "lanes_stepper", "joint": "joint_stepper", "dae": "dae_stepper"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kernels", nargs="+", choices=sorted(STEPPERS), default=["lanes", "joint", "dae"])
    ap.add_argument("--rounds", type=at_least_one, default=1, help="repeat each pair of measurements")
    args = ap.parse_args()
    print(f"# {machine_line()}")
    print("| kernel | round | cold compile, fix on (s) | cold compile, fix off (s) | off / on | cache load, fix on (s) |")
    print("|---|---|---|---|---|---|")
    for name in args.kernels:
        for r in range(args.rounds):
            on = compile_times(STEPPERS[name], {"RIG_ENV_FAST_INLINE": "1"})
            off = compile_times(STEPPERS[name], {"RIG_ENV_FAST_INLINE": "0"})
            print(f"| {name} | {r + 1} | {on['compile_s']:.1f} | {off['compile_s']:.1f} | {off['compile_s'] / on['compile_s']:.2f} | "
                  f"{on['cached_load_s']:.2f} |", flush=True)


if __name__ == "__main__":
    main()

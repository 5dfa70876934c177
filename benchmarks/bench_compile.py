"""Cold numba compile of each kernel: the right-hand side inlined by LLVM (the default) against numba's IR inliner.

    python benchmarks/bench_compile.py [--kernels lanes joint dae] [--rounds 1] [--rate]

Each measurement is a fresh interpreter with an empty numba cache (``bench_step.compile_times``: the
first call of the parallel kernel on 64 environments, which compiles it and everything it calls), then
a second interpreter on the cache it left.  The two ways of inlining the right-hand side's parts into
the kernels alternate kernel by kernel in one run, so both see the same machine; the ratio is the figure
to quote:

* ``llvm``: :mod:`rig_env.physics.llvm_inline` (the default): each part compiled once, inlined by LLVM;
* ``numba IR``: numba's ``inline="always"`` with the copy fix of :mod:`rig_env.physics.fast_inline`
  (``RIG_ENV_LLVM_INLINE=0``), what the kernels did before.

``--rate`` also times each variant's kernel (env-steps/s on 1024 environments, best of three 1 s windows,
in the second interpreter): the inlining must not cost speed.  A kernel's compile includes that of the
functions it calls, so the kernels' times are not additive.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.bench_step import at_least_one, compile_times, machine_line  # noqa: E402

VARIANTS = {"llvm": {"RIG_ENV_LLVM_INLINE": "1"}, "numba IR": {"RIG_ENV_LLVM_INLINE": "0"}}

STEPPERS = {"lanes": "lanes_stepper", "joint": "joint_stepper", "dae": "dae_stepper"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kernels", nargs="+", choices=sorted(STEPPERS), default=["lanes", "joint", "dae"])
    ap.add_argument("--rounds", type=at_least_one, default=1, help="repeat each pair of measurements")
    ap.add_argument("--rate", action="store_true", help="also time each variant's kernel, env-steps/s on 1024 environments")
    args = ap.parse_args()
    print(f"# {machine_line()}")
    print("| kernel | round | cold compile, llvm (s) | cold compile, numba IR (s) | numba IR / llvm | cache load, llvm (s) |"
          + (" env-steps/s llvm | env-steps/s numba IR |" if args.rate else ""))
    print("|---|---|---|---|---|---|" + ("---|---|" if args.rate else ""))
    for name in args.kernels:
        for r in range(args.rounds):
            res = {v: compile_times(STEPPERS[name], env, rate=args.rate) for v, env in VARIANTS.items()}
            on, off = res["llvm"], res["numba IR"]
            rates = f" {on['rate']:,.0f} | {off['rate']:,.0f} |" if args.rate else ""
            print(f"| {name} | {r + 1} | {on['compile_s']:.1f} | {off['compile_s']:.1f} | {off['compile_s'] / on['compile_s']:.2f} | "
                  f"{on['cached_load_s']:.2f} |{rates}", flush=True)


if __name__ == "__main__":
    main()

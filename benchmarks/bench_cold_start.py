"""A new user's first `rig compare --quick`: wall time from an empty numba cache, and the longest silence.

    python benchmarks/bench_cold_start.py [--rounds 1] [--before]

Each measurement runs ``rig compare --quick`` in a fresh interpreter with an empty ``NUMBA_CACHE_DIR``
(the package's own cache is never touched) and timestamps every line it writes (stdout and stderr, a
``\\r`` update counting as a line): the figures are the wall time to exit and the longest gap between two
lines.  Then the same command once more on the cache it left (the warm run every later call is).  Named
alternatives, alternating in one run so that all see the same machine:

* ``default``: the kernels compiled side by side in child processes (:mod:`rig_env.precompile`), the
  right-hand side inlined by LLVM (:mod:`rig_env.physics.llvm_inline`);
* ``one process``: ``RIG_ENV_PRECOMPILE_PROCESSES=1``, every kernel compiled where it is first used;
* ``--before``: also ``RIG_ENV_LLVM_INLINE=0`` with one process, numba's IR inliner (how the kernels were
  compiled before; about three minutes).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.bench_step import at_least_one, machine_line  # noqa: E402

VARIANTS = {
    "default": {},
    "one process": {"RIG_ENV_PRECOMPILE_PROCESSES": "1"},
    "numba IR inliner, one process": {"RIG_ENV_PRECOMPILE_PROCESSES": "1", "RIG_ENV_LLVM_INLINE": "0"},
}


def run(extra: dict[str, str], cache: str, out: str) -> dict[str, float]:
    """Wall time (s) and longest silence (s) of one ``rig compare --quick`` with the cache ``cache``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, MPLBACKEND="Agg", PYTHONUNBUFFERED="1", **extra)
    cmd = [sys.executable, "-m", "rig_cli", "compare", "--quick", "--out", out, "--overwrite"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    assert proc.stdout is not None
    last, gap, buf = t0, 0.0, b""
    while True:
        chunk = proc.stdout.read1(4096) if hasattr(proc.stdout, "read1") else proc.stdout.read(1)
        if not chunk:
            break
        now = time.perf_counter()
        buf += chunk
        if b"\n" in buf or b"\r" in buf:
            gap, last = max(gap, now - last), now
            buf = b""
    if proc.wait() != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed with exit code {proc.returncode}")
    end = time.perf_counter()
    return {"wall_s": end - t0, "silence_s": max(gap, end - last)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=at_least_one, default=1, help="repeat the alternation")
    ap.add_argument("--before", action="store_true", help="also the numba IR inliner in one process (about 3 minutes)")
    ap.add_argument("--only-default", action="store_true", help="the default variant alone (repeat it with --rounds)")
    args = ap.parse_args()
    names = ["default"] if args.only_default else (list(VARIANTS) if args.before else list(VARIANTS)[:2])
    print(f"# {machine_line()}")
    print("| variant | round | cold: wall (s) | cold: longest silence (s) | warm: wall (s) | cold / default cold |")
    print("|---|---|---|---|---|---|")
    for r in range(args.rounds):
        base = None
        for name in names:
            with tempfile.TemporaryDirectory(prefix="rig_cold_") as tmp:
                cold = run(VARIANTS[name], f"{tmp}/numba", f"{tmp}/out")
                warm = run(VARIANTS[name], f"{tmp}/numba", f"{tmp}/out")
            base = base or cold["wall_s"]
            print(f"| {name} | {r + 1} | {cold['wall_s']:.1f} | {cold['silence_s']:.1f} | {warm['wall_s']:.1f} | "
                  f"{cold['wall_s'] / base:.2f} |", flush=True)


if __name__ == "__main__":
    main()

"""Continuation speed: the periodic orbits' shooting on the lane kernel against the per-environment kernel.

    python benchmarks/bench_continuation.py [--rounds 3] [--case lower|upper] [--max-orbits N] [--json]

Runs ``rig_env.continuation`` with ``orbit_kernel="lanes"`` (the default: the environments' serial lane
kernel, eight perturbed states per register) and ``orbit_kernel="joint"`` (the per-environment kernel that
``rig_env.simulate`` runs), the two taking turns, on one of Fig. 8's bands (model pitch alone, unsteady model,
20 m/s, the paper's model ``RigParams.paper()``; docs/MODEL.md 7):

* ``lower``: the README's example, ``with_lift_break(6, 0.05)`` and ``sep_cp_travel`` 0.2, elevator 1.5 to 0.3
  deg (two Hopf points, one family of 21 stable orbits);
* ``upper``: ``sep_cp_travel`` 0.12, elevator -1.2 to -1.35 deg (the subcritical Hopf point, its fold of
  cycles; ``--max-orbits`` orbits, default 42).

JIT compilation is excluded (one short continuation with each kernel first).  Prints each round's wall
times and their ratio (per-environment over lanes), then the median ratio; the two kernels' orbits are
compared (largest difference of the orbits' parameter values and amplitudes) to show they are the same.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import rig_env  # noqa: E402


def case(name: str, max_orbits: int) -> tuple[rig_env.RigParams, dict[str, Any]]:
    """The rig and the continuation's arguments of a case (module docstring)."""
    p = rig_env.RigParams.paper()
    kw: dict[str, Any] = {"free_dofs": ("model_pitch",), "parameter": "hawk_elevator", "aero_model": "unsteady", "max_orbits": max_orbits}
    if name == "lower":
        return p.with_lift_break(6.0, 0.05).replace(**{"hawk_aero.sep_cp_travel": 0.2}), {**kw, "values": np.linspace(1.5, 0.3, 25)}
    if name == "upper":
        return p.replace(**{"hawk_aero.sep_cp_travel": 0.12}), {**kw, "values": np.linspace(-1.2, -1.35, 16),
                                                                 "q_guess": [0.0, 0.0, 0.0, math.radians(12.3), 0.0]}
    raise ValueError(f"--case {name!r}: allowed values: 'lower', 'upper'")


def run(name: str, rounds: int, max_orbits: int) -> dict[str, Any]:
    """Alternating timed continuations with each kernel; returns the times, ratios and the orbits' differences."""
    if rounds < 1 or max_orbits < 2:
        raise ValueError("--rounds must be at least 1 and --max-orbits at least 2")
    p, kw = case(name, max_orbits)
    for kernel in ("lanes", "joint"):  # compile (or load) both kernels outside the timing
        rig_env.continuation(p, **{**kw, "max_orbits": 2}, orbit_kernel=kernel)
    times: dict[str, list[float]] = {"lanes": [], "joint": []}
    last: dict[str, Any] = {}
    for r in range(rounds):
        for kernel in ("lanes", "joint"):
            t0 = time.perf_counter()
            br = rig_env.continuation(p, **kw, orbit_kernel=kernel)
            times[kernel].append(time.perf_counter() - t0)
            last[kernel] = [ob for ob in br.orbits if ob.values.size]
        print(f"round {r + 1}: lanes {times['lanes'][-1]:.2f} s, per-environment {times['joint'][-1]:.2f} s, "
              f"ratio {times['joint'][-1] / times['lanes'][-1]:.2f}", flush=True)
    a, b = last["lanes"], last["joint"]
    same = len(a) == len(b) and all(x.values.size == y.values.size for x, y in zip(a, b))
    dv = max((float(np.max(np.abs(x.values - y.values))) for x, y in zip(a, b)), default=0.0) if same else math.inf
    da = max((float(np.max(np.abs(x.amplitudes - y.amplitudes))) for x, y in zip(a, b)), default=0.0) if same else math.inf
    ratios = [j / lane for j, lane in zip(times["joint"], times["lanes"])]
    return {"case": name, "orbits": [int(x.values.size) for x in a], "seconds": times, "ratios": ratios,
            "median_ratio": statistics.median(ratios), "max_value_difference": dv, "max_amplitude_difference": da,
            "machine": f"{platform.processor() or platform.machine()}, python {platform.python_version()}"}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--case", default="lower")
    ap.add_argument("--max-orbits", type=int, default=42)
    ap.add_argument("--json", action="store_true", help="print one JSON object at the end")
    args = ap.parse_args(argv)
    out = run(args.case, args.rounds, args.max_orbits)
    print(f"{out['case']} band, orbits per family {out['orbits']}: per-environment / lanes median {out['median_ratio']:.2f} "
          f"over {args.rounds} rounds ({', '.join(f'{r:.2f}' for r in out['ratios'])}); the two kernels' orbits differ by at most "
          f"{out['max_value_difference']:.1e} deg in the parameter and {out['max_amplitude_difference']:.1e} in the amplitudes (state units)")
    if args.json:
        print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()

"""Identification speed: a 10-parameter output-error fit of 40 s of 80 Hz 2-DOF data (model pitch and rig
pitch, a Hawk-elevator 3-2-1-1 and a compensator doublet, twice each, 0.1 deg noise), against scipy's
``least_squares`` driving the same model one simulation at a time.

    python benchmarks/bench_sysid.py [--repeats 3] [--write]

Both fit the same record from the same start (every parameter 10 % off the truth), with the same model
(the default rig: LuGre friction, servos, stops) and the same outputs (the two angles), estimating the ten
aerodynamic derivatives and the four initial angles and rates:

* ``rig_env.sysid.fit``: Gauss-Newton / Levenberg-Marquardt; the sensitivities of each iteration are one
  batch of 15 environments (nominal and +step of each of the 14 parameters) in the serial lane kernel.
* ``scipy.optimize.least_squares`` (trust-region reflective within the same bounds, the Jacobian by its own
  2-point differences):
  each residual evaluation is one ``rig_env.simulate`` of the record (the per-environment kernel).

JIT compilation is excluded (one warm-up fit of each first).  Times are wall-clock medians of
``--repeats`` runs; the estimates of both are printed to show they agree.  ``--write`` replaces the
"## Identification" section of benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rig_env import RigParams, simulate, sysid  # noqa: E402
from rig_env.params import PARAM_INDEX  # noqa: E402
from rig_env.sysid.model import RecordModel  # noqa: E402
from rig_env.sysid.parameters import ParameterSet  # noqa: E402

FREE = ("rig_pitch", "model_pitch")
EST = ["hawk_aero.CL0", "hawk_aero.CLalpha", "hawk_aero.CLde", "hawk_aero.CM0", "hawk_aero.CMalpha", "hawk_aero.CMq",
       "hawk_aero.CMde", "comp_aero.CLalpha", "comp_aero.CLde", "comp_aero.CMq"]


def u3211(t: np.ndarray, amp: float = -1.5, unit: float = 0.28, t0: float = 0.5) -> np.ndarray:
    k = (np.asarray(t) - t0) / unit
    return amp * np.select([k < 0, k < 3, k < 5, k < 6, k < 7], [0.0, 1.0, -1.0, 1.0, -1.0], 0.0)


def doublet(t: np.ndarray, amp: float = 5.0, period: float = 1.0, t0: float = 4.0) -> np.ndarray:
    k = (np.asarray(t) - t0) / period
    return amp * np.select([k < 0, k < 0.5, k < 1.0], [0.0, 1.0, -1.0], 0.0)


def make_record(p: RigParams) -> sysid.FlightRecord:
    rest = simulate(p, [0.0, math.radians(7.0)], [0.0, 0.0], 20.0, free_dofs=FREE, airspeed=20.0)
    q0 = rest.q[-1]
    elev = lambda t: u3211(t) + u3211(t, t0=20.5)  # noqa: E731
    comp = lambda t: doublet(t) + doublet(t, t0=24.0)  # noqa: E731
    res = simulate(p, q0, [0.0, 0.0], 40.0, free_dofs=FREE, controls={"hawk_elevator": elev, "comp_elevator": comp}, airspeed=20.0)
    rng = np.random.default_rng(0)
    q = res.q + rng.normal(0.0, math.radians(0.1), res.q.shape)
    return sysid.FlightRecord(t=res.t, free_dofs=FREE, q=q, surfaces={"hawk_elevator": elev(res.t), "comp_elevator": comp(res.t)},
                              airspeed=20.0, name="two_dof")


def fit_ours(p: RigParams, rec: sysid.FlightRecord, start: dict) -> tuple[float, dict, int]:
    t0 = time.perf_counter()
    f = sysid.fit(rec, p, EST, start=start)
    return time.perf_counter() - t0, dict(f.values), f.iterations


def fit_scipy(p: RigParams, rec: sysid.FlightRecord, start: dict) -> tuple[float, dict, int]:
    from scipy.optimize import least_squares

    surf = {s: (lambda v: (lambda t: v[min(int(round(t * 80.0)), v.size - 1)]))(rec.surfaces[s]) for s in rec.surfaces}
    T = float(rec.t[-1])
    names = EST
    n_calls = [0]

    def residuals(x: np.ndarray) -> np.ndarray:
        n_calls[0] += 1
        pp = p.replace(**{n: float(v) for n, v in zip(names, x[: len(names)])})
        x0 = x[len(names):]
        r = simulate(pp, x0[:2], x0[2:], T, free_dofs=FREE, controls=surf, airspeed=20.0)
        return (r.q - rec.q).ravel()

    m = RecordModel(rec, p)
    x_start = np.concatenate([[start[n] for n in names], m.measured_x0()])
    ps = ParameterSet.build(p, names)  # the same bounds as sysid.fit: each parameter's allowed range
    lo = np.concatenate([ps.lower, np.full(4, -np.inf)])
    hi = np.concatenate([ps.upper, np.full(4, np.inf)])
    t0 = time.perf_counter()
    sol = least_squares(residuals, x_start, method="trf", x_scale="jac", bounds=(lo, hi))
    dt = time.perf_counter() - t0
    return dt, {n: float(v) for n, v in zip(names, sol.x)}, n_calls[0]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    p = RigParams.default()
    rec = make_record(p)
    vec = p.to_vector()
    truth = {n: float(vec[PARAM_INDEX[n]]) for n in EST}
    start = {n: 1.1 * v for n, v in truth.items()}
    print("warm-up (JIT compilation, excluded) ...", flush=True)
    fit_ours(p, rec, start)
    ours = [fit_ours(p, rec, start) for _ in range(a.repeats)]
    print(f"rig_env.sysid.fit: {[round(o[0], 2) for o in ours]} s, {ours[-1][2]} iterations", flush=True)
    theirs = [fit_scipy(p, rec, start) for _ in range(a.repeats)]
    print(f"scipy least_squares + simulate(): {[round(o[0], 2) for o in theirs]} s, {theirs[-1][2]} simulations", flush=True)
    t_ours = float(np.median([o[0] for o in ours]))
    t_theirs = float(np.median([o[0] for o in theirs]))
    rows = [f"| {n} | {truth[n]:.4g} | {ours[-1][1][n]:.4g} | {theirs[-1][1][n]:.4g} |" for n in EST]
    text = "\n".join([
        "## Identification",
        "",
        "A 10-parameter output-error fit of 40 s of 80 Hz 2-DOF data (rig pitch + model pitch; Hawk-elevator 3-2-1-1 "
        "and compensator doublet, twice each; 0.1 deg noise; start 10 % off), JIT compilation excluded, median of "
        f"{a.repeats} runs: `python benchmarks/bench_sysid.py --repeats {a.repeats} --write`.",
        "",
        "| fitter | wall time (s) | ratio |",
        "|---|---|---|",
        f"| `rig_env.sysid.fit` (one lane-kernel batch of 15 environments per iteration for the sensitivities; 9 iterations) | {t_ours:.2f} | 1 |",
        f"| scipy `least_squares` (trf, 2-point Jacobian) driving `simulate()` one run at a time ({theirs[-1][2]} simulations) | {t_theirs:.2f} | {t_theirs / t_ours:.1f}x slower |",
        "",
        f"Goal: under 5 s on this machine. Machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}.",
        "",
        "| parameter | truth | sysid.fit | least_squares |",
        "|---|---|---|---|",
        *rows,
        "",
    ])
    print(text)
    if a.write:
        path = ROOT / "benchmarks" / "RESULTS.md"
        old = path.read_text()
        if "## Identification" in old:
            head, _, rest = old.partition("## Identification")
            tail = rest[rest.find("\n## ") + 1 :] if "\n## " in rest else ""
            new = head + text + ("\n" + tail if tail else "")
        else:
            new = old.rstrip("\n") + "\n\n" + text
        path.write_text(new)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

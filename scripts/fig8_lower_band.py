"""What Fig. 8's lower pitch limit cycle (near 5 deg) takes: ``python scripts/fig8_lower_band.py [--out DIR] [--rig default]``.

On the paper's model (``RigParams.paper()``, which the analysis of Figs. 8 and 9 uses: its trims put the bands
where docs/MODEL.md 7 gives them; ``--rig default`` maps the default rig, its elevator window moved to the same
model pitch, :func:`elevator_grid`) the tables are linear to 8 deg, so the flow-separation model never acts near 5 deg (x0 = 1) and the
model shows no limit cycle there (docs/MODEL.md 7).  A wing at the rig's Reynolds number (about 1.6e5 at
20 m/s) can lose some lift to a laminar separation bubble at moderate incidence; this script puts such a
local break into the Hawk's tables (:meth:`rig_env.RigParams.with_lift_break`: ``depth`` of lift lost at 6 deg,
the tables at 4 and 8 deg unchanged, the lost lift acting at the aerodynamic centre) and maps, over the break's
depth and the centre of pressure's travel with separation (``hawk_aero.sep_cp_travel`` k, in chords):

* the stability boundary: the least depth (on a grid of ``--step``, up to 0.16, where the lift
  still rises from 4 to 6 deg) at which continuation over the elevator (model pitch only, 20 m/s,
  ``aero_model="unsteady"``, friction off) finds unstable equilibria with the model pitch between 4 and 8 deg
  (bounded by the kinks of x0(alpha) where the leading pair jumps across the axis: the lower where the lift
  deficit passes ``aero.SEP_LIFT_TOL``, 0.01 of CL, the upper on the 6 deg breakpoint; reported as Hopf points
  while the pair stays complex);
* the orbits: amplitude (deg) and frequency (Hz) of the stable limit cycle in the middle of the band, from
  a 60 s simulation without friction;
* the gimbal's friction: whether that cycle survives the model-pitch joint's LuGre friction (Table 2): the
  same simulation with friction on, started from the frictionless cycle's amplitude.

Writes ``fig8_lower_band.png`` (the boundary and the friction points in the (k, depth) plane) and
``fig8_lower_band.md`` (the tables) in ``--out`` (default: the current directory); an existing file is kept
unless ``--overwrite``.  About two minutes.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

import rig_env
from rig_env import RigParams

BREAK_DEG = 6.0  # the break's breakpoint, between the tables' 4 and 8 deg
BAND_DEG = (4.0, 8.0)
MAX_DEPTH = 0.16  # CL: below 0.17 (CL(6 deg) - CL(4 deg)) the lift still rises from 4 to 6 deg (no static fold)
ELEVATOR = np.linspace(1.7, 0.3, 281)  # deg: model pitch from about 3 to 7 deg at 20 m/s (the paper's model), 0.005 deg apart
RIGS = ("paper", "default")
AIRSPEED = 20.0
FREE = ("model_pitch",)


def rig(params: RigParams, k: float, depth: float) -> RigParams:
    """``params`` with centre-of-pressure travel k (chords) and a lift break of ``depth`` at BREAK_DEG."""
    p = params.replace(**{"hawk_aero.sep_cp_travel": k})
    return p.with_lift_break(BREAK_DEG, depth) if depth > 0.0 else p


def elevator_at(params: RigParams, pitch_deg: float) -> float:
    """The elevator (deg) that holds the model pitch at ``pitch_deg`` (1-DOF, AIRSPEED, attached flow): from the
    trims at 0 and 1 deg of elevator, the tables being linear from -8 to 8 deg."""
    def pitch(elevator: float) -> float:
        op = rig_env.trim(params, FREE, [0, 0, 0, math.radians(5.0), 0], controls={"hawk_elevator": elevator}, aero_model="unsteady",
                          airspeed=AIRSPEED)
        return math.degrees(op.q[3])

    p0, p1 = pitch(0.0), pitch(1.0)
    return (pitch_deg - p0) / (p1 - p0)


def elevator_grid(params: RigParams) -> np.ndarray:
    """ELEVATOR moved by the difference of the elevators that hold 5 deg on ``params`` and on the paper's model
    (whose trim ELEVATOR's window was chosen for): the same model pitch window, about 3 to 7 deg, on any rig."""
    shift = elevator_at(params, 5.0) - elevator_at(RigParams.paper(), 5.0)
    return ELEVATOR + (shift if abs(shift) > 1e-6 else 0.0)


def unstable_band(params: RigParams, elevator: np.ndarray = ELEVATOR) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """(elevators, model pitch angles) of the unstable equilibria with the model pitch in BAND_DEG (deg, in the
    branch's order), and the model pitch (deg) of the Hopf points continuation reports there.  The band's
    edges sit on the tables' breakpoints (4 and 6 deg), where x0's slope jumps and the leading pair can jump
    across the imaginary axis rather than cross it (a Hopf point is then reported only while the pair stays
    complex), so the unstable equilibria, not the Hopf points, decide whether the band exists."""
    br = rig_env.continuation(params, free_dofs=FREE, parameter="hawk_elevator", values=elevator, airspeed=AIRSPEED,
                              aero_model="unsteady", periodic=False, q_guess=[0, 0, 0, math.radians(3.0), 0])
    pitch = np.degrees(br.states[:, 0])
    inside = ~br.stable & (pitch > BAND_DEG[0]) & (pitch < BAND_DEG[1])
    hopf = sorted(math.degrees(sp.state[0]) for sp in br.special_points if sp.kind == "hopf")
    return br.values[inside], pitch[inside], [h for h in hopf if BAND_DEG[0] <= h <= BAND_DEG[1]]


def depths_unstable(params: RigParams, k: float, depths: np.ndarray, elevator: np.ndarray = ELEVATOR) -> np.ndarray:
    """The break depths of ``depths`` at which some equilibrium with the model pitch near 5 deg is unstable."""
    return np.array([d for d in depths if unstable_band(rig(params, k, float(d)), elevator)[0].size])


def cycle(params: RigParams, elevator: float, friction: bool, start_deg: float, seconds: float = 60.0) -> tuple[float, float, float]:
    """(trim pitch, half peak-to-peak amplitude over the last third, frequency) in deg, deg and Hz of model pitch
    at a held elevator, released start_deg above the trim."""
    op = rig_env.trim(params, FREE, [0, 0, 0, math.radians(5.0), 0], controls={"hawk_elevator": elevator},
                      aero_model="unsteady", airspeed=AIRSPEED)
    r = rig_env.simulate(params, [op.q[3] + math.radians(start_deg)], [0.0], seconds, free_dofs=FREE,
                         controls={"hawk_elevator": elevator}, airspeed=AIRSPEED, aero_model="unsteady", friction=friction)
    late = np.degrees(r.q[r.t > seconds * 2.0 / 3.0, 0])
    amp = 0.5 * float(late.max() - late.min())
    x = late - late.mean()
    spec = np.abs(np.fft.rfft(x))
    freq = float(np.fft.rfftfreq(x.size, r.t[1] - r.t[0])[np.argmax(spec)]) if amp > 1e-3 else math.nan
    return math.degrees(op.q[3]), amp, freq


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path("."), help="directory for fig8_lower_band.png and .md")
    ap.add_argument("--overwrite", action="store_true", help="replace existing output files")
    ap.add_argument("--step", type=float, default=0.005, help="the depths' grid spacing (CL)")
    ap.add_argument("--rig", choices=RIGS, default="paper",
                    help="the parameter set: the paper's model (default: the analysis of docs/MODEL.md 7) or the default rig")
    args = ap.parse_args(argv)
    if not 0.0 < args.step <= 0.05:
        ap.error(f"--step must be in (0, 0.05], not {args.step}")
    png, md = args.out / "fig8_lower_band.png", args.out / "fig8_lower_band.md"
    for f in (png, md):
        if f.exists() and not args.overwrite:
            ap.error(f"{f} exists; give --overwrite to replace it, or another --out")
    args.out.mkdir(parents=True, exist_ok=True)
    base = getattr(RigParams, args.rig)()
    elev = elevator_grid(base)
    print(f"{args.rig} rig: elevator {elev[0]:.3f} to {elev[-1]:.3f} deg (model pitch about 3 to 7 deg)", flush=True)
    none = [k for k in (0.0, 0.1, 0.2, 0.3) if unstable_band(base.replace(**{"hawk_aero.sep_cp_travel": k}), elev)[0].size]
    print(f"the {args.rig} rig's tables, k = 0, 0.1, 0.2, 0.3: unstable equilibria near 5 deg for k in {none or 'none'}", flush=True)
    ks = (0.05, 0.1, 0.15, 0.2, 0.25, 0.3)
    depths = np.arange(args.step, MAX_DEPTH + 1e-12, args.step)
    boundary = []
    for k in ks:
        found = depths_unstable(base, k, depths, elev)
        d = float(found.min()) if found.size else math.nan
        boundary.append(d)
        every = found.size == round((MAX_DEPTH - d) / args.step) + 1 if found.size else False
        print(f"k = {k:.2f} c: unstable equilibria near 5 deg from a break of depth {d:.3f}"
              f"{' (and at every depth above it on the grid)' if every else ' (not at every depth above it on the grid)'}", flush=True)
    rows = []
    for k in (0.15, 0.2, 0.3):
        for depth in (0.05, 0.1, 0.15):
            band_elev, pitch, hopf = unstable_band(rig(base, k, depth), elev)
            if band_elev.size == 0:
                rows.append((k, depth, "", math.nan, math.nan, math.nan, math.nan))
                print(f"k = {k} c, depth {depth}: no unstable equilibrium near 5 deg", flush=True)
                continue
            P = rig(base, k, depth)
            mid = 0.5 * float(band_elev.min() + band_elev.max())
            trim, amp, freq = cycle(P, mid, False, 0.5)
            _, amp_f, _ = cycle(P, mid, True, max(amp, 0.5))
            band = f"{pitch.min():.2f} - {pitch.max():.2f}" + (f" (Hopf {', '.join(f'{h:.2f}' for h in hopf)})" if hopf else "")
            rows.append((k, depth, band, mid, amp, freq, amp_f))
            print(f"k = {k} c, depth {depth}: band {band} deg, elevator {mid:.3f} deg (trim {trim:.2f} deg): cycle {amp:.2f} deg at {freq:.2f} Hz; "
                  f"with the gimbal's friction {amp_f:.2f} deg", flush=True)
    lines = ["| k (c) | least depth for unstable equilibria near 5 deg (CL) |", "|---|---|"]
    lines += [f"| {k:.2f} | {d:.3f} |" if math.isfinite(d) else f"| {k:.2f} | none up to {MAX_DEPTH} |" for k, d in zip(ks, boundary)]
    lines += ["", ("| k (c) | depth (CL) | unstable equilibria sampled, model pitch (deg) | elevator (deg) | cycle without friction (deg, half peak-to-peak) | "
                   "frequency (Hz) | with the gimbal's friction (deg) |"), "|---|---|---|---|---|---|---|"]
    for k, depth, band, mid, amp, freq, amp_f in rows:
        lines.append(f"| {k} | {depth} | {band or 'no Hopf point'} | {mid:.3f} | {amp:.2f} | {freq:.2f} | {amp_f:.2f} |" if band
                     else f"| {k} | {depth} | none | - | - | - | - |")
    md.write_text("\n".join(lines) + "\n")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    kk = np.array(ks)
    dd = np.array(boundary)
    ax.plot(kk, dd, "k-o", label="stability boundary (continuation, no friction)")
    ax.fill_between(kk, np.where(np.isfinite(dd), dd, MAX_DEPTH), MAX_DEPTH, color="0.9", label="unstable band near 5 deg")
    for k, depth, band, _, _, _, amp_f in rows:
        if band:
            live = amp_f > 0.2
            ax.plot(k, depth, "s" if live else "x", color="tab:red" if live else "tab:blue", ms=8)
            ax.annotate(f"{amp_f:.1f} deg", (k, depth), textcoords="offset points", xytext=(6, 4), fontsize=8)
    ax.plot([], [], "s", color="tab:red", label="cycle survives the gimbal's friction (its amplitude)")
    ax.plot([], [], "x", color="tab:blue", label="friction stops it")
    ax.set_xlabel("centre-of-pressure travel with separation k (chords)")
    ax.set_ylabel(f"lift lost at {BREAK_DEG:g} deg (CL)")
    ax.set_ylim(0.0, MAX_DEPTH)
    ax.set_title(f"Fig. 8's lower limit cycle ({args.rig} rig): 1-DOF model pitch, 20 m/s, unsteady model")
    fig.legend(fontsize=8, loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0.0, 0.1, 1.0, 1.0))
    fig.savefig(png, dpi=120)
    print(f"wrote {png} and {md}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

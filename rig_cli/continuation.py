"""``rig continuation``: equilibrium branches, their stability, folds, Hopf points and limit cycles from the command line.

    rig continuation --free model_pitch --parameter hawk_elevator --values 2 -3 101 --aero-model unsteady
                     --set hawk_aero.sep_cp_travel=0.1 [--lift-break 6 0.05] [--params FILE.toml]
                     [--airspeed 20] [--control hawk_rudder=2] [--q-guess DEG x5] [--no-orbits] [--state model_pitch]
                     [--sweep NAME FIRST LAST POINTS] [--out DIR] [--overwrite]

Runs :func:`rig_env.continuation` and prints the special points (kind, parameter, the free joints in deg, the
Hopf frequency in Hz), the limit-cycle families (the Hopf point's criticality, parameter range, largest
amplitude in deg, period in s, stability, and each family's folds of cycles, period doublings and tori) and
the notes; writes ``DIR/branch.csv`` (the sampled branch: parameter, every state in deg or deg/s (the
aerodynamic states in their units), stable, the leading eigenvalue's real and imaginary parts in 1/s),
``DIR/special_points.csv``, ``DIR/orbits.csv`` (per family its orbits, kind "orbit", then its located
bifurcations, kind "cycle_fold", "period_doubling" or "torus", stable left empty) and ``DIR/bifurcation.png``
(the diagram of ``--state``).
With ``--sweep`` a second parameter is swept (:func:`rig_env.continuation_sweep`, no orbits): a line per value, then
``DIR/loci.csv`` (its special points and unstable sampled equilibria: sweep value, kind, parameter, the free joints
in deg, the Hopf frequency in Hz) and ``DIR/sweep.png`` (the two-parameter diagram).
An existing output is kept unless ``--overwrite``.  Bad values raise ValueError naming the option.
"""

from __future__ import annotations

import contextlib
import csv
import math
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from rig_env.paths import check_out_folder
from rig_env.bifurcation.result import Branch, OrbitBranch, SpecialPoint
from rig_env.bifurcation.rig import ORBIT_DT_RANGE, resolve_parameter
from rig_env.bifurcation.sweep import Sweep
from rig_env.compile_watch import compile_watch
from rig_env.params import PARAM_NAMES, SURFACES, ParameterError, RigParams
from rig_env.params_io import did_you_mean
from rig_env.physics.pipeline import check_aero_model
from rig_env.simulate import check_free_dofs

OUTPUTS = ("branch.csv", "special_points.csv", "orbits.csv", "bifurcation.png")
SWEEP_OUTPUTS = ("loci.csv", "sweep.png")
MAX_POINTS = 2001


def _assignments(items: Sequence[str] | None, option: str, names: Sequence[str]) -> dict[str, float]:
    """NAME=VALUE strings as a dict; ValueError naming ``option`` for a bad item or an unknown name."""
    out: dict[str, float] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise ValueError(f"{option} {item!r}: expected NAME=VALUE")
        if name not in names:
            raise ValueError(f"{option} {item!r}: unknown name {name!r}{did_you_mean(name, names)}; "
                             f"valid names: {', '.join(names) if len(names) < 20 else 'see rig_env.PARAM_NAMES'}")
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"{option} {item!r}: {text!r} is not a number") from None
        if not math.isfinite(value):
            raise ValueError(f"{option} {item!r}: the value must be finite")
        out[name] = value
    return out


@contextlib.contextmanager
def _q_guess_named() -> Iterator[None]:
    """rig_env.continuation's "no equilibrium near q_guess" errors in the command's words: its option is --q-guess (deg)."""
    try:
        yield
    except ValueError as exc:
        text = str(exc)
        if text.startswith("q_guess: "):
            raise ValueError("--q-guess" + text.removeprefix("q_guess").replace("a better q_guess", "a better --q-guess (deg)")) from None
        raise


def rig_of(params_file: str | None, sets: Sequence[str] | None, lift_break: Sequence[float] | None) -> RigParams:
    """The rig to continue: the parameter file (default: the default rig), ``--set`` overrides, then ``--lift-break``."""
    p = RigParams.from_toml(params_file) if params_file else RigParams.default()
    over = _assignments(sets, "--set", PARAM_NAMES)
    try:
        p = p.replace(**over) if over else p
    except ParameterError as exc:
        raise ValueError(f"--set: {exc}") from None
    if lift_break is not None:
        try:
            p = p.with_lift_break(float(lift_break[0]), float(lift_break[1]))
        except ParameterError as exc:
            raise ValueError(f"--lift-break: {exc}") from None
    return p


def _grid(option: str, values: Sequence[float]) -> tuple[float, float, int]:
    """(first, last, points) of ``option``'s three numbers; ValueError naming the option otherwise."""
    first, last, n = (float(v) for v in values)
    if not (math.isfinite(first) and math.isfinite(last)) or first == last:
        raise ValueError(f"{option} {first} {last}: two different finite ends are needed")
    if not math.isfinite(n) or n != int(n) or not 2 <= int(n) <= MAX_POINTS:
        raise ValueError(f"{option}: the number of points must be an integer from 2 to {MAX_POINTS}, not {n}")
    return first, last, int(n)


_CYCLE_NAMES = {"cycle_fold": "fold of the orbits", "period_doubling": "period doubling", "torus": "torus (Neimark-Sacker)"}


def _stability_words(ob: OrbitBranch) -> str:
    """'all stable', 'all unstable' or 'stable in part' over the orbits whose multipliers can be read, and how many cannot."""
    st = ob.stable[ob.reliable]
    words = "stability not read" if not st.size else ("all stable" if st.all() else ("all unstable" if not st.any() else "stable in part"))
    bad = int(np.sum(~ob.reliable))
    if bad:
        words += (f" ({bad} of {ob.values.size} orbits' multipliers not reliable, error up to {ob.multiplier_errors.max():.2g}: "
                  "the tables' kinks under fixed-step RK4; a smaller --physics-dt reduces it)")
    return words


def _point_cells(sp: SpecialPoint, cols: Sequence[int]) -> list[str]:
    """A special point's CSV cells: kind, parameter value, the states of ``cols`` (deg), the Hopf frequency (Hz)."""
    return [sp.kind, f"{sp.value:.10g}", *[f"{math.degrees(sp.state[k]):.10g}" for k in cols], f"{sp.frequency_hz:.6g}" if sp.kind == "hopf" else ""]


def write_loci(sw: Sweep, free: Sequence[str], path: Path) -> None:
    """The sweep's special points and unstable sampled equilibria as CSV: sweep value, kind ("fold", "hopf", ...,
    or "unstable" for a sampled equilibrium that is), parameter value, the free joints (deg), the Hopf frequency (Hz)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([f"{sw.sweep} ({sw.sweep_unit})", "kind", f"{sw.parameter} ({sw.parameter_unit})", *[f"{j} (deg)" for j in free],
                    "frequency (Hz)", "note"])
        for value, br, err in zip(sw.sweep_values, sw.branches, sw.errors):
            if br is None:
                w.writerow([f"{value:.10g}", "no branch", "", *[""] * len(free), "", err])
                continue
            cols = [br.state_names.index(j) for j in free]
            for sp in br.special_points:
                w.writerow([f"{value:.10g}", *_point_cells(sp, cols), ""])
            for v, x, st in zip(br.values, br.states, br.stable):
                if not st:
                    w.writerow([f"{value:.10g}", "unstable", f"{v:.10g}", *[f"{math.degrees(x[k]):.10g}" for k in cols], "", ""])


def run(
    out: str | Path,
    *,
    free: Sequence[str],
    parameter: str,
    values: Sequence[float],
    aero_model: str = "linear",
    airspeed: float | None = None,
    controls: Sequence[str] | None = None,
    sets: Sequence[str] | None = None,
    lift_break: Sequence[float] | None = None,
    params_file: str | None = None,
    orbits: bool = True,
    physics_dt: float = 1e-3,
    state: str | None = None,
    sweep: tuple[str, float, float, float] | None = None,
    q_guess_deg: Sequence[float] | None = None,
    overwrite: bool = False,
    echo: bool = True,
) -> Branch | Sweep:
    """``rig continuation``: see the module docstring.  values: (first, last, points); sweep: (name, first, last,
    points) of a second parameter; physics_dt: the orbits' RK4 step (s, :func:`rig_env.continuation`); q_guess_deg:
    the five joint angles (deg) of ``q_guess``; returns the Branch, or with ``sweep`` the Sweep."""
    import rig_env
    from rig_env.bifurcation.plot import display_unit, plot_branch, plot_sweep

    first, last, n = _grid("--values", values)
    if not (math.isfinite(physics_dt) and ORBIT_DT_RANGE[0] <= physics_dt <= ORBIT_DT_RANGE[1]):
        raise ValueError(f"--physics-dt {physics_dt}: the orbits' RK4 step must lie in [{ORBIT_DT_RANGE[0]:g}, {ORBIT_DT_RANGE[1]:g}] s")
    folder = check_out_folder("--out", out)
    if sweep is not None:
        s_first, s_last, s_n = _grid("--sweep", sweep[1:])
        outputs = SWEEP_OUTPUTS
    else:
        outputs = OUTPUTS
    existing = [name for name in outputs if (folder / name).exists()]
    if existing and not overwrite:
        raise ValueError(f"--out {folder}: {', '.join(existing)} already there; give --overwrite to replace, or another --out")
    p = rig_of(params_file, sets, lift_break)
    check_aero_model(aero_model, "--aero-model")
    try:
        check_free_dofs(free)
    except ValueError as exc:
        raise ValueError(f"--free: {str(exc).removeprefix('free_dofs: ')}") from None
    for option, name in (("--parameter", parameter), *((("--sweep", sweep[0]),) if sweep is not None else ())):
        try:  # a misspelt name is refused before anything runs, by the option's name
            resolve_parameter(p, name)
        except ValueError as exc:
            raise ValueError(f"{option} {str(exc).removeprefix('parameter = ')}") from None
    ctrl = _assignments(controls, "--control", SURFACES)
    q_guess = None
    if q_guess_deg is not None:
        if len(q_guess_deg) != 5 or not all(math.isfinite(a) and abs(a) <= 360.0 for a in q_guess_deg):
            raise ValueError(f"--q-guess {' '.join(f'{a:g}' for a in q_guess_deg)}: five joint angles, finite and within +-360 deg")
        q_guess = [math.radians(a) for a in q_guess_deg]
    if state is not None and state not in free:
        raise ValueError(f"--state {state!r}: must be one of the free joints {list(free)}")
    if sweep is not None:
        with compile_watch(sys.stdout if echo else None), _q_guess_named():
            sw = rig_env.continuation_sweep(p, sweep=sweep[0], sweep_values=np.linspace(s_first, s_last, s_n), free_dofs=tuple(free),
                                            parameter=parameter, values=np.linspace(first, last, n), airspeed=airspeed, controls=ctrl or None,
                                            aero_model=aero_model, periodic=False, progress=echo, q_guess=q_guess)
        folder.mkdir(parents=True, exist_ok=True)
        write_loci(sw, free, folder / "loci.csv")
        plot_sweep(sw, folder / "sweep.png", title=f"{', '.join(free)} free, {aero_model}")
        if echo:
            print(f"wrote {folder / 'loci.csv'}, {folder / 'sweep.png'}")
        return sw
    if echo:
        print(f"continuing {', '.join(free)} over {parameter} ({n} values, {aero_model} model"
              f"{'; then the orbits of each Hopf point by shooting, up to a minute' if orbits else ''}) ...", flush=True)
    with compile_watch(sys.stdout if echo else None), _q_guess_named():  # a fresh installation compiles the kernels first: say so
        br = rig_env.continuation(p, free_dofs=tuple(free), parameter=parameter, values=np.linspace(first, last, n), airspeed=airspeed,
                                  controls=ctrl or None, aero_model=aero_model, periodic=orbits, physics_dt=physics_dt, q_guess=q_guess)
    folder.mkdir(parents=True, exist_ok=True)
    factors = [display_unit(u) for u in br.state_units]
    with open(folder / "branch.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([f"{br.parameter} ({br.parameter_unit})", *[f"{s} ({u})" for s, (_, u) in zip(br.state_names, factors)],
                    "stable", "leading_real (1/s)", "leading_imag (1/s)"])
        for v, x, st, ev in zip(br.values, br.states, br.stable, br.eigenvalues):
            lead = ev[0] if ev.size else complex(math.nan)
            w.writerow([f"{v:.10g}", *[f"{xi * f:.10g}" for xi, (f, _) in zip(x, factors)], int(bool(st)), f"{lead.real:.6g}", f"{abs(lead.imag):.6g}"])
    joints = [(k, s) for k, s in enumerate(br.state_names) if s in free]
    with open(folder / "special_points.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["kind", f"{br.parameter} ({br.parameter_unit})", *[f"{s} (deg)" for _, s in joints], "frequency (Hz)"])
        for sp in br.special_points:
            w.writerow(_point_cells(sp, [k for k, _ in joints]))
    with open(folder / "orbits.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["family", f"{br.parameter} ({br.parameter_unit})", "period (s)", *[f"{s} amplitude (deg)" for _, s in joints], "stable",
                    "kind", "multiplier error"])
        for i, ob in enumerate(br.orbits):
            for j in range(ob.values.size):  # stable left empty where the multipliers cannot be read (OrbitBranch.reliable)
                w.writerow([i, f"{ob.values[j]:.10g}", f"{ob.periods[j]:.6g}", *[f"{math.degrees(ob.amplitudes[j, k]):.6g}" for k, _ in joints],
                            int(bool(ob.stable[j])) if ob.reliable[j] else "", "orbit", f"{ob.multiplier_errors[j]:.2g}"])
            for c in ob.special_points:  # the family's located bifurcations: marginal orbits, neither stable nor unstable
                w.writerow([i, f"{c.value:.10g}", f"{c.period:.6g}", *[f"{math.degrees(c.amplitudes[k]):.6g}" for k, _ in joints], "", c.kind, ""])
    title = f"{br.parameter}: {', '.join(free)} free, {aero_model}, {airspeed if airspeed is not None else 20.0:g} m/s"
    plot_branch(br, folder / "bifurcation.png", state=state, title=title)
    if echo:
        print(summary(br, free))
        print(f"wrote {', '.join(str(folder / f) for f in OUTPUTS)}")
    return br


def summary(br: Branch, free: Sequence[str]) -> str:
    """The special points, the orbit families and the notes as text (deg, Hz, s)."""
    joints = [(k, s) for k, s in enumerate(br.state_names) if s in free]
    lines = [f"{len(br.values)} equilibria sampled, {int(np.sum(br.stable))} stable; {br.parameter} in {br.parameter_unit}"]
    if br.special_points:
        lines.append(f"{'kind':<24} {br.parameter:>16} " + " ".join(f"{s + ' (deg)':>18}" for _, s in joints) + "   Hopf frequency (Hz)")
        for sp in br.special_points:
            lines.append(f"{sp.kind:<24} {sp.value:>16.5g} " + " ".join(f"{math.degrees(sp.state[k]):>18.3f}" for k, _ in joints)
                         + (f"   {sp.frequency_hz:.3f}" if sp.kind == "hopf" else ""))
    else:
        lines.append("no fold, Hopf or branch point in the range")
    for i, ob in enumerate(br.orbits):
        if not ob.values.size:
            lines.append(f"orbit family {i}: none computed ({ob.end})")
            continue
        amp = np.degrees(ob.amplitudes[:, [k for k, _ in joints]]).max(axis=0)
        lines.append(f"orbit family {i} from the {ob.criticality} Hopf point at {ob.hopf.value:.5g}: {br.parameter} {ob.values.min():.5g} to {ob.values.max():.5g}, "
                     f"largest amplitude " + ", ".join(f"{s} {a:.2f} deg" for (_, s), a in zip(joints, amp))
                     + f", period {ob.periods.min():.3f}-{ob.periods.max():.3f} s, "
                     + _stability_words(ob) + f"; ended: {ob.end}")
        for c in ob.special_points:
            lines.append(f"  {_CYCLE_NAMES[c.kind]} at {br.parameter} {c.value:.5g}: period {c.period:.3f} s, amplitude "
                         + ", ".join(f"{s} {math.degrees(c.amplitudes[k]):.2f} deg" for k, s in joints))
    lines += [f"note: {n}" for n in br.notes]
    return "\n".join(lines)

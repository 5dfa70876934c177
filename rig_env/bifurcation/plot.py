"""The bifurcation diagram of a :class:`~rig_env.bifurcation.result.Branch` (matplotlib, Agg canvas: no display needed).

A branch (:func:`plot_branch`): one state against the parameter: stable equilibria solid, unstable dashed, folds as triangles, Hopf
points as circles, branch points as diamonds, and each Hopf point's periodic orbits as the envelope of
the state's minimum and maximum over the orbit (stable orbits filled dots, unstable open, grey crosses where
the multipliers cannot be read: ``OrbitBranch.reliable``; the family's folds of cycles, period doublings and
tori marked on both envelopes).  Angles and
rates are drawn in deg and deg/s.  A sweep (:func:`plot_sweep`): the loci of the special points and the unstable
sampled equilibria in the plane of the two parameters.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from rig_env.bifurcation.result import Branch
from rig_env.bifurcation.sweep import Sweep

_MARKERS = {"fold": ("v", "tab:red", "fold"), "hopf": ("o", "tab:purple", "Hopf"), "branch_point": ("D", "tab:brown", "branch point")}
_CYCLE_MARKERS = {"cycle_fold": ("^", "tab:orange", "fold of orbits"), "period_doubling": ("s", "tab:olive", "period doubling"),
                  "torus": ("P", "tab:cyan", "torus (Neimark-Sacker)")}


def display_unit(unit: str) -> tuple[float, str]:
    """Factor and unit in which a state of ``unit`` is shown (rad -> deg, rad/s -> deg/s; others unchanged)."""
    return {"rad": (180.0 / math.pi, "deg"), "rad/s": (180.0 / math.pi, "deg/s")}.get(unit, (1.0, unit))


def _runs(mask: np.ndarray) -> list[slice]:
    """Slices of equal consecutive values of mask, each extended by one point to join the next."""
    cuts = np.flatnonzero(mask[1:] != mask[:-1]) + 1
    bounds = [0, *cuts.tolist(), mask.size]
    return [slice(a, min(b + 1, mask.size)) for a, b in zip(bounds, bounds[1:])]


def plot_branch(branch: Branch, path: str | Path | None = None, *, state: str | None = None, title: str = "") -> Figure:
    """Draw ``state`` (a name of ``branch.state_names``; default the first) against the parameter; write a
    PNG to ``path`` (None: only return the figure)."""
    name = branch.state_names[0] if state is None else state
    if name not in branch.state_names:
        raise ValueError(f"state = {name!r}: not a state of this branch; states: {list(branch.state_names)}")
    k = branch.state_names.index(name)
    factor, unit = display_unit(branch.state_units[k])
    fig = Figure(figsize=(7.5, 4.8))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    x, y = branch.curve_values, branch.curve_states[:, k] * factor if branch.curve_states.size else np.zeros(0)
    for sl in _runs(branch.curve_stable) if x.size else ():
        stable = bool(branch.curve_stable[sl.start])
        ax.plot(x[sl], y[sl], "-" if stable else "--", color="tab:blue", lw=1.6 if stable else 1.2)
    ax.plot([], [], "-", color="tab:blue", label="stable equilibria")
    ax.plot([], [], "--", color="tab:blue", label="unstable equilibria")
    for kind, (marker, colour, label) in _MARKERS.items():
        pts = [sp for sp in branch.special_points if sp.kind == kind]
        if pts:
            ax.plot([sp.value for sp in pts], [sp.state[k] * factor for sp in pts], marker, color=colour, ms=8, ls="none", label=label)
    labelled: set[str] = set()
    for ob in branch.orbits:
        if not ob.values.size:
            continue
        kinds = (("stable orbits (min, max)", ob.stable & ob.reliable, {"mfc": "tab:green"}),
                 ("unstable orbits (min, max)", ~ob.stable & ob.reliable, {"mfc": "none"}),
                 ("orbits, stability not read (min, max)", ~ob.reliable, {"marker": "x", "color": "0.45"}))
        for env in (ob.lower[:, k], ob.upper[:, k]):
            ax.plot(ob.values, env * factor, "-", color="tab:green", lw=0.8, alpha=0.7)
            for label, mask, style in kinds:
                if mask.any():
                    ax.plot(ob.values[mask], env[mask] * factor, ls="none", ms=3.5, **{"marker": "o", "color": "tab:green", **style},
                            label=None if label in labelled else label)
                    labelled.add(label)
    for kind, (marker, colour, label) in _CYCLE_MARKERS.items():
        pts = [c for ob in branch.orbits for c in ob.points(kind)]
        if pts:
            ax.plot([c.value for c in pts] * 2, [c.lower[k] * factor for c in pts] + [c.upper[k] * factor for c in pts], marker,
                    color=colour, ms=7, ls="none", label=label)
    ax.set_xlabel(f"{branch.parameter} ({branch.parameter_unit})" if branch.parameter_unit else branch.parameter)
    ax.set_ylabel(f"{name} ({unit})" if unit else name)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def plot_sweep(result: Sweep, path: str | Path | None = None, *, title: str = "") -> Figure:
    """The two-parameter diagram: the continuation's parameter across, the swept one up; the unstable sampled
    equilibria shaded, the fold, Hopf and branch points marked.  Writes a PNG to ``path`` (None: only returns
    the figure)."""
    fig = Figure(figsize=(7.0, 4.8))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    un = result.unstable()
    if un.size:
        ax.plot(un[:, 1], un[:, 0], "s", color="0.8", ms=4, ls="none", label="unstable equilibria (sampled)")
    for kind, (marker, colour, label) in _MARKERS.items():
        loc = result.locus(kind)
        if loc.size:
            ax.plot(loc[:, 1], loc[:, 0], marker, color=colour, ms=6, ls="none", label=f"{label} points")
    missing = [float(s) for s, b in zip(result.sweep_values, result.branches) if b is None]
    if missing:
        ax.plot([], [], " ", label=f"no branch at {len(missing)} sweep value(s)")
    ax.set_xlabel(f"{result.parameter} ({result.parameter_unit})")
    ax.set_ylabel(f"{result.sweep} ({result.sweep_unit})")
    lo, hi = float(result.sweep_values.min()), float(result.sweep_values.max())
    pad = 0.05 * (hi - lo) if hi > lo else 0.5 * max(abs(lo), 1.0)
    ax.set_ylim(lo - pad, hi + pad)
    ax.grid(True, alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no special point and no unstable equilibrium", transform=ax.transAxes, ha="center")
    ax.set_title(title or f"{result.parameter} against {result.sweep}")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig

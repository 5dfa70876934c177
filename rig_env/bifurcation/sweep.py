"""Two-parameter bifurcation diagrams by sweeping: :func:`continuation_sweep`.

The loci of the fold and Hopf points in the plane of two parameters (the continuation's own and a second
one, the sweep) tell over which range of the second a bifurcation of the first exists: where a limit cycle
appears, where a static jump opens.  They are traced here by continuing the equilibria over the first
parameter (:func:`rig_env.continuation`) at each sampled value of the second, so every point of a locus is
a located special point of a branch (to the continuation's tolerance), the loci need no second derivatives
and pass the tables' kinks (where a Hopf-point locus of the augmented system would lose its smoothness);
between the samples a locus is not resolved.  The sampled equilibria's stability comes with them, so the
unstable region is drawn even where its edge is a kink rather than a Hopf point
(:func:`rig_env.bifurcation.plot.plot_sweep`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rig_env.bifurcation.result import Branch
from rig_env.params import ParameterError, RigParams


@dataclass(frozen=True)
class Sweep:
    """Equilibrium branches over ``parameter``, one per value of the swept parameter ``sweep``.

    sweep_values: (k,) the second parameter (``sweep_unit``); branches: (k,) the :class:`Branch` at each
    (None where the continuation found no branch: ``errors`` says why, "" elsewhere); parameter,
    parameter_unit: the continuation's parameter.
    """

    sweep: str
    sweep_unit: str
    sweep_values: np.ndarray
    parameter: str
    parameter_unit: str
    branches: tuple[Branch | None, ...]
    errors: tuple[str, ...]

    def locus(self, kind: str) -> np.ndarray:
        """(m, 2) rows (sweep value, parameter value) of the special points of ``kind`` ("fold", "hopf",
        "branch_point" or an event's name), sweep value by sweep value, each branch's in its curve's order."""
        rows = [(float(s), sp.value) for s, br in zip(self.sweep_values, self.branches) if br is not None for sp in br.points(kind)]
        return np.array(rows, dtype=np.float64).reshape(-1, 2)

    def unstable(self) -> np.ndarray:
        """(m, 2) rows (sweep value, parameter value) of every sampled equilibrium that is unstable."""
        rows = [(float(s), float(v)) for s, br in zip(self.sweep_values, self.branches) if br is not None
                for v, st in zip(br.values, br.stable) if not st]
        return np.array(rows, dtype=np.float64).reshape(-1, 2)


def continuation_sweep(
    params: RigParams,
    *,
    sweep: str,
    sweep_values: Sequence[float] | np.ndarray,
    parameter: str,
    values: Sequence[float] | np.ndarray,
    progress: bool = False,
    **options: Any,
) -> Sweep:
    """:func:`rig_env.continuation` over ``parameter`` (``values``) at each of ``sweep_values`` of ``sweep``.

    sweep: a surface of :data:`rig_env.SURFACES` (deg, held; not in ``controls``), ``"airspeed"`` (m/s; then no
    ``airspeed`` option) or a dotted name of :data:`rig_env.PARAM_NAMES` (its file unit), other than
    ``parameter``; options: the rest of :func:`rig_env.continuation`'s keywords (``free_dofs`` required;
    ``periodic`` defaults to False here: the orbits of every branch are seldom wanted); progress: a line per
    sweep value on stdout (value, special points, seconds).

    A sweep value at which no equilibrium is found near ``q_guess`` leaves a None branch and its reason in
    ``errors``; bad input (names, ranges) raises ValueError naming the field before any branch is traced.
    """
    from rig_env.bifurcation.rig import continuation, resolve_parameter

    sv = np.asarray(sweep_values, dtype=np.float64)
    if sv.ndim != 1 or sv.size < 1 or not np.all(np.isfinite(sv)):
        raise ValueError("sweep_values: expected a 1-D sequence of finite numbers")
    if sweep == parameter:
        raise ValueError(f"sweep = {sweep!r}: the swept parameter must differ from the continuation's parameter")
    par = resolve_parameter(params, sweep)
    options = {"periodic": False, **options}
    controls = dict(options.pop("controls", None) or {})

    def at(value: float) -> tuple[RigParams, dict[str, Any]]:
        opts = dict(options)
        if par.kind == "surface":
            opts["controls"] = {**controls, sweep: value}
        else:
            opts["controls"] = controls or None
        if par.kind == "airspeed":
            opts["airspeed"] = value
        if par.kind == "param":
            try:
                return params.replace(**{sweep: value}), opts
            except ParameterError as exc:
                raise ValueError(f"sweep_values: {exc}") from None
        return params, opts

    if par.kind == "surface" and sweep in controls:
        raise ValueError(f"controls: {sweep!r} is the swept parameter; leave it out of controls")
    if par.kind == "airspeed":
        if options.get("airspeed") is not None:
            raise ValueError("airspeed: the airspeed is the swept parameter (sweep_values); leave airspeed=None")
        if sv.min() < 0.0 or sv.max() > 60.0:
            raise ValueError(f"sweep_values: airspeed {sv.min():g}..{sv.max():g} m/s is outside the allowed range [0, 60] m/s")
    for end in (sv.min(), sv.max()):
        at(float(end))  # a value outside the parameter's range: ValueError before any work
    branches: list[Branch | None] = []
    errors: list[str] = []
    unit = par.unit
    for k, value in enumerate(sv):
        p, opts = at(float(value))
        t0 = time.perf_counter()
        try:
            br = continuation(p, parameter=parameter, values=values, **opts)
        except ValueError as exc:
            if k == 0 and not str(exc).startswith("q_guess: no equilibrium"):
                raise  # bad input, said once
            branches.append(None)
            errors.append(str(exc))
        else:
            branches.append(br)
            errors.append("")
        if progress:
            br = branches[-1]
            found = "no branch: " + errors[-1] if br is None else (
                ", ".join(f"{sum(1 for sp in br.special_points if sp.kind == kind)} {kind}" for kind in ("fold", "hopf")))
            print(f"sweep {k + 1}/{sv.size}: {sweep} = {value:g} {unit}: {found} ({time.perf_counter() - t0:.1f} s)", flush=True)
    first = next((b for b in branches if b is not None), None)
    punit = first.parameter_unit if first is not None else resolve_parameter(params, parameter).unit
    return Sweep(sweep, unit, sv, parameter, punit, tuple(branches), tuple(errors))


__all__ = ["Sweep", "continuation_sweep"]

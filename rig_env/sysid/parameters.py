"""The parameters an identification estimates: names, kernel columns, units, bounds and perturbation steps.

Names are the dotted names of :data:`rig_env.PARAM_NAMES`, values in the parameter file's units (degrees
where the name ends in ``_deg`` or ``_deg_s``); the kernels read SI and radians, so this module converts.
Bounds are each field's allowed range (:class:`rig_env.RigParams` metadata) intersected with the caller's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from rig_env.params import PARAM_INDEX, ParameterError, RigParams, _iter_leaves
from rig_env.sysid.checks import is_number


def _ranges(params: RigParams) -> dict[str, tuple[float, float, str]]:
    return {name: (float(lo), float(hi), unit) for name, _, (lo, hi), unit in _iter_leaves(params)}


@dataclass(frozen=True)
class ParameterSet:
    """The k estimated model parameters.

    names: (k,) dotted names; columns: (k,) kernel parameter columns; scale: (k,) factor from file units to
    kernel units (pi/180 for degree names, else 1); lower, upper: (k,) bounds (file units); start: (k,)
    start values (file units); units: (k,) unit strings.
    """

    names: tuple[str, ...]
    columns: np.ndarray
    scale: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    start: np.ndarray
    units: tuple[str, ...]

    @classmethod
    def build(
        cls,
        params: RigParams,
        estimate: Sequence[str],
        bounds: Mapping[str, tuple[float, float]] | None = None,
        start: Mapping[str, float] | None = None,
    ) -> "ParameterSet":
        """The set of ``estimate`` (dotted names) with the allowed range of each, narrowed by ``bounds``
        ({name: (low, high)}), starting at ``start`` ({name: value}) or the value in ``params``."""
        if isinstance(estimate, str):
            estimate = (estimate,)
        if not isinstance(estimate, (Sequence, np.ndarray)) or not all(isinstance(n, str) for n in estimate):
            raise ParameterError(f"estimate = {estimate!r}: give a list of dotted parameter names (rig_env.PARAM_NAMES)")
        names = tuple(estimate)
        if not names:
            raise ParameterError("estimate: name at least one parameter to estimate (dotted names of rig_env.PARAM_NAMES)")
        unknown = [n for n in names if n not in PARAM_INDEX]
        if unknown:
            raise ParameterError(f"estimate: unknown parameter(s) {unknown}; valid names: rig_env.PARAM_NAMES")
        if len(set(names)) != len(names):
            raise ParameterError(f"estimate: duplicate names in {list(names)}")
        rng = _ranges(params)
        vector = params.to_vector()
        for label, d in (("bounds", bounds), ("start", start)):
            if d is not None and not isinstance(d, Mapping):
                raise ParameterError(f"{label} = {d!r}: give a mapping {{name: {'(low, high)' if label == 'bounds' else 'value'}}} or None")
        bounds = dict(bounds or {})
        start = dict(start or {})
        for label, d in (("bounds", bounds), ("start", start)):
            extra = [n for n in d if n not in names]
            if extra:
                raise ParameterError(f"{label}: {extra} are not among the estimated parameters {list(names)}")
        lo = np.empty(len(names))
        hi = np.empty(len(names))
        x0 = np.empty(len(names))
        scale = np.array([math.pi / 180.0 if n.endswith(("_deg", "_deg_s")) else 1.0 for n in names])
        units = []
        for i, n in enumerate(names):
            a, b, unit = rng[n]
            units.append(unit)
            if n in bounds:
                pair = bounds[n]
                if not (isinstance(pair, (Sequence, np.ndarray)) and len(pair) == 2 and all(is_number(v) for v in pair)):
                    raise ParameterError(f"bounds[{n!r}] must be a pair (low, high) of numbers, got {pair!r}")
                ua, ub = float(pair[0]), float(pair[1])
                if not (math.isfinite(ua) and math.isfinite(ub) and ua < ub):
                    raise ParameterError(f"bounds[{n!r}] = ({ua}, {ub}): need finite low < high")
                if ub < a or ua > b:
                    raise ParameterError(f"bounds[{n!r}] = ({ua}, {ub}) lies outside the allowed range [{a}, {b}] {unit}")
                a, b = max(a, ua), min(b, ub)
            lo[i], hi[i] = a, b
            if n in start and not is_number(start[n]):
                raise ParameterError(f"start[{n!r}] = {start[n]!r}: must be a number in [{a}, {b}] {unit}")
            v = float(start[n]) if n in start else float(vector[PARAM_INDEX[n]]) / scale[i]
            if not (math.isfinite(v) and a <= v <= b):
                raise ParameterError(f"start value of {n} = {v} {unit} is outside its bounds [{a}, {b}] {unit}")
            x0[i] = v
        cols = np.array([PARAM_INDEX[n] for n in names], dtype=np.int64)
        return cls(names, cols, scale, lo, hi, x0, tuple(units))

    @property
    def k(self) -> int:
        return len(self.names)

    def steps(self, theta: np.ndarray) -> np.ndarray:
        """(k,) central-difference steps, file units: 1e-3 of max(|theta|, a floor of 1e-3 of the range, at most 1)."""
        floor = np.minimum(1e-3 * (self.upper - self.lower), 1.0)
        return 1e-3 * np.maximum(np.abs(theta), floor)

    def clip(self, theta: np.ndarray) -> np.ndarray:
        return np.clip(theta, self.lower, self.upper)

    def rows(self, base: np.ndarray, thetas: np.ndarray) -> np.ndarray:
        """(m, N_PARAMS) kernel rows: ``base`` (N_PARAMS,) with the estimated columns set from thetas (m, k)."""
        out = np.repeat(base[None, :], thetas.shape[0], axis=0)
        out[:, self.columns] = thetas * self.scale
        return out

    def apply(self, params: RigParams, theta: np.ndarray) -> RigParams:
        """``params`` with the estimates (validated: ParameterError if the set breaks a cross-field rule)."""
        return params.replace(**{n: float(v) for n, v in zip(self.names, theta)})

"""What a continuation returns: an equilibrium branch, its special points and the periodic orbits born at them.

Plain frozen dataclasses of numpy arrays (no solver state), shared by the generic core
(:mod:`rig_env.bifurcation.core`, :mod:`rig_env.bifurcation.periodic`) and the rig's continuation
(:mod:`rig_env.bifurcation.rig`); drawn by :func:`rig_env.bifurcation.plot.plot_branch`.  Arrays lead with the point axis; states are columns named by
``state_names`` (units ``state_units``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class SpecialPoint:
    """A located bifurcation of an equilibrium branch.

    kind: ``"fold"`` (a real eigenvalue through zero at a turning point of the branch), ``"hopf"``
    (a complex pair through the imaginary axis), ``"branch_point"`` (a real eigenvalue through zero
    where the branch does not turn: another branch crosses it) or the name of a user event (the rig's
    ``"stop:<joint>:lower"`` / ``"stop:<joint>:upper"``: a free joint reaching a gimbal stop).  value: the parameter; state: (n,)
    the equilibrium; eigenvalues: (n,) there; omega: the crossing pair's imaginary part (rad/s; Hopf
    only, else 0); eigenvector: (n,) complex, the crossing eigenvalue's (normalised, largest entry
    real); arclength: its position along the traced curve (scaled units of the continuation).
    """

    kind: str
    value: float
    state: np.ndarray
    eigenvalues: np.ndarray
    omega: float = 0.0
    eigenvector: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    arclength: float = 0.0

    @property
    def frequency_hz(self) -> float:
        """The Hopf frequency, Hz (omega / 2 pi)."""
        return self.omega / (2.0 * np.pi)

    @property
    def period(self) -> float:
        """The period of the orbits born at a Hopf point, s (2 pi / omega; inf otherwise)."""
        return 2.0 * np.pi / self.omega if self.omega > 0 else np.inf


READ_MARGIN = 3.0
"""An orbit's multipliers are read (:func:`readable`) when they stand more than READ_MARGIN times the monodromy
matrix's error off the unit circle (``periodic.trivial_defect``)."""


def readable(multipliers: np.ndarray, error: float) -> bool:
    """Whether an orbit's stability can be read from its Floquet ``multipliers`` given the monodromy matrix's
    ``error``: every multiplier but the trivial one (the one nearest 1, exactly 1 for an exact matrix) more than
    READ_MARGIN times the error from the unit circle, the error taken as the larger of ``error`` and the trivial
    multiplier's distance from 1 (a multiplier nearer than that could lie on either side)."""
    mu = np.asarray(multipliers)
    if not (mu.size and np.all(np.isfinite(mu)) and math.isfinite(error)):
        return False
    k = int(np.argmin(np.abs(mu - 1.0)))
    scale = max(float(error), float(abs(mu[k] - 1.0)))
    return bool(np.all(np.abs(np.abs(np.delete(mu, k)) - 1.0) > READ_MARGIN * scale))


CYCLE_KINDS = ("cycle_fold", "period_doubling", "torus")
"""The bifurcations of a periodic-orbit family (:class:`CyclePoint`)."""


@dataclass(frozen=True)
class CyclePoint:
    """A located bifurcation of a periodic-orbit family.

    kind: ``"cycle_fold"`` (a turning point of the family in the parameter: a Floquet multiplier through +1,
    where a stable and an unstable orbit meet; past it the family runs back), ``"period_doubling"`` (a real
    multiplier through -1: orbits of twice the period branch off) or ``"torus"`` (a complex pair through the
    unit circle, Neimark-Sacker: quasi-periodic motion on a torus branches off).  value: the parameter;
    period: s; state: (n,) the orbit's point on the phase section; lower, upper: (n,) each state's minimum
    and maximum over the orbit; multipliers: (n,) its Floquet multipliers (sorted by decreasing modulus,
    the trivial one included); arclength: its position along the traced family (scaled units).
    """

    kind: str
    value: float
    period: float
    state: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    multipliers: np.ndarray
    arclength: float = 0.0

    @property
    def amplitudes(self) -> np.ndarray:
        """(n,) half the peak-to-peak excursion of every state over the orbit."""
        return 0.5 * (self.upper - self.lower)


@dataclass(frozen=True)
class OrbitBranch:
    """Periodic orbits continued in the parameter from one Hopf point, one row per computed orbit.

    values: (k,) parameter; periods: (k,) s; initial_states: (k, n) a point of each orbit (on the
    phase section); lower, upper: (k, n) each state's minimum and maximum over the orbit;
    multipliers: (k, n) complex Floquet multipliers (the trivial one, 1, included); stable: (k,)
    every non-trivial multiplier inside the unit circle; hopf: the Hopf point the branch starts at;
    end: why the continuation stopped (the parameter range or the largest period left, the orbits' limit,
    the curve solver's failure, or "shrank back to an equilibrium (another Hopf point)": a family that grows
    and shrinks to nothing again joins two Hopf points, and the orbits past the second are not kept).

    special_points: the family's own bifurcations between its computed orbits (:class:`CyclePoint`: folds
    of cycles, period doublings, tori), located on the arclength, in the order of the family.
    criticality: the Hopf point's (``periodic.criticality``, from the side of it the first orbit lies on):
    ``"supercritical"`` (the side where the equilibrium is unstable: the orbits are born attracting and grow
    smoothly out of the equilibrium as it loses stability), ``"subcritical"`` (the side where it is still
    stable: born repelling, so that the loss of stability is a jump, typically onto a large orbit past a
    fold of cycles, with hysteresis), or ``"undetermined"`` (the crossing pair's real part there too small
    to tell); "" when no orbit was computed.

    multiplier_errors: (k,) each orbit's trivial-multiplier defect |M g - g| / |g| (g the flow's direction at
    its point, M the finite-difference monodromy matrix), the multipliers' accuracy; ``reliable`` where the
    multipliers stand clear of the unit circle by more than that (:func:`readable`).  Orbits through the tables'
    kinks integrated by fixed-step RK4 have a flow map that is not smooth on the finite differences' scale
    (errors of 1e-3 to 1e-2 at the default 1 ms step, in proportion to the step): where a multiplier lies
    within that of the circle, ``stable`` is a guess, and no period doubling or torus is located next to it.
    """

    values: np.ndarray
    periods: np.ndarray
    initial_states: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    multipliers: np.ndarray
    stable: np.ndarray
    hopf: SpecialPoint
    end: str
    special_points: tuple[CyclePoint, ...] = ()
    criticality: str = ""
    multiplier_errors: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def reliable(self) -> np.ndarray:
        """(k,) the orbits whose stability can be read from their multipliers (:func:`readable`)."""
        return np.array([readable(mu, e) for mu, e in zip(self.multipliers, self.multiplier_errors)], dtype=bool)

    @property
    def amplitudes(self) -> np.ndarray:
        """(k, n) half the peak-to-peak excursion of every state over each orbit."""
        return 0.5 * (self.upper - self.lower)

    def points(self, kind: str) -> tuple[CyclePoint, ...]:
        """The family's bifurcations of one kind (one of :data:`CYCLE_KINDS`), in the order of the family."""
        if kind not in CYCLE_KINDS:
            raise ValueError(f"kind = {kind!r}: the bifurcations of an orbit family are {list(CYCLE_KINDS)}")
        return tuple(c for c in self.special_points if c.kind == kind)

    @property
    def folds(self) -> np.ndarray:
        """Parameter values of the folds of cycles (turning points of the family), in the order of the family."""
        return np.array([c.value for c in self.points("cycle_fold")], dtype=np.float64)


@dataclass(frozen=True)
class Branch:
    """An equilibrium branch over a parameter, with stability, bifurcations and periodic orbits.

    The sampled branch (what ``values`` asks for): ``values`` (m,) the parameter at every point where the
    traced curve crosses a requested value, in the order of the curve (on a branch without folds,
    exactly the requested values); ``states`` (m, n) the equilibria, columns ``state_names`` in
    ``state_units``; ``stable`` (m,) every eigenvalue's real part below zero; ``eigenvalues`` (m, n)
    of the full Jacobian, sorted by decreasing real part.

    ``curve_values``, ``curve_states``, ``curve_stable``: the continuation's own points (pseudo-arclength
    steps and the located special points), for plotting.  ``hopf``, ``folds``, ``branch_points``: the
    parameter values of the located bifurcations; ``special_points``: all of them with their states,
    eigenvalues and (Hopf) frequencies.  ``orbits``: one :class:`OrbitBranch` per Hopf point (empty when
    not asked for).  ``notes``: what the continuation met on the way (a stop reached, a step that failed,
    the end of the range).  ``settings``: the model options it ran with.  ``at_stop`` (m,): the rig's
sampled points where a free joint lies past a gimbal stop (empty for a generic vector field).
    """

    parameter: str
    parameter_unit: str
    values: np.ndarray
    states: np.ndarray
    stable: np.ndarray
    eigenvalues: np.ndarray
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    curve_values: np.ndarray
    curve_states: np.ndarray
    curve_stable: np.ndarray
    special_points: tuple[SpecialPoint, ...]
    orbits: tuple[OrbitBranch, ...] = ()
    notes: tuple[str, ...] = ()
    settings: dict[str, object] = field(default_factory=dict)
    at_stop: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def _of(self, kind: str) -> np.ndarray:
        return np.array([s.value for s in self.special_points if s.kind == kind], dtype=np.float64)

    @property
    def hopf(self) -> np.ndarray:
        """Parameter values of the Hopf points, in the order of the curve."""
        return self._of("hopf")

    @property
    def folds(self) -> np.ndarray:
        """Parameter values of the fold (turning) points, in the order of the curve."""
        return self._of("fold")

    @property
    def branch_points(self) -> np.ndarray:
        """Parameter values where a real eigenvalue crosses zero without the branch turning."""
        return self._of("branch_point")

    def points(self, kind: str) -> tuple[SpecialPoint, ...]:
        """The special points of one kind ("fold", "hopf", "branch_point" or an event's name), in the order of the curve."""
        return tuple(s for s in self.special_points if s.kind == kind)

    def hopf_points(self) -> tuple[SpecialPoint, ...]:
        """The Hopf points with their states, eigenvalues and frequencies."""
        return tuple(s for s in self.special_points if s.kind == "hopf")

    def column(self, name: str) -> np.ndarray:
        """The sampled states' column ``name`` (one of ``state_names``), in its ``state_units``."""
        if name not in self.state_names:
            raise KeyError(f"{name!r}: not a state of this branch; states: {list(self.state_names)}")
        return self.states[:, self.state_names.index(name)]

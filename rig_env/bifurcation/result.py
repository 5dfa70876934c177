"""What a continuation returns: an equilibrium branch, its special points and the periodic orbits born at them.

Plain frozen dataclasses of numpy arrays (no solver state), shared by the generic core
(:mod:`rig_env.bifurcation.core`, :mod:`rig_env.bifurcation.periodic`) and the rig's continuation
(:mod:`rig_env.bifurcation.rig`); drawn by :func:`rig_env.bifurcation.plot.plot_branch`.  Arrays lead with the point axis; states are columns named by
``state_names`` (units ``state_units``).
"""

from __future__ import annotations

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

    @property
    def amplitudes(self) -> np.ndarray:
        """(k, n) half the peak-to-peak excursion of every state over each orbit."""
        return 0.5 * (self.upper - self.lower)


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

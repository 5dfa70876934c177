"""Trim and linearisation of the joint-space model, through the same numba kernels that simulate it.

``trim`` finds joint angles at which the free joints are in equilibrium (zero rates, zero
accelerations) for given surface deflections and airspeed, or, with some free joints held at
targets, the angles of the others and the inputs (surfaces, or named mixes of surfaces:
:class:`InputMix`) that hold them there.  ``linearize`` differentiates the
accelerations by central differences about an operating point and returns a python-control
``StateSpace`` with named states ``<joint>`` (rad) and ``<joint>_rate`` (rad/s) and named inputs
(surface deflections in rad, servos taken as ideal: flap = mixed command).  Friction is left out of
the linear model by default: the LuGre law is not differentiable at rest; ``friction="viscous"``
keeps its viscous term sigma2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import control
import numpy as np
from numba import njit
from scipy.optimize import least_squares

from rig_env.params import JOINTS, SURFACES, RigParams
from rig_env.physics import layout as L
from rig_env.physics import servo as sv
from rig_env.physics.integrator import limited_demands
from rig_env.physics.aero import MIN_AIRSPEED
from rig_env.physics.joint_space import ATTACHED, accelerations, separation_rates, separation_steady
from rig_env.physics.pipeline import AERO_MODELS, check_aero_model
from rig_env.simulate import check_free_dofs, check_static_controls

COMP_INPUTS = ("comp_aileron", "comp_elevator", "comp_rudder")
GUST_INPUTS: dict[str, tuple[int, ...]] = {
    **{f"gust_{a}": (L.U_GUST + k, L.U_GUST_COMP + k) for k, a in enumerate("xyz")},
    **{f"hawk_gust_{a}": (L.U_GUST + k,) for k, a in enumerate("xyz")},
    **{f"comp_gust_{a}": (L.U_GUST_COMP + k,) for k, a in enumerate("xyz")},
}
""":func:`linearize`'s gust inputs (m/s, world axes: x upstream, z down) and the input entries each moves:
``gust_*`` the same gust at the Hawk and the compensator (a uniform gust; the convection delay between them,
:mod:`rig_env.turbulence`, is left to the caller: a linear model of finite order holds no pure delay),
``hawk_gust_*`` and ``comp_gust_*`` each body's alone."""


@njit(cache=True, error_model="numpy")
def joint_accelerations(q, qd, u, p, flags, free_idx, tabs, xs=ATTACHED):
    """qdd (5,) for ideal servos (flaps = limited mixed demands of u), bristle states zero; xs: the
    aerodynamic states (7-tuple: flow separation of the Hawk and flaps 1-4's panels, the wake's sidewash and
    downwash at the compensator; flags' F_UNSTEADY only)."""
    flaps = np.empty(7)
    for k in range(7):
        flaps[k] = sv.limited(p, k, sv.demand(u, k))
    z = np.zeros(5)
    M = np.empty((5, 5))
    h = np.empty(5)
    Q = np.empty(5)
    jv = np.empty(45)
    qdd = np.empty(5)
    accelerations(q, qd, z, xs, flaps, u, p, flags, free_idx, free_idx.shape[0], tabs, M, h, Q, jv, qdd)
    return qdd


SEPARATION_STATES = ("hawk_separation", "flap1_separation", "flap2_separation", "flap3_separation", "flap4_separation",
                     "wake_sidewash", "wake_downwash")
"""Names of the unsteady model's aerodynamic states (layout.X_SEP order: the flow separation of the Hawk and the
compensator's panels, 1 attached, 0 separated; the Hawk's wake at the compensator, world y and z, m/s)."""


def hawk_surfaces(u: np.ndarray, p: np.ndarray) -> tuple[float, float, float]:
    """The Hawk's elevator, aileron and rudder (rad) of inputs u as ideal servos hold them: their limited demands."""
    d = limited_demands(u, p)  # the seven actuators' (rig_env.SERVOS order): the Hawk's are the last three
    return float(d[4]), float(d[5]), float(d[6])


@dataclass(frozen=True)
class OperatingPoint:
    """An equilibrium: joint angles and rates (rad, rad/s, all five joints), inputs, residual.

    ``controls_deg``: surface deflections, deg (the given ones and those of the mixed inputs);
    ``inputs``: the value of every input of the trim's :class:`InputMix` (given and solved), in its
    ``unit_deg`` units (empty without a mix).  ``aero_model``: the aerodynamic model it is an equilibrium
    of (:data:`rig_env.physics.pipeline.AERO_MODELS`); ``separation``: the flow-separation states there
    (the Hawk, flaps 1-4's panels), x0 at each one's angle of attack (the "unsteady" model's internal
    states, :data:`SEPARATION_STATES`; empty for the others).
    """

    q: np.ndarray
    qd: np.ndarray
    controls_deg: dict[str, float]
    airspeed: float
    free_dofs: tuple[str, ...]
    residual: float  # max |qdd| of the free joints at the solution, rad/s^2
    inputs: dict[str, float] = field(default_factory=dict)
    aero_model: str = "linear"
    separation: tuple[float, ...] = ()


@dataclass(frozen=True)
class InputMix:
    """Named inputs that each move several surfaces: ``surface_k (rad) = radians(unit_deg) * (weights[k] @ v)``.

    ``names``: the inputs, the order of ``v``; ``surfaces``: the surfaces they drive (names of
    :data:`~rig_env.params.SURFACES`); ``weights``: (len(surfaces), len(names)), surface deflection per
    input, in units of ``unit_deg`` (deg) per unit input.  E.g. a compensator rolled with the rig by
    phi: heave moves its elevator by cos(phi) and its rudder by -sin(phi).
    """

    names: tuple[str, ...]
    surfaces: tuple[str, ...]
    weights: np.ndarray
    unit_deg: float = 1.0

    def __post_init__(self) -> None:
        unknown = [n for n in self.surfaces if n not in SURFACES]
        if unknown:
            raise ValueError(f"InputMix.surfaces: unknown surface(s) {unknown}; valid names: {list(SURFACES)}")
        if len(set(self.names)) != len(self.names) or len(set(self.surfaces)) != len(self.surfaces):
            raise ValueError("InputMix: duplicate input or surface names")
        w = np.ascontiguousarray(self.weights, dtype=np.float64)
        if w.shape != (len(self.surfaces), len(self.names)) or not np.all(np.isfinite(w)):
            raise ValueError(f"InputMix.weights: expected finite ({len(self.surfaces)}, {len(self.names)}), got {w.shape}")
        if not (np.isfinite(self.unit_deg) and self.unit_deg > 0):
            raise ValueError(f"InputMix.unit_deg = {self.unit_deg}: must be > 0")
        object.__setattr__(self, "weights", w)

    def deflections(self, v: np.ndarray) -> np.ndarray:
        """(len(surfaces),) deflections, rad, of the input values v (len(names),)."""
        scale = math.radians(self.unit_deg)
        return np.array([scale * (self.weights[k] @ v) for k in range(len(self.surfaces))])


def _small_positive(name: str, v: object, hi: float, what: str) -> float:
    """``v`` as a float, or a ValueError naming ``name`` unless a real number in (0, ``hi``]: a tolerance or a
    difference step of zero, below zero or NaN reached scipy's own message or gave NaN matrices without a word."""
    ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)) and 0.0 < float(v) <= hi
    if not ok:
        raise ValueError(f"{name} = {v!r}: {what}; allowed range (0, {hi:g}]")
    return float(v)


def _inputs(controls_deg: Mapping[str, float], airspeed: float) -> np.ndarray:
    u = np.zeros(L.N_INPUTS)
    for k, name in enumerate(SURFACES):
        u[k] = np.radians(float(controls_deg.get(name, 0.0)))
    u[L.U_AIRSPEED] = airspeed
    return u


def _flags(aero: bool, friction: str | bool, aero_model: str = "linear") -> int:
    return (L.F_AERO if aero else 0) | (L.F_FRICTION if friction == "viscous" else 0) | (AERO_MODELS[aero_model] if aero else 0)


def _qdd(q: np.ndarray, qd: np.ndarray, u: np.ndarray, p: np.ndarray, flags: int, idx: np.ndarray, tabs: tuple,
         xs: tuple | None = None) -> np.ndarray:
    """qdd (5,) of the free joints idx; with the unsteady model the aerodynamic states are xs (7), or their
    steady values at (q, qd) when None (at an equilibrium x = x0: the loads are the tables', with the wake)."""
    if not flags & L.F_UNSTEADY:
        return joint_accelerations(q, qd, u, p, flags, idx, tabs)
    if xs is None:
        xs = separation_steady(q, qd, u, p, hawk_surfaces(u, p), tabs)
    return joint_accelerations(q, qd, u, p, flags, idx, tabs, tuple(float(v) for v in xs))


def trim(
    params: RigParams,
    free_dofs: Sequence[str],
    q_guess: Sequence[float] | None = None,
    *,
    airspeed: float = 20.0,
    controls: Mapping[str, float] | None = None,
    mix: InputMix | None = None,
    inputs: Mapping[str, float] | None = None,
    unknown_inputs: Sequence[str] = (),
    hold: Mapping[str, float] | None = None,
    aero: bool = True,
    aero_model: str = "linear",
    tol: float = 1e-10,
    max_residual: float | None = 1e-6,
) -> OperatingPoint:
    """Equilibrium of the free joints (rates zero): their angles, and the inputs that hold some at targets.

    Plain use: the angles of the free joints for fixed surface deflections ``controls`` (deg).
    ``q_guess``: all five joint angles (rad, JOINTS order); locked joints stay at their guess.

    With ``hold`` (free joint -> angle, rad) those joints are held at their targets and as many inputs,
    ``unknown_inputs``, are solved for instead (a square system: the residual is every free joint's
    acceleration).  The inputs are surface names (deg) without ``mix``, or names of ``mix`` (an
    :class:`InputMix`, values in its ``unit_deg``) whose other inputs take their ``inputs`` value (0 if
    not given); mixed surfaces may not also be in ``controls``.  Unknowns: the inputs (from 0) then the
    free joints not held (from their guess), solved by MINPACK's Levenberg-Marquardt to ``tol``.
    ``aero_model``: "linear" (default), "tables" or "unsteady" (:data:`rig_env.physics.pipeline.AERO_MODELS`;
    the unsteady model's equilibria are the tables', with the Hawk's separation state at x0).
    Returns the :class:`OperatingPoint`, with the solved inputs in ``inputs`` (surface names: in
    ``controls_deg``).  RuntimeError when max |qdd| > ``max_residual`` rad/s^2 (None: return the
    solver's point anyway, the caller checks ``residual``).  ``tol`` in (0, 0.01], ``max_residual`` in (0, 1000]
    or None: a ValueError naming either otherwise.
    """
    free = check_free_dofs(free_dofs)
    aero_model = check_aero_model(aero_model)
    controls = check_static_controls(controls or {}, params)
    tol = _small_positive("tol", tol, 0.01, "the solver's relative tolerance")
    if max_residual is not None:
        max_residual = _small_positive("max_residual", max_residual, 1.0e3, "the largest joint acceleration accepted as an equilibrium, rad/s^2, or None")
    q0 = np.zeros(5) if q_guess is None else np.array(q_guess, dtype=np.float64)
    if q0.shape != (5,) or not np.all(np.isfinite(q0)):
        raise ValueError("q_guess: expected 5 finite joint angles (rad, JOINTS order)")
    if not (0.0 <= airspeed <= 60.0):
        raise ValueError(f"airspeed = {airspeed} m/s is outside the allowed range [0, 60] m/s")
    hold = {j: float(a) for j, a in (hold or {}).items()}
    bad = [j for j in hold if j not in free]
    if bad:
        raise ValueError(f"hold: joint(s) {bad} are not free (free_dofs = {list(free)})")
    if mix is None:
        mix = InputMix(tuple(n for n in SURFACES if n not in controls), tuple(n for n in SURFACES if n not in controls),
                       np.eye(len(SURFACES) - len(controls))) if unknown_inputs else None
    given = dict(inputs or {})
    names = mix.names if mix is not None else ()
    bad = [n for n in (*unknown_inputs, *given) if n not in names]
    if bad:
        raise ValueError(f"inputs: unknown name(s) {bad}; this trim's inputs: {list(names)}")
    if set(unknown_inputs) & set(given) or len(set(unknown_inputs)) != len(tuple(unknown_inputs)):
        raise ValueError("unknown_inputs: each input once, and not also given in inputs")
    if len(tuple(unknown_inputs)) != len(hold):
        raise ValueError(f"trim: {len(hold)} held joint(s) need as many unknown inputs, got {list(unknown_inputs)}")
    if mix is not None and set(mix.surfaces) & set(controls):
        raise ValueError(f"controls: {sorted(set(mix.surfaces) & set(controls))} are driven by the input mix")
    p = params.to_vector()
    tabs = params.tables()
    idx = np.array([JOINTS.index(j) for j in free], dtype=np.int64)
    for j, a in hold.items():
        q0[JOINTS.index(j)] = a
    moved = np.array([JOINTS.index(j) for j in free if j not in hold], dtype=np.int64)
    u0 = _inputs(controls, airspeed)
    cols = [SURFACES.index(n) for n in mix.surfaces] if mix is not None else []
    v0 = np.zeros(len(names))
    for n, val in given.items():
        v0[names.index(n)] = float(val)
    solved = [names.index(n) for n in unknown_inputs]
    n_in = len(solved)
    flags = _flags(aero, False, aero_model)
    qd = np.zeros(5)

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, u, v = q0.copy(), u0.copy(), v0.copy()
        q[moved] += x[n_in:]
        v[solved] = x[:n_in]
        if mix is not None:
            u[cols] = mix.deflections(v)
        return q, u, v

    def residual(x: np.ndarray) -> np.ndarray:
        q, u, _ = unpack(x)
        return _qdd(q, qd, u, p, flags, idx, tabs)[idx]

    # solved for the change y from the guess, starting at y = 0: MINPACK's Levenberg-Marquardt sizes its
    # first step in proportion to the starting point's norm (100 |x0|, or 100 when x0 = 0), so a guess
    # of angles near 1e-17 rad (a trim of rounding-level asymmetry) would leave it no room to move
    sol = least_squares(residual, np.zeros(n_in + moved.size), xtol=tol, ftol=tol, gtol=tol, method="lm")
    q, u, v = unpack(sol.x)
    res = float(np.max(np.abs(residual(sol.x))))
    if max_residual is not None and res > max_residual:
        near_cut = MIN_AIRSPEED <= airspeed <= 1.1 * MIN_AIRSPEED
        raise RuntimeError(f"trim: no equilibrium found for free_dofs={list(free)} (max |qdd| = {res:.3g} rad/s^2)"
                           + (f"; airspeed = {airspeed:g} m/s is at the {MIN_AIRSPEED:g} m/s wind-off cut (aero.MIN_AIRSPEED), "
                              "where a body's loads and aerodynamic states switch on as its local airspeed crosses the cut, so "
                              "the accelerations jump there: trim a little above or below it" if near_cut else ""))
    out_controls = dict(controls)
    if mix is not None:
        out_controls.update({n: math.degrees(u[c]) for n, c in zip(mix.surfaces, cols)})  # every mixed surface, 0.0 included
    sep = tuple(float(v) for v in separation_steady(q, qd, u, p, hawk_surfaces(u, p), tabs)) if flags & L.F_UNSTEADY else ()
    return OperatingPoint(q=q, qd=qd, controls_deg=out_controls, airspeed=float(airspeed), free_dofs=free, residual=res,
                          inputs={n: float(v[k]) for k, n in enumerate(names)}, aero_model=aero_model, separation=sep)


def linearize(
    params: RigParams,
    op: OperatingPoint,
    *,
    inputs: Sequence[str] = COMP_INPUTS,
    aero: bool = True,
    friction: str | bool = False,
    eps: float = 1e-6,
) -> control.StateSpace:
    """Continuous-time linear model x' = A x + B u about ``op``; x = (angles, rates) of the free joints, then
    with ``op``'s aero_model "unsteady" the aerodynamic states (:data:`SEPARATION_STATES`, about their steady values).

    States are named ``<joint>`` and ``<joint>_rate``; inputs are the named surfaces in rad and the named gusts
    of :data:`GUST_INPUTS` in m/s; the outputs are the states.  The aerodynamic model is the operating point's (:func:`trim`'s ``aero_model``).
    ``eps``: the central differences' step (rad, rad/s and the inputs' units), in (0, 0.01].
    """
    if not isinstance(op, OperatingPoint):
        raise ValueError(f"op: expected the OperatingPoint rig_env.trim returns, not {type(op).__name__}")
    unknown = [n for n in inputs if n not in SURFACES and n not in GUST_INPUTS]
    if unknown:
        raise ValueError(f"inputs: unknown input(s) {unknown}; valid names: the surfaces {list(SURFACES)} and the gusts {list(GUST_INPUTS)}")
    if friction not in (False, "viscous"):
        raise ValueError("friction: allowed values are False and 'viscous'")
    eps = _small_positive("eps", eps, 0.01, "the finite-difference step (rad, rad/s and the inputs' units)")
    free = op.free_dofs
    p = params.to_vector()
    tabs = params.tables()
    idx = np.array([JOINTS.index(j) for j in free], dtype=np.int64)
    n = len(idx)
    u0 = _inputs(op.controls_deg, op.airspeed)
    flags = _flags(aero, friction, op.aero_model)
    unsteady = bool(flags & L.F_UNSTEADY)
    x_op = np.array(separation_steady(op.q, op.qd, u0, p, hawk_surfaces(u0, p), tabs)) if unsteady else np.array(ATTACHED)
    ns = L.N_AERO if unsteady else 0
    m = 2 * n + ns

    def f(q: np.ndarray, qd: np.ndarray, u: np.ndarray, xs: np.ndarray = x_op) -> np.ndarray:
        """(free accelerations, aerodynamic states' rates if unsteady) at (q, qd, u) and aerodynamic states xs (7,)."""
        t = tuple(float(v) for v in xs)
        acc = _qdd(q, qd, u, p, flags, idx, tabs, t)[idx]
        return np.append(acc, separation_rates(q, qd, u, p, t, hawk_surfaces(u, p), tabs)) if unsteady else acc

    A = np.zeros((m, m))
    A[:n, n:2 * n] = np.eye(n)
    for a, j in enumerate(idx):
        for which in (0, 1):
            dq = np.zeros(5)
            dq[j] = eps
            if which == 0:
                col = (f(op.q + dq, op.qd, u0) - f(op.q - dq, op.qd, u0)) / (2 * eps)
                A[n:, a] = col
            else:
                col = (f(op.q, op.qd + dq, u0) - f(op.q, op.qd - dq, u0)) / (2 * eps)
                A[n:, n + a] = col
    for k in range(ns):
        dx = np.zeros(L.N_AERO)
        dx[k] = eps
        A[n:, 2 * n + k] = (f(op.q, op.qd, u0, x_op + dx) - f(op.q, op.qd, u0, x_op - dx)) / (2 * eps)
    B = np.zeros((m, len(inputs)))
    for b, name in enumerate(inputs):
        du = np.zeros(L.N_INPUTS)
        du[list(GUST_INPUTS[name] if name in GUST_INPUTS else (SURFACES.index(name),))] = eps
        B[n:, b] = (f(op.q, op.qd, u0 + du) - f(op.q, op.qd, u0 - du)) / (2 * eps)
    states = [*free, *(f"{j}_rate" for j in free), *(SEPARATION_STATES if unsteady else ())]
    return control.ss(A, B, np.eye(m), np.zeros((m, len(inputs))), states=states, inputs=list(inputs), outputs=states)

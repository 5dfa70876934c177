"""The rig as a vector field for continuation: ``continuation()``, equilibria and periodic orbits of the joint-space model.

State: the free joints' angles (rad) and rates (rad/s), then any internal states of the aerodynamic
model (none for ``"linear"`` and ``"tables"``; an unsteady model adds its separation states there,
:class:`AeroModel`).  Right-hand side: the same accelerations as :func:`rig_env.trim` and
:func:`rig_env.linearize` (:func:`rig_env.linear.joint_accelerations`: the joint-space kernel with ideal
servos, the flaps at the limited commands).  Flow map of the periodic orbits: the environments' lane kernel
(:class:`rig_env.physics.pipeline.PhysicsBatch`, kind "lanes", serial: eight perturbed states per register;
the same model as :func:`rig_env.simulate`'s "joint" kernel, to 1e-10, which ``orbit_kernel="joint"`` runs
instead; RK4),
servo dynamics off (the surfaces sit at their held, limited command), every perturbed initial state of a
shooting Jacobian one environment of one batch.

Non-smooth terms.  LuGre friction has a stiction band: every angle where the static torque stays below
Fs is an equilibrium at rest, so equilibria are not isolated and a Jacobian at rest does not exist.
``friction="off"`` (default) leaves friction out; ``"viscous"`` keeps its smooth part, the viscous
torque -sigma2 qd (the kernels run with sigma0 = sigma1 = 0, so the bristle state carries no torque).
Joint stops are springs beyond the stop angles, continuous but with a kink: ``stops=False`` (default)
leaves them out and says in ``Branch.notes`` where the branch passes a stop (``Branch.at_stop`` marks
those points); ``stops=True`` puts the stop springs in, the branch then continues on the spring.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from rig_env.bifurcation.core import Settings
from rig_env.bifurcation.equilibria import check_values, equilibria
from rig_env.bifurcation.periodic import orbits as orbit_branch
from rig_env.bifurcation.result import Branch
from rig_env.linear import SEPARATION_STATES, hawk_surfaces, joint_accelerations
from rig_env.physics.aero import MIN_AIRSPEED
from rig_env.params import JOINTS, PARAM_INDEX, PARAM_NAMES, SURFACES, ParameterError, RigParams, _iter_leaves
from rig_env.params_io import did_you_mean
from rig_env.physics import layout as L
from rig_env.physics.friction import FRICTION_BASE
from rig_env.physics.joint_space import separation_rates, separation_steady
from rig_env.physics.pipeline import AERO_MODELS as FLAGS
from rig_env.physics.pipeline import PhysicsBatch, check_aero_model
from rig_env.simulate import check_free_dofs, check_static_controls


@dataclass(frozen=True)
class AeroModel:
    """An aerodynamic model option: its kernel flags and its internal states (names, units, state columns X_*)."""

    name: str
    flags: int
    internal: tuple[str, ...] = ()
    internal_units: tuple[str, ...] = ()
    internal_columns: tuple[int, ...] = ()


AERO_MODELS: dict[str, AeroModel] = {
    "linear": AeroModel("linear", FLAGS["linear"]),
    "tables": AeroModel("tables", FLAGS["tables"]),
    "unsteady": AeroModel("unsteady", FLAGS["unsteady"], SEPARATION_STATES, ("-",) * L.N_SEP + ("m/s",) * L.N_WAKE,
                          tuple(L.X_SEP + k for k in range(L.N_AERO))),
}
"""The aerodynamic models continuation knows: the linear derivatives, the high-incidence tables
(``simulate(aero_model="tables")``) and the unsteady model, whose aerodynamic states (the flow-separation
states x of the Hawk and the compensator's panels, the Hawk's wake at the compensator; ``internal``, with their
columns of the kernels' state vector) the continuation
state carries after the joint rates; :meth:`RigField.rates` takes its rate from the model (its equilibria have x = x0(alpha), where
the loads are the tables': the unsteady model's equilibria are the tables', their stability is its own)."""


@dataclass(frozen=True)
class RigParameter:
    """The continuation parameter: ``kind`` "surface" (deg, an input column), "airspeed" (m/s) or "param" (a
    :data:`rig_env.PARAM_NAMES` entry in its file unit, kernel column ``column`` = value * ``to_kernel``)."""

    name: str
    kind: str
    unit: str
    column: int
    to_kernel: float


def resolve_parameter(params: RigParams, name: str) -> RigParameter:
    """The parameter called ``name``: a surface of :data:`rig_env.SURFACES`, ``"airspeed"`` or a dotted name of
    :data:`rig_env.PARAM_NAMES`; ValueError listing the valid names otherwise."""
    if name in SURFACES:
        return RigParameter(name, "surface", "deg", SURFACES.index(name), math.pi / 180.0)
    if name == "airspeed":
        return RigParameter(name, "airspeed", "m/s", L.U_AIRSPEED, 1.0)
    if name in PARAM_INDEX:
        unit = next(u for n, _, _, u in _iter_leaves(params) if n == name)
        return RigParameter(name, "param", unit, PARAM_INDEX[name], math.pi / 180.0 if name.endswith(("_deg", "_deg_s")) else 1.0)
    raise ValueError(f"parameter = {name!r}: unknown{did_you_mean(name, (*SURFACES, 'airspeed', *PARAM_NAMES))}; valid names: the "
                     f"surfaces {list(SURFACES)}, 'airspeed', or one of the {len(PARAM_NAMES)} dotted rig parameter names of "
                     "rig_env.PARAM_NAMES (e.g. 'geometry.hawk_cg_x')")


MAX_ANGLE_DEG = 170.0
"""The trace ends where a free joint's angle passes +-170 deg: the aerodynamic angles wrap at 180 deg
(the linear model's coefficients jump there) and past one half turn the configurations repeat."""
ORBIT_DT_RANGE = (1e-4, 5e-3)
"""The orbits' RK4 step ``physics_dt`` (s): below 0.1 ms a shooting flow over a few seconds needs a work row of
hundreds of megabytes per block and minutes; above 5 ms (twice the environments' step) RK4 no longer resolves the
rig's 1-2 Hz orbits and their Floquet multipliers."""
MAX_ORBIT_AMPLITUDE = 0.5
"""The first orbit's amplitude along the critical eigenvector (rad or rad/s) at most: the linear orbit is its guess."""
MAX_ORBITS = 1000
"""Orbits per Hopf point at most (``max_orbits``)."""

_STOPS = {j: (getattr(L, f"P_STOPS_{j.upper()}_LOWER_DEG"), getattr(L, f"P_STOPS_{j.upper()}_UPPER_DEG"))
          for j in ("rig_pitch", "rig_yaw", "model_pitch")}  # fmt: skip


class RigField:
    """x' = f(x, value) of the rig with one parameter free; x = (free angles, free rates, internal states)."""

    def __init__(self, params: RigParams, free: tuple[str, ...], par: RigParameter, q_locked: np.ndarray,
                 controls: Mapping[str, float], airspeed: float, aero: AeroModel, friction: str, stops: bool,
                 kernel: str = "lanes") -> None:
        self.free, self.par, self.aero, self.kernel = free, par, aero, kernel
        self.idx = np.array([JOINTS.index(j) for j in free], dtype=np.int64)
        self.nf = len(free)
        self.n = 2 * self.nf + len(aero.internal)
        self.q_locked = q_locked
        self.flags = L.F_AERO | aero.flags | (L.F_FRICTION if friction == "viscous" else 0) | (L.F_STOPS if stops else 0)
        self.p0 = params.to_vector()
        if friction == "viscous":
            for j in range(5):
                self.p0[FRICTION_BASE[j] + 4] = 0.0  # sigma0: no bristle stiffness
                self.p0[FRICTION_BASE[j] + 5] = 0.0  # sigma1: no bristle damping; sigma2 qd remains
        self.tabs = params.tables()
        self.u0 = np.zeros(L.N_INPUTS)
        for name, deg in controls.items():
            self.u0[SURFACES.index(name)] = math.radians(deg)
        self.u0[L.U_AIRSPEED] = airspeed
        self.state_names = (*free, *(f"{j}_rate" for j in free), *aero.internal)
        self.state_units = ("rad",) * self.nf + ("rad/s",) * self.nf + aero.internal_units

    def inputs(self, value: float) -> tuple[np.ndarray, np.ndarray]:
        """The input vector (N_INPUTS,) and parameter row (N_PARAMS,) at the parameter value."""
        u, p = self.u0, self.p0
        if self.par.kind == "param":
            p = p.copy()
            p[self.par.column] = value * self.par.to_kernel
        else:
            u = u.copy()
            u[self.par.column] = value * self.par.to_kernel
        return u, p

    def rates(self, x: np.ndarray, value: float) -> np.ndarray:
        """f(x, value): (free rates, free accelerations, internal-state rates)."""
        u, p = self.inputs(value)
        q = self.q_locked.copy()
        qd = np.zeros(5)
        q[self.idx] = x[: self.nf]
        qd[self.idx] = x[self.nf : 2 * self.nf]
        if not self.aero.internal:
            qdd = joint_accelerations(q, qd, u, p, self.flags, self.idx, self.tabs)
            return np.concatenate([x[self.nf : 2 * self.nf], qdd[self.idx]])
        xs = tuple(float(v) for v in x[2 * self.nf :])
        qdd = joint_accelerations(q, qd, u, p, self.flags, self.idx, self.tabs, xs)
        return np.concatenate([x[self.nf : 2 * self.nf], qdd[self.idx], separation_rates(q, qd, u, p, xs, hawk_surfaces(u, p), self.tabs)])

    def steady_internal(self, x: np.ndarray, value: float) -> np.ndarray:
        """x with its internal states at their steady values for its angles and rates (x = x0 for the unsteady model)."""
        if not self.aero.internal:
            return x
        u, p = self.inputs(value)
        q = self.q_locked.copy()
        qd = np.zeros(5)
        q[self.idx] = x[: self.nf]
        qd[self.idx] = x[self.nf : 2 * self.nf]
        y = x.copy()
        y[2 * self.nf :] = separation_steady(q, qd, u, p, hawk_surfaces(u, p), self.tabs)
        return y

    def rates_batch(self, X: np.ndarray, values: np.ndarray) -> np.ndarray:
        return np.array([self.rates(x, v) for x, v in zip(X, values)])

    def flow(self, X0: np.ndarray, T: float, values: np.ndarray, samples: int, physics_dt: float) -> np.ndarray:
        """States at t = k T / samples (k = 0..samples) of every row of X0 under its parameter value, by the
        serial ``kernel`` of :class:`PhysicsBatch` (RK4 steps of at most physics_dt); NaN rows where it failed."""
        m = X0.shape[0]
        n_sub = max(1, math.ceil(T / samples / physics_dt))
        P = np.empty((m, L.N_PARAMS))
        U = np.empty((m, L.N_INPUTS))
        for i, v in enumerate(values):
            U[i], P[i] = self.inputs(float(v))
        batch = PhysicsBatch(P, self.tabs, self.idx, self.flags, T / (samples * n_sub), n_sub, kind=self.kernel, parallel=False)
        batch.U[:] = U
        q = np.repeat(self.q_locked[None, :], m, axis=0)
        qd = np.zeros((m, 5))
        q[:, self.idx] = X0[:, : self.nf]
        qd[:, self.idx] = X0[:, self.nf : 2 * self.nf]
        batch.reset(np.arange(m), q, qd)
        if self.aero.internal:
            batch.X[:, list(self.aero.internal_columns)] = X0[:, 2 * self.nf :]
        cols = [L.X_Q + j for j in self.idx] + [L.X_QD + j for j in self.idx] + list(self.aero.internal_columns)
        out = np.empty((m, samples + 1, self.n))
        out[:, 0] = X0
        for k in range(1, samples + 1):
            batch.step()
            out[:, k] = batch.X[:, cols]
        out[batch.status != L.S_OK] = np.nan
        return out

    def stop_contacts(self, states: np.ndarray) -> list[tuple[str, str, np.ndarray]]:
        """(joint, "lower"/"upper", mask over the rows of states) for every free limited joint past a stop."""
        out = []
        for a, j in enumerate(self.free):
            if j in _STOPS:
                lo, hi = (self.p0[c] for c in _STOPS[j])
                out.append((j, "lower", states[:, a] < lo))
                out.append((j, "upper", states[:, a] > hi))
        return out


def _check_options(aero_model: str, friction: str) -> AeroModel:
    check_aero_model(aero_model)
    if friction not in ("off", "viscous"):
        raise ValueError(f"friction = {friction!r}: allowed values: 'off', 'viscous' (LuGre's stiction band has no isolated "
                         "equilibria to continue)")
    return AERO_MODELS[aero_model]


def continuation(
    params: RigParams,
    *,
    free_dofs: Sequence[str],
    parameter: str,
    values: Sequence[float] | np.ndarray,
    airspeed: float | None = None,
    controls: Mapping[str, float] | None = None,
    aero_model: str = "linear",
    q_guess: Sequence[float] | None = None,
    friction: str = "off",
    stops: bool = False,
    periodic: bool = True,
    orbit_amplitude: float = 0.01,
    max_orbits: int = 40,
    physics_dt: float = 1e-3,
    orbit_kernel: str = "lanes",
    settings: Settings | None = None,
) -> Branch:
    """Equilibria of the rig's free joints over ``parameter``, their stability, folds and Hopf points, and the
    periodic orbits born at the Hopf points.

    free_dofs: the free joints (the others locked at ``q_guess``); parameter: a surface of
    :data:`rig_env.SURFACES` (deg), ``"airspeed"`` (m/s) or a dotted name of :data:`rig_env.PARAM_NAMES`
    (its file unit, e.g. ``"geometry.hawk_cg_x"``, m); values: the range (minimum to maximum) and the
    output sampling, traced from values[0] towards values[-1]; airspeed: m/s when it is not the parameter
    (default 20); controls: the other surfaces, deg (constant); aero_model: ``"linear"`` (the stability
    derivatives), ``"tables"`` (the high-incidence tables) or ``"unsteady"`` (the tables through the Hawk's
    flow-separation states, which become the last five columns of ``states``: ``hawk_separation``,
    ``flap1_separation`` .. ``flap4_separation``);
    q_guess: five joint angles (rad, JOINTS order): the locked joints' angles and the first equilibrium's
    guess (default zeros); friction: ``"off"`` or ``"viscous"``; stops: model the joint stops (see the
    module docstring); periodic: continue the orbits of every Hopf point (single shooting on the kernels,
    RK4 steps of at most ``physics_dt`` s, 1e-4 to 5e-3: :data:`ORBIT_DT_RANGE`), from an orbit of
    ``orbit_amplitude`` (0 to 0.5) along the critical eigenvector (whose largest entry is 1: rad or rad/s),
    ``max_orbits`` (1 to 1000) orbits at most per Hopf point;
    orbit_kernel: the shooting's kernel, ``"lanes"`` (the environments' lane kernel, eight perturbed states per
    register: faster, ``benchmarks/bench_continuation.py``) or ``"joint"`` (the per-environment kernel
    :func:`rig_env.simulate` runs: less to compile on a fresh installation);
    settings: the curve solver's steps and tolerances (:class:`rig_env.bifurcation.core.Settings`, scaled
    units: states in their units, the parameter by its range).

    Returns a :class:`~rig_env.bifurcation.result.Branch`: ``values``, ``states`` (columns ``<joint>`` rad,
    ``<joint>_rate`` rad/s), ``stable``, ``eigenvalues``, ``hopf``, ``folds``, ``orbits``, ``notes`` (a stop
    passed, the end of the trace), ``at_stop``.  ValueError for bad input (naming the field and the allowed
    values) and when no equilibrium is found near ``q_guess`` at values[0].
    """
    aero = _check_options(aero_model, friction)
    free = check_free_dofs(free_dofs)
    par = resolve_parameter(params, parameter)
    v = check_values(values)
    controls = check_static_controls(controls or {}, params)
    if par.kind == "surface" and parameter in controls:
        raise ValueError(f"controls: {parameter!r} is the continuation parameter; leave it out of controls")
    if par.kind == "surface":
        for end in (float(v.min()), float(v.max())):
            check_static_controls({**controls, parameter: end}, params, "values")
    if par.kind == "airspeed":
        if airspeed is not None:
            raise ValueError("airspeed: the airspeed is the continuation parameter (values); leave airspeed=None")
        if v.min() < 0.0 or v.max() > 60.0:
            raise ValueError(f"values: airspeed {v.min():g}..{v.max():g} m/s is outside the allowed range [0, 60] m/s")
    airspeed = 20.0 if airspeed is None else float(airspeed)
    if not 0.0 <= airspeed <= 60.0:
        raise ValueError(f"airspeed = {airspeed} m/s is outside the allowed range [0, 60] m/s")
    if aero.internal:  # the separation and wake states relax at a rate in proportion to V and are held below MIN_AIRSPEED
        low = float(v.min()) if par.kind == "airspeed" else airspeed
        if low < MIN_AIRSPEED:
            what = f"values: airspeed {low:g} m/s" if par.kind == "airspeed" else f"airspeed = {low:g} m/s"
            raise ValueError(f"{what}: with aero_model = {aero_model!r} the airspeed must be at least {MIN_AIRSPEED:g} m/s (below it "
                             "the aerodynamic states are held, so no equilibrium is isolated; the 'tables' model continues to 0)")
    if par.kind == "param":
        for end in (v.min(), v.max()):
            params.replace(**{parameter: float(end)})  # ParameterError naming the field and its range
    q0 = np.zeros(5) if q_guess is None else np.asarray(q_guess, dtype=np.float64)
    if q0.shape != (5,) or not np.all(np.isfinite(q0)):
        raise ValueError("q_guess: expected 5 finite joint angles (rad, JOINTS order)")
    if not (math.isfinite(physics_dt) and ORBIT_DT_RANGE[0] <= physics_dt <= ORBIT_DT_RANGE[1]):
        raise ValueError(f"physics_dt = {physics_dt}: the orbits' RK4 step must lie in [{ORBIT_DT_RANGE[0]:g}, {ORBIT_DT_RANGE[1]:g}] s")
    if not (math.isfinite(orbit_amplitude) and 0.0 < orbit_amplitude <= MAX_ORBIT_AMPLITUDE):
        raise ValueError(f"orbit_amplitude = {orbit_amplitude}: must lie in (0, {MAX_ORBIT_AMPLITUDE:g}] (rad or rad/s)")
    if isinstance(max_orbits, bool) or not isinstance(max_orbits, (int, np.integer)) or not 1 <= max_orbits <= MAX_ORBITS:
        raise ValueError(f"max_orbits = {max_orbits!r}: must be an integer from 1 to {MAX_ORBITS}")
    if settings is not None and not isinstance(settings, Settings):
        raise ValueError(f"settings: expected a rig_env.bifurcation.core.Settings or None, not {type(settings).__name__}")
    if orbit_kernel not in ("lanes", "joint"):
        raise ValueError(f"orbit_kernel = {orbit_kernel!r}: allowed values: 'lanes', 'joint'")
    rig = RigField(params, free, par, q0, controls, airspeed, aero, friction, bool(stops), orbit_kernel)
    x0, start = _first_equilibrium(rig, v)
    outside = [(j, math.degrees(x0[a])) for a, j in enumerate(free) if not abs(x0[a]) <= math.radians(MAX_ANGLE_DEG)]
    if outside:  # the trace would stop before its first point (its domain), leaving an empty branch
        raise ValueError(f"q_guess: the equilibrium found near it at {parameter} = {start:g} {par.unit} has "
                         f"{', '.join(f'{j} = {d:.4g} deg' for j, d in outside)}, outside the continuation's +-{MAX_ANGLE_DEG:g} deg; "
                         "give a better q_guess")
    events = {}
    for a, j in enumerate(free):
        if j in _STOPS:
            lo, hi = (rig.p0[c] for c in _STOPS[j])
            events[f"stop:{j}:lower"] = lambda x, a=a, lo=lo: float(x[a] - lo)
            events[f"stop:{j}:upper"] = lambda x, a=a, hi=hi: float(x[a] - hi)
    branch = equilibria(rig.rates, x0, v, state_names=rig.state_names, state_units=rig.state_units,
                        parameter=parameter, parameter_unit=par.unit, start=start, settings=settings,
                        domain=lambda x: bool(np.all(np.abs(x[: rig.nf]) <= math.radians(MAX_ANGLE_DEG))), events=events)
    notes = list(branch.notes)
    if start != v[0]:
        notes.insert(0, f"no equilibrium near q_guess at {parameter} = {v[0]:g} {par.unit}: started at {start:g} {par.unit}, traced both ways")
    notes += _stop_notes(rig, branch, bool(stops))
    at_stop = np.zeros(branch.values.size, dtype=bool)
    for _, _, mask in rig.stop_contacts(branch.states):
        at_stop |= mask
    found = []
    for h in branch.hopf_points() if periodic else ():
        try:
            ob = orbit_branch(rig.rates_batch, lambda X, T, P, k: rig.flow(X, T, P, k, physics_dt), h, (float(v.min()), float(v.max())),
                              amplitude=orbit_amplitude, max_orbits=max_orbits)
        except RuntimeError as exc:
            notes.append(f"orbits from the Hopf point at {parameter} = {h.value:.6g}: {exc}")
            continue
        found.append(ob)
        notes.append(f"orbits from the Hopf point at {parameter} = {h.value:.6g}: {len(ob.values)} orbits, ended: {ob.end}")
        for a, j in enumerate(free):
            if j in _STOPS:
                lo, hi = (rig.p0[c] for c in _STOPS[j])
                hit = (ob.upper[:, a] > hi) | (ob.lower[:, a] < lo)
                if np.any(hit):
                    notes.append(f"orbits from the Hopf point at {parameter} = {h.value:.6g} swing past a {j} stop from "
                                 f"{parameter} = {ob.values[np.argmax(hit)]:.6g} {par.unit} on")
    settings_out = {"free_dofs": free, "airspeed": airspeed if par.kind != "airspeed" else None, "controls": controls,
                    "aero_model": aero.name, "friction": friction, "stops": bool(stops), "q_guess": tuple(q0)}
    return dataclasses.replace(branch, orbits=tuple(found), notes=tuple(notes), settings=settings_out, at_stop=at_stop)


def _first_equilibrium(rig: RigField, values: np.ndarray) -> tuple[np.ndarray, float]:
    """An equilibrium near the guess at the first of ``values`` that has one (free angles by Levenberg-Marquardt
    on the accelerations, rates zero) and that value."""
    from scipy.optimize import least_squares

    nf = rig.nf
    x = np.zeros(rig.n)
    x[:nf] = rig.q_locked[rig.idx]
    worst = np.inf
    for value in values:

        def res(dq: np.ndarray, value: float = float(value)) -> np.ndarray:
            y = x.copy()
            y[:nf] += dq
            return rig.rates(rig.steady_internal(y, value), value)[nf : 2 * nf]

        sol = least_squares(res, np.zeros(nf), xtol=1e-12, ftol=1e-12, gtol=1e-12, method="lm")
        r = float(np.max(np.abs(sol.fun))) if np.all(np.isfinite(sol.fun)) else np.inf
        if r <= 1e-6:
            y = x.copy()
            y[:nf] += sol.x
            return rig.steady_internal(y, float(value)), float(value)
        worst = min(worst, r)
    raise ValueError(f"q_guess: no equilibrium of {list(rig.free)} found near it at any of the values of {rig.par.name} "
                     f"(smallest max |qdd| {worst:.3g} rad/s^2); give a better q_guess")


def _stop_notes(rig: RigField, branch: Branch, stops: bool) -> list[str]:
    """Where the branch reaches a stop of a free joint (the located ``stop:<joint>:<side>`` events)."""
    notes = []
    what = "on the stop spring beyond" if stops else "stops=False: the stop is not modelled, the equilibria beyond lie past it"
    for sp in branch.special_points:
        if sp.kind.startswith("stop:"):
            _, j, side = sp.kind.split(":")
            lim = rig.p0[_STOPS[j][0 if side == "lower" else 1]]
            notes.append(f"{j} reaches its {side} stop ({math.degrees(lim):g} deg) at {branch.parameter} = {sp.value:.6g} "
                         f"{branch.parameter_unit} ({what})")
    for j, side, mask in rig.stop_contacts(branch.curve_states[:1]):
        if mask.size and mask[0]:
            notes.append(f"{j} is past its {side} stop at the start of the branch ({branch.parameter} = {branch.curve_values[0]:.6g} "
                         f"{branch.parameter_unit})")
    return notes

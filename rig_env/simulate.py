"""``simulate``: run the rig model for a fixed time, batched or single, in either formulation.

This is the Python layer over the physics pipeline (:class:`rig_env.physics.pipeline.PhysicsBatch`, the
same batch and kernels the environments step): it checks inputs, lays out the batch, evaluates the
control and gust schedules once per control step, and collects the trajectory at the control rate.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np

from rig_env.params import JOINTS, SURFACES, ParameterError, RigParams, param_batch
from rig_env.physics import layout as L
from rig_env.physics.pipeline import PhysicsBatch, delay_line, flags_of, rates, resolve_aero_model  # noqa: F401  (delay_line: re-exported)
from rig_env.turbulence import MIN_CONVECTION_SPEED, convection_distance

Schedule = float | Sequence[float] | np.ndarray | Callable[[float], "float | Sequence[float] | np.ndarray"]
"""A signal over time: a constant, a per-environment (or per-component: a gust's three) sequence or array,
or a function of time in seconds giving either."""

STATUS_NAMES = {L.S_OK: "ok", L.S_NONFINITE: "non-finite state", L.S_RUNAWAY: "runaway joint rate", L.S_CONSTRAINT: "constraint residual"}


@dataclass(frozen=True)
class SimResult:
    """Trajectory at the control rate.  Batched arrays lead with the environment axis.

    t: (n_t,) s.  q, qd: (n_t, n_free) or (n_envs, n_t, n_free), rad and rad/s, free joints in
    ``free_dofs`` order.  q_all: the same for all five joints (JOINTS order).  energy: kinetic +
    potential (gravity, and a test fixture's spring and weight), J.  flaps: servo positions (deg, rig_env.SERVOS order).  z: LuGre bristle states
    (rad).  separation: the flow-separation states x (1 attached, 0 separated; the Hawk, then the
    compensator's panels of flaps 1-4: (n_t, 5); aero_model "unsteady" only, else None).  wake: the Hawk's wake
    at the compensator, its sidewash and downwash (m/s, world y and z: (n_t, 2); "unsteady" only, else None).  constraint_residual: max |C| per sample (DAE only, else None).  status: per-environment
    code (0 ok; see ``status_text``); fail_time: time of the detected blow-up (s) or NaN.  After a
    blow-up an environment's samples hold its last finite state.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_all: np.ndarray
    qd_all: np.ndarray
    energy: np.ndarray
    flaps: np.ndarray
    z: np.ndarray
    constraint_residual: np.ndarray | None
    status: np.ndarray
    fail_time: np.ndarray
    free_dofs: tuple[str, ...]
    formulation: str
    physics_dt: float
    control_dt: float
    separation: np.ndarray | None = None
    wake: np.ndarray | None = None

    @property
    def failed(self) -> np.ndarray:
        return self.status != L.S_OK

    def status_text(self) -> list[str]:
        return [STATUS_NAMES[int(s)] for s in np.atleast_1d(self.status)]


def check_free_dofs(free_dofs: Sequence[str]) -> tuple[str, ...]:
    """Validate a set of free joint names; returns them in JOINTS order."""
    if isinstance(free_dofs, str):
        free_dofs = (free_dofs,)
    names = tuple(free_dofs)
    unknown = [n for n in names if n not in JOINTS]
    if unknown:
        raise ValueError(f"free_dofs: unknown joint(s) {unknown}; valid names: {list(JOINTS)}")
    if len(set(names)) != len(names):
        raise ValueError(f"free_dofs: duplicate joint names in {list(names)}")
    if not names:
        raise ValueError("free_dofs: at least one joint must be free (locking all five leaves nothing to simulate)")
    return tuple(j for j in JOINTS if j in names)


def _as_batch(name: str, a, n_free: int) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] not in (n_free, 5):
        raise ValueError(f"{name}: expected shape ({n_free},) or (n_envs, {n_free}) (free joints) or (..., 5) (all joints), got {np.shape(a)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: values must be finite")
    return arr


def initial_state(q0, qd0, free: tuple[str, ...]) -> tuple[np.ndarray, bool]:
    """(n_envs, N_STATE) initial states from q0/qd0 given for the free joints or all five."""
    n_free = len(free)
    batched = np.ndim(q0) == 2
    Q = _as_batch("q0", q0, n_free)
    QD = _as_batch("qd0", qd0, n_free) if qd0 is not None else np.zeros((Q.shape[0], n_free))
    if QD.shape[0] != Q.shape[0]:
        if QD.shape[0] == 1:
            QD = np.repeat(QD, Q.shape[0], axis=0)
        else:
            raise ValueError(f"qd0: {QD.shape[0]} environments but q0 has {Q.shape[0]}")
    n = Q.shape[0]
    X = np.zeros((n, L.N_STATE))
    idx = [JOINTS.index(j) for j in free]
    if Q.shape[1] == 5:
        X[:, 0:5] = Q
    else:
        X[:, idx] = Q
    if QD.shape[1] == 5:
        locked = [k for k in range(5) if k not in idx]
        if np.any(QD[:, locked] != 0.0):
            raise ValueError("qd0: locked joints must have zero rate")
        X[:, 5:10] = QD
    else:
        X[:, [5 + k for k in idx]] = QD
    return X, batched


MAX_RESULT_BYTES = 4 * 2**30
"""simulate() refuses a run whose sampled states would take more than this (4 GiB) rather than ask numpy for it."""
STOP_MARGIN_DEG = 10.0
"""How far past a gimbal stop an initial angle may lie, deg: the stops are stiff spring-dampers, so a small
penetration is a physical state; 10 deg past one is not (the default stops' springs would push back with
kN m)."""
UNLIMITED_MAX_RAD = 1.0e4
"""Largest initial angle of an unlimited joint (rig_roll, model_yaw), rad: about 1600 turns, the loop's sensor bound."""
_STOP_COLUMNS = {"rig_pitch": (L.P_STOPS_RIG_PITCH_LOWER_DEG, L.P_STOPS_RIG_PITCH_UPPER_DEG),
                 "rig_yaw": (L.P_STOPS_RIG_YAW_LOWER_DEG, L.P_STOPS_RIG_YAW_UPPER_DEG),
                 "model_pitch": (L.P_STOPS_MODEL_PITCH_LOWER_DEG, L.P_STOPS_MODEL_PITCH_UPPER_DEG)}


def check_initial_state(X: np.ndarray, P: np.ndarray, stops: bool = True) -> None:
    """Refuse physically impossible initial states (ValueError naming the joint, the environment and the bound).

    X: (n, N_STATE) initial states (all five joints, locked ones included: rad, rad/s); P: (n, N_PARAMS)
    parameter rows (SI: the stops in rad); stops: the stops are modelled (``simulate(stops=...)``; without them the stop bound is
    not applied).  A limited joint (``LIMITED_JOINTS``) must lie within its stops (``P``'s
    ``stops.<joint>``, deg) widened by :data:`STOP_MARGIN_DEG`; an unlimited one within
    +-:data:`UNLIMITED_MAX_RAD`; every rate below the runaway bound ``layout.RUNAWAY_RATE`` (rad/s), where
    the kernels would freeze the environment at its first step.
    """
    for j, (lo_col, hi_col) in _STOP_COLUMNS.items() if stops else ():
        k = JOINTS.index(j)
        q = np.degrees(X[:, L.X_Q + k])
        stop_lo, stop_hi = np.degrees(P[:, lo_col]), np.degrees(P[:, hi_col])  # the kernels' rows hold SI units (rad)
        bad = np.flatnonzero((q < stop_lo - STOP_MARGIN_DEG) | (q > stop_hi + STOP_MARGIN_DEG))
        if bad.size:
            i = int(bad[0])
            raise ValueError(f"q0: {j} = {q[i]:.4g} deg (env {i}) is past its stops [{stop_lo[i]:.4g}, {stop_hi[i]:.4g}] deg "
                             f"by more than {STOP_MARGIN_DEG:g} deg: not a physical state")
    for j in ("rig_roll", "model_yaw"):
        q = X[:, L.X_Q + JOINTS.index(j)]
        bad = np.flatnonzero(np.abs(q) > UNLIMITED_MAX_RAD)
        if bad.size:
            raise ValueError(f"q0: {j} = {q[bad[0]]:.4g} rad (env {int(bad[0])}): allowed range +-{UNLIMITED_MAX_RAD:g} rad")
    qd = X[:, L.X_QD : L.X_QD + 5]
    bad = np.argwhere(np.abs(qd) >= L.RUNAWAY_RATE)
    if bad.size:
        i, k = (int(v) for v in bad[0])
        raise ValueError(f"qd0: {JOINTS[k]} = {qd[i, k]:.4g} rad/s (env {i}): at or above the runaway bound {L.RUNAWAY_RATE:g} rad/s")


def _schedule_value(name: str, s: Schedule, t: float, n: int, width: int | None = None) -> np.ndarray:
    v = s(t) if callable(s) else s
    arr = np.asarray(v, dtype=np.float64)
    shape = (n,) if width is None else (n, width)
    try:
        arr = np.broadcast_to(arr, shape)
    except ValueError:
        raise ValueError(f"{name}: value of shape {np.shape(v)} does not broadcast to {shape}") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: non-finite value at t = {t:.4f} s")
    return arr


def check_controls(controls: Mapping[str, Schedule] | None) -> dict[str, Schedule]:
    controls = dict(controls or {})
    unknown = [k for k in controls if k not in SURFACES]
    if unknown:
        raise ValueError(f"controls: unknown surface(s) {unknown}; valid names: {list(SURFACES)}")
    return controls


def check_static_controls(controls: Mapping[str, float], params: RigParams, field: str = "controls") -> dict[str, float]:
    """Constant surface deflections (deg) as floats, each finite and within its servos' travel: the Hawk's surfaces
    within ``servos.hawk.limit_deg``, the compensator's aileron, elevator and rudder such that every flap after
    mixing (flap i = aileron + e_i elevator + r_i rudder, signs +-1, :func:`rig_env.physics.aero.mix`) stays within
    ``servos.compensator.limit_deg``.  ValueError naming ``field`` otherwise: a deflection beyond the travel would
    be held at the stop by the servo model, so a trim or a branch at it would be one at the stop's angle."""
    from rig_env.physics.aero import mix

    out = {k: float(v) for k, v in check_controls(controls).items()}
    bad = [k for k, v in out.items() if not math.isfinite(v)]
    if bad:
        raise ValueError(f"{field}: {', '.join(f'{k} = {out[k]}' for k in bad)}: deflections must be finite (deg)")
    hawk = params.servos.hawk.limit_deg
    for k, v in out.items():
        if k.startswith("hawk_") and abs(v) > hawk:
            raise ValueError(f"{field}: {k} = {v:g} deg is beyond the servo's travel [-{hawk:g}, {hawk:g}] deg (servos.hawk.limit_deg)")
    comp = params.servos.compensator.limit_deg
    da, de, dr = (out.get(f"comp_{s}", 0.0) for s in ("aileron", "elevator", "rudder"))
    for i in range(4):
        flap = mix.py_func(da, de, dr, i)  # the kernels' mixing, run as Python (nothing compiled for a check)
        if abs(flap) > comp:
            raise ValueError(f"{field}: comp_aileron {da:g}, comp_elevator {de:g}, comp_rudder {dr:g} deg put flap {i + 1} at "
                             f"{flap:g} deg, beyond the servos' travel [-{comp:g}, {comp:g}] deg (servos.compensator.limit_deg)")
    return out


def fill_inputs(U: np.ndarray, t: float, controls: Mapping[str, Schedule], airspeed: Schedule, gust: Schedule | None,
                comp_gust: Schedule | None = None, distance: np.ndarray | None = None) -> None:
    """Inputs of every environment at time t: surface commands (deg -> rad), the Hawk's gust, airspeed and the
    compensator's gust.

    The compensator's gust: ``comp_gust`` at t when given; else, with ``distance`` (n,) m (the convection
    distance, :func:`rig_env.turbulence.convection_distance`), the Hawk's gust schedule at t - d / V (frozen
    turbulence, V the airspeed at t, at least ``turbulence.MIN_CONVECTION_SPEED``; a function of time is
    evaluated at each environment's delayed time, at 0 while that is negative: before the first d / V the
    compensator meets the gust of t = 0, as in the environments; a constant is its own delayed value);
    without ``distance``, the Hawk's gust at t.  Neither gust given: both stay as they are in U (zero).
    """
    n = U.shape[0]
    for k, name in enumerate(SURFACES):
        U[:, k] = np.radians(_schedule_value(f"controls[{name!r}]", controls[name], t, n)) if name in controls else 0.0
    if gust is not None:
        U[:, L.U_GUST : L.U_GUST + 3] = _schedule_value("gust", gust, t, n, 3)
    a = _schedule_value("airspeed", airspeed, t, n)
    if np.any((a < 0.0) | (a > 60.0)):
        raise ValueError(f"airspeed = {a.min():.3g}..{a.max():.3g} m/s is outside the allowed range [0, 60] m/s")
    U[:, L.U_AIRSPEED] = a
    comp = slice(L.U_GUST_COMP, L.U_GUST_COMP + 3)
    if comp_gust is not None:
        U[:, comp] = _schedule_value("comp_gust", comp_gust, t, n, 3)
    elif gust is not None and distance is not None and callable(gust):
        t_comp = np.maximum(t - distance / np.maximum(a, MIN_CONVECTION_SPEED), 0.0)
        for tc in np.unique(t_comp):  # one call per distinct delayed time (one, unless airspeed or geometry differ)
            rows = t_comp == tc
            U[rows, comp] = _schedule_value("gust", gust, float(tc), n, 3)[rows]
    elif gust is not None:
        U[:, comp] = U[:, L.U_GUST : L.U_GUST + 3]


def simulate(
    params: RigParams | Sequence[RigParams],
    q0,
    qd0,
    t_final: float,
    *,
    free_dofs: Sequence[str],
    controls: Mapping[str, Schedule] | None = None,
    airspeed: Schedule = 20.0,
    gust: Schedule | None = None,
    comp_gust: Schedule | None = None,
    gust_convection: bool = True,
    aero: bool = True,
    friction: bool = True,
    stops: bool = True,
    servo: bool = True,
    aero_model: str | None = None,
    nonlinear_aero: bool | None = None,
    formulation: str = "joint",
    control_rate: float = 80.0,
    physics_dt: float | None = None,
    overrides: Mapping[str, object] | None = None,
) -> SimResult:
    """Simulate the rig from (q0, qd0) for t_final seconds.

    q0, qd0: angles (rad) and rates (rad/s) of the free joints, shape (n_free,) or (n_envs, n_free);
    a last axis of 5 gives all joints (JOINTS order), from which locked joints take their angle.
    Physically impossible states are refused (:func:`check_initial_state`: a limited joint more than
    10 deg past its stops, locked or free; an unlimited one beyond 1e4 rad; a rate at the runaway bound).
    controls: surface name -> degrees (constant, (n_envs,) array, or function of time returning
    either), held over each control step.  airspeed: m/s (same forms).  gust: world-frame air
    velocity added to the tunnel flow at the Hawk, m/s, shape (3,) or (n_envs, 3) or a function of time.
    comp_gust: the same at the compensator (same forms); None (default): the Hawk's gust convected
    downstream (Taylor's frozen turbulence), the gust schedule at t - d / V with d the streamwise distance
    from the Hawk's c.g. to the compensator's aerodynamic reference (:func:`rig_env.turbulence.convection_distance`,
    1.18 m for the default rig: 0.059 s at 20 m/s) and V the airspeed at t; with ``gust_convection=False``
    the compensator meets the Hawk's gust at the same time (uniform gusts).  A function of time is called at
    the delayed times too, at 0 while they are negative (before d / V the compensator meets the gust of
    t = 0, as in the environments); a constant gust is the same at both.
    aero_model: "linear" (default: the stability derivatives of eq. 23), "tables" (the static high-incidence
    tables) or "unsteady" (the tables through the Hawk's flow-separation state, tau1 dx/dt + x = x0(alpha -
    tau2 alphadot), and the Hawk's wake at the compensator: docs/MODEL.md 3.1.1-3.1.2); nonlinear_aero=True
    is the older name of "tables".
    formulation: "joint" (fast joint-space model) or "dae" (the paper's body-coordinate DAE).
    control_rate: Hz; physics_dt: s, default the largest step <= 2.5 ms dividing the control step.  The run ends
    at the control step nearest t_final (a UserWarning says so when that is not t_final itself; ``result.t[-1]``).
    overrides: per-environment parameter overrides (see rig_env.param_batch).

    Initial servo state (the environments' convention, :meth:`rig_env.physics.pipeline.PhysicsBatch.reset`):
    the servos start in equilibrium with the commands of t = 0, as if those had been held since forever
    (at rest at the limited demand, the delay lines full of it), so a constant command holds from the
    start (a trim stays a trim) and a later change reaches the servos after their transport delay; with
    zero commands at t = 0 they start at rest at zero, as an environment's do at every reset.  "joint"
    runs the per-environment kernel (:func:`rig_env.physics.pipeline.choose_kernel`), "dae" the DAE kernel.
    """
    free = check_free_dofs(free_dofs)
    model = resolve_aero_model(aero_model, nonlinear_aero)
    if formulation not in ("joint", "dae"):
        raise ValueError(f"formulation = {formulation!r}; allowed: 'joint', 'dae'")
    if not (math.isfinite(t_final) and 0.0 < t_final <= 1e5):
        raise ValueError(f"t_final = {t_final} s is outside the allowed range (0, 1e5] s")
    controls = check_controls(controls)
    control_dt, h, n_sub = rates(control_rate, physics_dt)
    X, batched = initial_state(q0, qd0, free)
    n = X.shape[0]
    if not isinstance(params, RigParams) and not (isinstance(params, Sequence) and all(isinstance(p, RigParams) for p in params)):
        raise ParameterError("params must be a RigParams or a sequence of RigParams (one per environment)")
    P = param_batch(params, n, overrides)
    check_initial_state(X, P, stops)
    first = params if isinstance(params, RigParams) else params[0]
    tabs = first.tables()
    flags = flags_of(aero, friction, stops, servo, model)
    free_idx = np.array([JOINTS.index(j) for j in free], dtype=np.int64)
    n_t = int(round(t_final / control_dt)) + 1
    if n_t < 2:
        raise ValueError(f"t_final = {t_final:g} s is shorter than half a control step ({control_dt:g} s at {1.0 / control_dt:g} Hz): "
                         "nothing would be simulated")
    if abs((n_t - 1) * control_dt - t_final) > 1e-9 * max(1.0, t_final):
        warnings.warn(f"t_final = {t_final:g} s is not a whole number of control steps ({control_dt:g} s): the run ends at the "
                      f"nearest, {(n_t - 1) * control_dt:.10g} s (result.t[-1])", stacklevel=2)
    size = n_t * n * (L.N_STATE + 3) * 8  # the states, energies and residuals sampled, before the result's views
    if size > MAX_RESULT_BYTES:
        raise ValueError(f"t_final = {t_final:g} s: {n} environment(s) sampled at {1.0 / control_dt:g} Hz would need "
                         f"{size / 2**30:.1f} GiB for the result, more than {MAX_RESULT_BYTES / 2**30:g} GiB; shorten t_final, "
                         "run the environments in smaller batches or lower control_rate")
    batch = PhysicsBatch(P, tabs, free_idx, flags, h, n_sub, kind=formulation)
    U = batch.U
    distance = convection_distance(P) if gust_convection else None
    fill_inputs(U, 0.0, controls, airspeed, gust, comp_gust, distance)
    batch.reset(np.arange(n), X[:, L.X_Q : L.X_Q + 5], X[:, L.X_QD : L.X_QD + 5])  # servos at rest at the first command
    status = batch.status
    fail_time = np.full(n, np.nan)

    Xs = np.empty((n_t, n, L.N_STATE))
    E = np.empty((n_t, n))
    R = np.empty((n_t, n)) if formulation == "dae" else None

    def record(i: int) -> None:
        Xs[i] = batch.X
        batch.energy(E[i])
        if R is not None:
            batch.constraint_residual(R[i])

    record(0)
    for i in range(1, n_t):
        t_prev = (i - 1) * control_dt
        fill_inputs(U, t_prev, controls, airspeed, gust, comp_gust, distance)
        before = status.copy()
        batch.step()
        newly = (status != L.S_OK) & (before == L.S_OK)
        fail_time[newly] = i * control_dt
        record(i)
    if np.any(status != L.S_OK):
        bad = np.flatnonzero(status != L.S_OK)
        warnings.warn(
            f"simulate: {len(bad)} of {n} environment(s) blew up and were frozen (first: env {bad[0]}, "
            f"{STATUS_NAMES[int(status[bad[0]])]} at t = {fail_time[bad[0]]:.4f} s); see result.status",
            RuntimeWarning,
            stacklevel=2,
        )
    t = np.arange(n_t) * control_dt
    Xs = np.moveaxis(Xs, 1, 0)  # (n, n_t, N_STATE)
    E = E.T
    q_all = Xs[:, :, 0:5]
    qd_all = Xs[:, :, 5:10]
    out = dict(
        q=q_all[:, :, free_idx],
        qd=qd_all[:, :, free_idx],
        q_all=q_all,
        qd_all=qd_all,
        energy=E,
        flaps=np.degrees(Xs[:, :, L.X_SERVO : L.X_SERVO + 7]),
        z=Xs[:, :, L.X_Z : L.X_Z + 5],
        separation=Xs[:, :, L.X_SEP : L.X_SEP + L.N_SEP] if flags & L.F_UNSTEADY else None,
        wake=Xs[:, :, L.X_WAKE : L.X_WAKE + L.N_WAKE] if flags & L.F_UNSTEADY else None,
        constraint_residual=None if R is None else R.T,
    )
    if not batched:
        out = {k: (None if v is None else v[0]) for k, v in out.items()}
    return SimResult(
        t=t,
        status=status if batched else status[:1],
        fail_time=fail_time if batched else fail_time[:1],
        free_dofs=free,
        formulation=formulation,
        physics_dt=h,
        control_dt=control_dt,
        **out,
    )


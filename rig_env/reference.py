"""A stiff adaptive reference for validating the fixed-step joint-space integrator (one environment).

The state is ``y = [q (5), qd (5), z (5)]``: joint angles (rad), joint rates (rad/s) and LuGre bristle
deflections (rad), all in rig_env.JOINTS order.  Unlike :mod:`rig_env.physics.integrator`, which
advances the bristle ODE (eq. 19) by its exact frozen-rate solution on either side of each RK4 step
(Strang splitting), here eq. (19)

    dz/dt = v - sigma0 |v| z / S(v)

is part of one ODE system with the mechanics, integrated together by a stiff implicit method
(``scipy.integrate.solve_ivp``, Radau by default) at tight tolerances.  The servos are ideal (the
surfaces sit at the limited command, no delay, as ``simulate(..., servo=False)`` with constant
controls), and the accelerations come from the SAME numba kernel
(:func:`rig_env.physics.joint_space.accelerations`), so a disagreement measures integration error only.

:func:`simulate_scipy` samples the solution at the control rate with the shape conventions of
:func:`rig_env.simulate` for a single environment.  The benchmark peers (one environment, rtol 1e-6,
one solve_ivp call per env-step): :func:`env_steps_per_s_scipy_numpy` on the plain-numpy right-hand
side of :mod:`rig_env.numpy_model` (what a researcher would otherwise write) and
:func:`env_steps_per_s_scipy` on this module's compiled one.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numba import njit
from scipy.integrate import solve_ivp

from rig_env.params import JOINTS, SURFACES, RigParams
from rig_env.physics import friction as fr
from rig_env.physics import layout as L
from rig_env.physics import servo as sv
from rig_env.physics.joint_space import ATTACHED, accelerations
from rig_env.physics.pipeline import flags_of
from rig_env.simulate import check_controls, check_free_dofs, initial_state

_JIT = dict(cache=True, error_model="numpy", _nrt=False)

N_Y = 15  # q (5), qd (5), z (5)
# scratch layout of the work vector
_W_H = 0  # bias, 5
_W_Q = 5  # generalised forces, 5
_W_JV = 10  # Jacobian columns, 45
_W_QDD = 55  # accelerations, 5
_W_Y = 60  # one column of a vectorised call, 15
_W_O = 75  # its derivative, 15
N_WORK = 90
_SIGMA0 = L.P_FRICTION_RIG_ROLL_SIGMA0 - L.P_FRICTION_RIG_ROLL_FS  # offset in a joint's LuGre block


@njit(**_JIT)
def bristle_rate(p, j, v, z):
    """dz/dt of eq. (19) for joint j at rate v (rad/s) and bristle deflection z (rad)."""
    s0 = p[fr.FRICTION_BASE[j] + _SIGMA0]
    return v - s0 * abs(v) * z / fr.stribeck(p, j, v)


@njit(**_JIT)
def rhs_kernel(y, flaps, u, p, flags, free_idx, n_free, tabs, M, w, out):
    """dy/dt (15,) into out for y = [q, qd, z] (15,); locked joints have zero derivatives.

    flaps: (7,) servo positions, rad (rig_env.SERVOS order); u: (N_INPUTS,) inputs; p: (N_PARAMS,);
    M: (5, 5) and w: (N_WORK,) scratch.
    """
    q = y[0:5]
    qd = y[5:10]
    z = y[10:15]
    qdd = w[_W_QDD : _W_QDD + 5]
    accelerations(q, qd, z, ATTACHED, flaps, u, p, flags, free_idx, n_free, tabs, M, w[_W_H : _W_H + 5], w[_W_Q : _W_Q + 5], w[_W_JV : _W_JV + 45], qdd)
    for i in range(N_Y):
        out[i] = 0.0
    for a in range(n_free):
        j = free_idx[a]
        out[j] = qd[j]
        out[5 + j] = qdd[j]
        if flags & L.F_FRICTION:
            out[10 + j] = bristle_rate(p, j, qd[j], z[j])


@njit(**_JIT)
def rhs_columns(Y, flaps, u, p, flags, free_idx, n_free, tabs, M, w, OUT):
    """rhs_kernel on every column of Y (15, k) into OUT (15, k) (scipy's ``vectorized`` layout)."""
    y = w[_W_Y : _W_Y + N_Y]
    o = w[_W_O : _W_O + N_Y]
    for c in range(Y.shape[1]):
        for i in range(N_Y):
            y[i] = Y[i, c]
        rhs_kernel(y, flaps, u, p, flags, free_idx, n_free, tabs, M, w, o)
        for i in range(N_Y):
            OUT[i, c] = o[i]


def _flaps(u: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Ideal servos: each actuator at its limited demand (rad)."""
    return np.array([sv.limited(p, k, sv.demand(u, k)) for k in range(L.N_SERVOS)])


def continuous_rhs(
    t: float,
    y: np.ndarray,
    flaps: np.ndarray,
    u: np.ndarray,
    p: np.ndarray,
    flags: int,
    free_idx: np.ndarray,
    tabs: tuple,
    M: np.ndarray | None = None,
    w: np.ndarray | None = None,
) -> np.ndarray:
    """dy/dt of the continuous model for solve_ivp: y (15,) or (15, k) columns -> same shape.

    y = [q, qd, z] (rad, rad/s, rad; JOINTS order).  flaps (7,) rad, u (N_INPUTS,), p (N_PARAMS,),
    flags (layout.F_*), free_idx (n_free,) int64 joint indices, tabs from ``RigParams.tables()``;
    M (5, 5) and w (N_WORK,) optional scratch.  The model is autonomous: inputs are held constant.
    """
    if M is None:
        M = np.zeros((5, 5))
    if w is None:
        w = np.zeros(N_WORK)
    n_free = len(free_idx)
    if y.ndim == 1:
        out = np.empty(N_Y)
        rhs_kernel(np.ascontiguousarray(y), flaps, u, p, flags, free_idx, n_free, tabs, M, w, out)
        return out
    out = np.empty(y.shape)
    rhs_columns(y, flaps, u, p, flags, free_idx, n_free, tabs, M, w, out)
    return out


@dataclass(frozen=True)
class ReferenceResult:
    """Reference trajectory at the control rate (single environment, as ``rig_env.SimResult``).

    t: (n_t,) s.  q, qd: (n_t, n_free) rad, rad/s in ``free_dofs`` order; q_all, qd_all, z: (n_t, 5)
    all joints (z: bristle deflections, rad).  nfev: right-hand-side evaluations (columns).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_all: np.ndarray
    qd_all: np.ndarray
    z: np.ndarray
    free_dofs: tuple[str, ...]
    method: str
    nfev: int


def problem(
    params: RigParams,
    *,
    free_dofs: Sequence[str],
    controls: Mapping[str, float] | None = None,
    airspeed: float = 20.0,
    aero: bool = True,
    friction: bool = True,
    stops: bool = True,
) -> tuple:
    """The ``args`` tuple of :func:`continuous_rhs` for one environment with constant inputs."""
    if not isinstance(params, RigParams):
        raise TypeError("params must be a RigParams (the reference runs one environment)")
    free = check_free_dofs(free_dofs)
    controls = check_controls(controls)
    u = np.zeros(L.N_INPUTS)
    for name, value in controls.items():
        if not np.isscalar(value) or not np.isfinite(value):
            raise ValueError(f"controls[{name!r}]: the reference takes a finite constant (deg), got {value!r}")
        u[SURFACES.index(name)] = np.radians(float(value))
    if not (np.isfinite(airspeed) and 0.0 <= airspeed <= 60.0):
        raise ValueError(f"airspeed = {airspeed} m/s is outside the allowed range [0, 60] m/s")
    u[L.U_AIRSPEED] = airspeed
    p = params.to_vector()
    flags = flags_of(aero, friction, stops, False, False)
    free_idx = np.array([JOINTS.index(j) for j in free], dtype=np.int64)
    return (_flaps(u, p), u, p, flags, free_idx, params.tables(), np.zeros((5, 5)), np.zeros(N_WORK))


def simulate_scipy(
    params: RigParams,
    q0,
    qd0,
    t_final: float,
    *,
    free_dofs: Sequence[str],
    controls: Mapping[str, float] | None = None,
    airspeed: float = 20.0,
    aero: bool = True,
    friction: bool = True,
    stops: bool = True,
    method: str = "Radau",
    rtol: float = 1e-9,
    atol: float = 1e-11,
    control_rate: float = 80.0,
) -> ReferenceResult:
    """Integrate the continuous model (bristle ODE in the state) with ``solve_ivp`` from (q0, qd0), z = 0.

    q0, qd0: (n_free,) or (5,) as in :func:`rig_env.simulate` (single environment).  Samples at
    multiples of 1/control_rate up to t_final (solve_ivp's dense output).  Raises RuntimeError when
    the solver fails.
    """
    free = check_free_dofs(free_dofs)
    if np.ndim(q0) != 1:
        raise ValueError("simulate_scipy runs one environment: q0 must be 1-D")
    X, _ = initial_state(q0, qd0, free)
    args = problem(params, free_dofs=free, controls=controls, airspeed=airspeed, aero=aero, friction=friction, stops=stops)
    y0 = np.zeros(N_Y)
    y0[0:10] = X[0, 0:10]
    control_dt = 1.0 / control_rate
    n_t = int(round(t_final / control_dt)) + 1
    t = np.arange(n_t) * control_dt
    implicit = method in ("Radau", "BDF", "LSODA")
    sol = solve_ivp(continuous_rhs, (0.0, t[-1]), y0, method=method, t_eval=t, rtol=rtol, atol=atol, args=args, vectorized=implicit)
    if not sol.success:
        raise RuntimeError(f"simulate_scipy: solve_ivp({method}) failed: {sol.message}")
    Y = sol.y.T
    free_idx = args[4]
    return ReferenceResult(
        t=t,
        q=Y[:, free_idx],
        qd=Y[:, 5 + free_idx],
        q_all=Y[:, 0:5],
        qd_all=Y[:, 5:10],
        z=Y[:, 10:15],
        free_dofs=free,
        method=method,
        nfev=int(sol.nfev),
    )


def _benchmark_state() -> np.ndarray:
    """The peers' initial state: every joint within +-0.2 rad and +-0.5 rad/s (seed 0), bristles relaxed."""
    rng = np.random.default_rng(0)
    y = np.zeros(N_Y)
    y[0:5] = rng.uniform(-0.2, 0.2, 5)
    y[5:10] = rng.uniform(-0.5, 0.5, 5)
    return y


SEGMENT_ENV_STEPS = 80
"""Env-steps (12.5 ms each, 1 s of simulated time) that the solve_ivp peers time from
:func:`_benchmark_state`.  Their cost depends on the state (while the joints slide the LuGre bristles
are stiff; once the rig has come to rest, after about 20 s, an env-step costs a fraction), so every
peer integrates the same segment and the rate is whole env-steps over its wall time."""


def _env_steps_per_s(fun, args: tuple, env_steps: int, method: str, vectorized: bool, who: str) -> float:
    """Env-steps/s of ``solve_ivp(fun, (0, 12.5 ms), ...)`` calls, each from the previous end state,
    over the first ``env_steps`` env-steps from :func:`_benchmark_state` (after one discarded warm-up
    env-step: numba's cache load)."""
    if isinstance(env_steps, bool) or not isinstance(env_steps, (int, np.integer)) or env_steps < 1:
        raise ValueError(f"env_steps must be an integer >= 1, got {env_steps!r}")
    dt = 1.0 / 80.0

    def env_step(y: np.ndarray) -> np.ndarray:
        sol = solve_ivp(fun, (0.0, dt), y, method=method, rtol=1e-6, atol=1e-8, args=args, vectorized=vectorized)
        if not sol.success:
            raise RuntimeError(f"{who}: solve_ivp({method}) failed: {sol.message}")
        return sol.y[:, -1]

    env_step(_benchmark_state())
    y = _benchmark_state()
    t0 = time.perf_counter()
    for _ in range(env_steps):
        y = env_step(y)
    return env_steps / (time.perf_counter() - t0)


def env_steps_per_s_scipy(params: RigParams, env_steps: int = SEGMENT_ENV_STEPS, method: str = "Radau") -> float:
    """Env-steps/s of solve_ivp on rig_env's own compiled right-hand side (:func:`continuous_rhs`).

    One environment, all five joints free, aero at 20 m/s, friction, stops, ideal servos; each env-step
    (12.5 ms, inputs held) is one ``solve_ivp(continuous_rhs, ..., rtol=1e-6, atol=1e-8)`` call from
    the previous end state (``vectorized`` for the implicit methods), over the first ``env_steps``
    env-steps from the benchmark state (:data:`SEGMENT_ENV_STEPS`).  A researcher would not have this
    right-hand side: :func:`env_steps_per_s_scipy_numpy` is the peer the issue asks for.
    """
    implicit = method in ("Radau", "BDF", "LSODA")
    args = problem(params, free_dofs=JOINTS)
    return _env_steps_per_s(continuous_rhs, args, env_steps, method, implicit, "env_steps_per_s_scipy")


def env_steps_per_s_scipy_numpy(params: RigParams, env_steps: int = SEGMENT_ENV_STEPS, method: str = "Radau") -> float:
    """Env-steps/s of solve_ivp on the plain-numpy right-hand side (:func:`rig_env.numpy_model.rhs`).

    What a researcher would otherwise write: the same model, segment and protocol as
    :func:`env_steps_per_s_scipy` (rtol 1e-6, atol 1e-8, one call per 12.5 ms env-step) with the
    ordinary 1-D right-hand side (not ``vectorized``; the implicit methods form their Jacobian by
    finite differences).
    """
    from rig_env import numpy_model

    args = problem(params, free_dofs=JOINTS)[:6]  # flaps, u, p, flags, free_idx, tabs
    return _env_steps_per_s(numpy_model.rhs, args, env_steps, method, False, "env_steps_per_s_scipy_numpy")

"""Trim and linearisation of the joint-space model, through the same numba kernels that simulate it.

``trim`` finds joint angles at which the free joints are in equilibrium (zero rates, zero
accelerations) for given surface deflections and airspeed.  ``linearize`` differentiates the
accelerations by central differences about an operating point and returns a python-control
``StateSpace`` with named states ``<joint>`` (rad) and ``<joint>_rate`` (rad/s) and named inputs
(surface deflections in rad, servos taken as ideal: flap = mixed command).  Friction is left out of
the linear model by default: the LuGre law is not differentiable at rest; ``friction="viscous"``
keeps its viscous term sigma2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import control
import numpy as np
from numba import njit
from scipy.optimize import least_squares

from rig_env.params import JOINTS, SURFACES, RigParams
from rig_env.physics import layout as L
from rig_env.physics import servo as sv
from rig_env.physics.joint_space import accelerations
from rig_env.simulate import check_controls, check_free_dofs

COMP_INPUTS = ("comp_aileron", "comp_elevator", "comp_rudder")


@njit(cache=True, error_model="numpy")
def joint_accelerations(q, qd, u, p, flags, free_idx, tabs):
    """qdd (5,) for ideal servos (flaps = limited mixed demands of u), bristle states zero."""
    flaps = np.empty(7)
    for k in range(7):
        flaps[k] = sv.limited(p, k, sv.demand(u, k))
    z = np.zeros(5)
    M = np.empty((5, 5))
    h = np.empty(5)
    Q = np.empty(5)
    jv = np.empty(45)
    qdd = np.empty(5)
    accelerations(q, qd, z, flaps, u, p, flags, free_idx, free_idx.shape[0], tabs, M, h, Q, jv, qdd)
    return qdd


@dataclass(frozen=True)
class OperatingPoint:
    """An equilibrium: joint angles and rates (rad, rad/s, all five joints), inputs, residual."""

    q: np.ndarray
    qd: np.ndarray
    controls_deg: dict[str, float]
    airspeed: float
    free_dofs: tuple[str, ...]
    residual: float  # max |qdd| of the free joints at the solution, rad/s^2


def _inputs(controls_deg: Mapping[str, float], airspeed: float) -> np.ndarray:
    u = np.zeros(L.N_INPUTS)
    for k, name in enumerate(SURFACES):
        u[k] = np.radians(float(controls_deg.get(name, 0.0)))
    u[L.U_AIRSPEED] = airspeed
    return u


def _flags(aero: bool, friction: str | bool) -> int:
    return (L.F_AERO if aero else 0) | (L.F_FRICTION if friction == "viscous" else 0)


def trim(
    params: RigParams,
    *,
    free_dofs: Sequence[str],
    airspeed: float = 20.0,
    controls: Mapping[str, float] | None = None,
    q_guess: Sequence[float] | None = None,
    aero: bool = True,
    tol: float = 1e-10,
) -> OperatingPoint:
    """Equilibrium angles of the free joints (rates zero) for fixed surface deflections (deg).

    q_guess: all five joint angles (rad); locked joints stay at their guess.  Raises RuntimeError
    when no equilibrium with max |qdd| < 1e-6 rad/s^2 is found.
    """
    free = check_free_dofs(free_dofs)
    controls = {k: float(v) for k, v in check_controls(controls).items()}
    q0 = np.zeros(5) if q_guess is None else np.asarray(q_guess, dtype=np.float64)
    if q0.shape != (5,) or not np.all(np.isfinite(q0)):
        raise ValueError("q_guess: expected 5 finite joint angles (rad, JOINTS order)")
    if not (0.0 <= airspeed <= 60.0):
        raise ValueError(f"airspeed = {airspeed} m/s is outside the allowed range [0, 60] m/s")
    p = params.to_vector()
    tabs = params.tables()
    idx = np.array([JOINTS.index(j) for j in free], dtype=np.int64)
    u = _inputs(controls, airspeed)
    flags = _flags(aero, False)
    qd = np.zeros(5)

    def residual(y: np.ndarray) -> np.ndarray:
        q = q0.copy()
        q[idx] += y
        return joint_accelerations(q, qd, u, p, flags, idx, tabs)[idx]

    # solved for the change y from the guess, starting at y = 0: MINPACK's Levenberg-Marquardt sizes its
    # first step in proportion to the starting point's norm (100 |x0|, or 100 when x0 = 0), so a guess
    # of angles near 1e-17 rad (a trim of rounding-level asymmetry) would leave it no room to move
    sol = least_squares(residual, np.zeros(idx.size), xtol=tol, ftol=tol, gtol=tol, method="lm")
    q = q0.copy()
    q[idx] += sol.x
    res = float(np.max(np.abs(residual(sol.x))))
    if res > 1e-6:
        raise RuntimeError(f"trim: no equilibrium found for free_dofs={list(free)} (max |qdd| = {res:.3g} rad/s^2)")
    return OperatingPoint(q=q, qd=qd, controls_deg=controls, airspeed=float(airspeed), free_dofs=free, residual=res)


def linearize(
    params: RigParams,
    op: OperatingPoint,
    *,
    inputs: Sequence[str] = COMP_INPUTS,
    aero: bool = True,
    friction: str | bool = False,
    eps: float = 1e-6,
) -> control.StateSpace:
    """Continuous-time linear model x' = A x + B u about ``op``; x = (angles, rates) of the free joints.

    States are named ``<joint>`` and ``<joint>_rate``; inputs are the named surfaces in rad; the
    outputs are the states.
    """
    unknown = [n for n in inputs if n not in SURFACES]
    if unknown:
        raise ValueError(f"inputs: unknown surface(s) {unknown}; valid names: {list(SURFACES)}")
    if friction not in (False, "viscous"):
        raise ValueError("friction: allowed values are False and 'viscous'")
    free = op.free_dofs
    p = params.to_vector()
    tabs = params.tables()
    idx = np.array([JOINTS.index(j) for j in free], dtype=np.int64)
    n = len(idx)
    u0 = _inputs(op.controls_deg, op.airspeed)
    flags = _flags(aero, friction)

    def f(q: np.ndarray, qd: np.ndarray, u: np.ndarray) -> np.ndarray:
        return joint_accelerations(q, qd, u, p, flags, idx, tabs)[idx]

    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
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
    B = np.zeros((2 * n, len(inputs)))
    for b, name in enumerate(inputs):
        du = np.zeros(L.N_INPUTS)
        du[SURFACES.index(name)] = eps
        B[n:, b] = (f(op.q, op.qd, u0 + du) - f(op.q, op.qd, u0 - du)) / (2 * eps)
    states = [*free, *(f"{j}_rate" for j in free)]
    return control.ss(A, B, np.eye(2 * n), np.zeros((2 * n, len(inputs))), states=states, inputs=list(inputs), outputs=states)

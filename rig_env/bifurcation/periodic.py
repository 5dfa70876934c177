"""Periodic orbits born at a Hopf point: single shooting on a given flow, continued by pseudo-arclength, with Floquet multipliers.

Unknowns y = (x0, T, p): a point of the orbit, its period and the parameter.  Residual (n + 1 rows):

    phi(x0, T, p) - x0 = 0                      the orbit closes after T
    (x0 - x_ref) . f(x_ref, p_ref) = 0          phase: x0 on the plane through the last orbit's point
                                                x_ref normal to the flow there

with phi the flow map (the caller's integrator: for the rig, its own kernels).  Jacobian: dphi/dx0 (the
monodromy matrix at a converged orbit) and dphi/dp by central differences, all perturbed initial states
integrated as one batch; dphi/dT = f(phi(x0, T), p) exactly.  The branch starts from the Hopf point's
linear orbit x_H + a Re(v e^(i omega t)) (v the critical eigenvector): two orbits at amplitudes a and
2a along Re(v), with p free, give the first secant, then the curve solver of
:mod:`rig_env.bifurcation.core` continues it, the phase reference moving with every accepted orbit.
Floquet multipliers: the monodromy matrix's eigenvalues (read off the converged Jacobian, no further flow);
stable when all but the trivial one (the one nearest 1) lie inside the unit circle.

The family's own bifurcations (:class:`~rig_env.bifurcation.result.CyclePoint`), each a sign change of a
test function between two computed orbits, located on the arclength by :func:`~rig_env.bifurcation.core.locate`:

    fold of cycles      the tangent's parameter component (a multiplier through +1 where the family turns)
    period doubling     det(M + I) (a real multiplier through -1; complex pairs add |mu + 1|^2 > 0)
    torus               the product of |mu| - 1 over the complex multipliers (Im mu > 0, |arg mu| > 0.01: away
                        from the 1:1 resonance, where the trivial and the amplitude's multipliers may pair up
                        near the Hopf point), when both orbits have as many of them

The accuracy of the multipliers: M maps the flow's direction g onto itself at an exact orbit, so
|M g - g| / |g| (:func:`trivial_defect`) measures M's error; an orbit whose multipliers do not stand clear of
the unit circle by more than that (:func:`~rig_env.bifurcation.result.readable`) has no stability verdict
worth reading, and no period doubling or torus is located next to it (a fold of cycles is the curve's own
turning point and needs no multiplier).

The Hopf point's criticality (:func:`criticality`): on which side of the Hopf point the first orbit lies, the
side where the crossing pair is unstable (supercritical: the orbits are born attracting) or stable
(subcritical: born repelling).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from rig_env.bifurcation.core import Point, Settings, locate, null_vector, trace
from rig_env.bifurcation.equilibria import equilibrium_at
from rig_env.bifurcation.result import CyclePoint, OrbitBranch, SpecialPoint, readable

Flow = Callable[[np.ndarray, float, np.ndarray, int], np.ndarray]
"""``flow(X0 (m, n), T, P (m,), samples) -> (m, samples + 1, n)``: each row's state at t = k T / samples,
k = 0..samples, under parameter P[i] (non-finite rows where the integration failed)."""
BatchField = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""``f(X (m, n), P (m,)) -> (m, n)``: a vector field evaluated row by row."""


def rk4_flow(f: BatchField, steps_per_period: int = 400) -> Flow:
    """A :data:`Flow` by classical RK4 with ``steps_per_period`` equal steps over whatever T is asked for."""

    def flow(X0: np.ndarray, T: float, P: np.ndarray, samples: int) -> np.ndarray:
        n_steps = max(samples, steps_per_period) // samples * samples
        h = T / n_steps
        x = np.array(X0, dtype=np.float64)
        out = np.empty((x.shape[0], samples + 1, x.shape[1]))
        out[:, 0] = x
        for k in range(1, n_steps + 1):
            k1 = f(x, P)
            k2 = f(x + 0.5 * h * k1, P)
            k3 = f(x + 0.5 * h * k2, P)
            k4 = f(x + h * k3, P)
            x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            if k % (n_steps // samples) == 0:
                out[:, k // (n_steps // samples)] = x
        return out

    return flow


class Shooting:
    """The shooting residual and Jacobian in scaled unknowns z = (x0, T, p) / scale (the curve solver's ``fj``).

    A period outside (0, max_period] (where a Newton step has thrown it) is not integrated: the residual is NaN,
    which the correctors take as a failed step (a flow over T = 1e18 s would otherwise be asked for)."""

    def __init__(self, f: BatchField, flow: Flow, scale: np.ndarray, eps: float = 1e-6, max_period: float = math.inf) -> None:
        self.f, self.flow, self.scale, self.eps, self.max_period = f, flow, scale, eps, max_period
        self.n = scale.size - 2
        self.x_ref = np.zeros(self.n)
        self.g_ref = np.zeros(self.n)
        self.extra: list[tuple[np.ndarray, float]] = []  # further rows (a . y = c), for the first orbits

    def unpack(self, z: np.ndarray) -> tuple[np.ndarray, float, float]:
        y = z * self.scale
        return y[: self.n], float(y[self.n]), float(y[self.n + 1])

    def set_reference(self, x: np.ndarray, p: float) -> None:
        self.x_ref = x.copy()
        self.g_ref = self.f(x[None, :], np.array([p]))[0]

    def jacobian_parts(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """phi(x0, T, p), dphi/dx0, dphi/dT, dphi/dp at z (one batched flow of 2n + 3 rows)."""
        x, T, p = self.unpack(z)
        n = self.n
        if not (0.0 < T <= self.max_period and math.isfinite(p) and np.all(np.isfinite(x))):
            return np.full(n, np.nan), np.full((n, n), np.nan), np.full(n, np.nan), np.full(n, np.nan)
        hx = self.eps * (1.0 + np.abs(x))
        hp = self.eps * (1.0 + abs(p))
        X = np.repeat(x[None, :], 2 * n + 3, axis=0)
        P = np.full(2 * n + 3, p)
        for j in range(n):
            X[1 + 2 * j, j] += hx[j]
            X[2 + 2 * j, j] -= hx[j]
        P[-2] += hp
        P[-1] -= hp
        end = self.flow(X, T, P, 1)[:, -1]
        phi = end[0]
        M = np.empty((n, n))
        for j in range(n):
            M[:, j] = (end[1 + 2 * j] - end[2 + 2 * j]) / (2 * hx[j])
        dp = (end[-2] - end[-1]) / (2 * hp)
        dT = self.f(phi[None, :], np.array([p]))[0]
        return phi, M, dT, dp

    def monodromy(self, J: np.ndarray) -> np.ndarray:
        """The monodromy matrix dphi/dx0 from a Jacobian this object returned (scaled columns)."""
        n = self.n
        return J[:n, :n] / self.scale[None, :n] + np.eye(n)

    def __call__(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, _, _ = self.unpack(z)
        phi, M, dT, dp = self.jacobian_parts(z)
        n = self.n
        F = np.concatenate([phi - x, [(x - self.x_ref) @ self.g_ref]])
        J = np.zeros((n + 1, n + 2))
        J[:n, :n] = M - np.eye(n)
        J[:n, n] = dT
        J[:n, n + 1] = dp
        J[n, :n] = self.g_ref
        for a, c in self.extra:
            F = np.concatenate([F, [a @ (z * self.scale) - c]])
            J = np.vstack([J, a])
        return F, J * self.scale[None, :]


def _solve_square(fj: Shooting, z: np.ndarray, s: Settings) -> np.ndarray | None:
    """Newton on a square system (the shooting rows plus fj.extra), from z."""
    for _ in range(s.max_iter * 2):
        F, J = fj(z)
        if not (np.all(np.isfinite(F)) and np.all(np.isfinite(J))):
            return None
        try:
            dz = np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            return None
        z = z + dz
        if np.max(np.abs(dz)) < s.tol:
            return z
    return None


def trivial_defect(M: np.ndarray, g: np.ndarray) -> float:
    """|M g - g| / |g|, g the flow's direction at the orbit's point: zero for an exact monodromy matrix (the flow's
    direction is the trivial multiplier's eigenvector), so a measure of M's error.  It is large where the flow map
    is not smooth on the scale of the finite differences: an orbit through the tables' kinks under fixed-step RK4
    (an error in proportion to the step)."""
    return float(np.linalg.norm(M @ g - g) / np.linalg.norm(g))


def floquet(M: np.ndarray) -> tuple[np.ndarray, bool]:
    """Multipliers (sorted by decreasing modulus) and stability (all but the one nearest 1 inside the unit circle)."""
    mu = np.linalg.eigvals(M)
    mu = mu[np.argsort(-np.abs(mu))]
    rest = np.delete(mu, int(np.argmin(np.abs(mu - 1.0))))
    return mu, bool(np.all(np.abs(rest) < 1.0))


def _torus_test(mu: np.ndarray) -> tuple[int, float]:
    """The complex multipliers away from the 1:1 resonance (Im > 0, |arg| > 0.01) and the product of |mu| - 1 over them."""
    c = mu[(mu.imag > 0.0) & (np.abs(np.angle(mu)) > 0.01)]
    return int(c.size), float(np.prod(np.abs(c) - 1.0))


def criticality(f: BatchField, hopf: SpecialPoint, p_orbit: float, tol: float = 1e-9) -> str:
    """"supercritical" when the orbits born at ``hopf`` lie on the side of it where the equilibrium's crossing pair
    is unstable, "subcritical" when they lie where it is stable, "undetermined" when that pair's real part there
    is within ``tol`` (times 1 + omega) of zero (or the first orbit sits at the Hopf point itself).

    The pair's real part at the first orbit's parameter ``p_orbit``: the equilibrium there from the Hopf point's
    state (:func:`~rig_env.bifurcation.equilibria.equilibrium_at`), the eigenvalue of f_x nearest i omega.  This is
    the definition (via the first Lyapunov coefficient's sign and the crossing's direction) and needs no monodromy
    matrix, so it holds where the orbits' multipliers are not :func:`~rig_env.bifurcation.result.readable`."""
    eq = None if p_orbit == hopf.value else equilibrium_at(lambda x, p: f(x[None, :], np.array([p]))[0], hopf.state, p_orbit)
    if eq is None or not np.all(np.isfinite(eq[1])):
        return "undetermined"
    lam = np.linalg.eigvals(eq[1])
    re = float(lam[int(np.argmin(np.abs(lam - 1j * hopf.omega)))].real)
    if abs(re) <= tol * (1.0 + hopf.omega):
        return "undetermined"
    return "supercritical" if re > 0.0 else "subcritical"


def orbits(
    f: BatchField,
    flow: Flow,
    hopf: SpecialPoint,
    p_range: tuple[float, float],
    *,
    amplitude: float = 1e-2,
    x_scale: float | np.ndarray = 1.0,
    max_period: float | None = None,
    max_orbits: int = 60,
    samples: int = 200,
    settings: Settings | None = None,
) -> OrbitBranch:
    """The branch of periodic orbits from ``hopf`` (a :class:`SpecialPoint` of kind "hopf"), continued while
    the parameter stays in ``p_range`` and the period below ``max_period`` (default 20 Hopf periods).

    f, flow: the vector field row by row and its flow map (:data:`BatchField`, :data:`Flow`);
    amplitude: the first orbit's amplitude along Re(v) (state units), the second's twice that;
    max_orbits: computed orbits at most; samples: points per orbit for its extremes.
    """
    if hopf.kind != "hopf" or hopf.omega <= 0:
        raise ValueError("orbits: start from a Hopf point (kind 'hopf', omega > 0)")
    s = settings or Settings(ds=0.02, ds_max=0.1, tol=1e-9, max_points=max_orbits)
    n = hopf.state.size
    lo, hi = float(min(p_range)), float(max(p_range))
    T0 = hopf.period
    max_period = 20.0 * T0 if max_period is None else max_period
    scale = np.concatenate([np.broadcast_to(np.asarray(x_scale, dtype=np.float64), (n,)), [T0, hi - lo]])
    # the flow is refused beyond twice the largest period (a Newton step thrown far off), not at it: the curve must
    # still step past the largest period to end there with that reason
    sh = Shooting(f, flow, scale, max_period=2.0 * max_period)
    re, im = hopf.eigenvector.real, hopf.eigenvector.imag
    re_n = re / (re @ re)
    sh.x_ref, sh.g_ref = hopf.state.copy(), -im  # phase: (x0 - x_H) . Im(v) = 0 (the flow's direction at t = 0)
    found: list[np.ndarray] = []
    for a in (amplitude, 2 * amplitude):
        z = np.concatenate([hopf.state + a * re, [T0, hopf.value]]) / scale if not found else found[-1].copy()
        sh.extra = [(np.concatenate([re_n, [0.0, 0.0]]), re_n @ hopf.state + a)]
        z = _solve_square(sh, z, s)
        if z is None:
            raise RuntimeError(f"orbits: no periodic orbit of amplitude {a:g} found near the Hopf point at {hopf.value:g}")
        found.append(z)
    sh.extra = []
    d01 = float(np.linalg.norm(found[1] - found[0]))
    t = (found[1] - found[0]) / d01
    J0 = sh(found[0])[1]
    x1, _, p1 = sh.unpack(found[1])
    sh.set_reference(x1, p1)
    J1 = sh(found[1])[1]
    margin = 1e-12 * (hi - lo)

    def inside(z: np.ndarray) -> bool:
        _, T, p = sh.unpack(z)
        return lo - margin <= p <= hi + margin and 0 < T < max_period

    def extremes(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, T, p = sh.unpack(z)
        traj = flow(x[None, :], T, np.array([p]), samples)[0]
        return traj.min(axis=0), traj.max(axis=0)

    # a family that grows and shrinks back ends at another Hopf point: past it the curve would follow the
    # equilibrium as a zero-amplitude "orbit" of any period, which is no orbit at all.  Each orbit's extremes
    # (the widest state's peak-to-peak, against the first orbit's) are taken as the curve is traced, which
    # ends at the first orbit that has shrunk below half the first after growing past twice it
    first = Point(found[0], t, J0, 0.0, 0.0)
    seen = {id(z): extremes(z) for z in found}  # every orbit kept is here: the two found and each one trace accepts inside

    def width(z: np.ndarray) -> float:
        lo_z, hi_z = seen[id(z)]
        return float(np.max(hi_z - lo_z))

    size0 = width(found[0])
    shrank = "shrank back to an equilibrium (another Hopf point)"
    grown = width(found[1]) >= 2.0 * size0

    def shrunk(b: Point) -> str:
        nonlocal grown
        seen[id(b.y)] = extremes(b.y)
        a = width(b.y)
        grown = grown or a >= 2.0 * size0
        return shrank if grown and a < 0.5 * size0 else ""

    limit = s.max_points  # orbits at most, the first one (not traced) included
    pts, why = trace(sh, Point(found[1], null_vector(J1, t), J1, d01, d01), inside, dataclasses.replace(s, max_points=max(1, limit - 1)),
                     accepted=lambda b: sh.set_reference(*sh.unpack(b.y)[::2]), stop=shrunk)  # fmt: skip
    if why.startswith("stopped after max_points"):
        why = f"stopped after max_orbits = {limit} orbits"
    pts = [p for p in [first, *pts] if inside(p.y)][:limit]
    if why == shrank:
        pts = pts[:-1]  # the shrunk orbit itself
    if why == "left the parameter range":
        why = "left the parameter range or reached the largest period"
    rows = []
    G = f(np.array([sh.unpack(pt.y)[0] for pt in pts]).reshape(-1, n), np.array([sh.unpack(pt.y)[2] for pt in pts]))  # the flow's directions
    for pt, g in zip(pts, G):
        x, T, p = sh.unpack(pt.y)
        M = sh.monodromy(pt.J)
        mu, stable = floquet(M)
        rows.append((p, T, x, *seen[id(pt.y)], mu, stable, trivial_defect(M, g)))
    cols = list(zip(*rows)) if rows else [()] * 8
    errors = np.array(cols[7], dtype=float)
    return OrbitBranch(
        values=np.array(cols[0], dtype=float), periods=np.array(cols[1], dtype=float),
        initial_states=np.array(cols[2], dtype=float).reshape(-1, n), lower=np.array(cols[3], dtype=float).reshape(-1, n),
        upper=np.array(cols[4], dtype=float).reshape(-1, n), multipliers=np.array(cols[5], dtype=complex).reshape(-1, n),
        stable=np.array(cols[6], dtype=bool), hopf=hopf, end=why, multiplier_errors=errors,
        special_points=_cycle_points(sh, pts, cols[5], [readable(mu, e) for mu, e in zip(cols[5], errors)], s, extremes),
        criticality=criticality(f, hopf, float(cols[0][0])) if pts else "",
    )  # fmt: skip


def _cycle_points(sh: Shooting, pts: list[Point], multipliers: tuple[np.ndarray, ...], reliable: list[bool], s: Settings,
                  extremes: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]) -> tuple[CyclePoint, ...]:
    """The folds of cycles, period doublings and tori between consecutive orbits ``pts`` of a family, located (module
    docstring), given each orbit's ``multipliers``; period doublings and tori only between two orbits whose multipliers
    are ``reliable``."""
    n = sh.n
    tests: dict[str, Callable[[Point], float]] = {
        "cycle_fold": lambda pt: float(pt.t[-1]),
        "period_doubling": lambda pt: float(np.linalg.det(sh.monodromy(pt.J) + np.eye(n))),
        "torus": lambda pt: _torus_test(np.linalg.eigvals(sh.monodromy(pt.J)))[1],
    }
    tori = [_torus_test(mu) for mu in multipliers]
    g = [{"cycle_fold": float(pt.t[-1]), "period_doubling": tests["period_doubling"](pt), "torus": torus[1]} for pt, torus in zip(pts, tori)]
    found = []
    for i, (a, b) in enumerate(zip(pts, pts[1:])):
        for kind, test in tests.items():
            ga, gb = g[i][kind], g[i + 1][kind]
            if ga * gb >= 0.0 or (kind != "cycle_fold" and not (reliable[i] and reliable[i + 1])):
                continue
            if kind == "torus" and tori[i][0] != tori[i + 1][0]:
                continue
            sh.set_reference(*sh.unpack(a.y)[::2])  # the phase plane through the orbit the bracket starts at
            c = locate(sh, a, b, test, s, ga, gb)
            x, T, p = sh.unpack(c.y)
            lower, upper = extremes(c.y)
            found.append(CyclePoint(kind, p, T, x, lower, upper, floquet(sh.monodromy(c.J))[0], c.arclength))
    return tuple(found)

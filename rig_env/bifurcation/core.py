"""Pseudo-arclength continuation of the solutions of F(y) = 0, y = (u, p), and the equilibrium branches of x' = f(x, p).

The curve solver works on any smooth residual ``F: R^(k+1) -> R^k`` given with its Jacobian as one
callable ``fj(y) -> (F (k,), J (k, k+1))``; the last unknown is the parameter.  A step from a point
y_i with unit tangent t_i (the null vector of J(y_i), oriented as the previous one) predicts
y_i + ds t_i and corrects by Newton's method on

    F(y) = 0,   t_i . (y - y_i) - ds = 0

(Keller's pseudo-arclength condition), so the curve is followed through its turning points.  The
step ds adapts: halved after a failed corrector (or one whose correction exceeds the step: a jump to
another part of the curve; or a step whose parameter moved against the tangents at both its ends: a
pair of folds inside one step), grown by 1.5 after a corrector that needed at most three iterations,
within [ds_min, ds_max].  Where the corrector fails at every step down to 1000 ds_min (a corner of a
piecewise-smooth F, such as the linearly interpolated aerodynamic tables), the step is retried along the
null vector of the Jacobian a little ahead, the next piece's direction.  All of it happens in scaled unknowns y / scale, so that
angles in rad and a parameter in deg or m/s weigh alike in the arclength.

:func:`equilibria` applies it to F = f(x, p): stability from the eigenvalues of f_x at every point,
folds (sign change of the tangent's parameter component), Hopf points (a complex pair changing the
sign of its real part) and branch points (sign change of det f_x where the branch does not turn),
each located by the Illinois variant of regula falsi on the arclength to ``tol_s``, and the branch
sampled where it crosses the requested parameter values.  Generic: the rig is one user
(:mod:`rig_env.bifurcation.rig`); the tests run it on closed forms.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from rig_env.bifurcation.result import Branch, SpecialPoint

Residual = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
"""``fj(y) -> (F (k,), J (k, k+1))``: a residual and its Jacobian in the unknowns y = (u, p)."""
VectorField = Callable[[np.ndarray, float], np.ndarray]
"""``f(x (n,), p) -> (n,)``: the right-hand side of x' = f(x, p)."""


@dataclass(frozen=True)
class Settings:
    """Step control and tolerances of the curve solver (scaled units)."""

    ds: float = 0.02
    ds_min: float = 1e-7
    ds_max: float = 0.05
    tol: float = 1e-10  # Newton: max |F| (F's units) and max |dy| (scaled)
    max_iter: int = 12
    max_points: int = 5000
    tol_s: float = 1e-9  # location of special points and samples, arclength (scaled)


def null_vector(J: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """Unit null vector of the (k, k+1) matrix J (its last right singular vector), oriented along ``previous``."""
    t = np.linalg.svd(J)[2][-1]
    if previous is not None and t @ previous < 0:
        t = -t
    return t


def correct(fj: Residual, y_pred: np.ndarray, t: np.ndarray, s: Settings) -> tuple[np.ndarray, np.ndarray, int] | None:
    """Newton on F(y) = 0, t . (y - y_pred) = 0; returns (y, J(y), iterations) or None when it fails."""
    y = y_pred.copy()
    for it in range(1, s.max_iter + 1):
        F, J = fj(y)
        if not (np.all(np.isfinite(F)) and np.all(np.isfinite(J))):
            return None
        H = np.concatenate([F, [t @ (y - y_pred)]])
        try:
            dy = np.linalg.solve(np.vstack([J, t]), -H)
        except np.linalg.LinAlgError:
            return None
        y = y + dy
        if np.max(np.abs(dy)) < s.tol and np.max(np.abs(F)) < 1e3 * s.tol:
            F, J = fj(y)
            if np.max(np.abs(F)) < 1e3 * s.tol:
                return y, J, it
    return None


@dataclass
class Point:
    """A point of a traced curve (scaled unknowns): y, tangent t, Jacobian J, step ds that reached it, arclength."""

    y: np.ndarray
    t: np.ndarray
    J: np.ndarray
    ds: float
    arclength: float


def step_from(fj: Residual, a: Point, ds: float, s: Settings) -> Point | None:
    """The point at arclength ds from a (predictor along a's tangent, pseudo-arclength corrector)."""
    out = correct(fj, a.y + ds * a.t, a.t, s)
    if out is None:
        return None
    y, J, _ = out
    return Point(y, null_vector(J, a.t), J, ds, a.arclength + ds)


def trace(fj: Residual, start: Point, inside: Callable[[np.ndarray], bool], s: Settings,
          accepted: Callable[[Point], None] | None = None, stop: Callable[[Point], str] | None = None) -> tuple[list[Point], str]:
    """Follow the curve from ``start`` along its tangent while ``inside(y)``; returns the points and why it ended.

    The last point returned is the first one outside (the caller cuts the curve at the boundary).
    ``accepted(point)`` is called on every new point (e.g. to move a phase condition's reference); then
    ``stop(point)``, if given, on every new point inside: a non-empty string ends the curve there (that
    point the last returned) with that string as the reason.
    """
    pts = [start]
    ds = s.ds
    while len(pts) < s.max_points:
        a = pts[-1]
        out = correct(fj, a.y + ds * a.t, a.t, s)
        if out is None and ds < 1e3 * s.ds_min:
            b = _across_corner(fj, a, s)
            if b is not None:
                pts.append(b)
                if accepted is not None:
                    accepted(b)
                if not inside(b.y):
                    return pts, "left the parameter range"
                why = stop(b) if stop is not None else ""
                if why:
                    return pts, why
                ds = b.ds
                continue
        if out is None:
            ds *= 0.5
            if ds < s.ds_min:
                return pts, f"the corrector failed at the smallest step ({s.ds_min:g}) after {len(pts)} points"
            continue
        y, J, it = out
        t = null_vector(J, a.t)
        jumped = np.linalg.norm(y - (a.y + ds * a.t)) > max(ds, 1e3 * s.tol)  # a corrector that wandered off
        # the parameter moved against both tangents: two folds (a Z) inside one step, skipped unseen
        skipped = (y[-1] - a.y[-1]) * a.t[-1] < 0 and a.t[-1] * t[-1] > 0 and abs(y[-1] - a.y[-1]) > 1e3 * s.tol
        if jumped or skipped:
            ds *= 0.5
            if ds < s.ds_min:
                return pts, f"the corrector failed at the smallest step ({s.ds_min:g}) after {len(pts)} points"
            continue
        b = Point(y, t, J, ds, a.arclength + ds)
        pts.append(b)
        if accepted is not None:
            accepted(b)
        if not inside(y):
            return pts, "left the parameter range"
        why = stop(b) if stop is not None else ""
        if why:
            return pts, why
        if it <= 3:
            ds = min(1.5 * ds, s.ds_max)
    return pts, f"stopped after max_points = {s.max_points} points"


def _across_corner(fj: Residual, a: Point, s: Settings) -> Point | None:
    """A step over a corner of the curve (F only piecewise smooth, e.g. linearly interpolated tables), where the
    corrector fails however small the step: the direction beyond is the null vector of the Jacobian a little
    ahead (the next piece's), oriented to carry the state on as before; tried at a few step lengths."""
    for d in (1e-3, 3e-3, 1e-2, 3e-2):
        Jc = fj(a.y + d * a.t)[1]
        if not np.all(np.isfinite(Jc)):
            continue
        t2 = null_vector(Jc)
        if t2[:-1] @ a.t[:-1] < 0:
            t2 = -t2
        out = correct(fj, a.y + d * t2, t2, s)
        if out is not None and np.linalg.norm(out[0] - (a.y + d * t2)) <= d:
            return Point(out[0], null_vector(out[1], t2), out[1], d, a.arclength + d)
    return None


def locate(fj: Residual, a: Point, b: Point, test: Callable[[Point], float], s: Settings,
           ga: float | None = None, gb: float | None = None) -> Point:
    """The point of the curve between its neighbours a and b where ``test`` changes sign.

    The points between are parametrised by sigma along the chord c = (b - a) / |b - a|: the curve's
    intersection with the plane c . (y - a) = sigma (Newton from a + sigma c), sigma in [0, |b - a|];
    Illinois regula falsi on sigma until the bracket is shorter than ``tol_s``.  ga, gb: test(a), test(b)
    when already known.
    """
    chord = b.y - a.y
    hi = float(np.linalg.norm(chord))
    c = chord / hi
    lo = 0.0
    glo = test(a) if ga is None else ga
    ghi = test(b) if gb is None else gb
    best, side = (b if abs(ghi) <= abs(glo) else a), 0
    for _ in range(80):
        if hi - lo < s.tol_s:
            break
        m = hi - ghi * (hi - lo) / (ghi - glo) if ghi != glo else 0.5 * (lo + hi)
        if not (lo < m < hi):
            m = 0.5 * (lo + hi)
        out = correct(fj, a.y + m * c, c, s)
        if out is None:
            break
        p = Point(out[0], null_vector(out[1], a.t), out[1], m, a.arclength + m)
        best = p
        g = test(p)
        if g == 0.0:
            break
        if np.sign(g) == np.sign(glo):
            lo, glo = m, g
            if side == -1:
                ghi *= 0.5
            side = -1
        else:
            hi, ghi = m, g
            if side == 1:
                glo *= 0.5
            side = 1
    return best


def fd_jacobian(f: VectorField, x: np.ndarray, p: float, eps: float = 1e-6) -> np.ndarray:
    """(n, n+1) central-difference Jacobian [f_x | f_p] of f at (x, p); steps eps (1 + |value|)."""
    n = x.size
    J = np.empty((n, n + 1))
    for j in range(n + 1):
        h = eps * (1.0 + abs(x[j] if j < n else p))
        xp, xm = x.copy(), x.copy()
        pp = pm = p
        if j < n:
            xp[j] += h
            xm[j] -= h
        else:
            pp, pm = p + h, p - h
        J[:, j] = (f(xp, pp) - f(xm, pm)) / (2 * h)
    return J


def sorted_eigs(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues of A sorted by decreasing real part (then by imaginary part), with their eigenvectors (columns)."""
    lam, V = np.linalg.eig(A)
    order = np.lexsort((-lam.imag, -lam.real))
    return lam[order], V[:, order]

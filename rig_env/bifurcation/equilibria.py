"""Equilibrium branches of x' = f(x, p): pseudo-arclength continuation, stability, folds, Hopf and branch points.

:func:`equilibria` traces the curve f(x, p) = 0 from an equilibrium at the first requested value
towards the last (:mod:`rig_env.bifurcation.core`), then between consecutive points

* a **fold** where the tangent's parameter component changes sign (the branch turns; a real
  eigenvalue of f_x passes through zero there),
* a **branch point** where det f_x changes sign but the branch does not turn,
* a **Hopf point** where the number of complex eigenvalues with positive real part changes: the
  crossing pair (matched between the two points by proximity, opposite signs of the real part) is
  tracked and its real part located to zero,

and the sign changes of any user test functions (``events``), each located to the curve solver's
``tol_s``; and samples the branch where it crosses each requested
value (the state re-solved at exactly that value).  Stability: every eigenvalue of f_x with a negative
real part.  Jacobians by central differences unless ``jac`` is given.
"""

from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np

from rig_env.bifurcation.core import Point, Settings, VectorField, correct, fd_jacobian, locate, null_vector, sorted_eigs, trace
from rig_env.bifurcation.result import Branch, SpecialPoint

Jacobian = Callable[[np.ndarray, float], np.ndarray]
"""``jac(x, p) -> (n, n+1)``: [f_x | f_p]."""


def check_values(values: Sequence[float] | np.ndarray, name: str = "values") -> np.ndarray:
    """The requested parameter values as a float array: finite, at least two, not all equal."""
    v = np.asarray(values, dtype=np.float64).ravel()
    if v.size < 2 or not np.all(np.isfinite(v)) or v.max() == v.min():
        raise ValueError(f"{name}: expected at least two finite parameter values spanning a range, got {np.asarray(values)!r}")
    return v


class _Problem:
    """f in scaled unknowns z = (x, p) / scale, as the curve solver's ``fj``."""

    def __init__(self, f: VectorField, jac: Jacobian | None, scale: np.ndarray) -> None:
        self.f, self.jac, self.scale, self.n = f, jac, scale, scale.size - 1

    def xp(self, z: np.ndarray) -> tuple[np.ndarray, float]:
        y = z * self.scale
        return y[: self.n], float(y[self.n])

    def __call__(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, p = self.xp(z)
        J = self.jac(x, p) if self.jac is not None else fd_jacobian(self.f, x, p)
        return np.asarray(self.f(x, p), dtype=np.float64), J * self.scale[None, :]

    def fx(self, pt: Point) -> np.ndarray:
        """f_x at a point, unscaled."""
        return pt.J[:, : self.n] / self.scale[None, : self.n]

    def solve_at(self, z: np.ndarray, s: Settings) -> Point | None:
        """The equilibrium at z's parameter value (Newton from z with p held)."""
        e = np.zeros(self.n + 1)
        e[self.n] = 1.0
        out = correct(self, z, e, s)
        if out is None:
            return None
        return Point(out[0], null_vector(out[1]), out[1], 0.0, 0.0)


def equilibrium_at(f: VectorField, x_guess: np.ndarray, p: float, settings: Settings | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """The equilibrium of x' = f(x, p) nearest ``x_guess`` at the parameter p held (Newton, central-difference
    Jacobian) and f_x there, or None when Newton fails."""
    x0 = np.asarray(x_guess, dtype=np.float64)
    prob = _Problem(f, None, np.ones(x0.size + 1))
    pt = prob.solve_at(np.concatenate([x0, [p]]), settings or Settings())
    return None if pt is None else (pt.y[: prob.n], prob.fx(pt))


def _hopf_count(lam: np.ndarray, im_tol: float) -> int:
    c = lam[lam.imag > im_tol]
    return int(np.sum(c.real > 0))


def _crossing_pair(la: np.ndarray, lb: np.ndarray, im_tol: float) -> complex | None:
    """The eigenvalue (Im > 0) at a whose nearest partner at b has a real part of the other sign."""
    ca, cb = la[la.imag > im_tol], lb[lb.imag > im_tol]
    best, score = None, np.inf
    for x in ca:
        if cb.size == 0:
            break
        y = cb[np.argmin(np.abs(cb - x))]
        if np.sign(x.real) != np.sign(y.real) and abs(x.real) + abs(y.real) < score:
            best, score = x, abs(x.real) + abs(y.real)
    return best


def equilibria(
    f: VectorField,
    x0: Sequence[float] | np.ndarray,
    values: Sequence[float] | np.ndarray,
    *,
    jac: Jacobian | None = None,
    state_names: Sequence[str] | None = None,
    state_units: Sequence[str] | None = None,
    parameter: str = "p",
    parameter_unit: str = "",
    x_scale: float | Sequence[float] = 1.0,
    start: float | None = None,
    domain: Callable[[np.ndarray], bool] | None = None,
    events: Mapping[str, Callable[[np.ndarray], float]] | None = None,
    settings: Settings | None = None,
) -> Branch:
    """The equilibrium branch of x' = f(x, p) through the equilibrium near x0 at p = ``start``, over the range of ``values``.

    f: ``f(x (n,), p) -> (n,)``; x0: a guess of the equilibrium at p = start (default values[0]; Newton
    from x0 with p fixed); the branch is traced from there towards values[-1] and, when start is not
    values[0], towards values[0] too, and joined, so that it runs in the order values[0] -> values[-1];
    values: the parameter range (its minimum and maximum) and the output sampling (the branch is
    sampled wherever it crosses one of them); jac: ``jac(x, p) -> (n, n+1)`` [f_x | f_p] (default:
    central differences); x_scale: the states' scale in the arclength (the parameter's is its range);
    domain: ``domain(x) -> bool``, the states the branch may visit (the trace ends at the first point
    outside, with a note); events: named test functions ``g(x) -> float`` of the state, each sign change
    along the branch located like a bifurcation and listed in ``special_points`` with the event's name
    as its kind (e.g. a joint reaching a stop).
    Returns a :class:`~rig_env.bifurcation.result.Branch` (no orbits; :func:`rig_env.bifurcation.periodic.orbits`
    continues them from its Hopf points).  ValueError when Newton finds no equilibrium near x0.
    """
    s = settings or Settings()
    v = check_values(values)
    x0 = np.asarray(x0, dtype=np.float64).ravel()
    n = x0.size
    names = tuple(state_names) if state_names is not None else tuple(f"x{i}" for i in range(n))
    units = tuple(state_units) if state_units is not None else ("",) * n
    if len(names) != n or len(units) != n:
        raise ValueError(f"state_names/state_units: expected {n} entries")
    lo, hi = float(v.min()), float(v.max())
    scale = np.concatenate([np.broadcast_to(np.asarray(x_scale, dtype=np.float64), (n,)), [hi - lo]])
    prob = _Problem(f, jac, scale)
    p0 = float(v[0]) if start is None else float(start)
    if not lo <= p0 <= hi:
        raise ValueError(f"start = {p0:g}: outside the range of values [{lo:g}, {hi:g}]")
    z0 = np.concatenate([x0, [p0]]) / scale
    first = prob.solve_at(z0, s)
    if first is None:
        raise ValueError(f"equilibria: Newton found no equilibrium near x0 = {x0} at {parameter} = {p0:g}")
    forward = 1.0 if v[-1] > v[0] else -1.0
    t = first.t if first.t[n] * forward >= 0 else -first.t
    margin = 1e-12 * (hi - lo)

    def in_range(z: np.ndarray) -> bool:
        return lo - margin <= z[n] * scale[n] <= hi + margin

    def inside(z: np.ndarray) -> bool:
        return in_range(z) and (domain is None or domain(z[:n] * scale[:n]))

    def why_note(pts: list[Point], why: str, towards: float) -> list[str]:
        end = pts[-1].y
        if why.startswith("left") and not in_range(end):
            return []
        if why.startswith("left"):
            x, p = prob.xp(end)
            why = f"the state left the domain at {parameter} = {p:.6g} {parameter_unit}".rstrip()
        return [f"continuation towards {parameter} = {towards:g}: {why}"]

    pts, why = trace(prob, Point(first.y, t, first.J, 0.0, 0.0), inside, s)
    notes = why_note(pts, why, float(v[-1]))
    if p0 != v[0]:  # started inside the range: the part of the branch towards values[0] as well
        back, why = trace(prob, Point(first.y, -t, first.J, 0.0, 0.0), inside, s)
        notes += why_note(back, why, float(v[0]))
        back = [Point(b.y, -b.t, b.J, b.ds, -b.arclength) for b in back[:0:-1]]
        pts = back + pts
    eig = [sorted_eigs(prob.fx(p))[0] for p in pts]
    im_tol = 1e-7 * (1.0 + max(float(np.max(np.abs(e))) for e in eig))
    special: list[tuple[Point, SpecialPoint]] = []
    for i in range(len(pts) - 1):
        a, b = pts[i], pts[i + 1]
        if np.sign(a.t[n]) != np.sign(b.t[n]) and a.t[n] != 0.0:
            c = locate(prob, a, b, lambda q: q.t[n], s)
            special.append((c, _special(prob, c, "fold", im_tol)))
        elif np.sign(np.linalg.det(prob.fx(a))) != np.sign(np.linalg.det(prob.fx(b))):
            c = locate(prob, a, b, lambda q: np.linalg.det(prob.fx(q)), s)
            special.append((c, _special(prob, c, "branch_point", im_tol)))
        for name, g in (events or {}).items():
            ga, gb = g(prob.xp(a.y)[0]), g(prob.xp(b.y)[0])
            if np.sign(ga) != np.sign(gb):
                c = locate(prob, a, b, lambda q, g=g: g(prob.xp(q.y)[0]), s, ga, gb)
                special.append((c, _special(prob, c, name, im_tol)))
        if _hopf_count(eig[i], im_tol) != _hopf_count(eig[i + 1], im_tol):
            lam = _crossing_pair(eig[i], eig[i + 1], im_tol)
            if lam is None:
                continue
            ref = [lam]

            def test(q: Point) -> float:
                e = np.linalg.eigvals(prob.fx(q))
                e = e[e.imag > 0] if np.any(e.imag > 0) else e
                ref[0] = e[np.argmin(np.abs(e - ref[0]))]
                return float(ref[0].real)

            c = locate(prob, a, b, test, s)
            special.append((c, _special(prob, c, "hopf", im_tol, ref[0])))
    special = [(c, sp) for c, sp in special if inside(c.y)]
    # the located points split their brackets, so that a bracket holding a fold is sampled on both sides of it
    samples = _samples(prob, sorted(pts + [c for c, _ in special], key=lambda p: p.arclength), v, s, inside)
    pts = [p for p in pts if inside(p.y)]
    curve = sorted(pts + [c for c, _ in special], key=lambda p: p.arclength)
    xs = np.array([prob.xp(p.y)[0] for p in samples]).reshape(-1, n)
    lam_s = np.array([sorted_eigs(prob.fx(p))[0] for p in samples]).reshape(-1, n)
    lam_c = [sorted_eigs(prob.fx(p))[0] for p in curve]
    return Branch(
        parameter=parameter, parameter_unit=parameter_unit,
        values=np.array([prob.xp(p.y)[1] for p in samples]), states=xs,
        stable=np.all(lam_s.real < 0, axis=1), eigenvalues=lam_s, state_names=names, state_units=units,
        curve_values=np.array([prob.xp(p.y)[1] for p in curve]),
        curve_states=np.array([prob.xp(p.y)[0] for p in curve]).reshape(-1, n),
        curve_stable=np.array([bool(np.all(e.real < 0)) for e in lam_c]),
        special_points=tuple(sp for _, sp in sorted(special, key=lambda c: c[0].arclength)), notes=tuple(notes),
    )  # fmt: skip


def _special(prob: _Problem, c: Point, kind: str, im_tol: float, lam: complex | None = None) -> SpecialPoint:
    x, p = prob.xp(c.y)
    e, V = sorted_eigs(prob.fx(c))
    if kind == "hopf":
        k = int(np.argmin(np.abs(e - lam)))
        k = k if e[k].imag > 0 else int(np.argmin(np.abs(e - np.conj(lam))))
    else:
        k = int(np.argmin(np.abs(e)))
    vec = V[:, k]
    vec = vec / vec[np.argmax(np.abs(vec))]
    return SpecialPoint(kind=kind, value=p, state=x, eigenvalues=e, omega=abs(float(e[k].imag)) if kind == "hopf" else 0.0,
                        eigenvector=vec, arclength=c.arclength)


def _samples(prob: _Problem, pts: list[Point], v: np.ndarray, s: Settings, inside: Callable[[np.ndarray], bool]) -> list[Point]:
    """Points of the curve at each crossing of the requested values, in the order of the curve."""
    n = prob.n
    out: list[Point] = []
    ps = [p.y[n] * prob.scale[n] for p in pts]
    for i in range(len(pts) - 1):
        a, b = pts[i], pts[i + 1]
        pa, pb = ps[i], ps[i + 1]
        lo_, hi_ = min(pa, pb), max(pa, pb)
        hits = v[(v >= lo_) & (v <= hi_)]
        if i > 0:
            hits = hits[hits != pa]  # counted as the previous bracket's end
        hits = np.sort(hits) if pb >= pa else np.sort(hits)[::-1]
        for val in hits:
            if val == pa:
                c = a
            else:
                c = locate(prob, a, b, lambda q, val=val: q.y[n] * prob.scale[n] - val, s, pa - val, pb - val)
            z = c.y.copy()
            z[n] = val / prob.scale[n]
            exact = prob.solve_at(z, s)
            if exact is not None:
                c = Point(exact.y, c.t, exact.J, c.ds, c.arclength)
            if inside(c.y):
                out.append(c)
    return out

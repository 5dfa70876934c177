"""Output-error maximum likelihood: the model simulated open loop from each record's inputs, its outputs
matched to the measured ones by Gauss-Newton with Levenberg-Marquardt damping and bounds.

Cost (per record r, measurement noise covariance R_r, residuals v_k = z_k - y_k(p)):

    J(p) = 1/2 sum_r sum_k v_k' R_r^-1 v_k,    R_r = diag(1/N sum_k v_k v_k')   (re-estimated each iteration)

which with R at its estimate is the negative log-likelihood ``1/2 sum_r N_r ln det R_r`` up to a constant.
Step: ``(F + lambda diag F) dp = g`` with ``F = sum S' R^-1 S`` and ``g = sum S' R^-1 v``; a step that
does not lower J (at the iteration's R) is retried with lambda x 10, an accepted one divides it by 10.
Parameters leave their bounds never: a step is clipped to them.  Converged when an accepted step lowers
moves no parameter by more than 2 % of its standard error (``STEP_TOL``: far inside the estimate's
uncertainty, and above the finite-difference sensitivities' noise), or moves none by more than 20 % of
its standard error while lowering J by less than ``COST_TOL`` = 0.01 (moving one parameter by one standard
error raises J by 0.5) or by less than ``tol`` relatively.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from rig_env.sysid.covariance import coloured_middle, covariances, fisher_information
from rig_env.sysid.problem import Evaluation, Problem

STEP_TOL = 0.02  # converged when no parameter moves by more than this many standard errors
COST_TOL = 0.01  # ... or, moving none by 10 STEP_TOL, when J falls by less than this (one standard error costs 0.5)
VAR_FLOOR = 1e-18  # rad^2, smallest noise variance (a noise-free record would otherwise give R = 0)


@dataclass
class Solution:
    """What a solver returns: the estimate p, its covariances (white and coloured-corrected), the final
    evaluation, the noise covariances per record, and how it ended."""

    p: np.ndarray
    cov_white: np.ndarray
    cov: np.ndarray
    evaluation: Evaluation
    residuals: list[np.ndarray]
    noise: list[np.ndarray]
    cost_history: list[float]
    iterations: int
    converged: bool
    message: str
    extra: dict


def residuals_of(problem: Problem, ev: Evaluation) -> list[np.ndarray]:
    return [m.z - y for m, y in zip(problem.models, ev.Y)]


def noise_of(V: list[np.ndarray]) -> list[np.ndarray]:
    """Diagonal ML noise covariance per record from its residuals."""
    return [np.diag(np.maximum(np.mean(v * v, axis=0), VAR_FLOOR)) for v in V]


def cost_of(V: list[np.ndarray], R: list[np.ndarray]) -> float:
    return float(sum(0.5 * np.sum(v * v / np.diag(Ri)[None, :]) for v, Ri in zip(V, R)))


def output_error(problem: Problem, p0: np.ndarray, *, max_iter: int = 30, tol: float = 1e-6,
                 progress: Callable[[str], None] | None = None) -> Solution:
    """Fit ``problem`` from ``p0`` by output error (see the module docstring)."""
    say = progress or (lambda s: None)
    p = problem.clip(np.asarray(p0, dtype=np.float64))
    say("output error: sensitivities at the start values (the first fit in a fresh installation compiles the model's "
        "kernels once, a minute or two; numba caches them on disk)")
    ev = problem.evaluate(p, sensitivities=True)
    if not ev.ok:
        raise FloatingPointError("output error: the model blows up at the start values; check them and the records' configuration")
    problem.check_identifiable(ev)
    lam = 1e-3
    history: list[float] = []
    converged, message = False, "maximum number of iterations reached"
    it = 0
    for it in range(1, max_iter + 1):
        V = residuals_of(problem, ev)
        R = noise_of(V)
        J = cost_of(V, R)
        history.append(float(sum(0.5 * m.n_t * np.sum(np.log(np.diag(r))) for m, r in zip(problem.models, R))))
        F = sum(fisher_information(S, r) for S, r in zip(ev.S, R))
        g = sum(np.einsum("kip,ij,kj->p", S, np.linalg.inv(r), v) for S, r, v in zip(ev.S, R, V))
        d = np.diag(F).copy()
        d[d <= 0.0] = 1.0
        accepted = False
        for _ in range(12):
            try:
                dp = np.linalg.solve(F + lam * np.diag(d), g)
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            trial = problem.clip(p + dp)
            ev_t = problem.evaluate(trial, sensitivities=False)
            if ev_t.ok:
                J_t = cost_of(residuals_of(problem, ev_t), R)
                if J_t < J:
                    accepted = True
                    break
            lam *= 10.0
        if not accepted:
            converged, message = True, "no step lowers the cost further (converged to the solver's precision)"
            break
        step = trial - p
        p = trial
        lam = max(lam / 10.0, 1e-9)
        sd = np.sqrt(np.clip(np.diag(np.linalg.pinv(F, hermitian=True)), 1e-300, None))
        rel = (J - J_t) / max(J, 1e-300)
        say(f"output error: iteration {it}: -log-likelihood {history[-1]:.6g}, weighted cost {J_t:.6g} (was {J:.6g}), "
            f"largest step {np.max(np.abs(step) / sd):.3g} standard errors, lambda {lam:.1e}")
        ev = problem.evaluate(p, sensitivities=True)
        if not ev.ok:
            raise FloatingPointError("output error: the model blew up at an accepted estimate")
        small = np.max(np.abs(step) / sd) < 10 * STEP_TOL
        if np.max(np.abs(step) / sd) < STEP_TOL or (small and (rel < tol or J - J_t < COST_TOL)):
            converged, message = True, f"converged: largest step {np.max(np.abs(step) / sd):.2g} standard errors, relative cost change {rel:.2e}"
            break
    V = residuals_of(problem, ev)
    R = noise_of(V)
    F = sum(fisher_information(S, r) for S, r in zip(ev.S, R))
    middles = [coloured_middle(S, v, r) for S, v, r in zip(ev.S, V, R)]
    cw, cc = covariances(F, middles)
    return Solution(p, cw, cc, ev, V, R, history, it, converged, message, {})

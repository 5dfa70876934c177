"""Filter-error maximum likelihood: output error with a Kalman filter in the loop, for records with process
noise (turbulence), the paper's method.

The model (the environments' nonlinear rig) predicts each sample from the corrected state of the one
before; a steady-state Kalman gain corrects the free joints' angles and rates with the innovation:

    x_k^- = f(x_(k-1)^+, u_(k-1); p)        nu_k = z_k - y(x_k^-)        x_k^+ = x_k^- + K nu_k

x: the free joints' angles and rates (the LuGre bristles and the servos are carried by the model, not
corrected).  K comes from the discrete algebraic Riccati equation of the model linearised over one
sample interval about the record's first sample (central differences of the same kernel, friction off:
the LuGre pre-sliding spring is a small-signal artefact there), with process noise entering the joint
accelerations, ``Q = diag(0, F^2 dt)`` (F: rad/s^2 per free joint, estimated), and measurement noise
``R = diag(r)`` (estimated).  The innovations' covariance is ``B = C P C' + R``.  Negative log-likelihood
per record, minimised over the model parameters, log F and log sqrt r together by Gauss-Newton with the
exact Fisher information of Gaussian innovations:

    L = 1/2 sum_k nu_k' B^-1 nu_k + N/2 ln det B
    F_ij = sum_k dnu_i' B^-1 dnu_j + N/2 tr(B^-1 dB_i B^-1 dB_j)

Sensitivities are central differences, one batch per record: each perturbed parameter set runs its own
filter (its own gain).  Records are fitted jointly with one process-noise level per joint and their own
measurement noise; initial states are the records' first samples (the filter forgets them).
"""

from __future__ import annotations

import math
from typing import Callable, Mapping

import numpy as np

from rig_env import riccati
from rig_env.physics import layout as L
from rig_env.sysid.output_error import STEP_TOL, Solution
from rig_env.sysid.problem import Evaluation, Problem

LIN_STEP = 1e-5  # rad, rad/s: linearisation step


def _linear_map(model, rows: np.ndarray, x0: np.ndarray) -> np.ndarray:
    """(m, 2n, 2n) one-sample transition matrices of the free joints' angles and rates, per parameter row."""
    n2 = 2 * model.n_free
    m = rows.shape[0]
    R = np.repeat(rows, 2 * n2, axis=0)
    X0 = np.repeat(x0[None, :], m * 2 * n2, axis=0)
    for i in range(m):
        for j in range(n2):
            X0[i * 2 * n2 + 2 * j, j] += LIN_STEP
            X0[i * 2 * n2 + 2 * j + 1, j] -= LIN_STEP
    flags = model.flags & ~L.F_FRICTION & ~L.F_STOPS
    b = model.batch(R, X0, flags=flags)
    b.U[:] = model.U[0]
    b.step()
    out = np.empty((m * 2 * n2, n2))
    out[:, : model.n_free] = b.X[:, model.free_idx]
    out[:, model.n_free :] = b.X[:, L.X_QD + model.free_idx]
    out = out.reshape(m, n2, 2, n2)
    Phi = (out[:, :, 0, :] - out[:, :, 1, :]) / (2 * LIN_STEP)  # (m, j = perturbed state, i = result)
    return np.transpose(Phi, (0, 2, 1))


def _gains(Phi: np.ndarray, C: np.ndarray, Fstd: np.ndarray, r: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Steady-state gains K (m, 2n, n_out) and innovation covariances B (m, n_out, n_out)."""
    m, n2, _ = Phi.shape
    n = n2 // 2
    n_out = C.shape[0]
    K = np.empty((m, n2, n_out))
    B = np.empty((m, n_out, n_out))
    for i in range(m):
        Q = np.zeros((n2, n2))
        Q[n:, n:] = np.diag(Fstd[i] ** 2 * dt)
        Q += 1e-14 * np.eye(n2)
        Rm = np.diag(r[i])
        P = riccati.solve_are(Phi[i].T, C.T, Q, Rm, discrete=True, what="filter-error Kalman gain")
        Bi = C @ P @ C.T + Rm
        B[i] = 0.5 * (Bi + Bi.T)
        K[i] = P @ C.T @ np.linalg.inv(B[i])
    return K, B


class _Filter:
    """The filter-error problem: model parameters (the Problem's first k), then log F per joint, then log sqrt r per record and output."""

    def __init__(self, problem: Problem, process_noise: Mapping[str, float] | None) -> None:
        self.pb = problem
        joints: list[str] = []
        for m in problem.models:
            for j in m.record.free_dofs:
                if j not in joints:
                    joints.append(j)
        self.joints = joints
        pn = dict(process_noise or {})
        bad = [j for j in pn if j not in joints]
        if bad:
            raise ValueError(f"process_noise: {bad} are not free joints of the records ({joints})")
        k = problem.k
        names = list(problem.names[:k])
        start = list(problem.p0[:k])
        lower, upper = list(problem.lower[:k]), list(problem.upper[:k])
        self.f_slice = slice(len(names), len(names) + len(joints))
        for j in joints:
            v = float(pn.get(j, 0.5))
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"process_noise[{j!r}] = {v}: must be a positive std, rad/s^2")
            names.append(f"process_noise.{j}")
            start.append(math.log(v))
            lower.append(math.log(1e-8))
            upper.append(math.log(1e4))
        self.r_slices = []
        for m, rn in zip(problem.models, problem.record_names):
            a = len(names)
            v = np.maximum(np.std(np.diff(m.z, axis=0), axis=0) / math.sqrt(2.0), 1e-6)
            for o, s in zip(m.outputs, v):
                names.append(f"noise.{rn}.{o}")
                start.append(math.log(float(s)))
                lower.append(math.log(1e-9))
                upper.append(math.log(10.0))
            self.r_slices.append(slice(a, len(names)))
        self.names = tuple(names)
        self.p0 = np.array(start)
        self.lower = np.array(lower)
        self.upper = np.array(upper)
        self.n_p = len(names)

    def steps(self, p: np.ndarray) -> np.ndarray:
        st = np.full(self.n_p, 1e-3)
        st[: self.pb.k] = self.pb.pset.steps(p[: self.pb.k])
        return st

    def evaluate(self, p: np.ndarray, sensitivities: bool):
        """Per record: innovations (n_t, n_out), dnu/dp (n_t, n_out, n_p), B, dB/dp (n_p, n_out, n_out); and ok."""
        pb, k = self.pb, self.pb.k
        steps = self.steps(p)
        res = []
        ok = True
        for r, model in enumerate(pb.models):
            jidx = [self.joints.index(j) for j in model.record.free_dofs]
            moved = list(range(k)) + list(range(self.f_slice.start, self.f_slice.stop)) + list(range(self.r_slices[r].start, self.r_slices[r].stop))
            if not sensitivities:
                moved = []
            m = 1 + 2 * len(moved)
            P = np.repeat(p[None, :], m, axis=0)
            for c, i in enumerate(moved):
                P[1 + 2 * c, i] += steps[i]
                P[2 + 2 * c, i] -= steps[i]
            rows = pb.pset.rows(model.base_row, P[:, :k])
            rows = model.row_with(rows)
            x0 = pb.x0_fixed[r]
            # gains: linearisation depends on the model parameters only
            uniq_rows, inv = np.unique(rows, axis=0, return_inverse=True)
            Phi = _linear_map(model, uniq_rows, x0)[inv.ravel()]
            C = np.zeros((model.n_out, 2 * model.n_free))
            C[: model.n_free, : model.n_free] = np.eye(model.n_free)
            if model.n_out > model.n_free:
                C[model.n_free :, model.n_free :] = np.eye(model.n_free)
            Fstd = np.exp(P[:, self.f_slice])[:, jidx]
            rr = np.exp(2.0 * P[:, self.r_slices[r]])
            try:
                K, B = _gains(Phi, C, Fstd, rr, model.control_dt)
            except (np.linalg.LinAlgError, ValueError):
                return None, False
            qcols = model.free_idx
            nu_all = np.empty((m, model.n_t, model.n_out))

            def correct(kk: int, b, y: np.ndarray) -> None:
                nu = model.z[kk][None, :] - y
                nu_all[:, kk] = nu
                if kk == 0:
                    return
                dx = np.einsum("mij,mj->mi", K, nu)
                b.X[:, qcols] += dx[:, : model.n_free]
                b.X[:, L.X_QD + qcols] += dx[:, model.n_free :]

            _, status = model.run(rows, x0, correct=correct)
            nu0 = nu_all[0, 1:]
            if status[0] != 0 or not np.all(np.isfinite(nu0)):
                ok = False
            item = {"nu": nu0, "B": B[0], "dnu": None, "dB": None, "pred": model.z[1:] - nu0}
            if sensitivities:
                dnu = np.zeros((model.n_t - 1, model.n_out, self.n_p))
                dB = np.zeros((self.n_p, model.n_out, model.n_out))
                for c, i in enumerate(moved):
                    up, dn = 1 + 2 * c, 2 + 2 * c
                    dnu[:, :, i] = (nu_all[up, 1:] - nu_all[dn, 1:]) / (2 * steps[i])
                    dB[i] = (B[up] - B[dn]) / (2 * steps[i])
                item["dnu"], item["dB"] = dnu, dB
            res.append(item)
        return res, ok


def _nll(items) -> float:
    out = 0.0
    for it in items:
        Bi = np.linalg.inv(it["B"])
        nu = it["nu"]
        out += 0.5 * float(np.einsum("ki,ij,kj->", nu, Bi, nu)) + 0.5 * nu.shape[0] * float(np.linalg.slogdet(it["B"])[1])
    return out


def _fisher_and_gradient(items, n_p: int) -> tuple[np.ndarray, np.ndarray]:
    F = np.zeros((n_p, n_p))
    g = np.zeros(n_p)
    for it in items:
        Bi = np.linalg.inv(it["B"])
        nu, dnu, dB = it["nu"], it["dnu"], it["dB"]
        N = nu.shape[0]
        F += np.einsum("kip,ij,kjq->pq", dnu, Bi, dnu)
        BdB = np.einsum("ij,pjl->pil", Bi, dB)  # B^-1 dB_p
        F += 0.5 * N * np.einsum("pij,qji->pq", BdB, BdB)
        w = nu @ Bi  # (N, n_out): nu' B^-1
        g += np.einsum("ki,kip->p", w, dnu)
        g += 0.5 * N * np.einsum("pii->p", BdB)
        g -= 0.5 * np.einsum("ki,pij,kj->p", w, dB, w)
    return 0.5 * (F + F.T), g


def filter_error(problem: Problem, p0: np.ndarray, *, process_noise: Mapping[str, float] | None = None, max_iter: int = 30,
                 tol: float = 1e-6, progress: Callable[[str], None] | None = None) -> Solution:
    """Fit ``problem`` by filter error (see the module docstring); the Solution's p holds the model parameters
    first (covariance rows likewise), then log process-noise and log measurement-noise standard deviations."""
    say = progress or (lambda s: None)
    flt = _Filter(problem, process_noise)
    p = np.clip(np.concatenate([np.asarray(p0, dtype=np.float64)[: problem.k], flt.p0[problem.k :]]), flt.lower, flt.upper)
    say("filter error: innovations and sensitivities at the start values (the first fit in a fresh installation compiles "
        "the model's kernels once, a minute or two; numba caches them on disk)")
    items, ok = flt.evaluate(p, True)
    if not ok:
        raise FloatingPointError("filter error: the model or its filter blows up at the start values")
    dead = [flt.names[i] for i in range(problem.k) if all(not np.any(it_["dnu"][:, :, i]) for it_ in items)]
    if dead:
        raise ValueError(f"{dead}: no effect on the records' outputs, so not identifiable from them "
                         "(a locked joint's parameter, a surface never moved, a term switched off, a servo delay)")
    L0 = _nll(items)
    lam = 1e-3
    history = [L0]
    converged, message = False, "maximum number of iterations reached"
    it = 0
    for it in range(1, max_iter + 1):
        F, g = _fisher_and_gradient(items, flt.n_p)
        d = np.diag(F).copy()
        d[d <= 0.0] = 1.0
        accepted = False
        for _ in range(12):
            try:
                dp = -np.linalg.solve(F + lam * np.diag(d), g)
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            trial = np.clip(p + dp, flt.lower, flt.upper)
            t_items, t_ok = flt.evaluate(trial, False)
            if t_ok and t_items is not None:
                L_t = _nll(t_items)
                if L_t < L0:
                    accepted = True
                    break
            lam *= 10.0
        if not accepted:
            converged, message = True, "no step lowers the negative log-likelihood further (converged to the solver's precision)"
            break
        step = trial - p
        sd = np.sqrt(np.clip(np.diag(np.linalg.pinv(F, hermitian=True)), 1e-300, None))
        rel = (L0 - L_t) / max(abs(L0), 1e-300)
        p, L0 = trial, L_t
        lam = max(lam / 10.0, 1e-9)
        history.append(L0)
        say(f"filter error: iteration {it}: -log-likelihood {L0:.6g}, largest step {np.max(np.abs(step) / sd):.3g} standard errors, lambda {lam:.1e}")
        items, ok = flt.evaluate(p, True)
        if not ok:
            raise FloatingPointError("filter error: the model blew up at an accepted estimate")
        if np.max(np.abs(step) / sd) < STEP_TOL or (rel < tol and np.max(np.abs(step) / sd) < 10 * STEP_TOL):
            converged, message = True, f"converged: largest step {np.max(np.abs(step) / sd):.2g} standard errors, relative change of the negative log-likelihood {rel:.2e}"
            break
    F, _ = _fisher_and_gradient(items, flt.n_p)
    cov = np.linalg.pinv(F, hermitian=True)
    k = problem.k
    preds = [np.concatenate([m.z[:1], it_["pred"]]) for m, it_ in zip(problem.models, items)]
    resid = [m.z - y for m, y in zip(problem.models, preds)]
    noise = [np.diag(np.exp(2.0 * p[s])) for s in flt.r_slices]
    ev = Evaluation(preds, [None] * len(preds), ok)
    extra = {"process_noise": {f"{j}": float(np.exp(p[flt.f_slice][i])) for i, j in enumerate(flt.joints)},
             "innovation_cov": [it_["B"] for it_ in items]}
    full = np.concatenate([p[:k], p[k:]])
    return Solution(full, cov, cov, ev, resid, noise, history, it, converged, message, extra)

"""Equation error: the model's joint accelerations regressed on accelerations differentiated from a record.

For each record: the angles are differentiated by a Savitzky-Golay filter (cubic, ``window`` samples) to
rates and accelerations (measured rates are used where the record has them); the servo positions are the
model's response to the record's commands (they do not depend on the motion); the model's accelerations
``qdd(q, qd, flaps, airspeed; theta)`` (:func:`rig_env.physics.derivatives.joint_accelerations`, the
environments' equations of motion) are compared with the measured ones at every sample, and theta is
found by Gauss-Newton on the weighted squared difference (one weight per joint: the inverse of its
residual variance).  No simulation is involved, so the fit is fast and cannot diverge, and it is the
start value of an output-error or filter-error fit when nothing better is known.  Its weaknesses are the
classical ones: differentiated data are noisy (the errors-in-variables bias towards zero), and friction is
modelled by its steady-sliding value (the bristles at their steady deflection for the measured rate), so
the friction parameters themselves are better left to the output-error fit of the angle history.

Standard errors: the regression's Cramer-Rao bound, corrected for coloured residuals as the output error's
(:mod:`rig_env.sysid.covariance`; differentiated data are always coloured).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from rig_env.params import JOINTS, RigParams
from rig_env.physics import layout as L
from rig_env.physics.derivatives import joint_accelerations
from rig_env.sysid.covariance import coloured_middle, covariances, fisher_information
from rig_env.sysid.model import RecordModel
from rig_env.sysid.output_error import STEP_TOL, Solution, noise_of
from rig_env.sysid.parameters import ParameterSet
from rig_env.sysid.problem import Evaluation

WINDOW = 11  # samples of the Savitzky-Golay differentiator (0.14 s at 80 Hz)


def _steady_bristles(qd: np.ndarray, row: np.ndarray, free_idx: np.ndarray) -> np.ndarray:
    """(n, 5) LuGre bristle deflections in steady sliding at rates qd (n, 5): z = sign(v) g(v) / sigma0 with
    g(v) = Fc + (Fs - Fc) exp(-alpha_f |v|) (eq. 20), so that the friction torque is its steady value."""
    z = np.zeros_like(qd)
    for j in free_idx:
        name = JOINTS[j].upper()
        Fs, Fc, af, s0 = (row[getattr(L, f"P_FRICTION_{name}_{f}")] for f in ("FS", "FC", "ALPHA_F", "SIGMA0"))
        v = qd[:, j]
        z[:, j] = np.sign(v) * (Fc + (Fs - Fc) * np.exp(-af * np.abs(v))) / s0
    return z


class _Regression:
    def __init__(self, model: RecordModel, theta0: np.ndarray, pset: ParameterSet, window: int, friction: bool) -> None:
        from scipy.signal import savgol_filter

        rec = model.record
        if rec.n_t < 3 * window:
            raise ValueError(f"{rec.name}: equation error needs at least {3 * window} samples, the record has {rec.n_t}")
        dt = model.control_dt
        q = rec.q
        qs = savgol_filter(q, window, 3, axis=0)
        qd = rec.qd if rec.qd is not None else savgol_filter(q, window, 3, deriv=1, delta=dt, axis=0)
        qdd = savgol_filter(q, window, 3, deriv=2, delta=dt, axis=0)
        keep = slice(window, rec.n_t - window)  # the filter's edges are extrapolations
        self.model, self.pset, self.friction = model, pset, friction
        n = rec.n_t
        self.q5 = np.repeat(model.locked[None, :], n, axis=0)
        self.qd5 = np.zeros((n, 5))
        self.q5[:, model.free_idx] = qs
        self.qd5[:, model.free_idx] = qd
        self.flaps = model.servo_positions(pset.rows(model.base_row, theta0[None, :])[0])
        # inputs of sample k act over [t_k, t_k+1); the servo positions above are those at t_k
        self.U = model.U
        self.keep = keep
        self.y = qdd[keep]
        self.flags = model.flags & ~L.F_FRICTION if not friction else model.flags

    def linearise(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(model accelerations (n, n_free), residuals (n, n_free), their sensitivities (n, n_free, k)) at theta,
        rad/s^2; sensitivities by central differences."""
        a0 = self.accelerations(theta)
        steps = self.pset.steps(theta)
        cols = []
        for i in range(self.pset.k):
            tp, tm = theta.copy(), theta.copy()
            tp[i] += steps[i]
            tm[i] -= steps[i]
            cols.append((self.accelerations(tp) - self.accelerations(tm)) / (2 * steps[i]))
        return a0, self.y - a0, np.stack(cols, axis=-1)

    def accelerations(self, theta: np.ndarray) -> np.ndarray:
        row = self.pset.rows(self.model.base_row, theta[None, :])[0]
        row = self.model.row_with(row[None, :])[0]
        z = _steady_bristles(self.qd5, row, self.model.free_idx) if self.friction else None
        a = joint_accelerations(self.q5, self.qd5, self.flaps, self.U, row, self.flags, self.model.free_idx, self.model.tabs, z)
        return a[self.keep][:, self.model.free_idx]


def equation_error(records, params: RigParams, pset: ParameterSet, *, aero: bool | None = None, friction: bool = True, stops: bool = True,
                   aero_model: str = "linear", window: int = WINDOW, max_iter: int = 10,
                   progress: Callable[[str], None] | None = None) -> tuple[Solution, list[RecordModel], list[_Regression]]:
    """Fit the parameters of ``pset`` by equation error (see the module docstring)."""
    say = progress or (lambda s: None)
    theta = pset.start.copy()
    models = [RecordModel(r, params, aero=aero, friction=friction, stops=stops, aero_model=aero_model) for r in records]
    regs = [_Regression(m, theta, pset, window, friction) for m in models]
    history: list[float] = []
    converged, message, it = False, "maximum number of iterations reached", 0
    for it in range(1, max_iter + 1):
        lin = [rg.linearise(theta) for rg in regs]
        R = noise_of([e for _, e, _ in lin])  # per joint: the residual mean square (its inverse weighs the joint)
        F = sum(fisher_information(S, r) for (_, _, S), r in zip(lin, R))
        g = sum(np.einsum("kip,i,ki->p", S, 1.0 / np.diag(r), e) for (_, e, S), r in zip(lin, R))
        dtheta = np.linalg.lstsq(F, g, rcond=None)[0]
        new = pset.clip(theta + dtheta)
        J = float(sum(0.5 * np.sum(e * e / np.diag(r)[None, :]) for (_, e, _), r in zip(lin, R)))
        history.append(J)
        sd = np.sqrt(np.clip(np.diag(np.linalg.pinv(F, hermitian=True)), 1e-300, None))
        step = np.max(np.abs(new - theta) / sd)
        theta = new
        say(f"equation error: iteration {it}: weighted cost {J:.6g}, largest step {step:.3g} standard errors")
        if step < STEP_TOL:
            converged, message = True, f"converged: largest step {step:.2g} standard errors"
            break
    # statistics at the estimate
    lin = [rg.linearise(theta) for rg in regs]
    preds = [a0 for a0, _, _ in lin]
    resid = [e for _, e, _ in lin]
    S_list = [S for _, _, S in lin]
    R_list = noise_of(resid)
    F = sum(fisher_information(S, R) for S, R in zip(S_list, R_list))
    cw, cc = covariances(F, [coloured_middle(S, v, R) for S, v, R in zip(S_list, resid, R_list)])
    sol = Solution(theta, cw, cc, Evaluation(preds, S_list, True), resid, R_list, history, it, converged, message, {})
    return sol, models, regs

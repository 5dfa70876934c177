"""``LQRLaw`` (kind ``"lqr"``): gain-scheduled LQR with integral action and a delay-aware estimator.

Design (at construction, :func:`design_grid`): for every airspeed ``V`` of a grid over
``spec.airspeed_range`` and every roll angle ``phi`` of a 30 deg grid, trim and linearise the
task's free joints (:func:`controllers.model.design_model`, the numba model the environment
integrates, virtual inputs roll/heave/sway), augment the model with the integrals of the tracked
errors (roll angle; rig_pitch and rig_yaw when free) and solve ``control.lqr`` with Bryson weights
(:data:`MAX_DEVIATION`, :data:`MAX_INPUT`).  The operating point moves with phi (the arm's gravity
imbalance needs a steady aileron and changes the roll stiffness, ``-k cos phi``) and with V (all
aerodynamic terms), so gains, trims and models are interpolated bilinearly in (V, phi) at the
estimated state, periodically in phi.

Law, per control period (batched, numpy):

    (q, w)   = DelayedKalman(measured angles, measured surfaces)          (controllers.estimator)
    e        = [q - q_ref, w - w_ref, integral of the tracked angle errors]
    v        = u_trim(V, phi) + u_ff - K(V, phi) e                        (virtual roll, heave, sway)
    surfaces = resolve(phi, v)                                            (controllers.model.resolve)

``q_ref``: roll reference from the task's roll error (unwrapped against the estimate), rig_pitch and
rig_yaw from the task's errors when it gives them (else 0), model joints at their trim; ``w_ref``:
the task's rate references (else 0).
``u_ff``: the aileron that gives the reference roll acceleration at the reference rate on the
linear model.  The integrators stop while the output is saturated in their direction (clamping).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control
import numpy as np

from controllers.base import Controller, LoopSpec, register
from controllers.estimator import DelayedKalman, kalman_gain
from controllers.model import AXES, AXIS_OF, design_model, loop_elements, resolve
from controllers.signals import Signals
from controllers.tuning import axes_of, margins
from rig_env.envs.sensors import UNLIMITED
from rig_env.params import JOINTS, RigParams

MAX_DEVIATION = {  # Bryson: Q = 1 / max^2 (rad, rad/s, rad s)
    "rig_roll": math.radians(8.0), "rig_roll_rate": math.radians(90.0), "int_rig_roll": math.radians(10.0),
    "rig_pitch": math.radians(4.0), "rig_pitch_rate": math.radians(30.0), "int_rig_pitch": math.radians(4.0),
    "rig_yaw": math.radians(4.0), "rig_yaw_rate": math.radians(30.0), "int_rig_yaw": math.radians(4.0),
    "model_pitch": math.radians(40.0), "model_pitch_rate": math.radians(400.0),
    "model_yaw": math.radians(40.0), "model_yaw_rate": math.radians(400.0),
}
MAX_INPUT = {"roll": 0.1, "heave": 0.35, "sway": 0.35}
"""Normalised virtual inputs (1 = 40 deg) at V_REF; R = 1 / (max V_REF / V)^2: the allowed input grows
as the airspeed falls (the control derivatives scale with V^2, the gravity terms not at all); this
scaling keeps the loop margins nearly uniform over 15-25 m/s (see ``describe``)."""
V_REF = 20.0
PHI_STEP_DEG = 30.0
SIGMA_A = {"rig_roll": 20.0, "rig_pitch": 10.0, "rig_yaw": 10.0, "model_pitch": 40.0, "model_yaw": 40.0}  # rad/s^2
SIGMA_Z = math.radians(0.1)  # rad: 0.05 deg noise and 0.088 deg quantisation


@dataclass(frozen=True)
class Design:
    """One grid point: gains K (3, n_x + n_i), trim u_trim (3,), q_op (n_q,), A (n_x, n_x), B (n_x, 3),
    weights Q, R, Riccati solution P and closed-loop poles of the augmented model."""

    free_dofs: tuple[str, ...]
    airspeed: float
    phi: float
    K: np.ndarray
    u_trim: np.ndarray
    q_op: np.ndarray
    A: np.ndarray
    B: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    P: np.ndarray
    poles: np.ndarray


def augmented(A: np.ndarray, B: np.ndarray, free_dofs: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Append integrals of the tracked joints' angles: z' = q_j for j in rig_roll, rig_pitch, rig_yaw (free)."""
    tracked = axes_of(free_dofs)
    nx, ni = A.shape[0], len(tracked)
    Aa = np.zeros((nx + ni, nx + ni))
    Aa[:nx, :nx] = A
    for k, j in enumerate(tracked):
        Aa[nx + k, free_dofs.index(j)] = 1.0
    Ba = np.vstack([B, np.zeros((ni, B.shape[1]))])
    return Aa, Ba, [f"int_{j}" for j in tracked]


def design_point(params: RigParams, free_dofs: tuple[str, ...], airspeed: float, phi: float) -> Design:
    """Trim, linearise, augment and solve the LQR at one (V, phi)."""
    dp = design_model(params, free_dofs, airspeed, phi)
    A, B = np.asarray(dp.sys.A), np.asarray(dp.sys.B)
    Aa, Ba, ilabels = augmented(A, B, free_dofs)
    labels = list(dp.sys.state_labels) + ilabels
    Q = np.diag([1.0 / MAX_DEVIATION[s] ** 2 for s in labels])
    used = [AXIS_OF[j] for j in axes_of(free_dofs)]
    R = np.diag([1.0 / (MAX_INPUT[AXES[k]] * V_REF / airspeed) ** 2 for k in used])
    Kr, P, poles = control.lqr(Aa, Ba[:, used], Q, R)
    K = np.zeros((3, Aa.shape[0]))
    K[used] = Kr
    q_op = dp.op.q[[JOINTS.index(j) for j in free_dofs]]
    return Design(tuple(free_dofs), float(airspeed), float(phi), K, dp.u_trim, q_op, A, B, Q, R, np.asarray(P), np.asarray(poles))


def design_grid(params: RigParams, free_dofs: tuple[str, ...], airspeeds: np.ndarray, phis: np.ndarray) -> list[list[Design]]:
    """Designs for every (airspeed, phi) of the grid: ``grid[i_v][i_phi]``."""
    return [[design_point(params, free_dofs, float(v), float(f)) for f in phis] for v in airspeeds]


def loop_margins(d: Design, channel: int, elements: dict[str, control.TransferFunction]) -> tuple[float, float, float]:
    """(GM dB, PM deg, crossover rad/s) of the loop broken at virtual input ``channel`` (others closed),
    with the servo and the Pade transport delay in the loop."""
    Aa, Ba, _ = augmented(d.A, d.B, d.free_dofs)
    others = [k for k in range(3) if k != channel]
    Acl = Aa - Ba[:, others] @ d.K[others]
    Lss = control.ss(Acl, Ba[:, [channel]], d.K[[channel]], 0.0)
    L = Lss * control.tf2ss(elements["servo"] * elements["delay"])
    return margins(L)


@register("lqr")
class LQRLaw(Controller):
    """Gain-scheduled LQR; see the module docstring.  Keyword arguments:

    | argument | default | meaning |
    |---|---|---|
    | params | default rig | rig parameters of the design model |
    | link_delay_steps | 1 | measurement delay the estimator predicts over, control steps |
    | estimator | True | DelayedKalman; False: measured angles and filtered rates as they come |
    """

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, params: RigParams | None = None, link_delay_steps: int = 1,
                 estimator: bool = True) -> None:
        super().__init__(spec, num_envs)
        self.sig = Signals(spec)
        self.params = params or RigParams.default()
        fd = spec.free_dofs
        lo, hi = spec.airspeed_range
        self.airspeeds = np.linspace(lo, hi, max(2, math.ceil((hi - lo) / 2.5) + 1)) if hi > lo else np.array([lo])
        if self.airspeeds[0] <= 1.0:
            raise ValueError(f"airspeed_range = {spec.airspeed_range}: the LQR design needs airspeed > 1 m/s")
        self.phis = np.radians(np.arange(-180.0, 180.0, PHI_STEP_DEG))
        self.grid = design_grid(self.params, fd, self.airspeeds, self.phis)
        g = self.grid
        self._K = np.array([[d.K for d in r] for r in g])
        self._u = np.array([[d.u_trim for d in r] for r in g])
        self._qop = np.array([[d.q_op for d in r] for r in g])
        nq = len(fd)
        self._Aq = np.array([[d.A[nq:, :nq] for d in r] for r in g])
        self._Aw = np.array([[d.A[nq:, nq:] for d in r] for r in g])
        self._B = np.array([[d.B[nq:] for d in r] for r in g])
        self.tracked = axes_of(fd)
        self._track_idx = np.array([fd.index(j) for j in self.tracked])
        self._track_axis = np.array([AXIS_OF[j] for j in self.tracked])
        self.roll = fd.index("rig_roll")
        wrap = np.array([j in UNLIMITED for j in fd])
        gains = np.array([kalman_gain(spec.dt, SIGMA_A[j], SIGMA_Z) for j in fd])
        self.use_estimator = bool(estimator)
        self.kf = DelayedKalman(self.num_envs, spec.dt, wrap, gains, link_delay_steps)
        self.z = np.zeros((self.num_envs, len(self.tracked)))
        self.link_delay_steps = link_delay_steps
        n_x = 2 * len(fd)
        self._int_col = n_x + np.arange(len(self.tracked))  # columns of K acting on the integrals
        self._p_prev = np.zeros(self.num_envs)
        self._fresh = np.ones(self.num_envs, dtype=bool)

    def reset(self, mask: np.ndarray | None = None) -> None:
        m = self._mask(mask)
        self.z[m] = 0.0
        self.kf.reset(m)
        self._fresh |= m

    def _weights(self, V: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, ...]:
        """Bilinear interpolation indices and weights: (iv0, iv1, wv, ip0, ip1, wp)."""
        nv = self.airspeeds.size
        if nv == 1:
            iv0 = iv1 = np.zeros(V.shape, dtype=np.int64)
            wv = np.zeros(V.shape)
        else:
            x = np.clip(np.interp(V, self.airspeeds, np.arange(nv)), 0, nv - 1 - 1e-9)
            iv0 = np.floor(x).astype(np.int64)
            iv1, wv = iv0 + 1, x - iv0
        npf = self.phis.size
        y = ((phi - self.phis[0]) % (2 * math.pi)) / math.radians(PHI_STEP_DEG)
        ip0 = np.floor(y).astype(np.int64) % npf
        return iv0, iv1, wv, ip0, (ip0 + 1) % npf, y - np.floor(y)

    def _interp(self, table: np.ndarray, w: tuple[np.ndarray, ...]) -> np.ndarray:
        iv0, iv1, wv, ip0, ip1, wp = w
        ex = (slice(None),) + (None,) * (table.ndim - 2)
        a = (1 - wp)[ex] * table[iv0, ip0] + wp[ex] * table[iv0, ip1]
        b = (1 - wp)[ex] * table[iv1, ip0] + wp[ex] * table[iv1, ip1]
        return (1 - wv)[ex] * a + wv[ex] * b

    def act(self, obs: np.ndarray) -> np.ndarray:
        s = self.sig(self._check_obs(obs))
        fd = self.spec.free_dofs
        z_meas = np.stack([s.angle[j] for j in fd], axis=1)
        w_meas = np.stack([s.rate[j] for j in fd], axis=1)
        V = s.airspeed
        phi_now = np.where(self._fresh, s.phi, self.kf.q[:, self.roll])
        w = self._weights(V, phi_now)
        u_trim = self._interp(self._u, w)
        model = (self._interp(self._qop, w), self._interp(self._Aq, w), self._interp(self._Aw, w), self._interp(self._B, w), u_trim)
        if self.use_estimator:
            surf = s.surfaces
            c, sn = np.cos(s.phi), np.sin(s.phi)  # surfaces -> virtual axes (inverse of resolve)
            virt_meas = np.stack([surf[:, 0], c * surf[:, 1] - sn * surf[:, 2], sn * surf[:, 1] + c * surf[:, 2]], axis=1)
            q, wr = self.kf.step(z_meas, w_meas, virt_meas, model)
        else:
            q, wr = z_meas, w_meas
            self.kf.fresh[:] = False
        # errors: roll against its reference (unwrapped through the measurement), others against trim / 0
        dq = q - model[0]
        dq[:, self.roll] = -(s.roll_error + ((z_meas[:, self.roll] - q[:, self.roll] + math.pi) % (2 * math.pi) - math.pi))
        dw = wr.copy()
        dw[:, self.roll] -= s.roll_rate_ref
        for j in ("rig_pitch", "rig_yaw"):
            if j in fd:  # error against the task's reference (measured angle + error), else against 0
                k = fd.index(j)
                dq[:, k] = q[:, k] - (z_meas[:, k] + s.error[j])
                dw[:, k] -= s.rate_ref[j]
        K = self._interp(self._K, w)
        e = np.concatenate([dq, dw, self.z], axis=1)
        v = u_trim - np.einsum("nij,nj->ni", K, e)
        if self.sig.has_rate_ref:  # roll acceleration of the reference at the reference rate, on the model
            p_dot = np.where(self._fresh, 0.0, (s.roll_rate_ref - self._p_prev) / self.spec.dt)
            a_damp = model[2][:, self.roll, self.roll] * s.roll_rate_ref
            v[:, 0] += (p_dot - a_damp) / model[3][:, self.roll, 0]
            self._p_prev = s.roll_rate_ref.copy()
        sat = np.clip(v, -1.0, 1.0)
        # clamping anti-windup: hold an integral while its axis is saturated and it would push further
        err_i = dq[:, self._track_idx]
        k_i = K[:, self._track_axis, self._int_col]  # (n, n_tracked) gain of each axis on its own integral
        v_i, s_i = v[:, self._track_axis], sat[:, self._track_axis]
        push = (v_i != s_i) & (np.sign(-k_i * err_i) == np.sign(v_i))
        self.z += np.where(push, 0.0, self.spec.dt * err_i)
        self._fresh[:] = False
        return np.clip(resolve(q[:, self.roll], sat), -1.0, 1.0)

    def describe_point(self, airspeed: float, phi: float) -> dict[str, Any]:
        """Closed-loop poles and loop margins (servo and delay included) at the grid point nearest (V, phi)."""
        iv = int(np.argmin(np.abs(self.airspeeds - airspeed)))
        ip = int(np.argmin(np.abs(((self.phis - phi) + math.pi) % (2 * math.pi) - math.pi)))
        d = self.grid[iv][ip]
        el = loop_elements(self.params, self.spec.dt, self.link_delay_steps)
        out: dict[str, Any] = {"airspeed": d.airspeed, "phi_deg": math.degrees(d.phi), "poles": d.poles.tolist()}
        for j in self.tracked:
            gm, pm, wc = loop_margins(d, AXIS_OF[j], el)
            out[j] = {"gm_db": gm, "pm_deg": pm, "wc": wc}
        return out

    def describe(self) -> dict[str, Any]:
        """Margins at the lowest, middle and highest design airspeed, at roll 0 and 90 deg (for the report)."""
        vs = sorted({float(self.airspeeds[0]), float(np.median(self.airspeeds)), float(self.airspeeds[-1])})
        return {"points": [self.describe_point(v, math.radians(f)) for v in vs for f in (0.0, 90.0)]}

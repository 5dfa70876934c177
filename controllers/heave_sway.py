"""Heave and sway laws (PID and LQR) for the tasks that drive rig_pitch or rig_yaw with rig_roll locked.

Tasks: pull_up_push_over, forced_oscillation (``axis`` heave_pitch or sway_yaw) and
free_flight_emulation; the driven joint's reference comes from :class:`controllers.references.DrivenReference`
(angle error ``e``, rate ``w_ref``, acceleration ``a_ref``).  Both laws command the compensator's
virtual heave (elevator) or sway (rudder) input; roll is locked, so the surfaces are the virtual
inputs themselves (:func:`controllers.model.resolve` at phi = 0) and the aileron stays at 0.

Design model (:mod:`controllers.axis_design`): the rig's zero-input equilibrium and its linearisation
at every airspeed of a grid over ``spec.airspeed_range`` (2.5 m/s apart), interpolated linearly at
the measured airspeed.  Feedforward of the reference on that model, with the passive model joints
quasi-static (they follow the rig within a fraction of the reference's period):

    u_ff  = u_s(theta_ref, V) + (a_ref - A'_jj w_ref) / b_j

with ``u_s`` the rig's static input curve (:func:`controllers.axis_design.static_table`: the input
that holds the driven joint at theta with every free joint settled, from ``rig_env.trim``; its
slope at theta_op is the linear model's static gain ``1 / G_j``, ``G = -A_q^-1 B_axis`` (every joint's
angle per unit input; the input reaches the passive joints too, through the coupled inertia),
but the rig stiffens away from its trim), ``A'_jj`` the driven joint's damping and ``b_j`` its
control power.

| class | kind | law |
|---|---|---|
| :class:`HeaveSwayPID` | pid | outer P on ``e`` plus ``w_ref`` -> rate demand (limit :data:`RATE_DEMAND_MAX`); inner PI on the measured rate with ``u_ff`` and the decoupling ``u_dc`` (below) (:class:`controllers.pid_element.PID`: back-calculation anti-windup, output +-1, the servo's rate limit, bumpless engagement); gains from :func:`controllers.axis_design.tune_driven` at the middle airspeed, scaled by ``(V_design / V)^2`` |
| :class:`HeaveSwayLQR` | lqr | ``v = u_ff - K(V) [q - q_ref, w - w_ref, z]``, ``K`` from :func:`controllers.axis_design.lqr_point` (Bryson weights: the tightest of :data:`ANGLE_MAX_DEG` meeting :data:`LQR_TARGETS`) with the integral ``z`` of the driven joint's error (clamping anti-windup), ``(q, w)`` from :class:`controllers.estimator.DelayedKalman`; passive joints referenced to their quasi-static angle, or left free (zero gain) in free-flight emulation |

Decoupling (PID): the passive model joints pull on the driven joint (the model's lift and side force
on the arm; a gust shows first as a model-joint deflection).  ``u_dc = -(A_jp (q_p - q_p,ref) + A'_jp w_p) / b_j``
on the measured passive angles and rates cancels that pull on the linear model (``q_p,ref``: their
static angles for theta_ref); it halves the RMS error under gusts (pull-up 4.3 -> 2.4 deg, 16 episodes).
The LQR has these terms in ``K`` already.  Free-flight emulation instead inverts the whole driven-joint
row, ``u_ff = (a_ref - A_j x) / b_j`` on the measured state, so that the gimbal follows the free
Hawk's heave acceleration whatever the model does.

Departure recovery keeps rig_roll free, so the roll laws (:mod:`controllers.pid`, :mod:`controllers.lqr`)
fly it (they come first in the registry); with wind-tunnel turbulence (1 %) they recover 28/32 and 27/32
episodes at 20 m/s.  With 5 % gusts (the "gusty" stress mode) no law does: the passive model joints' rates stay
above the task's 20 deg/s recovery limit (peaks 60-85 deg/s), which no compensator input can damp.

``law.describe()`` gives gains and margins (servo, delay and rate sensor in the loop) for the report.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from controllers.axis_design import axis_point, lqr_margins, lqr_point, pid_margins_as_flown, static_table, tune_driven
from controllers.base import Controller, LoopSpec, register
from controllers.estimator import DelayedKalman, kalman_gain
from controllers.lqr import SIGMA_A, SIGMA_Z
from controllers.model import AXIS_OF
from controllers.pid_element import PID
from controllers.references import DrivenReference
from rig_env.envs.sensors import AIRSPEED_SCALE, ANGLE_SCALE, FLAP_SCALE, RATE_SCALE, UNLIMITED
from rig_env.params import JOINTS, RigParams
from rig_env.physics import layout as L
from rig_env.physics.aero import MIX_ELEVATOR, MIX_RUDDER

ANGLE_MAX_DEG = (4.0, 3.5, 3.0, 2.5, 2.0)
"""Candidate Bryson maxima of the driven joint's angle and its integral (deg, deg s), loosest first; the
rate's is 30 deg/s (as :data:`controllers.lqr.MAX_DEVIATION`).  :class:`HeaveSwayLQR` takes the tightest
whose loop (broken at the driven input, servo and Pade delay in, :func:`controllers.axis_design.lqr_margins`)
keeps :data:`LQR_TARGETS` at every design airspeed."""
LQR_TARGETS = {"gm_db": 6.0, "pm_deg": 45.0}
RATE_DEMAND_MAX = math.radians(90.0)
"""Limit of the outer loop's rate demand, rad/s (the tasks' reference rates stay below 40 deg/s)."""
V_STEP = 2.5  # m/s between design airspeeds
_UNMIX = np.array([[0.25] * 4, [0.25 * m for m in MIX_ELEVATOR], [0.25 * m for m in MIX_RUDDER]])


class _AxisModel:
    """Design models over the airspeed grid and the reference feedforward (module docstring)."""

    def __init__(self, spec: LoopSpec, params: RigParams) -> None:
        lo, hi = spec.airspeed_range
        if lo <= 1.0:
            raise ValueError(f"airspeed_range = {spec.airspeed_range}: the heave/sway design needs airspeed > 1 m/s")
        self.V = np.linspace(lo, hi, max(2, math.ceil((hi - lo) / V_STEP) + 1)) if hi > lo else np.array([lo])
        fd = spec.free_dofs
        self.points = [axis_point(params, fd, float(v), spec.action_scale_deg) for v in self.V]
        self.nq = len(fd)
        self.params, self.fd, self.scale_deg = params, fd, spec.action_scale_deg

    def setup(self, joint: str, fd: tuple[str, ...]) -> None:
        nq, k = self.nq, fd.index(joint)
        p = [i for i in range(nq) if i != k]
        self.k, self.passive = k, p
        cw, b, S = [], [], []
        for q_op, sys in self.points:
            A, B = np.asarray(sys.A), np.asarray(sys.B)
            Aq, Aw = A[nq:, :nq], A[nq:, nq:]
            G = -np.linalg.solve(Aq, B[nq:, AXIS_OF[joint]])  # static gain: joint angles per unit input
            cw.append(Aw[k, k])
            b.append(B[nq + k, AXIS_OF[joint]])
            S.append(G[p] / G[k])
        self.cw, self.b = np.array(cw), np.array(b)
        self.Arow = np.array([np.asarray(sys.A)[nq + k] for _, sys in self.points])  # (n_V, 2 nq): driven joint's acceleration row
        self.qop = np.array([q[[JOINTS.index(j) for j in self.fd]] for q, _ in self.points])  # (n_V, nq)
        self.S = np.array(S)  # (n_V, n_passive): passive joint angles per rad of the driven joint held by a steady input
        self.tables = [static_table(self.params, self.fd, joint, float(v), self.scale_deg) for v in self.V]

    def at(self, table: np.ndarray, V: np.ndarray) -> np.ndarray:
        """Linear interpolation in airspeed of a table (n_V, ...) at V (n,), clamped to the grid."""
        if self.V.size == 1:
            return np.broadcast_to(table[0], (V.size,) + table.shape[1:]).copy()
        x = np.clip(np.interp(V, self.V, np.arange(self.V.size)), 0, self.V.size - 1 - 1e-9)
        i = np.floor(x).astype(np.int64)
        w = (x - i).reshape((-1,) + (1,) * (table.ndim - 1))
        return (1 - w) * table[i] + w * table[i + 1]

    def static_input(self, V: np.ndarray, th: np.ndarray) -> np.ndarray:
        """(n,) u_s(theta, V): the static input curves at the grid airspeeds, interpolated linearly in V."""
        per_v = np.stack([np.interp(th, t, u) for t, u in self.tables])  # (n_V, n)
        return np.einsum("vn,nv->n", per_v, self.at(np.eye(self.V.size), V))

    def inverse(self, V: np.ndarray, q: np.ndarray, w: np.ndarray, a_ref: np.ndarray) -> np.ndarray:
        """(n,) input giving the driven joint the acceleration a_ref at the state (q, w) (n, nq) on the linear model."""
        x = np.concatenate([q - self.at(self.qop, V), w], axis=1)
        return (a_ref - np.einsum("nj,nj->n", self.at(self.Arow, V), x)) / self.at(self.b, V)

    def decouple(self, V: np.ndarray, q: np.ndarray, w: np.ndarray, th_ref: np.ndarray) -> np.ndarray:
        """(n,) input cancelling the passive joints' pull on the driven joint, A_jp (q_p - q_p,ref) + A'_jp w_p, on the linear model."""
        if not self.passive:
            return np.zeros(q.shape[0])
        row, qop = self.at(self.Arow, V), self.at(self.qop, V)
        q_ref = qop[:, self.passive] + self.at(self.S, V) * (th_ref - qop[:, self.k])[:, None]
        acc = np.einsum("nj,nj->n", row[:, self.passive], q[:, self.passive] - q_ref)
        acc += np.einsum("nj,nj->n", row[:, [self.nq + i for i in self.passive]], w[:, self.passive])
        return -acc / self.at(self.b, V)

    def feedforward(self, V: np.ndarray, th_ref: np.ndarray, w_ref: np.ndarray, a_ref: np.ndarray) -> np.ndarray:
        """(n,) u_ff, normalised virtual input."""
        return self.static_input(V, th_ref) + (a_ref - self.at(self.cw, V) * w_ref) / self.at(self.b, V)


class _HeaveSwayBase(Controller):
    def __init__(self, spec: LoopSpec, num_envs: int, params: RigParams | None, link_delay_steps: int) -> None:
        super().__init__(spec, num_envs)
        self.ref = DrivenReference(spec, self.num_envs, params or RigParams.default())  # UnsupportedTask first: cheap
        self.params = params or RigParams.default()
        self.joint = self.ref.joint
        self.axis = AXIS_OF[self.joint]
        self.link_delay_steps = int(link_delay_steps)
        self.model = _AxisModel(spec, self.params)
        self.model.setup(self.joint, spec.free_dofs)
        ix = spec.index
        self._flaps = [ix(f"flap{k}") for k in range(1, 5)]
        self._air = ix("airspeed")
        self._cols = [(ix(f"sin_{j}"), ix(f"cos_{j}")) if j in UNLIMITED else (ix(f"{j}_angle"),) for j in spec.free_dofs]
        self._rcols = [ix(f"{j}_rate") for j in spec.free_dofs]
        self.emulate = spec.task == "free_flight_emulation"

    def _joints(self, o: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n, nq) measured angles and (n, nq) filtered rates of the free joints, rad and rad/s."""
        q = np.stack([np.arctan2(o[:, c[0]], o[:, c[1]]) if len(c) == 2 else o[:, c[0]] * ANGLE_SCALE for c in self._cols], axis=1)
        return q, np.stack([o[:, c] * RATE_SCALE[j] for c, j in zip(self._rcols, self.spec.free_dofs)], axis=1)

    def _surface_now(self, obs: np.ndarray) -> np.ndarray:
        """(n,) measured virtual input of the driven axis (elevator or rudder, normalised)."""
        s = (obs[:, self._flaps] * FLAP_SCALE / math.radians(self.spec.action_scale_deg)) @ _UNMIX.T
        return s[:, self.axis]

    def _action(self, v: np.ndarray) -> np.ndarray:
        a = np.zeros((self.num_envs, self.spec.n_actions))
        a[:, self.axis] = v  # action order: comp_aileron, comp_elevator, comp_rudder = roll, heave, sway at phi = 0
        return np.clip(a, -1.0, 1.0)


@register("pid")
class HeaveSwayPID(_HeaveSwayBase):
    """Cascaded PID on the driven rig joint; see the module docstring.  Keyword arguments:

    | argument | default | meaning |
    |---|---|---|
    | params | default rig | rig parameters of the design model |
    | link_delay_steps | 1 | telemetry delay the tuning accounts for, control steps |
    | rate_filter_hz | 10.0 | the rate sensor's filter the tuning accounts for, Hz |
    | feedforward | True | reference feedforward ``u_ff`` |
    | decouple | True | decoupling ``u_dc`` of the passive joints |
    | targets | None | margin targets for :func:`controllers.axis_design.tune_driven` (``pm_inner``, ``gm_inner``, ``pm_outer``, ``gm_outer``) |
    """

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, params: RigParams | None = None, link_delay_steps: int = 1,
                 rate_filter_hz: float = 10.0, feedforward: bool = True, decouple: bool = True, targets: dict[str, float] | None = None) -> None:
        super().__init__(spec, num_envs, params, link_delay_steps)
        m = self.model
        i_mid = int(np.argmin(np.abs(m.V - 0.5 * (m.V[0] + m.V[-1]))))
        self.v_design = float(m.V[i_mid])
        self.tuning = tune_driven(self.params, m.points[i_mid][1], self.joint, self.v_design, spec.dt,
                                  link_delay_steps=link_delay_steps, rate_filter_hz=rate_filter_hz, **(targets or {}))
        t, n = self.tuning, self.num_envs
        rate_lim = math.degrees(self.params.to_vector()[L.P_SERVOS_COMPENSATOR_RATE_LIMIT_DEG_S]) / spec.action_scale_deg
        self.outer = PID(n, kp=t.k_angle, dt=spec.dt, u_min=-RATE_DEMAND_MAX, u_max=RATE_DEMAND_MAX)
        self.inner = PID(n, kp=t.kp, ki=t.ki, dt=spec.dt, rate=rate_lim)
        self.use_ff = bool(feedforward)
        self.decouple = bool(decouple)
        self._pending = np.ones(n, dtype=bool)

    def reset(self, mask: np.ndarray | None = None) -> None:
        m = self._mask(mask)
        self.outer.reset(m)
        self.inner.reset(m)
        self.ref.reset(m)
        self._pending |= m

    def act(self, obs: np.ndarray) -> np.ndarray:
        o = self._check_obs(obs)
        e, w_ref, a_ref = self.ref(o)
        th, rate = self.ref.theta(o)
        V = np.maximum(o[:, self._air] * AIRSPEED_SCALE, 5.0)
        g = (self.v_design / V) ** 2
        if not self.use_ff:
            ff = np.zeros(self.num_envs)
        elif self.emulate:
            ff = self.model.inverse(V, *self._joints(o), a_ref)
        else:
            ff = self.model.feedforward(V, th + e, w_ref, a_ref)
            if self.decouple:
                ff = ff + self.model.decouple(V, *self._joints(o), th + e)
        demand = self.outer.update(e, 0.0) + w_ref
        if np.any(self._pending):
            self.inner.engage(self._pending, demand, rate, self._surface_now(o), ff=ff, gain_scale=g)
            self._pending[:] = False
        return self._action(self.inner.update(demand, rate, ff=ff, gain_scale=g))

    def describe(self) -> dict[str, Any]:
        """Tuning (gains, inner and outer loop margins) and the margins of the whole law broken at the
        surface command (``*_input``: cascade and decoupling together, :func:`controllers.axis_design.pid_margins_as_flown`)."""
        i_mid = int(np.argmin(np.abs(self.model.V - self.v_design)))
        gm, pm, wc = pid_margins_as_flown(self.params, self.model.points[i_mid][1], self.joint, self.tuning, self.spec.dt,
                                          decouple="all" if self.emulate else ("passive" if self.decouple else None),
                                          link_delay_steps=self.link_delay_steps)
        return {self.joint: {**self.tuning.as_dict(), "gm_input": gm, "pm_input": pm, "wc_input": wc}}


@register("lqr")
class HeaveSwayLQR(_HeaveSwayBase):
    """LQR with integral action on the driven rig joint, scheduled in airspeed; see the module docstring.

    | argument | default | meaning |
    |---|---|---|
    | params | default rig | rig parameters of the design model |
    | link_delay_steps | 1 | measurement delay the estimator predicts over, control steps |
    | max_deviation | None | Bryson maxima (rad, rad/s, rad s) by state label, overriding the weight search |
    """

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, params: RigParams | None = None, link_delay_steps: int = 1,
                 max_deviation: dict[str, float] | None = None) -> None:
        super().__init__(spec, num_envs, params, link_delay_steps)
        fd, m, j = spec.free_dofs, self.model, self.joint
        candidates = [max_deviation] if max_deviation is not None else [
            {j: math.radians(a), f"{j}_rate": math.radians(30.0), f"int_{j}": math.radians(a)} for a in ANGLE_MAX_DEG]
        for md in candidates:  # loosest first: keep the tightest that meets the targets
            designs = [lqr_point(q, sys, fd, float(v), md) for v, (q, sys) in zip(m.V, m.points)]
            ok = all(gm >= LQR_TARGETS["gm_db"] and pm >= LQR_TARGETS["pm_deg"]
                     for gm, pm, _ in (lqr_margins(d, j, self.params, spec.dt, self.link_delay_steps, not self.emulate) for d in designs))
            if ok or not hasattr(self, "designs"):
                self.designs, self.max_deviation = designs, md
            if not ok:
                break
        self._K = np.array([d.K[self.axis] for d in self.designs])  # (n_V, 2 nq + 1): this axis' row
        self.hold_passive = not self.emulate  # emulation: the model is free
        nq = len(fd)
        if not self.hold_passive:
            self._K[:, [i for i in range(2 * nq) if i % nq != m.k]] = 0.0
        self._qop = np.array([d.q_op for d in self.designs])
        self._Aq = np.array([d.A[nq:, :nq] for d in self.designs])
        self._Aw = np.array([d.A[nq:, nq:] for d in self.designs])
        self._B = np.array([d.B[nq:] for d in self.designs])
        wrap = np.array([j in UNLIMITED for j in fd])
        gains = np.array([kalman_gain(spec.dt, SIGMA_A[j], SIGMA_Z) for j in fd])
        self.kf = DelayedKalman(self.num_envs, spec.dt, wrap, gains, self.link_delay_steps)
        self.z = np.zeros(self.num_envs)

    def reset(self, mask: np.ndarray | None = None) -> None:
        m = self._mask(mask)
        self.z[m] = 0.0
        self.kf.reset(m)
        self.ref.reset(m)

    def act(self, obs: np.ndarray) -> np.ndarray:
        o = self._check_obs(obs)
        m, k = self.model, self.model.k
        e, w_ref, a_ref = self.ref(o)
        z_meas, w_meas = self._joints(o)
        V = np.maximum(o[:, self._air] * AIRSPEED_SCALE, 5.0)
        q_op = m.at(self._qop, V)
        virt = np.zeros((self.num_envs, 3))
        virt[:, self.axis] = self._surface_now(o)
        q, w = self.kf.step(z_meas, w_meas, virt, (q_op, m.at(self._Aq, V), m.at(self._Aw, V), m.at(self._B, V), np.zeros((self.num_envs, 3))))
        th_ref = z_meas[:, k] + e
        dq, dw = q - q_op, w.copy()
        dq[:, k], dw[:, k] = q[:, k] - th_ref, w[:, k] - w_ref
        if m.passive:
            dq[:, m.passive] -= m.at(m.S, V) * (th_ref - q_op[:, k])[:, None]
        Kv = m.at(self._K, V)
        x = np.concatenate([dq, dw, self.z[:, None]], axis=1)
        ff = m.inverse(V, q, w, a_ref) if self.emulate else m.feedforward(V, th_ref, w_ref, a_ref)
        v = ff - np.einsum("nj,nj->n", Kv, x)
        sat = np.clip(v, -1.0, 1.0)
        push = (v != sat) & (np.sign(-Kv[:, -1] * dq[:, k]) == np.sign(v))  # clamping anti-windup
        self.z += np.where(push, 0.0, self.spec.dt * dq[:, k])
        return self._action(sat)

    def describe(self) -> dict[str, Any]:
        """Closed-loop poles and margins (servo and delay in the loop) at every design airspeed."""
        out = []
        for d in self.designs:
            gm, pm, wc = lqr_margins(d, self.joint, self.params, self.spec.dt, self.link_delay_steps, self.hold_passive)
            out.append({"airspeed": d.airspeed, "phi_deg": 0.0, "poles": d.poles.tolist(), self.joint: {"gm_db": gm, "pm_deg": pm, "wc": wc}})
        return {"points": out}

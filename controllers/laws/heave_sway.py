"""Heave and sway laws (PID and LQR) for the tasks that drive rig_pitch or rig_yaw with rig_roll locked.

Tasks: pull_up_push_over, forced_oscillation (``axis`` heave_pitch or sway_yaw) and
free_flight_emulation; the driven joint's reference comes from :class:`controllers.laws.references.DrivenReference`
(angle error ``e``, rate ``w_ref``, acceleration ``a_ref``).  Both laws command the compensator's
virtual heave (elevator) or sway (rudder) input; roll is locked, so the surfaces are the virtual
inputs themselves (:func:`controllers.design.model.resolve` at phi = 0) and the aileron stays at 0.

Design model (:mod:`controllers.design.heave_sway`): the rig's zero-input equilibrium and its linearisation
at every airspeed of a grid over ``spec.airspeed_range`` (2.5 m/s apart), interpolated linearly at
the measured airspeed.  Feedforward of the reference on that model, with the passive model joints
quasi-static (they follow the rig within a fraction of the reference's period):

    u_ff  = u_s(theta_ref, V) + (a_ref - A'_jj w_ref) / b_j

with ``u_s`` the rig's static input curve (:func:`controllers.design.heave_sway.static_table`: the input
that holds the driven joint at theta with every free joint settled, from ``rig_env.trim``; its
slope at theta_op is the linear model's static gain ``1 / G_j``, ``G = -A_q^-1 B_axis`` (every joint's
angle per unit input; the input reaches the passive joints too, through the coupled inertia),
but the rig stiffens away from its trim), ``A'_jj`` the driven joint's damping and ``b_j`` its
control power.

| class | kind | law |
|---|---|---|
| :class:`HeaveSwayPID` | pid | outer P on ``e`` plus ``w_ref`` -> rate demand (limit :data:`RATE_DEMAND_MAX`); inner PI on the measured rate with ``u_ff`` and the decoupling ``u_dc`` (below) (:class:`controllers.laws.pid_element.PID`: back-calculation anti-windup, output +-1, the servo's rate limit, bumpless engagement); gains from :func:`controllers.design.heave_sway.tune_driven` at the middle airspeed, scaled by ``(V_design / V)^2`` |
| :class:`HeaveSwayLQR` | lqr | ``v = u_ff - K(V) [q - q_ref, w - w_ref, z]``, ``K`` from :func:`controllers.design.heave_sway.lqr_point` (Bryson weights: the tightest of :data:`ANGLE_MAX_DEG` meeting :data:`LQR_TARGETS`) with the integral ``z`` of the driven joint's error (clamping anti-windup), ``(q, w)`` from :class:`controllers.laws.estimator.DelayedKalman`; passive joints referenced to their quasi-static angle, or left free (zero gain) in free-flight emulation |

Decoupling (PID): the passive model joints pull on the driven joint (the model's lift and side force
on the arm; a gust shows first as a model-joint deflection).  ``u_dc = -(A_jp (q_p - q_p,ref) + A'_jp w_p) / b_j``
on the measured passive angles and rates cancels that pull on the linear model (``q_p,ref``: their
static angles for theta_ref); it halves the RMS error under gusts (pull-up 4.3 -> 2.4 deg, 16 episodes).
The LQR has these terms in ``K`` already.  Free-flight emulation instead inverts the whole driven-joint
row, ``u_ff = (a_ref - A_j x) / b_j`` on the measured state, so that the gimbal follows the free
Hawk's heave acceleration whatever the model does.

Departure recovery keeps rig_roll free, so the roll laws (:mod:`controllers.laws.pid`, :mod:`controllers.laws.lqr`)
fly it (they come first in the registry); with wind-tunnel turbulence (1 %) the PID and the LQR recover 32/32
and 29/32 episodes at 20 m/s (the comparison's nominal conditions otherwise).  With 5 % gusts (the "gusty"
stress mode) no law does (0/32): the passive model joints' rates stay above the task's 30 deg/s recovery
limit (peaks 60-85 deg/s), which no compensator input can damp.

``law.describe()`` gives gains and margins (servo, delay and rate sensor in the loop) for the report.

Design and runtime are apart (as :mod:`controllers.laws.pid`, :mod:`controllers.laws.lqr`):
:mod:`controllers.design.heave_sway` (python-control, scipy, the numba model, ``rig_env``; imported
only when a law is designed) produces :class:`HeaveSwayTables`, plain data; this module runs them
with numpy alone, in simulation and from a deployed artefact (kinds ``"pid_heave_sway"`` and
``"lqr_heave_sway"``: ``law.to_data()`` / ``HeaveSwayPID.from_data(data, spec)``), one implementation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.laws.axes import AXIS_OF
from controllers.laws.base import LoopSpec, TabledLaw, register
from controllers.laws.emulation import EmulationLQR
from controllers.laws.estimator import DelayedKalman
from controllers.laws.pid_element import PID
from controllers.laws.references import TASKS, DrivenReference, ReferenceConstants
from controllers.laws.signals import SignalScales, table_array


ANGLE_MAX_DEG = (4.0, 3.5, 3.0, 2.5, 2.0)
"""Candidate Bryson maxima of the driven joint's angle and its integral (deg, deg s), loosest first; the
rate's is 30 deg/s (as :data:`controllers.laws.lqr.MAX_DEVIATION`).  :class:`HeaveSwayLQR` takes the tightest
whose loop (broken at the driven input, servo and Pade delay in, :func:`controllers.design.heave_sway.lqr_margins`)
keeps :data:`LQR_TARGETS` at every design airspeed."""
LQR_TARGETS = {"gm_db": 6.0, "pm_deg": 45.0}
RATE_DEMAND_MAX = math.radians(90.0)
"""Limit of the outer loop's rate demand, rad/s (the tasks' reference rates stay below 40 deg/s)."""
V_STEP = 2.5  # m/s between design airspeeds
_MODEL = ("airspeeds", "cw", "b", "A_row", "q_op", "S", "static_theta", "static_u", "static_n")
_LAW = {"pid": ("kp", "ki", "k_angle", "v_design", "rate_limit", "feedforward", "decouple"),
        "lqr": ("K", "A_q", "A_w", "B", "kalman_gain", "link_delay_steps")}


@dataclass(frozen=True)
class HeaveSwayTables:
    """Everything :class:`HeaveSwayPID` / :class:`HeaveSwayLQR` execute, checked against a :class:`LoopSpec`.

    ``nv`` design airspeeds, ``nq`` free joints, ``npas = nq - 1`` passive joints, ``m`` static-curve points.

    | field | shape | unit |
    |---|---|---|
    | airspeeds | (nv,) | m/s, increasing (> 1) |
    | cw | (nv,) | 1/s: the driven joint's damping ``A'_jj`` |
    | b | (nv,) | rad/s^2 per normalised input: the driven joint's control power ``b_j`` |
    | A_row | (nv, 2 nq) | the driven joint's acceleration row (per rad, per rad/s) |
    | q_op | (nv, nq) | rad, zero-input trim angles of the free joints |
    | S | (nv, npas) | passive joint angle per rad of the driven joint held by a steady input |
    | static_theta, static_u, static_n | (nv, m), (nv, m), (nv,) | the static input curve per airspeed: the first ``static_n`` points, rad ascending / normalised |
    | reference | :class:`controllers.laws.references.ReferenceConstants` | the reference parser's numbers |
    | scales | :class:`controllers.laws.signals.SignalScales` | the observation's normalisation |
    | law | dict | pid: ``kp``, ``ki`` (per rad/s, per rad s), ``k_angle`` (1/s), ``v_design`` (m/s), ``rate_limit`` (units/s), ``feedforward``, ``decouple``; lqr: ``K`` (nv, 2 nq + 1), ``A_q``, ``A_w`` (nv, nq, nq), ``B`` (nv, nq, 3), ``kalman_gain`` (nq, 2), ``link_delay_steps`` |
    | design | dict | provenance: targets, margins, weights, airspeed range, sensor layout assumed |
    """

    kind: str
    airspeeds: np.ndarray
    cw: np.ndarray
    b: np.ndarray
    A_row: np.ndarray
    q_op: np.ndarray
    S: np.ndarray
    static_theta: np.ndarray
    static_u: np.ndarray
    static_n: np.ndarray
    reference: ReferenceConstants
    scales: SignalScales
    law: dict[str, Any]
    design: dict[str, Any]

    def to_data(self) -> dict[str, Any]:
        """Artefact entries: numpy arrays and JSON values."""
        arrays = {k: np.array(getattr(self, k)) for k in _MODEL}
        law = {k: (np.array(v) if isinstance(v, np.ndarray) else v) for k, v in self.law.items()}
        return {**arrays, **law, **self.reference.to_data(), **self.scales.to_data(), "design": dict(self.design)}

    @classmethod
    def from_data(cls, kind: str, d: Mapping[str, Any], spec: LoopSpec) -> HeaveSwayTables:
        """Check ``d`` (from the design or an artefact) for law ``kind`` ("pid" or "lqr"); a ValueError names the entry."""
        name = f"{kind}_heave_sway"
        missing = [k for k in (*_MODEL, *_LAW[kind], "design") if k not in d]
        if missing:
            raise ValueError(f"{name}: missing entries {missing}")
        ref = ReferenceConstants.from_data(d, spec)
        nq = len(spec.free_dofs)
        V = table_array(d, "airspeeds", owner=name, shape=None)
        if V.ndim != 1 or V.size < 1 or V[0] <= 1.0 or np.any(np.diff(V) <= 0):
            raise ValueError(f"{name}: airspeeds must be increasing and > 1 m/s, got {V.tolist() if V.ndim == 1 else V.shape}")
        nv = V.size
        th = table_array(d, "static_theta", owner=name, shape=None)
        if th.ndim != 2 or th.shape[0] != nv:
            raise ValueError(f"{name}: static_theta: expected shape ({nv}, m), got {th.shape}")
        cnt = np.asarray(d["static_n"])
        if cnt.shape != (nv,) or not np.issubdtype(cnt.dtype, np.integer) or np.any(cnt < 2) or np.any(cnt > th.shape[1]):
            raise ValueError(f"{name}: static_n must be ({nv},) integers in [2, {th.shape[1]}]")
        if any(np.any(np.diff(th[i, :c]) <= 0) for i, c in enumerate(cnt)):
            raise ValueError(f"{name}: static_theta must increase over its first static_n points")
        m = {"airspeeds": V, "cw": table_array(d, "cw", owner=name, shape=(nv,)), "b": table_array(d, "b", owner=name, shape=(nv,)), "A_row": table_array(d, "A_row", owner=name, shape=(nv, 2 * nq)),
             "q_op": table_array(d, "q_op", owner=name, shape=(nv, nq)), "S": table_array(d, "S", owner=name, shape=(nv, nq - 1)), "static_theta": th,
             "static_u": table_array(d, "static_u", owner=name, shape=th.shape), "static_n": cnt.astype(np.int64)}
        if np.any(m["b"] == 0):
            raise ValueError(f"{name}: b (control power) must not be 0")
        if kind == "pid":
            law = {}
            for k in ("kp", "ki", "k_angle", "v_design", "rate_limit"):
                v = d[k]
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (k in ("v_design", "rate_limit") and v <= 0):
                    raise ValueError(f"{name}: {k} = {v!r}: must be a finite number{' > 0' if k in ('v_design', 'rate_limit') else ''}")
                law[k] = float(v)
            flags = {k: d[k] for k in ("feedforward", "decouple")}
            bad = [k for k, v in flags.items() if not isinstance(v, bool)]
            if bad:
                raise ValueError(f"{name}: {bad} must be bools (true / false)")
            law.update(flags)
        else:
            lds = d["link_delay_steps"]
            if isinstance(lds, bool) or not isinstance(lds, int) or not 0 <= lds <= 100:
                raise ValueError(f"{name}: link_delay_steps = {lds!r}: an integer in [0, 100]")
            law = {"K": table_array(d, "K", owner=name, shape=(nv, 2 * nq + 1)), "A_q": table_array(d, "A_q", owner=name, shape=(nv, nq, nq)), "A_w": table_array(d, "A_w", owner=name, shape=(nv, nq, nq)),
                   "B": table_array(d, "B", owner=name, shape=(nv, nq, 3)), "kalman_gain": table_array(d, "kalman_gain", owner=name, shape=(nq, 2)), "link_delay_steps": lds}
        if type(d["design"]) is not dict:
            raise ValueError(f"{name}: design must be an object")
        return cls(kind, **m, reference=ref, scales=SignalScales.from_data(d, spec), law=law, design=dict(d["design"]))


class _AxisModel:
    """The design model's tables over the airspeed grid and the reference feedforward (module docstring)."""

    def __init__(self, t: HeaveSwayTables, free_dofs: tuple[str, ...]) -> None:
        self.V, self.cw, self.b, self.Arow, self.qop, self.S = t.airspeeds, t.cw, t.b, t.A_row, t.q_op, t.S
        self.tables = [(t.static_theta[i, :n], t.static_u[i, :n]) for i, n in enumerate(t.static_n)]
        self.nq = len(free_dofs)
        self.k = free_dofs.index(t.reference.joint)
        self.passive = [i for i in range(self.nq) if i != self.k]

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


class _HeaveSwayBase(TabledLaw):
    _law = ""

    @classmethod
    def supports(cls, spec: LoopSpec) -> str | None:
        """The heave/sway laws fly the heave and sway tasks with rig_roll locked."""
        if spec.task not in TASKS:
            return f"task {spec.task!r}: the heave/sway laws fly {list(TASKS)}"
        if "rig_roll" in spec.free_dofs:
            return f"free_dofs = {list(spec.free_dofs)}: the heave/sway laws need rig_roll locked"
        return None

    def __init__(self, spec: LoopSpec, num_envs: int, tables: HeaveSwayTables | Mapping[str, Any]) -> None:
        super().__init__(spec, num_envs)
        t = self.tables = tables if isinstance(tables, HeaveSwayTables) else HeaveSwayTables.from_data(self._law, tables, spec)
        if t.kind != self._law:
            raise ValueError(f"tables of a {t.kind!r} heave/sway law given to {type(self).__name__}")
        self.ref = DrivenReference(spec, self.num_envs, constants=t.reference)
        self.joint = self.ref.joint
        self.axis = AXIS_OF[self.joint]
        self.model = _AxisModel(t, spec.free_dofs)
        sc = self.sc = t.scales
        ix = spec.index
        self._flaps = [ix(f"flap{k}") for k in range(1, 5)]
        self._air = ix("airspeed")
        self._cols = [(ix(f"sin_{j}"), ix(f"cos_{j}")) if j in sc.unlimited else (ix(f"{j}_angle"),) for j in spec.free_dofs]
        self._rcols = [ix(f"{j}_rate") for j in spec.free_dofs]
        self._rscale = [float(x) for x in sc.rate_scale]
        self.emulate = spec.task == "free_flight_emulation"

    def _joints(self, o: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n, nq) measured angles and (n, nq) filtered rates of the free joints, rad and rad/s."""
        a = self.sc.angle_scale
        q = np.stack([np.arctan2(o[:, c[0]], o[:, c[1]]) if len(c) == 2 else o[:, c[0]] * a for c in self._cols], axis=1)
        return q, np.stack([o[:, c] * r for c, r in zip(self._rcols, self._rscale)], axis=1)

    def _surface_now(self, obs: np.ndarray) -> np.ndarray:
        """(n,) measured virtual input of the driven axis (elevator or rudder, normalised)."""
        s = (obs[:, self._flaps] * self.sc.flap_scale / math.radians(self.spec.action_scale_deg)) @ self.sc.unmix.T
        return s[:, self.axis]

    def _airspeed(self, o: np.ndarray) -> np.ndarray:
        return np.maximum(o[:, self._air] * self.sc.airspeed_scale, 5.0)

    def _action(self, v: np.ndarray) -> np.ndarray:
        a = np.zeros((self.num_envs, self.spec.n_actions))
        a[:, self.axis] = v  # action order: comp_aileron, comp_elevator, comp_rudder = roll, heave, sway at phi = 0
        return np.clip(a, -1.0, 1.0)


@register("pid")
class HeaveSwayPID(_HeaveSwayBase):
    """Cascaded PID on the driven rig joint; see the module docstring.

    ``tables``: the design (:class:`HeaveSwayTables` or its data), made by
    :func:`controllers.design.heave_sway.design_heave_sway_pid` (or read from an artefact).
    """

    artefact_kind = "pid_heave_sway"
    _law = "pid"

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, tables: HeaveSwayTables | Mapping[str, Any]) -> None:
        super().__init__(spec, num_envs, tables)
        g, n = self.tables.law, self.num_envs
        self.v_design, self.use_ff, self.decouple = g["v_design"], g["feedforward"], g["decouple"]
        self.outer = PID(n, kp=g["k_angle"], dt=spec.dt, u_min=-RATE_DEMAND_MAX, u_max=RATE_DEMAND_MAX)
        self.inner = PID(n, kp=g["kp"], ki=g["ki"], dt=spec.dt, rate=g["rate_limit"])
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
        V = self._airspeed(o)
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
        surface command (``*_input``: cascade and decoupling together, :func:`controllers.design.heave_sway.pid_margins_as_flown`),
        as computed by the design."""
        return {self.joint: dict(self.tables.design["tuning"])}


@register("lqr")
class HeaveSwayLQR(_HeaveSwayBase):
    """LQR with integral action on the driven rig joint, scheduled in airspeed; see the module docstring.

    ``tables``: the design (:class:`HeaveSwayTables` or its data), made by
    :func:`controllers.design.heave_sway.design_heave_sway_lqr` (or read from an artefact).  It can
    fly free-flight emulation when built so, but :func:`~controllers.laws.base.law_for` routes that
    task's ``"lqr"`` to the model-following :class:`controllers.laws.emulation.EmulationLQR`.
    """

    artefact_kind = "lqr_heave_sway"
    _law = "lqr"

    @classmethod
    def supports(cls, spec: LoopSpec) -> str | None:
        """As the heave/sway PID, except free-flight emulation on the model-following law's joint set."""
        if EmulationLQR.supports(spec) is None:
            return "free-flight emulation on rig_pitch and model_pitch flies the model-following EmulationLQR"
        return _HeaveSwayBase.supports.__func__(cls, spec)

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, tables: HeaveSwayTables | Mapping[str, Any]) -> None:
        super().__init__(spec, num_envs, tables)
        g = self.tables.law
        self.max_deviation = dict(self.tables.design["max_deviation"])
        self.link_delay_steps = g["link_delay_steps"]
        self.hold_passive = not self.emulate  # emulation: the model is free (its gains are zero in K)
        self._K, self._Aq, self._Aw, self._B = g["K"], g["A_q"], g["A_w"], g["B"]
        wrap = np.array([j in self.sc.unlimited for j in spec.free_dofs])
        self.kf = DelayedKalman(self.num_envs, spec.dt, wrap, g["kalman_gain"], self.link_delay_steps)
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
        V = self._airspeed(o)
        q_op = m.at(m.qop, V)
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
        """Closed-loop poles (as [re, im]) and margins (servo and delay in the loop) at every design airspeed, as computed by the design."""
        return {"points": [dict(p) for p in self.tables.design["points"]]}

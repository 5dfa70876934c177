"""``LQRLaw`` (kind ``"lqr"``): gain-scheduled LQR with integral action and a delay-aware estimator.

Design (:func:`controllers.design.lqr.design_lqr`, at construction): an LQR with integral action on
a grid of airspeeds ``V`` over ``spec.airspeed_range`` and roll angles ``phi`` every 30 deg,
trimmed and linearised on the numba model the environment integrates.  The operating point moves
with phi (the arm's gravity imbalance needs a steady aileron and changes the roll stiffness,
``-k cos phi``) and with V (all aerodynamic terms), so gains, trims and models are interpolated
bilinearly in (V, phi) at the estimated state, periodically in phi.

Law, per control period (batched, numpy):

    (q, w)   = DelayedKalman(measured angles, measured surfaces)          (controllers.laws.estimator)
    e        = [q - q_ref, w - w_ref, integral of the tracked angle errors]
    v        = u_trim(V, phi) + u_ff - K(V, phi) e                        (virtual roll, heave, sway)
    surfaces = resolve(phi, v)                                            (controllers.laws.axes.resolve)

``q_ref``: roll reference from the task's roll error (unwrapped against the estimate), rig_pitch and
rig_yaw from the task's errors when it gives them (else 0), model joints at their trim; ``w_ref``:
the task's rate references (else 0).
``u_ff``: the aileron that gives the reference roll acceleration at the reference rate on the
linear model.  The integrators stop while the output is saturated in their direction (clamping).

Design and runtime are apart: the design (python-control, the numba model) is imported only when a
law is designed; its result is :class:`LQRTables`, plain data, which this module runs with numpy
alone, in simulation and from a deployed artefact (kind ``"lqr"``: ``law.to_data()`` /
``LQRLaw.from_data(data, spec)``), one implementation.  The design functions (``design_point``,
``augmented``, ``MAX_DEVIATION``...) live in :mod:`controllers.design.lqr` and are re-exported
here on first access.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.laws.axes import AXIS_OF, axes_of, resolve, unresolve
from controllers.laws.base import LoopSpec, TabledLaw, register
from controllers.laws.estimator import DelayedKalman
from controllers.laws.signals import Signals, SignalScales, require_roll, roll_reason, table_array


_TABLES = ("K", "u_trim", "q_op", "A_q", "A_w", "B")


@dataclass(frozen=True)
class LQRTables:
    """Everything :class:`LQRLaw` executes, checked against a :class:`LoopSpec`.

    ``nv`` airspeeds, ``nphi`` roll angles, ``nq`` = number of free joints, ``ni`` = tracked joints.

    | field | shape | unit |
    |---|---|---|
    | airspeeds | (nv,) | m/s, increasing |
    | phis | (nphi,) | rad, ``phis[0] + k phi_step``, covering 2 pi |
    | phi_step | scalar | rad |
    | K | (nv, nphi, 3, 2 nq + ni) | normalised virtual input per (rad, rad/s, rad s) |
    | u_trim | (nv, nphi, 3) | normalised virtual inputs |
    | q_op | (nv, nphi, nq) | rad, trim angles |
    | A_q, A_w | (nv, nphi, nq, nq) | 1/s^2, 1/s: joint accelerations per angle, per rate |
    | B | (nv, nphi, nq, 3) | rad/s^2 per normalised virtual input |
    | kalman_gain | (nq, 2) | estimator gains (angle, rate) per joint |
    | link_delay_steps | int | delay the estimator predicts over, control steps |
    | estimator | bool | False: measured angles and filtered rates as they come |
    | scales | :class:`SignalScales` | the observation's normalisation |
    | design | dict | provenance: weights, grid, noise model, loop margins |
    """

    airspeeds: np.ndarray
    phis: np.ndarray
    phi_step: float
    K: np.ndarray
    u_trim: np.ndarray
    q_op: np.ndarray
    A_q: np.ndarray
    A_w: np.ndarray
    B: np.ndarray
    kalman_gain: np.ndarray
    link_delay_steps: int
    estimator: bool
    scales: SignalScales
    design: dict[str, Any]

    def to_data(self) -> dict[str, Any]:
        """Artefact entries: numpy arrays and JSON values."""
        d: dict[str, Any] = {k: getattr(self, k).copy() for k in ("airspeeds", "phis", "kalman_gain", *_TABLES)}
        return {**d, "phi_step": self.phi_step, "link_delay_steps": self.link_delay_steps, "estimator": self.estimator,
                **self.scales.to_data(), "design": dict(self.design)}

    @classmethod
    def from_data(cls, d: Mapping[str, Any], spec: LoopSpec) -> LQRTables:
        """Check ``d`` (from :func:`controllers.design.lqr.design_lqr` or an artefact); a ValueError names the entry."""
        missing = [k for k in ("airspeeds", "phis", "phi_step", "kalman_gain", "link_delay_steps", "estimator", "design", *_TABLES) if k not in d]
        if missing:
            raise ValueError(f"lqr: missing entries {missing}")
        v = table_array(d, "airspeeds", owner="lqr", shape=None)
        ph = table_array(d, "phis", owner="lqr", shape=None)
        if v.ndim != 1 or v.size < 1 or v[0] <= 1.0 or np.any(np.diff(v) <= 0):
            raise ValueError(f"lqr: airspeeds must be increasing and > 1 m/s, got {v.tolist() if v.ndim == 1 else v.shape}")
        step = d["phi_step"]
        if isinstance(step, bool) or not isinstance(step, (int, float)) or not 0 < step <= math.pi:
            raise ValueError(f"lqr: phi_step = {step!r}: allowed range (0, pi] rad")
        if ph.ndim != 1 or ph.size < 2 or abs(ph.size * step - 2 * math.pi) > 1e-9 or np.any(np.abs(np.diff(ph) - step) > 1e-9):
            raise ValueError(f"lqr: phis must step by phi_step = {step} rad round the full circle, got shape {ph.shape}")
        lds = d["link_delay_steps"]
        if isinstance(lds, bool) or not isinstance(lds, int) or not 0 <= lds <= 100:
            raise ValueError(f"lqr: link_delay_steps = {lds!r}: an integer in [0, 100]")
        if not isinstance(d["estimator"], bool) or not isinstance(d["design"], dict):
            raise ValueError("lqr: estimator must be a bool and design an object")
        nv, nphi, nq, ni = v.size, ph.size, len(spec.free_dofs), len(axes_of(spec.free_dofs))
        want = {"K": (nv, nphi, 3, 2 * nq + ni), "u_trim": (nv, nphi, 3), "q_op": (nv, nphi, nq), "A_q": (nv, nphi, nq, nq),
                "A_w": (nv, nphi, nq, nq), "B": (nv, nphi, nq, 3)}
        t = {k: table_array(d, k, shape, "lqr") for k, shape in want.items()}
        return cls(v, ph, float(step), **t, kalman_gain=table_array(d, "kalman_gain", owner="lqr", shape=(nq, 2)), link_delay_steps=lds,
                   estimator=d["estimator"], scales=SignalScales.from_data(d, spec), design=dict(d["design"]))


@register("lqr")
class LQRLaw(TabledLaw):
    """Gain-scheduled LQR; see the module docstring.

    ``tables``: the design (:class:`LQRTables` or its data), made by
    :func:`controllers.design.lqr.design_lqr` (or read from an artefact); ``make_controller("lqr", spec)``
    designs and builds in one call.
    """

    artefact_kind = "lqr"

    @classmethod
    def supports(cls, spec: LoopSpec) -> str | None:
        """The scheduled roll-axis LQR flies any task with rig_roll free."""
        return roll_reason(spec)

    def __init__(self, spec: LoopSpec, num_envs: int = 1, *, tables: LQRTables | Mapping[str, Any]) -> None:
        super().__init__(spec, num_envs)
        require_roll(spec)
        t = self.tables = tables if isinstance(tables, LQRTables) else LQRTables.from_data(tables, spec)
        self.sig = Signals(spec, t.scales)
        fd = spec.free_dofs
        self.airspeeds, self.phis = t.airspeeds, t.phis
        self.tracked = axes_of(fd)
        self._track_idx = np.array([fd.index(j) for j in self.tracked])
        self._track_axis = np.array([AXIS_OF[j] for j in self.tracked])
        self.roll = fd.index("rig_roll")
        wrap = np.array([j in t.scales.unlimited for j in fd])
        self.use_estimator = t.estimator
        self.link_delay_steps = t.link_delay_steps
        self.kf = DelayedKalman(self.num_envs, spec.dt, wrap, t.kalman_gain, t.link_delay_steps)
        self.z = np.zeros((self.num_envs, len(self.tracked)))
        self._int_col = 2 * len(fd) + np.arange(len(self.tracked))  # columns of K acting on the integrals
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
        y = ((phi - self.phis[0]) % (2 * math.pi)) / self.tables.phi_step
        ip0 = np.floor(y).astype(np.int64) % npf
        return iv0, iv1, wv, ip0, (ip0 + 1) % npf, y - np.floor(y)

    def _interp(self, table: np.ndarray, w: tuple[np.ndarray, ...]) -> np.ndarray:
        iv0, iv1, wv, ip0, ip1, wp = w
        ex = (slice(None),) + (None,) * (table.ndim - 2)
        a = (1 - wp)[ex] * table[iv0, ip0] + wp[ex] * table[iv0, ip1]
        b = (1 - wp)[ex] * table[iv1, ip0] + wp[ex] * table[iv1, ip1]
        return (1 - wv)[ex] * a + wv[ex] * b

    def act(self, obs: np.ndarray) -> np.ndarray:
        t = self.tables
        s = self.sig(self._check_obs(obs))
        fd = self.spec.free_dofs
        z_meas = np.stack([s.angle[j] for j in fd], axis=1)
        w_meas = np.stack([s.rate[j] for j in fd], axis=1)
        V = s.airspeed
        phi_now = np.where(self._fresh, s.phi, self.kf.q[:, self.roll])
        w = self._weights(V, phi_now)
        u_trim = self._interp(t.u_trim, w)
        model = (self._interp(t.q_op, w), self._interp(t.A_q, w), self._interp(t.A_w, w), self._interp(t.B, w), u_trim)
        if self.use_estimator:
            q, wr = self.kf.step(z_meas, w_meas, unresolve(s.phi, s.surfaces), model)
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
        K = self._interp(t.K, w)
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

    def describe(self) -> dict[str, Any]:
        """Poles and loop margins (servo and delay included) at the lowest, middle and highest design airspeed,
        roll 0 and 90 deg, as computed by the design (for the report; poles as [re, im])."""
        return {"points": list(self.tables.design["margins"])}


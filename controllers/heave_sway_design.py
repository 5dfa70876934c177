"""Design of the heave/sway laws (:mod:`controllers.heave_sway`): the tables their numpy runtime executes.

Imported only when a law is designed (python-control, scipy, the numba model, ``rig_env``).  Steps,
at every airspeed of a grid over ``spec.airspeed_range`` (:data:`controllers.heave_sway.V_STEP` apart):

1. :func:`controllers.axis_design.axis_point`: the zero-input trim and its linear model; from it the
   driven joint's damping ``A'_jj``, control power ``b_j``, acceleration row, the trim angles and
   the passive joints' static ratio ``S = G_p / G_j`` (``G = -A_q^-1 B_axis``).
2. :func:`controllers.axis_design.static_table`: the static input curve ``u_s(theta)``.
3. PID: :func:`controllers.axis_design.tune_driven` at the middle airspeed, the servo's rate limit,
   and :func:`controllers.axis_design.pid_margins_as_flown` for the report.  LQR: the weight search
   of :class:`controllers.heave_sway.HeaveSwayLQR` (:func:`controllers.axis_design.lqr_point`,
   :func:`controllers.axis_design.lqr_margins`) and the estimator's Kalman gains
   (:data:`controllers.lqr_design.SIGMA_A`, :data:`controllers.lqr_design.SIGMA_Z`).

The reference parser's numbers (:func:`controllers.references.reference_constants`) and the
observation's scales (:func:`controllers.signals.signal_scales`) are read from ``rig_env`` here and
stored in the tables, so the runtime never imports it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from controllers.axes import AXIS_OF
from controllers.axis_design import (
    axis_point,
    lqr_margins,
    lqr_point,
    pid_margins_as_flown,
    static_table,
    tune_driven,
)
from controllers.base import LoopSpec
from controllers.estimator import kalman_gain
from controllers.heave_sway import ANGLE_MAX_DEG, LQR_TARGETS, V_STEP, HeaveSwayTables
from controllers.lqr_design import SIGMA_A, SIGMA_Z
from controllers.references import reference_constants
from controllers.signals import signal_scales
from rig_env.params import JOINTS, RigParams
from rig_env.physics import layout as L


def _grid(spec: LoopSpec) -> np.ndarray:
    lo, hi = spec.airspeed_range
    if lo <= 1.0:
        raise ValueError(f"airspeed_range = {spec.airspeed_range}: the heave/sway design needs airspeed > 1 m/s")
    return np.linspace(lo, hi, max(2, math.ceil((hi - lo) / V_STEP) + 1)) if hi > lo else np.array([lo])


def _model(spec: LoopSpec, params: RigParams) -> tuple[dict[str, Any], list, Any]:
    """Steps 1-2 (shared by both laws): the model tables, the design points [(q_op (5,), sys)] and the reference constants."""
    ref = reference_constants(spec, params)  # UnsupportedTask first: cheap
    joint, fd = ref.joint, spec.free_dofs
    V = _grid(spec)
    points = [axis_point(params, fd, float(v), spec.action_scale_deg) for v in V]
    nq, k = len(fd), fd.index(joint)
    p = [i for i in range(nq) if i != k]
    cw, b, S = [], [], []
    for _, sys in points:
        A, B = np.asarray(sys.A), np.asarray(sys.B)
        G = -np.linalg.solve(A[nq:, :nq], B[nq:, AXIS_OF[joint]])  # static gain: joint angles per unit input
        cw.append(A[nq:, nq:][k, k])
        b.append(B[nq + k, AXIS_OF[joint]])
        S.append(G[p] / G[k])
    curves = [static_table(params, fd, joint, float(v), spec.action_scale_deg) for v in V]
    m = max(t.size for t, _ in curves)
    th, us = np.zeros((V.size, m)), np.zeros((V.size, m))
    for i, (t, u) in enumerate(curves):  # padded with the last point; only the first static_n are read
        th[i], us[i] = t[-1], u[-1]
        th[i, : t.size], us[i, : u.size] = t, u
    tables = {"airspeeds": V, "cw": np.array(cw), "b": np.array(b),
              "A_row": np.array([np.asarray(sys.A)[nq + k] for _, sys in points]),
              "q_op": np.array([q[[JOINTS.index(j) for j in fd]] for q, _ in points]),
              "S": np.array(S).reshape(V.size, nq - 1), "static_theta": th, "static_u": us,
              "static_n": np.array([t.size for t, _ in curves], dtype=np.int64)}
    return tables, points, ref


def _design(spec: LoopSpec, link_delay_steps: int, rate_filter_hz: float = 10.0, **extra: Any) -> dict[str, Any]:
    return {"airspeed_range": list(spec.airspeed_range), "link_delay_steps": int(link_delay_steps), "rate_filter_hz": float(rate_filter_hz), **extra}


def design_heave_sway_pid(spec: LoopSpec, params: RigParams | None = None, *, link_delay_steps: int = 1, rate_filter_hz: float = 10.0,
                          feedforward: bool = True, decouple: bool = True, targets: dict[str, float] | None = None) -> HeaveSwayTables:
    """Tables of :class:`controllers.heave_sway.HeaveSwayPID` (steps 1-3)."""
    params_default, params = params is None, params or RigParams.default()
    model, points, ref = _model(spec, params)
    V = model["airspeeds"]
    i_mid = int(np.argmin(np.abs(V - 0.5 * (V[0] + V[-1]))))
    v_design = float(V[i_mid])
    t = tune_driven(params, points[i_mid][1], ref.joint, v_design, spec.dt, link_delay_steps=link_delay_steps,
                    rate_filter_hz=rate_filter_hz, **(targets or {}))
    rate_lim = math.degrees(params.to_vector()[L.P_SERVOS_COMPENSATOR_RATE_LIMIT_DEG_S]) / spec.action_scale_deg
    emulate = spec.task == "free_flight_emulation"
    gm, pm, wc = pid_margins_as_flown(params, points[i_mid][1], ref.joint, t, spec.dt,
                                      decouple="all" if emulate else ("passive" if decouple else None), link_delay_steps=link_delay_steps)
    law = {"kp": float(t.kp), "ki": float(t.ki), "k_angle": float(t.k_angle), "v_design": v_design, "rate_limit": float(rate_lim),
           "feedforward": bool(feedforward), "decouple": bool(decouple)}
    tuning = {**{k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in t.as_dict().items()},
              "gm_input": float(gm), "pm_input": float(pm), "wc_input": float(wc)}
    design = _design(spec, link_delay_steps, rate_filter_hz, params_default=params_default,
                     method="controllers.axis_design.tune_driven (loop shaping on the linearised rig at its zero-input trim)",
                     targets=dict(targets or {}), tuning=tuning)
    return HeaveSwayTables("pid", **model, reference=ref, scales=signal_scales(spec), law=law, design=design)


def design_heave_sway_lqr(spec: LoopSpec, params: RigParams | None = None, *, link_delay_steps: int = 1,
                          max_deviation: dict[str, float] | None = None) -> HeaveSwayTables:
    """Tables of :class:`controllers.heave_sway.HeaveSwayLQR` (steps 1-3; the weight search of its docstring)."""
    params_default, params = params is None, params or RigParams.default()
    model, points, ref = _model(spec, params)
    fd, j, V = spec.free_dofs, ref.joint, model["airspeeds"]
    hold_passive = spec.task != "free_flight_emulation"  # emulation: the model is free
    candidates = [max_deviation] if max_deviation is not None else [
        {j: math.radians(a), f"{j}_rate": math.radians(30.0), f"int_{j}": math.radians(a)} for a in ANGLE_MAX_DEG]
    chosen = None
    for md in candidates:  # loosest first: keep the tightest that meets the targets
        designs = [lqr_point(q, sys, fd, float(v), md) for v, (q, sys) in zip(V, points)]
        ok = all(gm >= LQR_TARGETS["gm_db"] and pm >= LQR_TARGETS["pm_deg"]
                 for gm, pm, _ in (lqr_margins(d, j, params, spec.dt, link_delay_steps, hold_passive) for d in designs))
        if ok or chosen is None:
            chosen = (designs, md)
        if not ok:
            break
    designs, md = chosen
    nq = len(fd)
    K = np.array([d.K[AXIS_OF[j]] for d in designs])  # (n_V, 2 nq + 1): this axis' row
    if not hold_passive:
        K[:, [i for i in range(2 * nq) if i % nq != fd.index(j)]] = 0.0
    points_out = []
    for d in designs:
        gm, pm, wc = lqr_margins(d, j, params, spec.dt, link_delay_steps, hold_passive)
        points_out.append({"airspeed": float(d.airspeed), "phi_deg": 0.0, "poles": [[float(p.real), float(p.imag)] for p in np.atleast_1d(d.poles)],
                           j: {"gm_db": float(gm), "pm_deg": float(pm), "wc": float(wc)}})
    gains = np.array([kalman_gain(spec.dt, SIGMA_A[x], SIGMA_Z) for x in fd])
    law = {"K": K, "A_q": np.array([d.A[nq:, :nq] for d in designs]), "A_w": np.array([d.A[nq:, nq:] for d in designs]),
           "B": np.array([d.B[nq:] for d in designs]), "kalman_gain": gains, "link_delay_steps": int(link_delay_steps)}
    design = _design(spec, link_delay_steps, params_default=params_default,
                     method="controllers.axis_design.lqr_point (control.lqr, Bryson weights, integral of the driven joint)",
                     max_deviation={k: float(v) for k, v in md.items()}, targets=dict(LQR_TARGETS),
                     sigma_a={x: float(SIGMA_A[x]) for x in fd}, sigma_z=float(SIGMA_Z), points=points_out)
    return HeaveSwayTables("lqr", **model, reference=ref, scales=signal_scales(spec), law=law, design=design)

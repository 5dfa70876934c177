"""Design of the heave and sway laws at the rig's own equilibrium: trim, linear model, PID tuning, LQR.

The roll laws (:mod:`controllers.design.model`) trim with rig_pitch and rig_yaw held at 0 deg.  The heave
and sway tasks fly around the rig's zero-input equilibrium instead (rig pitch about 4 deg at 20 m/s, 7 deg on the paper's model:
the model's lift balances the arm's weight; rig yaw at 0), where holding 0 deg would cost 16-17 deg
of elevator (27 on the paper's model).  So these designs trim there:

1. :func:`axis_point`: ``rig_env.trim`` with the compensator surfaces at zero (all the task's free
   joints settle), then ``rig_env.linearize`` (viscous friction kept) with the compensator elevator
   and rudder in normalised units (1 = ``scale_deg``); at rig roll 0 the virtual heave and sway inputs
   (:func:`controllers.design.model.resolve`) are the elevator and rudder themselves.
2. :func:`tune_driven`: the loop-shaping procedure of :func:`controllers.design.tuning.tune_axis` (same loop
   elements, grids and margin targets: inner PI PM >= 50 deg, GM >= 8 dB; outer P PM >= 60 deg,
   GM >= 10 dB; :func:`controllers.design.tuning.margins`) applied to the driven joint's rate plant of step 1
   with the law's decoupling of the passive joints closed around it (:func:`decoupled_rate_plant`), and the
   whole law broken at the surface command kept at :data:`AS_FLOWN_TARGETS` (GM >= 6 dB, PM >= 30 deg).
3. :func:`lqr_point`: ``control.lqr`` on the model of step 1 augmented with the integral of the driven
   joint's angle error (:func:`controllers.laws.lqr.augmented`), Bryson weights of :mod:`controllers.laws.lqr`
   (:data:`controllers.laws.lqr.MAX_DEVIATION`, :data:`controllers.laws.lqr.MAX_INPUT` scaled with airspeed).

The tables the numpy runtime (:mod:`controllers.laws.heave_sway`) executes, at every airspeed of a grid
over ``spec.airspeed_range`` (:data:`controllers.laws.heave_sway.V_STEP` apart):
at every airspeed of a grid over ``spec.airspeed_range`` (:data:`controllers.laws.heave_sway.V_STEP` apart):

1. :func:`controllers.design.heave_sway.axis_point`: the zero-input trim and its linear model; from it the
   driven joint's damping ``A'_jj``, control power ``b_j``, acceleration row, the trim angles and
   the passive joints' static ratio ``S = G_p / G_j`` (``G = -A_q^-1 B_axis``).
2. :func:`controllers.design.heave_sway.static_table`: the static input curve ``u_s(theta)``.
3. PID: :func:`controllers.design.heave_sway.tune_driven` at the middle airspeed, the servo's rate limit,
   and :func:`controllers.design.heave_sway.pid_margins_as_flown` for the report.  LQR: the weight search
   of :class:`controllers.laws.heave_sway.HeaveSwayLQR` (:func:`controllers.design.heave_sway.lqr_point`,
   :func:`controllers.design.heave_sway.lqr_margins`) and the estimator's Kalman gains
   (:data:`controllers.design.lqr.SIGMA_A`, :data:`controllers.design.lqr.SIGMA_Z`).

The reference parser's numbers (:func:`controllers.design.signals.reference_constants`) and the
observation's scales (:func:`controllers.design.signals.signal_scales`) are read from ``rig_env`` here and
stored in the tables, so the runtime never imports it.
"""

from __future__ import annotations

import math
from typing import Any

import control
import numpy as np

from controllers.design.lqr import MAX_DEVIATION, MAX_INPUT, SIGMA_A, SIGMA_Z, V_REF, Design, augmented, loop_margins
from controllers.design.model import INPUTS, check_flag, check_params, check_positive, check_steps, design_aero_model, loop_elements
from controllers.design.signals import reference_constants, signal_scales
from controllers.design.tuning import AxisTuning, margins, rate_tf, shape_loops
from controllers.laws.axes import AXIS_OF
from controllers.laws.base import LoopSpec
from rig_env import riccati
from controllers.design.estimator import kalman_gain
from controllers.laws.heave_sway import ANGLE_MAX_DEG, LQR_TARGETS, V_STEP, HeaveSwayTables
from rig_env import linearize, trim
from rig_env.params import JOINTS, RigParams

TARGET_KEYS = ("pm_inner", "gm_inner", "pm_outer", "gm_outer")
"""The margin targets :func:`design_heave_sway_pid`'s ``targets`` may override (:func:`tune_driven`'s arguments)."""
DRIVEN = ("rig_pitch", "rig_yaw")
"""Rig joints a heave/sway law drives (virtual input :data:`controllers.design.model.AXIS_OF`)."""
Q_GUESS_DEG = {"rig_pitch": 7.0}  # where the trim search starts (the rig's zero-input trim, task docstrings)


def axis_point(params: RigParams, free_dofs: tuple[str, ...], airspeed: float, scale_deg: float = 40.0,
               aero_model: str = "linear") -> tuple[np.ndarray, control.StateSpace]:
    """Zero-input equilibrium (5,) joint angles, rad, and the linear model there, on ``aero_model``
    (:func:`controllers.design.model.design_aero_model`).

    Model states ``<joint>``, ``<joint>_rate`` of ``free_dofs``; inputs the virtual (roll, heave,
    sway) in normalised units (roll column zero: the aileron is not used by these laws).
    """
    q0 = np.zeros(5)
    for j, deg in Q_GUESS_DEG.items():
        if j in free_dofs:  # a locked joint stays at its guess
            q0[JOINTS.index(j)] = math.radians(deg)
    op = trim(params, free_dofs=free_dofs, airspeed=float(airspeed), controls={}, q_guess=q0, aero_model=design_aero_model(aero_model))
    sys = linearize(params, op, inputs=INPUTS, friction="viscous")
    B = np.asarray(sys.B) * math.radians(scale_deg)
    B[:, 0] = 0.0
    out = control.ss(sys.A, B, sys.C, np.zeros_like(B), states=sys.state_labels, inputs=["roll", "heave", "sway"],
                     outputs=sys.output_labels)
    return op.q.copy(), out


def rate_plant(sys: control.StateSpace, joint: str) -> control.TransferFunction:
    """Joint rate (rad/s) per normalised virtual input of its axis, from the model of :func:`axis_point`."""
    return rate_tf(sys, joint)


AS_FLOWN_TARGETS = {"gm_db": 6.0, "pm_deg": 30.0}
"""Margins of the whole PID law broken at the surface command (cascade and decoupling together,
:func:`pid_margins_as_flown`) that :func:`tune_driven` keeps besides the cascade's own targets."""


def tune_driven(params: RigParams, sys: control.StateSpace, joint: str, airspeed: float, dt: float, *,
                link_delay_steps: int = 1, rate_filter_hz: float = 10.0, pm_inner: float = 50.0, gm_inner: float = 8.0,
                pm_outer: float = 60.0, gm_outer: float = 10.0, decouple: str | None = "passive") -> AxisTuning:
    """Step 2 of the module docstring (``tuning.shape_loops``' procedure); ValueError if infeasible.

    With ``decouple`` (``"passive"``, ``"all"``: :func:`pid_margins_as_flown`) the cascade is shaped on the
    rate plant the decoupling leaves it (:func:`decoupled_rate_plant`: the decoupling's loop closed, servo and
    delay in it), and its outer gain is the largest that also keeps the whole law's margins broken at the
    surface command at :data:`AS_FLOWN_TARGETS`.  Shaping on the plain rate plant and adding the decoupling
    afterwards changes the loop the margins were read on: on the default rig, where heave drives the Hawk's
    pitch (the alpha-dot split) across the lightly damped heave mode, that left a gain margin of 5.3 dB."""
    if joint not in DRIVEN:
        raise ValueError(f"joint = {joint!r}: driven joints are {list(DRIVEN)}")
    el = loop_elements(params, dt, link_delay_steps, rate_filter_hz)
    if decouple is None:
        return shape_loops(rate_plant(sys, joint), el, joint, airspeed,
                           pm_inner=pm_inner, gm_inner=gm_inner, pm_outer=pm_outer, gm_outer=gm_outer)

    def accept(kp: float, ki: float, k_angle: float) -> bool:
        gm, pm, _ = margins(as_flown_loop(sys, joint, kp, ki, k_angle, el, decouple))
        return gm >= AS_FLOWN_TARGETS["gm_db"] and pm >= AS_FLOWN_TARGETS["pm_deg"]

    return shape_loops(decoupled_rate_plant(sys, joint, el, decouple), el, joint, airspeed,
                       pm_inner=pm_inner, gm_inner=gm_inner, pm_outer=pm_outer, gm_outer=gm_outer, accept=accept)


def _angle_tf(sys: control.StateSpace, joint: str, i: int) -> control.TransferFunction:
    """State i of the model of :func:`axis_point` per unit input of ``joint``'s axis."""
    n = len(sys.state_labels)
    return control.ss2tf(control.ss(sys.A, sys.B[:, [AXIS_OF[joint]]], np.eye(n)[[i]], 0.0))


def _decoupling_tf(sys: control.StateSpace, joint: str, el: dict, decouple: str) -> control.TransferFunction:
    """``(A_jp + A'_jp H(s) s) P_p(s) / b_j`` summed over the decoupled joints p (the passive ones; with
    ``decouple="all"`` the driven joint's own row too): the decoupling's command per unit input, before the
    servo and delay."""
    if decouple not in ("passive", "all"):
        raise ValueError(f"decouple = {decouple!r}: allowed 'passive', 'all'")
    s = control.tf("s")
    nq = len(sys.state_labels) // 2
    k = sys.state_labels.index(joint)
    A = np.asarray(sys.A)
    b = float(sys.B[nq + k, AXIS_OF[joint]])
    H = el["rate_sensor"]
    D = 0 * s
    for i in range(nq):
        if i != k or decouple == "all":
            D = D + (A[nq + k, i] + A[nq + k, nq + i] * H * s) * _angle_tf(sys, joint, i) / b
    return D


def decoupled_rate_plant(sys: control.StateSpace, joint: str, el: dict, decouple: str = "passive") -> control.TransferFunction:
    """The driven joint's rate per unit command of the cascade with the decoupling's loop closed,
    ``s P_j / (1 + Dec S D)`` (:func:`_decoupling_tf`; S, D the servo and delay of ``el``)."""
    s = control.tf("s")
    loop = _decoupling_tf(sys, joint, el, decouple) * el["servo"] * el["delay"]
    return control.minreal(s * _angle_tf(sys, joint, sys.state_labels.index(joint)) / (1 + loop), verbose=False)


def as_flown_loop(sys: control.StateSpace, joint: str, kp: float, ki: float, k_angle: float, el: dict,
                  decouple: str | None = "passive") -> control.TransferFunction:
    """The heave/sway PID (gains kp, ki, k_angle) broken at the surface command, servo and delay in
    (:func:`pid_margins_as_flown`'s loop)."""
    s = control.tf("s")
    L = (kp + ki / s) * (k_angle + el["rate_sensor"] * s) * _angle_tf(sys, joint, sys.state_labels.index(joint))
    if decouple:
        L = L + _decoupling_tf(sys, joint, el, decouple)
    return L * el["servo"] * el["delay"]


def lqr_point(q_op: np.ndarray, sys: control.StateSpace, free_dofs: tuple[str, ...], airspeed: float,
              max_deviation: dict[str, float] | None = None, max_input: dict[str, float] | None = None) -> Design:
    """Step 3 of the module docstring at one airspeed; a :class:`controllers.laws.lqr.Design` (phi = 0).

    ``max_deviation``, ``max_input``: Bryson maxima overriding :data:`controllers.laws.lqr.MAX_DEVIATION`
    and :data:`controllers.laws.lqr.MAX_INPUT` entry by entry."""
    md = {**MAX_DEVIATION, **(max_deviation or {})}
    mi = {**MAX_INPUT, **(max_input or {})}
    A, B = np.asarray(sys.A), np.asarray(sys.B)
    Aa, Ba, ilabels = augmented(A, B, free_dofs)
    labels = list(sys.state_labels) + ilabels
    Q = np.diag([1.0 / md[s] ** 2 for s in labels])
    used = [AXIS_OF[j] for j in DRIVEN if j in free_dofs]
    axis_name = {1: "heave", 2: "sway"}
    R = np.diag([1.0 / (mi[axis_name[k]] * V_REF / airspeed) ** 2 for k in used])
    Kr, P, poles = riccati.lqr(Aa, Ba[:, used], Q, R, discrete=False, what=f"heave/sway LQR at {airspeed:g} m/s")
    K = np.zeros((3, Aa.shape[0]))
    K[used] = Kr
    q_free = q_op[[JOINTS.index(j) for j in free_dofs]]
    return Design(tuple(free_dofs), float(airspeed), 0.0, K, np.zeros(3), q_free, A, B, Q, R, np.asarray(P), np.asarray(poles))


def lqr_margins(d: Design, joint: str, params: RigParams, dt: float, link_delay_steps: int = 1,
                hold_passive: bool = True) -> tuple[float, float, float]:
    """(GM dB, PM deg, crossover rad/s) of the LQR loop broken at the driven joint's input, servo and delay in.

    ``hold_passive=False``: the gains on the passive model joints are zeroed first (the law as flown
    when it leaves the model free, free-flight emulation)."""
    K = d.K.copy()
    if not hold_passive:
        nq = len(d.free_dofs)
        for k, j in enumerate(d.free_dofs):
            if j not in DRIVEN:
                K[:, k] = 0.0
                K[:, nq + k] = 0.0
    dd = Design(d.free_dofs, d.airspeed, d.phi, K, d.u_trim, d.q_op, d.A, d.B, d.Q, d.R, d.P, d.poles)
    return loop_margins(dd, AXIS_OF[joint], loop_elements(params, dt, link_delay_steps))


U_TABLE = np.linspace(-0.9, 0.9, 19)
"""Normalised driven-axis inputs of the static trim table (:func:`static_table`)."""


def static_table(params: RigParams, free_dofs: tuple[str, ...], joint: str, airspeed: float,
                 scale_deg: float = 40.0, aero_model: str = "linear") -> tuple[np.ndarray, np.ndarray]:
    """The rig's static input curve: (theta (m,) rad ascending, u (m,) normalised) with ``rig_env.trim``.

    For each steady elevator (rig_pitch) or rudder (rig_yaw) input of :data:`U_TABLE` every free joint
    settles (passive model joints included); ``u(theta)`` interpolated in this table is the input
    that holds the driven joint at theta, the nonlinear (large-angle) form of the linear stiffness.
    Inputs whose equilibrium lies beyond the joint's stops or is not found are left out.
    """
    surface = {"rig_pitch": "comp_elevator", "rig_yaw": "comp_rudder"}[joint]
    jq = JOINTS.index(joint)
    q0 = np.zeros(5)
    for j, deg in Q_GUESS_DEG.items():
        if j in free_dofs:  # a locked joint stays at its guess
            q0[JOINTS.index(j)] = math.radians(deg)
    th, us = [], []
    for branch in (U_TABLE[U_TABLE >= 0], U_TABLE[U_TABLE < 0][::-1]):  # outward from 0, each trim from the last
        guess = q0.copy()
        for u in branch:
            if abs(u) * scale_deg > params.servos.compensator.limit_deg:  # beyond the flaps' travel: no such trim
                break
            try:
                op = trim(params, free_dofs=free_dofs, airspeed=float(airspeed), controls={surface: float(u) * scale_deg}, q_guess=guess,
                          aero_model=design_aero_model(aero_model))
            except RuntimeError:
                break
            if abs(op.q[jq]) >= math.radians(30.0):
                break
            th.append(op.q[jq])
            us.append(float(u))
            guess = op.q.copy()
    order = np.argsort(th)
    th_a, u_a = np.asarray(th)[order], np.asarray(us)[order]
    if th_a.size < 3 or np.any(np.diff(th_a) <= 0):
        raise ValueError(f"{joint} at {airspeed} m/s: the static input curve is not monotonic ({np.degrees(th_a)} deg)")
    return th_a, u_a


def pid_margins_as_flown(params: RigParams, sys: control.StateSpace, joint: str, t: AxisTuning, dt: float, *,
                         decouple: str | None = "passive", link_delay_steps: int = 1, rate_filter_hz: float = 10.0) -> tuple[float, float, float]:
    """(GM dB, PM deg, crossover rad/s) of the heave/sway PID broken at the surface command, servo and delay in.

    The cascade feeds back ``u = -C(s) (k_angle theta + H(s) theta')`` (``C = kp + ki / s``, ``H`` the rate
    sensor) and, with ``decouple="passive"``, ``-(A_jp theta_p + A'_jp H(s) theta_p') / b_j`` on the passive
    joints, so ``L(s) = [C (k_angle + H s) P_j + (A_jp + A'_jp H s) P_p / b_j] S D`` with ``P_j``, ``P_p`` the
    angles per unit input of the model of :func:`axis_point`; ``decouple="all"`` adds the driven joint's own
    row too (the inverse dynamics of free-flight emulation); None: the cascade alone."""
    if decouple not in (None, "passive", "all"):
        raise ValueError(f"decouple = {decouple!r}: allowed None, 'passive', 'all'")
    el = loop_elements(params, dt, link_delay_steps, rate_filter_hz)
    return margins(as_flown_loop(sys, joint, t.kp, t.ki, t.k_angle, el, decouple))


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
    points = [axis_point(params, fd, float(v), spec.action_scale_deg, spec.aero_model) for v in V]
    nq, k = len(fd), fd.index(joint)
    p = [i for i in range(nq) if i != k]
    cw, b, S = [], [], []
    for _, sys in points:
        A, B = np.asarray(sys.A), np.asarray(sys.B)
        G = -np.linalg.solve(A[nq:, :nq], B[nq:, AXIS_OF[joint]])  # static gain: joint angles per unit input
        cw.append(A[nq:, nq:][k, k])
        b.append(B[nq + k, AXIS_OF[joint]])
        S.append(G[p] / G[k])
    curves = [static_table(params, fd, joint, float(v), spec.action_scale_deg, spec.aero_model) for v in V]
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
    return {"airspeed_range": list(spec.airspeed_range), "link_delay_steps": int(link_delay_steps), "rate_filter_hz": float(rate_filter_hz),
            "aero_model": design_aero_model(spec.aero_model), **extra}


def design_heave_sway_pid(spec: LoopSpec, params: RigParams | None = None, *, link_delay_steps: int = 1, rate_filter_hz: float = 10.0,
                          feedforward: bool = True, decouple: bool = True, targets: dict[str, float] | None = None) -> HeaveSwayTables:
    """Tables of :class:`controllers.laws.heave_sway.HeaveSwayPID` (steps 1-3).

    ``targets``: margin targets overriding :func:`tune_driven`'s (``pm_inner``, ``gm_inner``, ``pm_outer``, ``gm_outer``).
    ValueError, before any design work, for a bad option: ``link_delay_steps`` an integer in [0, 100],
    ``rate_filter_hz`` a finite number > 0, ``feedforward`` and ``decouple`` bools, ``targets`` keys among those four."""
    check_params(params)
    link_delay_steps = check_steps("link_delay_steps", link_delay_steps)
    rate_filter_hz = check_positive("rate_filter_hz", rate_filter_hz)
    feedforward, decouple = check_flag("feedforward", feedforward), check_flag("decouple", decouple)
    unknown = sorted(set(targets or {}) - set(TARGET_KEYS))  # else a TypeError from tune_driven's signature
    if unknown:
        raise ValueError(f"targets: unknown key(s) {unknown}; allowed {list(TARGET_KEYS)}")
    params_default, params = params is None, params or RigParams.default()
    model, points, ref = _model(spec, params)
    V = model["airspeeds"]
    i_mid = int(np.argmin(np.abs(V - 0.5 * (V[0] + V[-1]))))
    v_design = float(V[i_mid])
    emulate = spec.task == "free_flight_emulation"
    how = "all" if emulate else ("passive" if decouple else None)
    # free-flight emulation's inverse dynamics is not shaped around: with its loop closed in the plant the cascade met
    # every margin but flew 0 of 32 emulation episodes at 20 m/s without gusts (shaped on the plain plant: 8 of 32)
    t = tune_driven(params, points[i_mid][1], ref.joint, v_design, spec.dt, link_delay_steps=link_delay_steps,
                    rate_filter_hz=rate_filter_hz, decouple=None if emulate else how, **(targets or {}))
    rate_lim = params.servos.compensator.rate_limit_deg_s / spec.action_scale_deg
    gm, pm, wc = pid_margins_as_flown(params, points[i_mid][1], ref.joint, t, spec.dt, decouple=how, link_delay_steps=link_delay_steps,
                                      rate_filter_hz=rate_filter_hz)
    law = {"kp": float(t.kp), "ki": float(t.ki), "k_angle": float(t.k_angle), "v_design": v_design, "rate_limit": float(rate_lim),
           "feedforward": bool(feedforward), "decouple": bool(decouple)}
    tuning = {**{k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in t.as_dict().items()},
              "gm_input": float(gm), "pm_input": float(pm), "wc_input": float(wc)}
    design = _design(spec, link_delay_steps, rate_filter_hz, params_default=params_default,
                     method="controllers.design.heave_sway.tune_driven (loop shaping on the linearised rig at its zero-input trim)",
                     targets=dict(targets or {}), tuning=tuning)
    return HeaveSwayTables("pid", **model, reference=ref, scales=signal_scales(spec), law=law, design=design)


def design_heave_sway_lqr(spec: LoopSpec, params: RigParams | None = None, *, link_delay_steps: int = 1,
                          max_deviation: dict[str, float] | None = None) -> HeaveSwayTables:
    """Tables of :class:`controllers.laws.heave_sway.HeaveSwayLQR` (steps 1-3; the weight search of its docstring).

    ``max_deviation``: Bryson maxima (keys of :data:`controllers.design.lqr.MAX_DEVIATION`, values finite > 0)
    replacing the search.  ValueError, before any design work, for an unknown key, a bad value or a
    ``link_delay_steps`` that is not an integer in [0, 100]."""
    check_params(params)
    link_delay_steps = check_steps("link_delay_steps", link_delay_steps)
    if max_deviation is not None:  # an unknown key was ignored silently and a negative maximum squared away
        unknown = sorted(set(max_deviation) - set(MAX_DEVIATION))
        if unknown:
            raise ValueError(f"max_deviation: unknown key(s) {unknown}; allowed {sorted(MAX_DEVIATION)}")
        max_deviation = {k: check_positive(f"max_deviation[{k!r}]", v) for k, v in max_deviation.items()}
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
                     method="controllers.design.heave_sway.lqr_point (control.lqr, Bryson weights, integral of the driven joint)",
                     max_deviation={k: float(v) for k, v in md.items()}, targets=dict(LQR_TARGETS),
                     sigma_a={x: float(SIGMA_A[x]) for x in fd}, sigma_z=float(SIGMA_Z), points=points_out)
    return HeaveSwayTables("lqr", **model, reference=ref, scales=signal_scales(spec), law=law, design=design)

"""Design of the model-following LQR (:mod:`controllers.laws.emulation`): the tables its numpy runtime executes.

Imported only when a law is designed (python-control, scipy, the numba model, ``rig_env``).  At every
airspeed of a grid over ``spec.airspeed_range`` (:data:`controllers.laws.emulation.V_STEP` apart):

1. :func:`continuous_model`: the rig at its zero-input trim (:func:`controllers.design.heave_sway.axis_point`,
   plus ``rig_env.linearize``'s Hawk-elevator and uniform vertical-gust columns there), the compensator and
   Hawk servos, the free Hawk's short period (the task's ``FreeHawkShortPeriod.matrices`` and
   ``gust_column``), the pilot command and the gust, side by side (the state table of
   :mod:`controllers.laws.emulation`).
2. :func:`zoh_with_delay`: exact zero-order-hold discretisation at the control period with the loop's
   input delay (servo delay + ``link_delay_steps`` periods), the delay line appended to the state.
3. ``control.dlqr`` with the Bryson weights of the module docstring; :func:`kalman_gain`, the estimator's; both
   Riccati solutions checked by their residuals (:mod:`rig_env.riccati`).
4. :func:`loop_as_flown`: the margins of the law as it flies (estimator and delay line, the rig with
   servo and delay), recorded in ``design["points"]``.
"""

from __future__ import annotations

import math
from typing import Any

import control
import numpy as np
from scipy.linalg import expm

from controllers.design.heave_sway import axis_point
from controllers.design.model import check_params, check_positive, check_steps
from controllers.laws.base import LoopSpec
from controllers.laws.emulation import (
    BASE_STATES,
    ESTIMATED,
    MEASURED,
    GUST_TAU,
    MAX_DEVIATION,
    MAX_INPUT,
    REF_ENTRIES,
    SIGMA_A,
    SIGMA_F,
    SIGMA_GUST,
    SIGMA_REF,
    SIGMA_Z,
    SIGMA_ZF,
    SIGMA_ZR,
    TARGETS,
    TAU_PILOT,
    V_REF,
    V_STEP,
    WEIGHT_SCALES,
    EmulationTables,
    check_emulation,
    state_labels,
)
from rig_env import riccati
from controllers.design.signals import signal_scales
from rig_env import linearize, trim
from rig_env.params import RigParams

_S = {k: i for i, k in enumerate(BASE_STATES)}


def zoh_with_delay(A: np.ndarray, b: np.ndarray, h: float, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """Sampling ``x' = A x + b u(t - tau)`` with a zero-order hold of period h: ``x(k+1) = Phi x(k) + sum_j G[j] u(k - j)``.

    Astrom & Wittenmark, *Computer-Controlled Systems*, sec. 2.3 (time delay): with ``tau = (d - 1) h + tau'``,
    0 < tau' <= h, ``G[d-1] = int_0^{h-tau'} e^{As} ds b`` and ``G[d] = e^{A(h-tau')} int_0^{tau'} e^{As} ds b``; tau = 0 gives
    the plain hold (d = 0).  Returns (Phi (n, n), G (d + 1, n)).
    """
    h, tau = check_positive("h", h), check_positive("tau", tau, allow_zero=True)  # tau = inf: OverflowError in int()
    A, b = np.asarray(A, dtype=float), np.asarray(b, dtype=float)
    n = A.shape[0] if A.ndim == 2 else -1
    if A.shape != (n, n) or b.shape != (n,):
        raise ValueError(f"A, b: shapes {A.shape}, {b.shape}; allowed (n, n) and (n,)")

    def hold(t: float) -> tuple[np.ndarray, np.ndarray]:  # (e^{At}, int_0^t e^{As} ds b)
        M = np.zeros((n + 1, n + 1))
        M[:n, :n], M[:n, n] = A, b
        E = expm(M * t)
        return E[:n, :n], E[:n, n]

    Phi, g = hold(h)
    d = math.ceil(tau / h - 1e-9)
    G = np.zeros((d + 1, n))
    if d == 0:
        G[0] = g
        return Phi, G
    tp = tau - (d - 1) * h
    E1, g0 = hold(h - tp)
    G[d - 1] = g0
    G[d] = E1 @ hold(tp)[1]
    return Phi, G


def servo_matrices(wn: float, zeta: float) -> tuple[np.ndarray, np.ndarray]:
    """(A (2, 2), b (2,)) of the servo ``s'' = wn^2 (u - s) - 2 zeta wn s'`` (``rig_env.physics.servo``), state (s, s')."""
    return np.array([[0.0, 1.0], [-wn**2, -2.0 * zeta * wn]]), np.array([0.0, wn**2])


def continuous_model(params: RigParams, airspeed: float, dt: float, tau_pilot: float = TAU_PILOT,
                     tau_gust: float = GUST_TAU) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
    """Step 1: (A (12, 12), b (12,), q_op (5,), free-Hawk model) in the :data:`controllers.laws.emulation.BASE_STATES` order; b: heave command (normalised).

    The gust state is the vertical gust's angle of attack alpha_g = -w_g / V (world z down), a first-order
    Gauss-Markov process of correlation time ``tau_gust``; it moves the rig through ``linearize``'s uniform
    ``gust_z`` column (per m/s, so times -V) and the free Hawk through its ``gust_column``, as the task flies
    the reference in the rig's air."""
    from rig_env.envs.tasks.freeflight import FreeHawkShortPeriod

    fd = ("rig_pitch", "model_pitch")
    P = params.to_vector()
    q_op, sys = axis_point(params, fd, airspeed)
    op = trim(params, free_dofs=fd, airspeed=float(airspeed), controls={}, q_guess=q_op)
    B_in = np.asarray(linearize(params, op, inputs=["hawk_elevator", "gust_z"], friction="viscous").B)
    b_hawk, b_gust = B_in[:, 0], -float(airspeed) * B_in[:, 1]  # per rad of alpha_g = -w_g / V
    ref = FreeHawkShortPeriod(1, dt)
    ref.configure(np.array([0]), np.array([float(airspeed)]), P[None])
    Am = ref.matrices(np.array([0]))[0][0]  # states alpha, q, theta, h, delta, delta'
    n = len(BASE_STATES)
    A, b = np.zeros((n, n)), np.zeros(n)
    r, f, m, hw, w, g = 0, _S["flap"], _S["alpha_ff"], _S["hawk_elevator"], _S["pilot_cmd"], _S["gust_alpha"]
    A[r:4, r:4] = np.asarray(sys.A)
    A[r:4, f] = np.asarray(sys.B)[:, 1]  # heave column, per normalised input
    A[r:4, hw] = b_hawk
    A[r:4, g] = b_gust
    A[f:f + 2, f:f + 2], b[f:f + 2] = servo_matrices(2 * math.pi * params.servos.compensator.natural_freq_hz, params.servos.compensator.damping)
    sub = [0, 1, 4, 5]  # alpha, q, delta, delta': theta and h do not feed back
    A[m:m + 4, m:m + 4] = Am[np.ix_(sub, sub)]  # includes the Hawk servo rows of the reference
    A[hw + 1, w] = ref.wn[0] ** 2
    A[w, w] = -1.0 / tau_pilot
    A[m:m + 2, g] = ref.gust_column(np.array([0]))[0, :2]  # alpha, q of the free Hawk
    A[g, g] = -1.0 / tau_gust
    return A, b, q_op, ref


def error_outputs(q_op: np.ndarray, airspeed: float, arm_length: float, n: int) -> np.ndarray:
    """(3, n): e_alpha, e_q and the rig pitch's deviation, linear in the state (the module docstring's cost)."""
    C = np.zeros((3, n))
    C[0, _S["alpha_ff"]] = 1.0
    C[0, [_S["rig_pitch"], _S["model_pitch"], _S["rig_pitch_rate"]]] = [-1.0, -1.0, arm_length * math.cos(q_op[1]) / airspeed]
    C[1, _S["q_ff"]] = 1.0
    C[1, [_S["rig_pitch_rate"], _S["model_pitch_rate"]]] = -1.0
    C[2, _S["rig_pitch"]] = 1.0
    return C


def measurement_rows(ref: Any, n: int) -> np.ndarray:
    """(5, n): the :data:`controllers.laws.emulation.MEASURED` quantities as rows of the design state: the two angles,
    the heave flap, q_ff, and a_n / V of the free Hawk, linear in alpha_ff + alpha_g, q_ff and delta
    (``FreeHawkShortPeriod.lift_row``, which its ``normal_acceleration`` uses; ``ref`` its model at the design airspeed)."""
    C = np.zeros((len(MEASURED), n))
    C[0, _S["rig_pitch"]] = C[1, _S["model_pitch"]] = C[2, _S["flap"]] = C[3, _S["q_ff"]] = 1.0
    ka, kq, kd = (float(k[0]) for k in ref.lift_row())
    C[4, [_S["alpha_ff"], _S["gust_alpha"], _S["q_ff"], _S["hawk_elevator"]]] = [ka, ka, kq, kd]
    return C


def kalman_gain(A_est: np.ndarray, C_est: np.ndarray, dt: float, sigma_a: tuple[float, float] = SIGMA_A, sigma_f: float = SIGMA_F,
                sigma_z: float = SIGMA_Z, sigma_zf: float = SIGMA_ZF, sigma_g: float = SIGMA_GUST,
                sigma_ref: tuple[float, float] = SIGMA_REF, sigma_zr: tuple[float, float] = SIGMA_ZR) -> np.ndarray:
    """(9, 5) steady-state Kalman gain of the :data:`controllers.laws.emulation.ESTIMATED` states from the
    :data:`controllers.laws.emulation.MEASURED` quantities.

    Model ``x+ = A_est x + (known inputs)``, ``z = C_est x + (known part)``; process noise: white accelerations of
    the two joints (rad/s^2, ``sigma_a``) and of the flap (normalised/s^2, ``sigma_f``: the servo model's error)
    held over a period (``dt^2 / 2`` and ``dt`` per unit), white rates of the free Hawk's alpha and q
    (``sigma_ref``, over ``dt``: its derivatives differ from the task's by the episode's mass and air), and the
    gust's own innovation ``sigma_g^2 (1 - a^2)``, ``a`` its one-period decay (a Gauss-Markov process of variance
    ``sigma_g^2`` sampled exactly); measurement noise: the two angles ``sigma_z`` (rad), the flap ``sigma_zf``
    (normalised), q_ref and a_n / V ``sigma_zr``.  The a-priori covariance from scipy's discrete Riccati solver (checked: :mod:`rig_env.riccati`);
    ``L = P C' (C P C' + R)^-1``, the correction applied to the prediction.  Measuring the flap (the plant's
    input, as the rig's encoders do) keeps the law's margins close to the state feedback's (loop transfer
    recovery; an estimator driven by the commanded input alone lost some 15 deg of phase margin here).  The gust
    is seen in the free Hawk's normal acceleration (its lift responds at once), and in the rig's angles as the
    accelerations the rest of the model does not explain.
    """
    h2 = 0.5 * dt * dt
    e = {k: i for i, k in enumerate(ESTIMATED)}
    Gn = np.zeros((len(ESTIMATED), 5))
    Gn[e["rig_pitch"], 0] = Gn[e["model_pitch"], 1] = Gn[e["flap"], 2] = h2
    Gn[e["rig_pitch_rate"], 0] = Gn[e["model_pitch_rate"], 1] = Gn[e["flap_rate"], 2] = dt
    Gn[e["alpha_ff"], 3] = Gn[e["q_ff"], 4] = dt
    Qn = Gn @ np.diag([sigma_a[0] ** 2, sigma_a[1] ** 2, sigma_f**2, sigma_ref[0] ** 2, sigma_ref[1] ** 2]) @ Gn.T
    g = e["gust_alpha"]
    Qn[g, g] = sigma_g**2 * (1.0 - A_est[g, g] ** 2)
    Rn = np.diag([sigma_z**2, sigma_z**2, sigma_zf**2, sigma_zr[0] ** 2, sigma_zr[1] ** 2])
    P = riccati.solve_are(A_est.T, C_est.T, Qn, Rn, discrete=True, what="model-following LQR's estimator")
    return P @ C_est.T @ np.linalg.inv(C_est @ P @ C_est.T + Rn)


EST = [_S[k] for k in ESTIMATED]
"""Design-model states the estimator estimates (:data:`controllers.laws.emulation.ESTIMATED`): the rig's angles and
rates, the heave flap's position and rate, the free Hawk's alpha_ff and q_ff, the gust."""


def design_point(params: RigParams, airspeed: float, dt: float, link_delay_steps: int, md: dict[str, float], max_input: float,
                 sigma_a: tuple[float, float] = SIGMA_A, sigma_f: float = SIGMA_F, sigma_z: float = SIGMA_Z, sigma_zf: float = SIGMA_ZF,
                 sigma_g: float = SIGMA_GUST) -> dict[str, Any]:
    """Steps 1-4 at one airspeed: the augmented discrete model, the gain, the estimator's gain and the margins of the loop as flown (:func:`loop_as_flown`)."""
    A, b, q_op, ref = continuous_model(params, airspeed, dt)
    tau = params.servos.compensator.delay_s + link_delay_steps * dt
    Phi, G = zoh_with_delay(A, b, dt, tau)
    n, d = A.shape[0], G.shape[0] - 1
    N = n + d
    Ad, Bd = np.zeros((N, N)), np.zeros((N, 1))
    Ad[:n, :n], Bd[:n, 0] = Phi, G[0]
    for j in range(1, d + 1):
        Ad[:n, n + j - 1] = G[j]
    if d:
        Bd[n, 0] = 1.0
        for j in range(1, d):
            Ad[n + j, n + j - 1] = 1.0
    C = error_outputs(q_op, airspeed, float(params.geometry.arm_length), N)
    W = np.diag([1.0 / md["alpha_error"] ** 2, 1.0 / md["q_error"] ** 2, 1.0 / md["rig_pitch"] ** 2])
    u_max = max_input * V_REF / airspeed
    Q = (C.T @ W @ C + 1e-8 * np.eye(N)) * dt  # the tiny identity only makes Q definite (every mode is stable or controlled)
    R = np.array([[dt / u_max**2]])
    K, _, poles = riccati.lqr(Ad, Bd, Q, R, discrete=True, what=f"model-following LQR at {airspeed:g} m/s")
    pt = {"airspeed": float(airspeed), "K": np.asarray(K)[0], "q_op": q_op[[1, 3]], "Ad": Ad, "Bd": Bd, "poles": np.asarray(poles), "d": d,
          "hawk_wn": float(ref.wn[0]), "hawk_zeta": float(ref.zeta[0]), "hawk_delay_steps": int(ref.delay_steps[0])}
    pt["meas_rows"] = measurement_rows(ref, N)
    pt["kalman_gain"] = kalman_gain(Ad[np.ix_(EST, EST)], pt["meas_rows"][:, EST], dt, sigma_a, sigma_f, sigma_z, sigma_zf, sigma_g)
    pt["margins"] = loop_as_flown(pt, dt)
    return pt


def loop_as_flown(pt: dict[str, Any], dt: float) -> dict[str, float]:
    """Margins (:func:`margins_discrete`) of the law as flown, broken at the heave command.

    Plant: the rig with the compensator servo and the loop's delay (the design's discrete model, the
    reference and pilot states dropped: they do not depend on the command); out: the two angles and the
    flap position.  Controller: the estimator (prediction ``p`` from the model's rows, correction
    ``x = p + L (z - C p)``), ``K`` on its estimate and on the delay line of the law's own commands
    (:meth:`controllers.laws.emulation.EmulationLQR.act`): a dynamic system of its own, so this loop, not the
    state-feedback one, is the one the rig closes (an estimator can erode an LQR's margins; Doyle,
    "Guaranteed margins for LQG regulators", IEEE TAC 1978).
    """
    Ad, Bd, K, d, Lk = pt["Ad"], pt["Bd"], pt["K"], pt["d"], pt["kalman_gain"]
    n = len(BASE_STATES)
    keep = [*EST, *range(n, n + d)]  # rig, flap, free Hawk and gust (uncontrolled, stable), delay line
    Ap, Bp = Ad[np.ix_(keep, keep)], Bd[keep]
    m = len(keep)
    C = pt["meas_rows"][:, keep]  # the free Hawk's rows: its states are kept (they do not depend on the command); the Hawk servo's part is known
    nm = C.shape[0]
    plant = control.ss(Ap, Bp, C, np.zeros((nm, 1)), dt)
    Kk = K[keep]
    ne = len(EST)
    Mx, Nx = np.eye(m), np.zeros((m, nm))  # x_hat = Mx s + Nx z, controller state s = (p (9), delay line (d))
    Mx[:ne] -= Lk @ C[:, :m]
    Nx[:ne] = Lk
    Ku_s, Ku_z = -Kk @ Mx, -Kk @ Nx  # u = Ku_s s + Ku_z z
    ctrl = control.ss(Ap @ Mx + np.outer(Bp[:, 0], Ku_s), Ap @ Nx + np.outer(Bp[:, 0], Ku_z), Ku_s[None, :], Ku_z[None, :], dt)
    return margins_discrete(-(ctrl * plant), dt)


def margins_discrete(L: control.StateSpace, dt: float, n_w: int = 4000) -> dict[str, float]:
    """Margins of a stable discrete SISO loop ``L`` (negative feedback), read off its frequency response on a log grid up to Nyquist.

    ``gm_db``: the smallest gain increase to reach -1 (phase crossings with |L| < 1; inf if none); ``gm_low_db``:
    the largest gain reduction that does (crossings with |L| > 1, a conditionally stable loop; -inf if none);
    ``pm_deg``: 180 deg minus the largest |phase| at a gain crossover (phase in (-180, 180]); ``wc``: that
    crossover, rad/s; ``delay_margin_s``: pm / wc, the extra loop delay that would destabilise it; ``sm``:
    min |1 + L|, the distance of the Nyquist curve to -1; ``rho``: the closed loop's largest |z| (< 1: stable).
    The design's tables store an infinite margin as None (JSON).
    """
    w = np.geomspace(1e-2, math.pi / dt, n_w)
    A, B, C, D = (np.asarray(x, dtype=np.float64) for x in (L.A, L.B, L.C, L.D))
    z = np.exp(1j * w * dt)
    Lw = (C @ np.linalg.solve(z[:, None, None] * np.eye(A.shape[0]) - A, np.broadcast_to(B, (w.size, *B.shape))))[:, 0, 0] + D[0, 0]
    mag, ph = np.abs(Lw), np.angle(Lw)
    out = {"gm_db": math.inf, "gm_low_db": -math.inf, "pm_deg": 180.0, "wc": 0.0, "delay_margin_s": math.inf,
           "sm": float(np.min(np.abs(1.0 + Lw))), "rho": float(np.max(np.abs(np.linalg.eigvals(A - B @ C / (1.0 + D[0, 0])))))}
    im = np.imag(Lw)
    for k in np.flatnonzero((np.sign(im[:-1]) != np.sign(im[1:])) & (np.real(Lw[:-1]) < 0)):  # crossings of the negative real axis
        g = -20.0 * math.log10(max(mag[k], 1e-300))
        if g > 0:
            out["gm_db"] = min(out["gm_db"], g)
        else:
            out["gm_low_db"] = max(out["gm_low_db"], g)
    for k in np.flatnonzero(np.sign(mag[:-1] - 1.0) != np.sign(mag[1:] - 1.0)):  # gain crossovers
        pm = 180.0 - abs(math.degrees(ph[k]))
        if pm < out["pm_deg"]:
            out.update(pm_deg=pm, wc=float(w[k]), delay_margin_s=math.radians(pm) / float(w[k]))
    return out


def _maximum(name: str, v: object) -> float:
    """A Bryson maximum as a float; ValueError naming ``name`` unless a finite real number > 0."""
    try:
        return check_positive(name, v)
    except ValueError:
        raise ValueError(f"{name} = {v!r}: every maximum must be finite and > 0; allowed a real number > 0") from None


def design_emulation_lqr(spec: LoopSpec, params: RigParams | None = None, *, link_delay_steps: int = 1,
                         max_deviation: dict[str, float] | None = None, max_input: float | None = None) -> EmulationTables:
    """Tables of :class:`controllers.laws.emulation.EmulationLQR` (steps 1-3 over the airspeed grid)."""
    from rig_env.envs.tasks.freeflight import FreeFlightEmulation

    check_emulation(spec)
    check_params(params)
    link_delay_steps = check_steps("link_delay_steps", link_delay_steps, 50)  # numpy integers too (np.int64 was refused)
    unknown = sorted(set(max_deviation or {}) - set(MAX_DEVIATION), key=str)
    if unknown:
        raise ValueError(f"max_deviation: unknown entries {unknown}; allowed {sorted(MAX_DEVIATION)}")
    # each maximum by name: a string reached float() / math.isfinite() (numpy's or Python's own message), True passed as 1
    md = {**MAX_DEVIATION, **{k: _maximum(f"max_deviation[{k!r}]", v) for k, v in (max_deviation or {}).items()}}
    mi = MAX_INPUT if max_input is None else _maximum("max_input", max_input)
    params_default, params = params is None, params or RigParams.default()
    lo, hi = spec.airspeed_range
    if lo <= 1.0:
        raise ValueError(f"airspeed_range = {spec.airspeed_range}: the emulation design needs airspeed > 1 m/s")
    V = np.linspace(lo, hi, max(2, math.ceil((hi - lo) / V_STEP) + 1)) if hi > lo else np.array([lo])
    if max_deviation is not None:
        candidates = [(None, md)]
    else:  # loosest first: keep the tightest that meets the targets
        candidates = [(s, {**md, "alpha_error": s * md["alpha_error"], "q_error": s * md["q_error"]}) for s in WEIGHT_SCALES]
    chosen = None
    for scale, mdc in candidates:
        pts = [design_point(params, float(v), spec.dt, link_delay_steps, mdc, mi) for v in V]
        ok = all(p["margins"]["gm_db"] >= TARGETS["gm_db"] and p["margins"]["pm_deg"] >= TARGETS["pm_deg"] and p["margins"]["rho"] < 1.0 for p in pts)
        if ok or chosen is None:
            chosen = (scale, mdc, pts)
        if not ok:
            break
    scale, md, pts = chosen
    d = pts[0]["d"]
    hawk = pts[0]
    Ah, bh = servo_matrices(hawk["hawk_wn"], hawk["hawk_zeta"])
    hawk_phi, hawk_gamma = zoh_with_delay(Ah, bh, spec.dt, 0.0)
    ref_scales = np.array([float(FreeFlightEmulation.ref_scales[e]) for e in REF_ENTRIES])
    points = [{"airspeed": p["airspeed"], "phi_deg": 0.0, "poles": [[float(z.real), float(z.imag)] for z in p["poles"]],
               "rig_pitch": {k: (float(v) if math.isfinite(v) else None) for k, v in p["margins"].items()}} for p in pts]
    design = {"airspeed_range": list(spec.airspeed_range), "link_delay_steps": int(link_delay_steps),
              "sigma_a": dict(zip(("rig_pitch", "model_pitch"), map(float, SIGMA_A))), "sigma_f": float(SIGMA_F), "sigma_z": float(SIGMA_Z),
              "sigma_zf": float(SIGMA_ZF), "sigma_gust": float(SIGMA_GUST), "gust_tau": float(GUST_TAU),
              "sigma_ref": list(map(float, SIGMA_REF)), "sigma_zr": list(map(float, SIGMA_ZR)), "params_default": params_default,
              "method": "controllers.design.emulation (explicit model following: control.dlqr on the rig and the free Hawk's short period side by side, servo and delay in)",
              "max_deviation": {k: float(v) for k, v in md.items()}, "weight_scale": scale, "targets": dict(TARGETS),
              "max_input": float(mi), "tau_pilot": float(TAU_PILOT),
              "states": list(state_labels(d)), "loop_delay_s": params.servos.compensator.delay_s + link_delay_steps * spec.dt,
              "points": points}
    return EmulationTables(V, np.array([p["K"] for p in pts]), np.array([p["q_op"] for p in pts]), hawk_phi, hawk_gamma[0],
                           int(hawk["hawk_delay_steps"]), ref_scales,
                           np.array([p["Ad"][EST] for p in pts]), np.array([p["Bd"][EST, 0] for p in pts]), np.array([p["meas_rows"] for p in pts]),
                           np.array([p["kalman_gain"] for p in pts]),
                           signal_scales(spec), design)

"""Design of the gain-scheduled LQR (:class:`controllers.laws.lqr.LQRLaw`): trim, linearise, solve, tabulate.

For every airspeed ``V`` of a grid over ``spec.airspeed_range`` and every roll angle ``phi`` of a
30 deg grid, :func:`design_point` trims and linearises the task's free joints
(:func:`controllers.design.model.design_model`, the numba model the environment integrates, virtual inputs
roll/heave/sway), augments the model with the integrals of the tracked errors (roll angle; rig_pitch
and rig_yaw when free) and solves ``control.lqr`` with Bryson weights (:data:`MAX_DEVIATION`,
:data:`MAX_INPUT`).  :func:`design_lqr` stacks the grid into the tables of
:class:`controllers.laws.lqr.LQRTables` (plain data, what the numpy runtime and a deployed artefact
hold) with the estimator's Kalman gains and the design's provenance: weights, grid, noise model,
and the loop margins (:func:`describe_point`, servo and Pade delay in the loop) at the lowest,
middle and highest design airspeed and roll 0 and 90 deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control
import numpy as np

from controllers.laws.axes import AXES, AXIS_OF, axes_of
from controllers.laws.base import LoopSpec
from rig_env import riccati
from controllers.design.estimator import kalman_gain
from controllers.design.model import check_flag, check_params, check_steps, design_aero_model, design_model, loop_elements
from controllers.design.signals import signal_scales
from controllers.design.tuning import margins, plain
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


def design_point(params: RigParams, free_dofs: tuple[str, ...], airspeed: float, phi: float, aero_model: str = "linear") -> Design:
    """Trim, linearise (on ``aero_model``: :func:`controllers.design.model.design_aero_model`), augment and solve the
    LQR at one (V, phi)."""
    dp = design_model(params, free_dofs, airspeed, phi, aero_model=aero_model)
    A, B = np.asarray(dp.sys.A), np.asarray(dp.sys.B)
    Aa, Ba, ilabels = augmented(A, B, free_dofs)
    labels = list(dp.sys.state_labels) + ilabels
    Q = np.diag([1.0 / MAX_DEVIATION[s] ** 2 for s in labels])
    used = [AXIS_OF[j] for j in axes_of(free_dofs)]
    R = np.diag([1.0 / (MAX_INPUT[AXES[k]] * V_REF / airspeed) ** 2 for k in used])
    Kr, P, poles = riccati.lqr(Aa, Ba[:, used], Q, R, discrete=False, what=f"roll LQR at {airspeed:g} m/s, phi {math.degrees(phi):g} deg")
    K = np.zeros((3, Aa.shape[0]))
    K[used] = Kr
    q_op = dp.op.q[[JOINTS.index(j) for j in free_dofs]]
    return Design(tuple(free_dofs), float(airspeed), float(phi), K, dp.u_trim, q_op, A, B, Q, R, np.asarray(P), np.asarray(poles))


def design_grid(params: RigParams, free_dofs: tuple[str, ...], airspeeds: np.ndarray, phis: np.ndarray,
                aero_model: str = "linear") -> list[list[Design]]:
    """Designs for every (airspeed, phi) of the grid: ``grid[i_v][i_phi]``."""
    return [[design_point(params, free_dofs, float(v), float(f), aero_model) for f in phis] for v in airspeeds]


def loop_margins(d: Design, channel: int, elements: dict[str, control.TransferFunction]) -> tuple[float, float, float]:
    """(GM dB, PM deg, crossover rad/s) of the loop broken at virtual input ``channel`` (others closed),
    with the servo and the Pade transport delay in the loop."""
    Aa, Ba, _ = augmented(d.A, d.B, d.free_dofs)
    others = [k for k in range(3) if k != channel]
    Acl = Aa - Ba[:, others] @ d.K[others]
    Lss = control.ss(Acl, Ba[:, [channel]], d.K[[channel]], 0.0)
    L = Lss * control.tf2ss(elements["servo"] * elements["delay"])
    return margins(L)


def describe_point(d: Design, elements: dict[str, control.TransferFunction]) -> dict[str, Any]:
    """Closed-loop poles and loop margins (servo and delay included) of one grid point."""
    out: dict[str, Any] = {"airspeed": d.airspeed, "phi_deg": math.degrees(d.phi), "poles": d.poles.tolist()}
    for j in axes_of(d.free_dofs):
        gm, pm, wc = loop_margins(d, AXIS_OF[j], elements)
        out[j] = {"gm_db": gm, "pm_deg": pm, "wc": wc}
    return out


def design_lqr(spec: LoopSpec, params: RigParams | None = None, *, link_delay_steps: int = 1, estimator: bool = True) -> dict[str, Any]:
    """The tables of :class:`controllers.laws.lqr.LQRTables` for ``spec`` (see the module docstring).

    Airspeed grid: every 2.5 m/s or finer over ``spec.airspeed_range`` (ValueError unless > 1 m/s).  Designed on
    the model the loop's rig flies (``spec.aero_model``; the unsteady model's quasi-steady form, the tables:
    :func:`controllers.design.model.design_aero_model`).  ValueError, before any design work, unless
    ``link_delay_steps`` is an integer in [0, 100], ``estimator`` a bool and ``params`` a RigParams or None.
    """
    check_params(params)
    link_delay_steps = check_steps("link_delay_steps", link_delay_steps)
    estimator = check_flag("estimator", estimator)
    p = params or RigParams.default()
    fd = spec.free_dofs
    lo, hi = spec.airspeed_range
    airspeeds = np.linspace(lo, hi, max(2, math.ceil((hi - lo) / 2.5) + 1)) if hi > lo else np.array([lo])
    if airspeeds[0] <= 1.0:
        raise ValueError(f"airspeed_range = {spec.airspeed_range}: the LQR design needs airspeed > 1 m/s")
    phis = np.radians(np.arange(-180.0, 180.0, PHI_STEP_DEG))
    aero = design_aero_model(spec.aero_model)
    grid = design_grid(p, fd, airspeeds, phis, aero)
    nq = len(fd)
    el = loop_elements(p, spec.dt, link_delay_steps)
    vs = sorted({float(airspeeds[0]), float(np.median(airspeeds)), float(airspeeds[-1])})
    points = []
    for v in vs:
        iv = int(np.argmin(np.abs(airspeeds - v)))
        for f in (0.0, math.radians(90.0)):
            ip = int(np.argmin(np.abs(((phis - f) + math.pi) % (2 * math.pi) - math.pi)))
            points.append(describe_point(grid[iv][ip], el))

    def table(get: Any) -> np.ndarray:
        return np.array([[get(d) for d in row] for row in grid])

    return {
        "airspeeds": airspeeds, "phis": phis, "phi_step": math.radians(PHI_STEP_DEG),
        "K": table(lambda d: d.K), "u_trim": table(lambda d: d.u_trim), "q_op": table(lambda d: d.q_op),
        "A_q": table(lambda d: d.A[nq:, :nq]), "A_w": table(lambda d: d.A[nq:, nq:]), "B": table(lambda d: d.B[nq:]),
        "kalman_gain": np.array([kalman_gain(spec.dt, SIGMA_A[j], SIGMA_Z) for j in fd]),
        "link_delay_steps": int(link_delay_steps), "estimator": bool(estimator),
        **signal_scales(spec).to_data(),
        "design": {"method": "control.lqr on the augmented linearised rig, Bryson weights, bilinear schedule in (V, phi)",
                   "max_deviation": dict(MAX_DEVIATION), "max_input": dict(MAX_INPUT), "v_ref": V_REF, "phi_step_deg": PHI_STEP_DEG,
                   "airspeed_range": list(spec.airspeed_range), "airspeed_grid": airspeeds.tolist(),
                   "sigma_a": {j: SIGMA_A[j] for j in fd}, "sigma_z": SIGMA_Z, "link_delay_steps": int(link_delay_steps),
                   "params_default": params is None, "aero_model": aero, "margins": plain(points)},
    }

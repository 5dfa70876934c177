"""The design model every model-based law uses: trim, linearisation and loop elements, from ``rig_env``.

Laws are designed on the same numba model the environment integrates (``rig_env.linear``), never on
a second copy.  This module adds what the designs need around it:

* :func:`operating_point`: trim at a task's operating point ``(airspeed V, rig roll angle phi)``:
  the actuated rig joints are held at their targets (rig_roll at ``phi``, rig_pitch and rig_yaw at
  0) by the compensator aileron, elevator and rudder, and the passive model joints (model_pitch,
  model_yaw) settle at their equilibrium.  Away from phi = 0 the arm's gravity imbalance needs a
  steady aileron, so the operating point and its linearisation move with phi.
* :func:`design_model`: the linearisation there, inputs in normalised action units (1 = 40 deg).
* :func:`loop_elements`: servo (second order, ``servos.compensator`` parameters), the total transport
  delay (servo delay + telemetry delay + half a control period for the zero-order hold) as a Pade
  approximation, and the rate sensor (backward difference, half a period, and its first-order
  filter), as python-control transfer functions.

Axes: the compensator is rolled with the rig, so its elevator and rudder act on rig_pitch and
rig_yaw through the roll angle.  The laws command *heave* ``h`` and *sway* ``s`` in the unrolled
frame and :func:`resolve` turns them into surfaces (the linear model gives, at every phi,
``rig_pitch'' = -b (cos phi de - sin phi dr)``, ``rig_yaw'' = -b (sin phi de + cos phi dr)``):

    de = cos(phi) h + sin(phi) s,     dr = -sin(phi) h + cos(phi) s

so ``h`` moves rig_pitch and ``s`` moves rig_yaw whatever the roll angle, with the gain they have
at phi = 0 (checked in ``tests/test_controllers.py``).  Design inputs: :data:`AXES`.  The geometry
(:data:`AXES`, :func:`resolve`, :func:`rotation`) lives in the numpy-only :mod:`controllers.laws.axes`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import numpy as np
from scipy.optimize import least_squares

from controllers.laws.axes import AXES, AXIS_OF, resolve, rotation  # noqa: F401  (re-exported: the numpy-only geometry)
from rig_env.linear import OperatingPoint, joint_accelerations, linearize
from rig_env.params import JOINTS, SURFACES, RigParams
from rig_env.physics import layout as L

INPUTS = ("comp_aileron", "comp_elevator", "comp_rudder")
PASSIVE = ("model_pitch", "model_yaw")


@dataclass(frozen=True)
class DesignPoint:
    """A trimmed operating point and its linear model (inputs normalised: 1 = ``scale_deg``).

    op: the trim (``rig_env.linear.OperatingPoint``); u_trim: (3,) normalised virtual inputs
    (:data:`AXES`); sys: python-control ``StateSpace`` with states ``<joint>``/``<joint>_rate`` of
    the free joints and the virtual inputs.
    """

    airspeed: float
    phi: float
    op: OperatingPoint
    u_trim: np.ndarray
    sys: control.StateSpace


def operating_point(params: RigParams, free_dofs: tuple[str, ...], airspeed: float, phi: float,
                    scale_deg: float = 40.0) -> tuple[OperatingPoint, np.ndarray]:
    """Trim at rig roll ``phi`` (rad): rig joints at their targets, passive joints at equilibrium.

    Unknowns: the virtual input of every free rig joint (:data:`AXIS_OF`) and the angles of the free
    passive joints; residual: the free joints' accelerations.  Where holding rig_pitch or rig_yaw at
    zero would need more than the flaps can give (a flap is aileron +- elevator +- rudder, limited
    to +-1), heave and sway are scaled back until the most loaded flap is at 0.95 and their rig
    joints settle instead (the rig weathercocks).  Returns the operating point and the normalised
    virtual inputs (3,).  RuntimeError if no trim with max |qdd| < 1e-6 rad/s^2 exists.
    """
    p, tabs = params.to_vector(), params.tables()
    idx = np.array([JOINTS.index(j) for j in free_dofs], dtype=np.int64)
    R = rotation(phi)
    scale = math.radians(scale_deg)
    q0 = np.zeros(5)
    q0[0] = phi
    u0 = np.zeros(L.N_INPUTS)
    u0[L.U_AIRSPEED] = airspeed

    def solve(fixed: dict[int, float]) -> tuple[np.ndarray, np.ndarray, float]:
        v_cols = [AXIS_OF[j] for j in free_dofs if j in AXIS_OF and AXIS_OF[j] not in fixed]
        q_cols = [JOINTS.index(j) for j in free_dofs if j in PASSIVE or (j in AXIS_OF and AXIS_OF[j] in fixed)]

        def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            q, u, v = q0.copy(), u0.copy(), np.zeros(3)
            q[q_cols] = x[len(v_cols):]
            v[v_cols] = x[: len(v_cols)]
            for k, val in fixed.items():
                v[k] = val
            for k, name in enumerate(INPUTS):
                u[SURFACES.index(name)] = scale * (R[k] @ v)
            return q, u, v

        def resid(x: np.ndarray) -> np.ndarray:
            q, u, _ = unpack(x)
            return joint_accelerations(q, np.zeros(5), u, p, L.F_AERO, idx, tabs)[idx]

        sol = least_squares(resid, np.zeros(len(v_cols) + len(q_cols)), xtol=1e-12, ftol=1e-12, gtol=1e-12, method="lm")
        q, _, v = unpack(sol.x)
        return q, v, float(np.max(np.abs(resid(sol.x))))

    q, v, res = solve({})
    for _ in range(3):  # flaps beyond their limit: scale heave and sway back, let their joints settle
        surf = rotation(phi) @ v
        need = abs(surf[0]) + abs(surf[1]) + abs(surf[2])  # the most loaded flap (mixing signs +-1)
        if res <= 1e-6 and need <= 1.0:
            break
        hs = abs(surf[1]) + abs(surf[2])
        c = max(0.0, 0.95 - abs(surf[0])) / hs if hs > 0 else 0.0
        fixed = {k: c * v[k] for k in (1, 2) if v[k] != 0.0}
        if not fixed:
            break
        q, v, res = solve(fixed)
    if res > 1e-6:
        raise RuntimeError(f"no trim at V = {airspeed} m/s, phi = {math.degrees(phi):.1f} deg (max |qdd| {res:.2g} rad/s^2)")
    u = np.array([scale * (R[k] @ v) for k in range(3)])
    controls = {name: math.degrees(u[k]) for k, name in enumerate(INPUTS) if u[k] != 0.0}
    op = OperatingPoint(q=q, qd=np.zeros(5), controls_deg=controls, airspeed=float(airspeed), free_dofs=tuple(free_dofs), residual=res)
    return op, v


def design_model(params: RigParams, free_dofs: tuple[str, ...], airspeed: float, phi: float,
                 scale_deg: float = 40.0) -> DesignPoint:
    """Trim at ``(airspeed, phi)`` and linearise (friction's viscous term kept); virtual inputs, normalised."""
    op, u_trim = operating_point(params, free_dofs, airspeed, phi, scale_deg)
    sys = linearize(params, op, inputs=INPUTS, friction="viscous")
    B = sys.B @ rotation(phi) * math.radians(scale_deg)
    sysn = control.ss(sys.A, B, sys.C, np.zeros_like(B), states=sys.state_labels, inputs=list(AXES), outputs=sys.output_labels)
    return DesignPoint(float(airspeed), float(phi), op, u_trim, sysn)


def loop_elements(params: RigParams, dt: float, link_delay_steps: int = 1, rate_filter_hz: float = 10.0,
                  pade_order: int = 3) -> dict[str, control.TransferFunction]:
    """Transfer functions of the loop around the rigid rig (normalised command in, measurements out).

    ``servo``: wn^2 / (s^2 + 2 zeta wn s + wn^2) (``servos.compensator``); ``delay``: Pade of
    servo delay + telemetry delay (``link_delay_steps`` dt) + dt / 2 (zero-order hold);
    ``rate_sensor``: 1 / (tau s + 1) (tau = 1 / (2 pi rate_filter_hz)) times Pade of dt / 2 (backward
    difference).  ``total_delay`` is returned as a 1x1 constant in seconds for the report.
    """
    c = params.to_vector()
    wn = 2 * math.pi * c[L.P_SERVOS_COMPENSATOR_NATURAL_FREQ_HZ]
    zeta = c[L.P_SERVOS_COMPENSATOR_DAMPING]
    tau_d = c[L.P_SERVOS_COMPENSATOR_DELAY_S] + link_delay_steps * dt + 0.5 * dt
    servo = control.tf([wn**2], [1.0, 2 * zeta * wn, wn**2])
    delay = control.tf(*control.pade(tau_d, pade_order))
    tau_f = 1.0 / (2 * math.pi * rate_filter_hz)
    rate = control.tf([1.0], [tau_f, 1.0]) * control.tf(*control.pade(0.5 * dt, 1))
    return {"servo": servo, "delay": delay, "rate_sensor": rate, "total_delay": control.tf([tau_d], [1.0])}

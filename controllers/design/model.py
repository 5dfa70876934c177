"""The design model every model-based law uses: trim, linearisation and loop elements, from ``rig_env``.

Laws are designed on the same numba model the environment integrates (``rig_env.linear``), never on
a second copy.  This module adds what the designs need around it:

* :func:`operating_point`: trim (``rig_env.trim``) at a task's operating point ``(airspeed V, rig
  roll angle phi)``: the actuated rig joints are held at their targets (rig_roll at ``phi``,
  rig_pitch and rig_yaw at 0) by the compensator aileron, elevator and rudder, and the passive model
  joints (model_pitch, model_yaw) settle at their equilibrium.  Away from phi = 0 the arm's gravity imbalance needs a
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

from controllers.laws.axes import AXES, AXIS_OF, resolve, rotation  # noqa: F401  (re-exported: the numpy-only geometry)
from controllers.laws.base import AERO_MODELS
from rig_env.linear import InputMix, OperatingPoint, linearize, trim
from rig_env.params import JOINTS, RigParams

INPUTS = ("comp_aileron", "comp_elevator", "comp_rudder")
LINK_DELAY_STEPS_MAX = 100
"""Largest ``link_delay_steps`` a design takes: the laws' tables refuse more (``LQRTables``, ``HeaveSwayTables``)."""


# Argument checks of the public design functions: a bad option is refused before any trim or Riccati solve, in one
# line naming it, rather than surfacing later as a scipy / python-control error, a ZeroDivisionError or a silent
# int() / bool() coercion in the tables (link_delay_steps = 1.5 stored as 1, feedforward = "no" stored as True).
def check_positive(name: str, v: object, *, allow_zero: bool = False) -> float:
    """``v`` as a float when it is a finite real number > 0 (>= 0 with ``allow_zero``); ValueError naming ``name`` otherwise."""
    real = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
    if not (real and math.isfinite(v) and (v >= 0 if allow_zero else v > 0)):
        raise ValueError(f"{name} = {v!r}: must be a finite number; allowed {'>= 0' if allow_zero else '> 0'}")
    return float(v)


def check_steps(name: str, v: object, hi: int = LINK_DELAY_STEPS_MAX) -> int:
    """``v`` as an int when it is an integer in [0, ``hi``] (not a bool, not a float); ValueError naming ``name`` otherwise."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or not 0 <= v <= hi:
        raise ValueError(f"{name} = {v!r}: must be an integer; allowed 0 to {hi}")
    return int(v)


def check_flag(name: str, v: object) -> bool:
    """``v`` when it is a bool (``"no"`` or 0.0 would be truthy or falsy by accident); ValueError naming ``name`` otherwise."""
    if not isinstance(v, (bool, np.bool_)):
        raise ValueError(f"{name} = {v!r}: must be a bool; allowed True, False")
    return bool(v)


def check_params(params: object) -> None:
    """ValueError unless ``params`` is None (the default rig) or a :class:`rig_env.params.RigParams`."""
    if params is not None and not isinstance(params, RigParams):
        raise ValueError(f"params = {type(params).__name__}: must be a rig_env.params.RigParams or None (the default rig)")


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


def compensator_mix(phi: float, scale_deg: float = 40.0) -> InputMix:
    """The virtual inputs (:data:`AXES`, normalised: 1 = ``scale_deg``) as ``rig_env``'s :class:`~rig_env.linear.InputMix`
    of the compensator surfaces at rig roll ``phi`` (rad): the rows of :func:`rotation`."""
    return InputMix(AXES, INPUTS, rotation(phi), scale_deg)


def design_aero_model(aero_model: str) -> str:
    """The aerodynamic model a law is designed on when its rig flies ``aero_model``: the same for "linear" and
    "tables"; for "unsteady" its quasi-steady form, the tables (the flow-separation states at their steady
    values x0(alpha), where the unsteady model's loads are the tables'): the laws measure no separation state,
    and a design that fed back on one could not be flown.  ValueError for any other name."""
    if aero_model not in AERO_MODELS:
        raise ValueError(f"aero_model = {aero_model!r}; allowed: {', '.join(repr(m) for m in AERO_MODELS)}")
    return "tables" if aero_model == "unsteady" else aero_model


def operating_point(params: RigParams, free_dofs: tuple[str, ...], airspeed: float, phi: float,
                    scale_deg: float = 40.0, aero_model: str = "linear") -> tuple[OperatingPoint, np.ndarray]:
    """Trim at rig roll ``phi`` (rad): rig joints at their targets, passive joints at equilibrium (``rig_env.trim``),
    on the aerodynamic model ``aero_model`` (:func:`design_aero_model`).

    ``rig_env.trim`` holds every free rig joint at its target (rig_roll at ``phi``, rig_pitch and
    rig_yaw at 0) with its virtual input (:data:`AXIS_OF`, :func:`compensator_mix`) as the unknown and
    lets the free passive joints settle.  Where holding rig_pitch or rig_yaw at zero would need more
    than the flaps can give (a flap is aileron +- elevator +- rudder, limited to +-1), heave and sway are
    scaled back until the most loaded flap is at 0.95 and their rig joints settle instead (the rig
    weathercocks): a loop around the trim, which then takes those inputs as given.  Returns the
    operating point and the normalised virtual inputs (3,).  RuntimeError if no trim with max |qdd| <
    1e-6 rad/s^2 exists; ValueError for a non-finite ``phi``.
    """
    if isinstance(phi, (bool, np.bool_)) or not isinstance(phi, (int, float, np.integer, np.floating)) or not math.isfinite(phi):
        raise ValueError(f"phi = {phi!r}: must be a finite rig roll angle, rad")
    mix = compensator_mix(phi, scale_deg)
    q_guess = np.zeros(5)
    q_guess[0] = phi
    targets = {j: float(q_guess[JOINTS.index(j)]) for j in AXIS_OF}

    def solve(fixed: dict[int, float]) -> tuple[OperatingPoint, np.ndarray]:
        held = [j for j in free_dofs if j in AXIS_OF and AXIS_OF[j] not in fixed]
        op = trim(params, free_dofs, q_guess, airspeed=airspeed, mix=mix, inputs={AXES[k]: val for k, val in fixed.items()},
                  unknown_inputs=[AXES[AXIS_OF[j]] for j in held], hold={j: targets[j] for j in held}, tol=1e-12, max_residual=None,
                  aero_model=design_aero_model(aero_model))
        return op, np.array([op.inputs[a] for a in AXES])

    op, v = solve({})
    for _ in range(3):  # flaps beyond their limit: scale heave and sway back, let their joints settle
        surf = rotation(phi) @ v
        need = abs(surf[0]) + abs(surf[1]) + abs(surf[2])  # the most loaded flap (mixing signs +-1)
        if op.residual <= 1e-6 and need <= 1.0:
            break
        hs = abs(surf[1]) + abs(surf[2])
        c = max(0.0, 0.95 - abs(surf[0])) / hs if hs > 0 else 0.0
        fixed = {k: c * v[k] for k in (1, 2) if v[k] != 0.0}
        if not fixed:
            break
        op, v = solve(fixed)
    if op.residual > 1e-6:
        raise RuntimeError(f"no trim at V = {airspeed} m/s, phi = {math.degrees(phi):.1f} deg (max |qdd| {op.residual:.2g} rad/s^2)")
    return op, v


def design_model(params: RigParams, free_dofs: tuple[str, ...], airspeed: float, phi: float,
                 scale_deg: float = 40.0, aero_model: str = "linear") -> DesignPoint:
    """Trim at ``(airspeed, phi)`` and linearise (friction's viscous term kept) on ``aero_model``
    (:func:`design_aero_model`); virtual inputs, normalised."""
    op, u_trim = operating_point(params, free_dofs, airspeed, phi, scale_deg, aero_model)
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
    difference).  ``total_delay`` is returned as a 1x1 constant in seconds for the report.  ValueError unless
    ``dt`` and ``rate_filter_hz`` are finite and > 0, ``link_delay_steps`` an integer in [0, 100] and ``pade_order``
    an integer in [1, 10] (order 0 would drop the delay from the loop).
    """
    dt = check_positive("dt", dt)
    link_delay_steps = check_steps("link_delay_steps", link_delay_steps)
    rate_filter_hz = check_positive("rate_filter_hz", rate_filter_hz)
    if isinstance(pade_order, (bool, np.bool_)) or not isinstance(pade_order, (int, np.integer)) or not 1 <= pade_order <= 10:
        raise ValueError(f"pade_order = {pade_order!r}: must be an integer; allowed 1 to 10")
    comp = params.servos.compensator
    wn = 2 * math.pi * comp.natural_freq_hz
    zeta = comp.damping
    tau_d = comp.delay_s + link_delay_steps * dt + 0.5 * dt
    servo = control.tf([wn**2], [1.0, 2 * zeta * wn, wn**2])
    delay = control.tf(*control.pade(tau_d, pade_order))
    tau_f = 1.0 / (2 * math.pi * rate_filter_hz)
    rate = control.tf([1.0], [tau_f, 1.0]) * control.tf(*control.pade(0.5 * dt, 1))
    return {"servo": servo, "delay": delay, "rate_sensor": rate, "total_delay": control.tf([tau_d], [1.0])}

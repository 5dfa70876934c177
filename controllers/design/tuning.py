"""Reproducible loop-shaping of the PID family on the linearised rig, to stated gain and phase margins.

Procedure (:func:`tune_axis`, one rig joint ``j`` and its virtual input, :mod:`controllers.design.model`):

1. Trim and linearise the task's free joints at the design airspeed (the middle of the task's range)
   and zero roll angle; ``P(s)``: joint rate (rad/s) per normalised virtual input.
2. Loop elements (:func:`controllers.design.model.loop_elements`): servo ``S(s)`` (6 Hz, zeta 0.7), the
   transport delay ``D(s)`` (servo 15 ms + telemetry one period + half a period for the hold) as a
   3rd-order Pade approximation, the rate sensor ``H(s)`` (10 Hz filter, half-period backward
   difference).  The angle path carries the same ``D`` and no filter.
3. Inner rate loop, PI: ``C_r(s) = kp (1 + wi / s)`` with ``wi = wc / 4``; ``kp`` puts the crossover of
   ``L_r = C_r S D P H`` at ``wc``.  ``wc`` is the largest on a log grid (0.5-60 rad/s) for which
   ``L_r`` has phase margin >= ``pm_inner`` and gain margin >= ``gm_inner`` dB (python-control
   ``stability_margins``).
4. Outer angle loop, P: ``L_a = k T_r / s`` with ``T_r`` the closed inner loop (rate reference to
   rate); ``k`` is the largest on a log grid that keeps phase margin >= ``pm_outer`` and gain
   margin >= ``gm_outer`` dB.

Default targets: inner PM 50 deg, GM 8 dB; outer PM 60 deg, GM 10 dB.  The laws rescale the gains
with dynamic pressure ``(V_design / V)^2`` (the control derivative scales with V^2).  Every number
comes from :func:`tune_axis` at construction; nothing is typed in.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import control
import numpy as np

from controllers.laws.axes import AXES, AXIS_OF, axes_of
from controllers.design.model import design_model, loop_elements
from rig_env.params import RigParams


@dataclass(frozen=True)
class AxisTuning:
    """Gains and achieved margins of one cascaded axis (rad, rad/s, normalised command).

    kp, ki: rate loop PI (command per rad/s, per rad; negative where the control power b is); k_angle: angle loop (rad/s per rad);
    wc_inner, wc_outer: crossovers, rad/s; pm_*: phase margins, deg; gm_*: gain margins, dB;
    b: control power at the design point, rad/s^2 per unit command.
    """

    joint: str
    airspeed: float
    kp: float
    ki: float
    k_angle: float
    wc_inner: float
    pm_inner: float
    gm_inner: float
    wc_outer: float
    pm_outer: float
    gm_outer: float
    b: float

    def as_dict(self) -> dict[str, float | str]:
        return asdict(self)


def margins(L: control.TransferFunction | control.StateSpace) -> tuple[float, float, float]:
    """(gain margin dB, phase margin deg, crossover rad/s) of the loop L, worst case over crossings.

    Phase margin: the smallest over every gain crossover; gain margin: the smallest increase of
    gain that destabilises (phase crossovers with |L| < 1); crossover: the highest gain crossover.
    A loop whose closed loop ``L / (1 + L)`` is unstable gets (-inf, -inf, nan).
    """
    Ls = L if isinstance(L, control.StateSpace) else control.tf2ss(L)
    if not all(np.all(np.isfinite(np.asarray(m, dtype=complex))) for m in (Ls.A, Ls.B, Ls.C, Ls.D)):
        # numpy's eigvals would raise LinAlgError("Array must not contain infs or NaNs") on the closed loop
        raise ValueError("L: non-finite coefficient(s) in the loop; allowed finite numbers only")
    cl = control.feedback(Ls, 1)
    if np.max(np.real(np.linalg.eigvals(cl.A))) > 1e-8:  # (a pole at the origin cancelled by a zero is not unstable)
        return -math.inf, -math.inf, math.nan
    with warnings.catch_warnings(), np.errstate(all="ignore"):  # python-control's polynomial root polishing
        warnings.simplefilter("ignore", RuntimeWarning)
        gm, pm, _, _, wg, _ = control.stability_margins(L, returnall=True)
    gm, pm, wg = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (gm, pm, wg))
    up = gm[np.isfinite(gm) & (gm > 1.0)]
    gm_db = 20 * math.log10(float(up.min())) if up.size else math.inf
    pm = np.abs((pm + 180.0) % 360.0 - 180.0)  # distance of the phase from -180 deg, modulo 360 (stability checked above)
    pm_min = float(pm[np.isfinite(pm)].min()) if np.any(np.isfinite(pm)) else math.inf
    wc = float(wg[np.isfinite(wg)].max()) if np.any(np.isfinite(wg)) else math.nan
    return gm_db, pm_min, wc


def check_targets(**targets: float) -> None:
    """ValueError naming the first margin target that is not a finite number in range (phase margins [0, 180) deg,
    gain margins >= 0 dB): a NaN target failed every comparison and was reported as "no crossover meets PM nan"."""
    for k, v in targets.items():
        real = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
        pm = k.startswith("pm")
        if not (real and math.isfinite(v) and v >= 0 and (v < 180 if pm else True)):
            raise ValueError(f"{k} = {v!r}: a margin target must be a finite number; allowed {'[0, 180) deg' if pm else '>= 0 dB'}")


def rate_tf(sys: control.StateSpace, joint: str) -> control.TransferFunction:
    """Joint rate (rad/s) per normalised virtual input of the joint's axis, from a linear rig model."""
    k_in = AXIS_OF[joint]
    k_out = sys.output_labels.index(f"{joint}_rate")
    siso = control.ss(sys.A, sys.B[:, [k_in]], sys.C[[k_out], :], 0.0)
    tf = control.minreal(control.ss2tf(siso), tol=1e-6, verbose=False)
    num, den = (np.asarray(c[0][0], dtype=float) for c in (tf.num, tf.den))
    num = np.where(np.abs(num) < 1e-9 * np.abs(num).max(), 0.0, num)  # exact zero at the origin (a rate)
    return control.tf(num, den)


def rate_plant(params: RigParams, free_dofs: tuple[str, ...], joint: str, airspeed: float,
               scale_deg: float = 40.0, aero_model: str = "linear") -> control.TransferFunction:
    """Joint rate (rad/s) per normalised virtual input of the joint's axis, at phi = 0, on ``aero_model``."""
    return rate_tf(design_model(params, free_dofs, airspeed, 0.0, scale_deg, aero_model).sys, joint)


def tune_axis(params: RigParams, free_dofs: tuple[str, ...], joint: str, airspeed: float, dt: float, *,
              link_delay_steps: int = 1, rate_filter_hz: float = 10.0, pm_inner: float = 50.0,
              gm_inner: float = 8.0, pm_outer: float = 60.0, gm_outer: float = 10.0, aero_model: str = "linear") -> AxisTuning:
    """The procedure of the module docstring for one joint, on ``aero_model``; ValueError if no gain meets the margins."""
    if joint not in AXIS_OF:
        raise ValueError(f"joint = {joint!r}: tunable joints are {list(AXIS_OF)}")
    if joint not in free_dofs:  # else the linear model has no '<joint>_rate' output ("... is not in list")
        raise ValueError(f"joint = {joint!r}: not among free_dofs {list(free_dofs)}; allowed {[j for j in AXIS_OF if j in free_dofs]}")
    check_targets(pm_inner=pm_inner, gm_inner=gm_inner, pm_outer=pm_outer, gm_outer=gm_outer)
    el = loop_elements(params, dt, link_delay_steps, rate_filter_hz)
    return shape_loops(rate_plant(params, free_dofs, joint, airspeed, aero_model=aero_model), el, joint, airspeed,
                       pm_inner=pm_inner, gm_inner=gm_inner, pm_outer=pm_outer, gm_outer=gm_outer)


def shape_loops(P: control.TransferFunction, el: dict, joint: str, airspeed: float, *, pm_inner: float, gm_inner: float,
                pm_outer: float, gm_outer: float, accept: Callable[[float, float, float], bool] | None = None) -> AxisTuning:
    """Loop shaping of the cascade on the rate plant P with the loop elements el (servo, delay, rate sensor).

    Inner PI rate loop: the largest crossover in 0.5-60 rad/s (integral corner at a quarter of it) that
    meets (pm_inner, gm_inner) and for which an outer gain exists; outer P angle loop: the largest gain that
    meets (pm_outer, gm_outer) and, if given, ``accept(kp, ki, k_angle)`` (the signed gains of the result: a
    further test of the whole law, such as its margins with a decoupling path the cascade does not see).
    Each grid is scanned from its top down and the scan stops at the first point that meets the margins: that
    is the largest feasible point whatever the feasible set's shape, and only the points above it are evaluated.
    """
    check_targets(pm_inner=pm_inner, gm_inner=gm_inner, pm_outer=pm_outer, gm_outer=gm_outer)
    s = control.tf("s")
    b = float(np.real(control.evalfr(P * s, 1j * 1e4)))  # high-frequency gain: rad/s^2 per unit command
    sign = 1.0 if b > 0 else -1.0  # rig_yaw accelerates negatively for positive sway
    G = el["servo"] * el["delay"] * (sign * P)
    inner_found = False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for wc in np.geomspace(0.5, 60.0, 80)[::-1]:  # from the top: the first feasible is the largest
            C0 = 1 + (wc / 4) / s
            kp = 1.0 / abs(control.evalfr(C0 * G * el["rate_sensor"], 1j * wc))
            gm_i, pm_i, wx_i = margins(kp * C0 * G * el["rate_sensor"])
            if not (pm_i >= pm_inner and gm_i >= gm_inner and np.isfinite(wx_i)):
                continue
            inner_found = True
            T_r = control.feedback(kp * C0 * G, el["rate_sensor"])
            for k in np.geomspace(0.1, 50.0, 120)[::-1]:
                gm_o, pm_o, wx_o = margins(k * T_r / s)
                if pm_o >= pm_outer and gm_o >= gm_outer and (accept is None or accept(sign * kp, sign * kp * wc / 4, k)):
                    return AxisTuning(joint, float(airspeed), sign * float(kp), sign * float(kp * wc / 4), float(k), float(wx_i), pm_i,
                                      gm_i, float(wx_o), pm_o, gm_o, b)
    if not inner_found:
        raise ValueError(f"{joint}: no rate-loop crossover in 0.5-60 rad/s meets PM {pm_inner} deg, GM {gm_inner} dB")
    further = " and the law's own test (accept)" if accept is not None else ""
    raise ValueError(f"{joint}: no angle-loop gain meets PM {pm_outer} deg, GM {gm_outer} dB{further} at any feasible rate-loop crossover")


def plain(x: Any) -> Any:
    """``x`` as plain finite JSON data for a design's provenance: complex -> [re, im], non-finite -> "inf"/"nan"."""
    if isinstance(x, dict):
        return {str(k): plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [plain(v) for v in list(x)]
    if isinstance(x, (complex, np.complexfloating)):
        return [float(x.real), float(x.imag)]
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else str(float(x))
    if isinstance(x, (np.integer, np.bool_)):
        return x.item()
    return x


__all__ = ["AXES", "AxisTuning", "axes_of", "margins", "plain", "rate_plant", "tune_axis"]

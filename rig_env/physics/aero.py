"""Aerodynamics of the Hawk (eq. 23 plus lateral-directional terms) and the cruciform compensator.

Both functions take world-frame kinematics of the body and return the aerodynamic force and moment in
world axes, so the joint-space and the DAE formulations share them unchanged.

Air: the tunnel flow moves at ``-V_t`` along world x (the model faces +x, upstream) plus a gust
vector (world axes, m/s).  The relative velocity of a body point is its ground velocity minus the air
velocity: the rig's own heave, sway and roll velocities change the local angle of attack and sideslip.

Compensator: four flapped panels in an X at roll positions 135, 45, -45 and -135 deg (flaps 1-4) about
the arm axis, each a strip with two Gauss stations over its span (exact for the linear terms).  With
the per-panel coefficients below the X sums to Table 4 exactly in pitch and yaw (an exact cruciform
equivalent), while the rolling moment and roll damping follow from the panels' spanwise lever arms.
Mixing (rig-code): flap_i = da + s_e,i de + s_r,i dr with (s_e, s_r) = (+,-), (-,-), (-,+), (+,+).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, types
from numba.core.errors import TypingError
from numba.extending import overload

from rig_env.physics import layout as L
from rig_env.physics import vmath
from rig_env.physics.llvm_inline import inlined
from rig_env.physics.vec import FASTMATH, col, dot, mtv, mv, scale, sub

_JIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=False)

MIN_AIRSPEED = 0.5
"""Below this local airspeed (m/s) a body or strip produces no aerodynamic load (wind off)."""

SQRT_HALF = math.sqrt(0.5)
# panel roll positions (rad) and mixing signs for flaps 1-4
PANEL_GAMMA = (0.75 * math.pi, 0.25 * math.pi, -0.25 * math.pi, -0.75 * math.pi)
# their span directions e_r = (0, cos, sin) in arm axes, evaluated once here rather than in every call
# (arrays, which the loop over the panels indexes; numba freezes global arrays as constants)
PANEL_COS = np.array([math.cos(g) for g in PANEL_GAMMA])
PANEL_SIN = np.array([math.sin(g) for g in PANEL_GAMMA])
MIX_ELEVATOR = (1.0, -1.0, -1.0, 1.0)
MIX_ELEVATOR_A = np.array(MIX_ELEVATOR)
MIX_RUDDER = (-1.0, -1.0, 1.0, 1.0)
GAUSS = 0.5 / math.sqrt(3.0)  # 2-point Gauss stations at mid +- GAUSS * length
ATTACHED4 = (1.0, 1.0, 1.0, 1.0)  # the panels' separation states when the model has none


def interp(x: float, xs, ys) -> float:
    """Piecewise-linear table look-up, end values held outside the grid (xs strictly increasing).

    In compiled code the tables come in one of three forms, chosen by their type when a kernel is compiled:
    arrays of breakpoints and values (a binary search, :func:`search_table`: the per-environment kernel), or
    the breakpoints as a tuple of floats with ys in its sum form ``(c, w)`` (:func:`table_sum_form`,
    :func:`sum_table`: no branch, loop or memory access, so that eight lanes compute it side by side in the
    lane kernel), or, for an odd table, the breakpoints of its non-negative half with ys the half's sum form
    marked odd, ``(c, w, ODD)`` (:func:`table_odd_form`, :func:`odd_table`: the same at half the
    segments).  Every form gives the value of :func:`search_table` to rounding."""
    if isinstance(ys, tuple) and isinstance(ys[1], tuple):  # the compiled forms' own functions, run as Python
        return float((odd_table if len(ys) == 3 else sum_table)(len(xs))(x, xs, ys))
    return float(np.interp(x, xs, ys))


def table_sum_form(xs: np.ndarray, ys: np.ndarray) -> tuple[tuple[float, ...], tuple[float, tuple[float, ...]]]:
    """A table (n breakpoints xs strictly increasing, values ys) in the form :func:`sum_table` evaluates: (xs as a
    tuple, (c, w)), w = (s_0, s_1 - s_0, ..., s_n-2 - s_n-3) the first segment's slope and the slope's changes
    at the interior breakpoints (s_k = (y_k+1 - y_k) / (x_k+1 - x_k)), c = y_n-1 - s_n-2 x_n-1."""
    xs = np.asarray(xs, dtype=np.float64)
    ys = np.asarray(ys, dtype=np.float64)
    slopes = np.diff(ys) / np.diff(xs)
    w = np.concatenate([slopes[:1], np.diff(slopes)])
    return tuple(float(v) for v in xs), (float(ys[-1] - slopes[-1] * xs[-1]), tuple(float(v) for v in w))


ODD = ()
"""The third member of an odd table's sum form ``(c, w, ODD)`` (:func:`table_odd_form`): a marker in the
form's type, from which :func:`interp` compiles :func:`odd_table` (the unsteady model's tables are marked
alike, by a sixth empty tuple: ``lanes.model_of``)."""


def odd_half(xs: np.ndarray, ys: np.ndarray) -> int:
    """The number of breakpoints from 0 up, (n + 1) / 2, when the table is odd: its n breakpoints symmetric
    about 0 with 0 among them and its values odd, x_n-1-k = -x_k and y_n-1-k = -y_k, both to the last bit
    (as a symmetric table in degrees stays in radians: ``RigParams.tables()``); else 0.  An odd table is
    looked up over that half alone (:func:`table_odd_form`); a table odd only to rounding is not taken for
    one, so that the odd form changes no value beyond the rounding of its sum."""
    xs = np.asarray(xs, dtype=np.float64)
    ys = np.asarray(ys, dtype=np.float64)
    n = xs.size
    if n < 3 or n % 2 == 0 or ys.size != n:
        return 0
    if not (np.array_equal(xs, -xs[::-1]) and np.array_equal(ys, -ys[::-1])):
        return 0
    return (n + 1) // 2


def table_odd_form(xs: np.ndarray, ys: np.ndarray) -> tuple[tuple[float, ...], tuple[float, tuple[float, ...], tuple[()]]]:
    """An odd table (:func:`odd_half`; ValueError otherwise) in the form :func:`odd_table` evaluates: its
    non-negative half in its sum form (:func:`table_sum_form`, the breakpoints from 0 up), marked ODD."""
    m = odd_half(xs, ys)
    if not m:
        raise ValueError("table_odd_form: the table is not odd (breakpoints symmetric about 0 with 0 among them, values odd)")
    xh, (c, w) = table_sum_form(np.asarray(xs)[-m:], np.asarray(ys)[-m:])
    return xh, (c, w, ODD)


@njit(**_JIT)
def search_table(x, xs, ys):
    """:func:`interp` of array tables: a binary search for the segment."""
    n = xs.shape[0]
    if x <= xs[0]:
        return ys[0]
    if x >= xs[n - 1]:
        return ys[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    t = (x - xs[lo]) / (xs[hi] - xs[lo])
    return ys[lo] + t * (ys[hi] - ys[lo])


_SUM_TABLES: dict[int, Any] = {}


def sum_table(n: int) -> Any:
    """:func:`interp` of a table of n breakpoints in its sum form (:func:`table_sum_form`), written out as a sum of
    hinges on the clamped x:

        x_c = min(max(x, x_0), x_n-1),   f(x) = c + s_0 x_c + sum_k=1..n-2 (s_k - s_k-1) max(x_c, x_k),

    each hinge the change of slope at an interior breakpoint, so the linear interpolant inside the grid and the
    end values held outside it (c = y_n-1 - s_n-2 x_n-1 makes f(x_n-1) = y_n-1).  Two operations per interior
    breakpoint whatever x is (a max and a multiply-add; the coefficients depend on the table only and come
    computed), against a search that no two lanes could share; two tables on one grid (the Hawk's CL and CM)
    share the hinges.  The same value as :func:`search_table` to rounding (a few 1e-16 of sum |w_k x_k|)."""
    if n not in _SUM_TABLES:
        terms = " + ".join(["ys[1][0] * xc"] + [f"ys[1][{k}] * max(xc, xs[{k}])" for k in range(1, n - 1)])
        ns: dict[str, Any] = {}
        exec(f"def table_{n}(x, xs, ys):\n    xc = min(max(x, xs[0]), xs[{n - 1}])\n    return ys[0] + ({terms})\n", ns)
        _SUM_TABLES[n] = ns[f"table_{n}"]
    return _SUM_TABLES[n]


_ODD_TABLES: dict[int, Any] = {}


def odd_table(m: int) -> Any:
    """:func:`interp` of an odd table in its odd form (:func:`table_odd_form`: the m breakpoints 0 = x_0 <
    ... < x_m-1 of its non-negative half, the half's sum form), written out:

        f(x) = sign(x) f+(|x|),   f+(a) = c + s_0 a_c + sum_k=1..m-2 (s_k - s_k-1) max(a_c, x_k),   a_c = min(a, x_m-1),

    :func:`sum_table`'s hinges over the half (the clamp's max dropped: |x| >= x_0 = 0), the sign applied as a
    multiplication by copysign(1, x) (exact, and no branch: the lanes vectorise).  An odd table's interpolant
    is odd, so this is the whole table's value to rounding at half its breakpoints' cost: the compensator's
    normal-force table, looked up for every strip in every RK stage of the lane kernel."""
    if m not in _ODD_TABLES:
        terms = " + ".join(["ys[1][0] * ac"] + [f"ys[1][{k}] * max(ac, xs[{k}])" for k in range(1, m - 1)])
        ns: dict[str, Any] = {"math": math}
        exec(f"def odd_table_{m}(x, xs, ys):\n    ac = min(abs(x), xs[{m - 1}])\n    return math.copysign(1.0, x) * (ys[0] + ({terms}))\n", ns)
        _ODD_TABLES[m] = ns[f"odd_table_{m}"]
    return _ODD_TABLES[m]


@overload(interp, inline="always", jit_options=dict(fastmath=FASTMATH, error_model="numpy"))
def _interp_sum_form(x, xs, ys):
    """The lane kernel's tables (breakpoints a tuple, ys in a sum form): :func:`sum_table`, or :func:`odd_table`
    for ys marked ODD (:func:`table_odd_form`), inlined where called."""
    if isinstance(xs, types.UniTuple) and isinstance(ys, types.BaseTuple) and len(ys) in (2, 3):
        coeffs = ys[1]
        if not isinstance(coeffs, types.UniTuple) or coeffs.count != xs.count - 1:
            raise TypingError(f"interp: {xs.count} breakpoints need {xs.count - 1} coefficients, not {coeffs}")
        if len(ys) == 2:
            return sum_table(xs.count)
        if not (isinstance(ys[2], types.BaseTuple) and len(ys[2]) == 0):
            raise TypingError(f"interp: an odd table's form is (c, w, ODD), not {ys}")
        return odd_table(xs.count)
    return None


@overload(interp, jit_options=dict(fastmath=FASTMATH, error_model="numpy"))
def _interp_arrays(x, xs, ys):
    """The per-environment kernels' tables (arrays): :func:`search_table`."""
    if isinstance(xs, types.Array) and isinstance(ys, types.Array):
        return search_table.py_func
    return None


@njit(**_JIT)
def mix(da, de, dr, i):
    """Flap i (0-3) deflection from compensator aileron, elevator and rudder (rad)."""
    return da + MIX_ELEVATOR[i] * de + MIX_RUDDER[i] * dr


@inlined(**_JIT)
def blanking(alpha, p):
    """Tail-blanking factor eta(alpha) of the fin's derivatives (docs/MODEL.md 3.1): 1 up to the onset
    alpha_b, a smoothstep down to ``blanked_fraction`` over ``blanking_width``, held beyond:

        t = clip((alpha - alpha_b) / width, 0, 1),   eta = 1 - (1 - eta_min) t^2 (3 - 2 t)

    Exactly 1 below the onset (the linear model there is untouched), continuous with its slope."""
    t = min(max((alpha - p[L.P_HAWK_AERO_BLANKING_ALPHA_DEG]) / p[L.P_HAWK_AERO_BLANKING_WIDTH_DEG], 0.0), 1.0)
    return 1.0 - (1.0 - p[L.P_HAWK_AERO_BLANKED_FRACTION]) * (t * t * (3.0 - 2.0 * t))


@inlined(**_JIT)
def hawk_aero_full(p, A, v_cg, omega, v_air, a_bias, de, da, dr, nonlinear, tab_alpha, tab_cl, tab_cm, unsteady, xsep):
    """Hawk force and moment about its c.g. (N, N m), and their alpha-dot parts, in the caller's axes.

    p: parameter vector; A: aircraft rotation (body to the caller's axes); v_cg, omega: c.g. velocity and
    angular velocity; v_air: air velocity at the c.g. (held over the step); a_bias: the part of the c.g.'s
    acceleration that the caller knows without the joint (or body) accelerations; de, da, dr: surface
    deflections (rad).  All vectors in the caller's axes (world, or the arm's: any inertial components).

    Eq. (23) with the combined q derivatives split (``alphadot_fraction`` f):
    CL = CL(alpha) + (1 - f) CLq q^ + f CLq alphadot^ + CLde de, CD = CD0 + CL_v^2/(pi e AR) (CL_v: alphadot's velocity part alone, below),
    CM = CM(alpha) + (1 - f) CMq q^ + f CMq alphadot^ + CMde de, with x^ = x c/2V; plus CY, Cl, Cn in beta,
    p, r, da, dr, the fin's terms times the blanking factor (Cnbeta's fuselage part Cnbeta_body not) and
    Clbeta + Clbeta_CL CL(alpha).

    unsteady (with nonlinear): CL(alpha) and CM(alpha) are :func:`separated_coefficients` at the flow-separation
    state xsep (1 attached, 0 separated), which equal the tables at xsep = x0(alpha); otherwise xsep is unused.

    alpha-dot: alpha = atan2(w, u) of v_b = A^T (v_cg - v_air), whose body-axis rate is
    v_b' = A^T a_cg - w_b x v_b, so

        alphadot = q - v (p u + r w) / (u^2 + w^2) + n . a_cg,    n = A (-w, 0, u) / (u^2 + w^2).

    The loads returned use alphadot_v, the value with a_cg = a_bias; the caller adds the rest, n . (a_cg -
    a_bias), through the returned (fd, md, n): the force and moment per unit of it and n, which makes the
    loads linear in the accelerations (an added-mass-like term the solvers handle: joint_space.solve_free_rank1,
    dae_solve.accelerations).  The induced drag takes the lift with alpha-dot's velocity part alone,
    q - v (p u + r w) / (u^2 + w^2) (its dependence on the c.g. acceleration is left out, so that the loads stay
    linear in the accelerations; the velocity part, unlike a_bias, is the same in every formulation, so the
    joint-space and DAE kernels fly one model).

    Returns (f, m, fd, md, n); all zero below MIN_AIRSPEED.
    """
    vb = mtv(A, sub(v_cg, v_air))
    vxz2 = vb[0] * vb[0] + vb[2] * vb[2]
    vxz = math.sqrt(vxz2)  # speed in the body x-z plane
    V = math.sqrt(vxz2 + vb[1] * vb[1])
    iV = 1.0 / V
    wb = mtv(A, omega)
    alpha = vmath.atan2(vb[2], vb[0])
    beta = vmath.atan2(vb[1], vxz)  # = asin(v / V), without its square root and division
    S = p[L.P_HAWK_AERO_S]
    c = p[L.P_HAWK_AERO_C]
    b = p[L.P_HAWK_AERO_B]
    qbar = 0.5 * p[L.P_ENVIRONMENT_AIR_DENSITY] * V * V
    ph = wb[0] * b * (0.5 * iV)
    qh = wb[1] * c * (0.5 * iV)
    rh = wb[2] * b * (0.5 * iV)
    ixz = 1.0 / vxz
    ixz2 = ixz * ixz if vxz > 0.0 else 0.0
    n = mv(A, (-(vb[2] * ixz2), 0.0, vb[0] * ixz2))
    adot_v = wb[1] - vb[1] * (wb[0] * vb[0] + wb[2] * vb[2]) * ixz2  # the velocities' part
    adh = (adot_v + dot(n, a_bias)) * c * (0.5 * iV)
    a0 = p[L.P_HAWK_AERO_ALPHA0]
    if nonlinear and unsteady:
        cl_static, cm_static = separated_coefficients(p, alpha, xsep, tab_alpha, tab_cl, tab_cm)
    elif nonlinear:
        cl_static = interp(alpha, tab_alpha, tab_cl)
        cm_static = interp(alpha, tab_alpha, tab_cm)
    else:
        cl_static = p[L.P_HAWK_AERO_CL0] + p[L.P_HAWK_AERO_CLALPHA] * (alpha - a0)
        cm_static = p[L.P_HAWK_AERO_CM0] + p[L.P_HAWK_AERO_CMALPHA] * (alpha - a0)
    f_ad = p[L.P_HAWK_AERO_ALPHADOT_FRACTION]
    clq = p[L.P_HAWK_AERO_CLQ]
    cmq = p[L.P_HAWK_AERO_CMQ]
    CL = cl_static + (1.0 - f_ad) * clq * qh + f_ad * clq * adh + p[L.P_HAWK_AERO_CLDE] * de
    CL_d = CL + f_ad * clq * (dot(n, a_bias) * c * (-0.5 * iV))  # the lift with alphadot's velocity part alone
    k_ind = S / (math.pi * p[L.P_HAWK_AERO_E_OSWALD] * b * b)  # 1 / (pi e AR), AR = b^2 / S
    CD = p[L.P_HAWK_AERO_CD0] + k_ind * CL_d * CL_d
    CM = cm_static + (1.0 - f_ad) * cmq * qh + f_ad * cmq * adh + p[L.P_HAWK_AERO_CMDE] * de
    eta = blanking(alpha, p)
    CY = eta * (p[L.P_HAWK_AERO_CYBETA] * beta + p[L.P_HAWK_AERO_CYDR] * dr)
    Cl = (
        (p[L.P_HAWK_AERO_CLBETA] + p[L.P_HAWK_AERO_CLBETA_CL] * cl_static) * beta
        + p[L.P_HAWK_AERO_CLP] * ph
        + p[L.P_HAWK_AERO_CLR] * rh
        + p[L.P_HAWK_AERO_CLDA] * da
        + eta * (p[L.P_HAWK_AERO_CLDR] * dr)
    )
    Cn = (
        (p[L.P_HAWK_AERO_CNBETA_BODY] + eta * p[L.P_HAWK_AERO_CNBETA]) * beta + eta * (p[L.P_HAWK_AERO_CNDR] * dr)
        + p[L.P_HAWK_AERO_CNP] * ph
        + p[L.P_HAWK_AERO_CNR] * rh
        + p[L.P_HAWK_AERO_CNDA] * da
    )
    sa = vb[2] * ixz if vxz > 0.0 else 0.0
    ca = vb[0] * ixz if vxz > 0.0 else 1.0
    k = qbar * S
    # lift normal to the velocity in the body x-z plane, drag against it, side force along body y
    kd = CD * iV
    fb = (
        k * (CL * sa - kd * vb[0]),
        k * (CY - kd * vb[1]),
        k * (-CL * ca - kd * vb[2]),
    )
    mb = (k * b * Cl, k * c * CM, k * b * Cn)
    # per unit of alphadot beyond alphadot_v: lift f CLq c/2V and moment f CMq c/2V
    kl = k * f_ad * clq * (c * 0.5 * iV)
    km = k * c * f_ad * cmq * (c * 0.5 * iV)
    fdb = (kl * sa, 0.0, -(kl * ca))
    if V < MIN_AIRSPEED:  # wind off: no load (the values above are computed anyway and dropped, so that
        fb = (0.0, 0.0, 0.0)  # the lane kernel has nothing to branch on)
        mb = (0.0, 0.0, 0.0)
        fdb = (0.0, 0.0, 0.0)
        km = 0.0
        n = (0.0, 0.0, 0.0)
    return mv(A, fb), mv(A, mb), mv(A, fdb), scale(col(A, 1), km), n


@inlined(**_JIT)
def hawk_aero(p, A, v_cg, omega, v_air, de, da, dr, nonlinear, tab_alpha, tab_cl, tab_cm):
    """Hawk force and moment about its c.g. (:func:`hawk_aero_full`) for a caller that does not have the
    accelerations (the MuJoCo peer): alphadot from the velocities alone, q - v (p u + r w) / (u^2 + w^2),
    which is alphadot wherever the c.g. does not accelerate (the model pitching about a gimbal at its c.g.)."""
    f, m, fd, md, n = hawk_aero_full(p, A, v_cg, omega, v_air, (0.0, 0.0, 0.0), de, da, dr, nonlinear, tab_alpha, tab_cl, tab_cm, False, 1.0)
    return f, m


# ---------------------------------------------------------------------- flow separation (aero_model="unsteady")
# Goman & Khrabrov, J. Aircraft 31(5) 1994: one internal variable x per lifting surface, the chordwise
# position of the separation point (1 attached, 0 fully separated), with Kirchhoff's thin-aerofoil relation
# for its lift, CN = CN_att ((1 + sqrt(x)) / 2)^2, and first-order dynamics
#
#     tau1 dx/dt + x = x0(alpha - tau2 alphadot),      tau1, tau2 in units of c / V.
#
# Static x0(alpha) is the table's lift inverted through that relation against the attached-flow lift
# CL_att = CLalpha sin(alpha - alpha_zl), alpha_zl = alpha0 - CL0 / CLalpha (Kirchhoff's sin alpha at the
# attached slope): F0 = CL_tab / CL_att clipped to [1/4, 1] (1/4 is x = 0), x0 = (2 sqrt(F0) - 1)^2, with
# a lift deficit CL_att - CL_tab below SEP_LIFT_TOL taken as attached flow (continuously: F0 = 1 - max(deficit
# - SEP_LIFT_TOL, 0) / |CL_att|), so that the tables' rounding near the zero-lift angle, where the ratio
# of two small numbers means nothing, does not read as separation.

SEP_LIFT_TOL = 0.01
"""Lift-coefficient deficit below which the flow counts as attached: the tables' agreement with the
attached slope over their linear range (0.887 against 0.881 at 8 deg, three decimals given)."""


@inlined(**_JIT)
def kirchhoff(x):
    """Kirchhoff's lift factor F(x) = ((1 + sqrt(x)) / 2)^2 of separation state x (clipped to [0, 1])."""
    r = 0.5 * (1.0 + math.sqrt(min(max(x, 0.0), 1.0)))
    return r * r


@inlined(**_JIT)
def attached_lift(p, alpha):
    """The attached-flow lift CLalpha sin(alpha - alpha_zl) of the Hawk (the linear model's slope at alpha_zl)."""
    cla = p[L.P_HAWK_AERO_CLALPHA]
    a_zl = p[L.P_HAWK_AERO_ALPHA0] - p[L.P_HAWK_AERO_CL0] / cla
    return cla * vmath.sincos(alpha - a_zl)[0]


@inlined(**_JIT)
def static_factor(p, alpha, cl_tab):
    """F(x0(alpha)) of the Hawk: :func:`lift_factor` against its attached-flow lift."""
    return lift_factor(attached_lift(p, alpha), cl_tab)


@inlined(**_JIT)
def lift_factor(cl_att, cl_tab):
    """F0 = F(x0): the table's lift over the attached-flow lift (a deficit below SEP_LIFT_TOL taken as
    none), clipped to Kirchhoff's range [1/4, 1]."""
    mag = abs(cl_att)
    deficit = mag - (cl_tab if cl_att >= 0.0 else -cl_tab)  # |CL_att| - CL_tab sign(CL_att)
    r = 1.0 - max(deficit - SEP_LIFT_TOL, 0.0) / max(mag, SEP_LIFT_TOL)
    return min(max(r, 0.25), 1.0)


@inlined(**_JIT)
def lift_deficit(cl_att, cl_tab):
    """cl_att (1 - F0), F0 = :func:`lift_factor`: the lift the static separation takes from the attached
    flow's, without a division (the right-hand side needs this product, not F0, and evaluates it for
    every strip in every RK stage).  With m = max(|cl_att|, tol) and d = max(deficit - tol, 0), F0 =
    1 - min(d, 3m/4) / m (the clip at 1 is d >= 0, at 1/4 the min), so cl_att (1 - F0) = g min(d, 3m/4)
    with g = cl_att / m = clip(cl_att / tol, -1, 1)."""
    mag = abs(cl_att)
    deficit = mag - (cl_tab if cl_att >= 0.0 else -cl_tab)
    g = min(max(cl_att * (1.0 / SEP_LIFT_TOL), -1.0), 1.0)
    return g * min(max(deficit - SEP_LIFT_TOL, 0.0), 0.75 * max(mag, SEP_LIFT_TOL))


@inlined(**_JIT)
def separation_static(p, alpha, tab_alpha, tab_cl):
    """The static separation state x0(alpha) = (2 sqrt(F0) - 1)^2 of the Hawk (:func:`static_factor`)."""
    s = 2.0 * math.sqrt(static_factor(p, alpha, interp(alpha, tab_alpha, tab_cl))) - 1.0
    return s * s


@inlined(**_JIT)
def separated_coefficients(p, alpha, x, tab_alpha, tab_cl, tab_cm):
    """The Hawk's CL and CM at angle of attack alpha and separation state x:

        CL = CL_tab(alpha) + CL_att(alpha) (F(x) - F(x0(alpha))),
        CM = CM_tab(alpha) + (CMalpha / CLalpha) (CL - CL_tab(alpha)),

    so both equal the tables whenever x = x0(alpha) (whatever the clipping of F0), and away from it the
    lift that separation takes away or gives back acts at the attached flow's aerodynamic centre (the
    static margin -CMalpha / CLalpha behind the c.g.).  With ``sep_cp_travel`` k the whole lift's centre of
    pressure moves k (1 - x) chords aft as the flow separates (Leishman and Beddoes' linear form), beyond the
    tables' static travel: CM - k (CL (1 - x) - CL_tab (1 - x0)), zero again at x = x0."""
    cl_tab = interp(alpha, tab_alpha, tab_cl)
    cm_tab = interp(alpha, tab_alpha, tab_cm)
    cl_att = attached_lift(p, alpha)
    dcl = cl_att * (kirchhoff(x) - 1.0) + lift_deficit(cl_att, cl_tab)  # cl_att (F(x) - F0), no division
    r0 = 2.0 * math.sqrt(lift_factor(cl_att, cl_tab)) - 1.0  # x0 = r0^2
    xc = min(max(x, 0.0), 1.0)
    travel = p[L.P_HAWK_AERO_SEP_CP_TRAVEL] * ((cl_tab + dcl) * (1.0 - xc) - cl_tab * (1.0 - r0 * r0))
    return cl_tab + dcl, cm_tab + (p[L.P_HAWK_AERO_CMALPHA] / p[L.P_HAWK_AERO_CLALPHA]) * dcl - travel


@inlined(**_JIT)
def hawk_flow(A, v_cg, omega, v_air):
    """The Hawk's angle of attack alpha (rad), airspeed V (m/s) and alpha-dot from the velocities (rad/s),
    q - v (p u + r w) / (u^2 + w^2) (:func:`hawk_aero_full`; the c.g. acceleration's part left out)."""
    vb = mtv(A, sub(v_cg, v_air))
    wb = mtv(A, omega)
    vxz2 = vb[0] * vb[0] + vb[2] * vb[2]
    ixz2 = 1.0 / vxz2 if vxz2 > 0.0 else 0.0
    V = math.sqrt(vxz2 + vb[1] * vb[1])
    return vmath.atan2(vb[2], vb[0]), V, wb[1] - vb[1] * (wb[0] * vb[0] + wb[2] * vb[2]) * ixz2


@inlined(**_JIT)
def separation_target(p, alpha, V, adot, tab_alpha, tab_cl):
    """The right-hand side x0(alpha - tau2 alphadot) of the separation state's equation (tau2 in seconds:
    the parameter times c / V), the state's steady value at constant alpha-dot."""
    c = p[L.P_HAWK_AERO_C]
    return separation_static(p, alpha - p[L.P_HAWK_AERO_SEP_TAU2] * (c / max(V, MIN_AIRSPEED)) * adot, tab_alpha, tab_cl)


@inlined(**_JIT)
def separation_relax(p, alpha, V, adot, x, dt, tab_alpha, tab_cl):
    """The separation state x after dt seconds of tau1 dx/dt + x = x0(alpha - tau2 alphadot) with its
    right-hand side held: x0_d + (x - x0_d) exp(-dt V / (tau1 c)), x0_d the delayed static state
    (:func:`separation_target`) and tau1 in seconds the parameter times c / V.  Below MIN_AIRSPEED x is held."""
    c = p[L.P_HAWK_AERO_C]
    Vs = max(V, MIN_AIRSPEED)
    target = separation_target(p, alpha, V, adot, tab_alpha, tab_cl)
    decay = vmath.exp(-(dt * Vs) / (p[L.P_HAWK_AERO_SEP_TAU1] * c))
    xn = target + (x - target) * decay
    return xn if V >= MIN_AIRSPEED else x


# the compensator's panels (NACA 0018 sections): one separation state per panel, the same model with the
# attached-flow normal force CLalpha sin(alpha) of the symmetric section, the panel's flow taken at its
# mid-span station, and its own time constants (comp_aero.sep_tau1, sep_tau2, in its chord S / span over V)


@inlined(**_JIT)
def panel_flow(vb0, wb, rm, i):
    """Panel i's angle of attack (rad), in-plane airspeed (m/s) and pitch rate about -e_r (rad/s; the
    velocity part of its alpha-dot) at radius rm, from the reference point's velocity relative to the air
    vb0 and the arm's angular velocity wb (arm axes; :func:`panel`'s kinematics)."""
    ce = PANEL_COS[i]
    sg = PANEL_SIN[i]
    u = vb0[0] + rm * (wb[1] * sg - wb[2] * ce)
    wn = vb0[1] * sg - vb0[2] * ce - rm * wb[0]
    return vmath.atan2(wn, u), math.sqrt(u * u + wn * wn), -(wb[1] * ce + wb[2] * sg)


@inlined(**_JIT)
def panel_separation_static(cla, alpha, tab_alpha, tab_cn):
    """x0(alpha) of a compensator panel: the table's CN inverted through Kirchhoff's factor against CLalpha sin(alpha)."""
    s = 2.0 * math.sqrt(lift_factor(cla * vmath.sincos(alpha)[0], interp(alpha, tab_alpha, tab_cn))) - 1.0
    return s * s


@inlined(**_JIT)
def comp_separation_relax(p, vb0, wb, xs, dt, tab_alpha, tab_cn):
    """The four panels' separation states xs (4-tuple) after dt seconds, each relaxed towards its target
    x0(alpha - tau2 alphadot) held (:func:`separation_relax`'s equation; tau1, tau2 the compensator's times
    its chord S / span over the panel's in-plane speed at mid-span); a panel below MIN_AIRSPEED holds x."""
    span = p[L.P_COMP_AERO_SPAN]
    c = p[L.P_COMP_AERO_S] / span
    rm = 0.5 * (p[L.P_GEOMETRY_ARM_RADIUS] + 0.5 * span)
    cla = p[L.P_COMP_AERO_CLALPHA]
    t1 = p[L.P_COMP_AERO_SEP_TAU1] * c
    t2 = p[L.P_COMP_AERO_SEP_TAU2] * c
    a0, v0, r0 = panel_flow(vb0, wb, rm, 0)
    a1, v1, r1 = panel_flow(vb0, wb, rm, 1)
    a2, v2, r2 = panel_flow(vb0, wb, rm, 2)
    a3, v3, r3 = panel_flow(vb0, wb, rm, 3)
    return (
        panel_relax(cla, a0, v0, r0, xs[0], dt, t1, t2, tab_alpha, tab_cn),
        panel_relax(cla, a1, v1, r1, xs[1], dt, t1, t2, tab_alpha, tab_cn),
        panel_relax(cla, a2, v2, r2, xs[2], dt, t1, t2, tab_alpha, tab_cn),
        panel_relax(cla, a3, v3, r3, xs[3], dt, t1, t2, tab_alpha, tab_cn),
    )


@inlined(**_JIT)
def panel_target(cla, alpha, V, adot, t2, tab_alpha, tab_cn):
    """A panel's x0(alpha - tau2 alphadot), t2 = tau2 c (m)."""
    return panel_separation_static(cla, alpha - (t2 / max(V, MIN_AIRSPEED)) * adot, tab_alpha, tab_cn)


@inlined(**_JIT)
def panel_relax(cla, alpha, V, adot, x, dt, t1, t2, tab_alpha, tab_cn):
    """A panel's separation state after dt seconds towards its held target (t1 = tau1 c, t2 = tau2 c, m)."""
    target = panel_target(cla, alpha, V, adot, t2, tab_alpha, tab_cn)
    xn = target + (x - target) * vmath.exp(-(dt * max(V, MIN_AIRSPEED)) / t1)
    return xn if V >= MIN_AIRSPEED else x


@inlined(**_JIT)
def comp_separation_targets(p, vb0, wb, tab_alpha, tab_cn):
    """The panels' targets x0(alpha - tau2 alphadot) (4-tuple): their separation states in steady flow."""
    span = p[L.P_COMP_AERO_SPAN]
    c = p[L.P_COMP_AERO_S] / span
    rm = 0.5 * (p[L.P_GEOMETRY_ARM_RADIUS] + 0.5 * span)
    cla = p[L.P_COMP_AERO_CLALPHA]
    t2 = p[L.P_COMP_AERO_SEP_TAU2] * c
    a0, v0, r0 = panel_flow(vb0, wb, rm, 0)
    a1, v1, r1 = panel_flow(vb0, wb, rm, 1)
    a2, v2, r2 = panel_flow(vb0, wb, rm, 2)
    a3, v3, r3 = panel_flow(vb0, wb, rm, 3)
    return (
        panel_target(cla, a0, v0, r0, t2, tab_alpha, tab_cn), panel_target(cla, a1, v1, r1, t2, tab_alpha, tab_cn),
        panel_target(cla, a2, v2, r2, t2, tab_alpha, tab_cn), panel_target(cla, a3, v3, r3, t2, tab_alpha, tab_cn),
    )


@inlined(**_JIT)
def comp_separation_rates(p, vb0, wb, xs, tab_alpha, tab_cn):
    """dx/dt (4-tuple, 1/s) of the panels' separation states (continuation and linearisation)."""
    span = p[L.P_COMP_AERO_SPAN]
    c = p[L.P_COMP_AERO_S] / span
    rm = 0.5 * (p[L.P_GEOMETRY_ARM_RADIUS] + 0.5 * span)
    cla = p[L.P_COMP_AERO_CLALPHA]
    t1 = p[L.P_COMP_AERO_SEP_TAU1] * c
    t2 = p[L.P_COMP_AERO_SEP_TAU2] * c
    return (
        panel_rate(cla, panel_flow(vb0, wb, rm, 0), xs[0], t1, t2, tab_alpha, tab_cn),
        panel_rate(cla, panel_flow(vb0, wb, rm, 1), xs[1], t1, t2, tab_alpha, tab_cn),
        panel_rate(cla, panel_flow(vb0, wb, rm, 2), xs[2], t1, t2, tab_alpha, tab_cn),
        panel_rate(cla, panel_flow(vb0, wb, rm, 3), xs[3], t1, t2, tab_alpha, tab_cn),
    )


@inlined(**_JIT)
def panel_rate(cla, flow, x, t1, t2, tab_alpha, tab_cn):
    """A panel's dx/dt (1/s) at its flow (alpha, V, alphadot) (:func:`panel_flow`); 0 below MIN_AIRSPEED."""
    a, V, r = flow
    rate = (panel_target(cla, a, V, r, t2, tab_alpha, tab_cn) - x) * V / t1
    return rate if V >= MIN_AIRSPEED else 0.0


# ---------------------------------------------------------------------- the Hawk's wake at the compensator (aero_model="unsteady")
# The Hawk's lift and side force leave a trailing vortex system that the air carries to the compensator,
# d = arm_length + hawk_cg_x - comp_aero_x (1.18 m) downstream, d / V later (docs/MODEL.md 3.1.2).  The
# lift's system is a horseshoe vortex of the elliptic wing's vortex span b' = pi b / 4 (semispan s = b' / 2),
# circulation G = L / (rho V b'); on its centre line at distance d the Biot-Savart law gives the downwash
# G (1 + r / d) / (2 pi s), r = sqrt(d^2 + s^2) (the two trailing vortices and the bound one; G / (pi s) far
# behind).  The compensator's panels span B = comp_aero.span, wider than the vortices' 2 s, and outboard of a
# trailing vortex the air goes up, so the load the panels feel is that of the downwash averaged over B: for a
# vortex pair far behind, G / (pi B) ln((B/2 + s) / |B/2 - s|), with a vortex core of radius WAKE_CORE s
# (ln of the squared distances with rc^2 added, so that a panel tip in a vortex stays finite).  The side
# force's vortices (the fin's, a pair much closer than B) give, averaged over B, 2 Y / (pi rho V B^2)
# whatever their spacing.  The wake's velocity is opposite to the force that made it.

WAKE_CORE = 0.1
"""Core radius of the Hawk's trailing vortices as a fraction of their semispan pi b / 8 (an estimate: a rolled-up
tip vortex's core is a few per cent of the span)."""


@inlined(**_JIT)
def wake_distance(p):
    """Streamwise distance (m) from the Hawk's c.g. to the compensator's reference point on the straight arm."""
    return p[L.P_GEOMETRY_ARM_LENGTH] + p[L.P_GEOMETRY_HAWK_CG_X] - p[L.P_GEOMETRY_COMP_AERO_X]


@inlined(**_JIT)
def wake_gains(p, V):
    """(k_y, k_z) (m/s per N): the sidewash and downwash velocity at the compensator, averaged over its span,
    per unit of the Hawk's side force and lift at tunnel speed V (at least MIN_AIRSPEED), times
    ``hawk_aero.wake_factor`` (module comment above)."""
    d = wake_distance(p)
    s = 0.125 * math.pi * p[L.P_HAWK_AERO_B]
    B = p[L.P_COMP_AERO_SPAN]
    h = 0.5 * B
    rc2 = (WAKE_CORE * s) * (WAKE_CORE * s)
    near = 0.5 * (1.0 + math.sqrt(d * d + s * s) / d)  # the bound vortex's share on the centre line
    ln = vmath.log(((h + s) * (h + s) + rc2) / ((h - s) * (h - s) + rc2))
    k = p[L.P_HAWK_AERO_WAKE_FACTOR] / (math.pi * p[L.P_ENVIRONMENT_AIR_DENSITY] * max(V, MIN_AIRSPEED) * B)
    return k * 2.0 / B, k * near * ln / (4.0 * s)


@inlined(**_JIT)
def wake_relax(p, V, f_world, w, dt):
    """The wake velocities w = (v, w) at the compensator (m/s, world y and z) after dt seconds of
    tau dw/dt + w = -(k_y F_y, k_z F_z), tau = d / V the convection time, f_world the Hawk's aerodynamic force
    (N, world axes) held: a first-order lag whose mean delay is the convection time (its phase lag omega tau
    at low frequency).  Below MIN_AIRSPEED the wake decays at MIN_AIRSPEED's rate towards zero."""
    ty, tz = wake_targets(p, V, f_world)
    decay = vmath.exp(-(dt * max(V, MIN_AIRSPEED)) / wake_distance(p))
    return ty + (w[0] - ty) * decay, tz + (w[1] - tz) * decay


@inlined(**_JIT)
def wake_targets(p, V, f_world):
    """The wake velocities in steady flow (:func:`wake_relax`'s targets)."""
    ky, kz = wake_gains(p, V)
    return -ky * f_world[1], -kz * f_world[2]


@inlined(**_JIT)
def wake_rates(p, V, f_world, w):
    """dw/dt (m/s^2) of the wake velocities (continuation and linearisation)."""
    ty, tz = wake_targets(p, V, f_world)
    r = max(V, MIN_AIRSPEED) / wake_distance(p)
    return (ty - w[0]) * r, (tz - w[1]) * r


@inlined(**_JIT)
def strip(u, wn, vs2, qp, c, dS, rho, k_ind, cl0, cm0, cla, cma, clq, cmq, cd0, nonlinear, tab_alpha, tab_cn, unsteady, x):
    """Loads of one strip from its velocity relative to the air in the panel's axes (e_x, n, e_r): u along
    x, -wn along the normal n, a spanwise component of square vs2.  Returns (f_x, f_n, dk, mc): the force's
    x and n components, the drag factor dk (the force's spanwise component is -dk times the spanwise
    velocity, the same for both strips of a panel, so the panel applies it once) and the section pitching
    moment mc (about -e_r).  Lift is normal to the in-plane velocity (u e_x - wn n), drag against the full
    strip velocity (so that the panels' drag sums to a force along the free stream, as Table 4's CD does).
    A strip below MIN_AIRSPEED carries no load (selected, not branched, so that panels vectorise).
    unsteady (with nonlinear): the table's CN moved by CLalpha sin(alpha) (F(x) - F0), x the panel's separation
    state (:func:`lift_factor`; the table's CN at x = x0), the moment with it as with the table."""
    V2 = u * u + wn * wn
    V = math.sqrt(V2)  # in-plane speed
    vabs = math.sqrt(V2 + vs2)  # full speed, with the spanwise component
    # 1 / V and 1 / vabs from one division (at V = 0 they are not finite: the strip's load is selected away below)
    inv = 1.0 / (V * vabs)
    alpha = vmath.atan2(wn, u)  # branch-free: the panels vectorise
    qhat = qp * c * (0.5 * vabs * inv)
    if nonlinear:
        cl_static = interp(alpha, tab_alpha, tab_cn)
        if unsteady:
            cn_att = cla * (wn * (vabs * inv))  # CLalpha sin(alpha): sin(atan2(wn, u)) = wn / V, no sine needed
            cl_static = cl_static + (cn_att * (kirchhoff(x) - 1.0) + lift_deficit(cn_att, cl_static))  # cn_att (F(x) - F0)
        cm_static = cl_static * (cma / cla) if cla != 0.0 else cma * alpha
    else:
        cl_static = cla * alpha
        cm_static = cma * alpha
    CL = cl0 + cl_static + clq * qhat
    CM = cm0 + cm_static + cmq * qhat
    CD = cd0 + k_ind * CL * CL
    hrs = 0.5 * rho * dS
    qS = hrs * V2
    lk = hrs * V * CL  # the lift's qS / V, without a division
    dk = qS * CD * (V * inv)  # qS CD / vabs
    f_x = lk * wn - dk * u
    f_n = lk * u + dk * wn
    mc = qS * c * CM
    if V < MIN_AIRSPEED:
        return 0.0, 0.0, 0.0, 0.0
    return f_x, f_n, dk, mc


@inlined(**_JIT)
def panel(i, vb0, wb, flap, rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, nonlinear, tab_alpha, tab_cn, unsteady, x):
    """Force and moment (arm axes, the moment about the reference point) of panel i: its two Gauss strips
    at r = rm -+ dr_g along its span e_r = (0, ce, sg), normal n = x_arm x e_r = (0, -sg, ce).

    A strip at r moves at v = vb0 + wb x (r e_r) relative to the air: in the panel's axes u = vb0_x +
    r (wb_y sg - wb_z ce) along x, vb0.n + r wb_x along n and vb0.e_r along e_r (the same for both
    strips).  A strip force f = f_x e_x + f_n n + f_r e_r at r e_r has the moment r (f_n e_x - f_x n); the
    section moment acts about -e_r.  The strips' loads are summed in the panel's axes and turned into
    arm axes once."""
    ce = PANEL_COS[i]
    sg = PANEL_SIN[i]
    se = MIX_ELEVATOR_A[i]
    qp = -(wb[1] * ce + wb[2] * sg)  # -w.e_r: rotation about -e_r moves the leading edge towards +n
    cl0 = se * cl_off + cld * flap
    cm0 = se * cm_off + cmd * flap
    vs = vb0[1] * ce + vb0[2] * sg
    vs2 = vs * vs
    wn0 = vb0[1] * sg - vb0[2] * ce  # -vb0.n
    du = wb[1] * sg - wb[2] * ce  # d(u) / dr
    ra = rm - dr_g
    rb = rm + dr_g
    a = strip(vb0[0] + ra * du, wn0 - ra * wb[0], vs2, qp, c, dS, rho, k_ind, cl0, cm0, cla, cma, clq, cmq, cd0, nonlinear, tab_alpha, tab_cn, unsteady, x)
    b = strip(vb0[0] + rb * du, wn0 - rb * wb[0], vs2, qp, c, dS, rho, k_ind, cl0, cm0, cla, cma, clq, cmq, cd0, nonlinear, tab_alpha, tab_cn, unsteady, x)
    fx = a[0] + b[0]
    fn = a[1] + b[1]
    fr = -(vs * (a[2] + b[2]))
    mx = ra * a[1] + rb * b[1]
    mn = -(ra * a[0] + rb * b[0])
    mr = -(a[3] + b[3])
    return fx, ce * fr - sg * fn, ce * fn + sg * fr, mx, ce * mr - sg * mn, ce * mn + sg * mr


@njit(**_JIT)
def strips_nonlinear(vb0, wb, flaps, rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, tab_alpha, tab_cn, unsteady, xs):
    """Sum of the eight strips' loads with the stall tables (a table search per strip: not vectorisable,
    so compiled once as its own function rather than inlined beside the linear loop); unsteady: through the
    panels' separation states xs (4-tuple)."""
    fx = fy = fz = mx = my = mz = 0.0
    for i in range(4):
        f = panel(i, vb0, wb, flaps[i], rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, True, tab_alpha, tab_cn, unsteady, xs[i])
        fx += f[0]
        fy += f[1]
        fz += f[2]
        mx += f[3]
        my += f[4]
        mz += f[5]
    return fx, fy, fz, mx, my, mz


@inlined(**_JIT)
def comp_aero(p, A, v_ref, omega, v_air, flaps, nonlinear, tab_alpha, tab_cn, unrolled=False, unsteady=False, xs=ATTACHED4):
    """Compensator force (world, N) and moment about its aerodynamic reference point (world, N m).

    A: arm rotation; v_ref: velocity of the reference point (world); omega: arm angular velocity
    (world); v_air: air velocity (world); the rest as :func:`comp_aero_arm`, which this calls with the
    velocities in arm axes.
    """
    f, m = comp_aero_arm(p, mtv(A, sub(v_ref, v_air)), mtv(A, omega), flaps, nonlinear, tab_alpha, tab_cn, unrolled, unsteady, xs)
    return mv(A, f), mv(A, m)


@inlined(**_JIT)
def comp_aero_arm(p, vb0, wb, flaps, nonlinear, tab_alpha, tab_cn, unrolled=False, unsteady=False, xs=ATTACHED4):
    """Compensator force (arm axes, N) and moment about its aerodynamic reference point (arm axes, N m).

    vb0: velocity of the reference point relative to the air, wb: arm angular velocity, both in arm
    axes; flaps: 4 flap deflections (rad, after mixing and servos); unrolled: the four panels written out, for
    the lane kernel, whose loop over environments must contain no loop of its own (a compile-time
    constant there; its tables are tuples, :func:`interp`); otherwise one loop over the panels, which LLVM
    vectorises across the panels (with the tables, :func:`strips_nonlinear`: a table search per strip).
    Each panel i (span e_r, normal n = x_arm cross e_r) carries Table 4 coefficients per unit area of
    half the reference area; its lift acts along n for positive local incidence or flap.  unsteady (with
    nonlinear): the panels' tables through their separation states xs (4-tuple, flaps 1-4 order).
    """
    S = p[L.P_COMP_AERO_S]
    span = p[L.P_COMP_AERO_SPAN]
    c = S / span
    r0 = p[L.P_GEOMETRY_ARM_RADIUS]
    r1 = 0.5 * span
    rm = 0.5 * (r0 + r1)
    dr_g = GAUSS * (r1 - r0)
    dS = 0.25 * S  # two strips per panel, each a quarter of S (a panel is half the reference area)
    rho = p[L.P_ENVIRONMENT_AIR_DENSITY]
    k_ind = S / (math.pi * p[L.P_COMP_AERO_E_OSWALD] * span * span)  # 1 / (pi e AR), AR = span^2 / S
    cla = p[L.P_COMP_AERO_CLALPHA]
    cma = p[L.P_COMP_AERO_CMALPHA]
    a0 = p[L.P_COMP_AERO_ALPHA0]
    cl_off = (p[L.P_COMP_AERO_CL0] - cla * a0) * SQRT_HALF
    cm_off = (p[L.P_COMP_AERO_CM0] - cma * a0) * SQRT_HALF
    cld = p[L.P_COMP_AERO_CLDE] * SQRT_HALF
    cmd = p[L.P_COMP_AERO_CMDE] * SQRT_HALF
    clq = p[L.P_COMP_AERO_CLQ]
    cmq = p[L.P_COMP_AERO_CMQ]
    cd0 = 0.5 * p[L.P_COMP_AERO_CD0]
    if nonlinear and not unrolled:
        fx, fy, fz, mx, my, mz = strips_nonlinear(vb0, wb, flaps, rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, tab_alpha, tab_cn, unsteady, xs)
    elif unrolled:
        f0 = panel(0, vb0, wb, flaps[0], rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, nonlinear, tab_alpha, tab_cn, unsteady, xs[0])
        f1 = panel(1, vb0, wb, flaps[1], rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, nonlinear, tab_alpha, tab_cn, unsteady, xs[1])
        f2 = panel(2, vb0, wb, flaps[2], rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, nonlinear, tab_alpha, tab_cn, unsteady, xs[2])
        f3 = panel(3, vb0, wb, flaps[3], rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, nonlinear, tab_alpha, tab_cn, unsteady, xs[3])
        fx = f0[0] + f1[0] + f2[0] + f3[0]
        fy = f0[1] + f1[1] + f2[1] + f3[1]
        fz = f0[2] + f1[2] + f2[2] + f3[2]
        mx = f0[3] + f1[3] + f2[3] + f3[3]
        my = f0[4] + f1[4] + f2[4] + f3[4]
        mz = f0[5] + f1[5] + f2[5] + f3[5]
    else:
        # one loop over the four panels, the same body for each and no library calls or jumps in it, so
        # that LLVM computes them side by side in SIMD lanes
        fx = fy = fz = mx = my = mz = 0.0
        for i in range(4):
            f = panel(i, vb0, wb, flaps[i], rm, dr_g, c, dS, rho, k_ind, cla, cma, cl_off, cm_off, cld, cmd, clq, cmq, cd0, False, tab_alpha, tab_cn, False, 1.0)
            fx += f[0]
            fy += f[1]
            fz += f[2]
            mx += f[3]
            my += f[4]
            mz += f[5]
    return (fx, fy, fz), (mx, my, mz)

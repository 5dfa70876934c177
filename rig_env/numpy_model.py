"""The rig's continuous model in plain numpy: an independent implementation and the scipy benchmark peer.

This is the same model as :func:`rig_env.reference.continuous_rhs` (joint-space dynamics, aero, LuGre
friction with the bristle ODE in the state, stops, ideal servos), written again from the equations of
docs/MODEL.md and the paper (AIAA 2009-5727 Sec. II) without numba and without any of the kernel's
code: it is what a researcher would write for ``scipy.integrate.solve_ivp``, and the tests check the
kernel against it term by term.  The two share only the parameter vector (``RigParams.to_vector()``,
indices in :mod:`rig_env.physics.layout`) and the state layout ``y = [q (5), qd (5), z (5)]`` (rad,
rad/s, rad; rig_env.JOINTS order).

Method (the textbook one, where the kernel uses condensed sums):

* rotations ``A_s = Rz(psi) Ry(theta) Rx(phi)``, ``A_a = A_s Rz(psi_a) Ry(theta_a)`` and their time
  derivatives by the product rule, with ``dR(a)/da = R(a) [e]x`` for an elementary rotation about e;
* body Jacobians formed explicitly, column k of joint k (axis a_k through the point c_k: the pivot for
  the rig joints, the model gimbal G for the model joints): ``J_v = a_k x (r - c_k)``, ``J_w = a_k``,
  zero for a body that joint k does not move; their time derivatives ``dJ_v = da_k x (r - c_k) +
  a_k x (dr - dc_k)``, ``dJ_w = da_k`` from the rotation derivatives (no finite differences);
* ``M = sum_b m_b J_v^T J_v + J_w^T I_b J_w``, ``h = sum_b m_b J_v^T dJ_v qd + J_w^T (I_b dJ_w qd +
  w x I_b w)`` with ``I_b = A_b I_body A_b^T`` (eqs. 3-11 projected on the joints);
* generalised forces ``Q = J_v^T F + J_w^T T`` of every load at its point of application: weights,
  the Hawk's aerodynamic force and moment at its c.g. (eq. 23 plus lateral terms), each of the
  compensator's eight strips (four panels, two Gauss stations) at its own station, friction (eqs.
  19-21, subtracted per eq. 22) and stops;
* a wind-off test fixture (springs and masses on a joint, the paper's Fig. 4(a)): its inertia on the
  joint's diagonal of M, its spring and constant torque in Q (:func:`fixture_inertia`,
  :func:`fixture_force`; zero in flight);
* the Hawk's alpha-dot (its share ``alphadot_fraction`` of the q derivatives) from the time derivative of
  its body-axis velocity, ``alpha' = (u w' - w u') / (u^2 + w^2)``, which is linear in qdd: the loads per
  unit alpha-dot, through ``J^T``, times its gradient go to the left-hand side, ``(M - d g^T) qdd = Q``;
* ``numpy.linalg.solve`` on the free rows and columns; locked joints have zero derivatives.

Locked joints are expected to have zero rate in ``y`` (as :func:`rig_env.simulate` sets them).
One evaluation costs about 0.35 ms (the kernel's, called from Python, about 0.015 ms).  Used by
tests/test_numpy_model.py (the kernel equals it to about 1e-14 relative) and by the benchmark peer
:func:`rig_env.reference.env_steps_per_s_scipy_numpy`.
"""

from __future__ import annotations

import math

import numpy as np

from rig_env.physics import layout as L

E_X = np.array([1.0, 0.0, 0.0])
E_Y = np.array([0.0, 1.0, 0.0])
E_Z = np.array([0.0, 0.0, 1.0])
MIN_AIRSPEED = 0.5  # m/s: below this local airspeed a body or strip carries no aerodynamic load
SEP_LIFT_TOL = 0.01  # lift-coefficient deficit counted as attached flow (docs/MODEL.md 3.1.1)
# compensator panels (docs/MODEL.md sec. 1): roll positions of flaps 1-4 and their mixing signs
PANEL_GAMMA = np.radians([135.0, 45.0, -45.0, -135.0])
PANEL_ELEVATOR_SIGN = np.array([1.0, -1.0, -1.0, 1.0])
FRICTION_BASE = (L.P_FRICTION_RIG_ROLL_FS, L.P_FRICTION_RIG_PITCH_FS, L.P_FRICTION_RIG_YAW_FS, L.P_FRICTION_MODEL_PITCH_FS, L.P_FRICTION_MODEL_YAW_FS)
STOP_BASE = {1: L.P_STOPS_RIG_PITCH_LOWER_DEG, 2: L.P_STOPS_RIG_YAW_LOWER_DEG, 3: L.P_STOPS_MODEL_PITCH_LOWER_DEG}


def hat(v: np.ndarray) -> np.ndarray:
    """[v]x, the cross-product matrix: hat(v) @ w = v x w."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


HAT_X, HAT_Y, HAT_Z = hat(E_X), hat(E_Y), hat(E_Z)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis, broadcast ((..., 3) arrays; np.cross without its axis bookkeeping,
    which costs several times the arithmetic on 3-vectors)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def body_inertia(ixx: float, iyy: float, izz: float, ixz: float = 0.0) -> np.ndarray:
    """Inertia tensor in body axes (kg m^2), aircraft convention for the product of inertia."""
    return np.array([[ixx, 0.0, -ixz], [0.0, iyy, 0.0], [-ixz, 0.0, izz]])


def kinematics(q: np.ndarray, qd: np.ndarray, p: np.ndarray) -> dict:
    """Rotations, joint axes and centres, and their time derivatives at (q (5,) rad, qd (5,) rad/s).

    Returns As, Aa (3, 3) body to world and dAs, dAa their time derivatives; axes, daxes (5, 3): joint
    axes (world) and their derivatives; centres, dcentres (5, 3): a point of each joint axis (pivot or
    model gimbal, m from the pivot) and its velocity.
    """
    phi, theta, psi, theta_a, psi_a = q
    dphi, dtheta, dpsi, dtheta_a, dpsi_a = qd
    Rz, Ry, Rx = rot_z(psi), rot_y(theta), rot_x(phi)
    As = Rz @ Ry @ Rx
    dAs = Rz @ HAT_Z @ Ry @ Rx * dpsi + Rz @ Ry @ HAT_Y @ Rx * dtheta + As @ HAT_X * dphi
    Rza, Rya = rot_z(psi_a), rot_y(theta_a)
    B = Rza @ Rya
    dB = Rza @ HAT_Z @ Rya * dpsi_a + B @ HAT_Y * dtheta_a
    Aa = As @ B
    dAa = dAs @ B + As @ dB
    # rig_roll: x_s; rig_pitch: y of the yawed ring, Rz(psi) e_y; rig_yaw: world z;
    # model_pitch: y_a; model_yaw: z_s
    axes = np.array([As[:, 0], Rz[:, 1], E_Z, Aa[:, 1], As[:, 2]])
    daxes = np.array([dAs[:, 0], (Rz @ HAT_Z)[:, 1] * dpsi, np.zeros(3), dAa[:, 1], dAs[:, 2]])
    arm = np.array([p[L.P_GEOMETRY_ARM_LENGTH], 0.0, 0.0])
    G, dG = As @ arm, dAs @ arm
    centres = np.array([np.zeros(3), np.zeros(3), np.zeros(3), G, G])
    dcentres = np.array([np.zeros(3), np.zeros(3), np.zeros(3), dG, dG])
    return dict(As=As, dAs=dAs, Aa=Aa, dAa=dAa, axes=axes, daxes=daxes, centres=centres, dcentres=dcentres)


def point_jacobian(kin: dict, r: np.ndarray, dr: np.ndarray, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(J_v, dJ_v) (3, 5) of a point at r (m, world, from the pivot) with velocity dr (m/s).

    moved (5,): 1.0 for the joints that move the point, 0.0 for the others.
    """
    lever = r - kin["centres"]
    dlever = dr - kin["dcentres"]
    Jv = cross(kin["axes"], lever).T * moved
    dJv = (cross(kin["daxes"], lever) + cross(kin["axes"], dlever)).T * moved
    return Jv, dJv


def rotation_jacobian(kin: dict, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(J_w, dJ_w) (3, 5) of a body turned by the joints flagged in moved (5,)."""
    return kin["axes"].T * moved, kin["daxes"].T * moved


RIG_JOINTS = np.array([1.0, 1.0, 1.0, 0.0, 0.0])  # arm and compensator: moved by the rig joints only
ALL_JOINTS = np.ones(5)  # the Hawk: by all five


def bodies(q: np.ndarray, qd: np.ndarray, p: np.ndarray) -> tuple[dict, list[dict]]:
    """The kinematics and the three bodies (arm s, compensator r, aircraft a) at (q, qd).

    Each body: m (kg), r (world c.g. from the pivot, m), I (world inertia at the c.g., kg m^2),
    Jv, dJv, Jw, dJw (3, 5).  The compensator is a point mass; its own inertia is carried by the arm
    (note to eq. 10).
    """
    kin = kinematics(q, qd, p)
    As, dAs, Aa, dAa = kin["As"], kin["dAs"], kin["Aa"], kin["dAa"]
    l_s = p[[L.P_GEOMETRY_ARM_CG_X, L.P_GEOMETRY_ARM_CG_Y, L.P_GEOMETRY_ARM_CG_Z]]
    l_r = p[[L.P_GEOMETRY_COMP_CG_X, L.P_GEOMETRY_COMP_CG_Y, L.P_GEOMETRY_COMP_CG_Z]]
    l_a = np.array([p[L.P_GEOMETRY_HAWK_CG_X], 0.0, p[L.P_GEOMETRY_HAWK_CG_Z]])
    G, dG = kin["centres"][3], kin["dcentres"][3]
    I_s = body_inertia(*(p[i] + p[j] for i, j in ((L.P_MASS_ARM_IXX, L.P_MASS_COMP_IXX), (L.P_MASS_ARM_IYY, L.P_MASS_COMP_IYY), (L.P_MASS_ARM_IZZ, L.P_MASS_COMP_IZZ))))
    I_a = body_inertia(p[L.P_MASS_HAWK_IXX], p[L.P_MASS_HAWK_IYY], p[L.P_MASS_HAWK_IZZ], p[L.P_MASS_HAWK_IXZ])
    specs = (
        ("arm", p[L.P_MASS_ARM_MASS], As @ l_s, dAs @ l_s, As @ I_s @ As.T, RIG_JOINTS),
        ("comp", p[L.P_MASS_COMP_MASS], As @ l_r, dAs @ l_r, np.zeros((3, 3)), RIG_JOINTS),
        ("hawk", p[L.P_MASS_HAWK_MASS], G + Aa @ l_a, dG + dAa @ l_a, Aa @ I_a @ Aa.T, ALL_JOINTS),
    )
    out = []
    for name, m, r, dr, I, joints in specs:
        Jv, dJv = point_jacobian(kin, r, dr, joints)
        Jw, dJw = rotation_jacobian(kin, joints)
        out.append(dict(name=name, m=m, r=r, I=I, Jv=Jv, dJv=dJv, Jw=Jw, dJw=dJw))
    return kin, out


def mass_matrix_and_bias(bs: list[dict], qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M (5, 5) kg m^2 and h (5,) N m of M qdd + h = Q from the bodies of :func:`bodies` at rates qd."""
    M = np.zeros((5, 5))
    h = np.zeros(5)
    for b in bs:
        w = b["Jw"] @ qd
        M += b["m"] * b["Jv"].T @ b["Jv"] + b["Jw"].T @ b["I"] @ b["Jw"]
        h += b["m"] * b["Jv"].T @ (b["dJv"] @ qd) + b["Jw"].T @ (b["I"] @ (b["dJw"] @ qd) + cross(w, b["I"] @ w))
    return M, h


def gravity_force(bs: list[dict], p: np.ndarray) -> np.ndarray:
    """Generalised gravity force (5,) N m: every body's weight m g (world +z, down) at its c.g."""
    g = p[L.P_ENVIRONMENT_GRAVITY]
    return sum(b["Jv"].T @ (b["m"] * g * E_Z) for b in bs)


def fin_factor(alpha: float, p: np.ndarray) -> float:
    """Share of the fin's derivatives left at angle of attack alpha (rad): 1 below the blanking onset,
    ``blanked_fraction`` beyond onset + width, a cubic smoothstep (3 t^2 - 2 t^3) in between."""
    t = np.clip((alpha - p[L.P_HAWK_AERO_BLANKING_ALPHA_DEG]) / p[L.P_HAWK_AERO_BLANKING_WIDTH_DEG], 0.0, 1.0)
    return 1.0 - (1.0 - p[L.P_HAWK_AERO_BLANKED_FRACTION]) * (3 * t**2 - 2 * t**3)


def separation_factor(p: np.ndarray, alpha: float, cl_table: float) -> tuple[float, float]:
    """(CL_att, F0): the attached-flow lift CLalpha sin(alpha - alpha_zl), alpha_zl = alpha0 - CL0 / CLalpha,
    and Kirchhoff's factor F0 = F(x0(alpha)) of the table's lift, CL_table / CL_att in [1/4, 1] with a lift
    deficit below SEP_LIFT_TOL counted as attached flow (docs/MODEL.md 3.1.1)."""
    cla = p[L.P_HAWK_AERO_CLALPHA]
    cl_att = cla * math.sin(alpha - (p[L.P_HAWK_AERO_ALPHA0] - p[L.P_HAWK_AERO_CL0] / cla))
    deficit = abs(cl_att) - math.copysign(1.0, cl_att) * cl_table
    f0 = 1.0 - max(deficit - SEP_LIFT_TOL, 0.0) / max(abs(cl_att), SEP_LIFT_TOL)
    return cl_att, min(max(f0, 0.25), 1.0)


def separation_static(p: np.ndarray, alpha: float, tabs: tuple) -> float:
    """x0(alpha): the separation state whose Kirchhoff factor ((1 + sqrt(x)) / 2)^2 is F0 (:func:`separation_factor`)."""
    f0 = separation_factor(p, alpha, float(np.interp(alpha, tabs[0], tabs[1])))[1]
    return (2.0 * math.sqrt(f0) - 1.0) ** 2


def hawk_loads(p: np.ndarray, Aa: np.ndarray, v_rel: np.ndarray, w: np.ndarray, de: float, da: float, dr: float, nonlinear: bool, tabs: tuple, alpha_dot: float, sep: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Hawk aerodynamic force (N) and moment about its c.g. (N m), world axes; eq. (23) plus lateral terms,
    and the force and moment per unit alpha-dot beyond ``alpha_dot`` (rad/s).

    v_rel: c.g. velocity relative to the air (world, m/s); w: angular velocity (world, rad/s);
    de, da, dr: elevator, aileron, rudder (rad).  The combined q derivatives CLq, CMq are shared between q
    ((1 - f) of them) and alpha-dot (f, ``alphadot_fraction``); the induced drag takes the lift with
    alpha-dot's velocity part alone, q - v (p u + r w) / (u^2 + w^2).  The fin's derivatives (CYbeta, Cnbeta and the rudder's) are scaled by
    :func:`fin_factor`; Clbeta grows with the static lift by Clbeta_CL.  sep (with nonlinear): the flow-separation
    state x; the tables' lift and moment then move by the Kirchhoff lift CL_att (F(x) - F0) and that lift times
    CMalpha / CLalpha (docs/MODEL.md 3.1.1).
    """
    u, v, wz = Aa.T @ v_rel
    V = math.sqrt(u * u + v * v + wz * wz)
    if V < MIN_AIRSPEED:
        return np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)
    pb, qb, rb = Aa.T @ w
    S, c, b = p[L.P_HAWK_AERO_S], p[L.P_HAWK_AERO_C], p[L.P_HAWK_AERO_B]
    alpha = math.atan2(wz, u)
    beta = math.asin(max(-1.0, min(1.0, v / V)))
    p_hat, q_hat, r_hat = pb * b / (2 * V), qb * c / (2 * V), rb * b / (2 * V)
    if nonlinear:
        cl_alpha = np.interp(alpha, tabs[0], tabs[1])
        cm_alpha = np.interp(alpha, tabs[0], tabs[2])
        if sep is not None:
            cl_att, f0 = separation_factor(p, alpha, float(cl_alpha))
            x = min(max(sep, 0.0), 1.0)
            dcl = cl_att * ((1.0 + math.sqrt(x)) ** 2 / 4.0 - f0)
            x0 = (2.0 * math.sqrt(f0) - 1.0) ** 2
            # the centre of pressure k (1 - x) chords behind where it sits in attached flow: its moment beyond the
            # table's, which holds it at x0
            travel = p[L.P_HAWK_AERO_SEP_CP_TRAVEL] * ((cl_alpha + dcl) * (1.0 - x) - cl_alpha * (1.0 - x0))
            cl_alpha = cl_alpha + dcl
            cm_alpha = cm_alpha + p[L.P_HAWK_AERO_CMALPHA] / p[L.P_HAWK_AERO_CLALPHA] * dcl - travel
    else:
        cl_alpha = p[L.P_HAWK_AERO_CL0] + p[L.P_HAWK_AERO_CLALPHA] * (alpha - p[L.P_HAWK_AERO_ALPHA0])
        cm_alpha = p[L.P_HAWK_AERO_CM0] + p[L.P_HAWK_AERO_CMALPHA] * (alpha - p[L.P_HAWK_AERO_ALPHA0])
    f = p[L.P_HAWK_AERO_ALPHADOT_FRACTION]
    CLq_q, CLq_ad = (1 - f) * p[L.P_HAWK_AERO_CLQ], f * p[L.P_HAWK_AERO_CLQ]
    CMq_q, CMq_ad = (1 - f) * p[L.P_HAWK_AERO_CMQ], f * p[L.P_HAWK_AERO_CMQ]
    ad_hat = alpha_dot * c / (2 * V)
    CL = cl_alpha + CLq_q * q_hat + CLq_ad * ad_hat + p[L.P_HAWK_AERO_CLDE] * de
    # the induced drag takes the lift with alpha-dot's velocity part alone (the c.g. acceleration's left out)
    ad_v = qb - v * (pb * u + rb * wz) / (u * u + wz * wz) if u * u + wz * wz > 0.0 else 0.0
    CL_d = CL + CLq_ad * (ad_v - alpha_dot) * c / (2 * V)
    CD = p[L.P_HAWK_AERO_CD0] + CL_d**2 / (math.pi * p[L.P_HAWK_AERO_E_OSWALD] * b * b / S)
    CM = cm_alpha + CMq_q * q_hat + CMq_ad * ad_hat + p[L.P_HAWK_AERO_CMDE] * de
    fin = fin_factor(alpha, p)
    CY = fin * (p[L.P_HAWK_AERO_CYBETA] * beta + p[L.P_HAWK_AERO_CYDR] * dr)
    Clb = p[L.P_HAWK_AERO_CLBETA] + p[L.P_HAWK_AERO_CLBETA_CL] * cl_alpha
    Cl = Clb * beta + p[L.P_HAWK_AERO_CLP] * p_hat + p[L.P_HAWK_AERO_CLR] * r_hat + p[L.P_HAWK_AERO_CLDA] * da + fin * p[L.P_HAWK_AERO_CLDR] * dr
    Cn = (p[L.P_HAWK_AERO_CNBETA_BODY] + fin * p[L.P_HAWK_AERO_CNBETA]) * beta + p[L.P_HAWK_AERO_CNP] * p_hat + p[L.P_HAWK_AERO_CNR] * r_hat + p[L.P_HAWK_AERO_CNDA] * da + fin * p[L.P_HAWK_AERO_CNDR] * dr
    qS = 0.5 * p[L.P_ENVIRONMENT_AIR_DENSITY] * V * V * S
    lift_dir = np.array([math.sin(alpha), 0.0, -math.cos(alpha)])  # normal to the velocity in the x-z plane
    force = qS * (CL * lift_dir - CD * np.array([u, v, wz]) / V + CY * E_Y)
    moment = qS * np.array([b * Cl, c * CM, b * Cn])
    per_ad = c / (2 * V)
    return Aa @ force, Aa @ moment, Aa @ (qS * CLq_ad * per_ad * lift_dir), Aa @ (qS * c * CMq_ad * per_ad * E_Y)


def hawk_alpha_dot(kin: dict, hawk: dict, qd: np.ndarray, v_air: np.ndarray) -> tuple[float, np.ndarray]:
    """The Hawk's alpha-dot (rad/s) at qdd = 0 and its gradient with respect to qdd (5,), s.

    alpha = atan2(w, u) of v_b = A_a^T (v_cg - v_air), the air held over the step:
    v_b' = dA_a^T (v_cg - v_air) + A_a^T (J_v qdd + dJ_v qd), alpha' = (u w' - w u') / (u^2 + w^2).
    """
    Aa, dAa = kin["Aa"], kin["dAa"]
    v_rel = hawk["Jv"] @ qd - v_air
    u, _, w = Aa.T @ v_rel
    if u * u + w * w == 0.0:  # no velocity in the body x-z plane: alpha undefined, no alpha-dot load
        return 0.0, np.zeros(5)
    vb_dot0 = dAa.T @ v_rel + Aa.T @ (hawk["dJv"] @ qd)
    k = np.array([-w, 0.0, u]) / (u * u + w * w)  # d(alpha) / d(v_b)
    return float(k @ vb_dot0), (k @ Aa.T) @ hawk["Jv"]


def compensator_strips(p: np.ndarray, As: np.ndarray, flaps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The eight strips (four panels x two Gauss stations): station offsets in arm axes (8, 3) from
    the aerodynamic reference point, span directions e_r and normals n = x_s x e_r in world axes (8, 3),
    elevator mixing signs (8,) and flap deflections (8,) rad."""
    r0, r1 = p[L.P_GEOMETRY_ARM_RADIUS], 0.5 * p[L.P_COMP_AERO_SPAN]
    stations = 0.5 * (r0 + r1) + np.array([-1.0, 1.0]) * (r1 - r0) / (2 * math.sqrt(3.0))  # 2-point Gauss
    gamma = np.repeat(PANEL_GAMMA, 2)
    radius = np.tile(stations, 4)
    e_r_body = np.stack([np.zeros(8), np.cos(gamma), np.sin(gamma)], axis=1)
    n_body = cross(E_X, e_r_body)
    return radius[:, None] * e_r_body, e_r_body @ As.T, n_body @ As.T, np.repeat(PANEL_ELEVATOR_SIGN, 2), np.repeat(flaps[:4], 2)


def lift_ratio(cl_att: np.ndarray, cl_table: np.ndarray) -> np.ndarray:
    """Kirchhoff's factor F0 of the table's lift against the attached-flow lift, in [1/4, 1], a lift deficit
    below SEP_LIFT_TOL counted as attached flow (array form of :func:`separation_factor`'s)."""
    deficit = np.abs(cl_att) - np.where(cl_att >= 0.0, cl_table, -cl_table)
    return np.clip(1.0 - np.maximum(deficit - SEP_LIFT_TOL, 0.0) / np.maximum(np.abs(cl_att), SEP_LIFT_TOL), 0.25, 1.0)


def compensator_panel_flow(p: np.ndarray, kin: dict, qd: np.ndarray, v_air: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(alpha, V, q_p), each (4,): the panels' incidence (rad), in-plane airspeed (m/s) and rotation rate
    about -e_r (rad/s) at their mid-span stations, flaps 1-4 order."""
    As = kin["As"]
    r0, r1 = p[L.P_GEOMETRY_ARM_RADIUS], 0.5 * p[L.P_COMP_AERO_SPAN]
    e_r_body = np.stack([np.zeros(4), np.cos(PANEL_GAMMA), np.sin(PANEL_GAMMA)], axis=1)
    e_r, n = e_r_body @ As.T, cross(E_X, e_r_body) @ As.T
    axes = kin["axes"][:3]
    w_s = axes.T @ qd[:3]
    r = As @ np.array([p[L.P_GEOMETRY_COMP_AERO_X], 0.0, 0.0]) + 0.5 * (r0 + r1) * e_r  # (4, 3), world
    v = np.cross(w_s[None, :], r) - v_air
    u, wn = v @ As[:, 0], -np.einsum("sc,sc->s", v, n)
    return np.arctan2(wn, u), np.hypot(u, wn), -(e_r @ w_s)


def compensator_separation_rates(p: np.ndarray, kin: dict, qd: np.ndarray, v_air: np.ndarray, xs: np.ndarray, tabs: tuple) -> np.ndarray:
    """dx/dt (4,) of the panels' separation states: (x0(alpha - tau2 q_p) - x) / tau1, tau1, tau2 the
    compensator's times its chord S / span over V, x0 from the CN table against CLalpha sin(alpha)."""
    alpha, V, qp = compensator_panel_flow(p, kin, qd, v_air)
    c = p[L.P_COMP_AERO_S] / p[L.P_COMP_AERO_SPAN]
    cla = p[L.P_COMP_AERO_CLALPHA]
    V_safe = np.maximum(V, MIN_AIRSPEED)
    a_d = alpha - p[L.P_COMP_AERO_SEP_TAU2] * c / V_safe * qp
    x0 = (2.0 * np.sqrt(lift_ratio(cla * np.sin(a_d), np.interp(a_d, tabs[3], tabs[4]))) - 1.0) ** 2
    return np.where(V >= MIN_AIRSPEED, (x0 - xs) * V / (p[L.P_COMP_AERO_SEP_TAU1] * c), 0.0)


def compensator_generalized_force(p: np.ndarray, kin: dict, qd: np.ndarray, v_air: np.ndarray, flaps: np.ndarray, nonlinear: bool, tabs: tuple,
                                  seps: np.ndarray | None = None) -> np.ndarray:
    """Q (5,) of the compensator's strip loads, each applied at its own station (docs/MODEL.md 3.2).

    Per strip: in-plane incidence alpha = atan2(-v.n, v.x_s); CL = s_e (CL0 - CLa a0)/sqrt2 + CLa alpha +
    CLq q_p c/2V + CLde/sqrt2 flap; CM likewise; CD = CD0/2 + CL^2/(pi e AR); lift qS CL normal to the
    in-plane velocity, drag qS CD against the full velocity, section moment qS c CM about -e_r, with
    V and qS = rho V^2 dS / 2 from the in-plane velocity and dS = S/4.  The eight strips are arrays.
    seps (4,), with nonlinear: the panels' separation states; each strip's table CN then moves by
    CLalpha sin(alpha) (F(x) - F0) (docs/MODEL.md 3.1.1).
    """
    As = kin["As"]
    S, span = p[L.P_COMP_AERO_S], p[L.P_COMP_AERO_SPAN]
    c, dS, AR = S / span, 0.25 * S, span * span / S
    cla, cma, a0 = p[L.P_COMP_AERO_CLALPHA], p[L.P_COMP_AERO_CMALPHA], p[L.P_COMP_AERO_ALPHA0]
    offsets, e_r, n, s_e, flap = compensator_strips(p, As, flaps)
    x_s = As[:, 0]
    axes = kin["axes"][:3]  # the rig joints, all through the pivot
    w_s = axes.T @ qd[:3]  # arm angular velocity (world)
    r = As @ np.array([p[L.P_GEOMETRY_COMP_AERO_X], 0.0, 0.0]) + offsets @ As.T  # stations (8, 3), world
    Jv = cross(axes[None, :, :], r[:, None, :])  # (8 strips, 3 joints, 3): a_k x r
    v = np.einsum("sjc,j->sc", Jv, qd[:3]) - v_air  # strip velocity relative to the air
    u, wn = v @ x_s, -np.einsum("sc,sc->s", v, n)
    V = np.hypot(u, wn)
    loaded = V >= MIN_AIRSPEED
    V_safe = np.where(loaded, V, 1.0)
    alpha = np.arctan2(wn, u)
    q_hat = -(e_r @ w_s) * c / (2 * V_safe)
    if nonlinear:
        cl_a = np.interp(alpha, tabs[3], tabs[4])
        if seps is not None:
            cn_att = cla * np.sin(alpha)
            x = np.clip(np.repeat(seps, 2), 0.0, 1.0)
            cl_a = cl_a + cn_att * ((1.0 + np.sqrt(x)) ** 2 / 4.0 - lift_ratio(cn_att, cl_a))
        cm_a = cl_a * cma / cla if cla != 0.0 else cma * alpha
    else:
        cl_a, cm_a = cla * alpha, cma * alpha
    CL = s_e * (p[L.P_COMP_AERO_CL0] - cla * a0) / math.sqrt(2) + cl_a + p[L.P_COMP_AERO_CLQ] * q_hat + p[L.P_COMP_AERO_CLDE] / math.sqrt(2) * flap
    CM = s_e * (p[L.P_COMP_AERO_CM0] - cma * a0) / math.sqrt(2) + cm_a + p[L.P_COMP_AERO_CMQ] * q_hat + p[L.P_COMP_AERO_CMDE] / math.sqrt(2) * flap
    CD = 0.5 * p[L.P_COMP_AERO_CD0] + CL**2 / (math.pi * p[L.P_COMP_AERO_E_OSWALD] * AR)
    qS = np.where(loaded, 0.5 * p[L.P_ENVIRONMENT_AIR_DENSITY] * V * V * dS, 0.0)
    lift = (qS * CL / V_safe)[:, None] * (wn[:, None] * x_s + u[:, None] * n)
    drag = -(qS * CD / np.where(loaded, np.linalg.norm(v, axis=1), 1.0))[:, None] * v
    moment = -(qS * c * CM)[:, None] * e_r
    Q = np.zeros(5)
    Q[:3] = np.einsum("sjc,sc->j", Jv, lift + drag) + axes @ moment.sum(axis=0)
    return Q


def friction_torque(p: np.ndarray, j: int, v: float, z: float) -> tuple[float, float]:
    """(tau_f (N m), dz/dt (rad/s)) of joint j, eqs. (19)-(21)."""
    fs, fc, alpha_f, v_d, s0, s1, s2 = p[FRICTION_BASE[j] : FRICTION_BASE[j] + 7]
    stribeck = fc + (fs - fc) * math.exp(-alpha_f * abs(v))
    zdot = v - s0 * abs(v) * z / stribeck
    return s1 * math.exp(-((v / v_d) ** 2)) * zdot + s0 * z + s2 * v, zdot


def stop_torque(p: np.ndarray, j: int, q: float, v: float) -> float:
    """One-sided spring-damper beyond joint j's limits, only ever pushing back into range (N m)."""
    if j not in STOP_BASE:
        return 0.0
    lo, hi, k, c = p[STOP_BASE[j] : STOP_BASE[j] + 4]
    if q > hi:
        return min(0.0, -k * (q - hi) - c * v)
    if q < lo:
        return max(0.0, -k * (q - lo) - c * v)
    return 0.0


FIXTURE_BASE = (
    L.P_FIXTURE_RIG_ROLL_STIFFNESS, L.P_FIXTURE_RIG_PITCH_STIFFNESS, L.P_FIXTURE_RIG_YAW_STIFFNESS,
    L.P_FIXTURE_MODEL_PITCH_STIFFNESS, L.P_FIXTURE_MODEL_YAW_STIFFNESS,
)  # fmt: skip


def fixture_inertia(p: np.ndarray) -> np.ndarray:
    """(5,) kg m^2: each joint's test-fixture inertia, added to its diagonal entry of M (a flywheel turning
    at the joint's rate; the fixture of the paper's Fig. 4(a), zero in flight)."""
    return np.array([p[b + 2] for b in FIXTURE_BASE])


def fixture_force(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(5,) N m: each joint's test-fixture torque, -stiffness (q_j - neutral) + torque (zero in flight)."""
    return np.array([p[b + 3] - p[b] * (q[j] - p[b + 1]) for j, b in enumerate(FIXTURE_BASE)])


def separation_rate(p: np.ndarray, Aa: np.ndarray, v_rel: np.ndarray, w: np.ndarray, x: float, tabs: tuple) -> float:
    """dx/dt = (x0(alpha - tau2 alphadot) - x) / tau1 of the Hawk's flow-separation state (Goman & Khrabrov 1994;
    tau1, tau2 the parameters times c / V), alphadot = q - v (p u + r w) / (u^2 + w^2) from the velocities."""
    u, v, wz = Aa.T @ v_rel
    V = math.sqrt(u * u + v * v + wz * wz)
    if V < MIN_AIRSPEED:
        return 0.0
    pb, qb, rb = Aa.T @ w
    c = p[L.P_HAWK_AERO_C]
    alpha_dot = qb - v * (pb * u + rb * wz) / (u * u + wz * wz)
    target = separation_static(p, math.atan2(wz, u) - p[L.P_HAWK_AERO_SEP_TAU2] * c / V * alpha_dot, tabs)
    return (target - x) * V / (p[L.P_HAWK_AERO_SEP_TAU1] * c)


def wake_rates(p: np.ndarray, force: np.ndarray, wake: np.ndarray, airspeed: float) -> np.ndarray:
    """d/dt (m/s^2) of the Hawk's wake at the compensator, wake = (sidewash, downwash) (m/s, world y and z), from
    the Hawk's aerodynamic force (N, world): a lag with the convection time d / V towards -(k_y F_y, k_z F_z).
    Written from the derivation (docs/MODEL.md 3.1.2), not from the kernels: the lift's horseshoe vortex of
    semispan s = pi b / 8 gives on its centre line d behind the downwash G (1 + r/d) / (2 pi s), G = L / (2 rho V s),
    r = hypot(d, s); over the compensator's span B a vortex pair far behind averages G / (pi B) ln((B/2 + s) / |B/2 - s|)
    (cores of radius 0.1 s), and the compact side-force pair averages 2 Y / (pi rho V B^2)."""
    d = p[L.P_GEOMETRY_ARM_LENGTH] + p[L.P_GEOMETRY_HAWK_CG_X] - p[L.P_GEOMETRY_COMP_AERO_X]
    V = max(airspeed, MIN_AIRSPEED)
    rho = p[L.P_ENVIRONMENT_AIR_DENSITY]
    s = math.pi * p[L.P_HAWK_AERO_B] / 8.0
    B = p[L.P_COMP_AERO_SPAN]
    rc = 0.1 * s
    circulation_per_newton = 1.0 / (2.0 * rho * V * s)  # G / L
    centre_far = circulation_per_newton / (math.pi * s)  # the pair's centre-line downwash far behind, per newton
    centre_near = circulation_per_newton * (1.0 + math.hypot(d, s) / d) / (2.0 * math.pi * s)
    mean_far = circulation_per_newton / (math.pi * B) * 0.5 * math.log(((B / 2 + s) ** 2 + rc**2) / ((B / 2 - s) ** 2 + rc**2))
    k_z = mean_far * centre_near / centre_far
    k_y = 2.0 / (math.pi * rho * V * B * B)
    f = p[L.P_HAWK_AERO_WAKE_FACTOR]
    target = np.array([-f * k_y * force[1], -f * k_z * force[2]])
    return (target - np.asarray(wake)) * V / d


def rhs(t: float, y: np.ndarray, flaps: np.ndarray, u: np.ndarray, p: np.ndarray, flags: int, free_idx: np.ndarray, tabs: tuple) -> np.ndarray:
    """dy/dt (15,) of y = [q, qd, z] (15,); the arguments of :func:`rig_env.reference.continuous_rhs`.
    With the unsteady model (flags' F_UNSTEADY) y has seven more entries, the flow-separation states x of
    the Hawk and of the compensator's panels (flaps 1-4) and the Hawk's wake at the compensator (sidewash,
    downwash; m/s, world), and dy/dt their rates (:func:`separation_rate`, :func:`compensator_separation_rates`,
    :func:`wake_rates`: the wake's target takes the Hawk's force with alpha-dot from the velocities).

    flaps (7,) servo positions (rad, rig_env.SERVOS order: four flaps after mixing, Hawk elevator,
    aileron, rudder); u (N_INPUTS,) with the Hawk's gust, the airspeed and the compensator's gust (world,
    m/s; the Hawk flies in the tunnel flow plus U_GUST, the compensator's strips in it plus U_GUST_COMP); p (N_PARAMS,);
    flags (layout.F_*); free_idx (n_free,) joint indices; tabs from ``RigParams.tables()``.
    """
    q, qd, z = y[0:5], y[5:10], y[10:15]
    unsteady = bool(flags & L.F_UNSTEADY)
    dy = np.zeros(22 if unsteady else 15)
    kin, bs = bodies(q, qd, p)
    M, h = mass_matrix_and_bias(bs, qd)
    M += np.diag(fixture_inertia(p))
    Q = gravity_force(bs, p) + fixture_force(q, p) - h
    if flags & L.F_AERO:
        nonlinear = bool(flags & L.F_NONLINEAR)
        v_air = np.array([-u[L.U_AIRSPEED], 0.0, 0.0]) + u[L.U_GUST : L.U_GUST + 3]  # the air at the Hawk
        v_air_comp = np.array([-u[L.U_AIRSPEED], 0.0, 0.0]) + u[L.U_GUST_COMP : L.U_GUST_COMP + 3]  # at the compensator
        if unsteady:
            v_air_comp = v_air_comp + np.array([0.0, y[20], y[21]])  # the Hawk's wake
        hawk = bs[2]
        # the Hawk's alpha-dot depends on qdd: its loads are Q0 + Q_ad (g . qdd), moved into M below
        ad0, g = hawk_alpha_dot(kin, hawk, qd, v_air)
        sep = float(y[15]) if unsteady else None
        F, T, dF, dT = hawk_loads(p, kin["Aa"], hawk["Jv"] @ qd - v_air, hawk["Jw"] @ qd, flaps[4], flaps[5], flaps[6], nonlinear, tabs, ad0, sep)
        if unsteady:
            dy[15] = separation_rate(p, kin["Aa"], hawk["Jv"] @ qd - v_air, hawk["Jw"] @ qd, float(y[15]), tabs)
            ub, vb, wb = kin["Aa"].T @ (hawk["Jv"] @ qd - v_air)
            pb, qb, rb = kin["Aa"].T @ (hawk["Jw"] @ qd)
            ad_v = qb - vb * (pb * ub + rb * wb) / (ub * ub + wb * wb) if ub * ub + wb * wb > 0 else 0.0
            F_v = hawk_loads(p, kin["Aa"], hawk["Jv"] @ qd - v_air, hawk["Jw"] @ qd, flaps[4], flaps[5], flaps[6], nonlinear, tabs, ad_v, sep)[0]
            dy[20:22] = wake_rates(p, F_v, y[20:22], float(u[L.U_AIRSPEED]))
        Q += hawk["Jv"].T @ F + hawk["Jw"].T @ T
        M = M - np.outer(hawk["Jv"].T @ dF + hawk["Jw"].T @ dT, g)
        Q += compensator_generalized_force(p, kin, qd, v_air_comp, flaps, nonlinear, tabs, y[16:20] if unsteady else None)
        if unsteady:
            dy[16:20] = compensator_separation_rates(p, kin, qd, v_air_comp, y[16:20], tabs)
    for j in free_idx:
        if flags & L.F_FRICTION:
            tau_f, dy[10 + j] = friction_torque(p, j, qd[j], z[j])
            Q[j] -= tau_f  # eq. (22)
        if flags & L.F_STOPS:
            Q[j] += stop_torque(p, j, q[j], qd[j])
    free = np.asarray(free_idx)
    dy[free] = qd[free]
    dy[5 + free] = np.linalg.solve(M[np.ix_(free, free)], Q[free])
    return dy

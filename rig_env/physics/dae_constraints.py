"""The DAE's constraints (the joints as eqs. 15-18 of AIAA 2009-5727, plus one row per locked joint): values,
Jacobian with respect to the velocities v and the velocity-product terms Jdot v, and their residual.

Constraints (10 + n_locked, besides the two quaternion norms):

    R_a - A_s [l_f 0 0]^T - A_a [hawk_cg_x 0 hawk_cg_z]^T = 0       (15)   rows 0-2
    R_s - A_s [arm_cg_x arm_cg_y arm_cg_z]^T = 0                    (16)   rows 3-5
    R_r - A_s [comp_cg_x comp_cg_y comp_cg_z]^T = 0                 (17)   rows 6-8
    (A_s^T A_a)[2, 1] = z_s . y_a = 0                               (18)   row 9
    one row per locked joint, holding its angle at the stored target:       rows 10...
        rig_roll     e_z . A_s [0, cos phi0, -sin phi0] = cos(theta) sin(phi - phi0)
        rig_pitch    e_z . x_s + sin theta0                = sin theta0 - sin theta
        rig_yaw      [-sin psi0, cos psi0, 0] . x_s        = cos(theta) sin(psi - psi0)
        model_pitch  z_s . x_a + sin theta_a0              = sin theta_a0 - sin theta_a
        model_yaw    A_s [cos psi_a0, sin psi_a0, 0] . y_a = -sin(psi_a - psi_a0)

(x_s = A_s e_x etc.)  J is stored row-major, N_CMAX rows of 15 (velocity columns C_VA ... C_VR of
:mod:`rig_env.physics.dae_layout`); the angular columns are with respect to body-frame virtual rotations.
"""

from __future__ import annotations

import math

from numba import njit

from rig_env.physics import layout as L
from rig_env.physics.dae_layout import AIRCRAFT, ARM, C_VA, C_VR, C_VS, C_WA, C_WS, GROUND, Y_QA, Y_QS, Y_RA, Y_RR, Y_RS, Y_TARGET
from rig_env.physics.dae_rotations import add, body_matrices, col, cross, dot, mtv, mv, scale, sub, vec3, world_rates

_JIT = dict(cache=True, error_model="numpy", _nrt=False)  # allocation-free kernels: no NRT refcounting


# ---------------------------------------------------------------------- constraints
@njit(**_JIT)
def _clear_row(J, r):
    for k in range(15):
        J[r * 15 + k] = 0.0


@njit(**_JIT)
def _put3(J, r, c0, v):
    J[r * 15 + c0] = v[0]
    J[r * 15 + c0 + 1] = v[1]
    J[r * 15 + c0 + 2] = v[2]


@njit(**_JIT)
def _point_rows(J, c, b, r0, cR, pos, lever_s, lever_a, As, Aa, w_s, w_a, use_a):
    """Rows r0..r0+2 of C = R - lever_s - lever_a (world levers fixed in the arm and the aircraft)."""
    for d in range(3):
        _clear_row(J, r0 + d)
        J[(r0 + d) * 15 + cR + d] = 1.0
        c[r0 + d] = pos[d] - lever_s[d] - lever_a[d]
    # -d(lever)/dt = -w x lever = lever x (A omega): column k of the omega block is lever x A e_k
    for k in range(3):
        ck = cross(lever_s, col(As, k))
        for d in range(3):
            J[(r0 + d) * 15 + C_WS + k] = ck[d]
    acc = scale(cross(w_s, cross(w_s, lever_s)), -1.0)
    if use_a:
        for k in range(3):
            ck = cross(lever_a, col(Aa, k))
            for d in range(3):
                J[(r0 + d) * 15 + C_WA + k] = ck[d]
        acc = sub(acc, cross(w_a, cross(w_a, lever_a)))
    for d in range(3):
        b[r0 + d] = acc[d]


@njit(**_JIT)
def _dot_row(J, c, b, r, u, v, body1, body2, A1, A2, w1, w2, c0):
    """Row r of C = u . v + c0, u fixed in body1 (or ground), v in body2.

    Cdot = (w1 - w2) . (u x v); Cddot = J vdot + (w1 - w2) . ((w1 x u) x v + u x (w2 x v)).
    """
    _clear_row(J, r)
    n = cross(u, v)
    if body1 != GROUND:
        g1 = mtv(A1, n)
        _put3(J, r, C_WS if body1 == ARM else C_WA, g1)
    g2 = scale(mtv(A2, n), -1.0)
    _put3(J, r, C_WS if body2 == ARM else C_WA, g2)
    c[r] = dot(u, v) + c0
    b[r] = dot(sub(w1, w2), add(cross(cross(w1, u), v), cross(u, cross(w2, v))))


@njit(**_JIT)
def constraint_system(y, tgt, p, locked, n_locked, J, c, b):
    """Constraint values c (m), Jacobian J (m x 15, w.r.t. v) and Jdot v terms b at state y.

    m = 10 + n_locked; y: coordinates and velocities (first 32 entries); tgt: locked targets (5).
    """
    Aa, As = body_matrices(y)
    return constraints_at(y, Aa, As, tgt, p, locked, n_locked, J, c, b)


@njit(**_JIT)
def constraints_at(y, Aa, As, tgt, p, locked, n_locked, J, c, b):
    """:func:`constraint_system` with the body rotations already computed."""
    w_a, w_s = world_rates(y, Aa, As)
    zero = (0.0, 0.0, 0.0)
    l_f = scale(col(As, 0), p[L.P_GEOMETRY_ARM_LENGTH])
    rho = mv(Aa, (p[L.P_GEOMETRY_HAWK_CG_X], 0.0, p[L.P_GEOMETRY_HAWK_CG_Z]))
    r_s = mv(As, (p[L.P_GEOMETRY_ARM_CG_X], p[L.P_GEOMETRY_ARM_CG_Y], p[L.P_GEOMETRY_ARM_CG_Z]))
    r_r = mv(As, (p[L.P_GEOMETRY_COMP_CG_X], p[L.P_GEOMETRY_COMP_CG_Y], p[L.P_GEOMETRY_COMP_CG_Z]))
    _point_rows(J, c, b, 0, C_VA, vec3(y, Y_RA), l_f, rho, As, Aa, w_s, w_a, True)
    _point_rows(J, c, b, 3, C_VS, vec3(y, Y_RS), r_s, zero, As, Aa, w_s, w_a, False)
    _point_rows(J, c, b, 6, C_VR, vec3(y, Y_RR), r_r, zero, As, Aa, w_s, w_a, False)
    x_s, z_s = col(As, 0), col(As, 2)
    x_a, y_a = col(Aa, 0), col(Aa, 1)
    ez = (0.0, 0.0, 1.0)
    _dot_row(J, c, b, 9, z_s, y_a, ARM, AIRCRAFT, As, Aa, w_s, w_a, 0.0)  # eq. (18)
    for a in range(n_locked):
        j = locked[a]
        r = 10 + a
        t = tgt[j]
        if j == L.J_RIG_ROLL:
            _dot_row(J, c, b, r, ez, mv(As, (0.0, math.cos(t), -math.sin(t))), GROUND, ARM, As, As, zero, w_s, 0.0)
        elif j == L.J_RIG_PITCH:
            _dot_row(J, c, b, r, ez, x_s, GROUND, ARM, As, As, zero, w_s, math.sin(t))
        elif j == L.J_RIG_YAW:
            _dot_row(J, c, b, r, (-math.sin(t), math.cos(t), 0.0), x_s, GROUND, ARM, As, As, zero, w_s, 0.0)
        elif j == L.J_MODEL_PITCH:
            _dot_row(J, c, b, r, z_s, x_a, ARM, AIRCRAFT, As, Aa, w_s, w_a, math.sin(t))
        else:
            _dot_row(J, c, b, r, mv(As, (math.cos(t), math.sin(t), 0.0)), y_a, ARM, AIRCRAFT, As, Aa, w_s, w_a, 0.0)
    return 10 + n_locked



@njit(**_JIT)
def locked_joints(free_idx, n_free, locked):
    """Fill locked[:n] with the joints not in free_idx[:n_free]; returns n."""
    n = 0
    for j in range(5):
        is_free = False
        for a in range(n_free):
            if free_idx[a] == j:
                is_free = True
        if not is_free:
            locked[n] = j
            n += 1
    return n


@njit(**_JIT)
def residual(y, p, locked, n_locked, J, c, b):
    """Max-abs residual of all constraints: the two quaternion norms, eqs. (15)-(18), locked joints.

    J (N_CMAX * 15,), c, b (N_CMAX,): scratch.
    """
    m = constraint_system(y, y[Y_TARGET : Y_TARGET + 5], p, locked, n_locked, J, c, b)
    err = 0.0
    for qb in (Y_QA, Y_QS):
        err = max(err, abs(y[qb] ** 2 + y[qb + 1] ** 2 + y[qb + 2] ** 2 + y[qb + 3] ** 2 - 1.0))
    for r in range(m):
        a = abs(c[r])
        if not a <= err:  # NaN propagates
            err = a
    return err



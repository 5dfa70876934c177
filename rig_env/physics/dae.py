"""The paper's constrained multibody DAE (AIAA 2009-5727, eqs. 1-22), solved in Newton-Euler form.

Bodies a (aircraft), s (arm, its inertia including the compensator's own ``comp_I*``) and r
(compensator, a point mass); 17 coordinates q = (R_a, theta_a, R_s, theta_s, R_r), Euler parameters
theta = (e0, e1, e2, e3), A(theta) body to world.  World axes x upstream, y starboard, z down, the
pivot at the origin, gravity +z.  Constraints (10 + n_locked, besides the two quaternion norms):

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
    (x_s = A_s e_x etc.; joint angles as in joint_space.frames: A_s = Rz(psi) Ry(theta) Rx(phi),
    A_a = A_s Rz(psi_a) Ry(theta_a).)

Equivalence of the structured solve with eq. (1)
------------------------------------------------
With Gb(theta) = [-e, -skew(e) + e0 I] (3x4), the paper's G (omega_body = G thetadot) is 2 Gb, so
m_thth = G^T I G, Q_v = -2 Gdot^T I omega (eq. 11) and a body-frame moment n enters Q_e as G^T n.
For unit theta, Gb Gb^T = I3 and Gb theta = 0, Gbdot thetadot = 0, hence omegadot = G thetaddot.
Premultiplying the Euler-parameter rows of eq. (1) by Gb / 2 (= G / 4) gives

    I omegadot + C_pi^T lambda = n - omega x I omega,        C_pi = C_theta G^T / 4,

i.e. Euler's equations, with C_pi the constraint Jacobian with respect to body-frame virtual
rotations (the ``J`` below); the norm multipliers drop out because C_theta of (13)/(14) is 2 theta^T
and G theta = 0.  The fourth component of thetaddot (along theta) is fixed by the norm constraint,
theta . thetaddot = -|thetadot|^2, which the kinematics thetadot = G^T omega / 4 = Gb^T omega / 2
satisfy identically.  So, with velocities v = (Rdot_a, omega_a, Rdot_s, omega_s, Rdot_r) (15, body
angular velocities) and M = diag(m_a, I_a, m_s, I_s, m_r):

    M vdot + J^T lambda = F,      J vdot = -b   (b = Jdot v, the velocity-product terms)
    (J M^-1 J^T) lambda = J M^-1 F + b,     vdot = M^-1 (F - J^T lambda)

a Schur complement of 10 + n_locked rows solved by Cholesky, exactly eq. (1).
``rig_env.physics.dae_reference`` assembles the literal 17-coordinate system and the tests check
the two agree to round-off.

Integration (per physics step h, as ``integrator.physics_step``): LuGre bristle half step at the
current joint rates; classical RK4 over h on (coordinates, velocities, servo states) with z frozen;
drift control (quaternions renormalised, Gauss-Newton projection of the positions onto C = 0 in the
M^-1 metric until max|C| < 1e-12 -- one update when the residual is already below 1e-10, as the
iteration converges quadratically -- then the mass-orthogonal projection of the velocities onto
J v = 0); bristle half step at the projected joint rates; servo limits.  Drift control comes before
the second bristle half step (the joint-space integrator has nothing to project), so the bristles see
constraint-consistent joint rates; the difference is at the 1e-12 level.  Joint rates come from the
body angular velocities through the dual bases of the joint axes (``joint_rates``).

Cost per physics step: four Schur solves (10 + n_locked rows) and one for the projection.

State row Y[i] (N_DAE = 56):

    ===========  =====  ==========================================================
    Y_RA         0:3    aircraft c.g. position R_a, m (world)
    Y_QA         3:7    aircraft Euler parameters theta_a (e0, e1, e2, e3)
    Y_RS         7:10   arm c.g. position R_s, m
    Y_QS         10:14  arm Euler parameters theta_s
    Y_RR         14:17  compensator c.g. position R_r, m
    Y_VA         17:20  Rdot_a, m/s (world)
    Y_WA         20:23  omega_a, rad/s (aircraft body axes)
    Y_VS         23:26  Rdot_s, m/s
    Y_WS         26:29  omega_s, rad/s (arm body axes)
    Y_VR         29:32  Rdot_r, m/s
    Y_Z          32:37  LuGre bristle deflections, rad (JOINTS order)
    Y_SERVO      37:44  servo positions, rad (SERVOS order)
    Y_SERVO_RATE 44:51  servo rates, rad/s
    Y_TARGET     51:56  locked-joint target angles, rad (JOINTS order; used for locked joints only)
    ===========  =====  ==========================================================
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from rig_env.physics import friction as fr
from rig_env.physics import layout as L
from rig_env.physics import servo as sv
from rig_env.physics.aero import comp_aero, hawk_aero
from rig_env.physics.integrator import push_demands
from rig_env.physics.joint_space import air_velocity, frames, joint_torque, velocities
from rig_env.physics import vec as _vec

_JIT = dict(cache=True, error_model="numpy", _nrt=False)  # allocation-free kernels: no NRT refcounting
_JIT_BATCH = dict(cache=True, error_model="numpy")  # batch drivers that allocate small scratch


def _plain(f):
    """vec.py's helper compiled as an ordinary function: LLVM still inlines it, but numba's IR-level
    ``inline="always"`` over the many call sites here would multiply the cold compile time."""
    return njit(error_model="numpy")(f.py_func)


add, col, cross, dot, mtv, mv, scale, sub = (
    _plain(f) for f in (_vec.add, _vec.col, _vec.cross, _vec.dot, _vec.mtv, _vec.mv, _vec.scale, _vec.sub)
)

# ---- state row layout
Y_RA = 0
Y_QA = 3
Y_RS = 7
Y_QS = 10
Y_RR = 14
N_COORD = 17
Y_V = 17
Y_VA = 17
Y_WA = 20
Y_VS = 23
Y_WS = 26
Y_VR = 29
N_VEL = 15
Y_Z = 32
Y_SERVO = 37
Y_SERVO_RATE = 44
Y_TARGET = 51
N_DAE = 56

# RK state: Y[0:32] (coordinates, velocities) then Y[37:51] (servo positions and rates)
N_RK = 46
N_CMAX = 15  # 10 joint constraints + up to 5 locked joints

# ---- velocity columns (v = Rdot_a, omega_a, Rdot_s, omega_s, Rdot_r)
C_VA, C_WA, C_VS, C_WS, C_VR = 0, 3, 6, 9, 12
GROUND, ARM, AIRCRAFT = 0, 1, 2

# ---- scratch row of one environment
W_Y0 = 0
W_K = 46  # 4 stage derivatives, 4 x 46
W_YT = 230
W_UD = 276
W_J = 283  # constraint Jacobian, N_CMAX x 15, row-major
W_MJ = 508  # M^-1 J^T stored as rows (M^-1 J[r]), N_CMAX x 15
W_SCHUR = 733  # Schur complement J M^-1 J^T and its Cholesky factor (lower), N_CMAX x N_CMAX
W_C = 958  # constraint values
W_B = 973  # velocity-product terms Jdot v
W_F = 988  # applied + gyroscopic forces F (15)
W_LAM = 1003  # multipliers / projection unknowns
W_ACC = 1018  # vdot (15)
W_BACK = 1033  # last good state, N_DAE
N_WORK_DAE = 1089

RK_C = (0.0, 0.5, 0.5, 1.0)
RK_W = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
PROJ_TOL = 1e-12
PROJ_ITERS = 4
PROJ_SKIP_RECHECK = 1e-10  # below this residual one Gauss-Newton update suffices


def new_work_dae(n_envs: int) -> tuple[np.ndarray]:
    """Per-environment scratch for :func:`step_batch_dae`: a 1-tuple holding (n_envs, N_WORK_DAE) floats."""
    return (np.zeros((n_envs, N_WORK_DAE)),)


# ---------------------------------------------------------------------- rotations
@njit(**_JIT)
def quat_matrix(e0, e1, e2, e3):
    """A(theta) (body to world, row-major 9-tuple) of the normalised Euler parameters."""
    s = 1.0 / (e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
    return (
        (e0 * e0 + e1 * e1 - e2 * e2 - e3 * e3) * s,
        2.0 * (e1 * e2 - e0 * e3) * s,
        2.0 * (e1 * e3 + e0 * e2) * s,
        2.0 * (e1 * e2 + e0 * e3) * s,
        (e0 * e0 - e1 * e1 + e2 * e2 - e3 * e3) * s,
        2.0 * (e2 * e3 - e0 * e1) * s,
        2.0 * (e1 * e3 - e0 * e2) * s,
        2.0 * (e2 * e3 + e0 * e1) * s,
        (e0 * e0 - e1 * e1 - e2 * e2 + e3 * e3) * s,
    )


@njit(**_JIT)
def matrix_quat(A):
    """Unit Euler parameters (e0 >= 0 where possible) of a rotation matrix (Shepperd's method)."""
    t = A[0] + A[4] + A[8]
    if t > 0.0:
        s = 2.0 * math.sqrt(t + 1.0)
        e = (0.25 * s, (A[7] - A[5]) / s, (A[2] - A[6]) / s, (A[3] - A[1]) / s)
    elif A[0] > A[4] and A[0] > A[8]:
        s = 2.0 * math.sqrt(1.0 + A[0] - A[4] - A[8])
        e = ((A[7] - A[5]) / s, 0.25 * s, (A[1] + A[3]) / s, (A[2] + A[6]) / s)
    elif A[4] > A[8]:
        s = 2.0 * math.sqrt(1.0 + A[4] - A[0] - A[8])
        e = ((A[2] - A[6]) / s, (A[1] + A[3]) / s, 0.25 * s, (A[5] + A[7]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + A[8] - A[0] - A[4])
        e = ((A[3] - A[1]) / s, (A[2] + A[6]) / s, (A[5] + A[7]) / s, 0.25 * s)
    n = math.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2 + e[3] ** 2)
    return (e[0] / n, e[1] / n, e[2] / n, e[3] / n)


@njit(**_JIT)
def body_matrices(y):
    """(A_a, A_s) of the coordinates in y (first 17 entries)."""
    Aa = quat_matrix(y[Y_QA], y[Y_QA + 1], y[Y_QA + 2], y[Y_QA + 3])
    As = quat_matrix(y[Y_QS], y[Y_QS + 1], y[Y_QS + 2], y[Y_QS + 3])
    return Aa, As


@njit(**_JIT)
def vec3(y, i):
    return (y[i], y[i + 1], y[i + 2])


@njit(**_JIT)
def normalise_quats(y):
    for b in (Y_QA, Y_QS):
        n = math.sqrt(y[b] ** 2 + y[b + 1] ** 2 + y[b + 2] ** 2 + y[b + 3] ** 2)
        for k in range(4):
            y[b + k] /= n


@njit(**_JIT)
def rotate_quat(y, b, d):
    """theta <- normalised(theta + Gb(theta)^T d / 2): a body-frame rotation increment d (rad)."""
    e0, e1, e2, e3 = y[b], y[b + 1], y[b + 2], y[b + 3]
    n0 = e0 - 0.5 * (e1 * d[0] + e2 * d[1] + e3 * d[2])
    n1 = e1 + 0.5 * (e0 * d[0] + e2 * d[2] - e3 * d[1])
    n2 = e2 + 0.5 * (e0 * d[1] + e3 * d[0] - e1 * d[2])
    n3 = e3 + 0.5 * (e0 * d[2] + e1 * d[1] - e2 * d[0])
    n = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
    y[b] = n0 / n
    y[b + 1] = n1 / n
    y[b + 2] = n2 / n
    y[b + 3] = n3 / n


# ---------------------------------------------------------------------- joint coordinates
@njit(**_JIT)
def joint_angles(Aa, As):
    """Joint angles (JOINTS order, principal branches) of the body orientations."""
    roll = math.atan2(As[7], As[8])
    pitch = math.atan2(-As[6], math.sqrt(As[7] * As[7] + As[8] * As[8]))
    yaw = math.atan2(As[3], As[0])
    x_s, y_s, z_s = col(As, 0), col(As, 1), col(As, 2)
    x_a, y_a, z_a = col(Aa, 0), col(Aa, 1), col(Aa, 2)
    mp = math.atan2(-dot(z_s, x_a), dot(z_s, z_a))  # Rel = A_s^T A_a = Rz(psi_a) Ry(theta_a)
    my = math.atan2(-dot(x_s, y_a), dot(y_s, y_a))
    return (roll, pitch, yaw, mp, my)


@njit(**_JIT)
def joint_bases(Aa, As):
    """Dual bases of the joint axes: rig rates qd_j = d_j . w_s (world), model rates via the Gram
    matrix of [a_model_pitch, a_model_yaw] = [y_a, z_s] (g12 = y_a . z_s, zero on the manifold)."""
    x_s = col(As, 0)
    ap = (-x_s[1], x_s[0], 0.0)  # e_z x x_s = cos(theta) Rz e_y
    na = math.sqrt(ap[0] * ap[0] + ap[1] * ap[1])
    ap = (ap[0] / na, ap[1] / na, 0.0)
    ez = (0.0, 0.0, 1.0)
    c1 = cross(ap, ez)
    det = dot(x_s, c1)
    d_roll = scale(c1, 1.0 / det)
    d_pitch = scale(cross(ez, x_s), 1.0 / det)
    d_yaw = scale(cross(x_s, ap), 1.0 / det)
    g12 = dot(col(Aa, 1), col(As, 2))
    return d_roll, d_pitch, d_yaw, g12


@njit(**_JIT)
def joint_rates(Aa, As, w_a, w_s, bases):
    """Joint rates (JOINTS order) of world angular velocities w_a, w_s."""
    d_roll, d_pitch, d_yaw, g12 = bases
    y_a = col(Aa, 1)
    z_s = col(As, 2)
    wr = sub(w_a, w_s)
    r1 = dot(wr, y_a)
    r2 = dot(wr, z_s)
    det2 = 1.0 - g12 * g12
    return (
        dot(d_roll, w_s),
        dot(d_pitch, w_s),
        dot(d_yaw, w_s),
        (r1 - g12 * r2) / det2,
        (r2 - g12 * r1) / det2,
    )


@njit(**_JIT)
def world_rates(y, Aa, As):
    return mv(Aa, vec3(y, Y_WA)), mv(As, vec3(y, Y_WS))


# ---------------------------------------------------------------------- forces
@njit(**_JIT)
def inv_inertias(p):
    """Inverse body inertias (9-tuples, body axes) of the aircraft and of arm + compensator."""
    ixx = p[L.P_MASS_HAWK_IXX]
    izz = p[L.P_MASS_HAWK_IZZ]
    ixz = p[L.P_MASS_HAWK_IXZ]
    d = ixx * izz - ixz * ixz
    ia = (izz / d, 0.0, ixz / d, 0.0, 1.0 / p[L.P_MASS_HAWK_IYY], 0.0, ixz / d, 0.0, ixx / d)
    i_s = (
        1.0 / (p[L.P_MASS_ARM_IXX] + p[L.P_MASS_COMP_IXX]),
        0.0,
        0.0,
        0.0,
        1.0 / (p[L.P_MASS_ARM_IYY] + p[L.P_MASS_COMP_IYY]),
        0.0,
        0.0,
        0.0,
        1.0 / (p[L.P_MASS_ARM_IZZ] + p[L.P_MASS_COMP_IZZ]),
    )
    return ia, i_s


@njit(**_JIT)
def inertias(p):
    """Body inertias (9-tuples, body axes) of the aircraft and of arm + compensator (eq. 10 note)."""
    ixz = p[L.P_MASS_HAWK_IXZ]
    ia = (p[L.P_MASS_HAWK_IXX], 0.0, -ixz, 0.0, p[L.P_MASS_HAWK_IYY], 0.0, -ixz, 0.0, p[L.P_MASS_HAWK_IZZ])
    i_s = (
        p[L.P_MASS_ARM_IXX] + p[L.P_MASS_COMP_IXX],
        0.0,
        0.0,
        0.0,
        p[L.P_MASS_ARM_IYY] + p[L.P_MASS_COMP_IYY],
        0.0,
        0.0,
        0.0,
        p[L.P_MASS_ARM_IZZ] + p[L.P_MASS_COMP_IZZ],
    )
    return ia, i_s


@njit(**_JIT)
def applied_loads(y, z, flaps, u, p, flags, free_idx, n_free, tabs):
    """Applied loads of state y; see :func:`loads_at`."""
    Aa, As = body_matrices(y)
    return loads_at(y, Aa, As, z, flaps, u, p, flags, free_idx, n_free, tabs)


@njit(**_JIT)
def loads_at(y, Aa, As, z, flaps, u, p, flags, free_idx, n_free, tabs):
    """Applied loads (world axes): (f_a, n_a, f_s, n_s, f_r), forces at each c.g. (N), moments (N m).

    Gravity on every body; Hawk aero at its c.g.; compensator aero force at the arm point
    A_s [comp_aero_x 0 0]^T plus its moment, on the arm; friction and stop torques of the free joints
    as equal and opposite torques about the joint axes (dual bases, so that torque . relative angular
    velocity = sum tau_j qd_j).
    """
    g = p[L.P_ENVIRONMENT_GRAVITY]
    w_a, w_s = world_rates(y, Aa, As)
    f_a = (0.0, 0.0, p[L.P_MASS_HAWK_MASS] * g)
    n_a = (0.0, 0.0, 0.0)
    f_s = (0.0, 0.0, p[L.P_MASS_ARM_MASS] * g)
    n_s = (0.0, 0.0, 0.0)
    f_r = (0.0, 0.0, p[L.P_MASS_COMP_MASS] * g)
    if flags & L.F_AERO:
        v_air = air_velocity(u)
        nonlin = (flags & L.F_NONLINEAR) != 0
        fa, ta = hawk_aero(
            p, Aa, vec3(y, Y_VA), w_a, v_air, flaps[4], flaps[5], flaps[6], nonlin, tabs[0], tabs[1], tabs[2]
        )
        f_a = add(f_a, fa)
        n_a = add(n_a, ta)
        lever = sub(scale(col(As, 0), p[L.P_GEOMETRY_COMP_AERO_X]), vec3(y, Y_RS))  # ref point - arm c.g.
        v_ref = add(vec3(y, Y_VS), cross(w_s, lever))
        fc, tc = comp_aero(p, As, v_ref, w_s, v_air, flaps, nonlin, tabs[3], tabs[4])
        f_s = add(f_s, fc)
        n_s = add(n_s, add(cross(lever, fc), tc))
    if flags & (L.F_FRICTION | L.F_STOPS):
        bases = joint_bases(Aa, As)
        qd = joint_rates(Aa, As, w_a, w_s, bases)
        q = joint_angles(Aa, As) if flags & L.F_STOPS else (0.0, 0.0, 0.0, 0.0, 0.0)  # for the stops
        t_rig = (0.0, 0.0, 0.0)
        tau_mp = 0.0
        tau_my = 0.0
        for a in range(n_free):
            j = free_idx[a]
            tau = joint_torque(j, q, qd, z, p, flags)
            if j == L.J_RIG_ROLL:
                t_rig = add(t_rig, scale(bases[0], tau))
            elif j == L.J_RIG_PITCH:
                t_rig = add(t_rig, scale(bases[1], tau))
            elif j == L.J_RIG_YAW:
                t_rig = add(t_rig, scale(bases[2], tau))
            elif j == L.J_MODEL_PITCH:
                tau_mp = tau
            else:
                tau_my = tau
        g12 = bases[3]
        det2 = 1.0 - g12 * g12
        t_m = add(scale(col(Aa, 1), (tau_mp - g12 * tau_my) / det2), scale(col(As, 2), (tau_my - g12 * tau_mp) / det2))
        n_a = add(n_a, t_m)
        n_s = add(n_s, sub(t_rig, t_m))
    return f_a, n_a, f_s, n_s, f_r


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


# ---------------------------------------------------------------------- Schur complement
@njit(**_JIT)
def _minv(src, s0, dst, d0, ima, ims, ma, ms, mr):
    """dst[d0:d0+15] = M^-1 src[s0:s0+15] (block diagonal, body-frame inertias; ma, ms, mr inverse masses)."""
    a0, a1, a2 = src[s0 + C_WA], src[s0 + C_WA + 1], src[s0 + C_WA + 2]
    b0, b1, b2 = src[s0 + C_WS], src[s0 + C_WS + 1], src[s0 + C_WS + 2]
    for d in range(3):
        dst[d0 + C_VA + d] = src[s0 + C_VA + d] * ma
        dst[d0 + C_VS + d] = src[s0 + C_VS + d] * ms
        dst[d0 + C_VR + d] = src[s0 + C_VR + d] * mr
    for d in range(3):
        dst[d0 + C_WA + d] = ima[3 * d] * a0 + ima[3 * d + 1] * a1 + ima[3 * d + 2] * a2
        dst[d0 + C_WS + d] = ims[3 * d] * b0 + ims[3 * d + 1] * b1 + ims[3 * d + 2] * b2


@njit(**_JIT)
def _factor(J, MJ, S, m, ima, ims, ma, ms, mr):
    """MJ rows = M^-1 J[r]; S = J M^-1 J^T (m x m), Cholesky-factored in place (lower triangle).

    ma, ms, mr: inverse masses.  The diagonal of the factor holds the reciprocal pivots.
    """
    for r in range(m):
        _minv(J, r * 15, MJ, r * 15, ima, ims, ma, ms, mr)
    # The translational columns of J are the identity in rows 0-8 (eqs. 15-17) and zero elsewhere, so
    # they add 1/m on the diagonal of those rows only; the rest comes from the two rotation blocks.
    inv_m = (ma, ms, mr)
    for r in range(m):
        ra = r * 15 + C_WA
        rs = r * 15 + C_WS
        for q in range(r + 1):
            qa = q * 15 + C_WA
            qs = q * 15 + C_WS
            s = (
                J[ra] * MJ[qa] + J[ra + 1] * MJ[qa + 1] + J[ra + 2] * MJ[qa + 2]
                + J[rs] * MJ[qs] + J[rs + 1] * MJ[qs + 1] + J[rs + 2] * MJ[qs + 2]
            )
            if q == r and r < 9:
                s += inv_m[r // 3]
            S[r * N_CMAX + q] = s
    for a in range(m):
        s = S[a * N_CMAX + a]
        for q in range(a):
            s -= S[a * N_CMAX + q] ** 2
        d = 1.0 / math.sqrt(s) if s > 0.0 else np.nan
        S[a * N_CMAX + a] = d
        for r in range(a + 1, m):
            t = S[r * N_CMAX + a]
            for q in range(a):
                t -= S[r * N_CMAX + q] * S[a * N_CMAX + q]
            S[r * N_CMAX + a] = t * d


@njit(**_JIT)
def _chol_solve(S, m, x):
    """x <- S^-1 x with S's Cholesky factor (lower, in place)."""
    for a in range(m):
        t = x[a]
        for q in range(a):
            t -= S[a * N_CMAX + q] * x[q]
        x[a] = t * S[a * N_CMAX + a]
    for a in range(m - 1, -1, -1):
        t = x[a]
        for q in range(a + 1, m):
            t -= S[q * N_CMAX + a] * x[q]
        x[a] = t * S[a * N_CMAX + a]


@njit(**_JIT)
def accelerations(y, tgt, z, flaps, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w):
    """vdot (15) of the DAE into w[W_ACC:W_ACC+15] by the Schur complement of the module docstring.

    y: coordinates and velocities in its first 32 entries; tgt: locked targets (5); z: bristle states
    (5); flaps: 7 surface deflections, rad; locked[:n_locked]: locked joints.  Returns the applied
    loads (world axes) (f_a, n_a, f_s, n_s, f_r).
    """
    J = w[W_J : W_J + N_CMAX * 15]
    MJ = w[W_MJ : W_MJ + N_CMAX * 15]
    S = w[W_SCHUR : W_SCHUR + N_CMAX * N_CMAX]
    c = w[W_C : W_C + N_CMAX]
    b = w[W_B : W_B + N_CMAX]
    F = w[W_F : W_F + 15]
    lam = w[W_LAM : W_LAM + N_CMAX]
    acc = w[W_ACC : W_ACC + 15]
    Aa, As = body_matrices(y)
    loads = loads_at(y, Aa, As, z, flaps, u, p, flags, free_idx, n_free, tabs)
    f_a, n_a, f_s, n_s, f_r = loads
    Ia, Is = inertias(p)
    ima, ims = inv_inertias(p)
    ma = 1.0 / p[L.P_MASS_HAWK_MASS]
    ms = 1.0 / p[L.P_MASS_ARM_MASS]
    mr = 1.0 / p[L.P_MASS_COMP_MASS]
    om_a = vec3(y, Y_WA)
    om_s = vec3(y, Y_WS)
    t_a = sub(mtv(Aa, n_a), cross(om_a, mv(Ia, om_a)))
    t_s = sub(mtv(As, n_s), cross(om_s, mv(Is, om_s)))
    for d in range(3):
        F[C_VA + d] = f_a[d]
        F[C_WA + d] = t_a[d]
        F[C_VS + d] = f_s[d]
        F[C_WS + d] = t_s[d]
        F[C_VR + d] = f_r[d]
    m = constraints_at(y, Aa, As, tgt, p, locked, n_locked, J, c, b)
    _factor(J, MJ, S, m, ima, ims, ma, ms, mr)
    _minv(F, 0, acc, 0, ima, ims, ma, ms, mr)
    for r in range(m):
        s = b[r]
        for k in range(15):
            s += MJ[r * 15 + k] * F[k]
        lam[r] = s
    _chol_solve(S, m, lam)
    for r in range(m):
        for k in range(15):
            acc[k] -= lam[r] * MJ[r * 15 + k]
    return loads


# ---------------------------------------------------------------------- integration
@njit(**_JIT)
def rhs_dae(yr, tgt, z, ud, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w, out):
    """Time derivative of the RK state yr (46,) into out (46,)."""
    if flags & L.F_SERVO:
        flaps = yr[32:39]
    else:
        flaps = ud
    accelerations(yr, tgt, z, flaps, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w)
    acc = w[W_ACC : W_ACC + 15]
    for d in range(3):
        out[Y_RA + d] = yr[Y_VA + d]
        out[Y_RS + d] = yr[Y_VS + d]
        out[Y_RR + d] = yr[Y_VR + d]
    for qb, wb in ((Y_QA, Y_WA), (Y_QS, Y_WS)):
        e0, e1, e2, e3 = yr[qb], yr[qb + 1], yr[qb + 2], yr[qb + 3]
        o0, o1, o2 = yr[wb], yr[wb + 1], yr[wb + 2]
        # thetadot = Gb^T omega / 2 = theta (x) (0, omega) / 2
        out[qb] = -0.5 * (e1 * o0 + e2 * o1 + e3 * o2)
        out[qb + 1] = 0.5 * (e0 * o0 + e2 * o2 - e3 * o1)
        out[qb + 2] = 0.5 * (e0 * o1 + e3 * o0 - e1 * o2)
        out[qb + 3] = 0.5 * (e0 * o2 + e1 * o1 - e2 * o0)
    for k in range(15):
        out[Y_V + k] = acc[k]
    sv.derivatives(yr, 32, 39, ud, p, flags, out, 32, 39)


@njit(**_JIT)
def project(y, tgt, p, locked, n_locked, w):
    """Drift control: positions onto C = 0 (Gauss-Newton in the M^-1 metric, quaternions renormalised,
    until max|C| < PROJ_TOL or PROJ_ITERS iterations), then velocities onto J v = 0 (mass-orthogonal).

    y: state with coordinates and velocities in its first 32 entries (in place).  Returns max|C|
    before the last position update.
    """
    J = w[W_J : W_J + N_CMAX * 15]
    MJ = w[W_MJ : W_MJ + N_CMAX * 15]
    S = w[W_SCHUR : W_SCHUR + N_CMAX * N_CMAX]
    c = w[W_C : W_C + N_CMAX]
    b = w[W_B : W_B + N_CMAX]
    lam = w[W_LAM : W_LAM + N_CMAX]
    dx = w[W_ACC : W_ACC + 15]
    ima, ims = inv_inertias(p)
    ma = 1.0 / p[L.P_MASS_HAWK_MASS]
    ms = 1.0 / p[L.P_MASS_ARM_MASS]
    mr = 1.0 / p[L.P_MASS_COMP_MASS]
    normalise_quats(y)
    err = 0.0
    m = 10 + n_locked
    for it in range(PROJ_ITERS):
        m = constraint_system(y, tgt, p, locked, n_locked, J, c, b)
        _factor(J, MJ, S, m, ima, ims, ma, ms, mr)
        err = 0.0
        for r in range(m):
            err = max(err, abs(c[r]))
        if not err > PROJ_TOL:  # converged (NaN also stops here and is caught by the caller's check)
            break
        for r in range(m):
            lam[r] = c[r]
        _chol_solve(S, m, lam)
        for k in range(15):
            s = 0.0
            for r in range(m):
                s -= lam[r] * MJ[r * 15 + k]
            dx[k] = s
        for d in range(3):
            y[Y_RA + d] += dx[C_VA + d]
            y[Y_RS + d] += dx[C_VS + d]
            y[Y_RR + d] += dx[C_VR + d]
        rotate_quat(y, Y_QA, (dx[C_WA], dx[C_WA + 1], dx[C_WA + 2]))
        rotate_quat(y, Y_QS, (dx[C_WS], dx[C_WS + 1], dx[C_WS + 2]))
        if err < PROJ_SKIP_RECHECK:
            # Gauss-Newton converges quadratically: the residual left is O(err^2), far below
            # PROJ_TOL, so the factor at the pre-update positions serves the velocity projection.
            break
    # velocities: v <- v - M^-1 J^T (J M^-1 J^T)^-1 J v, with J and its factor at the final positions
    for r in range(m):
        s = 0.0
        for k in range(15):
            s += J[r * 15 + k] * y[Y_V + k]
        lam[r] = s
    _chol_solve(S, m, lam)
    for r in range(m):
        for k in range(15):
            y[Y_V + k] -= lam[r] * MJ[r * 15 + k]
    return err


@njit(**_JIT)
def current_joint_rates(y):
    Aa, As = body_matrices(y)
    w_a, w_s = world_rates(y, Aa, As)
    return joint_rates(Aa, As, w_a, w_s, joint_bases(Aa, As))


@njit(**_JIT)
def physics_step_dae(y, ud, u, p, flags, free_idx, n_free, locked, n_locked, tabs, h, w):
    """Advance one environment's DAE state y (N_DAE,) by one physics step h (in place)."""
    z = y[Y_Z : Y_Z + 5]
    tgt = y[Y_TARGET : Y_TARGET + 5]
    if flags & L.F_FRICTION:
        qd = current_joint_rates(y)
        for a in range(n_free):
            j = free_idx[a]
            z[j] = fr.advance_bristle(p, j, qd[j], z[j], 0.5 * h)
    y0 = w[W_Y0 : W_Y0 + N_RK]
    yt = w[W_YT : W_YT + N_RK]
    for i in range(32):
        y0[i] = y[i]
    for i in range(14):
        y0[32 + i] = y[Y_SERVO + i]
    for s in range(4):
        k = w[W_K + s * N_RK : W_K + (s + 1) * N_RK]
        if s == 0:
            rhs_dae(y0, tgt, z, ud, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w, k)
        else:
            kp = w[W_K + (s - 1) * N_RK : W_K + s * N_RK]
            c = RK_C[s] * h
            for i in range(N_RK):
                yt[i] = y0[i] + c * kp[i]
            rhs_dae(yt, tgt, z, ud, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w, k)
    for i in range(N_RK):
        acc = 0.0
        for s in range(4):
            acc += RK_W[s] * w[W_K + s * N_RK + i]
        y0[i] += h * acc
    for i in range(32):
        y[i] = y0[i]
    for i in range(14):
        y[Y_SERVO + i] = y0[32 + i]
    project(y, tgt, p, locked, n_locked, w)
    if flags & L.F_FRICTION:
        qd = current_joint_rates(y)
        for a in range(n_free):
            j = free_idx[a]
            z[j] = fr.advance_bristle(p, j, qd[j], z[j], 0.5 * h)
    for k in range(7):
        if flags & L.F_SERVO:
            xs, vs = sv.project(p, k, y[Y_SERVO + k], y[Y_SERVO_RATE + k])
            y[Y_SERVO + k] = xs
            y[Y_SERVO_RATE + k] = vs
        else:
            y[Y_SERVO + k] = ud[k]
            y[Y_SERVO_RATE + k] = 0.0


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


@njit(**_JIT)
def check_dae(y, p, locked, n_locked, w):
    """Status of one environment after a control step (layout.S_*)."""
    for i in range(N_DAE):
        if not np.isfinite(y[i]):
            return L.S_NONFINITE
    err = residual(y, p, locked, n_locked, w[W_J : W_J + N_CMAX * 15], w[W_C : W_C + N_CMAX], w[W_B : W_B + N_CMAX])
    if not err <= L.CONSTRAINT_LIMIT:
        return L.S_CONSTRAINT
    qd = current_joint_rates(y)
    for j in range(5):
        if abs(qd[j]) > L.RUNAWAY_RATE:
            return L.S_RUNAWAY
    return L.S_OK


@njit(**_JIT)
def advance_env_dae(y, w, p, u, db, d_comp, d_hawk, k0, flags, free_idx, n_free, locked, n_locked, tabs, h, n_sub):
    """One environment over one control step of the DAE; returns its status (y restored on failure)."""
    n_buf = db.shape[0]
    ud = w[W_UD : W_UD + 7]
    backup = w[W_BACK : W_BACK + N_DAE]
    for k in range(N_DAE):
        backup[k] = y[k]
    for s in range(n_sub):
        k = k0 + s
        push_demands(db, k % n_buf, u, p)
        for a in range(7):
            d = d_comp if a < 4 else d_hawk
            ud[a] = db[(k - d) % n_buf, a]
        physics_step_dae(y, ud, u, p, flags, free_idx, n_free, locked, n_locked, tabs, h, w)
    st = check_dae(y, p, locked, n_locked, w)
    if st != L.S_OK:
        for k in range(N_DAE):
            y[k] = backup[k]
    return st


@njit(**_JIT)
def advance_slot_dae(i, Y, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, locked, n_locked, tabs, h, n_sub, status, W):
    """Environment i of the batch over one control step: skipped when flagged, flagged when it fails."""
    if status[i] == L.S_OK:
        st = advance_env_dae(
            Y[i], W[i], P[i], U[i], dbuf[i], delay_steps[i, 0], delay_steps[i, 1],
            k0, flags, free_idx, n_free, locked, n_locked, tabs, h, n_sub,
        )  # fmt: skip
        if st != L.S_OK:
            status[i] = st


@njit(parallel=True, **_JIT_BATCH)
def step_batch_dae(Y, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, W):
    """Advance all environments by one control step of n_sub physics steps of the DAE, in parallel.

    Arguments as ``integrator.step_batch`` with Y: (n, N_DAE) DAE states (in place) and W the scratch
    of :func:`new_work_dae`.  An environment whose state turns non-finite, whose constraint residual
    exceeds layout.CONSTRAINT_LIMIT or whose joint rates exceed layout.RUNAWAY_RATE is frozen at its
    last good state and flagged in status.
    """
    locked = np.empty(5, np.int64)
    n_locked = locked_joints(free_idx, n_free, locked)
    for i in prange(Y.shape[0]):
        advance_slot_dae(i, Y, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, locked, n_locked, tabs, h, n_sub, status, W)


@njit(**_JIT_BATCH)
def step_serial_dae(Y, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, tabs, h, n_sub, status, W):
    """Serial twin of step_batch_dae for small batches (see integrator.PARALLEL_MIN_ENVS); a separate
    function so that the two have separate numba cache entries (see integrator.step_serial)."""
    locked = np.empty(5, np.int64)
    n_locked = locked_joints(free_idx, n_free, locked)
    for i in range(Y.shape[0]):
        advance_slot_dae(i, Y, dbuf, k0, delay_steps, P, U, flags, free_idx, n_free, locked, n_locked, tabs, h, n_sub, status, W)

@njit(**_JIT_BATCH)
def constraint_residual_batch(Y, P, free_idx, n_free, out):
    """Max-abs constraint residual (all 12 paper constraints + locked joints) per environment into out (n,)."""
    locked = np.empty(5, np.int64)
    n_locked = locked_joints(free_idx, n_free, locked)
    s = np.empty(N_CMAX * 17)
    for i in range(Y.shape[0]):
        out[i] = residual(Y[i], P[i], locked, n_locked, s[: N_CMAX * 15], s[N_CMAX * 15 : N_CMAX * 16], s[N_CMAX * 16 :])


# ---------------------------------------------------------------------- conversions
@njit(**_JIT_BATCH)
def from_joint_state(X, P, Y):
    """Fill Y (n, N_DAE) from joint-space states X (n, layout.N_STATE); locked targets = X's angles."""
    for i in range(X.shape[0]):
        x = X[i]
        y = Y[i]
        p = P[i]
        q = x[L.X_Q : L.X_Q + 5]
        qd = x[L.X_QD : L.X_QD + 5]
        As, Aa, axes, G, rho, r_s, r_r, r_ref = frames(q, p)
        w_s, w_a, b_s, b_a = velocities(axes, qd)
        ea = matrix_quat(Aa)
        es = matrix_quat(As)
        R_a = add(G, rho)
        v_a = add(cross(w_s, G), cross(w_a, rho))
        om_a = mtv(Aa, w_a)
        om_s = mtv(As, w_s)
        v_s = cross(w_s, r_s)
        v_r = cross(w_s, r_r)
        for d in range(3):
            y[Y_RA + d] = R_a[d]
            y[Y_RS + d] = r_s[d]
            y[Y_RR + d] = r_r[d]
            y[Y_VA + d] = v_a[d]
            y[Y_WA + d] = om_a[d]
            y[Y_VS + d] = v_s[d]
            y[Y_WS + d] = om_s[d]
            y[Y_VR + d] = v_r[d]
        for k in range(4):
            y[Y_QA + k] = ea[k]
            y[Y_QS + k] = es[k]
        for j in range(5):
            y[Y_Z + j] = x[L.X_Z + j]
            y[Y_TARGET + j] = q[j]
        for k in range(14):
            y[Y_SERVO + k] = x[L.X_SERVO + k]


@njit(**_JIT_BATCH)
def _nearest(a, ref):
    """a + 2 pi k closest to ref."""
    return a + 2.0 * math.pi * math.floor((ref - a) / (2.0 * math.pi) + 0.5)


@njit(**_JIT_BATCH)
def to_joint_state(Y, P, X):
    """Joint angles, rates, bristle and servo states of Y into X (n, layout.N_STATE), in place.

    X holds the previous joint state on entry: rig_roll, rig_yaw, model_pitch and model_yaw take the
    2 pi branch nearest their previous value (so unlimited joints keep counting turns); rig_pitch is
    the principal value in [-pi/2, pi/2].
    """
    for i in range(Y.shape[0]):
        y = Y[i]
        x = X[i]
        Aa, As = body_matrices(y)
        w_a, w_s = world_rates(y, Aa, As)
        q = joint_angles(Aa, As)
        qd = joint_rates(Aa, As, w_a, w_s, joint_bases(Aa, As))
        for j in range(5):
            x[L.X_Q + j] = q[j] if j == L.J_RIG_PITCH else _nearest(q[j], x[L.X_Q + j])
            x[L.X_QD + j] = qd[j]
            x[L.X_Z + j] = y[Y_Z + j]
        for k in range(14):
            x[L.X_SERVO + k] = y[Y_SERVO + k]


@njit(**_JIT_BATCH)
def energy_batch_dae(Y, P, out):
    """Kinetic + gravitational energy (J) of every environment into out (n,), zero potential at the pivot."""
    for i in range(Y.shape[0]):
        y = Y[i]
        p = P[i]
        Ia, Is = inertias(p)
        om_a = vec3(y, Y_WA)
        om_s = vec3(y, Y_WS)
        ma = p[L.P_MASS_HAWK_MASS]
        ms = p[L.P_MASS_ARM_MASS]
        mr = p[L.P_MASS_COMP_MASS]
        t = 0.5 * (
            ma * dot(vec3(y, Y_VA), vec3(y, Y_VA))
            + ms * dot(vec3(y, Y_VS), vec3(y, Y_VS))
            + mr * dot(vec3(y, Y_VR), vec3(y, Y_VR))
            + dot(om_a, mv(Ia, om_a))
            + dot(om_s, mv(Is, om_s))
        )
        g = p[L.P_ENVIRONMENT_GRAVITY]
        out[i] = t - g * (ma * y[Y_RA + 2] + ms * y[Y_RS + 2] + mr * y[Y_RR + 2])


@njit(**_JIT_BATCH)
def accelerations_batch(Y, U, P, flags, free_idx, n_free, tabs, ACC, LOADS):
    """Test helper: vdot (n, 15) and applied loads (n, 15: f_a, n_a, f_s, n_s, f_r, world) of states Y.

    Flaps are the servo positions stored in Y.
    """
    locked = np.empty(5, np.int64)
    n_locked = locked_joints(free_idx, n_free, locked)
    w = np.zeros(N_WORK_DAE)
    for i in range(Y.shape[0]):
        y = Y[i]
        loads = accelerations(
            y, y[Y_TARGET : Y_TARGET + 5], y[Y_Z : Y_Z + 5], y[Y_SERVO : Y_SERVO + 7], U[i], P[i], flags,
            free_idx, n_free, locked, n_locked, tabs, w,
        )
        for k in range(15):
            ACC[i, k] = w[W_ACC + k]
        for b in range(5):
            for d in range(3):
                LOADS[i, 3 * b + d] = loads[b][d]

"""Joint-space equations of motion of the rig, derived from the same three bodies as the paper's DAE.

Bodies (paper Sec. II): aircraft a (mass m_a, inertia I_a at its c.g.), arm s (m_s, I_s at its c.g.,
with the compensator's own inertia I_r added: eq. 10 note), compensator r (point mass m_r at its
c.g.).  Joint angles q in rig_env.JOINTS order (rig_roll phi, rig_pitch theta, rig_yaw psi,
model_pitch theta_a, model_yaw psi_a); world axes x upstream, y starboard, z down, origin at the pivot.

    A_s = Rz(psi) Ry(theta) Rx(phi)                        arm (3-DOF gimbal, yaw outermost)
    A_a = A_s Rz(psi_a) Ry(theta_a)                        aircraft; (A_s^T A_a)(3,2) = 0 is eq. (18)
    R_s = A_s l_cgs,  R_r = A_s l_r,  R_a = A_s [l_f 0 0]^T + A_a l_cga         eqs. (15)-(17)

Every body velocity is J(q) qdot and every acceleration J qddot + b(q, qdot) with b the velocity-product
("bias") terms of the joint axes turning with the chain.  Substituting into the Newton-Euler equations
of the bodies and projecting onto the joint directions (the null space of the paper's constraint
Jacobian) gives

    M(q) qddot = Q(q, qdot, t) - h(q, qdot),
    M = sum m J_v^T J_v + J_w^T (A I A^T) J_w,  h = sum m J_v^T b_v + J_w^T (I_w b_w + w x I_w w),

with Q the generalised gravity, aerodynamic, friction and stop torques.  Locked joints keep their
angle and the equations are solved for the free subset only.

A wind-off test fixture (the paper's Sec. IV, Fig. 4(a): springs and masses on one joint;
``fixture.<joint>.*``, :class:`rig_env.params.Fixture`) adds -k (q_j - neutral) + torque to Q_j and its
inertia to M_jj; with the default zero fixture both terms are exact zeros.

The kernels evaluate M, h and Q with every vector in the arm's axes (:func:`arm_kinematics`): each
entry is a dot product of joint axes with inertias, forces and torques, the same in any axes, and in
the arm's the arm-fixed points and the arm's inertia about the pivot are constants and two joint axes
are unit vectors, so A_s itself is never formed (the lane kernel's RK-stage pass: 3,723 instructions
against 4,182 in world axes; 3,514 with the compensator's strips in panel axes, ``benchmarks/RESULTS.md``).  :func:`frames` and :func:`velocities` keep the
world-axes kinematics for the DAE, the drawings and the tests.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from rig_env.physics import friction as fr
from rig_env.physics import layout as L
from rig_env.physics import vmath
from rig_env.physics.aero import (
    MIN_AIRSPEED, comp_aero_arm, comp_separation_rates, comp_separation_relax, comp_separation_targets, hawk_aero_full, hawk_flow,
    separation_relax, separation_target, wake_rates, wake_relax, wake_targets,
)  # fmt: skip
from rig_env.physics.llvm_inline import inlined
from rig_env.physics.vec import FASTMATH, add, col, cross, dot, inertia_world, mm, mtv, mv, rot_zy, rot_zyx, scale, sub

_JIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=False)
ATTACHED = (1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0)
"""The aerodynamic states (layout.X_SEP .. + N_AERO) of a model without them: attached flow on the Hawk and
flaps 1-4, no wake at the compensator."""
_ZERO3 = (0.0, 0.0, 0.0)
# the right-hand side's parts are inlined into their callers by LLVM (rig_env.physics.llvm_inline): as separate
# functions they would exchange their tuples through memory and be optimised apart (about 1.3x per env-step)

STOP_BASE = (-1, L.P_STOPS_RIG_PITCH_LOWER_DEG, L.P_STOPS_RIG_YAW_LOWER_DEG, L.P_STOPS_MODEL_PITCH_LOWER_DEG, -1)


@njit(**_JIT)
def pitch_axis(psi):
    """Rig-pitch axis (world): Rz(psi) e_y."""
    s, c = vmath.sincos(psi)
    return (-s, c, 0.0)


@inlined(**_JIT)
def frames(q, p):
    """Rotations, joint axes (world) and body points (world, from the pivot) at joint angles q."""
    As = rot_zyx(q[L.J_RIG_YAW], q[L.J_RIG_PITCH], q[L.J_RIG_ROLL])
    Aa = mm(As, rot_zy(q[L.J_MODEL_YAW], q[L.J_MODEL_PITCH]))
    # JOINTS order
    axes = (col(As, 0), pitch_axis(q[L.J_RIG_YAW]), (0.0, 0.0, 1.0), col(Aa, 1), col(As, 2))
    G = scale(col(As, 0), p[L.P_GEOMETRY_ARM_LENGTH])
    rho = mv(Aa, (p[L.P_GEOMETRY_HAWK_CG_X], 0.0, p[L.P_GEOMETRY_HAWK_CG_Z]))
    r_s = mv(As, (p[L.P_GEOMETRY_ARM_CG_X], p[L.P_GEOMETRY_ARM_CG_Y], p[L.P_GEOMETRY_ARM_CG_Z]))
    r_r = mv(As, (p[L.P_GEOMETRY_COMP_CG_X], p[L.P_GEOMETRY_COMP_CG_Y], p[L.P_GEOMETRY_COMP_CG_Z]))
    r_ref = scale(col(As, 0), p[L.P_GEOMETRY_COMP_AERO_X])
    return As, Aa, axes, G, rho, r_s, r_r, r_ref


@inlined(**_JIT)
def velocities(axes, qd):
    """Arm and aircraft angular velocities (world) and their bias accelerations (J-dot qdot)."""
    a_roll, a_pitch, a_yaw, a_mp, a_my = axes[0], axes[1], axes[2], axes[3], axes[4]
    w_yaw = scale(a_yaw, qd[L.J_RIG_YAW])
    w_yp = add(w_yaw, scale(a_pitch, qd[L.J_RIG_PITCH]))
    w_s = add(w_yp, scale(a_roll, qd[L.J_RIG_ROLL]))
    w_sy = add(w_s, scale(a_my, qd[L.J_MODEL_YAW]))
    w_a = add(w_sy, scale(a_mp, qd[L.J_MODEL_PITCH]))
    # each axis turns with the bodies outboard of it: d(axis)/dt = (angular velocity before it) x axis
    b_s = add(scale(cross(w_yaw, a_pitch), qd[L.J_RIG_PITCH]), scale(cross(w_yp, a_roll), qd[L.J_RIG_ROLL]))
    b_a = add(b_s, add(scale(cross(w_s, a_my), qd[L.J_MODEL_YAW]), scale(cross(w_sy, a_mp), qd[L.J_MODEL_PITCH])))
    return w_s, w_a, b_s, b_a


@njit(**_JIT)
def point_bias(b, w, r):
    """Bias acceleration of a point at r (from the rotation centre): b x r + w x (w x r)."""
    return add(cross(b, r), cross(w, cross(w, r)))


@njit(**_JIT)
def point_inertia(m, r):
    """m (|r|^2 E - r r^T): inertia of a point mass m at r about the origin (9-tuple)."""
    rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    return (
        m * (rr - r[0] * r[0]), -m * r[0] * r[1], -m * r[0] * r[2],
        -m * r[1] * r[0], m * (rr - r[1] * r[1]), -m * r[1] * r[2],
        -m * r[2] * r[0], -m * r[2] * r[1], m * (rr - r[2] * r[2]),
    )  # fmt: skip


@njit(**_JIT)
def madd(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3], a[4] + b[4], a[5] + b[5], a[6] + b[6], a[7] + b[7], a[8] + b[8])


@inlined(**_JIT)
def arm_kinematics(q, qd, p):
    """The kinematics of the right-hand side in arm axes (components along A_s's columns).

    Every term of M, h and Q is a dot product of a joint axis with a force, torque or inertia times an
    axis, and such products do not depend on the axes the vectors are written in.  Written in the arm's
    axes, the arm's inertia about the pivot and the arm-fixed points (G, the c.g.s, the compensator's
    reference point) are constants of the parameters, the rig-roll and model-yaw axes are unit vectors
    and the rig-pitch and model-pitch axes have a zero component, so the world rotation A_s drops out of
    the mass matrix and the bias (rig yaw psi only turns the air velocity, :func:`forces`):

        a_roll = e_x,  a_pitch = Rx(phi)^T e_y = (0, c phi, -s phi),  a_yaw = A_s^T e_z = (-s theta, c theta s phi, c theta c phi),
        a_model_pitch = B e_y = (-s psi_a, c psi_a, 0),  a_model_yaw = e_z,  with B = Rz(psi_a) Ry(theta_a) = A_s^T A_a.

    The angular velocities and the bias accelerations (J-dot qdot) are :func:`velocities`' sums, each cross
    product with a unit or zero-component axis written out.  World z (down, gravity's direction) is a_yaw.

    Returns (B, (c phi, s phi), a_yaw, (s psi_a, c psi_a), rho, w_s, w_a, b_s, b_a, (c theta, s theta)), rho the
    Hawk c.g. from the model gimbal.
    """
    sf, cf = vmath.sincos(q[L.J_RIG_ROLL])
    st, ct = vmath.sincos(q[L.J_RIG_PITCH])
    B = rot_zy(q[L.J_MODEL_YAW], q[L.J_MODEL_PITCH])
    sz = -B[1]  # rot_zy: (cz cy, -sz, cz sy, sz cy, cz, sz sy, -sy, 0, cy)
    cz = B[4]
    a2 = (-st, ct * sf, ct * cf)
    q0, q1, q2, q3, q4 = qd[L.J_RIG_ROLL], qd[L.J_RIG_PITCH], qd[L.J_RIG_YAW], qd[L.J_MODEL_PITCH], qd[L.J_MODEL_YAW]
    w_yaw = (a2[0] * q2, a2[1] * q2, a2[2] * q2)
    w_yp = (w_yaw[0], w_yaw[1] + cf * q1, w_yaw[2] - sf * q1)
    w_s = (w_yp[0] + q0, w_yp[1], w_yp[2])
    w_sy = (w_s[0], w_s[1], w_s[2] + q4)
    w_a = (w_sy[0] - sz * q3, w_sy[1] + cz * q3, w_sy[2])
    # each axis turns with the bodies inboard of it: d(axis)/dt = (angular velocity before it) x axis
    # w_yaw x a_pitch, w_yp x e_x, w_s x e_z, w_sy x a_model_pitch:
    b_s = (
        (-w_yaw[1] * sf - w_yaw[2] * cf) * q1,
        w_yaw[0] * sf * q1 + w_yp[2] * q0,
        w_yaw[0] * cf * q1 - w_yp[1] * q0,
    )
    b_a = (
        b_s[0] + w_s[1] * q4 - w_sy[2] * cz * q3,
        b_s[1] - w_s[0] * q4 - w_sy[2] * sz * q3,
        b_s[2] + (w_sy[0] * cz + w_sy[1] * sz) * q3,
    )
    hx = p[L.P_GEOMETRY_HAWK_CG_X]
    hz = p[L.P_GEOMETRY_HAWK_CG_Z]
    rho = (B[0] * hx + B[2] * hz, B[3] * hx + B[5] * hz, B[6] * hx + B[8] * hz)
    return B, (cf, sf), a2, (sz, cz), rho, w_s, w_a, b_s, b_a, (ct, st)


@inlined(**_JIT)
def cross_x(a, s):
    """a x (s, 0, 0)."""
    return (0.0, a[2] * s, -(a[1] * s))


@inlined(**_JIT)
def x_cross(s, a):
    """(s, 0, 0) x a."""
    return (0.0, -(s * a[2]), s * a[1])


@inlined(**_JIT)
def dot_pitch(cs, v):
    """a_pitch . v with a_pitch = (0, c, -s), cs = (c, s)."""
    return cs[0] * v[1] - cs[1] * v[2]


@inlined(**_JIT)
def dot_model_pitch(sc, v):
    """a_model_pitch . v with a_model_pitch = (-s, c, 0), sc = (s, c)."""
    return sc[1] * v[1] - sc[0] * v[0]


@inlined(**_JIT)
def mass_matrix_terms(q, qd, p):
    """(M, h, kin) of M qdd + h = Q at joint angles q and rates qd, as values (no arrays, so that a loop over
    environments vectorises).

    M: the 15 entries of its upper triangle by rows (m00, m01, .., m04, m11, .., m14, m22, .., m44);
    h: 5 bias forces; kin: the kinematics of :func:`arm_kinematics` for :func:`forces`, with the Hawk c.g.'s
    bias acceleration a_a (J_v-dot qdot, arm axes) appended.  Every arm joint
    turns all three bodies about an axis through the pivot and every model joint turns the Hawk about an
    axis through the model gimbal, so with J_v = a x r, J_w = a:

        M_jk = a_j . I_pivot a_k                       (j, k arm joints)
        M_jk = a_j . I_gimbal a_k                      (j, k model joints)
        M_jk = a_j . (I_a + m_a((r_a.rho) E - rho r_a^T)) a_k   (j arm, k model)
        h_k  = a_k . sum over the bodies moved by k of [r x m b_v + I b_w + w x I w]

    with I_pivot, I_gimbal the inertias about the pivot and the gimbal (parallel-axis terms), r_a the
    Hawk c.g. from the pivot, rho from the gimbal, b_v, b_w the bias accelerations.  This is
    J^T M_body J and J^T (M_body b + gyroscopic) written without forming J, in arm axes
    (:func:`arm_kinematics`): there the arm and compensator are one rigid body of constant inertia
    I_arm about the pivot (their own inertias plus the parallel-axis terms of their c.g.s), whose
    bias torque about the pivot, sum of r x m b_v + I b_w + w x I w over its parts, is
    I_arm b_s + w_s x I_arm w_s.

    A test fixture's inertia (``fixture.<joint>.inertia``, :class:`rig_env.params.Fixture`) adds to its
    joint's diagonal entry M_jj only: a flywheel turning at that joint's rate about its axis.
    """
    kin = arm_kinematics(q, qd, p)
    B, cs, a2, sc, rho, w_s, w_a, b_s, b_a, ts = kin
    m_a = p[L.P_MASS_HAWK_MASS]
    lf = p[L.P_GEOMETRY_ARM_LENGTH]
    I_pts = madd(
        point_inertia(p[L.P_MASS_ARM_MASS], (p[L.P_GEOMETRY_ARM_CG_X], p[L.P_GEOMETRY_ARM_CG_Y], p[L.P_GEOMETRY_ARM_CG_Z])),
        point_inertia(p[L.P_MASS_COMP_MASS], (p[L.P_GEOMETRY_COMP_CG_X], p[L.P_GEOMETRY_COMP_CG_Y], p[L.P_GEOMETRY_COMP_CG_Z])),
    )
    I_arm = (
        I_pts[0] + (p[L.P_MASS_ARM_IXX] + p[L.P_MASS_COMP_IXX]), I_pts[1], I_pts[2],
        I_pts[3], I_pts[4] + (p[L.P_MASS_ARM_IYY] + p[L.P_MASS_COMP_IYY]), I_pts[5],
        I_pts[6], I_pts[7], I_pts[8] + (p[L.P_MASS_ARM_IZZ] + p[L.P_MASS_COMP_IZZ]),
    )  # fmt: skip
    I_a = inertia_world(B, p[L.P_MASS_HAWK_IXX], p[L.P_MASS_HAWK_IYY], p[L.P_MASS_HAWK_IZZ], p[L.P_MASS_HAWK_IXZ])
    r_a = (lf + rho[0], rho[1], rho[2])
    I_gim = madd(I_a, point_inertia(m_a, rho))
    I_piv = madd(I_arm, madd(I_a, point_inertia(m_a, r_a)))
    ra_rho = dot(r_a, rho)
    K = (
        I_a[0] + m_a * (ra_rho - rho[0] * r_a[0]), I_a[1] - m_a * rho[0] * r_a[1], I_a[2] - m_a * rho[0] * r_a[2],
        I_a[3] - m_a * rho[1] * r_a[0], I_a[4] + m_a * (ra_rho - rho[1] * r_a[1]), I_a[5] - m_a * rho[1] * r_a[2],
        I_a[6] - m_a * rho[2] * r_a[0], I_a[7] - m_a * rho[2] * r_a[1], I_a[8] + m_a * (ra_rho - rho[2] * r_a[2]),
    )  # fmt: skip
    cf, sf = cs
    # I_piv a_j and K^T a_j (a_j^T K) of the arm axes; I_gim a_k of the model axes
    I1 = (I_piv[1] * cf - I_piv[2] * sf, I_piv[4] * cf - I_piv[5] * sf, I_piv[7] * cf - I_piv[8] * sf)
    I2 = mv(I_piv, a2)
    K0 = (K[0], K[1], K[2])
    K1 = (K[3] * cf - K[6] * sf, K[4] * cf - K[7] * sf, K[5] * cf - K[8] * sf)
    K2 = mtv(K, a2)
    sz, cz = sc
    G3 = (I_gim[1] * cz - I_gim[0] * sz, I_gim[4] * cz - I_gim[3] * sz, I_gim[7] * cz - I_gim[6] * sz)
    Mt = (
        I_piv[0] + p[L.P_FIXTURE_RIG_ROLL_INERTIA], dot_pitch(cs, (I_piv[0], I_piv[3], I_piv[6])),
        I_piv[0] * a2[0] + I_piv[3] * a2[1] + I_piv[6] * a2[2], dot_model_pitch(sc, K0), K0[2],
        dot_pitch(cs, I1) + p[L.P_FIXTURE_RIG_PITCH_INERTIA], dot(I1, a2), dot_model_pitch(sc, K1), K1[2],
        dot(I2, a2) + p[L.P_FIXTURE_RIG_YAW_INERTIA], dot_model_pitch(sc, K2), K2[2],
        dot_model_pitch(sc, G3) + p[L.P_FIXTURE_MODEL_PITCH_INERTIA], G3[2],
        I_gim[8] + p[L.P_FIXTURE_MODEL_YAW_INERTIA],
    )  # fmt: skip
    # bias (velocity-product) generalised forces; G = (lf, 0, 0): b_s x G + w_s x (w_s x G)
    u = cross_x(w_s, lf)
    a_a = add(add(cross_x(b_s, lf), cross(w_s, u)), point_bias(b_a, w_a, rho))
    f_a = scale(a_a, m_a)
    t_hawk = add(add(mv(I_a, b_a), cross(w_a, mv(I_a, w_a))), cross(rho, f_a))  # about the gimbal
    t_arm = add(add(mv(I_arm, b_s), cross(w_s, mv(I_arm, w_s))), add(t_hawk, x_cross(lf, f_a)))
    ht = (t_arm[0], dot_pitch(cs, t_arm), dot(a2, t_arm), dot_model_pitch(sc, t_hawk), t_hawk[2])
    return Mt, ht, (B, cs, a2, sc, rho, w_s, w_a, b_s, b_a, ts, a_a)


# (row, column) of the 15 upper-triangle entries of mass_matrix_terms' M
M_UPPER = ((0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (1, 1), (1, 2), (1, 3), (1, 4), (2, 2), (2, 3), (2, 4), (3, 3), (3, 4), (4, 4))


@inlined(**_JIT)
def store_mass_matrix(Mt, ht, M, hvec):
    """M (5x5, symmetric) and hvec (5) from :func:`mass_matrix_terms`' values."""
    for e in range(15):
        j, k = M_UPPER[e]
        M[j, k] = Mt[e]
        M[k, j] = Mt[e]
    for k in range(5):
        hvec[k] = ht[k]


@inlined(**_JIT)
def mass_matrix_and_bias(q, qd, p, M, hvec, jv):
    """Fill M (5x5) and h (5) of M qdd + h = Q from :func:`mass_matrix_terms` (jv: unused scratch, kept for
    callers).  Returns the kinematics (As, Aa, axes, G, rho, r_s, r_r, r_ref, w_s, w_a) for the force terms."""
    Mt, ht, kin = mass_matrix_terms(q, qd, p)
    store_mass_matrix(Mt, ht, M, hvec)
    return kin


@njit(**_JIT)
def potential_energy(q, p):
    """Gravitational potential energy (J), zero with every c.g. at the pivot height (z down), plus the
    test fixtures' (:func:`fixture_potential`: springs and constant torques; zero without a fixture)."""
    As, Aa, axes, G, rho, r_s, r_r, r_ref = frames(q, p)
    g = p[L.P_ENVIRONMENT_GRAVITY]
    z_a = G[2] + rho[2]
    fixtures = fixture_potential(0, q, p) + fixture_potential(1, q, p) + fixture_potential(2, q, p) + fixture_potential(3, q, p) + fixture_potential(4, q, p)
    return -g * (p[L.P_MASS_ARM_MASS] * r_s[2] + p[L.P_MASS_COMP_MASS] * r_r[2] + p[L.P_MASS_HAWK_MASS] * z_a) + fixtures


@njit(**_JIT)
def air_velocity(u):
    """Air velocity at the Hawk (world, m/s): the tunnel flow along -x plus the Hawk's gust (U_GUST)."""
    return (-u[L.U_AIRSPEED] + u[L.U_GUST], u[L.U_GUST + 1], u[L.U_GUST + 2])


@njit(**_JIT)
def comp_air(u, xs):
    """Air velocity at the compensator (world, m/s): the tunnel flow along -x, the compensator's own gust
    (U_GUST_COMP: the Hawk's convected downstream, :mod:`rig_env.turbulence`, or whatever a caller sets) and the
    Hawk's wake (xs[5], xs[6]: sidewash and downwash, world y and z; aerodynamic states, zero without the unsteady
    model)."""
    return (-u[L.U_AIRSPEED] + u[L.U_GUST_COMP], u[L.U_GUST_COMP + 1] + xs[5], u[L.U_GUST_COMP + 2] + xs[6])


@inlined(**_JIT)
def arm_to_world(v, sp, cp, cs, ts):
    """Arm-axes vector v in world axes, A_s v = Rz(psi) Ry(theta) Rx(phi) v (:func:`world_to_arm`'s inverse)."""
    cf, sf = cs
    ct, st = ts
    v1 = (v[0], cf * v[1] - sf * v[2], sf * v[1] + cf * v[2])
    v2 = (ct * v1[0] + st * v1[2], v1[1], ct * v1[2] - st * v1[0])
    return (cp * v2[0] - sp * v2[1], sp * v2[0] + cp * v2[1], v2[2])


@inlined(**_JIT)
def world_to_arm(v, sp, cp, cs, ts):
    """World vector v in arm axes, A_s^T v = Rx(phi)^T Ry(theta)^T Rz(psi)^T v; (sp, cp) = sin, cos of rig
    yaw psi, cs = (cos, sin) of rig roll phi, ts = (cos, sin) of rig pitch theta (:func:`arm_kinematics`)."""
    cf, sf = cs
    ct, st = ts
    v1 = (cp * v[0] + sp * v[1], cp * v[1] - sp * v[0], v[2])
    v2 = (ct * v1[0] - st * v1[2], v1[1], st * v1[0] + ct * v1[2])
    return (v2[0], cf * v2[1] + sf * v2[2], cf * v2[2] - sf * v2[1])


@inlined(**_JIT)
def friction_torque(j, v, z, p, flags):
    """Friction on joint j at rate v and bristle state z (N m, on the joint's positive direction): -tau_f
    of eq. (21), or 0 without friction (computed, then selected: no branch for the lane kernel)."""
    tau_f = -fr.torque(p, j, v, z)
    return tau_f if flags & L.F_FRICTION else 0.0


@inlined(**_JIT)
def friction_torques(qd, z, p, flags):
    """:func:`friction_torque` of the five joints (a 5-tuple, N m)."""
    return (
        friction_torque(0, qd[0], z[0], p, flags), friction_torque(1, qd[1], z[1], p, flags),
        friction_torque(2, qd[2], z[2], p, flags), friction_torque(3, qd[3], z[3], p, flags),
        friction_torque(4, qd[4], z[4], p, flags),
    )  # fmt: skip


@inlined(**_JIT)
def stop_torque(j, q, qd, p, flags):
    """Joint-stop torque on joint j (N m; 0 for the unlimited joints, or within the stops, or without stops)."""
    b = STOP_BASE[j]
    if b >= 0:  # j is a constant wherever this is inlined: decided at compile time
        lo = p[b]
        hi = p[b + 1]
        k = p[b + 2]
        c = p[b + 3]
        above = min(0.0, -k * (q[j] - hi) - c * qd[j])
        below = max(0.0, -k * (q[j] - lo) - c * qd[j])
        stop = above if q[j] > hi else (below if q[j] < lo else 0.0)
        return stop if flags & L.F_STOPS else 0.0
    return 0.0


FIXTURE_BASE = (
    L.P_FIXTURE_RIG_ROLL_STIFFNESS,
    L.P_FIXTURE_RIG_PITCH_STIFFNESS,
    L.P_FIXTURE_RIG_YAW_STIFFNESS,
    L.P_FIXTURE_MODEL_PITCH_STIFFNESS,
    L.P_FIXTURE_MODEL_YAW_STIFFNESS,
)
"""Offset of joint j's four fixture parameters (stiffness, neutral, inertia, torque) in the parameter vector."""


@inlined(**_JIT)
def fixture_torque(j, qj, p):
    """A test fixture's generalised force on joint j at angle qj (N m): -k (qj - neutral) + torque (zero
    without one)."""
    b = FIXTURE_BASE[j]
    return p[b + 3] - p[b] * (qj - p[b + 1])


@inlined(**_JIT)
def applied_torques(q, qd, z, p, flags):
    """Friction (:func:`friction_torques`) plus fixture torque of the five joints (a 5-tuple, N m): the
    joint torques :func:`forces` takes as ``fric``."""
    f = friction_torques(qd, z, p, flags)
    return (
        f[0] + fixture_torque(0, q[0], p), f[1] + fixture_torque(1, q[1], p), f[2] + fixture_torque(2, q[2], p),
        f[3] + fixture_torque(3, q[3], p), f[4] + fixture_torque(4, q[4], p),
    )  # fmt: skip


@inlined(**_JIT)
def fixture_potential(j, q, p):
    """Potential energy (J) of joint j's fixture: k (q_j - neutral)^2 / 2 - torque q_j."""
    b = FIXTURE_BASE[j]
    d = q[j] - p[b + 1]
    return 0.5 * p[b] * d * d - p[b + 3] * q[j]


@inlined(**_JIT)
def joint_torque(j, q, qd, z, p, flags):
    """Friction and stop torque on joint j (N m, acting on the joint's positive direction).

    Every term is computed and the ones that do not apply are selected away (no branches: the lane
    kernel computes eight environments side by side)."""
    return friction_torque(j, qd[j], z[j], p, flags) + stop_torque(j, q, qd, p, flags)


@inlined(**_JIT)
def joint_projection(t_pivot, t_gimbal, cs, a2, sc):
    """Generalised force (5-tuple) of loads whose moment is t_pivot about the pivot (all of them) and
    t_gimbal about the model gimbal (those on the Hawk): each joint axis dotted with the moment about its
    centre (arm axes)."""
    return (t_pivot[0], dot_pitch(cs, t_pivot), dot(a2, t_pivot), dot_model_pitch(sc, t_gimbal), t_gimbal[2])


@inlined(**_JIT)
def hawk_air(q, u, p, kin):
    """The air velocity (inputs u: tunnel flow and gust) and the Hawk c.g.'s velocity, both in arm axes
    (kin: :func:`arm_kinematics` or :func:`mass_matrix_terms`' kinematics): :func:`forces`' first lines.
    forces keeps its own copy: called from there, this moved the lane kernel's code enough that its
    serial and parallel twins no longer agreed bit for bit (LLVM's contraction choices), which
    tests/test_envs.py requires of a batch of one and environment i of a batch."""
    B, cs, a2, sc, rho, w_s, w_a, b_s, b_a, ts = kin[:10]
    v_air = air_velocity(u)  # world; into arm axes: A_s^T = Rx(phi)^T Ry(theta)^T Rz(psi)^T
    sp, cp = vmath.sincos(q[L.J_RIG_YAW])
    cf, sf = cs
    ct, st = ts
    v1 = (cp * v_air[0] + sp * v_air[1], cp * v_air[1] - sp * v_air[0], v_air[2])
    v2 = (ct * v1[0] - st * v1[2], v1[1], st * v1[0] + ct * v1[2])
    v_air_s = (v2[0], cf * v2[1] + sf * v2[2], cf * v2[2] - sf * v2[1])
    return v_air_s, add(cross_x(w_s, p[L.P_GEOMETRY_ARM_LENGTH]), cross(w_a, rho))


@inlined(**_JIT)
def air_flows(q, qd, u, p, xs, flaps, tabs):
    """What the aerodynamic states see at joint state (q, qd), inputs u, aerodynamic states xs (7-tuple) and
    the Hawk's surfaces ``flaps`` (de, da, dr; rad): the Hawk's angle of attack, airspeed and alpha-dot from
    the velocities (:func:`rig_env.physics.aero.hawk_flow`); the compensator's reference point velocity
    relative to its own air (tunnel flow, U_GUST_COMP and the wake xs[5:7]) and the arm's angular velocity
    (arm axes); the Hawk's aerodynamic force in world axes (N; alpha-dot at its velocity part, the
    separation state xs[0]), which makes the wake."""
    kin = arm_kinematics(q, qd, p)
    v_air_s, v_a = hawk_air(q, u, p, kin)
    w_s = kin[5]
    sp, cp = vmath.sincos(q[L.J_RIG_YAW])
    v_air_c = world_to_arm(comp_air(u, xs), sp, cp, kin[1], kin[9])  # the compensator's own air (its gust, the wake)
    fa = hawk_aero_full(p, kin[0], v_a, kin[6], v_air_s, _ZERO3, flaps[0], flaps[1], flaps[2], True, tabs[0], tabs[1], tabs[2], True,
                        xs[0])[0]  # fmt: skip
    return (hawk_flow(kin[0], v_a, kin[6], v_air_s), sub(cross_x(w_s, p[L.P_GEOMETRY_COMP_AERO_X]), v_air_c), w_s,
            arm_to_world(fa, sp, cp, kin[1], kin[9]))  # fmt: skip


@inlined(**_JIT)
def separation_step(q, qd, u, p, xs, flaps, dt, tabs):
    """The aerodynamic states xs (7-tuple: the flow-separation states of the Hawk and flaps 1-4's panels, the
    wake's sidewash and downwash at the compensator) after dt seconds at joint state (q, qd), inputs u and
    the Hawk's surfaces ``flaps`` (de, da, dr), their targets held (:func:`rig_env.physics.aero.separation_relax`,
    :func:`rig_env.physics.aero.comp_separation_relax`, :func:`rig_env.physics.aero.wake_relax`)."""
    hawk, vb0, wb, f_world = air_flows(q, qd, u, p, xs, flaps, tabs)
    alpha, V, adot = hawk
    c = comp_separation_relax(p, vb0, wb, (xs[1], xs[2], xs[3], xs[4]), dt, tabs[3], tabs[4])
    w = wake_relax(p, u[L.U_AIRSPEED], f_world, (xs[5], xs[6]), dt)
    return separation_relax(p, alpha, V, adot, xs[0], dt, tabs[0], tabs[1]), c[0], c[1], c[2], c[3], w[0], w[1]


@njit(**_JIT)
def separation_rates(q, qd, u, p, xs, flaps, tabs):
    """d/dt of the aerodynamic states xs (7-tuple, :func:`separation_step`) at joint state (q, qd), inputs u
    and the Hawk's surfaces ``flaps``: dx/dt = (x0(alpha - tau2 alphadot) - x) / tau1 (1/s; tau1, tau2 in
    seconds: the parameters times c / V; 0 below MIN_AIRSPEED) and the wake's (m/s^2, aero.wake_rates).
    The integrators relax the states exactly over half steps (:func:`separation_step`); this is the same
    equation for continuation and linearisation."""
    hawk, vb0, wb, f_world = air_flows(q, qd, u, p, xs, flaps, tabs)
    alpha, V, adot = hawk
    target = separation_target(p, alpha, V, adot, tabs[0], tabs[1])
    rate = (target - xs[0]) * V / (p[L.P_HAWK_AERO_SEP_TAU1] * p[L.P_HAWK_AERO_C])
    c = comp_separation_rates(p, vb0, wb, (xs[1], xs[2], xs[3], xs[4]), tabs[3], tabs[4])
    w = wake_rates(p, u[L.U_AIRSPEED], f_world, (xs[5], xs[6]))
    return rate if V >= MIN_AIRSPEED else 0.0, c[0], c[1], c[2], c[3], w[0], w[1]


@njit(**_JIT)
def separation_steady(q, qd, u, p, flaps, tabs):
    """The aerodynamic states (7-tuple) in steady flow at joint state (q, qd), inputs u and the Hawk's surfaces
    ``flaps``: the separation states' targets x0(alpha - tau2 alphadot) (:func:`separation_step`'s, without
    the relaxation) and the wake's.  In that order: the Hawk's target depends on its flow alone, the wake on
    the Hawk's force at its target, the panels' targets on the compensator's flow with the wake."""
    hawk, vb0, wb, f_world = air_flows(q, qd, u, p, ATTACHED, flaps, tabs)
    x_h = separation_target(p, hawk[0], hawk[1], hawk[2], tabs[0], tabs[1])
    hawk, vb0, wb, f_world = air_flows(q, qd, u, p, (x_h, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0), flaps, tabs)
    w = wake_targets(p, u[L.U_AIRSPEED], f_world)
    hawk, vb0, wb, f_world = air_flows(q, qd, u, p, (x_h, 1.0, 1.0, 1.0, 1.0, w[0], w[1]), flaps, tabs)
    c = comp_separation_targets(p, vb0, wb, tabs[3], tabs[4])
    return x_h, c[0], c[1], c[2], c[3], w[0], w[1]


@inlined(**_JIT)
def forces(q, qd, fric, xs, flaps, u, p, flags, tabs, kin, nonlinear, unrolled):
    """Generalised forces (Q, D, G), three 5-tuples: Q (N m) of gravity, aerodynamics, stops and the joint
    torques ``fric``, with the Hawk's alpha-dot at its velocity part (aero.hawk_aero_full); D (N m s/rad)
    the generalised force per unit of the rest of alpha-dot (rad/s) and G (s) that rest per unit joint
    acceleration, so that the full generalised force is Q + D (G . qdd):

        G_k = n . J_v,k = a_k . (r_a x n)  (rig joints),  a_k . (rho x n)  (model joints)

    with n the Hawk's alpha-dot direction (aero.hawk_aero_full) and r_a, rho its c.g. from the pivot and
    the gimbal; D is :func:`joint_projection` of the loads per unit alpha-dot.  Without aerodynamics (or
    wind off) D = G = 0.

    fric: the joints' friction and test-fixture torques (:func:`applied_torques`; the lane kernel
    computes them in loops of their own, for the free joints only, so that a locked joint costs nothing).
    xs: the aerodynamic states (7-tuple: the flow-separation states of the Hawk and flaps 1-4's panels, used
    with flags' F_UNSTEADY and nonlinear only; the wake's sidewash and downwash at the compensator, world
    m/s, zero without the unsteady model: :data:`ATTACHED`).

    nonlinear: the stall tables (flags' F_NONLINEAR), unrolled: the compensator's panels written out
    (the lane kernel) rather than looped over (the per-environment kernel vectorises that loop); both
    are compile-time constants wherever the lane kernel inlines this.
    """
    B, cs, a2, sc, rho, w_s, w_a, b_s, b_a, ts, a_bias = kin  # arm axes (arm_kinematics, mass_matrix_terms)
    g = p[L.P_ENVIRONMENT_GRAVITY]
    m_a = p[L.P_MASS_HAWK_MASS]
    lf = p[L.P_GEOMETRY_ARM_LENGTH]
    r_a = (lf + rho[0], rho[1], rho[2])
    gv = scale(a2, g)  # gravity's acceleration: world z (down) is the rig-yaw axis a2
    f_a = scale(gv, m_a)
    t_a = (0.0, 0.0, 0.0)
    # torque of all arm-borne loads about the pivot: the arm's and compensator's weights at their c.g.s
    m_s = p[L.P_MASS_ARM_MASS]
    m_r = p[L.P_MASS_COMP_MASS]
    first_moment = (
        m_s * p[L.P_GEOMETRY_ARM_CG_X] + m_r * p[L.P_GEOMETRY_COMP_CG_X],
        m_s * p[L.P_GEOMETRY_ARM_CG_Y] + m_r * p[L.P_GEOMETRY_COMP_CG_Y],
        m_s * p[L.P_GEOMETRY_ARM_CG_Z] + m_r * p[L.P_GEOMETRY_COMP_CG_Z],
    )
    t_arm = cross(first_moment, gv)
    zero = (0.0, 0.0, 0.0, 0.0, 0.0)
    D = zero
    Gv = zero
    if flags & L.F_AERO:
        v_air = air_velocity(u)  # world; into arm axes: A_s^T = Rx(phi)^T Ry(theta)^T Rz(psi)^T
        sp, cp = vmath.sincos(q[L.J_RIG_YAW])
        cf, sf = cs
        ct, st = ts
        v1 = (cp * v_air[0] + sp * v_air[1], cp * v_air[1] - sp * v_air[0], v_air[2])
        v2 = (ct * v1[0] - st * v1[2], v1[1], st * v1[0] + ct * v1[2])
        v_air_s = (v2[0], cf * v2[1] + sf * v2[2], cf * v2[2] - sf * v2[1])
        v_a = add(cross_x(w_s, lf), cross(w_a, rho))
        unsteady = nonlinear and (flags & L.F_UNSTEADY) != 0  # folded away where nonlinear is a constant False (lanes)
        fa, ta, fd, md, n = hawk_aero_full(
            p, B, v_a, w_a, v_air_s, a_bias, flaps[4], flaps[5], flaps[6], nonlinear, tabs[0], tabs[1], tabs[2], unsteady, xs[0]
        )
        f_a = add(f_a, fa)
        t_a = ta
        D = joint_projection(add(cross(r_a, fd), md), add(cross(rho, fd), md), cs, a2, sc)
        Gv = joint_projection(cross(r_a, n), cross(rho, n), cs, a2, sc)
        x_ref = p[L.P_GEOMETRY_COMP_AERO_X]
        v_air_c = world_to_arm(comp_air(u, xs), sp, cp, cs, ts)  # the compensator's own air: its gust U_GUST_COMP, the Hawk's wake
        fc, tc = comp_aero_arm(p, sub(cross_x(w_s, x_ref), v_air_c), w_s, flaps, nonlinear, tabs[3], tabs[4], unrolled, unsteady,
                               (xs[1], xs[2], xs[3], xs[4]))
        t_arm = add(t_arm, add(x_cross(x_ref, fc), tc))
    t_pivot = add(t_arm, add(cross(r_a, f_a), t_a))
    t_gimbal = add(cross(rho, f_a), t_a)
    Qt = (
        t_pivot[0] + (fric[0] + stop_torque(0, q, qd, p, flags)),
        dot_pitch(cs, t_pivot) + (fric[1] + stop_torque(1, q, qd, p, flags)),
        dot(a2, t_pivot) + (fric[2] + stop_torque(2, q, qd, p, flags)),
        dot_model_pitch(sc, t_gimbal) + (fric[3] + stop_torque(3, q, qd, p, flags)),
        t_gimbal[2] + (fric[4] + stop_torque(4, q, qd, p, flags)),
    )
    return Qt, D, Gv


@inlined(**_JIT)
def generalized_forces(q, qd, z, flaps, u, p, flags, tabs, kin, Q, xs=ATTACHED):
    """Fill Q (5) with :func:`forces`' Q (alpha-dot at its velocity part; xs: the separation states)."""
    Qt, D, Gv = forces(q, qd, applied_torques(q, qd, z, p, flags), xs, flaps, u, p, flags, tabs, kin, (flags & L.F_NONLINEAR) != 0, False)
    for k in range(5):
        Q[k] = Qt[k]


@njit(**_JIT)
def is_free(j, free_idx, n):
    for a in range(n):
        if free_idx[a] == j:
            return True
    return False


@njit(**_JIT)
def free_mask(free_idx, n):
    """(5,) tuple: True for the joints listed in free_idx[:n]."""
    return (is_free(0, free_idx, n), is_free(1, free_idx, n), is_free(2, free_idx, n), is_free(3, free_idx, n), is_free(4, free_idx, n))


@inlined(**_JIT)
def solve_free(Mt, r, free):
    """qdd (5-tuple) of M[free, free] qdd[free] = r[free], qdd[locked] = 0 (:func:`ldl_factor`, :func:`ldl_solve`)."""
    return ldl_solve(ldl_factor(Mt, free), r, free)


@inlined(**_JIT)
def solve_free_rank1(Mt, r, d, g, free):
    """qdd (5-tuple) of (M - d g^T)[free, free] qdd[free] = r[free], qdd[locked] = 0: the joint equations
    with the Hawk's alpha-dot load D (G . qdd) moved to the left (:func:`forces`).

    Sherman-Morrison on M's one LDL^T factorisation: x = M^-1 r, y = M^-1 d, qdd = x + y (g . x) / (1 - g . y)
    (over the free joints; x and y are zero at the locked ones).  With d = 0 (no alpha-dot share, or wind
    off) qdd = x exactly."""
    fac = ldl_factor(Mt, free)
    x = ldl_solve(fac, r, free)
    y = ldl_solve(fac, d, free)
    s = (g[0] * x[0] + g[1] * x[1] + g[2] * x[2] + g[3] * x[3] + g[4] * x[4]) / (
        1.0 - (g[0] * y[0] + g[1] * y[1] + g[2] * y[2] + g[3] * y[3] + g[4] * y[4])
    )
    return x[0] + y[0] * s, x[1] + y[1] * s, x[2] + y[2] * s, x[3] + y[3] * s, x[4] + y[4] * s


@inlined(**_JIT)
def ldl_factor(Mt, free):
    """LDL^T factors ((l_ij), (1 / d_j)) of M[free, free] for :func:`ldl_solve`.

    Mt: M's upper triangle as :func:`mass_matrix_terms` gives it; free: 5 bools.
    Locked rows and columns are replaced by the identity (and r by 0), so one fixed 5x5 factorisation
    serves every lock set with no index indirection or branch.  LDL^T (Golub and Van Loan, Matrix
    Computations, sec. 4.1) rather than Cholesky: five divisions and no square roots, which are the
    slowest vector instructions of the right-hand side and lie on its critical path.  A pivot d_j <= 0
    (M not positive definite) gives NaN, which the caller reports as a blow-up of that environment.
    """
    f0, f1, f2, f3, f4 = free
    # M with locked rows and columns set to the identity
    m00 = Mt[0] if f0 else 1.0
    m01 = Mt[1] if f0 & f1 else 0.0
    m02 = Mt[2] if f0 & f2 else 0.0
    m03 = Mt[3] if f0 & f3 else 0.0
    m04 = Mt[4] if f0 & f4 else 0.0
    m11 = Mt[5] if f1 else 1.0
    m12 = Mt[6] if f1 & f2 else 0.0
    m13 = Mt[7] if f1 & f3 else 0.0
    m14 = Mt[8] if f1 & f4 else 0.0
    m22 = Mt[9] if f2 else 1.0
    m23 = Mt[10] if f2 & f3 else 0.0
    m24 = Mt[11] if f2 & f4 else 0.0
    m33 = Mt[12] if f3 else 1.0
    m34 = Mt[13] if f3 & f4 else 0.0
    m44 = Mt[14] if f4 else 1.0
    # M = L D L^T, L unit lower triangular; e_ij = l_ij d_j; i_j = 1 / d_j
    d = m00
    i0 = 1.0 / d if d > 0.0 else np.nan
    l10 = m01 * i0
    l20 = m02 * i0
    l30 = m03 * i0
    l40 = m04 * i0
    d = m11 - l10 * m01
    i1 = 1.0 / d if d > 0.0 else np.nan
    e21 = m12 - l20 * m01
    e31 = m13 - l30 * m01
    e41 = m14 - l40 * m01
    l21 = e21 * i1
    l31 = e31 * i1
    l41 = e41 * i1
    d = m22 - l20 * m02 - l21 * e21
    i2 = 1.0 / d if d > 0.0 else np.nan
    e32 = m23 - l30 * m02 - l31 * e21
    e42 = m24 - l40 * m02 - l41 * e21
    l32 = e32 * i2
    l42 = e42 * i2
    d = m33 - l30 * m03 - l31 * e31 - l32 * e32
    i3 = 1.0 / d if d > 0.0 else np.nan
    e43 = m34 - l40 * m03 - l41 * e31 - l42 * e32
    l43 = e43 * i3
    d = m44 - l40 * m04 - l41 * e41 - l42 * e42 - l43 * e43
    i4 = 1.0 / d if d > 0.0 else np.nan
    return (l10, l20, l30, l40, l21, l31, l41, l32, l42, l43), (i0, i1, i2, i3, i4)


@inlined(**_JIT)
def ldl_solve(fac, r, free):
    """x (5-tuple) of L D L^T x = r with :func:`ldl_factor`'s factors, r's locked entries taken as 0."""
    f0, f1, f2, f3, f4 = free
    (l10, l20, l30, l40, l21, l31, l41, l32, l42, l43), (i0, i1, i2, i3, i4) = fac
    # L y = r, then L^T x = D^-1 y
    y0 = r[0] if f0 else 0.0
    y1 = (r[1] if f1 else 0.0) - l10 * y0
    y2 = (r[2] if f2 else 0.0) - l20 * y0 - l21 * y1
    y3 = (r[3] if f3 else 0.0) - l30 * y0 - l31 * y1 - l32 * y2
    y4 = (r[4] if f4 else 0.0) - l40 * y0 - l41 * y1 - l42 * y2 - l43 * y3
    x4 = y4 * i4
    x3 = y3 * i3 - l43 * x4
    x2 = y2 * i2 - l32 * x3 - l42 * x4
    x1 = y1 * i1 - l21 * x2 - l31 * x3 - l41 * x4
    x0 = y0 * i0 - l10 * x1 - l20 * x2 - l30 * x3 - l40 * x4
    return x0, x1, x2, x3, x4


@inlined(**_JIT)
def accelerations(q, qd, z, xs, flaps, u, p, flags, free_idx, n_free, tabs, M, hvec, Q, jv, qdd):
    """Joint accelerations qdd (5; zero for locked joints) of the joint-space model, (M - D G^T) qdd + h = Q
    (:func:`forces`, :func:`solve_free_rank1`), with M, h and Q (alpha-dot at its velocity part) written to
    M, hvec and Q (jv: unused scratch, kept for callers); xs: the flow-separation states (5-tuple)."""
    Mt, ht, kin = mass_matrix_terms(q, qd, p)
    Qt, D, Gv = forces(q, qd, applied_torques(q, qd, z, p, flags), xs, flaps, u, p, flags, tabs, kin, (flags & L.F_NONLINEAR) != 0, False)
    r = (Qt[0] - ht[0], Qt[1] - ht[1], Qt[2] - ht[2], Qt[3] - ht[3], Qt[4] - ht[4])
    x = solve_free_rank1(Mt, r, D, Gv, free_mask(free_idx, n_free))
    store_mass_matrix(Mt, ht, M, hvec)
    for k in range(5):
        Q[k] = Qt[k]
        qdd[k] = x[k]


@njit(**_JIT)
def kinetic_energy(q, qd, p, M, hvec, jv):
    mass_matrix_and_bias(q, qd, p, M, hvec, jv)
    t = 0.0
    for j in range(5):
        for k in range(5):
            t += 0.5 * qd[j] * M[j, k] * qd[k]
    return t

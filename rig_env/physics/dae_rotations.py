"""Euler parameters of the DAE's bodies: rotation matrices, quaternion updates, and the joint angles and
rates that two body orientations and angular velocities imply.

A(theta) (body to world) is a row-major 9-tuple; joint angles as in
:func:`rig_env.physics.joint_space.frames` (A_s = Rz(psi) Ry(theta) Rx(phi), A_a = A_s Rz(psi_a)
Ry(theta_a)); joint rates through the dual bases of the joint axes (:func:`joint_bases`).
"""

from __future__ import annotations

import math

from numba import njit

from rig_env.physics import vec as _vec
from rig_env.physics.dae_layout import Y_QA, Y_QS, Y_WA, Y_WS

_JIT = dict(cache=True, error_model="numpy", _nrt=False)  # allocation-free kernels: no NRT refcounting


def _plain(f):
    """vec.py's helper compiled as an ordinary function: LLVM still inlines it, but numba's IR-level
    ``inline="always"`` over the many call sites here would multiply the cold compile time."""
    return njit(error_model="numpy")(f.py_func)


add, col, cross, dot, mtv, mv, scale, sub = (
    _plain(f) for f in (_vec.add, _vec.col, _vec.cross, _vec.dot, _vec.mtv, _vec.mv, _vec.scale, _vec.sub)
)


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
    """The 3-tuple y[i:i + 3] (a position in m or a velocity in m/s or rad/s of the state row y)."""
    return (y[i], y[i + 1], y[i + 2])


@njit(**_JIT)
def normalise_quats(y):
    """Both bodies' Euler parameters of the state row y scaled to unit norm, in place."""
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
    """(w_a, w_s): the aircraft's and the arm's angular velocities (rad/s) in world axes, from the body-axis
    ones of the state row y and the rotations Aa, As (9-tuples)."""
    return mv(Aa, vec3(y, Y_WA)), mv(As, vec3(y, Y_WS))



@njit(**_JIT)
def current_joint_rates(y):
    """Joint rates (rad/s, JOINTS order, a 5-tuple) of the DAE state row y."""
    Aa, As = body_matrices(y)
    w_a, w_s = world_rates(y, Aa, As)
    return joint_rates(Aa, As, w_a, w_s, joint_bases(Aa, As))



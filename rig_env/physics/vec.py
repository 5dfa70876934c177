"""Allocation-free 3-vector and 3x3 rotation helpers for the numba kernels.

Vectors are 3-tuples of float64, matrices are 9-tuples in row-major order.  Keeping them as tuples
lets LLVM hold them in registers: the hot loops allocate nothing.  Rotations take their sines and
cosines from :func:`rig_env.physics.vmath.sincos` (no library call, so a loop over environments vectorises).
"""

from __future__ import annotations

import math

from numba import njit

from rig_env.physics.vmath import FASTMATH, sincos

_JIT = dict(cache=True, inline="always", error_model="numpy", fastmath=FASTMATH, _nrt=False)


@njit(**_JIT)
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(**_JIT)
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(**_JIT)
def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@njit(**_JIT)
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(**_JIT)
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(**_JIT)
def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@njit(**_JIT)
def mv(m, v):
    """m @ v."""
    return (
        m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
        m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
        m[6] * v[0] + m[7] * v[1] + m[8] * v[2],
    )


@njit(**_JIT)
def mtv(m, v):
    """m.T @ v."""
    return (
        m[0] * v[0] + m[3] * v[1] + m[6] * v[2],
        m[1] * v[0] + m[4] * v[1] + m[7] * v[2],
        m[2] * v[0] + m[5] * v[1] + m[8] * v[2],
    )


@njit(**_JIT)
def mm(a, b):
    """a @ b."""
    return (
        a[0] * b[0] + a[1] * b[3] + a[2] * b[6],
        a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
        a[0] * b[2] + a[1] * b[5] + a[2] * b[8],
        a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
        a[3] * b[1] + a[4] * b[4] + a[5] * b[7],
        a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
        a[6] * b[0] + a[7] * b[3] + a[8] * b[6],
        a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
        a[6] * b[2] + a[7] * b[5] + a[8] * b[8],
    )


@njit(**_JIT)
def col(m, j):
    return (m[j], m[3 + j], m[6 + j])


@njit(**_JIT)
def rot_x(a):
    s, c = sincos(a)
    return (1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)


@njit(**_JIT)
def rot_y(a):
    s, c = sincos(a)
    return (c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)


@njit(**_JIT)
def rot_z(a):
    s, c = sincos(a)
    return (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)


@njit(**_JIT)
def rot_zy(yaw, pitch):
    """Rz(yaw) @ Ry(pitch), written out (the zero entries of the factors left out of the product)."""
    sz, cz = sincos(yaw)
    sy, cy = sincos(pitch)
    return (cz * cy, -sz, cz * sy, sz * cy, cz, sz * sy, -sy, 0.0, cy)


@njit(**_JIT)
def rot_zyx(yaw, pitch, roll):
    """Rz(yaw) @ Ry(pitch) @ Rx(roll), written out as :func:`rot_zy` times Rx."""
    b = rot_zy(yaw, pitch)
    sx, cx = sincos(roll)
    return (
        b[0], b[1] * cx + b[2] * sx, b[2] * cx - b[1] * sx,
        b[3], b[4] * cx + b[5] * sx, b[5] * cx - b[4] * sx,
        b[6], b[8] * sx, b[8] * cx,
    )  # fmt: skip


@njit(**_JIT)
def inertia_world(A, ixx, iyy, izz, ixz):
    """A I A^T for a body inertia with principal terms and one product Ixz (body axes); symmetric.

    With a_i the rows of A: (A I A^T)_ik = ixx a_i0 a_k0 + iyy a_i1 a_k1 + izz a_i2 a_k2 - ixz (a_i0 a_k2 + a_i2 a_k0).
    """
    # rows of A I_body: (ixx a_i0 - ixz a_i2, iyy a_i1, izz a_i2 - ixz a_i0); then (A I_body) A^T
    b00 = ixx * A[0] - ixz * A[2]
    b01 = iyy * A[1]
    b02 = izz * A[2] - ixz * A[0]
    b10 = ixx * A[3] - ixz * A[5]
    b11 = iyy * A[4]
    b12 = izz * A[5] - ixz * A[3]
    b20 = ixx * A[6] - ixz * A[8]
    b21 = iyy * A[7]
    b22 = izz * A[8] - ixz * A[6]
    m00 = b00 * A[0] + b01 * A[1] + b02 * A[2]
    m01 = b00 * A[3] + b01 * A[4] + b02 * A[5]
    m02 = b00 * A[6] + b01 * A[7] + b02 * A[8]
    m11 = b10 * A[3] + b11 * A[4] + b12 * A[5]
    m12 = b10 * A[6] + b11 * A[7] + b12 * A[8]
    m22 = b20 * A[6] + b21 * A[7] + b22 * A[8]
    return (m00, m01, m02, m01, m11, m12, m02, m12, m22)

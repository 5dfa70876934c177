"""The structured solve of the DAE: accelerations by the Schur complement of the constraint Jacobian
(equivalent to eq. 1 of AIAA 2009-5727), and the drift control that projects positions and velocities
back onto the constraints.

Equivalence of the structured solve with eq. (1)
------------------------------------------------
With Gb(theta) = [-e, -skew(e) + e0 I] (3x4), the paper's G (omega_body = G thetadot) is 2 Gb, so
m_thth = G^T I G, Q_v = -2 Gdot^T I omega (eq. 11) and a body-frame moment n enters Q_e as G^T n.
For unit theta, Gb Gb^T = I3 and Gb theta = 0, Gbdot thetadot = 0, hence omegadot = G thetaddot.
Premultiplying the Euler-parameter rows of eq. (1) by Gb / 2 (= G / 4) gives

    I omegadot + C_pi^T lambda = n - omega x I omega,        C_pi = C_theta G^T / 4,

i.e. Euler's equations, with C_pi the constraint Jacobian with respect to body-frame virtual
rotations (the ``J`` of :mod:`rig_env.physics.dae_constraints`); the norm multipliers drop out
because C_theta of (13)/(14) is 2 theta^T and G theta = 0.  The fourth component of thetaddot (along
theta) is fixed by the norm constraint, theta . thetaddot = -|thetadot|^2, which the kinematics
thetadot = G^T omega / 4 = Gb^T omega / 2 satisfy identically.  So, with velocities v = (Rdot_a,
omega_a, Rdot_s, omega_s, Rdot_r) (15, body angular velocities) and M = diag(m_a, I_a, m_s, I_s, m_r):

    M vdot + J^T lambda = F,      J vdot = -b   (b = Jdot v, the velocity-product terms)
    (J M^-1 J^T) lambda = J M^-1 F + b,     vdot = M^-1 (F - J^T lambda)

a Schur complement of 10 + n_locked rows solved by Cholesky, exactly eq. (1).
``rig_env.physics.dae_reference`` assembles the literal 17-coordinate system and the tests check
the two agree to round-off.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rig_env.physics import layout as L
from rig_env.physics.dae_constraints import constraint_system, constraints_at
from rig_env.physics.dae_layout import (
    C_VA, C_VR, C_VS, C_WA, C_WS, N_CMAX, PROJ_ITERS, PROJ_SKIP_RECHECK, PROJ_TOL, W_ACC, W_ACC2, W_B, W_C, W_F, W_J, W_LAM, W_MJ,
    W_SCHUR, Y_QA, Y_QS, Y_RA, Y_RR, Y_RS, Y_V, Y_WA, Y_WS,
)  # fmt: skip
from rig_env.physics.dae_loads import inertias, inv_inertias, loads_at
from rig_env.physics.dae_rotations import body_matrices, cross, mtv, mv, normalise_quats, rotate_quat, sub, vec3

_JIT = dict(cache=True, error_model="numpy", _nrt=False)  # allocation-free kernels: no NRT refcounting


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
def _solve_constrained(F, acc, MJ, S, m, lam, b, with_b, ima, ims, ma, ms, mr):
    """acc (15) = the accelerations under the loads F (15) and the m constraints already factored into MJ = J M^-1
    and the Schur complement S: acc = M^-1 F - MJ^T lam with S lam = MJ F + b (b only ``with_b``: the
    constraints' velocity terms; without them for a load alone, e.g. the alpha-dot load's column)."""
    _minv(F, 0, acc, 0, ima, ims, ma, ms, mr)
    for r in range(m):
        s = b[r] if with_b else 0.0
        for k in range(15):
            s += MJ[r * 15 + k] * F[k]
        lam[r] = s
    _chol_solve(S, m, lam)
    for r in range(m):
        for k in range(15):
            acc[k] -= lam[r] * MJ[r * 15 + k]


@njit(**_JIT)
def accelerations(y, tgt, z, xs, flaps, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w):
    """vdot (15) of the DAE into w[W_ACC:W_ACC+15] by the Schur complement of the module docstring.

    y: coordinates and velocities in its first 32 entries; tgt: locked targets (5); z: bristle states
    (5); xs: the flow-separation states (5-tuple); flaps: 7 surface deflections, rad; locked[:n_locked]: locked joints.  Returns the applied
    loads (world axes) (f_a, n_a, f_s, n_s, f_r): those of :func:`dae_loads.loads_at` with the Hawk's
    alpha-dot load at the solved acceleration added (the loads eq. (1) holds with).

    The Hawk's alpha-dot load F_ad (n . a_a) depends on the Hawk c.g.'s acceleration a_a (docs/MODEL.md 3.1):
    with v1 the solution for the loads F and v2 that for F_ad alone (b = 0), the same factorisation,
    vdot = v1 + v2 (n . a_a(v1)) / (1 - n . a_a(v2)) (Sherman-Morrison on the constrained system; v2 = 0 and
    vdot = v1 without the alpha-dot share).
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
    loads = loads_at(y, Aa, As, z, xs, flaps, u, p, flags, free_idx, n_free, tabs)
    f_a, n_a, f_s, n_s, f_r, ad = loads
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
    _solve_constrained(F, acc, MJ, S, m, lam, b, True, ima, ims, ma, ms, mr)
    if flags & L.F_AERO:
        fd, md, n = ad
        acc2 = w[W_ACC2 : W_ACC2 + 15]
        mdb = mtv(Aa, md)
        for k in range(15):
            F[k] = 0.0
        for d in range(3):
            F[C_VA + d] = fd[d]
            F[C_WA + d] = mdb[d]
        _solve_constrained(F, acc2, MJ, S, m, lam, b, False, ima, ims, ma, ms, mr)
        a1 = n[0] * acc[C_VA] + n[1] * acc[C_VA + 1] + n[2] * acc[C_VA + 2]
        a2 = n[0] * acc2[C_VA] + n[1] * acc2[C_VA + 1] + n[2] * acc2[C_VA + 2]
        c_ad = a1 / (1.0 - a2)
        for k in range(15):
            acc[k] += c_ad * acc2[k]
        s_ad = n[0] * acc[C_VA] + n[1] * acc[C_VA + 1] + n[2] * acc[C_VA + 2]  # = a1 / (1 - a2)
        return (
            (f_a[0] + s_ad * fd[0], f_a[1] + s_ad * fd[1], f_a[2] + s_ad * fd[2]),
            (n_a[0] + s_ad * md[0], n_a[1] + s_ad * md[1], n_a[2] + s_ad * md[2]),
            f_s, n_s, f_r,
        )  # fmt: skip
    return f_a, n_a, f_s, n_s, f_r



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



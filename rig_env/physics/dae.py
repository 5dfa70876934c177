"""The paper's constrained multibody DAE (AIAA 2009-5727, eqs. 1-22), solved in Newton-Euler form: the
integrator and its batch drivers.

Bodies a (aircraft), s (arm, its inertia including the compensator's own ``comp_I*``) and r
(compensator, a point mass); 17 coordinates q = (R_a, theta_a, R_s, theta_s, R_r), Euler parameters
theta = (e0, e1, e2, e3), A(theta) body to world.  World axes x upstream, y starboard, z down, the
pivot at the origin, gravity +z.  The model is split by idea:

    ==========================================  ===========================================================
    :mod:`rig_env.physics.dae_layout`           state row Y (N_DAE = 61), scratch row, solver constants
    :mod:`rig_env.physics.dae_rotations`        Euler parameters, rotation matrices, joint angles and rates
    :mod:`rig_env.physics.dae_loads`            body inertias; gravity, aero, friction and stop loads
    :mod:`rig_env.physics.dae_constraints`      constraints (15)-(18) and locked joints, Jacobian, residual
    :mod:`rig_env.physics.dae_solve`            Schur-complement accelerations (eq. 1), drift control
    this module                                 RK4 integration, blow-up checks, batch drivers, conversions
    ==========================================  ===========================================================

Every public name of those modules is importable from here as well (``from rig_env.physics import dae``
gives the whole model).

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
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from rig_env.physics import friction as fr
from rig_env.physics import layout as L
from rig_env.physics import servo as sv
from rig_env.physics.dae_constraints import (  # noqa: F401  (re-exported)
    constraint_system, constraints_at, locked_joints, residual,
)  # fmt: skip
from rig_env.physics.dae_layout import (  # noqa: F401  (re-exported)
    AIRCRAFT, ARM, C_VA, C_VR, C_VS, C_WA, C_WS, GROUND, N_CMAX, N_COORD, N_DAE, N_RK, N_VEL, N_WORK_DAE, PROJ_ITERS,
    PROJ_SKIP_RECHECK, PROJ_TOL, RK_C, RK_W, W_ACC, W_B, W_BACK, W_C, W_F, W_J, W_K, W_LAM, W_MJ, W_SCHUR, W_UD, W_Y0,
    W_YT, Y_QA, Y_QS, Y_RA, Y_RR, Y_RS, Y_SEP, Y_SERVO, Y_SERVO_RATE, Y_TARGET, Y_V, Y_VA, Y_VR, Y_VS, Y_WA, Y_WS, Y_Z,
    new_work_dae,
)  # fmt: skip
from rig_env.physics.dae_loads import applied_loads, inertias, inv_inertias, loads_at  # noqa: F401  (re-exported)
from rig_env.physics.dae_rotations import (  # noqa: F401  (re-exported)
    add, body_matrices, col, cross, current_joint_rates, dot, joint_angles, joint_bases, joint_rates, matrix_quat, mtv,
    mv, normalise_quats, quat_matrix, rotate_quat, scale, sub, vec3, world_rates,
)  # fmt: skip
from rig_env.physics.dae_solve import accelerations, project  # noqa: F401  (re-exported)
from rig_env.physics.integrator import push_demands
from rig_env.physics.aero import comp_separation_relax, hawk_aero_full, hawk_flow, separation_relax, wake_relax
from rig_env.physics.joint_space import air_velocity, comp_air, frames, velocities

_JIT = dict(cache=True, error_model="numpy", _nrt=False)  # allocation-free kernels: no NRT refcounting
_JIT_BATCH = dict(cache=True, error_model="numpy")  # batch drivers that allocate small scratch


# ---------------------------------------------------------------------- integration
@njit(**_JIT)
def rhs_dae(yr, tgt, z, xs, ud, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w, out):
    """Time derivative of the RK state yr (46,) into out (46,); z, xs: bristle and separation states, held."""
    if flags & L.F_SERVO:
        flaps = yr[32:39]
    else:
        flaps = ud
    accelerations(yr, tgt, z, xs, flaps, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w)
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
def half_separation_step_dae(y, u, p, tabs, h):
    """The aerodynamic states y[Y_SEP:Y_SEP + N_AERO] over h/2 at the bodies' state y (as the joint-space
    integrator's half step: :func:`rig_env.physics.aero.separation_relax` at the Hawk's flow angles,
    :func:`rig_env.physics.aero.comp_separation_relax` at the compensator reference point's flow in its own air,
    U_GUST_COMP and the wake, :func:`rig_env.physics.aero.wake_relax` at the Hawk's aerodynamic force with its
    surfaces at their servo positions)."""
    Aa, As = body_matrices(y)
    w_a, w_s = world_rates(y, Aa, As)
    v_air = air_velocity(u)
    xs = (y[Y_SEP], y[Y_SEP + 1], y[Y_SEP + 2], y[Y_SEP + 3], y[Y_SEP + 4], y[Y_SEP + 5], y[Y_SEP + 6])
    alpha, V, adot = hawk_flow(Aa, vec3(y, Y_VA), w_a, v_air)
    f = Y_SERVO + 4
    fa = hawk_aero_full(p, Aa, vec3(y, Y_VA), w_a, v_air, (0.0, 0.0, 0.0), y[f], y[f + 1], y[f + 2], True, tabs[0], tabs[1], tabs[2],
                        True, xs[0])[0]  # fmt: skip
    y[Y_SEP] = separation_relax(p, alpha, V, adot, xs[0], 0.5 * h, tabs[0], tabs[1])
    lever = sub(scale(col(As, 0), p[L.P_GEOMETRY_COMP_AERO_X]), vec3(y, Y_RS))  # ref point - arm c.g. (as dae_loads)
    v_ref = add(vec3(y, Y_VS), cross(w_s, lever))
    c = comp_separation_relax(p, mtv(As, sub(v_ref, comp_air(u, xs))), mtv(As, w_s), (xs[1], xs[2], xs[3], xs[4]), 0.5 * h, tabs[3], tabs[4])
    for k in range(4):
        y[Y_SEP + 1 + k] = c[k]
    wk = wake_relax(p, u[L.U_AIRSPEED], fa, (xs[5], xs[6]), 0.5 * h)
    y[Y_SEP + 5] = wk[0]
    y[Y_SEP + 6] = wk[1]


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
    if flags & L.F_UNSTEADY:
        half_separation_step_dae(y, u, p, tabs, h)
    xs = (y[Y_SEP], y[Y_SEP + 1], y[Y_SEP + 2], y[Y_SEP + 3], y[Y_SEP + 4], y[Y_SEP + 5], y[Y_SEP + 6])
    y0 = w[W_Y0 : W_Y0 + N_RK]
    yt = w[W_YT : W_YT + N_RK]
    for i in range(32):
        y0[i] = y[i]
    for i in range(14):
        y0[32 + i] = y[Y_SERVO + i]
    for s in range(4):
        k = w[W_K + s * N_RK : W_K + (s + 1) * N_RK]
        if s == 0:
            rhs_dae(y0, tgt, z, xs, ud, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w, k)
        else:
            kp = w[W_K + (s - 1) * N_RK : W_K + s * N_RK]
            c = RK_C[s] * h
            for i in range(N_RK):
                yt[i] = y0[i] + c * kp[i]
            rhs_dae(yt, tgt, z, xs, ud, u, p, flags, free_idx, n_free, locked, n_locked, tabs, w, k)
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
    for k in range(7):
        if flags & L.F_SERVO:
            xs, vs = sv.project(p, k, y[Y_SERVO + k], y[Y_SERVO_RATE + k])
            y[Y_SERVO + k] = xs
            y[Y_SERVO_RATE + k] = vs
        else:
            y[Y_SERVO + k] = ud[k]
            y[Y_SERVO_RATE + k] = 0.0
    if flags & L.F_UNSTEADY:  # after the servos' limits, as the joint-space integrator
        half_separation_step_dae(y, u, p, tabs, h)
    if flags & L.F_FRICTION:
        qd = current_joint_rates(y)
        for a in range(n_free):
            j = free_idx[a]
            z[j] = fr.advance_bristle(p, j, qd[j], z[j], 0.5 * h)


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
        for k in range(L.N_AERO):
            y[Y_SEP + k] = x[L.X_SEP + k]


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
        for k in range(L.N_AERO):
            x[L.X_SEP + k] = y[Y_SEP + k]


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
            y, y[Y_TARGET : Y_TARGET + 5], y[Y_Z : Y_Z + 5], (y[Y_SEP], y[Y_SEP + 1], y[Y_SEP + 2], y[Y_SEP + 3], y[Y_SEP + 4], y[Y_SEP + 5], y[Y_SEP + 6]),
            y[Y_SERVO : Y_SERVO + 7], U[i], P[i], flags,
            free_idx, n_free, locked, n_locked, tabs, w,
        )
        for k in range(15):
            ACC[i, k] = w[W_ACC + k]
        for b in range(5):
            for d in range(3):
                LOADS[i, 3 * b + d] = loads[b][d]

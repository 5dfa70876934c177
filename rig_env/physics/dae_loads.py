"""Body inertias and the applied loads (gravity, aerodynamics, joint friction and stops) on the DAE's
three bodies, in world axes."""

from __future__ import annotations

from numba import njit

from rig_env.physics import layout as L
from rig_env.physics.aero import comp_aero, hawk_aero_full
from rig_env.physics.dae_layout import Y_RS, Y_VA, Y_VS
from rig_env.physics.dae_rotations import add, body_matrices, col, cross, joint_angles, joint_bases, joint_rates, scale, sub, vec3, world_rates
from rig_env.physics.joint_space import ATTACHED, air_velocity, comp_air, joint_torque

_JIT = dict(cache=True, error_model="numpy", _nrt=False)  # allocation-free kernels: no NRT refcounting


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
    return loads_at(y, Aa, As, z, ATTACHED, flaps, u, p, flags, free_idx, n_free, tabs)


@njit(**_JIT)
def loads_at(y, Aa, As, z, xs, flaps, u, p, flags, free_idx, n_free, tabs):
    """Applied loads (world axes): (f_a, n_a, f_s, n_s, f_r, (fd, md, n)), forces at each c.g. (N), moments
    (N m), and the Hawk's alpha-dot terms (aero.hawk_aero_full, with no acceleration known: the whole c.g.
    acceleration goes through them): force and moment per unit of n . a_a, the Hawk c.g.'s acceleration
    along n (zero without aerodynamics).  xs: the aerodynamic states (7-tuple: flow separation of the Hawk and
    flaps 1-4's panels, F_UNSTEADY; the wake at the compensator, world y and z, m/s, zero without it).

    Gravity on every body; Hawk aero at its c.g. in the Hawk's air (tunnel flow and U_GUST); compensator aero
    force at the arm point A_s [comp_aero_x 0 0]^T plus its moment, on the arm, in the compensator's air
    (tunnel flow, U_GUST_COMP and the Hawk's wake); friction and stop torques of the free joints
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
    zero = (0.0, 0.0, 0.0)
    ad = (zero, zero, zero)
    if flags & L.F_AERO:
        v_air = air_velocity(u)
        nonlin = (flags & L.F_NONLINEAR) != 0
        fa, ta, fd, md, n = hawk_aero_full(
            p, Aa, vec3(y, Y_VA), w_a, v_air, zero, flaps[4], flaps[5], flaps[6], nonlin, tabs[0], tabs[1], tabs[2],
            (flags & L.F_UNSTEADY) != 0, xs[0],
        )
        ad = (fd, md, n)
        f_a = add(f_a, fa)
        n_a = add(n_a, ta)
        lever = sub(scale(col(As, 0), p[L.P_GEOMETRY_COMP_AERO_X]), vec3(y, Y_RS))  # ref point - arm c.g.
        v_ref = add(vec3(y, Y_VS), cross(w_s, lever))
        fc, tc = comp_aero(p, As, v_ref, w_s, comp_air(u, xs), flaps, nonlin, tabs[3], tabs[4], False, (flags & L.F_UNSTEADY) != 0,
                           (xs[1], xs[2], xs[3], xs[4]))
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
    return f_a, n_a, f_s, n_s, f_r, ad


"""Surface servos: transport delay, position limit, second-order lag with a rate limit.

For each of the seven actuators (four compensator flaps after mixing, three Hawk surfaces):

    u_d(t) = clip(u(t - delay), -limit, +limit)
    x'  = v
    v'  = wn^2 (u_d - x) - 2 zeta wn v,  held at 0 while |v| is at the rate limit and pushing outward

and after every physics step v is clipped to +-rate_limit and x to +-limit (a hard stop, v set to 0).
The delay is a whole number of physics steps (rounded to the nearest; reported by the simulator).
"""

from __future__ import annotations


from rig_env.physics import layout as L
from rig_env.physics.aero import mix
from rig_env.physics.llvm_inline import inlined
from rig_env.physics.vec import FASTMATH

_JIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=False)

# group parameter offsets: servo k < 4 is a compensator flap, k >= 4 a Hawk surface
_COMP = L.P_SERVOS_COMPENSATOR_DELAY_S
_HAWK = L.P_SERVOS_HAWK_DELAY_S
_DELAY, _RATE, _LIMIT, _FREQ, _ZETA = 0, 1, 2, 3, 4
TWO_PI = 6.283185307179586


@inlined(ir_fallback=False, **_JIT)
def group(k):
    return _COMP if k < 4 else _HAWK


@inlined(ir_fallback=False, **_JIT)
def demand(u, k):
    """Actuator k's demand (rad) from the surface commands u (rig_env.SURFACES order)."""
    if k < 4:
        return mix(u[L.U_COMP_AILERON], u[L.U_COMP_ELEVATOR], u[L.U_COMP_RUDDER], k)
    if k == 4:
        return u[L.U_HAWK_ELEVATOR]
    if k == 5:
        return u[L.U_HAWK_AILERON]
    return u[L.U_HAWK_RUDDER]


@inlined(ir_fallback=False, **_JIT)
def limited(p, k, d):
    lim = p[group(k) + _LIMIT]
    return min(lim, max(-lim, d))


@inlined(ir_fallback=False, **_JIT)
def accel(p, k, ud, x, v):
    """v' of actuator k for delayed, limited demand ud, position x and rate v."""
    g = group(k)
    wn = TWO_PI * p[g + _FREQ]
    a = wn * wn * (ud - x) - 2.0 * p[g + _ZETA] * wn * v
    rmax = p[g + _RATE]
    if (v >= rmax and a > 0.0) or (v <= -rmax and a < 0.0):
        return 0.0
    return a


@inlined(ir_fallback=False, **_JIT)
def project(p, k, x, v):
    """Rate and position limits applied after a physics step; returns (x, v)."""
    g = group(k)
    rmax = p[g + _RATE]
    lim = p[g + _LIMIT]
    v = min(rmax, max(-rmax, v))
    if x > lim:
        return lim, min(v, 0.0)
    if x < -lim:
        return -lim, max(v, 0.0)
    return x, v


@inlined(ir_fallback=False, **_JIT)
def derivatives(y, i_pos, i_rate, ud, p, flags, out, o_pos, o_rate):
    """Servo state derivatives: out[o_pos+k] = x_k', out[o_rate+k] = v_k' from y[i_pos+k], y[i_rate+k].

    Without servo dynamics (flags lacks F_SERVO) the servo states are not integrated: derivatives 0.
    """
    for k in range(7):
        if flags & L.F_SERVO:
            out[o_pos + k] = y[i_rate + k]
            out[o_rate + k] = accel(p, k, ud[k], y[i_pos + k], y[i_rate + k])
        else:
            out[o_pos + k] = 0.0
            out[o_rate + k] = 0.0

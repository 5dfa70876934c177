"""LuGre gimbal friction, eqs. (19)-(21) of AIAA 2009-5727, one bristle state per joint.

    dZ/dt = v - sigma0 |v| Z / S(v),                       (19)
    S(v)  = Fc + (Fs - Fc) exp(-alpha_f |v|),              (20)
    tau_f = sigma1 exp(-(v/v_d)^2) dZ/dt + sigma0 Z + sigma2 v   (21)

tau_f opposes the joint motion (it enters the joint's generalised force with a minus sign).  The
bristle equation is stiff (time constant S / (sigma0 |v|), 0.2 ms at 1 rad/s with Table 2), so it is
advanced with its exact solution at frozen v over half a physics step on each side of the mechanical
step (Strang splitting, second order), never inside the explicit stages.

exp and expm1 are :mod:`rig_env.physics.vmath`'s (no library calls: the lane kernel vectorises them).
"""

from __future__ import annotations


from rig_env.physics import layout as L
from rig_env.physics import vmath
from rig_env.physics.llvm_inline import inlined
from rig_env.physics.vmath import FASTMATH

_JIT = dict(cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=False)

# offset of joint j's seven LuGre parameters in the parameter vector
FRICTION_BASE = (
    L.P_FRICTION_RIG_ROLL_FS,
    L.P_FRICTION_RIG_PITCH_FS,
    L.P_FRICTION_RIG_YAW_FS,
    L.P_FRICTION_MODEL_PITCH_FS,
    L.P_FRICTION_MODEL_YAW_FS,
)
_FS, _FC, _ALPHA, _VD, _S0, _S1, _S2 = 0, 1, 2, 3, 4, 5, 6


@inlined(ir_fallback=False, **_JIT)
def stribeck(p, j, v):
    """S(v) of eq. (20) for joint j."""
    b = FRICTION_BASE[j]
    fc = p[b + _FC]
    return fc + (p[b + _FS] - fc) * vmath.exp(-p[b + _ALPHA] * abs(v))


@inlined(ir_fallback=False, **_JIT)
def torque(p, j, v, z):
    """Friction torque tau_f of eq. (21) for joint j at rate v (rad/s) and bristle state z (rad)."""
    b = FRICTION_BASE[j]
    s0 = p[b + _S0]
    sv = stribeck(p, j, v)
    vd = p[b + _VD]
    inv = 1.0 / (sv * vd)  # 1 / S(v) and 1 / v_d from one division
    zdot = v - s0 * abs(v) * z * (vd * inv)
    w = v * (sv * inv)  # v / v_d
    tau = p[b + _S1] * vmath.exp(-(w * w)) * zdot + s0 * z + p[b + _S2] * v
    return 0.0 if (v == 0.0) & (z == 0.0) else tau  # a locked joint, or a free one at rest and relaxed (selected, not branched)


@inlined(ir_fallback=False, **_JIT)
def bristle_decay(p, j, v, dt):
    """(a, g) of eq. (19) at rate v held over dt: decay rate a = sigma0 |v| / S(v) (1/s) and
    g = (1 - exp(-a dt)) / a (s), the factor of :func:`advance_bristle_decay`; g = dt in the limit a dt <
    1e-12 (no decay: a locked or resting joint), where its relative error is below 5e-13."""
    a = p[FRICTION_BASE[j] + _S0] * abs(v) / stribeck(p, j, v)
    small = a * dt < 1e-12
    g = -vmath.expm1(-a * dt) / (1.0 if small else a)
    return a, dt if small else g


@inlined(ir_fallback=False, **_JIT)
def advance_bristle_decay(v, z, a, g):
    """Exact solution of eq. (19) over dt with v held constant, from its (a, g) of :func:`bristle_decay`:
    z -> z_ss + (z - z_ss) exp(-a dt), z_ss = v / a, written as z + (v - a z) g, without cancellation and
    without a division or a branch (the lane kernel reuses (a, g) from one half step to the next, and
    that loop then has nothing a vector unit cannot do)."""
    return z + (v - a * z) * g


@inlined(ir_fallback=False, **_JIT)
def advance_bristle(p, j, v, z, dt):
    """Exact solution of eq. (19) over dt with v held constant."""
    a, g = bristle_decay(p, j, v, dt)
    return advance_bristle_decay(v, z, a, g)


@inlined(ir_fallback=False, **_JIT)
def steady_sliding(p, j, v):
    """Steady-state sliding friction S(v) sign(v) + sigma2 v (what eq. 21 tends to at constant v)."""
    b = FRICTION_BASE[j]
    return stribeck(p, j, v) * (1.0 if v > 0 else (-1.0 if v < 0 else 0.0)) + p[b + _S2] * v

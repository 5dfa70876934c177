"""Arctangents for the physics kernels written as inlined, branch-free arithmetic, so loops over them vectorise.

The compensator's eight strips each need an angle of incidence.  With the C library's atan inside
it, the loop over the panels is eight scalar passes (a call cannot be vectorised, and numba has no
vector math library here); with the functions below it has no calls and no jumps, and LLVM computes
the four panels side by side in SIMD lanes (the compensator aerodynamics cost half of what they did).
The algorithm is Cephes' ``atan.c`` (S. L. Moshier, *Methods and Programs for Mathematical Functions*,
1989: its rational approximation and coefficients), with the range reduction selected rather than
branched.

Only where a loop vectorises does this pay: as scalar code inlined in place of a library call,
Cephes-style exp and sin/cos measured no faster than glibc's (exp slower: glibc's is table-driven and
has no division), so the rest of the kernel keeps the C library.

Accuracy (tests/test_vmath.py, against the C library): within 1 ulp (atan) and 2 ulp (atan2).

| function | domain | notes |
|---|---|---|
| ``atan(x)`` | all x | +-pi/2 at +-inf, NaN in, NaN out |
| ``atan2(y, x)`` | finite (y, x) | quadrant from the signs; atan2(0, 0) = 0, atan2(+-0, x < 0) = +pi |
"""

from __future__ import annotations

import math

from numba import njit

from rig_env.physics.vec import FASTMATH

_JIT = dict(cache=True, inline="always", error_model="numpy", fastmath=FASTMATH, _nrt=False)


# ---------------------------------------------------------------- atan (Cephes atan.c)
_T3P8 = 2.41421356237309504880  # tan(3 pi / 8)
_MOREBITS = 6.123233995736765886130e-17  # pi/2 - float(pi/2)
_AP0, _AP1, _AP2, _AP3, _AP4 = (
    -8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
    -1.228866684490136173410e2, -6.485021904942025371773e1,
)  # fmt: skip
_AQ0, _AQ1, _AQ2, _AQ3, _AQ4 = (
    2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
    4.853903996359136964868e2, 1.945506571482613964425e2,
)  # fmt: skip
_PIO2 = 1.57079632679489661923
_PIO4 = 7.85398163397448309616e-1


@njit(**_JIT)
def atan(x):
    """arctan x (rad), in [-pi/2, pi/2]."""
    a = abs(x)
    big = a > _T3P8
    mid = a > 0.66
    # reduced argument: -1/a beyond tan(3pi/8), (a-1)/(a+1) between 0.66 and it, a below
    num = -1.0 if big else (a - 1.0 if mid else a)
    den = a if big else (a + 1.0 if mid else 1.0)
    t = num / den
    y0 = _PIO2 if big else (_PIO4 if mid else 0.0)
    extra = _MOREBITS if big else (0.5 * _MOREBITS if mid else 0.0)
    z = t * t
    p = (((_AP0 * z + _AP1) * z + _AP2) * z + _AP3) * z + _AP4
    q = ((((z + _AQ0) * z + _AQ1) * z + _AQ2) * z + _AQ3) * z + _AQ4
    r = y0 + ((t * (z * p / q) + t) + extra)
    return -r if x < 0.0 else r


@njit(**_JIT)
def atan2(y, x):
    """The angle of the point (x, y) (rad), in [-pi, pi]: atan(y / x) moved to the quadrant of (x, y)."""
    if x == 0.0:
        r = _PIO2 if y > 0.0 else (-_PIO2 if y < 0.0 else 0.0)
        return y if y != y else r  # NaN in, NaN out
    r = atan(y / x)
    if x < 0.0:
        r = r + (math.pi if y >= 0.0 else -math.pi)
    return r

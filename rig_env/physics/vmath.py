"""Elementary functions for the physics kernels as inlined, branch-free arithmetic, so loops over them vectorise.

A call into the C library cannot be vectorised (numba has no vector math library here), so any loop
that contains one runs one element at a time.  Two loops depend on these functions: the compensator's
four panels (:mod:`rig_env.physics.aero`, four lanes of one environment) and the lane kernel
(:mod:`rig_env.physics.lanes`), which computes eight environments side by side and calls every
function of the right-hand side.  The algorithms are Cephes' (S. L. Moshier, *Methods and Programs
for Mathematical Functions*, 1989: ``sin.c``, ``exp.c``, ``log.c``, ``unity.c`` (expm1) and ``atan.c``, their
range reductions and coefficients), with the reductions selected rather than branched.

Accuracy (tests/test_vmath.py, against the C library):

| function | domain | accuracy | notes |
|---|---|---|---|
| ``sincos(x)`` | abs(x) <= 2^30 rad | 2 ulp, 2.3e-16 absolute | three-part Cody-Waite reduction; larger arguments lose bits (never met: joint angles are bounded by the runaway check); NaN, inf -> NaN |
| ``exp(x)`` | all x | 2 ulp | 0 below -708.39 (subnormal range), inf above 709.78 |
| ``expm1(x)`` | all x | 4 ulp | Cephes' rational form for abs(x) <= 0.5, exp(x) - 1 outside |
| ``atan(x)`` | all x | 1 ulp | +-pi/2 at +-inf, NaN in, NaN out |
| ``atan2(y, x)`` | finite (y, x) | 2 ulp | reduced from abs(y), abs(x) directly (no y / x: two divisions in all); quadrant from the signs; atan2(0, 0) = 0, atan2(+-0, x < 0) = +pi |
| ``asin(x)`` | abs(x) <= 1 | 3 ulp | as atan2(x, sqrt((1 - x)(1 + x))) |
| ``log(x)`` | normal x > 0 | 1 ulp | -inf at 0, NaN below 0, inf at inf; subnormal x not reduced (never met: the random streams' uniforms are >= 2^-53) |
"""

from __future__ import annotations

import math
from types import FunctionType, SimpleNamespace

import numpy as np

from rig_env.physics import jit
from rig_env.physics.jit import kernel

FASTMATH = {"contract", "nsz", "arcp", "reassoc"}
"""LLVM fast-math flags of every physics kernel: fused multiply-adds, reassociation, reciprocals and the
sign of zero may change results in the last bits.  Never "nnan"/"ninf"/"fast": the blow-up detection
relies on NaN and inf propagating and on np.isfinite."""

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


@kernel(**_JIT)
def _atan_reduced(num, den, y0, extra):
    """y0 + atan(num / den) (+ extra, the low bits of y0) for abs(num / den) <= tan(pi/8): Cephes' rational form."""
    t = num / den
    z = t * t
    p = (((_AP0 * z + _AP1) * z + _AP2) * z + _AP3) * z + _AP4
    q = ((((z + _AQ0) * z + _AQ1) * z + _AQ2) * z + _AQ3) * z + _AQ4
    return y0 + ((t * (z * p / q) + t) + extra)


@kernel(**_JIT)
def atan(x):
    """arctan x (rad), in [-pi/2, pi/2]."""
    a = abs(x)
    big = a > _T3P8
    mid = a > 0.66
    # reduced argument: -1/a beyond tan(3pi/8), (a-1)/(a+1) between 0.66 and it, a below
    num = -1.0 if big else (a - 1.0 if mid else a)
    den = a if big else (a + 1.0 if mid else 1.0)
    y0 = _PIO2 if big else (_PIO4 if mid else 0.0)
    extra = _MOREBITS if big else (0.5 * _MOREBITS if mid else 0.0)
    r = _atan_reduced(num, den, y0, extra)
    return -r if x < 0.0 else r


@kernel(**_JIT)
def atan2(y, x):
    """The angle of the point (x, y) (rad), in [-pi, pi].

    atan's reduction applied to a = abs(y) / abs(x) without forming that quotient: the reduced argument
    is -abs(x) / abs(y), (abs(y) - abs(x)) / (abs(y) + abs(x)) or abs(y) / abs(x), one division (two in
    all, with the rational form's), no overflow for any finite pair; then moved to the quadrant."""
    a = abs(y)
    b = abs(x)
    big = a > _T3P8 * b
    mid = a > 0.66 * b
    num = -b if big else (a - b if mid else a)
    den = a if big else (a + b if mid else (b if b > 0.0 else 1.0))  # atan2(0, 0) = 0
    y0 = _PIO2 if big else (_PIO4 if mid else 0.0)
    extra = _MOREBITS if big else (0.5 * _MOREBITS if mid else 0.0)
    r = _atan_reduced(num, den, y0, extra)  # atan(a / b) in [0, pi/2]
    r = (math.pi - r) if x < 0.0 else r
    r = -r if y < 0.0 else r
    return r if (x == x) & (y == y) else x + y  # NaN in, NaN out


@kernel(**_JIT)
def asin(x):
    """arcsin x (rad) for abs(x) <= 1, in [-pi/2, pi/2]."""
    return atan2(x, math.sqrt((1.0 - x) * (1.0 + x)))


# ---------------------------------------------------------------- sin, cos (Cephes sin.c)
_PIO4_INV = 1.27323954473516268615  # 4 / pi
_DP1 = 7.85398125648498535156e-1  # pi/4 in three parts, each exact in few bits (Cody-Waite)
_DP2 = 3.77489470793079817668e-8
_DP3 = 2.69515142907905952645e-15
_S0, _S1, _S2, _S3, _S4, _S5 = (
    1.58962301576546568060e-10, -2.50507477628578072866e-8, 2.75573136213857245213e-6,
    -1.98412698295895385996e-4, 8.33333333332211858878e-3, -1.66666666666666307295e-1,
)  # fmt: skip
_C0, _C1, _C2, _C3, _C4, _C5 = (
    -1.13585365213876817300e-11, 2.08757008419747316778e-9, -2.75573141792967388112e-7,
    2.48015872888517045348e-5, -1.38888888888730564116e-3, 4.16666666666665929218e-2,
)  # fmt: skip
SINCOS_MAX = 1073741824.0
"""Up to this abs(x) (2^30 rad) :func:`sincos` is accurate to 2 ulp."""


_PY_SINCOS = None
_NUMPY_FLOOR_MATH = SimpleNamespace(floor=np.floor, inf=math.inf, nan=math.nan)


def _sincos_python(x):
    """:func:`sincos` run as Python (:mod:`rig_env.physics.jit`): its own code, with numba's ``math.floor``
    (a float: inf and NaN pass through, where Python's raises) for every input numba takes."""
    global _PY_SINCOS
    if _PY_SINCOS is None:
        f = sincos.py_func
        _PY_SINCOS = FunctionType(f.__code__, dict(f.__globals__, math=_NUMPY_FLOOR_MATH), f.__name__)
    return _PY_SINCOS(x)


@kernel(python=_sincos_python, **_JIT)
def sincos(x):
    """(sin x, cos x); x in rad."""
    a = abs(x)
    y = math.floor(a * _PIO4_INV)  # octant of a, rounded up to even below so the reduced z is in [-pi/4, pi/4]
    j = int(y if y < 4.0 * SINCOS_MAX else 0.0)  # a NaN or huge octant is not converted (z carries the NaN)
    odd = j & 1
    j += odd
    y += odd
    z = ((a - y * _DP1) - y * _DP2) - y * _DP3
    zz = z * z
    ps = z + z * zz * ((((((_S0 * zz + _S1) * zz + _S2) * zz + _S3) * zz + _S4) * zz + _S5))
    pc = 1.0 - 0.5 * zz + zz * zz * ((((((_C0 * zz + _C1) * zz + _C2) * zz + _C3) * zz + _C4) * zz + _C5))
    j &= 7
    swap = (j & 2) != 0  # octants 2, 6: sin and cos exchange
    s = pc if swap else ps
    c = ps if swap else pc
    s = -s if j >= 4 else s
    c = -c if (j == 2) | (j == 4) else c
    s = -s if x < 0.0 else s
    finite = a < math.inf  # False for inf and NaN
    return (s if finite else math.nan), (c if finite else math.nan)


# ---------------------------------------------------------------- exp (Cephes exp.c), expm1 (unity.c)
_LOG2E = 1.4426950408889634073599
_LN2_HI = 6.93145751953125e-1
_LN2_LO = 1.42860682030941723212e-6
_P0, _P1, _P2 = 1.26177193074810590878e-4, 3.02994407707441961300e-2, 9.99999999999999999910e-1
_Q0, _Q1, _Q2, _Q3 = 3.00198505138664455042e-6, 2.52448340349684104192e-3, 2.27265548208155028766e-1, 2.00000000000000000009e0
EXP_MIN = -708.3964185322641
"""Below this x, :func:`exp` returns 0 (exp(x) would be subnormal)."""
EXP_MAX = 709.782712893384
"""Above this x, :func:`exp` returns inf."""


@jit.intrinsic(python=jit.bits_from_float)
def _bits_from_float(typingctx, x):
    """The int64 holding the IEEE 754 bit pattern of the float64 ``x`` (a register move, no conversion)."""
    from llvmlite import ir
    from numba import types

    sig = types.int64(types.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return sig, codegen


@jit.intrinsic(python=jit.float_from_bits)
def _float_from_bits(typingctx, bits):
    """The float64 whose IEEE 754 bit pattern is the int64 ``bits`` (a register move, no conversion)."""
    from llvmlite import ir
    from numba import types

    sig = types.float64(types.int64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return sig, codegen


@kernel(**_JIT)
def _pade(r):
    """2 r P(r^2) / (Q(r^2) - r P(r^2)) = e^r - 1 for abs(r) <= 0.5 (Cephes' rational approximation)."""
    rr = r * r
    px = r * ((_P0 * rr + _P1) * rr + _P2)
    e = px / ((((_Q0 * rr + _Q1) * rr + _Q2) * rr + _Q3) - px)
    return e + e


@kernel(**_JIT)
def _reduced(x, small):
    """(e^r - 1, n) with x = n ln2 + r, abs(r) <= ln2 / 2, x clamped to [EXP_MIN, EXP_MAX] (NaN -> EXP_MIN: the
    callers select the ends); n = 0 and r = x where ``small``."""
    xc = x if x > EXP_MIN else EXP_MIN  # keeps 2^n a normal number
    xc = xc if xc < EXP_MAX else EXP_MAX
    n = 0.0 if small else math.floor(xc * _LOG2E + 0.5)
    r = (xc - n * _LN2_HI) - n * _LN2_LO
    return _pade(r), n


@kernel(**_JIT)
def _times_two_to(e, n):
    """e 2^n, 2^n built from its exponent bits (n in [-1022, 1024]; 2^1024 only at EXP_MAX, written as 2 * 2^1023)."""
    ni = int(n)
    two_n = _float_from_bits((min(ni, 1023) + 1023) << 52)
    return e * two_n * (2.0 if ni > 1023 else 1.0)


@kernel(**_JIT)
def exp(x):
    """e^x."""
    em, n = _reduced(x, False)
    e = _times_two_to(1.0 + em, n)
    e = 0.0 if x < EXP_MIN else e
    e = math.inf if x > EXP_MAX else e
    return x if x != x else e  # NaN in, NaN out


@kernel(**_JIT)
def expm1(x):
    """e^x - 1, without the cancellation of exp(x) - 1 near 0: Cephes' rational form of e^r - 1 at r = x for
    abs(x) <= 0.5, and 2^n (1 + (e^r - 1)) - 1 after exp's reduction outside (one rational form, whichever
    side is selected)."""
    small = abs(x) <= 0.5
    em, n = _reduced(x, small)
    e = em if small else _times_two_to(1.0 + em, n) - 1.0
    e = -1.0 if x < EXP_MIN else e
    e = math.inf if x > EXP_MAX else e
    return x if x != x else e  # NaN in, NaN out


# ---------------------------------------------------------------- log (Cephes log.c)
_LP0, _LP1, _LP2, _LP3, _LP4, _LP5 = (
    1.01875663804580931796e-4, 4.97494994976747001425e-1, 4.70579119878881725854e0,
    1.44989225341610930846e1, 1.79368678507819816313e1, 7.70838733755885391666e0,
)  # fmt: skip
_LQ0, _LQ1, _LQ2, _LQ3, _LQ4 = (
    1.12873587189167450590e1, 4.52279145837532221105e1, 8.29875266912776603211e1,
    7.11544750618563894466e1, 2.31251620126765340583e1,
)  # fmt: skip
_SQRTH = 0.70710678118654752440  # sqrt(1/2)


@kernel(**_JIT)
def log(x):
    """ln x: x = m 2^e with m in [sqrt(1/2), sqrt(2)) from the exponent bits, ln(1 + z) at z = m - 1 by
    Cephes' rational form z - z^2/2 + z^3 P(z)/Q(z), plus e ln2 in two parts."""
    bits = _bits_from_float(x)
    e = ((bits >> 52) & 0x7FF) - 1022  # x = m 2^e, m in [0.5, 1)
    m = _float_from_bits((bits & 0x000FFFFFFFFFFFFF) | (1022 << 52))
    low = m < _SQRTH
    e = e - 1 if low else e
    m = m + m if low else m
    z = m - 1.0
    zz = z * z
    p = ((((_LP0 * z + _LP1) * z + _LP2) * z + _LP3) * z + _LP4) * z + _LP5
    q = ((((z + _LQ0) * z + _LQ1) * z + _LQ2) * z + _LQ3) * z + _LQ4
    fe = float(e)
    y = z * zz * p / q + fe * _LN2_LO
    r = (z + (y - 0.5 * zz)) + fe * _LN2_HI
    r = r if (x > 0.0) & (x < math.inf) else x  # inf -> inf, NaN -> NaN
    r = -math.inf if x == 0.0 else r
    return math.nan if x < 0.0 else r

"""Branch-free elementary functions for the compiled kernel, so that LLVM vectorises its loops.

numba lowers ``math.atan``, ``math.tan`` and friends to scalar libm calls, which stop LLVM's loop
vectoriser (a loop with such a call runs one point at a time, latency-bound on the call). The
vector-math libraries LLVM knows (Intel SVML, glibc libmvec) are not reachable through the
PyPI builds of llvmlite (``llvmlite.binding.has_svml`` is False and ``-vector-library`` does not
reach the code generator), so the kernel uses these instead: plain arithmetic, FMA-friendly
polynomials and selects (no data-dependent branches), which LLVM turns into AVX2/AVX-512 code
on whatever CPU numba compiles for.

Accuracy: a few units in the last place over the whole double range the kernel can meet (the
tests compare each function with libm over wide ranges); every output of the model is checked
against the numpy reference to 1e-10 relative. The series are the textbook ones with exact
rational coefficients (Taylor series of atan, sin, cos, exp and atanh after range reduction),
truncated where the next term is below 1e-17 of the result.

Valid ranges: sin, cos and tan reduce with a three-part pi/2 (Cody-Waite) and are accurate to
a few ulp for |x| < 1.6e6 rad (the kernel's arguments are angles and bounded Magic Formula
phases); beyond that their absolute error grows like |x| * 1e-16, as a naive reduction's.
"""
from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from identify.model.kernel import cache as kernel_cache  # noqa: F401  (registers the kernel's cache stamp)

_JIT = {"cache": True, "fastmath": False, "error_model": "numpy", "nogil": True}
# small enough for LLVM to inline into the caller's loop (then vectorised); pow (exp of log) is
# not, so numba inlines it (its exp and log calls are then inlined by LLVM)
_JIT_INLINE = {**_JIT, "inline": "always"}

# pi/2 in three parts: PIO2_A and PIO2_B are rounded to 33 bits so k*PIO2_A and k*PIO2_B are
# exact for |k| < 2^20; PIO2_C carries the rest (pi/2 = A + B + C to 1e-37)
PIO2_A = 1.5707963267341256
PIO2_B = 6.077100506303966e-11
PIO2_C = 2.0222662487959506e-21
TWO_OVER_PI = 0.6366197723675814
PI_2 = 1.5707963267948966
PI_6 = 0.5235987755982989
SQRT3 = 1.7320508075688772
TAN_PI_12 = 0.2679491924311227  # 2 - sqrt(3)
LN2_HI = 0.6931471806019545     # ln 2 rounded to 32 bits (k*LN2_HI exact for |k| < 2^21)
LN2_LO = -4.2009150726810846e-11
INV_LN2 = 1.4426950408889634
SQRT_HALF = 0.7071067811865476

# Series coefficients, highest power first (for _horner); each is the exact rational of the
# textbook series rounded once, as the literal 1.0 / 27.0 would be
ATAN_SERIES = tuple((1.0 if k % 4 == 3 else -1.0) / k for k in range(29, 1, -2))  # -1/29 .. 1/3
SIN_SERIES = tuple((1.0 if k % 4 == 3 else -1.0) / math.factorial(k) for k in range(19, 1, -2))
COS_SERIES = tuple((1.0 if k % 4 == 0 else -1.0) / math.factorial(k) for k in range(20, 0, -2))
EXP_SERIES = tuple(1.0 / math.factorial(k) for k in range(14, -1, -1))  # 1/14! .. 1/1!, 1/0!
ATANH_SERIES = tuple(1.0 / k for k in range(25, 1, -2))  # 1/25 .. 1/3


@intrinsic
def _bits_to_float(typingctx, bits):
    """Reinterpret an int64 as a float64 (no conversion)."""
    sig = types.float64(types.int64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())
    return sig, codegen


@intrinsic
def _float_to_bits(typingctx, x):
    """Reinterpret a float64 as an int64 (no conversion)."""
    sig = types.int64(types.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))
    return sig, codegen


@numba.njit(**_JIT)
def _horner(z, coefficients):
    """c[0] z^(n-1) + c[1] z^(n-2) + ... + c[n-1] by Horner's rule (n-1 multiply-adds).

    ``coefficients`` is a constant tuple; LLVM unrolls the loop into the straight chain of
    multiply-adds.
    """
    s = coefficients[0]
    for c in coefficients[1:]:
        s = s * z + c
    return s


@numba.njit(**_JIT)
def _atan_series(u):
    # atan(u) = u - u^3/3 + u^5/5 - ... for |u| <= 2 - sqrt(3); 15 terms reach 1e-18 relative
    z = u * u
    return u - u * z * _horner(z, ATAN_SERIES)


@numba.njit(**_JIT)
def atan(x):
    """Arctangent [rad]; one division, no branches.

    |x| > 1 uses pi/2 - atan(1/|x|); t > 2 - sqrt(3) uses pi/6 + atan((sqrt3 t - 1)/(sqrt3 + t)),
    both folded into one quotient num/den.
    """
    ax = abs(x)
    big = ax > 1.0
    n = 1.0 if big else ax    # t = n / d in [0, 1]
    d = ax if big else 1.0
    mid = n > TAN_PI_12 * d
    num = SQRT3 * n - d if mid else n
    den = SQRT3 * d + n if mid else d
    r = _atan_series(num / den) + (PI_6 if mid else 0.0)
    r = PI_2 - r if big else r
    return -r if x < 0.0 else (x if math.isnan(x) else r)


@numba.njit(**_JIT)
def _reduce(x):
    """x = k pi/2 + r, |r| <= pi/4 -> (r, k mod 4 as a float in {0, 1, 2, 3})."""
    k = np.floor(x * TWO_OVER_PI + 0.5)
    r = x - k * PIO2_A
    r = r - k * PIO2_B
    r = r - k * PIO2_C
    q = k - 4.0 * np.floor(k * 0.25)
    return r, q


@numba.njit(**_JIT)
def _odd(q):
    # quadrant 1 or 3 (one comparison: short-circuit `or` would put a branch in the loop)
    return q - 2.0 * np.floor(q * 0.5) == 1.0


@numba.njit(**_JIT)
def _sin_cos(x):
    """(sin r, cos r, q) of the reduced argument x = k pi/2 + r, |r| <= pi/4, q = k mod 4."""
    r, q = _reduce(x)
    z = r * r
    # sin r = r - r^3/3! + ... to r^19/19! (the next term is below 2e-21)
    s = r - r * z * _horner(z, SIN_SERIES)
    # cos r = 1 - r^2/2! + ... to r^20/20! (the next term is below 1e-19)
    c = 1.0 + z * _horner(z, COS_SERIES)
    return s, c, q


@numba.njit(**_JIT)
def sin(x):
    """Sine of x [rad]."""
    s, c, q = _sin_cos(x)
    v = c if _odd(q) else s
    return -v if q >= 2.0 else v


@numba.njit(**_JIT)
def cos(x):
    """Cosine of x [rad]."""
    s, c, q = _sin_cos(x)
    v = s if _odd(q) else c
    return -v if abs(q - 1.5) < 1.0 else v  # quadrants 1 and 2


@numba.njit(**_JIT)
def tan(x):
    """Tangent of x [rad] (sin/cos of the reduced argument; one division)."""
    s, c, q = _sin_cos(x)
    return (-c / s) if _odd(q) else (s / c)


@numba.njit(**_JIT)
def exp(x):
    """e^x; overflows to inf above 709.78, flushes to 0 below -745 (as libm)."""
    xc = min(max(x, -746.0), 710.0)
    k = np.floor(xc * INV_LN2 + 0.5)
    r = (xc - k * LN2_HI) - k * LN2_LO
    # |r| <= ln2/2: Taylor to r^14/14!
    p = _horner(r, EXP_SERIES)
    # 2^k in two factors so that k down to -1075 and up to 1024 stay representable
    k1 = np.floor(k * 0.5)
    k2 = k - k1
    f1 = _bits_to_float((numba.int64(k1) + 1023) << 52)
    f2 = _bits_to_float((numba.int64(k2) + 1023) << 52)
    v = p * f1 * f2
    return x if math.isnan(x) else v


@numba.njit(**_JIT)
def log(x):
    """Natural logarithm for x > 0 (normal numbers); nan below 0, -inf at 0, inf at inf."""
    bits = _float_to_bits(x)
    e = ((bits >> 52) & 0x7FF) - 1023
    m = _bits_to_float((bits & 0x000FFFFFFFFFFFFF) | 0x3FF0000000000000)  # [1, 2)
    hi = m > 2.0 * SQRT_HALF
    m = 0.5 * m if hi else m                 # [sqrt(1/2), sqrt(2))
    ef = numba.float64(e) + (1.0 if hi else 0.0)
    s = (m - 1.0) / (m + 1.0)                # |s| <= 0.1716
    z = s * s
    # log m = 2 atanh s = 2 (s + s^3/3 + s^5/5 + ...), to s^25/25
    t = _horner(z, ATANH_SERIES)
    v = ef * LN2_HI + (ef * LN2_LO + 2.0 * (s + s * z * t))
    v = math.nan if x < 0.0 else v
    v = -math.inf if x == 0.0 else v
    v = x if (math.isnan(x) | (x == math.inf)) else v
    # subnormal x (below 2.2e-308) is not met by the kernel; it reads as 0 here
    return v


@numba.njit(**_JIT_INLINE)
def pow(x, y):
    """x**y for x >= 0 (exp(y log x)); nan for x < 0 unless y == 0, as numpy's power."""
    v = exp(y * log(x))
    if_zero = 1.0 if y == 0.0 else (0.0 if y > 0.0 else math.inf)
    v = if_zero if x == 0.0 else v
    v = 1.0 if y == 0.0 else v
    return v


@numba.njit(**_JIT)
def sqrt1p2(x):
    """sqrt(1 + x^2): 1/cos(atan(x)) without the two transcendental calls."""
    return math.sqrt(1.0 + x * x)

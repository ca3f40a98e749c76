"""exp and log in plain arithmetic, so that the loops calling them vectorize.

The face loops of the film (:mod:`solver.kernels.film`) evaluate a slip law
and a Bernoulli function on every face, each step: about 24 000 faces on the
default scene-2 grid.  One face is a chain of about 60 dependent operations,
so a scalar loop waits on latency; four faces in one AVX2 register take the
same time as one.  LLVM vectorizes such a loop only if its body has no calls
and no branches it cannot turn into selects, and numba's LLVM has no vector
math library (SVML) to replace ``math.exp`` and ``math.log`` with: a call to
libm keeps the whole loop scalar.  These two functions are written in
operations LLVM vectorizes (polynomials, floor, selects, the bit casts of
:mod:`solver.jit`), inlined into their callers.

:func:`exp_minus`: exp(-y) for y >= 0.  With n = round(y / ln 2) and
r = n ln 2 - y (Cody-Waite: ln 2 in two parts, the first exact in n ln2_hi),
|r| <= ln 2 / 2 and exp(-y) = 2^-n exp(r); exp(r) by its Taylor polynomial
to r^13 (truncation below 2e-18 relative), 2^-n written into the exponent
field.  y is clamped to 708 (exp(-708) = 3.3e-308, the last normal binade).

:func:`log_positive`: ln x for normal, finite x > 0.  x = 2^e m with m in
[sqrt(1/2), sqrt(2)) from the bits, t = (m - 1)/(m + 1), |t| <= 0.1716, and
ln m = 2 atanh(t) = 2 sum_k t^(2k+1)/(2k+1) to t^21 (truncation below 1e-17);
ln x = e ln 2 + ln m.

Both are within 2 ulp of libm over their ranges (``tests/test_elementary.py``
checks 1e5 arguments each).
"""

from __future__ import annotations

import math

from ..jit import bits_of_float, float_from_bits, njit

#: ln 2 in two parts: LN2_HI has 32 significant bits, so n * LN2_HI is exact for |n| < 2^21.
LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
INV_LN2 = 1.0 / math.log(2.0)
#: exp(-y) is taken at most this far (exp(-708) is normal; exp(-745) underflows to zero).
EXP_ARGUMENT_MAX = 708.0
SQRT2 = math.sqrt(2.0)
#: 1/k!, k = 0 .. 13: the Taylor polynomial of exp on |r| <= ln 2 / 2.
_E0, _E1, _E2, _E3, _E4, _E5, _E6, _E7, _E8, _E9, _E10, _E11, _E12, _E13 = (1.0 / math.factorial(k) for k in range(14))
#: 2 / (2k + 1), k = 0 .. 10: ln m = t sum_k (2 / (2k + 1)) t^2k.
_L0, _L1, _L2, _L3, _L4, _L5, _L6, _L7, _L8, _L9, _L10 = (2.0 / (2 * k + 1) for k in range(11))
#: The exponent bias and field of an IEEE 754 binary64 number.
_BIAS = 1023
_MANTISSA = 0x000FFFFFFFFFFFFF
_ONE_BITS = 0x3FF0000000000000


@njit(inline=True)
def exp_minus(y: float) -> float:
    """exp(-y) for 0 <= y (clamped to :data:`EXP_ARGUMENT_MAX`), branch-free."""
    y = min(y, EXP_ARGUMENT_MAX)
    n = math.floor(y * INV_LN2 + 0.5)
    r = (n * LN2_HI - y) + n * LN2_LO
    p = _E12 + r * _E13
    p = _E11 + r * p
    p = _E10 + r * p
    p = _E9 + r * p
    p = _E8 + r * p
    p = _E7 + r * p
    p = _E6 + r * p
    p = _E5 + r * p
    p = _E4 + r * p
    p = _E3 + r * p
    p = _E2 + r * p
    p = _E1 + r * p
    p = _E0 + r * p
    return p * float_from_bits((_BIAS - int(n)) << 52)


@njit(inline=True)
def log_positive(x: float) -> float:
    """ln x for a normal, finite x > 0, branch-free."""
    bits = bits_of_float(x)
    e = (bits >> 52) - _BIAS
    m = float_from_bits((bits & _MANTISSA) | _ONE_BITS)  # in [1, 2)
    big = m > SQRT2
    m = 0.5 * m if big else m
    k = float(e + 1) if big else float(e)
    t = (m - 1.0) / (m + 1.0)
    s = t * t
    p = _L9 + s * _L10
    p = _L8 + s * p
    p = _L7 + s * p
    p = _L6 + s * p
    p = _L5 + s * p
    p = _L4 + s * p
    p = _L3 + s * p
    p = _L2 + s * p
    p = _L1 + s * p
    p = _L0 + s * p
    return k * LN2_HI + (k * LN2_LO + t * p)

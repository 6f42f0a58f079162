"""numba kernel of the receiver noise of the air step (wrapped in :func:`rfsim.noise.add_awgn`).

The kernel draws ``Generator.standard_normal`` of a PCG64 generator itself, from the
generator's 128-bit state, so that each draw is a few instructions instead of a call through
the bit generator's interface (≈ 6 ns per draw instead of ≈ 11 ns):

* PCG64 (O'Neill 2014, "PCG: A family of simple fast space-efficient statistically good
  algorithms for random number generation", XSL-RR 128/64; NumPy ``pcg64.h``): the state
  s advances as s ← s·M + inc (mod 2¹²⁸), M = 0x2360ED051FC65DA44385DF649FCCF645, and each
  64-bit output is rotr64(hi(s) ⊕ lo(s), s >> 122) of the advanced state; a uniform double is
  (output >> 11)·2⁻⁵³.
* the standard normal: NumPy's ziggurat ``random_standard_normal`` (256 layers, tables and
  constants as numba compiles it, ``numba.np.random``), line for line.

So the kernel draws the same numbers, in the same order, as ``rng.standard_normal(out=ab)``
and leaves the generator in the same state (the wrapper writes the state back). The
plain-NumPy reference is :func:`rfsim.noise.add_awgn_reference`; the tests compare the two
bit for bit, the ziggurat's rare branches included.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic
from numba.np.random._constants import fi_double, ki_double, wi_double, ziggurat_nor_inv_r, ziggurat_nor_r

from rfsim._jit import njit

#: PCG64's 128-bit multiplier M as (high, low) 64-bit halves (NumPy ``PCG_DEFAULT_MULTIPLIER_128``)
PCG64_MULTIPLIER = (0x2360ED051FC65DA4, 0x4385DF649FCCF645)

_MASK64 = (1 << 64) - 1
_TO_DOUBLE = 1.0 / 9007199254740992.0  # 2⁻⁵³


@intrinsic
def _mul128(typingctx, a_hi, a_lo, b_hi, b_lo):
    """(a·b) mod 2¹²⁸ of two 128-bit numbers given as uint64 halves → (high, low)."""
    sig = types.UniTuple(types.uint64, 2)(types.uint64, types.uint64, types.uint64, types.uint64)

    def codegen(context, builder, signature, args):
        i128 = ir.IntType(128)
        sixty_four = ir.Constant(i128, 64)

        def joined(hi, lo):
            return builder.or_(builder.shl(builder.zext(hi, i128), sixty_four), builder.zext(lo, i128))

        p = builder.mul(joined(args[0], args[1]), joined(args[2], args[3]))
        hi = builder.trunc(builder.lshr(p, sixty_four), ir.IntType(64))
        lo = builder.trunc(p, ir.IntType(64))
        return context.make_tuple(builder, signature.return_type, (hi, lo))

    return sig, codegen


@njit
def _next64(s_hi, s_lo, inc_hi, inc_lo):
    """PCG64 step of the state (s_hi, s_lo) with increment (inc_hi, inc_lo), all uint64:
    ``(output, s_hi, s_lo)`` of the advanced state (module docstring). The state is passed
    by value so that it stays in registers."""
    hi, lo = _mul128(s_hi, s_lo, np.uint64(PCG64_MULTIPLIER[0]), np.uint64(PCG64_MULTIPLIER[1]))
    s_lo = lo + inc_lo
    carry = np.uint64(1) if s_lo < lo else np.uint64(0)
    s_hi = hi + inc_hi + carry
    x = s_hi ^ s_lo
    rot = s_hi >> np.uint64(58)
    return (x >> rot) | (x << ((np.uint64(64) - rot) & np.uint64(63))), s_hi, s_lo


@njit
def _standard_normal(s_hi, s_lo, inc_hi, inc_lo):
    """One standard normal from the PCG64 state: ``(x, s_hi, s_lo)``; NumPy's ziggurat line for
    line, its uniform doubles (output >> 11)·2⁻⁵³."""
    while True:
        r, s_hi, s_lo = _next64(s_hi, s_lo, inc_hi, inc_lo)
        idx = r & np.uint64(0xff)
        r >>= np.uint64(8)
        sign = r & np.uint64(1)
        rabs = (r >> np.uint64(1)) & np.uint64(0x000fffffffffffff)
        x = rabs * wi_double[idx]
        if sign & np.uint64(1):
            x = -x
        if rabs < ki_double[idx]:
            return x, s_hi, s_lo
        if idx == 0:
            while True:
                u, s_hi, s_lo = _next64(s_hi, s_lo, inc_hi, inc_lo)
                xx = -ziggurat_nor_inv_r * np.log1p(-(np.float64(u >> np.uint64(11)) * _TO_DOUBLE))
                u, s_hi, s_lo = _next64(s_hi, s_lo, inc_hi, inc_lo)
                yy = -np.log1p(-(np.float64(u >> np.uint64(11)) * _TO_DOUBLE))
                if yy + yy > xx * xx:
                    if (rabs >> np.uint64(8)) & np.uint64(1):
                        return -(ziggurat_nor_r + xx), s_hi, s_lo
                    return ziggurat_nor_r + xx, s_hi, s_lo
        else:
            u, s_hi, s_lo = _next64(s_hi, s_lo, inc_hi, inc_lo)
            if ((fi_double[idx - 1] - fi_double[idx]) * (np.float64(u >> np.uint64(11)) * _TO_DOUBLE)
                    + fi_double[idx]) < np.exp(-0.5 * x * x):
                return x, s_hi, s_lo


@njit
def _normal(s_hi, s_lo, inc_hi, inc_lo):
    """:func:`_standard_normal` with its common case (≈ 99 % of draws: the point falls inside
    its layer's rectangle) first, on its own, so that the compiler keeps it short; any other
    case draws again from the same state through :func:`_standard_normal`."""
    r, n_hi, n_lo = _next64(s_hi, s_lo, inc_hi, inc_lo)
    idx = r & np.uint64(0xff)
    r >>= np.uint64(8)
    rabs = (r >> np.uint64(1)) & np.uint64(0x000fffffffffffff)
    if rabs < ki_double[idx]:
        x = rabs * wi_double[idx]
        return (-x if r & np.uint64(1) else x), n_hi, n_lo
    return _standard_normal(s_hi, s_lo, inc_hi, inc_lo)


@njit
def standard_normal_kernel(st, out):
    """Fill ``out`` (flat float64) with standard normals, in order, from the PCG64 state
    ``st`` = [s_hi, s_lo, inc_hi, inc_lo] (uint64; advanced in place)."""
    s_hi, s_lo, inc_hi, inc_lo = st[0], st[1], st[2], st[3]
    for i in range(out.size):
        out[i], s_hi, s_lo = _normal(s_hi, s_lo, inc_hi, inc_lo)
    st[0], st[1] = s_hi, s_lo


@njit
def add_awgn_kernel(st, y, ab, scale):
    """Draw ``ab`` (2, n) from the PCG64 state ``st`` (as :func:`standard_normal_kernel`; row 0
    then row 1, in order), scale it by ``scale`` and add it to complex ``y`` (n,):
    ``y += ab[0] + j·ab[1]``, each part added on its own (``y.real += ab[0]; y.imag += ab[1]``)."""
    n = y.size
    s_hi, s_lo, inc_hi, inc_lo = st[0], st[1], st[2], st[3]
    for i in range(n):
        ab[0, i], s_hi, s_lo = _normal(s_hi, s_lo, inc_hi, inc_lo)
    for i in range(n):
        ab[1, i], s_hi, s_lo = _normal(s_hi, s_lo, inc_hi, inc_lo)
    st[0], st[1] = s_hi, s_lo
    for i in range(n):
        a = ab[0, i] * scale
        b = ab[1, i] * scale
        ab[0, i] = a
        ab[1, i] = b
        v = y[i]
        y[i] = complex(v.real + a, v.imag + b)


@njit
def add_awgn_inplace_kernel(st, y, a, scale):
    """:func:`add_awgn_kernel` without keeping the draws: ``a`` (n,) is scratch for the real
    parts (all drawn before the imaginary parts); each imaginary part is added as it is
    drawn. The same draws, products and sums."""
    n = y.size
    s_hi, s_lo, inc_hi, inc_lo = st[0], st[1], st[2], st[3]
    for i in range(n):
        a[i], s_hi, s_lo = _normal(s_hi, s_lo, inc_hi, inc_lo)
    for i in range(n):
        b, s_hi, s_lo = _normal(s_hi, s_lo, inc_hi, inc_lo)
        v = y[i]
        y[i] = complex(v.real + a[i] * scale, v.imag + b * scale)
    st[0], st[1] = s_hi, s_lo


def pcg64_state(bit_generator) -> tuple[np.ndarray, dict]:
    """``([s_hi, s_lo, inc_hi, inc_lo] uint64, the state dict)`` of a PCG64 bit generator."""
    d = bit_generator.state
    s = d["state"]
    v, inc = s["state"], s["inc"]
    return np.array([v >> 64, v & _MASK64, inc >> 64, inc & _MASK64], dtype=np.uint64), d


def set_pcg64_state(bit_generator, st: np.ndarray, d: dict) -> None:
    """Write the advanced 128-bit state ``st`` back into ``bit_generator`` (its buffered
    32-bit output, ``has_uint32``/``uinteger`` of the dict ``d``, untouched: the normals do not
    use it)."""
    hi, lo = int(st[0]), int(st[1])
    d["state"]["state"] = (hi << 64) | lo
    bit_generator.state = d

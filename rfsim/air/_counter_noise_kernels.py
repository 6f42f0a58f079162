"""numba kernels of the counter-based normal generator (:mod:`rfsim.air.noise`).

Normal number j of the stream with 64-bit key k (the algorithm; NumPy twin in
tests/reference/counter_noise.py, the same operations in the same order):

1. **Counter hash (SplitMix64).** h(k, c) = mix(k + (c + 1)·γ mod 2⁶⁴) with γ =
   0x9E3779B97F4A7C15 and mix the SplitMix64 finaliser (Steele, Lea & Flood 2014, "Fast
   splittable pseudorandom number generators", OOPSLA; variant 13 of Stafford's mixers):
   z ← (z ⊕ z≫30)·0xBF58476D1CE4E5B9, z ← (z ⊕ z≫27)·0x94D049BB133111EB, z ⊕ z≫31. For a
   fixed key, c ↦ h(k, c) is the SplitMix64 sequence itself (it passes BigCrush); every value
   is a function of (k, c) alone, so any subset of the stream is drawn without the others.
   Keys k and k + d·γ give the same values d counters apart: keys are random 64-bit draws
   (:func:`rfsim.air.noise.noise_key`), so K streams of L values overlap with probability
   ≈ K²·L/2⁶⁴ (10⁶ streams of 10⁵ values: 5·10⁻⁹).
2. **Pairs.** Normals 2p and 2p + 1 come from the pair p: u = 2 − m₁ ∈ (0, 1] with m₁ ∈ [1, 2)
   the float64 of exponent 0 and the 52 high bits of h(k, 2p) as mantissa (m₁ = 1 + ⌊h/2¹²⌋·2⁻⁵²),
   and w = h(k, 2p + 1).
3. **Box–Muller** (Box & Muller 1958): r = √(−2·ln u); the angle θ uniform on [0, 2π) is
   formed as the image of φ = (π/4)·f, f = ⌊w/2¹²⌋·2⁻⁵² ∈ [0, 1) (52 bits), under the octant
   symmetry chosen by the 3 low bits of w (bit 0: sign of the first, bit 1: sign of the
   second component, bit 2: cos and sin swapped). The 8 images of [0, π/4) under these
   symmetries tile the circle, so θ is uniform and (r·cos θ, r·sin θ) are two independent
   standard normals. The largest |z| is √(2·52·ln 2) = 8.49 (P(|z| > 8.49) ≈ 2·10⁻¹⁷). Every
   step is a bit operation or a float operation without a branch (bit casts, selects), so
   the loops vectorise.
4. **Elementary functions as polynomials** (vectorisable, no library calls): ln u from the
   exponent and mantissa of u (bit casts), ln m = 2·atanh(s), s = (m − 1)/(m + 1), m ∈
   [√½, √2), the halving where m > √2 a select (|s| ≤ 0.1716: the series to s²¹ leaves < 10⁻¹⁸ relative); cos φ and sin φ on
   [0, π/4] by their Taylor series to φ¹⁶ and φ¹⁵ (remainder < 10⁻¹⁷), in Horner form.

No division can be by zero (m + 1 ≥ 1.7), so the kernels use ``error_model="numpy"``
(:func:`rfsim.core._jit.njit_vector`), which lets the loops vectorise.

How the kernels run (the numbers above are not changed by it): the loops form the finaliser's
argument k + (c + 1)·γ by adding 2γ per pair (mod 2⁶⁴, :func:`first_counter`) instead of
multiplying per counter, the same integers with one of the three 64-bit products per hash fewer
(AVX2 has no 64-bit vector multiply; each is three 32-bit ones). One pair-by-pair loop is
bound by the latency of the logarithm's chain (division, ten Horner steps, square root: ≈ 110
cycles, longer than the out-of-order window covers), not by its operations, so the kernels
draw blocks of :data:`BLOCK` pairs in stages (:func:`normals_block`): the hashes, u and φ in one
loop, the radii with four independent chains per step, the normals with two, then the sum. Each
stage loop is vectorised 4 wide on AVX2 (ymm registers; ``<4 x double>`` in the LLVM IR).
Measured on an AVX2 machine (Zen 3, 2.45 GHz, shared; CPU time, both versions in one process,
21 alternating rounds of 100 calls): a pair added to a sample in 8.9 / 7.7 ns (1,508 / 7,109
samples) against 10.3 / 9.7 ns for one loop per pair with a product per counter (median ratio
of the rounds 0.86 / 0.80).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from rfsim.core._jit import njit_inline, njit_vector

GAMMA = np.uint64(0x9E3779B97F4A7C15)
_TWO_GAMMA = np.uint64(0x3C6EF372FE94F82A)  # 2γ mod 2⁶⁴
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S12, _S52, _S63 = (np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(12), np.uint64(52),
                                      np.uint64(63))
_ZERO, _ONE = np.uint64(0), np.uint64(1)
_MANT = np.uint64(0x000FFFFFFFFFFFFF)
_EXP1 = np.uint64(0x3FF0000000000000)
_SQRT2 = 1.4142135623730951
_LN2_HI = 6.93147180369123816490e-01  # fdlibm's split of ln 2: LN2_HI + LN2_LO
_LN2_LO = 1.90821492927058770002e-10
_QUARTER_PI = 0.7853981633974483


@intrinsic
def _f64_bits(typingctx, x):
    """The IEEE 754 bits of a float64 as a uint64 (a bit cast)."""
    sig = types.uint64(types.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return sig, codegen


@intrinsic
def _bits_f64(typingctx, x):
    """The float64 with the IEEE 754 bits of a uint64 (a bit cast)."""
    sig = types.float64(types.uint64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return sig, codegen


@njit_inline
def mix(z):
    """The SplitMix64 finaliser of the module docstring (uint64 in, uint64 out)."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@njit_inline
def splitmix(key, c):
    """h(k, c) of the module docstring (uint64 in, uint64 out)."""
    return mix(key + (c + _ONE) * GAMMA)


@njit_inline
def first_counter(key, p0):
    """k + (2·p0 + 1)·γ mod 2⁶⁴: the argument of the finaliser for h(k, 2·p0), the first hash
    of pair p0; the pair p0 + i has k + (2·p0 + 1)·γ + i·2γ (mod 2⁶⁴), its second hash that plus γ."""
    return key + (p0 + p0 + _ONE) * GAMMA


#: Horner coefficients in s² of (atanh(s)/s − 1)/s² = Σ s^(2k−2)/(2k+1), k = 1…10 (highest first)
LOG_SERIES = tuple(1.0 / d for d in (21.0, 19.0, 17.0, 15.0, 13.0, 11.0, 9.0, 7.0, 5.0, 3.0))
#: Horner coefficients in φ² of cos φ (to φ¹⁶) and of (sin φ − φ)/φ³ (to φ¹⁵), highest first
COS_SERIES = (1.0 / 20922789888000.0, -1.0 / 87178291200.0, 1.0 / 479001600.0, -1.0 / 3628800.0, 1.0 / 40320.0,
              -1.0 / 720.0, 1.0 / 24.0, -0.5, 1.0)
SIN_SERIES = (-1.0 / 1307674368000.0, 1.0 / 6227020800.0, -1.0 / 39916800.0, 1.0 / 362880.0, -1.0 / 5040.0,
              1.0 / 120.0, -1.0 / 6.0)


@njit_inline
def horner(coefs, x):
    """Σ coefs[k]·x^(K−k), K = len(coefs) − 1, by Horner's rule (one product and one sum per
    coefficient after the first)."""
    p = coefs[0]
    for c in coefs[1:]:
        p = p * x + c
    return p


@njit_inline
def log_unit(u):
    """ln u for u ∈ [2⁻⁵², 1] (module docstring, step 4)."""
    bits = _f64_bits(u)
    m = _bits_f64((bits & _MANT) | _EXP1)
    big = m > _SQRT2
    m = m * (0.5 if big else 1.0)
    ef = float(np.int64(bits >> _S52) - (1022 if big else 1023))
    s = (m - 1.0) / (m + 1.0)
    s2 = s * s
    p = horner(LOG_SERIES, s2)
    return ef * _LN2_HI + (2.0 * s + (2.0 * s * s2 * p + ef * _LN2_LO))


@njit_inline
def cos_sin_octant(phi):
    """(cos φ, sin φ) for φ ∈ [0, π/4] (module docstring, step 4)."""
    x2 = phi * phi
    return horner(COS_SERIES, x2), phi + phi * x2 * horner(SIN_SERIES, x2)


@njit_inline
def unit_and_angle(h1, w):
    """u ∈ (0, 1] and φ ∈ [0, π/4) of a pair from its hashes h1 = h(k, 2p) and w = h(k, 2p + 1)
    (module docstring, steps 2–3)."""
    u = 2.0 - _bits_f64((h1 >> _S12) | _EXP1)
    return u, (_bits_f64((w >> _S12) | _EXP1) - 1.0) * _QUARTER_PI


@njit_inline
def radius(u):
    """r = √(−2·ln u) (module docstring, step 3)."""
    return np.sqrt(-2.0 * log_unit(u))


@njit_inline
def octant_normals(r, phi, w):
    """The two normals r·cos θ, r·sin θ of a pair from its radius r, its angle φ in the first
    octant and the octant bits of w = h(k, 2p + 1) (module docstring, step 3)."""
    c, s = cos_sin_octant(phi)
    swap = (w & np.uint64(4)) != _ZERO
    a = s if swap else c
    b = c if swap else s
    a = _bits_f64(_f64_bits(a) ^ ((w & _ONE) << _S63))  # the sign flipped by bit 0
    b = _bits_f64(_f64_bits(b) ^ (((w >> _ONE) & _ONE) << _S63))  # and by bit 1
    return r * a, r * b


@njit_inline
def normal_pair(h1, w):
    """Normals 2p and 2p + 1 of a stream from the hashes h1 = h(k, 2p) and w = h(k, 2p + 1)
    (module docstring, steps 2–3)."""
    u, phi = unit_and_angle(h1, w)
    return octant_normals(radius(u), phi, w)


#: Pairs per block of the kernels' stage loops (three buffers of 4 KiB: in the L1 cache)
BLOCK = 512


@njit_inline
def _radii(u, k):
    """u[j] ← :func:`radius` (u[j]) for j < k, the four quarters of ``u[:k]`` interleaved (four
    independent chains per step of the loop) and the k mod 4 last ones after."""
    q = k // 4
    u0, u1, u2, u3 = u[:q], u[q:2 * q], u[2 * q:3 * q], u[3 * q:4 * q]
    for j in range(q):
        x0, x1, x2, x3 = u0[j], u1[j], u2[j], u3[j]
        u0[j] = radius(x0)
        u1[j] = radius(x1)
        u2[j] = radius(x2)
        u3[j] = radius(x3)
    for j in range(4 * q, k):
        u[j] = radius(u[j])


@njit_inline
def _octants(r, phi, w, k):
    """(r[j], phi[j]) ← :func:`octant_normals` (r[j], phi[j], w[j]) for j < k, the two halves of
    the block interleaved (as in :func:`_radii`) and the odd last one after."""
    h = k // 2
    r0, r1, p0, p1, w0, w1 = r[:h], r[h:2 * h], phi[:h], phi[h:2 * h], w[:h], w[h:2 * h]
    for j in range(h):
        a0, b0 = octant_normals(r0[j], p0[j], w0[j])
        a1, b1 = octant_normals(r1[j], p1[j], w1[j])
        r0[j], p0[j] = a0, b0
        r1[j], p1[j] = a1, b1
    for j in range(2 * h, k):
        r[j], phi[j] = octant_normals(r[j], phi[j], w[j])


@njit_inline
def normals_block(z, k, a, b, w):
    """The normals of the k pairs whose first hash's finaliser argument is z, z + 2γ, …
    (:func:`first_counter`), in stages over the block: the hashes, u and φ (one loop), the
    radii (:func:`_radii`), the normals (:func:`_octants`); a[j], b[j] the pair j (``a``, ``b``
    float64, ``w`` uint64 scratch, each ≥ k long). Returns the argument of the next pair.

    The same operations on each pair as :func:`normal_pair`, so the same bits; the stages'
    independent chains let the CPU overlap the long latency of the logarithm (division,
    Horner sum, square root) that bounds one pair-by-pair loop."""
    for j in range(k):
        h1 = mix(z)
        wj = mix(z + GAMMA)
        z = z + _TWO_GAMMA
        a[j], b[j] = unit_and_angle(h1, wj)
        w[j] = wj
    _radii(a, k)
    _octants(a, b, w, k)
    return z


@njit_inline
def _noise_blocks(key, p0, y, scale, add):
    """y[i] ← scale·(a + j·b) (``add`` false) or y[i] + scale·(a + j·b) (``add`` true) with
    (a, b) the pair p0 + i of the stream ``key``, block by block (:func:`normals_block`)."""
    n = y.size
    m = min(n, BLOCK)
    scratch = np.empty(3 * m)  # one allocation for the three buffers (a call's fixed cost)
    a, b, w = scratch[:m], scratch[m:2 * m], scratch[2 * m:].view(np.uint64)
    z = first_counter(key, p0)
    for s0 in range(0, n, BLOCK):
        k = min(n - s0, BLOCK)
        z = normals_block(z, k, a, b, w)
        if add:
            for j in range(k):
                v = y[s0 + j]
                y[s0 + j] = complex(v.real + scale * a[j], v.imag + scale * b[j])
        else:
            for j in range(k):
                y[s0 + j] = complex(scale * a[j], scale * b[j])


@njit_vector
def normals_kernel(key, p0, out):
    """out[2i], out[2i+1] = normals 2(p0 + i), 2(p0 + i) + 1 of the stream ``key``; ``out``
    (2n,) float64 (``key``, ``p0``: uint64); written through its complex128 view (the pair i
    as element i; 1·x = x exactly)."""
    _noise_blocks(key, p0, out[:out.size // 2 * 2].view(np.complex128), 1.0, False)


@njit_vector
def add_noise_kernel(key, i0, y, scale):
    """y[i] += scale·(a + j·b) with (a, b) the normal pair i0 + i of the stream ``key``, for
    every i of ``y`` ((n,) complex128, in place; sample i of a segment always gets pair i,
    whichever samples are drawn). ``key``, ``i0``: uint64."""
    _noise_blocks(key, i0, y, scale, True)

"""numba kernel of the receiver noise of the air step (wrapped in :func:`rfsim.air.noise.add_awgn`).

The kernel draws NumPy's standard normals itself, with NumPy's own algorithms written out
(numpy/random/src/pcg64/pcg64.h, numpy/random/src/distributions/distributions.c):

* **PCG64** (O'Neill, "PCG: a family of simple fast space-efficient statistically good
  algorithms for random number generation", 2014; XSL-RR 128/64): the 128-bit state
  s ← s·M + inc (mod 2^128), M = 2549297995355413924·2^64 + 4865540595714422341, then the
  output rotr64(hi(s) ⊕ lo(s), hi(s) >> 58) of the new state; s and inc as (hi, lo)
  uint64 words, the 64 × 64 → 128-bit product of the low words one widening multiply;
  ``next_double`` = (u64 >> 11)·2^−53.
* **Ziggurat** (Marsaglia & Tsang 2000, NumPy's 256-layer variant ``random_standard_normal``):
  idx = u & 0xff, the sign bit u >> 8 & 1, |x| = ((u >> 9) & (2^52 − 1))·w[idx], accepted
  when (u >> 9) & (2^52 − 1) < k[idx] (≈ 99.3 %), else the wedge test with f[idx−1], f[idx]
  or, for idx 0, the tail beyond r = 3.6541528853610088 from two ``next_double`` draws.
  The tables k, w, f are NumPy's (ziggurat_constants.h, as numba ships them in
  ``numba.np.random._constants``). The sign is applied as a product with ±1.0 (exact, the
  same value as the negation) so that the random sign costs no branch.

The draws are the numbers, in the same order, that ``rng.standard_normal(out=ab)`` gives, and
the generator's state afterwards is the one NumPy leaves (read from and written back to
``rng.bit_generator.state``; its buffered 32-bit half is neither used nor changed, as by
NumPy's normals). About twice as fast as NumPy's own, which calls the bit generator through
a function pointer per draw. The plain-NumPy reference is :func:`rfsim.air.noise.add_awgn_reference`;
the tests compare the two bit for bit (values, sums and generator state).

:func:`add_awgn_compiled` calls the kernel's compiled entry point for the one argument kind
the wrapper passes (the dispatcher would otherwise type the arguments anew on every call).
"""

from __future__ import annotations

import numpy as np

from rfsim.core._jit import njit, njit_inline  # before numba itself: it chooses numba's cache folder

from numba import types  # noqa: E402
from numba.extending import intrinsic  # noqa: E402

_MASK52 = np.uint64(0x000FFFFFFFFFFFFF)
_MULT_HI = np.uint64(2549297995355413924)  # PCG64's 128-bit multiplier M, high and low words
_MULT_LO = np.uint64(4865540595714422341)
_ZIG_R = 3.6541528853610087963519472518  # NumPy's ziggurat_nor_r and its inverse
_ZIG_INV_R = 0.27366123732975827203338247596


def _tables() -> tuple:
    """NumPy's ziggurat tables (k: uint64, w, f: float64; 256 layers)."""
    from numba.np.random._constants import fi_double, ki_double, wi_double

    return (np.ascontiguousarray(ki_double, dtype=np.uint64), np.ascontiguousarray(wi_double, dtype=np.float64),
            np.ascontiguousarray(fi_double, dtype=np.float64))


@intrinsic
def _mulhi64(typingctx, a, b):
    """The high 64 bits of the 128-bit product of two uint64 (one widening multiply)."""
    from llvmlite import ir

    def codegen(context, builder, signature, args):
        wide = ir.IntType(128)
        p = builder.mul(builder.zext(args[0], wide), builder.zext(args[1], wide))
        return builder.trunc(builder.lshr(p, ir.Constant(wide, 64)), ir.IntType(64))

    return types.uint64(types.uint64, types.uint64), codegen


@njit_inline
def _next_uint64(st):
    """One PCG64 (XSL-RR 128/64) output; ``st`` = (state hi, state lo, inc hi, inc lo) uint64."""
    sh, sl = st[0], st[1]
    hi = _mulhi64(sl, _MULT_LO)
    lo = sl * _MULT_LO
    hi = hi + sl * _MULT_HI + sh * _MULT_LO  # the cross terms, mod 2^64
    new_lo = lo + st[3]
    new_hi = hi + st[2] + (np.uint64(1) if new_lo < lo else np.uint64(0))
    st[0], st[1] = new_hi, new_lo
    x = new_hi ^ new_lo
    rot = new_hi >> np.uint64(58)
    return (x >> rot) | (x << ((np.uint64(64) - rot) & np.uint64(63)))


@njit_inline
def _next_double(st):
    return np.float64(_next_uint64(st) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit
def _rejected(st, idx, rabs, x, fi):
    """The ziggurat's rare branches: the tail (idx 0, always ends with a value) or the wedge
    test of layer idx. Returns (value, accepted)."""
    if idx == 0:
        while True:
            xx = -_ZIG_INV_R * np.log1p(-_next_double(st))
            yy = -np.log1p(-_next_double(st))
            if yy + yy > xx * xx:
                if ((rabs >> np.uint64(8)) & np.uint64(1)) != np.uint64(0):
                    return -(_ZIG_R + xx), True
                return _ZIG_R + xx, True
    if ((fi[idx - 1] - fi[idx]) * _next_double(st) + fi[idx]) < np.exp(-0.5 * x * x):
        return x, True
    return x, False


@njit_inline
def _standard_normals(st, out, ki, wi, fi):
    """Fill ``out`` (n,) with standard normals from the PCG64 state ``st``, in order."""
    for i in range(out.size):
        while True:
            r = _next_uint64(st)
            idx = np.int64(r & np.uint64(0xFF))
            r = r >> np.uint64(8)
            rabs = (r >> np.uint64(1)) & _MASK52
            x = np.float64(rabs) * wi[idx] * (1.0 - 2.0 * np.float64(r & np.uint64(1)))
            if rabs < ki[idx]:
                break
            x, ok = _rejected(st, idx, rabs, x, fi)
            if ok:
                break
        out[i] = x


@njit
def add_awgn_kernel(st, y, ab, scale, ki, wi, fi):
    """Draw ``ab`` (2, n) from the PCG64 state ``st`` (row 0 then row 1, in order; ``st``
    advanced in place), scale it by ``scale`` and add it to complex ``y`` (n,):
    ``y += ab[0] + j·ab[1]``, each part added on its own (``y.real += ab[0]; y.imag += ab[1]``).
    ``ki``, ``wi``, ``fi``: the ziggurat tables (module docstring)."""
    n = y.size
    _standard_normals(st, ab[0], ki, wi, fi)
    _standard_normals(st, ab[1], ki, wi, fi)
    for i in range(n):
        a = ab[0, i] * scale
        b = ab[1, i] * scale
        ab[0, i] = a
        ab[1, i] = b
        v = y[i]
        y[i] = complex(v.real + a, v.imag + b)


@njit
def skip_normals_kernel(st, n, ki, wi, fi):
    """Advance the PCG64 state ``st`` (in place) past ``n`` standard normals, as drawing them
    would (the ziggurat's rejections included), without keeping them."""
    buf = np.empty(min(n, 1024))  # drawn in blocks (the draws' loop as in add_awgn_kernel)
    done = 0
    while done < n:
        k = min(n - done, buf.size)
        _standard_normals(st, buf[:k], ki, wi, fi)
        done += k


@njit
def add_awgn_inplace_kernel(st, y, a, scale, ki, wi, fi):
    """:func:`add_awgn_kernel` without keeping the draws: ``a`` (n,) is scratch for the real
    parts (all drawn before the imaginary parts, as there); the imaginary parts are drawn in
    blocks and added. The same draws, products and sums, one pass and half the memory less."""
    n = y.size
    _standard_normals(st, a, ki, wi, fi)
    buf = np.empty(min(n, 1024))
    done = 0
    while done < n:
        k = min(n - done, buf.size)
        _standard_normals(st, buf[:k], ki, wi, fi)
        for j in range(k):
            i = done + j
            v = y[i]
            y[i] = complex(v.real + a[i] * scale, v.imag + buf[j] * scale)
        done += k


_ENTRY: dict = {}  # the compiled entry point of each kernel for the wrapper's argument kind
_TABLES: list = []
_WORD = (1 << 64) - 1


def _pcg64_state(rng) -> tuple:
    """(state dict of ``rng.bit_generator``, its PCG64 (4,) uint64 words for the kernels)."""
    full = rng.bit_generator.state
    s = full["state"]
    st = np.array([s["state"] >> 64, s["state"] & _WORD, s["inc"] >> 64, s["inc"] & _WORD], dtype=np.uint64)
    if not _TABLES:
        _TABLES.extend(_tables())
    return full, st


def _set_pcg64_state(rng, full: dict, st: np.ndarray) -> None:
    full["state"]["state"] = (int(st[0]) << 64) | int(st[1])
    rng.bit_generator.state = full


def _run_compiled(kernel, st, *args) -> None:
    """``kernel(st, *args, *tables)`` through its compiled entry point for the wrapper's
    argument kind: the first call goes through the dispatcher (compilation or cache load) and
    keeps the entry point, later calls use it (the dispatcher would type the arguments anew)."""
    entry = _ENTRY.get(kernel)
    full_args = (st, *args, *_TABLES)
    if entry is not None:
        entry(*full_args)
        return
    kernel(*full_args)
    from numba import typeof

    cres = kernel.overloads.get(tuple(typeof(a) for a in full_args))
    # the dispatcher itself where no overload matches: typed once here, not on every call
    _ENTRY[kernel] = kernel if cres is None else cres.entry_point


def add_awgn_compiled(rng, y, ab, scale: float) -> None:
    """:func:`add_awgn_kernel` on ``rng``'s PCG64 state for the argument kind of
    :func:`rfsim.air.noise.add_awgn` (a PCG64 Generator, a writeable aligned C-contiguous
    complex128 (n,) array, a fresh float64 (2, n) array, a float; the caller guarantees it):
    the state is read from ``rng.bit_generator.state``, advanced by the kernel and written
    back."""
    full, st = _pcg64_state(rng)
    _run_compiled(add_awgn_kernel, st, y, ab, scale)
    _set_pcg64_state(rng, full, st)


def add_awgn_inplace_compiled(rng, y, scale: float) -> None:
    """:func:`add_awgn_inplace_kernel` on ``rng``'s PCG64 state (as :func:`add_awgn_compiled`)."""
    full, st = _pcg64_state(rng)
    _run_compiled(add_awgn_inplace_kernel, st, y, np.empty(y.size), scale)
    _set_pcg64_state(rng, full, st)


def skip_normals_compiled(rng, n: int) -> None:
    """:func:`skip_normals_kernel` on ``rng``'s PCG64 state (a PCG64 Generator; read and
    written back as in :func:`add_awgn_compiled`)."""
    full, st = _pcg64_state(rng)
    skip_normals_kernel(st, int(n), *_TABLES)
    _set_pcg64_state(rng, full, st)

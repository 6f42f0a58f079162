"""numba kernel of the air step's one modulating reflector at a receiver (:func:`rfsim.air.step.propagate`).

A receiver on the emitter's carrier with a narrowband, static forward link g, backward link
b and its own coupling (or direct link) c gets, from one emitted segment x and one reflector
re-radiating r(t) = A_s − Γ(t) (:mod:`rfsim.air.step` model; rfsim.devices.tag, Nikitin, Rao & Lam 2006)

    y(t) = c·x(t) + b·((A_s − Γ(t))·(g·x(t)))    [√W],

which NumPy forms with its array operations (``c * x + b * ((a_s - gamma) * (g * x))``), one full-length
array per product. The kernel forms the same products sample by sample, in one pass and
without temporaries. NumPy multiplies complex arrays with fused multiply-adds where the CPU
has them (its SIMD loop: re = fma(a_r, b_r, −a_i·b_i), im = fma(a_r, b_i, a_i·b_r)); the
kernel does the same (:func:`cmul`) so that the sums agree bit for bit, and
:func:`fused_matches_numpy` checks this on the machine at hand before the air step uses the
kernel (else the step keeps NumPy's arithmetic).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from rfsim.core._jit import njit


@intrinsic
def _fma(typingctx, a, b, c):
    """a·b + c rounded once (``llvm.fma.f64``)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        f = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(f, args)

    return sig, codegen


@njit
def cmul(a, b):
    """a·b as NumPy's SIMD complex multiply forms it: (fma(a_r, b_r, −a_i·b_i), fma(a_r, b_i, a_i·b_r))."""
    ar, ai, br, bi = a.real, a.imag, b.real, b.imag
    return complex(_fma(ar, br, -(ai * bi)), _fma(ar, bi, ai * br))


@njit
def cmul_kernel(a, b, out):
    """out = a·b elementwise with :func:`cmul` (the probe of :func:`fused_matches_numpy`)."""
    for i in range(out.size):
        out[i] = cmul(a[i], b[i])


@njit
def backscatter_kernel(x, c, g, a_s, gamma, b, out):
    """out[i] = c·x[i] + b·((a_s − gamma[i])·(g·x[i])) (module docstring; the products in
    NumPy formulation's order)."""
    for i in range(out.size):
        xi = x[i]
        out[i] = cmul(c, xi) + cmul(b, cmul(a_s - gamma[i], cmul(g, xi)))


_MATCHES: list = []


def fused_matches_numpy() -> bool:
    """Whether :func:`cmul` reproduces NumPy's complex product on this machine (checked once,
    on 4099 pairs of values spread over many magnitudes, every length residue of NumPy's
    SIMD loop included)."""
    if not _MATCHES:
        rng = np.random.default_rng(20240601)
        n = 4099
        scale = 10.0 ** rng.uniform(-8, 8, (4, n))
        a = rng.standard_normal(n) * scale[0] + 1j * rng.standard_normal(n) * scale[1]
        bb = rng.standard_normal(n) * scale[2] + 1j * rng.standard_normal(n) * scale[3]
        ok = True
        for k in (n, 1, 2, 3, 5, 7, 13):
            out = np.empty(k, dtype=np.complex128)
            cmul_kernel(a[:k], bb[:k], out)
            ok &= np.array_equal((a[:k] * bb[:k]).view(np.float64), out.view(np.float64))
            cmul_kernel(np.full(k, a[0]), bb[:k], out)
            ok &= np.array_equal((complex(a[0]) * bb[:k]).view(np.float64), out.view(np.float64))
        _MATCHES.append(bool(ok))
    return _MATCHES[0]

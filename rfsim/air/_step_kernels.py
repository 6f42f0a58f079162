"""numba kernel of the air step's one modulating reflector at a receiver (:func:`rfsim.air.step.propagate`).

A receiver on the emitter's carrier with a narrowband, static forward link g, backward link
b and its own coupling (or direct link) c gets, from one emitted segment x and one reflector
re-radiating r(t) = A_s − Γ(t) (:mod:`rfsim.air.step` model; rfsim.devices.tag, Nikitin, Rao & Lam 2006)

    y(t) = c·x(t) + b·((A_s − Γ(t))·(g·x(t)))    [√W],

which NumPy forms with its array operations (``c * x + b * ((a_s - gamma) * (g * x))``), one full-length
array per product. The kernel forms the same products sample by sample, in one pass and
without temporaries. NumPy multiplies complex arrays with fused multiply-adds where the CPU
has them (its SIMD loop: re = fma(a_r, b_r, −a_i·b_i), im = fma(a_r, b_i, a_i·b_r)); the
kernel does the same (:func:`cmul`) so that the sums agree bit for bit there. Whether the
step uses the kernel is the run's explicit choice (:attr:`rfsim.air.cache.Strategy.fused_backscatter`);
tests/test_air_kernels.py compares it with its NumPy twin.
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
    """out = a·b elementwise with :func:`cmul` (compared with NumPy's product in the tests)."""
    for i in range(out.size):
        out[i] = cmul(a[i], b[i])


@njit
def backscatter_kernel(x, c, g, a_s, gamma, b, out):
    """out[i] = c·x[i] + b·((a_s − gamma[i])·(g·x[i])) (module docstring; the products in
    NumPy formulation's order)."""
    for i in range(out.size):
        xi = x[i]
        out[i] = cmul(c, xi) + cmul(b, cmul(a_s - gamma[i], cmul(g, xi)))

"""Reference twin of :mod:`rfsim.air._step_kernels` (the backscatter sum with NumPy's array
operations)."""

from __future__ import annotations

import numpy as np


def backscatter_reference(x: np.ndarray, c: complex, g: complex, a_s: complex, gamma: np.ndarray,
                          b: complex) -> np.ndarray:
    """Plain-NumPy twin of :func:`rfsim.air._step_kernels.backscatter_kernel`: the air step's own
    array operations."""
    y = c * x
    y += b * ((a_s - gamma) * (g * x))
    return y


def numpy_products_fused(cmul_kernel) -> bool:
    """Whether NumPy's complex product equals ``cmul_kernel``'s fused multiply-adds on this
    machine (4099 pairs of values spread over many magnitudes, every length residue of NumPy's
    SIMD loop included): where it does, the kernel and :func:`backscatter_reference` agree bit
    for bit."""
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
    return bool(ok)


__all__ = ["backscatter_reference", "numpy_products_fused"]

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


__all__ = ["backscatter_reference"]

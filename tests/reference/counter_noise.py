"""Reference twin of :mod:`rfsim.air._counter_noise_kernels`: the counter-based normals with
NumPy's array operations (the same operations in the same order: uint64 wrap-around products,
the same polynomials in Horner form)."""

from __future__ import annotations

import math

import numpy as np

GAMMA = np.uint64(0x9E3779B97F4A7C15)


def splitmix(key: int, c: np.ndarray) -> np.ndarray:
    """h(k, c) = SplitMix64's finaliser of k + (c + 1)·γ (mod 2⁶⁴), elementwise over ``c``."""
    with np.errstate(over="ignore"):
        z = np.uint64(key) + (c.astype(np.uint64) + np.uint64(1)) * GAMMA
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))


def _horner(coefs, x: np.ndarray) -> np.ndarray:
    p = np.full_like(x, coefs[0])
    for c in coefs[1:]:
        p = p * x + c
    return p


def log_unit(u: np.ndarray) -> np.ndarray:
    """ln u from exponent and mantissa: 2·atanh((m − 1)/(m + 1)) to s²¹ plus e·ln 2 (split)."""
    bits = u.view(np.uint64)
    m = ((bits & np.uint64(0x000FFFFFFFFFFFFF)) | np.uint64(0x3FF0000000000000)).view(np.float64)
    big = m > 1.4142135623730951
    m = m * np.where(big, 0.5, 1.0)
    ef = ((bits >> np.uint64(52)).astype(np.int64) - np.where(big, 1022, 1023)).astype(np.float64)
    s = (m - 1.0) / (m + 1.0)
    s2 = s * s
    p = _horner([1.0 / d for d in (21.0, 19.0, 17.0, 15.0, 13.0, 11.0, 9.0, 7.0, 5.0, 3.0)], s2)
    return ef * 6.93147180369123816490e-01 + (2.0 * s + (2.0 * s * s2 * p + ef * 1.90821492927058770002e-10))


def cos_sin_octant(phi: np.ndarray) -> tuple:
    """(cos φ, sin φ) on [0, π/4] by Taylor series to φ¹⁶ and φ¹⁵ (Horner in φ²)."""
    x2 = phi * phi
    fact = [float(math.factorial(k)) for k in range(17)]
    cos_c = [(-1.0) ** (k // 2) / fact[k] for k in range(16, -1, -2)]  # φ¹⁶ … φ⁰
    sin_c = [(-1.0) ** ((k - 1) // 2) / fact[k] for k in range(15, 2, -2)]  # φ¹⁵ … φ³, over φ³
    return _horner(cos_c, x2), phi + phi * x2 * _horner(sin_c, x2)


def normal_pairs(key: int, pairs: np.ndarray) -> tuple:
    """(a, b): normals 2p and 2p + 1 of the stream ``key`` for every pair index p."""
    p = pairs.astype(np.uint64)
    h1 = splitmix(key, p + p)
    w = splitmix(key, p + p + np.uint64(1))
    one = np.uint64(0x3FF0000000000000)
    u = 2.0 - ((h1 >> np.uint64(12)) | one).view(np.float64)
    r = np.sqrt(-2.0 * log_unit(u))
    c, s = cos_sin_octant((((w >> np.uint64(12)) | one).view(np.float64) - 1.0) * 0.7853981633974483)
    swap = (w & np.uint64(4)) != 0
    c, s = np.where(swap, s, c), np.where(swap, c, s)
    c = np.where((w & np.uint64(1)) != 0, -c, c)
    s = np.where((w & np.uint64(2)) != 0, -s, s)
    return r * c, r * s


__all__ = ["splitmix", "log_unit", "cos_sin_octant", "normal_pairs"]

"""Reference twins of :mod:`rfsim.devices.tag` (CW power and reflection coefficient in NumPy)."""

from __future__ import annotations

import numpy as np

from rfsim.devices.tag import _MIN_MODULATION


def cw_power_reference(env: np.ndarray, levels: tuple[float, float, float]) -> float:
    """Plain-NumPy twin of the CW-power kernel (median of env² over the CW samples)."""
    thr, lo, hi = levels
    if hi > 0 and hi - lo >= _MIN_MODULATION * hi:
        env = env[env >= thr]
    return float(np.median(env * env))


def reflection_reference(s: np.ndarray, gamma_b: complex, gamma_a: complex) -> np.ndarray:
    """Plain-NumPy twin of :func:`rfsim.devices.tag._reflection`."""
    return np.where(s > 0, gamma_b, gamma_a).astype(np.complex128, copy=False)


__all__ = ["cw_power_reference", "reflection_reference"]

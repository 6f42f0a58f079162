"""Reference twins of :mod:`rfsim.devices.msk_beacon` (MSK phase and FM discriminator in NumPy)."""

from __future__ import annotations

import numpy as np


def msk_phase_reference(chips, sps: float, offset_chips: float, n_samples: int):
    """NumPy twin of :func:`rfsim.devices.msk_beacon.msk_phase`."""
    c = np.asarray(chips, dtype=np.float64)
    u = float(offset_chips) + np.arange(int(n_samples)) / float(sps)
    k = np.floor(u).astype(np.int64)
    on = (k >= 0) & (k < c.size)
    kk = np.clip(k, 0, c.size - 1)
    starts = np.concatenate([[0.0], np.cumsum(0.5 * np.pi * c)])
    phase = np.where(on, starts[kk] + 0.5 * np.pi * c[kk] * (u - kk), 0.0)
    return phase, on


def discriminate_reference(y, y_prev: complex = 1.0 + 0.0j) -> np.ndarray:
    """NumPy twin of :func:`rfsim.devices.msk_beacon.discriminate`."""
    x = np.asarray(y, dtype=np.complex128)
    prev = np.concatenate([[complex(y_prev)], x[:-1]])
    return np.angle(x * np.conj(prev))


__all__ = ["msk_phase_reference", "discriminate_reference"]

"""Reference twins of :mod:`rfsim.devices.st_receiver` (the RC low-pass with SciPy's ``lfilter``, the
hysteresis comparator in plain Python)."""

from __future__ import annotations

import numpy as np
import scipy.signal as _signal

from rfsim.devices.st_receiver import _rc_coefficient


def rc_lowpass_reference(u, *, fs_hz: float, tau_s: float, y0: float | None = None) -> tuple[np.ndarray, float]:
    """Plain SciPy twin of :func:`rfsim.devices.st_receiver.rc_lowpass` (``lfilter``)."""
    u = np.asarray(u, dtype=np.float64)
    a = _rc_coefficient(fs_hz, tau_s)
    y0 = float(u[0]) if (y0 is None and u.size) else float(y0 or 0.0)
    y, _ = _signal.lfilter([a], [1.0, -(1.0 - a)], u, zi=[(1.0 - a) * y0])
    return y, float(y[-1]) if y.size else y0


def comparator_reference(v, *, threshold_v: float, state0: int = -1) -> tuple[np.ndarray, int, int]:
    """Plain-Python twin of :func:`rfsim.devices.st_receiver.comparator`."""
    out = np.empty(len(v))
    st, tog = int(state0), 0
    for n, x in enumerate(np.asarray(v, dtype=np.float64)):
        if st < 0 and x > 0.5 * threshold_v:
            st, tog = 1, tog + 1
        elif st > 0 and x < -0.5 * threshold_v:
            st, tog = -1, tog + 1
        out[n] = st
    return out, st, tog


__all__ = ["rc_lowpass_reference", "comparator_reference"]

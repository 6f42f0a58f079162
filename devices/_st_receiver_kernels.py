"""numba kernels of the sense-a-tag receive chain (wrapped and documented in
:mod:`devices.st_receiver`; NumPy twins there as ``*_reference``).
"""

from __future__ import annotations

from rfsim._jit import njit


@njit
def rc_lowpass_kernel(u, a, y0, out):
    """First-order RC low-pass ``y[n] = y[n−1] + a·(u[n] − y[n−1])``; returns the last y."""
    y = y0
    for n in range(u.size):
        y += a * (u[n] - y)
        out[n] = y
    return y


@njit
def comparator_kernel(v, v_high, v_low, state0, out):
    """Hysteresis comparator: goes to +1 above ``v_high``, to −1 below ``v_low``, else holds.

    Fills ``out`` with ±1.0 and returns ``(last state, number of toggles)``.
    """
    state = state0
    toggles = 0
    for n in range(v.size):
        if state < 0 and v[n] > v_high:
            state = 1
            toggles += 1
        elif state > 0 and v[n] < v_low:
            state = -1
            toggles += 1
        out[n] = state
    return state, toggles

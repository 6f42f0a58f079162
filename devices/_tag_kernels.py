"""numba kernels of the passive tag's front end (wrapped and documented in :mod:`devices.tag`;
the plain-NumPy twin is :func:`devices.tag.cw_power_reference`)."""

from __future__ import annotations

import math

import numpy as np

from rfsim._jit import njit


@njit
def cw_power_kernel(env, threshold, select, buf):
    """Median of ``env²`` over the samples with ``env ≥ threshold`` (all samples if not
    ``select``); ``buf`` is scratch of ``env.size``. As ``numpy.median``: the mean of the
    two middle values for an even count, NaN if a NaN enters the median or nothing does."""
    n = 0
    for i in range(env.size):
        v = env[i]
        if select:
            if v >= threshold:
                buf[n] = v * v
                n += 1
        else:
            if math.isnan(v):
                return math.nan
            buf[n] = v * v
            n += 1
    if n == 0:
        return math.nan
    return np.median(buf[:n])

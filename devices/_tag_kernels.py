"""numba kernels of the passive tag's front end (wrapped and documented in :mod:`rfsim.devices.tag`;
the plain-NumPy twin is :func:`reference.devices_tag.cw_power_reference` in the tests)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit


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


@njit
def plateau_kernel(x, env, threshold, select, margin, buf, idx, win):
    """Index of the CW sample the median of ``env²`` lands on (over the samples with ``env ≥
    threshold``, all if not ``select``; ties in sample order, as a stable sort) when the
    2·``margin`` + 1 samples around it in that order are all ±x at that index; −1 when they
    are not (or too few samples are selected), −2 when a NaN is among them or the median is
    none of the three candidates below (the caller then asks
    :func:`rfsim.devices.tag.plateau_reference`, which sorts). ``buf``/``idx``: scratch of ``env.size``
    (float64, int64); ``win``: int64 scratch of 2·``margin`` + 1.

    The median value v is found by counting (a candidate sample's value); with c_< samples below it,
    stable order puts the samples equal to v at positions c_< …, in sample order: position p
    is the (p − c_<)-th of them."""
    m = 0
    for i in range(env.size):
        v = env[i]
        if (not select) or v >= threshold:
            buf[m] = v * v
            idx[m] = i
            m += 1
    if m <= 2 * margin:
        return -1
    for k in range(m):
        if math.isnan(buf[k]):
            return -2
    mid = (m - 1) // 2
    # the median is usually the CW value of the first, middle or last selected sample: a
    # candidate c is the median exactly when #(< c) ≤ mid < #(≤ c); otherwise select it
    med = math.nan
    n_less = 0
    for c in (buf[0], buf[m - 1], buf[m // 2]):
        n_less = 0
        n_eq = 0
        for k in range(m):
            v = buf[k]
            if v < c:
                n_less += 1
            elif v == c:
                n_eq += 1
        if n_less <= mid < n_less + n_eq:
            med = c
            break
    if math.isnan(med):  # rare: the caller selects it (np.partition here would cost seconds of compilation)
        return -2
    start = mid - margin - n_less  # rank, among the samples equal to med, of the window's first
    if start < 0:
        return -1
    width = 2 * margin + 1
    r = 0
    w = 0
    for k in range(m):
        if buf[k] == med:
            if r >= start:
                win[w] = idx[k]
                w += 1
                if w == width:
                    break
            r += 1
    if w < width:
        return -1
    xm = x[win[margin]]
    for q in range(width):
        v = x[win[q]]
        if not (v == xm or v == -xm):
            return -1
    return win[margin]


@njit
def reflection_kernel(s, gamma_b, gamma_a, out):
    """Γ(t) of a reply: ``out[i] = gamma_b`` where the reply waveform ``s[i] > 0`` (float64 ``s``;
    or the mask of where it is, bool ``s``), else ``gamma_a`` (plain-NumPy twin:
    :func:`reference.devices_tag.reflection_reference` in the tests)."""
    for i in range(s.size):
        out[i] = gamma_b if s[i] > 0 else gamma_a

"""numba kernel of the statistic-level receiver (wrapped and documented in
:mod:`rfsim.devices.reader_statistic`; the plain-NumPy twin is
:func:`reference.devices_reader_statistic.piece_map_reference` in the tests)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit
from rfsim.gen2._linecode_kernels import INDEX_EPS

#: Piece classes (the second column of ``kind`` in :func:`piece_map_kernel`).
STEADY, INNER_EDGE, SINGLE, REST = 0, 1, 2, 3


@njit
def _element(i, start, elements_per_sample):
    """Element index of sample i of a reply starting at sample ``start`` (−1 before it), as
    :func:`rfsim.gen2._linecode_kernels.waveform_kernel` and the half-bit sums assign it."""
    u = (i - start) * elements_per_sample
    if u < 0.0:
        return -1
    return int(math.floor(u + INDEX_EPS))


@njit
def piece_map_kernel(n, i_first, start, elements_per_sample, m, n_elements, piece_of, sign, kind):
    """Partition of the samples ``i_first … n − 1`` into noise pieces (module docstring of
    :mod:`rfsim.devices.reader_statistic`, "Pieces").

    Writes, for sample ``i_first + q``, its piece ``piece_of[q]`` and its sign ``sign[q]``
    (the Miller subcarrier (−1)^k of element k, +1 for FM0 and outside the reply), and per
    piece p its class ``kind[p]`` (:data:`STEADY`: samples inside one element whose neighbours
    lie in the same element, merged per half-bit; :data:`INNER_EDGE`: Miller samples at an
    element edge inside one half-bit, merged per half-bit; :data:`SINGLE`: one sample at a
    half-bit edge or next to the reply's end, or the last sample; :data:`REST`: after the
    reply, both neighbours after it too, one piece). Returns the number of pieces."""
    n_p = 0
    cur = np.full(4, -1, np.int64)  # the open piece of each merged class (STEADY, INNER_EDGE: this half-bit)
    cur_half = -1
    kp = _element(i_first - 1, start, elements_per_sample)
    k = _element(i_first, start, elements_per_sample)
    for i in range(i_first, n):
        kn = _element(i + 1, start, elements_per_sample) if i + 1 < n else -2
        q = i - i_first
        h = k // m if 0 <= k < n_elements else -1
        if h != cur_half:
            cur_half = h
            cur[STEADY] = -1
            cur[INNER_EDGE] = -1
        sign[q] = -1.0 if (m > 1 and 0 <= k < n_elements and (k & 1)) else 1.0
        if k >= n_elements:
            cls = REST if (kp >= n_elements and kn >= n_elements) else SINGLE
        elif k >= 0 and kp == k and kn == k:
            cls = STEADY
        elif m > 1 and k >= 0 and kp >= 0 and kp // m == h and 0 <= kn < n_elements and kn // m == h:
            cls = INNER_EDGE
        else:
            cls = SINGLE
        if cls == SINGLE or cur[cls] < 0:
            kind[n_p] = cls
            if cls != SINGLE:
                cur[cls] = n_p
            piece_of[q] = n_p
            n_p += 1
        else:
            piece_of[q] = cur[cls]
        kp = k
        k = kn
    return n_p

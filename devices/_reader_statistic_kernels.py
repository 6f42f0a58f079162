"""numba kernel of the statistic-level receiver (wrapped and documented in
:mod:`rfsim.devices.reader_statistic`; the plain-NumPy twin is
:func:`reference.devices_reader_statistic.piece_map_reference` in the tests)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit
from rfsim.gen2._linecode_kernels import INDEX_EPS, element_sign

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
        sign[q] = float(element_sign(k, m)) if 0 <= k < n_elements else 1.0
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


@njit
def block_cuts_kernel(s, i0, b1, piece_of, kind, n_blocks, reach, cut_piece, cut_edge, cut_before, cut_after):
    """The steady pieces the measurement's block edges cut (:mod:`rfsim.devices.reader_statistic`
    step 4). ``s``: the reference reply from sample ``i0`` of the input (0 outside the reply);
    the measurement reads the samples strictly inside its first and last non-zero sample whose
    two neighbours carry the same level (:func:`rfsim.devices._reader_kernels.measure_kernel`),
    block k starting at the floor(k·m/K)-th of those m samples. For each edge k = 1 … K − 1 at a
    sample ≥ ``b1`` (the first sample of the pieces) inside a STEADY piece with members on both
    sides (searched within ±``reach`` samples): the piece, the edge (index from ``b1``) and its
    numbers of members before and after the edge, into the ``cut_*`` arrays (K − 1). Returns
    ``(m, number of cuts)``."""
    n = s.size
    first = 0
    while first < n and s[first] == 0.0:
        first += 1
    if first == n:
        return 0, 0
    last = n - 1
    while s[last] == 0.0:
        last -= 1
    m = 0
    for i in range(first + 1, last):
        m += (s[i] == s[i - 1]) & (s[i] == s[i + 1])
    n_cuts = 0
    count = 0
    k = 1
    target = m // n_blocks if m > 0 else -1
    for i in range(first + 1, last):
        if not ((s[i] == s[i - 1]) & (s[i] == s[i + 1])):
            continue
        while k < n_blocks and count == target:
            e = i0 + i - b1
            if e >= 0 and kind[piece_of[e]] == STEADY:
                p = piece_of[e]
                before = 0
                after = 0
                for q in range(max(0, e - reach), min(piece_of.size, e + reach)):
                    if piece_of[q] == p:
                        if q < e:
                            before += 1
                        else:
                            after += 1
                if before > 0 and after > 0:
                    cut_piece[n_cuts] = p
                    cut_edge[n_cuts] = e
                    cut_before[n_cuts] = before
                    cut_after[n_cuts] = after
                    n_cuts += 1
            k += 1
            target = k * m // n_blocks
        count += 1
    return m, n_cuts


@njit
def spread_add_kernel(r, b1, piece_of, sign, sums, sizes):
    """``r[b1 + q] += sign[q]·sums[p]/sizes[p]`` for p = piece_of[q] (the spread pieces added in place)."""
    for q in range(piece_of.size):
        p = piece_of[q]
        r[b1 + q] += sign[q] * (sums[p] / sizes[p])


@njit
def apply_cuts_kernel(r, b1, piece_of, sign, sums, sizes, cut_piece, cut_edge, reach, part_a, part_b):
    """Respread every cut piece: its members before the edge carry ``part_a``, after it
    ``part_b`` (each over its own members) instead of the whole piece's sum, in place."""
    for c in range(cut_piece.size):
        p = cut_piece[c]
        e = cut_edge[c]
        n_a = 0
        n_b = 0
        lo = max(0, e - reach)
        hi = min(piece_of.size, e + reach)
        for q in range(lo, hi):
            if piece_of[q] == p:
                if q < e:
                    n_a += 1
                else:
                    n_b += 1
        mean = sums[p] / sizes[p]
        for q in range(lo, hi):
            if piece_of[q] == p:
                part = part_a[c] / n_a if q < e else part_b[c] / n_b
                r[b1 + q] += sign[q] * (part - mean)

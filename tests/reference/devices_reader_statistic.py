"""Reference twin of :func:`rfsim.devices.reader_statistic.piece_map` in plain NumPy: the
element of every sample, then the pieces by their definition (module docstring of
:mod:`rfsim.devices.reader_statistic`, "Pieces") rather than by one pass."""

from __future__ import annotations

import numpy as np

from rfsim.gen2._linecode_kernels import INDEX_EPS

STEADY, INNER_EDGE, SINGLE, REST = 0, 1, 2, 3


def piece_map_reference(n, i_first, start, elements_per_sample, m, n_elements):
    """``(piece_of, sign, kind)`` as :func:`rfsim.devices.reader_statistic.piece_map`: pieces
    numbered in the order of their first sample."""
    idx = np.arange(i_first - 1, n + 1)
    u = (idx - start) * elements_per_sample
    k = np.where(u < 0.0, -1, np.floor(u + INDEX_EPS)).astype(np.int64)
    k[-1] = -2  # no sample after the last one
    keys = []
    signs = []
    for q in range(1, idx.size - 1):
        kp, kc, kn = k[q - 1], k[q], k[q + 1]
        if kc >= n_elements:
            signs.append(1.0)
            keys.append(("rest",) if (kp >= n_elements and kn >= n_elements) else ("single", q))
            continue
        h = kc // m if kc >= 0 else -1
        signs.append(-1.0 if (m > 1 and kc >= 0 and kc % 2 == 1) else 1.0)
        if kc >= 0 and kp == kc == kn:
            keys.append(("steady", h))
        elif m > 1 and kc >= 0 and kp >= 0 and kp // m == h and 0 <= kn < n_elements and kn // m == h:
            keys.append(("inner", h))
        else:
            keys.append(("single", q))
    number: dict = {}
    kinds = []
    piece_of = np.empty(len(keys), np.int64)
    for q, key in enumerate(keys):
        if key not in number:
            number[key] = len(number)
            kinds.append({"steady": STEADY, "inner": INNER_EDGE, "single": SINGLE, "rest": REST}[key[0]])
        piece_of[q] = number[key]
    return piece_of, np.array(signs), np.array(kinds, dtype=np.int64)


def block_cuts_reference(s, i0, b1, piece_of, kind, n_blocks):
    """``(m, piece, edge, before, after)`` as :func:`rfsim.devices.reader_statistic.block_cuts`:
    the measurement's samples by :func:`rfsim.devices.reader_measure.steady`, its block edges,
    the steady pieces with members on both sides of an edge (searched over the whole map)."""
    from rfsim.devices.reader_measure import steady

    nz = np.flatnonzero(s)
    if nz.size == 0:
        return 0, *(np.zeros(0, np.int64) for _ in range(4))
    used = np.flatnonzero(steady(s[nz[0]: nz[-1] + 1])) + nz[0] + i0
    m = used.size
    rows = []
    for k in range(1, n_blocks):
        e = used[k * m // n_blocks] - b1 if m else -1
        if e < 0 or kind[piece_of[e]] != STEADY:
            continue
        members = np.flatnonzero(piece_of == piece_of[e])
        before, after = int(np.sum(members < e)), int(np.sum(members >= e))
        if before and after:
            rows.append((piece_of[e], e, before, after))
    cols = np.array(rows, dtype=np.int64).reshape(-1, 4).T
    return m, *cols

"""Reference twin of :mod:`rfsim.gen2.capture` (the PIE plausibility gate in plain NumPy)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.gen2.capture import (GATE_DELIMITER_TARI, GATE_MIN_BITS, GATE_MIN_CONTRAST, GATE_PW_TARI, GATE_RTCAL_TARI,
                                GATE_TOL_SAMPLES, GATE_TOL_TARI, GATE_TRCAL_RTCAL, _frame_edges)
from rfsim.gen2.pie import PieEdges


def plausible_frames_reference(edges: PieEdges, env: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plain-NumPy twin of :func:`rfsim.gen2.capture.plausible_frames`."""
    first, last = _frame_edges(edges)
    pos, env = edges.pos, np.asarray(env, dtype=np.float64)
    keep = np.zeros(first.size, dtype=bool)
    contrast = np.zeros(first.size)
    for i, (e0, e1) in enumerate(zip(first.tolist(), last.tolist())):
        t, rt, tr = edges.tari[i], edges.rtcal[i], edges.trcal[i]
        tol = GATE_TOL_TARI * t + GATE_TOL_SAMPLES
        fall, rise = pos[e0:e1 + 1:2], pos[e0 + 1:e1 + 1:2]
        n_pre = 3 if math.isnan(tr) else 4
        spans = np.diff(rise)[n_pre - 1:]
        widths = (rise - fall)[1:]
        checks = [
            rise.size - n_pre >= GATE_MIN_BITS,
            GATE_RTCAL_TARI[0] <= rt / t <= GATE_RTCAL_TARI[1],
            math.isnan(tr) or GATE_TRCAL_RTCAL[0] <= tr / rt <= GATE_TRCAL_RTCAL[1],
            GATE_DELIMITER_TARI[0] <= (rise[0] - fall[0]) / t <= GATE_DELIMITER_TARI[1],
            bool(np.all((np.abs(spans - t) <= tol) | (np.abs(spans - (rt - t)) <= tol))),
            GATE_PW_TARI[0] <= widths[0] / t <= GATE_PW_TARI[1],
            bool(np.all(np.abs(widths - widths[0]) <= tol)),
        ]
        if not all(checks):
            continue
        lo_idx = np.round(0.5 * (fall + rise)).astype(np.int64)
        hi_idx = np.round(0.5 * (rise[:-1] + fall[1:])).astype(np.int64)
        lo = env[lo_idx[(lo_idx >= 0) & (lo_idx < env.size)]]
        hi = env[hi_idx[(hi_idx >= 0) & (hi_idx < env.size)]]
        if lo.size < 2 or hi.size < 2:
            continue
        var = 0.5 * (max(float(np.mean(lo * lo)) - float(lo.mean()) ** 2, 0.0)
                     + max(float(np.mean(hi * hi)) - float(hi.mean()) ** 2, 0.0))
        contrast[i] = (hi.mean() - lo.mean()) / math.sqrt(var) if var > 0 else math.inf
        keep[i] = contrast[i] >= GATE_MIN_CONTRAST
    return keep, contrast


def fit_gain_offset_reference(r, s) -> tuple[complex, complex]:
    """Plain-NumPy twin of :func:`rfsim.gen2.capture.fit_gain_offset` (NumPy's reductions:
    pairwise sums and BLAS dot products): the closed form of the 2×2 normal equations."""
    r = np.asarray(r, dtype=np.complex128)
    s = np.asarray(s, dtype=np.float64)
    ss, s1, n = float(s @ s), float(s.sum()), float(s.size)
    rs, r1 = complex(r @ s), complex(r.sum())
    det = ss * n - s1 * s1
    if abs(det) <= 1e-12 * max(ss * n, 1e-300):
        raise ValueError("the reference s is constant: gain and offset cannot be separated")
    return (n * rs - s1 * r1) / det, (ss * r1 - s1 * rs) / det


__all__ = ["plausible_frames_reference", "fit_gain_offset_reference"]

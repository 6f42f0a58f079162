"""Timing tracking of a tag reply in a capture (step 4 of :mod:`rfsim.gen2.replies`).

The tag's element clock (half subcarrier cycles) is modelled as u(t) = u₁·t + u₂·t² from
the reply's start (t in samples): a BLF u₁·fs/2 that drifts linearly (a tag's oscillator
warming or its supply sagging through a reply). With the decoded bits as reference the
reply is cut into blocks; each block's timing offset δ_b maximises the correlation of the
received ``y = Re((r − c)/h)`` with the remodulated reply (averaged over each sample
interval at :data:`SUBSAMPLES` points, so the correlation is a smooth function of δ even
where a sample is taken at one point of a sharp edge), searched on a 1/16-element grid
within ±1/2 element of a prediction and refined by the peak of the triangle through the
three best points. A weighted least-squares quadratic δ(t) is fitted over growing spans
(:data:`TRACK_SPANS`), each searched around the previous fit's extrapolation: a tracking
loop that follows a timing error growing past half an element towards the end. Then
u_new(t) = u(t − δ(t)) ≈ u(t) − u₁·δ(t). The window is resampled on the tag's clock
(:func:`warp_positions`, :func:`resample`: linear interpolation) for decoding with a
constant BLF.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.gen2.linecode import halfsymbols
from rfsim.core.lazy import lazy_import

_ck = lazy_import("rfsim.gen2._capture_kernels")

#: Elements per timing block of the tracking loop.
TRACK_BLOCK_ELEMENTS = 24
#: Growing spans of the reply (fractions from its start) the tracking loop fits in turn.
TRACK_SPANS = (0.25, 0.5, 1.0)
#: Fewest timing blocks for a drift (quadratic) fit; shorter replies get start and BLF only.
MIN_DRIFT_BLOCKS = 8
#: Points per sample interval at which the tracking reference is averaged.
SUBSAMPLES = 4
#: Fewest timing blocks (short replies get shorter blocks).
MIN_TRACK_BLOCKS = 6


def warp_positions(n_prime: np.ndarray, u1: float, u2: float, rho: float) -> np.ndarray:
    """Sample offsets where the element clock reaches ρ·n′.

    Solves u(t) = u₁·t + u₂·t² = ρ·n′ for t by the stable root
    t = 2ρn′ / (u₁ + √(u₁² + 4u₂ρn′)) (module docstring).

    Parameters
    ----------
    n_prime : numpy.ndarray
        Element positions n′ [elements].
    u1 : float
        Element rate u₁ [elements/sample].
    u2 : float
        Element-rate drift u₂ [elements/sample²].
    rho : float
        Scale of the element positions [1].

    Returns
    -------
    numpy.ndarray
        Offsets t from the reply start [samples], same shape as ``n_prime``.
    """
    target = rho * n_prime
    disc = np.maximum(u1 * u1 + 4.0 * u2 * target, 1e-300)
    return 2.0 * target / (u1 + np.sqrt(disc))


def resample(r: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Complex samples of ``r`` at fractional ``positions`` by linear interpolation.

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,)`` complex samples, sample k at position k.
    positions : numpy.ndarray
        ``(m,)`` positions [samples].

    Returns
    -------
    numpy.ndarray
        ``(m,) complex128`` interpolated samples, same unit as ``r``.
    """
    x = np.arange(r.size, dtype=np.float64)
    return np.interp(positions, x, r.real) + 1j * np.interp(positions, x, r.imag)


def _block_correlations(y, start, u1, u2, el, n_blocks, base, shifts, sub, n_blocks_used=None):
    corr = np.empty((shifts.size, n_blocks))
    centre_sum = np.empty(n_blocks)
    count = np.empty(n_blocks, dtype=np.int64)
    _ck.block_correlation_kernel(np.ascontiguousarray(y, dtype=np.float64), int(math.ceil(start)), float(start),
                                 float(u1), float(u2), el, int(n_blocks), np.ascontiguousarray(base, dtype=np.float64),
                                 shifts, sub, corr, centre_sum, count,
                                 int(n_blocks if n_blocks_used is None else n_blocks_used))
    return corr, centre_sum / np.maximum(count, 1)


def _block_offsets(y, start, u1, u2, el, n_blocks, base, n_blocks_used=None):
    """Per block: (centre offset t_b [samples], timing offset δ_b [samples], weight, block
    index), δ_b
    searched within ±1/2 element of ``base[b]``; blocks whose peak lies at the edge of that
    range are left out (only the first ``n_blocks_used`` blocks are searched)."""
    step = 1.0 / (16.0 * u1)  # 1/16 element in samples
    shifts = step * np.arange(-8, 9)
    sub = (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES - 0.5
    corr, centres = _block_correlations(y, start, u1, u2, el, n_blocks, base, shifts, sub, n_blocks_used)
    n_used = n_blocks if n_blocks_used is None else min(n_blocks, int(n_blocks_used))
    corr, centres, base = corr[:, :n_used], centres[:n_used], np.asarray(base)[:n_used]
    cols = np.arange(n_used)
    j = np.argmax(corr, axis=0)
    mid = corr[j, cols]
    keep = (mid > 0) & (j > 0) & (j < shifts.size - 1)
    j, cols, mid = j[keep], cols[keep], mid[keep]
    # peak of a triangle through the three points around the maximum
    left, right = corr[j - 1, cols], corr[j + 1, cols]
    slope = np.maximum(mid - left, mid - right)
    frac = np.where(slope > 0, 0.5 * (right - left) / np.where(slope > 0, slope, 1.0), 0.0)
    return np.column_stack([centres[cols], base[cols] + shifts[j] + frac * step, mid, cols])


def weighted_polyfit(t, d, w, deg):
    """Weighted least-squares polynomial fit.

    Minimises Σ w_i·(p(t_i) − d_i)² (w ≥ 0) by the normal equations in the centred, scaled
    variable x = (t − t̄)/s (well conditioned), then re-expanded in t.

    Parameters
    ----------
    t, d, w : array_like
        ``(n,)`` abscissae, ordinates and weights (≥ 0).
    deg : int
        Polynomial degree.

    Returns
    -------
    numpy.ndarray
        ``(deg + 1,)`` coefficients, highest power first (as :func:`numpy.polyfit`).
    """
    t, d, w = (np.asarray(v, dtype=np.float64) for v in (t, d, w))
    tm = float(t.mean())
    ts = float(np.max(np.abs(t - tm))) or 1.0
    x = (t - tm) / ts
    v = np.vander(x, deg + 1, increasing=True)  # columns 1, x, x², …
    a = (v * w[:, None]).T @ v
    c = np.linalg.solve(a, (v * w[:, None]).T @ d)  # p(t) = Σ c_k·((t − tm)/ts)^k
    # re-expand: Σ_k c_k·Σ_i C(k, i)·t^i·(−tm)^(k−i)/ts^k
    out = np.zeros(deg + 1)
    for k in range(deg + 1):
        for i in range(k + 1):
            out[i] += c[k] * math.comb(k, i) * (-tm) ** (k - i) / ts ** k
    return out[::-1]


def track(r, start, u1, u2, h, c, bits, m, trext, dummy):
    """Element clock of the reply refined by the tracking loop.

    One numba kernel (``track_kernel``); :func:`track_reference` is its NumPy twin and
    documents the loop (module docstring: per-block offsets δ_b, a weighted quadratic δ(t)
    over :data:`TRACK_SPANS`, u_new(t) ≈ u(t) − u₁·δ(t)).

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,)`` complex window at the working rate, any unit.
    start : float
        Reply start [samples].
    u1 : float
        Element rate [elements/sample].
    u2 : float
        Element-rate drift [elements/sample²].
    h, c : complex
        Reply gain and rest level (the received ``y = Re((r − c)/h)``), unit of ``r``.
    bits : numpy.ndarray
        ``(n_bits,) uint8`` decoded data bits (the reference).
    m : int
        Symbols per bit M.
    trext : bool
        Pilot tone present.
    dummy : bool
        Trailing dummy data-1 present.

    Returns
    -------
    tuple of float
        ``(start, u1, u2)`` [samples, elements/sample, elements/sample²].
    """
    el = halfsymbols(bits, m=m, trext=trext, dummy=dummy).astype(np.float64)
    n_blocks = max(MIN_TRACK_BLOCKS, el.size // TRACK_BLOCK_ELEMENTS)
    y = np.ascontiguousarray(((r - c) / h).real)
    sub = (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES - 0.5
    s0, v1, v2 = _ck.track_kernel(y, float(start), float(u1), float(u2), el, int(n_blocks),
                                  np.array(TRACK_SPANS, dtype=np.float64), sub, MIN_DRIFT_BLOCKS)
    return float(s0), float(v1), float(v2)


def track_reference(r, start, u1, u2, h, c, bits, m, trext, dummy):
    """Element clock of the reply refined from per-block timing offsets (NumPy twin of :func:`track`).

    Step 4 of :mod:`rfsim.gen2.replies`: the blocks are taken in growing spans from the
    reply start (the first quarter, half, all), each span's new offsets searched around the
    extrapolation of the previous span's fit (the leading blocks whose centres lay inside an
    earlier span keep the offsets measured then), so a BLF error or drift whose timing error
    grows past half an element towards the reply's end is still followed.

    Parameters
    ----------
    r : numpy.ndarray
        ``(n,)`` complex window at the working rate, any unit.
    start : float
        Reply start [samples].
    u1 : float
        Element rate [elements/sample].
    u2 : float
        Element-rate drift [elements/sample²].
    h, c : complex
        Reply gain and rest level (the received ``y = Re((r − c)/h)``), unit of ``r``.
    bits : numpy.ndarray
        ``(n_bits,) uint8`` decoded data bits (the reference).
    m : int
        Symbols per bit M.
    trext : bool
        Pilot tone present.
    dummy : bool
        Trailing dummy data-1 present.

    Returns
    -------
    tuple of float
        ``(start, u1, u2)`` [samples, elements/sample, elements/sample²].
    """
    el = halfsymbols(bits, m=m, trext=trext, dummy=dummy).astype(np.float64)
    n_blocks = max(MIN_TRACK_BLOCKS, el.size // TRACK_BLOCK_ELEMENTS)
    y = ((r - c) / h).real
    centres = (np.arange(n_blocks) + 0.5) / n_blocks * el.size / u1  # nominal block centres [samples]
    # start of each block on the element clock: a block that starts after a span's end
    # cannot have its centre inside it and is not searched
    block_starts = warp_positions(np.arange(n_blocks) * (el.size / n_blocks), u1, u2, 1.0)
    coef = np.zeros(3)  # δ(t) = coef[0]·t² + coef[1]·t + coef[2]
    kept = np.zeros((0, 4))  # rows of _block_offsets of the blocks measured inside an earlier span
    done = 0  # they are the blocks b < done: the leading blocks with centres inside it
    sub = (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES - 0.5
    _, block_centres = _block_correlations(y, start, u1, u2, el, n_blocks, np.zeros(n_blocks), np.zeros(1), sub, 0)
    for frac in TRACK_SPANS:
        limit = frac * el.size / u1
        base = np.polyval(coef, centres)
        n_used = min(n_blocks, int(np.count_nonzero(block_starts <= limit)) + 1)
        new = _block_offsets(y, start, u1, u2, el, n_blocks, base, n_used)
        blocks = np.vstack([kept, new[new[:, 3] >= done]])
        blocks = blocks[blocks[:, 0] <= limit]
        outside = np.flatnonzero(block_centres[:n_used] > limit)
        done = max(done, int(outside[0]) if outside.size else n_used)
        kept = blocks[blocks[:, 3] < done]
        if blocks.shape[0] < 3:
            continue
        tb, db, w, _ = blocks.T
        w = np.maximum(w, 0.0)
        if blocks.shape[0] >= MIN_DRIFT_BLOCKS:
            coef = weighted_polyfit(tb, db, w, 2)
        else:  # too short to tell a drift from noise: start and BLF only
            coef = np.concatenate([[0.0], weighted_polyfit(tb, db, w, 1)])
    a2, a1, a0 = coef
    # u_new(t) = u(t − δ(t)) ≈ u(t) − u1·δ(t), re-expressed from the new start
    return start + a0, u1 * (1.0 - a1), u2 - u1 * a2


__all__ = ["warp_positions", "resample", "weighted_polyfit", "track", "track_reference",
           "TRACK_SPANS", "SUBSAMPLES"]

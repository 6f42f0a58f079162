"""Reference twins of the statistic-level receiver in plain NumPy.

:func:`piece_map_reference`: the element of every sample, then the pieces by their definition
(module docstring of :mod:`rfsim.devices.reader_statistic`, "Pieces") rather than by one pass.
:func:`receive_reference`: the receiver's steps as NumPy calls of the sample-level decoder (the
kernel :func:`rfsim.devices._reader_statistic_kernels.receive_kernel` does them in one call)."""

from __future__ import annotations

import numpy as np

import math

from rfsim.devices import _reader_statistic_kernels as sk
from rfsim.devices import reader_statistic as rs
from rfsim.devices.reader_measure import ReadResult, known_levels
from rfsim.gen2._linecode_kernels import INDEX_EPS
from rfsim.gen2.capture import fit_gain_offset
from rfsim.gen2.crc import crc16_ok
from rfsim.gen2.linecode import decode_bits, decode_reply, preamble_levels, reply_duration_s

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


def _noise_fill(x: np.ndarray, lo: int, b1: int, sigma2_w: float, rng: np.random.Generator) -> np.ndarray:
    """``x`` plus the noise of the stretch before the search block (two pieces: sample 0 and
    samples 1 … b0 − 1) and of the search block b0 … b1 − 1 drawn per sample; samples from b1 on
    noise-free (drawn later, once the reply's start is known). Returns the new array."""
    b0 = max(0, lo - rs.SEARCH_MARGIN)
    head = min(b0, 2)  # pieces before the block: {0} and 1 … b0 − 1
    sizes = np.ones(head + b1 - b0)
    if head == 2:
        sizes[1] = b0 - 1
    p = rs.draw_piece_sums(sizes, sigma2_w, rng=rng)
    r = x.copy()
    if head:
        r[:1] += p[0]
    if head == 2:
        r[1:b0] += p[1] / (b0 - 1)
    r[b0:b1] += p[head:]
    return r


def receive_reference(reader, x, *, t0_s: float, n_bits: int, expect_crc: bool, cmd_end_s: float | None = None,
                      blf_hz: float | None = None, carrier: complex | None = None,
                      rng: np.random.Generator) -> ReadResult:
    """Twin of :func:`rfsim.devices.reader_statistic.receive` (its parameters and result): the
    same steps as NumPy calls of the sample-level decoder, the same draws in the same order."""
    x = np.ascontiguousarray(x, dtype=np.complex128)  # valid arguments only (the checks are the receiver's)
    n_bits, lk, fs, sigma2 = int(n_bits), reader.link, reader.fs_hz, reader._fixed().noise_w
    blf = lk.blf_hz if blf_hz is None else float(blf_hz)
    pre_n = reader.preamble_samples(blf)
    n_reply = int(math.ceil(reply_duration_s(n_bits, m=lk.m, trext=lk.trext, blf_hz=blf) * fs))
    lo, hi = reader.reply_start_lags(x.size, n_reply, t0_s=t0_s, cmd_end_s=cmd_end_s)
    if hi < lo or pre_n < 3:
        return ReadResult(False, None, "preamble not found")
    ratio = 2.0 * blf / fs
    n_pre_el = preamble_levels(m=lk.m, trext=lk.trext)[0].size * lk.m
    n_el = n_pre_el + 2 * lk.m * (n_bits + 1)
    # the decoder's own reply length and preamble samples (rfsim.gen2.linecode._plan)
    n_dec = int(math.ceil(n_el / ratio))
    last = min(x.size - lo - n_dec, hi - lo)
    b1 = min(x.size, lo + last + int(math.floor(n_pre_el / ratio)) + rs.SEARCH_MARGIN)
    # step 1-2: the search block per sample, the reply start from it
    r = _noise_fill(x, lo, b1, sigma2, rng)
    r0 = r - (r[:lo].mean() if lo >= 8 else 0.0)
    kw = dict(n_bits=n_bits, m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs, method=reader.config.decoder)
    start_rel = decode_reply(r0[lo:], search_samples=hi - lo, **kw).start_sample
    # step 3: the pieces after the search block, then the receiver's steps on x + ñ
    start = lo + start_rel
    piece_of, sign, kind = rs.piece_map(x.size, b1, start, ratio, lk.m, n_el)
    sizes = np.bincount(piece_of, minlength=kind.size)
    sums = rs.draw_piece_sums(sizes, sigma2, rng=rng)
    sk.spread_add_kernel(r, b1, piece_of, sign, sums, sizes.astype(np.float64))
    r = r - (r[:lo].mean() if lo >= 8 else 0.0)
    det = decode_reply(r[lo:], start_sample=start_rel, **kw)
    start_s = float(t0_s) + start / fs
    if det.corr < reader.detection_threshold(hi - lo + 1, blf):
        return ReadResult(False, None, "preamble not found", start_s=start_s, corr=det.corr)
    full = reader._reference(det.bits, start, r.size, blf)
    h, c = fit_gain_offset(*known_levels(r, full, start / fs * fs, ratio, n_pre_el))
    i0 = lo + int(math.floor(start_rel))
    bits = decode_bits(r[i0: i0 + n_reply + 4] - c, n_bits=n_bits, m=lk.m, trext=lk.trext, blf_hz=blf, fs_hz=fs,
                       method=reader.config.decoder, start_sample=start_rel - (i0 - lo), gain=h).astype(np.uint8)
    ref = full if bits.tobytes() == det.bits.tobytes() else reader._reference(bits, start, r.size, blf)
    # steps 4 and 6: the measurement's block edges split steady pieces; the in-piece energy
    s = ref[i0: i0 + n_reply + 4]
    n_free, n_used = _split_at_blocks(r, s, i0, b1, piece_of, sign, kind, sums, sizes, sigma2, rng)
    meas = reader._measure(r[i0: i0 + s.size] - c, s, blf)
    _complete(meas, n_free, n_used, sigma2, carrier, rng)
    ok = (not expect_crc) or crc16_ok(bits)
    return ReadResult(success=ok, bits=bits, failure_reason="" if ok else "crc error",
                      start_s=start_s, corr=det.corr, **meas)


def _complete(meas: dict, n_free: int, n_used: int, sigma2: float, carrier, rng: np.random.Generator) -> None:
    """Step 6 on the measurement ``meas`` (the reader's dict, in place) after the fact: the
    in-piece noise energy (:func:`rfsim.devices.reader_statistic.residual_correction`, ``n_free``
    degrees of freedom over ``n_used`` samples) added to the residual behind its SNR and Eb/N0
    (recovered from the RSSI and SNR); then the phase referred to ``carrier``."""
    if math.isfinite(meas["snr_db"]) and n_used > 0:
        p = abs(10.0 ** (meas["rssi_dbm"] / 10.0) * 1e-3)
        s2 = p / 10.0 ** (meas["snr_db"] / 10.0) + rs.residual_correction(n_free, sigma2, n_used, rng=rng)
        snr = 10.0 * math.log10(p / s2)
        meas["ebn0_db"] += snr - meas["snr_db"]
        meas["snr_db"] = snr
    if carrier is not None and complex(carrier) != 0:
        meas["phase_rad"] = float(np.mod(meas["phase_rad"] + np.angle(complex(carrier)), 2.0 * np.pi))


def _split_at_blocks(r, s, i0, b1, piece_of, sign, kind, sums, sizes, sigma2, rng) -> tuple[int, int]:
    """Steps 4 and 6 of the module docstring on ``r`` (in place): the steady pieces cut by the
    measurement's block edges (:func:`block_cuts`) split by a bridge and spread again. Returns
    (Σ(|p| − 1) over the steady pieces, all of which the measurement reads, less one per cut;
    the number of samples the measurement reads)."""
    is_steady = kind == sk.STEADY
    n_free = int(np.sum(sizes[is_steady] - 1))
    reach = _reach(sizes, is_steady)
    n_used, piece, edge, n_a, n_b = rs.block_cuts(s, i0, b1, piece_of, kind, reach)
    if piece.size:
        a, b = rs.bridge_split(sums[piece], n_a, n_b, sigma2, rng=rng)
        sk.apply_cuts_kernel(r, b1, piece_of, sign, sums, sizes.astype(np.float64), piece, edge, reach, a, b)
    return n_free - piece.size, n_used  # per cut: one more sum drawn, one fewer degree of freedom inside


def _reach(sizes: np.ndarray, is_steady: np.ndarray) -> int:
    """Samples around a block edge within which a steady piece's members lie: a steady piece
    lies within one half-bit, whose samples are at most 8 times its steady ones (plus 8)."""
    return int(np.max(sizes[is_steady], initial=0)) * 8 + 8


def piece_moments_reference(x, dc, b1, piece_of, sign, anchor, n_p):
    """``(mom, energy)`` as :func:`rfsim.devices._reader_statistic_kernels.piece_moments_kernel`
    by ``numpy.bincount`` over the pieces (u = x − dc from sample ``b1``, δ = i − anchor)."""
    u = x[b1: b1 + piece_of.size] - dc
    d = np.arange(b1, b1 + piece_of.size) - anchor[piece_of]

    def per_piece(v):
        return (np.bincount(piece_of, weights=np.real(v), minlength=n_p)
                + 1j * np.bincount(piece_of, weights=np.imag(v), minlength=n_p))

    su = sign * u
    mom = np.array([per_piece(su), per_piece(u), per_piece(su * d), per_piece(su * d * d)])
    return mom, np.bincount(piece_of, weights=np.abs(u) ** 2, minlength=n_p)

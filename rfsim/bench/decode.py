"""Benchmark of ``rfsim decode`` (issue "Decode real captures", item 8: ≥ 20× real time at
2 MS/s, a 10 s capture in ≤ 0.5 s).

The captures are synthetic monostatic recordings made from rfsim's own reader and tag
waveforms, x = L·e(t) + h·e(t)·s(t) + noise: e the reader's PIE envelope (depth 0.9, Tari
12.5 µs, data-1 2 Tari, PW Tari/2, hard edges: :func:`rfsim.gen2.pie.pie_envelope`), s(t) the tag's ±1
FM0/Miller element sequence during a reply (:func:`rfsim.gen2.linecode.halfsymbols`) and −1
(absorbing state) elsewhere, L = 0.8 + 0.3j the carrier leakage, h = 0.02 − 0.03j the tag's
gain, complex white noise of 1e−3 rms (E_h/N₀ ≈ 40 dB). A capture is built segment by
segment (CW constant + noise in chunks, then every command and reply added where it lies),
so 10 s at 2 MS/s (20 M samples) costs its 160 MB of complex64 and little more.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from rfsim.gen2.access import error_reply, read_reply, rn_reply, success_reply
from rfsim.gen2.bits import bits_to_int, int_to_bits
from rfsim.gen2.commands import (ACK, BlockErase, BlockWrite, Kill, Lock, Query, Read, ReqRN, Write, command_preamble,
                                 encode)
from rfsim.gen2.crc import append_crc16
from rfsim.gen2.linecode import halfsymbols
from rfsim.gen2 import _pie_kernels as _pk
from rfsim.gen2.pie import pie_timeline
from rfsim.gen2.synthetic_capture import Exchange, SyntheticLink, synthetic_capture as exchange_capture
from rfsim.core.rng import trial_rng

#: PC (EPC length 6 words) and the 96-bit EPC of the benchmark tag.
PC_BITS = np.array([int(c) for c in f"{0x3000:016b}"], dtype=np.uint8)
EPC_BITS = np.array([int(c) for c in f"{0x300833B2DDD9014000000027:096b}"], dtype=np.uint8)
#: Samples of noise drawn per chunk (each chunk from its own spawned stream).
NOISE_CHUNK = 1 << 20


@dataclass(frozen=True)
class SynthReply:
    """A tag reply of a synthetic capture.

    Attributes
    ----------
    bits : ndarray, shape (n,), uint8
        Data bits of the reply (the dummy 1 is added by the line code).
    m : int
        Line code: 1 = FM0, 2/4/8 = Miller.
    trext : bool
        Pilot tone before the preamble.
    blf_hz : float
        BLF at the reply's start [Hz].
    drift : float
        Relative BLF change across the reply (linear clock drift), default 0.
    t1_s : float or None
        Start after the command's last rising edge [s]; None: the nominal
        T1 = max(RTcal, 10/BLF).
    """

    bits: np.ndarray
    m: int
    trext: bool
    blf_hz: float
    drift: float = 0.0
    t1_s: float | None = None


def _pie(cmd, *, tari_s, trcal_s, fs_hz, gap_s):
    """``(envelope of the command up to its last rising edge, samples the command and the
    CW after it span, last rising edge [s])``: the envelope of
    :func:`rfsim.gen2.pie.pie_envelope` with ``cw_after_s = gap_s`` without the CW samples
    (all 1) after the command, which are not stored."""
    kw = dict(tari_s=tari_s, data1_tari=2.0, pw_s=0.5 * tari_s, delimiter_s=12.5e-6, preamble=command_preamble(cmd))
    bits = encode(cmd)
    trcal = trcal_s if kw["preamble"] == "query" else None
    tl = pie_timeline(bits, trcal_s=trcal, cw_after_s=gap_s, **kw)
    n_total = int(math.ceil(tl.duration_s * fs_hz))
    env = np.ones(min(n_total, int(math.ceil(tl.rise_s[-1] * fs_hz)) + 2))
    _pk.envelope_kernel(tl.fall_s * fs_hz, tl.rise_s * fs_hz, 0.9, 0.0, env)
    return env, n_total, float(tl.rise_s[-1])


def synthetic_capture(items, *, fs_hz: float, trcal_s: float | None, tari_s: float = 12.5e-6,
                      leak: complex = 0.8 + 0.3j, h: complex = 0.02 - 0.03j, noise_rms: float = 1e-3,
                      seed: int = 0, lead_s: float = 300e-6) -> tuple[np.ndarray, list]:
    r"""Build a synthetic monostatic capture and its truth (module docstring).

    :math:`x = L\,e(t) + h\,e(t)\,(s(t) + 1) - h + n(t)`, i.e. the carrier with the tag absorbing
    (s = −1) outside its replies. The tag's element clock is
    :math:`u(\tau) = 2\,\mathrm{BLF}\,(\tau + \mathrm{drift}\,\tau^2/(2T))` from the reply start
    (T its nominal duration). Noise chunk k of :data:`NOISE_CHUNK` samples is drawn from
    ``trial_rng(seed, 0, k)``.

    Parameters
    ----------
    items : sequence of tuple
        ``(command, SynthReply or None, CW after the command's last rising edge [s])``, in
        order after ``lead_s`` of CW.
    fs_hz : float
        Sample rate [Hz].
    trcal_s : float or None
        TRcal of the Query preambles [s].
    tari_s : float, default 12.5e-6
        Tari [s].
    leak : complex, default 0.8 + 0.3j
        Carrier leakage L [√W].
    h : complex, default 0.02 - 0.03j
        Tag gain h [√W].
    noise_rms : float, default 1e-3
        RMS of the complex white noise [√W].
    seed : int, default 0
        Seed of the noise.
    lead_s : float, default 300e-6
        CW before the first command and after the last item [s].

    Returns
    -------
    x : ndarray, shape (n,), complex64
        The capture [√W].
    truth : list of tuple
        ``(reply, start_s)`` of every reply, start [s] from sample 0.
    """
    lead = int(round(lead_s * fs_hz))
    cmds, replies, n0 = [], [], lead
    for cmd, reply, gap_s in items:
        env, n_span, end_s = _pie(cmd, tari_s=tari_s, trcal_s=trcal_s, fs_hz=fs_hz, gap_s=gap_s)
        cmds.append((n0, env))
        if reply is not None:
            t1 = max(3.0 * tari_s, 10.0 / reply.blf_hz) if reply.t1_s is None else reply.t1_s
            replies.append((reply, n0 / fs_hz + end_s + t1))
        n0 += n_span
    n = n0 + lead
    x = np.empty(n, dtype=np.complex64)
    rest = leak - h  # e = 1, s = −1: the carrier with the tag absorbing
    for k, a in enumerate(range(0, n, NOISE_CHUNK)):
        b = min(n, a + NOISE_CHUNK)
        rng = trial_rng(seed, 0, k)
        x[a:b] = rest + noise_rms / math.sqrt(2) * (rng.standard_normal(b - a) + 1j * rng.standard_normal(b - a))
    starts = np.array([c[0] for c in cmds], dtype=np.int64)

    def envelope(a, b):
        e = np.ones(b - a)
        for i in range(max(0, int(np.searchsorted(starts, a, side="right")) - 1), len(cmds)):
            c0, env = cmds[i]
            if c0 >= b:
                break
            lo, hi = max(a, c0), min(b, c0 + env.size)
            if hi > lo:
                e[lo - a: hi - a] = env[lo - c0: hi - c0]
        return e

    for c0, env in cmds:  # the command's low pulses: (e − 1)·(L − h)
        x[c0: c0 + env.size] += ((env - 1.0) * rest).astype(np.complex64)
    truth = []
    for reply, t_start in replies:  # the reply: e·h·(s + 1), s = ±1 inside, −1 outside
        el = halfsymbols(reply.bits, m=reply.m, trext=reply.trext).astype(np.float64)
        dur = el.size / (2.0 * reply.blf_hz)
        a = max(0, int(math.floor(t_start * fs_hz)))
        b = min(n, int(math.ceil((t_start + dur * (1.0 + abs(reply.drift))) * fs_hz)) + 2)
        tau = np.arange(a, b) / fs_hz - t_start
        u = 2.0 * reply.blf_hz * (tau + reply.drift * tau * tau / (2.0 * dur))
        k = np.floor(u).astype(np.int64)
        on = (u >= 0) & (k < el.size)
        s = np.full(b - a, -1.0)
        s[on] = el[k[on]]
        x[a:b] += (h * envelope(a, b) * (s + 1.0)).astype(np.complex64)
        truth.append((reply, t_start))
    return x, truth


def exchange_items(n_replies: int, *, m: int, with_query: bool, duration_s: float, blf_hz: float,
                   seed: int = 0) -> list:
    """Spread tag replies evenly over a capture, as command/reply items for :func:`synthetic_capture`.

    Pairs Query → RN16 and ACK → PC + EPC + CRC-16 (``with_query``), or ACK → EPC and
    Req_RN → handle + CRC-16 (no Query: the tag link is searched blind, then learned).

    Parameters
    ----------
    n_replies : int
        Number of tag replies (two per pair, at least one pair).
    m : int
        Line code of the replies (1 = FM0, 2/4/8 = Miller), without pilot.
    with_query : bool
        Whether the pairs open with a Query.
    duration_s : float
        Span of the capture [s].
    blf_hz : float
        BLF of the replies [Hz].
    seed : int, default 0
        Seed of the RN16s and handles.

    Returns
    -------
    list of tuple
        ``(command, SynthReply, CW after the command [s])`` items.
    """
    n_pairs = max(1, n_replies // 2)
    gap = duration_s / n_pairs - 4.0e-3
    epc = append_crc16(np.concatenate([PC_BITS, EPC_BITS]))
    link = dict(m=m, trext=False, blf_hz=blf_hz)
    items = []
    for k in range(n_pairs):
        rn = trial_rng(seed, 7, k).integers(0, 2, 16).astype(np.uint8)
        if with_query:
            items += [(Query(dr="64/3", m=m, trext=False, q=0), SynthReply(rn, **link), 0.6e-3),
                      (ACK(rn16=bits_to_int(rn)), SynthReply(epc, **link), gap)]
        else:
            handle = trial_rng(seed, 8, k).integers(0, 2, 16).astype(np.uint8)
            items += [(ACK(rn16=bits_to_int(rn)), SynthReply(epc, **link), 2.6e-3),
                      (ReqRN(rn16=bits_to_int(rn)), SynthReply(append_crc16(handle), **link), gap)]
    return items


def _decode_timed(x, fs_hz):
    from rfsim.gen2.capture import decode_reader_commands
    from rfsim.gen2.replies import decode_tag_replies

    c0, t0 = time.process_time(), time.perf_counter()
    records, _ = decode_reader_commands(x, fs_hz)
    replies = decode_tag_replies(x, fs_hz, records)
    return records, replies, time.perf_counter() - t0, time.process_time() - c0


def access_session(handle: int = 0xBEEF) -> list:
    """An access session as exchanges of :mod:`rfsim.gen2.synthetic_capture`: Query → RN16,
    ACK → PC + EPC + CRC-16, Req_RN → handle, Read → two words, Read → error (memory overrun),
    Write → delayed error (memory locked), BlockWrite, BlockErase and Lock → delayed success,
    Kill, Kill → handle, then delayed success (Req_RN before each cover-coded command).

    Parameters
    ----------
    handle : int, default 0xBEEF
        The tag's handle.

    Returns
    -------
    list of rfsim.gen2.synthetic_capture.Exchange
        The session, 14 commands and 14 replies (5 delayed, 1 ms after T1).
    """
    epc = append_crc16(np.concatenate([PC_BITS, EPC_BITS]))
    req = Exchange(ReqRN(rn16=handle), rn_reply(0x5A5A))
    late = dict(delayed=True, delay_s=1e-3)
    return [Exchange(Query(dr="64/3", m=4, q=0), int_to_bits(0x1234, 16)), Exchange(ACK(rn16=0x1234), epc),
            Exchange(ReqRN(rn16=0x1234), rn_reply(handle)),
            Exchange(Read(membank=3, word_ptr=0, word_count=2, rn16=handle), read_reply([0xCAFE, 0x0102], handle)),
            Exchange(Read(membank=3, word_ptr=90, word_count=2, rn16=handle), error_reply(0x03, handle)),
            req, Exchange(Write(membank=3, word_ptr=0, data=0x1234, rn16=handle), error_reply(0x04, handle), **late),
            Exchange(BlockWrite(membank=3, word_ptr=0, data=(1, 2), rn16=handle), success_reply(handle), **late),
            Exchange(BlockErase(membank=3, word_ptr=0, word_count=2, rn16=handle), success_reply(handle), **late),
            Exchange(Lock(mask=0b11, action=0b01, rn16=handle), success_reply(handle), **late),
            req, Exchange(Kill(password=0xDEAD, rn16=handle), rn_reply(handle)),
            req, Exchange(Kill(password=0xBEEF, rn16=handle), success_reply(handle), **late)]


def bench_decode(*, duration_s: float = 10.0, fs_hz: float = 2e6, reply_counts=(10, 100, 500),
                 line_codes=(1, 4), queries=(True, False), blf_hz: float = 256e3 * 1.01, seed: int = 0,
                 access_rates=(2e6, 25e6)) -> dict:
    """Time the decoding of synthetic captures (module docstring).

    Every combination of reply count, line code (1 = FM0, 4 = Miller-4) and with/without Query
    on a ``duration_s`` capture at ``fs_hz``. Compile time is excluded (the first 50 ms of each
    capture are decoded first).

    Parameters
    ----------
    duration_s : float, default 10.0
        Capture duration [s].
    fs_hz : float, default 2e6
        Sample rate [Hz].
    reply_counts : sequence of int, default (10, 100, 500)
        Replies per capture.
    line_codes : sequence of int, default (1, 4)
        Line codes M.
    queries : sequence of bool, default (True, False)
        With and/or without Query.
    blf_hz : float, default 256e3 * 1.01
        BLF of the tag [Hz] (1 % off the nominal 256 kHz).
    seed : int, default 0
        Seed of the captures.
    access_rates : sequence of float, default (2e6, 25e6)
        Sample rates [Hz] of an access session (:func:`access_session`, magnitude only, with
        and without its Query) also decoded.

    Returns
    -------
    dict
        Per case ``<query|no_query>_<fm0|millerM>_<n>``: ``_wall_s`` and ``_cpu_s`` [s],
        ``_real_time_factor_wall`` / ``_cpu`` (capture duration / time), ``_replies_found``
        ("found/sent") and ``_all_decoded`` (every reply found and decoded correctly: RN16s as
        encoded, every CRC good); and ``worst_real_time_factor_wall``, ``duration_s``,
        ``fs_hz``, ``blf_hz``; per access case ``access_<query|no_query>_<fs in MS/s>``:
        ``_wall_s``, ``_capture_s`` (its duration [s]) and ``_replies_exact`` ("exact/sent":
        replies found with the bits sent).
    """
    out: dict = {"duration_s": duration_s, "fs_hz": fs_hz, "blf_hz": blf_hz}
    worst = math.inf
    for with_query in queries:
        for m in line_codes:
            for n_rep in reply_counts:
                items = exchange_items(n_rep, m=m, with_query=with_query, duration_s=duration_s, blf_hz=blf_hz,
                                       seed=seed)
                x, truth = synthetic_capture(items, fs_hz=fs_hz, trcal_s=64 / 3 / 256e3, seed=seed)
                _decode_timed(x[: int(0.05 * fs_hz)], fs_hz)  # compile / load the kernels
                records, replies, wall, cpu = _decode_timed(x, fs_hz)
                sent = [bits for _, r, _ in items if r is not None for bits in [r.bits]]
                exact = len(replies) == len(sent) and all(
                    (rep.crc_ok is True) if rep.kind != "RN16" else rep.bits == "".join(map(str, b))
                    for rep, b in zip(replies, sent))
                name = f"{'query' if with_query else 'no_query'}_{'fm0' if m == 1 else f'miller{m}'}_{n_rep}"
                out[f"{name}_wall_s"] = wall
                out[f"{name}_cpu_s"] = cpu
                out[f"{name}_real_time_factor_wall"] = duration_s / wall
                out[f"{name}_real_time_factor_cpu"] = duration_s / cpu
                out[f"{name}_replies_found"] = f"{len(replies)}/{len(sent)}"
                out[f"{name}_all_decoded"] = bool(exact)
                worst = min(worst, duration_s / wall)
                del x
    out["worst_real_time_factor_wall"] = worst
    for rate in access_rates:
        for with_query in queries:
            session = access_session()
            link = SyntheticLink(blf_hz=blf_hz, m=4)
            cap = exchange_capture(session if with_query else session[1:], fs_hz=rate, link=link, tag_depth=0.03,
                                   noise_rms=2e-3, rng=trial_rng(seed, 9))
            x = cap.magnitude.astype(np.float32)
            _decode_timed(x[: int(0.002 * rate)], rate)
            _, replies, wall, _ = _decode_timed(x, rate)
            sent = {t.index: "".join(map(str, t.bits)) for t in cap.replies}
            exact = sum(rep.bits == sent.get(rep.command_index) for rep in replies)
            name = f"access_{'query' if with_query else 'no_query'}_{rate / 1e6:g}"
            out[f"{name}_wall_s"] = wall
            out[f"{name}_capture_s"] = x.size / rate
            out[f"{name}_replies_exact"] = f"{exact}/{len(sent)}"
    return out


__all__ = ["SynthReply", "synthetic_capture", "exchange_items", "access_session", "bench_decode", "PC_BITS",
           "EPC_BITS"]

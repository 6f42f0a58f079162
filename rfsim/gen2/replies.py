"""Tag replies in recorded captures: search, link estimation, timing tracking, decoding.

After every reader command that elicits a reply (gen2-and-validation-anchors.md §4.3–4.4;
EPC Gen2 v2 §6.3.2.12.3: Query/QueryRep/QueryAdjust → RN16; ACK → PC + EPC + CRC-16; Req_RN,
Access, the first Kill → handle + CRC-16; Read → header 0 + words + handle + CRC-16 or the
error reply header 1 + code(8) + handle + CRC-16) the reply is searched in the T1 window
after the command's last rising edge, T1 = max(RTcal, 10/BLF)·(1 ± FrT) ± 2 µs (§4.3). After
Write, BlockWrite, BlockErase, Lock and the final Kill (a Kill that follows a Kill, with only
Req_RN between) the tag answers with a delayed (in-process) reply, success header 0 + handle +
CRC-16 (33 bits) or error (41 bits), sent with the extended preamble (the pilot, as if
TRext = 1) up to T5 max = 20 ms after the command (:data:`rfsim.gen2.link.T_MAX_S`): its
window runs from T1 min to T1 max + 20 ms, or to the next command. Select and NAK elicit no
reply. In
a monostatic capture the reply rides on the reader's CW leakage, a constant complex offset
c over the window; outside its reply the tag rests in its absorbing state, the reply's −1
level, so the window is ``r = c + h·s(t) + noise`` with s = ±1 the line code during the
reply and −1 around it. A magnitude-only capture |c + h·s| ≈ |c| + Re(h·c*/|c|)·s has the
same form with real h (|h| ≪ |c|). Steps per window:

1. **Working rate**: the window, with the mean of its samples before the earliest reply
   start removed, is averaged over boxcars of D samples, D = floor(fs/(2·BLF_max·6)) (≥ 6
   samples per element of half a subcarrier cycle at the highest BLF searched; sample j of
   the result is at (j·D + (D − 1)/2)/fs). Decoding needs no more, and pre-filtered,
   decimated captures are handled alike.
2. **Detection** (the simulated reader's rule, :func:`rfsim.gen2.capture.preamble_threshold`):
   maximum zero-mean normalised preamble correlation over the T1 lags of every link
   hypothesis (M, TRext, BLF on a geometric grid of relative step 1/(2·preamble
   elements)); the threshold γ makes P(false alarm) = ``false_alarm_probability`` per
   window on white noise, corr² ~ Beta(1, n − 2) with the union bound over all lags and
   hypotheses tested. With the line code known (a Query in the capture, or given) the BLF
   grid spans DR/TRcal·(1 ± FrT); without it, M ∈ {1, 2, 4, 8}, TRext ∈ {0, 1} and BLF
   over the Gen2 range 40–640 kHz widened by the largest FrT (22 %) are searched blind.
   After a reply, the next window is searched first within ±2 coarse steps of its BLF, and
   over the whole range when that finds nothing or its best lies at the narrow range's edge
   (another tag), the threshold counting both searches (:func:`rfsim.gen2.reply_search._detect`).
3. **BLF from the reply itself**: BLFs across ±2 coarse steps are decoded over the first
   16 bits, coarse to fine (17 BLFs, then the span narrowed to one step around the best)
   down to a step of 1/(4·their elements); the one whose remodulated reply
   (rest level −1 around it) leaves the least residual power under
   :func:`rfsim.gen2.capture.fit_gain_offset` wins. That gives the reply's length (EPC:
   the PC's L field); the search is repeated over the whole reply across ±2 steps of the
   first bits' search around their BLF, first on a grid of 1/(2·its elements) (the whole
   reply's residual has a minimum ≈ 1/elements wide in BLF: a coarser grid can step over
   it and settle on a wrong BLF), then narrowed down to a step of 1/(4·its elements)
   (decoding needs the BLF to ≈ 1/(4·elements), 0.02 % for a 128-bit Miller-4 reply). A reply the next command cuts is decoded to its
   last whole bit (**truncated**: reported with the bits that fit, never as a complete
   frame).
4. **Timing tracking** (tag clock drift, :mod:`rfsim.gen2.reply_tracking`): with the decoded bits as reference the reply is
   cut into blocks of ≈ 24 elements (at least 6 blocks); in each block the timing offset
   δ_b that maximises the correlation with the remodulated reply (averaged over each
   sample interval at 4 points, so that the correlation varies smoothly with δ even where
   a sample is taken at one point of a sharp edge) is found on a 1/16-element grid within
   ±1/2 element of a prediction and refined by the peak of the triangular correlation. A
   weighted least-squares quadratic δ(t) (start, BLF, linear BLF drift; a line for replies
   of fewer than 8 blocks) is fitted over growing spans from the reply start (¼, ½, all),
   each span's offsets searched around the previous fit's extrapolation — a
   tracking loop that follows a timing error growing past half an element towards the
   end. The element clock u(t) = u₁·t + u₂·t² is updated, the window resampled on the tag's
   clock (linear interpolation) and decoded again (twice, unless the first pass moved the
   clock by ≤ :data:`rfsim.gen2.reply_decoding.TRACK_CONVERGED_ELEMENTS` of an element and
   left the bits unchanged). Reported: the mean BLF (u₁ + u₂·T)·fs_w/2 over the reply's T
   samples and the drift, the relative BLF change across it, 2·u₂·T/u₁.
5. **Validation**: (h, c) by least squares over the decision-free samples (preamble and
   rest level), then over the whole remodulated reply; the reply is kept only if its
   energy per half-bit over the residual noise, E_h/N₀ = |h|²·(samples per half-bit)/σ²,
   is ≥ :data:`MIN_HALFBIT_SNR_DB` (noise forced through the decoder gives ≈ 0 dB), so
   coloured or impulsive noise that passes the correlation test is not reported.
   RSSI 10·log10|h|² + 30 (dBm if the capture is in √W, else dB relative to its unit),
   phase (−arg h) mod 2π and SNR |h|²/σ² per sample at the capture's rate, as the
   simulated reader defines them (rfsim.devices.reader ``ReadResult``).

Steps 1–5 run as the one reply decoder's steps (:func:`rfsim.gen2.reply_decoder.decode`, its
"link" plan: the conditioning and the delayed reply's spans there, the search of step 2 in
:mod:`rfsim.gen2.reply_search`, steps 3–5 in :mod:`rfsim.gen2.reply_decoding`, the tracking
loop of step 4 in :mod:`rfsim.gen2.reply_tracking`); this module cuts the window after each
command, chooses the hypotheses and makes the records.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.gen2.access import ERROR_REPLY_BITS, SUCCESS_REPLY_BITS
from rfsim.gen2.bits import bits_to_int, bits_to_str
from rfsim.gen2.capture import ReaderCommandRecord
from rfsim.gen2.commands import DR_VALUES, normalize_dr
from rfsim.gen2.link import BLF_RANGE_HZ, M_VALUES, T_MAX_S, TRCAL_TABLE_RANGE_S, frt_fraction, t1_range
from rfsim.gen2.memory import TagError
from rfsim.gen2.linecode import METHODS
from rfsim.gen2.reply_decoder import CaptureTiming, DecodePlan, decode
from rfsim.gen2.reply_decoding import MIN_HALFBIT_SNR_DB, _NBitsRule, fixed_length
from rfsim.gen2.reply_core import n_reply_elements
from rfsim.gen2.reply_search import LinkHypothesis, boxcar_decimate, preamble_correlation
from rfsim.core.lazy import lazy_import

_rk = lazy_import("rfsim.gen2._reply_kernels")

#: Reply searched after each command (anchors §4.4; EPC Gen2 v2 §6.3.2.12.3): "delayed" is the
#: in-process reply (success or error, extended preamble, T5); a Kill that follows a Kill is
#: the final one, whose reply is delayed (:func:`decode_tag_replies`).
REPLY_KIND = {"Query": "RN16", "QueryRep": "RN16", "QueryAdjust": "RN16", "ACK": "EPC", "Req_RN": "handle",
              "Read": "read", "Access": "handle", "Kill": "handle", "Write": "delayed", "BlockWrite": "delayed",
              "BlockErase": "delayed", "Lock": "delayed"}
#: FrT assumed when the divide ratio or TRcal is unknown (the largest value of the table).
FRT_UNKNOWN = 0.22
#: BLF range of the blind search [Hz]: the Gen2 range widened by FRT_UNKNOWN.
BLIND_BLF_RANGE_HZ = (BLF_RANGE_HZ[0] * (1 - FRT_UNKNOWN), BLF_RANGE_HZ[1] * (1 + FRT_UNKNOWN))
#: A window whose variance is below this fraction of its power holds no modulation at all.
_MIN_RELATIVE_VARIANCE = 1e-12


@dataclass(frozen=True)
class TagReplyRecord:
    """One tag reply found in a capture.

    Attributes
    ----------
    command_index : index of the preceding reader command in the command records
    command : its name ("Query", "ACK", "Req_RN", …)
    kind : "RN16", "EPC" (PC + EPC + CRC-16), "handle" (RN16 + CRC-16), "read"
        (header 0 + words + handle + CRC-16), "success" (header 0 + handle + CRC-16, a
        delayed reply) or "error" (header 1 + code + handle + CRC-16, delayed or after Read)
    start_s : start of the reply (pilot or preamble) [s]
    bits : decoded data bits as a 0/1 string (dummy 1 removed)
    blf_hz : BLF measured on the reply (its mean over the reply) [Hz]
    blf_drift : relative BLF change from the reply's start to its end (tracked)
    m, trext : line code of the reply (1 = FM0, 2/4/8 = Miller), pilot
    corr : normalised preamble correlation (0…1) at the decoded start and BLF (on the
        tag's clock)
    truncated : the next command (or the capture's end) cut the reply at ``end_s``;
        ``bits`` holds the whole bits before the cut
    end_s : end of the reply, or where it was cut [s]
    n_bits_expected : data bits of the complete reply (−1 when unknown)
    crc_ok : CRC-16 over the reply (EPC, handle, read, success, error); None for an RN16 or
        truncated reply
    rn16 : the RN16 (RN16 replies) or the handle (handle, read, success, error replies), else None
    pc, epc_hex : PC word and EPC as upper-case hex (EPC replies), else None
    data_hex : the words read (read replies), else None
    rssi_dbm, phase_rad, snr_db : step 5 of the module docstring
    delayed : the reply was searched as a delayed (in-process) reply, up to 20 ms after the command
    error_code, error_name : code of an error reply and its name (EPC Gen2 v2 Annex I,
        :class:`rfsim.gen2.memory.TagError`; "0x.." for a code not named there), else None
    latency_s : from the command's last rising edge to the reply's start [s] (T1, or T5 of a
        delayed reply)
    """

    command_index: int
    command: str
    kind: str
    start_s: float
    bits: str
    blf_hz: float
    m: int
    trext: bool
    corr: float
    truncated: bool = False
    end_s: float = math.nan
    n_bits_expected: int = -1
    blf_drift: float = 0.0
    crc_ok: bool | None = None
    rn16: int | None = None
    pc: int | None = None
    epc_hex: str | None = None
    data_hex: str | None = None
    rssi_dbm: float = math.nan
    phase_rad: float = math.nan
    snr_db: float = math.nan
    delayed: bool = False
    error_code: int | None = None
    error_name: str | None = None
    latency_s: float = math.nan


def _error_name(code: int) -> str:
    """Name of a Gen2 error code (:class:`rfsim.gen2.memory.TagError`), or its hex value."""
    try:
        return TagError(code).name
    except ValueError:
        return f"0x{code:02X}"


def _header_fields(kind: str, bits: np.ndarray, truncated: bool, crc_ok: bool | None) -> dict:
    """Kind, handle and error code of a reply that starts with a header bit (read or delayed
    window): header 1 is an error reply, header 0 read data or a delayed success."""
    out: dict = {"kind": "error" if bits.size and bits[0] == 1 else ("read" if kind == "read" else "success")}
    out["crc_ok"] = crc_ok
    if out["kind"] == "error":
        if bits.size >= 9:
            code = bits_to_int(bits[1:9])
            out.update(error_code=code, error_name=_error_name(code))
        if bits.size >= 25:
            out["rn16"] = bits_to_int(bits[9:25])
    elif out["kind"] == "success" and bits.size >= 17:
        out["rn16"] = bits_to_int(bits[1:17])
    elif out["kind"] == "read" and not truncated and bits.size >= 33:
        data = bits[1:-32]
        out["data_hex"] = "".join(f"{bits_to_int(data[i:i + 4]):X}" for i in range(0, data.size, 4))
        out["rn16"] = bits_to_int(bits[-32:-16])
    return out


def _reply_fields(kind: str, bits: np.ndarray, truncated: bool, crc_ok: bool | None) -> dict:
    """RN16/handle/PC/EPC/data/error code of a decoded reply (``bits`` (n,) uint8) with its CRC
    check ``crc_ok`` (the decoder's CRC step, :func:`rfsim.gen2.reply_decoder.decode` with
    ``crc``; None: truncated or an RN16), and its kind where the header bit tells it (read or
    delayed window)."""
    out: dict = {}
    if kind in ("read", "delayed"):
        return _header_fields(kind, bits, truncated, crc_ok)
    if kind == "RN16":
        if bits.size >= 16:
            out["rn16"] = bits_to_int(bits[:16])
        return out
    out["crc_ok"] = crc_ok
    if kind == "EPC":
        if bits.size >= 16:
            out["pc"] = bits_to_int(bits[:16])
        epc = bits[16:-16] if not truncated else bits[16:16 + 16 * ((bits.size - 16) // 16)]
        n_hex = epc.size // 4
        out["epc_hex"] = f"{bits_to_int(epc[:4 * n_hex]):0{n_hex}X}" if n_hex else ""
    elif kind == "handle":
        if bits.size >= 16:
            out["rn16"] = bits_to_int(bits[:16])
    return out


def _max_bits(kind: str, rec: ReaderCommandRecord) -> int:
    """Most data bits a reply of ``kind`` can have: RN16 16, handle 32, EPC 32 + 16·31 (the
    PC's 5-bit L field), read 1 + 16·WordCount + 32 (WordCount 0: 255 words) or an error
    reply, delayed: an error reply (41)."""
    if kind == "RN16":
        return 16
    if kind == "handle":
        return 32
    if kind == "read":
        return max(1 + 16 * (int(rec.fields.get("word_count", 0)) or 255) + 32, ERROR_REPLY_BITS)
    if kind == "delayed":
        return ERROR_REPLY_BITS
    return 32 + 16 * 31


@dataclass(frozen=True)
class _HeaderRule:
    """``n_bits_of(bits)`` of a reply that starts with a header bit: ``if_zero`` data bits
    after a 0 (read data, delayed success; −1 unknown), ``if_one`` after a 1 (error reply)."""

    if_zero: int
    if_one: int = ERROR_REPLY_BITS

    def __call__(self, bits) -> int:
        if len(bits) == 0:
            return -1
        return self.if_one if bits[0] == 1 else self.if_zero


def _n_bits_rule(kind: str, rec: ReaderCommandRecord):
    """``n_bits_of(bits)`` of a reply kind: the complete reply's data bits (−1 unknown)."""
    if kind == "RN16":
        return fixed_length(16)
    if kind == "handle":
        return fixed_length(32)
    if kind == "read":
        wc = int(rec.fields.get("word_count", 0))
        return _HeaderRule(1 + 16 * wc + 32 if wc > 0 else -1)
    if kind == "delayed":
        return _HeaderRule(SUCCESS_REPLY_BITS)
    return _NBitsRule(_rk.RULE_EPC)


def decode_tag_reply(samples, fs_hz: float, *, listen_s: float, window_end_s: float, cmd_end_s: float,
                     rtcal_s: float, frt: float, hypotheses, kind: str, n_bits_of, max_bits: int,
                     cut_s: float | None = None,
                     method: str = "viterbi", false_alarm_probability: float = 1e-3, command_index: int = -1,
                     command: str = "", blf_hint_hz: float | None = None,
                     delayed: bool = False, plans: dict | None = None) -> TagReplyRecord | None:
    """Search, decode and check one tag reply in a capture (module docstring, steps 1–5).

    Parameters
    ----------
    samples : (n,) complex baseband or real envelope, arbitrary scale, sample k at k/fs [s]
    fs_hz : sample rate [Hz]
    listen_s, window_end_s : the part of the capture used [s] (after the command's last edge
        has settled, up to before the next command)
    cmd_end_s, rtcal_s, frt : the command's last rising edge [s], its RTcal [s] and the BLF
        tolerance FrT that set the T1 window
    hypotheses : sequence of :class:`LinkHypothesis` searched
    kind : reply kind (:data:`REPLY_KIND` values)
    n_bits_of : callable
        ``n_bits_of(bits)`` the complete reply's data bits from its first decoded bits
        (−1 unknown)
    max_bits : int
        The most data bits the reply can have (the window is cut after the longest reply)
    cut_s : where the window is cut (the next command's start) [s]; default ``window_end_s``
    method : "viterbi" or "bitwise"
    false_alarm_probability : per window, sets the detection threshold

    command_index, command : written into the record (the preceding command)
    blf_hint_hz : BLF of an earlier reply in the capture: a single hypothesis is searched
        first within ±2 coarse steps of it (:func:`rfsim.gen2.reply_search._detect`)
    delayed : bool
        Search a delayed reply: its start anywhere from T1 min to T1 max + 20 ms
        (:data:`rfsim.gen2.link.T_MAX_S`; module docstring)
    plans : dict or None
        Where the decode plans (:class:`rfsim.gen2.reply_decoder.DecodePlan`, with the BLF grids
        and octaves they keep) are kept between the windows of one capture, by hypotheses,
        method, false-alarm probability and rate; default None, a plan for this window only

    Returns
    -------
    TagReplyRecord or None
        The decoded reply, or None when no reply is detected and validated.

    Raises
    ------
    ValueError
        If ``method`` is not one of :data:`METHODS`.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    hyps = list(hypotheses)
    if not hyps:
        return None
    fs = float(fs_hz)
    x = np.asarray(samples)
    i0 = max(0, int(math.ceil(listen_s * fs)))
    delay_max_s = T_MAX_S if delayed else 0.0
    # no longer than the longest reply any hypothesis allows (rest level around it included)
    longest_s = delay_max_s + max(t1_range(rtcal_s=rtcal_s, blf_hz=h.blf_lo_hz, frt=frt).max_s
                                  + n_reply_elements(max_bits, h.m, h.trext) / (2.0 * h.blf_lo_hz) for h in hyps)
    end_s = min(window_end_s, cmd_end_s + longest_s + 16.0 / fs + 2e-6)
    i1 = min(x.size, int(math.floor(end_s * fs)))
    if i1 - i0 < 16:
        return None
    r = x[i0:i1].astype(np.complex128)
    power = float(np.mean(r.real * r.real + r.imag * r.imag))
    if power == 0.0 or power - abs(complex(r.sum()) / r.size) ** 2 <= _MIN_RELATIVE_VARIANCE * power:
        return None
    t1_earliest = min(t1_range(rtcal_s=rtcal_s, blf_hz=h.blf_hi_hz, frt=frt).min_s for h in hyps)
    lo_full = int(math.floor((cmd_end_s + t1_earliest) * fs)) - i0 - 1  # step 1's lead (the decoder's)
    key = (tuple(hyps), method, false_alarm_probability, fs)
    plan = None if plans is None else plans.get(key)
    if plan is None:
        plan = DecodePlan("link", fs, method=method, false_alarm_probability=false_alarm_probability,
                          hypotheses=key[0], track_timing=True)
        if plans is not None:
            plans[key] = plan
    out = decode(r, plan, blf_hint_hz=blf_hint_hz, crc=kind != "RN16",
                 timing=CaptureTiming(i0, cmd_end_s, rtcal_s, frt, delay_max_s, lo_full, bool(delayed), n_bits_of))
    if not out.found:
        return None
    res = out.extra
    d = res["decimation"]
    centre = 0.5 * (d - 1)
    bits = out.bits
    to_s = lambda j: (i0 + j * d + centre) / fs  # noqa: E731  (working-rate sample → time)
    h = out.gain
    p = abs(h) ** 2
    snr = 10.0 * math.log10(p / (out.sigma2 * d)) if out.sigma2 > 0 else math.inf
    truncated = bool(res["truncated"])
    fields = {"kind": kind, **_reply_fields(kind, bits, truncated, out.crc_ok)}
    start_s = float(to_s(out.start))
    return TagReplyRecord(
        command_index=int(command_index), command=str(command), start_s=start_s, bits=bits_to_str(bits),
        blf_hz=out.blf_hz, m=int(res["m"]), trext=bool(res["trext"]), corr=out.corr, truncated=truncated,
        end_s=float(((window_end_s if cut_s is None else cut_s) if end_s >= window_end_s else end_s) if truncated
                    else to_s(res["end"])),
        n_bits_expected=int(res["n_full"]), blf_drift=float(res["drift"]),
        rssi_dbm=10.0 * math.log10(p) + 30.0 if p > 0 else -math.inf,
        phase_rad=float((-np.angle(h)) % (2.0 * math.pi)), snr_db=snr, delayed=bool(delayed),
        latency_s=start_s - float(cmd_end_s), **fields)


def _hypotheses(query: ReaderCommandRecord | None, learned, *, blf_hz, trcal_s, dr, m, trext, blf_tolerance,
                delayed=False):
    """``(hypotheses, frt)`` for the reply after a command: the line code of the last Query
    (or the caller's), BLF = DR/TRcal·(1 ± FrT) or the given BLF·(1 ± tolerance); what is not
    known is searched blind (:data:`BLIND_BLF_RANGE_HZ`, every M and TRext), unless an
    earlier reply in the capture (``learned`` = (m, trext, blf)) already told it. A delayed
    reply has the pilot whatever TRext (the extended preamble)."""
    f = query.fields if query is not None else {}
    m = f.get("m") if m is None else m
    trext = f.get("trext") if trext is None else trext
    dr = f.get("dr") if dr is None else dr
    trcal = (query.trcal_s if query is not None else math.nan) if trcal_s is None else trcal_s
    frt = FRT_UNKNOWN
    if dr is not None and not math.isnan(trcal):
        lo_s, hi_s = TRCAL_TABLE_RANGE_S[dr]
        # a TRcal measured within 5 % outside the table (edge quantisation, reader clock)
        # takes the nearest row
        t = min(max(trcal, lo_s), hi_s) if 0.95 * lo_s <= trcal <= 1.05 * hi_s else trcal
        try:
            frt = frt_fraction(dr, t)
        except ConfigError:
            pass
    if blf_hz is not None:
        blf, tol = float(blf_hz), 0.02 if blf_tolerance is None else blf_tolerance
    elif dr is not None and not math.isnan(trcal):
        blf, tol = float(DR_VALUES[dr]) / trcal, frt if blf_tolerance is None else blf_tolerance
    else:
        blf, tol = None, None
    if blf is None and m is None and trext is None and learned is not None:
        m, trext, blf = learned
        tol = 0.1 if blf_tolerance is None else blf_tolerance
    lo, hi = (BLIND_BLF_RANGE_HZ if blf is None else (blf * (1 - tol), blf * (1 + tol)))
    ms = M_VALUES if m is None else (int(m),)
    trexts = (True,) if delayed else (False, True) if trext is None else (bool(trext),)
    return [LinkHypothesis(mm, tt, lo, hi) for mm in ms for tt in trexts], frt


def decode_tag_replies(samples, fs_hz: float, records: list[ReaderCommandRecord], *,
                       blf_hz: float | None = None, trcal_s: float | None = None, dr=None,
                       m: int | None = None, trext: bool | None = None, blf_tolerance: float | None = None,
                       method: str = "viterbi", false_alarm_probability: float = 1e-3,
                       max_blind_misses: int = 4) -> list[TagReplyRecord]:
    """Find and decode the tag reply after every command of ``records`` that elicits one
    (:data:`REPLY_KIND`; ``records`` from :func:`rfsim.gen2.capture.decode_reader_commands`).

    Parameters
    ----------
    samples : (n,) complex baseband capture or real envelope, arbitrary scale
    fs_hz : sample rate [Hz]
    records : the reader commands found in ``samples``
    blf_hz : the tags' BLF [Hz]; default DR/TRcal of the last Query (TRcal measured), else
        searched blind
    trcal_s, dr, m, trext : override the last Query's measured TRcal [s] and parsed DR
        ("8" or "64/3"), M (1, 2, 4, 8) and TRext
    blf_tolerance : relative BLF search range; default FrT when the BLF comes from TRcal,
        2 % when ``blf_hz`` is given
    method, false_alarm_probability : see :func:`decode_tag_reply`
    max_blind_misses : a blind search (no Query, no link given) costs about a second per
        window; after this many blind windows without a reply the remaining windows that would
        need one are not searched (give the link, or a capture with a Query, to search them).
        Once a reply has told the link (M, TRext, BLF), later windows are searched with it
        first (BLF ± 10 %), and blind only when that finds no reply (a tag with another link)

    The reply after command k is searched from half a Tari after its last rising edge up to
    half a Tari before command k + 1 (or the capture's end), its start within the T1 window
    of the BLF range searched (RTcal measured on the command), or, after Write, BlockWrite,
    BlockErase, Lock and the final Kill (the second of two Kills with only Req_RN between),
    from T1 min to T1 max + 20 ms with the pilot (a delayed reply; long windows around the
    onsets of :func:`rfsim.gen2.reply_search.modulation_onsets`).

    Returns
    -------
    list of TagReplyRecord
        The replies found, in time order.
    """
    fs = float(fs_hz)
    if not (math.isfinite(fs) and fs > 0):
        raise ValueError(f"fs_hz must be > 0, got {fs_hz}")
    if blf_hz is not None and not (math.isfinite(blf_hz) and blf_hz > 0):
        raise ConfigError("blf", blf_hz, "a positive frequency in Hz")
    if trcal_s is not None and not (math.isfinite(trcal_s) and trcal_s > 0):
        raise ConfigError("trcal", trcal_s, "a positive duration in s")
    if dr is not None:
        dr = normalize_dr(dr, "dr")
    if m is not None and m not in M_VALUES:
        raise ConfigError("m", m, "1 (FM0), 2, 4 or 8 (Miller)")
    if blf_tolerance is not None and not 0.0 <= blf_tolerance < 0.5:
        raise ConfigError("blf_tolerance", blf_tolerance, "a fraction in [0, 0.5)")
    out: list[TagReplyRecord] = []
    plans: dict = {}  # the decode plans of this capture (decode_tag_reply)
    query, learned, blind_misses, kill_pending = None, None, 0, False
    n = np.asarray(samples).size
    for k, rec in enumerate(records):
        if rec.name == "Query" and rec.fields:
            query = rec
        kind = REPLY_KIND.get(rec.name)
        if rec.name == "Kill" and rec.fields:  # the second Kill of a pair is the final one
            kind, kill_pending = ("delayed", False) if kill_pending else (kind, True)
        elif rec.name != "Req_RN":
            kill_pending = False
        if kind is None or not rec.fields or math.isnan(rec.end_s):
            continue
        delayed = kind == "delayed"
        link = dict(blf_hz=blf_hz, trcal_s=trcal_s, dr=dr, m=m, trext=trext, blf_tolerance=blf_tolerance,
                    delayed=delayed)
        hyps, frt = _hypotheses(query, None, **link)
        blind = (len(hyps) > 1 or delayed) and hyps[0].blf_lo_hz == BLIND_BLF_RANGE_HZ[0]
        # an earlier reply told the link: it is tried first, the blind search only when it
        # finds no reply (a tag with another link)
        tries = ([_hypotheses(query, learned, **link)] if blind and learned is not None else []) + [(hyps, frt)]
        tari = rec.tari_s if not math.isnan(rec.tari_s) else 0.0
        cut_s = records[k + 1].start_s if k + 1 < len(records) else n / fs
        found = None
        for hyps_k, frt_k in tries:
            searching_blind = blind and hyps_k is hyps
            if searching_blind and blind_misses >= max_blind_misses:
                break
            found = decode_tag_reply(samples, fs, listen_s=rec.end_s + 0.5 * tari,
                                     window_end_s=cut_s - (0.5 * tari if k + 1 < len(records) else 0.0),
                                     cmd_end_s=rec.end_s, rtcal_s=rec.rtcal_s, frt=frt_k, hypotheses=hyps_k,
                                     kind=kind, n_bits_of=_n_bits_rule(kind, rec), max_bits=_max_bits(kind, rec),
                                     cut_s=cut_s, method=method, false_alarm_probability=false_alarm_probability,
                                     command_index=k, command=rec.name, delayed=delayed,
                                     blf_hint_hz=out[-1].blf_hz if out and not searching_blind else None,
                                     plans=plans)
            if found is not None:
                break
            if searching_blind:
                blind_misses += 1
        if found is not None:
            out.append(found)
            if query is None and blf_hz is None and not delayed:  # a delayed reply's pilot is not the link's TRext
                learned = (found.m, found.trext, found.blf_hz)
            elif query is None and blf_hz is None and learned is None:
                learned = (found.m, trext, found.blf_hz)
    return out


__all__ = [
    "REPLY_KIND",
    "FRT_UNKNOWN",
    "BLIND_BLF_RANGE_HZ",
    "MIN_HALFBIT_SNR_DB",
    "TagReplyRecord",
    "LinkHypothesis",
    "boxcar_decimate",
    "preamble_correlation",
    "decode_tag_reply",
    "decode_tag_replies",
]

"""Gen2 link profiles, link timing (T1–T7) and frame durations.

Reader → tag (PIE, gen2-and-validation-anchors.md §4.1): data-0 lasts Tari, data-1 lasts
``data1_tari``·Tari (1.5–2.0 Tari), RTcal = data-0 + data-1 (2.5–3.0 Tari),
TRcal = 1.1–3.0 RTcal, delimiter 12.5 µs ± 5 %, PW = max(0.265 Tari, 2 µs) … 0.525 Tari,
modulation depth 80–100 %. Lead-ins: frame-sync = delimiter + data-0 + RTcal; the Query
preamble = frame-sync + TRcal.

Tag → reader (§4.2): BLF = DR / TRcal, DR ∈ {8, 64/3}, BLF 40–640 kHz; bit rate BLF/M
(FM0: M = 1). A reply is preamble + payload + one dummy data-1; the preamble is 6 bits for
FM0 (18 with TRext, pilot of 12 data-0), 10 bits for Miller (22 with TRext), each bit
M·Tpri long (Tpri = 1/BLF).

Timing (§4.3, FT = FrT): T1 = max(RTcal, 10 Tpri)·(1 ± FT) ± 2 µs, T2 = 3–20 Tpri, T3 ≥ 0,
T4 ≥ 2 RTcal, T5 = T6 = T1min … 20 ms, T7 = max(250 µs, T2max) … 20 ms.

The divide ratio is stored as its name, ``"8"`` or ``"64/3"`` (exact, TOML friendly);
:attr:`LinkProfile.dr_value` gives it as a :class:`fractions.Fraction`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from rfsim.core.errors import ConfigError, did_you_mean
from rfsim.core.lazy import lazy_import

_bits = lazy_import("rfsim.gen2.bits")
_commands = lazy_import("rfsim.gen2.commands")

TARI_RANGE_S = (6.25e-6, 25e-6)
DATA1_TARI_RANGE = (1.5, 2.0)
TRCAL_RTCAL_RANGE = (1.1, 3.0)
BLF_RANGE_HZ = (40e3, 640e3)
DELIMITER_NOMINAL_S = 12.5e-6
DELIMITER_RANGE_S = (11.875e-6, 13.125e-6)
DEPTH_RANGE = (0.8, 1.0)
MODULATIONS = ("DSB-ASK", "SSB-ASK", "PR-ASK")
M_VALUES = (1, 2, 4, 8)
T_MAX_S = 20e-3  # upper limit of T5, T6, T7
T7_MIN_S = 250e-6

_REL_TOL = 1e-9  # slack on range limits for float round-off (e.g. 64/3 / 640 kHz)
_POINT_TOL = 1e-6  # TRcal "equal to" a FrT table point


def _ge(x: float, b: float, tol: float = _REL_TOL) -> bool:
    return x >= b * (1 - tol)


def _le(x: float, b: float, tol: float = _REL_TOL) -> bool:
    return x <= b * (1 + tol)


# ------------------------------------------------------------------ FrT (BLF tolerance)

# Rows (lo_us, hi_us, lo_closed, hi_closed, FrT nominal temperature, FrT extended temperature),
# TRcal in µs. Points (lo == hi) are TRcal values the standard lists on their own; "33.3",
# "66.7", "83.3", "133.3" µs are 64/3 divided by 640, 320, 256, 160 kHz.
# Provenance: gen2-and-validation-anchors.md §4.2 (reproduced from the unit tests of the
# master-thesis-rfid-sim project); the same nominal values appear, keyed by BLF, in PASS's
# epc_protocol_timings.m (pass-paris-simulator.md §2.5). Not re-checked against the
# standard's own table text.
_FRT_ROWS: dict[str, tuple[tuple[float, float, bool, bool, float, float], ...]] = {
    "64/3": (
        (100 / 3, 100 / 3, True, True, 0.15, 0.15),
        (100 / 3, 200 / 3, False, False, 0.22, 0.22),
        (200 / 3, 200 / 3, True, True, 0.10, 0.15),
        (200 / 3, 250 / 3, False, False, 0.12, 0.15),
        (250 / 3, 250 / 3, True, True, 0.10, 0.10),
        (250 / 3, 400 / 3, False, True, 0.10, 0.12),
        (400 / 3, 200.0, False, True, 0.07, 0.07),
        (200.0, 225.0, False, True, 0.05, 0.05),
    ),
    "8": (
        (17.2, 25.0, True, False, 0.19, 0.19),
        (25.0, 25.0, True, True, 0.10, 0.15),
        (25.0, 31.25, False, False, 0.12, 0.15),
        (31.25, 31.25, True, True, 0.10, 0.10),
        (31.25, 50.0, False, False, 0.10, 0.10),
        (50.0, 50.0, True, True, 0.07, 0.07),
        (50.0, 75.0, False, True, 0.07, 0.07),
        (75.0, 200.0, False, True, 0.04, 0.04),
    ),
}
TRCAL_TABLE_RANGE_S = {"8": (17.2e-6, 200e-6), "64/3": (100 / 3 * 1e-6, 225e-6)}


def frt_fraction(dr, trcal_s: float, *, extended_temperature: bool = False) -> float:
    """BLF tolerance FrT (fraction, e.g. 0.15 for ±15 %) for a divide ratio and TRcal.

    Table of gen2-and-validation-anchors.md §4.2 (nominal temperature by default; the
    bracketed extended-temperature values with ``extended_temperature=True``). A TRcal
    within 1e-6 (relative) of a listed point takes that point's value.

    Parameters
    ----------
    dr : str, int or fractions.Fraction
        Divide ratio, 8 or 64/3 (what :func:`rfsim.gen2.commands.normalize_dr` accepts; not a
        float).
    trcal_s : float
        TRcal [s].
    extended_temperature : bool
        Use the extended-temperature column.

    Returns
    -------
    float
        FrT as a fraction [1].

    Raises
    ------
    ConfigError
        ``("link.trcal_s", ...)`` outside the table's TRcal range.
    """
    name = _commands.normalize_dr(dr, "link.dr")
    t_us = float(trcal_s) * 1e6
    tol = _POINT_TOL
    for lo, hi, lo_closed, hi_closed, nominal, extended in _FRT_ROWS[name]:
        above = t_us >= lo * (1 - tol) if lo_closed else t_us > lo * (1 + tol)
        below = t_us <= hi * (1 + tol) if hi_closed else t_us < hi * (1 - tol)
        if above and below:
            return extended if extended_temperature else nominal
    lo_s, hi_s = TRCAL_TABLE_RANGE_S[name]
    raise ConfigError("link.trcal_s", trcal_s, f"[{lo_s * 1e6:.4g}, {hi_s * 1e6:.4g}] µs for DR {name}")


# ------------------------------------------------------------------ durations (low level)


def pie_duration_s(bits, *, tari_s: float, data1_s: float, delimiter_s: float = DELIMITER_NOMINAL_S,
                   trcal_s: float | None = None) -> float:
    """Duration of a PIE frame: lead-in + n0·Tari + n1·data-1.

    Lead-in = delimiter + Tari + RTcal (frame-sync; RTcal = Tari + data-1), plus TRcal when
    ``trcal_s`` is given (the Query preamble); gen2-and-validation-anchors.md §4.1. n0, n1
    are the counts of 0 and 1 bits in ``bits``, so the duration depends on the bit values.

    Parameters
    ----------
    bits : array_like
        ``(n,) uint8`` command bits.
    tari_s, data1_s, delimiter_s : float
        Tari, data-1 and delimiter durations [s].
    trcal_s : float or None
        TRcal [s] for a Query preamble; None for frame-sync.

    Returns
    -------
    float
        Frame duration [s].
    """
    arr = _bits.as_bits(bits)
    n1 = int(arr.sum())
    n0 = arr.size - n1
    lead_in = delimiter_s + tari_s + (tari_s + data1_s) + (trcal_s if trcal_s is not None else 0.0)
    return lead_in + n0 * tari_s + n1 * data1_s


def reply_preamble_bits(m: int, trext: bool) -> int:
    """Length of the tag-reply preamble in bit periods: FM0 6 (TRext 18), Miller 10 (22).

    Parameters
    ----------
    m : int
        Symbols per bit M (1 = FM0, 2/4/8 = Miller).
    trext : bool
        Pilot tone (12 extra data-0) present.

    Returns
    -------
    int
        Preamble length [bit periods].

    Raises
    ------
    ValueError
        If ``m`` is not one of 1, 2, 4, 8.
    """
    if m not in M_VALUES:
        raise ValueError(f"m must be one of {M_VALUES}, got {m!r}")
    return (6 if m == 1 else 10) + (12 if trext else 0)


def backscatter_duration_s(n_payload_bits: int, *, blf_hz: float, m: int, trext: bool,
                           dummy_bit: bool = True) -> float:
    """Duration of a tag reply: (preamble + payload + dummy-1) bits × M / BLF (§4.2).

    Parameters
    ----------
    n_payload_bits : int
        Payload bits (≥ 0).
    blf_hz : float
        Backscatter link frequency [Hz].
    m : int
        Symbols per bit M.
    trext : bool
        Pilot tone present.
    dummy_bit : bool
        Count the trailing dummy data-1.

    Returns
    -------
    float
        Reply duration [s].

    Raises
    ------
    ValueError
        If ``n_payload_bits`` is negative.
    """
    if int(n_payload_bits) < 0:
        raise ValueError(f"n_payload_bits must be >= 0, got {n_payload_bits}")
    n = reply_preamble_bits(m, trext) + int(n_payload_bits) + (1 if dummy_bit else 0)
    return n * m / blf_hz


# ------------------------------------------------------------------ timing (low level)


@dataclass(frozen=True)
class TimingRange:
    """A Gen2 link-timing interval [s]; ``None`` where the standard gives no bound."""

    min_s: float
    nom_s: float | None = None
    max_s: float | None = None


def t1_range(*, rtcal_s: float, blf_hz: float, frt: float) -> TimingRange:
    """T1 (reader command end → tag reply start): max(RTcal, 10 Tpri)·(1 ± FrT) ± 2 µs (§4.2).

    Parameters
    ----------
    rtcal_s : float
        RTcal [s].
    blf_hz : float
        Backscatter link frequency [Hz] (Tpri = 1/BLF).
    frt : float
        BLF tolerance FrT [fraction].

    Returns
    -------
    TimingRange
        T1 min, nominal and max [s].
    """
    nom = max(rtcal_s, 10.0 / blf_hz)
    return TimingRange(nom * (1 - frt) - 2e-6, nom, nom * (1 + frt) + 2e-6)


def t2_range(*, blf_hz: float) -> TimingRange:
    """T2 (tag reply end → reader command start): 3.0–20.0 Tpri.

    Parameters
    ----------
    blf_hz : float
        Backscatter link frequency [Hz].

    Returns
    -------
    TimingRange
        T2 min and max [s] (no nominal).
    """
    return TimingRange(3.0 / blf_hz, None, 20.0 / blf_hz)


# ------------------------------------------------------------------ link profile


@dataclass(frozen=True)
class LinkProfile:
    """Reader ↔ tag link parameters (PIE forward link, FM0/Miller return link).

    Parameters
    ----------
    tari_s : data-0 duration Tari [s], 6.25–25 µs
    data1_tari : data-1 duration in units of Tari, 1.5–2.0 (PASS's ``x`` = data1_tari − 1)
    trcal_s : TRcal [s], 1.1–3.0 RTcal; BLF = DR/TRcal must be 40–640 kHz and TRcal inside
        the FrT table range (DR 8: 17.2–200 µs, DR 64/3: 33.3–225 µs)
    dr : divide ratio name, ``"8"`` or ``"64/3"`` (int 8 / Fraction(64, 3) accepted)
    m : 1 (FM0) or 2, 4, 8 (Miller subcarrier cycles per bit)
    trext : pilot tone (long reply preamble) requested
    modulation : "DSB-ASK", "SSB-ASK" or "PR-ASK"
    depth : modulation depth (A − B)/A, 0.8–1.0
    pw_s : PIE low-pulse width [s], max(0.265 Tari, 2 µs)–0.525 Tari; None → 0.5 Tari
    delimiter_s : delimiter [s], 12.5 µs ± 5 %
    """

    tari_s: float
    data1_tari: float
    trcal_s: float
    dr: str = "8"
    m: int = 1
    trext: bool = False
    modulation: str = "PR-ASK"
    depth: float = 0.9
    pw_s: float | None = None
    delimiter_s: float = DELIMITER_NOMINAL_S

    def __post_init__(self):
        def num(key, value):
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
                    or not math.isfinite(value):
                raise ConfigError(f"link.{key}", value, "a finite number")
            return float(value)

        tari = num("tari_s", self.tari_s)
        if not (_ge(tari, TARI_RANGE_S[0]) and _le(tari, TARI_RANGE_S[1])):
            raise ConfigError("link.tari_s", self.tari_s, "[6.25e-6, 25e-6] s")
        object.__setattr__(self, "tari_s", tari)
        d1 = num("data1_tari", self.data1_tari)
        if not (_ge(d1, DATA1_TARI_RANGE[0]) and _le(d1, DATA1_TARI_RANGE[1])):
            raise ConfigError("link.data1_tari", self.data1_tari, "[1.5, 2.0] (data-1 length in Tari)")
        object.__setattr__(self, "data1_tari", d1)
        object.__setattr__(self, "dr", _commands.normalize_dr(self.dr, "link.dr"))
        trcal = num("trcal_s", self.trcal_s)
        rtcal = self.rtcal_s
        lo, hi = TRCAL_RTCAL_RANGE[0] * rtcal, TRCAL_RTCAL_RANGE[1] * rtcal
        if not (_ge(trcal, lo) and _le(trcal, hi)):
            raise ConfigError("link.trcal_s", self.trcal_s,
                              f"[1.1, 3.0]·RTcal = [{lo:.6g}, {hi:.6g}] s")
        object.__setattr__(self, "trcal_s", trcal)
        blf = self.blf_hz
        if not (_ge(blf, BLF_RANGE_HZ[0]) and _le(blf, BLF_RANGE_HZ[1])):
            raise ConfigError("link.trcal_s", self.trcal_s,
                              f"TRcal giving BLF = DR/TRcal in [40, 640] kHz (got {blf / 1e3:.6g} kHz)")
        frt_fraction(self.dr, trcal)  # raises outside the FrT table's TRcal range
        if isinstance(self.m, bool) or self.m not in M_VALUES:
            raise ConfigError("link.m", self.m, "1 (FM0), 2, 4 or 8 (Miller)")
        object.__setattr__(self, "m", int(self.m))
        if not isinstance(self.trext, (bool, np.bool_)):
            raise ConfigError("link.trext", self.trext, "true/false")
        object.__setattr__(self, "trext", bool(self.trext))
        if self.modulation not in MODULATIONS:
            raise ConfigError("link.modulation", self.modulation,
                              "one of " + ", ".join(MODULATIONS) + did_you_mean(str(self.modulation), MODULATIONS))
        depth = num("depth", self.depth)
        if not (_ge(depth, DEPTH_RANGE[0]) and _le(depth, DEPTH_RANGE[1])):
            raise ConfigError("link.depth", self.depth, "[0.8, 1.0] ((A-B)/A)")
        object.__setattr__(self, "depth", depth)
        pw = 0.5 * tari if self.pw_s is None else num("pw_s", self.pw_s)
        pw_lo, pw_hi = max(0.265 * tari, 2e-6), 0.525 * tari
        if not (_ge(pw, pw_lo) and _le(pw, pw_hi)):
            raise ConfigError("link.pw_s", self.pw_s,
                              f"[max(0.265 Tari, 2 µs), 0.525 Tari] = [{pw_lo:.6g}, {pw_hi:.6g}] s")
        object.__setattr__(self, "pw_s", pw)
        delim = num("delimiter_s", self.delimiter_s)
        if not (_ge(delim, DELIMITER_RANGE_S[0]) and _le(delim, DELIMITER_RANGE_S[1])):
            raise ConfigError("link.delimiter_s", self.delimiter_s, "[11.875e-6, 13.125e-6] s (12.5 µs ± 5 %)")
        object.__setattr__(self, "delimiter_s", delim)

    # ---- derived quantities
    @property
    def data1_s(self) -> float:
        """data-1 duration [s] = data1_tari · Tari."""
        return self.data1_tari * self.tari_s

    @property
    def rtcal_s(self) -> float:
        """RTcal [s] = data-0 + data-1 = Tari·(1 + data1_tari)."""
        return self.tari_s * (1.0 + self.data1_tari)

    @property
    def dr_value(self) -> Fraction:
        """Divide ratio as an exact fraction (8 or 64/3)."""
        return _commands.DR_VALUES[self.dr]

    @property
    def blf_hz(self) -> float:
        """Backscatter link frequency [Hz] = DR / TRcal."""
        return float(self.dr_value) / self.trcal_s

    @property
    def tpri_s(self) -> float:
        """Backscatter period Tpri [s] = 1 / BLF."""
        return 1.0 / self.blf_hz

    @property
    def bitrate_bps(self) -> float:
        """Tag data rate [bit/s] = BLF / M."""
        return self.blf_hz / self.m

    @property
    def frt(self) -> float:
        """BLF tolerance FrT (fraction) at nominal temperature, see :func:`frt_fraction`."""
        return frt_fraction(self.dr, self.trcal_s)

    @property
    def blf_range_hz(self) -> tuple[float, float]:
        """Allowed tag BLF [Hz]: BLF·(1 − FrT) … BLF·(1 + FrT)."""
        return (self.blf_hz * (1 - self.frt), self.blf_hz * (1 + self.frt))

    @property
    def frame_sync_s(self) -> float:
        """Frame-sync duration [s] = delimiter + Tari + RTcal."""
        return self.delimiter_s + self.tari_s + self.rtcal_s

    @property
    def preamble_s(self) -> float:
        """Query preamble duration [s] = frame-sync + TRcal."""
        return self.frame_sync_s + self.trcal_s

    # ---- durations
    def command_duration_s(self, bits_or_cmd, preamble: str | None = None) -> float:
        """Duration of a reader command incl. its lead-in (see :func:`pie_duration_s`).

        Parameters
        ----------
        bits_or_cmd : command object or array_like
            A command object (its lead-in is used unless ``preamble`` is given) or its bits
            (``(n,) uint8``; ``preamble`` is then required).
        preamble : {"query", "frame-sync"} or None
            Lead-in to use.

        Returns
        -------
        float
            Command duration [s].

        Raises
        ------
        ValueError
            If the lead-in is neither "query" nor "frame-sync".
        """
        if isinstance(bits_or_cmd, _commands.COMMAND_TYPES):
            bits = _commands.encode(bits_or_cmd)
            preamble = preamble or bits_or_cmd.PREAMBLE
        else:
            bits = _bits.as_bits(bits_or_cmd)
        if preamble not in ("query", "frame-sync"):
            raise ValueError(f'preamble must be "query" or "frame-sync", got {preamble!r}')
        return pie_duration_s(bits, tari_s=self.tari_s, data1_s=self.data1_s, delimiter_s=self.delimiter_s,
                              trcal_s=self.trcal_s if preamble == "query" else None)

    def reply_duration_s(self, n_payload_bits: int) -> float:
        """Tag reply duration at nominal BLF: (preamble + payload + dummy-1) · M / BLF.

        Parameters
        ----------
        n_payload_bits : int
            Payload bits.

        Returns
        -------
        float
            Reply duration [s].
        """
        return backscatter_duration_s(n_payload_bits, blf_hz=self.blf_hz, m=self.m, trext=self.trext)


# ------------------------------------------------------------------ timing of a profile


#: CW the reader keeps after a reply window's nominal end: 3 Tpri (a late or slow tag's last
#: symbols and the receiver's filters still fit).
REPLY_WINDOW_TAIL_TPRI = 3.0
#: The reader's receiver listens from half a Tari after its own command's last rising edge
#: (the edge and the channel's delay spread have settled) and searches the reply in T1.
READER_LISTEN_DELAY_TARI = 0.5


def reply_window_s(link: LinkProfile, reply_bits: int) -> float:
    """CW kept after a command for a reply of ``reply_bits`` payload bits.

    T1max + reply duration (nominal BLF) + :data:`REPLY_WINDOW_TAIL_TPRI` Tpri.

    Parameters
    ----------
    link : LinkProfile
        The link.
    reply_bits : int
        Payload bits of the expected reply.

    Returns
    -------
    float
        Window length [s].
    """
    return link.reply_duration_s(int(reply_bits)) + t1(link).max_s + REPLY_WINDOW_TAIL_TPRI * link.tpri_s


def delayed_reply_window_s(link: LinkProfile, reply_bits: int) -> float:
    """CW kept after a command for a delayed ("in-process") reply of ``reply_bits`` payload bits.

    T5max (20 ms, the latest start of a delayed reply after the command, anchors §4.3) + the
    reply with the extended preamble (a delayed reply is sent as if TRext = 1, EPC Gen2 v2
    §6.3.2.12.3) at the slowest BLF of the tolerance, BLF·(1 − FrT), +
    :data:`REPLY_WINDOW_TAIL_TPRI` Tpri.

    Parameters
    ----------
    link : LinkProfile
        The link.
    reply_bits : int
        Payload bits of the expected reply (header, handle and CRC-16 included).

    Returns
    -------
    float
        Window length [s].
    """
    reply_s = backscatter_duration_s(int(reply_bits), blf_hz=link.blf_hz, m=link.m, trext=True)
    return t5(link).max_s + reply_s / (1.0 - link.frt) + REPLY_WINDOW_TAIL_TPRI * link.tpri_s


def reader_listen_start_s(link: LinkProfile, cmd_end_s: float) -> float:
    """When the reader's receiver starts listening after a command.

    ``cmd_end_s`` + :data:`READER_LISTEN_DELAY_TARI` · Tari.

    Parameters
    ----------
    link : LinkProfile
        The link.
    cmd_end_s : float
        The command's last rising edge [s].

    Returns
    -------
    float
        Listen start [s].
    """
    return float(cmd_end_s) + READER_LISTEN_DELAY_TARI * link.tari_s


def t1(link: LinkProfile) -> TimingRange:
    """T1 of ``link`` with its nominal-temperature FrT (see :func:`t1_range`).

    Parameters
    ----------
    link : LinkProfile
        The link.

    Returns
    -------
    TimingRange
        T1 [s].
    """
    return t1_range(rtcal_s=link.rtcal_s, blf_hz=link.blf_hz, frt=link.frt)


def t2(link: LinkProfile) -> TimingRange:
    """T2 = 3.0–20.0 Tpri.

    Parameters
    ----------
    link : LinkProfile
        The link.

    Returns
    -------
    TimingRange
        T2 [s].
    """
    return t2_range(blf_hz=link.blf_hz)


def t3(link: LinkProfile) -> TimingRange:
    """T3 (reader wait after T1 before the next command when no reply): ≥ 0.

    Parameters
    ----------
    link : LinkProfile
        The link (unused: T3 has no link-dependent bound).

    Returns
    -------
    TimingRange
        T3 [s].
    """
    return TimingRange(0.0)


def t4(link: LinkProfile) -> TimingRange:
    """T4 (minimum time between reader commands): ≥ 2.0 RTcal.

    Parameters
    ----------
    link : LinkProfile
        The link.

    Returns
    -------
    TimingRange
        T4 [s].
    """
    return TimingRange(2.0 * link.rtcal_s)


def t5(link: LinkProfile) -> TimingRange:
    """T5 (delayed-reply wait): T1 min … 20 ms.

    Parameters
    ----------
    link : LinkProfile
        The link.

    Returns
    -------
    TimingRange
        T5 [s].
    """
    return TimingRange(t1(link).min_s, None, T_MAX_S)


def t6(link: LinkProfile) -> TimingRange:
    """T6: T1 min … 20 ms.

    Parameters
    ----------
    link : LinkProfile
        The link.

    Returns
    -------
    TimingRange
        T6 [s].
    """
    return TimingRange(t1(link).min_s, None, T_MAX_S)


def t7(link: LinkProfile) -> TimingRange:
    """T7: max(250 µs, T2 max) … 20 ms.

    Parameters
    ----------
    link : LinkProfile
        The link.

    Returns
    -------
    TimingRange
        T7 [s].
    """
    return TimingRange(max(T7_MIN_S, t2(link).max_s), None, T_MAX_S)


# ------------------------------------------------------------------ named profiles

PROFILES: dict[str, LinkProfile] = {
    # gen2-and-validation-anchors.md §3.5 profile A (gr-rfid's link: T1 = 250 µs, T2max = 500 µs)
    "fm0-40k": LinkProfile(tari_s=25e-6, data1_tari=2.0, trcal_s=200e-6, dr="8", m=1,
                           modulation="DSB-ASK"),
    # §3.5 profile B: fastest Gen2 link (Tari 6.25 µs, BLF 640 kHz, FM0)
    "fm0-640k": LinkProfile(tari_s=6.25e-6, data1_tari=1.5, trcal_s=float(Fraction(64, 3) / 640_000),
                            dr="64/3", m=1, modulation="DSB-ASK"),
    # §3.5 profile C: Tari 12.5 µs, BLF 320 kHz, Miller-4
    "miller4-320k": LinkProfile(tari_s=12.5e-6, data1_tari=1.5, trcal_s=float(Fraction(64, 3) / 320_000),
                                dr="64/3", m=4, modulation="PR-ASK"),
    # PASS default reader link (pass-paris-simulator.md §3.1; auris-sense-a-tag.md):
    # PR-ASK, Tari 25 µs, x = 1 (data-1 = 2 Tari), LF 48 kHz, DR 8, Miller-2, TRext 1, depth 90 %
    "pass-miller2-48k": LinkProfile(tari_s=25e-6, data1_tari=2.0, trcal_s=8 / 48_000, dr="8", m=2,
                                    trext=True, modulation="PR-ASK", depth=0.9),
}


def profile(name: str) -> LinkProfile:
    """The named link profile from :data:`PROFILES`.

    Parameters
    ----------
    name : str
        Profile name, e.g. ``"fm0-40k"``.

    Returns
    -------
    LinkProfile
        The profile.

    Raises
    ------
    ConfigError
        ``("link.profile", ...)`` with a did-you-mean hint for unknown names.
    """
    try:
        return PROFILES[name]
    except (KeyError, TypeError):
        raise ConfigError("link.profile", name,
                          "one of " + ", ".join(PROFILES) + did_you_mean(str(name), PROFILES)) from None


__all__ = [
    "LinkProfile",
    "PROFILES",
    "profile",
    "TimingRange",
    "frt_fraction",
    "pie_duration_s",
    "reply_preamble_bits",
    "backscatter_duration_s",
    "t1_range",
    "reply_window_s",
    "reader_listen_start_s",
    "REPLY_WINDOW_TAIL_TPRI",
    "delayed_reply_window_s",
    "READER_LISTEN_DELAY_TARI",
    "t2_range",
    "t1",
    "t2",
    "t3",
    "t4",
    "t5",
    "t6",
    "t7",
    "MODULATIONS",
    "TARI_RANGE_S",
    "BLF_RANGE_HZ",
]

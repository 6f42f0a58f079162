"""Gen2 reader transmitter: PIE commands as complex baseband at the antenna port.

Transmitter (gen2-and-validation-anchors.md §4.1; pass-paris-simulator.md §2.1
``reader_modulation``). With ``e(t)`` the PIE envelope of :func:`rfsim.gen2.pie.pie_envelope`
(1 during CW, ``1 − depth`` in the low pulses, raised-cosine edges) and ``P`` the conducted
power [W] at the antenna port, the complex baseband [√W] is

* DSB-ASK: ``x = √P·e(t)``;
* PR-ASK:  ``x = √P·s(t)·e(t)`` with ``s(t) = ±1`` changing sign at the middle of every low
  pulse (delimiter included), i.e. every PIE symbol has the opposite polarity of the previous
  one; ``|x|`` equals the DSB magnitude sample by sample. At ``depth < 1`` the sign change is
  a jump of ``2(1 − depth)·√P`` (an ideal PR-ASK has depth 1 and passes through zero);
* SSB-ASK: ``x = √P·(e(t) + j·(h_H * (e − 1))(t))`` with ``h_H`` a Blackman-windowed FIR
  Hilbert transformer (``h[k] = 2/(πk)`` for odd k, 0 for even k, |k| ≤ 4·Tari·fs) applied
  to the modulation part ``e − 1`` (zero during CW). Normalisation: the carrier term is not
  transformed, so wherever the envelope has been CW for more than 4 Tari the baseband is
  exactly ``√P`` (CW power = P); the modulation sideband sits at positive frequencies only.
  (An ideal, infinitely long Hilbert transform such as ``scipy.signal.hilbert`` would spread
  the pulse train's non-zero mean as a 1/t tail across the whole reply window; the finite
  FIR leaves the band below ≈ 1/(8·Tari) double-sided instead.)

A segment holds ``cw_before_s`` of CW (default one Tari), the command and ``cw_after_s`` of
CW: ``ceil((cw_before + T_cmd + cw_after)·fs)`` samples, ``T_cmd =
LinkProfile.command_duration_s(cmd)``.
"""

from __future__ import annotations

import math
import weakref
from typing import NamedTuple

import numpy as np

from rfsim.air.cache import AirCache, CommandKey, Waveform
from rfsim.gen2.commands import COMMAND_TYPES
from rfsim.gen2.pie import AskCommand, ask_command, ask_command_baseband, pie_lead_in, pie_timeline, timeline_envelope
from rfsim.core.lazy import lazy_import

_signal = lazy_import("scipy.signal")

__all__ = ["TxSegment", "PieTransmitter", "hilbert_fir", "SSB_HILBERT_HALF_TARI", "TX_CACHE_SIZE"]

#: Half-length of the SSB Hilbert FIR in Tari.
SSB_HILBERT_HALF_TARI = 4.0
#: Number of modulated command segments a Reader keeps for reuse.
TX_CACHE_SIZE = 64


class _Command(NamedTuple):
    """A command as sent: its bits (read-only), its preamble and its duration T_cmd [s]."""

    bits: np.ndarray
    preamble: str
    duration_s: float


class _TxMemo(NamedTuple):
    """What the transmitter derives from the reader's (frozen) config and link, its sample rate
    and its run cache, kept while they are the same objects (``PieTransmitter._tx_memo``)."""

    config: object
    link: object
    fs_hz: float
    air_cache: AirCache
    durations: dict  # (preamble, bits, ones) -> T_cmd [s]
    asks: dict  # (preamble, cw_before_s, cw_after_s) -> the ASK command's arguments (AskCommand)


class TxSegment(NamedTuple):
    """One transmitted segment: PIE command + CW (a named tuple: one is made per command sent).

    Attributes
    ----------
    t0_s : float
        Absolute time of sample 0 [s].
    fs_hz : float
        Sample rate [Hz].
    samples : ndarray of complex128, shape (n,)
        Baseband at the antenna port [√W].
    fc_hz : float
        Carrier frequency [Hz].
    channel_index : int
        1-based index into :func:`~rfsim.devices.reader_config.frequency_plan`.
    antenna_index : int
        0-based index into ``Reader.antennas``.
    cmd_start_s : float
        Absolute time of the delimiter's falling edge (50 % point) [s].
    cmd_end_s : float
        Absolute time of the last rising edge of the command [s].
    memo : dict
        Data derived from ``samples`` that devices share (the run's
        :class:`rfsim.air.cache.Waveform` memo of these samples: a tag's decoding of them, and
        a weak reference to the run's cache under the key :class:`rfsim.air.cache.AirCache`).
    """

    t0_s: float
    fs_hz: float
    samples: np.ndarray
    fc_hz: float
    channel_index: int
    antenna_index: int
    cmd_start_s: float
    cmd_end_s: float
    memo: dict

    @property
    def end_s(self) -> float:
        """Time just after the last sample [s]."""
        return self.t0_s + self.samples.size / self.fs_hz


def _lead_in(link, preamble: str, cw_before_s: float):
    """The checked PIE lead-in of ``link`` (:func:`rfsim.gen2.pie.pie_lead_in`)."""
    return pie_lead_in(tari_s=link.tari_s, data1_tari=link.data1_tari, trcal_s=link.trcal_s, pw_s=link.pw_s,
                       delimiter_s=link.delimiter_s, preamble=preamble, cw_before_s=cw_before_s)


def _command_duration_s(link, preamble: str, n_bits: int, n_ones: int) -> float:
    """T_cmd [s] of a command of ``n_bits`` bits, ``n_ones`` of them 1 (``link.command_duration_s``
    of such bits: the duration depends only on these counts)."""
    bits = np.zeros(n_bits, dtype=np.uint8)
    bits[:n_ones] = 1
    return link.command_duration_s(bits, preamble)


def hilbert_fir(half_length: int) -> np.ndarray:
    """Design the Blackman-windowed FIR Hilbert transformer of SSB-ASK.

    :math:`h[k] = \\frac{2}{\\pi k} w[k]` for odd k, 0 for even k (k = −K…K, w the Blackman
    window); its response is ≈ −j·sign(f) above ≈ 2·fs/K.

    Parameters
    ----------
    half_length : int
        K [samples].

    Returns
    -------
    ndarray of float64, shape (2K + 1,)
        The taps, centred on k = 0.
    """
    k = np.arange(-half_length, half_length + 1)
    h = np.zeros(k.size)
    odd = k % 2 != 0
    h[odd] = 2.0 / (np.pi * k[odd])
    return h * np.blackman(k.size + 2)[1:-1]


class PieTransmitter:
    """The transmitter side of :class:`rfsim.devices.reader.Reader`.

    A command's bits and duration, its PIE baseband and the transmitted segment (module
    docstring).

    Uses the reader's ``link`` (LinkProfile), ``config`` (ReaderConfig), ``fs_hz``,
    ``_cw_amplitude()``, ``fc_hz(t)``, ``channel_index(t)``, ``antenna_index(round)``, its
    command cache ``_cmd_cache`` / ``_cmd_cache_link`` and its run's ``air_cache``
    (:class:`rfsim.air.cache.AirCache`: the modulated segments by content).
    """

    def _command(self, cmd, memo: _TxMemo) -> _Command:
        """The bits, preamble and T_cmd [s] of a command (:class:`_Command`) (up to :data:`TX_CACHE_SIZE`
        commands are kept, all dropped when full: a reader repeats its Query/QueryRep/ACK many times)."""
        if self._cmd_cache_link is not self.link:
            self._cmd_cache.clear()
            self._cmd_cache_link = self.link
        try:
            hit = self._cmd_cache.get(cmd)
        except TypeError:  # an unhashable command: no caching
            hit, cmd_key = None, None
        else:
            cmd_key = cmd
        if hit is not None:
            return hit
        bits = cmd._encode()  # encode(cmd) of a command transmit checked
        bits.setflags(write=False)
        preamble = type(cmd).PREAMBLE  # command_preamble(cmd) of a command transmit checked
        # T_cmd depends on the bits only through their number and the number of 1s (an ACK's
        # RN16 changes every trial, its duration takes one of 17 values): kept per link in the
        # run, and on the reader
        durations = memo.durations
        timing = (preamble, bits.size, int(np.add.reduce(bits, dtype=np.int64)))  # bits, ones
        duration_s = durations.get(timing)
        if duration_s is None:
            if len(durations) >= TX_CACHE_SIZE:
                durations.clear()
            duration_s = durations[timing] = self.air_cache.link_timing(_command_duration_s, self.link, *timing)
        hit = _Command(bits, preamble, duration_s)
        if cmd_key is not None:
            if len(self._cmd_cache) >= TX_CACHE_SIZE:
                self._cmd_cache.clear()
            self._cmd_cache[cmd_key] = hit
        return hit

    def _tx_memo(self) -> _TxMemo:
        """The :class:`_TxMemo`, made again when the config, link, sample rate or run cache is replaced."""
        memo = self.__dict__.get("_tx_kept")
        if (memo is None or memo.config is not self.config or memo.link is not self.link or memo.fs_hz != self.fs_hz
                or memo.air_cache is not self.air_cache):
            memo = self._tx_kept = _TxMemo(self.config, self.link, self.fs_hz, self.air_cache, {}, {})
        return memo

    def _ask_command(self, preamble: str, cw_before_s: float, cw_after_s: float, memo: _TxMemo) -> AskCommand:
        """The DSB-/PR-ASK arguments of a command with this lead-in and these CW lengths [s]
        (:func:`rfsim.gen2.pie.ask_command`), kept on the reader (``memo``, :class:`_TxMemo`): every
        command after the first modulates with them, only its bits new."""
        asks = memo.asks
        key = (preamble, cw_before_s, cw_after_s)
        hit = asks.get(key)
        if hit is None:
            lk = self.link
            # Beyond the last rising edge's ramp (≤ 0.28 Tari wide) e = 1 and the PR-ASK sign no
            # longer changes: the samples up to 2 Tari after that edge are modulated, the CW
            # after them is the constant A·s_end (s_end = −1 after an odd number of low pulses).
            # The checked lead-in (preamble or frame-sync) is the run's, per link profile.
            lead = self.air_cache.link_timing(_lead_in, lk, preamble, cw_before_s)
            hit = ask_command(lead, cw_after_s=cw_after_s, modulated_after_s=min(cw_after_s, 2.0 * lk.tari_s),
                              amplitude=self._cw_amplitude(), pr_ask=lk.modulation == "PR-ASK", depth=lk.depth,
                              fs_hz=self.fs_hz, rise_fall_s=self.config.pie_rise_fall_tari * lk.tari_s)
            if len(asks) >= TX_CACHE_SIZE:
                asks.clear()
            asks[key] = hit
        return hit

    def _cw_from(self, n: int, preamble: str, cw_after_s: float, cw_before_s: float, memo: _TxMemo) -> int | None:
        """Index from which the ``n`` samples of a DSB-/PR-ASK command are all equal (its CW after
        the modulated span), or None (SSB-ASK, or too short a CW after the command).

        The baseband kernel writes ``n = ⌈(r_last + cw_after)·fs⌉`` samples, the envelope up to
        ``n_mod = ⌈(r_last + modulated_after)·fs⌉`` and the constant CW beyond
        (:func:`rfsim.gen2.pie.ask_command_baseband`); as ``⌈a⌉ − ⌈b⌉ ≥ ⌊a − b⌋``,
        ``n_mod ≤ n − ⌊(cw_after − modulated_after)·fs⌋`` up to the roundings of the sums, one
        sample each at most: the index returned has a sample to spare."""
        if self.link.modulation not in ("DSB-ASK", "PR-ASK"):
            return None
        ask = self._ask_command(preamble, cw_before_s, cw_after_s, memo)
        k = n - math.floor((ask.cw_after_s - ask.modulated_after_s) * ask.fs_hz) + 2
        return k if k < n else None

    def modulate(self, bits, *, preamble: str, cw_after_s: float, cw_before_s: float = 0.0) -> np.ndarray:
        """Modulate a PIE command to complex baseband (module docstring equations).

        DSB-ASK :math:`x = \\sqrt{P} e(t)`, PR-ASK :math:`x = \\sqrt{P} s(t) e(t)` or SSB-ASK
        :math:`x = \\sqrt{P} (e(t) + j (h_H * (e - 1))(t))`, per the link's modulation.

        Parameters
        ----------
        bits : array_like of {0, 1}, shape (n_bits,)
            Command bits (CRC included).
        preamble : {"query", "frame-sync"}
            Keyword-only: the command's preamble.
        cw_after_s : float
            Keyword-only: CW after the last rising edge [s].
        cw_before_s : float, optional
            Keyword-only: CW before the falling edge of the delimiter [s], default 0.0.

        Returns
        -------
        ndarray of complex128, shape (n_samples,)
            Baseband at the antenna port [√W].
        """
        return self._modulate(bits, preamble, float(cw_after_s), float(cw_before_s), self._tx_memo())

    def _modulate(self, bits, preamble: str, cw_after_s: float, cw_before_s: float, memo: _TxMemo) -> np.ndarray:
        """:meth:`modulate` with the reader's :class:`_TxMemo`."""
        lk = self.link
        if lk.modulation in ("DSB-ASK", "PR-ASK"):  # the arguments but the bits kept (_ask_command)
            return ask_command_baseband(self._ask_command(preamble, cw_before_s, cw_after_s, memo), bits)
        rise_fall_s = self.config.pie_rise_fall_tari * lk.tari_s
        amp = self._cw_amplitude()
        tl = pie_timeline(bits, tari_s=lk.tari_s, data1_tari=lk.data1_tari, trcal_s=lk.trcal_s, pw_s=lk.pw_s,
                          delimiter_s=lk.delimiter_s, preamble=preamble, cw_after_s=float(cw_after_s),
                          cw_before_s=float(cw_before_s))
        e = timeline_envelope(tl, depth=lk.depth, fs_hz=self.fs_hz, rise_fall_s=rise_fall_s)
        # SSB-ASK
        half = int(round(SSB_HILBERT_HALF_TARI * lk.tari_s * self.fs_hz))
        quad = _signal.fftconvolve(e - 1.0, hilbert_fir(half), mode="same")
        return amp * (e + 1j * quad)

    def transmit(self, cmd, *, t0_s: float, cw_after_s: float, cw_before_s: float | None = None,
                 round_index: int = 0) -> TxSegment:
        """Transmit CW, a PIE command, then CW.

        CW for ``cw_before_s``, the command ``cmd`` (Query: full preamble, others:
        frame-sync), then CW for ``cw_after_s``. The segment has
        ``ceil((cw_before + T_cmd + cw_after)·fs)`` samples,
        ``T_cmd = LinkProfile.command_duration_s(cmd)``; ``cmd_end_s = cmd_start_s + T_cmd``.
        ``samples`` is read-only: the last :data:`TX_CACHE_SIZE` distinct segments are kept in
        the run's cache (``air_cache.waveforms``, keyed by the command's bits, preamble, CW
        lengths and fs: :class:`rfsim.air.cache.CommandKey`) and returned again, with their
        ``memo`` (a tag's decoding of them, :class:`rfsim.devices.tag.SharedFrontEnd`, a weak
        reference to the run's cache under the key :class:`rfsim.air.cache.AirCache`, and under
        ``"cw_from"`` the index from which a DSB-/PR-ASK segment's samples are all equal,
        :attr:`rfsim.air.cache.Waveform.cw_from`), for a repeated command.

        Parameters
        ----------
        cmd : rfsim.gen2.commands command
            A command of :mod:`rfsim.gen2.commands`.
        t0_s : float
            Keyword-only (like the others): absolute time of the first sample [s].
        cw_after_s : float
            CW after the command [s] (T1max + reply + T2 for a reply window).
        cw_before_s : float or None, optional
            CW before the delimiter [s]; default None, one Tari, so that a receiver's
            envelope detector sees the delimiter's falling edge (the segment otherwise starts
            in the middle of that edge). ``cmd_start_s = t0_s + cw_before_s``.
        round_index : int, optional
            Inventory round, selects the antenna (round robin); default 0.

        Returns
        -------
        TxSegment
            The segment, on the carrier and channel of ``t0_s``.

        Raises
        ------
        TypeError
            When ``cmd`` is not a Gen2 command.
        ValueError
            When ``cw_after_s`` or ``cw_before_s`` is negative.
        """

        if not isinstance(cmd, COMMAND_TYPES):
            raise TypeError(f"not a Gen2 command: {cmd!r}")
        if not cw_after_s >= 0:
            raise ValueError(f"cw_after_s must be >= 0, got {cw_after_s}")
        cw_before_s = self.link.tari_s if cw_before_s is None else float(cw_before_s)
        if not cw_before_s >= 0:
            raise ValueError(f"cw_before_s must be >= 0, got {cw_before_s}")
        memo = self._tx_memo()
        bits, preamble, cmd_duration_s = self._command(cmd, memo)
        # A reader sends the same commands (Query, QueryRep, …) again and again: keep the last
        # modulated segments (read-only) by content, made by this (frozen) config and link profile.
        cache = self.air_cache
        key = CommandKey(bits.tobytes(), preamble, float(cw_after_s), cw_before_s, self.fs_hz)
        makers = (self.config, self.link)
        hit = cache.waveform(key, makers)
        if hit is None:
            x = self._modulate(bits, preamble, float(cw_after_s), cw_before_s, memo)
            x.setflags(write=False)
            # the memo names the run's cache (weakly: the cache holds the entry) so that a tag
            # reacting to these samples keeps its reply there, and where the constant CW starts
            cw_from = self._cw_from(x.size, preamble, float(cw_after_s), cw_before_s, memo)
            shared = {AirCache: weakref.ref(cache)}
            if cw_from is not None:
                shared["cw_from"] = cw_from
            hit = Waveform(samples=x, makers=makers, memo=shared, cw_from=cw_from)
            cache.remember(cache.waveforms, key, hit)
        t0_s = float(t0_s)
        start = t0_s + cw_before_s
        channel = self.channel_index(t0_s)
        return TxSegment(t0_s=t0_s, fs_hz=self.fs_hz, samples=hit.samples, fc_hz=float(self.plan_hz[channel - 1]),
                         channel_index=channel,
                         antenna_index=self.antenna_index(round_index),
                         cmd_start_s=start, cmd_end_s=start + cmd_duration_s, memo=hit.memo)

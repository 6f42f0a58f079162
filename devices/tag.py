"""Passive EPC Gen2 tag as a sample-level device: power-up, envelope detection, PIE
decoding with the tag's own clock, Gen2 state machine and the backscatter Γ(t).

:class:`PassiveTag` composes the tested pieces of :mod:`rfsim.devices.tag_frontend` (power-up,
reflection states, tag clock), :mod:`rfsim.gen2.pie` (PIE decoder),
:mod:`rfsim.gen2.commands` (parser), :mod:`rfsim.devices.gen2_tag_state` (protocol logic) and
:mod:`rfsim.gen2.linecode` (FM0/Miller waveform). One call of :meth:`PassiveTag.listen`
handles one reader segment (command + CW), as in DESIGN.md "Simulation flow" steps 3–4:

1. **Power-up** (pass-paris-simulator.md §2.2 steps 1–4; anchors §4.7). The incident
   (available) power P_inc is the CW power of the segment: the median of |x|² over the
   samples whose envelope lies above the midpoint between the two level clusters of the
   PIE envelope (isodata split, :func:`rfsim.gen2.pie.two_level_threshold`); a segment
   without modulation (swing below half the CW level) counts entirely. The median makes
   the estimate insensitive to the samples on the PIE edges (a clean segment gives P_inc
   exactly); PASS averages over the whole vector instead, which lets the command's
   modulation lower the estimate. The buffer capacitor is assumed to bridge the PIE low
   pulses. The chip absorbs P_chip = τ·P_inc with τ = 1 − |Γ_A|² (the power-wave
   identity of :func:`rfsim.devices.tag_frontend.power_transmission_coefficient`; τ = 1 for
   the default conjugate-matched ASK tag); powered ⇔ P_chip ≥ P_min (chip sensitivity).
2. **Envelope detection**: the ideal envelope detector e = |x|, optionally followed by a
   first-order RC low-pass e_f[n] = a·e_f[n−1] + (1 − a)·e[n], a = exp(−1/(τ_RC·fs))
   (``envelope_rc_s``; 0 = off; PASS uses τ = 169 ns at RF, §2.2 ``tag_demodulation``).
   PIE decoding is relative (threshold between the two level clusters), so the envelope's
   scale and DC do not matter.
3. **Tag clock**: :func:`rfsim.gen2.pie.pie_decode` measures Tari, RTcal, TRcal in input
   samples; the tag counts them in ticks of its own oscillator,
   N = round(samples · f_clk / fs), f_clk = f_nominal·(1 + error) (a counter: integer
   ticks). TRcal of the last Query sets the subcarrier divider
   N_BLF = round(N_TRcal / DR) and BLF = f_clk / N_BLF (:meth:`TagClock.blf_hz`; anchors
   §4.2: nominal BLF = DR/TRcal, the clock error cancels up to the integer rounding). A
   tag's own BLF error ε (``blf_error_percent``; the oscillator drifting between TRcal and
   the reply, Gen2 allows |ε| ≤ FrT) scales it: BLF = f_clk/N_BLF·(1 + ε)
   (:mod:`rfsim.devices.tag_spread` draws ε per tag).
4. **Reply timing** (anchors §4.3): the tag waits T1 = max(RTcal, 10·Tpri) counted in its
   own ticks, N_T1 = max(N_RTcal, 10·N_BLF), from the command's last rising edge, so the
   true T1 = N_T1 / f_clk: the RTcal branch is exact up to the half-tick rounding of
   N_RTcal, the 10·Tpri branch scales with the tag's actual BLF. Clock jitter
   (``clock_jitter_rms``, a fraction of one period, as in PASS ``tag_clock``) displaces the
   reply start by σ·ε/f_clk, ε ~ N(0, 1); the reply itself is on an ideal grid of the
   tag's actual BLF (no per-element jitter). A tag's own T1 adds ``t1_offset_s`` to the
   counted T1 (:mod:`rfsim.devices.tag_spread` draws it so that T1 is uniform in [T1min, T1max]).
   Reply start and BLF are floats: the waveform is sampled at fractional-sample timing
   (:func:`rfsim.gen2.linecode.reply_waveform`), never rounded to samples. A delayed
   ("in-process") reply to Write, BlockWrite, BlockErase, Lock or Kill (EPC Gen2 v2
   §6.3.2.12.3; :mod:`rfsim.gen2.access`) starts ``Reply.delay_s`` (the chip's programming
   time) after that T1 and is sent with the extended preamble (TRext = 1 whatever the Query
   said: the standard has the tag reply to these commands as if TRext = 1); the response's
   ``reply_start_s``, ``reply_end_s`` and ``trext`` are those of the delayed reply. The chip's
   power margin (:meth:`PassiveTag.power_margin_db`) decides whether a write succeeds (error
   0x0B insufficient power below the memory chip's write threshold: the ``memory`` argument's chip
   model, :data:`rfsim.gen2.memory.CHIP_MODELS`).
5. **Backscatter**: the line code s(t) = :func:`rfsim.gen2.linecode.reply_waveform`
   (M and TRext of the last Query) is ±1 during the reply and 0 outside. The tag's
   reflection coefficient is Γ(t) = Γ_B where s = +1 (modulating state) and Γ_A where
   s = −1 or s = 0 (absorbing state, in which the tag harvests); where s > 0 is kept in the
   run's cache by the reply's content (:func:`reply_gamma`: an EPC sent again at the same
   place in its segment is not sampled again; an RN16, drawn anew, is not kept). The rest
   state scatters a static A_s − Γ_A (step 6; nonzero at Γ_A = 0 for A_s = 1) that the reader
   removes with the carrier leakage; it is not special-cased.
6. **Re-radiation** (structural and antenna modes): the field an antenna loaded by the chip
   scatters is proportional to A_s − Γ(t) (Nikitin, Rao & Lam, "Theory and measurement of
   backscattering from RFID tags", IEEE AP Magazine 48(6), 2006; R. C. Hansen, "Relationships
   between antennas as scatterers and as radiators", Proc. IEEE 77(5), 1989), so the tag
   re-radiates r(t)·x_incident(t) with r(t) = A_s − Γ(t) (:meth:`TagResponse.reradiation`;
   DESIGN.md "Signal model": Γ(t) "with the antenna scattering terms of the chosen tag
   model"). A_s is the structural-mode term (``structural_mode``): |A_s| = 1 for a
   canonical minimum-scattering antenna (a conjugate-matched one scatters as much power as
   it absorbs, r = 1 at Γ = 0), A_s = 0 leaves the antenna mode −Γ alone. A_s is taken
   real (a model choice): its phase is the phase of the antenna's own scattering referred
   to its port (the reference plane of Γ), a property of the antenna that the canonical
   minimum-scattering antenna (A_s = 1) fixes to 0; a complex A_s would change
   |A_s − Γ_A| and |A_s − Γ_B|, not their difference.
   Consequences: the modulated part r_B − r_A = −(Γ_B − Γ_A) keeps |Γ_A − Γ_B| (the
   differential RCS and M = |Γ_A − Γ_B|²/4, anchors §4.7, are unchanged) with its sign
   flipped (the reader's phase is π away from that of a tag re-radiating +Γ(t)); the two
   scattered amplitudes |A_s − Γ_A|, |A_s − Γ_B| (what an envelope detector beside the tag
   sees) and the static backscatter at the reader depend on A_s.

Γ states (:class:`rfsim.devices.tag_frontend.ReflectionStates`): ``"ASK"`` uses the PASS UCODE
G2XM-class chip at 900 MHz against a conjugate-matched antenna
(:meth:`ReflectionStates.pass_default`: Γ_A = 0, Γ_B = Γ(Z_ic ∥ Z_mod)); ``"PSK"`` uses
Γ_A,B = |Γ|·e^(±jφ) (:meth:`ReflectionStates.psk`, ``psk_gamma_magnitude``,
``psk_phase_deg``; M = |Γ|²·sin²φ, τ = 1 − |Γ|²).
"""

from __future__ import annotations

import math
import struct
from typing import Any, NamedTuple

import numpy as np

from rfsim.air.cache import AirCache, ReplyStates, run_cache
from rfsim.devices.gen2_tag_state import TagState
from rfsim.devices.tag_chip import ChipOperatingPoint, PowerDependentChip
from rfsim.devices.tag_config import DEFAULT_SENSITIVITY_DBM, TagConfig, chip_spread as _chip_spread
from rfsim.devices.tag_frontend import ReflectionStates
from rfsim.devices.tag_population import TagPopulation
from rfsim.devices.tag_response import REASONS, TagResponse
from rfsim.gen2.commands import ACCESS_COMMANDS, CommandParseError, Query, parse
from rfsim.gen2.linecode import reply_duration_s, reply_waveform_arguments
from rfsim.gen2.memory import CHIP_MODELS, TagMemory
from rfsim.gen2.pie import (ISODATA_MAX_ITER, MAX_TRCAL_RTCAL, PIE_HYSTERESIS, RTCAL_TARI_RANGE, PieFrame,
                            pie_decode, two_level_threshold)
from rfsim.core.lazy import lazy_import

_signal = lazy_import("scipy.signal")
_k = lazy_import("rfsim.devices._tag_kernels")

class QuietPoint(NamedTuple):
    """A tag's remembered power decision at one incident power (:meth:`PassiveTag.quiet_point`).

    Attributes
    ----------
    config : TagConfig
        The config it was made with (an entry of another config is not used).
    chip : PowerDependentChip or None
        The chip it was made with.
    powered : bool
        Whether the tag is powered.
    p_dbm : float
        Incident CW power P_inc [dBm].
    gamma_rest : complex
        Γ_A, the rest (absorbing) state's reflection coefficient.
    structural_mode : complex
        The antenna's structural mode A_s.
    operating_point : ChipOperatingPoint or None
        The chip's operating point (with a chip).
    reflection_states : ReflectionStates or None
        Its reflection states (with a chip).
    unpowered : TagResponse or None
        The response of an unpowered tag at this power (None when ``powered``).
    """

    config: Any
    chip: Any
    powered: bool
    p_dbm: float
    gamma_rest: complex
    structural_mode: complex
    operating_point: Any
    reflection_states: Any
    unpowered: Any


class _ReplyTiming(NamedTuple):
    """A tag's reply timing for one Query's TRcal and one command's RTcal (steps 3–4 of the module
    docstring), kept by :meth:`PassiveTag._timing` while its inputs stay the same.

    Attributes
    ----------
    clock : TagClock
        The tag clock it was made with (compared by identity: a frozen object).
    config : TagConfig
        The config it was made with (BLF error and T1 offset; compared by identity).
    trcal_ticks : int
        N_TRcal, the last Query's TRcal in clock ticks.
    dr : str
        The Query's divide ratio.
    rtcal_ticks : int
        N_RTcal, the command's RTcal in clock ticks (what T1 depends on: the RTcal measured in
        samples and the sample rate enter only through this count).
    blf_hz : float
        The tag's BLF [Hz] (with its own BLF error).
    t1_ticks_s : float
        N_T1 / f_clk [s], T1 before the tag's own offset.
    """

    clock: Any
    config: Any
    trcal_ticks: int
    dr: Any
    rtcal_ticks: int
    blf_hz: float
    t1_ticks_s: float


class _ChipPoint(NamedTuple):
    """A power-dependent chip's operating point at one incident power, and its reflection states."""

    chip: Any
    operating_point: Any
    reflection_states: Any


#: Chip model of a tag's memory when none is given: "generic" (3 ms per word, 3 dB write threshold,
#: the project's assumptions; :data:`rfsim.gen2.memory.CHIP_MODELS`).
DEFAULT_CHIP = "generic"

#: A segment counts as modulated when the swing between its two envelope clusters exceeds
#: this fraction of the high level (Gen2 PIE depth is 80–100 %).
_MIN_MODULATION = 0.5


# ----------------------------------------------------------------------------- front end


def incident_power_w(x: np.ndarray) -> float:
    """CW power of a reader segment [W]: median of |x|² over the CW samples.

    CW samples: envelope above (high + low)/2, with high/low the isodata cluster means of
    |x| (:func:`rfsim.gen2.pie.two_level_threshold`); all samples when the swing is below
    half the high level (no command). Step 1 of the module docstring
    (pass-paris-simulator.md §2.2).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples,), complex
        Incident baseband signal at the tag antenna port [√W].

    Returns
    -------
    float
        Incident (available) CW power P_inc [W].

    Raises
    ------
    ValueError
        If the segment is empty.
    """
    env = np.abs(np.asarray(x))
    if env.size == 0:
        raise ValueError("empty segment")
    return _cw_power_w(env, two_level_threshold(env))


def _cw_power_w(env: np.ndarray, levels: tuple[float, float, float]) -> float:
    """:func:`incident_power_w` from the envelope |x| ((n,) float64) and its
    ``two_level_threshold`` (numba kernel)."""
    thr, lo, hi = levels
    env = np.ascontiguousarray(env, dtype=np.float64)
    return float(_k.cw_power_kernel(env, float(thr), bool(hi > 0 and hi - lo >= _MIN_MODULATION * hi),
                                    np.empty(env.size)))


def _reflection(s: np.ndarray, gamma_b: complex, gamma_a: complex) -> np.ndarray:
    """Γ(t) of a reply, (n,) complex128: Γ_B where the ±1 reply waveform ``s`` (float64, 0
    outside the reply) is +1 (or where the mask ``s > 0``, bool, is True), Γ_A elsewhere
    (numba kernel)."""
    out = np.empty(s.size, dtype=np.complex128)
    _k.reflection_kernel(s, complex(gamma_b), complex(gamma_a), out)
    return out


#: Γ(t) arrays kept per reply entry (pairs (Γ_B, Γ_A) of the tags that sent it again).
_MAX_GAMMAS = 4


def _kept_reflection(states: ReplyStates, gamma_b: complex, gamma_a: complex) -> np.ndarray:
    """Γ(t) of a reply seen again (:func:`reply_gamma`): from its mask, kept read-only in its entry
    ``states`` by the exact bits of (Γ_B, Γ_A) (up to :data:`_MAX_GAMMAS` pairs), so that tags with the
    same reflection states sending the same reply share one array (an EPC, trial after trial)."""
    gb, ga = complex(gamma_b), complex(gamma_a)
    key = struct.pack("<4d", gb.real, gb.imag, ga.real, ga.imag)
    gamma = states.gammas.get(key)
    if gamma is None:
        gamma = _reflection(states.modulating, gb, ga)
        gamma.flags.writeable = False
        if len(states.gammas) < _MAX_GAMMAS:
            states.gammas[key] = gamma
    return gamma


#: Kinds of reply (:class:`rfsim.devices.gen2_tag_state.Reply`) whose bits are drawn anew every time
#: (a 16-bit random number: two are equal with probability 2⁻¹⁶): :meth:`PassiveTag._replied` keeps
#: nothing of them (:func:`reply_gamma` with ``drawn``), so that they do not push the replies that come
#: again (an EPC at each of its starts) out of the run's cache.
_DRAWN_REPLIES = frozenset({"RN16"})


def reply_gamma(bits: np.ndarray, *, m: int, trext: bool, blf_hz: float, fs_hz: float, t0_s: float,
                n_samples: int, gamma_b: complex, gamma_a: complex, cache: AirCache | None = None,
                drawn: bool = False) -> np.ndarray:
    """Γ(t) of a reply over a segment: Γ_B where its reply waveform s(t) > 0, Γ_A elsewhere.

    s(t) = :func:`rfsim.gen2.linecode.reply_waveform` (±1 during the reply, 0 outside; step 5 of
    the module docstring). With the run's ``cache`` the samples where s > 0 are kept by the
    reply's content (:class:`rfsim.air.cache.ReplyStates` in ``cache.replies``, keyed by the bits
    and their dtype, M, TRext and the exact bit patterns of BLF, fs and ``t0_s``, and
    ``n_samples``: every argument s reads), so that a reply sent again at the same place in its
    segment (a tag's EPC, round after round) is not sampled again; Γ(t) then takes the same
    values Γ_A and Γ_B at the same samples, bit for bit, and is itself kept read-only in the entry
    per (Γ_B, Γ_A), shared by every later use of the same reply and reflection states.

    Parameters
    ----------
    bits : numpy.ndarray, shape (n_bits,), uint8
        Reply bits (without the dummy-1, which is appended).
    m : int
        Symbols per bit M (1 = FM0, 2/4/8 = Miller).
    trext : bool
        Pilot tone present.
    blf_hz : float
        Backscatter link frequency [Hz].
    fs_hz : float
        Sample rate [Hz].
    t0_s : float
        Start of the reply after the segment's first sample [s].
    n_samples : int
        Length of the segment [samples].
    gamma_b : complex
        Γ_B, the modulating state's reflection coefficient.
    gamma_a : complex
        Γ_A, the absorbing (rest) state's reflection coefficient.
    cache : rfsim.air.cache.AirCache or None, optional
        The run's cache (default None: nothing kept in it).
    drawn : bool, default False
        The bits are drawn anew each time (an RN16): nothing is kept for them, neither in
        ``cache`` nor the line code's elements
        (:func:`rfsim.gen2.linecode.reply_waveform_arguments` with ``keep=False``).

    Returns
    -------
    numpy.ndarray, shape (n_samples,), complex128
        Γ(t): a new array, or, for a reply seen again with the run's ``cache``, the entry's
        read-only array.
    """
    key = None
    if cache is not None and not drawn and isinstance(bits, np.ndarray):
        key = ("tag reply", bits.dtype.str, bits.shape, bits.tobytes(), int(m), bool(trext),
               struct.pack("<3d", blf_hz, fs_hz, t0_s), int(n_samples))
        hit = cache.reply(key)
        if hit is not None:
            return _kept_reflection(hit, gamma_b, gamma_a)
    # s(t), where s > 0 and Γ(t) from that mask (as a reply seen again) in one kernel call
    el, t0, r, n = reply_waveform_arguments(bits, m=m, trext=trext, blf_hz=blf_hz, fs_hz=fs_hz, t0_s=t0_s,
                                            n_samples=n_samples, keep=not drawn)
    modulating, gamma = np.empty(n, dtype=np.bool_), np.empty(n, dtype=np.complex128)
    _k.reply_states_kernel(el, t0, r, complex(gamma_b), complex(gamma_a), modulating, gamma)
    if key is not None:
        modulating.flags.writeable = False
        cache.remember(cache.replies, key, ReplyStates(modulating=modulating))
    return gamma


def envelope(x: np.ndarray, *, fs_hz: float, rc_s: float = 0.0) -> np.ndarray:
    r"""Envelope detector output (arbitrary units): |x|, optionally RC low-passed.

    .. math::

        e_f[n] = a\,e_f[n-1] + (1 - a)\,|x[n]|, \qquad a = e^{-1/(\tau_{RC} f_s)}

    started at ``e_f[−1] = |x[0]|`` (the detector has settled on the CW before the segment;
    step 2 of the module docstring, PASS ``tag_demodulation``).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples,), complex
        Incident baseband signal [√W].
    fs_hz : float
        Sample rate [Hz].
    rc_s : float, default 0.0
        RC time constant [s]; 0 → the ideal detector |x|.

    Returns
    -------
    numpy.ndarray, shape (n_samples,), float64
        Detector output (scale of |x|).
    """
    env = np.abs(np.asarray(x)).astype(np.float64)
    if rc_s <= 0 or env.size == 0:
        return env
    a = math.exp(-1.0 / (rc_s * fs_hz))
    out, _ = _signal.lfilter([1.0 - a], [1.0, -a], env, zi=[a * env[0]])
    return out


class Decoded(NamedTuple):
    """A tag's decoding of a reader segment: the parsed command and its PIE frame (both None
    when no valid command is decoded).

    Attributes
    ----------
    command : object or None
        The command (:mod:`rfsim.gen2.commands`).
    frame : rfsim.gen2.pie.PieFrame or None
        Its frame, durations in samples of the segment.
    """

    command: Any
    frame: Any


#: Nothing decoded.
_NOTHING = Decoded(None, None)


def _command_of(frames) -> Decoded:
    """:class:`Decoded` of the first PIE frame, or of nothing when it is not a valid command
    (nothing decoded, a parse error, or a Query without TRcal / another command with it)."""
    if not frames:
        return _NOTHING
    frame = frames[0]
    try:
        cmd = parse(frame.bits)
    except CommandParseError:
        return _NOTHING
    if isinstance(cmd, Query) != frame.has_trcal:
        # a Query needs the preamble with TRcal; other commands start with a frame-sync
        return _NOTHING
    return Decoded(cmd, frame)


#: Half-width of the run of equal CW samples the median must lie in for the shared front end.
_PLATEAU_MARGIN = 8


class SharedFrontEnd:
    """The front end's work on one emitted segment x, shared by every tag that sees g·x.

    ``plateau`` is the index of the sample the CW median lands on when that median lies
    inside a run of at least 2·:data:`_PLATEAU_MARGIN` + 1 equal CW samples that are ±one
    complex value (a reader's CW: DSB or PR-ASK), so that for any gain g the median of |g·x|²
    over the CW samples is |g·x_m|² exactly; None otherwise (the tags then listen on their
    own samples).

    The ideal detector's command (:meth:`command` with no RC) is decoded in the same numba call as
    the levels and the plateau (:func:`rfsim.devices._tag_kernels.front_end_decode_kernel`).

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples,), complex
        The emitted segment [√W].
    fs_hz : float
        Sample rate [Hz].
    cw_from : int or None, optional
        Index from which the samples are known to be all equal (a reader's constant CW after
        its command, :attr:`rfsim.air.cache.Waveform.cw_from`), or None. The front end then forms
        the envelope up to that sample only and counts the rest (the same numbers, bit for
        bit: every step reads the first of the equal samples that end the envelope and counts
        the others).

    Attributes
    ----------
    env : numpy.ndarray, shape (n_samples,)
        Envelope |x| (formed when asked).
    levels : tuple of float
        ``(threshold, low, high)`` of :func:`rfsim.gen2.pie.two_level_threshold` of ``env``.
    plateau : int or None
        Index of the median CW sample on a flat plateau, or None.
    cw_sample : complex
        ``x[plateau]`` (only when ``plateau`` is not None).
    """

    def __init__(self, x: np.ndarray, *, fs_hz: float, cw_from: int | None = None):
        self.x, self.fs_hz = x, float(fs_hz)
        self._env = None
        if x.ndim == 1 and x.size > 0:  # one kernel call: extremes, levels, plateau
            n = x.size
            head = n if cw_from is None else min(max(int(cw_from), 0) + 1, n)
            if head < n:  # |x| up to the first CW sample: the kernel reads no further
                env = np.empty(n)
                np.abs(x[:head], out=env[:head])
            else:
                env = self._env = np.abs(x)
            # the ideal detector's PIE decoding of |x| in the same call (the samples it reads: up
            # to the first of the equal samples that end |x|, where rfsim.gen2.pie.pie_decode stops)
            self.levels, self.plateau, self._ideal, tail = _front_end(x, env, head)
            self._decoded_env = env[:tail + 1]
        else:
            env = self._decoded_env = self.env
            self.levels = two_level_threshold(env)
            self.plateau = _plateau(x, env, self.levels)
            self._ideal = None
        if self.plateau is not None:
            self._xm = x[self.plateau:self.plateau + 1]
            self.cw_sample = complex(self._xm[0])
        self._commands: dict = {}

    @property
    def env(self) -> np.ndarray:
        """Envelope |x| of the whole segment, (n_samples,) float64 (formed on first use)."""
        if self._env is None:
            self._env = np.abs(self.x)
        return self._env

    def power_w(self, gain: complex) -> float:
        """CW power of the scaled copy g·x, as :func:`incident_power_w` of it.

        Requires :attr:`plateau` to be set: the power is ``|g·x_m|²`` with x_m the median CW
        sample.

        Parameters
        ----------
        gain : complex
            Complex (dimensionless) gain g of the tag's link.

        Returns
        -------
        float
            Incident CW power [W].
        """
        return float(self.powers_w(gain)[0])

    def powers_w(self, gains) -> np.ndarray:
        """:meth:`power_w` of many gains at once (the same numpy operations element by element,
        so the same bits).

        Parameters
        ----------
        gains : complex or array_like of complex, shape (n,)
            Complex (dimensionless) gains g_j of the tags' links.

        Returns
        -------
        numpy.ndarray, shape (n,) (1 for a scalar gain)
            Incident CW power |g_j·x_m|² per gain [W].
        """
        v = np.abs(np.asarray(gains, dtype=np.complex128) * self._xm)  # as numpy's |x| of the copy computes it
        return v * v

    def command(self, rc_s: float) -> tuple:
        """The command every copy of x decodes to, for a tag with RC time constant ``rc_s``.

        PIE decoding (:func:`rfsim.gen2.pie.pie_decode`) is scale-invariant, so one decoding per
        RC time constant serves every tag (remembered per ``rc_s``).

        Parameters
        ----------
        rc_s : float
            Envelope-detector RC time constant [s] (0 = ideal detector).

        Returns
        -------
        Decoded
            ``(command, frame)``: the parsed command and its :class:`rfsim.gen2.pie.PieFrame`,
            or ``(None, None)`` when no valid command is decoded.
        """
        hit = self._commands.get(rc_s)
        if hit is None:
            if rc_s > 0:
                frames = pie_decode(envelope(self.x, fs_hz=self.fs_hz, rc_s=rc_s))
            elif self._ideal is not None:  # decoded in the front end's kernel call (its first frame)
                frames = self._ideal
            else:
                frames = pie_decode(self._decoded_env, levels=self.levels)
            hit = self._commands[rc_s] = _command_of(frames)
        return hit


def _front_end(x: np.ndarray, env: np.ndarray, head: int) -> tuple:
    """``(two_level_threshold(env), _plateau(x, env, those levels), frames, tail)`` of the samples
    ``x`` ((n,) complex128, n ≥ 1) and their envelope ``env`` = |x| in one numba call (the
    extremes, the isodata split, the plateau and the PIE decoding; the same numbers, bit for bit):
    ``frames`` is ``[first frame]`` of :func:`rfsim.gen2.pie.pie_decode` of ``env`` with those
    levels, or ``[]`` (all :func:`_command_of` reads); ``tail`` is the index of the first of the
    equal values that end ``env`` (the decoder reads ``env[:tail + 1]``). Only ``env[:head]`` is
    formed and read (1 ≤ ``head`` ≤ n): ``x[head - 1:]`` are all equal."""
    x = np.ascontiguousarray(x, dtype=np.complex128)
    env = np.ascontiguousarray(env, dtype=np.float64)
    thr, lo, hi, p, tail, nf, start, end, delimiter, tari, rtcal, trcal, bits = _k.front_end_decode_kernel(
        x, env, int(head), ISODATA_MAX_ITER, _MIN_MODULATION, _PLATEAU_MARGIN, PIE_HYSTERESIS, *RTCAL_TARI_RANGE,
        MAX_TRCAL_RTCAL)
    levels = (thr, lo, hi)
    frames = [PieFrame(start, end, delimiter, tari, rtcal, trcal, bits)] if nf else []
    if p == -2:
        return levels, plateau_reference(x, env if head == env.size else np.abs(x), levels), frames, tail
    return levels, (None if p < 0 else p), frames, tail


def _plateau(x: np.ndarray, env: np.ndarray, levels: tuple) -> int | None:
    """:attr:`SharedFrontEnd.plateau` of the samples ``x`` ((n,) complex128), their envelope
    ``env`` = |x| and its ``two_level_threshold`` (numba kernel; :func:`plateau_reference` is its
    plain-NumPy twin, and answers where a NaN is among the CW samples)."""
    thr, lo, hi = levels
    x = np.ascontiguousarray(x, dtype=np.complex128)
    env = np.ascontiguousarray(env, dtype=np.float64)
    n = env.size
    p = int(_k.plateau_kernel(x, env, float(thr), bool(hi > 0 and hi - lo >= _MIN_MODULATION * hi),
                              _PLATEAU_MARGIN, np.empty(n), np.empty(n, np.int64),
                              np.empty(2 * _PLATEAU_MARGIN + 1, np.int64)))
    if p == -2:
        return plateau_reference(x, env, levels)
    return None if p < 0 else p


def plateau_reference(x: np.ndarray, env: np.ndarray, levels: tuple) -> int | None:
    """Plain-NumPy twin of the plateau kernel of :class:`SharedFrontEnd`.

    A stable sort of env² over the CW samples (as :func:`_cw_power_w` selects them), its
    2·:data:`_PLATEAU_MARGIN` + 1 middle positions, and whether their samples are ± the
    sample at the median position.

    Parameters
    ----------
    x : numpy.ndarray, shape (n_samples,), complex128
        Segment samples [√W].
    env : numpy.ndarray, shape (n_samples,), float64
        Envelope |x|.
    levels : tuple of float
        ``(threshold, low, high)`` of :func:`rfsim.gen2.pie.two_level_threshold` of ``env``.

    Returns
    -------
    int or None
        Index of the median CW sample when it lies on a flat ± plateau, else None.
    """
    thr, lo, hi = levels
    sel = np.flatnonzero(env >= thr) if (hi > 0 and hi - lo >= _MIN_MODULATION * hi) else np.arange(env.size)
    if sel.size <= 2 * _PLATEAU_MARGIN:
        return None
    e2 = env[sel] ** 2
    order = np.argsort(e2, kind="stable")
    mid = (sel.size - 1) // 2
    idx = sel[order[mid - _PLATEAU_MARGIN:mid + 1 + _PLATEAU_MARGIN]]
    xm = x[idx[_PLATEAU_MARGIN]]
    if np.all((x[idx] == xm) | (x[idx] == -xm)):
        return int(idx[_PLATEAU_MARGIN])
    return None


def _dbm(p_w: float) -> float:
    """10·log10(P) + 30 [dBm] (−inf for 0 W), as :func:`rfsim.core.units.w_to_dbm` for a scalar."""
    return 10.0 * math.log10(p_w) + 30.0 if p_w > 0 else -math.inf


#: Power decisions a tag remembers (:meth:`PassiveTag.quiet_point`): the carriers' incident powers
#: of the last few hops; a population decides every member at a new carrier at once
#: (:meth:`PassiveTag.quiet_points`), so a small number keeps the objects held per tag bounded.
_QUIET_MEMO = 4


def _config_powered(tau, tau_pu, sens_w, p_inc):
    """The config's power-up rule ``PowerUp.is_powered(τ·P_inc)``: τ_pu·(τ·P_inc) ≥ P_sens, for
    scalars (a bool) or arrays (element-wise; the same float64 arithmetic, so the same bits).

    τ is the config's power transfer, τ_pu and P_sens [W] those of its ``power_up``, P_inc [W]
    the incident CW power."""
    return tau_pu * (tau * p_inc) >= sens_w


# ----------------------------------------------------------------------------- device


class PassiveTag:
    """A passive Gen2 tag: reflector device of the engine.

    Parameters
    ----------
    config : TagConfig
    antenna : rfsim.channels.Antenna (position, orientation, pattern; used by the engine's channel)
    rng : numpy.random.Generator — the tag's own stream (slot counters, RN16, handles, jitter)
    t0_s : time of the initial, unpowered state [s]; segments must not start earlier
    chip : :class:`rfsim.devices.tag_chip.PowerDependentChip` or None
        A chip whose impedance follows its absorbed power: each segment's CW power sets
        :attr:`reflection_states` and power-up (its rule, not ``config.sensitivity_dbm``)
        through :meth:`~rfsim.devices.tag_chip.PowerDependentChip.operating_point`.
    memory : :class:`rfsim.gen2.memory.TagMemory` or None
        The tag's memory (its chip model gives the write time and write threshold); default
        None: ``config.epc_hex``, the default TID and the "generic" chip's User memory
        (zeros) on that chip model (its write time and threshold are the project's assumptions) (:class:`rfsim.devices.gen2_tag_state.TagState`).

    Attributes
    ----------
    state : :class:`rfsim.devices.gen2_tag_state.TagState`
    clock : :class:`rfsim.devices.tag_frontend.TagClock`
    reflection_states : :class:`rfsim.devices.tag_frontend.ReflectionStates`
    operating_point : :class:`rfsim.devices.tag_chip.ChipOperatingPoint` of the last segment (with
        ``chip``; None otherwise)
    """

    def __init__(self, config: TagConfig, antenna, *, rng: np.random.Generator, t0_s: float = 0.0,
                 chip: PowerDependentChip | None = None, memory: TagMemory | None = None):
        if not isinstance(config, TagConfig):
            raise TypeError(f"config must be a TagConfig, got {type(config).__name__}")
        if not isinstance(rng, np.random.Generator):
            raise TypeError("rng must be a numpy.random.Generator")
        self.config = config
        self.antenna = antenna
        self.rng = rng
        self.clock = config.clock
        self.reflection_states = config.reflection_states
        self.chip = chip
        self.operating_point: ChipOperatingPoint | None = None
        if memory is None:  # the config's EPC, the default TID, the memory chip's User memory (zeros)
            self.state = TagState(config.epc_hex.replace(" ", ""), powered=False, t0_s=t0_s, chip=DEFAULT_CHIP,
                                  user="0000" * CHIP_MODELS[DEFAULT_CHIP].user_words)
        else:
            self.state = TagState(memory=memory, powered=False, t0_s=t0_s)
        #: share the front end's work among tags that see scaled copies of one segment (:meth:`reflect`)
        self.shared_front_end = True
        self._p_memo: dict = {}  # (gain, CW sample) -> CW power of the scaled copy [W]
        self._chip_memo: dict = {}  # P_inc [W] -> _ChipPoint
        self._quiet: dict = {}  # P_inc [W] -> its power decision and responses (:meth:`_quiet_response`)
        self._trcal_ticks: int | None = None  # TRcal of the last Query, in tag clock ticks
        self._derived: tuple = (None, None)  # (config, quantities derived from it)

    #: Number of times any tag's :attr:`antenna` has been set (a population's antenna tuple,
    #: rfsim.devices.tag_population, stays valid while this count stays the same).
    antenna_changes = 0

    @property
    def antenna(self):
        """The tag's antenna (rfsim.channels.Antenna); setting it moves the tag."""
        return self._antenna

    @antenna.setter
    def antenna(self, value) -> None:
        self._antenna = value
        PassiveTag.antenna_changes += 1

    @property
    def tau(self) -> float:
        """τ = 1 − |Γ_A|² (see :attr:`TagConfig.tau`)."""
        return self.config.tau

    def _tau_power_up(self) -> tuple:
        """``(config.tau, τ of config.power_up, its chip sensitivity [W], A_s as complex)``,
        recomputed only when ``config`` is replaced (the config is frozen; all are pure
        functions of it)."""
        d = self._derived
        if d[0] is not self.config:
            cfg = self.config
            pu = cfg.power_up
            d = self._derived = (cfg, (cfg.tau, float(pu.tau), float(pu.chip_sensitivity_w),
                                       complex(cfg.structural_mode)))
        return d[1]

    def ticks(self, samples: float, fs_hz: float) -> int:
        """A duration of input samples counted in tag clock ticks, ``round(samples·f_clk/fs)``.

        Parameters
        ----------
        samples : float
            Duration in input samples.
        fs_hz : float
            Input sample rate [Hz].

        Returns
        -------
        int
            Duration in ticks of the tag's oscillator (step 3 of the module docstring).
        """
        return int(round(samples * self.clock.f_hz / fs_hz))

    def reflect(self, incident) -> TagResponse:
        """Reflector protocol of the air interface: the tag's reaction to an incident segment.

        When the segment is a scaled copy g·x of an emitted segment x (a narrowband, static
        link) and :attr:`shared_front_end` is set, the front end's work on x (envelope, level
        split, PIE decoding, the CW samples' median) is done once per emitted segment for every
        tag that sees a copy of it (:class:`SharedFrontEnd`, kept in the segment's ``memo``):
        the envelope detector, the decoder's relative thresholds and the median are
        scale-equivariant, and the CW power is |g·x_m|² with x_m the median CW sample, computed
        as :meth:`listen` computes it. The state machine, power-up (config or chip) and the reply
        are the same code as :meth:`listen` (:meth:`_respond`). Otherwise, or when the median is
        not on a flat CW plateau, :meth:`listen` runs on the samples.

        Parameters
        ----------
        incident : rfsim.air.segment.Segment
            The incident segment (``samples`` [√W], ``t0_s``, ``fs_hz``, ``n_samples``, and
            ``base``/``gain`` when it is a scaled copy).

        Returns
        -------
        TagResponse
            Power state, decoded command, reply and its Γ(t).
        """
        base = incident.base
        if self.shared_front_end and base is not None and base.samples.ndim == 1:
            fe = self.front_end_of(base)
            if fe.plateau is not None:
                p_inc = self._incident_power_w(fe, incident.gain)
                rc = self.config.envelope_rc_s
                quiet = self._quiet_at(p_inc)
                if quiet is not None:
                    # the power decision of this P_inc is known (:meth:`_respond` made it): the
                    # tag stays unpowered, or stays powered and takes a silent step
                    decoded = fe.command(rc)
                    out = self._quiet_response(quiet, decoded, incident)
                    if out is not None:
                        return out
                    if quiet.powered and self.state.powered:
                        # or stays powered and answers: the tail of _respond after its power
                        # decision (the scaled copy has its base's time base; the base's memo
                        # names the run's cache)
                        # (_quiet_response has asked for a silent step of a command other than a Query)
                        return self.respond_decoded(quiet, decoded, base, silent_tried=decoded[0] is not None
                                                    and not isinstance(decoded[0], Query))
                return self._respond(p_inc, lambda: fe.command(rc), t0_s=incident.t0_s,
                                     fs_hz=incident.fs_hz, n_samples=incident.n_samples,
                                     cache=run_cache(base.memo))
        return self.listen(incident.samples, t0_s=incident.t0_s, fs_hz=incident.fs_hz)

    @staticmethod
    def front_end_of(base) -> SharedFrontEnd:
        """The :class:`SharedFrontEnd` of an emitted segment, kept in its ``memo``.

        For a reader's command segment the memo is that of the run's cached waveform
        (:class:`rfsim.air.cache.Waveform`): a command sent again is decoded once per run.

        Parameters
        ----------
        base : rfsim.air.segment.Segment
            The emitted segment (``samples``, ``fs_hz``, ``memo``).

        Returns
        -------
        SharedFrontEnd
            The shared front end of ``base`` (created on first use).
        """
        fe = base.memo.get(SharedFrontEnd)
        if fe is None:
            fe = base.memo[SharedFrontEnd] = SharedFrontEnd(base.samples, fs_hz=base.fs_hz,
                                                            cw_from=base.memo.get("cw_from"))
        return fe

    @classmethod
    def population(cls, tags) -> TagPopulation:
        """Tags as one reflector group of the air step.

        Parameters
        ----------
        tags : sequence of PassiveTag
            The tags of the group.

        Returns
        -------
        rfsim.devices.tag_population.TagPopulation
            The group.
        """
        return TagPopulation(tags)

    def _incident_power_w(self, fe: SharedFrontEnd, gain: complex) -> float:
        """P_inc [W] of the scaled copy gain·x of ``fe``'s segment, |g·x_m|² (remembered:
        it depends only on the gain and the CW sample, so a held link and a reader at
        constant power give the same value exchange after exchange)."""
        key = (gain, fe.cw_sample)
        p_inc = self._p_memo.get(key)
        if p_inc is None:
            if len(self._p_memo) > 64:
                self._p_memo.clear()
            p_inc = self._p_memo[key] = fe.power_w(gain)
        return p_inc

    @staticmethod
    def quiet_points(tags, fe: SharedFrontEnd, gains) -> list:
        """:meth:`quiet_point` with ``decide`` of many tags at once (a population at a new carrier).

        The incident powers |g_j·x_m|² (:meth:`SharedFrontEnd.powers_w`) and the config power-up
        rule of every tag without a chip (:func:`_config_powered`) are one array operation each,
        with the same arithmetic per tag as :meth:`quiet_point` (the same bits); tags with a chip,
        or that do not share front ends, take :meth:`quiet_point` one by one. Decisions are
        remembered as :meth:`quiet_point` remembers them (the incident powers are not: a tag's
        own path computes the same number again).

        Parameters
        ----------
        tags : sequence of PassiveTag
            The tags.
        fe : SharedFrontEnd
            Shared front end of the emitted segment x.
        gains : sequence of complex
            Complex gain g_j of each tag's link.

        Returns
        -------
        list of QuietPoint or None
            Per tag, what ``quiet_point(fe, g_j, decide=True)`` returns.
        """
        n = len(tags)
        if fe.plateau is None:
            return [None] * n
        p_arr = fe.powers_w(gains)
        p_list = p_arr.tolist()
        out: list = [None] * n
        batch = []  # (index, tag, P_inc) of the tags whose decision is made below, at once
        for j, (t, p_inc) in enumerate(zip(tags, p_list)):
            if type(t) is not PassiveTag or t.chip is not None or not t.shared_front_end:
                out[j] = t.quiet_point(fe, gains[j], decide=True)
            elif p_inc in t._quiet:
                out[j] = t._quiet_at(p_inc)
            else:
                batch.append(j)
        if not batch:
            return out
        derived = [tags[j]._tau_power_up() for j in batch]
        tau, tau_pu, sens_w = (np.array(c, dtype=float) for c in list(zip(*derived))[:3])
        powered = _config_powered(tau, tau_pu, sens_w, p_arr[batch]).tolist()
        for j, on, d in zip(batch, powered, derived):
            t, p_inc = tags[j], p_list[j]
            p_dbm, rest, a_s = _dbm(p_inc), t.reflection_states.gamma_a, d[3]
            out[j] = t._remember_quiet(p_inc, on, p_dbm, rest, a_s, None)
        return out

    def _remember_quiet(self, p_inc: float, powered: bool, p_dbm: float, rest: complex, a_s: complex,
                        hit) -> QuietPoint:
        """Remember the power decision of ``p_inc`` [W] as a :class:`QuietPoint` (``hit``: the
        chip's _ChipPoint or None) and return it."""
        if len(self._quiet) >= _QUIET_MEMO:
            self._quiet.clear()
        q = self._quiet[p_inc] = QuietPoint(self.config, self.chip, powered, p_dbm, rest, a_s,
                                            None if hit is None else hit.operating_point,
                                            None if hit is None else hit.reflection_states,
                                            None if powered else TagResponse(
                                                False, None, None, None, None, None, "not powered", p_dbm, None,
                                                None, None, None, rest, a_s))
        return q

    def _quiet_at(self, p_inc: float) -> QuietPoint | None:
        """The remembered power decision of ``p_inc`` (made by :meth:`_respond` with the
        current config and chip), or None."""
        quiet = self._quiet.get(p_inc)
        if quiet is not None and quiet.config is self.config and quiet.chip is self.chip:
            return quiet
        return None

    def quiet_point(self, fe: SharedFrontEnd, gain: complex, *, decide: bool = False) -> QuietPoint | None:
        """The remembered power decision for the scaled copy g·x of a shared segment.

        Used by a population (:mod:`rfsim.devices.tag_population`). With ``decide`` the
        decision is made now when it is not known yet: the one :meth:`reflect` would make
        (config or chip power-up at |g·x_m|², :meth:`_power_decision`), remembered, without
        changing the tag (its state machine, operating point and power state are left as they
        are); a population decides every member at a new carrier this way and drives only the
        members that do not stay quiet.

        Parameters
        ----------
        fe : SharedFrontEnd
            Shared front end of the emitted segment x.
        gain : complex
            Complex gain g of the tag's link.
        decide : bool, default False
            Make the decision when it is not known.

        Returns
        -------
        QuietPoint or None
            The decision (config, chip, powered, P_inc [dBm], Γ_A, A_s, chip operating point or
            None, its reflection states, the unpowered response); None when it is not known
            (yet, without ``decide``; or a decision of another config or chip is remembered at
            this power), the tag does not share front ends or the segment has no CW plateau.
        """
        if not self.shared_front_end or fe.plateau is None:
            return None
        p_inc = self._incident_power_w(fe, gain)
        quiet = self._quiet_at(p_inc)
        if quiet is None and decide:
            self._power_decision(p_inc)
            quiet = self._quiet_at(p_inc)
        return quiet

    def take_quiet_step(self, quiet: tuple) -> None:
        """Apply a remembered power decision to the tag (besides its state machine's silent step).

        Sets the operating point and reflection states of ``quiet`` (with a chip) and, when
        unpowered, forgets the TRcal of the last Query.

        Parameters
        ----------
        quiet : QuietPoint
            Power decision from :meth:`quiet_point`.
        """
        op = quiet.operating_point
        if op is not None:
            self.operating_point, self.reflection_states = op, quiet.reflection_states
        if not quiet.powered:
            self._trcal_ticks = None

    def take_command(self, quiet: tuple, decoded: tuple, cmd_end_s: float, fs_hz: float):
        """Have a powered tag whose power decision is known take a decoded command that is not
        a silent step of its state machine, without forming its response.

        Applies the operating point of ``quiet`` (:meth:`take_quiet_step`), takes a Query's
        TRcal, then the state machine takes the command at its end (``TagState.on_command``
        with the tag's own generator): the steps of :meth:`respond_decoded` before the reply's
        Γ(t). Without a reply the tag's response is :meth:`silent_response`'s; with one,
        :meth:`respond_reply` forms it.

        Parameters
        ----------
        quiet : tuple
            Remembered power decision (powered) from :meth:`quiet_point`.
        decoded : tuple
            ``(command, frame)`` decoded from the segment (:meth:`SharedFrontEnd.command`);
            not an access command.
        cmd_end_s : float
            End of the command [s] (the segment's start plus the frame's end).
        fs_hz : float
            The segment's sample rate [Hz].

        Returns
        -------
        Reply or None
            The state machine's reply, or None.
        """
        self.take_quiet_step(quiet)
        cmd, frame = decoded
        self._take_trcal(cmd, frame, fs_hz)
        return self.state.on_command(cmd, t_s=cmd_end_s, rng=self.rng)

    def _take_trcal(self, cmd, frame, fs_hz: float) -> None:
        """A Query's TRcal [samples at ``fs_hz``] counted in clock ticks (step 3 of the module
        docstring), kept for the replies of its round."""
        if isinstance(cmd, Query):
            self._trcal_ticks = self.ticks(frame.trcal, fs_hz)

    def respond_decoded(self, quiet: tuple, decoded: tuple, incident, *, silent_tried: bool = False,
                        power_up: bool = False) -> TagResponse:
        """:meth:`reflect` of a powered tag whose power decision for this segment is known.

        Applies the operating point of ``quiet``, then continues from the decoded
        ``(command, frame)`` on (state machine, reply): what :meth:`_respond` computes, without
        deciding the power again.

        Parameters
        ----------
        quiet : tuple
            Remembered power decision (powered) from :meth:`quiet_point`.
        decoded : tuple
            ``(command, frame)`` decoded from the segment (:meth:`SharedFrontEnd.command`).
        incident : rfsim.air.segment.Segment
            The segment (``t0_s``, ``fs_hz``, ``n_samples`` are read).
        silent_tried : bool, default False
            The state machine has already declined a silent step of this command
            (``TagState.on_command_if_silent``): it is not asked again.
        power_up : bool, default False
            The tag is unpowered and ``quiet`` powers it: its state machine powers up at the
            segment's start first (``TagState.on_power``; the TRcal of an earlier Query is
            forgotten), as in :meth:`_respond`.

        Returns
        -------
        TagResponse
            The tag's reaction.
        """
        self.take_quiet_step(quiet)
        if power_up:
            self.state.on_power(True, incident.t0_s)
            self._trcal_ticks = None
        return self._decoded(decoded[0], decoded[1], quiet.p_dbm, quiet.gamma_rest, quiet.structural_mode,
                             t0_s=incident.t0_s, fs_hz=incident.fs_hz, n_samples=incident.n_samples,
                             cache=run_cache(incident.memo), silent_tried=silent_tried)

    @staticmethod
    def silent_response(quiet: tuple, cmd, cmd_end_s: float) -> TagResponse:
        """The response for a remembered power decision without a reply.

        Parameters
        ----------
        quiet : tuple
            Remembered power decision from :meth:`quiet_point`.
        cmd : object
            The decoded command.
        cmd_end_s : float
            End time of the command [s].

        Returns
        -------
        TagResponse
            The unpowered response, or a powered tag's silent step of ``cmd`` ("no reply").
        """
        if not quiet.powered:
            return quiet.unpowered
        return TagResponse(True, cmd, None, None, None, None, "no reply", quiet.p_dbm, cmd_end_s, None, None, None,
                           quiet.gamma_rest, quiet.structural_mode)

    def _quiet_response(self, quiet: tuple, decoded: tuple, incident) -> TagResponse | None:
        """:meth:`_respond`'s result for a tag that stays unpowered, or that stays powered
        and takes a silent step of its state machine (``TagState.on_command_if_silent``),
        from the remembered power decision ``quiet`` of this P_inc; None (nothing done) in
        every other case."""
        powered = quiet.powered
        if powered != self.state.powered:
            return None
        if not powered:
            self.take_quiet_step(quiet)
            return quiet.unpowered
        cmd, frame = decoded
        if cmd is None or isinstance(cmd, Query):
            return None
        cmd_end_s = incident.t0_s + frame.end / incident.fs_hz
        if not self.state.on_command_if_silent(cmd, t_s=cmd_end_s):
            return None
        self.take_quiet_step(quiet)
        return self.silent_response(quiet, cmd, cmd_end_s)

    def listen(self, incident: np.ndarray, *, t0_s: float, fs_hz: float) -> TagResponse:
        """Receive one reader segment and return the tag's reaction.

        Steps 1–6 of the module docstring: power-up from the CW power, envelope detection, PIE
        decoding with the tag's clock, the Gen2 state machine and the reply's Γ(t). A segment
        carries one command: if the decoder finds several PIE frames, the first is used. Power
        is judged once per segment (at ``t0_s``).

        Parameters
        ----------
        incident : numpy.ndarray, shape (n_samples,), complex
            Field at the tag antenna port [√W] (command + CW), at least 2 samples.
        t0_s : float
            Absolute time of sample 0 [s]; segments must come in time order.
        fs_hz : float
            Sample rate [Hz] (> 0).

        Returns
        -------
        TagResponse
            Power state, decoded command, reply, Γ(t) over the segment and reply timing.

        Raises
        ------
        ValueError
            If ``incident`` is not 1-D with at least 2 samples or ``fs_hz`` is not > 0.
        """
        x = np.asarray(incident)
        if x.ndim != 1 or x.size < 2:
            raise ValueError(f"incident must be a 1-D array of >= 2 samples, got shape {x.shape}")
        fs_hz, t0_s = float(fs_hz), float(t0_s)
        if not fs_hz > 0:
            raise ValueError(f"fs_hz must be > 0, got {fs_hz}")
        env = np.abs(x)
        levels = two_level_threshold(env)
        p_inc = _cw_power_w(env, levels)  # = incident_power_w(x)

        def decode():
            if self.config.envelope_rc_s > 0:
                return _command_of(pie_decode(envelope(x, fs_hz=fs_hz, rc_s=self.config.envelope_rc_s)))
            # the ideal detector's envelope is |x|, already split into its two levels
            return _command_of(pie_decode(env, levels=levels))

        return self._respond(p_inc, decode, t0_s=t0_s, fs_hz=fs_hz, n_samples=x.size)

    def _respond(self, p_inc: float, decode, *, t0_s: float, fs_hz: float, n_samples: int,
                 cache: AirCache | None = None) -> TagResponse:
        """Everything after the front end: power-up (config or chip) from the incident power
        ``p_inc`` [W], the command from ``decode()`` → (command, PIE frame) or (None, None),
        the state machine and the reply's Γ(t) over ``n_samples`` samples (kept in the run's
        ``cache`` by content, :func:`reply_gamma`)."""
        powered, p_dbm, rest, a_s, hit = self._power_decision(p_inc)
        if hit is not None:
            self.operating_point, self.reflection_states = hit.operating_point, hit.reflection_states
        if not powered:
            if self.state.powered:
                self.state.on_power(False, t0_s)
            self._trcal_ticks = None
            return TagResponse(False, None, None, None, None, None, "not powered", p_dbm, None, None, None, None,
                               rest, a_s)
        if not self.state.powered:
            self.state.on_power(True, t0_s)
            self._trcal_ticks = None

        cmd, frame = decode()
        return self._decoded(cmd, frame, p_dbm, rest, a_s, t0_s=t0_s, fs_hz=fs_hz, n_samples=n_samples, cache=cache)

    def _power_decision(self, p_inc: float) -> tuple:
        """Power-up at the incident power ``p_inc`` [W] (config or chip), without changing the
        tag: ``(powered, P_inc [dBm], Γ_A, A_s, the chip's _ChipPoint or None)``. The decision is
        remembered as a :class:`QuietPoint` (with :attr:`shared_front_end`)."""
        p_dbm = _dbm(p_inc)
        hit = None
        if self.chip is not None:
            # the operating point is a pure function of the (frozen) chip and P_inc: a held
            # link gives the same P_inc exchange after exchange
            hit = self._chip_memo.get(p_inc)
            if hit is None or hit.chip is not self.chip:
                if len(self._chip_memo) > 64:
                    self._chip_memo.clear()
                op = self.chip.operating_point(p_inc)
                hit = self._chip_memo[p_inc] = _ChipPoint(self.chip, op, _chip_spread(
                    ReflectionStates(op.gamma_unmod, op.gamma_mod), self.config.chip_gain_db,
                    self.config.chip_phase_deg))
            powered = hit.operating_point.powered
            rest, a_s = hit.reflection_states.gamma_a, self._tau_power_up()[3]
        else:
            tau, tau_pu, sens_w, a_s = self._tau_power_up()
            powered = _config_powered(tau, tau_pu, sens_w, p_inc)
            rest = self.reflection_states.gamma_a
        if self.shared_front_end and p_inc not in self._quiet:  # the power decision of this P_inc
            self._remember_quiet(p_inc, powered, p_dbm, rest, a_s, hit)
        return powered, p_dbm, rest, a_s, hit

    def _decoded(self, cmd, frame, p_dbm: float, rest: complex, a_s: complex, *, t0_s: float, fs_hz: float,
                 n_samples: int, cache: AirCache | None = None, silent_tried: bool = False) -> TagResponse:
        """:meth:`_respond` of a powered tag from the decoded ``(cmd, frame)`` on: TRcal, the
        state machine and the reply's Γ(t) (P_inc ``p_dbm`` [dBm], Γ_A ``rest``, A_s ``a_s``);
        the one tail of every path (:meth:`_respond`, :meth:`respond_decoded`). ``silent_tried``:
        the state machine has already declined a silent step of ``cmd``."""
        if cmd is None:
            return TagResponse(True, None, None, None, None, None, "decode error", p_dbm, None, None, None, None,
                               rest, a_s)
        self._take_trcal(cmd, frame, fs_hz)
        cmd_end_s = t0_s + frame.end / fs_hz
        # the state machine's silent steps first (a QueryRep counting down, an ACK not for it;
        # a step it declines changes nothing, so asking again after _quiet_response is the same)
        if not silent_tried and self.state.on_command_if_silent(cmd, t_s=cmd_end_s):
            reply = None
        elif isinstance(cmd, ACCESS_COMMANDS):
            reply = self.state.on_command(cmd, t_s=cmd_end_s, rng=self.rng,
                                          power_margin_db=self.power_margin_db(p_dbm))
        else:
            reply = self.state.on_command(cmd, t_s=cmd_end_s, rng=self.rng)
        return self._replied(cmd, frame, reply, cmd_end_s, p_dbm, rest, a_s, t0_s=t0_s, fs_hz=fs_hz,
                             n_samples=n_samples, cache=cache)

    def power_margin_db(self, p_dbm: float) -> float:
        """Power at the chip above its sensitivity [dB], at incident power ``p_dbm``.

        Without a power-dependent chip 10·log10(τ_PU·τ·P_inc / P_min) (step 1 of the module
        docstring: powered ⇔ margin ≥ 0); with one 10·log10(P_chip / P_threshold) of the
        last segment's operating point. Access commands that write memory need a margin of at
        least the memory chip's write threshold (the tag's memory's chip model,
        :func:`rfsim.gen2.access.execute`).

        Parameters
        ----------
        p_dbm : float
            Incident (available) CW power P_inc [dBm].

        Returns
        -------
        float
            The margin [dB] (−inf at zero power).
        """
        if self.chip is not None and self.operating_point is not None:
            p_chip_w = self.operating_point.p_chip_w
            return 10.0 * math.log10(p_chip_w / self.chip.threshold_w) if p_chip_w > 0 else -math.inf
        tau, tau_pu, sens_w, _ = self._tau_power_up()
        if p_dbm == -math.inf:
            return -math.inf
        return p_dbm - 30.0 + 10.0 * math.log10(tau_pu * tau / sens_w)

    def respond_reply(self, quiet: tuple, decoded: tuple, incident, reply) -> TagResponse:
        """:meth:`respond_decoded` of a tag whose state machine has already answered.

        The state machine has already taken the decoded ``(command, frame)`` and given ``reply``
        (a population's QueryAdjust, the counters loaded at once:
        ``StateArrays.take_redraw_steps``): applies the operating point of ``quiet``, then forms
        the reply's Γ(t) as :meth:`_decoded` does.

        Parameters
        ----------
        quiet : tuple
            Remembered power decision (powered) from :meth:`quiet_point`.
        decoded : tuple
            ``(command, frame)`` decoded from the segment.
        incident : rfsim.air.segment.Segment
            The segment (``t0_s``, ``fs_hz``, ``n_samples`` are read).
        reply : object or None
            The state machine's reply (bits to backscatter), or None.

        Returns
        -------
        TagResponse
            The tag's reaction.
        """
        self.take_quiet_step(quiet)
        cmd, frame = decoded
        return self._replied(cmd, frame, reply, incident.t0_s + frame.end / incident.fs_hz, quiet.p_dbm,
                             quiet.gamma_rest, quiet.structural_mode, t0_s=incident.t0_s, fs_hz=incident.fs_hz,
                             n_samples=incident.n_samples, cache=run_cache(incident.memo))

    def _timing(self, dr, rtcal: float, fs_hz: float) -> _ReplyTiming:
        """The reply's BLF and counted T1 for the last Query's TRcal (:attr:`_trcal_ticks`), its
        divide ratio ``dr`` and the command's RTcal ``rtcal`` [samples at ``fs_hz``]: N_BLF =
        :meth:`TagClock.blf_divider`, BLF = f_clk/N_BLF·(1 + ε), N_T1 = max(N_RTcal, 10·N_BLF)
        (steps 3–4 of the module docstring); the last one is kept, by N_RTcal (a Query and the ACK
        after it give the same, although their RTcal measured in samples may differ in its last bits)."""
        t = self.__dict__.get("_reply_timing")
        clock, cfg, trcal_ticks = self.clock, self.config, self._trcal_ticks
        rtcal_ticks = self.ticks(rtcal, fs_hz)
        if (t is not None and t.clock is clock and t.config is cfg and t.trcal_ticks == trcal_ticks and t.dr == dr
                and t.rtcal_ticks == rtcal_ticks):
            return t
        f_clk = clock.f_hz
        n_blf = clock.blf_divider(trcal_ticks / f_clk, dr, trcal_ticks=trcal_ticks)
        blf_hz = f_clk / n_blf
        if cfg.blf_error_percent:  # the tag's own BLF error (rfsim.devices.tag_spread)
            blf_hz *= 1.0 + 0.01 * cfg.blf_error_percent
        n_t1 = max(rtcal_ticks, 10 * n_blf)
        t = self.__dict__["_reply_timing"] = _ReplyTiming(clock, cfg, trcal_ticks, dr, rtcal_ticks, blf_hz,
                                                          n_t1 / f_clk)
        return t

    def _replied(self, cmd, frame, reply, cmd_end_s: float, p_dbm: float, rest: complex, a_s: complex, *,
                 t0_s: float, fs_hz: float, n_samples: int, cache: AirCache | None = None) -> TagResponse:
        """The response of a powered tag whose state machine answered ``cmd`` (ending at
        ``cmd_end_s`` [s]) with ``reply`` (or None): the reply's timing and Γ(t) (:func:`reply_gamma`,
        with the run's ``cache``)."""
        query = self.state.last_query
        if reply is None or query is None or self._trcal_ticks is None:
            return TagResponse(True, cmd, None, None, None, None, "no reply", p_dbm, cmd_end_s, None, None, None,
                               rest, a_s)

        timing = self._timing(query.dr, frame.rtcal, fs_hz)
        blf_hz = timing.blf_hz
        start_s = cmd_end_s + timing.t1_ticks_s + self.config.t1_offset_s
        if self.clock.jitter_rms > 0:
            start_s += self.clock.jitter_rms * float(self.rng.standard_normal()) / self.clock.f_hz
        trext = query.trext
        if reply.delayed:  # step 4: a delayed reply, after the programming time, with the pilot tone
            start_s += reply.delay_s
            trext = True
        gamma = reply_gamma(reply.bits, m=query.m, trext=trext, blf_hz=blf_hz, fs_hz=fs_hz, t0_s=start_s - t0_s,
                            n_samples=n_samples, gamma_b=self.reflection_states.gamma_b, gamma_a=rest, cache=cache,
                            drawn=reply.kind in _DRAWN_REPLIES)
        end_s = start_s + reply_duration_s(reply.bits.size, m=query.m, trext=trext, blf_hz=blf_hz)
        return TagResponse(powered=True, command=cmd, reply=reply, gamma=gamma, reply_start_s=start_s, blf_hz=blf_hz,
                           reason="", incident_power_dbm=p_dbm, command_end_s=cmd_end_s, reply_end_s=end_s,
                           m=query.m, trext=trext, gamma_rest=rest, structural_mode=a_s)


__all__ = ["TagResponse", "PassiveTag", "QuietPoint", "SharedFrontEnd", "Decoded", "incident_power_w", "envelope",
           "reply_gamma", "DEFAULT_SENSITIVITY_DBM", "REASONS"]

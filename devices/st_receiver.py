"""Sense-a-tag (ST) receive chain at sample level: envelope detector → band-pass →
hysteresis comparator → FM0/Miller decoding, single and dual antenna.

Hardware model (auris-sense-a-tag.md §6 "ST hardware", seed L1228-1250): antenna →
(modulator, matching) → diode envelope detector → analog backscatter path = band-pass
filter removing the DC of the CW + comparator acting as a one-bit A/D converter → digital
decoder. Phase cancellation is judged on the envelope-detector output difference between
the two reflection states with the threshold 5 mV (§3.1, L3443-3445, L3500-3502).

Signal model
------------
Input ``x : (n,) complex128`` is the complex baseband at the ST antenna port in √W
(``|x|²`` = available power [W]; the carrier is implicit), i.e. reader CW + backscatter as
the engine delivers it. Detector (:class:`EnvelopeDetector`):

* ``law="linear"`` (large-signal diode, the regime of the AURIS closed forms): the RF peak
  voltage across the reference impedance R is ``V = sqrt(2·R·P) = sqrt(2R)·|x|`` and the
  detector output is ``v = gain·V``. With ``gain = 1`` the output difference between the
  two reflection states equals ``|A1 − A2|`` of Eq. 3.3/3.4 for ``A = sqrt(2R)·|a|``.
* ``law="square"`` (small-signal diode): ``v = responsivity·|x|²`` [V/W·W].
* ``law="diode"`` (the ST's diode detector, default of the phase-cancellation scenario):
  an exponential diode ``I = I_s·(e^{v/(n·V_T)} − 1)`` rectifying a carrier of peak
  ``V_d = G_v·V`` into an unloaded RC holds the output where the mean diode current is zero,
  ``v = n·V_T·ln I0(G_v·V/(n·V_T))`` (the classic peak-detector result; I0 the modified
  Bessel function, V_T = kT/q = 24.99 mV at 290 K, n the ideality factor, G_v the matching
  network's voltage gain). Square law ``v ≈ (G_v·V)²/(4·n·V_T)`` for ``G_v·V ≪ n·V_T``;
  linear ``v ≈ G_v·V − n·V_T·ln sqrt(2π·G_v·V/(n·V_T))`` above. A small change ΔV of the
  envelope gives ``Δv = G_v·[I1(x)/I0(x)]·ΔV`` with ``x = G_v·V/(n·V_T)``: at the ST's CW
  (≈ 0.6 V peak at 50 Ω in cell 1, x ≈ 20) the slope is ``G_v·0.975``.
* ``law="agc"``: PASS's demodulator characteristic (``meas_tag_agc``: envelope peak
  ``venv(V_rf)`` at Vdda 2 V for a chip voltage V_rf = V·agc_scale): the output is the
  envelope scaled so that its peak over the input equals ``venv`` (per row),
  ``v(t) = venv(max V·s)/max V · V(t)`` (pass-paris-simulator.md §2.2/§2.3).

Diode detector: conversion and threshold. The source's threshold 5 mV is a detector-output
voltage. Its two quoted conversions are per source volt (peak sqrt(2P) across 1 Ω): R3-1
(Table 3.1 row 2) 0.0015 V → "0.01 V" and R3-4 0.0019 V → 0.012 V, i.e. 0.0106 V and
0.0134 V at 50 Ω (√50 × source volts) that the detector turns into × 0.94 and × 0.89. The
ratio differs because R3-4's envelope is low (θ ≈ π, A_T/A_R = 0.68: 0.22 V peak, x ≈ 8)
where I1/I0 = 0.94, against 0.98 at R3-1's 0.77 V. One parameter,
``G_v`` = :data:`DEFAULT_MATCHING_GAIN` = 0.96, gives 0.0100 V and 0.0121 V (both within
1 %; the linear unit-gain detector gave +6 % and +12 %). The threshold stays 5 mV at the
detector output; the conversion from the antenna is the diode's. (A lossless match to a
high-impedance diode would give G_v > 1; 0.96 is a fit to the source, stated as such.)

The source's detector outputs are about 6× the antenna-level differences (0.0017 V →
0.01 V, L3358-3362; 0.0019 V → 0.012 V, L3436-3441); ``gain`` reproduces such a
conversion; the default 1 makes the output equal the closed forms.

Source voltage unit. The source's simulator (PASS, auris-sense-a-tag.md §6.1) sets the
reader's real passband signal to variance P_tx, so its "volts" are the peak ``sqrt(2P)``
across 1 Ω (:data:`SOURCE_IMPEDANCE_OHM`): a source amplitude is ``sqrt(2P)`` =
``V / sqrt(R/1 Ω)`` of the 50 Ω peak voltage here (:func:`to_source_volts`). With
3.28 W EIRP the CW at a dipole 1 m away is 0.0856 V in that unit (0.605 V at 50 Ω), as
Table 3.1's A_R = 0.0802 V at cell 1 (L3372-3380). The source's ×6 detector conversion
applies to source volts: per 50 Ω volt it is ``6/sqrt(50)`` = 0.85, within 15 % of the
default gain 1.

followed by an RC low-pass ``τ·dv/dt = v_d − v`` (discretised exactly for a held input:
``a = 1 − exp(−1/(fs·τ))``); the default ``τ = 1/(2π·4·BLF)`` passes the subcarrier
and its third harmonic (4 BLF is also the PASS reader's demodulation cut-off, §6.1).

The band-pass (Butterworth, default order 1 over ``[BLF/8, 4·BLF]``) starts in the steady
state of its first input sample (no CW switch-on transient). The comparator switches to
+1 above ``+threshold/2`` and to −1 below ``−threshold/2`` (hysteresis width = threshold),
so a band-passed swing of peak-to-peak ``|A1 − A2|`` toggles it only if it exceeds the
threshold — the comparator realises the source's 5 mV criterion (approximately: the
band-pass reshapes the square wave, by a few % near the edges of its band).

Decoding: :func:`rfsim.gen2.linecode.decode_reply` on the ±1 comparator output; detection
requires the comparator to toggle and, with ``crc=True``, a valid CRC-16 (PC+EPC+CRC),
otherwise a preamble correlation of at least ``min_corr`` (RN16).

Dual antenna (§1.5, §1.6, §5): simple combination = RF sum of the two antenna ports before
the detector (:func:`receive_combined`); receiving-path selection = two chains, decode both,
Algorithm 1 (:func:`receive_selection`); ASK-PSK stamp = one decoding path chosen from the
stamp decoded on the default path (:func:`receive_stamp`). SA1 feeds the receive-only path
P1, SA2 the full ST path P2.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from rfsim.devices.st_analytic import THRESHOLD_V, select_path
from rfsim.devices.st_bandpass import butter_bandpass_sos
from rfsim.devices.st_levels import settled_mask, state_envelope_difference, state_levels
from rfsim.core.errors import ConfigError
from rfsim.gen2.crc import crc16_ok
from rfsim.gen2.linecode import SearchArrays, decode_reply, halfsymbols, reply_waveform, search_arrays
from rfsim.core.lazy import lazy_import

_signal = lazy_import("scipy.signal")
_special = lazy_import("scipy.special")
_k = lazy_import("rfsim.devices._st_receiver_kernels")

REFERENCE_IMPEDANCE_OHM = 50.0
#: Reference impedance of the source's amplitudes (PASS: peak sqrt(2P) across 1 Ω) [Ω]
SOURCE_IMPEDANCE_OHM = 1.0
DETECTOR_LAWS = ("linear", "square", "diode", "agc")
#: Boltzmann constant over the elementary charge [V/K] (thermal voltage V_T = k·T/q)
K_OVER_Q_V_PER_K = 1.380649e-23 / 1.602176634e-19
#: Matching-network voltage gain G_v of the default diode detector, chosen so that the
#: source's two quoted detector conversions are met (R3-1: 0.0015 V → "0.01 V", R3-4:
#: 0.0019 V → 0.012 V in source volts, both within 1 %; module docstring "Diode detector")
DEFAULT_MATCHING_GAIN = 0.96
#: Diode ideality factor n (zero-bias Schottky detector diodes: 1.05) and temperature [K]
DEFAULT_IDEALITY = 1.05
DEFAULT_TEMPERATURE_K = 290.0

# ----------------------------------------------------------------------------- building blocks


def to_source_volts(v, *, impedance_ohm: float = REFERENCE_IMPEDANCE_OHM):
    """Peak RF voltage across ``impedance_ohm`` → the source's amplitude unit [V].

    The source (PASS) amplitude is ``sqrt(2P)`` across :data:`SOURCE_IMPEDANCE_OHM` (1 Ω);
    for ``V = sqrt(2·R·P)`` it is ``V·sqrt(SOURCE_IMPEDANCE_OHM / R)`` (module docstring,
    "Source voltage unit"; auris-sense-a-tag.md §6.1).

    Parameters
    ----------
    v : float or array_like
        Peak RF voltage across ``impedance_ohm`` [V].
    impedance_ohm : float, default REFERENCE_IMPEDANCE_OHM (50 Ω)
        Reference impedance R of ``v`` [Ω] (> 0).

    Returns
    -------
    numpy.ndarray
        Amplitude in source volts [V].

    Raises
    ------
    ValueError
        If ``impedance_ohm`` is not > 0.
    """
    if not impedance_ohm > 0:
        raise ValueError(f"impedance_ohm must be > 0, got {impedance_ohm}")
    return np.asarray(v, dtype=float) * math.sqrt(SOURCE_IMPEDANCE_OHM / impedance_ohm)


def rc_lowpass(u, *, fs_hz: float, tau_s: float, y0: float | None = None) -> tuple[np.ndarray, float]:
    """First-order RC low-pass (numba kernel).

    ``y[n] = y[n−1] + a·(u[n] − y[n−1])``, ``a = 1 − exp(−1/(fs·τ))`` (exact step response
    of ``τ·dy/dt = u − y`` for an input held over each sample).

    Parameters
    ----------
    u : (n,) float64 input [V]
    fs_hz, tau_s : sample rate [Hz], time constant [s]
    y0 : state before the first sample (default ``u[0]``, the steady state)

    Returns
    -------
    y : (n,) float64 [V], and the final state (pass it as ``y0`` to continue in chunks)
    """
    u = np.ascontiguousarray(u, dtype=np.float64)
    if u.ndim != 1:
        raise ValueError(f"u must be 1-D, got shape {u.shape}")
    a = _rc_coefficient(fs_hz, tau_s)
    y0 = float(u[0]) if (y0 is None and u.size) else float(y0 or 0.0)
    out = np.empty_like(u)
    last = _k.rc_lowpass_kernel(u, a, y0, out)
    return out, float(last)


def _rc_coefficient(fs_hz: float, tau_s: float) -> float:
    if not (fs_hz > 0 and tau_s > 0):
        raise ValueError(f"fs_hz and tau_s must be > 0, got {fs_hz}, {tau_s}")
    return -math.expm1(-1.0 / (float(fs_hz) * float(tau_s)))


def i0e(x) -> np.ndarray:
    """Exponentially scaled modified Bessel function ``exp(−|x|)·I0(x)`` (numba).

    The Cephes series of ``scipy.special.i0e`` evaluated in the same order (equal results;
    SciPy's is the twin).

    Parameters
    ----------
    x : float or array_like
        Argument.

    Returns
    -------
    numpy.ndarray, float64
        ``exp(−|x|)·I0(x)``, shape of ``x``.
    """
    x = np.asarray(x, dtype=np.float64)
    out = np.empty(x.shape)
    _k.i0e_kernel(np.ascontiguousarray(x).reshape(-1), out.reshape(-1))
    return out


def comparator(v, *, threshold_v: float, state0: int = -1) -> tuple[np.ndarray, int, int]:
    """Hysteresis comparator (one-bit A/D) with switching levels ``±threshold_v/2`` (numba).

    The output switches to +1 above ``+threshold_v/2`` and to −1 below ``−threshold_v/2``
    (hysteresis width = threshold; auris-sense-a-tag.md §6, the 5 mV criterion of §3.1).

    Parameters
    ----------
    v : array_like, shape (n_samples,)
        Band-passed detector output [V].
    threshold_v : float
        Hysteresis width [V] (>= 0).
    state0 : {-1, 1}, default -1
        Output state before the first sample.

    Returns
    -------
    out : numpy.ndarray, shape (n_samples,), float64
        Comparator output (±1).
    last_state : int
        State after the last sample (pass as ``state0`` to continue in chunks).
    n_toggles : int
        Number of output transitions.

    Raises
    ------
    ValueError
        If ``threshold_v < 0`` or ``state0`` is not ±1.
    """
    v = np.ascontiguousarray(v, dtype=np.float64)
    if not threshold_v >= 0:
        raise ValueError(f"threshold_v must be >= 0, got {threshold_v}")
    if state0 not in (-1, 1):
        raise ValueError(f"state0 must be ±1, got {state0}")
    out = np.empty_like(v)
    st, tog = _k.comparator_kernel(v, 0.5 * threshold_v, -0.5 * threshold_v, int(state0), out)
    return out, int(st), int(tog)


def passband_envelope_v(v_rf, *, fs_hz: float, tau_s: float) -> np.ndarray:
    """Envelope of a real RF voltage by full-wave rectification and RC smoothing [V].

    Cross-check of the baseband detector (passband mode): for ``v(t) = A(t)·cos(ωt + φ(t))``
    with ``1/f_c ≪ τ``, the mean of ``|v|`` is ``(2/π)·A``, so ``(π/2)·RC{|v|}`` tends to A
    (ripple at 2·f_c attenuated by ``≈ 1/(4π f_c τ)``). The RC starts from 0.

    Parameters
    ----------
    v_rf : array_like, shape (n_samples,)
        Real RF voltage [V], sampled at ``fs_hz ≫ f_c``.
    fs_hz : float
        Sample rate [Hz].
    tau_s : float
        RC time constant [s].

    Returns
    -------
    numpy.ndarray, shape (n_samples,), float64
        Envelope estimate [V].
    """
    u = 0.5 * np.pi * np.abs(np.asarray(v_rf, dtype=np.float64))
    return rc_lowpass(u, fs_hz=fs_hz, tau_s=tau_s, y0=0.0)[0]


# ----------------------------------------------------------------------------- detector


@dataclass(frozen=True)
class EnvelopeDetector:
    """Diode envelope detector with an RC output filter.

    Attributes
    ----------
    tau_s : RC time constant [s]
    law : ``"linear"`` (``v = gain·sqrt(2R)·|x|``), ``"square"`` (``v = responsivity·|x|²``),
        ``"diode"`` (``v = n·V_T·ln I0(G_v·V/(n·V_T))``) or ``"agc"`` (module docstring)
    matching_gain, ideality, temperature_k : G_v, n and T of the diode law
    agc_vrf_v, agc_venv_v, agc_scale : AGC table (chip voltage → envelope peak) and V → V_rf factor
    gain : linear-law voltage conversion (output V per RF peak V)
    responsivity_v_per_w : square-law responsivity [V/W]
    impedance_ohm : reference impedance R of the antenna port [Ω]
    """

    tau_s: float
    law: str = "linear"
    gain: float = 1.0
    responsivity_v_per_w: float = 1000.0
    impedance_ohm: float = REFERENCE_IMPEDANCE_OHM
    matching_gain: float = DEFAULT_MATCHING_GAIN
    ideality: float = DEFAULT_IDEALITY
    temperature_k: float = DEFAULT_TEMPERATURE_K
    agc_vrf_v: tuple = ()
    agc_venv_v: tuple = ()
    agc_scale: float = 1.0

    def __post_init__(self):
        if self.law not in DETECTOR_LAWS:
            raise ConfigError("law", self.law, "one of " + ", ".join(DETECTOR_LAWS))
        for key in ("tau_s", "gain", "responsivity_v_per_w", "impedance_ohm", "matching_gain", "ideality",
                    "temperature_k", "agc_scale"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v > 0):
                raise ConfigError(key, v, "> 0")
        if self.law == "agc" and (len(self.agc_vrf_v) < 2 or len(self.agc_vrf_v) != len(self.agc_venv_v)):
            raise ConfigError("agc_vrf_v", len(self.agc_vrf_v), "an AGC table of >= 2 points (vrf, venv)")

    @property
    def thermal_voltage_v(self) -> float:
        """``n·V_T = n·k·T/q`` [V]."""
        return self.ideality * K_OVER_Q_V_PER_K * self.temperature_k

    def transfer_v(self, v_peak):
        r"""Static detector law: output for an RF peak voltage at the port.

        ``linear``: ``gain·V``; ``square``: ``responsivity·V²/(2R)``; ``diode``:

        .. math::

            v = n V_T \ln I_0\!\left(\frac{G_v V}{n V_T}\right)

        (evaluated as ``n·V_T·(ln i0e(x) + x)``, no overflow; module docstring); ``agc``:
        ``agc_gain(V)·V`` sample by sample (the per-row scaling of :meth:`instantaneous_v` uses
        the peak instead).

        Parameters
        ----------
        v_peak : float or array_like
            RF peak voltage at the port [V].

        Returns
        -------
        numpy.ndarray or float
            Detector output [V], shape of ``v_peak`` (a scalar for a scalar diode input).
        """
        v = np.asarray(v_peak, float)
        if self.law == "linear":
            return self.gain * v
        if self.law == "square":
            return self.responsivity_v_per_w * v * v / (2.0 * self.impedance_ohm)
        if self.law == "diode":
            # nvt·(ln I0(x) + ...) with ln I0(x) = ln(i0e(x)) + x (no overflow), x = g·V/(n·V_T);
            # evaluated in place (the same operations in the same order as the formula)
            nvt = self.thermal_voltage_v
            x = self.matching_gain * v
            x /= nvt
            y = i0e(x)
            np.log(y, out=y)
            y += x
            y *= nvt
            return y if y.ndim else y[()]
        return self.agc_gain(v) * v

    def agc_gain(self, v_peak_max):
        """AGC law: ``venv(V·s)/V`` for the envelope peak V [V/V].

        ``venv`` is interpolated linearly in the AGC table (``agc_vrf_v`` → ``agc_venv_v``) at the
        chip voltage ``V·agc_scale`` (pass-paris-simulator.md §2.2/§2.3).

        Parameters
        ----------
        v_peak_max : float or array_like
            Peak RF voltage of the envelope [V] (floored at 1e-30 V).

        Returns
        -------
        numpy.ndarray
            Conversion gain (output V per RF peak V).
        """
        v = np.maximum(np.asarray(v_peak_max, float), 1e-30)
        return np.interp(v * self.agc_scale, self.agc_vrf_v, self.agc_venv_v) / v

    def slope(self, v_peak):
        """Small-signal conversion ``dv/dV`` at an RF peak voltage [V/V].

        Diode: ``G_v·I1(x)/I0(x)`` with ``x = G_v·V/(n·V_T)``; square: ``responsivity·V/R``;
        agc: the AGC gain at V; linear: ``gain``.

        Parameters
        ----------
        v_peak : float or array_like
            RF peak voltage at the port [V].

        Returns
        -------
        numpy.ndarray
            Slope of the detector law [V/V], shape of ``v_peak``.
        """
        v = np.asarray(v_peak, float)
        if self.law == "diode":
            x = self.matching_gain * v / self.thermal_voltage_v
            return self.matching_gain * _special.i1e(x) / _special.i0e(x)
        if self.law == "square":
            return self.responsivity_v_per_w * v / self.impedance_ohm
        if self.law == "agc":
            return self.agc_gain(v)
        return np.full_like(v, self.gain)

    @property
    def volts_per_sqrt_w(self) -> float:
        """RF peak voltage per baseband unit: ``sqrt(2R)`` [V/√W]."""
        return math.sqrt(2.0 * self.impedance_ohm)

    def rf_peak_v(self, x) -> np.ndarray:
        """RF peak voltage at the port, ``sqrt(2R)·|x|`` [V].

        Parameters
        ----------
        x : complex or array_like of complex
            Baseband signal at the antenna port [√W].

        Returns
        -------
        numpy.ndarray
            Peak voltage [V], shape of ``x``.
        """
        return self.volts_per_sqrt_w * np.abs(np.asarray(x))

    def instantaneous_v(self, x) -> np.ndarray:
        """Detector output before the RC filter [V].

        Linear: ``gain·sqrt(2R)·|x|``; square: ``responsivity·|x|²``; diode: :meth:`transfer_v`
        of the peak voltage; agc: the peak voltage scaled by :meth:`agc_gain` of its maximum over
        the last axis (per row).

        Parameters
        ----------
        x : array_like of complex, shape (..., n_samples)
            Baseband signal at the antenna port [√W].

        Returns
        -------
        numpy.ndarray, float64
            Instantaneous detector output [V], shape of ``x``.
        """
        x = np.asarray(x)
        if self.law == "linear":
            return self.gain * self.rf_peak_v(x)
        if self.law == "square":
            return self.responsivity_v_per_w * (x.real ** 2 + x.imag ** 2)
        v = self.rf_peak_v(x)
        if self.law == "agc":
            return self.agc_gain(v.max(axis=-1, keepdims=True)) * v
        return self.transfer_v(v)

    def output_v(self, x, *, fs_hz: float, y0: float | None = None) -> np.ndarray:
        """Filtered detector output: :meth:`instantaneous_v` through the RC low-pass [V].

        Parameters
        ----------
        x : array_like of complex, shape (n_samples,)
            Baseband signal at the antenna port [√W].
        fs_hz : float
            Sample rate [Hz].
        y0 : float, optional
            RC state before the first sample [V] (default: the first input, the steady state).

        Returns
        -------
        numpy.ndarray, shape (n_samples,), float64
            Detector output after the RC [V].
        """
        return rc_lowpass(self.instantaneous_v(x), fs_hz=fs_hz, tau_s=self.tau_s, y0=y0)[0]


# ----------------------------------------------------------------------------- receiver


@dataclass(frozen=True)
class ChainOutput:
    """Intermediate signals of one receive path.

    Attributes
    ----------
    envelope_v : numpy.ndarray, shape (n_samples,), float64
        Detector output after the RC [V].
    bandpassed_v : numpy.ndarray, shape (n_samples,), float64
        Output of the band-pass [V].
    comparator : numpy.ndarray, shape (n_samples,), float64
        One-bit comparator output (±1).
    toggles : int
        Number of comparator transitions.
    """

    envelope_v: np.ndarray
    bandpassed_v: np.ndarray
    comparator: np.ndarray
    toggles: int


@dataclass(frozen=True)
class Reception:
    """Result of one receive path.

    Attributes
    ----------
    detected : reply detected and decoded (CRC-16 valid when requested)
    bits : (n_bits,) uint8 decoded bits, or None when nothing was decoded
    envelope_difference_v : |A(+1) − A(−1)| of the detector output [V] (NaN if unknown)
    envelope_difference_signed_v : A(+1) − A(−1) [V]
    toggles : comparator transitions; corr : preamble correlation; start_sample : reply start
    """

    detected: bool
    bits: np.ndarray | None
    envelope_difference_v: float
    envelope_difference_signed_v: float
    toggles: int
    corr: float = 0.0
    start_sample: float = float("nan")
    chain: ChainOutput | None = field(default=None, repr=False)


@dataclass(frozen=True)
class STReceiver:
    """Sense-a-tag receive chain for one link profile.

    Attributes
    ----------
    fs_hz : sample rate [Hz]; blf_hz : backscatter link frequency [Hz]
    m, trext : line code (1 = FM0, 2/4/8 = Miller-M) and pilot flag of the expected replies
    threshold_v : comparator hysteresis width = detection threshold [V] (default 5 mV)
    detector : envelope detector (default: linear, τ = 1/(2π·4·BLF), 50 Ω, gain 1)
    bpf_low_factor, bpf_high_factor, bpf_order : band-pass edges in units of BLF, order
    method : decoder (``"viterbi"`` or ``"bitwise"``)
    min_corr : preamble correlation needed when no CRC is checked
    min_toggles : comparator transitions needed before decoding is attempted
    settle_tau : RC time constants skipped after a state change when measuring levels
    """

    fs_hz: float
    blf_hz: float
    m: int = 2
    trext: bool = True
    threshold_v: float = THRESHOLD_V
    detector: EnvelopeDetector | None = None
    bpf_low_factor: float = 0.125
    bpf_high_factor: float = 4.0
    bpf_order: int = 1
    method: str = "viterbi"
    min_corr: float = 0.8
    min_toggles: int = 8
    settle_tau: float = 6.0

    def __post_init__(self):
        if not (self.fs_hz > 0 and self.blf_hz > 0):
            raise ConfigError("fs_hz/blf_hz", (self.fs_hz, self.blf_hz), "> 0")
        if not 0 < self.bpf_low_factor < self.bpf_high_factor:
            raise ConfigError("bpf_low_factor", self.bpf_low_factor, "0 < value < bpf_high_factor")
        if self.bpf_high_factor * self.blf_hz >= 0.5 * self.fs_hz:
            limit = 0.5 * self.fs_hz / self.blf_hz
            raise ConfigError("bpf_high_factor", self.bpf_high_factor, f"< fs/2/BLF = {limit:g}")
        if not self.threshold_v >= 0:
            raise ConfigError("threshold_v", self.threshold_v, ">= 0")
        if self.m not in (1, 2, 4, 8):
            raise ConfigError("m", self.m, "one of 1 (FM0), 2, 4, 8 (Miller)")

    @functools.cached_property
    def search_arrays(self) -> SearchArrays:
        """The preamble search's arrays of this receiver's line code, BLF and sample rate.

        :func:`rfsim.gen2.linecode.search_arrays`, made once per receiver and kept with it
        (its decodes pass them to :func:`rfsim.gen2.linecode.decode_reply`).

        Returns
        -------
        rfsim.gen2.linecode.SearchArrays
            The read-only arrays.
        """
        return search_arrays(int(self.m), bool(self.trext), 2.0 * float(self.blf_hz) / float(self.fs_hz))

    @property
    def envelope_detector(self) -> EnvelopeDetector:
        return self.detector if self.detector is not None else EnvelopeDetector(
            tau_s=1.0 / (2.0 * math.pi * 4.0 * self.blf_hz))

    @property
    def sos(self) -> np.ndarray:
        """Band-pass second-order sections (Butterworth, :func:`rfsim.devices.st_bandpass.butter_bandpass_sos`)."""
        return butter_bandpass_sos(self.bpf_order, self.bpf_low_factor * self.blf_hz,
                                   self.bpf_high_factor * self.blf_hz, self.fs_hz)

    @property
    def settle_samples(self) -> int:
        return int(math.ceil(self.settle_tau * self.envelope_detector.tau_s * self.fs_hz))

    @property
    def guard_samples(self) -> int:
        """Samples skipped before a state change when measuring levels (alignment margin)."""
        return 2

    def chain(self, x) -> ChainOutput:
        """Run detector, band-pass and comparator on one input.

        The band-pass starts in the steady state of the first detector sample, the comparator
        in −1.

        Parameters
        ----------
        x : array_like of complex, shape (n_samples,)
            Baseband signal at the antenna port [√W], at least 2 samples.

        Returns
        -------
        ChainOutput
            Detector output, band-pass output, comparator output and toggle count.

        Raises
        ------
        ValueError
            If ``x`` is not 1-D with at least 2 samples.
        """
        x = np.asarray(x)
        if x.ndim != 1 or x.size < 2:
            raise ValueError(f"x must be 1-D with >= 2 samples, got shape {x.shape}")
        env = self.envelope_detector.output_v(x, fs_hz=self.fs_hz)
        sos = self.sos
        bp = _signal.sosfilt(sos, env, zi=_signal.sosfilt_zi(sos) * env[0])[0]
        cmp_out, _, tog = comparator(bp, threshold_v=self.threshold_v)
        return ChainOutput(env, bp, cmp_out, tog)

    def receive(self, x, *, n_bits: int, crc: bool = True, states=None, start_sample: int = 0,
                search_samples: int | None = None) -> Reception:
        """Detect and decode one reply of ``n_bits`` bits in ``x`` (baseband at the port, √W).

        :meth:`chain` followed by :meth:`decode_chain`.

        Parameters
        ----------
        x : array_like of complex, shape (n_samples,)
            Baseband signal at the antenna port [√W].
        n_bits : int
            Data bits of the reply (RN16: 16; PC+EPC+CRC-16: 128 for a 96-bit EPC).
        crc : bool, default True
            Require a valid CRC-16 over the decoded bits (else a preamble correlation of at least
            ``min_corr``).
        states : array_like, shape (n_samples,), optional
            True line-code level (±1, 0 outside the reply) for measuring the envelope
            difference; default: re-encode the decoded bits.
        start_sample : int, default 0
            Decode only from this sample on (the chain runs over all of ``x``).
        search_samples : int, optional
            The reply start is searched within this many samples after ``start_sample``
            (default: anywhere; a known window makes decoding faster).

        Returns
        -------
        Reception
            Detection flag, decoded bits, envelope difference [V] and the chain's signals.
        """
        return self.decode_chain(self.chain(x), n_bits=n_bits, crc=crc, states=states, start_sample=start_sample,
                                 search_samples=search_samples)

    def _aligned_levels(self, envelope_v, bits, start: float) -> np.ndarray:
        """Re-encoded line-code levels of ``bits`` aligned on the detector output.

        The comparator output lags the envelope (RC and band-pass group delay), so the
        reply start is re-estimated by correlating the re-encoded levels with the
        mean-free envelope over ±2 elements around the decoded start.
        """
        n = envelope_v.size
        lvl = reply_waveform(bits, m=self.m, trext=self.trext, blf_hz=self.blf_hz, fs_hz=self.fs_hz)
        w = int(math.ceil(self.fs_hz / self.blf_hz))
        best, best_lag = -1.0, int(round(start))
        env0 = envelope_v - envelope_v.mean()
        for lag in range(int(round(start)) - w, int(round(start)) + w + 1):
            lo, hi = max(lag, 0), min(lag + lvl.size, n)
            if hi - lo < lvl.size // 2:
                continue
            v = abs(float(env0[lo:hi] @ lvl[lo - lag: hi - lag]))
            if v > best:
                best, best_lag = v, lag
        out = np.zeros(n)
        lo, hi = max(best_lag, 0), min(best_lag + lvl.size, n)
        out[lo:hi] = lvl[lo - best_lag: hi - best_lag]
        return out

    def decode_comparator(self, cmp, *, n_bits: int, search_samples: int | None = None):
        """Line-code decoding of a comparator output from its first sample.

        :func:`rfsim.gen2.linecode.decode_reply` with this receiver's line code, BLF, sample rate
        and decoder method.

        Parameters
        ----------
        cmp : array_like, shape (n_samples,)
            Comparator output (±1).
        n_bits : int
            Data bits of the reply.
        search_samples : int, optional
            The reply start is searched within this many samples (default: anywhere).

        Returns
        -------
        rfsim.gen2.linecode.ReplyDetection or None
            Decoded bits, preamble correlation and start sample, or None where no reply start
            fits.
        """
        try:
            return decode_reply(np.asarray(cmp).astype(np.complex128), n_bits=n_bits, m=self.m, trext=self.trext,
                                blf_hz=self.blf_hz, fs_hz=self.fs_hz, method=self.method,
                                search_samples=search_samples, arrays=self.search_arrays)
        except ValueError:
            return None

    def decode_chain(self, ch: ChainOutput, *, n_bits: int, crc: bool = True, states=None,
                     start_sample: int = 0, search_samples: int | None = None) -> Reception:
        """Decoding and measurement part of :meth:`receive` on a precomputed chain.

        Decoding is tried only when the comparator toggles at least ``min_toggles`` times after
        ``start_sample``; the envelope difference ``A(+1) − A(−1)`` is measured on the settled
        detector output (:func:`rfsim.devices.st_levels.state_envelope_difference`).

        Parameters
        ----------
        ch : ChainOutput
            Output of :meth:`chain`.
        n_bits : int
            Data bits of the reply.
        crc : bool, default True
            Require a valid CRC-16 (else a preamble correlation of at least ``min_corr``).
        states : array_like, shape (n_samples,), optional
            True line-code level (±1, 0 outside the reply); default: the decoded bits re-encoded
            and aligned on the detector output.
        start_sample : int, default 0
            Decode only from this sample on.
        search_samples : int, optional
            The reply start is searched within this many samples after ``start_sample``.

        Returns
        -------
        Reception
            Detection flag, decoded bits (None unless detected), envelope difference [V]
            (NaN when unknown), toggles, correlation, reply start and ``ch``.
        """
        s0 = int(start_sample)
        cmp_part = ch.comparator[s0:]
        toggles = int(np.count_nonzero(np.diff(cmp_part))) if cmp_part.size > 1 else 0
        bits, corr, start, detected = None, 0.0, float("nan"), False
        if toggles >= self.min_toggles:
            det = self.decode_comparator(cmp_part, n_bits=n_bits, search_samples=search_samples)
            if det is not None:
                bits, corr, start = det.bits, det.corr, det.start_sample + s0
                detected = bool(crc16_ok(bits)) if crc else corr >= self.min_corr
        if states is None and bits is not None:
            states = self._aligned_levels(ch.envelope_v, bits, start)
        diff = float("nan")
        if states is not None:
            diff = state_envelope_difference(ch.envelope_v, states, settle_samples=self.settle_samples,
                                             guard_samples=self.guard_samples)
        return Reception(detected=detected, bits=bits if detected else None, envelope_difference_v=abs(diff),
                         envelope_difference_signed_v=diff, toggles=toggles, corr=corr, start_sample=start, chain=ch)


# ----------------------------------------------------------------------------- dual antenna


def receive_combined(rx: STReceiver, x_sa1, x_sa2, **kwargs) -> Reception:
    """Simple combination (§1.5, Eq. 3.14): one chain on the RF sum ``x_sa1 + x_sa2``.

    The two ports are summed as complex amplitudes (ideal lossless combiner referred to one
    port; a real Wilkinson combiner would scale the sum by 1/√2, not modelled, as in
    Eq. 3.14; auris-sense-a-tag.md §1.5).

    Parameters
    ----------
    rx : STReceiver
        Receive chain.
    x_sa1, x_sa2 : array_like of complex, shape (n_samples,)
        Baseband signals at the ports of SA1 and SA2 [√W].
    **kwargs
        Passed to :meth:`STReceiver.receive` (``n_bits``, ``crc``, ...).

    Returns
    -------
    Reception
        Reception of the combined signal.
    """
    return rx.receive(np.asarray(x_sa1) + np.asarray(x_sa2), **kwargs)


@dataclass(frozen=True)
class SelectionReception:
    """Receiving-path selection result.

    Attributes
    ----------
    selected : Reception
        The selected reception (P2's when neither path decoded).
    path : {1, 2, None}
        Selected path, None when neither decoded.
    p1, p2 : Reception
        Receptions of both paths.
    """

    selected: Reception
    path: int | None
    p1: Reception
    p2: Reception

    @property
    def detected(self) -> bool:
        return self.path is not None


def receive_selection(rx: STReceiver, x_sa1, x_sa2, *, rx_p1: STReceiver | None = None, **kwargs) -> SelectionReception:
    """Receiving-path selection (§1.6, Algorithm 1, seed L3182-3196).

    Path P1 = receive-only chain on SA1 (``rx_p1``, default ``rx``), P2 = the full ST chain on
    SA2; both decode; ``ID2`` is returned if not NULL, else ``ID1``
    (:func:`rfsim.devices.st_analytic.select_path`).

    Parameters
    ----------
    rx : STReceiver
        Receive chain of P2 (and of P1 unless ``rx_p1`` is given).
    x_sa1, x_sa2 : array_like of complex, shape (n_samples,)
        Baseband signals at the ports of SA1 and SA2 [√W].
    rx_p1 : STReceiver, optional
        Receive chain of P1 (default ``rx``).
    **kwargs
        Passed to :meth:`STReceiver.receive` (``n_bits``, ``crc``, ...).

    Returns
    -------
    SelectionReception
        Selected reception, the chosen path and both receptions.
    """
    r1 = (rx_p1 or rx).receive(x_sa1, **kwargs)
    r2 = rx.receive(x_sa2, **kwargs)
    id1 = r1.bits if r1.detected else None
    id2 = r2.bits if r2.detected else None
    chosen = select_path(id1, id2)
    if chosen is None:
        return SelectionReception(r2, None, r1, r2)
    return (SelectionReception(r2, 2, r1, r2) if chosen is id2 else SelectionReception(r1, 1, r1, r2))


# ----------------------------------------------------------------------------- ASK-PSK stamp

#: Reflection-state labels of the three-state ASK-PSK modulator (§5, Fig. 5.3/5.4):
#: 0 = S1 (ASK state 1, PSK reference), 1 = S2 (ASK state 2), 2 = S3 = S1·e^{jψ} (PSK state).
STAMP_S1, STAMP_S2, STAMP_S3 = 0, 1, 2


@dataclass(frozen=True)
class StampFrame:
    """Sampled state sequence of a stamped frame and where its parts are [samples].

    Attributes
    ----------
    states : numpy.ndarray, shape (n_samples,), int8
        Reflection-state label per sample (:data:`STAMP_S1`, :data:`STAMP_S2`,
        :data:`STAMP_S3`; rest state S1 outside the frame).
    levels : numpy.ndarray, shape (n_samples,), float64
        Line-code level of the data reply (±1 inside it, 0 elsewhere).
    start : int
        First sample of the ASK stamp segment.
    ask_stop, psk_stop : int
        Ends (exclusive) of the ASK and PSK stamp segments.
    reply_start : int
        First sample of the Gen2 reply (pilot, preamble, data).
    """

    states: np.ndarray
    levels: np.ndarray
    start: int
    ask_stop: int
    psk_stop: int
    reply_start: int


def stamp_frame(bits, *, m: int, trext: bool, blf_hz: float, fs_hz: float, n_stamp_cycles: int = 8,
                t0_s: float = 0.0, tail_s: float = 0.0, n_settle_cycles: int = 0) -> StampFrame:
    """Frame of chapter 5: ASK-PSK stamp, then an ASK-modulated reply (seed L5874-6023).

    The stamp (Fig. 5.7; its exact format is not in the text) is modelled as
    ``n_stamp_cycles`` subcarrier cycles at BLF alternating S1/S2 (ASK part) followed by as
    many alternating S1/S3 (PSK part), then ``n_settle_cycles`` more ASK (S1/S2) pilot
    cycles before the reply's pilot tone (the stamp sits in the pilot, L6011-6017). The
    reply maps line-code level +1 → S1 and −1 → S2 (auris-sense-a-tag.md §5).

    Parameters
    ----------
    bits : array_like of uint8
        Reply data bits.
    m : int
        Line code: 1 = FM0, 2/4/8 = Miller-M.
    trext : bool
        Whether the reply carries the extended pilot tone.
    blf_hz : float
        Backscatter link frequency [Hz].
    fs_hz : float
        Sample rate [Hz].
    n_stamp_cycles : int, default 8
        Subcarrier cycles of each stamp part (>= 1).
    t0_s : float, default 0.0
        Start of the stamp [s].
    tail_s : float, default 0.0
        Rest-state time after the reply [s].
    n_settle_cycles : int, default 0
        ASK pilot cycles between the stamp and the reply (>= 0).

    Returns
    -------
    StampFrame
        State and level sequences and the segment boundaries [samples].

    Raises
    ------
    ConfigError
        If ``n_stamp_cycles < 1`` or ``n_settle_cycles < 0``.

    Notes
    -----
    Why the settling cycles: the PSK part swings the envelope by up to ``2·|b|`` (ψ = π)
    against ``|b1 − b2|`` for the ASK reply (5–10× more at the PASS tag's shallow
    modulation) and the band-pass (high-pass pole at BLF/8, τ = 8/(2π·BLF)) carries that
    swing's offset into the reply for a few τ. Without a guard the first pilot cycles are
    lost at the comparator, the preamble correlation of a reply barely above the threshold
    drops below ``min_corr`` and the stamp technique fails where path selection, decoding
    an undisturbed reply, succeeds (phase-cancellation scenario, module docstring). Eight
    cycles are 8/BLF = 6.3 τ (offset × 0.002).
    """
    if n_stamp_cycles < 1:
        raise ConfigError("n_stamp_cycles", n_stamp_cycles, ">= 1")
    if n_settle_cycles < 0:
        raise ConfigError("n_settle_cycles", n_settle_cycles, ">= 0")
    el_s = 1.0 / (2.0 * blf_hz)
    start = int(math.ceil(t0_s * fs_hz))
    seg = int(round(2 * n_stamp_cycles * el_s * fs_hz))
    ask_stop, psk_stop = start + seg, start + 2 * seg
    settle = int(round(2 * n_settle_cycles * el_s * fs_hz))
    reply_start = psk_stop + settle
    n_el = halfsymbols(bits, m=m, trext=trext).size
    n = int(math.ceil(reply_start + n_el * el_s * fs_hz + tail_s * fs_hz)) + 1
    states = np.full(n, STAMP_S1, dtype=np.int8)

    def alternate(n_samples):
        k = np.arange(n_samples)
        return (np.floor(k / (el_s * fs_hz) + 1e-9).astype(np.int64) % 2) == 1

    odd = alternate(seg)
    states[start:ask_stop] = np.where(odd, STAMP_S2, STAMP_S1)
    states[ask_stop:psk_stop] = np.where(odd, STAMP_S3, STAMP_S1)
    states[psk_stop:reply_start] = np.where(alternate(settle), STAMP_S2, STAMP_S1)
    levels = reply_waveform(bits, m=m, trext=trext, blf_hz=blf_hz, fs_hz=fs_hz, t0_s=reply_start / fs_hz,
                            n_samples=n)
    states[levels < 0] = STAMP_S2
    return StampFrame(states, levels, start, ask_stop, psk_stop, reply_start)


@dataclass(frozen=True)
class StampReception:
    """ASK-PSK stamp result.

    Attributes
    ----------
    ask_symbol, psk_symbol : {'1', '-'}
        Stamp symbols decoded on P2.
    use_p1 : bool
        Whether the ST switched to P1.
    selected : Reception
        Reception of the one path that decoded the data.
    """

    ask_symbol: str
    psk_symbol: str
    use_p1: bool
    selected: Reception

    @property
    def detected(self) -> bool:
        return self.selected.detected

    @property
    def cancellation_flagged(self) -> bool:
        """ASK stamp cancelled while the PSK stamp is present (the phase-cancellation signature)."""
        return self.ask_symbol == "-" and self.psk_symbol == "1"


def receive_stamp(rx: STReceiver, x_sa1, x_sa2, frame: StampFrame, *, rx_p1: STReceiver | None = None,
                  **kwargs) -> StampReception:
    """ASK-PSK stamp path switching (§5, seed L5984-5990, L6019-6023).

    The default path P2 (SA2) runs its analog chain; a stamp segment decodes as '1' when
    the comparator toggles at least once per subcarrier cycle of the segment (half the
    transitions of an undisturbed segment), else '-'. An ASK '-' switches the digital
    decoding to P1 (SA1); only the chosen path decodes the data (from ``frame.reply_start``,
    with ``frame.levels`` as the true states unless given).

    Parameters
    ----------
    rx : STReceiver
        Receive chain of P2 (and of P1 unless ``rx_p1`` is given).
    x_sa1, x_sa2 : array_like of complex, shape (n_samples,)
        Baseband signals at the ports of SA1 and SA2 [√W].
    frame : StampFrame
        The stamped frame sent (segment boundaries).
    rx_p1 : STReceiver, optional
        Receive chain of P1 (default ``rx``).
    **kwargs
        Passed to :meth:`STReceiver.receive` / :meth:`STReceiver.decode_chain`
        (``n_bits``, ``crc``, ...).

    Returns
    -------
    StampReception
        Stamp symbols, path switch and the reception of the chosen path.
    """
    ch2 = rx.chain(x_sa2)
    n_cycles = (frame.ask_stop - frame.start) * rx.blf_hz / rx.fs_hz
    need = max(1, int(round(n_cycles)))
    sym = ["1" if np.count_nonzero(np.diff(ch2.comparator[a:b])) >= need else "-"
           for a, b in ((frame.start, frame.ask_stop), (frame.ask_stop, frame.psk_stop))]
    use_p1 = sym[0] == "-"
    kwargs.setdefault("start_sample", frame.reply_start)
    kwargs.setdefault("states", frame.levels)
    if use_p1:
        sel = (rx_p1 or rx).receive(x_sa1, **kwargs)
    else:
        sel = rx.decode_chain(ch2, **kwargs)
    return StampReception(sym[0], sym[1], use_p1, sel)


__all__ = [
    "REFERENCE_IMPEDANCE_OHM", "SOURCE_IMPEDANCE_OHM", "to_source_volts", "DETECTOR_LAWS", "K_OVER_Q_V_PER_K",
    "DEFAULT_MATCHING_GAIN", "DEFAULT_IDEALITY", "DEFAULT_TEMPERATURE_K", "rc_lowpass", "i0e", "comparator",
    "passband_envelope_v", "settled_mask", "state_levels",
    "state_envelope_difference", "EnvelopeDetector", "ChainOutput", "Reception", "STReceiver",
    "receive_combined", "SelectionReception", "receive_selection", "STAMP_S1", "STAMP_S2", "STAMP_S3",
    "StampFrame", "stamp_frame", "StampReception", "receive_stamp",
]

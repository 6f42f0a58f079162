"""Binary-offset-carrier (BOC) line code of the HIMR inertial tag: chips, sampled packet
trains, per-bit matched filter, coherent decoder and preamble search.

Not EPC Gen2 (the HIMR tag runs a custom, free-running protocol: himr-tag.md §0.1, seed
000 L411, L713), hence outside :mod:`rfsim.gen2`.

Waveform (himr-tag.md §2.2 "[not in source] a BOC definition that fits the numbers";
wave2-specs.md §H "BOC waveform"): each data bit is N chips of a ±1 square subcarrier of
frequency f_sc, the bit setting the polarity (BPSK on a square subcarrier,
BOC(f_sc, R_b)):

    s(t) = p_i · q(t),   p_i = +1 (bit 1) / −1 (bit 0),   i = floor(t·R_c / N)
    q(t) = +1 on the first half of every subcarrier cycle, −1 on the second half

with chip rate R_c [chip/s], bit rate R_b = R_c / N [bit/s] and f_sc = R_c/2 by default
(one chip per subcarrier half-cycle, i.e. the "transitions" of seed L411/L715). The two
HIMR formats: 64 chips/bit at 5 Mcps → 78,125 b/s (L411), 8 chips/bit at 4 Mcps →
500,000 b/s (L715). Rules checked on construction of :class:`BocCode`: R_c must be an
even integer multiple of f_sc (a subcarrier half-cycle is a whole number of chips) and N
a multiple of the chips per subcarrier cycle (every bit holds whole cycles, so s(t) has
no DC within a bit).

Bandwidth: the spectrum of s(t) has its two main lobes at ±f_sc, each R_b wide on either
side, so the complex baseband needs ``fs ≥ B = 2·(f_sc + R_b)`` (5 MHz for the 9-axis
format, 5.156 MHz for the 6-axis one); :meth:`BocCode.check_fs` rejects lower rates.

Sampling: sample n of a waveform whose packet starts at the fractional sample s0 takes
the chip floor((n − s0)·R_c/fs + 1e−9) (:mod:`rfsim.himr._boc_kernels`), so any fs works
without drift.

Decoding of ``r = h·s(t) + c + noise`` (unknown complex gain h and offset c, e.g. the
carrier leakage and the structural-mode echo) at a known start: the per-bit sums
y_i = Σ r·q are corrected for the offset (c₀ = mean of r over the packet), the preamble
gives a phase reference h₀ = Σ p_i y_i / Σ n_i, each bit is decided by the sign of
Re(y_i·conj(h₀)), and h, c are then re-estimated jointly by least squares against the
decided chips (normal equations of r ≈ h·s + c over every sample of the packet). The
residual gives the noise variance per complex sample σ² and SNR = |h|²/σ².
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.memo import PureCache
from rfsim.gen2.bits import as_bits
from rfsim.core.lazy import lazy_import

_signal = lazy_import("scipy.signal")
_k = lazy_import("rfsim.himr._boc_kernels")


@dataclass(frozen=True)
class BocCode:
    """A BOC line code: N chips per bit at R_c chips/s on a square subcarrier f_sc.

    Parameters
    ----------
    chips_per_bit : N (int ≥ 2)
    chip_rate_hz : R_c [chip/s]
    subcarrier_hz : f_sc [Hz]; None → R_c/2
    key : config key prefix used in error messages (e.g. ``"tag"``)
    """

    chips_per_bit: int
    chip_rate_hz: float
    subcarrier_hz: float | None = None
    key: str = "boc"

    def __post_init__(self):
        k = self.key
        if isinstance(self.chips_per_bit, bool) or not isinstance(self.chips_per_bit, (int, np.integer)) \
                or self.chips_per_bit < 2:
            raise ConfigError(f"{k}.chips_per_bit", self.chips_per_bit, "an integer ≥ 2")
        if not (isinstance(self.chip_rate_hz, (int, float)) and math.isfinite(self.chip_rate_hz)
                and self.chip_rate_hz > 0):
            raise ConfigError(f"{k}.chip_rate_hz", self.chip_rate_hz, "a finite number > 0 chip/s")
        fsc = self.subcarrier_hz_value
        if not (math.isfinite(fsc) and fsc > 0):
            raise ConfigError(f"{k}.subcarrier_hz", self.subcarrier_hz, "a finite number > 0 Hz")
        ratio = self.chip_rate_hz / fsc
        m = round(ratio)
        if m < 2 or m % 2 or abs(ratio - m) > 1e-9 * m:
            raise ConfigError(f"{k}.chip_rate_hz", self.chip_rate_hz,
                              f"an even integer multiple of the subcarrier {fsc:g} Hz "
                              f"(R_c/f_sc = {ratio:g})")
        if self.chips_per_bit % m:
            raise ConfigError(f"{k}.chips_per_bit", self.chips_per_bit,
                              f"a multiple of the {m} chips per subcarrier cycle")

    @property
    def subcarrier_hz_value(self) -> float:
        """f_sc [Hz] (R_c/2 when not given)."""
        return self.chip_rate_hz / 2.0 if self.subcarrier_hz is None else float(self.subcarrier_hz)

    @property
    def chips_per_cycle(self) -> int:
        """Chips per subcarrier cycle, R_c / f_sc (even)."""
        return int(round(self.chip_rate_hz / self.subcarrier_hz_value))

    @property
    def half_cycle_chips(self) -> int:
        """Chips per subcarrier half-cycle."""
        return self.chips_per_cycle // 2

    @property
    def bit_rate_bps(self) -> float:
        """R_b = R_c / N [bit/s]."""
        return self.chip_rate_hz / self.chips_per_bit

    @property
    def bandwidth_hz(self) -> float:
        """Two-sided main-lobe bandwidth B = 2·(f_sc + R_b) [Hz] (module docstring)."""
        return 2.0 * (self.subcarrier_hz_value + self.bit_rate_bps)

    def duration_s(self, n_bits: int) -> float:
        """Air time of ``n_bits`` bits: n_bits·N / R_c.

        Parameters
        ----------
        n_bits : int
            Number of bits.

        Returns
        -------
        float
            Air time [s].
        """
        return int(n_bits) * self.chips_per_bit / self.chip_rate_hz

    def check_fs(self, fs_hz: float, key: str = "fs_hz") -> float:
        """``fs_hz`` as float, checked against :attr:`bandwidth_hz` = 2·(f_sc + R_b).

        Parameters
        ----------
        fs_hz : float
            Sample rate [Hz].
        key : str
            Configuration key named in the error.

        Returns
        -------
        float
            The sample rate [Hz].

        Raises
        ------
        ConfigError
            When the rate is not finite or below the BOC bandwidth.
        """
        fs = float(fs_hz)
        if not (math.isfinite(fs) and fs >= self.bandwidth_hz * (1.0 - 1e-12)):
            raise ConfigError(key, fs_hz, f"a sample rate ≥ the BOC bandwidth 2·(f_sc + R_b) = "
                                          f"{self.bandwidth_hz:g} Hz")
        return fs


# ----------------------------------------------------------------------------- encoder


def boc_chips(bits, code: BocCode) -> np.ndarray:
    """Chip levels of ``bits`` (numba kernel).

    Parameters
    ----------
    bits : array_like or str
        ``(n_bits,)`` 0/1.
    code : BocCode
        The line code.

    Returns
    -------
    numpy.ndarray
        ``(n_bits·N,) int8`` of ±1.
    """
    arr = as_bits(bits)
    out = np.empty(arr.size * code.chips_per_bit, dtype=np.int8)
    _k.chips_kernel(arr, code.chips_per_bit, code.half_cycle_chips, out)
    return out


def _train_args(starts_s, bits, t0_s, fs_hz):
    bits = np.asarray(bits)
    if bits.ndim == 1:
        bits = bits[None, :]
    if bits.ndim != 2:
        raise ValueError(f"bits must be (n_packets, n_bits), got shape {bits.shape}")
    bits = np.ascontiguousarray(bits, dtype=np.uint8)
    if bits.size and bits.max() > 1:
        raise ValueError("bits must contain only 0 and 1")
    starts = np.atleast_1d(np.asarray(starts_s, dtype=np.float64))
    if starts.shape != (bits.shape[0],):
        raise ValueError(f"{starts.size} start times for {bits.shape[0]} packets")
    return np.ascontiguousarray((starts - float(t0_s)) * float(fs_hz)), bits


def boc_train(starts_s, bits, code: BocCode, *, t0_s: float, fs_hz: float, n_samples: int,
              level_plus: complex = 1.0, level_minus: complex = -1.0, rest: complex = 1.0) -> np.ndarray:
    """A train of BOC packets sampled on the time base ``t = t0_s + n/fs_hz`` (numba kernel).

    Parameters
    ----------
    starts_s : array_like
        ``(P,)`` start time of each packet [s].
    bits : array_like
        ``(P, n_bits)`` uint8 0/1 (or ``(n_bits,)`` for one packet).
    code : BocCode
        The line code.
    t0_s : float
        Time of sample 0 [s].
    fs_hz : float
        Sample rate [Hz]; must reach :attr:`BocCode.bandwidth_hz`.
    n_samples : int
        Length of the time base.
    level_plus, level_minus : complex
        Value on a +1 / −1 chip (e.g. Γ_open, Γ_short).
    rest : complex
        Value outside every packet.

    Returns
    -------
    numpy.ndarray
        ``(n_samples,) complex128``, in the unit of the levels.

    Raises
    ------
    ConfigError
        If ``fs_hz`` is below the BOC bandwidth.
    ValueError
        For malformed bits or a start count that differs from the packet count.
    """
    fs = code.check_fs(fs_hz)
    s0, bits = _train_args(starts_s, bits, t0_s, fs)
    out = np.full(int(n_samples), complex(rest), dtype=np.complex128)
    _k.train_kernel(s0, bits, code.chip_rate_hz / fs, code.chips_per_bit, code.half_cycle_chips,
                    complex(level_plus), complex(level_minus), out)
    return out


# ----------------------------------------------------------------------------- decoder


@dataclass(frozen=True)
class BocDetection:
    """Result of :func:`boc_decode`.

    Attributes
    ----------
    bits : (n_bits,) uint8, decided bits (preamble included)
    gain : complex h, least squares against the decided chips (input units)
    offset : complex c, the constant part of the input
    noise_var : σ², residual power per complex sample (input units squared)
    snr_db : 10·log10(|h|²/σ²) per sample (inf without noise)
    preamble_ok : the decided preamble bits equal the expected ones
    """

    bits: np.ndarray
    gain: complex
    offset: complex
    noise_var: float
    snr_db: float
    preamble_ok: bool


def boc_bit_sums(r, start_sample: float, code: BocCode, *, fs_hz: float, n_bits: int):
    """Per-bit sums of a packet (numba kernel).

    Over the samples of bit i (q = subcarrier sign): ``ysum[i] = Σ r·q``, ``qsum[i] = Σ q``,
    ``count[i]`` samples, ``rsum[i] = Σ r``, ``r2sum[i] = Σ |r|²``.

    Parameters
    ----------
    r : array_like
        ``(n,)`` complex baseband, any unit.
    start_sample : float
        Fractional sample index of the packet's first chip.
    code : BocCode
        The line code.
    fs_hz : float
        Sample rate [Hz].
    n_bits : int
        Bits of the packet.

    Returns
    -------
    ysum, qsum, count, rsum, r2sum : numpy.ndarray
        ``(n_bits,)`` each; unit of r (r2sum: its square).
    """
    fs = code.check_fs(fs_hz)
    r = np.ascontiguousarray(r, dtype=np.complex128)
    out = (np.zeros(n_bits, np.complex128), np.zeros(n_bits), np.zeros(n_bits, np.int64),
           np.zeros(n_bits, np.complex128), np.zeros(n_bits))
    _k.bit_sums_kernel(r, float(start_sample), code.chip_rate_hz / fs, code.chips_per_bit,
                       code.half_cycle_chips, *out)
    return out


def _decide(sums, preamble: np.ndarray) -> BocDetection:
    ysum, qsum, count, rsum, r2sum = sums
    n_total = count.sum()
    if n_total == 0 or count.min() == 0:
        raise ValueError("the packet is not fully inside the input (a bit has no samples)")
    c0 = rsum.sum() / n_total
    y = ysum - c0 * qsum
    npre = preamble.size
    p_pre = 2.0 * preamble - 1.0
    h0 = (p_pre * y[:npre]).sum() / count[:npre].sum() if npre else y.sum()
    bits = ((y * np.conj(h0)).real >= 0).astype(np.uint8)
    p = 2.0 * bits - 1.0
    # least squares r ≈ h·s + c: normal equations from the per-bit sums
    s2, s1, n1 = float(count.sum()), float((p * qsum).sum()), float(n_total)
    b_s, b_1 = (p * ysum).sum(), rsum.sum()
    det = s2 * n1 - s1 * s1
    h = (n1 * b_s - s1 * b_1) / det
    c = (s2 * b_1 - s1 * b_s) / det
    ss = float(r2sum.sum() - (np.conj(h) * b_s + np.conj(c) * b_1).real)
    noise = max(ss, 0.0) / max(n_total - 2, 1)
    snr = math.inf if noise <= 1e-300 * max(abs(h) ** 2, 1e-300) else 10 * math.log10(abs(h) ** 2 / noise)
    return BocDetection(bits=bits, gain=complex(h), offset=complex(c), noise_var=noise, snr_db=snr,
                        preamble_ok=bool(np.array_equal(bits[:npre], preamble)))


def boc_decode(r, *, code: BocCode, fs_hz: float, n_bits: int, start_sample: float,
               preamble_bits=()) -> BocDetection:
    """Decode one BOC packet of ``n_bits`` bits starting at ``start_sample`` of ``r``.

    Offset-corrected per-bit sums, preamble phase reference, sign decisions, then least-squares
    h, c and σ² (module docstring).

    Parameters
    ----------
    r : array_like
        ``(n,)`` complex baseband (any unit; h, c and σ² come out in it).
    code : BocCode
        The line code.
    fs_hz : float
        Sample rate [Hz].
    n_bits : int
        Bits of the packet.
    start_sample : float
        Fractional sample index of the packet's first chip.
    preamble_bits : array_like
        The known first bits, used as phase reference (empty: all bits, which leaves the sign
        of h ambiguous).

    Returns
    -------
    BocDetection
        Bits, gain, offset, noise variance, SNR [dB] and the preamble check.

    Raises
    ------
    ValueError
        If the packet is not fully inside ``r``.
    """
    pre = as_bits(preamble_bits) if len(preamble_bits) else np.zeros(0, np.uint8)
    return _decide(boc_bit_sums(r, start_sample, code, fs_hz=fs_hz, n_bits=n_bits), pre)


def _preamble_template(code: BocCode, preamble: bytes, fs_hz: float) -> np.ndarray:
    """The sampled preamble (start at sample 0), real ±1, read-only (remembered per code,
    preamble and rate in :data:`PREAMBLE_TEMPLATE_CACHE`)."""
    pre = np.frombuffer(preamble, dtype=np.uint8)
    n_pre = int(math.ceil(code.duration_s(pre.size) * fs_hz))
    tmpl = boc_train([0.0], pre, code, t0_s=0.0, fs_hz=fs_hz, n_samples=n_pre).real
    tmpl.setflags(write=False)
    return tmpl


#: :func:`_preamble_template` by (code, preamble, rate): a pure function of its arguments, not run
#: state (:class:`rfsim.core.memo.PureCache`).
PREAMBLE_TEMPLATE_CACHE = PureCache(_preamble_template, 32)


def boc_find(r, *, code: BocCode, fs_hz: float, preamble_bits, search: tuple[int, int]) -> tuple[int, float]:
    """Integer start sample of a packet in ``r`` by preamble correlation.

    Correlates ``r − mean(r)`` with the sampled preamble (start at sample 0) for every start
    in ``range(search[0], search[1])``; ρ is the normalised correlation (1 for a noise-free,
    sample-aligned packet).

    Parameters
    ----------
    r : array_like
        ``(n,)`` complex baseband, any unit.
    code : BocCode
        The line code.
    fs_hz : float
        Sample rate [Hz].
    preamble_bits : array_like
        The known preamble bits.
    search : tuple of int
        ``(first, end)`` start samples searched.

    Returns
    -------
    start : int
        Start sample.
    rho : float
        |ρ| at that start [1].

    Raises
    ------
    ValueError
        If the search window does not hold a whole preamble.
    """
    fs = code.check_fs(fs_hz)
    pre = as_bits(preamble_bits)
    tmpl = PREAMBLE_TEMPLATE_CACHE(code, pre.tobytes(), fs)
    n_pre = tmpl.size
    lo, hi = max(0, int(search[0])), min(int(search[1]), np.size(r) - n_pre + 1)
    if hi <= lo:
        raise ValueError("search window does not hold a whole preamble")
    x = np.asarray(r, dtype=np.complex128)[lo:hi + n_pre - 1]
    x = x - x.mean()
    corr = np.abs(_signal.correlate(x, tmpl, mode="valid"))
    energy = np.sqrt(np.convolve(np.abs(x) ** 2, np.ones(n_pre), mode="valid") * (tmpl @ tmpl))
    rho = corr / np.maximum(energy, 1e-300)
    j = int(np.argmax(rho))
    return lo + j, float(rho[j])


__all__ = ["BocCode", "BocDetection", "boc_chips", "boc_train", "boc_bit_sums", "boc_decode", "boc_find"]

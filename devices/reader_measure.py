"""Per-read measurements of the Gen2 reader (:meth:`rfsim.devices.reader.Reader.receive` steps 3
and 5): the outcome record (:class:`ReadResult`), the samples whose level is known without
decisions (:func:`known_levels`) and RSSI, phase, Doppler and residual from the decoded reply
(:func:`measure`, numba kernels).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import repeat

import numpy as np

from rfsim.core.lazy import lazy_import
from rfsim.core.units import w_to_dbm, wrap_phase_rad
from rfsim.gen2.reply_decoder import DOPPLER_BLOCKS  # the blocks of the Doppler fit

_rk = lazy_import("rfsim.gen2._measure_kernels")

__all__ = ["ReadResult", "FAILURES", "DOPPLER_BLOCKS", "measure", "measurements", "known_levels", "steady",
           "refer_phase"]


FAILURES = ("", "preamble not found", "crc error", "rn16 rejected")


@dataclass
class ReadResult:
    """Outcome and measurements of one reply window (treat as read-only; not a frozen dataclass:
    one is made for every reply window, and a frozen one sets each field through a call).

    Attributes
    ----------
    success : bool
        Reply detected, decoded and (if expected) CRC-16 correct.
    bits : ndarray of uint8, shape (n_bits,), or None
        Decoded bits (also on a CRC error), None if no reply was found.
    failure_reason : str
        One of :data:`FAILURES`: "" on success, "preamble not found", "crc error" or
        "rn16 rejected".
    rssi_dbm : float
        Power of the modulated component at the antenna port, 10·log10(|h|²)+30 [dBm], with
        h the complex amplitude of the ±1 reply waveform (NaN without a reply).
    phase_rad : float
        (−arg h) mod 2π [rad], h at the centre of the reply; for a tag re-radiating
        r = A_s − Γ (rfsim.devices.tag) h ∝ (r_B − r_A)/2 = (Γ_A − Γ_B)/2, A_s cancels.
    doppler_hz : float
        (1/2π)·d(arg h)/dt across the reply [Hz] (positive for an approaching tag).
    snr_db : float
        |h|²/σ² [dB], σ² the residual power per sample at ``fs_hz`` (noise bandwidth fs).
    ebn0_db : float
        snr_db + 10·log10(fs/bit rate) [dB], independent of fs.
    start_s : float
        Absolute time of the detected reply start [s].
    corr : float
        Normalised preamble correlation (0…1) at the detected start.
    blf_hz : float
        The BLF the reply was decoded at [Hz] (NaN: the nominal BLF, ``blf_search`` off).
    decision_ebn0_db : float
        The acceptance statistic, Eb/(N0 + I) of the decoded reply against its residual [dB]
        (:func:`rfsim.gen2.blf_search.search_decode`; NaN with ``blf_search`` off).
    """

    success: bool
    bits: np.ndarray | None
    failure_reason: str
    rssi_dbm: float = math.nan
    phase_rad: float = math.nan
    doppler_hz: float = math.nan
    snr_db: float = math.nan
    ebn0_db: float = math.nan
    start_s: float = math.nan
    corr: float = math.nan
    blf_hz: float = math.nan
    decision_ebn0_db: float = math.nan


def measure(z: np.ndarray, s: np.ndarray, fs_hz: float) -> tuple[complex, float, float]:
    """Measure gain, phase slope and residual power of a reply against its reference.

    Fits :math:`z = h\\, e^{j \\cdot \\mathrm{slope} \\cdot t} s(t) + \\mathrm{noise}` (numba
    kernel; the procedure is :meth:`rfsim.devices.reader.Reader.receive` step 5, over
    :data:`DOPPLER_BLOCKS` blocks; ``reference.devices_reader.measure_reference`` in the tests
    is its NumPy twin).

    Parameters
    ----------
    z : ndarray of complex, shape (n,)
        Received reply, offset removed [√W].
    s : ndarray of float, shape (n,)
        The ±1 reference waveform of the decoded reply (0 outside it).
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    h : complex
        Complex amplitude at the centre of the reply [√W].
    slope : float
        Phase slope d(arg h)/dt [rad/s].
    sigma2 : float
        Mean residual power per sample over the reply [W].
    """
    z = np.ascontiguousarray(z, dtype=np.complex128)
    s = np.ascontiguousarray(s, dtype=np.float64)
    h, slope, sigma2 = _rk.measure_kernel(z, s, float(fs_hz), DOPPLER_BLOCKS)
    return complex(h), float(slope), float(sigma2)


def known_levels(r: np.ndarray, full: np.ndarray, t0_samples: float, elements_per_sample: float,
                  n_pre_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """Select the samples whose level is known without decisions.

    Those on the preamble (pilot included) or outside the reply (the rest state, level −1),
    whose two neighbours carry the same level (numba kernel;
    ``reference.devices_reader.known_levels_reference`` in the tests is its NumPy twin).

    Parameters
    ----------
    r : ndarray of complex, shape (n,)
        Received samples [√W].
    full : ndarray of float, shape (n,)
        The sampled ±1 reply (0 outside it) starting at ``t0_samples``.
    t0_samples : float
        Start of the reply in samples (``reply_waveform``'s t0_s·fs).
    elements_per_sample : float
        Line-code elements per sample, 2·BLF/fs.
    n_pre_elements : int
        Elements of the preamble (the first of the reply).

    Returns
    -------
    r : ndarray of complex, shape (m,)
        The selected samples, in order.
    level : ndarray of float, shape (m,)
        Their known levels (±1).
    """
    r_out = np.empty(r.size, dtype=np.complex128)
    level_out = np.empty(r.size)
    m = _rk.known_levels_kernel(np.ascontiguousarray(r, dtype=np.complex128),
                                np.ascontiguousarray(full, dtype=np.float64), float(t0_samples),
                                float(elements_per_sample), int(n_pre_elements), r_out, level_out)
    return r_out[:m], level_out[:m]


def steady(level: np.ndarray) -> np.ndarray:
    """Mark the samples whose two neighbours have the same level.

    Parameters
    ----------
    level : ndarray, shape (n,)
        Levels per sample.

    Returns
    -------
    ndarray of bool, shape (n,)
        True where ``level[i - 1] == level[i] == level[i + 1]`` (the ends are False).
    """

    out = np.zeros(level.size, dtype=bool)
    out[1:-1] = (level[1:-1] == level[:-2]) & (level[1:-1] == level[2:])
    return out


def refer_phase(phase_rad, carrier):
    """A measured phase referred to the reader's transmitted carrier: the one rule of both
    receiver models (:meth:`rfsim.devices.reader.Reader.receive` step 5 and
    :mod:`rfsim.devices.reader_statistic`), for one read or B reads at once.

    φ_ref = wrap(φ + arg c) with φ = −arg h the phase of the measured gain and c the reader's
    transmitted baseband during the reply; arg c is NumPy's ``np.angle`` (the same arithmetic
    as the measurement's −arg h).

    Parameters
    ----------
    phase_rad : float or ndarray of float, shape (B,)
        Phase of the measured gain, −arg h [rad].
    carrier : complex or ndarray of complex, shape (B,)
        The reader's transmitted baseband during the reply (non-zero) [√W].

    Returns
    -------
    float or ndarray of float, shape (B,)
        ``phase_rad + arg(carrier)`` wrapped to [0, 2π) [rad] (a float for scalar arguments).
    """
    if isinstance(phase_rad, np.ndarray) and phase_rad.ndim:
        return wrap_phase_rad(np.add(phase_rad, np.angle(carrier)))
    c = complex(carrier)  # np.angle's own arithmetic, arctan2(Im, Re), on the one value (no 0-d array made)
    return float(wrap_phase_rad(phase_rad + float(np.arctan2(c.imag, c.real))))


def measurements(gain, slope, sigma2, *, blf_hz: float, fs_hz: float, m: int) -> dict:
    """RSSI, phase, Doppler and SNR of B reads from their measured gain, slope and residual.

    The reader's measurement rule (:meth:`rfsim.devices.reader.Reader.receive` step 5), for one
    read (B = 1) and for a batch alike: with p = |h|²,

    - RSSI = 10·log10(p) + 30 [dBm] (−∞ for p = 0),
    - phase = (−arg h) mod 2π [rad] (the reader refers it to its carrier, :func:`refer_phase`),
    - Doppler = slope/(2π) [Hz],
    - SNR = 10·log10(p/σ²) [dB] (+∞ unless σ² > 0 and p > 0),
    - Eb/N0 = SNR + 10·log10(fs·M/BLF) [dB].

    |h| is Python's ``abs`` of a complex and p = |h|**2 and log10(p/σ²) are taken with Python's
    float arithmetic and ``math.log10`` (NumPy's vectorised ``abs``, ``**2`` and ``log10``
    differ from them in the last bit for some values); RSSI and phase
    are NumPy's ufuncs, element for element the same on B = 1 and on a batch.

    Parameters
    ----------
    gain : sequence of complex, shape (B,)
        Measured gain h at the reply centre [√W] (a list or an array).
    slope : sequence of float, shape (B,)
        Phase slope d(arg h)/dt [rad/s].
    sigma2 : sequence of float, shape (B,)
        Residual power per sample σ² [W].
    blf_hz : float
        Keyword-only (like the others): the BLF decoded at [Hz].
    fs_hz : float
        Sample rate [Hz].
    m : int
        Subcarrier cycles per symbol M (1 for FM0).

    Returns
    -------
    dict
        ``rssi_dbm``, ``phase_rad``, ``doppler_hz``, ``snr_db``, ``ebn0_db``: lists of B floats.
    """
    gain = gain.tolist() if isinstance(gain, np.ndarray) else gain
    slope = slope.tolist() if isinstance(slope, np.ndarray) else slope
    sigma2 = sigma2.tolist() if isinstance(sigma2, np.ndarray) else sigma2
    p = list(map(pow, map(abs, map(complex, gain)), repeat(2)))
    inf = math.inf
    snr = [10.0 * math.log10(x / s) if s > 0 and x > 0 else inf for x, s in zip(p, sigma2)]
    ebn0 = 10.0 * math.log10(fs_hz * m / blf_hz)
    if len(p) == 1:  # the same ufuncs on the one value (NumPy's scalar call: no arrays to make)
        h = complex(gain[0])
        rssi = [float(w_to_dbm(p[0])) if p[0] > 0 else -inf]
        phase = [float(wrap_phase_rad(-np.arctan2(h.imag, h.real)))]  # -arg h, as np.angle
    else:
        pos = [x > 0 for x in p]
        rssi = w_to_dbm([x if ok else 1.0 for x, ok in zip(p, pos)]).tolist()
        if not all(pos):  # |h| = 0 (or NaN): −∞
            rssi = [v if ok else -inf for v, ok in zip(rssi, pos)]
        g = np.array(gain, dtype=np.complex128)
        phase = wrap_phase_rad(-np.arctan2(g.imag, g.real)).tolist()
    # slope/(2π) and SNR + 10·log10(fs·M/BLF), element by element
    return dict(rssi_dbm=rssi, phase_rad=phase, doppler_hz=list(map((2.0 * math.pi).__rtruediv__, slope)),
                snr_db=snr, ebn0_db=list(map(ebn0.__radd__, snr)))

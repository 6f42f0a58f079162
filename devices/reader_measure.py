"""Per-read measurements of the Gen2 reader (:meth:`rfsim.devices.reader.Reader.receive` steps 3
and 5): the outcome record (:class:`ReadResult`), the samples whose level is known without
decisions (:func:`known_levels`) and RSSI, phase, Doppler and residual from the decoded reply
(:func:`measure`, numba kernels).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.lazy import lazy_import

_rk = lazy_import("rfsim.devices._reader_kernels")

__all__ = ["ReadResult", "FAILURES", "DOPPLER_BLOCKS", "measure", "known_levels", "steady"]

#: Number of blocks of the reply used for the Doppler fit.
DOPPLER_BLOCKS = 8

FAILURES = ("", "preamble not found", "crc error", "rn16 rejected")


@dataclass(frozen=True)
class ReadResult:
    """Outcome and measurements of one reply window.

    Attributes
    ----------
    success : reply detected, decoded and (if expected) CRC-16 correct
    bits : (n_bits,) uint8 decoded bits (also on a CRC error), None if no reply was found
    failure_reason : "", "preamble not found" or "crc error"
    rssi_dbm : power of the modulated component at the antenna port, 10·log10(|h|²)+30, with
        h the complex amplitude of the ±1 reply waveform (NaN without a reply)
    phase_rad : (−arg h) mod 2π, h at the centre of the reply; for a tag re-radiating
        r = A_s − Γ (rfsim.devices.tag) h ∝ (r_B − r_A)/2 = (Γ_A − Γ_B)/2, A_s cancels
    doppler_hz : (1/2π)·d(arg h)/dt across the reply (positive for an approaching tag)
    snr_db : |h|²/σ², σ² the residual power per sample at ``fs_hz`` (noise bandwidth fs)
    ebn0_db : snr_db + 10·log10(fs/bit rate), independent of fs
    start_s : absolute time of the detected reply start [s]
    corr : normalised preamble correlation (0…1) at the detected start
    blf_hz : the BLF the reply was decoded at [Hz] (NaN: the nominal BLF, ``blf_search`` off)
    decision_ebn0_db : the acceptance statistic, Eb/(N0 + I) of the decoded reply against its
        residual (:func:`rfsim.devices.reader_search.search_decode`; NaN with ``blf_search`` off)
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
    """``(h, slope [rad/s], σ²)`` of ``z = h·e^{j·slope·t}·s(t) + noise`` (numba kernel; the
    procedure is :meth:`rfsim.devices.reader.Reader.receive` step 5,
    :func:`reference.devices_reader.measure_reference` in the tests its NumPy twin)."""
    z = np.ascontiguousarray(z, dtype=np.complex128)
    s = np.ascontiguousarray(s, dtype=np.float64)
    h, slope, sigma2 = _rk.measure_kernel(z, s, float(fs_hz), DOPPLER_BLOCKS)
    return complex(h), float(slope), float(sigma2)


def known_levels(r: np.ndarray, full: np.ndarray, t0_samples: float, elements_per_sample: float,
                  n_pre_elements: int) -> tuple[np.ndarray, np.ndarray]:
    """``(r, level)`` at the samples whose level is known without decisions (numba kernel;
    :func:`reference.devices_reader.known_levels_reference` in the tests is its NumPy twin). ``full`` is the sampled reply starting
    at ``t0_samples`` (``reply_waveform``'s t0_s·fs), its first ``n_pre_elements`` elements
    the preamble."""
    r_out = np.empty(r.size, dtype=np.complex128)
    level_out = np.empty(r.size)
    m = _rk.known_levels_kernel(np.ascontiguousarray(r, dtype=np.complex128),
                                np.ascontiguousarray(full, dtype=np.float64), float(t0_samples),
                                float(elements_per_sample), int(n_pre_elements), r_out, level_out)
    return r_out[:m], level_out[:m]


def steady(level: np.ndarray) -> np.ndarray:
    """(n,) bool: samples whose two neighbours have the same level (the ends are False)."""
    out = np.zeros(level.size, dtype=bool)
    out[1:-1] = (level[1:-1] == level[:-2]) & (level[1:-1] == level[2:])
    return out

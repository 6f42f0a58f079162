"""Field definitions and the report stage of the per-read records every reader-side dataset shares.

What a reader reports for one decoded reply (gen2-and-validation-anchors.md §4.9, LLRP
TagReportData + Impinj low-level data): antenna port, hop-table channel, carrier, RSSI,
phase, Doppler and SNR, under the names the protocol layer's read logs use (name → (units,
description)). In a dataset's ``reads`` table they appear under the per-read schema's names
(:mod:`rfsim.core.reads`: ``antenna_port``, ``peak_rssi_dbm``, ``phase_angle_rad``,
``doppler_frequency_hz``, ``first_seen_timestamp_us``, …), so a column means the same thing in
every dataset.

The *report stage* (:class:`ReportConfig`, :func:`report_columns`) turns the receiver's
measurements into what a commercial reader hands over (wave2-specs.md "What a per-read dataset
should look like"; LLRP PeakRSSI in whole dBm, Impinj RSSI in dBm×100, Impinj RF phase angle
as a 12-bit code, first-seen time stamps in µs):

* per-port phase offset: ``φ_rep = (φ + φ_port[a]) mod 2π`` — the cable and front-end phase
  of antenna port ``a`` (a constant per port, not a multiple of π; phase-tracking.md §1.2
  [not in source]);
* phase code: ``c = round(φ_rep·2^b/2π) mod 2^b`` with ``b = phase_bits`` (12 for Impinj:
  0.0879° = 1.534 mrad steps); the code's phase is ``c·2π/2^b``;
* RSSI: ``RSSI_rep = s·round(P/s)`` with ``s = rssi_step_db`` (1 dB LLRP PeakRSSI, 0.01 dB
  Impinj; 0 = not quantized), the same rule as ``rfsim.devices.rss_reader.RssReport``;
* sensitivity floor: a decoded reply with ``P < sensitivity_dbm`` is not reported (a reader's
  configurable receive sensitivity);
* time stamp: ``t_us = round(t_s·10⁶)`` (int64 µs since the start of the run).

:func:`long_table` sorts the rows of a read log by time stamp (stable), the long format
pandas/filterpy users expect (one row per read).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import

_bits = lazy_import("rfsim.gen2.bits")

READ_MEASUREMENT_FIELDS: dict[str, tuple[str, str]] = {
    "antenna": ("1", "reader antenna port (1-based, as LLRP)"),
    "channel_index": ("1", "1-based index into the reader's hop table"),
    "frequency_hz": ("Hz", "carrier frequency of the read (the hop channel's centre)"),
    "rssi_dbm": ("dBm", "RSSI: power of the tag's modulated EPC reply at the reader antenna port "
                        "(NaN where the read failed)"),
    "phase_rad": ("rad", "reader-reported phase (-arg h) mod 2pi of the EPC reply (NaN where the read failed)"),
    "doppler_hz": ("Hz", "Doppler from the phase slope across the EPC reply (NaN where the read failed)"),
    "snr_db": ("dB", "SNR of the EPC reply as defined by the reader receiver (NaN where the read failed)"),
}

#: Columns the report stage adds (:func:`report_columns`), name → (units, description).
READ_REPORT_FIELDS: dict[str, tuple[str, str]] = {
    "t_us": ("us", "first-seen time stamp of the read in whole microseconds since the start of the run "
                   "(round(t_s·1e6))"),
    "epc": ("", "EPC the reader decoded, as an upper-case hex string ('' where the read failed)"),
    "reported": ("1", "the reader reports the read: EPC decoded with CRC ok and RSSI at or above the "
                      "sensitivity floor (reader.report.sensitivity_dbm)"),
    "rssi_reported_dbm": ("dBm", "RSSI as the reader reports it: rounded to reader.report.rssi_step_db "
                                 "(NaN where not reported)"),
    "phase_reported_rad": ("rad", "reported phase: (-arg h + the port's phase offset) mod 2pi "
                                  "(reader.report.port_phase_offsets_rad; NaN where not reported)"),
    "phase_code": ("1", "reported phase as the reader's integer code round(phase·2^bits/2pi) mod 2^bits "
                        "(reader.report.phase_bits; -1 where not reported)"),
}


@dataclass(frozen=True)
class ReportConfig:
    """What a reader does with its measurements before it reports them (module docstring)."""

    rssi_step_db: float = param(1.0, lo=0.0, hi=10.0, unit="dB",
                                doc="RSSI resolution: 1 = LLRP PeakRSSI (whole dBm), 0.01 = Impinj, 0 = none")
    sensitivity_dbm: float = param(-90.0, lo=-150.0, hi=0.0, unit="dBm",
                                   doc="receive sensitivity: decoded replies weaker than this are not reported")
    phase_bits: int = param(12, lo=0, hi=32, doc="bits of the reported phase code (Impinj: 12; 0 = not quantized)")
    port_phase_offsets_rad: tuple[float, ...] = param(
        (), lo=-2 * math.pi, hi=2 * math.pi, unit="rad",
        doc="phase offset of each antenna port (cables, front end), port 1 first; () = none")

    def port_offset_rad(self, antenna) -> np.ndarray:
        """Phase offset [rad] of the 1-based ``antenna`` ports (0 without offsets); a port the
        list does not cover is a one-line ``ConfigError``."""
        a = np.asarray(antenna, dtype=np.int64)
        if not self.port_phase_offsets_rad:
            return np.zeros(a.shape)
        offsets = np.asarray(self.port_phase_offsets_rad, float)
        if a.size and (a.min() < 1 or a.max() > offsets.size):
            raise ConfigError("reader.report.port_phase_offsets_rad", list(self.port_phase_offsets_rad),
                              f"one offset per antenna port (ports 1…{int(a.max())} are used)")
        return offsets[a - 1]


def quantize_rssi_dbm(rssi_dbm, step_db: float) -> np.ndarray:
    """``step·round(P/step)`` [dBm] (``step = 0``: unchanged); NaN stays NaN."""
    p = np.asarray(rssi_dbm, float)
    return p.copy() if step_db == 0 else step_db * np.round(p / step_db)


def phase_code(phase_rad, bits: int) -> np.ndarray:
    """Integer phase code ``round(φ·2^bits/2π) mod 2^bits`` (int64; −1 where φ is NaN)."""
    phi = np.asarray(phase_rad, float)
    n = 2 ** int(bits)
    ok = np.isfinite(phi)
    code = np.full(phi.shape, -1, dtype=np.int64)
    code[ok] = np.mod(np.round(phi[ok] * (n / (2.0 * math.pi))), n).astype(np.int64)
    return code


def phase_of_code(code, bits: int) -> np.ndarray:
    """Phase [rad] of a phase code: ``c·2π/2^bits`` (NaN for the code −1)."""
    c = np.asarray(code, dtype=np.int64)
    return np.where(c >= 0, c * (2.0 * math.pi / 2 ** int(bits)), np.nan)


def time_stamp_us(t_s) -> np.ndarray:
    """Time stamps in whole microseconds, ``round(t_s·10⁶)`` (int64)."""
    return np.round(np.asarray(t_s, float) * 1e6).astype(np.int64)


def epc_hex(bits) -> str:
    """EPC of a decoded PC + EPC + CRC-16 reply as upper-case hex ('' for None or < 48 bits)."""
    if bits is None:
        return ""
    b = np.asarray(bits, dtype=np.uint8)
    if b.size < 48 or (b.size - 32) % 4:
        return ""
    return _bits.bits_to_hex(b[16:-16])


def report_columns(config: ReportConfig, *, t_s, antenna, rssi_dbm, phase_rad, success) -> dict[str, np.ndarray]:
    """The report stage over a read log: ``t_us``, ``reported``, ``rssi_reported_dbm``,
    ``phase_reported_rad``, ``phase_code`` (:data:`READ_REPORT_FIELDS`).

    Parameters
    ----------
    config : :class:`ReportConfig`
    t_s : (n,) read times [s];  antenna : (n,) 1-based ports
    rssi_dbm, phase_rad : (n,) the receiver's measurements (NaN where nothing was decoded)
    success : (n,) bool, EPC decoded with CRC ok
    """
    p = np.asarray(rssi_dbm, float)
    reported = np.asarray(success, bool) & np.isfinite(p) & (np.nan_to_num(p, nan=-np.inf) >= config.sensitivity_dbm)
    phi = np.mod(np.asarray(phase_rad, float) + config.port_offset_rad(antenna), 2.0 * math.pi)
    phi = np.where(reported, phi, np.nan)
    if config.phase_bits:
        code = phase_code(phi, config.phase_bits)
        phi_rep = phase_of_code(code, config.phase_bits)
    else:
        code = np.full(phi.shape, -1, dtype=np.int64)
        phi_rep = phi
    return {"t_us": time_stamp_us(t_s), "reported": reported,
            "rssi_reported_dbm": np.where(reported, quantize_rssi_dbm(p, config.rssi_step_db), np.nan),
            "phase_reported_rad": phi_rep, "phase_code": code}


def long_table(columns: dict[str, np.ndarray], *, time_key: str = "t_us") -> dict[str, np.ndarray]:
    """The rows of ``columns`` sorted by ``time_key`` (a stable sort: reads at the same
    microsecond keep their order), every column as an array."""
    cols = {k: np.asarray(v) for k, v in columns.items()}
    order = np.argsort(cols[time_key], kind="stable")
    return {k: v[order] for k, v in cols.items()}


__all__ = ["READ_MEASUREMENT_FIELDS", "READ_REPORT_FIELDS", "ReportConfig", "quantize_rssi_dbm", "phase_code",
           "phase_of_code", "time_stamp_us", "epc_hex", "report_columns", "long_table"]

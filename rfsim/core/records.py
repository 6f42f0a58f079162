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
    """What a reader does with its measurements before it reports them (see the module docstring).

    Parameters
    ----------
    rssi_step_db : float, default 1.0
        RSSI resolution [dB] in [0, 10]: 1 = LLRP PeakRSSI (whole dBm), 0.01 = Impinj,
        0 = not quantized.
    sensitivity_dbm : float, default -90.0
        Receive sensitivity [dBm] in [-150, 0]: decoded replies weaker than this are not
        reported.
    phase_bits : int, default 12
        Bits of the reported phase code in [0, 32] (Impinj: 12; 0 = not quantized).
    port_phase_offsets_rad : tuple of float, default ()
        Phase offset [rad] of each antenna port (cables, front end), port 1 first, each in
        [-2π, 2π]; () = none.
    """

    rssi_step_db: float = param(1.0, lo=0.0, hi=10.0, unit="dB",
                                doc="RSSI resolution: 1 = LLRP PeakRSSI (whole dBm), 0.01 = Impinj, 0 = none")
    sensitivity_dbm: float = param(-90.0, lo=-150.0, hi=0.0, unit="dBm",
                                   doc="receive sensitivity: decoded replies weaker than this are not reported")
    phase_bits: int = param(12, lo=0, hi=32, doc="bits of the reported phase code (Impinj: 12; 0 = not quantized)")
    port_phase_offsets_rad: tuple[float, ...] = param(
        (), lo=-2 * math.pi, hi=2 * math.pi, unit="rad",
        doc="phase offset of each antenna port (cables, front end), port 1 first; () = none")

    def port_offset_rad(self, antenna) -> np.ndarray:
        r"""Phase offset of antenna ports, :math:`\varphi_\mathrm{port}[a]`.

        Parameters
        ----------
        antenna : array_like of int
            1-based antenna ports.

        Returns
        -------
        ndarray of float
            Offset [rad] per port, the shape of ``antenna``; zeros without offsets.

        Raises
        ------
        rfsim.core.errors.ConfigError
            If a port is below 1 or beyond the list of offsets (one line).
        """
        a = np.asarray(antenna, dtype=np.int64)
        if not self.port_phase_offsets_rad:
            return np.zeros(a.shape)
        offsets = np.asarray(self.port_phase_offsets_rad, float)
        if a.size and (a.min() < 1 or a.max() > offsets.size):
            raise ConfigError("reader.report.port_phase_offsets_rad", list(self.port_phase_offsets_rad),
                              f"one offset per antenna port (ports 1…{int(a.max())} are used)")
        return offsets[a - 1]


def quantize_rssi_dbm(rssi_dbm, step_db: float) -> np.ndarray:
    r"""Round RSSI to a reader's step: :math:`P_q = s \, \mathrm{round}(P/s)`.

    The same rule as ``rfsim.devices.rss_reader.RssReport``; ties to even (numpy's rounding).

    Parameters
    ----------
    rssi_dbm : array_like of float
        RSSI [dBm]; NaN stays NaN.
    step_db : float
        Step :math:`s` [dB]; 0 leaves the values unchanged.

    Returns
    -------
    ndarray of float
        Quantized RSSI [dBm] (a copy), the shape of ``rssi_dbm``.
    """
    p = np.asarray(rssi_dbm, float)
    return p.copy() if step_db == 0 else step_db * np.round(p / step_db)


def phase_code(phase_rad, bits: int) -> np.ndarray:
    r"""Integer phase code :math:`c = \mathrm{round}(\varphi \, 2^b / 2\pi) \bmod 2^b`.

    Parameters
    ----------
    phase_rad : array_like of float
        Phase :math:`\varphi` [rad], any range.
    bits : int
        Bits :math:`b` of the code (12 for Impinj's RF phase angle).

    Returns
    -------
    ndarray of int64
        Codes in [0, 2^b), the shape of ``phase_rad``; −1 where the phase is not finite.
    """
    phi = np.asarray(phase_rad, float)
    n = 2 ** int(bits)
    ok = np.isfinite(phi)
    code = np.full(phi.shape, -1, dtype=np.int64)
    code[ok] = np.mod(np.round(phi[ok] * (n / (2.0 * math.pi))), n).astype(np.int64)
    return code


def phase_of_code(code, bits: int) -> np.ndarray:
    r"""Phase of a phase code: :math:`\varphi = c \, 2\pi / 2^b`.

    Parameters
    ----------
    code : array_like of int
        Codes (:func:`phase_code`); −1 means none.
    bits : int
        Bits :math:`b` of the code.

    Returns
    -------
    ndarray of float
        Phase [rad] in [0, 2π), the shape of ``code``; NaN for the code −1.
    """
    c = np.asarray(code, dtype=np.int64)
    return np.where(c >= 0, c * (2.0 * math.pi / 2 ** int(bits)), np.nan)


def time_stamp_us(t_s) -> np.ndarray:
    r"""Time stamps in whole microseconds, :math:`t_\mu = \mathrm{round}(t \cdot 10^6)`.

    Parameters
    ----------
    t_s : array_like of float
        Times [s] since the start of the run.

    Returns
    -------
    ndarray of int64
        Time stamps [µs], the shape of ``t_s``.
    """
    return np.round(np.asarray(t_s, float) * 1e6).astype(np.int64)


def epc_hex(bits) -> str:
    """EPC of a decoded PC + EPC + CRC-16 reply as upper-case hex.

    The 16 PC bits and the 16 CRC bits are dropped (the ACK reply,
    gen2-and-validation-anchors.md §3.2).

    Parameters
    ----------
    bits : array_like of int or None
        The reply's bits (0/1), PC first, CRC-16 last.

    Returns
    -------
    str
        The EPC in hex; ``""`` for None, fewer than 48 bits, or an EPC that is not a whole
        number of hex digits.
    """
    if bits is None:
        return ""
    b = np.asarray(bits, dtype=np.uint8)
    if b.size < 48 or (b.size - 32) % 4:
        return ""
    return _bits.bits_to_hex(b[16:-16])


def report_columns(config: ReportConfig, *, t_s, antenna, rssi_dbm, phase_rad, success) -> dict[str, np.ndarray]:
    r"""Apply the report stage to a read log.

    A read is reported when its EPC was decoded with CRC ok and its RSSI is finite and at
    least ``config.sensitivity_dbm``. For reported reads the phase is
    :math:`\varphi_\mathrm{rep} = (\varphi + \varphi_\mathrm{port}[a]) \bmod 2\pi`, then coded
    (:func:`phase_code`, :func:`phase_of_code`) when ``config.phase_bits`` > 0, and the RSSI is
    rounded to ``config.rssi_step_db`` (:func:`quantize_rssi_dbm`). See the module docstring
    for the sources.

    Parameters
    ----------
    config : ReportConfig
        The reader's report settings.
    t_s : array_like of float, shape (n,)
        Read times [s].
    antenna : array_like of int, shape (n,)
        1-based antenna ports.
    rssi_dbm : array_like of float, shape (n,)
        The receiver's RSSI [dBm] (NaN where nothing was decoded).
    phase_rad : array_like of float, shape (n,)
        The receiver's phase [rad] (NaN where nothing was decoded).
    success : array_like of bool, shape (n,)
        EPC decoded with CRC ok.

    Returns
    -------
    dict of str to ndarray
        The columns of :data:`READ_REPORT_FIELDS` but ``epc``, each shape (n,): ``t_us``
        (int64 [µs]), ``reported`` (bool), ``rssi_reported_dbm`` [dBm] and
        ``phase_reported_rad`` [rad] (NaN where not reported), ``phase_code`` (int64, −1 where
        not reported or not quantized).

    Raises
    ------
    rfsim.core.errors.ConfigError
        If a port has no phase offset while offsets are given
        (:meth:`ReportConfig.port_offset_rad`).
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
    """Sort the rows of a read log by time stamp (one row per read, the long format).

    The sort is stable: reads at the same time stamp keep their order.

    Parameters
    ----------
    columns : dict of str to array_like
        Columns of equal length n.
    time_key : str, default "t_us"
        The column to sort by.

    Returns
    -------
    dict of str to ndarray
        Every column as an array, rows reordered.
    """
    cols = {k: np.asarray(v) for k, v in columns.items()}
    order = np.argsort(cols[time_key], kind="stable")
    return {k: v[order] for k, v in cols.items()}


__all__ = ["READ_MEASUREMENT_FIELDS", "READ_REPORT_FIELDS", "ReportConfig", "quantize_rssi_dbm", "phase_code",
           "phase_of_code", "time_stamp_us", "epc_hex", "report_columns", "long_table"]

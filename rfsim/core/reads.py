"""The per-read schema: the columns every dataset that holds tag reads shares.

One row of a ``reads`` table is one read — what a reader reports for one decoded EPC reply
(a *tag report*) — or, in the tables that keep them, a read attempt that failed. The names
and units are those of LLRP ``TagReportData`` with the Impinj low-level-data extensions, as
sllurp hands them to its users (gen2-and-validation-anchors.md §2.5 and §4.9; wave2-specs.md
"What a per-read dataset should look like"), spelled in snake case with the unit as the
suffix:

============================ ====== =====================================================
column                       units  LLRP / Impinj parameter
============================ ====== =====================================================
``epc``                      text   EPC-96 / EPCData (upper-case hex)
``antenna_port``             1      AntennaID (1-based)
``channel_index``            1      ChannelIndex (1-based index into the hop table)
``frequency_hz``             Hz     the hop table's frequency at ChannelIndex
``first_seen_timestamp_us``  us     FirstSeenTimestampUptime (µs since the start of the run)
``last_seen_timestamp_us``   us     LastSeenTimestampUptime
``tag_seen_count``           1      TagSeenCount
``peak_rssi_dbm``            dBm    PeakRSSI / ImpinjPeakRSSI, unquantized
``phase_angle_rad``          rad    ImpinjRFPhaseAngle, unquantized
``doppler_frequency_hz``     Hz     ImpinjRFDopplerFrequency
============================ ====== =====================================================

Beside them, the reader-quantized variants (what an Impinj reader's numbers look like) and
the ground truth a simulation knows:

* ``peak_rssi_quantized_dbm`` — :func:`quantize_rssi_impinj_dbm`: ``0.5·round(P/0.5)``, the
  0.5 dB RSSI steps of Impinj readers (gen2-and-validation-anchors.md §4.9);
* ``phase_angle_quantized_rad`` — :func:`quantize_phase_12bit_rad`: ``c·2π/4096`` with
  ``c = round(φ·4096/2π) mod 4096``, the 12-bit ImpinjRFPhaseAngle (0–4095 ↔ 0–2π, §2.5);
* ``true_distance_m``, ``true_x_m``/``true_y_m``/``true_z_m``, ``true_incident_power_dbm`` —
  distance from the reading antenna port to the tag, the tag's position and the CW power
  incident at its antenna port at the read (NaN where a dataset cannot know them, e.g. a
  decoded capture).

Each row is one read, so ``last_seen_timestamp_us = first_seen_timestamp_us`` and
``tag_seen_count`` is 1 for a reported read, 0 for a failed attempt (a reader reports no such
row; ``rfsim export`` leaves them out). Time stamps are whole microseconds since the start
of the run, ``round(t_s·10⁶)`` (:func:`rfsim.core.records.time_stamp_us`) — a reader's uptime
clock, not UTC.

:data:`READ_SCHEMA` is the one definition (units, short label, description, LLRP source);
:func:`read_columns` builds a table's schema columns from what a scenario measured; each
dataset adds its own context columns (round, slot, failure reason, ...) after them. The
datasets page of the documentation lists the same table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rfsim.core.lazy import lazy_import
from rfsim.core.records import phase_code, phase_of_code, quantize_rssi_dbm, time_stamp_us

if TYPE_CHECKING:
    from rfsim.core.dataset import Column

# The scenario modules import this one to name their columns; the dataset module (h5py) loads
# when a table is built, not when ``rfsim config`` reads a scenario's config.
_dataset = lazy_import("rfsim.core.dataset")

#: RSSI step [dB] of Impinj readers' reports (gen2-and-validation-anchors.md §4.9).
IMPINJ_RSSI_STEP_DB = 0.5
#: Bits of the ImpinjRFPhaseAngle code: 0–4095 ↔ 0–2π, 2π/4096 = 1.534 mrad steps (§2.5).
IMPINJ_PHASE_BITS = 12


@dataclass(frozen=True)
class ReadField:
    """One column of the per-read schema.

    Parameters
    ----------
    units : str
        Units as in the file (``""`` for text).
    long_name : str
        The short label (CF ``long_name``).
    description : str
        The sentence that says what the column is.
    llrp : str, default ""
        The LLRP/Impinj parameter the column corresponds to (``""`` for the simulation's
        ground truth).
    """

    units: str
    long_name: str
    description: str
    llrp: str = ""

    def text(self, note: str = "") -> str:
        """The column's ``description`` attribute: ``"<long_name>: <description>"``.

        Written so, the file's ``long_name`` (:func:`rfsim.core.dataset.long_name`) is exactly
        :attr:`long_name`.

        Parameters
        ----------
        note : str, default ""
            What a dataset adds to the description, appended in parentheses ("" for nothing).

        Returns
        -------
        str
            The description attribute.
        """
        return f"{self.long_name}: {self.description}" + (f" ({note})" if note else "")


READ_SCHEMA: dict[str, ReadField] = {
    "epc": ReadField("", "EPC", "EPC the reader decoded, as an upper-case hex string ('' where no EPC was "
                                "decoded)", "EPC-96 / EPCData"),
    "antenna_port": ReadField("1", "antenna port", "reader antenna port that made the read, 1-based as LLRP "
                                                   "(0: not known)", "AntennaID"),
    "channel_index": ReadField("1", "channel index", "1-based index of the read's carrier in the reader's hop "
                                                     "table (0: not known)", "ChannelIndex"),
    "frequency_hz": ReadField("Hz", "carrier frequency", "carrier frequency of the read, the hop channel's "
                                                         "centre (NaN: not known)", "hop table at ChannelIndex"),
    "first_seen_timestamp_us": ReadField("us", "first-seen time stamp", "time of the read in whole microseconds "
                                         "since the start of the run, round(t_s·1e6)", "FirstSeenTimestampUptime"),
    "last_seen_timestamp_us": ReadField("us", "last-seen time stamp", "equal to first_seen_timestamp_us: one row is "
                                        "one read", "LastSeenTimestampUptime"),
    "tag_seen_count": ReadField("1", "tag seen count", "reads the row reports: 1 for a reported read, 0 for a "
                                                       "read attempt the reader does not report", "TagSeenCount"),
    "peak_rssi_dbm": ReadField("dBm", "peak RSSI", "power of the tag's EPC reply at the reader antenna port as "
                                                   "the receiver measured it, not quantized (NaN where no EPC was "
                                                   "decoded)", "PeakRSSI / ImpinjPeakRSSI"),
    "peak_rssi_quantized_dbm": ReadField("dBm", "peak RSSI in 0.5 dB steps", "peak_rssi_dbm rounded to the 0.5 dB "
                                         "steps of an Impinj reader, 0.5·round(P/0.5) (NaN where no EPC was decoded)",
                                         "ImpinjPeakRSSI"),
    "phase_angle_rad": ReadField("rad", "RF phase angle", "reader-reported phase (-arg h) mod 2pi of the EPC "
                                                          "reply, not quantized (NaN where no EPC was decoded)",
                                 "ImpinjRFPhaseAngle"),
    "phase_angle_quantized_rad": ReadField("rad", "RF phase angle, 12-bit", "phase_angle_rad as the 12-bit "
                                           "ImpinjRFPhaseAngle code c = round(phi·4096/2pi) mod 4096 gives it, "
                                           "c·2pi/4096 (NaN where no EPC was decoded)", "ImpinjRFPhaseAngle"),
    "doppler_frequency_hz": ReadField("Hz", "RF Doppler frequency", "Doppler shift from the phase slope across "
                                      "the EPC reply (NaN where not measured)", "ImpinjRFDopplerFrequency"),
    "true_distance_m": ReadField("m", "true distance", "ground truth: distance from the reading antenna port to "
                                                       "the tag antenna at the read (NaN: not known)"),
    "true_x_m": ReadField("m", "true tag x", "ground truth: x of the tag antenna at the read (NaN: not known)"),
    "true_y_m": ReadField("m", "true tag y", "ground truth: y of the tag antenna at the read (NaN: not known)"),
    "true_z_m": ReadField("m", "true tag z", "ground truth: z of the tag antenna at the read (NaN: not known)"),
    "true_incident_power_dbm": ReadField("dBm", "true incident power", "ground truth: CW power incident at the "
                                         "tag antenna port during the read (NaN: not known)"),
}

#: Schema columns a reader reports (the rest are the quantized variants and the ground truth).
REPORT_KEYS = ("epc", "antenna_port", "channel_index", "frequency_hz", "first_seen_timestamp_us",
               "last_seen_timestamp_us", "tag_seen_count", "peak_rssi_dbm", "phase_angle_rad", "doppler_frequency_hz")


def quantize_rssi_impinj_dbm(rssi_dbm) -> np.ndarray:
    r"""RSSI in the 0.5 dB steps of an Impinj reader.

    .. math:: P_q = 0.5 \, \mathrm{round}(P / 0.5)

    with ties to even (numpy's rounding); NaN stays NaN. Source:
    gen2-and-validation-anchors.md §4.9.

    Parameters
    ----------
    rssi_dbm : array_like of float
        RSSI [dBm].

    Returns
    -------
    ndarray of float
        Quantized RSSI [dBm], the shape of ``rssi_dbm``.
    """
    return quantize_rssi_dbm(rssi_dbm, IMPINJ_RSSI_STEP_DB)


def quantize_phase_12bit_rad(phase_rad) -> np.ndarray:
    r"""Phase as the 12-bit ImpinjRFPhaseAngle reports it.

    .. math:: c = \mathrm{round}(\varphi \cdot 4096 / 2\pi) \bmod 4096, \qquad
              \varphi_q = c \cdot 2\pi / 4096

    so :math:`\varphi_q \in [0, 2\pi)` in 1.534 mrad steps; NaN stays NaN. Source:
    gen2-and-validation-anchors.md §2.5 (0–4095 ↔ 0–2π).

    Parameters
    ----------
    phase_rad : array_like of float
        Phase [rad], any range.

    Returns
    -------
    ndarray of float
        Quantized phase [rad], the shape of ``phase_rad``.
    """
    return phase_of_code(phase_code(phase_rad, IMPINJ_PHASE_BITS), IMPINJ_PHASE_BITS)


def _full(value, n: int, dtype) -> np.ndarray:
    arr = np.asarray(value, dtype=dtype)
    return np.broadcast_to(arr, (n,)).copy() if arr.ndim == 0 else arr


def read_columns(*, epc, antenna_port, channel_index, frequency_hz, first_seen_timestamp_us, tag_seen_count,
                 peak_rssi_dbm, phase_angle_rad, doppler_frequency_hz, true_distance_m=math.nan,
                 true_position_m=None, true_incident_power_dbm=math.nan,
                 notes: Mapping[str, str] | None = None) -> dict[str, Column]:
    """The schema's columns of a reads table (:data:`READ_SCHEMA`, in its order).

    Parameters
    ----------
    epc : (n,) str
        decoded EPC, upper-case hex ('' where none).
    antenna_port, channel_index : (n,) int
        1-based antenna port and hop-table index (0: not known).
    frequency_hz : (n,) float
        carrier [Hz].
    first_seen_timestamp_us : (n,) int
        read time stamps [µs] (:func:`rfsim.core.records.time_stamp_us`).
    tag_seen_count : (n,) int or bool
        1 for a reported read, 0 for a failed attempt.
    peak_rssi_dbm, phase_angle_rad, doppler_frequency_hz : (n,) float
        the receiver's measurements [dBm, rad, Hz], unquantized (NaN where none).
    true_distance_m, true_incident_power_dbm : (n,) float or scalar
        ground truth [m, dBm] (NaN: not known).
    true_position_m : (n, 3) float or None
        ground-truth tag position [m] (None: not known, NaN columns).
    notes : mapping, optional
        column → what this dataset adds to the schema's description (e.g. how a capture
        defines its RSSI); the long name stays the schema's.

    Returns
    -------
    dict
        column name → :class:`rfsim.core.dataset.Column`, the quantized variants computed
        here (:func:`quantize_rssi_impinj_dbm`, :func:`quantize_phase_12bit_rad`) and
        ``last_seen_timestamp_us = first_seen_timestamp_us``.

    Raises
    ------
    ValueError
        If ``notes`` names a column outside the schema.
    """
    epc = np.asarray(epc)
    n = epc.shape[0]
    t_us = np.asarray(first_seen_timestamp_us, dtype=np.int64)
    rssi = np.asarray(peak_rssi_dbm, dtype=float)
    phase = np.asarray(phase_angle_rad, dtype=float)
    pos = np.full((n, 3), np.nan) if true_position_m is None else np.asarray(true_position_m, dtype=float).reshape(n, 3)
    values = {
        "epc": epc.astype(str) if epc.dtype.kind != "O" else epc,
        "antenna_port": np.asarray(antenna_port, dtype=np.int64),
        "channel_index": np.asarray(channel_index, dtype=np.int64),
        "frequency_hz": np.asarray(frequency_hz, dtype=float),
        "first_seen_timestamp_us": t_us,
        "last_seen_timestamp_us": t_us.copy(),
        "tag_seen_count": np.asarray(tag_seen_count).astype(np.int64),
        "peak_rssi_dbm": rssi,
        "peak_rssi_quantized_dbm": quantize_rssi_impinj_dbm(rssi),
        "phase_angle_rad": phase,
        "phase_angle_quantized_rad": quantize_phase_12bit_rad(phase),
        "doppler_frequency_hz": np.asarray(doppler_frequency_hz, dtype=float),
        "true_distance_m": _full(true_distance_m, n, float),
        "true_x_m": pos[:, 0].copy(), "true_y_m": pos[:, 1].copy(), "true_z_m": pos[:, 2].copy(),
        "true_incident_power_dbm": _full(true_incident_power_dbm, n, float),
    }
    notes = notes or {}
    unknown = set(notes) - set(READ_SCHEMA)
    if unknown:
        raise ValueError(f"notes for columns outside the read schema: {sorted(unknown)}")
    out = {}
    for name, field in READ_SCHEMA.items():
        v = values[name]
        out[name] = _dataset.Column(v, field.units, field.text(notes.get(name, ""))) if v.dtype == object else \
            _dataset.column(v, field.units, field.text(notes.get(name, "")))
    return out


#: The names a read log uses for what the schema holds (the protocol layer's
#: :data:`rfsim.protocols.inventory.READ_FIELDS`, :data:`rfsim.core.records.READ_MEASUREMENT_FIELDS` and
#: :data:`~rfsim.core.records.READ_REPORT_FIELDS`, a scenario's ``distance_m``/``x_m``/…): in a
#: dataset's reads table they appear only under the schema's names (:func:`reads_table`).
LOG_NAMES = ("epc", "epc_hex", "antenna", "t_us", "rssi_dbm", "phase_rad", "doppler_hz",
             "tag_incident_power_dbm", "distance_m", "true_position_m", "x_m", "y_m", "z_m")


def _first(log: Mapping, names: tuple[str, ...], default=None):
    return next((log[k] for k in names if k in log), default)


def log_read_columns(log: Mapping, *, true_position_m=None, true_distance_m=None,
                     notes: Mapping[str, str] | None = None) -> dict[str, Column]:
    """The schema's columns (:func:`read_columns`) of a read log under the protocol layer's names.

    Parameters
    ----------
    log : mapping of str to array_like
        Read log, sequences of one length n: ``epc`` or ``epc_hex``, ``antenna``,
        ``channel_index``, ``frequency_hz`` [Hz], ``rssi_dbm`` [dBm], ``phase_rad`` [rad],
        ``doppler_hz`` [Hz]; the time stamp ``t_us`` [µs], else ``time_s`` (or ``t_s``) [s],
        rounded to µs; ``reported`` (absent: every entry is a reported read); where the log
        has them, the truth ``tag_incident_power_dbm`` [dBm], ``distance_m`` or
        ``true_distance_m`` [m], and ``x_m``/``y_m``/``z_m`` or ``true_position_m``
        (n, 3) [m] (absent: NaN).
    true_position_m : array_like of float, shape (n, 3), optional
        Ground-truth tag positions [m]; overrides the log's.
    true_distance_m : array_like of float, shape (n,), or float, optional
        Ground-truth distance [m]; overrides the log's.
    notes : mapping of str to str or None, default None
        Column → what this dataset adds to the schema's description.

    Returns
    -------
    dict of str to rfsim.core.dataset.Column
        The schema's columns, in the order of :data:`READ_SCHEMA`.

    Raises
    ------
    ValueError
        If ``notes`` names a column outside the schema.
    """
    epc = np.asarray(_first(log, ("epc", "epc_hex")), dtype=str)
    n = epc.shape[0]
    t_us = log["t_us"] if "t_us" in log else time_stamp_us(_first(log, ("time_s", "t_s")))
    if true_position_m is None and "x_m" in log:
        true_position_m = np.column_stack([log["x_m"], log["y_m"], log["z_m"]])
    if true_position_m is None and "true_position_m" in log:
        true_position_m = log["true_position_m"]
    if true_distance_m is None:
        true_distance_m = _first(log, ("distance_m", "true_distance_m"), math.nan)
    return read_columns(epc=epc.reshape(n), antenna_port=np.asarray(log["antenna"], dtype=np.int64).reshape(n),
                        channel_index=np.asarray(log["channel_index"], dtype=np.int64).reshape(n),
                        frequency_hz=log["frequency_hz"], first_seen_timestamp_us=t_us,
                        tag_seen_count=log["reported"] if "reported" in log else np.ones(n, np.int64),
                        peak_rssi_dbm=log["rssi_dbm"], phase_angle_rad=log["phase_rad"],
                        doppler_frequency_hz=log["doppler_hz"], true_distance_m=np.asarray(true_distance_m, float),
                        true_position_m=None if true_position_m is None else
                        np.reshape(np.asarray(true_position_m, float), (n, 3)),
                        true_incident_power_dbm=np.asarray(_first(log, ("tag_incident_power_dbm",), math.nan), float),
                        notes=notes)


def reads_table(log: Mapping, fields: Mapping[str, tuple[str, str]], *, true_position_m=None, true_distance_m=None,
                notes: Mapping[str, str] | None = None) -> dict[str, Column]:
    """A dataset's ``reads`` table from a read log.

    The schema's columns (:func:`log_read_columns`), then the log's other columns named in
    ``fields``; the :data:`LOG_NAMES` that the schema already holds are left out.

    Parameters
    ----------
    log : mapping of str to array_like
        Read log (see :func:`log_read_columns`).
    fields : mapping of str to (str, str)
        Column name → (units, description) of the log's extra columns to keep.
    true_position_m, true_distance_m, notes : optional
        As in :func:`log_read_columns` (ground truth [m] that overrides the log's, and the
        dataset's notes on the schema's descriptions).

    Returns
    -------
    dict of str to rfsim.core.dataset.Column
        The table's columns, schema first.

    Raises
    ------
    ValueError
        If ``notes`` names a column outside the schema.
    """
    schema = log_read_columns(log, true_position_m=true_position_m, true_distance_m=true_distance_m, notes=notes)
    return {**schema, **{k: _dataset.column(np.asarray(log[k]), *fields[k]) for k in fields
                         if k not in schema and k not in LOG_NAMES}}


def has_read_schema(names) -> bool:
    """Whether a table holds every column of :data:`READ_SCHEMA`.

    Parameters
    ----------
    names : iterable of str
        The table's column names (a dict of columns works too).

    Returns
    -------
    bool
        True if every schema column is among ``names``.
    """
    return set(READ_SCHEMA) <= set(names)


__all__ = ["ReadField", "READ_SCHEMA", "REPORT_KEYS", "IMPINJ_RSSI_STEP_DB", "IMPINJ_PHASE_BITS",
           "quantize_rssi_impinj_dbm", "quantize_phase_12bit_rad", "read_columns", "LOG_NAMES",
           "log_read_columns", "reads_table", "has_read_schema"]

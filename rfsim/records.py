"""Field definitions of the per-read records every reader-side dataset shares.

What a reader reports for one decoded reply (gen2-and-validation-anchors.md §4.9, LLRP
TagReportData + Impinj low-level data): antenna port, hop-table channel, carrier, RSSI,
phase, Doppler and SNR. Scenarios build their read tables from these definitions (name →
(units, description)) plus their own context columns, so a column means the same thing in
every dataset.
"""

from __future__ import annotations

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

__all__ = ["READ_MEASUREMENT_FIELDS"]

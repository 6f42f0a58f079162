"""EPC Gen2 (ISO/IEC 18000-63) physical-layer and framing primitives.

Modules: :mod:`~rfsim.gen2.bits` (bit arrays), :mod:`~rfsim.gen2.crc` (CRC-5/CRC-16),
:mod:`~rfsim.gen2.commands` (reader command encoders and parsers),
:mod:`~rfsim.gen2.memory` (tag memory banks, lock state, chip models),
:mod:`~rfsim.gen2.access` (tag-side execution of access commands: replies, states, delays),
:mod:`~rfsim.gen2.link` (link profiles, BLF tolerance, T1–T7, durations),
:mod:`~rfsim.gen2.pie` (PIE envelope encoder and decoder),
:mod:`~rfsim.gen2.linecode` (FM0/Miller encoders, sampled replies, coherent and Viterbi
decoders), :mod:`~rfsim.gen2.capture` (reader commands in recorded waveforms) and
:mod:`~rfsim.gen2.replies` (tag replies in recorded waveforms).

Capture decoding of tag replies is split by step: detection (:mod:`~rfsim.gen2.reply_search`),
decoding (:mod:`~rfsim.gen2.reply_decoding`), block tracking (:mod:`~rfsim.gen2.reply_tracking`)
and the records (:mod:`~rfsim.gen2.replies`, :mod:`~rfsim.gen2.capture_records`); the steps the
reader's search decoder and the capture decoder share are written once in
:mod:`~rfsim.gen2.reply_core`.
"""

from rfsim.core.lazy import lazy_exports

#: Module of the package → the public names it provides, each imported on first use (so
#: that importing one module, e.g. the link profiles, does not import the others).
_SOURCES = {
    "bits": ("bits_to_hex", "bits_to_int", "hex_to_bits", "int_to_bits"),
    "commands": ("ACK", "NAK", "CommandParseError", "Query", "QueryAdjust", "QueryRep", "Read", "ReqRN",
                 "Select", "Write", "Kill", "Lock", "Access", "BlockWrite", "BlockErase", "cover_code",
                 "command_name", "command_preamble", "encode", "parse"),
    "crc": ("append_crc5", "append_crc16", "crc5", "crc5_ok", "crc16", "crc16_bytes", "crc16_ok"),
    "link": ("PROFILES", "LinkProfile", "TimingRange", "backscatter_duration_s", "frt_fraction",
             "pie_duration_s", "profile", "t1", "t2", "t3", "t4", "t5", "t6", "t7"),
}
__getattr__, __dir__ = lazy_exports(globals(), _SOURCES)

__all__ = [
    "int_to_bits", "bits_to_int", "hex_to_bits", "bits_to_hex",
    "crc5", "crc16", "crc16_bytes", "crc5_ok", "crc16_ok", "append_crc5", "append_crc16",
    "Query", "QueryRep", "QueryAdjust", "ACK", "NAK", "ReqRN", "Read", "Select",
    "CommandParseError", "encode", "parse", "command_name", "command_preamble",
    "LinkProfile", "PROFILES", "profile", "TimingRange", "frt_fraction", "pie_duration_s",
    "backscatter_duration_s", "t1", "t2", "t3", "t4", "t5", "t6", "t7",
]

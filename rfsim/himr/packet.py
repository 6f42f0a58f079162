"""HIMR packet formats, framing and CRC-8: packets of inertial words as bit arrays.

Formats (himr-tag.md §2.1–2.2; wave2-specs.md §H):

* ``9axis-2d`` (seed 000 Table 5, L715–L720): 3 B header, 2 B tag ID, 6 B accelerometer,
  6 B gyroscope, 6 B compass, 1 B CRC = 24 B = 192 bit ("a three-bytes header, a unique
  two-bytes tag identification code, 18-bytes inertial data, and a single-byte CRC", L715);
  BOC with 8 chips/bit at 4 Mcps (500 kb/s, 0.384 ms air time); 141 packets/s. (The
  reference pages' "30 bytes = 240 bit, 0.48 ms" does not follow from these byte counts.)
* ``6axis-1d`` (seed 000 Table 2, L411–L422): 3 B preamble, 2 B tag ID, 6 B accelerometer,
  1 B CRC = 96 bit; 64 chips/bit at 5 Mcps (78,125 b/s, 1.2288 ms air time); about
  300 packets/s.

The seed defers the preamble pattern, the CRC polynomial and the bit order to its ref.
[58] (L411), which is not available; :class:`Framing` makes them configurable with these
documented defaults [not in source]:

* header / preamble ``F9AF12``: Barker-13 followed by Barker-11
  (1111100110101 11100010010, 24 bit), chosen for its low autocorrelation sidelobes;
* CRC-8 with polynomial x⁸ + x² + x + 1 (0x07), init 0x00, no reflection, no final XOR
  (CRC-8/SMBUS; check value on ASCII "123456789": 0xF4), computed over the tag ID and the
  data bytes (everything between the header and the CRC);
* bytes sent MSB first (``bit_order = "msb"``); 16-bit words big-endian, high byte first
  (``word_order = "big"``, the MPU-9250 accelerometer/gyroscope register order).

Words are int16 in the order of the format's data fields (accel x, y, z, then gyro x, y,
z, then compass x, y, z).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.memo import PureCache
from rfsim.himr.boc import BocCode
from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError, did_you_mean

#: Default header / preamble: Barker-13 then Barker-11 (24 bit) [not in source].
DEFAULT_PREAMBLE_HEX = "F9AF12"


@dataclass(frozen=True)
class PacketFormat:
    """Layout and line code of one HIMR packet format.

    Attributes
    ----------
    name : format name
    fields : ((field name, bytes), ...) in transmission order; first ``header``, last ``crc``
    chips_per_bit, chip_rate_hz : BOC N and R_c [chip/s]
    packet_rate_hz : nominal packets per second of the free-running tag
    n_words : int16 data words per packet (3 per 6-byte sensor field)
    """

    name: str
    fields: tuple[tuple[str, int], ...]
    chips_per_bit: int
    chip_rate_hz: float
    packet_rate_hz: float

    @property
    def n_bytes(self) -> int:
        return sum(n for _, n in self.fields)

    @property
    def n_bits(self) -> int:
        return 8 * self.n_bytes

    @property
    def data_fields(self) -> tuple[str, ...]:
        return tuple(f for f, _ in self.fields if f not in ("header", "id", "crc"))

    @property
    def n_words(self) -> int:
        return sum(n for f, n in self.fields if f in self.data_fields) // 2

    def code(self, *, chip_rate_hz: float | None = None, subcarrier_hz: float | None = None,
             key: str = "tag") -> BocCode:
        """The BOC line code of the format (optionally with another chip rate / subcarrier).

        Parameters
        ----------
        chip_rate_hz : float or None
            Chip rate R_c [chip/s]; None: the format's.
        subcarrier_hz : float or None
            Subcarrier frequency [Hz]; None: the code's default.
        key : str
            Configuration key named in errors.

        Returns
        -------
        BocCode
            The line code.
        """
        return BocCode(self.chips_per_bit, self.chip_rate_hz if chip_rate_hz is None else chip_rate_hz,
                       subcarrier_hz, key=key)

    @property
    def bit_rate_bps(self) -> float:
        return self.chip_rate_hz / self.chips_per_bit

    @property
    def air_time_s(self) -> float:
        """n_bits·N / R_c [s]."""
        return self.n_bits * self.chips_per_bit / self.chip_rate_hz

    @property
    def packet_period_s(self) -> float:
        return 1.0 / self.packet_rate_hz


PACKET_FORMATS: dict[str, PacketFormat] = {
    "9axis-2d": PacketFormat("9axis-2d", (("header", 3), ("id", 2), ("accel", 6), ("gyro", 6),
                                          ("compass", 6), ("crc", 1)),
                             chips_per_bit=8, chip_rate_hz=4e6, packet_rate_hz=141.0),
    "6axis-1d": PacketFormat("6axis-1d", (("header", 3), ("id", 2), ("accel", 6), ("crc", 1)),
                             chips_per_bit=64, chip_rate_hz=5e6, packet_rate_hz=300.0),
}


#: How the ``9axis-2d`` packet size follows from the source's byte counts (module docstring), as a
#: one-line note for datasets.
PACKET_BITS_NOTE = (
    "packet size from the source's byte counts: the 9axis-2d packet is 3 B header + 2 B ID + 6 B accel + 6 B gyro + "
    "6 B compass + 1 B CRC = 24 B = 192 bit (seed 000 Table 5, L715-L720; 'three-bytes header, two-bytes ID, "
    "18-bytes inertial data, single-byte CRC'), air time 192 x 8 / 4 Mcps = 0.384 ms; the reference pages' "
    "'30 bytes = 240 bit, 0.48 ms' does not follow from those byte counts")


def packet_format(name: str, key: str = "tag.packet_format") -> PacketFormat:
    """The :class:`PacketFormat` called ``name``.

    Parameters
    ----------
    name : str
        Format name, a key of :data:`PACKET_FORMATS`.
    key : str
        Configuration key named in the error.

    Returns
    -------
    PacketFormat
        The format.

    Raises
    ------
    ConfigError
        One line, with a did-you-mean hint, for an unknown name.
    """
    try:
        return PACKET_FORMATS[name]
    except (KeyError, TypeError):
        allowed = "one of " + ", ".join(repr(n) for n in PACKET_FORMATS)
        hint = did_you_mean(name, PACKET_FORMATS) if isinstance(name, str) else ""
        raise ConfigError(key, name, allowed + hint) from None


# ----------------------------------------------------------------------------- CRC-8


def _crc8_table(poly: int) -> np.ndarray:
    """T[b]: the CRC-8 register after shifting byte b through x⁸ + ``poly`` eight times."""
    reg = np.arange(256, dtype=np.int64)
    for _ in range(8):
        reg = np.where(reg & 0x80, (reg << 1) ^ poly, reg << 1) & 0xFF
    return reg.astype(np.uint8)


#: :func:`_crc8_table` by polynomial: a pure function of a config value, not run state
#: (:class:`rfsim.core.memo.PureCache`).
CRC8_TABLE_CACHE = PureCache(_crc8_table, 16)


def crc8(data, *, poly: int = 0x07, init: int = 0x00, xorout: int = 0x00) -> int:
    """Non-reflected CRC-8 of a byte sequence (MSB-first register, table driven).

    ``reg ← T[reg ⊕ byte]`` with T[b] the register after shifting b through x⁸ + poly
    eight times; the result is ``reg ⊕ xorout``. Defaults: CRC-8/SMBUS (check 0xF4).

    Parameters
    ----------
    data : bytes or array_like of uint8
        The bytes.
    poly : int
        Polynomial without the x⁸ term.
    init : int
        Register preset.
    xorout : int
        Final XOR.

    Returns
    -------
    int
        CRC in [0, 255].
    """
    table = CRC8_TABLE_CACHE(int(poly))
    reg = int(init) & 0xFF
    raw = bytes(data) if isinstance(data, (bytes, bytearray)) else np.asarray(data, dtype=np.uint8).tobytes()
    for byte in raw:
        reg = int(table[reg ^ byte])
    return reg ^ (int(xorout) & 0xFF)


# ----------------------------------------------------------------------------- framing


@dataclass(frozen=True)
class Framing:
    """Preamble, CRC-8 and bit/byte order of HIMR packets (module docstring for defaults)."""

    preamble_hex: str = param(DEFAULT_PREAMBLE_HEX, doc="header / preamble bytes (hex, 3 bytes)")
    crc_poly: int = param(0x07, lo=1, hi=255, doc="CRC-8 polynomial without the x^8 term")
    crc_init: int = param(0x00, lo=0, hi=255, doc="CRC-8 register preset")
    crc_xorout: int = param(0x00, lo=0, hi=255, doc="CRC-8 final XOR")
    bit_order: Literal["msb", "lsb"] = param("msb", doc="bit order of each byte on the air")
    word_order: Literal["big", "little"] = param("big", doc="byte order of the int16 words")

    def __post_init__(self):
        check_fields(self, "tag.framing")
        text = self.preamble_hex.replace(" ", "")
        if len(text) != 6 or any(c not in "0123456789abcdefABCDEF" for c in text):
            raise ConfigError("tag.framing.preamble_hex", self.preamble_hex, "6 hex digits (3 bytes)")

    @property
    def preamble_bytes(self) -> bytes:
        return bytes.fromhex(self.preamble_hex.replace(" ", ""))

    def to_bits(self, byte_rows: np.ndarray) -> np.ndarray:
        """Bytes to bits in air order (:attr:`bit_order`).

        Parameters
        ----------
        byte_rows : numpy.ndarray
            ``(..., n_bytes) uint8``.

        Returns
        -------
        numpy.ndarray
            ``(..., 8·n_bytes) uint8`` bits.
        """
        return np.unpackbits(byte_rows, axis=-1, bitorder="big" if self.bit_order == "msb" else "little")

    def to_bytes(self, bit_rows: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_bits`.

        Parameters
        ----------
        bit_rows : numpy.ndarray
            ``(..., 8·n_bytes) uint8`` bits in air order.

        Returns
        -------
        numpy.ndarray
            ``(..., n_bytes) uint8``.
        """
        return np.packbits(bit_rows, axis=-1, bitorder="big" if self.bit_order == "msb" else "little")

    @property
    def preamble_bits(self) -> np.ndarray:
        return self.to_bits(np.frombuffer(self.preamble_bytes, dtype=np.uint8))

    def crc(self, payload: bytes) -> int:
        """CRC-8 of a payload with this framing's polynomial, preset and final XOR (:func:`crc8`).

        Parameters
        ----------
        payload : bytes
            ID and data bytes.

        Returns
        -------
        int
            CRC in [0, 255].
        """
        return crc8(payload, poly=self.crc_poly, init=self.crc_init, xorout=self.crc_xorout)


def _word_dtype(framing: Framing) -> str:
    return ">i2" if framing.word_order == "big" else "<i2"


def build_packets(fmt: PacketFormat, framing: Framing, tag_id: int, words) -> np.ndarray:
    """Bits of P packets: header, tag ID, data words, CRC-8.

    Parameters
    ----------
    fmt : PacketFormat
        The packet layout.
    framing : Framing
        Preamble, CRC and bit/byte order.
    tag_id : int
        0…65535, sent big-endian.
    words : array_like
        ``(P, fmt.n_words)`` int16 (values outside int16 are rejected).

    Returns
    -------
    numpy.ndarray
        ``(P, fmt.n_bits) uint8`` bits in air order.

    Raises
    ------
    ValueError
        For words of the wrong shape or outside int16, or a tag ID outside 0…65535.
    """
    w = np.asarray(words)
    if w.ndim != 2 or w.shape[1] != fmt.n_words:
        raise ValueError(f"words must be (n_packets, {fmt.n_words}), got shape {w.shape}")
    if w.size and (w.min() < -32768 or w.max() > 32767):
        raise ValueError("words must fit in int16")
    if not 0 <= int(tag_id) <= 0xFFFF:
        raise ValueError(f"tag_id must be in [0, 65535], got {tag_id}")
    n = w.shape[0]
    data = np.ascontiguousarray(w.astype(_word_dtype(framing))).view(np.uint8).reshape(n, -1)
    ident = np.tile(np.frombuffer(int(tag_id).to_bytes(2, "big"), dtype=np.uint8), (n, 1))
    payload = np.concatenate([ident, data], axis=1)
    crc = np.array([[framing.crc(row.tobytes())] for row in payload], dtype=np.uint8).reshape(n, 1)
    header = np.tile(np.frombuffer(framing.preamble_bytes, dtype=np.uint8), (n, 1))
    return framing.to_bits(np.concatenate([header, payload, crc], axis=1))


@dataclass(frozen=True)
class ParsedPackets:
    """Fields of P received packets (:func:`parse_packets`).

    ``words`` rows are meaningful only where ``crc_ok``: the IMU words ride in the packet,
    so a packet that fails its CRC loses them together with its RF measurement.
    """

    tag_id: np.ndarray      #: (P,) int64
    words: np.ndarray       #: (P, n_words) int16
    crc_ok: np.ndarray      #: (P,) bool
    header_ok: np.ndarray   #: (P,) bool


def parse_packets(fmt: PacketFormat, framing: Framing, bits) -> ParsedPackets:
    """Inverse of :func:`build_packets` with the CRC and header checks.

    Parameters
    ----------
    fmt : PacketFormat
        The packet layout.
    framing : Framing
        Preamble, CRC and bit/byte order.
    bits : array_like
        ``(P, fmt.n_bits)`` received bits.

    Returns
    -------
    ParsedPackets
        Tag IDs, words, CRC and header checks per packet.

    Raises
    ------
    ValueError
        If the rows do not have ``fmt.n_bits`` bits.
    """
    b = np.atleast_2d(np.asarray(bits, dtype=np.uint8))
    if b.shape[1] != fmt.n_bits:
        raise ValueError(f"{fmt.name} packets have {fmt.n_bits} bits, got {b.shape[1]}")
    by = framing.to_bytes(b)
    n_head = dict(fmt.fields)["header"]
    payload = by[:, n_head:-1]
    crc_ok = np.array([framing.crc(row.tobytes()) == int(c) for row, c in zip(payload, by[:, -1])], dtype=bool)
    header_ok = np.all(by[:, :n_head] == np.frombuffer(framing.preamble_bytes, dtype=np.uint8), axis=1)
    tag_id = payload[:, 0].astype(np.int64) * 256 + payload[:, 1]
    words = np.ascontiguousarray(payload[:, 2:]).view(_word_dtype(framing)).astype(np.int16)
    return ParsedPackets(tag_id=tag_id, words=words, crc_ok=crc_ok, header_ok=header_ok)


__all__ = ["PacketFormat", "PACKET_FORMATS", "PACKET_BITS_NOTE", "packet_format", "crc8", "Framing", "build_packets",
           "ParsedPackets", "parse_packets", "DEFAULT_PREAMBLE_HEX"]

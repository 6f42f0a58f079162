"""Bit-array helpers shared by the Gen2 modules.

A *bit array* in rfsim is a 1-D ``numpy.uint8`` array of 0/1 values, most significant
bit first (the order in which Gen2 sends bits over the air).
"""

from __future__ import annotations

import numpy as np


def as_bits(bits) -> np.ndarray:
    """Validate and return ``bits`` as a contiguous ``(n,) uint8`` array of 0/1.

    Accepts any 1-D sequence of 0/1 (ints, bools) or a string of ``'0'``/``'1'``
    characters (spaces and underscores are ignored).

    Parameters
    ----------
    bits : array_like of int or bool, or str
        1-D sequence of 0/1, MSB first, or a ``'0'``/``'1'`` string.

    Returns
    -------
    numpy.ndarray
        ``(n,) uint8`` contiguous bit array.

    Raises
    ------
    ValueError
        If ``bits`` is not 1-D, not integer/bool, or holds values other than 0 and 1.
    """
    if isinstance(bits, str):
        return str_to_bits(bits)
    if isinstance(bits, np.ndarray) and bits.dtype == np.uint8 and bits.ndim == 1:
        if bits.size and bits.max() > 1:  # the common case: only the range to check
            raise ValueError("bits must contain only 0 and 1")
        return np.ascontiguousarray(bits)
    arr = np.asarray(bits)
    if arr.ndim != 1:
        raise ValueError(f"bits must be 1-D, got shape {arr.shape}")
    if arr.size and not (np.issubdtype(arr.dtype, np.integer) or arr.dtype == bool):
        raise ValueError(f"bits must be integers 0/1, got dtype {arr.dtype}")
    if arr.size and (arr.min() < 0 or arr.max() > 1):
        raise ValueError("bits must contain only 0 and 1")
    return np.ascontiguousarray(arr, dtype=np.uint8)


def int_to_bits(value: int, n_bits: int) -> np.ndarray:
    """``value`` as ``n_bits`` bits, MSB first.

    Parameters
    ----------
    value : int
        Unsigned value to encode.
    n_bits : int
        Number of bits (any length; above 63 bits the value is unpacked byte-wise).

    Returns
    -------
    numpy.ndarray
        ``(n_bits,) uint8`` bit array, MSB first.

    Raises
    ------
    ValueError
        If ``value`` or ``n_bits`` is negative or ``value`` does not fit in ``n_bits`` bits.

    Examples
    --------
    >>> int_to_bits(5, 4).tolist()
    [0, 1, 0, 1]
    """
    value, n_bits = int(value), int(n_bits)
    if n_bits < 0 or value < 0 or value >> n_bits:
        raise ValueError(f"value {value} does not fit in {n_bits} unsigned bits")
    if n_bits <= 63:
        shifts = np.arange(n_bits - 1, -1, -1, dtype=np.int64)
        return ((value >> shifts) & 1).astype(np.uint8)
    # longer words (an EPC): the bytes of the value, big-endian, unpacked MSB first
    n_bytes = (n_bits + 7) // 8
    return np.unpackbits(np.frombuffer(value.to_bytes(n_bytes, "big"), dtype=np.uint8))[8 * n_bytes - n_bits:]


def bits_to_int(bits) -> int:
    """Unsigned integer of an MSB-first bit array.

    Parameters
    ----------
    bits : array_like or str
        Bit array, MSB first (anything :func:`as_bits` accepts).

    Returns
    -------
    int
        Python ``int`` of any length.

    Examples
    --------
    >>> bits_to_int([0, 1, 0, 1])
    5
    """
    arr = as_bits(bits)
    if arr.size <= 32:  # a short word (RN16, handle, field): bit by bit, cheaper than packing
        value = 0
        for b in arr.tolist():
            value = (value << 1) | b
        return value
    # a long word (an EPC): the bits packed MSB first into bytes (the last byte padded with
    # zeros at its end), read as one big-endian integer, less the padding
    return int.from_bytes(np.packbits(arr).tobytes(), "big") >> (-arr.size % 8)


def str_to_bits(text: str) -> np.ndarray:
    """Bits of a ``'0'``/``'1'`` string (spaces and underscores ignored).

    Parameters
    ----------
    text : str
        String of ``'0'``/``'1'`` characters.

    Returns
    -------
    numpy.ndarray
        ``(n,) uint8`` bit array, MSB first.

    Raises
    ------
    ValueError
        If ``text`` holds a character other than 0, 1, space or underscore.
    """
    clean = text.replace(" ", "").replace("_", "")
    if any(c not in "01" for c in clean):
        raise ValueError(f"not a bit string: {text!r}")
    return np.frombuffer(clean.encode("ascii"), dtype=np.uint8) - np.uint8(ord("0"))


def bits_to_str(bits) -> str:
    """``'0'``/``'1'`` string of a bit array.

    Parameters
    ----------
    bits : array_like or str
        Bit array (anything :func:`as_bits` accepts).

    Returns
    -------
    str
        One ``'0'``/``'1'`` character per bit, MSB first.
    """
    return (as_bits(bits) + np.uint8(ord("0"))).tobytes().decode("ascii")


def hex_to_bits(text: str) -> np.ndarray:
    """Bits of a hex string, 4 bits per digit, MSB first (spaces ignored).

    Parameters
    ----------
    text : str
        Hex digits, optionally prefixed ``0x``; spaces and underscores ignored.

    Returns
    -------
    numpy.ndarray
        ``(4 * n_digits,) uint8`` bit array, MSB first.

    Raises
    ------
    ValueError
        If ``text`` is not a hex string.

    Examples
    --------
    >>> bits_to_str(hex_to_bits("3A"))
    '00111010'
    """
    clean = text.replace(" ", "").replace("_", "")
    if clean.lower().startswith("0x"):
        clean = clean[2:]
    try:
        value = int(clean, 16) if clean else 0
    except ValueError:
        raise ValueError(f"not a hex string: {text!r}") from None
    return int_to_bits(value, 4 * len(clean))


def bits_to_hex(bits) -> str:
    """Upper-case hex string of a bit array whose length is a multiple of 4.

    Parameters
    ----------
    bits : array_like or str
        Bit array, MSB first.

    Returns
    -------
    str
        Upper-case hex digits, ``n / 4`` of them (empty for no bits).

    Raises
    ------
    ValueError
        If the bit count is not a multiple of 4.
    """
    arr = as_bits(bits)
    if arr.size % 4:
        raise ValueError(f"bit count {arr.size} is not a multiple of 4")
    return f"{bits_to_int(arr):0{arr.size // 4}X}" if arr.size else ""


__all__ = [
    "as_bits",
    "int_to_bits",
    "bits_to_int",
    "str_to_bits",
    "bits_to_str",
    "hex_to_bits",
    "bits_to_hex",
]

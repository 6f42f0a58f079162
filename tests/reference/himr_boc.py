"""Reference twins of :mod:`rfsim.himr.boc` (the BOC chip train and the per-bit sums in plain NumPy)."""

from __future__ import annotations

import numpy as np

from rfsim.gen2.bits import as_bits
from rfsim.himr._boc_kernels import INDEX_EPS
from rfsim.himr.boc import BocCode, BocDetection, _decide, _train_args


def boc_chips_reference(bits, code: BocCode) -> np.ndarray:
    """Plain-NumPy twin of :func:`rfsim.himr.boc.boc_chips`."""
    p = 2 * as_bits(bits).astype(np.int8) - 1
    k = np.arange(code.chips_per_bit)
    q = np.where((k // code.half_cycle_chips) % 2 == 0, 1, -1).astype(np.int8)
    return (p[:, None] * q[None, :]).ravel()


def boc_train_reference(starts_s, bits, code: BocCode, *, t0_s: float, fs_hz: float, n_samples: int,
                        level_plus: complex = 1.0, level_minus: complex = -1.0,
                        rest: complex = 1.0) -> np.ndarray:
    """Plain-NumPy twin of :func:`rfsim.himr.boc.boc_train`."""
    fs = code.check_fs(fs_hz)
    s0, bits = _train_args(starts_s, bits, t0_s, fs)
    out = np.full(int(n_samples), complex(rest), dtype=np.complex128)
    n = np.arange(int(n_samples))
    for p in range(bits.shape[0]):
        chips = boc_chips_reference(bits[p], code)
        u = (n - s0[p]) * (code.chip_rate_hz / fs)
        k = np.floor(u + INDEX_EPS).astype(np.int64)
        ok = (u + INDEX_EPS >= 0) & (k < chips.size)
        out[ok] = np.where(chips[k[ok]] > 0, complex(level_plus), complex(level_minus))
    return out


def boc_bit_sums_reference(r, start_sample: float, code: BocCode, *, fs_hz: float, n_bits: int):
    """Plain-NumPy twin of :func:`rfsim.himr.boc.boc_bit_sums`."""
    fs = code.check_fs(fs_hz)
    r = np.asarray(r, dtype=np.complex128)
    n = np.arange(r.size)
    u = (n - float(start_sample)) * (code.chip_rate_hz / fs)
    k = np.floor(u + INDEX_EPS).astype(np.int64)
    i = k // code.chips_per_bit
    ok = (u + INDEX_EPS >= 0) & (i < n_bits)
    q = np.where(((k % code.chips_per_bit) // code.half_cycle_chips) % 2 == 0, 1.0, -1.0)
    i, q, x = i[ok], q[ok], r[ok]
    return (np.bincount(i, weights=(x * q).real, minlength=n_bits)
            + 1j * np.bincount(i, weights=(x * q).imag, minlength=n_bits),
            np.bincount(i, weights=q, minlength=n_bits),
            np.bincount(i, minlength=n_bits).astype(np.int64),
            np.bincount(i, weights=x.real, minlength=n_bits) + 1j * np.bincount(i, weights=x.imag,
                                                                                 minlength=n_bits),
            np.bincount(i, weights=np.abs(x) ** 2, minlength=n_bits))


def boc_decode_reference(r, *, code: BocCode, fs_hz: float, n_bits: int, start_sample: float,
                         preamble_bits=()) -> BocDetection:
    """:func:`rfsim.himr.boc.boc_decode` on the NumPy twin of the bit sums."""
    pre = as_bits(preamble_bits) if len(preamble_bits) else np.zeros(0, np.uint8)
    return _decide(boc_bit_sums_reference(r, start_sample, code, fs_hz=fs_hz, n_bits=n_bits), pre)


__all__ = ["boc_chips_reference", "boc_train_reference", "boc_bit_sums_reference", "boc_decode_reference"]

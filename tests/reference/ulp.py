"""Comparison by units in the last place (ULP): the numerical contract between a kernel and its
reference twin when the two do not perform the same exactly-rounded arithmetic.

Why ULP and not bits: numba calls the C library's ``log``/``exp``/``sin`` (``math.log``) while
NumPy may take a SIMD path (AVX-512 ``np.log``); both are faithfully rounded (≤ 1 ULP from the
exact value, IEEE 754 does not require correct rounding of transcendental functions), so the two
may differ by 1 ULP per call, and a chain of k such operations by up to ≈ k ULP after rounding of
the arithmetic between them. Bit identity is kept only where both sides do the same integer or
exactly-rounded arithmetic (CRC, bit packing, RNG streams, a dataset before/after a pure refactor).

Bounds used in the tests are derived where they are used, e.g. ``log`` then ``exp`` (two
faithfully rounded calls, each ≤ 1 ULP, the error of the first amplified by at most |x·f'/f|
of the second): ≤ 8 ULP.
"""

from __future__ import annotations

import numpy as np


def ulp_distance(a, b) -> np.ndarray:
    """Number of representable float64 (or float32) values between ``a`` and ``b``, elementwise.

    Uses the ordered integer image of IEEE 754 floats (sign-magnitude mapped to two's
    complement), so the distance is exact across zero and across binades; NaN against NaN is 0,
    NaN against a number is the largest integer. Complex inputs: the larger of the real-part and
    imaginary-part distances.
    """
    a = np.asarray(a)
    b = np.asarray(b)
    if np.iscomplexobj(a) or np.iscomplexobj(b):
        a = np.asarray(a, dtype=np.result_type(a, b, np.complex64))
        b = np.asarray(b, dtype=a.dtype)
        return np.maximum(ulp_distance(a.real, b.real), ulp_distance(a.imag, b.imag))
    dtype = np.result_type(a, b, np.float32)
    a = np.asarray(a, dtype=dtype)
    b = np.asarray(b, dtype=dtype)
    itype = np.int64 if dtype == np.float64 else np.int32
    ia = a.view(itype).astype(np.int64)
    ib = b.view(itype).astype(np.int64)
    lo = np.iinfo(itype).min
    ia = np.where(ia < 0, lo - ia, ia)
    ib = np.where(ib < 0, lo - ib, ib)
    d = np.abs(ia - ib).astype(np.uint64)
    both_nan = np.isnan(a) & np.isnan(b)
    one_nan = np.isnan(a) ^ np.isnan(b)
    d = np.where(both_nan, np.uint64(0), d)
    return np.where(one_nan, np.uint64(np.iinfo(np.int64).max), d)


def assert_close_ulp(actual, desired, max_ulp: int, *, atol: float = 0.0, err_msg: str = "") -> None:
    """Assert ``actual`` and ``desired`` agree within ``max_ulp`` units in the last place.

    Parameters
    ----------
    actual, desired : array_like, float or complex
        Same shape (broadcasting is not applied).
    max_ulp : int
        Largest allowed ULP distance (:func:`ulp_distance`); derive it in a comment where used.
    atol : float, optional
        Elements with ``|actual - desired| <= atol`` pass whatever their ULP distance: for results
        formed by cancellation near zero, where a relative bound has no meaning. Default 0.
    """
    actual = np.asarray(actual)
    desired = np.asarray(desired)
    assert actual.shape == desired.shape, f"shapes differ: {actual.shape} vs {desired.shape} {err_msg}"
    d = ulp_distance(actual, desired)
    if atol > 0:
        d = np.where(np.abs(actual - desired) <= atol, np.uint64(0), d)
    worst = int(d.max()) if d.size else 0
    if worst > max_ulp:
        k = np.unravel_index(int(np.argmax(d)), d.shape)
        raise AssertionError(f"{int((d > max_ulp).sum())} of {d.size} elements differ by more than {max_ulp} ULP "
                             f"(worst {worst} ULP at {k}: {actual[k]!r} vs {desired[k]!r}) {err_msg}")


__all__ = ["ulp_distance", "assert_close_ulp"]

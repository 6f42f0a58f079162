"""The ULP contract itself (:mod:`reference.ulp`) against values whose distance is known by
construction of the IEEE 754 format (``np.nextafter``), not by the helper."""

import numpy as np
import pytest

from reference.ulp import assert_close_ulp, ulp_distance


def test_distance_counts_representable_values():
    x = np.array([1.0, -2.5, 1e-300, 0.0, 3.0e5])
    y = x.copy()
    for _ in range(3):
        y = np.nextafter(y, np.inf)
    np.testing.assert_array_equal(ulp_distance(x, y), [3, 3, 3, 3, 3])


def test_distance_across_zero_counts_both_signs():
    tiny = np.nextafter(0.0, 1.0)  # smallest subnormal
    assert ulp_distance(tiny, -tiny) == 2
    assert ulp_distance(0.0, -0.0) == 0


def test_complex_takes_the_worse_part():
    z = np.array([1 + 1j])
    w = np.array([np.nextafter(1.0, 2.0) + 1j * np.nextafter(np.nextafter(1.0, 2.0), 2.0)])
    assert ulp_distance(z, w)[0] == 2


def test_assert_fails_beyond_the_bound_and_passes_within():
    x = np.linspace(0.5, 2.0, 7)
    y = np.nextafter(np.nextafter(x, 3.0), 3.0)
    assert_close_ulp(x, y, 2)
    with pytest.raises(AssertionError, match="more than 1 ULP"):
        assert_close_ulp(x, y, 1)


def test_nan_against_number_fails():
    with pytest.raises(AssertionError):
        assert_close_ulp(np.array([np.nan]), np.array([1.0]), 100)
    assert_close_ulp(np.array([np.nan]), np.array([np.nan]), 0)

"""The bit-array helpers of rfsim.gen2.bits against Python's own integer parsing."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.core.rng import trial_rng
from rfsim.gen2.bits import bits_to_int


@pytest.mark.parametrize("n_bits", [0, 1, 7, 8, 9, 16, 31, 32, 33, 63, 64, 65, 96, 127, 128, 129, 496])
def test_bits_to_int_equals_python_base_2_parsing(n_bits):
    """Every length around the short-word bound (32) and byte bounds: the value equals
    ``int(digits, 2)`` of the same bits, MSB first, all zeros and all ones included."""
    rng = trial_rng(7, n_bits)
    cases = [rng.integers(0, 2, n_bits).astype(np.uint8) for _ in range(20)]
    cases += [np.zeros(n_bits, np.uint8), np.ones(n_bits, np.uint8)]
    for bits in cases:
        expected = int("".join(str(b) for b in bits.tolist()), 2) if n_bits else 0
        assert bits_to_int(bits) == expected
    if n_bits:
        assert bits_to_int(np.ones(n_bits, np.uint8)) == 2**n_bits - 1


def test_bits_to_int_rejects_values_other_than_0_and_1():
    with pytest.raises(ValueError, match="only 0 and 1"):
        bits_to_int(np.array([0, 2] + [1] * 40, np.uint8))

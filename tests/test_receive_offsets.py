"""The offsets the receive kernels take off the samples as they read them.

The reader's receive kernel does not form the DC-removed copy r = rx − dc of its whole window:
the half-bit sums, the known levels and the measurement read rx and subtract dc (and the
measurement then c) themselves. Each must return, bit for bit, what it returns on the array
with the offset taken off beforehand by NumPy (the same componentwise subtraction); and an
offset of 0 must change nothing (x − 0 is x, −0 included).
"""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.gen2._linecode_kernels import signed_halfbit_sums_kernel
from rfsim.gen2._measure_kernels import known_levels_kernel, measure_kernel


def _samples(rng, n):
    z = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    z[3] = complex(-0.0, 0.0)  # signed zeros and an exact offset-sized sample
    z[4] = complex(0.0, -0.0)
    z[5] = 0.3 - 0.2j
    return z


def _levels(rng, n, pad):
    """±1 runs of 3 to 7 samples, zeros on ``pad`` samples at either end."""
    s = np.zeros(n)
    i, v = pad, 1.0
    while i < n - pad:
        k = int(rng.integers(3, 8))
        s[i:min(i + k, n - pad)] = v
        v = -v
        i += k
    return s


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("d", [0.3 - 0.2j, 0j])
def test_measure_offset_d_is_subtracting_first(seed, d):
    rng = np.random.default_rng(seed)
    z = _samples(rng, 900)
    s = _levels(rng, 900, 20)
    c = 0.05 + 0.01j
    got = measure_kernel(z, s, 2.0e6, 8, c, d)
    want = measure_kernel(z - d, s, 2.0e6, 8, c)
    assert np.array(got).tobytes() == np.array(want).tobytes()
    if d == 0j:
        assert np.array(measure_kernel(z, s, 2.0e6, 8, c)).tobytes() == np.array(got).tobytes()


@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("dc", [0.3 - 0.2j, 0j])
def test_known_levels_offset_is_subtracting_first(seed, dc):
    rng = np.random.default_rng(seed)
    n = 700
    r = _samples(rng, n)
    full = _levels(rng, n, 60)
    t0 = 60.0
    out_a, lev_a = np.empty(n, np.complex128), np.empty(n)
    out_b, lev_b = np.empty(n, np.complex128), np.empty(n)
    ka = known_levels_kernel(r, full, t0, 0.4, 12, out_a, lev_a, dc)
    kb = known_levels_kernel(r - dc, full, t0, 0.4, 12, out_b, lev_b)
    assert ka == kb and ka > 100
    assert out_a[:ka].tobytes() == out_b[:kb].tobytes()
    assert lev_a[:ka].tobytes() == lev_b[:kb].tobytes()


@pytest.mark.parametrize("m", [1, 2, 4, 8])
@pytest.mark.parametrize("dc", [0.3 - 0.2j, 0j])
def test_signed_halfbit_sums_offset_is_subtracting_first(m, dc):
    rng = np.random.default_rng(m)
    part = _samples(rng, 1200)
    nh = 40
    sa, ca = np.empty(nh, np.complex128), np.empty(nh)
    sb, cb = np.empty(nh, np.complex128), np.empty(nh)
    signed_halfbit_sums_kernel(part, 0.375, 0.61, m, sa, ca, dc)
    signed_halfbit_sums_kernel(part - dc, 0.375, 0.61, m, sb, cb)
    assert sa.tobytes() == sb.tobytes()
    assert ca.tobytes() == cb.tobytes()
    assert np.count_nonzero(ca) > nh // 2

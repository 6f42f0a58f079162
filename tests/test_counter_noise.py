"""The counter-based normal generator (:mod:`rfsim.air._counter_noise_kernels`,
:func:`rfsim.air.noise.add_counter_awgn`): its kernels against their NumPy twin, its elementary
functions against NumPy's, the distribution of its draws, and the stream rules (a sample's
noise depends only on the key and its index)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from rfsim.air import _counter_noise_kernels as k
from rfsim.air.noise import add_counter_awgn, counter_normals, noise_key
from reference.counter_noise import cos_sin_octant, log_unit, normal_pairs
from reference.ulp import assert_close_ulp

KEY = 0x0123456789ABCDEF


@pytest.mark.parametrize("key, first_pair, n", [(KEY, 0, 2), (KEY, 7, 10), (2**64 - 1, 2**40, 4096), (0, 0, 6014)])
def test_normals_equal_the_numpy_twin_bit_for_bit(key, first_pair, n):
    # the same integer arithmetic and the same exactly rounded float operations in the same order
    got = counter_normals(key, n, first_pair=first_pair)
    a, b = normal_pairs(key, np.arange(first_pair, first_pair + n // 2, dtype=np.uint64))
    want = np.empty(n)
    want[0::2], want[1::2] = a, b
    assert np.array_equal(got, want)


@pytest.mark.parametrize("n, start", [(k.BLOCK - 1, 0), (k.BLOCK, 1), (2 * k.BLOCK + 7, 3), (3 * k.BLOCK + 2, k.BLOCK + 1)])
def test_added_noise_equals_the_numpy_twin_across_blocks(n, start):
    # the kernel draws blocks of BLOCK pairs in stages (quarters and halves interleaved, their
    # remainders after): every sample, whatever its place in a block, gets its own pair;
    # √(N/2) = 1 and 0 + x = x exactly, so the noise added to zeros is the twin's pair itself
    y = np.zeros((2, n), dtype=np.complex128)
    add_counter_awgn(y, 2.0, KEY, start=start)
    pairs = (np.arange(2)[:, None] * n + np.arange(start, n)[None, :]).reshape(-1).astype(np.uint64)
    a, b = normal_pairs(KEY, pairs)
    assert np.array_equal(y[:, start:].reshape(-1).real, a) and np.array_equal(y[:, start:].reshape(-1).imag, b)


def test_log_matches_numpy_within_a_few_ulp():
    # ln u = e·ln2_hi + (2s + (2s·s²·p + e·ln2_lo)): e·ln2_hi is exact (ln2_hi has 21 trailing
    # zero bits, |e| ≤ 53); s = (m−1)/(m+1) rounds once (≤ ½ ULP of s, carried into 2s), the
    # series term (≤ 1 % of 2s) carries a few ULP of its own (≤ 0.04 ULP of the sum), and the
    # two outer additions round once each: ≤ 2 ULP from the exact value, NumPy's log ≤ 1 ULP:
    # ≤ 3 ULP apart; where the sum cancels (u near 1/√2·2^e boundaries never cancels, near u = 1
    # e = 0) the bound is relative to the result itself
    rng = np.random.default_rng(1)
    u = np.concatenate([rng.random(200_000), 2.0 ** -rng.uniform(0, 52, 200_000), [2.0 ** -52, 0.5, 1.0]])
    u = u[u >= 2.0 ** -52]
    assert_close_ulp(log_unit(u), np.log(u), 3)


def test_cos_sin_match_numpy_within_a_few_ulp():
    # Horner sums of positive-then-alternating terms on [0, π/4]: each of ≤ 9 steps rounds once,
    # the leading terms dominate (1 and φ), so the result is within 2 ULP of the exact value;
    # NumPy's cos/sin are within 1 ULP: ≤ 3 ULP apart
    phi = np.random.default_rng(2).random(400_000) * (math.pi / 4)
    c, s = cos_sin_octant(phi)
    assert_close_ulp(c, np.cos(phi), 3)
    assert_close_ulp(s, np.sin(phi), 3)


N = 1 << 22


@pytest.fixture(scope="module")
def draws():
    return counter_normals(KEY, N)


def test_moments(draws):
    # standard errors for n draws of N(0, 1): mean 1/√n, variance √(2/n), skewness √(6/n),
    # excess kurtosis √(24/n); 5 standard errors (two-sided p ≈ 6e-7 each)
    n = draws.size
    assert abs(draws.mean()) < 5 / math.sqrt(n)
    assert abs(draws.var() - 1.0) < 5 * math.sqrt(2 / n)
    assert abs(stats.skew(draws)) < 5 * math.sqrt(6 / n)
    assert abs(stats.kurtosis(draws)) < 5 * math.sqrt(24 / n)


def test_kolmogorov_smirnov(draws):
    assert stats.kstest(draws, "norm").pvalue > 1e-4


@pytest.mark.parametrize("x", [2.0, 3.0, 4.0])
def test_tails(draws, x):
    # the count beyond ±x is binomial(n, p), p = 2·Q(x): within 5 standard deviations
    p = math.erfc(x / math.sqrt(2))
    expected = draws.size * p
    assert abs(np.count_nonzero(np.abs(draws) > x) - expected) < 5 * math.sqrt(expected * (1 - p))


def test_pairs_independent(draws):
    # the two normals of a pair (one radius, cos and sin) are uncorrelated, as are neighbours
    a, b = draws[0::2], draws[1::2]
    n = a.size
    assert abs(np.mean(a * b)) < 5 / math.sqrt(n)
    assert abs(np.mean(a[1:] * a[:-1])) < 5 / math.sqrt(n)
    assert abs(np.mean(a * b * b) - 0.0) < 5 * math.sqrt(3 / n)
    # and the squared pair radius is χ²(2), i.e. exponential with mean 2
    r2 = a * a + b * b
    assert stats.kstest(r2, "expon", args=(0, 2)).pvalue > 1e-4


def test_streams_of_different_keys_are_uncorrelated():
    a = counter_normals(KEY, 1 << 18)
    b = counter_normals(KEY + 1, 1 << 18)
    assert abs(np.mean(a * b)) < 5 / math.sqrt(a.size)
    # a key one counter step further (k + γ) is the same sequence shifted by one hash: the
    # documented overlap of additive keys; random 64-bit keys make it unlikely (kernel docstring)
    c = counter_normals(KEY + int(k.GAMMA), 4)
    assert k.splitmix(np.uint64(KEY + int(k.GAMMA)), np.uint64(0)) == k.splitmix(np.uint64(KEY), np.uint64(1))
    assert not np.array_equal(c, a[:4])


def test_a_sample_gets_the_same_noise_whichever_samples_are_drawn():
    n = 1000
    full = np.zeros((3, n), dtype=np.complex128)
    add_counter_awgn(full, 2.0, KEY)
    part = np.zeros((3, n), dtype=np.complex128)
    add_counter_awgn(part, 2.0, KEY, start=377)
    assert np.array_equal(part[:, 377:], full[:, 377:])
    assert not part[:, :377].any()
    row = np.zeros(n, dtype=np.complex128)
    add_counter_awgn(row, 2.0, KEY)
    assert np.array_equal(row, full[0])
    # sample i of row b is pair b·n + i of the stream, scaled by √(N/2) = 1
    ab = counter_normals(KEY, 2 * 3 * n)
    assert np.array_equal(full.reshape(-1).real, ab[0::2]) and np.array_equal(full.reshape(-1).imag, ab[1::2])


def test_noise_key_is_one_draw_of_the_generator():
    r1, r2 = np.random.default_rng(5), np.random.default_rng(5)
    key = noise_key(r1)
    assert key == int(r2.integers(0, 2**64, dtype=np.uint64))
    assert r1.bit_generator.state == r2.bit_generator.state


def test_noise_key_equals_the_generators_integers_after_any_draws():
    # the PCG64 shortcut (the raw 64-bit output) against NumPy's full-range integers, after draws
    # that leave a buffered 32-bit half or a used normal in the generator; and another bit generator
    for make in (lambda: np.random.default_rng(11), lambda: np.random.Generator(np.random.MT19937(11))):
        r1, r2 = make(), make()
        for draw in (lambda r: None, lambda r: r.integers(0, 7, dtype=np.uint32),
                     lambda r: r.standard_normal(3), lambda r: r.random()):
            draw(r1), draw(r2)
            keys = [noise_key(r1) for _ in range(4)]
            assert keys == [int(r2.integers(0, 2**64, dtype=np.uint64)) for _ in range(4)]
            assert np.array_equal(r1.integers(0, 2**63, size=5), r2.integers(0, 2**63, size=5))

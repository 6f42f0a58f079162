"""The steps the tag-reply decoders share (rfsim.gen2.reply_core and its kernels), each against
a closed form or a construction whose answer is known without the code under test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.gen2._reply_core_kernels import (blf_resolution, centred_start, cumulative_sums_into, fine_step,
                                            halfbit_decisions, normalised_correlation, parabola_offset,
                                            preamble_gain_offset, rest_level_sums, steady_residual)
from rfsim.gen2.linecode import FM0_PREAMBLE, preamble_state, reply_waveform
from rfsim.gen2.reply_core import (coarse_blf_step, geometric_blf_grid_hz, n_pre_elements, n_reply_elements,
                                   preamble_template0)


@pytest.mark.parametrize("m, trext, n_pre", [(1, False, 12), (1, True, 36), (2, False, 40), (4, True, 176)])
def test_element_counts_and_coarse_step(m, trext, n_pre):
    """FM0: 6 preamble symbols = 12 elements, TRext adds 12 data-0 (24 elements); Miller-M: a
    pilot of 4·M or 16·M subcarrier cycles (4 or 16 bit periods) and 6 preamble bits, 2·M
    elements per bit (anchors §4.2)."""
    assert n_pre_elements(m, trext) == n_pre
    assert n_reply_elements(16, m, trext) == n_pre + 2 * m * 17
    assert coarse_blf_step(m, trext) == 1.0 / (2 * n_pre)


def test_geometric_grid_spans_the_range_in_equal_ratios():
    grid = geometric_blf_grid_hz(200e3, 300e3, 0.01)
    assert grid[0] == pytest.approx(200e3) and grid[-1] == pytest.approx(300e3)
    ratios = grid[1:] / grid[:-1]
    assert np.allclose(ratios, ratios[0]) and ratios[0] <= 1.01
    assert grid.size == math.ceil(math.log(1.5) / math.log(1.01)) + 1


def test_preamble_template0_is_the_zero_mean_fm0_preamble():
    """At 4 samples per element the FM0 preamble is its half-bit levels repeated 4 times."""
    t = preamble_template0(1, False, 100e3, 800e3, 48)
    expected = np.repeat(FM0_PREAMBLE.astype(float), 4)
    np.testing.assert_allclose(t, expected - expected.mean(), atol=1e-15)


@pytest.mark.parametrize("grouped", [True, False])
def test_cumulative_sums(grouped):
    """Both groupings of |r|² are running sums of |r|² (to rounding); Σr exact on integers."""
    rng = np.random.default_rng(3)
    r = rng.integers(-50, 50, 200) + 1j * rng.integers(-50, 50, 200)
    c_re, c_im, p2 = (np.empty(201) for _ in range(3))
    cumulative_sums_into(r.astype(np.complex128), c_re, c_im, p2, grouped)
    np.testing.assert_array_equal(c_re[1:], np.cumsum(r.real))
    np.testing.assert_array_equal(c_im[1:], np.cumsum(r.imag))
    np.testing.assert_array_equal(p2[1:], np.cumsum(r.real ** 2 + r.imag ** 2))  # integers: exact either way
    assert c_re[0] == c_im[0] == p2[0] == 0.0


def test_normalised_correlation_of_a_scaled_offset_template_is_one():
    t = np.array([1.0, 1.0, -1.0, 1.0, -1.0, -1.0])
    t0 = t - t.mean()
    z = (0.3 - 0.2j) * t + (2.0 + 1.0j)
    acc = np.sum(z * t0)
    c = normalised_correlation(acc.real, acc.imag, math.sqrt(np.sum(t0 * t0)), float(np.sum(np.abs(z) ** 2)),
                               z.sum().real, z.sum().imag, t.size)
    assert c == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("vertex", [-0.4, 0.0, 0.25])
def test_parabola_offset_finds_the_vertex(vertex):
    c = [1.0 - 0.1 * (x - vertex) ** 2 for x in (-1, 0, 1)]
    assert parabola_offset(*c) == pytest.approx(vertex, abs=1e-12)
    assert parabola_offset(0.1, 0.0, 0.1) == 0.0  # curving upwards: no vertex to move to


def test_centred_start():
    """Preamble of 12 elements at 0.5 elements per sample centred on sample 100: starts at 88,
    12/0.5 = 24 samples inside it; a reply of 50 elements needs 100 + 2 samples from there."""
    assert centred_start(100.0, 12, 50, 0.5, 190) == (True, 88.0, 24)
    assert centred_start(100.0, 12, 50, 0.5, 189)[0] is False
    assert centred_start(5.0, 12, 50, 0.5, 1000)[0] is False


def test_fine_step_and_blf_resolution():
    assert fine_step(0.02, 4, 0.001) == (0.005, 4)
    assert fine_step(0.004, 4, 0.002) == (0.002, 2)
    assert blf_resolution(125) == 0.002


def test_preamble_gain_offset_recovers_h_and_c():
    t = np.repeat(FM0_PREAMBLE.astype(float), 3)
    h, c = 0.02 - 0.05j, 0.7 + 0.1j
    r = np.concatenate([np.zeros(5), h * t + c, np.zeros(5)]).astype(np.complex128)
    h_est, c_est = preamble_gain_offset(r, 5, t, t.mean(), t.size, complex(np.mean(r[5:5 + t.size])))
    assert h_est == pytest.approx(h, abs=1e-15) and c_est == pytest.approx(c, abs=1e-15)


@pytest.mark.parametrize("viterbi", [True, False])
def test_halfbit_decisions_decode_clean_fm0_sums(viterbi):
    """Half-bit sums of a clean FM0 reply (its levels) decode to its bits."""
    bits = np.array([1, 0, 0, 1, 1, 0, 1, 0], dtype=np.uint8)
    s = reply_waveform(bits, m=1, trext=False, blf_hz=1.0, fs_hz=2.0)  # one sample per element
    sums = s[: FM0_PREAMBLE.size + 2 * (bits.size + 1)]
    out = np.empty(bits.size + 1, dtype=np.uint8)
    halfbit_decisions(sums, FM0_PREAMBLE.size, False, preamble_state(m=1, trext=False), viterbi,
                      np.empty(out.size), np.empty(out.size), out)
    np.testing.assert_array_equal(out[:-1], bits)
    assert out[-1] == 1  # the dummy 1


def test_rest_level_sums_and_steady_residual():
    ref = np.array([0.0, 0.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, 0.0, 0.0])
    r = np.arange(10) + 1j * np.arange(10)[::-1]
    ss, s1, rs, r1 = rest_level_sums(r, ref.copy(), 10, False)
    v = np.where(ref == 0, -1.0, ref)
    assert (ss, s1) == (10.0, float(v.sum())) and rs == pytest.approx(np.sum(r * v)) and r1 == r.sum()
    written = ref.copy()
    rest_level_sums(r, written, 10, True)
    np.testing.assert_array_equal(written, v)
    # steady samples of v: both neighbours at the same level → n = 3, 6, 7, 8 (within 1 … 8)
    acc, cnt = steady_residual(r, v, 2.0 + 0j, 1.0 + 0j, 1, 9)
    expected = sum(abs(r[n] - 1.0 - 2.0 * v[n]) ** 2 for n in (3, 6, 7, 8))
    assert cnt == 4 and acc == pytest.approx(expected)

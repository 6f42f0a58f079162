"""FM0/Miller encoders (PASS golden sequences), sampled replies at any fs, and the
bit-by-bit / Viterbi decoders (clean, noisy, BER vs theory, kernels vs NumPy twins)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.io import loadmat
from scipy.stats import norm

from rfsim.bench.linecode import benchmark_linecode
from rfsim.gen2 import _linecode_kernels as K
from rfsim.gen2.link import PROFILES, backscatter_duration_s
from rfsim.gen2.linecode import (decode_reply, elements_of_levels, halfsymbols, preamble_levels, preamble_state,
                                 reply_duration_s, reply_waveform, reply_waveform_for_profile)
from rfsim.core.rng import trial_rng
from reference.gen2_linecode import (_elements, _state_index, decode_reply_reference, fm0_levels_reference,
                                     halfbit_sums_reference, miller_levels_reference, reply_waveform_reference)

CODES = [("fm0", 1, 2), ("miller2", 2, 3), ("miller4", 4, 3), ("miller8", 8, 3)]


# ----------------------------------------------------------------- golden: PASS tag_encoding


def test_pass_tag_encoding_all_56(reference_data):
    """Column i of each table encodes the binary of i (2 bits FM0, 3 bits Miller, MSB first),
    as ±1 half-subcarrier elements incl. pilot, preamble and dummy-1."""
    m = loadmat(reference_data / "pass-selftest" / "results_tag_encoding.mat", squeeze_me=True,
                struct_as_record=False)
    n = 0
    for name, mm, nb in CODES:
        for trext in (0, 1):
            table = getattr(getattr(m["results"], name), f"trext{trext}")
            for i in range(table.shape[1]):
                bits = [(i >> (nb - 1 - j)) & 1 for j in range(nb)]
                assert np.array_equal(halfsymbols(bits, m=mm, trext=bool(trext)), table[:, i]), (name, trext, i)
                n += 1
    assert n == 56


def test_preamble_lengths_match_link_module():
    """Reply durations agree with the independent formula in rfsim.gen2.link."""
    for m in (1, 2, 4, 8):
        for trext in (False, True):
            assert reply_duration_s(16, m=m, trext=trext, blf_hz=40e3) == pytest.approx(
                backscatter_duration_s(16, blf_hz=40e3, m=m, trext=trext), rel=1e-12)


def test_level_kernels_equal_reference():
    """The table-driven encoder gives the levels and final state of the rules written out."""
    bits = np.random.default_rng(0).integers(0, 2, 300).astype(np.uint8)
    for cur in (-1, 1):
        out = np.empty(600, dtype=np.int8)
        last = K.levels_kernel(bits, 1, (0 if cur == 1 else 1), out)
        ref, ref_last = fm0_levels_reference(bits, cur)
        assert np.array_equal(out, ref) and K.LEVEL_OF_STATE[last] == ref_last
        for prev in (0, 1):
            for m in (2, 4, 8):
                last = K.levels_kernel(bits, m, (0 if cur == 1 else 1) + 2 * prev, out)
                ref, rc, rp = miller_levels_reference(bits, cur, prev)
                assert np.array_equal(out, ref)
                assert (K.LEVEL_OF_STATE[last], K.PREV_BIT_OF_STATE[last]) == (rc, rp)


@pytest.mark.parametrize("m", [1, 2, 4, 8])
def test_elements_of_levels_equal_reference(m):
    """Each level held for M elements, the odd ones inverted for Miller (the NumPy twin)."""
    levels = np.where(np.random.default_rng(m).integers(0, 2, 50) == 1, 1, -1).astype(np.int8)
    assert np.array_equal(elements_of_levels(levels, m), _elements(levels, m))
    assert np.array_equal(elements_of_levels(levels, m, np.float64), _elements(levels, m).astype(np.float64))


@pytest.mark.parametrize("m", [1, 2, 4, 8])
@pytest.mark.parametrize("trext", [False, True])
def test_preamble_state_is_the_state_after_the_preamble(m, trext):
    """The encoder state after pilot + preamble: FM0 ends on level +1; Miller ends the preamble
    ``010111`` on a data-1 (previous bit 1) at the level its encoding leaves."""
    _, level, prev = preamble_levels(m=m, trext=trext)
    assert preamble_state(m=m, trext=trext) == _state_index(level, prev, m > 1)
    if m == 1:
        assert (level, prev) == (1, 0)
    else:
        assert prev == 1


@pytest.mark.parametrize("miller", [False, True])
def test_transition_tables_follow_the_rules(miller):
    """Every entry of the tables against the rules as text: FM0 inverts at each boundary and
    mid-bit for data-0; Miller inverts mid-bit for data-1 and at the boundary of two data-0s."""
    code = K.MILLER if miller else K.FM0
    for state in range(K.N_STATES if miller else 2):
        level, prev = (1 if state % 2 == 0 else -1), state // 2
        for bit in (0, 1):
            first, second = (int(v) for v in K.HALF_LEVELS[code, state, bit])
            if miller:
                assert first == (-level if (bit == 0 and prev == 0) else level)
                assert second == (-first if bit == 1 else first)
            else:
                assert first == -level
                assert second == (first if bit == 1 else -first)
            nxt = int(K.NEXT_STATE[code, state, bit])
            assert K.LEVEL_OF_STATE[nxt] == second
            assert K.PREV_BIT_OF_STATE[nxt] == (bit if miller else 0)


# ----------------------------------------------------------------- sampled waveform


@pytest.mark.parametrize("m", [1, 2, 4, 8])
def test_waveform_integer_oversampling_is_repeat(m):
    """At 8 samples per element and t0 = 0 the waveform is each element repeated 8 times."""
    bits = np.random.default_rng(m).integers(0, 2, 40)
    s = reply_waveform(bits, m=m, trext=True, blf_hz=250e3, fs_hz=4e6)
    assert np.array_equal(s, np.repeat(halfsymbols(bits, m=m, trext=True), 8).astype(float))


@pytest.mark.parametrize("fs_hz, blf_hz, t0_s", [(1.0e6, 40e3, 0.0), (3.7e6, 320e3, 1.234e-5),
                                                  (2.0e6, 256e3 * 1.013, 7e-7)])
def test_waveform_no_drift_and_reference(fs_hz, blf_hz, t0_s):
    """Non-integer samples per element: every element starts at the first sample at or after
    its exact time t0 + k/(2·BLF) (no cumulative drift); kernel == NumPy twin."""
    bits = np.random.default_rng(2).integers(0, 2, 500)
    el = halfsymbols(bits, m=2, trext=False)
    s = reply_waveform(bits, m=2, trext=False, blf_hz=blf_hz, fs_hz=fs_hz, t0_s=t0_s, n_samples=None)
    assert np.array_equal(s, reply_waveform_reference(bits, m=2, trext=False, blf_hz=blf_hz, fs_hz=fs_hz, t0_s=t0_s))
    n = np.arange(s.size)
    k = np.floor((n / fs_hz - t0_s) * 2 * blf_hz + 1e-6).astype(int)  # independent, eps-tolerant
    inside = (n / fs_hz >= t0_s) & (k < el.size)
    exact = np.abs((n / fs_hz - t0_s) * 2 * blf_hz - np.round((n / fs_hz - t0_s) * 2 * blf_hz)) > 1e-6
    assert np.array_equal(s[inside & exact], el[k[inside & exact]].astype(float))
    assert np.all(s[~inside] == 0)
    assert s.size == math.ceil((t0_s + el.size / (2 * blf_hz)) * fs_hz)


def test_waveform_for_profile():
    prof = PROFILES["miller4-320k"]
    s = reply_waveform_for_profile([1, 0, 1], prof, fs_hz=prof.blf_hz * 16)
    assert np.array_equal(s, np.repeat(halfsymbols([1, 0, 1], m=4, trext=False), 8).astype(float))


# ----------------------------------------------------------------- decoders


def _channel(s, rng, *, gain, dc, lead, tail, sigma):
    r = np.concatenate([np.zeros(lead), gain * s, np.zeros(tail)]) + dc
    if sigma:
        r = r + sigma / math.sqrt(2) * (rng.standard_normal(r.size) + 1j * rng.standard_normal(r.size))
    return r


@pytest.mark.parametrize("m", [1, 2, 4, 8])
@pytest.mark.parametrize("trext", [False, True])
@pytest.mark.parametrize("method", ["viterbi", "bitwise"])
def test_decode_clean_unknown_gain_dc_start(m, trext, method):
    rng = trial_rng(11, m, trext)
    bits = rng.integers(0, 2, 128).astype(np.uint8)
    blf, fs = 64e3, 64e3 * 2 * 5.37
    s = reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=3.1e-5)
    r = _channel(s, rng, gain=2e-3 * np.exp(2.5j), dc=0.4 - 0.9j, lead=333, tail=50, sigma=0)
    kw = dict(n_bits=128, m=m, trext=trext, blf_hz=blf, fs_hz=fs, method=method)
    det = decode_reply(r, **kw)
    assert np.array_equal(det.bits, bits)
    assert abs(det.start_sample - (333 + 3.1e-5 * fs)) <= 1
    assert abs(det.gain - 2e-3 * np.exp(2.5j)) < 2e-4 and det.corr > 0.95
    ref = decode_reply_reference(r, **kw)
    assert np.array_equal(ref.bits, det.bits) and ref.start_sample == det.start_sample
    assert ref.gain == pytest.approx(det.gain, rel=1e-9)


@pytest.mark.parametrize("m", [1, 4])
def test_decode_noisy_kernel_equals_reference(m):
    """At Eb/N0 = 3 dB (errors present) both paths give identical decisions."""
    rng = trial_rng(12, m)
    bits = rng.integers(0, 2, 400).astype(np.uint8)
    spe = 4
    fs, blf = 2 * 100e3 * spe, 100e3
    s = reply_waveform(bits, m=m, trext=False, blf_hz=blf, fs_hz=fs)
    nb = 2 * m * spe
    r = _channel(s, rng, gain=1.0, dc=0, lead=0, tail=0, sigma=math.sqrt(nb / 10 ** 0.3))
    for method in ("viterbi", "bitwise"):
        kw = dict(n_bits=400, m=m, trext=False, blf_hz=blf, fs_hz=fs, method=method, start_sample=0, gain=1.0)
        a, b = decode_reply(r, **kw), decode_reply_reference(r, **kw)
        assert np.array_equal(a.bits, b.bits)
        assert 0 < np.count_nonzero(a.bits != bits) < 100
    y = rng.standard_normal(1000)
    out = np.empty(37)
    K.projected_halfbit_sums_kernel(y.astype(np.complex128), 1.0, 0.0, 0.0, 3.3, 0.37, 4, out)  # g = 1, no DC
    np.testing.assert_allclose(out, halfbit_sums_reference(y, 3.3, 0.37, 4, 37), rtol=1e-12, atol=1e-12)


def _ber(m, ebn0_db, n_bits, method, seed):
    """Monte-Carlo BER with known sync and gain: Eb/N0 = N_b/σ² for ±1 samples, N_b samples
    per bit and complex noise of variance σ² (coherent projection keeps σ²/2)."""
    rng = trial_rng(seed, m, int(ebn0_db * 10))
    spe = 4
    blf, fs = 100e3, 2 * 100e3 * spe
    bits = rng.integers(0, 2, n_bits).astype(np.uint8)
    s = reply_waveform(bits, m=m, trext=False, blf_hz=blf, fs_hz=fs)
    nb = 2 * m * spe
    r = _channel(s, rng, gain=1.0, dc=0, lead=0, tail=0, sigma=math.sqrt(nb / 10 ** (ebn0_db / 10)))
    det = decode_reply(r, n_bits=n_bits, m=m, trext=False, blf_hz=blf, fs_hz=fs, method=method,
                       start_sample=0, gain=1.0)
    return np.count_nonzero(det.bits != bits) / n_bits


def _pb_bitwise(ebn0_db):
    p = norm.sf(math.sqrt(10 ** (ebn0_db / 10)))
    return 2 * p * (1 - p)


def test_bitwise_ber_matches_theory_short():
    """FM0 bit-by-bit at Eb/N0 = 4 dB: P_b = 2p(1−p) = 0.1066 (anchors §4.8). 20 000 bits:
    σ = √(P(1−P)/n) = 0.0022; tolerance 5σ = 0.011. Viterbi must be at least 2× better."""
    pb = _pb_bitwise(4.0)
    assert pb == pytest.approx(0.1066, abs=5e-4)
    ber = _ber(1, 4.0, 20_000, "bitwise", 1)
    assert abs(ber - pb) < 5 * math.sqrt(pb * (1 - pb) / 20_000)
    assert _ber(1, 4.0, 20_000, "viterbi", 1) < 0.5 * ber


@pytest.mark.slow
@pytest.mark.parametrize("m", [1, 2, 4, 8])
@pytest.mark.parametrize("ebn0_db", [0.0, 4.0, 8.0])
def test_bitwise_ber_matches_theory_long(m, ebn0_db):
    """2·10⁵ bits per point, tolerance 5σ of the binomial estimate (σ = √(P(1−P)/n));
    the Viterbi detector beats bit-by-bit at every point."""
    n = 200_000
    pb = _pb_bitwise(ebn0_db)
    ber = _ber(m, ebn0_db, n, "bitwise", 2)
    assert abs(ber - pb) < 5 * math.sqrt(pb * (1 - pb) / n)
    assert _ber(m, ebn0_db, n, "viterbi", 2) < ber


@settings(max_examples=40, deadline=None)
@example(bits=[1, 1, 1, 1, 1], m=4, trext=True, blf_khz=40.0, samples_per_element=3.125, t0_frac=0.125,
         phase=0.0, method="viterbi")  # integer-lag peak three elements early (found by hypothesis)
@given(
    bits=st.lists(st.integers(0, 1), min_size=1, max_size=48),
    m=st.sampled_from([1, 2, 4, 8]),
    trext=st.booleans(),
    blf_khz=st.floats(40.0, 640.0),
    samples_per_element=st.floats(3.0, 10.0),
    t0_frac=st.floats(0.0, 1.0),
    phase=st.floats(-math.pi, math.pi),
    method=st.sampled_from(["viterbi", "bitwise"]),
)
def test_round_trip_property(bits, m, trext, blf_khz, samples_per_element, t0_frac, phase, method):
    blf = blf_khz * 1e3
    fs = 2 * blf * samples_per_element
    s = reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=t0_frac * 20 / fs)
    r = np.concatenate([np.zeros(30), 0.7 * np.exp(1j * phase) * s, np.zeros(5)]) + 0.2
    kw = dict(n_bits=len(bits), m=m, trext=trext, blf_hz=blf, fs_hz=fs, method=method)
    det = decode_reply(r, **kw)
    assert det.bits.tolist() == list(bits)
    assert np.array_equal(decode_reply_reference(r, **kw).bits, det.bits)


def test_decode_rejects_bad_input():
    with pytest.raises(ValueError):
        decode_reply(np.zeros(10, complex), n_bits=16, m=1, trext=False, blf_hz=40e3, fs_hz=1e6)
    with pytest.raises(ValueError):
        decode_reply(np.zeros(10000, complex), n_bits=16, m=3, trext=False, blf_hz=40e3, fs_hz=1e6)
    with pytest.raises(ValueError):
        decode_reply(np.zeros(10000, complex), n_bits=16, m=1, trext=False, blf_hz=40e3, fs_hz=1e6, method="ml")


def test_benchmark_smoke():
    out = benchmark_linecode(n_bits=2000)
    assert out["numba_bit_errors"] == 0
    assert out["numba_s"] > 0 and out["fs_hz"] == 2 * 160e3 * 8


def test_reply_waveform_remembered_elements_follow_the_bits():
    # the element sequence of a reply is remembered by its bits: the same bits again, and the
    # same array changed in place, give the reference's waveform
    bits = np.array([0, 1, 1, 0, 1, 0, 0, 0, 1, 1, 1, 0, 0, 1, 0, 1], dtype=np.uint8)
    kw = dict(m=4, trext=False, blf_hz=320e3, fs_hz=4e6, t0_s=3.1e-6, n_samples=900)
    for _ in range(2):
        assert np.array_equal(reply_waveform(bits, **kw), reply_waveform_reference(bits, **kw))
    bits[3] = 1
    assert np.array_equal(reply_waveform(bits, **kw), reply_waveform_reference(bits, **kw))
    with pytest.raises(ValueError):
        reply_waveform(np.array([0, 2], dtype=np.uint8), **kw)

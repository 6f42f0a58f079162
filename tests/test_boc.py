"""BOC line code of the HIMR tag: kernels against their NumPy twins, encode → decode round
trips (hypothesis), preamble search, and the one-line errors of bad codes and sample rates."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rfsim.himr.boc import BocCode, boc_bit_sums, boc_chips, boc_decode, boc_find, boc_train
from rfsim.core.errors import ConfigError
from rfsim.core.rng import trial_rng
from reference.himr_boc import boc_bit_sums_reference, boc_chips_reference, boc_decode_reference, boc_train_reference

CODES = {"9axis-2d": BocCode(8, 4e6), "6axis-1d": BocCode(64, 5e6)}


def test_chip_pattern_by_hand():
    """Bits 1, 0 with N = 8 at f_sc = R_c/2: +−+−+−+− then −+−+−+−+; with f_sc = R_c/4 the
    half-cycle is two chips: ++−−++−− for a 1."""
    np.testing.assert_array_equal(boc_chips([1, 0], BocCode(8, 4e6)),
                                  [1, -1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1, -1, 1, -1, 1])
    np.testing.assert_array_equal(boc_chips([1], BocCode(8, 4e6, 1e6)), [1, 1, -1, -1, 1, 1, -1, -1])


def test_rates_and_bandwidth_by_hand():
    """R_b = R_c/N: 4e6/8 = 500,000 b/s and 5e6/64 = 78,125 b/s (seed 000 L715, L411);
    B = 2·(f_sc + R_b): 2·(2 MHz + 0.5 MHz) = 5 MHz, 2·(2.5 MHz + 78.125 kHz) = 5.15625 MHz."""
    assert CODES["9axis-2d"].bit_rate_bps == 500_000.0
    assert CODES["6axis-1d"].bit_rate_bps == 78_125.0
    assert CODES["9axis-2d"].bandwidth_hz == 5e6
    assert CODES["6axis-1d"].bandwidth_hz == 5_156_250.0
    assert CODES["6axis-1d"].duration_s(96) == pytest.approx(1.2288e-3, rel=1e-12)


@given(bits=st.lists(st.integers(0, 1), min_size=1, max_size=40),
       n_cycles=st.integers(1, 8), half=st.sampled_from([1, 2, 4]))
def test_chips_kernel_equals_reference(bits, n_cycles, half):
    code = BocCode(2 * half * n_cycles, 4e6, 4e6 / (2 * half))
    np.testing.assert_array_equal(boc_chips(bits, code), boc_chips_reference(bits, code))


def test_chips_are_dc_free_per_bit():
    """Whole subcarrier cycles in every bit: each bit's chips sum to zero."""
    bits = trial_rng(1, 0).integers(0, 2, 50)
    for code in CODES.values():
        chips = boc_chips(bits, code).reshape(50, -1)
        assert np.all(chips.sum(axis=1) == 0)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), fmt=st.sampled_from(sorted(CODES)),
       spc=st.floats(1.3, 6.0), n_packets=st.integers(1, 4))
def test_train_kernel_equals_reference(seed, fmt, spc, n_packets):
    """Random packets at random fractional starts (overlapping allowed), any fs ≥ B."""
    rng = trial_rng(seed, 0)
    code = CODES[fmt]
    fs = max(code.chip_rate_hz * spc, code.bandwidth_hz)
    n_bits = int(rng.integers(1, 30))
    bits = rng.integers(0, 2, (n_packets, n_bits)).astype(np.uint8)
    dur = code.duration_s(n_bits)
    starts = np.sort(rng.uniform(-0.5 * dur, 2.0 * dur, n_packets))
    n = int(3 * dur * fs)
    kw = dict(t0_s=float(rng.uniform(-1e-6, 1e-6)), fs_hz=fs, n_samples=n, level_plus=0.7 + 0.1j,
              level_minus=-0.9j, rest=0.25)
    np.testing.assert_array_equal(boc_train(starts, bits, code, **kw),
                                  boc_train_reference(starts, bits, code, **kw))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), fmt=st.sampled_from(sorted(CODES)),
       spc=st.floats(1.3, 8.0), n_bits=st.integers(24, 120),
       offset_ratio=st.floats(0.0, 100.0))
def test_round_trip_noise_free(seed, fmt, spc, n_bits, offset_ratio):
    """encode → r = h·s + c → decode gives the same bits, h and c (to 1e-9 relative) for a
    random complex gain, a random offset up to 100·|h| (leakage), a fractional start and
    any fs from B to 8 samples per chip; kernel and NumPy twin agree."""
    rng = trial_rng(seed, 1)
    code = CODES[fmt]
    fs = max(code.chip_rate_hz * spc, code.bandwidth_hz)
    bits = rng.integers(0, 2, n_bits).astype(np.uint8)
    start_s = float(rng.uniform(0.0, 5.0)) / fs + 3.0 / fs
    n = int(math.ceil((start_s + code.duration_s(n_bits)) * fs)) + 5
    s = boc_train([start_s], bits, code, t0_s=0.0, fs_hz=fs, n_samples=n, rest=0.0)
    h = complex(*rng.normal(size=2)) * 10.0 ** rng.uniform(-4, 0)
    c = abs(h) * offset_ratio * np.exp(1j * rng.uniform(0, 2 * np.pi))
    r = h * s + c
    kw = dict(code=code, fs_hz=fs, n_bits=n_bits, start_sample=start_s * fs, preamble_bits=bits[:24])
    det = boc_decode(r, **kw)
    np.testing.assert_array_equal(det.bits, bits)
    assert abs(det.gain - h) <= 1e-9 * abs(h) * (1 + offset_ratio)
    assert abs(det.offset - c) <= 1e-9 * abs(h) * (1 + offset_ratio)
    assert det.preamble_ok
    ref = boc_decode_reference(r, **kw)
    np.testing.assert_array_equal(ref.bits, det.bits)
    assert abs(ref.gain - det.gain) <= 1e-9 * abs(h) * (1 + offset_ratio)


@pytest.mark.parametrize("fmt", sorted(CODES))
def test_bit_sums_kernel_equals_reference(fmt):
    rng = trial_rng(2, 0)
    code = CODES[fmt]
    r = rng.normal(size=4000) + 1j * rng.normal(size=4000)
    for start in (0.0, 3.37, 11.5):
        a = boc_bit_sums(r, start, code, fs_hz=13.3e6, n_bits=5)
        b = boc_bit_sums_reference(r, start, code, fs_hz=13.3e6, n_bits=5)
        for x, y in zip(a, b):
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12)


def test_decoder_bit_error_rate_matches_bpsk_theory():
    """Coherent BOC is BPSK on a square subcarrier: P_b = Q(√(2·Eb/N0)). At Eb/N0 = 4 dB
    P_b = 0.01250; 200 packets × 176 payload bits = 35,200 bits → binomial σ = 5.9e-4,
    tolerance 4σ (the preamble phase reference adds a negligible loss at 24 bits)."""
    from scipy.stats import norm
    code, fs, n_bits = CODES["9axis-2d"], 16e6, 200
    ebn0 = 10 ** 0.4
    spb = fs / code.bit_rate_bps                   # 32 samples per bit, |s| = 1
    sigma = math.sqrt(spb / ebn0)                  # Eb = spb·|h|², N0 = σ² per complex sample
    rng = trial_rng(3, 0)
    errors = total = 0
    for _ in range(200):
        bits = rng.integers(0, 2, n_bits).astype(np.uint8)
        s = boc_train([0.0], bits, code, t0_s=0.0, fs_hz=fs, n_samples=int(spb * n_bits), rest=0.0)
        h = np.exp(1j * rng.uniform(0, 2 * np.pi))
        r = h * s + sigma * (rng.normal(size=s.size) + 1j * rng.normal(size=s.size)) / math.sqrt(2)
        det = boc_decode(r, code=code, fs_hz=fs, n_bits=n_bits, start_sample=0.0, preamble_bits=bits[:24])
        errors += int(np.sum(det.bits[24:] != bits[24:]))
        total += n_bits - 24
    pb = norm.sf(math.sqrt(2 * ebn0))
    assert abs(pb - 0.012500) < 2e-5
    assert abs(errors / total - pb) < 4 * math.sqrt(pb * (1 - pb) / total)


def test_snr_estimate_matches_injected_noise():
    """σ² from the residual within 3 % for 6,144 samples (relative std of a χ² estimate
    1/√n = 1.3 %)."""
    code, fs = CODES["9axis-2d"], 16e6
    rng = trial_rng(4, 0)
    bits = rng.integers(0, 2, 192).astype(np.uint8)
    s = boc_train([0.0], bits, code, t0_s=0.0, fs_hz=fs, n_samples=6144, rest=0.0)
    noise = 0.1 * (rng.normal(size=s.size) + 1j * rng.normal(size=s.size)) / math.sqrt(2)
    det = boc_decode(2.0 * s + 0.5 + noise, code=code, fs_hz=fs, n_bits=192, start_sample=0.0,
                     preamble_bits=bits[:24])
    assert abs(det.noise_var / 0.01 - 1) < 0.03
    assert abs(det.snr_db - 10 * math.log10(4 / 0.01)) < 0.15


def test_find_locates_packet_start():
    code, fs = CODES["6axis-1d"], 10e6
    rng = trial_rng(5, 0)
    bits = rng.integers(0, 2, 96).astype(np.uint8)
    start = 1234
    s = boc_train([start / fs], bits, code, t0_s=0.0, fs_hz=fs, n_samples=start + 14000, rest=0.0)
    r = (0.2 - 0.4j) * s + 3.0 + 0.05 * (rng.normal(size=s.size) + 1j * rng.normal(size=s.size))
    found, rho = boc_find(r, code=code, fs_hz=fs, preamble_bits=bits[:24], search=(1000, 1500))
    assert found == start
    assert rho > 0.9


# ----------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("kwargs, key", [
    (dict(chips_per_bit=8, chip_rate_hz=4e6, subcarrier_hz=1.5e6), "tag.chip_rate_hz"),
    (dict(chips_per_bit=8, chip_rate_hz=4e6, subcarrier_hz=4e6), "tag.chip_rate_hz"),
    (dict(chips_per_bit=6, chip_rate_hz=4e6, subcarrier_hz=1e6), "tag.chips_per_bit"),
    (dict(chips_per_bit=1, chip_rate_hz=4e6), "tag.chips_per_bit"),
    (dict(chips_per_bit=8, chip_rate_hz=-4e6), "tag.chip_rate_hz"),
])
def test_bad_codes_are_one_line_config_errors(kwargs, key):
    """A chip rate that is not an even integer multiple of the subcarrier, and the like."""
    with pytest.raises(ConfigError) as err:
        BocCode(**kwargs, key="tag")
    assert err.value.key == key
    assert "\n" not in str(err.value)


def test_fs_below_boc_bandwidth_is_rejected():
    code = CODES["9axis-2d"]
    with pytest.raises(ConfigError, match="BOC bandwidth") as err:
        boc_train([0.0], [1, 0], code, t0_s=0.0, fs_hz=4.9e6, n_samples=10)
    assert "\n" not in str(err.value)
    with pytest.raises(ConfigError):
        boc_decode(np.zeros(100, complex), code=code, fs_hz=4e6, n_bits=2, start_sample=0.0)
    assert boc_train([0.0], [1, 0], code, t0_s=0.0, fs_hz=5e6, n_samples=10).size == 10

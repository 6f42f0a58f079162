"""Fast paths of the sample-level exchange: numba kernels against their NumPy twins, and the
keyed caches (channel geometry, command bits, preamble templates) against a fresh computation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.channels.antennas import Antenna, HalfWaveDipole, Patch
from rfsim.channels.scene import Channel, Scene
from rfsim.channels.small_scale import ApdpModel
from rfsim.channels.surfaces import Surface
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.gen2 import _linecode_kernels as LK
from rfsim.gen2 import _pie_kernels as PK
from rfsim.gen2 import linecode as L
from rfsim.gen2.commands import ACK, Query
from rfsim.gen2.pie import two_level_threshold
from rfsim.core.rng import trial_rng
from reference import gen2_linecode as RL
from reference.gen2_pie import pr_ask_baseband_reference, two_level_threshold_reference
from reference.ulp import assert_close_ulp


# ----------------------------------------------------------------------------- kernels


def test_pairwise_sum_equals_numpy_sum():
    """The kernel sums in numpy's pairwise order: equal to np.add.reduce bit for bit, for
    every length around the block boundaries (8, 128, 256, …) and some long ones."""
    rng = trial_rng(50, 0)
    sizes = list(range(0, 300)) + [511, 512, 513, 1023, 1024, 1025, 4097, 12345]
    for n in sizes:
        x = rng.standard_normal(n) * 10.0 ** rng.uniform(-3, 3, n)
        assert PK.pairwise_sum(x, 0, n) == np.add.reduce(x), n
    x = rng.standard_normal(1000)
    assert PK.pairwise_sum(x, 17, 600) == np.add.reduce(x[17:617])
    assert len(sizes) == 308


@pytest.mark.parametrize("seed", range(6))
def test_two_level_threshold_kernel_equals_reference(seed):
    """Isodata split of noisy two-level envelopes (random depth, duty cycle, length)."""
    rng = trial_rng(51, seed)
    n = int(rng.integers(50, 20000))
    levels = np.where(rng.random(n) < rng.uniform(0.05, 0.95), 1.0, 1.0 - rng.uniform(0.2, 1.0))
    x = np.abs(levels + 0.05 * rng.standard_normal(n)) * 10.0 ** rng.uniform(-4, 1)
    # exact: the kernel sums in NumPy's pairwise order (test_pairwise_sum_equals_numpy_sum)
    assert two_level_threshold(x) == two_level_threshold_reference(x)
    assert two_level_threshold(x, max_iter=2) == two_level_threshold_reference(x, max_iter=2)


def test_pairwise_sum_of_a_constant_tail_equals_numpy_sum():
    """A constant tail is summed without being read (blocks and nodes inside it by their
    length): equal to np.add.reduce of the full values bit for bit, for tails and heads of
    every length around the block boundaries, tails of ±0 and of NaN."""
    rng = trial_rng(53, 0)
    lengths = [0, 1, 7, 8, 9, 127, 128, 129, 255, 256, 257, 1000, 4097]
    for n_head in lengths:
        for n_tail in lengths[1:]:
            for c in (0.1 + rng.uniform(), -3.0e5, 0.0, -0.0):
                x = np.concatenate([rng.standard_normal(n_head) * 10.0 ** rng.uniform(-3, 3, n_head),
                                    np.full(n_tail, c)])
                buf = np.full(x.size, np.nan)  # the tail is not there: only the block that holds its start
                buf[:n_head] = x[:n_head]
                buf[n_head:n_head + 128] = c
                memo_n, memo_v = np.zeros(64, np.int64), np.empty(64)
                got = PK.pairwise_sum_tail(buf, 0, x.size, n_head, c, memo_n, memo_v)
                want = np.add.reduce(x)
                assert got == want, (n_head, n_tail, c)
                # the sign of a zero sum as the kernel's sum of the full values (numpy's reduce
                # adds the sum to +0: all −0 values give +0 there)
                assert math.copysign(1.0, got) == math.copysign(1.0, PK.pairwise_sum(x, 0, x.size))
                # the memo holds sums by length for this c: asked again, the same
                assert PK.pairwise_sum_tail(buf, 0, x.size, n_head, c, memo_n, memo_v) == want
    x = np.concatenate([np.ones(300), np.full(700, np.nan)])
    assert math.isnan(PK.pairwise_sum_tail(x, 0, 1000, 300, np.nan, np.zeros(64, np.int64), np.empty(64)))
    # the run that ends an array: zeros of both signs are not one run; a NaN ends none
    assert PK.trailing_run_start(np.array([1.0, 2.0, 2.0, 2.0])) == 1
    assert PK.trailing_run_start(np.array([0.0, -0.0, -0.0])) == 1
    assert PK.trailing_run_start(np.array([np.nan, np.nan])) == 1
    assert PK.trailing_run_start(np.array([5.0])) == 0


@pytest.mark.parametrize("seed", range(8))
def test_two_level_threshold_of_a_segment_with_a_cw_tail_equals_reference(seed):
    """A reader segment's shape: a PIE-like head, then a long CW tail at the high level, at the
    low level (on the other side of the split) or of a single sample."""
    rng = trial_rng(54, seed)
    n_head, n_tail = int(rng.integers(1, 3000)), int(rng.integers(1, 20000))
    head = np.where(rng.random(n_head) < 0.7, 1.0, 0.1) + 0.02 * rng.standard_normal(n_head) * (seed % 2)
    c = (1.0, 0.1, 0.55, float(head[-1]))[seed % 4]
    x = np.concatenate([head, np.full(n_tail, c)]) * 10.0 ** rng.uniform(-4, 1)
    assert two_level_threshold(x) == two_level_threshold_reference(x)
    assert two_level_threshold(x, max_iter=2) == two_level_threshold_reference(x, max_iter=2)


def test_two_level_threshold_edge_cases():
    """Constant input, 2-D input (C order, as numpy's masks), NaN (no iteration)."""
    for x in (np.full(10, 3.0), np.arange(24.0).reshape(4, 6), np.array([1.0, np.nan, 0.0]),
              np.array([0.0, 1.0])):
        a, b = two_level_threshold(x), two_level_threshold_reference(x)
        np.testing.assert_array_equal(np.array(a), np.array(b))
    with pytest.raises(ValueError):
        two_level_threshold(np.zeros(0))


def test_corr_abs_kernel_equals_scipy():
    rng = trial_rng(52, 0)
    r = rng.standard_normal(700) + 1j * rng.standard_normal(700)
    t0 = rng.standard_normal(500)
    out = np.empty(201)
    LK.corr_abs_kernel(r, t0, out)
    np.testing.assert_allclose(out, L.corr_abs_reference(r, t0), rtol=1e-12)


@pytest.mark.parametrize("m", [1, 4])
def test_refine_kernel_equals_reference(m):
    """Sub-sample peak refinement on a noisy preamble: same start, same correlation."""
    rng = trial_rng(53, m)
    fs, blf = 4e6, 320e3
    ratio = 2 * blf / fs
    bits = rng.integers(0, 2, 16).astype(np.uint8)
    s = L.reply_waveform(bits, m=m, trext=False, blf_hz=blf, fs_hz=fs, t0_s=30.3 / fs, n_samples=3000)
    r = (0.3 + 0.2j) * s + 0.2 * (rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size))
    rows, norms = L._refine_bank(m, False, ratio)
    cands = np.array([31, 29, 0, 30])
    a = L._kernel_refine(r, cands, L._REFINE_SHIFTS, rows, norms)
    b = RL.refine_reference(r, cands, L._REFINE_SHIFTS, rows, norms)
    assert a[1] == b[1] and a[0] == pytest.approx(b[0], rel=1e-12)
    assert 29.5 <= a[1] <= 31.0
    # negative positions are skipped, as in the reference
    a = L._kernel_refine(r, np.array([0]), L._REFINE_SHIFTS, rows, norms)
    assert a[1] >= 0 and a[1] == RL.refine_reference(r, np.array([0]), L._REFINE_SHIFTS, rows, norms)[1]


def test_refine_kernel_sums_in_sample_order_exactly():
    """The kernel's sums are those of a sample-by-sample loop, bit for bit (the shifts are
    summed side by side, each in the order i = 0, 1, ...), on a complex input and on a
    comparator's +-1 input with ties."""
    rng = trial_rng(54, 0)
    fs, blf, m = 1e6, 48e3, 2
    rows, norms = L._refine_bank(m, True, 2 * blf / fs)
    n_pre = rows.shape[1]
    for r in (rng.standard_normal(n_pre + 60) + 1j * rng.standard_normal(n_pre + 60),
              np.sign(rng.standard_normal(n_pre + 60)).astype(np.complex128)):
        cands = np.array([40, 3, 0, 57, 12])
        best, start = -1.0, math.nan
        for c in cands.tolist():
            for d, t, norm in zip(L._REFINE_SHIFTS.tolist(), rows, norms):
                if c + d < 0:
                    continue
                acc_re = acc_im = 0.0
                for i in range(n_pre):
                    acc_re += r[c + i].real * t[i]
                    acc_im += r[c + i].imag * t[i]
                v = math.hypot(acc_re, acc_im) / norm
                if v > best:
                    best, start = v, c + d
        assert L._kernel_refine(r, cands, L._REFINE_SHIFTS, rows, norms) == (best, start)


@pytest.mark.parametrize("m, trext, fs, blf", [(4, False, 4e6, 320e3), (1, False, 4e6, 160e3), (2, True, 1e6, 48e3),
                                             (8, True, 2e6, 40e3)])
def test_refine_runs_kernel_equals_refine_kernel_bit_for_bit(m, trext, fs, blf):
    """The refinement over the templates' runs (approximation, then the sample-by-sample sums of
    the pairs that can win) returns refine_kernel's best value and start exactly: on noise, on a
    comparator's +-1 input (exact ties), on a reply with a large offset, and with candidates whose
    negative shifts are skipped."""
    rng = trial_rng(54, m, int(trext))
    ratio = 2 * blf / fs
    rows, norms = L._refine_bank(m, trext, ratio)
    runs = L._refine_runs(rows)
    n = rows.shape[1] + 80
    n_ties = 0
    for trial in range(60):
        if trial % 3 == 0:
            r = rng.standard_normal(n) + 1j * rng.standard_normal(n)
        elif trial % 3 == 1:
            r = np.sign(rng.standard_normal(n)).astype(np.complex128)
        else:
            bits = rng.integers(0, 2, 16).astype(np.uint8)
            s = L.reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=(30 + rng.random()) / fs,
                                 n_samples=n)
            r = (0.3 + 0.2j) * s + 1e-3 * (rng.standard_normal(n) + 1j * rng.standard_normal(n)) + 5.0
        cands = np.array([0, 1, 2]) if trial % 5 == 0 else rng.choice(70, 5, replace=False)
        cands = cands.astype(np.int64)
        a = LK.refine_kernel(r, cands, L._REFINE_SHIFTS, rows, norms)
        b = LK.refine_runs_kernel(r, cands, L._REFINE_SHIFTS, rows, norms, *runs)
        assert a == b
        n_ties += int(np.any(runs[3]))
    assert n_ties > 0  # equal templates at neighbouring shifts occur (ties resolved as refine_kernel does)


def test_template_cache_matches_fresh_template():
    """The preamble template equals one built from the element sequence directly."""
    fs, blf, m = 4e6, 320e3, 4
    ratio = 2 * blf / fs
    pre = L.preamble_levels(m=m, trext=False)[0]
    el = np.repeat(pre, m).astype(np.float64)
    el[1::2] *= -1
    n_pre = int(math.floor(el.size / ratio))
    for delta in (0.0, 0.3125, -0.5):
        u = (np.arange(n_pre) - delta) * ratio
        k = np.floor(u + LK.INDEX_EPS).astype(int)
        t = np.where(u >= 0, el[np.clip(k, 0, el.size - 1)], 0.0)
        np.testing.assert_array_equal(L._template(m, False, ratio, delta)[0], t)
    assert not L._template(m, False, ratio, 0.0)[0].flags.writeable
    # the public function still hands out a fresh, writable array
    a = L.preamble_levels(m=m, trext=False)[0]
    a[0] = 9
    assert L.preamble_levels(m=m, trext=False)[0][0] == 1


# ----------------------------------------------------------------------------- caches


def _scene():
    floor = Surface(point_m=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), eps_r=5.0)
    return Scene(surfaces=(floor,), apdp=ApdpModel(), image_order=1)


def test_channel_geometry_cache_is_bit_identical():
    """Links from a channel that has kept the static geometry equal those of a fresh channel
    with the same draws, for several antennas and carriers; a moved antenna is a new link."""
    reader = Antenna([0.0, 0.0, 1.0], pattern=Patch(6.0, 70.0), polarization="circular")
    tags = [Antenna([d, 0.5, 1.2], orientation=(np.pi, 0.0, 0.0), pattern=HalfWaveDipole()) for d in (1.0, 3.0)]
    held = Channel(_scene())
    n = 0
    for rep in range(3):
        for fc in (902.75e6, 915.25e6):
            for i, tag in enumerate(tags):
                fresh = Channel(_scene())
                a = held.link(reader, tag, fc_hz=fc, rng=trial_rng(54, rep, i))
                b = fresh.link(reader, tag, fc_hz=fc, rng=trial_rng(54, rep, i))
                for f in ("gain", "delay_s", "doppler_hz"):
                    np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
                n += 1
    assert n == 12 and len(held._static) == 4 and len(held._placements) == 2
    moved = Antenna([3.5, 0.5, 1.2], orientation=(np.pi, 0.0, 0.0), pattern=HalfWaveDipole())
    a = held.link(reader, moved, fc_hz=915.25e6, rng=trial_rng(54, 9))
    b = Channel(_scene()).link(reader, moved, fc_hz=915.25e6, rng=trial_rng(54, 9))
    np.testing.assert_array_equal(a.gain, b.gain)
    # a moving tag is never taken from the cache
    v = np.array([0.0, 1.0, 0.0])
    a = held.link(reader, tags[1], fc_hz=915.25e6, rng=trial_rng(54, 10), t_s=0.5, rx_motion=v)
    b = Channel(_scene()).link(reader, tags[1], fc_hz=915.25e6, rng=trial_rng(54, 10), t_s=0.5, rx_motion=v)
    np.testing.assert_array_equal(a.gain, b.gain)
    np.testing.assert_array_equal(a.doppler_hz, b.doppler_hz)
    assert abs(a.doppler_hz[0]) > 0


def test_reader_command_cache():
    """Repeated and distinct commands: bits, command end and samples as without the cache."""
    rd = Reader(ReaderConfig(), [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(55, 0))
    lk = rd.link
    for cmd in (Query(dr=lk.dr, m=lk.m, q=0), ACK(0x1234), Query(dr=lk.dr, m=lk.m, q=0), ACK(0x4321)):
        for _ in range(2):
            seg = rd.transmit(cmd, t0_s=0.01, cw_after_s=1e-4)
            assert seg.cmd_end_s == 0.01 + lk.tari_s + lk.command_duration_s(cmd)
            fresh = Reader(ReaderConfig(), [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(55, 0))
            np.testing.assert_array_equal(seg.samples, fresh.transmit(cmd, t0_s=0.01, cw_after_s=1e-4).samples)
    assert len(rd._cmd_cache) == 3
    assert rd.noise_power_w() == fresh.noise_power_w() and rd.leakage_gain() == fresh.leakage_gain()


def test_cw_power_kernel_equals_reference():
    """Median of env² over the CW samples: odd/even counts, ties (rounded envelopes), an
    unmodulated segment (all samples) and NaN handling as numpy.median."""
    from rfsim.devices.tag import _cw_power_w
    from reference.devices_tag import cw_power_reference

    rng = trial_rng(56, 0)
    n_cases = 0
    for k in range(200):
        n = int(rng.integers(1, 3000))
        env = np.abs(np.where(rng.random(n) < 0.7, 1.0, rng.uniform(0.0, 0.6)) + 0.05 * rng.standard_normal(n))
        if k % 4 == 0:
            env = np.round(env, 2)
        lv = two_level_threshold(env)
        assert _cw_power_w(env, lv) == cw_power_reference(env, lv)
        n_cases += 1
    flat = np.full(11, 0.5)
    assert _cw_power_w(flat, two_level_threshold(flat)) == cw_power_reference(flat, two_level_threshold(flat)) == 0.25
    nan = np.array([1.0, np.nan, 0.2, 1.0])
    # swing 0.1 < half the high level: every sample counts, the NaN too (numpy: NaN)
    assert math.isnan(_cw_power_w(nan, (0.5, 0.2, 0.3)))
    assert math.isnan(cw_power_reference(nan, (0.5, 0.2, 0.3)))
    assert n_cases == 200


def test_halfsymbols_kernel_equals_reference():
    """Element sequences of random replies, every M, TRext and dummy setting."""
    rng = trial_rng(57, 0)
    n = 0
    for m in (1, 2, 4, 8):
        for trext in (False, True):
            for dummy in (False, True):
                for _ in range(10):
                    bits = rng.integers(0, 2, int(rng.integers(0, 150))).astype(np.uint8)
                    a = L.halfsymbols(bits, m=m, trext=trext, dummy=dummy)
                    b = RL.halfsymbols_reference(bits, m=m, trext=trext, dummy=dummy)
                    assert a.dtype == b.dtype == np.int8
                    np.testing.assert_array_equal(a, b)
                    n += 1
    assert n == 160


@pytest.mark.parametrize("preamble", ["query", "frame-sync"])
def test_pr_ask_kernel_equals_reference(preamble):
    """PR-ASK baseband of random commands at a non-integer number of samples per Tari."""
    from rfsim.gen2.pie import pie_timeline, pr_ask_baseband, timeline_envelope

    rng = trial_rng(58, len(preamble))
    for _ in range(5):
        bits = rng.integers(0, 2, int(rng.integers(1, 60))).astype(np.uint8)
        tl = pie_timeline(bits, tari_s=12.5e-6, data1_tari=2.0, trcal_s=66.7e-6, pw_s=6.25e-6,
                          delimiter_s=12.5e-6, preamble=preamble, cw_before_s=12.5e-6, cw_after_s=1e-4)
        fs = 3.3e6
        e = timeline_envelope(tl, depth=0.9, fs_hz=fs, rise_fall_s=1.25e-6)
        a = pr_ask_baseband(tl, e, amplitude=0.7, fs_hz=fs)
        b = pr_ask_baseband_reference(tl, e, amplitude=0.7, fs_hz=fs)
        assert a.dtype == np.complex128
        np.testing.assert_array_equal(a, b)  # exact: one product amplitude·envelope, a sign flip
        assert np.any(a.real < 0) and np.any(a.real > 0)


@pytest.mark.parametrize("doppler_hz", [0.0, 37.0, -400.0])
def test_measure_kernel_equals_reference(doppler_hz):
    """Reader measurements (gain, Doppler slope, residual power) of a Miller-4 reply with a
    rotating phase and noise: kernel and NumPy twin agree to round-off (different summation
    order, so not bit for bit)."""
    from rfsim.devices.reader_measure import measure as _measure
    from reference.devices_reader import measure_reference

    rng = trial_rng(59, int(abs(doppler_hz)))
    fs, blf = 4e6, 320e3
    bits = rng.integers(0, 2, 128).astype(np.uint8)
    s = L.reply_waveform(bits, m=4, trext=False, blf_hz=blf, fs_hz=fs, t0_s=200.37 / fs, n_samples=8000)
    t = np.arange(s.size) / fs
    z = 1e-4 * np.exp(1j * (0.7 + 2 * np.pi * doppler_hz * t)) * s
    z = z + 3e-6 * (rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size))
    h, slope, sigma2 = _measure(z, s, fs)
    h_r, slope_r, sigma2_r = measure_reference(z, s, fs)
    assert h == pytest.approx(h_r, rel=1e-11)
    assert slope == pytest.approx(slope_r, rel=1e-9, abs=1e-9)
    assert sigma2 == pytest.approx(sigma2_r, rel=1e-9)
    # and both measure what was put in: Doppler within a few Hz, noise power 2·(3e-6)²
    assert slope / (2 * np.pi) == pytest.approx(doppler_hz, abs=5.0)
    assert sigma2 == pytest.approx(2 * 9e-12, rel=0.1)


def test_projected_halfbit_sums_kernel_equals_reference():
    rng = trial_rng(60, 0)
    part = rng.standard_normal(3000) + 1j * rng.standard_normal(3000)
    g = complex(0.3, -1.7)
    for m, start in ((1, 0.0), (4, 2.3125), (8, 0.9375)):
        a = L._kernel_sums(part, g, 0.25, start, 0.16, m, 60)
        b = RL.projected_halfbit_sums_reference(part, g, 0.25, start, 0.16, m, 60)
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("m, start, ratio", [(1, 0.0, 0.16), (2, 3.3, 0.37), (4, 2.3125, 0.16), (8, 0.9375, 0.9),
                                             (4, -1.75, 0.3125)])
def test_signed_halfbit_sums_kernel_equals_reference_and_projection(m, start, ratio):
    """Signed half-bit sums S_j = Σσ·r, C_j = Σσ: bit for bit the NumPy twin (both add the
    exact terms σ·r in sample order); projected, Re(g·S_j) − dc·C_j is the projecting kernel's
    sum of Re(r·g) − dc up to the order of the operations (bound: a few ε per term of the sum)."""
    rng = trial_rng(61, m)
    part = rng.standard_normal(3000) + 1j * rng.standard_normal(3000)
    nh = 60
    s_sum, s_count = np.empty(nh, np.complex128), np.empty(nh)
    LK.signed_halfbit_sums_kernel(part, start, ratio, m, s_sum, s_count)
    s_ref, c_ref = RL.signed_halfbit_sums_reference(part, start, ratio, m, nh)
    np.testing.assert_array_equal(s_sum, s_ref)
    np.testing.assert_array_equal(s_count, c_ref)
    assert np.any(s_count != 0) and np.any(s_sum != 0)
    g, dc_g = complex(0.3, -1.7), 0.25
    projected = L._kernel_sums(part, g, dc_g, start, ratio, m, nh)
    from_signed = (g * s_sum).real - dc_g * s_count
    # each side rounds each of its ≤ n_terms + 3 operations per half-bit by at most ε·Σ|term|,
    # with |term| ≤ max|y|, y = Re(r·g) − dc_g, and n_terms ≤ m/ratio + 2 samples per half-bit
    n_terms = m / ratio + 2
    bound = 2 * (n_terms + 3) * np.finfo(float).eps * n_terms * np.max(np.abs(part) * abs(g) + dc_g)
    assert np.max(np.abs(from_signed - projected)) <= bound
    assert np.max(np.abs(projected)) > 1e6 * bound  # the bound is far below the sums themselves


def test_signed_sum_decisions_equal_projected_decisions():
    """The reader's decisions from the signed sums equal the decoder's from the projected sums
    on noisy Miller/FM0 replies (the sums agree to round-off; no near tie in these draws)."""
    from rfsim.gen2 import _decode_reply_kernels as DK
    from rfsim.gen2 import _reply_core_kernels as RC

    for m in (1, 2, 4, 8):
        rng = trial_rng(62, m)
        for _ in range(20):
            bits = rng.integers(0, 2, 32).astype(np.uint8)
            fs, blf = 4e6, 320e3
            ratio = 2 * blf / fs
            t0 = float(rng.uniform(2, 5))
            s = L.reply_waveform(bits, m=m, trext=False, blf_hz=blf, fs_hz=fs, t0_s=t0 / fs, n_samples=4000)
            h = complex(rng.normal(), rng.normal()) * 1e-4
            dc = complex(rng.normal(), rng.normal()) * 1e-4
            part = h * s + dc + 4e-5 * (rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size))
            n_pre_levels = L.preamble_levels(m=m, trext=False)[0].size
            nh = n_pre_levels + 2 * (bits.size + 1)
            state0 = L.preamble_state(m=m, trext=False)
            g = 1.0 / h
            a_out = np.empty(bits.size + 1, np.uint8)
            b_out = np.empty(bits.size + 1, np.uint8)
            sums = np.empty(nh)
            DK.decisions_kernel(part, g.real, g.imag, (dc * g).real, t0, ratio, m, n_pre_levels, state0, True, sums,
                                a_out)
            s_sum, s_count = np.empty(nh, np.complex128), np.empty(nh)
            LK.signed_halfbit_sums_kernel(part, t0, ratio, m, s_sum, s_count)
            RC.signed_sum_decisions(s_sum, s_count, g, (dc * g).real, n_pre_levels, m > 1, state0, True, np.empty(nh),
                                    np.empty(bits.size + 1), np.empty(bits.size + 1), b_out)
            np.testing.assert_array_equal(a_out, b_out)


@pytest.mark.parametrize("m, trext", [(1, False), (4, False), (2, True)])
def test_known_levels_kernel_equals_reference(m, trext):
    """Known-level selection of the reader (preamble + outside the reply, steady neighbours)
    on the references of a real reply: the same samples and levels, bit for bit."""
    from rfsim.devices.reader_measure import known_levels as _known_levels
    from rfsim.gen2._measure_kernels import known_indices_kernel
    from reference.devices_reader import known_levels_reference

    rng = trial_rng(61, m)
    fs, blf = 4e6, 320e3 if m > 1 else 160e3
    n = 0
    for start in (100.0, 137.3125, 3.5):
        bits = rng.integers(0, 2, 16).astype(np.uint8)
        kw = dict(m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=start / fs, n_samples=2500)
        pre = L.reply_waveform(np.zeros(0, np.uint8), dummy=False, **kw)
        full = L.reply_waveform(bits, **kw)
        r = rng.standard_normal(2500) + 1j * rng.standard_normal(2500)
        n_pre_el = L.preamble_levels(m=m, trext=trext)[0].size * m
        a = _known_levels(r, full, start / fs * fs, 2.0 * blf / fs, n_pre_el)
        b = known_levels_reference(r, pre, full)
        np.testing.assert_array_equal(a[0], b[0])  # a selection of samples and ±1 levels: exact
        np.testing.assert_array_equal(a[1], b[1])
        assert a[1].size > 1000 and set(np.unique(a[1])) <= {-1.0, 1.0}
        # the rule's index form: the indices of the samples the reference selects, the same levels
        index, level = np.empty(2500, np.int64), np.empty(2500)
        k = known_indices_kernel(full, start / fs * fs, 2.0 * blf / fs, n_pre_el, index, level)
        want_index, want_level = known_levels_reference(np.arange(2500), pre, full)
        np.testing.assert_array_equal(index[:k], want_index)
        np.testing.assert_array_equal(level[:k], want_level)
        n += 1
    assert n == 3


def test_halfsymbols_rejects_bad_bits_on_the_fast_path():
    """uint8 arrays skip the generic validation; the kernel still rejects values other than 0/1."""
    with pytest.raises(ValueError, match="only 0 and 1"):
        L.halfsymbols(np.array([0, 1, 2], dtype=np.uint8), m=4, trext=False)
    with pytest.raises(ValueError):
        L.reply_waveform(np.array([3], dtype=np.uint8), m=1, trext=False, blf_hz=40e3, fs_hz=1e6)
    np.testing.assert_array_equal(L.halfsymbols([1, 0], m=2, trext=False),
                                  L.halfsymbols(np.array([1, 0], dtype=np.uint8), m=2, trext=False))


@pytest.mark.parametrize("samples_per_element, offset", [(3.7, 0.0), (25.0, 5.0 - 2.0j)])
def test_corr_abs_runs_kernel_equals_scipy(samples_per_element, offset):
    """The run-by-run correlation (cumulative sums) equals scipy's on a sampled Miller-4
    preamble template, zero-mean or not, with a large constant offset in r."""
    rng = trial_rng(53, 0)
    el = L.halfsymbols(np.zeros(0, np.uint8), m=4, trext=True, dummy=False).astype(np.float64)
    t = np.empty(int(el.size * samples_per_element))
    LK.waveform_kernel(el, 0.3, 1.0 / samples_per_element, t)
    r = offset + rng.standard_normal(t.size + 300) + 1j * rng.standard_normal(t.size + 300)
    for t0 in (t, t - t.mean()):
        out = np.empty(301)
        LK.corr_abs_runs_kernel(r, t0, out)
        np.testing.assert_allclose(out, L.corr_abs_reference(r, t0), rtol=1e-9, atol=1e-9 * t.size)
def test_air_accumulate_is_the_sequential_sum():
    """The air step's held constant of a tag population (rfsim.air.groups.accumulate) equals the
    left-to-right Python sum of the same complex terms, bit for bit, over magnitudes spread
    across 16 decades (where the summation order changes the rounding)."""
    from rfsim.air.groups import accumulate

    rng = trial_rng(62, 0)
    n = 0
    for _ in range(100):
        k = int(rng.integers(0, 600))
        v = (rng.standard_normal(k) + 1j * rng.standard_normal(k)) * 10.0 ** rng.uniform(-8, 8, k)
        start = complex(rng.standard_normal(), rng.standard_normal())
        want = start
        for x in v.tolist():
            want = want + x
        got = accumulate(start, v)
        assert got == want and type(got) is complex
        n += 1
    assert n == 100


def test_air_masked_sum_is_the_sequential_sum_of_the_picked_terms():
    """rfsim.air.groups.masked_sum (one compiled pass) equals the left-to-right Python sum of
    the picked terms, bit for bit, with the count of terms picked (0: the start unchanged), over
    magnitudes spread across 16 decades and random masks."""
    from rfsim.air.groups import masked_sum

    rng = trial_rng(63, 0)
    for trial in range(100):
        k = int(rng.integers(0, 600))
        v = (rng.standard_normal(k) + 1j * rng.standard_normal(k)) * 10.0 ** rng.uniform(-8, 8, k)
        use = rng.random(k) < (0.0 if trial % 10 == 0 else rng.random())
        start = complex(rng.standard_normal(), rng.standard_normal())
        want = start
        for x, u in zip(v.tolist(), use.tolist()):
            if u:
                want = want + x
        n, got = masked_sum(start, v, use)
        assert (n, got) == (int(use.sum()), want) and type(got) is complex


def test_front_end_cache_of_read_only_segments():
    """A reader's cached (read-only) command segment sent twice: the run's cache gives the
    second segment the first one's memo, so the tag's SharedFrontEnd is kept, and its level
    split, plateau, CW sample and decoded command equal a fresh one's; a segment made from a
    copy of the samples (no shared memo) gets a front end of its own."""
    from rfsim.devices.tag import PassiveTag, SharedFrontEnd
    from rfsim.air.step import FixedEmitter, Segment
    from rfsim.gen2.commands import QueryRep

    rd = Reader(ReaderConfig(), [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(63, 0))
    tx = [rd.transmit(QueryRep(session=s), t0_s=0.01 * k, cw_after_s=2e-4) for k, s in enumerate((1, 1, 2))]
    assert tx[0].samples is tx[1].samples and not tx[0].samples.flags.writeable
    assert tx[0].memo is tx[1].memo and tx[2].memo is not tx[0].memo
    segs = [FixedEmitter(rd.antennas[0], t).segment for t in tx]
    fes = [PassiveTag.front_end_of(seg) for seg in segs]
    assert fes[0] is fes[1] and fes[2] is not fes[0]
    for t, fe in zip(tx, fes):
        fresh = SharedFrontEnd(t.samples.copy(), fs_hz=t.fs_hz)
        assert (fe.levels, fe.plateau, fe.cw_sample) == (fresh.levels, fresh.plateau, fresh.cw_sample)
        assert fe.command(0.0)[0] == fresh.command(0.0)[0] and fe.command(0.0)[1].end == fresh.command(0.0)[1].end
    assert fes[2].command(0.0)[0] == QueryRep(session=2)
    writable = tx[0].samples.copy()
    a = PassiveTag.front_end_of(Segment(0.0, tx[0].fs_hz, tx[0].fc_hz, writable))
    b = PassiveTag.front_end_of(Segment(0.0, tx[0].fs_hz, tx[0].fc_hz, writable))
    assert a is not b and a is not fes[0]
    # another reader (another run) keeps its own segments
    rd2 = Reader(ReaderConfig(), [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(63, 0))
    assert rd2.transmit(QueryRep(session=1), t0_s=0.0, cw_after_s=2e-4).memo is not tx[0].memo


# ----------------------------------------------------------------------------- reader receive / transmit


def test_peak_candidates_kernel_equals_reference():
    """Integer peak and the five largest local maxima around it (plateaus and equal values
    included): the kernel returns the same lags in the same order as the NumPy twin."""
    rng = trial_rng(62, 0)
    for k in range(40):
        n = int(rng.integers(3, 90))
        c = rng.random(n)
        if k % 3 == 0:  # ties and plateaus: values on a coarse grid
            c = np.round(c * 4) / 4
        w = int(rng.integers(1, 8))
        lag, cands = L._kernel_candidates(c, w)
        lag_r, cands_r = RL.peak_candidates_reference(c, w)
        assert lag == lag_r
        np.testing.assert_array_equal(cands, cands_r)
        assert 1 <= cands.size <= 5 and c[cands[0]] == c[cands].max()


@pytest.mark.parametrize("m, trext", [(1, False), (4, False), (2, True), (8, True)])
def test_preamble_search_kernel_equals_reference(m, trext):
    """Noisy replies with an unknown start, gain and offset: the one-call decoder (correlation,
    candidates, sub-sample refinement, estimates, sums + Viterbi) gives the NumPy twin's start
    and bits exactly, its gain and correlation within the bound of their sums' order; the
    known-start decode gives decode_reply's bits."""
    rng = trial_rng(63, m)
    fs, blf = 4e6, 320e3 if m > 1 else 160e3
    for k in range(3):
        bits = rng.integers(0, 2, 64).astype(np.uint8)
        start = 40.0 + 17.3 * k
        n = int(start + L.reply_duration_s(64, m=m, trext=trext, blf_hz=blf) * fs) + 200
        s = L.reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=start / fs, n_samples=n)
        h = 2e-3 * np.exp(1j * (0.4 + k))
        r = h * np.where(s == 0, -1.0, s) + (0.3 - 0.2j) * 1e-3
        r = r + 2e-4 * (rng.standard_normal(r.size) + 1j * rng.standard_normal(r.size))
        kw = dict(n_bits=64, m=m, trext=trext, blf_hz=blf, fs_hz=fs, search_samples=120)
        a, b = L.decode_reply(r, **kw), RL.decode_reply_reference(r, **kw)
        assert a.start_sample == b.start_sample and abs(a.start_sample - start) < 1.5 * fs / (2 * blf)  # ≤ 1 element
        np.testing.assert_array_equal(a.bits, b.bits)
        # corr and gain: sums over the n preamble samples, in order (kernel) or pairwise / by
        # BLAS (twin); two orders of a sum of n terms differ by ≤ 2n·u·Σ|terms| (Higham, eq. 4.4),
        # here Σ|r·t0| ≤ n·max|r| (|t0| ≤ 2) against e_t ≈ n (|t| = 1, |mean| < 1): the gain by
        # ≤ 4n·u·max|r|·2 + 2n·u·|h|, the correlation (three such sums, relative to their values
        # ≈ n·|h|, n·|h|², n) by ≤ 2n·u·(2·max|r|/|h| + 3) relative; + 4 ULP of the final operations
        n_pre, u, big = L._plan(64, m, trext, blf, fs, "viterbi").n_pre, 2.0 ** -53, float(np.max(np.abs(r)))
        d_gain = 8 * n_pre * u * big + 2 * n_pre * u * abs(b.gain)
        d_corr = 2 * n_pre * u * (2 * big / abs(b.gain) + 3) * b.corr
        assert_close_ulp(a.gain, b.gain, int(d_gain / np.spacing(min(abs(b.gain.real), abs(b.gain.imag)))) + 4)
        assert_close_ulp(a.corr, b.corr, int(d_corr / np.spacing(b.corr)) + 4)
        lag = int(math.floor(a.start_sample)) - 3  # on a slice, as the reader decodes r − c
        known = dict(n_bits=64, m=m, trext=trext, blf_hz=blf, fs_hz=fs, gain=a.gain * 1.01)
        full = L.decode_reply(r, start_sample=a.start_sample, **known).bits
        np.testing.assert_array_equal(L.decode_bits(r[lag:], start_sample=a.start_sample - lag, **known), full)
        np.testing.assert_array_equal(RL.decode_reply_reference(r, start_sample=a.start_sample, **known).bits, full)


def test_measurement_on_the_reply_span_equals_the_window():
    """The reader measures on the reply's samples only: the same (h, slope, σ²) bit for bit as
    over the whole window (times from the span's centre do not depend on the slice)."""
    from rfsim.devices.reader_measure import measure as _measure

    rng = trial_rng(64, 0)
    fs = 4e6
    bits = rng.integers(0, 2, 128).astype(np.uint8)
    s = L.reply_waveform(bits, m=4, trext=False, blf_hz=320e3, fs_hz=fs, t0_s=311.4375 / fs, n_samples=8000)
    t = np.arange(s.size) / fs
    z = 1e-4 * np.exp(1j * (0.7 + 2 * np.pi * 55.0 * t)) * s
    z = z + 3e-6 * (rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size))
    whole = _measure(z, s, fs)
    assert _measure(z[311:7300], s[311:7300], fs) == whole
    assert _measure(z[100:], s[100:], fs) == whole
    assert whole[1] / (2 * np.pi) == pytest.approx(55.0, abs=5.0)


@pytest.mark.parametrize("modulation", ["PR-ASK", "DSB-ASK"])
def test_modulate_equals_the_envelope_of_the_whole_segment(modulation):
    """The reader modulates up to 2 Tari after the last rising edge and fills the CW after it:
    the same samples, bit for bit, as the envelope and PR-ASK sign of the whole segment."""
    import dataclasses

    from rfsim.gen2.link import PROFILES
    from rfsim.gen2.pie import pie_timeline, pr_ask_baseband, timeline_envelope

    rng = trial_rng(65, len(modulation))
    for profile, fs, rise_fall in (("miller4-320k", 4e6, 0.1), ("fm0-40k", 1.3e6, 0.33), ("miller4-320k", 3.3e6, 0.0)):
        lk = dataclasses.replace(PROFILES[profile], modulation=modulation)
        rd = Reader(ReaderConfig(link_profile=profile, fs_hz=fs, pie_rise_fall_tari=rise_fall),
                    [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(65, 1), link=lk)
        for cw_after in (0.0, 0.3 * lk.tari_s, 5e-4):
            bits = rng.integers(0, 2, int(rng.integers(1, 40))).astype(np.uint8)
            for preamble in ("query", "frame-sync"):
                x = rd.modulate(bits, preamble=preamble, cw_after_s=cw_after, cw_before_s=lk.tari_s)
                tl = pie_timeline(bits, tari_s=lk.tari_s, data1_tari=lk.data1_tari, trcal_s=lk.trcal_s,
                                  pw_s=lk.pw_s, delimiter_s=lk.delimiter_s, preamble=preamble,
                                  cw_after_s=cw_after, cw_before_s=lk.tari_s)
                e = timeline_envelope(tl, depth=lk.depth, fs_hz=fs, rise_fall_s=rise_fall * lk.tari_s)
                amp = math.sqrt(rd.ptx_w)
                ref = (pr_ask_baseband(tl, e, amplitude=amp, fs_hz=fs) if modulation == "PR-ASK"
                       else (amp * e).astype(np.complex128))
                assert x.dtype == np.complex128 and x.shape == ref.shape
                np.testing.assert_array_equal(x, ref)

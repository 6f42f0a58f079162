"""numba kernels of the capture decoders against their plain-NumPy twins, and the
histogram level split against the sample-exact isodata split."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.gen2.capture import envelope_levels, load_capture, plausible_frames
from rfsim.gen2.linecode import halfsymbols, reply_waveform
from rfsim.gen2.pie import pie_decode_arrays
from rfsim.gen2.replies import _n_bits_rule
from rfsim.gen2.reply_decoding import (_decode_window, _decode_window_python, _fine, _fine_python, _track_decode,
                                       _track_decode_python)
from rfsim.gen2.reply_core import n_pre_elements
from rfsim.gen2.reply_search import LinkHypothesis, _search, preamble_correlation
from rfsim.gen2.reply_tracking import (_block_correlations, track, track_reference,
                                       weighted_polyfit)
from rfsim.core.rng import trial_rng
from reference.gen2_capture import plausible_frames_reference
from reference.gen2_pie import two_level_threshold_reference
from reference.gen2_replies import _search_reference
from reference.gen2_reply_tracking import block_correlations_reference


def _noise(n, seed):
    rng = trial_rng(seed, 0)
    return rng.standard_normal(n) + 1j * rng.standard_normal(n)


def test_frame_gate_kernel_matches_twin(reference_data):
    """On the gr-rfid waveform (401 real commands) and on complex noise (thousands of
    threshold-crossing 'frames') the kernel and its twin keep the same frames with the same
    contrast; the gr-rfid commands all pass, the noise frames all fail."""
    grrfid = load_capture(reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32")
    for x, expect in [(grrfid, 401), (_noise(200_000, 1), 0)]:
        env, thr, lo, hi = envelope_levels(x)
        edges = pie_decode_arrays(env, levels=(thr, lo, hi))
        keep, contrast = plausible_frames(edges, env)
        keep_r, contrast_r = plausible_frames_reference(edges, env)
        assert np.array_equal(keep, keep_r)
        np.testing.assert_allclose(contrast, contrast_r, rtol=1e-12)
        assert keep.sum() == expect


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_histogram_levels_match_isodata(seed):
    """The histogram split equals the isodata split on the samples to within one bin
    (range/16384) — on a two-level envelope with noise and on Rayleigh noise."""
    rng = trial_rng(seed, 3)
    two = np.where(rng.random(50_000) < 0.3, 0.1, 1.0) + 0.02 * rng.standard_normal(50_000)
    for x in (two, np.abs(_noise(50_000, seed))):
        _, thr, lo, hi = envelope_levels(x)
        thr_r, lo_r, hi_r = two_level_threshold_reference(x)
        width = (x.max() - x.min()) / 16384
        assert abs(thr - thr_r) <= 2 * width and abs(lo - lo_r) <= 2 * width and abs(hi - hi_r) <= 2 * width


def test_block_correlation_kernel_matches_twin():
    rng = trial_rng(4, 0)
    el = halfsymbols(rng.integers(0, 2, 40).astype(np.uint8), m=2, trext=True).astype(np.float64)
    y = rng.standard_normal(2500)
    shifts = 0.4 * np.arange(-8, 9) / 8
    sub = np.array([-0.375, -0.125, 0.125, 0.375])
    base = 0.3 * rng.standard_normal(8)
    for u2 in (0.0, 3e-8):
        corr, centres = _block_correlations(y, 17.3, 0.16, u2, el, 8, base, shifts, sub)
        corr_r, centres_r = block_correlations_reference(y, 17.3, 0.16, u2, el, 8, base, shifts, sub)
        np.testing.assert_allclose(corr, corr_r, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(centres, centres_r, rtol=1e-12)


def test_preamble_correlation_definition():
    """|Σ r[k+i]·t0[i]| / (‖t0‖·‖r_k − mean(r_k)‖) lag by lag, written out directly."""
    r = _noise(300, 5)
    t0 = trial_rng(5, 1).standard_normal(40)
    t0 -= t0.mean()
    got = preamble_correlation(r, t0)
    want = []
    for k in range(r.size - t0.size + 1):
        seg = r[k:k + t0.size]
        want.append(abs(np.sum(seg * t0)) / (np.linalg.norm(t0) * np.linalg.norm(seg - seg.mean())))
    np.testing.assert_allclose(got, want, rtol=1e-9)
    assert got.max() <= 1.0 + 1e-12


def _reply_window(seed, *, m, trext, n_bits, blf_hz, fs_hz, start_s=60e-6, noise=0.05):
    """c + h·s(t) + noise with s the reply (±1) of random bits from ``start_s`` and −1 around it."""
    rng = trial_rng(seed, 2)
    bits = rng.integers(0, 2, n_bits).astype(np.uint8)
    s = reply_waveform(bits, m=m, trext=trext, blf_hz=blf_hz, fs_hz=fs_hz, t0_s=start_s)
    s = np.concatenate([np.where(s == 0, -1.0, s), -np.ones(200)])
    w = rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size)
    r = 0.3 - 0.2j + (0.02 + 0.05j) * s + noise * 0.05 * w
    return r, bits


@pytest.mark.parametrize("m, trext, method", [(1, False, "viterbi"), (4, False, "bitwise"), (2, True, "viterbi")])
def test_fine_kernel_matches_twin(m, trext, method):
    """The fused decode-and-fit kernel picks the same BLF, start and bits as the NumPy twin
    (decode_reply + reply_waveform + least squares per BLF), and the bits are those encoded."""
    fs, blf = 2e6, 160e3 * 1.004
    r, bits = _reply_window(m, m=m, trext=trext, n_bits=16, blf_hz=blf, fs_hz=fs)
    centre = 60e-6 * fs + 0.5 * n_pre_elements(m, trext) * fs / (2.0 * blf)
    blfs = 160e3 * (1.0 + 0.002 * np.arange(-8, 9))
    got = _fine(r, centre, 16, m, trext, blfs, fs, method)
    want = _fine_python(r, centre, 16, m, trext, blfs, fs, method)
    assert got[0] == want[0] and got[2] == pytest.approx(want[2], abs=1e-9)
    assert np.array_equal(got[1], want[1]) and np.array_equal(got[1], bits)
    assert _fine(r, -1e6, 16, m, trext, blfs, fs, method) is None  # every start outside the window


@pytest.mark.parametrize("m, trext", [(1, False), (4, True)])
def test_preamble_search_kernel_matches_twin(m, trext):
    """Best correlation, BLF, refined lag and the number of lags tested as the NumPy twin
    (scipy correlation per BLF)."""
    fs = 2e6
    r, _ = _reply_window(10 + m, m=m, trext=trext, n_bits=16, blf_hz=200e3, fs_hz=fs, noise=1.0)
    hyps = [LinkHypothesis(m, trext, 150e3, 260e3), LinkHypothesis(m, not trext, 150e3, 260e3)]
    lo_of, hi_of = (lambda blf: 20), (lambda blf: 200)
    got, n = _search(r, fs, hyps, lo_of, hi_of)
    want, n_r = _search_reference(r, fs, hyps, lo_of, hi_of)
    assert n == n_r and got[1:3] == want[1:3] and got[4:] == want[4:]
    assert got[0] == pytest.approx(want[0], rel=1e-9) and got[3] == pytest.approx(want[3], abs=1e-6)
    # the encoded start (120 samples) to half an element (5 samples per element; coarse BLF grid)
    assert got[2] == hyps[0] and abs(got[3] - 60e-6 * fs) <= 2.5


def test_weighted_polyfit_matches_numpy():
    """weighted_polyfit(t, d, w) equals numpy.polyfit(t, d, w=√w) (weights on the unsquared
    residuals) on sample offsets of a few thousand samples."""
    rng = trial_rng(6, 0)
    t = np.sort(rng.uniform(0, 5000, 40))
    d = 0.3 + 1e-3 * t - 2e-8 * t * t + 0.01 * rng.standard_normal(40)
    w = rng.uniform(0.1, 2.0, 40)
    for deg in (1, 2):
        np.testing.assert_allclose(weighted_polyfit(t, d, w, deg), np.polyfit(t, d, deg, w=np.sqrt(w)),
                                   rtol=1e-7, atol=1e-14)


def test_complex_edges_equal_envelope_edges(reference_data):
    """The comparator and the gate reading a complex capture's magnitude on the fly give the
    edges, frames and contrasts of the explicit |x| envelope (gr-rfid waveform)."""
    x = load_capture(reference_data / "gr-rfid-waveforms" / "reader_tx_query_ack.cf32")
    env, thr, lo, hi = envelope_levels(x)
    a = pie_decode_arrays(env, levels=(thr, lo, hi))
    b = pie_decode_arrays(x, levels=(thr, lo, hi))
    np.testing.assert_allclose(a.pos, b.pos, rtol=0, atol=1e-9)
    assert a.start.size == b.start.size
    assert all(np.array_equal(fa.bits, fb.bits) for fa, fb in zip(a.frames(), b.frames()))
    assert plausible_frames(b, x)[0].sum() == 401
    np.testing.assert_allclose(plausible_frames(a, env)[1], plausible_frames(b, x)[1], rtol=1e-12)


@pytest.mark.parametrize("blf_error, drift_u2", [(0.0, 0.0), (2e-3, 0.0), (-1e-3, 4e-9)])
def test_track_kernel_matches_twin(blf_error, drift_u2):
    """The one-call tracking kernel refines the element clock as the NumPy twin (block
    correlations, triangle peaks, weighted fits span by span) on a Miller-2 reply whose
    clock differs from the starting guess by a BLF error and a drift."""
    fs, blf, m, trext = 1e6, 40e3, 2, True
    rng = trial_rng(7, 0)
    bits = rng.integers(0, 2, 128).astype(np.uint8)
    el = halfsymbols(bits, m=m, trext=trext).astype(np.float64)
    rho = 2 * blf / fs
    t = np.arange(int(el.size / rho) + 400) - 150.3
    u = rho * (1 + blf_error) * t + drift_u2 * t * t
    k = np.floor(u).astype(np.int64)
    s = np.where((u >= 0) & (k < el.size), el[np.clip(k, 0, el.size - 1)], -1.0)
    r = 0.1 + 0.2j + (0.3 - 0.1j) * s + 0.02 * (rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size))
    args = (r, 150.3, rho, 0.0, 0.3 - 0.1j, 0.1 + 0.2j, bits, m, trext, True)
    got, want = track(*args), track_reference(*args)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    assert got[1] == pytest.approx(rho * (1 + blf_error), rel=2e-4)


@pytest.mark.parametrize("m, trext, method, blf_error, drift_u2, truncated", [
    (1, False, "viterbi", 1e-3, 0.0, False), (4, False, "bitwise", -5e-4, 2e-9, False),
    (2, True, "viterbi", 0.0, -3e-9, True)])
def test_track_decode_kernel_matches_twin(m, trext, method, blf_error, drift_u2, truncated):
    """The one-call step 4 (fit, tracking loop, resampling on the tag's clock, decoding
    again; up to two passes) gives the twin's clock, resampled window and bits, and the bits
    are those encoded, on a 96-bit reply whose clock differs from the starting guess by a BLF
    error and a drift (a truncated reply is decoded without its dummy 1)."""
    fs, blf = 2e6, 200e3
    rng = trial_rng(8, m)
    bits = rng.integers(0, 2, 96).astype(np.uint8)
    el = halfsymbols(bits, m=m, trext=trext, dummy=not truncated).astype(np.float64)
    rho = 2 * blf / fs
    t = np.arange(int(el.size / rho) + 300) - 120.4
    u = rho * (1 + blf_error) * t + drift_u2 * t * t
    k = np.floor(u).astype(np.int64)
    s = np.where((u >= 0) & (k < el.size), el[np.clip(k, 0, el.size - 1)], -1.0)
    r = 0.4 - 0.1j + (0.05 + 0.08j) * s + 0.01 * (rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size))
    args = (r, fs, blf, bits, 120.4, truncated, m, trext, method)
    got, want = _track_decode(*args), _track_decode_python(*args)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[0], bits)
    np.testing.assert_allclose(got[1:4], want[1:4], rtol=1e-9, atol=1e-13)
    assert got[5] == want[5] == 120
    np.testing.assert_allclose(got[4], want[4], rtol=1e-9, atol=1e-12)
    # the tracked element clock follows the true one to within 0.15 element over the reply
    tt = np.linspace(0.0, el.size / rho, 9)
    clock = got[2] * (tt + 120.4 - got[1]) + got[3] * (tt + 120.4 - got[1]) ** 2
    np.testing.assert_allclose(clock, rho * (1 + blf_error) * tt + drift_u2 * tt * tt, atol=0.15)


@pytest.mark.parametrize("m, trext, kind, cut_samples, method", [
    (4, False, "EPC", None, "viterbi"), (1, False, "RN16", None, "bitwise"), (1, True, "EPC", 800, "viterbi"),
    (2, False, "handle", None, "viterbi")])
def test_decode_window_kernel_matches_twin(m, trext, kind, cut_samples, method):
    """Steps 3–5 in one kernel (fine BLF over the first bits, length from the PC, whole-reply
    BLF, tracking, measurements) give the twin's bits, BLF, start, gain, noise and
    correlation; the bits are those encoded (a window cut short: the whole bits before the
    cut, reported truncated)."""
    from rfsim.gen2.capture import ReaderCommandRecord
    fs, blf = 2e6, 256e3 * 1.004
    rng = trial_rng(9, m)
    n_bits = {"EPC": 128, "RN16": 16, "handle": 32}[kind]
    bits = rng.integers(0, 2, n_bits).astype(np.uint8)
    if kind == "EPC":
        bits[:16] = [int(c) for c in f"{0x3000:016b}"]  # PC: 6 EPC words
    s = reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=60e-6)
    s = np.concatenate([np.where(s == 0, -1.0, s), -np.ones(300)])[:cut_samples]
    r = 0.3 - 0.2j + (0.02 + 0.05j) * s + 2e-3 * (rng.standard_normal(s.size) + 1j * rng.standard_normal(s.size))
    found, _ = _search(r, fs, [LinkHypothesis(m, trext, 0.85 * 256e3, 1.15 * 256e3)], lambda b: 80, lambda b: 160)
    rule = _n_bits_rule(kind, ReaderCommandRecord(start_s=0.0, name="ACK", bits=""))
    got = _decode_window(r, fs, found, rule, method)
    want = _decode_window_python(r, fs, found, rule, method)
    assert got is not None and want is not None
    assert np.array_equal(got["bits"], want["bits"])
    assert got["truncated"] == want["truncated"] == (cut_samples is not None) and got["n_full"] == want["n_full"]
    n_good = got["bits"].size
    assert np.array_equal(got["bits"], bits[:n_good]) and (n_good == n_bits or 0 < n_good < n_bits)
    for key in ("start", "blf", "drift", "end", "sigma2", "corr"):
        assert got[key] == pytest.approx(want[key], rel=1e-9, abs=1e-12), key
    assert abs(got["h"] - want["h"]) <= 1e-9 * abs(want["h"])
    assert got["blf"] == pytest.approx(blf, rel=2e-3)

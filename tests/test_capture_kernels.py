"""numba kernels of the capture decoders against their plain-NumPy twins, and the
histogram level split against the sample-exact isodata split."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.gen2.capture import envelope_levels, load_capture, plausible_frames, plausible_frames_reference
from rfsim.gen2.linecode import halfsymbols
from rfsim.gen2.pie import pie_decode_arrays, two_level_threshold_reference
from rfsim.gen2.replies import preamble_correlation
from rfsim.gen2.reply_tracking import _block_correlations, block_correlations_reference
from rfsim.rng import trial_rng


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

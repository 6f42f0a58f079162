"""Per-packet pylon DSP on a hand-built baseband (no air step): each packet of the tag
arrives with the gain of its round trip, g_k = √K_u/d_k²·exp(−j4πd_k/λ), frozen over the
packet, on top of a static leakage; the DSP must return d_k from the RSS (eq. 22), the
average radial velocity (d_k − d_{k−1})/Δt from Δφ (eq. 23) where it is below λ/(4Δt),
and that value minus λ/(2Δt)·sign where it is above (aliasing)."""

from __future__ import annotations

import math

import numpy as np

from rfsim.devices.himr_tag import HimrTag, HimrTagConfig
from rfsim.himr.boc import boc_train
from rfsim.himr.dsp import measure_packets
from rfsim.core.rng import trial_rng
from rfsim.core.trajectories import RotatingBoom

PYLON_1 = np.array([-0.1, 1.5, 0.0])  # seed 000 Table 7
FC = 5.79e9
K_U = 1e-9  # W·m⁴


def _baseband(t0, fs, n, noise_std=0.0):
    tag = HimrTag(HimrTagConfig(jitter_rms_s=30e-6), RotatingBoom())
    plan = tag.plan(t0 + n / fs, rng=trial_rng(40, 0))
    keep = (plan.start_s >= t0) & (plan.start_s + tag.config.air_time_s < t0 + n / fs)
    starts, bits = plan.start_s[keep], plan.bits[keep]
    mid = starts + 0.5 * tag.config.air_time_s
    d = np.linalg.norm(tag.trajectory(mid).position_m - PYLON_1, axis=1)
    lam = 299792458.0 / FC
    g = math.sqrt(K_U) / d ** 2 * np.exp(-1j * 4 * np.pi * d / lam)
    r = np.full(n, 3e-3 * np.exp(0.4j), dtype=np.complex128)
    width = int(tag.config.air_time_s * fs) + 4
    for k in range(starts.size):
        a = int((starts[k] - t0) * fs) - 2
        r[a:a + width] += g[k] * boc_train([starts[k]], bits[k], tag.config.code, t0_s=t0 + a / fs, fs_hz=fs,
                                           n_samples=width, rest=0.0)
    if noise_std:
        rng = trial_rng(40, 1)
        r += noise_std * (rng.normal(size=n) + 1j * rng.normal(size=n)) / math.sqrt(2)
    return tag, starts, bits, d, r


def test_range_and_radial_velocity_noise_free():
    t0, fs, n = 0.40, 8e6, 2_400_000          # 0.40–0.70 s, where |ṙ₁| passes 1.822 m/s
    tag, starts, bits, d, r = _baseband(t0, fs, n)
    m = measure_packets(r, t0_s=t0, fs_hz=fs, fc_hz=FC, fmt=tag.config.format, framing=tag.config.framing,
                        code=tag.config.code, expected_starts_s=starts + 1e-6, k_u=K_U)
    assert m.start_s.size == starts.size and m.crc_ok.all()
    # the first sample inside each packet (2 samples per chip: every start in that sample
    # interval assigns the samples to the same chips)
    assert np.all((m.start_s - starts >= -1e-12) & (m.start_s - starts < 1 / fs))
    np.testing.assert_allclose(m.range_m, d, rtol=1e-9)
    lam = 299792458.0 / FC
    dt = np.diff(starts)
    v_avg = np.diff(d) / dt
    limit = lam / (4 * dt)
    # Δt comes from the found starts, quantised to 1/fs: relative error ≤ 2/(fs·Δt) = 3.5e-5
    np.testing.assert_allclose(m.aliasing_limit_mps[1:], limit, rtol=1e-4)
    ok = np.abs(v_avg) < limit
    assert ok.sum() >= 5 and (~ok).sum() >= 5
    np.testing.assert_allclose(m.radial_velocity_mps[1:][ok], v_avg[ok], rtol=1e-4, atol=1e-6)
    alias = v_avg[~ok] - np.sign(v_avg[~ok]) * lam / (2 * dt[~ok])
    np.testing.assert_allclose(m.radial_velocity_mps[1:][~ok], alias, rtol=1e-4, atol=1e-6)
    np.testing.assert_array_equal(m.words, tag.current_plan.words[np.isin(tag.current_plan.start_s, starts)])


def test_range_noise_matches_the_snr():
    """With noise the RSS range scatters as σ_r/r = ¼·σ_P/P, σ_P/P ≈ 2/√(SNR·N) for N samples
    per packet at per-sample SNR (|h|² = power of a ±1 waveform): checked within 30 % over
    the ≈ 40 packets of 0.3 s."""
    t0, fs, n = 0.40, 8e6, 2_400_000
    noise = 2e-6
    tag, starts, bits, d, r = _baseband(t0, fs, n, noise_std=noise)
    m = measure_packets(r, t0_s=t0, fs_hz=fs, fc_hz=FC, fmt=tag.config.format, framing=tag.config.framing,
                        code=tag.config.code, expected_starts_s=starts - 1e-6, k_u=K_U)
    assert m.crc_ok.all()
    rel = m.range_m / d - 1
    snr = (K_U / d ** 4) / noise ** 2
    n_samp = tag.config.air_time_s * fs
    predicted = 0.25 * 2 / np.sqrt(snr * n_samp)
    assert abs(np.std(rel) / np.mean(predicted) - 1) < 0.3
    assert np.all(np.abs(m.snr_db - 10 * np.log10(snr)) < 0.5)

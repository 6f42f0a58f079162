"""HIMR pylons through the air step (rfsim.scenes.himr_air, rfsim.devices.himr_pylon): the measured
complex gain against the radar equation written out here (eq. 3 with M = 1, Friis round trip,
phase 4πd/λ of eq. 1), the phase-derived radial velocity and its aliasing flag against the
trajectory's own distances, the RSS range (eq. 22), and the joint-carrier harmonic bias."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.devices.himr_pylon import Pylon, PylonConfig, lowpass_taps
from rfsim.devices.himr_tag import HimrTag, HimrTagConfig
from rfsim.core.errors import ConfigError
from rfsim.estimators.himr_model import PYLONS_M
from rfsim.core.trajectories import LinearTrapezoid, RotatingBoom
from rfsim.scenes.himr_air import RadioConfig, check_sample_rate, simulate

C = 299792458.0
QUIET = dict(receiver_noise=False)


def test_static_tag_gain_and_phase_equal_the_radar_equation():
    """A tag at rest 1.5 m from a 9.5 dBi pylon (2 dBi tag): |h|² = P_T·G_p²·G_t²·λ⁴/(4π·d)⁴
    (eq. 3, M = |Γ_open − Γ_short|²/4 = 1, X = 1) and φ = −arg h = 4πd/λ + π (eq. 1; the
    re-radiation −Γ of an open chip adds π) to 1e-9; RSS range (eq. 22) with the link-budget
    K_u = d, with the start-pose K_u = d as well."""
    fc = 5.8e9
    lam = C / fc
    d = 1.5
    tag = HimrTag(HimrTagConfig(packet_format="6axis-1d"), LinearTrapezoid(start_m=(d, 0, 0), t_start_s=10.0))
    radio = RadioConfig(fs_hz=20e6, rss_calibration="link-budget", **QUIET)
    run = simulate(tag, [(0.0, 0.0)], [fc], radio, seed=3, t_end_s=0.02)
    m = run.measurements[0]
    assert m.crc_ok.all() and m.start_s.size == 6
    gp, gt = 10 ** 0.95, 10 ** 0.2
    p_expected = run.ptx_w * gp * gp * gt * gt * lam ** 4 / (4 * math.pi * d) ** 4
    np.testing.assert_allclose(np.abs(m.gain) ** 2, p_expected, rtol=1e-6)
    err = np.angle(np.exp(1j * (m.phase_rad - 4 * math.pi * d / lam - math.pi)))
    assert np.abs(err).max() < 1e-6
    np.testing.assert_allclose(m.range_m, d, rtol=1e-6)
    assert not m.aliased.any()
    cal = simulate(tag, [(0.0, 0.0)], [fc], RadioConfig(fs_hz=20e6, **QUIET), seed=3, t_end_s=0.02)
    np.testing.assert_allclose(cal.measurements[0].range_m, d, rtol=1e-6)


def test_boom_radial_velocity_aliasing_and_range():
    """Pylon 1 and the boom at 141 packets/s, 0–0.8 s: where the true mean radial speed over a
    packet interval (from the trajectory's distances at the packet middles) is below
    λ/(4Δt) the measured ṙ equals it within 5 mm/s; where it is above, the packet is flagged
    ``aliased`` and ṙ is off by ∓λ/(2Δt) (the wrapped alias). The RSS range stays within
    0.5 % (the phase turns 4π·v·T_air/λ ≤ 0.26 rad during the 0.384 ms packet at 2.78 m/s:
    the constant-gain fit loses 1 − sinc² of the power, ≤ 0.6 %, a quarter of it in range)."""
    fc = 5.79e9
    lam = C / fc
    boom = RotatingBoom()
    tag = HimrTag(HimrTagConfig(jitter_rms_s=20e-6), boom)
    run = simulate(tag, PYLONS_M[:1], [fc], RadioConfig(rss_calibration="link-budget", **QUIET), seed=4, t_end_s=0.8)
    m = run.measurements[0]
    starts = tag.current_plan.start_s[run.packet_index[0]]
    mid = starts + 0.5 * tag.config.air_time_s
    r = np.linalg.norm(boom(mid).position_m[:, :2] - PYLONS_M[0], axis=1)
    dt = np.diff(starts)
    v = np.diff(r) / dt
    limit = lam / (4 * dt)
    over = np.abs(v) >= limit
    assert over.sum() >= 5 and (~over).sum() >= 20
    np.testing.assert_array_equal(m.aliased[1:], over)
    meas = m.radial_velocity_mps[1:]
    np.testing.assert_allclose(meas[~over], v[~over], atol=5e-3)
    np.testing.assert_allclose(meas[over], v[over] - np.sign(v[over]) * 2 * limit[over], atol=5e-3)
    np.testing.assert_allclose(m.range_m, r, rtol=5e-3)


def test_joint_carriers_show_the_harmonic_bias():
    """All three carriers in one step at 50 MS/s (every 10–20 MHz offset inside ±fs/2) against
    each pylon alone at the same rate, noise-free: the tag's ±1 square wave mixes the other
    carriers onto a pylon's ±2 MHz subcarrier (the 9th/11th harmonics, 1/9 and 1/11 of the
    fundamental, put 5.81 GHz on the 5.79 GHz pylon's subcarrier; wave2-specs.md §H). Their
    projection on the subcarrier is (1/9 − 1/11)/2 ≈ 1 % of the other carrier's fundamental,
    which is comparable to the pylon's own (the distances differ by < 40 %): the gain moves by
    0.3–10 %."""
    res = {}
    for mode, fs in (("ignore", 50e6), ("joint", 50e6)):  # the same time base, the same filter
        tag = HimrTag(HimrTagConfig(), RotatingBoom())
        res[mode] = simulate(tag, PYLONS_M, (5.79e9, 5.80e9, 5.81e9),
                             RadioConfig(fs_hz=fs, cross_carrier=mode, rx_cutoff_hz=3e6, **QUIET), seed=5,
                             t_end_s=0.04)
    for u in range(3):
        hi, hj = res["ignore"].measurements[u].gain, res["joint"].measurements[u].gain
        assert res["joint"].measurements[u].crc_ok.all()
        rel = np.median(np.abs(hj - hi) / np.abs(hi))
        assert 0.003 < rel < 0.10, (u, rel)
    assert res["joint"].dropped == 0


def test_channel_filter_rejects_a_carrier_offset_tone():
    """The pylon's FIR low-pass (cut-off 3 MHz at 50 MS/s) passes 2 MHz within 0.1 dB and
    stops the 10 MHz tone of a neighbouring carrier by ≥ 75 dB."""
    taps = lowpass_taps(3e6, 50e6)
    f = np.array([2e6, 10e6, 20e6])
    resp = np.abs(np.exp(-2j * np.pi * np.outer(f / 50e6, np.arange(taps.size))) @ taps)
    assert abs(20 * np.log10(resp[0])) < 0.1
    assert np.all(20 * np.log10(resp[1:]) < -75)


def test_pylon_emits_its_cw_and_couples_only_its_own():
    p = Pylon(PylonConfig(fc_hz=5.81e9, ptx_w=0.04, coupling_db=-40.0, coupling_phase_rad=0.0), antenna=None)
    seg = p.emit(t0_s=0.1, fs_hz=16e6, n_samples=5)
    np.testing.assert_allclose(seg.samples, 0.2)
    assert seg.fc_hz == 5.81e9
    assert p.coupling(p) == pytest.approx(0.01)
    assert p.coupling(object()) is None
    p.set_sample_rate(16e6)
    assert p.noise_power_w == pytest.approx(1.380649e-23 * 290 * 16e6 * 10 ** 0.6, rel=1e-6)


def test_sample_rate_rules():
    """fs ≥ 8·f_sc = 16 MHz (wave2-specs §H) and ≥ the BOC bandwidth 2·(2 MHz + 500 kHz):
    one-line errors naming radio.fs_hz."""
    tag = HimrTag(HimrTagConfig(), RotatingBoom())
    carriers = (5.79e9, 5.80e9, 5.81e9)
    for fs in (4e6, 12e6):
        with pytest.raises(ConfigError, match="radio.fs_hz"):
            check_sample_rate(RadioConfig(fs_hz=fs), tag, carriers)
    check_sample_rate(RadioConfig(fs_hz=16e6), tag, carriers)
    check_sample_rate(RadioConfig(fs_hz=50e6, cross_carrier="joint"), tag, carriers)


def test_joint_step_at_16_msps_drops_the_other_carriers():
    """A joint step at 16 MS/s: the other pylons' carriers are 10 and 20 MHz away, outside
    ±8 MHz, and the air step drops them (per packet: 2 emitters at the tag's reference
    carrier 5.79 GHz, 2 at each of the 3 receivers = 8 drops); what remains is each pylon's own
    carrier — the same gains as one step per pylon (noise-free, same channel filter)."""
    res = {}
    for mode in ("ignore", "joint"):
        tag = HimrTag(HimrTagConfig(), RotatingBoom())
        res[mode] = simulate(tag, PYLONS_M, (5.79e9, 5.80e9, 5.81e9),
                             RadioConfig(cross_carrier=mode, rx_cutoff_hz=3e6, **QUIET), seed=6, t_end_s=0.03)
    n = tag.current_plan.start_s.size
    assert res["ignore"].dropped == 0 and res["joint"].dropped == 8 * n
    for u in range(3):
        np.testing.assert_allclose(res["joint"].measurements[u].gain, res["ignore"].measurements[u].gain,
                                   rtol=1e-9)

"""HIMR tag device, IMU model and trajectories: kinematics against the seed's and the
reference's printed numbers, IMU scaling/noise/quantisation, the free-running schedule,
Γ(t) on any time base, and the packet round trip tag → baseband → decoder → IMU words."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.devices.himr_tag import HimrTag, HimrTagConfig
from rfsim.devices.imu import G_MPS2, ImuConfig, heading_from_compass, imu_words, true_readings, words_to_si
from rfsim.himr.boc import boc_decode
from rfsim.core.errors import ConfigError
from rfsim.himr.packet import parse_packets
from rfsim.core.rng import trial_rng
from rfsim.core.trajectories import LinearTrapezoid, RotatingBoom, check_inside

PYLONS = np.array([(-0.1, 1.5), (2.0, 3.05), (2.7, -0.03)])   # seed 000 Table 7, L1006–L1008


# ----------------------------------------------------------------------------- trajectories


def test_linear_trapezoid_numbers():
    """Erratum 9 (himr-tag.md §0.3, §3.1): 7.35 m/s² to 1.2 m/s gives t_acc = 0.1633 s,
    d_acc = 0.0980 m; with the 355 ms cruise the travel is 0.6219 m and the motion lasts
    0.6815 s; 0.61 m would need a 0.3451 s cruise."""
    tr = LinearTrapezoid()
    assert tr.t_acc_s == pytest.approx(0.1633, abs=1e-4)
    assert tr.travel_m == pytest.approx(0.6219, abs=1e-4)
    assert tr.duration_s == pytest.approx(0.6815, abs=1e-4)
    k = tr(np.array([0.0, tr.t_acc_s, 0.4, 2.0]))
    np.testing.assert_allclose(k.position_m[:, 0], [1.0, 1.0 + 0.0980, 1.0980 + 1.2 * (0.4 - 0.1633), 1.6219], atol=1e-4)
    assert k.velocity_mps[2, 0] == pytest.approx(1.2)
    assert LinearTrapezoid(preserve="distance").cruise_time_s == pytest.approx(0.3451, abs=1e-4)
    assert LinearTrapezoid(preserve="distance").travel_m == pytest.approx(0.61, abs=1e-12)


def test_boom_kinematics_against_at8():
    """AT-8: θ̇_cruise = 2π/0.7 = 8.976 rad/s, tangential 5.565 m/s², centripetal at cruise
    R·ω² = 24.98 m/s²; start (2, 1.8048) m heading π (L1159, L1100); back at the start after
    1.2 s, having turned 2π."""
    tr = RotatingBoom()
    k = tr(np.array([0.0, 0.25, 0.6, 1.2, 1.5]))
    np.testing.assert_allclose(k.position_m[0, :2], [2.0, 1.8048], atol=1e-12)
    assert k.heading_rad[0] == pytest.approx(math.pi)
    assert k.rate_rad_s[2] == pytest.approx(8.976, abs=1e-3)
    assert k.angular_accel_rad_s2[1] * 0.31 == pytest.approx(5.565, abs=1e-3)
    assert np.hypot(*k.acceleration_mps2[2, :2]) == pytest.approx(24.98, abs=1e-2)
    np.testing.assert_allclose(k.position_m[3:, :2], [[2.0, 1.8048]] * 2, atol=1e-12)
    assert k.heading_rad[4] == pytest.approx(3 * math.pi)
    assert tr.duration_s == pytest.approx(1.2)
    assert RotatingBoom(lag_s=0.15)(np.array([0.15])).position_m[0, 1] == pytest.approx(1.8048)


@pytest.mark.parametrize("tr", [RotatingBoom(), RotatingBoom(direction="cw", lag_s=0.1), LinearTrapezoid()])
def test_derivatives_match_finite_differences(tr):
    """Velocity and acceleration are the time derivatives of the position, heading rate the
    derivative of the heading (central differences, h = 1 µs, away from profile kinks)."""
    t = np.linspace(0.02, 1.15, 40) + 0.0013
    h = 1e-6
    k, kp, km = tr(t), tr(t + h), tr(t - h)
    np.testing.assert_allclose(k.velocity_mps, (kp.position_m - km.position_m) / (2 * h), atol=1e-5)
    np.testing.assert_allclose(k.acceleration_mps2, (kp.velocity_mps - km.velocity_mps) / (2 * h), atol=1e-4)
    np.testing.assert_allclose(k.rate_rad_s, (kp.heading_rad - km.heading_rad) / (2 * h), atol=1e-5)


def test_ranges_and_radial_speeds_to_the_pylons():
    """himr-tag.md §3.3/§1.3 [derived]: ranges over the circle 1.790–2.410 m (pylon 1),
    1.245–1.865 m (pylon 2), 1.368–1.988 m (pylon 3); max |ṙ| 2.78, 2.30, 2.78 m/s."""
    k = RotatingBoom()(np.linspace(0, 1.2, 24001))
    d = k.position_m[:, None, :2] - PYLONS[None]
    r = np.hypot(d[..., 0], d[..., 1])
    rdot = np.sum(d * k.velocity_mps[:, None, :2], axis=2) / r
    np.testing.assert_allclose(r.min(0), [1.790, 1.245, 1.368], atol=1.5e-3)
    np.testing.assert_allclose(r.max(0), [2.410, 1.865, 1.988], atol=1.5e-3)
    np.testing.assert_allclose(np.abs(rdot).max(0), [2.78, 2.30, 2.78], atol=6e-3)


def test_trajectory_leaving_the_room_is_one_line_error():
    """The seed's 4 × 3 m area (L997) holds the boom; a 2.5 m wide room does not."""
    check_inside(RotatingBoom(), t_end_s=1.2, room_min_m=(0, 0), room_max_m=(4, 3))
    with pytest.raises(ConfigError) as err:
        check_inside(RotatingBoom(centre_m=(2.3, 1.5)), t_end_s=1.2, room_min_m=(0, 0), room_max_m=(2.5, 3))
    assert err.value.key == "trajectory" and "\n" not in str(err.value)
    assert "inside the room" in str(err.value)


# ----------------------------------------------------------------------------- IMU


def test_imu_readings_on_the_boom():
    """Body frame of erratum 13: during cruise the accelerometer reads the centripetal
    −R·ω² = −24.98 m/s² on x^B (seed measured ≈ −21, L1090) and 0 on y^B; during the
    acceleration phase +5.565 m/s² on y^B; z reads +g; the gyro ψ̇."""
    k = RotatingBoom()(np.array([0.0, 0.6, 0.1]))
    f = true_readings(k, ImuConfig())
    assert f[1, 0] == pytest.approx(-0.31 * (2 * math.pi / 0.7) ** 2, rel=1e-12)
    assert f[1, 1] == pytest.approx(0.0, abs=1e-12)
    assert f[2, 1] == pytest.approx(0.31 * 2 * math.pi / 0.35, rel=1e-12)
    np.testing.assert_allclose(f[:, 2], G_MPS2)
    np.testing.assert_allclose(f[:, 5], k.rate_rad_s)


def test_quantisation_and_saturation():
    """LSB = range/32768: 8 g → 2.394e-3 m/s²; ±2 g saturates at 32767 on the 24.98 m/s²
    centripetal force; 1000 °/s → 5.326e-4 rad/s."""
    cfg = ImuConfig(noise="none")
    assert cfg.accel_lsb_mps2 == pytest.approx(8 * 9.80665 / 32768)
    assert cfg.gyro_lsb_rad_s == pytest.approx(math.radians(1000) / 32768)
    k = RotatingBoom()(np.array([0.6]))
    w = imu_words(k, cfg, rng=trial_rng(0, 0))
    assert w[0, 0] == round(-0.31 * (2 * math.pi / 0.7) ** 2 / cfg.accel_lsb_mps2)
    w2 = imu_words(k, ImuConfig(noise="none", accel_range_g=2), rng=trial_rng(0, 0))
    assert w2[0, 0] == -32768
    si = words_to_si(w, cfg)
    assert abs(si[0, 5] - 2 * math.pi / 0.7) <= cfg.gyro_lsb_rad_s / 2


@pytest.mark.parametrize("mode, sigma", [("datasheet", 300e-6 * 9.80665 * math.sqrt(92)), ("seed-noise", 0.05)])
def test_accelerometer_noise_level(mode, sigma):
    """White noise σ = 300 µg/√Hz · √92 Hz = 0.02822 m/s² (datasheet) or 0.05 m/s² (seed,
    L616): sample std of 4000 samples within 5 % (relative std of s: 1/√(2n) = 1.1 %)."""
    k = LinearTrapezoid()(np.zeros(4000))
    w = imu_words(k, ImuConfig(noise=mode, accel_range_g=2), rng=trial_rng(1, 0))
    x = words_to_si(w, ImuConfig(accel_range_g=2))[:, 0]
    assert abs(x.std() / sigma - 1) < 0.05
    assert abs(x.mean()) < 4 * sigma / math.sqrt(4000) + 1e-3


def test_compass_heading_round_trip():
    """ψ = δ + atan2(m_x, m_y) recovers the heading (noise-free, 0.6 µT quantisation of a
    22 µT field: |error| ≤ 0.6/22 rad)."""
    tr = RotatingBoom()
    k = tr(np.linspace(0, 1.2, 50))
    for d in (0.0, 1.0):
        cfg = ImuConfig(noise="none", declination_rad=d)
        m = words_to_si(imu_words(k, cfg, rng=trial_rng(0, 0)), cfg)
        psi = heading_from_compass(m[:, 6], m[:, 7], d)
        err = np.angle(np.exp(1j * (psi - k.heading_rad)))
        assert np.abs(err).max() < 0.6 / 22


# ----------------------------------------------------------------------------- tag


def test_schedule_rate_and_jitter():
    """141 packets/s over 1.2 s → 170 packets (t_k = k/141 < 1.2), 300 packets/s over
    0.999 s → 300 packets; jittered periods have
    mean T and std σ_j (2000 periods: tolerances 4σ/√n and 10 %)."""
    tag = HimrTag(HimrTagConfig(), RotatingBoom())
    assert tag.schedule(1.2, rng=trial_rng(0, 0)).size == 170
    tag = HimrTag(HimrTagConfig(jitter_rms_s=50e-6), RotatingBoom())
    p = np.diff(tag.schedule(2000 / 141, rng=trial_rng(0, 1)))
    assert p.size > 1900
    assert abs(p.mean() - 1 / 141) < 4 * 50e-6 / math.sqrt(p.size)
    assert abs(p.std() / 50e-6 - 1) < 0.1
    one_d = HimrTag(HimrTagConfig(packet_format="6axis-1d"), LinearTrapezoid())
    assert one_d.schedule(0.999, rng=trial_rng(0, 0)).size == 300


def test_reflection_is_open_short_and_chunks_equal_one_shot():
    """Γ ∈ {+1, −1}; the share of short chips during a packet is 1/2 (DC-free BOC); Γ on a
    chunked time base equals one call over the whole base."""
    tag = HimrTag(HimrTagConfig(jitter_rms_s=20e-6), RotatingBoom())
    tag.plan(0.1, rng=trial_rng(2, 0))
    fs = 16e6
    g = tag.reflection(0.0, fs, 1_600_000)
    assert set(np.unique(g)) == {1 + 0j, -1 + 0j}
    n_short = int(np.sum(g == -1))
    air = tag.config.air_time_s * fs * tag.current_plan.start_s.size
    assert abs(n_short / air - 0.5) < 0.01
    parts = [tag.reflection(i * 0.0123, fs, int(round(0.0123 * fs))) for i in range(8)]
    np.testing.assert_array_equal(np.concatenate(parts), g[: 8 * int(round(0.0123 * fs))])
    np.testing.assert_array_equal(tag.reradiation(0.0, fs, 100), -tag.reflection(0.0, fs, 100))


def test_packets_round_trip_through_baseband():
    """tag Γ(t) → r = h·Γ + c + noise (SNR 20 dB per sample at 16 MS/s) → BOC decode at the
    scheduled starts → CRC → IMU words identical to what the tag sampled; a packet hit by
    a noise burst loses its words together with its reading. (A constant burst would not
    hurt: every bit holds whole subcarrier cycles, so the matched filter rejects DC.)"""
    tag = HimrTag(HimrTagConfig(jitter_rms_s=20e-6), RotatingBoom(), ImuConfig())
    plan = tag.plan(0.2, rng=trial_rng(3, 0))
    fs, fmt = 16e6, tag.config.format
    n = int(0.2 * fs) + 8000
    rng = trial_rng(3, 1)
    h, c = 0.01 * np.exp(0.7j), 0.5 - 0.2j
    r = h * tag.reflection(0.0, fs, n) + c
    r += 0.001 * (rng.normal(size=n) + 1j * rng.normal(size=n)) / math.sqrt(2)
    burst = int(plan.start_s[5] * fs) + 1000
    r[burst:burst + 200] += 0.05 * (rng.normal(size=200) + 1j * rng.normal(size=200))
    bits = np.array([boc_decode(r, code=tag.config.code, fs_hz=fs, n_bits=fmt.n_bits,
                                start_sample=t * fs, preamble_bits=tag.config.framing.preamble_bits).bits
                     for t in plan.start_s])
    p = parse_packets(fmt, tag.config.framing, bits)
    assert p.crc_ok.sum() == plan.start_s.size - 1 and not p.crc_ok[5]
    np.testing.assert_array_equal(p.words[p.crc_ok], plan.words[p.crc_ok])


def test_bad_tag_configs():
    for kwargs, key in [(dict(packet_format="9-axis"), "tag.packet_format"),
                        (dict(chip_rate_hz=3e6, subcarrier_hz=2e6), "tag.chip_rate_hz"),
                        (dict(packet_rate_hz=5000.0), "tag.packet_rate_hz"),
                        (dict(tag_id=70000), "tag.tag_id")]:
        with pytest.raises(ConfigError) as err:
            HimrTagConfig(**kwargs)
        assert err.value.key == key and "\n" not in str(err.value)
    tag = HimrTag(HimrTagConfig(), RotatingBoom())
    tag.plan(0.05, rng=trial_rng(0, 0))
    with pytest.raises(ConfigError, match="BOC bandwidth"):
        tag.reflection(0.0, 4e6, 100)


def test_reflector_protocol_of_the_air_step():
    """``reflect(segment)`` gives r = A_s − Γ on the segment's time base; constant (the rest
    state) between packets; the antenna follows the trajectory."""
    from types import SimpleNamespace
    tag = HimrTag(HimrTagConfig(structural_mode=0.5), RotatingBoom())
    plan = tag.plan(0.05, rng=trial_rng(4, 0))
    fs = 8e6
    seg = SimpleNamespace(t0_s=plan.start_s[2] - 1e-4, fs_hz=fs, n_samples=8000)
    refl = tag.reflect(seg)
    np.testing.assert_array_equal(refl.reradiation(8000), 0.5 - tag.reflection(seg.t0_s, fs, 8000))
    assert refl.constant_reradiation is None and refl.scatters
    quiet = tag.reflect(SimpleNamespace(t0_s=plan.start_s[2] + 1e-3, fs_hz=fs, n_samples=800))
    assert quiet.constant_reradiation == 0.5 - 1.0
    np.testing.assert_allclose(tag.position_m(0.0), [2.0, 1.8048, 0.0])

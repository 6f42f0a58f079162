"""Active beacon tag and active-RFID reader at sample level (Özkaya's 868 MHz system): MSK
kernels vs their NumPy twins, MSK spectrum and envelope, frame and CRC against crcmod, RSSI
through the air step against the link budget, reporting floor and steps, collisions and
listen-before-talk (rfsim.protocols.beacons)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import firwin

from rfsim.channels import Antenna, Channel, LinkLargeScale, LogDistance, Scene
from rfsim.devices.active_reader import ActiveReader, ActiveReaderConfig
from rfsim.devices.active_tag import ActiveTag, ActiveTagConfig
from rfsim.devices.msk_beacon import (FRAME_BITS, beacon_bits, discriminate, manchester_decode, manchester_encode,
                                msk_phase)
from rfsim.air.step import LinkTable, propagate
from rfsim.protocols.beacons import run_beacons
from rfsim.core.rng import trial_rng
from reference.devices_msk_beacon import discriminate_reference, msk_phase_reference
from reference.ulp import assert_close_ulp

FS = 2e6
RC = 250e3


def test_msk_kernels_equal_their_numpy_twins():
    rng = trial_rng(11, 0)
    checked = 0
    for sps, offset, n in [(8.0, 0.0, 1700), (7.3, -3.25, 2000), (4.0, 17.6, 900)]:
        chips = rng.choice([-1, 1], size=208).astype(np.int8)
        p, on = msk_phase(chips, sps, offset, n)
        pr, onr = msk_phase_reference(chips, sps, offset, n)
        np.testing.assert_array_equal(on, onr)
        np.testing.assert_allclose(p, pr, rtol=0, atol=1e-12)
        y = np.exp(1j * p) + 0.1 * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
        # re, im of y[n]·conj(y[n−1]): two products and a sum each, NumPy's complex loop may fuse
        # them (FMA), so each may move by ≤ 2·eps·|y[n]||y[n−1]|, the angle by ≤ 3·eps [rad]; then
        # atan2 (C library) against np.angle (maybe SIMD), both faithfully rounded: ≤ 1 ULP each.
        # Bound: 2 ULP, and 8·eps absolute (≥ 3·eps plus 2 ULP of π) for the product's share
        assert_close_ulp(discriminate(y, 0.3 - 1j), discriminate_reference(y, 0.3 - 1j), 2,
                         atol=8 * np.finfo(float).eps)
        checked += 1
    assert checked == 3


def test_msk_phase_steps_envelope_and_99_percent_bandwidth():
    """h = 1/2: ±π/2 per chip, linear inside the chip (π/(2·sps) per sample), constant
    envelope; 99 % of the power within ±0.6·R_c (Pasupathy 1979: B99 ≈ 1.2·R_c) and ≥ 99.5 %
    within the reader's ±270 kHz."""
    rng = trial_rng(11, 1)
    sps = 16
    chips = rng.choice([-1, 1], size=4096).astype(np.int8)
    p, on = msk_phase(chips, sps, 0.0, chips.size * sps)
    assert on.all()
    d = np.diff(p)
    np.testing.assert_allclose(np.abs(d), np.pi / (2 * sps), rtol=0, atol=1e-9)
    np.testing.assert_allclose(p[sps::sps] - p[:-sps:sps], chips[:-1] * np.pi / 2, atol=1e-9)
    x = np.exp(1j * p)
    spec = np.abs(np.fft.fftshift(np.fft.fft(x))) ** 2
    f = np.fft.fftshift(np.fft.fftfreq(x.size, 1 / (sps * RC)))
    frac = lambda half: spec[np.abs(f) <= half].sum() / spec.sum()   # noqa: E731
    assert 0.985 <= frac(0.6 * RC) <= 0.995
    assert frac(270e3) >= 0.995


def test_frame_manchester_and_crc_against_crcmod():
    crcmod = pytest.importorskip("crcmod.predefined")
    ref = crcmod.mkPredefinedCrcFun("crc-16-genibus")
    for tag_id, seq in [(0x1234ABCD, 7), (1, 255), (0, 0)]:
        bits = beacon_bits(tag_id, seq)
        assert bits.size == FRAME_BITS == 104
        assert np.array_equal(bits[:32], np.tile([1, 0], 16))
        payload = bytes(np.packbits(bits[48:88]))
        assert int("".join(map(str, bits[88:])), 2) == ref(payload)
        assert payload == tag_id.to_bytes(4, "big") + bytes([seq])
        chips = manchester_encode(bits)
        assert chips.size == 208 and np.all(chips[::2] == -chips[1::2])
        back, violations = manchester_decode(chips)
        assert violations == 0 and np.array_equal(back, bits)
    assert ActiveTagConfig().burst_s == pytest.approx(208 / 250e3, rel=1e-15)


def _link(distance_m, pl_d0_db=57.0, exponent=2.3):
    reader = ActiveReader(ActiveReaderConfig(), Antenna([0.0, 0.0, 1.0]))
    model = LogDistance(exponent, 1.0, pl_d0_db=pl_d0_db)
    ch = Channel(Scene(large_scale=LinkLargeScale(by_antenna=[(reader.antenna, model)])))
    return reader, ch


def _tag(x_m, tag_id=0x42, seed=0, y_m=0.0, **cfg):
    return ActiveTag(ActiveTagConfig(tag_id=tag_id, **cfg), Antenna([x_m, y_m, 1.0]), rng=trial_rng(5, seed))


@pytest.mark.parametrize("distance_m", [1.0, 4.0, 20.0, 60.0])
def test_rssi_through_the_air_step_matches_the_link_budget(distance_m):
    """α = −52 dBm, n = 2.3 (L1141–L1144): Pr = P_t − PL(d) = −52 − 23·log10 d. The measured
    RSSI (filtered power over the frame) equals Pr plus the in-band noise N = k·T0·fs·F·Σh²
    (63-tap filter, NF 10 dB: −107 dBm) within 0.03 dB (the MSK power outside the filter) + 4σ
    of the signal × noise cross term, σ = 4.34·√(2·(N/Pr)/L) dB over L = 1664·(540 kHz/fs)
    independent samples, down to −93 dBm (60 m); the ID and sequence decode; the report is
    the 1 dB step, or nothing below −90 dBm."""
    reader, ch = _link(distance_m)
    tag = _tag(distance_m)
    tag.send(123.4e-6, 9)
    n = int(1.1e-3 * FS)
    res = propagate([tag], [], [reader], LinkTable(ch), t0_s=0.0, fs_hz=FS, n_samples=n, rng=trial_rng(5, 9))
    reads = res.outputs[0]
    expected = -52.0 - 23.0 * np.log10(distance_m)
    taps = firwin(63, 270e3, fs=FS)
    noise_dbm = 10 * np.log10(1.380649e-23 * 290.0 * FS * 10.0 * np.sum(taps ** 2)) + 30
    with_noise = 10 * np.log10(10 ** (expected / 10) + 10 ** (noise_dbm / 10))
    assert len(reads) == 1 and reads[0].crc_ok and (reads[0].tag_id, reads[0].seq) == (0x42, 9)
    sigma_db = 10 / np.log(10) * np.sqrt(2 * 10 ** ((noise_dbm - expected) / 10) / (1664 * 540e3 / FS))
    assert abs(reads[0].rssi_dbm - with_noise) < 0.03 + 4 * sigma_db
    assert abs(reads[0].t_s - 123.4e-6) <= 1 / FS
    if expected >= -90:
        assert reads[0].rssi_reported_dbm == np.round(reads[0].rssi_dbm)
    else:
        assert np.isnan(reads[0].rssi_reported_dbm)


def test_below_sensitivity_nothing_is_decoded():
    """At −115 dBm the in-band SNR is −8 dB (kT·540 kHz·NF 10 dB = −106.7 dBm): no valid frame."""
    reader, ch = _link(1.0, pl_d0_db=120.0)
    tag = _tag(1.0)
    tag.send(100e-6, 1)
    res = propagate([tag], [], [reader], LinkTable(ch), t0_s=0.0, fs_hz=FS, n_samples=2400, rng=trial_rng(5, 10))
    assert not any(r.crc_ok for r in res.outputs[0])


def _collide(delta_db, lag_s=0.3e-3, seed=0):
    reader, ch = _link(1.0)
    a = _tag(3.0, 0xA, seed)
    b = ActiveTag(ActiveTagConfig(tag_id=0xB), Antenna([0.0, 3.0 * 10 ** (delta_db / 23.0), 1.0]),
                  rng=trial_rng(5, seed + 100))
    a.send(60e-6, 1)
    b.send(60e-6 + lag_s, 2)
    n = int((lag_s + 1.0e-3) * FS)
    res = propagate([a, b], [], [reader], LinkTable(ch), t0_s=0.0, fs_hz=FS, n_samples=n, rng=trial_rng(5, 20 + seed))
    return {r.tag_id for r in res.outputs[0] if r.crc_ok}


def test_collisions_lose_equal_beacons_and_capture_the_much_stronger():
    """Two beacons overlapping by 0.53 ms at the same power: neither CRC holds (8 draws of the
    oscillator phases); 20 dB apart: the stronger one is decoded, the weaker is lost."""
    for seed in range(8):
        assert _collide(0.0, seed=seed) == set()
        assert _collide(20.0, seed=seed) == {0xA}


def test_listen_before_talk_defers_and_simultaneous_starts_collide():
    """rfsim.protocols.beacons: tag B due 0.3 ms after tag A began senses A's beacon (4.2 m apart, free space
    between tags: −39 dBm > −90 dBm) and backs off, so both are read; without LBT they collide and, at equal
    power at the reader (both 3 m away), both are lost; two tags due at the same instant both
    find the channel idle and collide."""
    reader, ch = _link(1.0)

    def run(listen_s, lag_s):
        a = _tag(3.0, 0xA, 0, jitter_s=0.0, lbt_listen_s=listen_s)
        b = _tag(0.0, 0xB, 1, y_m=3.0, jitter_s=0.0, lbt_listen_s=listen_s)
        return run_beacons([a, b], [reader], LinkTable(ch), t0_s=0.0, t1_s=0.5, fs_hz=FS, rng=trial_rng(5, 30),
                           offsets_s=[0.1, 0.1 + lag_s])

    lbt = run(0.2e-3, 0.3e-3)
    assert lbt.lbt_steps >= 1 and [r.attempts for r in lbt.bursts] == [1, 2]
    assert not any(r.collided for r in lbt.bursts)
    assert {r.tag_id for r in lbt.reads[0] if r.crc_ok} == {0xA, 0xB}
    off = run(0.0, 0.3e-3)
    assert all(r.collided for r in off.bursts) and not any(r.crc_ok for r in off.reads[0])
    same = run(0.2e-3, 0.0)
    assert same.lbt_steps == 0 and all(r.collided and r.attempts == 1 for r in same.bursts)


def test_beacon_schedule_period_jitter_and_drops():
    """Period 1 s, ±10 ms jitter: 10 beacons in 10 s per tag at k·1 s + offset; a tag whose
    channel stays busy (an LBT threshold below the neighbour's level, one attempt) drops."""
    reader, ch = _link(1.0)
    tags = [_tag(2.0 + i, 0x10 + i, i) for i in range(3)]
    run = run_beacons(tags, [reader], LinkTable(ch), t0_s=0.0, t1_s=10.0, fs_hz=FS, rng=trial_rng(5, 40),
                      offsets_s=[0.2, 0.5, 0.8])
    for i, off in enumerate([0.2, 0.5, 0.8]):
        t = np.array([r.t_s for r in run.bursts if r.tag == i])
        assert t.size == 10
        assert np.all(np.abs(t - (off + np.arange(10))) <= 0.01)
    assert run.steps == 30 and sum(r.crc_ok for r in run.reads[0]) == 30
    seqs = [r.seq for r in run.reads[0] if r.tag_id == 0x10]
    assert seqs == list(range(10))
    a = _tag(3.0, 0xA, 0, jitter_s=0.0, lbt_listen_s=0.0)
    b = _tag(0.0, 0xB, 1, y_m=3.0, jitter_s=0.0, max_attempts=1)
    both = run_beacons([a, b], [reader], LinkTable(ch), t0_s=0.0, t1_s=0.5, fs_hz=FS, rng=trial_rng(5, 41),
                       offsets_s=[0.1, 0.1003])
    dropped = [r for r in both.bursts if r.lbt_dropped]
    assert len(dropped) == 1 and dropped[0].tag == 1 and math.isnan(dropped[0].t_s)

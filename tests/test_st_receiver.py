"""Sense-a-tag receive chain at sample level: kernels vs references, envelope difference vs
the closed forms (issue 5 item 4 at the level of the receive chain), comparator/decoder
threshold behaviour, dual-antenna techniques at a single-antenna null.

Closed-form expectations come from phasor sums written out here (Eq. 3.1/3.6/3.12) and the
printed values of auris-sense-a-tag.md; nothing is compared with outputs of the code under
test alone.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from rfsim.devices import st_analytic as sa
from rfsim.devices import st_receiver as sr
from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import int_to_bits
from rfsim.gen2.crc import append_crc16
from rfsim.gen2.linecode import reply_waveform
from reference.devices_st_receiver import comparator_reference, rc_lowpass_reference

FS_HZ, BLF_HZ = 8e6, 160e3
R_OHM = 50.0
V_TO_SQRT_W = 1.0 / math.sqrt(2.0 * R_OHM)  # peak volts across 50 Ω → baseband √W
RN16 = int_to_bits(0xA5C3, 16)


def _rx(**kw) -> sr.STReceiver:
    return sr.STReceiver(fs_hz=FS_HZ, blf_hz=BLF_HZ, m=2, trext=True, **kw)


def _levels(bits, t0_s=40e-6, tail=300) -> np.ndarray:
    s = reply_waveform(bits, m=2, trext=True, blf_hz=BLF_HZ, fs_hz=FS_HZ, t0_s=t0_s)
    return np.concatenate([s, np.zeros(tail)])


def _st_input(cw_v, b1_v, b2_v, s) -> np.ndarray:
    """Baseband at the ST port [√W]: CW + backscatter state 1 (level ≥ 0) or 2 (level −1)."""
    return (cw_v + np.where(np.asarray(s) < 0, b2_v, b1_v)) * V_TO_SQRT_W


def _epc_bits() -> np.ndarray:
    rng = np.random.default_rng(5)
    return append_crc16(np.concatenate([int_to_bits(0x3000, 16), rng.integers(0, 2, 96).astype(np.uint8)]))


# ----------------------------------------------------------------------------- kernels


def test_rc_lowpass_matches_lfilter_and_chunks():
    rng = np.random.default_rng(0)
    u = rng.normal(size=3000)
    y, last = sr.rc_lowpass(u, fs_hz=FS_HZ, tau_s=0.3e-6, y0=0.2)
    a = 1 - math.exp(-1 / (FS_HZ * 0.3e-6))
    ref = lfilter([a], [1, -(1 - a)], u, zi=[(1 - a) * 0.2])[0]
    np.testing.assert_allclose(y, ref, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(rc_lowpass_reference(u, fs_hz=FS_HZ, tau_s=0.3e-6, y0=0.2)[0], y, atol=1e-14)
    y1, s1 = sr.rc_lowpass(u[:1234], fs_hz=FS_HZ, tau_s=0.3e-6, y0=0.2)
    y2, _ = sr.rc_lowpass(u[1234:], fs_hz=FS_HZ, tau_s=0.3e-6, y0=s1)
    np.testing.assert_array_equal(np.concatenate([y1, y2]), y)
    # step response 1 − exp(−t/τ)
    step, _ = sr.rc_lowpass(np.ones(100), fs_hz=FS_HZ, tau_s=1e-6, y0=0.0)
    np.testing.assert_allclose(step, 1 - np.exp(-np.arange(1, 101) / (FS_HZ * 1e-6)), rtol=1e-12)


def test_i0e_equals_scipy_bit_for_bit():
    """The diode law's exp(-x)·I0(x) kernel against its twin scipy.special.i0e on both series
    (|x| <= 8, > 8), the switch point, signs, the extremes and 2-D input; and I0 itself
    against its power series sum_k (x/2)^(2k)/(k!)^2 at a few points."""
    from scipy.special import i0e

    rng = np.random.default_rng(3)
    x = np.concatenate([rng.uniform(0.0, 8.0, 20000), rng.uniform(8.0, 400.0, 20000), -rng.uniform(0.0, 20.0, 2000),
                        [0.0, -0.0, 8.0, np.nextafter(8.0, 9.0), np.nextafter(8.0, 0.0), 1e-300, 1e300, np.inf,
                         np.nan]])
    got = sr.i0e(x)
    np.testing.assert_array_equal(got.view(np.int64), i0e(x).view(np.int64))
    grid = x[:600].reshape(20, 30)
    np.testing.assert_array_equal(sr.i0e(grid), i0e(grid))
    assert sr.i0e(np.float64(3.0)).shape == () and sr.i0e(3.0)[()] == i0e(3.0)
    for v in (0.3, 2.0, 7.5, 12.0):
        series = sum((v / 2.0) ** (2 * k) / math.factorial(k) ** 2 for k in range(80))
        assert sr.i0e(np.array([v]))[0] * math.exp(v) == pytest.approx(series, rel=1e-14)


def test_comparator_matches_reference():
    rng = np.random.default_rng(1)
    v = np.cumsum(rng.normal(scale=2e-3, size=5000))
    out, st, tog = sr.comparator(v, threshold_v=5e-3)
    ref, st_r, tog_r = comparator_reference(v, threshold_v=5e-3)
    np.testing.assert_array_equal(out, ref)
    assert (st, tog) == (st_r, tog_r) and tog == np.count_nonzero(np.diff(out)) + (out[0] > 0)
    # a ±2.4 mV square wave (4.8 mV pk-pk) never toggles a 5 mV comparator; ±2.6 mV does
    sq = np.tile(np.r_[np.full(10, 1.0), np.full(10, -1.0)], 20)
    assert sr.comparator(2.4e-3 * sq, threshold_v=5e-3)[2] == 0
    assert sr.comparator(2.6e-3 * sq, threshold_v=5e-3)[2] == 40  # from state −1: 20 up + 20 down


def test_detector_units_and_config():
    det = sr.EnvelopeDetector(tau_s=1e-6)
    p_w = 1e-3  # 0 dBm into 50 Ω → peak 0.3162 V
    x = np.full(10, math.sqrt(p_w))
    np.testing.assert_allclose(det.instantaneous_v(x), math.sqrt(2 * 50 * p_w))
    sq = sr.EnvelopeDetector(tau_s=1e-6, law="square", responsivity_v_per_w=500.0)
    np.testing.assert_allclose(sq.output_v(x, fs_hz=FS_HZ), 500.0 * p_w)
    with pytest.raises(ConfigError):
        sr.EnvelopeDetector(tau_s=1e-6, law="log")
    with pytest.raises(ConfigError):
        sr.EnvelopeDetector(tau_s=0.0)
    with pytest.raises(ConfigError):
        _rx(bpf_high_factor=30.0)


def test_source_voltage_unit_reproduces_table_3_1_cw_level():
    # Independent derivation: 3.28 W EIRP (auris-sense-a-tag.md §6.1) at 1 m on a half-wave
    # dipole (G = 1.64): P = EIRP/(4π d²)·G·λ²/(4π) = 3.66 mW at 915 MHz; the source's unit
    # is the peak sqrt(2P) across 1 Ω = 0.0856 V, Table 3.1 measured A_R = 0.0802 V at cell 1
    # (L3372-3380), the tag at 1 m and the ST within 0.5 m of it.
    lam = 299792458.0 / 915e6
    p_w = 3.28 / (4 * math.pi) * 1.64 * lam ** 2 / (4 * math.pi)
    v50 = sr.EnvelopeDetector(tau_s=1e-6).instantaneous_v(np.array([math.sqrt(p_w)]))[0]
    v_src = float(sr.to_source_volts(v50))
    assert v_src == pytest.approx(math.sqrt(2 * p_w), rel=1e-12)
    assert v_src == pytest.approx(0.0802, rel=0.1)
    assert float(sr.to_source_volts(1.0, impedance_ohm=1.0)) == 1.0
    with pytest.raises(ValueError):
        sr.to_source_volts(1.0, impedance_ohm=0.0)


# ----------------------------------------------------------------------------- sample level = closed form


def _zero_crossings(th, d):
    i = np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0)
    return th[i] - d[i] * (th[i + 1] - th[i]) / (d[i + 1] - d[i])


def _sweep(rx, s, b_states, cw_v, thetas):
    """Signed envelope difference A(+1) − A(−1) measured for each θ (states known)."""
    out = np.empty(thetas.size)
    for i, th in enumerate(thetas):
        b1, b2 = (b * np.exp(1j * th) for b in b_states)
        env = rx.envelope_detector.output_v(_st_input(cw_v, b1, b2, s), fs_hz=FS_HZ)
        out[i] = sr.state_envelope_difference(env, s, settle_samples=rx.settle_samples)
    return out


@pytest.mark.parametrize("a_r,a_t1,a_t2", [(0.0802, 0.0576, 0.0560), (0.1087, 0.0585, 0.0568), (1.0, 0.4, 0.3)])
def test_ask_sample_level_equals_eq_3_4(a_r, a_t1, a_t2):
    rx = _rx()
    s = _levels(RN16)
    thetas = np.linspace(-np.pi, np.pi, 129)  # ≥ 64 values of θ
    meas = _sweep(rx, s, (a_t1, a_t2), a_r, thetas)
    # Eq. 3.3 phasors written out: A1 − A2 (signed)
    exp = np.abs(a_r + a_t1 * np.exp(1j * thetas)) - np.abs(a_r + a_t2 * np.exp(1j * thetas))
    assert thetas.size >= 64
    np.testing.assert_allclose(np.abs(meas), np.abs(exp), rtol=0.01, atol=1e-9)
    np.testing.assert_allclose(np.abs(meas), sa.ask_envelope_difference(a_r, a_t1, a_t2, thetas), rtol=0.01,
                               atol=1e-9)
    # nulls at ±θ_cancel (Eq. 3.5) within 0.02 rad
    tc = math.acos(-(a_t1 + a_t2) / (2 * a_r))
    z = np.sort(_zero_crossings(thetas, meas))
    assert z.size == 2
    np.testing.assert_allclose(z, [-tc, tc], atol=0.02)


@pytest.mark.parametrize("psi", [np.pi, np.pi / 2, np.pi / 4])
def test_psk_sample_level_equals_eq_3_9(psi):
    rx = _rx()
    s = _levels(RN16)
    a_r, a_t = 1.0, 0.4  # Fig. 3.5
    thetas = np.linspace(-np.pi, np.pi, 128, endpoint=False) + 0.0123  # no grid point on a null
    meas = _sweep(rx, s, (a_t, a_t * np.exp(1j * psi)), a_r, thetas)
    exp = np.abs(np.abs(a_r + a_t * np.exp(1j * thetas)) - np.abs(a_r + a_t * np.exp(1j * (thetas + psi))))
    np.testing.assert_allclose(np.abs(meas), exp, rtol=0.01, atol=1e-9)
    np.testing.assert_allclose(np.abs(meas), sa.psk_envelope_difference(a_r, a_t, psi, thetas), rtol=0.01,
                               atol=1e-9)
    assert np.abs(meas).max() <= 2 * a_t * math.sin(psi / 2) * 1.01
    z = np.sort(_zero_crossings(thetas, meas))
    nulls = np.sort((np.array([-psi / 2, -psi / 2 + np.pi]) + np.pi) % (2 * np.pi) - np.pi)
    assert z.size == 2
    np.testing.assert_allclose(z, nulls, atol=0.02)


# ----------------------------------------------------------------------------- comparator / decoder


def test_rn16_above_threshold_decodes_below_does_not():
    rx = _rx()
    s = _levels(RN16)
    # 20 mV envelope difference (θ = 0): detected and decoded; measured difference = A_T1 − A_T2
    r = rx.receive(_st_input(0.2, 0.080, 0.060, s), n_bits=16, crc=False)
    assert r.detected and np.array_equal(r.bits, RN16)
    assert r.envelope_difference_v == pytest.approx(0.020, rel=0.01)
    # a known search window gives the same result
    r_w = rx.receive(_st_input(0.2, 0.080, 0.060, s), n_bits=16, crc=False, search_samples=int(60e-6 * FS_HZ))
    assert r_w.detected and np.array_equal(r_w.bits, RN16) and r_w.start_sample == r.start_sample
    # 3 mV (< 5 mV): the comparator never toggles, nothing detected
    r = rx.receive(_st_input(0.2, 0.063, 0.060, s), n_bits=16, crc=False)
    assert not r.detected and r.bits is None and r.toggles == 0
    assert np.isnan(r.envelope_difference_v)
    # with the true states supplied the difference is still measured
    r = rx.receive(_st_input(0.2, 0.063, 0.060, s), n_bits=16, crc=False, states=s)
    assert r.envelope_difference_v == pytest.approx(0.003, rel=0.01)


def test_epc_with_crc_and_table_3_1_cases():
    rx = _rx()
    bits = _epc_bits()
    s = _levels(bits)
    r = rx.receive(_st_input(0.2, 0.080, 0.060, s), n_bits=bits.size, crc=True)
    assert r.detected and np.array_equal(r.bits, bits)
    # a corrupted CRC is not a detection
    bad = bits.copy()
    bad[-1] ^= 1
    r = rx.receive(_st_input(0.2, 0.080, 0.060, _levels(bad)), n_bits=bits.size, crc=True)
    assert not r.detected
    # Table 3.1 amplitudes (V at the detector, gain 1): cancellation point → 0.000133 V, not detected
    a_r, a_t1, a_t2, th = 0.0802, 0.0576, 0.0560, 2.2710
    r = rx.receive(_st_input(a_r, a_t1 * np.exp(1j * th), a_t2 * np.exp(1j * th), s), n_bits=bits.size, states=s)
    assert not r.detected and r.envelope_difference_v == pytest.approx(0.000133, abs=5e-7)
    # source detector output ≈ 6× the antenna difference (0.0017 V → 0.01 V, L3358-3362): with
    # gain 6 the no-cancellation row (0.0015 V) is detected, the cancellation row is not
    rx6 = _rx(detector=sr.EnvelopeDetector(tau_s=1 / (2 * math.pi * 4 * BLF_HZ), gain=6.0))
    a_r, a_t1, a_t2, th = 0.1087, 0.0585, 0.0568, 0.7570
    r = rx6.receive(_st_input(a_r, a_t1 * np.exp(1j * th), a_t2 * np.exp(1j * th), s), n_bits=bits.size)
    assert r.detected and r.envelope_difference_v == pytest.approx(6 * 0.0015, rel=0.01)


# ----------------------------------------------------------------------------- dual antenna


def _dual_inputs(orientation_deg: float, s):
    """Eq. 3.23 geometry: SA2 at a single-antenna null on the reader–tag axis, SA1 λ/4 away.

    Phasors: CW ``A_R·e^{−j2πR̃/λ}``, backscatter ``A_Ti·e^{j(−2πr/λ + θ_C)}``, so that
    θ = 2π(R̃ − r)/λ + θ_C as in Eq. 3.23.
    """
    m = sa.NullMapModel()
    lam = m.wavelength_m
    s_null = m.axis_nulls_m(1.55, 1.65)
    assert s_null.size == 1
    p2 = np.array([0.0, s_null[0]])
    u = np.array([math.sin(math.radians(orientation_deg)), math.cos(math.radians(orientation_deg))])
    p1 = p2 + lam / 4 * u

    def phasors(p):
        big_r, r = np.hypot(*p), np.hypot(p[0], p[1] - 2.0)
        cw = m.a_r_trans / big_r * np.exp(-2j * np.pi * big_r / lam)
        bs = np.exp(1j * (-2 * np.pi * r / lam + m.theta_c_rad)) / r
        return cw, m.a_t1_bsk * bs, m.a_t2_bsk * bs

    ph1, ph2 = phasors(p1), phasors(p2)
    return _st_input(*ph1, s), _st_input(*ph2, s), ph1, ph2


@pytest.mark.parametrize("orientation_deg", [45.0, 315.0])
def test_dual_antenna_recovers_single_antenna_null(orientation_deg):
    rx = _rx()
    bits = _epc_bits()
    s = _levels(bits)
    x1, x2, ph1, ph2 = _dual_inputs(orientation_deg, s)
    # single antenna (SA2, the full ST): synchronised difference > 5 mV but at a null
    assert abs(abs(ph2[1]) - abs(ph2[2])) > 5e-3
    single = rx.receive(x2, n_bits=bits.size, states=s)
    assert not single.detected and single.envelope_difference_v < 1e-4
    # simple combination: measured = Eq. 3.21 from Eq. 3.15 of the per-antenna quantities
    comb = sr.receive_combined(rx, x1, x2, n_bits=bits.size, states=s)
    th = np.angle(ph1[1]) - np.angle(ph1[0])
    thp = np.angle(ph2[1]) - np.angle(ph2[0])
    th1 = np.angle(ph2[0]) - np.angle(ph1[0])
    c = sa.combine_dual(abs(ph1[0]), abs(ph1[1]), abs(ph1[2]), th, abs(ph2[0]), abs(ph2[1]), abs(ph2[2]), thp, th1)
    assert comb.envelope_difference_v == pytest.approx(float(sa.combined_envelope_difference(c)), rel=0.01)
    assert comb.detected and np.array_equal(comb.bits, bits)
    # receiving-path selection: P2 (SA2) decodes nothing, Algorithm 1 returns ID1 from SA1
    sel = sr.receive_selection(rx, x1, x2, n_bits=bits.size)
    assert sel.detected and sel.path == 1 and np.array_equal(sel.selected.bits, bits)
    assert sel.p1.envelope_difference_v == pytest.approx(
        float(sa.ask_envelope_difference(abs(ph1[0]), abs(ph1[1]), abs(ph1[2]), th)), rel=0.01)


def test_selection_prefers_p2_when_both_decode():
    rx = _rx()
    s = _levels(RN16)
    x = _st_input(0.2, 0.08, 0.06, s)
    sel = sr.receive_selection(rx, x, x, n_bits=16, crc=False)
    assert sel.path == 2 and sel.selected is sel.p2
    quiet = _st_input(0.2, 0.061, 0.06, s)
    assert sr.receive_selection(rx, quiet, quiet, n_bits=16, crc=False).path is None


def test_ask_psk_stamp_switches_path_at_ask_null():
    rx = _rx()
    bits = _epc_bits()
    fr = sr.stamp_frame(bits, m=2, trext=True, blf_hz=BLF_HZ, fs_hz=FS_HZ, n_stamp_cycles=8, t0_s=40e-6,
                        tail_s=40e-6)
    assert fr.states.size == fr.levels.size and fr.ask_stop - fr.start == round(8 / BLF_HZ * FS_HZ)
    assert set(np.unique(fr.states[fr.start:fr.ask_stop])) == {sr.STAMP_S1, sr.STAMP_S2}
    assert set(np.unique(fr.states[fr.ask_stop:fr.psk_stop])) == {sr.STAMP_S1, sr.STAMP_S3}
    m = sa.NullMapModel()
    lam = m.wavelength_m
    p2 = np.array([0.0, m.axis_nulls_m(1.55, 1.65)[0]])
    p1 = p2 + lam / 4 * np.array([math.sin(math.pi / 4), math.cos(math.pi / 4)])
    psi = np.pi  # ideal 180° PSK (seed L6017-6019)

    def port(p):
        big_r, r = np.hypot(*p), np.hypot(p[0], p[1] - 2.0)
        cw = m.a_r_trans / big_r * np.exp(-2j * np.pi * big_r / lam)
        bs = np.exp(1j * (-2 * np.pi * r / lam + m.theta_c_rad)) / r
        g = np.array([m.a_t1_bsk, m.a_t2_bsk, m.a_t1_bsk * np.exp(1j * psi)]) * bs
        return (cw + g[fr.states]) * V_TO_SQRT_W

    x1, x2 = port(p1), port(p2)
    res = sr.receive_stamp(rx, x1, x2, fr, n_bits=bits.size)
    assert res.ask_symbol == "-" and res.psk_symbol == "1" and res.cancellation_flagged
    assert res.use_p1 and res.detected and np.array_equal(res.selected.bits, bits)
    # no cancellation on P2: the stamp keeps P2
    res2 = sr.receive_stamp(rx, x2, x1, fr, n_bits=bits.size)
    assert res2.ask_symbol == "1" and not res2.use_p1 and res2.detected


def test_passband_detector_equals_eq_3_4():
    """Real RF samples of Eq. 3.2 (C_i = A_R cos ωt + A_Ti cos(ωt+θ)) through a full-wave
    rectifier + RC: an independent check that the baseband detector |x| is the envelope.

    The carrier is scaled down to f_c ≈ 2.98 MHz (fs/f_c = 20 + √2, incommensurate so the
    sampled |cos| averages to 2/π); τ = 3 µs ≫ 1/f_c; states alternate every 60 µs.
    """
    fs, tau = 64e6, 3e-6
    fc = fs / (20 + math.sqrt(2))
    run = int(60e-6 * fs)
    s = np.tile(np.r_[np.ones(run), -np.ones(run)], 3)
    t = np.arange(s.size) / fs
    a_r, a_t1, a_t2 = 0.0802, 0.0576, 0.0560  # Table 3.1, cancellation row
    thetas = np.linspace(-np.pi, np.pi, 64, endpoint=False) + 0.0123
    meas = np.empty(thetas.size)
    for i, th in enumerate(thetas):
        v = a_r * np.cos(2 * np.pi * fc * t) + np.where(s > 0, a_t1, a_t2) * np.cos(2 * np.pi * fc * t + th)
        env = sr.passband_envelope_v(v, fs_hz=fs, tau_s=tau)
        meas[i] = sr.state_envelope_difference(env, s, settle_samples=int(8 * tau * fs))
    exp = np.abs(np.abs(a_r + a_t1 * np.exp(1j * thetas)) - np.abs(a_r + a_t2 * np.exp(1j * thetas)))
    # 1 % of the value, or 0.2 % of the peak |A_T1 − A_T2| near the nulls (residual carrier ripple)
    np.testing.assert_allclose(np.abs(meas), exp, rtol=0.01, atol=2e-3 * abs(a_t1 - a_t2))
    z = np.sort(_zero_crossings(thetas, meas))
    tc = math.acos(-(a_t1 + a_t2) / (2 * a_r))
    np.testing.assert_allclose(z, [-tc, tc], atol=0.02)


def _rectifier_output_v(v_d, nvt):
    """Unloaded exponential-diode peak detector by direct quadrature (independent of the
    Bessel form): the output v where the mean diode current over a carrier period is zero,
    (1/2π)·∫ e^{(V_d·cos ωt − v)/(n·V_T)} dωt = 1 → v = n·V_T·ln(mean of e^{V_d·cos/(n·V_T)})."""
    wt = np.linspace(0.0, 2.0 * np.pi, 4001)[:-1]
    z = v_d / nvt * np.cos(wt)
    zmax = z.max()
    return nvt * (zmax + np.log(np.mean(np.exp(z - zmax))))


def test_diode_law_against_direct_rectifier_and_its_limits():
    det = sr.EnvelopeDetector(tau_s=1e-6, law="diode", matching_gain=0.96, ideality=1.05, temperature_k=290.0)
    nvt = 1.05 * 1.380649e-23 * 290.0 / 1.602176634e-19  # n·k·T/q = 26.24 mV
    assert det.thermal_voltage_v == pytest.approx(nvt, rel=1e-12)
    for v in (1e-4, 3e-3, 0.03, 0.2, 0.6, 2.0):
        assert float(det.transfer_v(v)) == pytest.approx(_rectifier_output_v(0.96 * v, nvt), rel=1e-9), v
    # square law below n·V_T: v ≈ (G_v·V)²/(4·n·V_T); linear slope G_v far above
    v = 1e-4
    assert float(det.transfer_v(v)) == pytest.approx((0.96 * v) ** 2 / (4 * nvt), rel=1e-3)
    dv = 1e-6
    assert float(det.transfer_v(20.0 + dv) - det.transfer_v(20.0)) / dv == pytest.approx(0.96, rel=1e-3)
    # small-signal slope G_v·I1(x)/I0(x) against a finite difference of the law
    for v in (0.05, 0.3, 0.8):
        fd = float(det.transfer_v(v + 1e-7) - det.transfer_v(v - 1e-7)) / 2e-7
        assert float(det.slope(v)) == pytest.approx(fd, rel=1e-5)
    # the chain uses it: a constant input gives the law's output after the RC
    x = np.full(64, 0.6 / math.sqrt(2 * R_OHM))
    np.testing.assert_allclose(det.output_v(x, fs_hz=FS_HZ), _rectifier_output_v(0.96 * 0.6, nvt), rtol=1e-9)
    with pytest.raises(ConfigError):
        sr.EnvelopeDetector(tau_s=1e-6, law="agc")  # no table


def test_diode_detector_reproduces_the_quoted_output_differences(reference_data):
    """R3-1 (Table 3.1 row 2, |A1 − A2| = 0.0015 V in the source's unit → "0.01 V") and R3-4
    (SA1, 0.0019 V → 0.012 V). The default diode detector (G_v = 0.96, n = 1.05, 290 K) on the
    50 Ω peak voltages (√50 × source volts) meets both within 2 %; the unit-gain linear
    detector gives 0.0106 V and 0.0134 V (+6 %, +12 %); PASS's tag demodulator normalises
    the envelope peak to venv(V_rf) (``meas_tag_agc``, Vdda 2 V, chip voltage √(2P·R_p) with
    the ST chip Z_ic = 70.085 − j111.36 Ω, pass-paris-simulator.md §2.2/§2.3): venv·|A1 − A2|/A_peak
    gives 0.0084 V and 0.029 V — R3-4 missed by 2.4×."""
    from scipy.io import loadmat

    agc = loadmat(reference_data / "pass-characteristics" / "meas_tag_agc.mat", squeeze_me=True)
    vrf, venv = np.asarray(agc["vrf"], float), np.asarray(agc["venv"], float)[:, list(agc["vdda"]).index(2.0)]
    r_p = 1.0 / (1.0 / complex(70.085, -111.36)).real
    diode = sr.EnvelopeDetector(tau_s=1e-6, law="diode")
    cases = {"R3-1": ((0.1087, 0.0585, 0.0568, 0.7570), 0.01, 0.10),
             "R3-4": ((0.0976, 0.066, 0.064, 3.2536), 0.012, 0.15)}
    for name, ((a_r, a_t1, a_t2, th), quoted, tol) in cases.items():
        e1, e2 = (abs(a_r + a * np.exp(1j * th)) * math.sqrt(50.0) for a in (a_t1, a_t2))
        out = abs(float(diode.transfer_v(e1) - diode.transfer_v(e2)))
        assert out == pytest.approx(quoted, rel=0.02), name
        d = float(sa.ask_envelope_difference(a_r, a_t1, a_t2, th))
        linear = d * math.sqrt(50.0)  # sqrt(2·50 Ω·P) / sqrt(2P)
        assert linear == pytest.approx(quoted, rel=tol) and linear > 1.05 * quoted, name
        a_peak = max(abs(a_r + a_t1 * np.exp(1j * th)), abs(a_r + a_t2 * np.exp(1j * th)))
        agc_out = np.interp(a_peak * np.sqrt(r_p), vrf, venv) * d / a_peak
        if name == "R3-4":
            assert agc_out > 2.0 * quoted
        else:
            assert agc_out == pytest.approx(0.0084, abs=0.0003)

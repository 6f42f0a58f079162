"""Tag front end: power transmission, power-wave Γ, modulation factor, sensitivity, clock, BLF.

Closed forms are derived independently in the tests (conjugate match, short/open loads,
τ + |Γ|² = 1); the PASS default constants are checked against the PASS characteristic files
and the numbers quoted in pass-paris-simulator.md §5.2; BLF tolerance from rfsim.gen2.link.
"""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.devices.tag_frontend import (
    PASS_PICMIN_900MHZ_W,
    PASS_TAG_JITTER_RMS,
    PASS_ZIC_900MHZ_OHM,
    PASS_ZMOD_900MHZ_OHM,
    PowerUp,
    ReflectionStates,
    TagClock,
    differential_rcs_m2,
    modulation_factor,
    parallel_ohm,
    power_transmission_coefficient,
    reflection_coefficient,
)
from rfsim.devices.tag_chip import load_pass_tag_characteristics
from rfsim.core.errors import ConfigError, UserError
from rfsim.core.units import dbm_to_w, wavelength_m

ZC = complex(32.0, -198.6)


def test_conjugate_match_tau_one_gamma_zero():
    for zc in (ZC, complex(10, -300), complex(50, 0), complex(1200, 40)):
        za = np.conj(zc)
        assert power_transmission_coefficient(zc, za) == pytest.approx(1.0, abs=1e-14)
        assert abs(reflection_coefficient(zc, za)) < 1e-14


def test_closed_form_loads():
    r = 50.0
    # Real antenna: short → Γ = −1, open → Γ → +1, real load R_L → (R_L − R)/(R_L + R).
    assert reflection_coefficient(0.0, r) == pytest.approx(-1.0)
    assert reflection_coefficient(1e12, r) == pytest.approx(1.0, abs=1e-9)
    assert reflection_coefficient(150.0, r) == pytest.approx(0.5)
    assert power_transmission_coefficient(150.0, r) == pytest.approx(0.75)  # 4·150·50/200²
    # Complex antenna, short load: |Γ| = 1 with Γ = −Z_a*/Z_a (power-wave definition;
    # the voltage-wave (Z − Za)/(Z + Za) would give −1 here).
    za = complex(30.3, 157.0)
    assert reflection_coefficient(0.0, za) == pytest.approx(-np.conj(za) / za)
    assert abs(reflection_coefficient(0.0, za)) == pytest.approx(1.0)
    # A purely reactive chip absorbs nothing.
    assert power_transmission_coefficient(complex(0, -200), za) == 0.0


def test_tau_plus_gamma_squared_is_one():
    # Power conservation for the power-wave Γ: 1 − |Γ|² = 4 R_c R_a / |Z_c + Z_a|².
    rng = np.random.default_rng(0)
    zc = rng.uniform(0.1, 500, 1000) + 1j * rng.uniform(-800, 800, 1000)
    za = rng.uniform(0.1, 500, 1000) + 1j * rng.uniform(-800, 800, 1000)
    np.testing.assert_allclose(power_transmission_coefficient(zc, za), 1 - np.abs(reflection_coefficient(zc, za)) ** 2,
                               rtol=0, atol=1e-12)


def test_modulation_factor():
    assert modulation_factor(0, -1) == 0.25
    assert ReflectionStates.ask().modulation_factor == 0.25  # Γ_A ≈ 0, Γ_B = −1
    assert modulation_factor(1, -1) == 1.0
    assert modulation_factor(0.3 + 0.1j, 0.3 + 0.1j) == 0.0
    # PSK: |Γ|e^(±jφ) → M = |Γ|² sin²φ.
    psk = ReflectionStates.psk(0.8, np.pi / 5)
    assert abs(psk.gamma_a) == pytest.approx(abs(psk.gamma_b))
    assert psk.modulation_factor == pytest.approx(0.64 * np.sin(np.pi / 5) ** 2)
    np.testing.assert_array_equal(psk.gamma(np.array([0, 1, 1])), [psk.gamma_a, psk.gamma_b, psk.gamma_b])
    with pytest.raises(ConfigError):
        ReflectionStates(0, 1.2)
    with pytest.raises(ConfigError):
        ReflectionStates.ask(0, 0.5j)


def test_differential_rcs_matches_griffin_durgin_link_budget():
    # Radar equation with Δσ/4 must equal P_R = P_T G_T G_R G² (λ/4π)⁴ / d⁴ · M (§4.7).
    lam, g_tag, g_r, p_t, d = wavelength_m(915e6), 1.64, 4.0, 1.0, 3.0
    states = ReflectionStates(0.1 + 0.05j, -0.7 + 0.2j)
    rcs = states.differential_rcs_m2(gain_lin=g_tag, wavelength_m=lam)
    p_radar = p_t * g_r * g_r * lam**2 * (rcs / 4) / ((4 * np.pi) ** 3 * d**4)
    p_gd = p_t * g_r * g_r * g_tag**2 * (lam / (4 * np.pi)) ** 4 / d**4 * states.modulation_factor
    assert p_radar == pytest.approx(p_gd, rel=1e-12)
    # Open ↔ short of a real antenna: Δσ = λ²G²·4/(4π) = λ²G²/π (the maximum).
    assert differential_rcs_m2(1, -1, gain_lin=g_tag, wavelength_m=lam) == pytest.approx(lam**2 * g_tag**2 / np.pi)


def test_sensitivity_threshold():
    pu = PowerUp()  # PASS chip, conjugate-matched antenna
    assert pu.tau == pytest.approx(1.0)
    p_min = PASS_PICMIN_900MHZ_W
    assert pu.is_powered(p_min) and pu.is_powered(1.001 * p_min) and not pu.is_powered(0.999 * p_min)
    np.testing.assert_array_equal(pu.is_powered(np.array([0.5, 1.0, 2.0]) * p_min), [False, True, True])
    # A mismatched antenna raises the available-power threshold by 1/τ.
    za = complex(21.4, 155.3)
    mis = PowerUp(z_ant_ohm=za)
    tau = 4 * ZC.real * za.real / abs(ZC + za) ** 2
    assert mis.tau == pytest.approx(tau)
    assert mis.threshold_available_w == pytest.approx(p_min / tau)
    assert not mis.is_powered(0.999 * p_min / tau) and mis.is_powered(1.001 * p_min / tau)
    # Settable threshold in dBm.
    typ = PowerUp.from_dbm(-15.0)
    assert typ.chip_sensitivity_w == pytest.approx(dbm_to_w(-15.0))
    assert typ.sensitivity_dbm == pytest.approx(-15.0)
    assert typ.is_powered(dbm_to_w(-14.9)) and not typ.is_powered(dbm_to_w(-15.1))
    with pytest.raises(ConfigError):
        PowerUp(chip_sensitivity_w=0.0)
    with pytest.raises(ConfigError):
        PowerUp(z_ant_ohm=complex(0, 100))


def test_pass_default_states():
    st = ReflectionStates.pass_default()
    zb = ZC * PASS_ZMOD_900MHZ_OHM / (ZC + PASS_ZMOD_900MHZ_OHM)
    assert abs(st.gamma_a) < 1e-12
    assert st.gamma_b == pytest.approx((zb - ZC) / (zb + np.conj(ZC)))
    assert 0 < st.modulation_factor < 0.25


def test_pass_constants_match_the_characteristic_files(reference_data):
    folder = reference_data / "pass-characteristics"
    from scipy.io import loadmat

    pm = loadmat(folder / "meas_tag_picmin.mat", squeeze_me=True)
    assert pm["f"].size == 11  # cases loaded
    i900 = int(np.flatnonzero(pm["f"] == 900e6)[0])
    assert pm["p"][i900] == pytest.approx(PASS_PICMIN_900MHZ_W, rel=1e-4)
    ch = load_pass_tag_characteristics(folder, fc_hz=900e6, p_chip_w=PASS_PICMIN_900MHZ_W)
    assert ch.picmin_w == pytest.approx(PASS_PICMIN_900MHZ_W, rel=1e-4)
    assert ch.z_chip_ohm == pytest.approx(PASS_ZIC_900MHZ_OHM, abs=0.1)
    assert ch.z_mod_ohm == pytest.approx(PASS_ZMOD_900MHZ_OHM, abs=0.1)
    # Numbers quoted in pass-paris-simulator.md §5.2 (900 MHz chip impedance vs power,
    # antenna v6 at 915 MHz, picmin range).
    for p_w, z_ref in ((10e-6, 11.9 - 205j), (100e-6, 46.8 - 185j), (1e-3, 69.4 - 93.8j)):
        z = load_pass_tag_characteristics(folder, fc_hz=900e6, p_chip_w=p_w).z_chip_ohm
        assert abs(z.real - z_ref.real) < 0.6 and abs(z.imag - z_ref.imag) < 1.0, (p_w, z)
    za = load_pass_tag_characteristics(folder, fc_hz=914e6, p_chip_w=1e-4).z_ant_ohm
    assert za == pytest.approx(30.3 + 157j, abs=0.5)
    assert pm["p"].min() == pytest.approx(48.7e-6, rel=1e-3) and pm["p"].max() == pytest.approx(69.7e-6, rel=1e-3)
    # The measured antenna + chip pair works end to end.
    pu, st = ch.power_up(), ch.reflection_states()
    assert 0 < pu.tau < 1 and abs(st.gamma_a) < 1 and abs(st.gamma_b) < 1
    with pytest.raises(UserError):
        load_pass_tag_characteristics(folder, fc_hz=900e6, p_chip_w=1e-4, antenna="nope")


def test_parallel():
    assert parallel_ohm(100, 100) == pytest.approx(50)


# ------------------------------------------------------------------ clock and BLF


def _trcal_grid(dr):
    from rfsim.gen2.link import TRCAL_TABLE_RANGE_S

    lo, hi = TRCAL_TABLE_RANGE_S[dr]
    num = 8.0 if dr == "8" else 64 / 3
    grid = np.linspace(lo, hi, 300)
    return [t for t in grid if 40e3 * (1 - 1e-9) <= num / t <= 640e3 * (1 + 1e-9)], num


@pytest.mark.parametrize("dr", ["8", "64/3"])
def test_blf_within_frt_for_clock_errors(dr):
    # Clock error range ±10 % (and 0): with a 1.92 MHz clock the BLF stays within FrT over
    # the whole TRcal range of the FrT table, because the error cancels in the TRcal count
    # up to the integer divider's rounding.
    link = pytest.importorskip("rfsim.gen2.link")
    trcals, num = _trcal_grid(dr)
    assert len(trcals) > 100
    n_checked = 0
    for ppm in (-1e5, -5e4, -1e4, 0.0, 1e4, 5e4, 1e5):
        clock = TagClock(freq_error_ppm=ppm)
        for trcal in trcals:
            frt = link.frt_fraction(dr, trcal)
            err = clock.blf_hz(trcal, dr) / (num / trcal) - 1
            assert abs(err) <= frt, (ppm, trcal, err, frt)
            n_checked += 1
    assert n_checked == 7 * len(trcals)


def test_blf_named_profiles_and_divider_rule():
    # Anchors §3.5: A 40 kHz (DR 8, TRcal 200 µs), B 640 kHz (64/3, 33.33 µs), C 320 kHz.
    clock = TagClock()
    assert clock.count_ticks(200e-6) == 384
    assert clock.blf_divider(200e-6, "8") == 48 and clock.blf_hz(200e-6, "8") == pytest.approx(40e3)
    assert clock.blf_divider(100e-6 / 3, "64/3") == 3 and clock.blf_hz(100e-6 / 3, "64/3") == pytest.approx(640e3)
    assert clock.blf_hz(200e-6 / 3, "64/3") == pytest.approx(320e3)
    # Clock +5 %: N_TRcal = round(403.2) = 403 → N = round(50.375) = 50 → 2.016 MHz / 50.
    fast = TagClock(freq_error_ppm=5e4)
    assert fast.blf_divider(200e-6, "8") == 50
    assert fast.blf_hz(200e-6, "8") == pytest.approx(1.92e6 * 1.05 / 50)
    # A measured TRcal count overrides the nominal one.
    assert clock.blf_hz(200e-6, "8", trcal_ticks=400) == pytest.approx(1.92e6 / 50)
    with pytest.raises(ConfigError):
        TagClock(jitter_rms=0.6)


def test_clock_jitter_statistics():
    # n = 200 000 ticks with σ = 5/3 % of a period (PASS). The sample std of the grid
    # deviations has relative standard error √(1/(2n)) = 0.16 %; allow 5 standard errors
    # (0.8 %). Mean deviation: standard error σT/√n; allow 5 of them. Period jitter std is
    # √2·σ·T (differences of independent deviations), checked the same way; and the
    # jitter does not accumulate (last 10 % of ticks has the same spread as the first 10 %).
    n = 200_000
    clock = TagClock(freq_error_ppm=2e4, jitter_rms=PASS_TAG_JITTER_RMS)
    rng = np.random.default_rng(2024)
    t = clock.tick_times_s(n, rng=rng, t0_s=1e-3)
    T = clock.period_s
    assert T == pytest.approx(1 / (1.92e6 * 1.02))
    dev = t - (1e-3 + np.arange(n) * T)
    sigma = PASS_TAG_JITTER_RMS * T
    assert abs(dev.mean()) < 5 * sigma / np.sqrt(n)
    assert abs(dev.std() / sigma - 1) < 5 * np.sqrt(1 / (2 * n))
    per = np.diff(t)
    assert abs(per.mean() / T - 1) < 1e-6
    # Periods form an MA(1) series (lag-1 correlation −1/2): the sample variance has relative
    # standard error √((2/n)(1 + 2·¼)) = √(3/n), the std half that, ≈ 0.87/√n; allow 5/√n.
    assert abs(per.std() / (np.sqrt(2) * sigma) - 1) < 5 * np.sqrt(1 / n)
    k = n // 10
    first, last = dev[:k].std(), dev[-k:].std()
    assert abs(last / first - 1) < 5 * np.sqrt(2 / (2 * k))
    # Deterministic given the rng; jitter-free clock is the exact grid.
    t2 = clock.tick_times_s(n, rng=np.random.default_rng(2024), t0_s=1e-3)
    np.testing.assert_array_equal(t, t2)
    np.testing.assert_array_equal(TagClock().tick_times_s(5, rng=rng), np.arange(5) / 1.92e6)


def test_blf_divider_remembered_by_dr_name_still_checks_and_agrees():
    # the divider of a (TRcal count, DR name) is remembered; a bad DR is still refused after
    # a good one with the same count, and int/Fraction DRs give the same N as the names
    from fractions import Fraction

    from rfsim.devices.tag_frontend import TagClock
    from rfsim.core.errors import ConfigError

    clk = TagClock()
    for n_trcal in (100, 101, 533, 1707):
        by_name = [clk.blf_divider(0.0, "64/3", trcal_ticks=n_trcal) for _ in range(2)]
        assert by_name[0] == by_name[1] == clk.blf_divider(0.0, Fraction(64, 3), trcal_ticks=n_trcal)
        assert by_name[0] == max(1, round(Fraction(n_trcal) * 3 / 64))
        assert clk.blf_divider(0.0, "8", trcal_ticks=n_trcal) == clk.blf_divider(0.0, 8, trcal_ticks=n_trcal)
    with pytest.raises(ConfigError):
        clk.blf_divider(0.0, "7", trcal_ticks=100)
    with pytest.raises(ValueError):
        clk.blf_divider(0.0, "8", trcal_ticks=0)

"""Exponential APDP: closed forms, the PASS selftest settings, and Rician draw statistics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate
from scipy.io import loadmat

from rfsim.channels.small_scale import ApdpModel, apdp_decay_rate, average_profile, draw_taps, rician_gains

N_DETERMINISTIC = 1000  # PASS results_channel_small.mat partition "deterministic NLOS"


def _k_and_trms(powers, delays):
    """Independent statistics of a discrete profile: LoS (tap 0) / rest, RMS delay spread."""
    p = np.asarray(powers, float)
    t = np.asarray(delays, float)
    m1 = np.dot(p, t) / p.sum()
    m2 = np.dot(p, t * t) / p.sum()
    return p[0] / (p.sum() - p[0]), np.sqrt(m2 - m1 * m1)


def test_pass_room_curves():
    # auris-sense-a-tag.md §1.7: ≈ 27.3 dB / 4.67 ns at 1 m, 24.7 dB / 9.03 ns at 2 m
    m = ApdpModel()
    assert m.k_db_at(1.0) == pytest.approx(27.3, abs=0.05)
    assert m.k_db_at(2.0) == pytest.approx(24.7, abs=0.05)
    assert m.tau_rms_s_at(1.0) == pytest.approx(4.67e-9, abs=0.01e-9)
    assert m.tau_rms_s_at(2.0) == pytest.approx(9.03e-9, abs=0.01e-9)


@pytest.mark.parametrize("k_db, tau", [(-10.0, 2e-9), (0.0, 20e-9), (20.0, 70e-9), (40.0, 5e-9)])
def test_decay_rate_gives_target_delay_spread(k_db, tau):
    # moments of the continuous P(τ) = K/(K+1)δ(τ) + γ/(K+1)e^{−γτ}, integrated numerically
    k = 10 ** (k_db / 10)
    g = float(apdp_decay_rate(k, tau))
    # in units of 1/γ (u = γτ) so the quadrature works at O(1) scales
    m1 = integrate.quad(lambda u: u * np.exp(-u) / (k + 1), 0, np.inf)[0] / g
    m2 = integrate.quad(lambda u: u * u * np.exp(-u) / (k + 1), 0, np.inf)[0] / g**2
    assert np.sqrt(m2 - m1 * m1) == pytest.approx(tau, rel=1e-8)


def _golden_settings(reference_data):
    m = loadmat(reference_data / "pass-selftest" / "results_channel_small.mat", squeeze_me=True,
                struct_as_record=False)
    part = m["partitioning"]
    names = list(part.names)
    i = names.index("deterministic NLOS")
    stop = int(part.indices[i])
    start = stop - int(part.runs[i])
    cases = list(m["settings"][start:stop])
    assert len(cases) == N_DETERMINISTIC
    assert all(int(c.det) == 1 and int(c.on) == 1 for c in cases)
    return cases


@pytest.mark.parametrize("pass_rounding", [False, True], ids=["exact-delays", "sample-rounded"])
def test_pass_deterministic_profiles(reference_data, pass_rounding):
    """PASS selftest settings (K in dB, τrms, bw, fres, fs, maxrays, eps): K within 1e-3
    relative in all cases, τrms within eps_trms in ≥ 98 % (pass-paris-simulator.md §4.3)."""
    cases = _golden_settings(reference_data)
    k_ok = t_ok = 0
    for c in cases:
        k = 10 ** (c.k / 10)
        p, d = average_profile(k, c.trms, bandwidth_hz=c.bw, fres_hz=c.fres,
                               fs_hz=c.fs if pass_rounding else None, max_taps=int(c.maxrays),
                               max_iter=int(c.maxiter), eps_k=c.eps_k, eps_trms=c.eps_trms)
        assert p.size <= int(c.maxrays)
        assert p.sum() == pytest.approx(1.0, rel=1e-12)
        assert d[0] == 0.0 and np.all(d >= 0)
        k_hat, t_hat = _k_and_trms(p, d)
        k_ok += abs(k_hat - k) / k <= 1e-3
        t_ok += abs(t_hat - c.trms) / c.trms <= c.eps_trms
    assert k_ok == N_DETERMINISTIC
    assert t_ok >= 0.98 * N_DETERMINISTIC


def _ensemble_stats(k_db, tau, n_draws, seed):
    """Ensemble K, τrms of the mean PDP and amount of fading of the narrowband sum Σ taps."""
    rng = np.random.default_rng(seed)
    k = 10 ** (k_db / 10)
    pdp = None
    h2 = []
    chunk = 10_000
    for start in range(0, n_draws, chunk):
        g, d = draw_taps(k, tau, rng=rng, n_draws=min(chunk, n_draws - start))
        s = np.sum(np.abs(g) ** 2, axis=0)
        pdp = s if pdp is None else pdp + s
        h2.append(np.abs(g.sum(axis=1)) ** 2)
    pdp = pdp / n_draws
    h2 = np.concatenate(h2)
    k_hat, t_hat = _k_and_trms(pdp, d)
    af = h2.var() / h2.mean() ** 2
    return k, k_hat, t_hat, af


def _check_stats(k_db, tau, n_draws, tol_k, tol_t, tol_af, seed):
    k, k_hat, t_hat, af = _ensemble_stats(k_db, tau, n_draws, seed)
    af_theory = (2 * k + 1) / (k + 1) ** 2  # gen2-and-validation-anchors.md §4.7
    assert abs(k_hat - k) / k <= tol_k if k > 1e-12 else True
    assert abs(t_hat - tau) / tau <= tol_t
    assert abs(af - af_theory) / af_theory <= tol_af


# Fast tier: 4000 draws. Relative standard errors: NLoS power (hence K) ≤ 1/√N = 1.6 %;
# amount of fading worst at K = 0 (|h|² exponential: var of the variance estimate 8/N) →
# √(8/4000) = 4.5 %. Tolerances ≈ 3.5σ: K 6 %, τrms 8 %, AF 16 %.
@pytest.mark.parametrize("k_db", [0.0, 10.0, 30.0])
@pytest.mark.parametrize("tau", [2e-9, 70e-9])
def test_draw_statistics_fast(k_db, tau):
    _check_stats(k_db, tau, 4000, 0.06, 0.08, 0.16, seed=11)


# Slow tier: 40 000 draws: K std ≤ 0.5 % (tol 2 % = 4σ); AF std at K = 0 √(8/4e4) = 1.4 %
# (tol 5 % = 3.5σ); τrms 5 %.
@pytest.mark.slow
@pytest.mark.parametrize("k_db", [0.0, 3.0, 10.0, 20.0, 30.0])
@pytest.mark.parametrize("tau", [2e-9, 20e-9, 70e-9])
def test_draw_statistics_full_grid(k_db, tau):
    _check_stats(k_db, tau, 40_000, 0.02, 0.05, 0.05, seed=12)


def test_draw_shapes_and_los():
    rng = np.random.default_rng(3)
    g, d = draw_taps(100.0, 10e-9, rng=rng, n_draws=5, los_phase_rad=0.3)
    assert g.dtype == np.complex128 and g.shape[0] == 5 and g.shape[1] == d.size
    np.testing.assert_allclose(g[:, 0], np.sqrt(100 / 101) * np.exp(0.3j), rtol=1e-15)
    g1, _ = draw_taps(100.0, 10e-9, rng=np.random.default_rng(3), n_draws=5, los_phase_rad=0.3)
    np.testing.assert_array_equal(g, g1)


def test_rician_gains_have_unit_power_and_the_jakes_correlation():
    # h_q = sqrt(K/(K+1))·e^{jφ} + sqrt(1/(K+1))·g_q, E[g_q g_p*] = J0(2π f_D Δt) (Clarke/Jakes;
    # the expectation is scipy's J0, not the code under test). 1500 independent pairs: the
    # covariance estimate has a standard error ≈ σ²/sqrt(1500) = 0.005 for K = 6 dB (σ² = 0.2).
    from scipy.special import j0

    k = 10 ** 0.6
    for dt, f_d in ((0.004, 2.0), (0.1, 2.0), (0.3, 3.0)):
        h = np.array([rician_gains([0.0, dt], doppler_hz=f_d, k_db=6.0, rng=np.random.default_rng(i))
                      for i in range(1500)])
        mean_power = np.mean(np.abs(h) ** 2)
        assert mean_power == pytest.approx(1.0, abs=0.03)
        # remove the LoS term by its magnitude: |E h| = sqrt(K/(K+1)) with a random phase per draw,
        # so use the product h_q·conj(h_p) − K/(K+1) (the LoS phase cancels in the product)
        cov = np.mean(h[:, 0] * np.conj(h[:, 1])).real - k / (k + 1)
        assert cov == pytest.approx(j0(2 * np.pi * f_d * dt) / (k + 1), abs=0.015)
    # f_D = 0: a held channel, one constant unit-magnitude gain
    h0 = rician_gains([0.0, 0.1, 0.2], doppler_hz=0.0, k_db=6.0, rng=np.random.default_rng(1))
    assert np.all(h0 == h0[0]) and abs(h0[0]) == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("distance_m", [0.5, 3.0, 13.0])
def test_draw_nlos_taps_gives_draw_taps_numbers(distance_m):
    # the channel's one-draw path: the NLoS taps, LoS amplitude and delays of draw_taps to the
    # bit, and the generator left in the same state
    from rfsim.channels.small_scale import draw_nlos_taps, tap_terms

    model = ApdpModel()
    k, tau = float(model.k_lin_at(distance_m)), float(model.tau_rms_s_at(distance_m))
    terms = tap_terms(k, tau, model.profile_items)
    for seed in range(20):
        ours, ref = np.random.default_rng(seed), np.random.default_rng(seed)
        taps, rel = draw_taps(k, tau, rng=ref, n_draws=1, **model.profile_options)
        assert draw_nlos_taps(terms, ours).tobytes() == taps[0, 1:].tobytes()
        assert ours.bit_generator.state == ref.bit_generator.state
        assert terms.los_amplitude == abs(taps[0, 0]) and terms.nlos_delays_s.tobytes() == rel[1:].tobytes()

"""Detection-probability reference models and their fits (rfsim.detection).

Golden values are the derived tables of the reference pages, compared to their printed digits:
auris-sense-a-tag.md §2.2 (TS/RTS values) and binary-detection.md §1.6.4, §1.10, §3.1 (DA
model: E[p], σ², α, β, P(n = 0), E[n], P(n ≤ 10), d50, feasible intervals, N = 1 values).
Fits are checked on synthetic data drawn from the models with fixed seeds; tolerances are
derived from the trial counts (stated at each test).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize, stats

from rfsim.detection import (DA_DEAD_ZONE, DA_MEAN_COEFFICIENTS, DA_VARIANCE_COEFFICIENTS,
                             PUBLISHED_READER_MODEL, RTS_COEFFICIENTS,
                             ReaderDetectionModel, beta_from_moments, binned_probability,
                             cross_entropy, expected_cross_entropy, fit_logistic, fit_reader_mle,
                             fit_reader_moments, predict_proba, rts_design, rts_probability,
                             st_features, ts_design, ts_probability, wilson_interval)
from rfsim.core.errors import ConfigError, UserError

MODEL = PUBLISHED_READER_MODEL
N50 = 50

# ---------------------------------------------------------------- TS / RTS (auris §2.2) -------
# (D, d, θ = φ [rad], printed p) — rows without angles have θ = φ = 0
RTS_TABLE = [
    (1, 0.0, 0.0, 0.7247), (2, 0.5, 0.0, 0.3145), (2, 0.5, np.pi / 2, 0.2929),
    (2, 0.6, 0.0, 0.2631), (3, 0.2, 0.0, 0.3725), (3, 0.4, 0.0, 0.2645), (3, 0.6, 0.0, 0.1789),
    (3, 1.0, 0.0, 0.0740), (4, 0.6, 0.0, 0.1173),
]
TS_TABLE = [(0.0, 0.2897), (0.2, 0.2001), (0.4, 0.1330), (0.6, 0.0860), (1.0, 0.0342),
            (2.0, 0.0031)]


def test_rts_ts_page_values():
    assert len(RTS_TABLE) == 9 and len(TS_TABLE) == 6
    big_d, small_d, ang, want = (np.array(c, float) for c in zip(*RTS_TABLE))
    np.testing.assert_allclose(rts_probability(big_d, small_d, ang, ang), want, atol=5e-5)
    d, want_ts = (np.array(c, float) for c in zip(*TS_TABLE))
    np.testing.assert_allclose(ts_probability(d), want_ts, atol=5e-5)
    # the TS model never reaches 0.5 (a0 > 0); RTS 50 % contour d50 = (1.462 − 0.4941 D)/2.506
    assert np.all(ts_probability(np.linspace(0, 5, 51)) < 0.5)
    # printed 0.189 m at D = 2: ±0.0005 m → |Δp| ≤ 0.0005·a2·p(1−p) < 4e-4. At D = 1 the page
    # prints 0.389 m, but its own formula gives (1.462 − 0.4941)/2.506 = 0.3862 m (page slip,
    # p(1, 0.389) = 0.4983); the formula value is tested.
    np.testing.assert_allclose(rts_probability([1.0, 2.0], [0.386, 0.189], 0.0, 0.0), 0.5,
                               atol=4e-4)
    assert rts_probability(2.97, 0.0, 0.0, 0.0)[0] < 0.5 < rts_probability(2.95, 0, 0, 0)[0]


def test_rts_is_symmetric_in_angles_and_design_shapes():
    p = rts_probability([2, 2, 2], 0.5, [0.3, -0.3, 0.3], [0.2, 0.2, -0.2])
    assert p[0] == p[1] == p[2]
    assert rts_design(1.0, 2.0, -0.5, 0.25).tolist() == [[1.0, 1.0, 2.0, 0.5, 0.25]]
    assert ts_design([0.5, 1.5]).shape == (2, 2)
    with pytest.raises(ValueError):
        predict_proba(np.ones((3, 2)), RTS_COEFFICIENTS)


def test_st_features_geometry():
    # antenna frame: boresight +x, z up; θ = arcsin(v_y/D) (plane X-Z), φ = arcsin(v_z/D)
    tag = np.array([[3.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, -1.0], [1.0, 1.0, 1.0]])
    st = tag + np.array([[0.0, 0.0, 1.0], [0.3, 0.4, 0.0], [0.0, 0.0, 0.0], [1.0, 2.0, 2.0]])
    big_d, small_d, theta, phi = st_features(tag, st)
    np.testing.assert_allclose(big_d, [3.0, np.sqrt(2), np.sqrt(2), np.sqrt(3)])
    np.testing.assert_allclose(small_d, [1.0, 0.5, 0.0, 3.0])
    np.testing.assert_allclose(theta, [0.0, np.pi / 4, 0.0, np.arcsin(1 / np.sqrt(3))])
    np.testing.assert_allclose(phi, [0.0, 0.0, -np.pi / 4, np.arcsin(1 / np.sqrt(3))])
    # an antenna off the origin shifts the frame
    b2, _, t2, _ = st_features([[4.0, 2.0, 0.0]], [[4.0, 2.0, 0.0]], antenna_xyz_m=(2, 0, 0))
    np.testing.assert_allclose([b2[0], t2[0]], [np.sqrt(8), np.pi / 4])


# ---------------------------------------------------------------- DA model (binary §1.6) ------
def test_published_da_parameters():
    # seed 004 L666 and L838
    assert DA_MEAN_COEFFICIENTS == (-3.2699, 0.4931, 0.0438)
    assert DA_VARIANCE_COEFFICIENTS == (0.0448, 0.0057, -0.0011, 0.0004, 0.0)
    assert DA_DEAD_ZONE == (0.1875, 3.5625)
    lam_a, lam_b = DA_DEAD_ZONE
    assert MODEL.dead_zone_mean == pytest.approx(0.05, abs=1e-12)
    # Beta variance of λ: αβ/((α+β)²(α+β+1)) = 0.01 (L838)
    assert stats.beta(lam_a, lam_b).var() == pytest.approx(0.01, abs=1e-12)


MEAN_ROWS = {  # binary-detection.md §1.6.4, E[p](d, θ) for θ = 0, 15, ..., 90°
    0.5: (0.954, 0.914, 0.847, 0.741, 0.598, 0.435, 0.285),
    1: (0.941, 0.893, 0.812, 0.691, 0.537, 0.376, 0.238),
    2: (0.908, 0.836, 0.725, 0.578, 0.415, 0.269, 0.160),
    3: (0.857, 0.757, 0.617, 0.455, 0.302, 0.183, 0.104),
    4: (0.785, 0.655, 0.496, 0.338, 0.209, 0.121, 0.066),
    5: (0.691, 0.537, 0.375, 0.237, 0.139, 0.077, 0.042),
    6: (0.577, 0.414, 0.268, 0.160, 0.090, 0.049, 0.026),
    7: (0.455, 0.302, 0.183, 0.104, 0.057, 0.030, 0.016),
    8: (0.337, 0.209, 0.120, 0.066, 0.035, 0.019, 0.010),
    9: (0.237, 0.139, 0.077, 0.042, 0.022, 0.012, 0.006),
    10: (0.160, 0.090, 0.049, 0.026, 0.014, 0.007, 0.004),
}
VAR_ROWS = {  # raw σ²(d, θ)
    1: (0.0494, 0.0554, 0.0614, 0.0674, 0.0734, 0.0794, 0.0854),
    2: (0.0518, 0.0578, 0.0638, 0.0698, 0.0758, 0.0818, 0.0878),
    3: (0.0520, 0.0580, 0.0640, 0.0700, 0.0760, 0.0820, 0.0880),
    4: (0.0500, 0.0560, 0.0620, 0.0680, 0.0740, 0.0800, 0.0860),
    5: (0.0458, 0.0518, 0.0578, 0.0638, 0.0698, 0.0758, 0.0818),
    6: (0.0394, 0.0454, 0.0514, 0.0574, 0.0634, 0.0694, 0.0754),
    8: (0.0200, 0.0260, 0.0320, 0.0380, 0.0440, 0.0500, 0.0560),
    9: (0.0070, 0.0130, 0.0190, 0.0250, 0.0310, 0.0370, 0.0430),
    10: (-0.0082, -0.0022, 0.0038, 0.0098, 0.0158, 0.0218, 0.0278),
}
THETAS = np.arange(0, 91, 15)


def test_da_mean_and_variance_tables():
    assert len(MEAN_ROWS) * 7 == 77 and len(VAR_ROWS) * 7 == 63
    for d, row in MEAN_ROWS.items():
        np.testing.assert_allclose(MODEL.mean(d, THETAS), row, atol=5e-4 + 1e-9, err_msg=f"{d}")
    for d, row in VAR_ROWS.items():
        np.testing.assert_allclose(MODEL.raw_variance(d, THETAS), row, atol=5e-5 + 1e-9)
    # the two "(clip)" entries at d = 10 m become 0; 0.0038 at 30° stays (d = 10 is not > 10)
    np.testing.assert_allclose(MODEL.variance(10.0, [0, 15, 30]), [0.0, 0.0, 0.0038],
                               atol=5e-5)
    # "clipped to zero when the distance is greater than 10 m" (seed 004 L666)
    assert np.all(MODEL.variance(10.01, THETAS) == 0.0)
    # variance peak at θ = 0: d = c2/(−2 c3) = 2.59 m, σ² = 0.0522
    d = np.arange(0, 10, 0.001)
    v = MODEL.raw_variance(d, 0.0)
    assert d[np.argmax(v)] == pytest.approx(2.59, abs=0.005)
    assert v.max() == pytest.approx(0.0522, abs=5e-5)


def test_d50_and_probability_levels():
    # 6.63 / 3.97 / 1.30 m at 0 / 30 / 60°; < 0 at 90° (binary-detection.md §1.6.4)
    np.testing.assert_allclose(MODEL.d50([0, 30, 60]), [6.63, 3.97, 1.30], atol=0.005)
    np.testing.assert_allclose(MODEL.d50([-30]), MODEL.d50([30]))
    assert MODEL.d50(90) < 0
    np.testing.assert_allclose(MODEL.mean(MODEL.d50([0, 30, 60]), [0, 30, 60]), 0.5, atol=1e-12)
    # E[p] = 0.9 at 2.18 m and 0.1 at 11.09 m (θ = 0)
    for level, want in ((0.9, 2.18), (0.1, 11.09)):
        root = optimize.brentq(lambda x: MODEL.mean(x, 0.0) - level, 0.0, 20.0)
        assert root == pytest.approx(want, abs=0.005)


BB_TABLE = [  # (d, θ, E[p], σ², α, β, P(n=0), E[n], P(n≤10)) binary-detection.md §1.6.4
    (1, 0, 0.9414, 0.0494, 0.1097, 0.0068, 0.0844, 44.72, 0.0981),
    (2, 0, 0.9075, 0.0518, 0.5629, 0.0574, 0.0590, 43.11, 0.0915),
    (3, 0, 0.8570, 0.0520, 1.1627, 0.1940, 0.0519, 40.71, 0.0813),
    (3, 30, 0.6169, 0.0640, 1.6612, 1.0314, 0.0521, 29.30, 0.1301),
    (3, 60, 0.3021, 0.0760, 0.5359, 1.2381, 0.1675, 14.35, 0.5149),
    (4, 0, 0.7854, 0.0500, 1.8620, 0.5087, 0.0504, 37.31, 0.0749),
    (4, 30, 0.4959, 0.0620, 1.5035, 1.5285, 0.0558, 23.55, 0.2058),
    (4, 60, 0.2091, 0.0740, 0.2581, 0.9765, 0.3595, 9.93, 0.6803),
    (5, 0, 0.6909, 0.0458, 2.5306, 1.1321, 0.0502, 32.82, 0.0768),
    (6, 0, 0.5772, 0.0394, 2.9979, 2.1960, 0.0502, 27.42, 0.0941),
    (8, 0, 0.3374, 0.0200, 3.4341, 6.7440, 0.0510, 16.03, 0.2642),
]


@pytest.mark.parametrize("row", BB_TABLE, ids=[f"{r[0]}m-{r[1]}deg" for r in BB_TABLE])
def test_beta_binomial_table(row):
    d, th, mu, var, alpha, beta, p0, en, cdf10 = row
    tol4, tol2 = 5e-5 + 1e-9, 5e-3 + 1e-9      # half a unit of the last printed digit
    assert MODEL.mean(d, th) == pytest.approx(mu, abs=tol4)
    assert MODEL.variance(d, th) == pytest.approx(var, abs=tol4)
    a, b = MODEL.beta_params(d, th)
    assert a == pytest.approx(alpha, abs=tol4) and b == pytest.approx(beta, abs=tol4)
    assert MODEL.prob_no_read(N50, d, th) == pytest.approx(p0, abs=tol4)
    assert MODEL.expected_reads(N50, d, th) == pytest.approx(en, abs=tol2)
    assert MODEL.cdf(10, N50, d, th) == pytest.approx(cdf10, abs=tol4)
    pmf = MODEL.pmf(np.arange(N50 + 1), N50, d, th)
    assert pmf.sum() == pytest.approx(1.0, abs=1e-12)
    assert pmf @ np.arange(N50 + 1) == pytest.approx(MODEL.expected_reads(N50, d, th), rel=1e-10)


def test_beta_binomial_against_scipy_and_single_read():
    assert len(BB_TABLE) == 11
    # independent composition of (4.11) with scipy.stats.betabinom, at (4 m, 60°)
    a, b = MODEL.beta_params(4.0, 60.0)
    n = np.arange(N50 + 1)
    want = 0.95 * stats.betabinom.pmf(n, N50, a, b) + 0.05 * (n == 0)
    np.testing.assert_allclose(MODEL.pmf(n, N50, 4.0, 60.0), want, rtol=1e-10, atol=1e-300)
    # N = 1 (Ch. 5, Eq. 5.4): P(n = 1) = βλ/(αλ+βλ)·E[p]; binary-detection.md §1.10
    d = np.array([1, 2, 3, 4, 6, 8.0])
    np.testing.assert_allclose(MODEL.pmf(1, 1, d, 0.0),
                               [0.8943, 0.8621, 0.8142, 0.7461, 0.5483, 0.3205], atol=5e-5)
    assert MODEL.pmf(1, 1, 4.0, 60.0) == pytest.approx(0.1986, abs=5e-5)


FEASIBLE = {0: (0.70, 9.47), 15: (0.0, 9.86), 30: (0.0, 10.22), 45: (0.0, 10.57),
            60: (0.0, 6.91), 75: (0.0, 4.82), 90: (0.0, 3.15)}


def test_feasible_region_matches_page():
    # scan 0-12 m in 0.01 m steps (binary-detection.md §1.6.4); first feasible interval
    d = np.round(np.arange(0, 1201) * 0.01, 2)
    assert len(FEASIBLE) == 7
    for th, (lo, hi) in FEASIBLE.items():
        ok = MODEL.feasible(d, th)
        first = np.flatnonzero(ok)[0]
        end = first + np.argmin(ok[first:]) - 1
        assert (d[first], d[end]) == (lo, hi), th
    # the sliver 10.24-10.91 m at 60°
    ok60 = MODEL.feasible(d, 60)
    assert ok60[(d >= 10.24) & (d <= 10.91)].all() and not ok60[(d > 6.91) & (d < 10.24)].any()


def test_variance_clipping():
    lam = MODEL.dead_zone_mean
    # infeasible high: d = 0, θ = 0: σ² = 0.0448 > μ(1−μ) = 0.0353 → κ·μ(1−μ)
    mu0 = MODEL.mean(0.0, 0.0)
    assert MODEL.raw_variance(0.0, 0.0) == pytest.approx(0.0448)
    assert mu0 * (1 - mu0) == pytest.approx(0.0353, abs=5e-5)
    assert MODEL.variance(0.0, 0.0) == pytest.approx(0.99 * mu0 * (1 - mu0), rel=1e-12)
    # the page's example: θ = 60°, d = 8 m, σ² = 0.044 > μ(1−μ) = 0.034
    mu8 = MODEL.mean(8.0, 60.0)
    assert MODEL.raw_variance(8.0, 60.0) == pytest.approx(0.044, abs=5e-4)
    assert mu8 * (1 - mu8) == pytest.approx(0.034, abs=5e-4)
    for d, th in ((0.0, 0.0), (8.0, 60.0)):
        a, b = MODEL.beta_params(d, th)
        assert 0 < a < np.inf and 0 < b < np.inf
        # α, β reproduce the clipped moments
        assert stats.beta(a, b).mean() == pytest.approx(MODEL.mean(d, th), rel=1e-9)
        assert stats.beta(a, b).var() == pytest.approx(MODEL.variance(d, th), rel=1e-9)
        pmf = MODEL.pmf(np.arange(N50 + 1), N50, d, th)
        assert np.all(pmf >= 0) and pmf.sum() == pytest.approx(1.0, abs=1e-12)
    # σ² ≤ 0 (d = 9.6 m, θ = 0) and d > 10 m: plain binomial plus the dead zone
    for d, th in ((9.6, 0.0), (10.5, 45.0)):
        assert MODEL.variance(d, th) == 0.0
        assert np.isinf(MODEL.beta_params(d, th)[0])
        n = np.arange(N50 + 1)
        want = (1 - lam) * stats.binom.pmf(n, N50, MODEL.mean(d, th)) + lam * (n == 0)
        np.testing.assert_allclose(MODEL.pmf(n, N50, d, th), want, rtol=1e-10, atol=1e-300)
    # the cutoff can be disabled
    assert ReaderDetectionModel(variance_cutoff_m=None).variance(10.5, 45.0) > 0
    # beta_from_moments directly
    a, b = beta_from_moments([0.5, 0.5, 0.5], [0.3, 0.0, -0.1], kappa=0.5)
    assert a[0] == pytest.approx(0.5) and b[0] == pytest.approx(0.5)   # s = 1/κ − 1 = 1
    assert np.isinf(a[1:]).all() and np.isinf(b[1:]).all()
    with pytest.raises(ConfigError):
        ReaderDetectionModel(kappa=1.0)
    with pytest.raises(ConfigError):
        ReaderDetectionModel(dead_zone_alpha=0.0)


def test_sample_reads_matches_model():
    # 40000 draws at (4 m, 60°): E[n] = 9.93, P(n = 0) = 0.3595. Tolerances 4 standard errors:
    # SE(mean n) = sd(n)/√40000, sd(n) from the page-independent pmf via scipy betabinom.
    rng = np.random.default_rng(20240508)
    m = 40_000
    n = MODEL.sample_reads(N50, np.full(m, 4.0), np.full(m, 60.0), rng=rng)
    a, b = MODEL.beta_params(4.0, 60.0)
    k = np.arange(N50 + 1)
    pmf = 0.95 * stats.betabinom.pmf(k, N50, a, b) + 0.05 * (k == 0)
    sd = np.sqrt(pmf @ k**2 - (pmf @ k) ** 2)
    assert abs(n.mean() - 9.93) < 4 * sd / np.sqrt(m) + 0.005
    assert abs(np.mean(n == 0) - 0.3595) < 4 * np.sqrt(0.3595 * 0.6405 / m) + 5e-5
    # the deterministic-p region draws a binomial
    nb = MODEL.sample_reads(N50, np.full(m, 9.6), 0.0, rng=rng)
    mu = MODEL.mean(9.6, 0.0)
    assert abs(nb.mean() - 0.95 * N50 * mu) < 4 * np.sqrt(N50 * mu * 2) / np.sqrt(m)


# ---------------------------------------------------------------- logistic fits ---------------
def _st_geometry(m, rng):
    """Tag uniform in x ∈ [1, 8], y, z ∈ [−4, 4] m; ST uniform in a 2 m ball around it."""
    tag = np.column_stack([rng.uniform(1, 8, m), rng.uniform(-4, 4, m), rng.uniform(-4, 4, m)])
    u = rng.normal(size=(m, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    st = tag + u * (2.0 * rng.random(m) ** (1 / 3))[:, None]
    return rts_design(*st_features(tag, st))


# A "truth" with detections common enough for a well-conditioned fit; signs as published.
TRUE_RTS = np.array([-2.0, 0.35, 1.6, 0.3, 0.4])


def test_logistic_fit_is_the_mle():
    # independent check: textbook logistic regression p = σ(X b) by scipy BFGS; b = −a
    rng = np.random.default_rng(1)
    x = _st_geometry(3000, rng)
    y = rng.random(3000) < predict_proba(x, TRUE_RTS)

    def nll(b):
        z = x @ b
        return np.sum(np.logaddexp(0, z) - y * z)

    ref = optimize.minimize(nll, np.zeros(5), method="BFGS", options={"gtol": 1e-8}).x
    fit = fit_logistic(x, y)
    np.testing.assert_allclose(fit.coefficients, -ref, atol=2e-4)
    assert fit.log_likelihood == pytest.approx(-nll(ref), abs=1e-6)
    assert fit.cross_entropy(x, y) == pytest.approx(nll(ref) / 3000, abs=1e-9)
    assert cross_entropy(y, fit.predict_proba(x)) == pytest.approx(nll(ref) / 3000, abs=1e-9)
    # binomial counts give the same estimate as the expanded binary rows
    counts = fit_logistic(np.array([[1, 0.0], [1, 1.0]]), [3, 7], [10, 10])
    binary = fit_logistic(np.repeat([[1, 0.0], [1, 1.0]], 10, axis=0),
                          np.r_[np.ones(3), np.zeros(7), np.ones(7), np.zeros(3)])
    np.testing.assert_allclose(counts.coefficients, binary.coefficients, atol=1e-9)
    # exact solution: a0 = −logit(0.3), a1 = logit(0.3) − logit(0.7)
    np.testing.assert_allclose(counts.coefficients,
                               [np.log(7 / 3), np.log(3 / 7) - np.log(7 / 3)], atol=1e-9)
    with pytest.raises(UserError):      # perfectly separated
        fit_logistic(np.column_stack([np.ones(6), np.arange(6.0)]), [1, 1, 1, 0, 0, 0])


def test_logistic_fit_recovers_coefficients_within_3se():
    rng = np.random.default_rng(7)
    for truth in (TRUE_RTS, RTS_COEFFICIENTS):
        x = _st_geometry(3000, rng)       # 3000 training samples as in the reference
        y = rng.random(3000) < predict_proba(x, truth)
        fit = fit_logistic(x, y)
        assert np.all(np.abs(fit.coefficients - truth) < 3 * fit.stderr), (fit, truth)


def test_logistic_stderr_matches_monte_carlo_spread():
    # 200 refits with fresh outcomes on fixed features (SEs are conditional on X). The sample
    # SD over R = 200 replicates has relative SE 1/√(2·199) ≈ 5 %, so ±20 % is ≈ 4 SE.
    rng = np.random.default_rng(11)
    x = _st_geometry(3000, rng)
    p = predict_proba(x, TRUE_RTS)
    fits = [fit_logistic(x, rng.random(3000) < p) for _ in range(200)]
    est = np.array([f.coefficients for f in fits])
    se = np.mean([f.stderr for f in fits], axis=0)
    ratio = est.std(axis=0, ddof=1) / se
    assert np.all((ratio > 0.8) & (ratio < 1.2)), ratio
    # and the estimator is unbiased to within 4 SE of the mean of 200
    assert np.all(np.abs(est.mean(axis=0) - TRUE_RTS) < 4 * se / np.sqrt(200))


def test_cross_entropy_of_true_model():
    # analytic E[J] = mean H(p_i), SD[J]² = Σ p(1−p) logit(p)² / m² ; checked two ways
    rng = np.random.default_rng(3)
    x = _st_geometry(1000, rng)          # 1000 test samples as in the reference
    p = predict_proba(x, TRUE_RTS)
    mean, sd = expected_cross_entropy(p)
    # direct numerical expectation over y ∈ {0, 1}
    assert mean == pytest.approx(np.mean(-p * np.log(p) - (1 - p) * np.log1p(-p)), rel=1e-12)
    j = np.array([cross_entropy(rng.random(1000) < p, p) for _ in range(2000)])
    # mean of 2000 replicates within 4 SE; the SD of J within 10 % (rel. SE ≈ 1.6 %)
    assert abs(j.mean() - mean) < 4 * sd / np.sqrt(2000)
    assert j.std(ddof=1) == pytest.approx(sd, rel=0.10)
    # one test set, as in the scenario: within 4 SD of the expectation
    y = rng.random(1000) < p
    assert abs(cross_entropy(y, p) - mean) < 4 * sd


def test_rts_beats_ts_on_rts_generated_data():
    rng = np.random.default_rng(5)
    x_train, x_test = _st_geometry(3000, rng), _st_geometry(1000, rng)
    y_train = rng.random(3000) < predict_proba(x_train, TRUE_RTS)
    y_test = rng.random(1000) < predict_proba(x_test, TRUE_RTS)
    rts = fit_logistic(x_train, y_train)
    ts = fit_logistic(x_train[:, [0, 2]], y_train)
    assert rts.cross_entropy(x_test, y_test) < ts.cross_entropy(x_test[:, [0, 2]], y_test)
    assert ts.coefficients[1] > 0 and rts.coefficients[1] > 0 and rts.coefficients[2] > 0


# ---------------------------------------------------------------- Beta-binomial fits ----------
def _campaign(model, reps, rng, distances=np.linspace(1.0, 8.0, 18),
              angles=np.linspace(0.0, 45.0, 13)):
    """Campaign-A-like grid (18 distances × 13 angles × reps) inside the feasible region."""
    d = np.repeat(distances, angles.size * reps)
    th = np.tile(np.repeat(angles, reps), distances.size)
    return d, th, model.sample_reads(N50, d, th, rng=rng)


def test_beta_binomial_mle_recovers_published_model():
    # 18 × 13 cells × 20 repetitions (2 rooms × 10) of N = 50 queries; all 9 parameters
    # within 3 standard errors of the truth
    rng = np.random.default_rng(2015)
    d, th, n = _campaign(MODEL, 20, rng)
    assert d.size == 18 * 13 * 20
    fit = fit_reader_mle(d, th, n, N50)
    truth = np.array([*DA_MEAN_COEFFICIENTS, *DA_VARIANCE_COEFFICIENTS, MODEL.dead_zone_mean])
    assert np.all(np.isfinite(fit.stderr))
    z = (fit.estimates - truth) / fit.stderr
    assert np.all(np.abs(z) < 3), dict(zip(fit.parameter_names, z))
    np.testing.assert_allclose(fit.model.d50([0, 30]), MODEL.d50([0, 30]), atol=0.15)
    # the MLE beats the truth and the moment start in likelihood
    ll_true = np.sum(MODEL.logpmf(n, N50, d, th))
    assert fit.log_likelihood >= ll_true - 1e-6
    assert fit.log_likelihood == pytest.approx(np.sum(fit.model.logpmf(n, N50, d, th)), abs=1e-6)


def test_moment_fit_on_dead_zone_free_data():
    # without dead zone the moment fit targets (a, c) directly; 40 reps per cell so the cell
    # variances are informative. Mean coefficients within 3 SE; variance c1..c4 within 3 SE.
    truth = ReaderDetectionModel(dead_zone_alpha=1e-9, dead_zone_beta=1.0)
    rng = np.random.default_rng(99)
    d, th, n = _campaign(truth, 40, rng)
    fit = fit_reader_moments(d, th, n, N50, dead_zone=(1e-9, 1.0))
    want = np.array([*DA_MEAN_COEFFICIENTS, *DA_VARIANCE_COEFFICIENTS])
    z = (fit.estimates[:8] - want) / fit.stderr[:8]
    assert np.all(np.abs(z) < 3), z
    assert np.isnan(fit.stderr[8]) and fit.method == "moments"
    with pytest.raises(UserError):
        fit_reader_moments([1.0, 2.0], [0.0, 0.0], [3, 4], N50)    # one repetition per cell


@pytest.mark.slow
def test_beta_binomial_stderr_matches_monte_carlo_spread():
    # 40 refits on independent campaigns of 18 × 13 × 10; sample SD of 40 has relative SE
    # ≈ 11 %, so the ratio SD/SE is accepted in [0.65, 1.45] (≈ 3.5 SE)
    rng = np.random.default_rng(4)
    fits = []
    for _ in range(40):
        d, th, n = _campaign(MODEL, 10, rng)
        fits.append(fit_reader_mle(d, th, n, N50))
    est = np.array([f.estimates for f in fits])
    se = np.median([f.stderr for f in fits], axis=0)
    ratio = est.std(axis=0, ddof=1) / se
    assert np.all((ratio > 0.65) & (ratio < 1.45)), ratio


# ---------------------------------------------------------------- Wilson / binning ------------
def test_wilson_interval_reference_values():
    # Newcombe (1998), Statistics in Medicine 17:857, method 3 (score, no continuity correction)
    cases = [((81, 263), (0.2553, 0.3662)), ((15, 148), (0.0624, 0.1605)),
             ((0, 20), (0.0, 0.1611)), ((1, 29), (0.0061, 0.1718))]
    assert len(cases) == 4
    for (k, n), want in cases:
        np.testing.assert_allclose(wilson_interval(k, n), want, atol=5e-5)
    # the bounds solve (p̂ − p)² = z² p(1 − p)/n
    lo, hi = wilson_interval(7, 40, confidence=0.9)
    z = stats.norm.ppf(0.95)
    for p in (lo, hi):
        assert (7 / 40 - p) ** 2 == pytest.approx(z * z * p * (1 - p) / 40, rel=1e-9)


def test_binned_probability():
    x = np.array([0.05, 0.1, 0.25, 0.35, 0.36, 0.55, 0.6])
    y = np.array([1, 0, 1, 1, 1, 0, 0])
    b = binned_probability(x, y, [0.0, 0.2, 0.4, 0.5, 0.6])
    assert b.trials.tolist() == [2, 3, 0, 2]            # last bin closed: 0.6 included
    assert b.successes.tolist() == [1, 3, 0, 0]
    np.testing.assert_allclose(b.centers, [0.1, 0.3, 0.45, 0.55])
    np.testing.assert_allclose(b.p_hat[[0, 1, 3]], [0.5, 1.0, 0.0])
    assert np.isnan(b.p_hat[2]) and np.isnan(b.lower[2]) and np.isnan(b.upper[2])
    lo, hi = wilson_interval(3, 3)
    assert (b.lower[1], b.upper[1]) == (lo, hi) and hi == pytest.approx(1.0)
    # coverage sanity on Bernoulli data: 2000 draws at p = 0.3 in 20 bins of 100
    rng = np.random.default_rng(0)
    xs = rng.random(2000)
    ys = rng.random(2000) < 0.3
    bb = binned_probability(xs, ys, np.linspace(0, 1, 21))
    assert bb.trials.sum() == 2000
    assert np.mean((bb.lower <= 0.3) & (0.3 <= bb.upper)) >= 0.8


def test_entropy_and_wilson_use_the_values_of_scipy_stats():
    # the scipy.stats forms (Bernoulli log-pmf, normal quantile) as the reference, bit for bit
    import scipy.stats

    rng = np.random.default_rng(11)
    p = np.concatenate([rng.random(5000), 10.0 ** rng.uniform(-300, 0, 500), [0.5, 1.0 - 1e-16]])
    h_ref = -(scipy.stats.bernoulli.logpmf(1, p) * p + np.log1p(-p) * (1.0 - p))
    mean, _ = expected_cross_entropy(p)
    assert mean == float(np.mean(h_ref))
    k, n = rng.integers(0, 50, 200), rng.integers(50, 100, 200)
    for conf in (0.95, 0.9, 0.5):
        z = scipy.stats.norm.ppf(0.5 + conf / 2.0)
        pk = k / n
        denom = 1.0 + z * z / n
        centre = (pk + z * z / (2.0 * n)) / denom
        half = z * np.sqrt(pk * (1.0 - pk) / n + z * z / (4.0 * n * n)) / denom
        lo, hi = wilson_interval(k, n, confidence=conf)
        np.testing.assert_array_equal(lo, np.clip(centre - half, 0.0, 1.0))
        np.testing.assert_array_equal(hi, np.clip(centre + half, 0.0, 1.0))

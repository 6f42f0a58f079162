"""Grid Bayes, LANDMARC, weighted centroid, calibration and the CRLB against brute-force
references written here (plain loops, scipy)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import stats

from rfsim.estimators import (calibrate_log_distance, fit_log_distance, gaussian_log_likelihood,
                              gaussian_transition, grid_bayes_filter, grid_estimates, landmarc,
                              log_distance_crlb, weighted_centroid)

CELLS = np.array([(x, y) for x in range(1, 5) for y in range(1, 8)], float)


def test_gaussian_log_likelihood_equals_scipy_and_skips_nan():
    rng = np.random.default_rng(5)
    z = rng.normal(-60, 5, size=(6, 1, 3))
    mu = rng.normal(-60, 5, size=(28, 3))
    sig = np.array([5.0, 4.0, 6.0])
    ref = stats.norm.logpdf(z, mu, sig).sum(axis=-1)
    np.testing.assert_allclose(gaussian_log_likelihood(z, mu, sig), ref, rtol=1e-12)
    z[0, 0, 1] = np.nan
    ref0 = stats.norm.logpdf(z[0, 0, [0, 2]], mu[:, [0, 2]], sig[[0, 2]]).sum(axis=-1)
    np.testing.assert_allclose(gaussian_log_likelihood(z, mu, sig)[0], ref0, rtol=1e-12)


def _grid_loop(lik, cells, D):
    """Eq. 4.12 and 4.15 as nested loops over cells (one trial)."""
    m = len(cells)
    bel = [1.0 / m] * m
    out = []
    for t in range(lik.shape[0]):
        pred = []
        for l in range(m):
            s = 0.0
            for lp in range(m):
                norm = sum(np.exp(-np.sum((cells[k] - cells[lp]) ** 2) / (2 * D * D)) for k in range(m))
                s += np.exp(-np.sum((cells[l] - cells[lp]) ** 2) / (2 * D * D)) / norm * bel[lp]
            pred.append(s)
        post = [lik[t, l] * pred[l] for l in range(m)]
        tot = sum(post)
        bel = [p / tot for p in post]
        out.append(bel)
    return np.array(out)


def test_grid_bayes_matches_nested_loops():
    rng = np.random.default_rng(6)
    cells = CELLS[::3]
    ll = rng.normal(0, 3, size=(2, 4, len(cells)))
    bel = grid_bayes_filter(ll, gaussian_transition(cells, 0.7))
    for b in range(2):
        np.testing.assert_allclose(bel[b], _grid_loop(np.exp(ll[b]), cells, 0.7), rtol=1e-10)
    mmse, map_ = grid_estimates(bel, cells)
    np.testing.assert_allclose(mmse[1, 3], sum(bel[1, 3, l] * cells[l] for l in range(len(cells))))
    assert np.array_equal(map_[0, 2], cells[np.argmax(bel[0, 2])])


def test_grid_static_and_uniform_transitions():
    """No transition: beliefs are products of likelihoods; uniform (D = ∞): the last one only."""
    rng = np.random.default_rng(7)
    ll = rng.normal(0, 1, size=(3, 5, 28))
    static = grid_bayes_filter(ll, None)
    prod = np.exp(ll.cumsum(axis=1))
    np.testing.assert_allclose(static, prod / prod.sum(-1, keepdims=True), rtol=1e-10)
    uni = grid_bayes_filter(ll, gaussian_transition(CELLS, np.inf))
    last = np.exp(ll)
    np.testing.assert_allclose(uni, last / last.sum(-1, keepdims=True), rtol=1e-10)


def _landmarc_loop(z, ref, xy, k):
    e = [np.sqrt(np.sum((ref[j] - z) ** 2)) for j in range(len(ref))]
    order = sorted(range(len(ref)), key=lambda j: e[j])[:k]
    w = [1.0 / e[j] ** 2 for j in order]
    return sum(w[i] * xy[j] for i, j in enumerate(order)) / sum(w)


@pytest.mark.parametrize("k", [1, 4, 15, 28])
def test_landmarc_matches_loop(k):
    rng = np.random.default_rng(8)
    ref = rng.normal(-60, 8, size=(28, 3))
    z = rng.normal(-60, 8, size=(40, 3))
    got = landmarc(z, ref, CELLS, k)
    ref_est = np.array([_landmarc_loop(z[i], ref, CELLS, k) for i in range(40)])
    np.testing.assert_allclose(got, ref_est, rtol=1e-12)


def test_landmarc_exact_match_and_bad_k():
    ref = np.array([[0.0, 0.0], [1.0, 1.0], [5.0, 5.0]])
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    np.testing.assert_allclose(landmarc(np.array([1.0, 1.0]), ref, xy, 2), [1.0, 0.0])
    with pytest.raises(ValueError, match="k must be"):
        landmarc(np.zeros(2), ref, xy, 4)


def test_weighted_centroid():
    pos = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 4.0]])
    np.testing.assert_allclose(weighted_centroid(np.array([1.0, 1.0, 2.0]), pos), [0.5, 2.0])
    assert np.isnan(weighted_centroid(np.zeros(3), pos)).all()


def test_grid_search_calibration_equals_brute_force():
    rng = np.random.default_rng(9)
    d = rng.uniform(1, 5, size=(3, 4))
    walls = np.array([[0, 0, 2, 2], [0, 2, 0, 2], [2, 2, 0, 0]], float)
    rss = -50 - 23 * np.log10(d) - walls + rng.normal(0, 4, size=(5, 3, 4))
    ag, ng = np.arange(-55, -39.99, 0.5), np.arange(1.5, 3.001, 0.05)
    got = calibrate_log_distance(rss, np.log10(d), walls, alpha_grid_dbm=ag, exponent_grid=ng)
    for b, j in itertools.product(range(5), range(3)):
        best = min(((np.sum((rss[b, j] - (a - 10 * n * np.log10(d[j]) - walls[j])) ** 2), a, n)
                    for a in ag for n in ng))
        assert got.alpha_dbm[b, j] == pytest.approx(best[1], abs=1e-9)
        assert got.exponent[b, j] == pytest.approx(best[2], abs=1e-9)
    # pooled σ (eq. 6.7) from the fitted parameters
    pred = got.alpha_dbm[..., None] - 10 * got.exponent[..., None] * np.log10(d) - walls
    np.testing.assert_allclose(got.sigma_db, np.sqrt(np.mean((rss - pred) ** 2, axis=(1, 2))))


def test_offline_fit_equals_scipy_linregress():
    rng = np.random.default_rng(10)
    d = np.repeat([1.0, 1.5, 2.0, 2.5, 3.0], 400)
    rss = -52 - 23 * np.log10(d) + rng.normal(0, 5.2, size=d.size)
    fit = fit_log_distance(rss, d)
    lr = stats.linregress(-10 * np.log10(d), rss)
    assert fit.alpha_dbm == pytest.approx(lr.intercept, abs=1e-9)
    assert fit.exponent == pytest.approx(lr.slope, abs=1e-9)


def test_crlb_corrected_equals_numerical_fisher_and_printed_a13():
    readers = np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 8.0]])
    n, sig = np.array([2.3, 2.0, 2.5]), np.array([5.2, 4.0, 6.0])
    pts = np.array([[1.0, 2.0], [3.5, 6.0], [2.5, 4.0]])

    def mu(p):
        return -52 - 10 * n * np.log10(np.linalg.norm(p - readers, axis=1))

    for p in pts:
        h = 1e-6
        J = np.stack([(mu(p + h * e) - mu(p - h * e)) / (2 * h) for e in np.eye(2)], axis=1)
        F = J.T @ np.diag(1 / sig ** 2) @ J
        assert log_distance_crlb(p, readers, n, sig) == pytest.approx(np.sqrt(np.trace(np.linalg.inv(F))), rel=1e-6)
    # printed (A.13) with a common n and σ: (σ ln10/10n)² (Σc² + Σs²)/(Σc² Σs² − (Σcs)²)
    p = pts[0]
    u = (readers - p) / np.linalg.norm(readers - p, axis=1)[:, None]
    c, s = u[:, 0], u[:, 1]
    a13 = (5.2 * np.log(10) / 23) ** 2 * (np.sum(c * c) + np.sum(s * s)) / (
        np.sum(c * c) * np.sum(s * s) - np.sum(c * s) ** 2)
    assert log_distance_crlb(p, readers, 2.3, 5.2, form="printed") == pytest.approx(np.sqrt(a13), rel=1e-12)
    # both bounds are proportional to σ
    assert log_distance_crlb(p, readers, 2.3, 10.4) == pytest.approx(2 * log_distance_crlb(p, readers, 2.3, 5.2))

"""Resampling against the printed algorithm (Table 4.2) run as a plain loop; SIR vs the KF."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.estimators import (effective_sample_size, multinomial_resample, sir_filter,
                              systematic_indices, systematic_resample)


def _systematic_loop(w, u1):
    """Table 4.2 (Özkaya L706–L726) with the inclusive CDF, one trial, as printed."""
    n = len(w)
    c = np.cumsum(w / w.sum())
    out = np.empty(n, dtype=int)
    j = 0
    for i in range(n):
        u = u1 + i / n
        while u > c[j] and j < n - 1:
            j += 1
        out[i] = j
    return out


def test_systematic_matches_the_printed_loop():
    rng = np.random.default_rng(1)
    w = rng.exponential(size=(200, 37)) ** 3
    w[:, ::5] = 0.0                                         # zero weights are never picked
    u1 = rng.uniform(0, 1 / 37, size=200)
    got = systematic_indices(w, u1)
    ref = np.array([_systematic_loop(w[b], u1[b]) for b in range(200)])
    assert np.array_equal(got, ref)
    assert not np.isin(got, np.arange(0, 37, 5)).any()


def test_systematic_copies_are_floor_or_ceil_of_n_w():
    """Systematic resampling's known property: each particle gets ⌊Nw⌋ or ⌈Nw⌉ copies."""
    rng = np.random.default_rng(2)
    w = rng.dirichlet(np.ones(50), size=300)
    idx = systematic_resample(w, rng=rng)
    counts = np.stack([np.bincount(r, minlength=50) for r in idx])
    nw = 50 * w
    assert np.all((counts >= np.floor(nw) - 1e-9) & (counts <= np.ceil(nw) + 1e-9))


def test_multinomial_counts_are_unbiased():
    """Mean copy counts over R repetitions → N·w within 5 standard errors (binomial variance)."""
    rng = np.random.default_rng(3)
    n, reps = 20, 4000
    w = rng.dirichlet(np.ones(n))
    idx = multinomial_resample(np.broadcast_to(w, (reps, n)), rng=rng)
    counts = np.stack([np.bincount(r, minlength=n) for r in idx])
    se = np.sqrt(n * w * (1 - w) / reps)
    assert np.all(np.abs(counts.mean(axis=0) - n * w) < 5 * se + 1e-12)
    assert np.all(np.diff(idx, axis=1) >= 0)


def test_effective_sample_size_limits():
    assert effective_sample_size(np.full(8, 1 / 8)) == pytest.approx(8.0)
    assert effective_sample_size(np.eye(5)[2]) == pytest.approx(1.0)


def test_sir_tracks_the_kalman_posterior_mean_of_a_random_walk():
    """1-D Gaussian random walk with Gaussian observations: the posterior mean is the scalar
    Kalman recursion (computed here by hand). With N = 2000 particles the MMSE differs from it
    by a Monte-Carlo error of order √(P/N); over 200 trials × 15 steps the mean absolute
    difference must stay below 4·√(P/N)."""
    rng = np.random.default_rng(4)
    B, T, N, q, r, p0 = 200, 15, 2000, 0.5, 0.7, 2.0
    x = rng.normal(0, np.sqrt(p0), size=B)
    zs = np.empty((B, T, 1))
    for t in range(T):
        x = x + rng.normal(0, q, size=B)
        zs[:, t, 0] = x + rng.normal(0, r, size=B)
    # hand-written scalar Kalman filter
    m, P = np.zeros(B), p0
    km = np.empty((B, T))
    kp = np.empty(T)
    for t in range(T):
        P = P + q * q
        K = P / (P + r * r)
        m = m + K * (zs[:, t, 0] - m)
        P = (1 - K) * P
        km[:, t], kp[t] = m, P
    init = rng.normal(0, np.sqrt(p0), size=(B, N, 1))
    res = sir_filter(zs, init, propagate=lambda p, t, g: p + g.normal(0, q, size=p.shape),
                     log_likelihood=lambda p, z: -0.5 * ((p[..., 0] - z[:, None, 0]) / r) ** 2,
                     rng=rng)
    err = np.abs(res.mmse[..., 0] - km)
    assert err.mean() < 4 * np.sqrt(kp.mean() / N)
    assert res.resampled.all()
    # ESS-gated resampling with √w selection stays consistent too (weights carried over)
    res2 = sir_filter(zs, init, propagate=lambda p, t, g: p + g.normal(0, q, size=p.shape),
                      log_likelihood=lambda p, z: -0.5 * ((p[..., 0] - z[:, None, 0]) / r) ** 2,
                      rng=rng, threshold=0.5, sqrt_weights=True, resampler="multinomial")
    assert np.abs(res2.mmse[..., 0] - km).mean() < 6 * np.sqrt(kp.mean() / N)
    assert 0 < res2.resampled.mean() < 1


def test_bad_arguments():
    with pytest.raises(ValueError):
        systematic_indices(np.zeros((2, 4)), np.zeros(2))
    with pytest.raises(ValueError):
        sir_filter(np.zeros((1, 1, 1)), np.zeros((1, 3, 1)), propagate=lambda p, t, g: p,
                   log_likelihood=lambda p, z: np.zeros(p.shape[:2]), rng=np.random.default_rng(0),
                   threshold=0.0)

"""Trackers of binary proximity observations (rfsim.estimators.proximity) against independent
derivations: explicit (6.1) matrices, filterpy's Kalman filter, Gaussian conditioning for the
RBPF's velocity means, and a grid posterior for the Bernoulli PF."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.estimators.proximity import (bernoulli_pf, cv_process_noise, cv_transition, logistic_log_likelihood,
                                        proximity_kalman, rbpf)

filterpy_kalman = pytest.importorskip("filterpy.kalman")


def test_cv_transition_is_the_kronecker_form_of_eq_6_1():
    dt = 0.3
    A, B = cv_transition([dt])
    assert np.array_equal(A[0], [[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1]])
    assert np.array_equal(B[0], [[dt * dt / 2, 0], [dt, 0], [0, dt * dt / 2], [0, dt]])
    Q = cv_process_noise([dt], [0.01, 0.04])[0]
    assert np.allclose(Q[:2, :2], 0.01 * np.array([[dt ** 4 / 4, dt ** 3 / 2], [dt ** 3 / 2, dt * dt]]))
    assert np.allclose(Q[2:, 2:], 0.04 * np.array([[dt ** 4 / 4, dt ** 3 / 2], [dt ** 3 / 2, dt * dt]]))
    assert np.all(Q[:2, 2:] == 0)


def test_proximity_kalman_matches_filterpy_with_irregular_steps():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.02, 0.4, 30))
    z = rng.normal(0, 1.0, (30, 2))
    x0, P0 = np.array([0.1, 0.5, -0.2, 0.0]), np.diag([0.2, 0.3, 0.2, 0.3])
    r, q = 2.0, 0.01
    ours = proximity_kalman(t, z, x0, P0, t0_s=0.0, accel_var=q, range_m=r)
    kf = filterpy_kalman.KalmanFilter(dim_x=4, dim_z=2)
    kf.x, kf.P = x0.copy(), P0.copy()
    kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    kf.R = np.eye(2) * r * r / 2
    prev = 0.0
    for k in range(t.size):
        h = t[k] - prev
        prev = t[k]
        F = np.kron(np.eye(2), [[1, h], [0, 1]])
        G = np.kron(np.eye(2), [[h * h / 2], [h]])
        kf.predict(F=F, Q=G @ (q * G.T))
        kf.update(z[k])
        assert np.allclose(ours.x[k], kf.x, atol=1e-9) and np.allclose(ours.P[k], kf.P, atol=1e-9)


def test_rbpf_velocity_is_the_gaussian_conditional_mean_given_the_positions():
    """With a flat likelihood (a2 = 0) one particle keeps its path; its Kalman velocity mean after
    k steps must equal E[v_k | x_1..x_k] of the joint Gaussian of (6.1), computed from scratch."""
    rng = np.random.default_rng(5)
    n = 6
    t = np.cumsum(rng.uniform(0.1, 0.5, n))
    dt = np.diff(t, prepend=0.0)
    m0, p0, q = 0.4, 0.09, 0.01
    init = np.array([[[0.0, m0, 0.0, m0]]])
    res = rbpf(t, np.zeros((n, 2)), init, p0, t0_s=0.0, accel_var=q, a1=0.0, a2=0.0, rng=rng)
    x = res.mmse[0, :, 0]  # the particle's x path, and its velocity means
    # joint of (x_1..x_n, v_1..v_n) as linear maps of w = (v0, u_1..u_n), one axis
    cov_w = np.diag([p0] + [q] * n)
    mean_w = np.r_[m0, np.zeros(n)]
    X, V = np.zeros((n, n + 1)), np.zeros((n, n + 1))
    xk, vk = np.zeros(n + 1), np.eye(n + 1)[0]
    for k in range(n):
        e = np.eye(n + 1)[k + 1]
        xk = xk + dt[k] * vk + dt[k] ** 2 / 2 * e
        vk = vk + dt[k] * e
        X[k], V[k] = xk, vk
    for k in range(n):
        Xk = X[:k + 1]
        gain = V[k] @ cov_w @ Xk.T @ np.linalg.inv(Xk @ cov_w @ Xk.T)
        expected = V[k] @ mean_w + gain @ (x[:k + 1] - Xk @ mean_w)
        assert res.mmse[0, k, 1] == pytest.approx(expected, abs=1e-8)


def test_bernoulli_pf_matches_a_grid_posterior_for_a_still_tag():
    """q = 0 and zero velocity: the posterior after one decode of a tag at l is
    N(x0, σ²) · p(‖x − l‖) (Eq. 6.5); its mean on a fine grid vs the PF's MMSE (2000 particles,
    20 runs: MC standard error ≈ 0.3/√40000 ≈ 0.0015 m per axis)."""
    rng = np.random.default_rng(11)
    x0, sd, l = np.array([0.0, 0.0]), 0.5, np.array([0.6, 0.3])
    a1, a2 = -8.0, 10.0
    init = np.zeros((20, 2000, 4))
    init[..., 0::2] = x0 + sd * rng.standard_normal((20, 2000, 2))
    res = bernoulli_pf([0.5], l[None], init, t0_s=0.0, accel_var=0.0, a1=a1, a2=a2, rng=rng)
    g = np.linspace(-3, 3, 601)
    gx, gy = np.meshgrid(g, g, indexing="ij")
    post = np.exp(-(gx ** 2 + gy ** 2) / (2 * sd * sd)) / (1 + np.exp(a1 + a2 * np.hypot(gx - l[0], gy - l[1])))
    mean = np.array([(gx * post).sum(), (gy * post).sum()]) / post.sum()
    got = res.mmse[:, 0, 0::2].mean(axis=0)
    assert np.allclose(got, mean, atol=0.01)
    assert np.linalg.norm(mean) > 0.1  # the decode moved the estimate: the check is not trivial


def test_logistic_log_likelihood_is_eq_6_5():
    p = np.zeros((1, 2, 2))
    p[0, 1] = [3.0, 4.0]
    ll = logistic_log_likelihood(p, np.zeros((1, 2)), a1=-2.0, a2=1.5)
    assert ll[0] == pytest.approx(np.log([1 / (1 + np.exp(-2.0)), 1 / (1 + np.exp(-2.0 + 7.5))]))

"""KF / EKF / RTS against filterpy on the same data (to 1e-9), batched over trials."""

from __future__ import annotations

import numpy as np
import pytest

filterpy_kalman = pytest.importorskip("filterpy.kalman")

from rfsim.estimators import (ekf_update, extended_kalman_filter, kalman_filter, kf_predict, kf_update,
                              rts_smoother)


def _cv_model(dt=0.1, q=0.5, r=0.2):
    """2-D constant-velocity model, state (x, vx, y, vy), position measurements."""
    f1 = np.array([[1.0, dt], [0.0, 1.0]])
    q1 = q * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    F = np.kron(np.eye(2), f1)
    Q = np.kron(np.eye(2), q1)
    H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    R = r ** 2 * np.eye(2)
    return F, Q, H, R


def _simulate(F, Q, H, R, n_steps, n_trials, rng):
    n = F.shape[0]
    x = np.zeros((n_trials, n))
    zs = np.empty((n_trials, n_steps, H.shape[0]))
    lq, lr = np.linalg.cholesky(Q), np.linalg.cholesky(R)
    for k in range(n_steps):
        x = x @ F.T + rng.standard_normal((n_trials, n)) @ lq.T
        zs[:, k] = x @ H.T + rng.standard_normal((n_trials, H.shape[0])) @ lr.T
    return zs


def _filterpy_run(zs_1, F, Q, H, R, x0, P0, Fs=None, Qs=None):
    kf = filterpy_kalman.KalmanFilter(dim_x=F.shape[0], dim_z=H.shape[0])
    kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = x0.copy(), P0.copy(), F, Q, H, R
    zlist = [None if np.isnan(z).any() else z for z in zs_1]
    return kf.batch_filter(zlist, Fs=Fs, Qs=Qs)


def test_kalman_filter_matches_filterpy_batch_filter():
    rng = np.random.default_rng(11)
    F, Q, H, R = _cv_model()
    zs = _simulate(F, Q, H, R, 60, 3, rng)
    zs[1, 10:14] = np.nan                                  # a gap in trial 1: predictions only
    x0, P0 = np.array([0.1, 0.0, -0.2, 0.0]), np.diag([1.0, 4.0, 1.0, 4.0])
    res = kalman_filter(zs, x0, P0, F, Q, H, R, predict_first=True)
    for b in range(3):
        mu, cov, mu_p, cov_p = _filterpy_run(zs[b], F, Q, H, R, x0, P0)
        np.testing.assert_allclose(res.x[b], mu, rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.P[b], cov, rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.x_pred[b], mu_p, rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.P_pred[b], cov_p, rtol=0, atol=1e-9)
    # the gap really skipped the updates: covariance grows through it
    assert np.all(np.diff(res.P[1, 9:14, 0, 0]) > 0)


def test_rts_smoother_matches_filterpy():
    rng = np.random.default_rng(12)
    F, Q, H, R = _cv_model(dt=0.2, q=1.0, r=0.5)
    zs = _simulate(F, Q, H, R, 40, 2, rng)
    x0, P0 = np.zeros(4), 9.0 * np.eye(4)
    res = kalman_filter(zs, x0, P0, F, Q, H, R, predict_first=True)
    xs_s, Ps_s = rts_smoother(res.x, res.P, F, Q)
    kf = filterpy_kalman.KalmanFilter(dim_x=4, dim_z=2)
    for b in range(2):
        mu, cov, _, _ = _filterpy_run(zs[b], F, Q, H, R, x0, P0)
        xs_ref, Ps_ref, _, _ = kf.rts_smoother(mu, cov, Fs=[F] * 40, Qs=[Q] * 40)
        np.testing.assert_allclose(xs_s[b], xs_ref, rtol=0, atol=1e-9)
        np.testing.assert_allclose(Ps_s[b], Ps_ref, rtol=0, atol=1e-9)
    # smoothing never increases the marginal variance
    assert np.all(np.diagonal(Ps_s, axis1=-2, axis2=-1) <= np.diagonal(res.P, axis1=-2, axis2=-1) + 1e-12)


def test_time_varying_model_convention_matches_filterpy():
    """F[k]/Q[k] act into step k in the filter; the smoother uses F[k+1] for k → k+1."""
    rng = np.random.default_rng(13)
    dts = rng.uniform(0.05, 0.4, size=30)
    models = [_cv_model(dt=dt) for dt in dts]
    Fs = np.array([m[0] for m in models])
    Qs = np.array([m[1] for m in models])
    _, _, H, R = models[0]
    zs = _simulate(Fs[0], Qs[0], H, R, 30, 1, rng)
    x0, P0 = np.zeros(4), 4.0 * np.eye(4)
    res = kalman_filter(zs, x0, P0, Fs, Qs, H, R, predict_first=True)
    mu, cov, _, _ = _filterpy_run(zs[0], Fs[0], Qs[0], H, R, x0, P0, Fs=list(Fs), Qs=list(Qs))
    np.testing.assert_allclose(res.x[0], mu, rtol=0, atol=1e-9)
    xs_s, Ps_s = rts_smoother(res.x, res.P, Fs, Qs)
    kf = filterpy_kalman.KalmanFilter(dim_x=4, dim_z=2)
    # KalmanFilter.rts_smoother uses Fs[k+1] to go from k to k+1, as rts_smoother does
    xs_ref, Ps_ref, _, _ = kf.rts_smoother(mu, cov, Fs=list(Fs), Qs=list(Qs))
    np.testing.assert_allclose(xs_s[0], xs_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(Ps_s[0], Ps_ref, rtol=0, atol=1e-9)


def _range_h(anchors):
    def h(x):
        pos = np.stack([x[..., 0], x[..., 2]], axis=-1)
        return np.linalg.norm(pos[..., None, :] - anchors, axis=-1)

    def jac(x):
        pos = np.stack([x[..., 0], x[..., 2]], axis=-1)
        diff = pos[..., None, :] - anchors
        r = np.linalg.norm(diff, axis=-1)
        J = np.zeros(x.shape[:-1] + (anchors.shape[0], 4))
        J[..., 0] = diff[..., 0] / r
        J[..., 2] = diff[..., 1] / r
        return J
    return h, jac


def test_ekf_matches_filterpy_extended_kalman_filter():
    rng = np.random.default_rng(14)
    F, Q, _, _ = _cv_model(dt=0.1, q=0.2)
    anchors = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0], [3.0, 3.0]])
    h, jac = _range_h(anchors)
    R = 0.05 ** 2 * np.eye(4)
    x_true = np.array([1.0, 0.3, 1.5, -0.2])
    x0, P0 = np.array([1.2, 0.0, 1.3, 0.0]), np.diag([0.5, 1.0, 0.5, 1.0])
    ekf = filterpy_kalman.ExtendedKalmanFilter(dim_x=4, dim_z=4)
    ekf.x, ekf.P, ekf.F, ekf.Q, ekf.R = x0[:, None].copy(), P0.copy(), F, Q, R
    x, P = x0.copy(), P0.copy()
    zs, ref_x = [], []
    for _ in range(40):
        x_true = F @ x_true
        z = h(x_true) + 0.05 * rng.standard_normal(4)
        zs.append(z)
        ekf.predict()
        ekf.update(z[:, None], lambda s: jac(s[:, 0]), lambda s: h(s[:, 0])[:, None])
        x, P = kf_predict(x, P, F, Q)
        x, P = ekf_update(x, P, z, h, jac, R)
        np.testing.assert_allclose(x, ekf.x[:, 0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(P, ekf.P, rtol=0, atol=1e-9)
        ref_x.append(ekf.x[:, 0].copy())
    # the sequence form, batched over two copies of the trial
    res = extended_kalman_filter(np.stack([zs, zs]), x0, P0, F, Q, lambda s, k: h(s),
                                 lambda s, k: jac(s), R, predict_first=True)
    np.testing.assert_allclose(res.x[1], np.array(ref_x), rtol=0, atol=1e-9)


def test_iterated_linearisation_at_the_truth_is_the_linear_kf_of_the_linearised_model():
    """With x_lin given, the EKF is the KF of z − h(x̄) + H x̄ = H x: check against kalman_filter."""
    rng = np.random.default_rng(16)
    F, Q, _, _ = _cv_model(dt=0.1, q=0.2)
    anchors = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    h, jac = _range_h(anchors)
    R = 0.05 ** 2 * np.eye(3)
    x_lin = np.cumsum(rng.normal(0, 0.05, size=(20, 4)), axis=0) + [1.0, 0.0, 1.0, 0.0]
    zs = h(x_lin) + 0.05 * rng.standard_normal((20, 3))
    x0, P0 = np.array([1.0, 0.0, 1.0, 0.0]), np.eye(4)
    got = extended_kalman_filter(zs, x0, P0, F, Q, lambda s, k: h(s), lambda s, k: jac(s), R, x_lin=x_lin)
    Hs = jac(x_lin)
    z_lin = zs - h(x_lin) + np.einsum("tmn,tn->tm", Hs, x_lin)
    ref = kalman_filter(z_lin, x0, P0, F, Q, Hs, R)
    np.testing.assert_allclose(got.x, ref.x, atol=1e-10)
    np.testing.assert_allclose(got.P, ref.P, atol=1e-10)


def test_ekf_with_linear_h_equals_kf_at_any_linearisation_point():
    rng = np.random.default_rng(15)
    _, _, H, R = _cv_model()
    x = rng.standard_normal((5, 4))
    A = rng.standard_normal((5, 4, 4))
    P = A @ np.swapaxes(A, -1, -2) + np.eye(4)
    z = rng.standard_normal((5, 2))
    ref = kf_update(x, P, z, H, R)
    got = ekf_update(x, P, z, lambda s: s @ H.T, lambda s: np.broadcast_to(H, s.shape[:-1] + H.shape),
                     R, x_lin=x + 10.0 * rng.standard_normal((5, 4)))
    np.testing.assert_allclose(got[0], ref[0], atol=1e-10)
    np.testing.assert_allclose(got[1], ref[1], atol=1e-10)


def test_scalar_update_closed_form():
    """One scalar update against the textbook formulas m + P/(P+R)(z−m), P·R/(P+R)."""
    x, P = kf_update(np.array([[2.0]]), np.array([[[3.0]]]), np.array([[5.0]]),
                     np.array([[1.0]]), np.array([[1.0]]))
    assert x[0, 0] == pytest.approx(2.0 + 0.75 * 3.0, abs=1e-12)
    assert P[0, 0, 0] == pytest.approx(0.75, abs=1e-12)

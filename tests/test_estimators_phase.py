"""Phase-tracking estimators (Särkkä et al. 2012): discretisation against scipy's matrix exponential
(Van Loan), unwrapping against known ranges and its λ/(4Δt) limit, the eq. (13) RSSI fix against
scipy.optimize.least_squares on the full (p, ln A0) problem, and the per-read EKF / RTS kernels
against filterpy and the generic NumPy filters of rfsim.estimators.kalman on the same data (1e-9).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import least_squares

from rfsim.estimators import extended_kalman_filter, rts_smoother
from rfsim.estimators.phase_tracking import (continuous_model, discrete_model, ekf_reads, initial_state, rssi_fix,
                                             rts_reads, track_phase, unwrap_limit_mps, unwrap_pseudoranges)

filterpy_kalman = pytest.importorskip("filterpy.kalman")

LAMBDA_890 = 299792458.0 / 890e6
ANCHORS = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0], [0.0, 3.0]])


def test_discretisation_is_van_loans_matrix_exponential():
    d, s, qv, qb, dt = 2, 4, 0.7, 3e-4, 0.013
    F, L, Qc = continuous_model(d, s, q_v=qv, q_b=qb)
    n = F.shape[0]
    M = np.zeros((2 * n, 2 * n))  # Van Loan (1978): expm([[-F, LQLᵀ], [0, Fᵀ]]·dt)
    M[:n, :n], M[:n, n:], M[n:, n:] = -F, L @ Qc @ L.T, F.T
    E = expm(M * dt)
    A_ref = E[n:, n:].T
    W_ref = A_ref @ E[:n, n:]
    A, W = discrete_model(dt, d, s, q_v=qv, q_b=qb)
    np.testing.assert_allclose(A, expm(F * dt), rtol=0, atol=1e-14)
    np.testing.assert_allclose(A, A_ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(W, W_ref, rtol=1e-10, atol=1e-18)


def _phase_of(r_m, phi0=0.7):
    return np.mod(4 * math.pi * r_m / LAMBDA_890 + phi0, 2 * math.pi)


def test_unwrapping_recovers_range_changes_and_fails_above_lambda_over_4dt():
    dt = 0.01
    limit = unwrap_limit_mps(LAMBDA_890, dt)
    assert limit == pytest.approx(8.42, abs=0.005)  # λ/(4Δt) at 890 MHz, 100 reads/s (P§1.2)
    t = np.arange(200) * dt
    for factor, exact in ((0.98, True), (1.03, False)):
        r = 2.0 + factor * limit * t * np.cos(0.3 * t)  # radial speed up to factor·limit
        z = unwrap_pseudoranges(np.zeros(t.size, int), _phase_of(r), wavelength_m=LAMBDA_890, r0_m=[1.5])
        err = z - (r - r[0] + 1.5)
        if exact:
            np.testing.assert_allclose(err, 0.0, atol=1e-9)
        else:  # the first steps over λ/4 land on the wrong branch: jumps of λ/2
            jumps = np.round(np.diff(err) / (LAMBDA_890 / 2))
            assert np.abs(jumps).max() == 1 and np.abs(err).max() > 0.4 * LAMBDA_890


def test_unwrapping_interleaved_antennas_and_failed_reads():
    t = np.arange(40) * 0.0025
    ant = np.arange(40) % 4
    p = np.column_stack([1.0 + 0.2 * t, 1.0 + 0.1 * t])
    r = np.linalg.norm(p - ANCHORS[ant], axis=1)
    phi = _phase_of(r) + 0.3 * ant  # per-port offsets
    phi[9] = np.nan
    z = unwrap_pseudoranges(ant, np.mod(phi, 2 * math.pi), wavelength_m=LAMBDA_890, r0_m=[1, 2, 3, 4])
    assert np.isnan(z[9])
    for i in range(4):
        m = (ant == i) & np.isfinite(z)
        np.testing.assert_allclose(z[m] - r[m], z[m][0] - r[m][0], atol=1e-12)  # true range + constant b_i


def _rssi(p, a0_ln=-7.0):
    d = np.linalg.norm(p[..., None, :] - ANCHORS, axis=-1)
    return 30.0 + (a0_ln - 2 * np.log(d)) / (math.log(10) / 20)


def test_rssi_fix_exact_without_noise_and_equal_to_scipy_least_squares():
    rng = np.random.default_rng(5)
    p_true = rng.uniform(0.5, 2.5, size=(20, 2))
    p, ln_a0 = rssi_fix(_rssi(p_true), ANCHORS)
    np.testing.assert_allclose(p, p_true, atol=1e-7)
    np.testing.assert_allclose(ln_a0, -7.0, atol=1e-7)
    noisy = _rssi(p_true) + rng.normal(0, 2.0, size=(20, 4))
    p, _ = rssi_fix(noisy, ANCHORS)
    y = math.log(10) / 20 * (noisy - 30.0)
    for k in range(5):
        def res(theta, k=k):
            return theta[2] - 2 * np.log(np.linalg.norm(theta[:2] - ANCHORS, axis=1)) - y[k]
        ref = least_squares(res, x0=[1.5, 1.5, -7.0], xtol=1e-14, ftol=1e-14, gtol=1e-14).x
        np.testing.assert_allclose(p[k], ref[:2], atol=1e-6)


def _reads(n=240, seed=3):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.002, 0.003, n))
    ant = np.arange(n) % 4
    p = np.column_stack([1.0 + 0.2 * t, 1.2 + 0.15 * np.sin(t)])
    bias = np.array([0.05, -0.11, 0.02, 0.08])
    z = np.linalg.norm(p - ANCHORS[ant], axis=1) + bias[ant] + rng.normal(0, 0.003, n)
    z[17] = np.nan  # a failed read: prediction only
    return t, ant, z


def test_ekf_and_rts_match_filterpy_to_1e9():
    t, ant, z = _reads()
    qv, qb, sigma = 1.0, 1e-4, 0.01
    x0, P0 = initial_state([1.3, 1.4], 4)
    xf, Pf, xp, Pp = ekf_reads(t, ant, z, ANCHORS, x0, P0, q_v=qv, q_b=qb, sigma_m=sigma)
    xs, Ps = rts_reads(t, xf, Pf, xp, Pp, dims=2, n_antennas=4, q_v=qv, q_b=qb)
    ekf = filterpy_kalman.ExtendedKalmanFilter(dim_x=8, dim_z=1)
    ekf.x, ekf.P = x0[:, None].copy(), P0.copy()
    ref_x, ref_P, Fs, Qs = [], [], [np.eye(8)], [np.zeros((8, 8))]
    for k in range(t.size):
        if k:
            ekf.F, ekf.Q = discrete_model(t[k] - t[k - 1], 2, 4, q_v=qv, q_b=qb)
            Fs.append(ekf.F)
            Qs.append(ekf.Q)
            ekf.predict()
        i = ant[k]

        def H(x, i=i):
            row = np.zeros((1, 8))
            row[0, :2] = (x[:2, 0] - ANCHORS[i]) / np.linalg.norm(x[:2, 0] - ANCHORS[i])
            row[0, 2 + i] = 1.0
            return row

        def hx(x, i=i):
            return np.array([[np.linalg.norm(x[:2, 0] - ANCHORS[i]) + x[2 + i, 0]]])

        ekf.update(None if np.isnan(z[k]) else np.array([[z[k]]]), H, hx, R=np.array([[sigma ** 2]]))
        ref_x.append(ekf.x[:, 0].copy())
        ref_P.append(ekf.P.copy())
    np.testing.assert_allclose(xf, np.array(ref_x), rtol=0, atol=1e-9)
    np.testing.assert_allclose(Pf, np.array(ref_P), rtol=0, atol=1e-9)
    kf = filterpy_kalman.KalmanFilter(dim_x=8, dim_z=1)
    xs_ref, Ps_ref, _, _ = kf.rts_smoother(np.array(ref_x)[:, :, None], np.array(ref_P), Fs=Fs, Qs=Qs)
    np.testing.assert_allclose(xs, xs_ref[:, :, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(Ps, Ps_ref, rtol=0, atol=1e-9)


def test_kernels_equal_the_generic_numpy_filters():
    """The NumPy twin: rfsim.estimators.kalman's EKF and RTS with a per-step scalar model
    (h and its Jacobian change with the antenna of read k; F[k], Q[k] act into step k)."""
    t, ant, z = _reads(120, seed=4)
    qv, qb, sigma = 0.5, 1e-3, 0.02
    x0, P0 = initial_state([1.6, 1.1], 4, pos_std_m=1.0)
    models = [discrete_model(t[k] - t[k - 1] if k else 0.0, 2, 4, q_v=qv, q_b=qb) for k in range(t.size)]
    F = np.array([m[0] for m in models])
    Q = np.array([m[1] for m in models])

    def h(x, k):
        i = ant[k]
        return (np.linalg.norm(x[..., :2] - ANCHORS[i], axis=-1) + x[..., 2 + i])[..., None]

    def jac(x, k):
        i = ant[k]
        J = np.zeros(x.shape[:-1] + (1, 8))
        J[..., 0, :2] = (x[..., :2] - ANCHORS[i]) / np.linalg.norm(x[..., :2] - ANCHORS[i], axis=-1)[..., None]
        J[..., 0, 2 + i] = 1.0
        return J

    ref = extended_kalman_filter(z[:, None], x0, P0, F, Q, h, jac, np.array([[sigma ** 2]]))
    xf, Pf, xp, Pp = ekf_reads(t, ant, z, ANCHORS, x0, P0, q_v=qv, q_b=qb, sigma_m=sigma)
    np.testing.assert_allclose(xf, ref.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(Pf, ref.P, rtol=0, atol=1e-9)
    np.testing.assert_allclose(xp, ref.x_pred, rtol=0, atol=1e-9)
    xs_ref, Ps_ref = rts_smoother(ref.x, ref.P, F, Q)
    xs, Ps = rts_reads(t, xf, Pf, xp, Pp, dims=2, n_antennas=4, q_v=qv, q_b=qb)
    np.testing.assert_allclose(xs, xs_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(Ps, Ps_ref, rtol=0, atol=1e-9)


def test_second_pass_starts_from_the_smoothed_state_and_tracks_better():
    t, ant, z = _reads(4000, seed=6)  # 10 s: a short run leaves the biases weakly observable
    x0, P0 = initial_state([1.9, 1.9], 4)  # ≈ 0.9 m off
    passes = track_phase(t, ant, z, ANCHORS, x0, P0, passes=2)
    np.testing.assert_array_equal(passes[1].x_pred[0], passes[0].x_smooth[0])
    p = np.column_stack([1.0 + 0.2 * t, 1.2 + 0.15 * np.sin(t)])

    def rmse(x):
        return float(np.sqrt(np.mean(np.sum((x[:, :2] - p) ** 2, axis=1))))
    # measured: EKF 3.5 → 0.9 cm, RTS 0.25 → 0.24 cm (σ = 3 mm pseudo-range noise)
    assert rmse(passes[1].x_filt) < 0.5 * rmse(passes[0].x_filt)
    assert rmse(passes[0].x_smooth) < 0.2 * rmse(passes[0].x_filt)
    assert rmse(passes[1].x_smooth) < 0.005


def test_passes_without_covariances_have_the_same_means():
    t, ant, z = _reads(800, seed=7)
    x0, P0 = initial_state([1.9, 1.9], 4)
    full = track_phase(t, ant, z, ANCHORS, x0, P0, passes=2)
    lean = track_phase(t, ant, z, ANCHORS, x0, P0, passes=2, keep_covariances=False)
    for a, b in zip(full, lean):
        np.testing.assert_array_equal(b.x_filt, a.x_filt)
        np.testing.assert_array_equal(b.x_smooth, a.x_smooth)
        assert b.P_filt is None and b.P_smooth is None and b.P_pred is None and b.x_pred is None

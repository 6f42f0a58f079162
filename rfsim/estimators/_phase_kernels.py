"""Numba kernels of the sequential per-read EKF and the RTS smoother of phase tracking.

Plain loops over preallocated arrays (rfsim.core._jit policy); the validating wrappers are in
:mod:`rfsim.estimators.phase_tracking`. Their NumPy twins are the generic
:func:`rfsim.estimators.kalman.extended_kalman_filter` and :func:`~rfsim.estimators.kalman.rts_smoother`
run on the same data with one-hot measurement vectors (tests/test_estimators_phase.py), and
filterpy's ``ExtendedKalmanFilter`` / ``KalmanFilter.rts_smoother``.

State layout ``x = (p_1..p_d, b_1..b_s, v_1..v_d)`` (Särkkä et al. 2012 eq. 10).
"""

from __future__ import annotations

import numpy as np

from rfsim.core._jit import njit


@njit
def transition_kernel(dt, d, s, q_v, q_b, A, W):
    """Fill ``A = exp(F·dt)`` and ``W = ∫ exp(Fτ) L Q Lᵀ exp(Fᵀτ) dτ`` (closed form, eq. 14)."""
    n = 2 * d + s
    for i in range(n):
        for j in range(n):
            A[i, j] = 0.0
            W[i, j] = 0.0
        A[i, i] = 1.0
    for k in range(d):
        pi, vi = k, d + s + k
        A[pi, vi] = dt
        W[pi, pi] = q_v * dt ** 3 / 3.0
        W[pi, vi] = q_v * dt ** 2 / 2.0
        W[vi, pi] = q_v * dt ** 2 / 2.0
        W[vi, vi] = q_v * dt
    for k in range(s):
        W[d + k, d + k] = q_b * dt


@njit
def ekf_kernel(t_s, antenna, z_m, anchors, x0, P0, q_v, q_b, sigma2, xf, Pf, xp, Pp):
    """Sequential scalar EKF over reads (eq. 16–17, Joseph covariance update).

    ``t_s (N,)``, ``antenna (N,)`` 0-based, ``z_m (N,)`` pseudo-ranges (NaN: no update),
    ``anchors (s, d)``; fills filtered ``xf (N, n)``, ``Pf (N, n, n)`` and predicted
    ``xp``, ``Pp`` (at step 0 the prior ``x0, P0``). Returns the number of updates.
    """
    N = t_s.shape[0]
    s, d = anchors.shape
    n = 2 * d + s
    A = np.empty((n, n))
    W = np.empty((n, n))
    x = x0.copy()
    P = P0.copy()
    H = np.zeros(n)
    K = np.zeros(n)
    PH = np.zeros(n)
    used = 0
    for k in range(N):
        if k > 0:
            transition_kernel(t_s[k] - t_s[k - 1], d, s, q_v, q_b, A, W)
            x = A @ x
            P = A @ P @ A.T + W
        xp[k] = x
        Pp[k] = P
        z = z_m[k]
        if z == z:  # not NaN
            i = antenna[k]
            r2 = 0.0
            for c in range(d):
                r2 += (x[c] - anchors[i, c]) ** 2
            r = np.sqrt(r2)
            for c in range(n):
                H[c] = 0.0
            for c in range(d):
                H[c] = (x[c] - anchors[i, c]) / r
            H[d + i] = 1.0
            innovation = z - (r + x[d + i])
            for a in range(n):
                acc = 0.0
                for b in range(n):
                    acc += P[a, b] * H[b]
                PH[a] = acc
            S = sigma2
            for a in range(n):
                S += H[a] * PH[a]
            for a in range(n):
                K[a] = PH[a] / S
            for a in range(n):
                x[a] += K[a] * innovation
            IKH = np.eye(n)
            for a in range(n):
                for b in range(n):
                    IKH[a, b] -= K[a] * H[b]
            P = IKH @ P @ IKH.T
            for a in range(n):
                for b in range(n):
                    P[a, b] += sigma2 * K[a] * K[b]
            used += 1
        xf[k] = x
        Pf[k] = P
    return used


@njit
def rts_kernel(t_s, d, s, q_v, q_b, xf, Pf, xp, Pp, xs, Ps):
    """RTS smoother (eq. 19) of the filtered moments, with the predictions ``xp, Pp`` of the
    forward pass (``xp[k+1] = A xf[k]``, ``Pp[k+1] = A Pf[k] Aᵀ + W``)."""
    N = xf.shape[0]
    n = xf.shape[1]
    A = np.empty((n, n))
    W = np.empty((n, n))
    xs[N - 1] = xf[N - 1]
    Ps[N - 1] = Pf[N - 1]
    for k in range(N - 2, -1, -1):
        transition_kernel(t_s[k + 1] - t_s[k], d, s, q_v, q_b, A, W)
        # G = Pf Aᵀ Pp⁻¹  ⇔  Pp Gᵀ = A Pf
        G = np.linalg.solve(Pp[k + 1], A @ Pf[k]).T
        xs[k] = xf[k] + G @ (xs[k + 1] - xp[k + 1])
        Ps[k] = Pf[k] + G @ (Ps[k + 1] - Pp[k + 1]) @ G.T

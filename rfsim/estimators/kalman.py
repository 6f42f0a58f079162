"""Kalman filter, extended Kalman filter and Rauch–Tung–Striebel smoother, batched over trials.

Linear-Gaussian state-space model (Särkkä, *Bayesian Filtering and Smoothing*, 2013, ch. 4 and
8; phase-tracking.md §1.4–1.6, seeds/001 L161–L166)::

    x_k = F_k x_{k-1} + q_{k-1},   q ~ N(0, Q_k)
    z_k = H x_k + r_k,             r ~ N(0, R)

Prediction (Särkkä eq. 4.20)::

    m⁻_k = F_k m_{k-1},            P⁻_k = F_k P_{k-1} F_kᵀ + Q_k

Update (eq. 4.21), with the Joseph form of the covariance update (Bucy & Joseph 1968), which
keeps ``P`` symmetric positive semi-definite and is what filterpy uses::

    v = z − H m⁻,   S = H P⁻ Hᵀ + R,   K = P⁻ Hᵀ S⁻¹
    m = m⁻ + K v,   P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ

The EKF replaces ``H m⁻`` by ``h(x̄) + H_x(x̄)(m⁻ − x̄)`` linearised at ``x̄`` (``x̄ = m⁻`` for the
plain EKF, eq. 5.24–5.25; a previous smoothed estimate for the iterated extended RTS smoother,
Särkkä §9). The RTS smoother (eq. 8.6)::

    P⁻_{k+1} = F_{k+1} P_k F_{k+1}ᵀ + Q_{k+1},   G_k = P_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹
    m^s_k = m_k + G_k (m^s_{k+1} − F_{k+1} m_k),   P^s_k = P_k + G_k (P^s_{k+1} − P⁻_{k+1}) G_kᵀ

Shapes: every function takes leading batch dimensions ``(...)`` (independent trials) before the
state dimension: ``x (..., n)``, ``P (..., n, n)``, ``z (..., m)``; model matrices broadcast
against them. Sequences put time right before the state axes: ``zs (..., T, m)``,
``F (T, n, n)`` or ``(n, n)``. A measurement containing NaN is missing: that trial keeps its
prediction at that step (sequential per-antenna updates use this).

Convention for time-varying models: ``F[k]``/``Q[k]`` is the transition **into** step ``k`` (the
prediction before update ``k``; ``F[0]`` is used to predict from the prior into step 0 when
``predict_first`` is True). The smoother uses ``F[k+1]`` to go from ``k`` to ``k+1``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np


def _t(a: np.ndarray) -> np.ndarray:
    return np.swapaxes(a, -1, -2)


def _mv(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    return (a @ v[..., None])[..., 0]


def kf_predict(x, P, F, Q) -> tuple[np.ndarray, np.ndarray]:
    """One prediction step ``m⁻ = F m``, ``P⁻ = F P Fᵀ + Q`` (Särkkä 2013 eq. 4.20).

    Units are those of the model's state.

    Parameters
    ----------
    x : array_like
        ``(..., n)`` state mean.
    P : array_like
        ``(..., n, n)`` covariance.
    F : array_like
        ``(..., n, n)`` transition (broadcast).
    Q : array_like
        ``(..., n, n)`` process-noise covariance (broadcast).

    Returns
    -------
    x_pred : numpy.ndarray
        ``(..., n)`` predicted mean.
    P_pred : numpy.ndarray
        ``(..., n, n)`` predicted covariance.
    """
    F = np.asarray(F, float)
    x_pred = _mv(F, np.asarray(x, float))
    P_pred = F @ np.asarray(P, float) @ _t(F) + np.asarray(Q, float)
    return x_pred, P_pred


def _joseph_update(x, P, innovation, H, R):
    S = H @ P @ _t(H) + R
    # K = P Hᵀ S⁻¹ = (S⁻¹ H P)ᵀ  (S and P symmetric)
    K = _t(np.linalg.solve(S, H @ P))
    x_new = x + _mv(K, innovation)
    I_KH = np.eye(P.shape[-1]) - K @ H
    P_new = I_KH @ P @ _t(I_KH) + K @ R @ _t(K)
    return x_new, P_new


def _keep_where_missing(valid, new, old):
    return np.where(valid, new, old)


def _update_where_measured(x, P, z, diff, H, R):
    """Joseph update with innovation ``diff`` where ``z`` has no NaN; ``(x, P)`` kept elsewhere."""
    valid = ~np.isnan(z).any(axis=-1)
    innovation = np.where(valid[..., None], diff, 0.0)
    x_new, P_new = _joseph_update(x, P, innovation, H, R)
    return (_keep_where_missing(valid[..., None], x_new, x),
            _keep_where_missing(valid[..., None, None], P_new, P))


def kf_update(x, P, z, H, R) -> tuple[np.ndarray, np.ndarray]:
    """One linear update in Joseph form (eq. 4.21, module docstring).

    Trials whose ``z`` has a NaN keep ``(x, P)``. Units are those of the model.

    Parameters
    ----------
    x : array_like
        ``(..., n)`` predicted mean.
    P : array_like
        ``(..., n, n)`` predicted covariance.
    z : array_like
        ``(..., m)`` measurement (NaN: missing).
    H : array_like
        ``(..., m, n)`` measurement matrix.
    R : array_like
        ``(..., m, m)`` measurement-noise covariance.

    Returns
    -------
    x_new : numpy.ndarray
        ``(..., n)`` updated mean.
    P_new : numpy.ndarray
        ``(..., n, n)`` updated covariance.
    """
    x = np.asarray(x, float)
    P = np.asarray(P, float)
    z = np.asarray(z, float)
    H = np.asarray(H, float)
    R = np.asarray(R, float)
    return _update_where_measured(x, P, z, z - _mv(H, x), H, R)


def ekf_update(x, P, z, h: Callable, jacobian: Callable, R, *, x_lin=None,
               residual: Callable | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One extended-Kalman update, linearised at ``x_lin`` (default: the prediction ``x``).

    ``ẑ = h(x̄) + H(x̄)(x − x̄)``, ``H(x̄) = jacobian(x̄)``; then the Joseph update of
    :func:`kf_update` with innovation ``residual(z, ẑ)`` (default ``z − ẑ``; pass a wrapping
    residual for angles). Särkkä (2013) eq. 5.24–5.25; with ``x_lin`` a previous smoothed
    estimate it is the update of the iterated extended RTS smoother (§9).

    Parameters
    ----------
    x : array_like
        ``(..., n)`` predicted mean.
    P : array_like
        ``(..., n, n)`` predicted covariance.
    z : array_like
        ``(..., m)`` measurement (NaN: missing, the trial keeps ``(x, P)``).
    h : callable
        ``(..., n) → (..., m)``, vectorised measurement function.
    jacobian : callable
        ``(..., n) → (..., m, n)``.
    R : array_like
        ``(..., m, m)`` measurement-noise covariance.
    x_lin : array_like or None
        ``(..., n)`` linearisation point.
    residual : callable or None
        ``(z, ẑ) → innovation``; default ``z − ẑ``.

    Returns
    -------
    x_new : numpy.ndarray
        ``(..., n)`` updated mean.
    P_new : numpy.ndarray
        ``(..., n, n)`` updated covariance.
    """
    x = np.asarray(x, float)
    P = np.asarray(P, float)
    z = np.asarray(z, float)
    R = np.asarray(R, float)
    xl = x if x_lin is None else np.asarray(x_lin, float)
    H = np.asarray(jacobian(xl), float)
    z_hat = np.asarray(h(xl), float) + _mv(H, x - xl)
    diff = (z - z_hat) if residual is None else residual(z, z_hat)
    return _update_where_measured(x, P, z, diff, H, R)


class FilterResult(NamedTuple):
    """Filtered and predicted moments of a sequence.

    x, P : (..., T, n), (..., T, n, n) filtered means and covariances
    x_pred, P_pred : (..., T, n), (..., T, n, n) one-step predictions before each update
    """

    x: np.ndarray
    P: np.ndarray
    x_pred: np.ndarray
    P_pred: np.ndarray


def _per_step(a: np.ndarray | None, n_steps: int, ndim: int) -> Callable[[int], np.ndarray]:
    """Return ``k → a[k]`` for time-varying ``a`` (leading T axis) or ``k → a`` if constant."""
    if a is None:
        return lambda k: None
    a = np.asarray(a, float)
    if a.ndim == ndim + 1:
        if a.shape[0] != n_steps:
            raise ValueError(f"time-varying model has {a.shape[0]} steps, the data {n_steps}")
        return lambda k: a[k]
    return lambda k: a


def kalman_filter(zs, x0, P0, F, Q, H, R, *, predict_first: bool = False) -> FilterResult:
    """Run the Kalman filter over ``zs (..., T, m)`` (NaN rows are missing measurements).

    Step ``k``: predict with ``F[k], Q[k]`` (skipped at ``k = 0`` unless ``predict_first``, so
    ``x0, P0`` is then the prior of step 0, as filterpy's ``batch_filter`` after one predict
    would be), then update with ``zs[..., k, :]``.

    Parameters
    ----------
    zs : array_like
        ``(..., T, m)`` measurements.
    x0 : array_like
        ``(..., n)`` initial mean.
    P0 : array_like
        ``(..., n, n)`` initial covariance.
    F, Q : array_like
        ``(n, n)`` or ``(T, n, n)`` transition and process-noise covariance.
    H : array_like
        ``(m, n)`` or ``(T, m, n)`` measurement matrix.
    R : array_like
        ``(m, m)`` or ``(T, m, m)`` measurement-noise covariance.
    predict_first : bool
        Predict before the first update too.

    Returns
    -------
    FilterResult
        Filtered and predicted means and covariances, ``(..., T, n)`` and ``(..., T, n, n)``.

    Raises
    ------
    ValueError
        If a time-varying model's length differs from the data's.
    """
    zs = np.asarray(zs, float)
    n_steps = zs.shape[-2]
    Fk, Qk = _per_step(F, n_steps, 2), _per_step(Q, n_steps, 2)
    Hk, Rk = _per_step(H, n_steps, 2), _per_step(R, n_steps, 2)
    x = np.asarray(x0, float)
    P = np.asarray(P0, float)
    batch = np.broadcast_shapes(zs.shape[:-2], x.shape[:-1], P.shape[:-2])
    n = x.shape[-1]
    xs = np.empty(batch + (n_steps, n))
    Ps = np.empty(batch + (n_steps, n, n))
    xps, Pps = np.empty_like(xs), np.empty_like(Ps)
    x = np.broadcast_to(x, batch + (n,))
    P = np.broadcast_to(P, batch + (n, n))
    for k in range(n_steps):
        if k > 0 or predict_first:
            x, P = kf_predict(x, P, Fk(k), Qk(k))
        xps[..., k, :], Pps[..., k, :, :] = x, P
        x, P = kf_update(x, P, zs[..., k, :], Hk(k), Rk(k))
        xs[..., k, :], Ps[..., k, :, :] = x, P
    return FilterResult(xs, Ps, xps, Pps)


def extended_kalman_filter(zs, x0, P0, F, Q, h: Callable, jacobian: Callable, R, *,
                           x_lin=None, residual: Callable | None = None,
                           predict_first: bool = False) -> FilterResult:
    """EKF over ``zs (..., T, m)`` with a linear transition and a nonlinear measurement.

    As :func:`kalman_filter`, with :func:`ekf_update` at each step. Filter +
    :func:`rts_smoother` repeated with ``x_lin`` the previous smoothed means is the iterated
    extended RTS smoother (Särkkä 2013 §9; phase-tracking.md, seeds/001 L205). NaN
    measurements are skipped.

    Parameters
    ----------
    zs : array_like
        ``(..., T, m)`` measurements.
    x0 : array_like
        ``(..., n)`` initial mean.
    P0 : array_like
        ``(..., n, n)`` initial covariance.
    F, Q : array_like
        ``(n, n)`` or ``(T, n, n)`` transition and process-noise covariance.
    h : callable
        ``h(x, k)``: ``(..., n) → (..., m)`` at step k (a sequential per-antenna model changes
        with k).
    jacobian : callable
        ``jacobian(x, k)``: ``(..., n) → (..., m, n)``.
    R : array_like
        ``(m, m)`` or ``(T, m, m)`` measurement-noise covariance.
    x_lin : array_like or None
        ``(..., T, n)``: step k is linearised at ``x_lin[..., k, :]`` instead of the prediction.
    residual : callable or None
        ``(z, ẑ) → innovation``; default ``z − ẑ``.
    predict_first : bool
        Predict before the first update too.

    Returns
    -------
    FilterResult
        Filtered and predicted means and covariances.

    Raises
    ------
    ValueError
        If a time-varying model's length differs from the data's.
    """
    zs = np.asarray(zs, float)
    n_steps = zs.shape[-2]
    Fk, Qk, Rk = _per_step(F, n_steps, 2), _per_step(Q, n_steps, 2), _per_step(R, n_steps, 2)
    x = np.asarray(x0, float)
    P = np.asarray(P0, float)
    batch = np.broadcast_shapes(zs.shape[:-2], x.shape[:-1], P.shape[:-2])
    n = x.shape[-1]
    x = np.broadcast_to(x, batch + (n,))
    P = np.broadcast_to(P, batch + (n, n))
    xs = np.empty(batch + (n_steps, n))
    Ps = np.empty(batch + (n_steps, n, n))
    xps, Pps = np.empty_like(xs), np.empty_like(Ps)
    for k in range(n_steps):
        if k > 0 or predict_first:
            x, P = kf_predict(x, P, Fk(k), Qk(k))
        xps[..., k, :], Pps[..., k, :, :] = x, P
        xl = None if x_lin is None else np.asarray(x_lin, float)[..., k, :]
        x, P = ekf_update(x, P, zs[..., k, :], lambda s, k=k: h(s, k), lambda s, k=k: jacobian(s, k),
                          Rk(k), x_lin=xl, residual=residual)
        xs[..., k, :], Ps[..., k, :, :] = x, P
    return FilterResult(xs, Ps, xps, Pps)


def rts_smoother(xs, Ps, F, Q) -> tuple[np.ndarray, np.ndarray]:
    """Rauch–Tung–Striebel smoother of filtered moments (Särkkä 2013 eq. 8.6).

    Parameters
    ----------
    xs : array_like
        ``(..., T, n)`` filtered means.
    Ps : array_like
        ``(..., T, n, n)`` filtered covariances.
    F, Q : array_like
        ``(n, n)``, or ``(T, n, n)`` with ``F[k+1]`` the transition from step k to k+1.

    Returns
    -------
    xs_smooth : numpy.ndarray
        ``(..., T, n)`` smoothed means.
    Ps_smooth : numpy.ndarray
        ``(..., T, n, n)`` smoothed covariances.
    """
    xs = np.asarray(xs, float)
    Ps = np.asarray(Ps, float)
    n_steps = xs.shape[-2]
    Fk, Qk = _per_step(F, n_steps, 2), _per_step(Q, n_steps, 2)
    xsm = xs.copy()
    Psm = Ps.copy()
    for k in range(n_steps - 2, -1, -1):
        Fn = Fk(k + 1)
        x_k, P_k = xs[..., k, :], Ps[..., k, :, :]
        x_pred, P_pred = kf_predict(x_k, P_k, Fn, Qk(k + 1))
        # G = P Fᵀ (P⁻)⁻¹ = (P⁻⁻¹ F P)ᵀ
        G = _t(np.linalg.solve(P_pred, Fn @ P_k))
        xsm[..., k, :] = x_k + _mv(G, xsm[..., k + 1, :] - x_pred)
        Psm[..., k, :, :] = P_k + G @ (Psm[..., k + 1, :, :] - P_pred) @ _t(G)
    return xsm, Psm


__all__ = [
    "kf_predict",
    "kf_update",
    "ekf_update",
    "FilterResult",
    "kalman_filter",
    "extended_kalman_filter",
    "rts_smoother",
]

"""HIMR fixed-gain observers (1-D and 2-D) and an EKF variant, with CARE gains and
eigenvalue diagnostics (himr-tag.md §1.6–1.10, §6; seed 000 L500–L596, L842–L970,
L1104–L1174; wave2-specs.md §H "Observers").

Gain (eqs. 14–16 / 45–47, L551–L583, L953–L970): with W = Wᵀ > 0, V = Vᵀ > 0, Y solves the
continuous-time algebraic Riccati equation AY + YAᵀ − YCᵀV⁻¹CY + W = 0 and L = YCᵀV⁻¹.
It is solved by :func:`scipy.linalg.solve_continuous_are` on the dual problem
(Aᵀ, Cᵀ, W, V) — the filter CARE is the control CARE of the transposed system.
Tunings: 1-D W = 5·10⁴·diag(3, 1, 1), V = I₃ (L571); 2-D V = I (L1153) with
W = 965·I₉ ("D.1", L1964–L1972) or diag(579, 137, 149, 479, 127, 119, 191, 67, 67) ("D.2",
L1987–L1995), gains at the Table 8 point. The seed prints Lᵀ (erratum 4).

Observer (eqs. 10, 20, 29, 53; forward Euler, L587–L596, L1110–L1117): at the epochs t_k of
the measurement stream (packet times, so T = t_{k+1} − t_k ≈ 1/141 s)

    x̂_{k+1} = x̂_k + T_k·(A x̂_k + g_k·L·(y_k − h(x̂_k)))

with g_k = 1, or 0 where the gain is switched off (outage Case 3, eq. 52). A NaN in y_k
(a lost packet, an output not available) contributes no innovation for that output. The
estimate reported at t_k is x̂_k (it has used y_0 … y_{k−1}).

Variants of the 2-D observer: ``literal`` (h with the trigonometric acceleration rows,
the seed's estimator), ``prerotated`` (accelerations rotated into the fixed frame first,
:func:`~rfsim.estimators.himr_model.prerotate_accelerations`; the gain is unchanged), and
``ekf``: a discrete extended Kalman filter on the literal model, F = I + A·T, Q = W·T,
H = C(x̂⁻) re-linearised at every step, R = ``ekf_r`` (default: the diagonal of the
measurement variances of himr-tag.md §6.3,
:class:`~rfsim.estimators.himr_surrogate.SurrogateNoise`), reported estimate = the
posterior at t_k, P₀ = ``p0`` (default 10⁻²·I). The seed's V = I read as a continuous
noise density gives R = V/T (σ ≈ 12 in every output at 141 packets/s); with it the EKF's
heading lags the 18 rad/s² boom start by radians and the position error reaches ≈ 1.6 m
on the noise-free stream, so the EKF takes the physical noise levels instead.

Diagnostics (eqs. 33–35, L869–L889; Fig. 82, L2009–L2015): the frozen-time error matrix
A − L·C(x(t)) along a trajectory; its eigenvalue with the largest real part shows when the
fixed gain is locally unstable.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.estimators.himr_model import (A3, A9, C1, PYLONS_M, TABLE8_STATE, h_2d, jacobian_2d,
                                         prerotate_accelerations)
from rfsim.estimators.himr_surrogate import SurrogateNoise
from rfsim.core.lazy import lazy_import

_linalg = lazy_import("scipy.linalg")

Variant = Literal["literal", "prerotated", "ekf"]
VARIANTS = ("literal", "prerotated", "ekf")

#: Tunings of the seed (module docstring).
W_1D = 5e4 * np.diag([3.0, 1.0, 1.0])
W_D1 = 965.0 * np.eye(9)
W_D2 = np.diag([579.0, 137.0, 149.0, 479.0, 127.0, 119.0, 191.0, 67.0, 67.0])


@dataclass(frozen=True, eq=False)
class Gain:
    """A CARE gain: ``L`` (n, p), Riccati solution ``Y`` (n, n) and eig(A − L·C) (n,)."""

    L: np.ndarray
    Y: np.ndarray
    eigenvalues: np.ndarray


def care_gain(A, C, W, V) -> Gain:
    """CARE gain L = Y·Cᵀ·V⁻¹ with Y from the filter CARE AY + YAᵀ − YCᵀV⁻¹CY + W = 0 (eqs. 14–16).

    Solved by :func:`scipy.linalg.solve_continuous_are` on the dual problem (module docstring).

    Parameters
    ----------
    A : array_like
        ``(n, n)`` state matrix.
    C : array_like
        ``(p, n)`` output matrix.
    W : array_like
        ``(n, n)`` symmetric positive-definite state weight.
    V : array_like
        ``(p, p)`` symmetric positive-definite output weight.

    Returns
    -------
    Gain
        ``L`` (n, p), ``Y`` (n, n) and eig(A − L·C), sorted by real part [1/s].
    """
    A, C, W, V = (np.asarray(m, dtype=float) for m in (A, C, W, V))
    Y = _linalg.solve_continuous_are(A.T, C.T, W, V)
    L = Y @ C.T @ np.linalg.inv(V)
    ev = np.linalg.eigvals(A - L @ C)
    return Gain(L=L, Y=Y, eigenvalues=ev[np.lexsort((ev.imag, ev.real))])


def gain_1d(W=W_1D, V=None) -> Gain:
    """The 1-D HIMR gain (eq. 17–18): A₃, C = I₃, W = 5·10⁴·diag(3, 1, 1), V = I₃.

    Parameters
    ----------
    W : array_like
        ``(3, 3)`` state weight.
    V : array_like or None
        ``(3, 3)`` output weight; None: I₃.

    Returns
    -------
    Gain
        The CARE gain.
    """
    return care_gain(A3, C1, W, np.eye(3) if V is None else V)


def gain_2d(W=W_D2, V=None, *, point=TABLE8_STATE, pylons_m=PYLONS_M, accel="literal") -> Gain:
    """The 2-D HIMR gain at a linearisation point (Table 8 by default), V = I by default.

    Parameters
    ----------
    W : array_like
        ``(9, 9)`` state weight (default "D.2").
    V : array_like or None
        ``(2P + 4, 2P + 4)`` output weight; None: I.
    point : array_like
        ``(9,)`` linearisation state (units of :func:`rfsim.estimators.himr_model.h_2d`).
    pylons_m : array_like
        ``(P, 2)`` pylon positions [m].
    accel : {"literal", "prerotated"}
        Acceleration rows of C.

    Returns
    -------
    Gain
        The CARE gain.
    """
    C = jacobian_2d(point, pylons_m, "prerotated" if accel == "prerotated" else "literal")
    return care_gain(A9, C, W, np.eye(C.shape[0]) if V is None else V)


# ----------------------------------------------------------------------------- observers


def _check_stream(t_s, y, n_out: int):
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise ValueError("t_s must be increasing epochs (at least two)")
    if y.shape != (t.size, n_out):
        raise ValueError(f"y must be ({t.size}, {n_out}), got {y.shape}")
    return t, y


def wrap_innovation(innov, period):
    """``innov`` wrapped into ±period/2 where ``period`` > 0 (NaN or 0: unchanged).

    Parameters
    ----------
    innov : array_like
        Innovations, unit of the output.
    period : array_like
        Wrap period per output (broadcast), same unit.

    Returns
    -------
    numpy.ndarray
        Wrapped innovations.
    """
    p = np.nan_to_num(np.asarray(period, float))
    safe = np.where(p > 0, p, 1.0)
    return np.where(p > 0, innov - safe * np.round(innov / safe), innov)


def luenberger(t_s, y, *, A, L, h, x0, gain_on=None, wrap_period=None, innovation=None) -> np.ndarray:
    """Forward-Euler fixed-gain observer (module docstring) with output map ``h``.

    x̂_{k+1} = x̂_k + T_k·(A x̂_k + g_k·L·(y_k − h(x̂_k))) (eqs. 10, 20, 29, 53).

    Parameters
    ----------
    t_s : array_like
        ``(n,)`` increasing epochs [s].
    y : array_like
        ``(n, p)`` measurements (NaN = missing).
    A : array_like
        ``(m, m)`` state matrix.
    L : array_like
        ``(m, p)`` gain.
    h : callable
        Output map ``x (m,) → (p,)``.
    x0 : array_like
        ``(m,)`` initial estimate.
    gain_on : array_like of bool or None
        ``(n,)`` g_k (None: all on).
    wrap_period : array_like or None
        ``(p,)`` or ``(n, p)``: an output measured modulo its period (a phase-derived radial
        velocity, period λ/(2·Δt)) gets its innovation wrapped into ±period/2 — the aliasing is
        resolved by the estimate the other sensors support.
    innovation : callable or None
        ``(k, innov) → innov`` applied after the wrapping (e.g. to drop outputs at an epoch:
        NaN contributes no innovation).

    Returns
    -------
    numpy.ndarray
        ``(n, m)`` estimates x̂_k at the epochs.

    Raises
    ------
    ValueError
        If ``t_s`` is not increasing (at least two epochs) or ``y`` has the wrong shape.
    """
    A, L = np.asarray(A, float), np.asarray(L, float)
    t, y = _check_stream(t_s, y, L.shape[1])
    on = np.ones(t.size, bool) if gain_on is None else np.asarray(gain_on, bool)
    T = np.append(np.diff(t), t[-1] - t[-2])
    out = np.empty((t.size, A.shape[0]))
    x = np.array(x0, dtype=float)
    wp = None if wrap_period is None else np.broadcast_to(np.asarray(wrap_period, float), y.shape)
    for k in range(t.size):
        out[k] = x
        dx = A @ x
        if on[k]:
            innov = y[k] - h(x)
            if wp is not None:
                innov = wrap_innovation(innov, wp[k])
            if innovation is not None:
                innov = innovation(k, innov)
            dx += L @ np.where(np.isnan(innov), 0.0, innov)
        x = x + T[k] * dx
    return out


def observe_1d(t_s, y, *, x0, gain: Gain | None = None, gain_on=None, wrap_period=None) -> np.ndarray:
    """1-D HIMR observer (eq. 20) on a measurement stream.

    Parameters
    ----------
    t_s : array_like
        ``(n,)`` increasing epochs [s].
    y : array_like
        ``(n, 3)`` = [RSS range [m], radial velocity [m/s], acceleration [m/s²]].
    x0 : array_like
        ``(3,)`` initial estimate [m, m/s, m/s²].
    gain : Gain or None
        Precomputed gain; None: :func:`gain_1d`.
    gain_on : array_like of bool or None
        ``(n,)`` gain switch (None: all on).
    wrap_period : array_like or None
        Wrap periods of outputs measured modulo them (:func:`luenberger`).

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` estimates [m, m/s, m/s²].
    """
    g = gain_1d() if gain is None else gain
    return luenberger(t_s, y, A=A3, L=g.L, h=lambda x: C1 @ x, x0=x0, gain_on=gain_on, wrap_period=wrap_period)


def _ekf(t, y, pylons, W, R, x0, p0, wrap_period=None):
    T = np.append(np.diff(t), t[-1] - t[-2])
    x = np.array(x0, dtype=float)
    P = np.asarray(p0, float).copy()
    out = np.empty((t.size, 9))
    eye = np.eye(9)
    wp = None if wrap_period is None else np.broadcast_to(np.asarray(wrap_period, float), y.shape)
    for k in range(t.size):
        ok = ~np.isnan(y[k])
        if ok.any():
            H = jacobian_2d(x, pylons)[ok]
            S = H @ P @ H.T + R[np.ix_(ok, ok)]
            K = np.linalg.solve(S, H @ P).T
            innov = y[k] - h_2d(x, pylons)
            if wp is not None:
                innov = wrap_innovation(innov, wp[k])
            x = x + K @ innov[ok]
            P = (eye - K @ H) @ P
        out[k] = x
        F = eye + A9 * T[k]
        x = F @ x
        P = F @ P @ F.T + W * T[k]
    return out


def observe_2d(t_s, y, *, x0=None, variant: Variant = "prerotated", pylons_m=PYLONS_M, W=W_D2,
               V=None, gain: Gain | None = None, gain_on=None, p0=None, ekf_r=None,
               wrap_period=None, innovation=None) -> np.ndarray:
    """2-D HIMR observer on a measurement stream (module docstring).

    Parameters
    ----------
    t_s : array_like
        ``(n,)`` increasing epochs [s].
    y : array_like
        ``(n, 2P + 4)`` measured outputs in observer order with the literal acceleration
        convention (a₁ = a·y^B, a₂ = −a·x^B); ``prerotated`` rotates them itself.
    x0 : array_like or None
        ``(9,)`` initial estimate (default: IC #1 of Table 9, (2, 1.8048) m, ψ = π, at rest).
    variant : {"literal", "prerotated", "ekf"}
        Observer variant.
    pylons_m : array_like
        ``(P, 2)`` pylons whose outputs are in ``y`` [m] (Case 7: the first two).
    W, V : array_like or None
        CARE tuning (V default I).
    gain : Gain or None
        A precomputed gain (else from W, V at Table 8).
    gain_on : array_like of bool or None
        ``(n,)`` Case-3 gain switch.
    p0 : array_like or None
        ``(9, 9)`` EKF initial covariance (default 10⁻²·I).
    ekf_r : array_like or None
        ``(2P + 4, 2P + 4)`` EKF measurement covariance (default: himr-tag.md §6.3 variances).
    wrap_period : array_like or None
        Per-output (or per-epoch and output) period of outputs measured modulo it
        (:func:`luenberger`; the EKF wraps its innovation the same way).
    innovation : callable or None
        A hook on the fixed-gain observers' innovations (:func:`luenberger`).

    Returns
    -------
    numpy.ndarray
        ``(n, 9)`` state estimates [x ẋ ẍ y ẏ ÿ ψ ψ̇ ψ̈] [m, m/s, m/s², m, m/s, m/s², rad,
        rad/s, rad/s²].

    Raises
    ------
    ValueError
        For an unknown variant or a malformed stream.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    pyl = np.asarray(pylons_m, float)
    n_out = 2 * pyl.shape[0] + 4
    x0 = np.array([2.0, 0, 0, 1.8048, 0, 0, np.pi, 0, 0]) if x0 is None else np.asarray(x0, float)
    V = np.eye(n_out) if V is None else np.asarray(V, float)
    t, y = _check_stream(t_s, y, n_out)
    if variant == "ekf":
        R = np.diag(SurrogateNoise().sigmas(pyl.shape[0]) ** 2) if ekf_r is None else np.asarray(ekf_r, float)
        return _ekf(t, y, pyl, np.asarray(W, float), R, x0, 1e-2 * np.eye(9) if p0 is None else p0, wrap_period)
    accel = "prerotated" if variant == "prerotated" else "literal"
    g = gain_2d(W, V, pylons_m=pyl, accel=accel) if gain is None else gain
    if accel == "prerotated":
        y = prerotate_accelerations(y, pyl.shape[0])
    return luenberger(t, y, A=A9, L=g.L, h=lambda x: h_2d(x, pyl, accel), x0=x0, gain_on=gain_on,
                      wrap_period=wrap_period, innovation=innovation)


# ----------------------------------------------------------------------------- diagnostics


def eig_along(states, L, *, pylons_m=PYLONS_M, accel="literal") -> np.ndarray:
    """eig(A − L·C(x)) for each state of a trajectory (eqs. 33–35).

    Parameters
    ----------
    states : array_like
        ``(n, 9)`` states.
    L : array_like
        ``(9, p)`` gain.
    pylons_m : array_like
        ``(P, 2)`` pylon positions [m].
    accel : {"literal", "prerotated"}
        Acceleration rows of C.

    Returns
    -------
    numpy.ndarray
        ``(n, 9) complex`` eigenvalues [1/s].
    """
    st = np.atleast_2d(np.asarray(states, float))
    return np.linalg.eigvals(A9 - L @ jacobian_2d(st, pylons_m, accel))


def unstable_intervals(t_s, max_real) -> list[tuple[float, float]]:
    """Intervals [t_first, t_last] of consecutive epochs where ``max_real`` > 0.

    Parameters
    ----------
    t_s : array_like
        ``(n,)`` epochs [s].
    max_real : array_like
        ``(n,)`` largest real part of the error-matrix eigenvalues [1/s].

    Returns
    -------
    list of tuple of float
        ``(t_first, t_last)`` [s] per interval.
    """
    t = np.asarray(t_s, float)
    pos = np.asarray(max_real) > 0
    out, i = [], 0
    while i < t.size:
        if pos[i]:
            j = i
            while j + 1 < t.size and pos[j + 1]:
                j += 1
            out.append((float(t[i]), float(t[j])))
            i = j + 1
        else:
            i += 1
    return out


def ranks_along(states, *, pylons_m=PYLONS_M, accel="literal") -> np.ndarray:
    """Rank of O = [C; CA; CA²] (A³ = 0) for each state of a trajectory.

    Parameters
    ----------
    states : array_like
        ``(n, 9)`` states.
    pylons_m : array_like
        ``(P, 2)`` pylon positions [m].
    accel : {"literal", "prerotated"}
        Acceleration rows of C.

    Returns
    -------
    numpy.ndarray
        ``(n,) int`` ranks.
    """
    C = jacobian_2d(np.atleast_2d(np.asarray(states, float)), pylons_m, accel)
    return np.linalg.matrix_rank(np.concatenate([C, C @ A9, C @ A9 @ A9], axis=-2)).astype(int)


def range_gate(n_pylons: int, gate_m: float, period):
    """Innovation hook (:func:`luenberger`) of the gated dealiasing of the 2-D radial velocities.

    The radial-velocity innovations are wrapped into ±period/2 only while every measured
    RSS-range innovation is below ``gate_m`` — then the position the other sensors support is
    close enough for the prediction to pick the right alias; otherwise (after an outage, from a
    far initial condition) the measured value is used as it is. Wrapping always can lock the
    observer onto a wrong alias: a velocity error of a multiple of λ/(2Δt) along every pylon's
    direction gives zero wrapped innovation and is held by a constant range innovation.

    Parameters
    ----------
    n_pylons : int
        P; the outputs are in observer order [r₁ ṙ₁ … r_P ṙ_P, …].
    gate_m : float
        The gate on every |range innovation| [m].
    period : array_like
        ``(n, 2P + 4)`` wrap period per epoch and output (λ/(2Δt) [m/s] on the ṙ outputs, 0
        elsewhere).

    Returns
    -------
    callable
        ``hook(k, innov) → innov``.
    """
    rows = np.arange(0, 2 * n_pylons, 2)

    def hook(k, innov):
        r = innov[rows]
        r = r[~np.isnan(r)]
        if r.size and np.abs(r).max() < gate_m:
            return wrap_innovation(innov, period[k])
        return innov
    return hook


__all__ = ["range_gate", "Gain", "care_gain", "gain_1d", "gain_2d", "W_1D", "W_D1", "W_D2", "VARIANTS",
           "luenberger", "wrap_innovation", "observe_1d", "observe_2d", "eig_along", "unstable_intervals",
           "ranks_along"]

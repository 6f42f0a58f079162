"""Phase-based tracking of a UHF RFID tag at one carrier (Särkkä, Viikari, Huusko, Jaakkola 2012).

Source: phase-tracking.md (seeds/001, IEEE Sensors J. 12(5), DOI 10.1109/JSEN.2011.2164062);
``Lnn`` are lines of the seed. Every function is a reference implementation for validating
phase datasets, cross-checked in tests/test_estimators_phase.py (filterpy, scipy).

Pseudo-ranges (eq. 3–6, L63–L85). A reader reporting ``φ = (−arg h) mod 2π`` of the round-trip
response ``h ∝ exp(−j·4πr/λ)`` (eq. 1) sees ``φ = 4πr/λ + φ_0 (mod 2π)``, so (the sign erratum
of eq. 2, P§5, does not arise with this convention)::

    r̂_n = r̂_{n−1} + (λ/4π)·wrap(φ_n − φ_{n−1}),   wrap into (−π, π]            (4)
    r̂_0 = |p̂_0 − a_i|                                                        (5)
    r̂_n = |p_n − a_i| + b_i                                                   (6)

per antenna ``i`` over its own reads; the constant ``b_i`` absorbs the unknown wraps and any
per-port phase offset. It is unambiguous while ``|Δr| < λ/4`` between two reads of one antenna,
i.e. a radial speed below ``λ/(4Δt)`` (8.42 m/s at 890 MHz and 100 reads/s; the paper's
λ/(2Δt), L73, is twice too loose, P§1.2).

RSSI fix (eq. 13, L115–L123): ``min_p Σ_i [ln(A_0/|p − a_i|²) − ln|Y_i|]²`` with ``|Y_i|`` the
received amplitude (``ln|Y| = ln10·(RSSI_dBm − 30)/20``) and ``A_0`` unknown: the cost is linear
in ``ln A_0``, which is eliminated exactly (its optimum is the mean of ``ln|Y_i| + 2 ln d_i``),
leaving a 2-D (or 3-D) nonlinear least-squares problem solved by damped Gauss–Newton
(Levenberg–Marquardt), batched over epochs.

Dynamics (eq. 7–12, L87–L113): Wiener velocity (CWNA) for the position, a random walk per
bias, ``x = (p_1..p_d, b_1..b_s, v_1..v_d)``, ``dx/dt = F x + L w``, ``Q = diag(q_b I_s, q_v I_d)``.
Exact discretisation (eq. 14, closed form P§1.6)::

    A(Δt) = [[I_d, 0, Δt I_d], [0, I_s, 0], [0, 0, I_d]]
    W(Δt) = [[q_v Δt³/3 I_d, 0, q_v Δt²/2 I_d], [0, q_b Δt I_s, 0], [q_v Δt²/2 I_d, 0, q_v Δt I_d]]

Measurement ``r̂_i = |p − a_i| + b_i + ε``, ``ε ~ N(0, σ²)``. The reader reads one antenna at a
time (L57, L178), so the EKF (eq. 16–17) is run per read: predict over the time since the
previous read, then a scalar update with the antenna of this read (the "straightforward"
non-synchronised extension, L137). RTS smoother: eq. 18–19. Iteration (L161–L166, L205): the
next pass starts from the smoothed state at the first read of the previous pass (same prior
covariance); the paper's threshold on the bias change is not given, so the number of passes
is a parameter.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from rfsim.core.lazy import lazy_import

_pk = lazy_import("rfsim.estimators._phase_kernels")


#: log-amplitude per dBm: ln|Y| = LN_AMPLITUDE_PER_DB·(RSSI_dBm − 30)
LN_AMPLITUDE_PER_DB = math.log(10.0) / 20.0


def unwrap_limit_mps(wavelength_m: float, dt_s) -> np.ndarray:
    """Largest radial speed the unwrapping (eq. 4) follows between reads: ``λ/(4Δt)``.

    A range step below λ/4, a phase step below π (module docstring; P§1.2).

    Parameters
    ----------
    wavelength_m : float
        Carrier wavelength λ [m].
    dt_s : array_like
        Time between reads of one antenna Δt [s].

    Returns
    -------
    numpy.ndarray
        Speed limit [m/s], shape of ``dt_s``.
    """
    return float(wavelength_m) / (4.0 * np.asarray(dt_s, float))


def unwrap_pseudoranges(antenna, phase_rad, *, wavelength_m: float, r0_m) -> np.ndarray:
    """Pseudo-ranges [m] of a time-sorted read log by eq. (4)–(5), per antenna.

    Parameters
    ----------
    antenna : (N,) int, 0-based antenna of each read
    phase_rad : (N,) reported phase (−arg h) mod 2π [rad]; NaN for a failed read (its
        pseudo-range is NaN, the next read is unwrapped against the last valid one)
    wavelength_m : carrier wavelength λ [m]
    r0_m : (s,) starting range of each antenna [m] (eq. 5: |p̂_0 − a_i|)

    Returns
    -------
    (N,) float pseudo-ranges [m]
    """
    ant = np.asarray(antenna, dtype=np.int64)
    phi = np.asarray(phase_rad, float)
    r0 = np.asarray(r0_m, float)
    out = np.full(phi.shape, np.nan)
    scale = float(wavelength_m) / (4.0 * math.pi)
    for i in range(r0.size):
        idx = np.flatnonzero((ant == i) & np.isfinite(phi))
        if idx.size == 0:
            continue
        dphi = np.diff(phi[idx])
        step = np.mod(dphi + math.pi, 2.0 * math.pi) - math.pi  # (−π, π] up to the endpoint
        step = np.where(step == -math.pi, math.pi, step)
        out[idx] = r0[i] + scale * np.concatenate(([0.0], np.cumsum(step)))
    return out


def rssi_fix(rssi_dbm, anchors_m, *, p0_m=None, iterations: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Position from RSSI by log least squares, eq. (13), with ``ln A_0`` eliminated.

    Parameters
    ----------
    rssi_dbm : (..., s) RSSI of each antenna [dBm] (one epoch per leading index)
    anchors_m : (s, d) antenna positions [m]
    p0_m : (..., d) or (d,) starting point; default the centroid of the antennas
    iterations : Gauss–Newton steps (with Levenberg–Marquardt damping)

    Returns
    -------
    p (..., d) [m], ln_a0 (...) the fitted ln A_0 (amplitude units √W·m²)
    """
    y = LN_AMPLITUDE_PER_DB * (np.asarray(rssi_dbm, float) - 30.0)
    a = np.asarray(anchors_m, float)
    batch = y.shape[:-1]
    p = np.broadcast_to(a.mean(axis=0) if p0_m is None else np.asarray(p0_m, float), batch + a.shape[1:]).copy()

    def residual(p):
        diff = p[..., None, :] - a                        # (..., s, d)
        d2 = np.maximum(np.sum(diff ** 2, axis=-1), 1e-12)
        u = y + np.log(d2)                                # ln|Y| + 2 ln d = ln A0 + residual
        e = u - u.mean(axis=-1, keepdims=True)
        g = 2.0 * diff / d2[..., None]                    # ∂u/∂p
        J = g - g.mean(axis=-2, keepdims=True)
        return e, J, u.mean(axis=-1)

    lam = np.full(batch, 1e-3)
    e, J, _ = residual(p)
    cost = np.sum(e ** 2, axis=-1)
    eye = np.eye(a.shape[1])
    for _ in range(int(iterations)):
        JTJ = np.swapaxes(J, -1, -2) @ J
        JTe = (np.swapaxes(J, -1, -2) @ e[..., None])[..., 0]
        step = np.linalg.solve(JTJ + lam[..., None, None] * (np.diagonal(JTJ, axis1=-2, axis2=-1)[..., None] * eye
                                                               + 1e-12 * eye), -JTe[..., None])[..., 0]
        e_new, J_new, _ = residual(p + step)
        cost_new = np.sum(e_new ** 2, axis=-1)
        better = cost_new < cost
        p = np.where(better[..., None], p + step, p)
        e = np.where(better[..., None], e_new, e)
        J = np.where(better[..., None, None], J_new, J)
        cost = np.where(better, cost_new, cost)
        lam = np.where(better, lam * 0.3, lam * 10.0)
    return p, residual(p)[2]


def continuous_model(dims: int, n_antennas: int, *, q_v: float, q_b: float) -> tuple[np.ndarray, ...]:
    """Continuous-time model ``dx/dt = F x + L w`` of eq. (8)–(12), n = 2d + s.

    Parameters
    ----------
    dims : int
        Spatial dimensions d.
    n_antennas : int
        Antennas s (one bias each).
    q_v : float
        Velocity noise spectral density [m²/s³].
    q_b : float
        Bias random-walk density [m²/s].

    Returns
    -------
    F : numpy.ndarray
        ``(n, n)`` drift matrix.
    L : numpy.ndarray
        ``(n, s + d)`` noise gain.
    Qc : numpy.ndarray
        ``(s + d, s + d)`` spectral density ``diag(q_b I_s, q_v I_d)``.
    """
    d, s = int(dims), int(n_antennas)
    n = 2 * d + s
    F = np.zeros((n, n))
    F[:d, d + s:] = np.eye(d)
    L = np.zeros((n, s + d))
    L[d:d + s, :s] = np.eye(s)
    L[d + s:, s:] = np.eye(d)
    Qc = np.diag(np.concatenate([np.full(s, float(q_b)), np.full(d, float(q_v))]))
    return F, L, Qc


def discrete_model(dt_s: float, dims: int, n_antennas: int, *, q_v: float, q_b: float) -> tuple[np.ndarray, np.ndarray]:
    """``A(Δt) = exp(FΔt)`` and ``W(Δt)`` of eq. (14) in closed form (module docstring).

    Parameters
    ----------
    dt_s : float
        Time step Δt [s].
    dims : int
        Spatial dimensions d.
    n_antennas : int
        Antennas s.
    q_v : float
        Velocity noise spectral density [m²/s³].
    q_b : float
        Bias random-walk density [m²/s].

    Returns
    -------
    A : numpy.ndarray
        ``(n, n)`` transition.
    W : numpy.ndarray
        ``(n, n)`` process-noise covariance [m², m²/s, m²/s²].
    """
    d, s = int(dims), int(n_antennas)
    n = 2 * d + s
    A, W = np.zeros((n, n)), np.zeros((n, n))
    _pk.transition_kernel(float(dt_s), d, s, float(q_v), float(q_b), A, W)
    return A, W


def initial_state(p0_m, n_antennas: int, *, pos_std_m: float = 3.0, bias_std_m: float = 1.0,
                  vel_std_mps: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Prior ``x0 = (p̂_0, 0, 0)`` and ``P0 = diag(σ_p², σ_b², σ_v²)``.

    3 m position std (L203); 1 m bias and 0.5 m/s velocity std (P§6).

    Parameters
    ----------
    p0_m : array_like
        ``(d,)`` starting position p̂_0 [m].
    n_antennas : int
        Antennas s.
    pos_std_m : float
        σ_p [m].
    bias_std_m : float
        σ_b [m].
    vel_std_mps : float
        σ_v [m/s].

    Returns
    -------
    x0 : numpy.ndarray
        ``(2d + s,)`` state ``(p, b, v)`` [m, m, m/s].
    P0 : numpy.ndarray
        ``(2d + s, 2d + s)`` covariance.
    """
    p0 = np.asarray(p0_m, float)
    d, s = p0.size, int(n_antennas)
    x0 = np.concatenate([p0, np.zeros(s), np.zeros(d)])
    P0 = np.diag(np.concatenate([np.full(d, pos_std_m ** 2), np.full(s, bias_std_m ** 2), np.full(d, vel_std_mps ** 2)]))
    return x0, P0


class PassResult(NamedTuple):
    """One filter + smoother pass over the reads.

    x_filt, x_smooth : (N, n) EKF and RTS means, state ``(p, b, v)``
    P_filt, P_smooth : (N, n, n) their covariances
    x_pred, P_pred : (N, n), (N, n, n) predictions before each update (step 0: the prior)

    The covariances and predictions are None when :func:`track_phase` was asked not to keep
    them (``keep_covariances=False``: 3·N·n² floats per pass, 37 MB for 24,000 reads and n = 8).
    """

    x_filt: np.ndarray
    P_filt: np.ndarray
    x_pred: np.ndarray
    P_pred: np.ndarray
    x_smooth: np.ndarray
    P_smooth: np.ndarray


def _check_reads(t_s, antenna, z_m, anchors_m):
    t = np.ascontiguousarray(t_s, dtype=np.float64)
    ant = np.ascontiguousarray(antenna, dtype=np.int64)
    z = np.ascontiguousarray(z_m, dtype=np.float64)
    a = np.ascontiguousarray(anchors_m, dtype=np.float64)
    if not (t.ndim == ant.ndim == z.ndim == 1 and t.size == ant.size == z.size):
        raise ValueError("t_s, antenna and z_m must be 1-D of equal length")
    if t.size == 0:
        raise ValueError("no reads")
    if np.any(np.diff(t) < 0):
        raise ValueError("reads must be sorted by time")
    if ant.size and (ant.min() < 0 or ant.max() >= a.shape[0]):
        raise ValueError(f"antenna indices must be in 0…{a.shape[0] - 1}")
    return t, ant, z, a


def ekf_reads(t_s, antenna, z_m, anchors_m, x0, P0, *, q_v: float, q_b: float, sigma_m: float):
    """Sequential per-read EKF (eq. 16–17).

    Parameters
    ----------
    t_s : array_like
        ``(N,)`` read times [s], sorted.
    antenna : array_like of int
        ``(N,)`` 0-based antenna of each read.
    z_m : array_like
        ``(N,)`` pseudo-ranges [m] (NaN: the read is skipped).
    anchors_m : array_like
        ``(s, d)`` antenna positions [m].
    x0 : array_like
        ``(n,)`` prior mean at ``t_s[0]``, state ``(p, b, v)`` [m, m, m/s].
    P0 : array_like
        ``(n, n)`` prior covariance.
    q_v : float
        Velocity noise spectral density [m²/s³].
    q_b : float
        Bias random-walk density [m²/s].
    sigma_m : float
        Pseudo-range noise std σ [m].

    Returns
    -------
    x_filt, P_filt : numpy.ndarray
        ``(N, n)``, ``(N, n, n)`` filtered means and covariances.
    x_pred, P_pred : numpy.ndarray
        ``(N, n)``, ``(N, n, n)`` predictions before each update.

    Raises
    ------
    ValueError
        For reads of unequal length, none, unsorted, antenna indices out of range, or a prior of
        the wrong shape.
    """
    t, ant, z, a = _check_reads(t_s, antenna, z_m, anchors_m)
    s, d = a.shape
    n = 2 * d + s
    x0 = np.ascontiguousarray(x0, dtype=np.float64)
    P0 = np.ascontiguousarray(P0, dtype=np.float64)
    if x0.shape != (n,) or P0.shape != (n, n):
        raise ValueError(f"x0 must be ({n},) and P0 ({n}, {n}) for {s} antennas in {d}-D")
    N = t.size
    xf, xp = np.empty((N, n)), np.empty((N, n))
    Pf, Pp = np.empty((N, n, n)), np.empty((N, n, n))
    _pk.ekf_kernel(t, ant, z, a, x0, P0, float(q_v), float(q_b), float(sigma_m) ** 2, xf, Pf, xp, Pp)
    return xf, Pf, xp, Pp


def rts_reads(t_s, x_filt, P_filt, x_pred, P_pred, *, dims: int, n_antennas: int, q_v: float, q_b: float):
    """RTS smoother (eq. 19) of :func:`ekf_reads` output.

    Parameters
    ----------
    t_s : array_like
        ``(N,)`` read times [s].
    x_filt, P_filt, x_pred, P_pred : numpy.ndarray
        The outputs of :func:`ekf_reads`.
    dims : int
        Spatial dimensions d.
    n_antennas : int
        Antennas s.
    q_v : float
        Velocity noise spectral density [m²/s³].
    q_b : float
        Bias random-walk density [m²/s].

    Returns
    -------
    x_smooth, P_smooth : numpy.ndarray
        ``(N, n)``, ``(N, n, n)`` smoothed means and covariances.
    """
    t = np.ascontiguousarray(t_s, dtype=np.float64)
    xs, Ps = np.empty_like(x_filt), np.empty_like(P_filt)
    _pk.rts_kernel(t, int(dims), int(n_antennas), float(q_v), float(q_b), np.ascontiguousarray(x_filt),
                   np.ascontiguousarray(P_filt), np.ascontiguousarray(x_pred), np.ascontiguousarray(P_pred), xs, Ps)
    return xs, Ps


def track_phase(t_s, antenna, z_m, anchors_m, x0, P0, *, q_v: float = 1.0, q_b: float = 1e-4,
                sigma_m: float = 0.01, passes: int = 2, keep_covariances: bool = True) -> list[PassResult]:
    """EKF + RTS passes over the pseudo-ranges (module docstring).

    Pass k+1 starts from the smoothed state of pass k at the first read (L205).

    Parameters
    ----------
    t_s : array_like
        ``(N,)`` read times [s], sorted.
    antenna : array_like of int
        ``(N,)`` 0-based antenna of each read.
    z_m : array_like
        ``(N,)`` pseudo-ranges [m] (NaN: skipped).
    anchors_m : array_like
        ``(s, d)`` antenna positions [m].
    x0, P0 : array_like
        Prior of the first pass (:func:`initial_state`).
    q_v : float
        Velocity noise spectral density [m²/s³] (default 1, wave2-specs.md §R, P§6).
    q_b : float
        Bias random-walk density [m²/s] (default 1e-4).
    sigma_m : float
        Pseudo-range noise std [m] (default 0.01).
    passes : int
        Number of passes (≥ 1).
    keep_covariances : bool
        False keeps only the means of each pass (x_filt, x_smooth; the rest None), so memory
        does not grow with the passes.

    Returns
    -------
    list of PassResult
        One per pass.

    Raises
    ------
    ValueError
        If ``passes`` < 1 (and as :func:`ekf_reads`).
    """
    if int(passes) < 1:
        raise ValueError(f"passes must be ≥ 1, got {passes}")
    a = np.asarray(anchors_m, float)
    s, d = a.shape
    out = []
    x_start = np.asarray(x0, float)
    for _ in range(int(passes)):
        xf, Pf, xp, Pp = ekf_reads(t_s, antenna, z_m, a, x_start, P0, q_v=q_v, q_b=q_b, sigma_m=sigma_m)
        xs, Ps = rts_reads(t_s, xf, Pf, xp, Pp, dims=d, n_antennas=s, q_v=q_v, q_b=q_b)
        if keep_covariances:
            out.append(PassResult(xf, Pf, xp, Pp, xs, Ps))
        else:
            out.append(PassResult(xf, None, None, None, xs, None))
            del Pf, xp, Pp, Ps
        x_start = xs[0].copy()
    return out


def first_per_antenna(antenna, values, n_antennas: int) -> np.ndarray:
    """The first finite value of every antenna in a time-sorted read log.

    E.g. the first reported RSSI per antenna for the eq. (13) start fix p̂₀.

    Parameters
    ----------
    antenna : array_like of int
        ``(N,)`` 0-based antenna of each read.
    values : array_like of float
        ``(N,)`` one value per read (NaN for a failed read), any unit.
    n_antennas : int
        Number of antennas s.

    Returns
    -------
    numpy.ndarray
        ``(s,)`` unit of ``values``, NaN where an antenna has none.
    """
    ant, v = np.asarray(antenna), np.asarray(values, float)
    first = np.full(n_antennas, np.nan)
    for i in range(n_antennas):
        idx = np.flatnonzero((ant == i) & np.isfinite(v))
        if idx.size:
            first[i] = v[idx[0]]
    return first


def latest_per_antenna(antenna, values, n_antennas: int) -> np.ndarray:
    """At each read of a time-sorted log, the latest finite value of every antenna.

    Up to and including that read, e.g. the RSSI vector of the RSSI-only track (eq. 13 at
    every read, Fig. 8, L207).

    Parameters
    ----------
    antenna : array_like of int
        ``(N,)`` 0-based antenna of each read.
    values : array_like of float
        ``(N,)`` one value per read (NaN for a failed read), any unit.
    n_antennas : int
        Number of antennas s.

    Returns
    -------
    numpy.ndarray
        ``(N, s)`` unit of ``values``, NaN before an antenna's first value.
    """
    ant, v = np.asarray(antenna), np.asarray(values, float)
    out = np.full((v.size, n_antennas), np.nan)
    idx = np.arange(v.size)
    for i in range(n_antennas):
        have = (ant == i) & np.isfinite(v)
        last = np.maximum.accumulate(np.where(have, idx, -1))
        out[:, i] = np.where(last >= 0, v[np.maximum(last, 0)], np.nan)
    return out


def unwrap_jumps(antenna, offset_m, *, wavelength_m: float, n_antennas: int) -> np.ndarray:
    """Reads whose pseudo-range offset jumped by more than λ/4 since the same antenna's previous valid read.

    The offset (pseudo-range − true range, eq. 6) is the constant b_i plus noise; a change
    above λ/4 is an unwrapping jump of λ/2 (the radial speed exceeded λ/(4Δt),
    :func:`unwrap_limit_mps`).

    Parameters
    ----------
    antenna : array_like of int
        ``(N,)`` 0-based antenna of each read.
    offset_m : array_like of float
        ``(N,)`` offsets [m], NaN for a failed read.
    wavelength_m : float
        Carrier wavelength λ [m].
    n_antennas : int
        Number of antennas s.

    Returns
    -------
    numpy.ndarray
        ``(N,) bool``.
    """
    ant, off = np.asarray(antenna), np.asarray(offset_m, float)
    jump = np.zeros(off.size, dtype=bool)
    for i in range(n_antennas):
        idx = np.flatnonzero((ant == i) & np.isfinite(off))
        jump[idx[1:]] = np.abs(np.diff(off[idx])) > wavelength_m / 4
    return jump


def error_stats(err_m) -> dict[str, float]:
    """Error statistics of the finite position errors (Särkkä et al., L203–L207).

    Parameters
    ----------
    err_m : array_like
        Position errors [m] (non-finite values ignored).

    Returns
    -------
    dict of str to float
        ``rmse_m``, ``mean_m``, ``median_m``, ``p90_m``, ``max_m``, ``std_m`` [m].
    """
    e = np.asarray(err_m, float)
    e = e[np.isfinite(e)]
    return {"rmse_m": float(np.sqrt(np.mean(e ** 2))), "mean_m": float(e.mean()), "median_m": float(np.median(e)),
            "p90_m": float(np.quantile(e, 0.9)), "max_m": float(e.max()), "std_m": float(e.std())}


__all__ = ["first_per_antenna", "latest_per_antenna", "unwrap_jumps", "error_stats", "LN_AMPLITUDE_PER_DB", "unwrap_limit_mps", "unwrap_pseudoranges", "rssi_fix", "continuous_model",
           "discrete_model", "initial_state", "PassResult", "ekf_reads", "rts_reads", "track_phase"]

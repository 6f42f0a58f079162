"""Particle filters that track a sense-a-tag from how often it detected each landmark tag:
PF-BIN, PF-AA (with its bias compensation) and the weighted centroid, batched over runs.

AURIS ch. 4 (auris-sense-a-tag.md §7.2-§7.5; seeds/003 L2122-L2192, L4090-L4616, L5042-L5100).
In query period t (length Δt = T_s) the ST decodes landmark k in n_{t,k} of the N rounds
(Eq. 4.10). The likelihood of a position x (Eqs. 4.15, 4.18-4.19) is binomial over *all*
landmarks, detected or not::

    p(y_t | x) = Π_k C(N, n_k) p_k(x)^{n_k} (1 − p_k(x))^{N − n_k},

with p_k(x) the RTS model of the landmark (Eq. 4.6; the scenario supplies it).

* **WCL** (Eq. 4.12): x̂*_t = Σ_k n_{t,k} L_k / Σ_k n_{t,k} (:func:`rfsim.estimators.nearest.weighted_centroid`).
* **PF-BIN** (Eq. 4.9, the baseline of [11]; L4610-L4616): state [x1, x2, ẋ1, ẋ2], x_{t+1} = A x_t + B u_t,
  A = [[1,0,T,0],[0,1,0,T],[0,0,1,0],[0,0,0,1]], B = [[T,0],[0,T],[1,0],[0,1]], u ~ N(0, diag(σ_u²)),
  σ_u² = 0.01 (L4614), started from the known initial state.
* **PF-AA** (Algorithm 2, Eqs. 4.11-4.24): position-only particles with the AR motion
  x_t = x_{t−1} + v̂_t Δt + q_t, q_t ~ N(0, σ_q² I), the velocity input v̂_t = b0 v̂*_t + b1 v̂_{t−1}
  from v̂*_t = (x̂*_t − x̂_{t−1})/Δt (Eqs. 4.13-4.14; v̂*_t = 0 in a period without detections),
  and after the update v̂_t = (x̂_t − x̂_{t−1})/Δt (Eq. 4.22). Initialisation (t = 1): particles
  ~ N(x̂*_1, σ_1² I), v̂_1 = 0, no propagation. With compensation, when |v̂_t| ≥ v_threshold the
  output is x̃_t = x̂_t + (b0 v̂_t + b1 v̂_{t−1})(t − t̂), t̂ the mean detection time of the period
  (Eqs. 4.23-4.24); otherwise x̃_t = x̂_t. SQLAM's module 1 (Algorithm 3) is PF-AA without it.

Both PFs run :func:`rfsim.estimators.particle.sir_filter` with multinomial resampling at every
step (L5008-L5014). PF-AA's motion needs x̂_{t−1}: since every step resamples, the weights
entering step t are uniform and the MMSE of step t is Σ softmax(log-likelihood)·particles, which
its likelihood hook records for the next propagation (exactly the filter's own MMSE).

Parameters (:class:`LandmarkFilterConfig`; L4503-L4616, L5393-L5409): M = 200, q_t std 0.3 m
(the source's N(0, 0.3) does not say std or variance, A§0.4: std taken), b0 = 0.8, b1 = 0.2,
initial spread 0.3 m, v_threshold 1.2 m/s; PF-BIN u ~ N(0, diag(0.01, 0.01)).
:func:`run_tracker` runs one of them by name ("wcl", "pfbin", "pfaa" with a threshold; SQLAM's
tracking module is "pfaa" with v_threshold = ∞).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rfsim.core.config import param

from rfsim.estimators.nearest import weighted_centroid
from rfsim.core.lazy import lazy_import

_particle = lazy_import("rfsim.estimators.particle")  # the SIR filter loads on first use


def binomial_log_likelihood(counts, p, n_rounds: int) -> np.ndarray:
    """Binomial log-likelihood of the landmark detections at every particle (Eq. 4.15 without the constant C(N, n)).

    ln p(y | x) = Σ_k [n_k log p_k + (N − n_k) log(1 − p_k)], p clipped to [1e−12, 1 − 1e−12].

    Parameters
    ----------
    counts : array_like
        ``(B, L)`` detections per landmark in the period.
    p : array_like
        ``(B, M, L)`` detection probabilities in (0, 1).
    n_rounds : int
        Rounds N per period.

    Returns
    -------
    numpy.ndarray
        ``(B, M)`` log-likelihood [nats].
    """
    n = np.asarray(counts, float)[:, None, :]
    p = np.clip(p, 1e-12, 1.0 - 1e-12)
    return np.sum(n * np.log(p) + (n_rounds - n) * np.log1p(-p), axis=-1)


def wcl_track(counts, landmarks_xy, start_xy) -> np.ndarray:
    """Weighted-centroid positions per period (Eq. 4.12).

    A period without detections keeps the previous estimate (``start_xy`` before the first
    detection).

    Parameters
    ----------
    counts : array_like
        ``(B, T, L)`` detections per landmark.
    landmarks_xy : array_like
        ``(L, 2)`` landmark positions [m].
    start_xy : array_like
        ``(2,)`` or ``(B, 2)`` estimate before the first detection [m].

    Returns
    -------
    numpy.ndarray
        ``(B, T, 2)`` positions [m].
    """
    est = weighted_centroid(np.asarray(counts, float), landmarks_xy)           # (B, T, 2), NaN if none
    out = np.empty_like(est)
    prev = np.broadcast_to(np.asarray(start_xy, float), est[:, 0].shape).copy()
    for t in range(est.shape[1]):
        ok = np.isfinite(est[:, t, 0])
        prev[ok] = est[:, t][ok]
        out[:, t] = prev
    return out


def pf_bin(counts, initial_state, *, n_particles: int, period_s: float, accel_var: float, n_rounds: int,
           probability: Callable, rng: np.random.Generator) -> np.ndarray:
    """PF-BIN MMSE positions (Eq. 4.9, module docstring).

    Parameters
    ----------
    counts : array_like
        ``(B, T, L)`` detections per landmark.
    initial_state : array_like
        ``(B, 4)`` the known [x1, x2, ẋ1, ẋ2] at the start [m, m, m/s, m/s].
    n_particles : int
        Particles M.
    period_s : float
        Query period T [s].
    accel_var : float
        Variance σ_u² of the velocity input per period [m²/s²].
    n_rounds : int
        Rounds N per period.
    probability : callable
        ``(positions (B, M, 2) [m], t) → p (B, M, L)`` (RTS model of every landmark).
    rng : numpy.random.Generator
        The filter's stream.

    Returns
    -------
    numpy.ndarray
        ``(B, T, 2)`` positions [m].
    """
    b = np.asarray(initial_state, float)
    particles = np.repeat(b[:, None, :], n_particles, axis=1)
    sd = np.sqrt(accel_var)
    T = period_s

    def propagate(p, t, rng):
        u = rng.standard_normal(p.shape[:-1] + (2,)) * sd
        out = p.copy()
        out[..., :2] += T * p[..., 2:] + T * u
        out[..., 2:] += u
        return out

    step = {"t": 0}

    def loglik(p, n):
        ll = binomial_log_likelihood(n, probability(p[..., :2], step["t"]), n_rounds)
        step["t"] += 1
        return ll

    res = _particle.sir_filter(counts, particles, propagate=propagate, log_likelihood=loglik, rng=rng,
                     resampler="multinomial")
    return res.mmse[..., :2]


def pf_aa(counts, landmarks_xy, *, n_particles: int, period_s: float, q_std_m: float, init_std_m: float,
          b0: float, b1: float, n_rounds: int, probability: Callable,
          rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """PF-AA without compensation (Algorithm 2, Eqs. 4.11–4.22).

    Step 0 is the initialisation (particles ~ N(x̂*_1, σ_1²), no propagation, v̂_1 = 0).

    Parameters
    ----------
    counts : array_like
        ``(B, T, L)`` detections per landmark.
    landmarks_xy : array_like
        ``(L, 2)`` landmark positions [m].
    n_particles : int
        Particles M.
    period_s : float
        Query period Δt [s].
    q_std_m : float
        AR noise std σ_q per period [m].
    init_std_m : float
        Initial spread σ_1 around the first WCL [m].
    b0, b1 : float
        Velocity AR weights (Eq. 4.14) [1].
    n_rounds : int
        Rounds N per period.
    probability : callable
        As in :func:`pf_bin`.
    rng : numpy.random.Generator
        The filter's stream.

    Returns
    -------
    x_hat : numpy.ndarray
        ``(B, T, 2)`` MMSE positions [m].
    v_hat : numpy.ndarray
        ``(B, T, 2)`` velocities (Eq. 4.22) [m/s].
    """
    n = np.asarray(counts, float)
    n_runs, n_steps, _ = n.shape
    wcl = weighted_centroid(n, landmarks_xy)                                      # (B, T, 2), NaN if none
    centre = np.mean(np.asarray(landmarks_xy, float), axis=0)   # no detection in period 1: the centre
    start = np.where(np.isfinite(wcl[:, 0]), wcl[:, 0], centre)
    particles = start[:, None, :] + init_std_m * rng.standard_normal((n_runs, n_particles, 2))
    x_hat = np.zeros((n_runs, n_steps, 2))
    v_hat = np.zeros((n_runs, n_steps, 2))
    state = {"t": 0}

    def propagate(p, t, rng):
        if t == 0:
            return p
        prev_x, prev_v = x_hat[:, t - 1], v_hat[:, t - 1]
        star = np.where(np.isfinite(wcl[:, t]), (wcl[:, t] - prev_x) / period_s, 0.0)   # Eq. 4.13
        v_in = b0 * star + b1 * prev_v                                                   # Eq. 4.14
        return p + (v_in * period_s)[:, None, :] + q_std_m * rng.standard_normal(p.shape)

    def loglik(p, y):
        t = state["t"]
        ll = binomial_log_likelihood(y, probability(p, t), n_rounds)
        w = np.exp(ll - ll.max(axis=1, keepdims=True))
        w /= w.sum(axis=1, keepdims=True)
        x_hat[:, t] = np.einsum("bm,bmd->bd", w, p)
        v_hat[:, t] = (x_hat[:, t] - x_hat[:, t - 1]) / period_s if t > 0 else 0.0      # Eq. 4.22
        state["t"] = t + 1
        return ll

    res = _particle.sir_filter(n, particles, propagate=propagate, log_likelihood=loglik, rng=rng, resampler="multinomial")
    return res.mmse, v_hat


def bias_compensate(x_hat, v_hat, *, period_end_s, mean_detection_s, b0: float, b1: float,
                    v_threshold_mps: float) -> np.ndarray:
    """Bias compensation of PF-AA (Eqs. 4.23–4.24).

    x̃_t = x̂_t + (b0 v̂_t + b1 v̂_{t−1})(t − t̂) where |v̂_t| ≥ v_threshold, else x̂_t.

    Parameters
    ----------
    x_hat, v_hat : array_like
        ``(B, T, 2)`` positions [m] and velocities [m/s].
    period_end_s : array_like
        ``(T,)`` period end times t [s].
    mean_detection_s : array_like
        ``(B, T)`` mean detection times t̂ [s] (NaN: no detection).
    b0, b1 : float
        Velocity AR weights [1].
    v_threshold_mps : float
        Speed above which the output is compensated [m/s].

    Returns
    -------
    numpy.ndarray
        ``(B, T, 2)`` compensated positions [m].
    """
    v_prev = np.concatenate([np.zeros_like(v_hat[:, :1]), v_hat[:, :-1]], axis=1)
    lag = np.asarray(period_end_s, float)[None, :] - np.asarray(mean_detection_s, float)
    on = (np.linalg.norm(v_hat, axis=-1) >= v_threshold_mps) & np.isfinite(lag)
    shift = (b0 * v_hat + b1 * v_prev) * np.where(on, lag, 0.0)[..., None]
    return x_hat + shift


@dataclass(frozen=True)
class LandmarkFilterConfig:
    """Parameters of PF-AA, SQLAM's tracking PF and PF-BIN (module docstring)."""

    particles: int = param(200, lo=1, hi=1_000_000, doc="particles M of PF-AA, SQLAM and PF-BIN (L4505)")
    q_std_m: float = param(0.3, lo=1e-6, hi=10.0, unit="m", doc="PF-AA / SQLAM AR noise std per period (L4503)")
    init_std_m: float = param(0.3, lo=1e-6, hi=10.0, unit="m", doc="PF-AA initial spread around the first WCL")
    b0: float = param(0.8, lo=0.0, hi=1.0, doc="velocity AR weight of the current WCL velocity (L5403)")
    b1: float = param(0.2, lo=0.0, hi=1.0, doc="velocity AR weight of the previous velocity (L5403)")
    v_threshold_mps: float = param(1.2, lo=0.0, hi=1000.0, unit="m/s", doc="bias compensation above (L4605)")
    pfbin_accel_var: float = param(0.01, lo=0.0, hi=100.0, unit="m2/s2",
                                   doc="PF-BIN velocity noise variance per period (L4614)")


def run_tracker(kind: str, counts, landmarks_xy, *, config: LandmarkFilterConfig, v_threshold_mps: float,
                period_s: float, n_rounds: int, probability: Callable, initial_state, period_end_s,
                mean_detection_s, rng: np.random.Generator) -> np.ndarray:
    """One tracker's estimates on the detections of B runs.

    Parameters
    ----------
    kind : {"wcl", "pfbin", "pfaa"}
        "wcl" (:func:`wcl_track` from the landmarks' centre), "pfbin" (:func:`pf_bin`) or
        "pfaa" (:func:`pf_aa`, then :func:`bias_compensate` per run unless
        ``v_threshold_mps`` is ∞).
    counts : array_like
        ``(B, T, L)`` detections.
    landmarks_xy : array_like
        ``(L, 2)`` landmark positions [m].
    config : LandmarkFilterConfig
        The filters' parameters (its own ``v_threshold_mps`` is not read: the argument is).
    v_threshold_mps : float
        Bias-compensation threshold [m/s] (∞: none).
    period_s : float
        Δt [s].
    n_rounds : int
        Rounds N per period.
    probability : callable
        As in :func:`pf_bin`.
    initial_state : array_like
        ``(B, 4)`` PF-BIN's known [x1, x2, ẋ1, ẋ2] [m, m, m/s, m/s].
    period_end_s, mean_detection_s : array_like
        ``(B, T)`` t and t̂ of every period [s] (NaN: no detection).
    rng : numpy.random.Generator
        The filter's stream (WCL draws nothing).

    Returns
    -------
    numpy.ndarray
        ``(B, T, 2)`` estimates [m].
    """
    f = config
    if kind == "wcl":
        return wcl_track(counts, landmarks_xy, np.mean(landmarks_xy, axis=0))
    if kind == "pfbin":
        return pf_bin(counts, initial_state, n_particles=f.particles, period_s=period_s, accel_var=f.pfbin_accel_var,
                      n_rounds=n_rounds, probability=probability, rng=rng)
    x, v = pf_aa(counts, landmarks_xy, n_particles=f.particles, period_s=period_s, q_std_m=f.q_std_m,
                 init_std_m=f.init_std_m, b0=f.b0, b1=f.b1, n_rounds=n_rounds, probability=probability, rng=rng)
    if not np.isfinite(v_threshold_mps):
        return x
    return np.concatenate([bias_compensate(x[i:i + 1], v[i:i + 1], period_end_s=period_end_s[i],
                                           mean_detection_s=mean_detection_s[i:i + 1], b0=f.b0, b1=f.b1,
                                           v_threshold_mps=v_threshold_mps) for i in range(x.shape[0])])


__all__ = [
    "LandmarkFilterConfig",
    "run_tracker",
    "binomial_log_likelihood",
    "wcl_track",
    "pf_bin",
    "pf_aa",
    "bias_compensate",
]

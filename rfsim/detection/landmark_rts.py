"""The RTS surrogate of a sense-a-tag (ST) listening to a reader's query rounds over landmark
tags on the floor (AURIS ch. 4; auris-sense-a-tag.md §3.3, §7; seeds/003 L4493-L4650,
L5600-L5641; coefficients L3854-L3873).

In each query period of T_s the reader runs N rounds; in round j the ST decodes landmark k
with the RTS probability (Eq. 4.6, :data:`rfsim.detection.models.RTS_COEFFICIENTS`)::

    p = 1/(1 + exp(a0 + a1·D_k + a2·d + a3·|θ_k| + a4·|φ_k|))

with D_k, θ_k, φ_k the active antenna → landmark geometry (antenna frame: boresight down;
θ = arcsin(Δy/D), φ = arcsin(Δx/D)) and d the ST → landmark distance at the round's time
τ_j = (t + (j + ½)/N)·T_s. The surrogate draws those detections as Bernoulli trials, so a still
ST sees n ~ Binomial(N, p_RTS) — what the source did (its PASS had no Q algorithm,
L469-L473); a moving ST sees the Poisson-binomial of its positions, which is the "false
synchronous detection" that PF-AA's bias compensation corrects
(:func:`rfsim.estimators.landmark_pf.bias_compensate`). With several antennas the one nearest
to the previous period's weighted-centroid estimate is active (the source: "nearest to the
current ST estimate", L5633-L5641; (0, 0) before the first detection).

The geometric part of the logit, a0 + a1·D + a3·|θ| + a4·|φ|, depends on the antenna and the
landmark only: :func:`rts_fixed_logit` computes it once per room, :func:`rts_landmark_probability`
adds the ST's a2·d.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rfsim.detection.models import RTS_COEFFICIENTS

#: Positions drawn at once per block of periods (single antenna), bounding the (T, N, L) arrays.
_BLOCK_PERIODS = 2000


def rts_fixed_logit(antennas_xyz_m, landmarks_xy) -> np.ndarray:
    """The fixed part a0 + a1·D + a3·|θ| + a4·|φ| of Eq. 4.6 for every antenna → landmark pair.

    Parameters
    ----------
    antennas_xyz_m : (A, 3) m, reader antennas facing down
    landmarks_xy : (L, 2) m, landmark tags on the floor (z = 0)

    Returns
    -------
    (A, L) float64; D = |landmark − antenna|, θ = arcsin(Δy/D), φ = arcsin(Δx/D).
    """
    a = RTS_COEFFICIENTS
    landmarks = np.asarray(landmarks_xy, float)
    ant = np.asarray(antennas_xyz_m, float)
    v = np.concatenate([landmarks, np.zeros((landmarks.shape[0], 1))], axis=1)[None] - ant[:, None, :]
    D = np.linalg.norm(v, axis=-1)
    theta, phi = np.arcsin(v[..., 1] / D), np.arcsin(v[..., 0] / D)
    return a[0] + a[1] * D + a[3] * np.abs(theta) + a[4] * np.abs(phi)


def rts_landmark_probability(fixed_logit, distance_st_m) -> np.ndarray:
    """Eq. 4.6, p = 1/(1 + exp(fixed + a2·d)), from the fixed part and the ST → landmark distance.

    Parameters
    ----------
    fixed_logit : array_like
        a0 + a1·D + a3·|θ| + a4·|φ| (:func:`rts_fixed_logit`) [1].
    distance_st_m : array_like
        ST → landmark distance d [m] (broadcast).

    Returns
    -------
    numpy.ndarray
        Detection probabilities [1].
    """
    return 1.0 / (1.0 + np.exp(fixed_logit + RTS_COEFFICIENTS[2] * distance_st_m))


def draw_landmark_detections(fixed_logit, landmarks_xy, antennas_xyz_m, positions_m, *, period_s: float,
                             rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Bernoulli RTS detections of one track (module docstring).

    Parameters
    ----------
    fixed_logit : numpy.ndarray
        ``(A, L)`` from :func:`rts_fixed_logit`.
    landmarks_xy : numpy.ndarray
        ``(L, 2)`` landmark positions [m].
    antennas_xyz_m : array_like
        ``(A, 3)`` antenna positions [m].
    positions_m : numpy.ndarray
        ``(T, N, 2)`` the ST at the round times τ_j of each of the T periods [m].
    period_s : float
        T_s [s].
    rng : numpy.random.Generator
        The uniforms, (T, N, L) in one draw with several antennas, in blocks of periods with one.

    Returns
    -------
    dict of str to numpy.ndarray
        ``counts`` (T, L) int64 detections n_{t,k}; ``mean_detection_s`` (T,) mean τ of the
        period's detections t̂ [s] (Eq. 4.23; NaN: none); ``active`` (T,) int64 active antenna.
    """
    T, N, _ = positions_m.shape
    base = fixed_logit
    tau = (np.arange(T)[:, None] + (np.arange(N)[None, :] + 0.5) / N) * period_s
    ant = np.asarray(antennas_xyz_m, float)[:, :2]
    active = np.zeros(T, dtype=np.int64)
    counts = np.zeros((T, landmarks_xy.shape[0]), dtype=np.int64)
    tsum = np.zeros(T)
    if ant.shape[0] == 1:
        for a in range(0, T, _BLOCK_PERIODS):
            b = a + _BLOCK_PERIODS
            d = np.linalg.norm(positions_m[a:b, :, None, :] - landmarks_xy, axis=-1)
            det = rng.random(d.shape) < rts_landmark_probability(base[0], d)
            counts[a:b] = det.sum(axis=1)
            tsum[a:b] = np.einsum("tnl,tn->t", det, tau[a:b])
    else:
        est = np.zeros(2)
        u = rng.random((T, N, landmarks_xy.shape[0]))
        for t in range(T):
            active[t] = int(np.argmin(np.linalg.norm(ant - est, axis=1)))
            d = np.linalg.norm(positions_m[t, :, None, :] - landmarks_xy, axis=-1)
            det = u[t] < rts_landmark_probability(base[active[t]], d)
            counts[t] = det.sum(axis=0)
            tsum[t] = det.sum(axis=1) @ tau[t]
            if counts[t].sum() > 0:
                est = counts[t] @ landmarks_xy / counts[t].sum()
    total = counts.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_t = np.where(total > 0, tsum / total, np.nan)
    return {"counts": counts, "mean_detection_s": mean_t, "active": active}


def rts_likelihood_model(fixed_logit, active, landmarks_xy) -> Callable:
    """The RTS detection probabilities as the particle filters' model.

    The ``probability`` of :func:`rfsim.estimators.landmark_pf.pf_aa`.

    Parameters
    ----------
    fixed_logit : numpy.ndarray
        ``(A, L)`` from :func:`rts_fixed_logit`.
    active : numpy.ndarray
        ``(B, T)`` active antenna per run and period.
    landmarks_xy : numpy.ndarray
        ``(L, 2)`` landmark positions [m].

    Returns
    -------
    callable
        ``(positions (B, M, 2) [m], t) → p (B, M, L)``.
    """
    def probability(p, t):
        d = np.linalg.norm(p[:, :, None, :] - landmarks_xy, axis=-1)
        return rts_landmark_probability(fixed_logit[active[:, t]][:, None, :], d)

    return probability


__all__ = ["rts_fixed_logit", "rts_landmark_probability", "draw_landmark_detections", "rts_likelihood_model"]

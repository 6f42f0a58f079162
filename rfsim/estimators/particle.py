"""Sequential importance resampling (SIR) particle filter, batched over trials.

Özkaya (rssi-localization.md §1.6; seeds/002 L600–L793) after Arulampalam et al. (IEEE TSP
50(2), 2002). The posterior is a weighted particle set (eq. 4.16–4.17)::

    p(L_t | s_{1..t}) ≈ Σ_j w_t^j δ(L_t − L_t^j)

With the prior as proposal, ``q = p(L_t | L_{t−1}^j)`` (eq. 4.33–4.34), the weights update as
``w_t^j ∝ w_{t−1}^j p(s_t | L_t^j)``; the basic SIR filter (Table 4.4) resamples at every step,
so ``w_t^j ∝ p(s_t | L_t^j)`` (eq. 4.37). The "improved SIR" of the thesis (L1085–L1087,
L1639–L1642) resamples only when the effective sample size (eq. 4.28)

    N_eff = 1 / Σ_j (w_t^j)²

falls below ``N_t = threshold·N`` (the printed N_t = 0.5 is a fraction of N, erratum R§5.5) and
selects with the smoothed weights ``a^j ∝ √w^j``, the survivors keeping ``w^j / a^j``
(L782–L787, "modified resampling").

Estimates: MMSE = Σ_j w^j L^j (eq. 4.8); MAP = the particle of largest weight after the update
(eq. 4.9 on the particle support).

Resampling: systematic (Table 4.2, L706–L726, with the inclusive CDF c_j = Σ_{k≤j} w^k, erratum
R§5.6: one u₁ ~ U[0, 1/N), u_i = u₁ + (i − 1)/N, particle j is taken for every u_i in
(c_{j−1}, c_j]) or multinomial (N independent draws from the weights).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal, NamedTuple

import numpy as np


def effective_sample_size(weights) -> np.ndarray:
    """Effective sample size ``N_eff = 1/Σ w²`` of normalised weights (eq. 4.28).

    Parameters
    ----------
    weights : array_like
        ``(..., N)`` normalised weights [1].

    Returns
    -------
    numpy.ndarray
        ``(...)`` N_eff [particles].
    """
    w = np.asarray(weights, float)
    return 1.0 / np.sum(w * w, axis=-1)


def _normalise(weights) -> np.ndarray:
    w = np.asarray(weights, float)
    total = w.sum(axis=-1, keepdims=True)
    if np.any(~(total > 0)):
        raise ValueError("every weight vector needs a positive finite sum")
    return w / total


def _indices_from_counts(counts: np.ndarray) -> np.ndarray:
    """Ancestor indices (..., N) from copy counts (..., N) that sum to N per row."""
    n = counts.shape[-1]
    flat = counts.reshape(-1, n)
    source = np.broadcast_to(np.arange(n), flat.shape)
    return np.repeat(source.ravel(), flat.ravel()).reshape(counts.shape)


def systematic_indices(weights, u1) -> np.ndarray:
    """Systematic-resampling ancestors of ``weights`` for given offsets ``u1``.

    Particle j is copied once for every ``u_i = u1 + i/N`` (i = 0..N−1) with
    ``c_{j−1} < u_i ≤ c_j`` (inclusive CDF, Table 4.2 with erratum R§5.6), i.e.
    ``ceil(N c_j − N u1) − ceil(N c_{j−1} − N u1)`` times; the result is sorted (ancestors in
    increasing order), as Table 4.2's loop produces.

    Parameters
    ----------
    weights : array_like
        ``(..., N)`` non-negative weights (normalised here).
    u1 : array_like
        ``(...)`` offsets in [0, 1/N).

    Returns
    -------
    numpy.ndarray
        ``(..., N) int`` ancestor indices.

    Raises
    ------
    ValueError
        If a weight vector does not have a positive finite sum.
    """
    w = _normalise(weights)
    n = w.shape[-1]
    c = np.cumsum(w, axis=-1)
    c[..., -1] = 1.0
    s = n * np.asarray(u1, float)[..., None]
    edges = np.ceil(n * c - s)
    edges = np.clip(edges, 0, n)
    counts = np.diff(edges, axis=-1, prepend=0.0).astype(np.int64)
    return _indices_from_counts(counts)


def systematic_resample(weights, *, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling (Table 4.2): one uniform offset per weight vector.

    Parameters
    ----------
    weights : array_like
        ``(..., N)`` non-negative weights.
    rng : numpy.random.Generator
        Source of the offsets u1 ~ U[0, 1/N).

    Returns
    -------
    numpy.ndarray
        ``(..., N) int`` sorted ancestor indices.
    """
    w = np.asarray(weights, float)
    n = w.shape[-1]
    u1 = rng.uniform(0.0, 1.0 / n, size=w.shape[:-1])
    return systematic_indices(w, u1)


def multinomial_resample(weights, *, rng: np.random.Generator) -> np.ndarray:
    """Multinomial resampling: N i.i.d. draws from the weights.

    Parameters
    ----------
    weights : array_like
        ``(..., N)`` non-negative weights (normalised here).
    rng : numpy.random.Generator
        Source of the draws.

    Returns
    -------
    numpy.ndarray
        ``(..., N) int`` sorted ancestor indices.

    Raises
    ------
    ValueError
        If a weight vector does not have a positive finite sum.
    """
    w = _normalise(weights)
    n = w.shape[-1]
    counts = rng.multinomial(n, w.reshape(-1, n)).reshape(w.shape)
    return _indices_from_counts(counts)


_RESAMPLERS = {"systematic": systematic_resample, "multinomial": multinomial_resample}


class ParticleFilterResult(NamedTuple):
    """Per-step outputs of :func:`sir_filter`.

    mmse, map : (B, T, d) estimates;  ess : (B, T) N_eff after each update;
    resampled : (B, T) bool, whether the trial resampled at that step
    """

    mmse: np.ndarray
    map: np.ndarray
    ess: np.ndarray
    resampled: np.ndarray


def sir_filter(observations, initial_particles, *, propagate: Callable, log_likelihood: Callable,
               rng: np.random.Generator, resampler: Literal["systematic", "multinomial"] = "systematic",
               threshold: float = 1.0, sqrt_weights: bool = False) -> ParticleFilterResult:
    """Run a SIR particle filter for B independent trials at once.

    Step t: ``particles = propagate(particles, t, rng)`` (draw from the prior proposal),
    ``w ∝ w · exp(log_likelihood(particles, observations[:, t]))``, read out MMSE/MAP, then
    resample the trials with ``N_eff < threshold·N`` (``threshold = 1`` always resamples,
    Table 4.4; ``0.5`` is the thesis's improved SIR). With ``sqrt_weights`` the selection uses
    ``a ∝ √w`` and survivors keep ``w/a`` (normalised).

    Parameters
    ----------
    observations : (B, T, ...) per-trial measurement sequence (passed through per step)
    initial_particles : (B, N, d) draws from p(L_0), uniform weights
    propagate : callable ``(particles (B, N, d), t, rng) → (B, N, d)``
    log_likelihood : callable ``(particles (B, N, d), z_t (B, ...)) → (B, N)``
    rng : generator for propagation noise and resampling (keyword-only)
    resampler : ``"systematic"`` or ``"multinomial"``
    threshold : resample when N_eff < threshold·N, in (0, 1]
    sqrt_weights : select with √w (the thesis's "w smoothing")

    Returns
    -------
    :class:`ParticleFilterResult`
    """
    if resampler not in _RESAMPLERS:
        raise ValueError(f"resampler must be one of {sorted(_RESAMPLERS)}, got {resampler!r}")
    if not 0.0 < threshold <= 1.0:
        raise ValueError(f"threshold must be in (0, 1], got {threshold!r}")
    resample = _RESAMPLERS[resampler]
    obs = np.asarray(observations)
    particles = np.array(initial_particles, dtype=float)
    n_trials, n_particles, dim = particles.shape
    n_steps = obs.shape[1]
    weights = np.full((n_trials, n_particles), 1.0 / n_particles)
    mmse = np.empty((n_trials, n_steps, dim))
    map_est = np.empty_like(mmse)
    ess = np.empty((n_trials, n_steps))
    resampled = np.zeros((n_trials, n_steps), dtype=bool)
    rows = np.arange(n_trials)[:, None]
    for t in range(n_steps):
        particles = propagate(particles, t, rng)
        loglik = np.asarray(log_likelihood(particles, obs[:, t]), float)
        logw = np.log(weights) + loglik
        logw -= logw.max(axis=1, keepdims=True)
        weights = _normalise(np.exp(logw))
        mmse[:, t] = np.einsum("bn,bnd->bd", weights, particles)
        map_est[:, t] = particles[np.arange(n_trials), np.argmax(weights, axis=1)]
        ess[:, t] = effective_sample_size(weights)
        due = ess[:, t] < threshold * n_particles if threshold < 1.0 else np.ones(n_trials, bool)
        if due.any():
            w_due = weights[due]
            select = _normalise(np.sqrt(w_due)) if sqrt_weights else w_due
            idx = resample(select, rng=rng)
            sub = rows[due]
            particles[due] = particles[sub, idx]
            new_w = w_due[np.arange(idx.shape[0])[:, None], idx] / select[np.arange(idx.shape[0])[:, None], idx]
            weights[due] = _normalise(new_w)
            resampled[due, t] = True
    return ParticleFilterResult(mmse, map_est, ess, resampled)


__all__ = [
    "effective_sample_size",
    "systematic_indices",
    "systematic_resample",
    "multinomial_resample",
    "ParticleFilterResult",
    "sir_filter",
]

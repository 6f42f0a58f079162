"""Grid-based Bayesian filter (Markov localization) with a Gaussian RSS likelihood.

Özkaya, rssi-localization.md §1.5 (seeds/002 L564–L598, L1317). The area is sliced into M cells
l (centres ``cells_m``); the belief is propagated and updated recursively (eq. 4.12, 4.15)::

    P(L_t = l | s_{1..t−1}) = Σ_{l'} P(l | l') Bel(L_{t−1} = l')
    Bel(L_t = l) = β · P(s_t | l) · P(L_t = l | s_{1..t−1})

Transition (L1317): a Gaussian displacement of standard deviation D,
``P(l | l') ∝ exp(−|l − l'|²/(2D²))`` normalised over l; ``D = ∞`` is the uniform transition
(no motion prior, L1451). Likelihood: independent Gaussian readers (eq. 5.13 / corrected 5.11)::

    ln P(s | l) = Σ_j [ −(s_j − μ_j(l))²/(2σ_j²) − ln(√(2π) σ_j) ]

with readers whose value is NaN (not heard) left out. Estimates: MMSE = Σ_l Bel(l)·l (eq. 4.8)
and MAP = argmax_l Bel(l) (eq. 4.9).
"""

from __future__ import annotations

import numpy as np


def gaussian_log_likelihood(z, mean, sigma) -> np.ndarray:
    """``Σ_j ln N(z_j; mean_j, σ_j²)`` over the last axis, NaN entries of ``z`` skipped.

    Parameters
    ----------
    z : (..., R) observations (broadcast against ``mean``), NaN = missing
    mean : (..., R) model means (e.g. (B, M, R) per cell)
    sigma : scalar or (..., R) standard deviations (> 0)

    Returns
    -------
    (...) float64 log-likelihood
    """
    z = np.asarray(z, float)
    mean = np.asarray(mean, float)
    sigma = np.asarray(sigma, float)
    r = (z - mean) / sigma
    terms = -0.5 * r * r - np.log(np.sqrt(2.0 * np.pi) * sigma)
    return np.where(np.isnan(terms), 0.0, terms).sum(axis=-1)


def gaussian_transition(cells_m, step_std_m: float) -> np.ndarray:
    """Row-stochastic transition ``T[l', l] = P(l | l')`` of a Gaussian displacement.

    Parameters
    ----------
    cells_m : (M, d) cell centres [m]
    step_std_m : D [m] (> 0, ``inf`` = uniform transition)

    Returns
    -------
    (M, M) float64, rows sum to 1
    """
    cells = np.asarray(cells_m, float)
    m = cells.shape[0]
    if not step_std_m > 0:
        raise ValueError(f"step_std_m must be > 0, got {step_std_m!r}")
    if np.isinf(step_std_m):
        return np.full((m, m), 1.0 / m)
    d2 = np.sum((cells[:, None, :] - cells[None, :, :]) ** 2, axis=-1)
    k = np.exp(-d2 / (2.0 * step_std_m ** 2))
    return k / k.sum(axis=1, keepdims=True)


def grid_bayes_filter(log_likelihood, transition=None, prior=None) -> np.ndarray:
    """Beliefs ``Bel_t`` of the grid filter for B trials over T steps.

    Step t: predict ``Bel⁻ = Bel_{t−1} @ T`` (skipped when ``transition`` is None: a static
    target, the identity), update ``Bel ∝ Bel⁻ · exp(log_likelihood[:, t])``. ``Bel_0`` before
    the first prediction is ``prior`` (default uniform).

    Parameters
    ----------
    log_likelihood : (B, T, M) ln P(s_t | l)
    transition : (M, M) row-stochastic ``P(l | l')`` or None
    prior : (M,) or (B, M), default uniform

    Returns
    -------
    (B, T, M) normalised beliefs
    """
    ll = np.asarray(log_likelihood, float)
    n_trials, n_steps, m = ll.shape
    bel = np.broadcast_to(np.full(m, 1.0 / m) if prior is None else np.asarray(prior, float),
                          (n_trials, m)).copy()
    out = np.empty_like(ll)
    for t in range(n_steps):
        if transition is not None:
            bel = bel @ transition
        lt = ll[:, t] - ll[:, t].max(axis=1, keepdims=True)
        bel = bel * np.exp(lt)
        bel /= bel.sum(axis=1, keepdims=True)
        out[:, t] = bel
    return out


def grid_estimates(beliefs, cells_m) -> tuple[np.ndarray, np.ndarray]:
    """MMSE (eq. 4.8) and MAP (eq. 4.9) positions of grid beliefs.

    x̂_MMSE = Σ_m b_m·c_m; x̂_MAP = c_argmax(b).

    Parameters
    ----------
    beliefs : array_like
        ``(..., M)`` probabilities over the M cells [1].
    cells_m : array_like
        ``(M, d)`` cell positions [m].

    Returns
    -------
    mmse, map : numpy.ndarray
        ``(..., d)`` positions [m].
    """
    bel = np.asarray(beliefs, float)
    cells = np.asarray(cells_m, float)
    return bel @ cells, cells[np.argmax(bel, axis=-1)]


__all__ = [
    "gaussian_log_likelihood",
    "gaussian_transition",
    "grid_bayes_filter",
    "grid_estimates",
]

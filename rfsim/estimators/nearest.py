"""Nearest-neighbour (kNN / LANDMARC) and weighted-centroid locators.

**NN / LANDMARC** (Özkaya, rssi-localization.md §1.2, seeds/002 L443–L485; Ni et al., LANDMARC,
Wireless Networks 10, 2004). With reference signatures ``R_j`` (one RSS vector per cell or
reference tag j, from a model map, eq. 3.14/6.4, or from measurements) and the target's vector
``R_t``::

    E_j = √(Σ_i (R_ij − R_ti)²)                                   (3.1)
    (x̂, ŷ) = Σ_{j ∈ k nearest} w_j (x_j, y_j)                     (3.2)
    w_j = (1/E_j²) / Σ_{l ∈ k nearest} (1/E_l²)                  (3.3, LANDMARC-normalised)

The printed (3.3) divides by Σ E_l², which does not normalise (erratum R§5.1); the LANDMARC
form is used. Signatures matched exactly (E_j = 0) share the weight equally.

**Weighted centroid** (WCL; Blumenthal et al., 2007; AURIS PF-AA/SQLAM comparisons,
auris-sense-a-tag.md ch. 4): ``x̂ = Σ_l w_l x_l / Σ_l w_l`` over landmarks l with weights w_l ≥ 0
(e.g. detection counts); a trial with no positive weight gives NaN.
"""

from __future__ import annotations

import numpy as np


def landmarc(rss, reference_rss, reference_xy, k: int) -> np.ndarray:
    """LANDMARC / kNN position estimates.

    Parameters
    ----------
    rss : (..., R) target RSS vectors [dB or dBm]
    reference_rss : (M, R) or (..., M, R) reference signatures (same units)
    reference_xy : (M, d) reference positions [m]
    k : number of nearest references averaged, 1 ≤ k ≤ M

    Returns
    -------
    (..., d) float64 estimated positions [m]
    """
    z = np.asarray(rss, float)
    ref = np.asarray(reference_rss, float)
    xy = np.asarray(reference_xy, float)
    m = ref.shape[-2]
    if not 1 <= int(k) <= m:
        raise ValueError(f"k must be in [1, {m}] (the number of references), got {k!r}")
    k = int(k)
    e2 = np.sum((ref - z[..., None, :]) ** 2, axis=-1)              # (..., M)
    nearest = np.argpartition(e2, k - 1, axis=-1)[..., :k] if k < m else np.broadcast_to(
        np.arange(m), e2.shape)
    e2k = np.take_along_axis(e2, nearest, axis=-1)
    exact = e2k == 0.0
    with np.errstate(divide="ignore"):
        w = np.where(exact.any(axis=-1, keepdims=True), exact.astype(float), 1.0 / e2k)
    w /= w.sum(axis=-1, keepdims=True)
    return np.einsum("...k,...kd->...d", w, xy[nearest])


def weighted_centroid(weights, positions_m) -> np.ndarray:
    """Weighted centroid ``Σ w_l x_l / Σ w_l``.

    Parameters
    ----------
    weights : (..., L) non-negative weights
    positions_m : (L, d) landmark positions [m]

    Returns
    -------
    (..., d) float64; NaN where all weights are zero
    """
    w = np.asarray(weights, float)
    if np.any(w < 0):
        raise ValueError("weights must be non-negative")
    pos = np.asarray(positions_m, float)
    total = w.sum(axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (w @ pos) / total, np.nan)


__all__ = [
    "landmarc",
    "weighted_centroid",
]

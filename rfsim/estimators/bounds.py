"""Cramér–Rao lower bound of RSS localization under the log-distance model.

Özkaya Appendix A (rssi-localization.md §1.11, seeds/002 L2225–L2284), corrected. With readers
j at ``p_j``, mean RSS ``μ_j(l) = α_j − 10·n_j·log10(d_j)``, ``d_j = |p_j − l|`` and independent
Gaussian shadowing σ_j (eq. A.6–A.8), the Fisher information of the position l is::

    F(l) = Σ_j (10·n_j / (σ_j·ln 10))² · u_j u_jᵀ / d_j²,    u_j = (l − p_j)/d_j

(∂μ_j/∂l = −10·n_j/ln 10 · (l − p_j)/d_j²). The printed (A.10)–(A.12) lack the 1/d_j² factor
(erratum a) and (A.3)/(A.4) swap numerators (erratum b); the position bound
``var(x̂) + var(ŷ) ≥ tr F⁻¹`` (A.5) is unaffected by (b). ``form="printed"`` evaluates the
range-free printed Fisher matrix, for comparison with the thesis's numbers (which are
proportional to σ, 0.154 m/dB).
"""

from __future__ import annotations

from typing import Literal

import numpy as np


def log_distance_crlb(points_m, readers_m, exponent, sigma_db, *,
                      form: Literal["corrected", "printed"] = "corrected") -> np.ndarray:
    """Position CRLB ``√(tr F⁻¹)`` [m] at ``points_m``.

    Parameters
    ----------
    points_m : (..., 2) positions [m]
    readers_m : (J, 2) reader positions [m]
    exponent : scalar or (J,) path-loss exponents n_j
    sigma_db : scalar or (J,) shadowing standard deviations σ_j [dB]
    form : ``"corrected"`` (with 1/d_j²) or ``"printed"`` (A.10–A.12 as printed)

    Returns
    -------
    (...) float64 [m]; ``inf`` where F is singular (e.g. on a reader)
    """
    l = np.asarray(points_m, float)[..., None, :]
    p = np.asarray(readers_m, float)
    diff = l - p                                                    # (..., J, 2)
    d2 = np.sum(diff * diff, axis=-1)
    c = (10.0 * np.asarray(exponent, float) / (np.asarray(sigma_db, float) * np.log(10.0))) ** 2
    denom = d2 * d2 if form == "corrected" else d2
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.broadcast_to(c, d2.shape) / denom
        fxx = np.sum(w * diff[..., 0] ** 2, axis=-1)
        fyy = np.sum(w * diff[..., 1] ** 2, axis=-1)
        fxy = np.sum(w * diff[..., 0] * diff[..., 1], axis=-1)
        det = fxx * fyy - fxy ** 2
        out = np.sqrt((fxx + fyy) / det)
    return np.where(np.isfinite(out) & (det > 0), out, np.inf)


__all__ = [
    "log_distance_crlb",
]

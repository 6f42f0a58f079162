"""Online calibration of the log-distance parameters (α_j, n_j) and σ from reference tags.

Özkaya, rssi-localization.md §1.8 (seeds/002 L1024–L1055, L1097–L1103). With reference tags i
at known distances d_ij from reader j and walls costing ``L_ij = nW_ij·WAF`` (WAF fixed a
priori), each reader's α_j, n_j minimise (eq. 6.5–6.6)::

    F_j(α, n) = Σ_i (RSSI_ij − RSSI'_ij)²,   RSSI'_ij = α − 10·n·log10(d_ij) − L_ij

over the grid α ∈ [−55, −40] dBm, n ∈ [1.5, 3] (L1040; the step sizes are not given: 0.1 dB
and 0.01 by default here), recomputed at every observation step. The filter's σ is one pooled
value over all tag–reader pairs (eq. 6.7)::

    σ = √( (1/(I·J)) Σ_j Σ_i (RSSI_ij − RSSI'_ij)² )

Exact grid search at O(|n grid|) per reader: for fixed n, F_j is the parabola
``I·(α − ȳ_n)² + const`` with ``ȳ_n = mean_i(RSSI_ij + L_ij + 10·n·log10 d_ij)``, so the best grid
α is the grid value nearest ȳ_n; the best n is then the arg-min over the n grid. This equals
the brute-force search over the full (α, n) grid (tested). NaN readings (below the reader's
floor) are left out of the sums.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: Default search grids (L1040 gives the ranges; the steps are this implementation's choice).
ALPHA_GRID_DBM = np.round(np.arange(-55.0, -40.0 + 1e-9, 0.1), 10)
EXPONENT_GRID = np.round(np.arange(1.5, 3.0 + 1e-9, 0.01), 10)


class Calibration(NamedTuple):
    """Calibrated parameters: alpha_dbm (..., J), exponent (..., J), sigma_db (...) pooled."""

    alpha_dbm: np.ndarray
    exponent: np.ndarray
    sigma_db: np.ndarray


def _nearest_on_grid(values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    i = np.clip(np.searchsorted(grid, values), 1, grid.size - 1)
    lower, upper = grid[i - 1], grid[i]
    return np.where(values - lower <= upper - values, lower, upper)


def calibrate_log_distance(rss_dbm, log10_distance, wall_loss_db=0.0, *,
                           alpha_grid_dbm=ALPHA_GRID_DBM, exponent_grid=EXPONENT_GRID) -> Calibration:
    """Grid-search α_j, n_j per reader and the pooled σ (eq. 6.5–6.7).

    Parameters
    ----------
    rss_dbm : (..., J, I) reference-tag RSS at reader j from tag i [dBm], NaN = not heard
    log10_distance : (J, I) or broadcastable, log10 of d_ij / 1 m
    wall_loss_db : (J, I) or scalar, nW_ij·WAF [dB]
    alpha_grid_dbm, exponent_grid : ascending 1-D search grids

    Returns
    -------
    :class:`Calibration`
    """
    s = np.asarray(rss_dbm, float)
    g = np.broadcast_to(np.asarray(log10_distance, float), s.shape)
    wl = np.broadcast_to(np.asarray(wall_loss_db, float), s.shape)
    ag = np.sort(np.asarray(alpha_grid_dbm, float))
    ng = np.asarray(exponent_grid, float)
    valid = ~np.isnan(s)
    count = valid.sum(axis=-1)                                      # (..., J)
    if np.any(count == 0):
        raise ValueError("every reader needs at least one reference-tag reading")
    y0 = np.where(valid, s + wl, 0.0)[..., None, :]                # (..., J, 1, I)
    gg = np.where(valid, g, 0.0)[..., None, :]
    y = y0 + 10.0 * ng[:, None] * gg                               # (..., J, Nn, I)
    mask = valid[..., None, :]
    ybar = y.sum(axis=-1) / count[..., None]                        # (..., J, Nn)
    alpha = _nearest_on_grid(ybar, ag)
    sse = np.sum(np.where(mask, (y - alpha[..., None]) ** 2, 0.0), axis=-1)
    best = np.argmin(sse, axis=-1)                                  # (..., J)
    alpha_best = np.take_along_axis(alpha, best[..., None], axis=-1)[..., 0]
    sse_best = np.take_along_axis(sse, best[..., None], axis=-1)[..., 0]
    sigma = np.sqrt(sse_best.sum(axis=-1) / count.sum(axis=-1))
    return Calibration(alpha_best, ng[best], sigma)


def fit_log_distance(rss_dbm, distance_m, wall_loss_db=0.0) -> Calibration:
    """Offline least-squares fit of one reader's α, n and σ (Sec. 6.1, L993–L1000).

    ``RSSI + L = α − 10·n·log10(d)`` solved by linear least squares over all samples; σ is the
    root mean square residual (the thesis averages per-distance standard deviations, L998; the
    two agree when the model fits).

    Parameters
    ----------
    rss_dbm, distance_m, wall_loss_db : (K,) samples (broadcast)

    Returns
    -------
    :class:`Calibration` with scalar fields
    """
    s, d, wl = np.broadcast_arrays(np.asarray(rss_dbm, float), np.asarray(distance_m, float),
                                   np.asarray(wall_loss_db, float))
    ok = ~np.isnan(s)
    a = np.column_stack([np.ones(ok.sum()), -10.0 * np.log10(d[ok])])
    coef, *_ = np.linalg.lstsq(a, s[ok] + wl[ok], rcond=None)
    resid = s[ok] + wl[ok] - a @ coef
    return Calibration(np.float64(coef[0]), np.float64(coef[1]), np.sqrt(np.mean(resid ** 2)))


__all__ = [
    "ALPHA_GRID_DBM",
    "EXPONENT_GRID",
    "Calibration",
    "calibrate_log_distance",
    "fit_log_distance",
]

"""The RSS localization estimators of Özkaya's active-RFID study, on a floor plan's cells
(rssi-localization.md §1.2–1.9, §2.4; seeds/002 L443–L485, L1105–L1109, Tables 7.3–7.42): LANDMARC
kNN on the model map, grid Bayes (MMSE and MAP), the SIR particle filter (MMSE and MAP), and the
home replica's online reference-tag calibration with RSSI smoothing.

Likelihood of a beacon epoch: independent Gaussian readers around the model map
μ_j(l) = α_j − 10·n_j·log10 d_j(l) − nW_j(l)·WAF (eq. 5.11 corrected, 6.4); readers that did not
hear the beacon (below the floor, NaN) are left out. kNN replaces an unheard reading by the floor
value. The particle filter's Gaussian proposal is reflected at the walls of the area (the filter
knows the room, "up to walls", Table 7.22).

The channel argument is any object with the methods of ``rfsim.channels.rss.RssChannel``
(``mean_rss_dbm``, ``distance_m``, ``wall_loss_db``, ``n_readers``, ``alpha_dbm``, ``exponent``,
``d0_m``); the plan any object with ``cells_xy`` (M, 2), ``bounds`` (xmin, ymin, xmax, ymax)
[m] and ``tag_height_m``.
"""

from __future__ import annotations

import numpy as np

from rfsim.estimators.calibration import Calibration, calibrate_log_distance
from rfsim.estimators.grid_bayes import gaussian_log_likelihood, gaussian_transition, grid_bayes_filter, grid_estimates
from rfsim.estimators.nearest import landmarc
from rfsim.estimators.particle import sir_filter

#: Filter σ used when the simulated σ0 is 0 (the zero-noise runs of Fig. 7.7 keep σ = 5.2) [dB].
DEFAULT_FILTER_SIGMA_DB = 5.2
#: Lower bound on the pooled online σ (eq. 6.7 with 4 tags can come out near 0) [dB].
MIN_ONLINE_SIGMA_DB = 1.0
#: RSSI-smoothing threshold on a reference tag's LANDMARC weight (§1.9, L1107).
SMOOTHING_WEIGHT = 0.4


def _xyz(xy, z):
    xy = np.asarray(xy, float)
    return np.concatenate([xy, np.full(xy.shape[:-1] + (1,), z)], axis=-1)


def reflect_into(p: np.ndarray, bounds) -> np.ndarray:
    """Mirror positions into a rectangle.

    Parameters
    ----------
    p : (..., 2) positions [m]
    bounds : (xmin, ymin, xmax, ymax) [m]

    Returns
    -------
    (..., 2) positions mirrored at the lower edges (x < xmin → 2·xmin − x), then at the upper
    edges (x > xmax → 2·xmax − x), then clipped into the rectangle (a step longer than the room).
    """
    lo = np.array(bounds[:2], float)
    hi = np.array(bounds[2:], float)
    p = np.where(p < lo, 2 * lo - p, p)
    p = np.where(p > hi, 2 * hi - p, p)
    return np.clip(p, lo, hi)


def _fill_floor(z: np.ndarray, floor_dbm: float) -> np.ndarray:
    return np.where(np.isnan(z), floor_dbm, z)


def _pad(est: np.ndarray, n_steps: int) -> np.ndarray:
    if est.shape[1] == n_steps:
        return est
    out = np.full((est.shape[0], n_steps, est.shape[2]), np.nan)
    out[:, :est.shape[1]] = est
    return out


def rss_sir(channel, plan, z_aug, n_particles: int, step_std_m: float, *, rng: np.random.Generator,
            velocity_xy=(0.0, 0.0), threshold: float = 1.0, sqrt_weights: bool = False):
    """SIR particle filter on RSS vectors with per-epoch model parameters.

    Parameters
    ----------
    channel, plan : module docstring
    z_aug : (B, T, 3J + 1) or (B, T, 4J) per trial and epoch [z | α | n | σ]: the reported RSS
        of the J readers [dBm] (NaN: not heard), the map's α_j [dBm] and n_j, and σ [dB], one
        value or one per reader (:func:`augment` repeats it per reader)
    n_particles : N, drawn uniformly over ``plan.bounds`` at the first epoch
    step_std_m : D, std of the Gaussian random-walk proposal per epoch [m], reflected at the
        walls (:func:`reflect_into`)
    rng : the filter's stream (initial particles, proposal, resampling)
    velocity_xy : known displacement per epoch [m] added to the proposal (improved SIR)
    threshold, sqrt_weights : resampling rule of :func:`rfsim.estimators.particle.sir_filter`

    Returns
    -------
    :class:`rfsim.estimators.particle.ParticleFilterResult` (``mmse``, ``map`` (B, T, 2) [m])
    """
    n_read = channel.n_readers
    b = z_aug.shape[0]
    xmin, ymin, xmax, ymax = plan.bounds
    init = rng.uniform((xmin, ymin), (xmax, ymax), size=(b, n_particles, 2))
    vel = np.asarray(velocity_xy, float)

    def propagate(p, t, g):
        step = g.normal(0.0, step_std_m, size=p.shape)
        return reflect_into(p + (vel if t > 0 else 0.0) + (step if t > 0 else 0.0), plan.bounds)

    def loglik(p, zt):
        z, a, n, s = (zt[:, :n_read], zt[:, n_read:2 * n_read], zt[:, 2 * n_read:3 * n_read],
                      zt[:, 3 * n_read:])
        mu = channel.mean_rss_dbm(_xyz(p, plan.tag_height_m), a[:, None, :], n[:, None, :])
        return gaussian_log_likelihood(z[:, None, :], mu, s[:, None, :])

    return sir_filter(z_aug, init, propagate=propagate, log_likelihood=loglik, rng=rng,
                      threshold=threshold, sqrt_weights=sqrt_weights)


def augment(z, alpha, exponent, sigma) -> np.ndarray:
    """[z | α | n | σ] of :func:`rss_sir` from z and α, n, σ broadcast to it.

    Parameters
    ----------
    z : (B, T, J) reported RSS [dBm] (NaN: not heard)
    alpha : α_j [dBm], broadcast to ``z``
    exponent : path-loss exponents n_j [1], broadcast to ``z``
    sigma : σ [dB], broadcast to ``z``; a (B, T) array is one pooled value per epoch

    Returns
    -------
    (B, T, 4J) the concatenation [z | α | n | σ]
    """
    b, t, j = z.shape
    a = np.broadcast_to(alpha, (b, t, j))
    n = np.broadcast_to(exponent, (b, t, j))
    s = np.broadcast_to(np.asarray(sigma, float)[..., None] if np.ndim(sigma) == 2 else sigma, (b, t, j))
    return np.concatenate([z, a, n, s], axis=-1)


def estimate_simulation(z_dbm, channel, plan, *, sigma0_db: float, rt: dict, k: int, estimators,
                        floor_dbm: float, step_std_m: float, n_particles: int, rng: np.random.Generator) -> dict:
    """kNN, grid Bayes (MMSE/MAP) and SIR (MMSE/MAP) of the simulation rooms.

    Parameters
    ----------
    z_dbm : (B, T, J) reported RSS per trial, epoch and reader [dBm] (NaN: not heard)
    channel, plan : module docstring (the channel's own α_j, n_j make the model map)
    sigma0_db : σ of the filters [dB] (0: :data:`DEFAULT_FILTER_SIGMA_DB`)
    rt : recursions of the filters, ``{"grid": rt, "pf": rt}`` (estimates after them are NaN)
    k : LANDMARC k
    estimators : families to run, from "nn", "grid", "pf"
    floor_dbm : the value kNN puts in place of an unheard reading [dBm]
    step_std_m : D of the grid transition and the SIR proposal [m]
    n_particles : SIR N
    rng : the SIR filter's stream

    Returns
    -------
    {name: (B, T, 2) estimates [m]} with names nn, grid-mmse, grid-map, pf-mmse, pf-map
    """
    z = z_dbm
    n_steps = z.shape[1]
    cells = plan.cells_xy
    mu = channel.mean_rss_dbm(_xyz(cells, plan.tag_height_m))                  # (M, J)
    sigma = sigma0_db if sigma0_db > 0 else DEFAULT_FILTER_SIGMA_DB
    out = {}
    if "nn" in estimators:
        out["nn"] = landmarc(_fill_floor(z, floor_dbm), mu, cells, k)
    if "grid" in estimators:
        n_rt = rt["grid"]
        ll = gaussian_log_likelihood(z[:, :n_rt, None, :], mu, sigma)
        bel = grid_bayes_filter(ll, gaussian_transition(cells, step_std_m))
        mmse, map_ = grid_estimates(bel, cells)
        out["grid-mmse"], out["grid-map"] = _pad(mmse, n_steps), _pad(map_, n_steps)
    if "pf" in estimators:
        n_rt = rt["pf"]
        zaug = augment(z[:, :n_rt], channel.alpha_dbm, channel.exponent, sigma)
        res = rss_sir(channel, plan, zaug, n_particles, step_std_m, rng=rng)
        out["pf-mmse"], out["pf-map"] = _pad(res.mmse, n_steps), _pad(res.map, n_steps)
    return out


def smooth_rssi(z, ref_z, ref_expected):
    """RSSI smoothing with reference tags (§1.9, L1105–L1109).

    LANDMARC weights w_k of the reference tags in RSS space (eq. 3.1/3.3 over all I tags); for
    every tag with w_k > 0.4 the target's vector is corrected by ``w_k·e_k``, ``e_k = observed_k −
    expected_k`` (the tag's error against the calibrated model).

    Parameters
    ----------
    z : (B, T, J) target RSS [dBm]
    ref_z : (B, T, J, I) reference tags' RSS [dBm]
    ref_expected : (B, T, J, I) the calibrated model's RSS at the reference tags [dBm]

    Returns
    -------
    (B, T, J) smoothed target RSS [dBm]
    """
    e2 = np.nansum((ref_z - z[..., None]) ** 2, axis=-2)                      # (B, T, I)
    with np.errstate(divide="ignore"):
        inv = np.where(e2 > 0, 1.0 / e2, np.inf)
    w = np.where(np.isinf(inv).any(-1, keepdims=True), np.isinf(inv).astype(float), inv)
    w = w / w.sum(axis=-1, keepdims=True)
    err = np.nan_to_num(ref_z - ref_expected)
    corr = np.sum(np.where(w > SMOOTHING_WEIGHT, w, 0.0)[..., None, :] * err, axis=-1)
    return z - corr


def estimate_home(z_dbm, ref_z_dbm, pattern_map_dbm, channel, plan, *, reference_xy, offline_alpha_dbm,
                  offline_exponent, velocity_xy, k: int, floor_dbm: float, step_std_m: float, n_particles: int,
                  rng: np.random.Generator) -> tuple[dict, Calibration]:
    """The home-replica estimators of Tables 7.41/7.42.

    Parameters
    ----------
    z_dbm : (B, T, J) reported RSS of the target [dBm]
    ref_z_dbm : (B, T, J, I) reported RSS of the I reference tags [dBm]
    reference_xy : (I, 2) positions of the reference tags [m]
    pattern_map_dbm : (B, M, J) fingerprint map per trial [dBm] or None (no ``nn-pattern``)
    channel, plan : module docstring
    offline_alpha_dbm, offline_exponent : (J,) the offline fit's α_j [dBm] and n_j
    velocity_xy : known displacement per epoch of the improved SIR [m]
    k, floor_dbm, step_std_m, n_particles : as :func:`estimate_simulation`
    rng : the SIR filters' stream

    Returns
    -------
    ({name: (B, T, 2) estimates [m]}, the online calibration of every epoch (eq. 6.5–6.7,
    :func:`rfsim.estimators.calibration.calibrate_log_distance`))
    """
    z = z_dbm
    cells3 = _xyz(plan.cells_xy, plan.tag_height_m)
    ref3 = _xyz(reference_xy, plan.tag_height_m)
    # online calibration at every beacon epoch from the reference tags (eq. 6.5–6.7)
    log_d = np.log10(channel.distance_m(ref3) / channel.d0_m).T                # (J, I)
    walls = channel.wall_loss_db(ref3).T
    cal = calibrate_log_distance(ref_z_dbm, log_d, walls)
    sig_on = np.maximum(cal.sigma_db, MIN_ONLINE_SIGMA_DB)                    # (B, T)
    mu_off = channel.mean_rss_dbm(cells3, offline_alpha_dbm, offline_exponent)  # (M, J)
    mu_on = channel.mean_rss_dbm(cells3, cal.alpha_dbm[:, :, None, :], cal.exponent[:, :, None, :])
    ref_exp = channel.mean_rss_dbm(ref3, cal.alpha_dbm[:, :, None, :], cal.exponent[:, :, None, :])
    z_s = smooth_rssi(z, ref_z_dbm, np.swapaxes(ref_exp, -1, -2))
    zf = _fill_floor(z, floor_dbm)
    out = {"nn-offline": landmarc(zf, mu_off, plan.cells_xy, k),
           "nn-online": landmarc(zf, mu_on, plan.cells_xy, k)}
    if pattern_map_dbm is not None:
        out["nn-pattern"] = landmarc(zf, _fill_floor(pattern_map_dbm, floor_dbm)[:, None], plan.cells_xy, k)
    trans = gaussian_transition(plan.cells_xy, step_std_m)
    s0 = DEFAULT_FILTER_SIGMA_DB

    def grid(zz, mu, sig):
        sig = np.asarray(sig, float)
        sig = sig[..., None, None] if sig.ndim == 2 else sig
        return grid_estimates(grid_bayes_filter(gaussian_log_likelihood(zz[:, :, None, :], mu, sig), trans),
                              plan.cells_xy)[0]

    out["grid"] = grid(z, mu_off, s0)
    out["grid-auto-sigma"] = grid(z, mu_on, sig_on)
    out["grid-smoothing"] = grid(z_s, mu_on, s0)
    pf = dict(rng=rng, velocity_xy=velocity_xy, threshold=0.5, sqrt_weights=True)
    out["pf-improved"] = rss_sir(channel, plan, augment(z, cal.alpha_dbm, cal.exponent, s0),
                                 n_particles, step_std_m, **pf).mmse
    out["pf-improved-sigma-smoothing"] = rss_sir(
        channel, plan, augment(z_s, cal.alpha_dbm, cal.exponent, sig_on), n_particles, step_std_m, **pf).mmse
    return out, cal


def error_statistics(err: np.ndarray) -> dict[str, float]:
    """RMSE, mean, median, 90th percentile and std of absolute errors [m] (L1155).

    Parameters
    ----------
    err : (n,) absolute position errors [m]

    Returns
    -------
    dict with ``rmse_m``, ``mean_m``, ``median_m``, ``p90_m``, ``std_m`` [m]
    """
    e = np.asarray(err, float)
    return dict(rmse_m=float(np.sqrt(np.mean(e * e))), mean_m=float(e.mean()),
                median_m=float(np.median(e)), p90_m=float(np.percentile(e, 90)), std_m=float(e.std()))


__all__ = ["DEFAULT_FILTER_SIGMA_DB", "MIN_ONLINE_SIGMA_DB", "SMOOTHING_WEIGHT", "reflect_into", "rss_sir", "augment",
           "estimate_simulation", "smooth_rssi", "estimate_home", "error_statistics"]

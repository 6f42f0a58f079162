"""Estimators and tables of the ``rss-localization`` scenario (the reference estimators of
rfsim.estimators applied to the simulated beacons; equations in their docstrings).

Likelihood of a beacon epoch: independent Gaussian readers around the model map
μ_j(l) = α_j − 10·n_j·log10 d_j(l) − nW_j(l)·WAF (eq. 5.11 corrected, 6.4); readers that did not
hear the beacon (below the floor) are left out. kNN replaces an unheard reading by the floor
value. The particle filter's Gaussian proposal is reflected at the walls of the area (the filter
knows the room, "up to walls", Table 7.22).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from rfsim.core.dataset import Column, Dataset, column
from rfsim.estimators import (calibrate_log_distance, gaussian_log_likelihood, gaussian_transition,
                              grid_bayes_filter, grid_estimates, landmarc, sir_filter)

#: Filter σ used when the simulated σ0 is 0 (the zero-noise runs of Fig. 7.7 keep σ = 5.2).
DEFAULT_FILTER_SIGMA_DB = 5.2
#: Lower bound on the pooled online σ (eq. 6.7 with 4 tags can come out near 0).
MIN_ONLINE_SIGMA_DB = 1.0
#: Beacon carrier and transmit power of the active tag (L957).
FC_HZ = 868e6
TX_POWER_DBM = 5.0
#: RSSI-smoothing threshold on a reference tag's LANDMARC weight (§1.9, L1107).
SMOOTHING_WEIGHT = 0.4


def _xyz(xy, z):
    xy = np.asarray(xy, float)
    return np.concatenate([xy, np.full(xy.shape[:-1] + (1,), z)], axis=-1)


def reflect_into(p: np.ndarray, bounds) -> np.ndarray:
    """Mirror positions ``(..., 2)`` at the edges of ``bounds`` (xmin, ymin, xmax, ymax)."""
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


def _run_pf(channel, plan, z_aug, n_particles, step_std_m, *, rng, velocity_xy=(0.0, 0.0),
            threshold=1.0, sqrt_weights=False):
    """SIR over z_aug (B, T, 3J + 1) = [z | α | n | σ]; returns the filter result."""
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


def _augment(z, alpha, exponent, sigma):
    b, t, j = z.shape
    a = np.broadcast_to(alpha, (b, t, j))
    n = np.broadcast_to(exponent, (b, t, j))
    s = np.broadcast_to(np.asarray(sigma, float)[..., None] if np.ndim(sigma) == 2 else sigma, (b, t, j))
    return np.concatenate([z, a, n, s], axis=-1)


def estimate_simulation(config, plan, channel, data, sigma0, motion, rt, k, *, rng) -> dict:
    """kNN, grid Bayes (MMSE/MAP) and SIR (MMSE/MAP) on a simulation case → name → (B, T, 2)."""
    z = data.reported_dbm
    n_steps = z.shape[1]
    cells = plan.cells_xy
    mu = channel.mean_rss_dbm(_xyz(cells, plan.tag_height_m))                  # (M, J)
    sigma = sigma0 if sigma0 > 0 else DEFAULT_FILTER_SIGMA_DB
    floor = config.report.floor_dbm if config.report is not None else -90.0
    out = {}
    if "nn" in config.estimators:
        out["nn"] = landmarc(_fill_floor(z, floor), mu, cells, k)
    if "grid" in config.estimators:
        n_rt = rt["grid"]
        ll = gaussian_log_likelihood(z[:, :n_rt, None, :], mu, sigma)
        bel = grid_bayes_filter(ll, gaussian_transition(cells, config.step_std_m))
        mmse, map_ = grid_estimates(bel, cells)
        out["grid-mmse"], out["grid-map"] = _pad(mmse, n_steps), _pad(map_, n_steps)
    if "pf" in config.estimators:
        n_rt = rt["pf"]
        zaug = _augment(z[:, :n_rt], channel.alpha_dbm, channel.exponent, sigma)
        res = _run_pf(channel, plan, zaug, config.particles, config.step_std_m, rng=rng)
        out["pf-mmse"], out["pf-map"] = _pad(res.mmse, n_steps), _pad(res.map, n_steps)
    return out


def smooth_rssi(z, ref_z, ref_expected):
    """RSSI smoothing with reference tags (§1.9, L1105–L1109).

    LANDMARC weights w_k of the reference tags in RSS space (eq. 3.1/3.3 over all I tags); for
    every tag with w_k > 0.4 the target's vector is corrected by ``w_k·e_k``, ``e_k = observed_k −
    expected_k`` (the tag's error against the calibrated model).

    z (B, T, J); ref_z (B, T, J, I); ref_expected (B, T, J, I) → (B, T, J)
    """
    e2 = np.nansum((ref_z - z[..., None]) ** 2, axis=-2)                      # (B, T, I)
    with np.errstate(divide="ignore"):
        inv = np.where(e2 > 0, 1.0 / e2, np.inf)
    w = np.where(np.isinf(inv).any(-1, keepdims=True), np.isinf(inv).astype(float), inv)
    w = w / w.sum(axis=-1, keepdims=True)
    err = np.nan_to_num(ref_z - ref_expected)
    corr = np.sum(np.where(w > SMOOTHING_WEIGHT, w, 0.0)[..., None, :] * err, axis=-1)
    return z - corr


def estimate_home(config, plan, channel, data, offline, motion, k, *, rng, tables, case) -> dict:
    """The home-replica estimators of Tables 7.41/7.42 → name → (B, T, 2)."""
    z = data.reported_dbm
    b, t, j = z.shape
    cells3 = _xyz(plan.cells_xy, plan.tag_height_m)
    ref3 = _xyz(plan.reference_xy, plan.tag_height_m)
    floor = (config.report.floor_dbm if config.report is not None else -90.0)
    a_off = np.array([r["alpha_dbm"] for r in offline])
    n_off = np.array([r["exponent"] for r in offline])
    # online calibration at every beacon epoch from the 4 reference tags (eq. 6.5–6.7)
    log_d = np.log10(channel.distance_m(ref3) / channel.d0_m).T                # (J, I)
    walls = channel.wall_loss_db(ref3).T
    cal = calibrate_log_distance(data.ref_reported_dbm, log_d, walls)
    sig_on = np.maximum(cal.sigma_db, MIN_ONLINE_SIGMA_DB)                    # (B, T)
    tables.add_calibration(case, cal.alpha_dbm, cal.exponent, cal.sigma_db)
    mu_off = channel.mean_rss_dbm(cells3, a_off, n_off)                         # (M, J)
    mu_on = channel.mean_rss_dbm(cells3, cal.alpha_dbm[:, :, None, :], cal.exponent[:, :, None, :])
    ref_exp = channel.mean_rss_dbm(ref3, cal.alpha_dbm[:, :, None, :], cal.exponent[:, :, None, :])
    z_s = smooth_rssi(z, data.ref_reported_dbm, np.swapaxes(ref_exp, -1, -2))
    zf = _fill_floor(z, floor)
    out = {"nn-offline": landmarc(zf, mu_off, plan.cells_xy, k),
           "nn-online": landmarc(zf, mu_on, plan.cells_xy, k)}
    if data.pattern_map_dbm is not None:
        out["nn-pattern"] = landmarc(zf, _fill_floor(data.pattern_map_dbm, floor)[:, None], plan.cells_xy, k)
    trans = gaussian_transition(plan.cells_xy, config.step_std_m)
    s0 = DEFAULT_FILTER_SIGMA_DB

    def grid(zz, mu, sig):
        sig = np.asarray(sig, float)
        sig = sig[..., None, None] if sig.ndim == 2 else sig
        return grid_estimates(grid_bayes_filter(gaussian_log_likelihood(zz[:, :, None, :], mu, sig), trans),
                              plan.cells_xy)[0]

    out["grid"] = grid(z, mu_off, s0)
    out["grid-auto-sigma"] = grid(z, mu_on, sig_on)
    out["grid-smoothing"] = grid(z_s, mu_on, s0)
    vel = (0.0, 0.0) if motion == "fixed" else tuple(plan.mobile_paths_xy[0][1] - plan.mobile_paths_xy[0][0])
    pf = dict(rng=rng, velocity_xy=vel, threshold=0.5, sqrt_weights=True)
    out["pf-improved"] = _run_pf(channel, plan, _augment(z, cal.alpha_dbm, cal.exponent, s0),
                                 config.particles, config.step_std_m, **pf).mmse
    out["pf-improved-sigma-smoothing"] = _run_pf(
        channel, plan, _augment(z_s, cal.alpha_dbm, cal.exponent, sig_on), config.particles,
        config.step_std_m, **pf).mmse
    return out


# --------------------------------------------------------------------------- tables


def error_statistics(err: np.ndarray) -> dict[str, float]:
    """RMSE, mean, median, 90th percentile and std of absolute errors [m] (L1155)."""
    e = np.asarray(err, float)
    return dict(rmse_m=float(np.sqrt(np.mean(e * e))), mean_m=float(e.mean()),
                median_m=float(np.median(e)), p90_m=float(np.percentile(e, 90)), std_m=float(e.std()))


class _EpcOfTag:
    """The EPC column of the beacons table held as tag indices (expanded when written): tag k
    has the EPC ``3000 0…0 (k+1)`` as 24 hex digits."""

    def __init__(self, tag: np.ndarray):
        self.tag = np.asarray(tag)
        self.size = self.tag.size

    def strings(self) -> np.ndarray:
        """The EPCs as an object array: one ``str`` per tag, shared by that tag's rows."""
        names = np.array([f"3000{0:016X}{k + 1:04X}" for k in range(int(self.tag.max(initial=-1)) + 1)],
                         dtype=object)
        return names[self.tag] if self.size else np.zeros(0, dtype=object)


def _concat(parts) -> np.ndarray:
    """One column from its per-case parts (arrays, broadcast scalars or :class:`_EpcOfTag`).

    Text comes back as an object array whose rows share one ``str`` per distinct value
    (8 bytes a row instead of 4 bytes a character)."""
    if any(isinstance(p, _EpcOfTag) or p.dtype.kind == "U" for p in parts):
        return np.concatenate([p.strings() if isinstance(p, _EpcOfTag) else _shared_text(p) for p in parts])
    return np.concatenate(parts)


def _shared_text(part: np.ndarray) -> np.ndarray:
    """A text part as an object array with one ``str`` object per distinct value."""
    if part.size and part.strides == (0,):   # a broadcast scalar (the usual case)
        shared = np.empty(part.size, dtype=object)
        shared.fill(str(part[0]))   # one object in every row (np.full would copy it per row)
        return shared
    values, index = np.unique(part, return_inverse=True)
    return np.array([str(v) for v in values], dtype=object)[index.reshape(-1)]


class Tables:
    """Accumulates the rows of the scenario's tables across cases."""

    def __init__(self):
        self.rows = defaultdict(lambda: defaultdict(list))
        self._errors = {}
        self._crlb = {}

    def _extend(self, table, **cols):
        """Append rows; a scalar value is kept as a read-only broadcast view (no memory until
        :meth:`write` concatenates the column)."""
        n = max(v.size if isinstance(v, _EpcOfTag) else np.size(v) for v in cols.values())
        for k, v in cols.items():
            if isinstance(v, _EpcOfTag):
                self.rows[table][k].append(v)
            else:
                self.rows[table][k].append(np.broadcast_to(np.asarray(v), (n,)) if np.ndim(v) == 0 else np.ravel(v))

    def add_case(self, case, sigma0, motion, data, results, scored, crlb, *, beacons, tag_z_m,
                 reference_xy):
        b, t, j = data.reported_dbm.shape
        tr, st = np.meshgrid(np.arange(b), np.arange(t), indexing="ij")
        if beacons:
            rss = np.concatenate([data.rss_dbm[..., None], data.ref_rss_dbm], axis=-1)        # (B,T,J,1+I)
            rep = np.concatenate([data.reported_dbm[..., None], data.ref_reported_dbm], axis=-1)
            shape = rss.shape
            idx = np.indices(shape)
            tag = idx[3]
            xy = np.concatenate([data.truth_xy[:, :, None, :],
                                 np.broadcast_to(reference_xy, (b, t) + reference_xy.shape)], axis=2)
            pos = np.broadcast_to(xy[:, :, None], shape + (2,))                           # (B,T,J,1+I,2)
            t_s = idx[1] * 1.0
            if data.beacon_t_s is not None:   # waveform mode: when each beacon was sent
                sent = np.broadcast_to(data.beacon_t_s[:, :, None, :], shape)
                t_s = np.where(np.isfinite(sent), sent, t_s)
            self._extend("beacons", t_s=t_s.ravel(),
                         t_us=np.round(t_s * 1_000_000).astype(np.int64).ravel(), case=case,
                         trial=idx[0].ravel(), step=idx[1].ravel(), reader=(idx[2] + 1).ravel(),
                         antenna=1, tag=tag.ravel(),
                         epc=_EpcOfTag(tag.ravel()),
                         rssi_dbm=rss.ravel(), rssi_reported_dbm=rep.ravel(),
                         detected=~np.isnan(rep.ravel()), frequency_hz=FC_HZ,
                         tx_power_dbm=TX_POWER_DBM, x_m=pos[..., 0].ravel(),
                         y_m=pos[..., 1].ravel(), z_m=float(tag_z_m),
                         sigma0_db=float(sigma0), motion=motion)
        wide = {f"rssi_r{r + 1}_dbm": data.reported_dbm[..., r].ravel() for r in range(j)}
        self._extend("rssi_wide", case=np.full(b * t, case), trial=tr.ravel(), step=st.ravel(),
                     t_s=st.ravel() * 1.0, x_m=data.truth_xy[..., 0].ravel(),
                     y_m=data.truth_xy[..., 1].ravel(), **wide)
        for name, est in results.items():
            err = np.linalg.norm(est - data.truth_xy, axis=-1)
            mask = np.broadcast_to(scored[name], (b, t))
            self._extend("estimates", case=np.full(b * t, case), estimator=name,
                         sigma0_db=float(sigma0), motion=motion,
                         trial=tr.ravel(), step=st.ravel(), x_est_m=est[..., 0].ravel(),
                         y_est_m=est[..., 1].ravel(), x_true_m=data.truth_xy[..., 0].ravel(),
                         y_true_m=data.truth_xy[..., 1].ravel(), error_m=err.ravel(), scored=mask.ravel())
            self._errors[(case, name)] = err[mask]
            self._crlb[(case, name)] = crlb[mask]

    def add_calibration(self, case, alpha, exponent, sigma):
        b, t, j = alpha.shape
        idx = np.indices((b, t, j))
        self._extend("calibration", kind=np.full(alpha.size, "online"), case=np.full(alpha.size, case),
                     trial=idx[0].ravel(), step=idx[1].ravel(), reader=(idx[2] + 1).ravel(),
                     alpha_dbm=alpha.ravel(), exponent=exponent.ravel(),
                     sigma_db=np.repeat(sigma.ravel(), j), waf_db=np.full(alpha.size, np.nan))

    def add_waveform(self, case, sigma0, motion, stats):
        self._extend("waveform", case=case, sigma0_db=sigma0, motion=motion, beacons_due=stats.due,
                     lbt_dropped=stats.dropped, collided=stats.collided, decoded=stats.decoded,
                     reported=stats.reported, air_steps=stats.air_steps)

    def add_summary(self, case, name, sigma0, motion, pub):
        s = error_statistics(self._errors[(case, name)])
        pub = pub or (None,)
        p = [np.nan if v is None else v for v in pub] + [np.nan] * (5 - len(pub))
        crlb = self._crlb[(case, name)]
        self._extend("summary", case=case, estimator=name, sigma0_db=sigma0, motion=motion,
                     n_scored=self._errors[(case, name)].size, **s,
                     crlb_m=float(np.sqrt(np.mean(np.where(np.isfinite(crlb), crlb, np.nan) ** 2))),
                     published_rmse_m=p[0], published_mean_m=p[1], published_median_m=p[2],
                     published_p90_m=p[3], published_std_m=p[4],
                     relative_difference=(s["rmse_m"] - p[0]) / p[0] if np.isfinite(p[0]) else np.nan)

    def write(self, ds: Dataset, offline):
        for r in offline:
            self._extend("calibration", kind="offline", case=-1, trial=-1, step=-1, reader=r["reader"],
                         alpha_dbm=r["alpha_dbm"], exponent=r["exponent"], sigma_db=r["sigma_db"],
                         waf_db=r["waf_db"])
        for name in list(self.rows):
            cols = self.rows.pop(name)
            out = {}
            for k in list(cols):  # one column at a time, its parts freed as it is joined
                parts = cols.pop(k)
                joined = _concat(parts)
                out[k] = (Column(joined, *_UNITS.get(k, ("", k))) if joined.dtype == object
                          else column(joined, *_UNITS.get(k, ("", k))))
                del parts
            ds.add_table(name, out, description=_GROUPS[name])


#: Description of each table the scenario writes.
_GROUPS = {
    "beacons": "one row per beacon and reader: the long per-read log (time stamp in µs, EPC as hex, "
               "true and reported RSSI, whether the reader heard it, the tag's true position)",
    "rssi_wide": "one row per beacon epoch: the reported RSSI of every reader side by side (NaN = not heard), "
                 "the input of the estimators",
    "calibration": "log-distance parameters: the offline least-squares fit of the measurement campaign and "
                   "the online reference-tag calibration (α, n, σ per reader)",
    "estimates": "one row per estimator, trial and step: estimated and true position and the error",
    "waveform": "one row per case of rss_model = waveform: beacons due, dropped by listen-before-talk and "
                "collided, frames decoded (valid CRC, every reader) and reported (above the floor), air steps",
    "summary": "one row per case (σ0, motion) and estimator: error statistics, the corrected CRLB and the "
               "thesis's published values beside them",
}

_UNITS = {
    "t_s": ("s", "epoch time (1 beacon per second); in the beacons table of the waveform mode the time "
                 "the tag sent the beacon (the epoch for one dropped by listen-before-talk)"),
    "t_us": ("us", "beacon time stamp in whole microseconds, as readers report it"),
    "case": ("1", "index of the (σ0, motion) case"),
    "trial": ("1", "run (simulation) or track (home) index"), "step": ("1", "beacon epoch / recursion"),
    "reader": ("1", "index of the reader that heard the beacon, 1-based in the floor plan's reader order"), "antenna": ("1", "reader antenna port (1-based)"),
    "tag": ("1", "0 = target, 1.. = reference tags"), "epc": ("", "tag EPC as a hex string"),
    "rssi_dbm": ("dBm", "true received power (model)"),
    "rssi_reported_dbm": ("dBm", "RSSI the reader reports (quantized; NaN below the floor)"),
    "detected": ("1", "beacon heard (above the reader floor)"),
    "sigma0_db": ("dB", "RSSI noise σ0 of the case (NaN = per-reader Table 6.1 σ)"),
    "motion": ("", "fixed or mobile target"), "x_m": ("m", "true x coordinate of the tag in the floor plan when it sent the beacon"),
    "y_m": ("m", "true y coordinate of the tag in the floor plan when it sent the beacon"),
    "z_m": ("m", "true tag height"), "frequency_hz": ("Hz", "carrier frequency of the active beacon (868 MHz band)"),
    "tx_power_dbm": ("dBm", "tag transmit power"),
    "estimator": ("", "which estimator produced the row: nn (kNN/LANDMARC), grid (grid Bayes) or pf (SIR particle filter), with its variant"), "x_est_m": ("m", "x coordinate the estimator returned for this step"),
    "y_est_m": ("m", "y coordinate the estimator returned for this step"),
    "x_true_m": ("m", "true x coordinate of the tag at this step"),
    "y_true_m": ("m", "true y coordinate of the tag at this step"),
    "error_m": ("m", "localization error: Euclidean distance between the estimated and the true position"),
    "scored": ("1", "counted in the summary (fixed: last recursion; mobile/home: every step)"),
    "kind": ("", "offline fit or online (reference-tag) calibration"),
    "alpha_dbm": ("dBm", "α: RSS at 1 m"), "exponent": ("1", "path-loss exponent n"),
    "sigma_db": ("dB", "σ (offline: per reader; online: pooled eq. 6.7)"),
    "waf_db": ("dB", "wall attenuation factor (offline fit)"),
    "n_scored": ("1", "number of errors in the statistics"), "rmse_m": ("m", "root mean square error"),
    "mean_m": ("m", "mean of the scored localization errors"),
    "median_m": ("m", "median of the scored localization errors"),
    "p90_m": ("m", "90th percentile of the scored localization errors"),
    "std_m": ("m", "standard deviation of the error"),
    "crlb_m": ("m", "corrected CRLB, RMS over the scored true positions"),
    "published_rmse_m": ("m", "thesis RMSE of the case (NaN = none)"),
    "published_mean_m": ("m", "mean error the thesis reports for this case (NaN = none)"),
    "published_median_m": ("m", "median error the thesis reports for this case (NaN = none)"),
    "published_p90_m": ("m", "90th-percentile error the thesis reports for this case (NaN = none)"),
    "published_std_m": ("m", "standard deviation of the error the thesis reports for this case (NaN = none)"),
    "relative_difference": ("1", "(rmse − published)/published"),
    "beacons_due": ("1", "beacons due in the case (every tag, trial and epoch)"),
    "lbt_dropped": ("1", "beacons dropped after the last listen-before-talk attempt found the channel busy"),
    "collided": ("1", "beacons that overlapped another tag's beacon in time"),
    "decoded": ("1", "frames with a valid CRC, summed over the readers"),
    "reported": ("1", "decoded frames of the right epoch reported above the reader floor, summed over readers"),
    "air_steps": ("1", "air-interface steps run (reception clusters and carrier sensing)"),
}
for _r in range(1, 9):
    _UNITS[f"rssi_r{_r}_dbm"] = ("dBm", f"reported RSSI at reader {_r} (NaN = not heard)")

"""Tables of the ``rss-localization`` scenario: rows accumulated case by case and written once
(the per-beacon log, the estimators' inputs and outputs, calibration, summary)."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from rfsim.core.dataset import Column, Dataset, column
from rfsim.estimators.rss_localization import error_statistics

#: Beacon carrier and transmit power of the active tag (L957).
FC_HZ = 868e6
TX_POWER_DBM = 5.0


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

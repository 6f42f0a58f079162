"""Tables of the ``rss-localization`` scenario: rows accumulated case by case and written once
(the per-beacon log, the estimators' inputs and outputs, calibration, summary)."""

from __future__ import annotations

import numpy as np

from rfsim.core.dataset import Dataset
from rfsim.core.rows import RowTables
from rfsim.scenes.active_beacons import WAVEFORM_UNITS
from rfsim.scenes.rss_rooms import BEACON_LOG_UNITS, beacon_log
from rfsim.estimators.rss_localization import error_statistics


class Tables(RowTables):
    """Accumulates the rows of the scenario's tables across cases."""

    def __init__(self):
        super().__init__()
        self._errors, self._crlb = {}, {}

    def add_case(self, case, sigma0, motion, data, results, scored, crlb, *, beacons, tag_z_m, reference_xy):
        b, t, j = data.reported_dbm.shape
        tr, st = np.meshgrid(np.arange(b), np.arange(t), indexing="ij")
        if beacons:
            self.extend("beacons", **beacon_log(data, reference_xy, tag_z_m=tag_z_m, case=case), sigma0_db=float(sigma0),
                        motion=motion)
        wide = {f"rssi_r{r + 1}_dbm": data.reported_dbm[..., r].ravel() for r in range(j)}
        self.extend("rssi_wide", case=np.full(b * t, case), trial=tr.ravel(), step=st.ravel(), t_s=st.ravel() * 1.0,
                    x_m=data.truth_xy[..., 0].ravel(), y_m=data.truth_xy[..., 1].ravel(), **wide)
        for name, est in results.items():
            err = np.linalg.norm(est - data.truth_xy, axis=-1)
            mask = np.broadcast_to(scored[name], (b, t))
            self.extend("estimates", case=np.full(b * t, case), estimator=name, sigma0_db=float(sigma0), motion=motion,
                        trial=tr.ravel(), step=st.ravel(), x_est_m=est[..., 0].ravel(), y_est_m=est[..., 1].ravel(),
                        x_true_m=data.truth_xy[..., 0].ravel(), y_true_m=data.truth_xy[..., 1].ravel(),
                        error_m=err.ravel(), scored=mask.ravel())
            self._errors[(case, name)] = err[mask]
            self._crlb[(case, name)] = crlb[mask]

    def add_calibration(self, case, alpha, exponent, sigma):
        b, t, j = alpha.shape
        idx = np.indices((b, t, j))
        self.extend("calibration", kind=np.full(alpha.size, "online"), case=np.full(alpha.size, case),
                    trial=idx[0].ravel(), step=idx[1].ravel(), reader=(idx[2] + 1).ravel(), alpha_dbm=alpha.ravel(),
                    exponent=exponent.ravel(), sigma_db=np.repeat(sigma.ravel(), j), waf_db=np.full(alpha.size, np.nan))

    def add_summary(self, case, name, sigma0, motion, pub):
        s = error_statistics(self._errors[(case, name)])
        pub = pub or (None,)
        p = [np.nan if v is None else v for v in pub] + [np.nan] * (5 - len(pub))
        crlb = self._crlb[(case, name)]
        self.extend("summary", case=case, estimator=name, sigma0_db=sigma0, motion=motion,
                    n_scored=self._errors[(case, name)].size, **s,
                    crlb_m=float(np.sqrt(np.mean(np.where(np.isfinite(crlb), crlb, np.nan) ** 2))),
                    **{f"published_{k}_m": v for k, v in zip(("rmse", "mean", "median", "p90", "std"), p)},
                    relative_difference=(s["rmse_m"] - p[0]) / p[0] if np.isfinite(p[0]) else np.nan)

    def write(self, ds: Dataset, offline):
        for r in offline:
            self.extend("calibration", kind="offline", case=-1, trial=-1, step=-1, reader=r["reader"],
                        alpha_dbm=r["alpha_dbm"], exponent=r["exponent"], sigma_db=r["sigma_db"], waf_db=r["waf_db"])
        super().write(ds, _UNITS, _GROUPS)


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
    **BEACON_LOG_UNITS, **WAVEFORM_UNITS,
    "sigma0_db": ("dB", "RSSI noise σ0 of the case (NaN = per-reader Table 6.1 σ)"), "motion": ("", "fixed or mobile target"),
    "estimator": ("", "which estimator produced the row: nn (kNN/LANDMARC), grid (grid Bayes) or pf (SIR particle filter), "
                      "with its variant"),
    **{f"{c}_est_m": ("m", f"{c} coordinate the estimator returned for this step") for c in "xy"},
    "x_true_m": ("m", "true x coordinate of the tag at this step"), "y_true_m": ("m", "true y coordinate of the tag at this step"),
    "error_m": ("m", "localization error: Euclidean distance between the estimated and the true position"),
    "scored": ("1", "counted in the summary (fixed: last recursion; mobile/home: every step)"),
    "kind": ("", "offline fit or online (reference-tag) calibration"),
    "alpha_dbm": ("dBm", "α: RSS at 1 m"), "exponent": ("1", "path-loss exponent n"),
    "sigma_db": ("dB", "σ (offline: per reader; online: pooled eq. 6.7)"), "waf_db": ("dB", "wall attenuation factor (offline fit)"),
    "n_scored": ("1", "number of errors in the statistics"), "rmse_m": ("m", "root mean square error"),
    "mean_m": ("m", "mean of the scored localization errors"), "median_m": ("m", "median of the scored localization errors"),
    "p90_m": ("m", "90th percentile of the scored localization errors"), "std_m": ("m", "standard deviation of the error"),
    "crlb_m": ("m", "corrected CRLB, RMS over the scored true positions"),
    "published_rmse_m": ("m", "thesis RMSE of the case (NaN = none)"),
    **{f"published_{k}_m": ("m", f"{d} the thesis reports for this case (NaN = none)") for k, d in (
        ("mean", "mean error"), ("median", "median error"), ("p90", "90th-percentile error"),
        ("std", "standard deviation of the error"))},
    "relative_difference": ("1", "(rmse − published)/published"),
}
for _r in range(1, 9):
    _UNITS[f"rssi_r{_r}_dbm"] = ("dBm", f"reported RSSI at reader {_r} (NaN = not heard)")

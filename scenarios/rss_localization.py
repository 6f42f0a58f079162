"""Scenario ``rss-localization``: Özkaya's active-RFID RSSI localization, statistical mode.

An active tag beacons once per second (868 MHz, 5 dBm; seeds/002 L957, L1773); every reader
reports the beacon's RSSI. ``rss_model = "log-distance"`` draws the received power from the
thesis's statistical model (rfsim.channels.rss: per-reader α_j, n_j, σ_j, WAF per wall crossing,
quasi-static shadowing per position and reader, optionally spatially correlated, plus a
time-varying people term) and the reader's report from rfsim.devices.rss_reader (quantization,
−90 dBm floor). ``rss_model = "waveform"`` keeps those draws (paired trial by trial) and sends
every beacon at sample level instead: Manchester MSK bursts of rfsim.devices.ActiveTag through the
air interface, per-link log-distance models in the channel, listen-before-talk and
collisions (rfsim.protocols.beacons), the RSSI measured and reported by rfsim.devices.ActiveReader
(rfsim.scenarios._rss_waveform); its counts are in the table ``waveform``.

Presets (rfsim.scenarios._rss_plans): ``sim-5x8`` (3 or 4 corner readers), ``sim-10x16`` and
``home-2room`` (two rooms, a brick wall, Table 6.1 readers, 4 reference tags).

Experiments per σ0 (simulation presets; §2.4, L1133–L1155, L1319–L1327): a **fixed** target
(uniform in the room, shadowing frozen over the rt recursions, scored after the last) and a
**mobile** target (Gaussian random walk D0 = 0.5 m per beacon, steps leaving the room redrawn,
fresh shadowing at every new position, scored at every step). Estimators: LANDMARC kNN on the
model map (k = 4; 68 in the 10 × 16 m room), grid Bayes over the k_CELL cells (D = 0.5 m, MMSE
and MAP), SIR particle filter (N = 250, Gaussian proposal D = 0.5 m reflected at the walls,
systematic resampling every step, MMSE and MAP); rt per σ from the thesis's tables. The home
replica adds the offline fit, online calibration of α_j, n_j and σ from the reference tags (eq. 6.5–6.7), RSSI smoothing
(§1.9), the fingerprint (pattern) map of 40 reads per cell and the improved SIR (√w selection,
resampling when N_eff < 0.5 N, the known 0.5 m/step velocity for the mobile target); kNN
uses k = 36 there (L1814).

Noise model: **independent per reader** (see rfsim.channels.rss; dataset attribute ``noise_model``):
it reproduces Table 7.3, a term shared by all readers does not (wave2-specs.md §R: 1.24/1.61/
1.82/2.01 m shared vs 1.36/1.92/2.20/2.48 m independent; tested here). Physically each reader
sees the tag through its own obstacles, orientation and multipath. Simulation presets: all of σ0² quasi-static and
independent per position (the thesis's "noise drawn once per run"), no quantization. Home: 75 %
of σ_j² quasi-static with Gudmundson correlation (d_corr = 3 m, so that a target near a
reference tag shares its error, §1.9), 25 % a people term redrawn per beacon, 1 dB RSSI steps
(L1787); these shares are this replica's choice, the thesis does not split its σ. The share
decides the home's fixed-target ordering: with 75 % quasi-static, grid Bayes ties the offline
NN; with all of σ² quasi-static it falls behind both NNs as in Table 7.41, but then loses the
mobile grid < online NN of Table 7.42 (tests/test_scenario_rss_localization.py). Grid Bayes
fixed at σ0 = 1 dB is ≈ 13 % above Table 7.11: the targets are uniform in the room, and the
28 cell centres leave a 1 m strip along the walls that no estimate on them reaches (tested).

Randomness: case c (σ0 index × motion), trial b draws its environment and track from
``trial_rng(seed, c, 0, b)``; the estimators of case c (particle propagation, resampling) use
``trial_rng(seed, c, 1)``; the offline campaign ``trial_rng(seed, 10**6)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.devices.rss_reader import RssReport
from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.core.progress import track
from rfsim.core.rng import trial_rng
from rfsim.scenarios._rss_waveform import WaveformConfig, sample_level_reports
from rfsim.core.lazy import lazy_import

_large_scale = lazy_import("rfsim.channels.large_scale")
_rss = lazy_import("rfsim.channels.rss")
_dataset = lazy_import("rfsim.core.dataset")
_calibration = lazy_import("rfsim.estimators.calibration")
_bounds = lazy_import("rfsim.estimators.bounds")
est = lazy_import("rfsim.scenarios._rss_estimate")
_rss_figures = lazy_import("rfsim.scenarios._rss_figures")
_rss_plans = lazy_import("rfsim.scenarios._rss_plans")

NAME = "rss-localization"
DESCRIPTION = ("active-RFID RSSI localization (Özkaya): log-distance RSS datasets, kNN, grid Bayes, "
               "SIR PF, reference-tag calibration")

BEACON_PERIOD_S = 1.0


@dataclass(frozen=True)
class ShadowingConfig:
    decorrelation_m: float | None = param(
        None, lo=0.0, hi=100.0, unit="m",
        doc="Gudmundson decorrelation distance (0 = independent per position; none = preset: 0 sim, 3 home)")
    static_fraction: float | None = param(
        None, lo=0.0, hi=1.0,
        doc="share of σ² that is quasi-static, the rest is the people term (none = preset: 1 sim, 0.75 home)")
    people_correlation: float = param(0.0, lo=0.0, hi=0.999,
                                      doc="AR(1) coefficient of the people term between beacons")
    readers: Literal["independent", "shared"] = param(
        "independent", doc="quasi-static term independent per reader, or one term shared by all readers")


@dataclass(frozen=True)
class Config:
    preset: Literal["sim-5x8", "sim-10x16", "home-2room"] = param("sim-5x8", doc="floor plan and experiment")
    rss_model: Literal["log-distance", "waveform"] = param(
        "log-distance", doc="statistical RSS model, or beacons sent at sample level (MSK, LBT, collisions)")
    waveform: WaveformConfig = param(WaveformConfig(), doc="sample-level beacons (rss_model = waveform)")
    n_readers: Literal[3, 4] = param(3, doc="corner readers of the simulation rooms")
    readers_xy: tuple[tuple[float, float], ...] | None = param(
        None, unit="m", doc="reader positions overriding the preset")
    walls_xy: tuple[tuple[float, float, float, float], ...] | None = param(
        None, unit="m", doc="walls (x0, y0, x1, y1) overriding the preset")
    alpha_dbm: float = param(-52.0, lo=-120.0, hi=0.0, unit="dBm", doc="simulation presets: RSS at 1 m")
    exponent: float = param(2.3, lo=0.5, hi=8.0, lo_open=True, doc="simulation presets: path-loss exponent n")
    waf_db: float = param(2.0, lo=0.0, hi=40.0, unit="dB", doc="wall attenuation factor per crossing")
    sigma0_db: tuple[float, ...] = param((3.0, 5.2, 7.0, 9.0), lo=0.0, hi=30.0, unit="dB",
                                         doc="simulation presets: RSSI noise σ0 values (σ = σ0 in the filters)")
    motions: tuple[Literal["fixed", "mobile"], ...] = param(("fixed", "mobile"), doc="target motions simulated")
    estimators: tuple[Literal["nn", "grid", "pf"], ...] = param(("nn", "grid", "pf"), doc="estimator families")
    trials: int | None = param(
        None, lo=1, hi=1_000_000,
        doc="runs per case (none = preset: 1000 sim; home: 4 × the 25 points / 25 walks, own environments)")
    nn_k: int | None = param(
        None, lo=1, hi=100000,
        doc="LANDMARC k ≤ the number of cells (none = the thesis's: 4 sim-5x8, 68 sim-10x16, 36 home)")
    step_std_m: float = param(0.5, lo=0.0, hi=100.0, lo_open=True, unit="m", doc="D = D0: motion std per beacon")
    recursions: int = param(0, lo=0, hi=1000, doc="rt (0 = the thesis's value for each σ0 and filter)")
    particles: int = param(250, lo=1, hi=1_000_000, doc="SIR particles N")
    home_steps: int = param(30, lo=1, hi=1000, doc="home: estimates per fixed point (30 in the thesis)")
    shadowing: ShadowingConfig = param(ShadowingConfig(), doc="shadowing and people term")
    report: RssReport | None = param(
        None, doc="reader RSSI report (none = preset: no quantization sim, 1 dB home)")
    write_beacons: bool = param(True, doc="write the long per-beacon table")

    def __post_init__(self):
        check_fields(self)
        plan = floor_plan(self)
        if self.nn_k is not None and self.nn_k > plan.cells_xy.shape[0]:
            raise ConfigError("nn_k", self.nn_k, f"an integer in [1, {plan.cells_xy.shape[0]}] "
                              f"(the number of reference signatures of {self.preset})")


# --------------------------------------------------------------------------- geometry


def floor_plan(config: Config) -> _rss_plans.FloorPlan:
    """The preset's plan with the reader/wall overrides, validated (one-line errors).

    Overridden readers keep the preset's per-reader (α, n, σ) when their number is unchanged;
    otherwise every reader takes the first reader's parameters.
    """
    if config.preset == "home-2room":
        plan = _rss_plans.home_plan()
    else:
        w, l = (5.0, 8.0) if config.preset == "sim-5x8" else (10.0, 16.0)
        plan = _rss_plans.simulation_plan(w, l, config.n_readers, config.alpha_dbm, config.exponent)
    xmin, ymin, xmax, ymax = plan.bounds
    readers = plan.readers_xy if config.readers_xy is None else config.readers_xy
    if len(readers) == 0:
        raise ConfigError("readers_xy", [], "at least one reader position [x, y] in m")
    for i, (x, y) in enumerate(readers):
        if not (xmin <= x <= xmax and ymin <= y <= ymax):
            raise ConfigError(f"readers_xy[{i}]", [x, y], f"a point inside the floor plan "
                              f"[{xmin:g}, {xmax:g}] x [{ymin:g}, {ymax:g}] m")
    walls = plan.walls_xy if config.walls_xy is None else config.walls_xy
    for i, (x0, y0, x1, y1) in enumerate(walls):
        if not np.hypot(x1 - x0, y1 - y0) > 0:
            raise ConfigError(f"walls_xy[{i}]", [x0, y0, x1, y1], "a wall segment of non-zero length")
    params = plan.reader_params
    if len(readers) != len(params):
        params = (params[0],) * len(readers)
    return _rss_plans.FloorPlan(plan.name, plan.bounds, tuple(readers), tuple(walls), params, plan.cells_xy,
                                plan.reference_xy, plan.fixed_points_xy, plan.mobile_paths_xy,
                                plan.reader_height_m, plan.tag_height_m)


def rss_channel(plan: _rss_plans.FloorPlan, waf_db: float, sigma_db=None) -> _rss.RssChannel:
    """The per-reader log-distance channel of ``plan`` (σ_j replaced by ``sigma_db`` if given)."""
    readers = [_rss.ReaderLink((x, y, plan.reader_height_m), a, n, s if sigma_db is None else sigma_db)
               for (x, y), (a, n, s) in zip(plan.readers_xy, plan.reader_params)]
    walls = [_large_scale.Wall.segment_2d((x0, y0), (x1, y1), waf_db) for x0, y0, x1, y1 in plan.walls_xy]
    return _rss.RssChannel(readers, walls)


def _xyz(xy: np.ndarray, z: float) -> np.ndarray:
    return np.concatenate([xy, np.full(xy.shape[:-1] + (1,), z)], axis=-1)


#: The thesis's k_NN per preset (Tables 7.3, 7.6; L1814).
DEFAULT_NN_K = {"sim-5x8": 4, "sim-10x16": 68, "home-2room": 36}


def nn_k(config: Config) -> int:
    """LANDMARC k of the run."""
    return config.nn_k if config.nn_k is not None else DEFAULT_NN_K[config.preset]


def _home(config: Config) -> bool:
    return config.preset == "home-2room"


def _report(config: Config) -> RssReport:
    if config.report is not None:
        return config.report
    return RssReport(step_db=1.0 if _home(config) else 0.0)


def _shadowing(config: Config) -> tuple[float, float]:
    s = config.shadowing
    dec = s.decorrelation_m if s.decorrelation_m is not None else (3.0 if _home(config) else 0.0)
    frac = s.static_fraction if s.static_fraction is not None else (0.75 if _home(config) else 1.0)
    return dec, frac


# --------------------------------------------------------------------------- simulation


def random_walk(start_xy, n_steps: int, step_std_m: float, bounds, *, rng) -> np.ndarray:
    """Gaussian random walk (D0 per step) whose steps leaving ``bounds`` are redrawn → (T, 2)."""
    xmin, ymin, xmax, ymax = bounds
    track = np.empty((n_steps, 2))
    track[0] = start_xy
    for t in range(1, n_steps):
        while True:
            p = track[t - 1] + rng.normal(0.0, step_std_m, size=2)
            if xmin <= p[0] <= xmax and ymin <= p[1] <= ymax:
                break
        track[t] = p
    return track


@dataclass
class CaseData:
    """Simulated beacons of one case: truth (B, T, 2), true/reported RSS (B, T, J) of the
    target and (B, T, J, I) of the reference tags, the pattern map (B, M, J), and in the
    waveform mode the beacons' start times."""

    truth_xy: np.ndarray
    rss_dbm: np.ndarray
    reported_dbm: np.ndarray
    ref_rss_dbm: np.ndarray
    ref_reported_dbm: np.ndarray
    pattern_map_dbm: np.ndarray | None
    #: waveform mode: start time [s] of every tag's beacon (B, T, 1 + I) (NaN: dropped by LBT)
    beacon_t_s: np.ndarray | None = None


def simulate_case(config: Config, plan: _rss_plans.FloorPlan, channel: _rss.RssChannel, case: int, motion: str,
                  n_steps: int, seed: int) -> CaseData:
    """Draw every trial's track and beacons for one case (per-trial streams)."""
    dec, frac = _shadowing(config)
    sig = channel.sigma_db
    report = _report(config)
    ref = plan.reference_xy
    n_ref, n_read = ref.shape[0], channel.n_readers
    tracks, shadow_t, shadow_r, people_t, people_r, pattern = [], [], [], [], [], []
    xmin, ymin, xmax, ymax = plan.bounds
    for b in range(n_tracks(config, plan, motion)):
        rng = trial_rng(seed, case, 0, b)
        if _home(config):
            track = _home_track(plan, motion, b, n_steps)
        else:
            start = rng.uniform((xmin, ymin), (xmax, ymax))
            track = (np.repeat(start[None], n_steps, axis=0) if motion == "fixed"
                     else random_walk(start, n_steps, config.step_std_m, plan.bounds, rng=rng))
        fp = _fingerprint_points(plan, rng) if _home(config) else np.zeros((0, 2))
        pts = _xyz(np.concatenate([track, ref, fp]), plan.tag_height_m)
        x = _rss.quasi_static_shadowing_db(pts, np.sqrt(frac) * sig, rng=rng, decorrelation_m=dec,
                                           shared=config.shadowing.readers == "shared")
        sp = np.sqrt(1.0 - frac) * sig
        kw = dict(rng=rng, correlation=config.shadowing.people_correlation)
        tracks.append(track)
        shadow_t.append(x[:n_steps])
        shadow_r.append(x[n_steps:n_steps + n_ref])
        people_t.append(_rss.people_term_db(n_steps, n_read, 1.0, **kw) * sp)
        people_r.append(_rss.people_term_db(n_steps, n_read * n_ref, 1.0, **kw).reshape(n_steps, n_ref, n_read) * sp)
        if fp.size:
            fp_rss = channel.mean_rss_dbm(pts[n_steps + n_ref:]) + x[n_steps + n_ref:]
            fp_rss = fp_rss + rng.standard_normal(fp_rss.shape) * sp
            pattern.append(np.nanmean(report.report(fp_rss).reshape(plan.cells_xy.shape[0], -1, n_read), axis=1))
    truth = np.array(tracks)
    rss = channel.mean_rss_dbm(_xyz(truth, plan.tag_height_m)) + np.array(shadow_t) + np.array(people_t)
    ref_mean = channel.mean_rss_dbm(_xyz(ref, plan.tag_height_m))                       # (I, J)
    ref_rss = ref_mean[None, None] + np.array(shadow_r)[:, None] + np.array(people_r)  # (B, T, I, J)
    ref_rss = np.swapaxes(ref_rss, -1, -2) if n_ref else np.zeros(rss.shape + (0,))
    return CaseData(truth, rss, report.report(rss), ref_rss, report.report(ref_rss),
                    np.array(pattern) if pattern else None)


#: Fingerprint campaign (Sec. 6.3, L1057–L1061): 40 vectors per cell, tag moved within 20 cm.
FINGERPRINTS_PER_CELL = 40


def _fingerprint_points(plan: _rss_plans.FloorPlan, rng) -> np.ndarray:
    jitter = rng.uniform(-0.1, 0.1, size=(plan.cells_xy.shape[0], FINGERPRINTS_PER_CELL, 2))
    return (plan.cells_xy[:, None, :] + jitter).reshape(-1, 2)


def n_tracks(config: Config, plan: _rss_plans.FloorPlan, motion: str) -> int:
    """Tracks of a case: ``trials`` (simulation) or ``trials`` × 25 (home: the 25 fixed points, or
    25 walks alternating between the two room paths)."""
    if not _home(config):
        return config.trials if config.trials is not None else 1000
    return (config.trials if config.trials is not None else 4) * plan.fixed_points_xy.shape[0]


def _home_track(plan: _rss_plans.FloorPlan, motion: str, trial: int, n_steps: int) -> np.ndarray:
    if motion == "fixed":
        p = plan.fixed_points_xy[trial % plan.fixed_points_xy.shape[0]]
        return np.repeat(p[None], n_steps, axis=0)
    return plan.mobile_paths_xy[trial % len(plan.mobile_paths_xy)]


def offline_campaign(channel: _rss.RssChannel, waf_db: float, *, rng) -> list[dict]:
    """The offline calibration of Sec. 6.1 (L988–L1011) on the simulated channel.

    Per reader: 4 locations × 100 reads (8 orientations, people moving: every read an
    independent draw of the reader's σ_j) at 1, 1.5, 2, 2.5, 3 m in the reader's room → LS fit of
    α_j, n_j, σ_j (fit_log_distance); WAF from the same 400 reads at 3 m through one wall minus
    the in-room mean at 3 m (L1000).
    """
    rows = []
    d = np.repeat([1.0, 1.5, 2.0, 2.5, 3.0], 400)
    for j, r in enumerate(channel.readers):
        mean = r.alpha_dbm - 10.0 * r.exponent * np.log10(d)
        rss = mean + rng.normal(0.0, r.sigma_db, size=d.size)
        fit = _calibration.fit_log_distance(rss, d)
        wall = r.alpha_dbm - 10.0 * r.exponent * np.log10(3.0) - waf_db + rng.normal(0.0, r.sigma_db, 400)
        waf = float(np.mean(rss[d == 3.0]) - np.mean(wall))
        rows.append(dict(reader=j + 1, alpha_dbm=float(fit.alpha_dbm), exponent=float(fit.exponent),
                         sigma_db=float(fit.sigma_db), waf_db=waf, true_alpha_dbm=r.alpha_dbm,
                         true_exponent=r.exponent, true_sigma_db=r.sigma_db))
    return rows


# --------------------------------------------------------------------------- run


def _recursions(config: Config, family: str, sigma0: float) -> int:
    if config.recursions:
        return config.recursions
    if _home(config):
        return config.home_steps
    return _rss_plans.RECURSIONS[family].get(round(sigma0, 3), 10)


def _scored(motion: str, n_rt: int, n_steps: int) -> np.ndarray:
    mask = np.zeros(n_steps, bool)
    if motion == "fixed":
        mask[n_rt - 1] = True
    else:
        mask[:n_rt] = True
    return mask


def _cases(config: Config) -> list[tuple[float, str]]:
    if _home(config):
        return [(float("nan"), m) for m in config.motions]
    return [(s, m) for s in config.sigma0_db for m in config.motions]


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    plan = floor_plan(config)
    home = _home(config)
    tables = est.Tables()
    nominal = rss_channel(plan, config.waf_db)
    offline = offline_campaign(nominal, config.waf_db, rng=trial_rng(seed, 10 ** 6)) if home else []
    for case, (sigma0, motion) in enumerate(track(_cases(config), desc="cases", unit="cases")):
        channel = nominal if home else rss_channel(plan, config.waf_db, sigma_db=sigma0)
        if home:
            n_steps = config.home_steps if motion == "fixed" else plan.mobile_paths_xy[0].shape[0]
            rt = {f: n_steps for f in ("grid", "pf")}
        else:
            rt = {f: _recursions(config, f, sigma0) for f in ("grid", "pf")}
            n_steps = max(rt[f] for f in config.estimators if f != "nn") if set(config.estimators) - {"nn"} else 1
            rt["nn"] = n_steps
        data = simulate_case(config, plan, channel, case, motion, n_steps, seed)
        if config.rss_model == "waveform":
            data.reported_dbm, data.ref_reported_dbm, data.beacon_t_s, st = sample_level_reports(
                config, plan, channel, data, case, seed, _report(config))
            tables.add_waveform(case, sigma0, motion, st)
        rng = trial_rng(seed, case, 1)
        if home:
            results = est.estimate_home(config, plan, channel, data, offline, motion, nn_k(config), rng=rng,
                                        tables=tables, case=case)
            scored = {name: np.ones(n_steps, bool) for name in results}
        else:
            results = est.estimate_simulation(config, plan, channel, data, sigma0, motion, rt, nn_k(config),
                                              rng=rng)
            scored = {name: _scored(motion, rt[name.split("-")[0]], n_steps) for name in results}
        # 2-D bound on the floor plan (the 0.2 m height difference of the home is neglected)
        crlb = _bounds.log_distance_crlb(data.truth_xy, channel.positions_m[:, :2], channel.exponent,
                                         np.maximum(channel.sigma_db, 1e-3))
        tables.add_case(case, sigma0, motion, data, results, scored, crlb,
                        beacons=config.write_beacons, tag_z_m=plan.tag_height_m,
                        reference_xy=plan.reference_xy)
        for name in results:
            pub = (_rss_plans.PUBLISHED_HOME.get((name, motion)),) if home else _rss_plans.published(
                plan.name, len(plan.readers_xy), name, motion, sigma0)
            tables.add_summary(case, name, sigma0, motion, pub)
    ds = _dataset.Dataset(title=f"active-RFID RSSI localization (Özkaya 2011), {config.rss_model} mode")
    tables.write(ds, offline)
    ds.attrs.update(preset=plan.name, readers_xy=np.asarray(plan.readers_xy, float),
                    walls_xy=np.asarray(plan.walls_xy, float).reshape(-1, 4),
                    bounds_m=np.asarray(plan.bounds, float), cells_xy=plan.cells_xy,
                    reference_xy=plan.reference_xy, beacon_period_s=BEACON_PERIOD_S,
                    rss_model=config.rss_model,
                    noise_model=("independent per reader" if config.shadowing.readers == "independent"
                                 else "one term shared by all readers")
                    + ", quasi-static per position: the independent model reproduces Table 7.3 "
                      "(NN 1.36/1.92/2.20/2.48 m vs 1.38/1.95/2.29/2.57), a shared term does not "
                      "(1.24/1.61/1.82/2.01 m)")
    return ds


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Floor plan with tracks, error CDF per estimator, RMSE vs σ0 beside the thesis."""
    return _rss_figures.plot_all(dataset_path, out_dir)

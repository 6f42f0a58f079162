"""Scenario ``rss-localization``: Özkaya's active-RFID RSSI localization, statistical mode.

An active tag beacons once per second (868 MHz, 5 dBm; seeds/002 L957, L1773); every reader
reports the beacon's RSSI. ``rss_model = "log-distance"`` draws the received power from the
thesis's statistical model (rfsim.channels.rss: per-reader α_j, n_j, σ_j, WAF per wall crossing,
quasi-static shadowing, a time-varying people term; rfsim.scenes.rss_rooms.draw_beacons) and the
reader's report from rfsim.devices.rss_reader (quantization, −90 dBm floor). ``rss_model =
"waveform"`` keeps those draws (paired trial by trial) and sends every beacon at sample level
instead (rfsim.scenes.active_beacons: MSK bursts of active tags through the air interface,
listen-before-talk, collisions, the readers' RSSI); its counts are in the table ``waveform``.

Presets (rfsim.scenes.rss_rooms): ``sim-5x8`` (3 or 4 corner readers), ``sim-10x16`` and
``home-2room`` (two rooms, a brick wall, Table 6.1 readers, 4 reference tags).

Experiments per σ0 (simulation presets; §2.4, L1133–L1155, L1319–L1327): a **fixed** target
(uniform in the room, shadowing frozen over the rt recursions, scored after the last) and a
**mobile** target (Gaussian random walk D0 = 0.5 m per beacon, steps leaving the room redrawn,
fresh shadowing at every new position, scored at every step). Estimators
(rfsim.estimators.rss_localization): LANDMARC kNN on the model map (k = 4; 68 in the 10 × 16 m
room), grid Bayes over the cells (D = 0.5 m, MMSE and MAP), SIR (N = 250, MMSE and MAP); rt per σ
from the thesis's tables. The home replica adds the offline fit, online reference-tag calibration
(eq. 6.5–6.7), RSSI smoothing (§1.9), the fingerprint map (40 reads per cell) and the improved
SIR; kNN uses k = 36 there (L1814).

Noise model (rfsim.scenes.rss_rooms, dataset attribute ``noise_model``): independent per reader
(it reproduces Table 7.3, a shared term does not); all of σ0² quasi-static in the simulation rooms,
75 % quasi-static (Gudmundson, 3 m) + 25 % people term and 1 dB RSSI steps in the home.

Randomness: case c (σ0 index × motion), trial b draws its environment and track from
``trial_rng(seed, c, 0, b)``; the estimators of case c (particle propagation, resampling) use
``trial_rng(seed, c, 1)``; the offline campaign ``trial_rng(seed, 10**6)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.devices.rss_reader import RssReport
from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.core.plots import figure_path
from rfsim.core.progress import track
from rfsim.core.rng import trial_rng
from rfsim.scenes.active_beacons import WaveformConfig, sample_level_reports
from rfsim.scenes.rss_rooms import ShadowingConfig as _ShadowingConfig
from rfsim.core.lazy import lazy_import

_dataset = lazy_import("rfsim.core.dataset")
_bounds = lazy_import("rfsim.estimators.bounds")
est = lazy_import("rfsim.estimators.rss_localization")
_rss_tables = lazy_import("rfsim.scenarios._rss_tables")
_rss_figures = lazy_import("rfsim.scenarios._rss_figures")
_rooms = lazy_import("rfsim.scenes.rss_rooms")

NAME = "rss-localization"
DESCRIPTION = ("active-RFID RSSI localization (Özkaya): log-distance RSS datasets, kNN, grid Bayes, "
               "SIR PF, reference-tag calibration")

BEACON_PERIOD_S = 1.0


@dataclass(frozen=True)
class Config:
    preset: Literal["sim-5x8", "sim-10x16", "home-2room"] = param("sim-5x8", doc="floor plan and experiment")
    rss_model: Literal["log-distance", "waveform"] = param(
        "log-distance", doc="statistical RSS model, or beacons sent at sample level (MSK, LBT, collisions)")
    waveform: WaveformConfig = param(WaveformConfig(), doc="sample-level beacons (rss_model = waveform)")
    n_readers: Literal[3, 4] = param(3, doc="corner readers of the simulation rooms")
    readers_xy: tuple[tuple[float, float], ...] | None = param(None, unit="m", doc="reader positions overriding the preset")
    walls_xy: tuple[tuple[float, float, float, float], ...] | None = param(None, unit="m", doc="walls (x0, y0, x1, y1) "
                                                                                            "overriding the preset")
    alpha_dbm: float = param(-52.0, lo=-120.0, hi=0.0, unit="dBm", doc="simulation presets: RSS at 1 m")
    exponent: float = param(2.3, lo=0.5, hi=8.0, lo_open=True, doc="simulation presets: path-loss exponent n")
    waf_db: float = param(2.0, lo=0.0, hi=40.0, unit="dB", doc="wall attenuation factor per crossing")
    sigma0_db: tuple[float, ...] = param((3.0, 5.2, 7.0, 9.0), lo=0.0, hi=30.0, unit="dB",
                                         doc="simulation presets: RSSI noise σ0 values (σ = σ0 in the filters)")
    motions: tuple[Literal["fixed", "mobile"], ...] = param(("fixed", "mobile"), doc="target motions simulated")
    estimators: tuple[Literal["nn", "grid", "pf"], ...] = param(("nn", "grid", "pf"), doc="estimator families")
    trials: int | None = param(None, lo=1, hi=1_000_000, doc="runs per case (none = preset: 1000 sim; home: 4 × the 25 points / 25 walks, own environments)")
    nn_k: int | None = param(None, lo=1, hi=100000, doc="LANDMARC k ≤ the number of cells (none = the thesis's: 4 sim-5x8, 68 sim-10x16, 36 home)")
    step_std_m: float = param(0.5, lo=0.0, hi=100.0, lo_open=True, unit="m", doc="D = D0: motion std per beacon")
    recursions: int = param(0, lo=0, hi=1000, doc="rt (0 = the thesis's value for each σ0 and filter)")
    particles: int = param(250, lo=1, hi=1_000_000, doc="SIR particles N")
    home_steps: int = param(30, lo=1, hi=1000, doc="home: estimates per fixed point (30 in the thesis)")
    shadowing: _ShadowingConfig = param(_ShadowingConfig(), doc="shadowing and people term")
    report: RssReport | None = param(None, doc="reader RSSI report (none = preset: no quantization sim, 1 dB home)")
    write_beacons: bool = param(True, doc="write the long per-beacon table")

    def __post_init__(self):
        check_fields(self)
        plan = floor_plan(self)
        if self.nn_k is not None and self.nn_k > plan.cells_xy.shape[0]:
            raise ConfigError("nn_k", self.nn_k, f"an integer in [1, {plan.cells_xy.shape[0]}] "
                              f"(the number of reference signatures of {self.preset})")


# --------------------------------------------------------------------------- geometry


def floor_plan(config: Config) -> _rooms.FloorPlan:
    """The preset's floor plan with the config's reader and wall overrides, validated.

    Parameters
    ----------
    config : Config
        ``preset``, ``n_readers``, ``alpha_dbm``, ``exponent``, ``readers_xy`` and ``walls_xy``.

    Returns
    -------
    rfsim.scenes.rss_rooms.FloorPlan
        The plan (:func:`rfsim.scenes.rss_rooms.with_overrides`).

    Raises
    ------
    ConfigError
        A reader outside the plan or a wall of zero length (one line naming the key).
    """
    plan = _rooms.preset_plan(config.preset, config.n_readers, config.alpha_dbm, config.exponent)
    return _rooms.with_overrides(plan, readers_xy=config.readers_xy, walls_xy=config.walls_xy)


def _preset(config: Config, key: str, value):
    """``value`` of the config, or the preset's default (rfsim.scenes.rss_rooms.PRESET_DEFAULTS)."""
    return _rooms.PRESET_DEFAULTS[config.preset][key] if value is None else value


def _report(config: Config) -> RssReport:
    return config.report if config.report is not None else RssReport(step_db=_preset(config, "report_step_db", None))


def simulate_case(config: Config, plan: _rooms.FloorPlan, channel, case: int, motion: str,
                  n_steps: int, seed: int) -> _rooms.CaseData:
    """Draw every trial's track and beacons for one case (rfsim.scenes.rss_rooms.draw_beacons).

    Parameters
    ----------
    config : Config
        The run's config (trials, motion step, shadowing, report).
    plan : rfsim.scenes.rss_rooms.FloorPlan
        The floor plan.
    channel : rfsim.channels.rss.RssChannel
        The case's channel (σ = σ0 in the simulation rooms).
    case : int
        The case's index (σ0 × motion), which seeds its trials.
    motion : {"fixed", "mobile"}
        The target's motion.
    n_steps : int
        Beacons per track.
    seed : int
        The run's seed.

    Returns
    -------
    rfsim.scenes.rss_rooms.CaseData
        ``trials`` tracks (simulation) or ``trials`` × 25 (home: the 25 fixed points, or 25
        walks on the two room paths).
    """
    n = _preset(config, "trials", config.trials) * (plan.fixed_points_xy.shape[0] if config.preset == "home-2room" else 1)
    sh = config.shadowing
    return _rooms.draw_beacons(plan, channel, _report(config), case=case, motion=motion, n_tracks=n, n_steps=n_steps,
                               step_std_m=config.step_std_m, decorrelation_m=_preset(config, "decorrelation_m", sh.decorrelation_m),
                               static_fraction=_preset(config, "static_fraction", sh.static_fraction),
                               shared=sh.readers == "shared", people_correlation=sh.people_correlation, seed=seed)


# --------------------------------------------------------------------------- run


def _steps(config: Config, plan: _rooms.FloorPlan, sigma0: float, motion: str) -> tuple[int, dict]:
    """Beacons per track and the recursions rt of each estimator family (the thesis's per σ0 and filter)."""
    if config.preset == "home-2room":
        n_steps = config.home_steps if motion == "fixed" else plan.mobile_paths_xy[0].shape[0]
        return n_steps, {f: n_steps for f in ("grid", "pf")}
    rt = {f: config.recursions or _rooms.RECURSIONS[f].get(round(sigma0, 3), 10) for f in ("grid", "pf")}
    n_steps = max(rt[f] for f in config.estimators if f != "nn") if set(config.estimators) - {"nn"} else 1
    return n_steps, {**rt, "nn": n_steps}


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate every case (σ0 × motion; home: motion) and run its estimators.

    Each case's beacons are drawn, estimated, reduced to rows and freed before the next
    case, so that one case's work is held at a time besides the rows.

    Parameters
    ----------
    config : Config
        The run's config.
    seed : int
        The run's seed (module docstring: randomness).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``beacons``, ``rssi_wide``, ``estimates``, ``summary`` (and ``calibration``,
        ``waveform`` where they apply); the floor plan in the attributes.
    """
    plan = floor_plan(config)
    home = config.preset == "home-2room"
    tables = _rss_tables.Tables()
    nominal = _rooms.rss_channel(plan, config.waf_db)
    offline = _rooms.offline_campaign(nominal, config.waf_db, rng=trial_rng(seed, 10 ** 6)) if home else []
    cases = [(math.nan, m) for m in config.motions] if home else [(s, m) for s in config.sigma0_db for m in config.motions]
    for case, (sigma0, motion) in enumerate(track(cases, desc="cases", unit="cases")):
        channel = nominal if home else _rooms.rss_channel(plan, config.waf_db, sigma_db=sigma0)
        n_steps, rt = _steps(config, plan, sigma0, motion)
        data = simulate_case(config, plan, channel, case, motion, n_steps, seed)
        if config.rss_model == "waveform":
            data.reported_dbm, data.ref_reported_dbm, data.beacon_t_s, st = sample_level_reports(
                config.waveform, plan, channel, data, waf_db=config.waf_db, case=case, seed=seed, report=_report(config))
            tables.extend("waveform", case=case, sigma0_db=sigma0, motion=motion, **st.row())
        common = dict(k=_preset(config, "nn_k", config.nn_k), floor_dbm=_report(config).floor_dbm, step_std_m=config.step_std_m,
                      n_particles=config.particles, rng=trial_rng(seed, case, 1))
        if home:
            path = plan.mobile_paths_xy[0]
            results, cal = est.estimate_home(
                data.reported_dbm, data.ref_reported_dbm, data.pattern_map_dbm, channel, plan,
                reference_xy=plan.reference_xy, offline_alpha_dbm=np.array([r["alpha_dbm"] for r in offline]),
                offline_exponent=np.array([r["exponent"] for r in offline]),
                velocity_xy=(0.0, 0.0) if motion == "fixed" else tuple(path[1] - path[0]), **common)
            tables.add_calibration(case, cal.alpha_dbm, cal.exponent, cal.sigma_db)
            scored = {name: np.ones(n_steps, bool) for name in results}
        else:
            results = est.estimate_simulation(data.reported_dbm, channel, plan, sigma0_db=sigma0, rt=rt,
                                              estimators=config.estimators, **common)
            scored = {name: _rooms.scored_steps(motion, rt[name.split("-")[0]], n_steps) for name in results}
        # 2-D bound on the floor plan (the 0.2 m height difference of the home is neglected)
        crlb = _bounds.log_distance_crlb(data.truth_xy, channel.positions_m[:, :2], channel.exponent,
                                         np.maximum(channel.sigma_db, 1e-3))
        tables.add_case(case, sigma0, motion, data, results, scored, crlb, beacons=config.write_beacons,
                        tag_z_m=plan.tag_height_m, reference_xy=plan.reference_xy)
        for name in results:
            tables.add_summary(case, name, sigma0, motion, _rooms.published(plan.name, len(plan.readers_xy), name, motion,
                                                                            sigma0))
        del data, results, crlb  # only the rows are kept: the next case's work does not overlap this one's
    ds = _dataset.Dataset(title=f"active-RFID RSSI localization (Özkaya 2011), {config.rss_model} mode")
    tables.write(ds, offline)
    ds.attrs.update(preset=plan.name, readers_xy=np.asarray(plan.readers_xy, float), bounds_m=np.asarray(plan.bounds, float),
                    walls_xy=np.asarray(plan.walls_xy, float).reshape(-1, 4), cells_xy=plan.cells_xy,
                    reference_xy=plan.reference_xy, beacon_period_s=BEACON_PERIOD_S, rss_model=config.rss_model,
                    noise_model=_rooms.noise_model(shared=config.shadowing.readers == "shared"))
    return ds


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Floor plan with tracks, error CDF per estimator, RMSE vs σ0 beside the thesis.

    Parameters
    ----------
    dataset_path : Path
        A dataset this scenario wrote.
    out_dir : Path
        Folder of the figures.

    Returns
    -------
    list of Path
        The three figures.
    """
    return [_rss_figures.plot_floor_plan(dataset_path, figure_path(dataset_path, out_dir, "floorplan")),
            _rss_figures.plot_error_cdf(dataset_path, figure_path(dataset_path, out_dir, "cdf")),
            _rss_figures.plot_rmse_vs_sigma(dataset_path, figure_path(dataset_path, out_dir, "rmse"))]

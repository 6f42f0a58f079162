"""Scenario ``st-localization``: tracking a sense-a-tag (ST) from the landmark tags it detects
(AURIS ch. 4: PF-BIN, PF-AA, SQLAM's tracking module, weighted centroid; auris-sense-a-tag.md
§3.3, §4.2, §7; seeds/003 L4493-L4650, L5375-L5415, L5600-L5690; wave2-specs.md §R).

Scene :mod:`rfsim.scenes.landmark_room` (tracks: :mod:`rfsim.scenes.landmark_tracks`): reader
panel(s) 2 m above a floor of landmark tags, the ST moving on the floor, N = 10 rounds per query
period. ``mode``: ``surrogate`` (RTS detections per round of a T_s = 0.3 s period,
:mod:`rfsim.detection.landmark_rts`) or ``sample-level`` (real Gen2 QT rounds heard by the ST,
:mod:`rfsim.scenes.landmark_listening`; periods as long as the rounds take). Trackers:
:mod:`rfsim.estimators.landmark_pf` (``filters``, L4503-L4616, L5393-L5409).

Experiments (reduced unless ``full``): ``speed-sweep`` (Fig. 4.11, L4587-L4605: PF-AA compensating
never / always on trajectory 1, crossover ≈ 1.2 m/s); ``trajectory-2`` (Figs. 4.12-4.14,
L4616-L4636: PF-BIN, PF-AA, WCL; 0.1681 / 0.1717 m at 0.5 m/s); ``random-walk`` (Figs. 4.15,
4.19, L4638-L4650, L5409-L5415, L5657-L5664: PF-AA vs WCL −36.6 % over 1500 s; sqlam: SQLAM vs
WCL −41.9 % over 500 s; lab: SQLAM 0.2560 m over 10,000 s). ``summary.mean_error_m`` is the
source's "average RMSE" (‖x̃_t − x_t‖ at period ends averaged over realizations and periods,
L4507-L4513, L5383-L5385); ``summary.rmse_m`` the time average of RMSE_t (larger).

Measured (seed 1): crossover 1.19 m/s; PF-AA vs WCL −44.6 %; sqlam −37.3 % (0.268 / 0.428 m);
lab 0.316 m (+23 %); trajectory 2 at 0.5 m/s (100 realizations) PF-BIN 0.179 m, PF-AA 0.188 m
(standard errors 0.0014 / 0.0008 m): the detections lag the period end by T_s/2 on average and
this grid carries ≈ 0.2 m of position information. SQLAM's mapping and landmark replacement are
not implemented. Sample level (pfaa, 0.5 m/s, 12 s): 4.72 s periods (694 slots, 450 reads, ≈ 53
replies decoded), PF-BIN 1.62 m, PF-AA 0.99 m, WCL 0.94 m.

Randomness: case c, realization b: ``trial_rng(seed, c, b, 0)`` the walk, ``(…, 1)`` the
detections (sample level ``(…, 2, k)``); tracker f of chunk g ``trial_rng(seed, c, 1000 + g, f)``
(sample level, realization i of chunk g: ``trial_rng(seed, c, 2000 + 100·g + i, f)``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.core.columns import concat
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.procs import map_in_order
from rfsim.core.rng import trial_rng
from rfsim.estimators.landmark_pf import LandmarkFilterConfig
from rfsim.estimators.track_errors import mean_rms_error
from rfsim.scenes import landmark_room as rooms
from rfsim.scenes import landmark_tracks as tracks
from rfsim.scenes.landmark_listening import SampleLevelConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.core.lazy import lazy_import

_dataset = lazy_import("rfsim.core.dataset")
_st_figures = lazy_import("rfsim.scenarios._st_figures")

NAME = "st-localization"
DESCRIPTION = ("sense-a-tag tracking from landmark detections (AURIS ch. 4): RTS surrogate, PF-BIN, PF-AA with "
               "bias compensation, SQLAM tracking, WCL")

#: Published values (seeds/003): RMSE [m] or change vs WCL [%].
PUBLISHED = {
    ("trajectory-2", "pfbin", 0.5): 0.1681,   # L4624
    ("trajectory-2", "pfaa", 0.5): 0.1717,    # L4624
    "crossover_mps": 1.2,                     # L4605
    "pfaa_vs_wcl_percent": -36.6,             # L4650, random walk 1500 s
    "sqlam_vs_wcl_percent": -41.9,            # L5415, 500 s
    "lab_rmse_m": 0.2560,                     # L5664, 10,000 s
}

_EXPERIMENTS = {"pfaa": ("speed-sweep", "trajectory-2", "random-walk"), "sqlam": ("random-walk",), "lab": ("random-walk",)}
_WALK_S = {"pfaa": 1500.0, "sqlam": 500.0, "lab": 10000.0}


@dataclass(frozen=True)
class Config:
    """Configuration of the ``st-localization`` scenario.

    Checked on construction: a non-empty experiment list (or none), at least one landmark,
    trajectory 1 inside the room, sample-level mode only with one reader antenna and not
    with the stamp technique, and a valid random-walk speed range.

    Attributes
    ----------
    preset : {"pfaa", "sqlam", "lab"}, default "pfaa"
        Room, landmark grid and antennas.
    mode : {"surrogate", "sample-level"}, default "surrogate"
        'surrogate' = Bernoulli RTS detections per round; 'sample-level' = the ST
        listens through real Gen2 rounds (rfsim.scenes.landmark_listening).
    sample_level : rfsim.scenes.landmark_listening.SampleLevelConfig
        Sample-level mode: reader, rounds, duration.
    st : rfsim.devices.sense_a_tag_config.SenseATagConfig
        Sample-level mode: the sense-a-tag (technique, threshold).
    experiments : tuple of {"speed-sweep", "trajectory-2", "random-walk"} or None, default None
        Experiments (none = preset: pfaa all three; sqlam and lab random-walk).
    full : bool, default False
        The source's realization counts and durations.
    realizations : int, default 10
        Realizations per case unless full, in [1, 100000].
    landmark_grid : tuple of (int, int) or None, default None
        Landmarks nx, ny (none = preset), each in [1, 1000].
    period_s : float, default 0.3
        Query period T_s (L4597) [s], in [0.001, 100].
    rounds : int, default 10
        Query rounds N per period (L4507), in [1, 1000].
    speeds_mps : tuple of float, default (0.1, 0.3, 0.5, 0.8, 1.0, 1.2, 1.5, 2.0, 2.5, 3.0)
        Speed-sweep speeds on trajectory 1 (L4587) [m/s], in [0.01, 20].
    trajectory_2_speeds_mps : tuple of float, default (0.5, 2.5)
        Trajectory-2 speeds (L4616-L4630) [m/s], in [0.01, 20].
    path_duration_s : float, default 60.0
        Duration on trajectories 1 and 2 [s], in [0.5, 100000].
    walk_duration_s : float or None, default None
        Random-walk duration (none = preset: 1500 pfaa, 500 sqlam, 10000 lab) [s], in
        [0.5, 1e6].
    walk_speed_mps : tuple of (float, float), default (0.1, 3.0)
        Random-walk speed range U[lo, hi] (L4638) [m/s], in [0, 20].
    trajectory_1_xy_m : tuple of (float, float), default :data:`rfsim.scenes.landmark_room.TRAJECTORY_1_XY`
        Trajectory 1 waypoints (closed polyline) [m].
    filters : rfsim.estimators.landmark_pf.LandmarkFilterConfig
        Particle-filter parameters.
    workers : int, default 2
        Worker processes (0 = all cores, 1 = in process), in [0, 256].
    """

    preset: Literal["pfaa", "sqlam", "lab"] = param("pfaa", doc="room, landmark grid and antennas")
    mode: Literal["surrogate", "sample-level"] = param(
        "surrogate", doc="'surrogate' = Bernoulli RTS detections per round; 'sample-level' = the ST listens "
                         "through real Gen2 rounds (rfsim.scenes.landmark_listening)")
    sample_level: SampleLevelConfig = param(SampleLevelConfig(), doc="sample-level mode: reader, rounds, duration")
    st: SenseATagConfig = param(SenseATagConfig(), doc="sample-level mode: the sense-a-tag (technique, threshold)")
    experiments: tuple[Literal["speed-sweep", "trajectory-2", "random-walk"], ...] | None = param(
        None, doc="experiments (none = preset: pfaa all three; sqlam and lab random-walk)")
    full: bool = param(False, doc="the source's realization counts and durations")
    realizations: int = param(10, lo=1, hi=100000, doc="realizations per case unless full")
    landmark_grid: tuple[int, int] | None = param(None, lo=0, hi=1000, doc="nx, ny landmarks (none = preset)")
    period_s: float = param(0.3, lo=1e-3, hi=100.0, unit="s", doc="query period T_s (L4597)")
    rounds: int = param(10, lo=1, hi=1000, doc="query rounds N per period (L4507)")
    speeds_mps: tuple[float, ...] = param((0.1, 0.3, 0.5, 0.8, 1.0, 1.2, 1.5, 2.0, 2.5, 3.0), lo=0.01, hi=20.0,
                                          unit="m/s", doc="speed-sweep speeds on trajectory 1 (L4587)")
    trajectory_2_speeds_mps: tuple[float, ...] = param((0.5, 2.5), lo=0.01, hi=20.0, unit="m/s",
                                                       doc="trajectory-2 speeds (L4616-L4630)")
    path_duration_s: float = param(60.0, lo=0.5, hi=1e5, unit="s", doc="duration on trajectories 1 and 2")
    walk_duration_s: float | None = param(None, lo=0.5, hi=1e6, unit="s",
                                          doc="random-walk duration (none = preset: 1500 pfaa, 500 sqlam, 10000 lab)")
    walk_speed_mps: tuple[float, float] = param((0.1, 3.0), lo=0.0, hi=20.0, unit="m/s",
                                                doc="random-walk speed range U[lo, hi] (L4638)")
    trajectory_1_xy_m: tuple[tuple[float, float], ...] = param(rooms.TRAJECTORY_1_XY, unit="m",
                                                               doc="trajectory 1 waypoints (closed polyline)")
    filters: LandmarkFilterConfig = param(LandmarkFilterConfig(), doc="particle-filter parameters")
    workers: int = param(2, lo=0, hi=256, doc="worker processes (0 = all cores, 1 = in process)")

    def __post_init__(self):
        if self.experiments is not None and not self.experiments:
            raise ConfigError("experiments", [], "a non-empty list of 'speed-sweep', 'trajectory-2', 'random-walk' "
                                                 "or none (the preset's experiments)")
        if 0 in self.room.grid:
            raise ConfigError("landmark_grid", list(self.landmark_grid), "nx, ny >= 1 (at least one landmark)")
        self.room.check_waypoints("trajectory_1_xy_m", self.trajectory_1_xy_m, self.preset)
        if self.mode == "sample-level" and len(self.room.antennas_xyz_m) != 1:
            raise ConfigError("mode", self.mode, f"'surrogate' for preset {self.preset} (sample-level: presets with "
                                                 "one reader antenna, pfaa or sqlam)")
        if self.mode == "sample-level" and self.st.technique == "stamp":
            raise ConfigError("st.technique", self.st.technique, "'single', 'combination' or 'selection'")
        if self.walk_speed_mps[1] < self.walk_speed_mps[0] or self.walk_speed_mps[1] <= 0:
            raise ConfigError("walk_speed_mps", list(self.walk_speed_mps), "[lo, hi] with 0 <= lo <= hi, hi > 0")

    @property
    def room(self) -> rooms.Room:
        """The preset's room with ``landmark_grid`` applied."""
        return rooms.PRESETS[self.preset].with_grid(self.landmark_grid)

    @property
    def experiment_list(self) -> tuple[str, ...]:
        """The experiments in effect (``experiments``, or the preset's; sample-level pfaa: trajectory-2)."""
        if self.experiments is not None:
            return self.experiments
        return ("trajectory-2",) if self.mode == "sample-level" and self.preset == "pfaa" else _EXPERIMENTS[self.preset]

    @property
    def walk_s(self) -> float:
        """Random-walk duration in effect [s] (``walk_duration_s``, or the preset's)."""
        return self.walk_duration_s if self.walk_duration_s is not None else _WALK_S[self.preset]


@dataclass(frozen=True)
class Case:
    """One case: experiment, path, speed, realizations, duration, trackers (label, kind, v_threshold).

    Attributes
    ----------
    index : int
        Position of the case in :func:`cases`.
    experiment : str
        ``"speed-sweep"``, ``"trajectory-2"`` or ``"random-walk"``.
    trajectory : str
        ``"1"``, ``"2"`` or ``"random-walk"``.
    speed_mps : float
        Constant speed on trajectories 1 and 2 [m/s]; NaN for the random walk.
    realizations : int
        Independent realizations of the case.
    duration_s : float
        Tracking duration [s].
    trackers : tuple of (str, str, float)
        Per tracker: label, kind (``"pfbin"``, ``"pfaa"``, ``"wcl"``) and the PF-AA
        compensation speed threshold [m/s] (0: always, inf: never).
    """

    index: int
    experiment: str
    trajectory: str
    speed_mps: float
    realizations: int
    duration_s: float
    trackers: tuple[tuple[str, str, float], ...]


def cases(config: Config) -> list[Case]:
    """Every case of the configured experiments (module docstring), in order.

    Parameters
    ----------
    config : Config
        Scenario configuration.

    Returns
    -------
    list of Case
        The cases; with ``full`` the source's realization counts, in sample-level mode the
        realizations and duration of ``sample_level``.
    """
    out: list[Case] = []
    full, R, vt = config.full, config.realizations, config.filters.v_threshold_mps
    for exp in config.experiment_list:
        if exp == "speed-sweep":
            for v in config.speeds_mps:
                out.append(Case(len(out), exp, "1", v, 100 if full else R, config.path_duration_s,
                                (("pfaa-never", "pfaa", np.inf), ("pfaa-always", "pfaa", 0.0))))
        elif exp == "trajectory-2":
            for v in config.trajectory_2_speeds_mps:
                n = (500 if v >= 2.5 else 100) if full else R
                out.append(Case(len(out), exp, "2", v, n, config.path_duration_s,
                                (("pfbin", "pfbin", 0.0), ("pfaa", "pfaa", vt), ("wcl", "wcl", 0.0))))
        else:
            main = ("pfaa", "pfaa", vt) if config.preset == "pfaa" else ("sqlam", "pfaa", np.inf)
            n = (100 if config.preset == "sqlam" else 1) if full else (R if config.preset == "sqlam" else 1)
            out.append(Case(len(out), exp, "random-walk", np.nan, n, config.walk_s, (main, ("wcl", "wcl", 0.0))))
    sl, sample = config.sample_level, config.mode == "sample-level"
    return [replace(c, realizations=sl.realizations, duration_s=sl.duration_s) for c in out] if sample else out


def truth_at(config: Config, case: Case, b: int, seed: int, t_s) -> np.ndarray:
    """True ST positions at times ``t_s`` (…, 2) for realization b of the case.

    Parameters
    ----------
    config : Config
        Scenario configuration (room, trajectory 1, walk speeds).
    case : Case
        The case (trajectory and speed).
    b : int
        Realization index; the random walk draws from ``trial_rng(seed, case.index, b, 0)``.
    seed : int
        Root seed.
    t_s : array_like
        Times [s].

    Returns
    -------
    ndarray, shape (..., 2)
        True ST positions (x, y) [m] at ``t_s``.
    """
    return rooms.path_positions(case.trajectory, t_s, speed_mps=case.speed_mps, trajectory_1_xy=config.trajectory_1_xy_m,
                                bounds_m=config.room.bounds_m, walk_speed_mps=config.walk_speed_mps,
                                walk_rng=partial(trial_rng, seed, case.index, b, 0))


def _track(config: Config, case: Case, b: int, seed: int) -> dict:
    """Realization b's track (:mod:`rfsim.scenes.landmark_tracks`): surrogate detections (stream
    ``trial_rng(seed, case, b, 1)``) or heard at sample level (``trial_rng(seed, case, b, 2, k)``)."""
    position_at = partial(truth_at, config, case, b, seed)
    if config.mode == "sample-level":
        return tracks.listened_track(config.room, position_at, height_m=config.sample_level.st_height_m,
                                     rounds=config.rounds, sl=config.sample_level, st_config=config.st, seed=seed,
                                     key=(case.index, b, 2))
    return tracks.surrogate_track(config.room, position_at, duration_s=case.duration_s, period_s=config.period_s,
                                  rounds=config.rounds, rng=trial_rng(seed, case.index, b, 1))


def simulate_chunk(config: Config, case: Case, group: int, bs: list[int], seed: int) -> dict[str, dict]:
    """Detections and every tracker of realizations ``bs`` of ``case``: per-table columns (the
    trackers on the chunk at once; at sample level, with unequal period counts, per realization).

    Parameters
    ----------
    config : Config
        Scenario configuration.
    case : Case
        The case.
    group : int
        Index of the chunk within the case (the trackers' streams).
    bs : list of int
        Realization indices of the chunk.
    seed : int
        Root seed.

    Returns
    -------
    dict of str to dict
        Columns of the tables ``periods``, ``detections``, ``estimates`` and ``reads``
        (:func:`rfsim.scenes.landmark_tracks.chunk_tables`).
    """
    chunk = [_track(config, case, b, seed) for b in bs]
    f, N, n = config.filters, config.rounds, len(case.trackers)
    if config.mode == "sample-level":  # tracker streams (seed, c, 2000 + 100·g + i, f)
        est = [tracks.track_estimates(config.room, [d], case.trackers, filters=f, rounds=N, rngs=[
            trial_rng(seed, case.index, 2000 + 100 * group + i, k) for k in range(n)]) for i, d in enumerate(chunk)]
    else:
        est = tracks.track_estimates(config.room, chunk, case.trackers, filters=f, rounds=N,
                                     rngs=[trial_rng(seed, case.index, 1000 + group, k) for k in range(n)])
        est = [{k: v[i:i + 1] for k, v in est.items()} for i in range(len(chunk))]
    rows = [tracks.estimate_rows(case.index, b, d, {k: x[0] for k, x in e.items()}) for b, d, e in zip(bs, chunk, est)]
    return tracks.chunk_tables(case.index, bs, chunk, rows, config.room, len(case.trackers))


def _task(args):
    return simulate_chunk(*args)


def monte_carlo(config: Config, *, seed: int) -> dict[str, dict[str, np.ndarray]]:
    """Every case in chunks of ≤ 10 realizations on ``config.workers`` processes, in order.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed.

    Returns
    -------
    dict of str to dict of str to ndarray
        The tables ``periods``, ``detections``, ``estimates`` and ``reads`` of every chunk,
        concatenated in case and chunk order.
    """
    tasks = [(config, c, g, list(range(a, min(a + 10, c.realizations))), seed) for c in cases(config)
             for g, a in enumerate(range(0, c.realizations, 10))]
    parts = map_in_order(_task, tasks, config.workers, desc="cases", unit="chunks")
    return {n: concat([p[n] for p in parts]) for n in ("periods", "detections", "estimates", "reads")}


def summarize(config: Config, tables) -> tuple[dict[str, np.ndarray], dict]:
    """One row per (case, tracker): the source's average RMSE (the ℓ2 error averaged over
    realizations and periods, L4507-L4513, L5383-L5385) beside the published value, the RMS error
    (:func:`rfsim.estimators.track_errors.mean_rms_error`), the change vs WCL (of the source's
    measure); and the headline numbers (crossover speed, PF-AA / SQLAM vs WCL, lab) as attributes,
    all of the source's measure.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    tables : dict of str to dict
        The tables of :func:`monte_carlo` (uses ``estimates``).

    Returns
    -------
    summary : dict of str to ndarray
        One row per (case, tracker): case, experiment, trajectory, speed [m/s],
        realizations, duration [s], tracker, ``mean_error_m``, ``rmse_m``,
        ``published_rmse_m`` [m], ``vs_wcl_percent`` and ``published_vs_wcl_percent`` [%].
    attrs : dict
        Headline numbers: ``crossover_mps`` (speed where always-compensating PF-AA beats
        never-compensating, linear interpolation; NaN when the curves do not cross) and the
        published one, ``<tracker>_vs_wcl_percent``, ``<tracker>_random_walk_rmse_m`` and,
        for the lab preset, ``published_lab_rmse_m``.
    """
    est, rows, attrs, sweep = tables["estimates"], [], {}, {}
    pub_rel = {"pfaa": PUBLISHED["pfaa_vs_wcl_percent"], "sqlam": PUBLISHED["sqlam_vs_wcl_percent"]}.get(config.preset, np.nan)
    for c in cases(config):
        sel = {label: (est["case"] == c.index) & (est["tracker"] == label) for label, _, _ in c.trackers}
        vals = {label: float(np.mean(est["error_m"][m])) if m.any() else float("nan") for label, m in sel.items()}
        for label, value in vals.items():
            rel = 100.0 * (value / vals["wcl"] - 1.0) if "wcl" in vals and label != "wcl" else np.nan
            walk = c.experiment == "random-walk" and label != "wcl"
            if walk:
                attrs[f"{label}_vs_wcl_percent"] = rel
                attrs[f"{label}_random_walk_rmse_m"] = value
            rows.append((c.index, c.experiment, c.trajectory, c.speed_mps, c.realizations, c.duration_s, label, value,
                         mean_rms_error(est["period"][sel[label]], est["error_m"][sel[label]]),
                         PUBLISHED.get((c.experiment, label, c.speed_mps), np.nan), rel, pub_rel if walk else np.nan))
            if c.experiment == "speed-sweep":
                sweep.setdefault(label, []).append(value)
    if sweep:
        diff = np.asarray(sweep["pfaa-always"]) - np.asarray(sweep["pfaa-never"])
        v = np.asarray(config.speeds_mps, float)
        cross = np.flatnonzero((diff[:-1] > 0) & (diff[1:] <= 0))
        attrs["crossover_mps"] = float(v[cross[0]] - diff[cross[0]] * (v[cross[0] + 1] - v[cross[0]]) /
                                       (diff[cross[0] + 1] - diff[cross[0]])) if cross.size else np.nan
        attrs["published_crossover_mps"] = PUBLISHED["crossover_mps"]
    if config.preset == "lab":
        attrs["published_lab_rmse_m"] = PUBLISHED["lab_rmse_m"]
    keys = ("case", "experiment", "trajectory", "speed_mps", "realizations", "duration_s", "tracker", "mean_error_m",
            "rmse_m", "published_rmse_m", "vs_wcl_percent", "published_vs_wcl_percent")
    return {k: np.asarray(v) for k, v in zip(keys, zip(*rows))}, attrs


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate sense-a-tag tracking from landmark detections and score the trackers.

    Reproduces AURIS ch. 4 (auris-sense-a-tag.md §3.3, §4.2, §7; seeds/003 L4493–L4650,
    L5375–L5415, L5600–L5690): Fig. 4.11 (speed sweep), Figs. 4.12–4.14 (trajectory 2),
    Figs. 4.15 and 4.19 (random walk) with PF-BIN, PF-AA, SQLAM's tracking module and WCL.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed (the streams of the module docstring).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``detections``, ``periods``, ``truth`` (true position per period end [m]),
        ``estimates`` (per tracker and period: estimate and error [m]), ``summary`` (from
        :func:`summarize`), ``cases`` and, in sample-level mode, ``reads`` (the reader's reads
        of the landmarks, per-read schema); root attributes with the room (bounds,
        landmarks, antennas, trajectories [m]), the query period [s] and the headline numbers
        beside the published ones.
    """
    tables = monte_carlo(config, seed=seed)
    summary, attrs = summarize(config, tables)
    tables["summary"] = summary
    cs = cases(config)
    tables["truth"] = {k: tables["periods"][k] for k in ("case", "realization", "period", "t_end_s", "x_true_m",
                                                         "y_true_m")}
    tables["cases"] = {k: np.array([getattr(c, "index" if k == "case" else k) for c in cs]) for k in (
        "case", "experiment", "trajectory", "speed_mps", "realizations", "duration_s")}
    ds = _dataset.Dataset(title=f"sense-a-tag localization from landmark detections (AURIS ch. 4), preset {config.preset}")
    for name in ("detections", "periods", "truth", "estimates", "summary", "cases"):
        ds.add_table(name, {k: _dataset.column(v, _unit(k), _TEXT.get(k, k.replace("_", " "))) for k, v in tables[name].items()},
                     description=_GROUPS[name])
    if tables["reads"]:  # sample level: the reader's reads of the landmarks (per-read schema, rfsim.core.reads)
        ds.add_table("reads", tracks.reads_columns(tables["reads"]), description=_GROUPS["reads"])
    room = config.room
    ds.attrs.update({"preset": config.preset, "mode": config.mode, "bounds_m": np.asarray(room.bounds_m),
                     "landmarks_xy_m": room.landmarks_xy(), "antennas_xyz_m": np.asarray(room.antennas_xyz_m),
                     "trajectory_1_xy_m": np.asarray(config.trajectory_1_xy_m, float),
                     "trajectory_2_xy_m": rooms.trajectory_2_xy(200), "detection_period_s": config.period_s})
    if config.mode == "sample-level":
        per = tables["periods"]
        ds.attrs.update({"detection_period_s": float(np.mean(per["period_duration_s"])),
                         "detection_period_std_s": float(np.std(per["period_duration_s"])),
                         "source_detection_period_s": config.period_s, "slots_per_period": float(np.mean(per["slots"])),
                         "reads_per_period": float(np.mean(per["reads"])),
                         "detection_period_meaning": "mean duration of a query period of N QT rounds at sample "
                                                     "level (the source assumed 0.3 s)"})
    ds.attrs.update(attrs)
    for key in [k for k, v in ds.attrs.items() if isinstance(v, float) and not np.isfinite(v)]:
        ds.attrs[f"{key}_meaning"] = "NaN: the curves do not cross inside the swept speeds (or no WCL reference)"
    return ds


def _unit(key: str) -> str:
    return next((u for suf, u in (("_percent", "%"), ("_mps", "m/s"), ("_m", "m"), ("_s", "s")) if key.endswith(suf)), "1")


_TEXT = {
    **tracks.COLUMN_TEXT, "case": "index of the case (experiment, trajectory, speed) in the cases table",
    "tracker": "tracker: wcl, pfbin, pfaa (v_threshold), pfaa-never / pfaa-always, sqlam",
    "experiment": "speed-sweep, trajectory-2 or random-walk", "realizations": "realizations of the case",
    "trajectory": "trajectory: 1, 2 (Fig. 4.10 replicas) or random-walk", "duration_s": "tracking duration of the case",
    "speed_mps": "constant speed on trajectories 1 and 2 (NaN for the random walk)",
    "mean_error_m": "the source's average RMSE: the l2 error averaged over realizations and periods (L4507, L5383)",
    "rmse_m": "time average of the RMS error over realizations",
    "published_rmse_m": "the source's average RMSE (compare mean_error_m; NaN: none)",
    "vs_wcl_percent": "change of mean_error_m against WCL on the same detections",
    "published_vs_wcl_percent": "the source's change against WCL (L4650, L5415; NaN: none)"}

_GROUPS = {
    **tracks.TABLE_TEXT, "summary": "one row per (case, tracker): RMSE beside the published value and the change vs WCL",
    "cases": "one row per case: experiment, trajectory, speed, realizations, duration",
}


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Room with landmarks and tracks, error vs time, error CDF, speed sweep, RMSE vs published.

    Parameters
    ----------
    dataset_path : pathlib.Path
        A dataset written by :func:`run`.
    out_dir : pathlib.Path
        Folder of the figures.

    Returns
    -------
    list of pathlib.Path
        The written figure files.
    """
    return _st_figures.plot_all(Path(dataset_path), Path(out_dir))


__all__ = ["NAME", "DESCRIPTION", "Config", "run", "plot", "cases", "simulate_chunk", "summarize", "PUBLISHED"]

"""Scenario ``tag-to-tag-tracking``: Geng's reader-free self-tracking of a mobile tag from the
broadcasts of reference tags (binary-detection.md §1.11, §2.4, §3.4; seeds/004 L1049-L1260;
wave2-specs.md §X).

Scene: an RF exciter powers 10 reference tags on the two shelves of a 2 m wide warehouse aisle
(L1203; the layout of Fig. 6.3 is not in the text — default: 5 tags per shelf face, y = ±1 m,
x = 0, 2, …, 8 m, the pair at x = 0 being the portal; recorded in the dataset). Each tag
broadcasts its location once per T_s = 0.5 s in a random slotted-Aloha slot (L1068, L1084;
50 slots by default, the seed gives none); a mobile tag that enters the aisle at the portal and
moves by the motion model (6.1) (Q = diag(0.01, 0.01), initial speed U[0.1, 1] m/s along the
aisle, 12 s, L1203-L1212) decodes what reaches it (``range_model``, ``collision_model``:
:mod:`rfsim.detection.tag_to_tag`, :mod:`rfsim.scenes.reference_tags`) and records y_k = l_i (L1089).

Trackers (:mod:`rfsim.estimators.proximity`): NN (association, L1099), KF with H = I⊗[1 0] and
G = diag(r²/2, r²/2) (L1115-L1119), the Bernoulli PF with Eq. (6.5) (M = 10/20/30, L1125,
L1246) and the RBPF of Table 6.1 (M = 30). All start from "the prior knowledge of the states"
(Table 6.1): N(true initial state, diag(σ_p², σ_v², σ_p², σ_v²)), σ_p = σ_v = 0.3 (m, m/s; the
seed gives no prior). The filters' Eq. (6.5) — "a1 and a2 from real experimental data" (L1125),
not printed — is the ``exciter-link`` fit (pooled a1 = −2.523, a2 = 5.028 /m, d50 = 0.50 m for
the default exciter and listener) stretched so that p(r) = 0.5: a1 = −2.523, a2 = 2.523/r; with
``range_model = "logistic"`` the mobile tag decodes by that same curve. 100 trajectories × 50
filter runs (L1214-L1219); KF and NN are deterministic given the observations (one run).

Measured (default config, seed 1, 100 × 50; 34 s CPU in one process) against Table 6.2: NN 1.167/1.411/1.637 m
(+9/+5/+5 %), PF M = 10 +13…+17 %, M = 20 −6…−8 %, M = 30 −14…−20 %, RBPF within 2 % of PF30;
PF error falling with M and rising with r, RBPF ≈ PF30. Not reproduced: the KF, 0.294/0.289/
0.320 m (published 0.561/0.820/1.078 m), so NN − KF = 0.87/1.12/1.32 m (published ≈ 0.5 m) and
the KF, not PF30, is the best tracker here.

Why the KF differs from Table 6.2 (the readings of the text tried, and what would reproduce it):
:mod:`rfsim.estimators.proximity_trackers`. The readings L1203 leaves open are config keys:
the tag layout ``layout.tag_layout`` (:data:`rfsim.scenes.aisle.NAMED_LAYOUTS`), "[0.1, 1] m/s"
as a speed range along the aisle or a velocity vector (``motion.initial_velocity``,
``motion.initial_velocity_mps``), and the trackers' prior ``trackers.prior`` (true initial
state, the portal, or the first decode). Over the grid 5 layouts × 3 motions × 3 priors × r
(seed 1, 100 trajectories; table on the docs page) the KF row is reproduced (within 25 % at
every r and NN − KF = 0.5 ± 0.15 m) only with the velocity read as a vector — 1 m/s across
the aisle, the tag bouncing between the shelves (e.g. ``short-1m``, true prior: KF
0.64/0.78/0.96 m, seeds 1-3 within ± 0.015 m, NN 1.04/1.38/1.57 m; with the speed reading
0.20/0.32/0.51 m) — or 1 m/s along it with a prior that does not know the velocity; the
motion or prior the KF's constant-velocity model cannot follow is what makes it grow with r
(test ``test_kf_row_follows_the_velocity_reading``). In none of them do the PFs reproduce:
PF30 is 0.6-3.0 m there (published 0.52-0.58 m), above the KF in every reading, so Table 6.2
as a whole is not reproduced by any reading tried (strict xfails).

Error metric: per run, RMSE = sqrt(mean over the run's observation instants of ‖x̂ − x‖²);
"average RMSE" of Table 6.2 = the mean of the RMSEs over trajectories and runs (trajectories
with no decode have no estimate and are counted in ``summary/undecoded_trajectories``).

``range_model = "physical"`` and ``collision_model = "physical"`` decode slots at sample level
(:mod:`rfsim.scenes.reference_tags`, which also gives what they measure).

Randomness: trajectory j uses ``trial_rng(seed, j, s)``: s = 0 motion, 1 broadcast slots,
2 + i the reception draws at the i-th range (and the physical slots' channel draws, noise and
tags), 100 + 10·i + f the filter f at range i (prior draws, propagation, resampling); the
physical threshold calibration at range i ``trial_rng(seed, 10**6, i)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.core.columns import concat, unit_of
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.procs import map_in_order
from rfsim.core.rng import trial_rng
from rfsim.detection.tag_to_tag import Eq65Config
from rfsim.estimators.proximity_trackers import PUBLISHED_TABLE_6_2, TrackerConfig, prior_for, run_tracker
from rfsim.protocols.tag_to_tag import AlohaConfig, aloha_schedule
from rfsim.scenes.aisle import AisleConfig, MotionConfig, position_at, simulate_motion
from rfsim.scenes.reference_tags import ReferenceTagsConfig, calibrate_threshold, receive_broadcasts

_dataset = lazy_import("rfsim.core.dataset")
_figures = lazy_import("rfsim.scenarios._tag_to_tag_tracking_figures")

NAME = "tag-to-tag-tracking"
DESCRIPTION = ("reader-free self-tracking of a mobile tag from reference-tag broadcasts (Geng ch. 6): "
               "slotted Aloha, NN / KF / Bernoulli PF / RBPF, Table 6.2")

@dataclass(frozen=True)
class Config:
    """Configuration of the ``tag-to-tag-tracking`` scenario.

    Checked on construction: at least one reference tag, ranges r > 0, a valid speed
    range, a motion step no longer than the run, and a start inside the aisle.

    Attributes
    ----------
    ranges_m : tuple of float, default (1.5, 2.0, 2.5)
        Sensing ranges r (L1247) [m].
    range_model : {"disc", "logistic", "physical"}, default "disc"
        'disc' = decoded iff d <= r; 'logistic' = Eq. (6.5) fitted by exciter-link;
        'physical' = sample-level decode through the air interface (threshold calibrated
        to r).
    collision_model : {"loss", "physical"}, default "loss"
        'loss' = every collided broadcast is lost (L1084); 'physical' = collided slots
        superpose at waveform level and the strongest frame may still decode.
    trajectories : int, default 100
        Trajectories (L1214), in [1, 1e6].
    filter_runs : int, default 50
        Independent PF/RBPF runs per trajectory (L1219), in [1, 100000].
    workers : int, default 2
        Worker processes (0 = all cores, 1 = in process), in [0, 256].
    layout : rfsim.scenes.aisle.AisleConfig
        Reference tags, aisle, exciter.
    motion : rfsim.scenes.aisle.MotionConfig
        Mobile tag motion (6.1).
    protocol : rfsim.protocols.tag_to_tag.AlohaConfig
        All-tag-talk slotted Aloha.
    range : rfsim.detection.tag_to_tag.Eq65Config
        Eq. (6.5) coefficients of the logistic range model.
    trackers : rfsim.estimators.proximity_trackers.TrackerConfig
        Particle counts and priors.
    physical : rfsim.scenes.reference_tags.ReferenceTagsConfig
        Sample-level link of the physical models.
    write_estimates : bool, default True
        Write the per-observation estimates of run 0.
    """

    ranges_m: tuple[float, ...] = param((1.5, 2.0, 2.5), unit="m", doc="sensing ranges r (L1247)")
    range_model: Literal["disc", "logistic", "physical"] = param(
        "disc", doc="'disc' = decoded iff d <= r; 'logistic' = Eq. (6.5) fitted by exciter-link; 'physical' = "
                    "sample-level decode through the air interface (threshold calibrated to r)")
    collision_model: Literal["loss", "physical"] = param(
        "loss", doc="'loss' = every collided broadcast is lost (L1084); 'physical' = collided slots superpose at "
                    "waveform level and the strongest frame may still decode")
    trajectories: int = param(100, lo=1, hi=1_000_000, doc="trajectories (L1214)")
    filter_runs: int = param(50, lo=1, hi=100000, doc="independent PF/RBPF runs per trajectory (L1219)")
    workers: int = param(2, lo=0, hi=256, doc="worker processes (0 = all cores, 1 = in process)")
    layout: AisleConfig = param(AisleConfig(), doc="reference tags, aisle, exciter")
    motion: MotionConfig = param(MotionConfig(), doc="mobile tag motion (6.1)")
    protocol: AlohaConfig = param(AlohaConfig(), doc="all-tag-talk slotted Aloha")
    range: Eq65Config = param(Eq65Config(), doc="Eq. (6.5) coefficients of the logistic range model")
    trackers: TrackerConfig = param(TrackerConfig(), doc="particle counts and priors")
    physical: ReferenceTagsConfig = param(ReferenceTagsConfig(), doc="sample-level link of the physical models")
    write_estimates: bool = param(True, doc="write the per-observation estimates of run 0")

    def __post_init__(self):
        if len(self.layout.tags_xy_m) == 0:
            raise ConfigError("layout.tags_xy_m", [], "at least one reference tag (x, y) in m")
        if len(self.ranges_m) == 0 or any(not r > 0 for r in self.ranges_m):
            raise ConfigError("ranges_m", list(self.ranges_m), "one or more decoding radii r > 0 m")
        m = self.motion
        if m.speed_max_mps < m.speed_min_mps:
            raise ConfigError("motion.speed_max_mps", m.speed_max_mps, f">= motion.speed_min_mps = {m.speed_min_mps}")
        if m.dt_s > m.duration_s:
            raise ConfigError("motion.dt_s", m.dt_s, f"<= motion.duration_s = {m.duration_s}")
        if not abs(m.start_xy_m[1]) <= self.layout.y_limit_m:
            raise ConfigError("motion.start_xy_m", list(m.start_xy_m),
                              f"a start inside the aisle, |y| <= {self.layout.y_limit_m:g} m "
                              "(half width minus the shelf clearance)")

    @property
    def uses_physical(self) -> bool:
        """Whether the range or the collision model decodes at sample level (``"physical"``)."""
        return self.range_model == "physical" or self.collision_model == "physical"


# ----------------------------------------------------------------------------- one trajectory


def filter_coefficients(config: Config, range_m: float) -> tuple[float, float]:
    """The (6.5) coefficients the PF/RBPF use at range r (module docstring).

    With ``trackers.likelihood = "exciter-link"`` the ``range`` coefficients stretched to
    p(r) = 0.5; otherwise a2 = ``trackers.slope_per_m`` and a1 = −a2·r.

    Parameters
    ----------
    config : Config
        Scenario configuration (``trackers``, ``range``).
    range_m : float
        Sensing range r [m].

    Returns
    -------
    a1 : float
        Intercept of Eq. (6.5), p(d) = 1/(1 + exp(a1 + a2·d)).
    a2 : float
        Slope of Eq. (6.5) [1/m].
    """
    if config.trackers.likelihood == "exciter-link":
        return config.range.coefficients(range_m)
    a2 = config.trackers.slope_per_m
    return -a2 * range_m, a2


def track(config: Config, range_m: float, times_s, observed_xy, truth_xy, x0, *, rngs) -> list[dict]:
    """Every tracker on one observation sequence at range r: per tracker, estimates (runs, T, 2) and RMSEs
    (:func:`rfsim.estimators.proximity_trackers.run_tracker`), from the prior ``trackers.prior``
    (:func:`rfsim.estimators.proximity_trackers.prior_for`; ``x0`` the true initial state).

    Parameters
    ----------
    config : Config
        Scenario configuration (``trackers``, ``motion``, ``filter_runs``).
    range_m : float
        Sensing range r [m].
    times_s : ndarray, shape (T,)
        Observation instants [s].
    observed_xy : ndarray, shape (T, 2)
        Observations y_k: positions of the decoded reference tags [m].
    truth_xy : ndarray, shape (T, 2)
        True mobile-tag positions at the observations [m].
    x0 : ndarray, shape (4,)
        True initial state (x, v_x, y, v_y) [m, m/s].
    rngs : sequence of numpy.random.Generator
        One stream per tracker of ``trackers.labels``.

    Returns
    -------
    list of dict
        Per tracker: ``label``, ``kind``, ``m`` (particles), ``estimates`` (runs, T, 2) [m],
        ``error_m`` (runs, T) [m] and ``rmse_m`` (runs,) [m].
    """
    t, a1, a2 = config.trackers, *filter_coefficients(config, range_m)
    t0, mean, sd = prior_for(t.prior, x0, config.motion.start_xy_m, times_s, observed_xy, range_m=range_m,
                             position_std_m=t.prior_position_std_m, velocity_std_mps=t.prior_velocity_std_mps)
    out = []
    for (label, kind, m), rng in zip(config.trackers.labels, rngs):
        est = run_tracker(kind, times_s, observed_xy, mean, m=m, n_runs=config.filter_runs, range_m=range_m,
                          accel_var=config.motion.accel_var, a1=a1, a2=a2, position_std_m=sd[0],
                          velocity_std_mps=sd[1], rng=rng, t0_s=t0, from_first=t.prior == "first-decode")
        err = np.linalg.norm(est - truth_xy[None], axis=-1)
        out.append({"label": label, "kind": kind, "m": m, "estimates": est, "error_m": err,
                    "rmse_m": np.sqrt(np.mean(err * err, axis=-1))})
    return out


def simulate_trajectory(config: Config, j: int, seed: int, thresholds_v=None) -> dict[str, dict[str, np.ndarray]]:
    """Motion, broadcasts, receptions and every tracker of trajectory ``j``: per-table columns.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    j : int
        Trajectory index; its streams are ``trial_rng(seed, j, s)`` (module docstring).
    seed : int
        Root seed.
    thresholds_v : sequence of float, optional
        The listener threshold per range [V] for the physical models (:func:`calibrate`);
        None (default) for the disc and logistic models.

    Returns
    -------
    dict of str to dict of str to ndarray
        Columns of the tables ``truth`` (motion grid: time [s], position [m], velocity
        [m/s]), ``broadcasts`` (slot, time, tag, collision), ``receptions`` (per range and
        broadcast: distance [m], reached, decoded, reason), ``observations`` (per decode:
        the observed tag position y_k and the true position [m]) and, where the
        trajectory has decodes, ``runs`` (per tracker and filter run: RMSE [m]) and
        ``estimates`` (filter run 0's estimates and errors [m]).
    """
    m, p, lay, c = config.motion, config.protocol, config.layout, config.range
    tags = np.asarray(lay.tags_xy_m, float)
    t_grid, states = simulate_motion(trial_rng(seed, j, 0), duration_s=m.duration_s, dt_s=m.dt_s, start_xy_m=m.start_xy_m,
                                     speed_range_mps=(m.speed_min_mps, m.speed_max_mps), accel_var=m.accel_var,
                                     y_limit_m=lay.y_limit_m, velocity_xy_mps=m.initial_velocity_xy_mps)
    b = aloha_schedule(trial_rng(seed, j, 1), n_tags=tags.shape[0], duration_s=m.duration_s, period_s=p.period_s,
                       n_slots=p.n_slots)
    pos = position_at(t_grid, states, b["t_s"])
    dist = np.linalg.norm(pos - tags[b["tag"]], axis=1)
    n_b = b["t_s"].size
    tables = {"truth": {"trajectory": np.full(t_grid.size, j), "t_s": t_grid, "x_m": states[:, 0],
                        "vx_mps": states[:, 1], "y_m": states[:, 2], "vy_mps": states[:, 3]},
              "broadcasts": {"trajectory": np.full(n_b, j), "broadcast": np.arange(n_b), **b,
                             "tag_x_m": tags[b["tag"], 0], "tag_y_m": tags[b["tag"], 1],
                             "collided": b["n_in_slot"] > 1}}
    rec, obs, est, runs = [], [], [], []
    for i, r in enumerate(config.ranges_m):
        th = thresholds_v[i] if thresholds_v is not None else np.nan
        a1, a2 = c.coefficients(r)
        reach, decoded = receive_broadcasts(
            config.physical, lay.exciter_xyz_m, tags, b, pos, dist, range_model=config.range_model, a1=a1, a2=a2,
            collision_model=config.collision_model, range_m=r, n_slots=p.n_slots, threshold_v=th,
            rng=trial_rng(seed, j, 2 + i))
        reason = np.where(decoded, "", np.where(b["n_in_slot"] > 1, "collision", "out of range"))
        rec.append(_rows(n_b, j, r, broadcast=np.arange(n_b), distance_m=dist, reached=reach, decoded=decoded,
                         reason=reason))
        k = np.flatnonzero(decoded)
        obs.append(_rows(k.size, j, r, observation=np.arange(k.size), broadcast=k, t_s=b["t_s"][k], tag=b["tag"][k],
                         y_x_m=tags[b["tag"][k], 0], y_y_m=tags[b["tag"][k], 1], x_true_m=pos[k, 0],
                         y_true_m=pos[k, 1], distance_m=dist[k]))
        if k.size == 0:
            continue
        rngs = [trial_rng(seed, j, 100 + 10 * i + f) for f in range(len(config.trackers.labels))]
        for res in track(config, r, b["t_s"][k], tags[b["tag"][k]], pos[k], states[0], rngs=rngs):
            n_runs = res["rmse_m"].size
            runs.append(_rows(n_runs, j, r, tracker=np.full(n_runs, res["label"]), particles=np.full(n_runs, res["m"]),
                              run=np.arange(n_runs), observations=np.full(n_runs, k.size), rmse_m=res["rmse_m"]))
            if config.write_estimates:
                e0 = res["estimates"][0]
                est.append(_rows(k.size, j, r, tracker=np.full(k.size, res["label"]), observation=np.arange(k.size),
                                 t_s=b["t_s"][k], x_est_m=e0[:, 0], y_est_m=e0[:, 1], x_true_m=pos[k, 0],
                                 y_true_m=pos[k, 1], error_m=res["error_m"][0]))
    parts = {"receptions": rec, "observations": obs, "runs": runs, "estimates": est}
    return {**tables, **{name: concat(rows) for name, rows in parts.items() if rows}}


def _rows(n: int, j: int, r: float, **columns) -> dict[str, np.ndarray]:
    """n rows of trajectory j at range r: the trajectory and range columns, then ``columns``."""
    return {"trajectory": np.full(n, j), "range_m": np.full(n, r), **columns}


def _task(args):
    config, js, seed, th = args
    return [simulate_trajectory(config, j, seed, th) for j in js]


def calibrate(config: Config, *, seed: int) -> list[tuple[float, float, float]]:
    """Per range: (threshold [V], min, max decode fraction at r over the tags) of the physical
    listener (:func:`rfsim.scenes.reference_tags.calibrate_threshold`, ``trial_rng(seed, 10**6, i)``).

    Parameters
    ----------
    config : Config
        Scenario configuration (``physical``, ``layout``, ``ranges_m``).
    seed : int
        Root seed.

    Returns
    -------
    list of tuple of (float, float, float)
        Per range: the threshold [V] and the smallest and largest decode fraction at r over
        the reference tags.
    """
    return [calibrate_threshold(config.physical, config.layout.exciter_xyz_m, config.layout.tags_xy_m, r,
                                trial_rng(seed, 10 ** 6, i)) for i, r in enumerate(config.ranges_m)]


def monte_carlo(config: Config, *, seed: int, thresholds_v=None) -> dict[str, dict[str, np.ndarray]]:
    """Every trajectory on ``config.workers`` processes (chunks of 5), tables concatenated in order.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed.
    thresholds_v : sequence of float, optional
        The physical listener's threshold per range [V] (:func:`calibrate`); None (default)
        without the physical models.

    Returns
    -------
    dict of str to dict of str to ndarray
        The tables of :func:`simulate_trajectory` over every trajectory.
    """
    chunks = [list(range(a, min(a + 5, config.trajectories))) for a in range(0, config.trajectories, 5)]
    tasks = [(config, js, seed, thresholds_v) for js in chunks]
    parts = [t for chunk in map_in_order(_task, tasks, config.workers, desc="trajectories", unit="chunks") for t in chunk]
    names = dict.fromkeys(n for part in parts for n in part)
    return {n: concat([part[n] for part in parts if n in part]) for n in names}


# ----------------------------------------------------------------------------- summary and run


def summarize(config: Config, tables) -> dict[str, np.ndarray]:
    """Table 6.2 layout: one row per r, the average RMSE per tracker beside the published value.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    tables : dict of str to dict
        The tables of :func:`monte_carlo` (``runs``, ``receptions``, ``broadcasts``).

    Returns
    -------
    dict of str to ndarray, shape (n_ranges,)
        ``range_m``; per tracker ``<label>_rmse_m`` (the mean of the runs' RMSEs over
        trajectories and runs, NaN without runs) and ``<label>_published_rmse_m`` [m];
        ``undecoded_trajectories``, ``decodes_per_s``, ``collided_fraction`` and
        ``max_decodes_per_s`` [1/s].
    """
    runs, rec = tables.get("runs"), tables["receptions"]
    out: dict[str, list] = {"range_m": list(config.ranges_m)}
    for label, _, _ in config.trackers.labels:
        out[f"{label}_rmse_m"], out[f"{label}_published_rmse_m"] = [], []
    extra = {"undecoded_trajectories": [], "decodes_per_s": [], "collided_fraction": [], "max_decodes_per_s": []}
    for r in config.ranges_m:
        for label, _, _ in config.trackers.labels:
            sel = (runs["range_m"] == r) & (runs["tracker"] == label) if runs is not None else np.zeros(0, bool)
            out[f"{label}_rmse_m"].append(float(runs["rmse_m"][sel].mean()) if sel.any() else np.nan)
            out[f"{label}_published_rmse_m"].append(PUBLISHED_TABLE_6_2.get(r, {}).get(label, np.nan))
        sel = rec["range_m"] == r
        n_traj = config.trajectories
        decoded_traj = np.unique(rec["trajectory"][sel & rec["decoded"]]).size
        extra["undecoded_trajectories"].append(n_traj - decoded_traj)
        extra["decodes_per_s"].append(rec["decoded"][sel].sum() / (n_traj * config.motion.duration_s))
        extra["collided_fraction"].append(float(tables["broadcasts"]["collided"].mean()))
        extra["max_decodes_per_s"].append(len(config.layout.tags_xy_m) / config.protocol.period_s)
    return {k: np.asarray(v) for k, v in {**out, **extra}.items()}


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate Geng's reader-free self-tracking of a mobile tag and score the trackers.

    Reproduces Geng ch. 6, Table 6.2 and Fig. 6.4 (binary-detection.md §1.11, §2.4, §3.4;
    seeds/004 L1049–L1260): reference tags broadcast by slotted Aloha, the mobile tag decodes
    what reaches it, and NN, KF, the Bernoulli PF and the RBPF track it from the decodes.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed (the streams of the module docstring).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``broadcasts``, ``receptions``, ``observations``, ``truth``, ``estimates``
        (with ``write_estimates``), ``runs`` (per trajectory, range, tracker and filter run:
        RMSE [m], the CDF of Fig. 6.4) and ``summary`` (Table 6.2 layout); root attributes
        with the layout (reference tags, aisle width, exciter [m]), the models, the filters'
        Eq. (6.5) coefficients per range, NN − KF per range [m] and, with the physical
        models, the calibrated thresholds [V].
    """
    cal = calibrate(config, seed=seed) if config.uses_physical else None
    tables = monte_carlo(config, seed=seed, thresholds_v=None if cal is None else [c[0] for c in cal])
    tables["summary"] = summarize(config, tables)
    ds = _dataset.Dataset(title="reader-free tag-to-tag self-tracking (Geng ch. 6): broadcasts, decodes, NN/KF/PF/RBPF")
    for name in ("broadcasts", "receptions", "observations", "truth", "estimates", "runs", "summary"):
        if name in tables:
            ds.add_table(name, {k: _dataset.column(v, unit_of(k, _UNITS), _describe(name, k)) for k, v in tables[name].items()},
                         description=_GROUPS[name])
    s = tables["summary"]
    ds.attrs["tags_xy_m"] = np.asarray(config.layout.tags_xy_m, float)
    ds.attrs["aisle_width_m"] = config.layout.aisle_width_m
    ds.attrs["exciter_xyz_m"] = np.asarray(config.layout.exciter_xyz_m, float)
    ds.attrs["range_model"], ds.attrs["collision_model"] = config.range_model, config.collision_model
    for i, r in enumerate(config.ranges_m):
        if cal is not None:
            ds.attrs[f"physical_threshold_r{r:g}_v"] = cal[i][0]
            ds.attrs[f"physical_p_at_r{r:g}_min"], ds.attrs[f"physical_p_at_r{r:g}_max"] = cal[i][1], cal[i][2]
        a1, a2 = filter_coefficients(config, r)
        ds.attrs[f"filter_eq65_a1_r{r:g}"], ds.attrs[f"filter_eq65_a2_r{r:g}"] = a1, a2
        if np.isfinite(s["nn_rmse_m"][i]) and np.isfinite(s["kf_rmse_m"][i]):
            ds.attrs[f"nn_minus_kf_r{r:g}_m"] = float(s["nn_rmse_m"][i] - s["kf_rmse_m"][i])
    return ds


#: Units of the columns by name suffix ("_per_s" before "_s").
_UNITS = {"_per_s": "1/s", "_m": "m", "_s": "s", "_mps": "m/s"}


_TEXT = {  # column descriptions by name
    "distance_m": "distance from the mobile tag to the broadcasting reference tag at the broadcast",
    "max_decodes_per_s": "decode rate with every tag in range and no collision (L1203: 20/s)",
    "decoded": "the mobile tag decoded the broadcast (reached and not lost in a collision)",
    "observation": "index k of the decode in the trajectory's observation sequence y_k",
    "undecoded_trajectories": "trajectories with no decode at this range (no estimate)",
    "reason": "why not decoded: 'out of range' or 'collision' (empty when decoded)",
    "reached": "the broadcast would be decoded without a collision (range model)", "x_m": "true x of the mobile tag",
    "broadcast": "index of the broadcast within its trajectory (time order)", "x_est_m": "estimated x (filter run 0)",
    "n_in_slot": "number of broadcasts in the same slot (2 or more collide)", "y_est_m": "estimated y (filter run 0)",
    "observations": "number of observations of the trajectory at this range", "y_m": "true y of the mobile tag",
    "tag": "index of the broadcasting reference tag in layout.tags_xy_m",
    "t_s": "time (end of the slot: the instant the frame is decoded)", "range_m": "sensing range r of the mobile tag",
    "collided": "another reference tag broadcast in the same slot", "particles": "particle count M (0 for NN and KF)",
    "period": "broadcast period (of T_s) the broadcast belongs to", "run": "filter run (independent PF realisation)",
    "collided_fraction": "fraction of broadcasts that collided", "slot": "Aloha slot chosen by the tag in its period",
    "tracker": "tracker: nn, kf, pf<M> (Bernoulli PF), rbpf<M>", "trajectory": "index of the mobile tag's trajectory",
    "y_x_m": "observation y_k: x of the decoded reference tag", "error_m": "position error of the estimate (run 0)",
    "y_y_m": "observation y_k: y of the decoded reference tag", "tag_x_m": "x of the broadcasting reference tag",
    "rmse_m": "RMSE of the run over its observation instants", "decodes_per_s": "mean decodes per second of tracking",
    "x_true_m": "true x of the mobile tag at the observation", "tag_y_m": "y of the broadcasting reference tag",
    "y_true_m": "true y of the mobile tag at the observation", "vx_mps": "true x velocity of the mobile tag",
    "vy_mps": "true y velocity of the mobile tag",
}


_GROUPS = {
    "broadcasts": "one row per reference-tag broadcast (slotted Aloha, one per tag and period) of every trajectory",
    "receptions": "one row per (range, broadcast): distance, whether it reached and was decoded by the mobile tag",
    "observations": "one row per decoded broadcast: the observation y_k = l_i of the trackers and the true position",
    "truth": "the mobile tag's true state on the motion grid of every trajectory",
    "estimates": "one row per (range, tracker, observation) of filter run 0: estimate, truth and error",
    "runs": "one row per (trajectory, range, tracker, filter run): RMSE over the run (CDF of Fig. 6.4)",
    "summary": "Table 6.2 layout: one row per sensing range r, average RMSE per tracker beside the published value",
}


def _describe(table: str, key: str) -> str:
    if key.endswith("_published_rmse_m"):
        return f"Table 6.2 (seeds/004 L1247-L1249) average RMSE of {key[:-17]} (NaN: not published)"
    if table == "summary" and key.endswith("_rmse_m"):
        return f"average RMSE of {key[:-7]} over trajectories and runs"
    return _TEXT.get(key, key.replace("_", " "))


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """The figures the dataset has tables for: Table 6.2 bars, RMSE CDF per tracker (Fig. 6.4), the aisle
    with the tracks of trajectory 0 (after Fig. 6.3), error vs time.

    Drawn by :mod:`rfsim.scenarios._tag_to_tag_tracking_figures`.

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
    return _figures.plot(dataset_path, out_dir)


__all__ = ["NAME", "DESCRIPTION", "Config", "run", "plot", "simulate_trajectory", "summarize", "PUBLISHED_TABLE_6_2"]

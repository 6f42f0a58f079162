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
:mod:`rfsim.scenarios._t2t_network`, :mod:`rfsim.scenarios._t2t_physical`) and records y_k = l_i (L1089).

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

The KF is the one the text fixes (:func:`rfsim.estimators.proximity.proximity_kalman`): the
measurement is the single decoded tag's location y = l_i (L1089, L1109), one at a time (L1061),
G = diag(r²/2, r²/2) (L1119), an update only when a decode arrives (L1095), the motion model
(6.1) over the real gap Δt = t2 − t1 (L1080) with Q = diag(0.01, 0.01) (L1203), and the same
prior knowledge as the PF/RBPF (Table 6.1, L1208; the text gives the KF none). Its error stays
flat in r because the decoded-tag offsets are nearly zero-mean along the two-sided aisle and
independent between decodes, and the decode rate grows with r (3.4/5.4/7.0 per s), which
offsets the larger spread of the offsets. Readings the text leaves open, each tried alone (40
trajectories, seed 1; KF at r = 1.5/2/2.5 m): a KF prior at the first decode with zero velocity
(σ_v 0.3-3 m/s) 0.47-0.52/0.45-0.50/0.54-0.61; its Q × 0 … × 10⁴ 0.30-0.81 m, flat or falling
in r; R = r/2 … r²/2000 0.33-0.72 m, flat; the truth stepped at T_s = 0.5 s as in ch. 4 (L836)
0.40/0.40/0.48; v0 read as the vector (0.1, 1) m/s, 1 m/s along the aisle, 0.31/0.33/0.42;
10 or 20 Aloha slots instead of 50 0.48/0.42/0.43 and 0.38/0.35/0.37 m. None grows like Table
6.2's KF (× 1.9 from r = 1.5 to 2.5 m).
Only changes against the text do: a fixed Δt per decode (1 s: 0.56/0.66/0.76 m; L1080 says
t2 − t1), or a truth 10 × rougher than the filters' Q (q = 0.1 m²/s⁴ on 0.5 s steps: KF
0.55/0.67/0.81 m, NN 1.07/1.40/1.66 m) — which lifts PF30 to 0.78/0.92/1.04 m, so PF30 < KF
fails. Table 6.2's KF (≈ NN − 0.5 m, worse than PF20 at r ≥ 2 m) thus looks like a KF
handicapped relative to the PF in a way the text does not state, e.g. a motion model or prior
it does not share with the PF [inference]; with the stated model and prior the linear KF is
the better tracker.

Error metric: per run, RMSE = sqrt(mean over the run's observation instants of ‖x̂ − x‖²);
"average RMSE" of Table 6.2 = the mean of the RMSEs over trajectories and runs (trajectories
with no decode have no estimate and are counted in ``summary/undecoded_trajectories``).

``range_model = "physical"`` and ``collision_model = "physical"`` decode slots at sample level
(:mod:`rfsim.scenarios._t2t_physical`: exciter, harvesting tags, superposed frames, the mobile tag's
comparator chain with its threshold calibrated so that the tag at the median exciter distance
is decoded half of the time at r). Measured (10 trajectories × 10 runs, seed 1): the physical
range is soft — P(decode) ≈ 0.8 within 1 m (the single-antenna listener's phase cancellation,
AURIS ch. 3), ≈ 0.5 at r, still 0.05-0.4 up to r + 0.5 m, and 0.2-0.6 at r over the ten tags
(attributes ``physical_p_at_r*``) — so NN grows (1.34/1.47/1.61 m), fewer decodes arrive (3.2/4.1/
5.0 per s against 3.4/5.4/7.0 with the disc) and the PF30 error is flat in r (0.53 m); physical
collisions keep 10-17 % of the collided broadcasts (capture of a dominant frame), which adds
≈ 5 % decodes to the loss model and leaves the errors within their Monte-Carlo spread.

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

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.procs import map_in_order
from rfsim.core.rng import trial_rng
from rfsim.scenarios._t2t_physical import PhysicalConfig, calibrate_threshold, decode_events
from rfsim.core.lazy import lazy_import

_dataset = lazy_import("rfsim.core.dataset")
_proximity = lazy_import("rfsim.estimators.proximity")
net = lazy_import("rfsim.scenarios._t2t_network")
_exciter_scene = lazy_import("rfsim.scenarios._exciter_scene")
_t2t_figures = lazy_import("rfsim.scenarios._t2t_figures")

NAME = "tag-to-tag-tracking"
DESCRIPTION = ("reader-free self-tracking of a mobile tag from reference-tag broadcasts (Geng ch. 6): "
               "slotted Aloha, NN / KF / Bernoulli PF / RBPF, Table 6.2")

#: Table 6.2 (seeds/004 L1242-L1249): average RMSE [m] per sensing range r: NN, KF, PF M = 10, 20, 30.
PUBLISHED_TABLE_6_2 = {
    1.5: {"nn": 1.0720, "kf": 0.5611, "pf10": 0.6466, "pf20": 0.5484, "pf30": 0.5183},
    2.0: {"nn": 1.3391, "kf": 0.8203, "pf10": 0.7351, "pf20": 0.5886, "pf30": 0.5340},
    2.5: {"nn": 1.5643, "kf": 1.0782, "pf10": 0.8046, "pf20": 0.6513, "pf30": 0.5812},
}

_DEFAULT_TAGS = tuple((2.0 * i, s) for s in (-1.0, 1.0) for i in range(5))


@dataclass(frozen=True)
class LayoutConfig:
    tags_xy_m: tuple[tuple[float, float], ...] = param(
        _DEFAULT_TAGS, unit="m", doc="reference-tag positions (x, y); default 5 per shelf face at y = ±1 m")
    aisle_width_m: float = param(2.0, lo=0.1, hi=100.0, unit="m", doc="width between the shelves (L1203)")
    shelf_clearance_m: float = param(0.1, lo=0.0, hi=10.0, unit="m",
                                     doc="closest approach of the mobile tag to a shelf face (y reflected there)")
    exciter_xyz_m: tuple[float, float, float] = param((4.0, 0.0, 2.0), unit="m",
                                                      doc="exciter position (the seed gives none, B§0.2)")


@dataclass(frozen=True)
class MotionConfig:
    duration_s: float = param(12.0, lo=0.1, hi=3600.0, unit="s", doc="tracking time per trajectory (L1212)")
    dt_s: float = param(0.05, lo=1e-4, hi=1.0, unit="s", doc="grid of the true motion (6.1)")
    accel_var: float = param(0.01, lo=0.0, hi=100.0, unit="m2/s4", doc="q of u ~ N(0, diag(q, q)) (L1203)")
    speed_min_mps: float = param(0.1, lo=0.0, hi=10.0, unit="m/s", doc="initial speed lower bound (L1203)")
    speed_max_mps: float = param(1.0, lo=0.0, hi=10.0, unit="m/s", doc="initial speed upper bound (L1203)")
    start_xy_m: tuple[float, float] = param((0.0, 0.0), unit="m", doc="where the mobile tag enters the aisle")


@dataclass(frozen=True)
class ProtocolConfig:
    period_s: float = param(0.5, lo=1e-3, hi=100.0, unit="s", doc="broadcast period T_s of every tag (L1203)")
    n_slots: int = param(50, lo=1, hi=100000, doc="Aloha slots per period (not in the seed)")


@dataclass(frozen=True)
class RangeConfig:
    logistic_a1: float = param(-2.523, lo=-100.0, hi=100.0,
                               doc="Eq. (6.5) a1: exciter-link pooled fit (default run, seed 1)")
    logistic_a2_per_m: float = param(5.028, lo=-1000.0, hi=1000.0, unit="1/m",
                                     doc="Eq. (6.5) a2: exciter-link pooled fit (d50 = 0.50 m)")
    scale_to_range: bool = param(True, doc="stretch the fitted curve so that p(r) = 0.5 (a2 = -a1/r)")


@dataclass(frozen=True)
class TrackerConfig:
    particles: tuple[int, ...] = param((10, 20, 30), lo=1, hi=100000, doc="Bernoulli PF particle counts M (L1246)")
    rbpf_particles: tuple[int, ...] = param((30,), lo=1, hi=100000, doc="RBPF particle counts M (L1221)")
    likelihood: Literal["exciter-link", "slope"] = param(
        "exciter-link", doc="the filters' Eq. (6.5): the range section's (exciter-link) curve, or p(r) = 0.5 "
                            "with the slope slope_per_m")
    slope_per_m: float = param(4.0, lo=0.01, hi=1000.0, unit="1/m",
                               doc="likelihood 'slope': a2 of the filters' Eq. (6.5) with p(r) = 0.5")
    prior_position_std_m: float = param(0.3, lo=1e-6, hi=100.0, unit="m", doc="prior std of the initial position")
    prior_velocity_std_mps: float = param(0.3, lo=1e-6, hi=100.0, unit="m/s", doc="prior std of the initial velocity")


@dataclass(frozen=True)
class Config:
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
    layout: LayoutConfig = param(LayoutConfig(), doc="reference tags, aisle, exciter")
    motion: MotionConfig = param(MotionConfig(), doc="mobile tag motion (6.1)")
    protocol: ProtocolConfig = param(ProtocolConfig(), doc="all-tag-talk slotted Aloha")
    range: RangeConfig = param(RangeConfig(), doc="Eq. (6.5) coefficients of the logistic range model")
    trackers: TrackerConfig = param(TrackerConfig(), doc="particle counts and priors")
    physical: PhysicalConfig = param(PhysicalConfig(), doc="sample-level link of the physical models")
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
        if not abs(m.start_xy_m[1]) <= self.y_limit_m:
            raise ConfigError("motion.start_xy_m", list(m.start_xy_m),
                              f"a start inside the aisle, |y| <= {self.y_limit_m:g} m "
                              "(half width minus the shelf clearance)")

    @property
    def uses_physical(self) -> bool:
        return self.range_model == "physical" or self.collision_model == "physical"

    @property
    def y_limit_m(self) -> float:
        return self.layout.aisle_width_m / 2.0 - self.layout.shelf_clearance_m

    @property
    def trackers_list(self) -> list[tuple[str, str, int]]:
        """(label, kind, M) of every tracker run."""
        t = self.trackers
        return ([("nn", "nn", 0), ("kf", "kf", 0)] + [(f"pf{m}", "pf", m) for m in t.particles]
                + [(f"rbpf{m}", "rbpf", m) for m in t.rbpf_particles])


# ----------------------------------------------------------------------------- one trajectory


def filter_coefficients(config: Config, range_m: float) -> tuple[float, float]:
    """The (6.5) coefficients the PF/RBPF use at range r (module docstring)."""
    if config.trackers.likelihood == "exciter-link":
        c = config.range
        return net.logistic_coefficients(c.logistic_a1, c.logistic_a2_per_m, range_m, c.scale_to_range)
    a2 = config.trackers.slope_per_m
    return -a2 * range_m, a2


def _prior(config: Config, x0: np.ndarray, rng, n_runs: int, m: int, kind: str) -> np.ndarray:
    t = config.trackers
    sd = np.array([t.prior_position_std_m, t.prior_velocity_std_mps] * 2)
    p = x0 + rng.standard_normal((n_runs, m, 4)) * sd
    if kind == "rbpf":  # velocity slots hold the Kalman mean x^l_0 (Table 6.1)
        p[..., 1::2] = x0[1::2]
    return p


def track(config: Config, range_m: float, times_s, observed_xy, truth_xy, x0, *, rngs) -> list[dict]:
    """Every tracker on one observation sequence at range r: per tracker, estimates (runs, T, 2) and RMSEs."""
    t = config.trackers
    P0 = np.diag([t.prior_position_std_m, t.prior_velocity_std_mps] * 2) ** 2
    out = []
    for (label, kind, m), rng in zip(config.trackers_list, rngs):
        if kind == "nn":
            est = _proximity.association(observed_xy)[None]
        elif kind == "kf":
            est = _proximity.proximity_kalman(times_s, observed_xy, x0, P0, t0_s=0.0, accel_var=config.motion.accel_var,
                                              range_m=range_m).x[None][..., 0::2]
        else:
            a1, a2 = filter_coefficients(config, range_m)
            init = _prior(config, x0, rng, config.filter_runs, m, kind)
            if kind == "pf":
                res = _proximity.bernoulli_pf(times_s, observed_xy, init, t0_s=0.0, accel_var=config.motion.accel_var,
                                              a1=a1, a2=a2, rng=rng)
            else:
                res = _proximity.rbpf(times_s, observed_xy, init, t.prior_velocity_std_mps ** 2, t0_s=0.0,
                                      accel_var=config.motion.accel_var, a1=a1, a2=a2, rng=rng)
            est = res.mmse[..., 0::2]
        err = np.linalg.norm(est - truth_xy[None], axis=-1)
        out.append({"label": label, "kind": kind, "m": m, "estimates": est, "error_m": err,
                    "rmse_m": np.sqrt(np.mean(err * err, axis=-1))})
    return out


def receptions(config: Config, b, pos, dist, tags, i: int, r: float, rng, threshold_v: float) -> tuple:
    """(reached, decoded) per broadcast at range r by ``range_model`` and ``collision_model``.

    Physical decodes run per slot (:func:`rfsim.scenarios._t2t_physical.decode_events`): all slots for
    ``range_model = "physical"``, the collided ones for ``collision_model = "physical"``; a slot
    decodes as at most one of its senders.
    """
    c = config.range
    a1, a2 = net.logistic_coefficients(c.logistic_a1, c.logistic_a2_per_m, r, c.scale_to_range)
    single = b["n_in_slot"] == 1
    if config.range_model != "physical":
        reach = net.in_range(dist, model=config.range_model, range_m=r, a1=a1, a2=a2, rng=rng)
        decoded = reach & single
        slots = ~single if config.collision_model == "physical" else np.zeros_like(single)
    else:
        reach = np.zeros_like(single)
        decoded = np.zeros_like(single)
        slots = np.ones_like(single)
    if slots.any():
        key = b["period"] * config.protocol.n_slots + b["slot"]
        uniq, first = np.unique(key[slots], return_index=True)
        members = [tuple(b["tag"][slots][key[slots] == k]) for k in uniq]
        where = pos[np.flatnonzero(slots)[first]]
        got = decode_events(config.physical, config.layout.exciter_xyz_m, tags, members, where, r, threshold_v, rng)
        won = dict(zip(uniq.tolist(), got.tolist()))
        hit = np.array([won.get(int(k), -1) == t for k, t in zip(key, b["tag"])]) & slots
        decoded = decoded | hit
        if config.range_model == "physical":
            reach = hit
    return reach, decoded


def simulate_trajectory(config: Config, j: int, seed: int, thresholds_v=None) -> dict[str, dict[str, np.ndarray]]:
    """Motion, broadcasts, receptions and every tracker of trajectory ``j``: per-table columns.

    ``thresholds_v``: the listener threshold per range for the physical models (:func:`calibrate`)."""
    m, p, lay = config.motion, config.protocol, config.layout
    tags = np.asarray(lay.tags_xy_m, float)
    t_grid, states = net.simulate_motion(trial_rng(seed, j, 0), duration_s=m.duration_s, dt_s=m.dt_s,
                                         start_xy_m=m.start_xy_m, speed_range_mps=(m.speed_min_mps, m.speed_max_mps),
                                         accel_var=m.accel_var, y_limit_m=config.y_limit_m)
    b = net.aloha_schedule(trial_rng(seed, j, 1), n_tags=tags.shape[0], duration_s=m.duration_s,
                           period_s=p.period_s, n_slots=p.n_slots)
    pos = net.position_at(t_grid, states, b["t_s"])
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
        reach, decoded = receptions(config, b, pos, dist, tags, i, r, trial_rng(seed, j, 2 + i), th)
        reason = np.where(decoded, "", np.where(b["n_in_slot"] > 1, "collision", "out of range"))
        rec.append({"trajectory": np.full(n_b, j), "range_m": np.full(n_b, r), "broadcast": np.arange(n_b),
                    "distance_m": dist, "reached": reach, "decoded": decoded, "reason": reason})
        k = np.flatnonzero(decoded)
        obs.append({"trajectory": np.full(k.size, j), "range_m": np.full(k.size, r), "observation": np.arange(k.size),
                    "broadcast": k, "t_s": b["t_s"][k], "tag": b["tag"][k], "y_x_m": tags[b["tag"][k], 0],
                    "y_y_m": tags[b["tag"][k], 1], "x_true_m": pos[k, 0], "y_true_m": pos[k, 1],
                    "distance_m": dist[k]})
        if k.size == 0:
            continue
        rngs = [trial_rng(seed, j, 100 + 10 * i + f) for f in range(len(config.trackers_list))]
        for res in track(config, r, b["t_s"][k], tags[b["tag"][k]], pos[k], states[0], rngs=rngs):
            n_runs = res["rmse_m"].size
            runs.append({"trajectory": np.full(n_runs, j), "range_m": np.full(n_runs, r),
                         "tracker": np.full(n_runs, res["label"]), "particles": np.full(n_runs, res["m"]),
                         "run": np.arange(n_runs), "observations": np.full(n_runs, k.size), "rmse_m": res["rmse_m"]})
            if config.write_estimates:
                e0 = res["estimates"][0]
                est.append({"trajectory": np.full(k.size, j), "range_m": np.full(k.size, r),
                            "tracker": np.full(k.size, res["label"]), "observation": np.arange(k.size),
                            "t_s": b["t_s"][k], "x_est_m": e0[:, 0], "y_est_m": e0[:, 1],
                            "x_true_m": pos[k, 0], "y_true_m": pos[k, 1], "error_m": res["error_m"][0]})
    tables["receptions"] = _exciter_scene.concat(rec)
    tables["observations"] = _exciter_scene.concat(obs)
    if runs:
        tables["runs"] = _exciter_scene.concat(runs)
    if est:
        tables["estimates"] = _exciter_scene.concat(est)
    return tables


def _task(args):
    config, js, seed, th = args
    return [simulate_trajectory(config, j, seed, th) for j in js]


def calibrate(config: Config, *, seed: int) -> list[tuple[float, float, float]]:
    """Per range: (threshold [V], min, max decode fraction at r over the tags) of the physical
    listener (:func:`rfsim.scenarios._t2t_physical.calibrate_threshold`, ``trial_rng(seed, 10**6, i)``)."""
    return [calibrate_threshold(config.physical, config.layout.exciter_xyz_m, config.layout.tags_xy_m, r,
                                trial_rng(seed, 10 ** 6, i)) for i, r in enumerate(config.ranges_m)]


def monte_carlo(config: Config, *, seed: int, thresholds_v=None) -> dict[str, dict[str, np.ndarray]]:
    """Every trajectory on ``config.workers`` processes (chunks of 5), tables concatenated in order."""
    chunks = [list(range(a, min(a + 5, config.trajectories))) for a in range(0, config.trajectories, 5)]
    tasks = [(config, js, seed, thresholds_v) for js in chunks]
    parts = [t for chunk in map_in_order(_task, tasks, config.workers,
                                        desc="trajectories", unit="chunks") for t in chunk]
    names = dict.fromkeys(n for part in parts for n in part)
    return {n: _exciter_scene.concat([part[n] for part in parts if n in part]) for n in names}


# ----------------------------------------------------------------------------- summary and run


def summarize(config: Config, tables) -> dict[str, np.ndarray]:
    """Table 6.2 layout: one row per r, the average RMSE per tracker beside the published value."""
    runs, rec = tables.get("runs"), tables["receptions"]
    out: dict[str, list] = {"range_m": list(config.ranges_m)}
    for label, _, _ in config.trackers_list:
        out[f"{label}_rmse_m"], out[f"{label}_published_rmse_m"] = [], []
    extra = {"undecoded_trajectories": [], "decodes_per_s": [], "collided_fraction": [], "max_decodes_per_s": []}
    for r in config.ranges_m:
        for label, _, _ in config.trackers_list:
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
    cal = calibrate(config, seed=seed) if config.uses_physical else None
    tables = monte_carlo(config, seed=seed, thresholds_v=None if cal is None else [c[0] for c in cal])
    tables["summary"] = summarize(config, tables)
    ds = _dataset.Dataset(title="reader-free tag-to-tag self-tracking (Geng ch. 6): broadcasts, decodes, NN/KF/PF/RBPF")
    for name in ("broadcasts", "receptions", "observations", "truth", "estimates", "runs", "summary"):
        if name in tables:
            ds.add_table(name, {k: _dataset.column(v, _unit(k), _describe(name, k)) for k, v in tables[name].items()},
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


_UNITS = {"_m": "m", "_s": "s", "_mps": "m/s"}


def _unit(key: str) -> str:
    if key.endswith("_per_s"):
        return "1/s"
    return next((u for suf, u in _UNITS.items() if key.endswith(suf)), "1")


_TEXT = {
    "trajectory": "index of the mobile tag's trajectory",
    "broadcast": "index of the broadcast within its trajectory (time order)",
    "period": "broadcast period (of T_s) the broadcast belongs to",
    "tag": "index of the broadcasting reference tag in layout.tags_xy_m",
    "slot": "Aloha slot chosen by the tag in its period",
    "t_s": "time (end of the slot: the instant the frame is decoded)",
    "n_in_slot": "number of broadcasts in the same slot (2 or more collide)",
    "collided": "another reference tag broadcast in the same slot",
    "tag_x_m": "x of the broadcasting reference tag", "tag_y_m": "y of the broadcasting reference tag",
    "range_m": "sensing range r of the mobile tag",
    "distance_m": "distance from the mobile tag to the broadcasting reference tag at the broadcast",
    "reached": "the broadcast would be decoded without a collision (range model)",
    "decoded": "the mobile tag decoded the broadcast (reached and not lost in a collision)",
    "reason": "why not decoded: 'out of range' or 'collision' (empty when decoded)",
    "observation": "index k of the decode in the trajectory's observation sequence y_k",
    "y_x_m": "observation y_k: x of the decoded reference tag", "y_y_m": "observation y_k: y of the decoded reference tag",
    "x_true_m": "true x of the mobile tag at the observation", "y_true_m": "true y of the mobile tag at the observation",
    "x_m": "true x of the mobile tag", "y_m": "true y of the mobile tag",
    "vx_mps": "true x velocity of the mobile tag", "vy_mps": "true y velocity of the mobile tag",
    "tracker": "tracker: nn, kf, pf<M> (Bernoulli PF), rbpf<M>",
    "particles": "particle count M (0 for NN and KF)", "run": "filter run (independent PF realisation)",
    "observations": "number of observations of the trajectory at this range",
    "rmse_m": "RMSE of the run over its observation instants", "x_est_m": "estimated x (filter run 0)",
    "y_est_m": "estimated y (filter run 0)", "error_m": "position error of the estimate (run 0)",
    "undecoded_trajectories": "trajectories with no decode at this range (no estimate)",
    "decodes_per_s": "mean decodes per second of tracking", "collided_fraction": "fraction of broadcasts that collided",
    "max_decodes_per_s": "decode rate with every tag in range and no collision (L1203: 20/s)",
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
    """Aisle with tracks, error vs time, RMSE CDF per tracker, Table 6.2 bars (:mod:`rfsim.scenarios._t2t_figures`)."""
    return _t2t_figures.plot_all(Path(dataset_path), Path(out_dir))


__all__ = ["NAME", "DESCRIPTION", "Config", "run", "plot", "simulate_trajectory", "summarize", "PUBLISHED_TABLE_6_2"]

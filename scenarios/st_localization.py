"""Scenario ``st-localization``: tracking a sense-a-tag (ST) from the landmark tags it detects
(AURIS ch. 4: PF-BIN, PF-AA, SQLAM's tracking module, weighted centroid; auris-sense-a-tag.md
§3.3, §4.2, §7; seeds/003 L4493-L4650, L5375-L5415, L5600-L5690; wave2-specs.md §R).

Scene (presets, :mod:`rfsim.scenarios._st_paths`): a reader's panel antenna(s) 2 m above the floor
facing down, an nx × ny grid of landmark tags on the floor, the ST moving on the floor. In each
query period of T_s = 0.3 s the reader runs N = 10 rounds; in round j the ST decodes landmark k
with the RTS probability (Eq. 4.6, :func:`rfsim.detection.rts_probability`'s coefficients)

    p = 1/(1 + exp(a0 + a1·D_k + a2·d + a3·|θ_k| + a4·|φ_k|))

with D_k, θ_k, φ_k the active antenna → landmark geometry (antenna frame: boresight down;
θ = arcsin(Δy/D), φ = arcsin(Δx/D)) and d the ST → landmark distance at the round's time
τ_j = (t + (j + ½)/N)·T_s. ``mode = "surrogate"`` draws those detections as Bernoulli trials, so
a still ST sees n ~ Binomial(N, p_RTS) — what the source did (its PASS had no Q algorithm,
L469-L473); a moving ST sees the Poisson-binomial of its positions, which is the "false
synchronous detection" that PF-AA's bias compensation corrects. With several antennas (``lab``)
the one nearest to the previous period's WCL estimate is active (the source: "nearest to the
current ST estimate", L5633-L5641; the WCL keeps one data set for all trackers).

Experiments (preset defaults; ``realizations`` and durations reduced unless ``full``):

* ``speed-sweep`` (Fig. 4.11, L4587-L4605): trajectory 1 at 0.1-3 m/s, PF-AA with compensation
  never (v_threshold = ∞) and always (0); the crossover speed where "always" becomes better
  (published ≈ 1.2 m/s).
* ``trajectory-2`` (Figs. 4.12-4.14, L4616-L4636): PF-BIN (known initial state) vs PF-AA
  (v_threshold 1.2 m/s) vs WCL at 0.5 and 2.5 m/s (published 0.1681 / 0.1717 m at 0.5 m/s).
* ``random-walk`` (Fig. 4.15, L4638-L4650; Fig. 4.19, L5409-L5415; L5657-L5664): pfaa: PF-AA vs
  WCL over 1500 s (−36.6 %); sqlam: SQLAM's tracking PF (PF-AA without compensation, Algorithm 3)
  vs WCL over 500 s (−41.9 %); lab: SQLAM over 10,000 s (0.2560 m).

Filter parameters (L4503-L4616, L5393-L5409): M = 200, q_t std 0.3 m (the source's N(0, 0.3)
does not say std or variance, A§0.4: std taken), b0 = 0.8, b1 = 0.2, initial spread 0.3 m;
PF-BIN u ~ N(0, diag(0.01, 0.01)). Error: ‖x̃_t − x_t‖ at the period end. A case's value is the
source's "average RMSE" (``summary.mean_error_m``): that ℓ2 error ("the RMSE for one realization",
L4507-L4513; "ℓ2-norm operation of the difference between estimation and true location",
L5383-L5385) averaged over realizations and periods; ``summary.rmse_m`` is the time average of
RMSE_t = sqrt(mean over realizations of the squared error), which is larger (0.196 against
0.179 m for PF-BIN below). Changes vs WCL and the crossover use the source's measure.

Measured (seed 1): crossover 1.19 m/s (published ≈ 1.2; speed sweep, 20 realizations); random
walk 1500 s PF-AA vs WCL −44.6 % (−36.6 %); sqlam, 20 tracks × 500 s, SQLAM vs WCL −37.3 %
(−41.9 %; SQLAM 0.268 m, WCL 0.428 m); lab, 10,000 s, SQLAM 0.316 m (published 0.2560 m,
+23 %, inside the ±25 % of wave2-specs §R; WCL 0.412 m), 31-91 s CPU; trajectory 2 at 0.5 m/s
(100 realizations) PF-BIN 0.179 m, PF-AA 0.188 m (published 0.1681 / 0.1717 m; standard errors
0.0014 / 0.0008 m). What remains above the published values: the detections of a period are
spread over it, so the estimates lag the period end by T_s/2 on average (0.075 m at 0.5 m/s,
the false synchronous detection PF-AA compensates only above 1.2 m/s), and the 45 binomial
counts per period of this replica's grid (landmarks at cell centres, ST and tags on the floor;
the source's heights and grid offsets are not given) carry ≈ 0.2 m of position information.
In the RMS measure (20 realizations): against the truth T_s/2 before the period end PF-BIN
gives 0.156 m (0.190 m at the period end), PF-AA 0.209 m (0.215 m); PF-AA's AR noise q std
0.15 m gives 0.202 m, the variance reading of q (std 0.548 m) 0.229 m; a grid with landmarks on
the room's edges (9 × 5 at 0.5 × 0.8 m) is worse (PF-BIN 0.214 m, PF-AA 0.240 m). SQLAM's
mapping and landmark-replacement modules are not implemented.

``mode = "sample-level"`` (:mod:`rfsim.scenarios._st_sample_level`; presets with one antenna): each
query period is N QT rounds of a real Gen2 inventory of the landmarks at sample level (Q
algorithm, RN16 → ACK → EPC), the ST decoding every EPC reply with its envelope receiver; a
CRC-valid EPC is a detection at the reply's start. The periods are as long as the rounds take
(``periods.period_duration_s``, attribute ``detection_period_s``), the truth is taken at each
measured period end and the trackers use the mean period as Δt and the RTS model as their
likelihood. Cases: ``sample_level.realizations`` tracks of ``sample_level.duration_s`` (default
experiment pfaa: trajectory 2). Measured (seed 1, pfaa, 0.5 m/s, 12 s, N = 10; 62 s CPU, 291 MB):
period 4.72 s (694 slots and 450 EPC reads per period, the source assumed 0.3 s); the ST decodes
≈ 53 of the 450 replies (13-19 landmarks) per period; average RMSE PF-BIN 1.62 m, PF-AA 0.99 m, WCL
0.94 m (the ST moves 2.4 m per period).

Randomness: case c, realization b: ``trial_rng(seed, c, b, 0)`` the random walk,
``trial_rng(seed, c, b, 1)`` the detections (sample level: ``trial_rng(seed, c, b, 2, k)`` the
reader, air, ST links, ST and landmarks); the trackers of case c and realization chunk g use
``trial_rng(seed, c, 1000 + g, f)`` for tracker f (sample level, realization i of chunk g:
``trial_rng(seed, c, 2000 + 100·g + i, f)``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.core.columns import concat
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.procs import map_in_order
from rfsim.core.rng import trial_rng
from rfsim.scenarios import _st_paths as paths
from rfsim.scenarios._st_sample_level import SampleLevelConfig, listen_track
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.core.lazy import lazy_import

_dataset = lazy_import("rfsim.core.dataset")
_detection = lazy_import("rfsim.detection")
_landmark_pf = lazy_import("rfsim.estimators.landmark_pf")
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

_EXPERIMENTS = {"pfaa": ("speed-sweep", "trajectory-2", "random-walk"), "sqlam": ("random-walk",),
                "lab": ("random-walk",)}
_WALK_S = {"pfaa": 1500.0, "sqlam": 500.0, "lab": 10000.0}


@dataclass(frozen=True)
class FilterConfig:
    particles: int = param(200, lo=1, hi=1_000_000, doc="particles M of PF-AA, SQLAM and PF-BIN (L4505)")
    q_std_m: float = param(0.3, lo=1e-6, hi=10.0, unit="m", doc="PF-AA / SQLAM AR noise std per period (L4503)")
    init_std_m: float = param(0.3, lo=1e-6, hi=10.0, unit="m", doc="PF-AA initial spread around the first WCL")
    b0: float = param(0.8, lo=0.0, hi=1.0, doc="velocity AR weight of the current WCL velocity (L5403)")
    b1: float = param(0.2, lo=0.0, hi=1.0, doc="velocity AR weight of the previous velocity (L5403)")
    v_threshold_mps: float = param(1.2, lo=0.0, hi=1000.0, unit="m/s", doc="bias compensation above (L4605)")
    pfbin_accel_var: float = param(0.01, lo=0.0, hi=100.0, unit="m2/s2",
                                   doc="PF-BIN velocity noise variance per period (L4614)")


@dataclass(frozen=True)
class Config:
    preset: Literal["pfaa", "sqlam", "lab"] = param("pfaa", doc="room, landmark grid and antennas")
    mode: Literal["surrogate", "sample-level"] = param(
        "surrogate", doc="'surrogate' = Bernoulli RTS detections per round; 'sample-level' = the ST listens "
                         "through real Gen2 rounds (rfsim.scenarios._st_sample_level)")
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
    trajectory_1_xy_m: tuple[tuple[float, float], ...] = param(paths.TRAJECTORY_1_XY, unit="m",
                                                               doc="trajectory 1 waypoints (closed polyline)")
    filters: FilterConfig = param(FilterConfig(), doc="particle-filter parameters")
    workers: int = param(2, lo=0, hi=256, doc="worker processes (0 = all cores, 1 = in process)")

    def __post_init__(self):
        if self.n_landmarks == 0:
            raise ConfigError("landmark_grid", list(self.landmark_grid), "nx, ny >= 1 (at least one landmark)")
        x0, y0, x1, y1 = self.room.bounds_m
        pts = np.asarray(self.trajectory_1_xy_m, float).reshape(-1, 2)
        if pts.shape[0] < 2:
            raise ConfigError("trajectory_1_xy_m", [list(p) for p in pts], "at least 2 waypoints (x, y) in m")
        out = ~((pts[:, 0] >= x0) & (pts[:, 0] <= x1) & (pts[:, 1] >= y0) & (pts[:, 1] <= y1))
        if out.any():
            raise ConfigError("trajectory_1_xy_m", list(pts[np.argmax(out)]),
                              f"waypoints inside the {self.preset} room x in [{x0:g}, {x1:g}], y in [{y0:g}, {y1:g}] m "
                              "(the trajectory leaves the room)")
        if self.mode == "sample-level" and len(self.room.antennas_xyz_m) != 1:
            raise ConfigError("mode", self.mode, f"'surrogate' for preset {self.preset} (sample-level: presets with "
                                                 "one reader antenna, pfaa or sqlam)")
        if self.mode == "sample-level" and self.st.technique == "stamp":
            raise ConfigError("st.technique", self.st.technique, "'single', 'combination' or 'selection'")
        if self.walk_speed_mps[1] < self.walk_speed_mps[0] or self.walk_speed_mps[1] <= 0:
            raise ConfigError("walk_speed_mps", list(self.walk_speed_mps), "[lo, hi] with 0 <= lo <= hi, hi > 0")

    @property
    def room(self) -> paths.Room:
        r = paths.PRESETS[self.preset]
        return r if self.landmark_grid is None else paths.Room(r.size_m, tuple(self.landmark_grid), r.antennas_xyz_m)

    @property
    def n_landmarks(self) -> int:
        g = self.room.grid
        return int(g[0] * g[1])

    @property
    def experiment_list(self) -> tuple[str, ...]:
        if self.experiments is not None:
            return self.experiments
        if self.mode == "sample-level" and self.preset == "pfaa":
            return ("trajectory-2",)
        return _EXPERIMENTS[self.preset]

    @property
    def walk_s(self) -> float:
        return self.walk_duration_s if self.walk_duration_s is not None else _WALK_S[self.preset]


@dataclass(frozen=True)
class Case:
    """One case: experiment, path, speed, realizations, duration, trackers (label, kind, v_threshold)."""

    index: int
    experiment: str
    trajectory: str
    speed_mps: float
    realizations: int
    duration_s: float
    trackers: tuple[tuple[str, str, float], ...]


def cases(config: Config) -> list[Case]:
    """Every case of the configured experiments (module docstring), in order."""
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
    if config.mode == "sample-level":
        sl = config.sample_level
        out = [replace(c, realizations=sl.realizations, duration_s=sl.duration_s) for c in out]
    return out


# ----------------------------------------------------------------------------- detections


def antenna_geometry(room: paths.Room, landmarks: np.ndarray) -> np.ndarray:
    """base (A, L) = a0 + a1·D + a3·|θ| + a4·|φ| of every antenna → landmark pair (Eq. 4.6)."""
    a = _detection.RTS_COEFFICIENTS
    ant = np.asarray(room.antennas_xyz_m, float)
    v = np.concatenate([landmarks, np.zeros((landmarks.shape[0], 1))], axis=1)[None] - ant[:, None, :]
    D = np.linalg.norm(v, axis=-1)
    theta, phi = np.arcsin(v[..., 1] / D), np.arcsin(v[..., 0] / D)
    return a[0] + a[1] * D + a[3] * np.abs(theta) + a[4] * np.abs(phi)


def rts_p(base, d_m) -> np.ndarray:
    """Eq. 4.6 from the fixed part ``base`` and the ST → landmark distance d."""
    return 1.0 / (1.0 + np.exp(base + _detection.RTS_COEFFICIENTS[2] * d_m))


def truth_at(config: Config, case: Case, b: int, seed: int, t_s) -> np.ndarray:
    """True ST positions at times ``t_s`` (…, 2) for realization b of the case."""
    if case.trajectory == "1":
        pts = np.asarray(config.trajectory_1_xy_m, float)
        if not np.array_equal(pts[0], pts[-1]):
            pts = np.vstack([pts, pts[:1]])
        return paths.along_path(pts, case.speed_mps, t_s)
    if case.trajectory == "2":
        return paths.along_path(paths.trajectory_2_xy(), case.speed_mps, t_s)
    flat = np.asarray(t_s, float).ravel()
    order = np.argsort(flat, kind="stable")
    out = np.empty((flat.size, 2))
    out[order] = paths.random_walk(trial_rng(seed, case.index, b, 0), config.room.bounds_m, config.walk_speed_mps,
                                   flat[order])
    return out.reshape(np.shape(t_s) + (2,))


def detect(config: Config, base, landmarks, pos_rounds, rng) -> dict[str, np.ndarray]:
    """Detections of one realization: counts (T, L), mean detection time (T,), active antenna (T,).

    pos_rounds : (T, N, 2) ST positions at the round times.
    """
    T, N, _ = pos_rounds.shape
    Ts = config.period_s
    tau = (np.arange(T)[:, None] + (np.arange(N)[None, :] + 0.5) / N) * Ts
    ant = np.asarray(config.room.antennas_xyz_m, float)[:, :2]
    active = np.zeros(T, dtype=np.int64)
    counts = np.zeros((T, landmarks.shape[0]), dtype=np.int64)
    tsum = np.zeros(T)
    if ant.shape[0] == 1:
        for a in range(0, T, 2000):
            d = np.linalg.norm(pos_rounds[a:a + 2000, :, None, :] - landmarks, axis=-1)
            det = rng.random(d.shape) < rts_p(base[0], d)
            counts[a:a + 2000] = det.sum(axis=1)
            tsum[a:a + 2000] = np.einsum("tnl,tn->t", det, tau[a:a + 2000])
    else:
        est = np.zeros(2)
        u = rng.random((T, N, landmarks.shape[0]))
        for t in range(T):
            active[t] = int(np.argmin(np.linalg.norm(ant - est, axis=1)))
            d = np.linalg.norm(pos_rounds[t, :, None, :] - landmarks, axis=-1)
            det = u[t] < rts_p(base[active[t]], d)
            counts[t] = det.sum(axis=0)
            tsum[t] = det.sum(axis=1) @ tau[t]
            if counts[t].sum() > 0:
                est = counts[t] @ landmarks / counts[t].sum()
    total = counts.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_t = np.where(total > 0, tsum / total, np.nan)
    return {"counts": counts, "mean_detection_s": mean_t, "active": active}


# ----------------------------------------------------------------------------- one chunk


def _surrogate_track(config: Config, case: Case, b: int, seed: int, base, landmarks) -> dict:
    """Truth, PF-BIN start and RTS detections of realization b on the fixed period grid."""
    Ts, N = config.period_s, config.rounds
    T = int(round(case.duration_s / Ts))
    t_end = (np.arange(T) + 1) * Ts
    tau = (np.arange(T)[:, None] + (np.arange(N)[None, :] + 0.5) / N) * Ts
    pos = truth_at(config, case, b, seed, np.concatenate([[0.0, 1e-3], tau.ravel(), t_end]))
    det = detect(config, base, landmarks, pos[2:2 + tau.size].reshape(T, N, 2), trial_rng(seed, case.index, b, 1))
    return {"t_end_s": t_end, "truth": pos[2 + tau.size:], "start": np.r_[pos[0], (pos[1] - pos[0]) / 1e-3],
            "slots": np.zeros(T, np.int64), "reads": np.zeros(T, np.int64), **det}


def _sample_level_track(config: Config, case: Case, b: int, seed: int) -> dict:
    """Truth, PF-BIN start and the detections of realization b heard through sample-level Gen2
    rounds (:func:`rfsim.scenarios._st_sample_level.listen_track`, streams ``trial_rng(seed, case, b, 2, k)``)."""
    h = config.sample_level.st_height_m

    def centre(t):
        return np.r_[truth_at(config, case, b, seed, np.array([t]))[0], h]

    res = listen_track(config.room, centre, rounds=config.rounds, sl=config.sample_level, st_config=config.st,
                       seed=seed, key=(case.index, b, 2))
    pos = truth_at(config, case, b, seed, np.concatenate([[0.0, 1e-3], res.t_end_s]))
    T = res.t_end_s.size
    return {"t_end_s": res.t_end_s, "truth": pos[2:], "start": np.r_[pos[0], (pos[1] - pos[0]) / 1e-3],
            "counts": res.counts, "mean_detection_s": res.mean_detection_s, "active": np.zeros(T, np.int64),
            "slots": res.slots_per_period, "reads": res.reads_per_period}


def _trackers(config: Config, case: Case, group: int, tracks: list[dict], base, landmarks,
              seed: int) -> dict[str, np.ndarray]:
    """Every tracker of the case on realizations with a common number of periods: (B, T, 2) each.
    The filters' period Δt is the mean period of the tracks (T_s in the surrogate mode)."""
    f, N = config.filters, config.rounds
    counts = np.stack([d["counts"] for d in tracks])
    mean_t = np.stack([d["mean_detection_s"] for d in tracks])
    active = np.stack([d["active"] for d in tracks])
    t_end = np.stack([d["t_end_s"] for d in tracks])
    Ts = float(np.mean(t_end[:, -1] / t_end.shape[1]))

    def probability(p, t):
        d = np.linalg.norm(p[:, :, None, :] - landmarks, axis=-1)
        return rts_p(base[active[:, t]][:, None, :], d)

    estimates = {}
    for k, (label, kind, vt) in enumerate(case.trackers):
        rng = trial_rng(seed, case.index, 1000 + group, k)
        if kind == "wcl":
            est = _landmark_pf.wcl_track(counts, landmarks, np.mean(landmarks, axis=0))
        elif kind == "pfbin":
            est = _landmark_pf.pf_bin(counts, np.stack([d["start"] for d in tracks]), n_particles=f.particles, period_s=Ts,
                                      accel_var=f.pfbin_accel_var, n_rounds=N, probability=probability, rng=rng)
        else:
            x, v = _landmark_pf.pf_aa(counts, landmarks, n_particles=f.particles, period_s=Ts, q_std_m=f.q_std_m,
                                      init_std_m=f.init_std_m, b0=f.b0, b1=f.b1, n_rounds=N, probability=probability, rng=rng)
            if np.isfinite(vt):
                est = np.concatenate([_landmark_pf.bias_compensate(x[i:i + 1], v[i:i + 1], period_end_s=t_end[i],
                                                                   mean_detection_s=mean_t[i:i + 1], b0=f.b0, b1=f.b1,
                                                                   v_threshold_mps=vt) for i in range(len(tracks))])
            else:
                est = x
        estimates[label] = est
    return estimates


def simulate_chunk(config: Config, case: Case, group: int, bs: list[int], seed: int) -> dict[str, dict]:
    """Detections and every tracker of realizations ``bs`` of ``case``: per-table columns.

    Surrogate: the trackers run on the chunk at once. Sample level: the tracks have their own
    period counts, and the trackers run per realization (tracker streams
    ``trial_rng(seed, c, 2000 + 100·g + i, f)`` for realization i of chunk g)."""
    room = config.room
    landmarks = room.landmarks_xy()
    base = antenna_geometry(room, landmarks)
    sample = config.mode == "sample-level"
    tracks = [(_sample_level_track(config, case, b, seed) if sample else
               _surrogate_track(config, case, b, seed, base, landmarks)) for b in bs]
    if sample:
        est = [_trackers(config, case, 1000 + 100 * group + i, [d], base, landmarks, seed)
               for i, d in enumerate(tracks)]
    else:
        est = [_trackers(config, case, group, tracks, base, landmarks, seed)]
        est = [{k: v[i:i + 1] for k, v in est[0].items()} for i in range(len(tracks))]
    periods, detections, est_rows = [], [], []
    for b, d, e in zip(bs, tracks, est):
        T = d["t_end_s"].size
        c, truth = d["counts"], d["truth"]
        dur = np.diff(np.r_[0.0, d["t_end_s"]])
        periods.append({"case": np.full(T, case.index), "realization": np.full(T, b), "period": np.arange(T),
                        "t_end_s": d["t_end_s"], "period_duration_s": dur, "x_true_m": truth[:, 0],
                        "y_true_m": truth[:, 1], "detected_landmarks": (c > 0).sum(axis=1),
                        "detections": c.sum(axis=1), "mean_detection_s": d["mean_detection_s"],
                        "active_antenna": d["active"], "slots": d["slots"], "reads": d["reads"]})
        nz = np.nonzero(c)
        detections.append({"case": np.full(nz[0].size, case.index), "realization": np.full(nz[0].size, b),
                           "period": nz[0], "landmark": nz[1], "count": c[nz]})
        for label, x in e.items():
            err = np.linalg.norm(x[0] - truth, axis=-1)
            est_rows.append({"case": np.full(T, case.index), "realization": np.full(T, b), "period": np.arange(T),
                             "tracker": np.full(T, label), "x_est_m": x[0, :, 0], "y_est_m": x[0, :, 1],
                             "error_m": err})
    labels = [t[0] for t in case.trackers]
    order = sorted(range(len(est_rows)), key=lambda i: labels.index(est_rows[i]["tracker"][0]))
    return {"periods": concat(periods), "detections": concat(detections),
            "estimates": concat([est_rows[i] for i in order])}


def _task(args):
    return simulate_chunk(*args)


def monte_carlo(config: Config, *, seed: int) -> dict[str, dict[str, np.ndarray]]:
    """Every case in chunks of ≤ 10 realizations on ``config.workers`` processes, in order."""
    tasks = []
    for c in cases(config):
        for g, a in enumerate(range(0, c.realizations, 10)):
            tasks.append((config, c, g, list(range(a, min(a + 10, c.realizations))), seed))
    parts = map_in_order(_task, tasks, config.workers, desc="cases", unit="chunks")
    return {n: concat([p[n] for p in parts]) for n in ("periods", "detections", "estimates")}


# ----------------------------------------------------------------------------- summary and run


def case_rmse(est, case: int, tracker: str) -> float:
    """Time average of RMSE_t = sqrt(mean over realizations of err_t²), over the periods t that
    some realization has (sample level: tracks of unequal period counts)."""
    sel = (est["case"] == case) & (est["tracker"] == tracker)
    n_periods = int(est["period"][sel].max()) + 1 if sel.any() else 0
    e2 = np.zeros(n_periods)
    cnt = np.zeros(n_periods)
    np.add.at(e2, est["period"][sel], est["error_m"][sel] ** 2)
    np.add.at(cnt, est["period"][sel], 1)
    ok = cnt > 0
    return float(np.mean(np.sqrt(e2[ok] / cnt[ok]))) if ok.any() else float("nan")


def case_mean_error(est, case: int, tracker: str) -> float:
    """The source's "average RMSE": the ℓ2 error ‖x̃_t − x_t‖ ("the RMSE for one realization",
    L4507-L4513; "ℓ2-norm of the difference between estimation and true location", L5383-L5385)
    averaged over realizations and time."""
    sel = (est["case"] == case) & (est["tracker"] == tracker)
    return float(np.mean(est["error_m"][sel])) if sel.any() else float("nan")


def summarize(config: Config, tables) -> tuple[dict[str, np.ndarray], dict]:
    """One row per (case, tracker): the source's average RMSE (:func:`case_mean_error`) beside the
    published value, the RMS error (:func:`case_rmse`), the change vs WCL (of the source's
    measure); and the headline numbers (crossover speed, PF-AA / SQLAM vs WCL, lab) as attributes,
    all of the source's measure."""
    est = tables["estimates"]
    rows: dict[str, list] = {k: [] for k in ("case", "experiment", "trajectory", "speed_mps", "realizations",
                                             "duration_s", "tracker", "mean_error_m", "rmse_m", "published_rmse_m",
                                             "vs_wcl_percent", "published_vs_wcl_percent")}
    attrs: dict = {}
    sweep: dict[str, list] = {}
    for c in cases(config):
        vals = {label: case_mean_error(est, c.index, label) for label, _, _ in c.trackers}
        for label, value in vals.items():
            pub = PUBLISHED.get((c.experiment, label, c.speed_mps), np.nan)
            rel = 100.0 * (value / vals["wcl"] - 1.0) if "wcl" in vals and label != "wcl" else np.nan
            pub_rel = np.nan
            if c.experiment == "random-walk" and label != "wcl":
                pub_rel = PUBLISHED["pfaa_vs_wcl_percent"] if config.preset == "pfaa" else (
                    PUBLISHED["sqlam_vs_wcl_percent"] if config.preset == "sqlam" else np.nan)
                attrs[f"{label}_vs_wcl_percent"] = rel
                attrs[f"{label}_random_walk_rmse_m"] = value
            for k, v in zip(rows, (c.index, c.experiment, c.trajectory, c.speed_mps, c.realizations, c.duration_s,
                                   label, value, case_rmse(est, c.index, label), pub, rel, pub_rel)):
                rows[k].append(v)
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
    return {k: np.asarray(v) for k, v in rows.items()}, attrs


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    tables = monte_carlo(config, seed=seed)
    summary, attrs = summarize(config, tables)
    tables["summary"] = summary
    cs = cases(config)
    tables["truth"] = {k: tables["periods"][k] for k in ("case", "realization", "period", "t_end_s", "x_true_m",
                                                         "y_true_m")}
    tables["cases"] = {"case": np.array([c.index for c in cs]), "experiment": np.array([c.experiment for c in cs]),
                       "trajectory": np.array([c.trajectory for c in cs]),
                       "speed_mps": np.array([c.speed_mps for c in cs]),
                       "realizations": np.array([c.realizations for c in cs]),
                       "duration_s": np.array([c.duration_s for c in cs])}
    ds = _dataset.Dataset(title=f"sense-a-tag localization from landmark detections (AURIS ch. 4), preset {config.preset}")
    for name in ("detections", "periods", "truth", "estimates", "summary", "cases"):
        ds.add_table(name, {k: _dataset.column(v, _unit(k), _describe(k)) for k, v in tables[name].items()},
                     description=_GROUPS[name])
    room = config.room
    ds.attrs.update({"preset": config.preset, "mode": config.mode, "bounds_m": np.asarray(room.bounds_m),
                     "landmarks_xy_m": room.landmarks_xy(), "antennas_xyz_m": np.asarray(room.antennas_xyz_m),
                     "trajectory_1_xy_m": np.asarray(config.trajectory_1_xy_m, float),
                     "trajectory_2_xy_m": paths.trajectory_2_xy(200), "detection_period_s": config.period_s})
    if config.mode == "sample-level":
        dur = tables["periods"]["period_duration_s"]
        ds.attrs.update({"detection_period_s": float(np.mean(dur)), "detection_period_std_s": float(np.std(dur)),
                         "source_detection_period_s": config.period_s,
                         "slots_per_period": float(np.mean(tables["periods"]["slots"])),
                         "reads_per_period": float(np.mean(tables["periods"]["reads"])),
                         "detection_period_meaning": "mean duration of a query period of N QT rounds at sample "
                                                     "level (the source assumed 0.3 s)"})
    ds.attrs.update(attrs)
    for key in [k for k, v in ds.attrs.items() if isinstance(v, float) and not np.isfinite(v)]:
        ds.attrs[f"{key}_meaning"] = "NaN: the curves do not cross inside the swept speeds (or no WCL reference)"
    return ds


def _unit(key: str) -> str:
    if key.endswith("_percent"):
        return "%"
    return next((u for suf, u in (("_mps", "m/s"), ("_m", "m"), ("_s", "s")) if key.endswith(suf)), "1")


_TEXT = {
    "case": "index of the case (experiment, trajectory, speed) in the cases table",
    "realization": "realization (independent detections, and walk) of the case",
    "period": "query period index t (the period ends at (t + 1) T_s)", "landmark": "landmark index (grid order)",
    "count": "detections n_{t,k} of the landmark among the N rounds of the period (zeros not stored)",
    "t_end_s": "end of the period (the estimate's time)",
    "period_duration_s": "duration of the query period (T_s in the surrogate mode; sample level: N QT rounds)",
    "slots": "Gen2 slots of the period's N QT rounds (sample level; 0 in the surrogate mode)",
    "reads": "landmark EPCs the reader read in the period (sample level; 0 in the surrogate mode)",
    "x_true_m": "true x of the ST at the period end",
    "y_true_m": "true y of the ST at the period end", "detected_landmarks": "landmarks detected at least once",
    "detections": "detections summed over landmarks and rounds",
    "mean_detection_s": "mean detection time t-hat of the period (Eq. 4.23; NaN: nothing detected)",
    "active_antenna": "reader antenna active in the period (nearest to the previous WCL estimate)",
    "tracker": "tracker: wcl, pfbin, pfaa (v_threshold), pfaa-never / pfaa-always, sqlam",
    "x_est_m": "estimated x (compensated where the tracker compensates)",
    "y_est_m": "estimated y of the tracker at the period end (compensated where the tracker compensates)",
    "error_m": "distance from the estimate to the true position", "experiment": "speed-sweep, trajectory-2 or random-walk",
    "trajectory": "trajectory: 1, 2 (Fig. 4.10 replicas) or random-walk",
    "speed_mps": "constant speed on trajectories 1 and 2 (NaN for the random walk)",
    "realizations": "realizations of the case", "duration_s": "tracking duration of the case",
    "mean_error_m": "the source's average RMSE: the l2 error averaged over realizations and periods (L4507, L5383)",
    "rmse_m": "time average of the RMS error over realizations",
    "published_rmse_m": "the source's average RMSE (compare mean_error_m; NaN: none)",
    "vs_wcl_percent": "change of mean_error_m against WCL on the same detections",
    "published_vs_wcl_percent": "the source's change against WCL (L4650, L5415; NaN: none)",
}

_GROUPS = {
    "detections": "one row per (case, realization, period, landmark) with at least one detection",
    "periods": "one row per (case, realization, query period): duration, truth, detection totals, active antenna",
    "truth": "true ST position at the end of every query period of every realization",
    "estimates": "one row per (case, realization, period, tracker): estimate and error",
    "summary": "one row per (case, tracker): RMSE beside the published value and the change vs WCL",
    "cases": "one row per case: experiment, trajectory, speed, realizations, duration",
}


def _describe(key: str) -> str:
    return _TEXT.get(key, key.replace("_", " "))


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Room with landmarks and tracks, error vs time, error CDF, speed sweep, RMSE vs published."""
    return _st_figures.plot_all(Path(dataset_path), Path(out_dir))


__all__ = ["NAME", "DESCRIPTION", "Config", "run", "plot", "cases", "simulate_chunk", "summarize", "PUBLISHED"]

"""Rooms of Özkaya's active-RFID RSSI study (2011): the presets' floor plans, their published
results, and the statistical beacon draws of a localization run in them.

Simulation rooms (rssi-localization.md §2.4, seeds/002 L1133–L1155, L1266, L1283–L1297): a
single 5 × 8 m room with readers at 3 corners (the "5 m and 8 m separations", L1297) or at all
4, and the 10 × 16 m variant with doubled separations. Grid cells (k_CELL = 28 / 135) are the
interior integer points (§2.4 [not in source] inferred layout). Reader and tag at the same
height: the plan is 2-D. α = −52 dBm, n = 2.3 for every reader (L1141–L1144).

Home replica (§2.1, L955–L957, L1743–L1745; the coordinates exist only in Figs. 6.1, 7.17 and
7.21, so this plan is chosen and recorded here): a 3 × 4 m room (x ∈ [0, 3]) beside a 6 × 4 m
room (x ∈ [3, 9]), y ∈ [0, 4], one brick wall x = 3 (WAF 2 dB per crossing, L1000). Reader 3
in the small room, readers 1 and 2 in opposite corners of the large room, 0.1 m in from the
walls, at 1.2 m; tags at 1 m. Reader parameters of Table 6.1 (L1002–L1007). 36 cells of 1 m²
(12 + 24), 4 reference tags, two per room toward the centre (L957); 25 fixed test points at
least 1 m from the walls (L1820–L1827); mobile paths along +y at 0.5 m/step, y = 0.25 → 3.75 m
in each room (the thesis's 0 → 3.5 m and 0 → 4 m, L1831, kept inside the rooms).

Noise model: **independent per reader** (see rfsim.channels.rss; dataset attribute ``noise_model``):
it reproduces Table 7.3, a term shared by all readers does not (wave2-specs.md §R: 1.24/1.61/
1.82/2.01 m shared vs 1.36/1.92/2.20/2.48 m independent; tested with the scenario). Physically each reader
sees the tag through its own obstacles, orientation and multipath. Simulation presets: all of σ0² quasi-static and
independent per position (the thesis's "noise drawn once per run"), no quantization. Home: 75 %
of σ_j² quasi-static with Gudmundson correlation (d_corr = 3 m, so that a target near a
reference tag shares its error, §1.9), 25 % a people term redrawn per beacon, 1 dB RSSI steps
(L1787); these shares are this replica's choice, the thesis does not split its σ. The share
decides the home's fixed-target ordering: with 75 % quasi-static, grid Bayes ties the offline
NN; with all of σ² quasi-static it falls behind both NNs as in Table 7.41, but then loses the
mobile grid < online NN of Table 7.42 (tested with the scenario ``rss-localization``). Grid Bayes
fixed at σ0 = 1 dB is ≈ 13 % above Table 7.11: the targets are uniform in the room, and the
28 cell centres leave a 1 m strip along the walls that no estimate on them reaches (tested).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.rng import trial_rng
from rfsim.scenes.active_beacons import TX_POWER_DBM

# the physics is imported on first use: a configuration (rfsim config) needs only the plans
_large_scale = lazy_import("rfsim.channels.large_scale")
_rss = lazy_import("rfsim.channels.rss")
_rows = lazy_import("rfsim.core.rows")
_calibration = lazy_import("rfsim.estimators.calibration")


@dataclass(frozen=True)
class FloorPlan:
    """Geometry of one preset (all in metres; 2-D plan, heights separate)."""

    name: str
    bounds: tuple[float, float, float, float]          # xmin, ymin, xmax, ymax of the area
    readers_xy: tuple[tuple[float, float], ...]
    walls_xy: tuple[tuple[float, float, float, float], ...]
    reader_params: tuple[tuple[float, float, float], ...]  # (α dBm, n, σ dB) per reader
    cells_xy: np.ndarray
    reference_xy: np.ndarray
    fixed_points_xy: np.ndarray | None
    mobile_paths_xy: tuple[np.ndarray, ...]
    reader_height_m: float
    tag_height_m: float


def _interior_points(width: float, length: float) -> np.ndarray:
    return np.array([(x, y) for x in range(1, int(width)) for y in range(1, int(length))], float)


def _corners(width: float, length: float, n: int) -> tuple[tuple[float, float], ...]:
    corners = ((0.0, 0.0), (width, 0.0), (0.0, length), (width, length))
    return corners[:n]


def simulation_plan(width_m: float, length_m: float, n_readers: int, alpha_dbm: float,
                    exponent: float) -> FloorPlan:
    """A single room with readers at ``n_readers`` corners and cells at the interior integer points.

    Parameters
    ----------
    width_m, length_m : float
        The room's size [m].
    n_readers : int
        Readers at the corners (0, 0), (w, 0), (0, l), (w, l), in that order.
    alpha_dbm : float
        α of every reader: RSS at 1 m [dBm].
    exponent : float
        Path-loss exponent n of every reader.

    Returns
    -------
    FloorPlan
        Named ``sim-<w>x<l>``, 2-D (readers and tag at 1 m), no walls or reference tags.
    """
    return FloorPlan(
        name=f"sim-{width_m:g}x{length_m:g}", bounds=(0.0, 0.0, width_m, length_m),
        readers_xy=_corners(width_m, length_m, n_readers), walls_xy=(),
        reader_params=((alpha_dbm, exponent, 0.0),) * n_readers,
        cells_xy=_interior_points(width_m, length_m), reference_xy=np.zeros((0, 2)),
        fixed_points_xy=None, mobile_paths_xy=(), reader_height_m=1.0, tag_height_m=1.0)


def home_plan() -> FloorPlan:
    """The two-room home replica (Table 6.1 readers, 4 reference tags).

    Returns
    -------
    FloorPlan
        ``home-2room`` (module docstring): 36 cells, 25 fixed test points, two mobile paths.
    """
    cells = np.array([(x + 0.5, y + 0.5) for x in range(9) for y in range(4)], float)
    fixed = [(x, y) for x in (1.0, 2.0) for y in (1.0, 2.0, 3.0)]
    fixed += [(x, y) for x in (4.0, 5.0, 6.0, 7.0, 8.0) for y in (1.0, 2.0, 3.0)]
    fixed += [(4.5, 1.5), (5.5, 2.5), (6.5, 1.5), (7.5, 2.5)]
    ys = np.arange(0.25, 3.751, 0.5)
    paths = (np.column_stack([np.full(ys.size, 1.5), ys]), np.column_stack([np.full(ys.size, 6.0), ys]))
    return FloorPlan(
        name="home-2room", bounds=(0.0, 0.0, 9.0, 4.0),
        readers_xy=((8.9, 3.9), (3.1, 0.1), (0.1, 0.1)),
        walls_xy=((3.0, 0.0, 3.0, 4.0),),
        reader_params=((-42.0, 2.3, 5.3), (-52.0, 2.3, 5.2), (-45.0, 2.5, 5.0)),
        cells_xy=cells, reference_xy=np.array([(1.5, 1.3), (1.5, 2.7), (5.0, 2.0), (7.0, 2.0)]),
        fixed_points_xy=np.array(fixed), mobile_paths_xy=paths, reader_height_m=1.2,
        tag_height_m=1.0)


def preset_plan(preset: str, n_readers: int, alpha_dbm: float, exponent: float) -> FloorPlan:
    """The floor plan of a preset.

    Parameters
    ----------
    preset : {"sim-5x8", "sim-10x16", "home-2room"}
        The preset.
    n_readers : int
        Corner readers of the simulation rooms.
    alpha_dbm : float
        α of the simulation rooms' readers [dBm].
    exponent : float
        n of the simulation rooms' readers.

    Returns
    -------
    FloorPlan
        :func:`home_plan`, or :func:`simulation_plan` of 5 × 8 m or 10 × 16 m.
    """
    if preset == "home-2room":
        return home_plan()
    w, l = (5.0, 8.0) if preset == "sim-5x8" else (10.0, 16.0)
    return simulation_plan(w, l, n_readers, alpha_dbm, exponent)


def with_overrides(plan: FloorPlan, *, readers_xy=None, walls_xy=None) -> FloorPlan:
    """``plan`` with other reader positions and walls, validated.

    Overridden readers keep the plan's per-reader (α, n, σ) when their number is unchanged;
    otherwise every reader takes the first reader's parameters.

    Parameters
    ----------
    plan : FloorPlan
        The plan.
    readers_xy : sequence of (float, float) or None
        Reader positions [m] (None: the plan's).
    walls_xy : sequence of (float, float, float, float) or None
        Walls (x0, y0, x1, y1) [m] (None: the plan's).

    Returns
    -------
    FloorPlan
        The plan with those readers and walls.

    Raises
    ------
    ConfigError
        No reader, a reader outside the plan's bounds or a wall of zero length (one line
        naming ``readers_xy[i]`` or ``walls_xy[i]``).
    """
    xmin, ymin, xmax, ymax = plan.bounds
    readers = plan.readers_xy if readers_xy is None else readers_xy
    if len(readers) == 0:
        raise ConfigError("readers_xy", [], "at least one reader position [x, y] in m")
    for i, (x, y) in enumerate(readers):
        if not (xmin <= x <= xmax and ymin <= y <= ymax):
            raise ConfigError(f"readers_xy[{i}]", [x, y], f"a point inside the floor plan "
                              f"[{xmin:g}, {xmax:g}] x [{ymin:g}, {ymax:g}] m")
    walls = plan.walls_xy if walls_xy is None else walls_xy
    for i, (x0, y0, x1, y1) in enumerate(walls):
        if not np.hypot(x1 - x0, y1 - y0) > 0:
            raise ConfigError(f"walls_xy[{i}]", [x0, y0, x1, y1], "a wall segment of non-zero length")
    params = plan.reader_params
    if len(readers) != len(params):
        params = (params[0],) * len(readers)
    return FloorPlan(plan.name, plan.bounds, tuple(readers), tuple(walls), params, plan.cells_xy,
                     plan.reference_xy, plan.fixed_points_xy, plan.mobile_paths_xy,
                     plan.reader_height_m, plan.tag_height_m)


#: The thesis's settings per preset where the configuration leaves them open: LANDMARC k (Tables 7.3,
#: 7.6; L1814), trials per case (home: per test point or walk), the quasi-static shadowing's
#: Gudmundson distance [m] and share of σ² (module docstring), the readers' RSSI step [dB].
PRESET_DEFAULTS = {
    "sim-5x8": dict(nn_k=4, trials=1000, decorrelation_m=0.0, static_fraction=1.0, report_step_db=0.0),
    "sim-10x16": dict(nn_k=68, trials=1000, decorrelation_m=0.0, static_fraction=1.0, report_step_db=0.0),
    "home-2room": dict(nn_k=36, trials=4, decorrelation_m=3.0, static_fraction=0.75, report_step_db=1.0),
}


def scored_steps(motion: str, n_rt: int, n_steps: int) -> np.ndarray:
    """The estimates the thesis scores (§2.4, L1319–L1327).

    Parameters
    ----------
    motion : {"fixed", "mobile"}
        The target's motion.
    n_rt : int
        Recursions rt of the estimator.
    n_steps : int
        Beacons per track.

    Returns
    -------
    ndarray of bool, shape (n_steps,)
        A fixed target scored after the last of its ``n_rt`` recursions, a mobile one at each
        of its first ``n_rt`` steps.
    """
    mask = np.zeros(n_steps, bool)
    if motion == "fixed":
        mask[n_rt - 1] = True
    else:
        mask[:n_rt] = True
    return mask


#: Recursions rt per σ = σ0 of the thesis's tables (grid: Tables 7.10/7.11; SIR: 7.15/7.16).
RECURSIONS = {"grid": {1.0: 8, 3.0: 8, 5.2: 10, 7.0: 12, 9.0: 16},
              "pf": {1.0: 6, 3.0: 8, 5.2: 10, 7.0: 16, 9.0: 20}}

#: Published RMSE [m] (and where printed mean/median/p90/std), keyed
#: (preset, readers, estimator, motion, σ0). Sources: Tables 7.2, 7.3, 7.6, 7.7, 7.9, 7.10,
#: 7.11, 7.14, 7.15, 7.16 (seeds/002 L1186–L1554; rssi-localization.md §3.2–3.4).
PUBLISHED: dict[tuple[str, int, str, str, float], tuple[float, ...]] = {
    ("sim-5x8", 3, "nn", "fixed", 3.0): (1.38, 1.18, 1.01, 2.21, 0.71),
    ("sim-5x8", 3, "nn", "fixed", 5.2): (1.95, 1.66, 1.46, 3.09, 1.0),
    ("sim-5x8", 3, "nn", "fixed", 7.0): (2.29, 1.95, 1.74, 3.61, 1.20),
    ("sim-5x8", 3, "nn", "fixed", 9.0): (2.57, 2.2, 2.00, 4.10, 1.33),
    ("sim-5x8", 4, "nn", "fixed", 5.2): (1.74, 1.49, 1.30, 2.76, 0.91),
    ("sim-10x16", 3, "nn", "fixed", 5.2): (3.73, 3.32, 3.10, 5.58, 1.69),
    ("sim-10x16", 4, "nn", "fixed", 5.2): (3.39, 3.07, 2.98, 4.92, 1.44),
    ("sim-5x8", 3, "grid-mmse", "mobile", 1.0): (0.57, 0.49, 0.49, 0.80, 0.24),
    ("sim-5x8", 3, "grid-mmse", "mobile", 3.0): (0.97, 0.84, 0.77, 1.44, 0.42),
    ("sim-5x8", 3, "grid-mmse", "mobile", 5.2): (1.22, 1.09, 1.02, 1.81, 0.54),
    ("sim-5x8", 3, "grid-mmse", "mobile", 7.0): (1.34, 1.18, 1.12, 1.96, 0.58),
    ("sim-5x8", 3, "grid-mmse", "mobile", 9.0): (1.51, 1.33, 1.29, 2.20, 0.62),
    ("sim-5x8", 4, "grid-mmse", "mobile", 5.2): (1.12, 0.97, 0.92, 1.64, 0.49),
    ("sim-5x8", 3, "grid-map", "mobile", 1.0): (0.67,),
    ("sim-5x8", 3, "grid-map", "mobile", 3.0): (1.06,),
    ("sim-5x8", 3, "grid-map", "mobile", 5.2): (1.40,),
    ("sim-5x8", 3, "grid-mmse", "fixed", 1.0): (0.65, 0.55, 0.47, 0.97, 0.35),
    ("sim-5x8", 3, "grid-mmse", "fixed", 3.0): (1.36, 1.17, 1.05, 2.13, 0.70),
    ("sim-5x8", 3, "grid-mmse", "fixed", 5.2): (1.83, 1.54, 1.34, 2.91, 0.98),
    ("sim-5x8", 3, "grid-mmse", "fixed", 7.0): (2.07, 1.77, 1.54, 3.33, 1.07),
    ("sim-5x8", 3, "grid-mmse", "fixed", 9.0): (2.34, 2.00, 1.83, 3.86, 1.21),
    ("sim-5x8", 3, "pf-mmse", "fixed", 1.0): (0.63, 0.53, 0.46, 0.97, 0.34),
    ("sim-5x8", 3, "pf-mmse", "fixed", 3.0): (1.48, 1.29, 1.22, 2.23, 0.73),
    ("sim-5x8", 3, "pf-mmse", "fixed", 5.2): (2.00, 1.70, 1.51, 3.09, 1.07),
    ("sim-5x8", 3, "pf-mmse", "fixed", 7.0): (2.38, 2.06, 1.86, 3.65, 1.20),
    ("sim-5x8", 3, "pf-mmse", "fixed", 9.0): (2.55, 2.18, 1.92, 4.19, 1.32),
    ("sim-5x8", 3, "pf-mmse", "mobile", 1.0): (0.53, 0.43, 0.37, 0.84, 0.27),
    ("sim-5x8", 3, "pf-mmse", "mobile", 3.0): (0.97, 0.83, 0.77, 1.44, 0.45),
    ("sim-5x8", 3, "pf-mmse", "mobile", 5.2): (1.14, 0.98, 0.88, 1.77, 0.54),
    ("sim-5x8", 3, "pf-mmse", "mobile", 7.0): (1.38, 1.21, 1.13, 2.11, 0.67),
    ("sim-5x8", 3, "pf-mmse", "mobile", 9.0): (1.45, 1.27, 1.23, 2.18, 0.68),
    ("sim-5x8", 3, "pf-map", "mobile", 1.0): (0.64,),
    ("sim-5x8", 3, "pf-map", "mobile", 3.0): (1.41,),
    ("sim-5x8", 3, "pf-map", "mobile", 5.2): (2.06,),
}

#: Home replica, RMSE [m] (Tables 7.41 fixed, 7.42 mobile; L2077–L2097).
PUBLISHED_HOME: dict[tuple[str, str], float] = {
    ("nn-pattern", "fixed"): 1.32, ("nn-offline", "fixed"): 1.68, ("nn-online", "fixed"): 1.63,
    ("grid", "fixed"): 2.04, ("grid-auto-sigma", "fixed"): 1.98, ("grid-smoothing", "fixed"): 1.87,
    ("pf-improved", "fixed"): 1.72,
    ("nn-offline", "mobile"): 1.84, ("nn-online", "mobile"): 1.73, ("grid", "mobile"): 1.58,
    ("grid-auto-sigma", "mobile"): 1.50, ("grid-smoothing", "mobile"): 1.37,
    ("pf-improved", "mobile"): 1.32, ("pf-improved-sigma-smoothing", "mobile"): 1.25,
}


def published(preset: str, n_readers: int, estimator: str, motion: str, sigma0_db: float):
    """The thesis's published errors of a case (:data:`PUBLISHED`, :data:`PUBLISHED_HOME`).

    Parameters
    ----------
    preset : str
        The plan's name.
    n_readers : int
        Its number of readers.
    estimator : str
        The estimator's name (e.g. ``nn``, ``grid-mmse``, ``pf-improved``).
    motion : {"fixed", "mobile"}
        The target's motion.
    sigma0_db : float
        σ0 of the case [dB] (rounded to 3 decimals; ignored in the home).

    Returns
    -------
    tuple of float or None
        (RMSE, mean, median, p90, std) [m] or (RMSE,), None where the thesis has no value;
        home: (RMSE or None,).
    """
    if preset == "home-2room":
        return (PUBLISHED_HOME.get((estimator, motion)),)
    return PUBLISHED.get((preset, n_readers, estimator, motion, round(float(sigma0_db), 3)))


@dataclass(frozen=True)
class ShadowingConfig:
    """Shadowing and people term of :func:`draw_beacons` (None: the preset's, :data:`PRESET_DEFAULTS`)."""

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



def noise_model(*, shared: bool) -> str:
    """One line on the readers' noise model (``ShadowingConfig.readers``) and what it reproduces.

    Parameters
    ----------
    shared : bool
        One quasi-static term shared by all readers (else independent per reader).

    Returns
    -------
    str
        The dataset attribute ``noise_model``.
    """
    return (("one term shared by all readers" if shared else "independent per reader")
            + ", quasi-static per position: the independent model reproduces Table 7.3 "
              "(NN 1.36/1.92/2.20/2.48 m vs 1.38/1.95/2.29/2.57), a shared term does not "
              "(1.24/1.61/1.82/2.01 m)")


# --------------------------------------------------------------------------- the beacons of a run


def rss_channel(plan: FloorPlan, waf_db: float, sigma_db=None) -> _rss.RssChannel:
    r"""The per-reader log-distance channel of ``plan`` (rfsim.channels.rss).

    Mean RSS at reader j of a tag at distance :math:`d_j` behind :math:`n_{W,j}` walls
    (seeds/002 L1133–L1155):

    .. math:: \bar P_j = \alpha_j - 10 n_j \log_{10}(d_j / 1\,\mathrm{m}) - n_{W,j} \mathrm{WAF}

    Parameters
    ----------
    plan : FloorPlan
        Readers (at ``reader_height_m``), their (α, n, σ) and walls.
    waf_db : float
        WAF: attenuation per wall crossing [dB].
    sigma_db : float or None
        σ_j of every reader [dB] (None: the plan's).

    Returns
    -------
    rfsim.channels.rss.RssChannel
        The channel.
    """
    readers = [_rss.ReaderLink((x, y, plan.reader_height_m), a, n, s if sigma_db is None else sigma_db)
               for (x, y), (a, n, s) in zip(plan.readers_xy, plan.reader_params)]
    walls = [_large_scale.Wall.segment_2d((x0, y0), (x1, y1), waf_db) for x0, y0, x1, y1 in plan.walls_xy]
    return _rss.RssChannel(readers, walls)


def _xyz(xy: np.ndarray, z: float) -> np.ndarray:
    return np.concatenate([xy, np.full(xy.shape[:-1] + (1,), z)], axis=-1)


def random_walk(start_xy, n_steps: int, step_std_m: float, bounds, *, rng: np.random.Generator) -> np.ndarray:
    """Gaussian random walk whose steps leaving the room are redrawn (D0, §2.4).

    Parameters
    ----------
    start_xy : array_like, shape (2,)
        First position [m].
    n_steps : int
        Positions of the walk.
    step_std_m : float
        Std of each coordinate's step [m].
    bounds : tuple of float
        (xmin, ymin, xmax, ymax) of the room [m].
    rng : numpy.random.Generator
        The trial's stream.

    Returns
    -------
    ndarray, shape (n_steps, 2)
        The positions [m].
    """
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
    """Simulated beacons of one case: truth (B, T, 2) [m], true/reported RSS (B, T, J) [dBm] of the
    target and (B, T, J, I) of the reference tags, the pattern map (B, M, J) [dBm], and in the
    waveform mode the beacons' start times."""

    truth_xy: np.ndarray
    rss_dbm: np.ndarray
    reported_dbm: np.ndarray
    ref_rss_dbm: np.ndarray
    ref_reported_dbm: np.ndarray
    pattern_map_dbm: np.ndarray | None
    #: waveform mode: start time [s] of every tag's beacon (B, T, 1 + I) (NaN: dropped by LBT)
    beacon_t_s: np.ndarray | None = None


#: Fingerprint campaign (Sec. 6.3, L1057–L1061): 40 vectors per cell, tag moved within 20 cm.
FINGERPRINTS_PER_CELL = 40


def _fingerprint_points(plan: FloorPlan, rng) -> np.ndarray:
    jitter = rng.uniform(-0.1, 0.1, size=(plan.cells_xy.shape[0], FINGERPRINTS_PER_CELL, 2))
    return (plan.cells_xy[:, None, :] + jitter).reshape(-1, 2)


def _home_track(plan: FloorPlan, motion: str, trial: int, n_steps: int) -> np.ndarray:
    if motion == "fixed":
        p = plan.fixed_points_xy[trial % plan.fixed_points_xy.shape[0]]
        return np.repeat(p[None], n_steps, axis=0)
    return plan.mobile_paths_xy[trial % len(plan.mobile_paths_xy)]


def draw_beacons(plan: FloorPlan, channel: _rss.RssChannel, report, *, case: int, motion: str, n_tracks: int,
                 n_steps: int, step_std_m: float, decorrelation_m: float, static_fraction: float,
                 shared: bool, people_correlation: float, seed: int) -> CaseData:
    r"""Draw every trial's track and beacons of one case (rfsim.channels.rss model).

    A plan with test points (``fixed_points_xy``, the home replica) puts the target on them
    (``fixed``) or on its paths (``mobile``) in turn and runs the fingerprint survey (40 reads
    per cell); otherwise the target starts uniformly in the room and stands (``fixed``) or walks
    (:func:`random_walk`, ``step_std_m``). σ_j² splits into ``static_fraction`` quasi-static
    shadowing (per position and reader, Gudmundson ``decorrelation_m`` [m], one term for every
    reader if ``shared``) and a people term per beacon (AR(1) ``people_correlation``); ``report``
    (:class:`rfsim.devices.rss_reader.RssReport`) turns the powers into reports. Trial b uses
    ``trial_rng(seed, case, 0, b)``. The received power (module docstring; seeds/002 L1133–L1155):

    .. math:: P_j = \bar P_j(x) + \sqrt{f}\,\sigma_j X_j(x) + \sqrt{1 - f}\,\sigma_j Y_{j,t}

    with :math:`\bar P_j` of :func:`rss_channel`, :math:`f` = ``static_fraction``, :math:`X`
    the unit quasi-static shadowing and :math:`Y` the unit people term.

    Parameters
    ----------
    plan : FloorPlan
        The floor plan (its fixed points and paths in the home).
    channel : rfsim.channels.rss.RssChannel
        The case's channel.
    report : rfsim.devices.rss_reader.RssReport
        The readers' report (quantization, floor).
    case : int
        The case's index.
    motion : {"fixed", "mobile"}
        The target's motion.
    n_tracks : int
        Tracks B (trials).
    n_steps : int
        Beacons T per track.
    step_std_m : float
        Std of the random walk's step [m].
    decorrelation_m : float
        Gudmundson decorrelation distance of the shadowing [m] (0: independent per position).
    static_fraction : float
        Share f of σ² that is quasi-static.
    shared : bool
        One quasi-static term for every reader.
    people_correlation : float
        AR(1) coefficient of the people term between beacons.
    seed : int
        The run's seed.

    Returns
    -------
    CaseData
        Truth (B, T, 2) [m], RSS and reports (B, T, J) [dBm], the reference tags' (B, T, J, I)
        and the home's fingerprint map (B, M, J) [dBm].
    """
    home = plan.fixed_points_xy is not None
    sig = channel.sigma_db
    ref = plan.reference_xy
    n_ref, n_read = ref.shape[0], channel.n_readers
    tracks, shadow_t, shadow_r, people_t, people_r, pattern = [], [], [], [], [], []
    xmin, ymin, xmax, ymax = plan.bounds
    for b in range(n_tracks):
        rng = trial_rng(seed, case, 0, b)
        if home:
            track = _home_track(plan, motion, b, n_steps)
        else:
            start = rng.uniform((xmin, ymin), (xmax, ymax))
            track = (np.repeat(start[None], n_steps, axis=0) if motion == "fixed"
                     else random_walk(start, n_steps, step_std_m, plan.bounds, rng=rng))
        fp = _fingerprint_points(plan, rng) if home else np.zeros((0, 2))
        pts = _xyz(np.concatenate([track, ref, fp]), plan.tag_height_m)
        x = _rss.quasi_static_shadowing_db(pts, np.sqrt(static_fraction) * sig, rng=rng, decorrelation_m=decorrelation_m,
                                      shared=shared)
        sp = np.sqrt(1.0 - static_fraction) * sig
        kw = dict(rng=rng, correlation=people_correlation)
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


def offline_campaign(channel: _rss.RssChannel, waf_db: float, *, rng: np.random.Generator) -> list[dict]:
    """The offline calibration of Sec. 6.1 (L988–L1011) on the simulated channel.

    Per reader: 4 locations × 100 reads (8 orientations, people moving: every read an
    independent draw of the reader's σ_j) at 1, 1.5, 2, 2.5, 3 m in the reader's room → LS fit of
    α_j, n_j, σ_j (:func:`rfsim.estimators.calibration.fit_log_distance`); WAF from the same 400
    reads at 3 m through one wall minus the in-room mean at 3 m (L1000).

    Parameters
    ----------
    channel : rfsim.channels.rss.RssChannel
        The true channel.
    waf_db : float
        The true WAF [dB].
    rng : numpy.random.Generator
        The campaign's stream.

    Returns
    -------
    list of dict
        Per reader: ``reader`` (1-based), fitted ``alpha_dbm``, ``exponent``, ``sigma_db``,
        ``waf_db`` and the true ``true_alpha_dbm``, ``true_exponent``, ``true_sigma_db``.
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


# --------------------------------------------------------------------------- the per-beacon log


#: Beacon carrier [Hz] of the active tag (L957; its transmit power: active_beacons.TX_POWER_DBM).
FC_HZ = 868e6


def epc(tag: int) -> str:
    """EPC of a tag of the run.

    Parameters
    ----------
    tag : int
        0 = the target, 1.. the reference tags.

    Returns
    -------
    str
        ``3000 0…0 (k+1)``: 24 hex digits.
    """
    return f"3000{0:016X}{tag + 1:04X}"


def beacon_log(data: CaseData, reference_xy, *, tag_z_m: float, case: int) -> dict:
    """The per-read log of a case: one row per (trial, epoch, reader, tag).

    Time: the epoch (1 beacon per second), or in the waveform mode when the tag sent the
    beacon (``data.beacon_t_s``, where it was sent).

    Parameters
    ----------
    data : CaseData
        The case's beacons.
    reference_xy : ndarray, shape (I, 2)
        Positions of the reference tags [m].
    tag_z_m : float
        Tag height [m].
    case : int
        The case's index.

    Returns
    -------
    dict
        The columns of :data:`BEACON_LOG_UNITS`: arrays of B·T·J·(1 + I) rows or scalars; the
        EPC as :class:`rfsim.core.rows.IndexedText`.
    """
    b, t = data.reported_dbm.shape[:2]
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
    return dict(t_s=t_s.ravel(), t_us=np.round(t_s * 1_000_000).astype(np.int64).ravel(), case=case,
                trial=idx[0].ravel(), step=idx[1].ravel(), reader=(idx[2] + 1).ravel(), antenna=1, tag=tag.ravel(),
                epc=_rows.IndexedText(tag.ravel(), epc), rssi_dbm=rss.ravel(), rssi_reported_dbm=rep.ravel(),
                detected=~np.isnan(rep.ravel()), frequency_hz=FC_HZ, tx_power_dbm=TX_POWER_DBM,
                x_m=pos[..., 0].ravel(), y_m=pos[..., 1].ravel(), z_m=float(tag_z_m))


#: (unit, description) of the columns of :func:`beacon_log`.
BEACON_LOG_UNITS = {
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
    "x_m": ("m", "true x coordinate of the tag in the floor plan when it sent the beacon"),
    "y_m": ("m", "true y coordinate of the tag in the floor plan when it sent the beacon"),
    "z_m": ("m", "true tag height"), "frequency_hz": ("Hz", "carrier frequency of the active beacon (868 MHz band)"),
    "tx_power_dbm": ("dBm", "tag transmit power"),
}


__all__ = ["FloorPlan", "simulation_plan", "home_plan", "preset_plan", "with_overrides", "PRESET_DEFAULTS", "scored_steps",
           "ShadowingConfig", "noise_model", "RECURSIONS", "PUBLISHED", "PUBLISHED_HOME", "published",
           "rss_channel", "random_walk", "CaseData", "FINGERPRINTS_PER_CELL", "draw_beacons", "offline_campaign",
           "FC_HZ", "epc", "beacon_log", "BEACON_LOG_UNITS"]

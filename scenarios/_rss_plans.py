"""Floor plans and published results of the ``rss-localization`` presets (Özkaya 2011).

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
    """A single room with readers at ``n_readers`` corners and cells at the interior integer points."""
    return FloorPlan(
        name=f"sim-{width_m:g}x{length_m:g}", bounds=(0.0, 0.0, width_m, length_m),
        readers_xy=_corners(width_m, length_m, n_readers), walls_xy=(),
        reader_params=((alpha_dbm, exponent, 0.0),) * n_readers,
        cells_xy=_interior_points(width_m, length_m), reference_xy=np.zeros((0, 2)),
        fixed_points_xy=None, mobile_paths_xy=(), reader_height_m=1.0, tag_height_m=1.0)


def home_plan() -> FloorPlan:
    """The two-room home replica (Table 6.1 readers, 4 reference tags)."""
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
    """Published (RMSE, mean, median, p90, std) or (RMSE,) for a case, or None."""
    return PUBLISHED.get((preset, n_readers, estimator, motion, round(float(sigma0_db), 3)))


__all__ = ["FloorPlan", "simulation_plan", "home_plan", "RECURSIONS", "PUBLISHED",
           "PUBLISHED_HOME", "published"]

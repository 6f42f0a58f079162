"""Rooms, landmark grids and sense-a-tag trajectories of ``st-localization`` (AURIS ch. 4).

Presets (auris-sense-a-tag.md §3.3; seeds/003 L4493-L4501, L5375-L5383, L5600-L5641): the room is
centred on the origin, the landmark tags sit at the centres of an nx × ny grid of equal cells
on the floor (z = 0, as the ST), the reader's panel antennas hang at 2 m facing the floor.

Trajectories 1 and 2 exist only as drawings (Fig. 4.10, L4587-L4630); this replica defines them
(and records them in the dataset):

* **1**: a rectangle loop through the corners (±1.5, ±1.0) m (10 m long, anticlockwise from
  (−1.5, −1.0)), at constant speed;
* **2**: a figure-eight x = 1.5 sin s, y = 1.0 sin 2s (Lissajous 1:2), at constant speed;
* **random-walk** (L4638-L4648): straight lines at constant speed; at a wall the ST bounces
  into a random inward direction with a new speed ~ U[v_min, v_max].

Paths 1 and 2 are traversed at constant speed by arc length (a polyline of 2000 points for 2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Room:
    """A preset: room size, landmark grid, reader antennas."""

    size_m: tuple[float, float]
    grid: tuple[int, int]
    antennas_xyz_m: tuple[tuple[float, float, float], ...]

    @property
    def bounds_m(self) -> tuple[float, float, float, float]:
        w, h = self.size_m
        return (-w / 2, -h / 2, w / 2, h / 2)

    def landmarks_xy(self) -> np.ndarray:
        (w, h), (nx, ny) = self.size_m, self.grid
        x = -w / 2 + (np.arange(nx) + 0.5) * w / nx
        y = -h / 2 + (np.arange(ny) + 0.5) * h / ny
        gx, gy = np.meshgrid(x, y, indexing="ij")
        return np.column_stack([gx.ravel(), gy.ravel()])


PRESETS = {
    "pfaa": Room((4.0, 3.2), (9, 5), ((0.0, 0.0, 2.0),)),
    "sqlam": Room((5.0, 4.0), (7, 6), ((0.0, 0.0, 2.0),)),
    "lab": Room((10.0, 8.0), (11, 9), ((-2.5, -2.0, 2.0), (2.5, -2.0, 2.0), (-2.5, 2.0, 2.0), (2.5, 2.0, 2.0))),
}

TRAJECTORY_1_XY = ((-1.5, -1.0), (1.5, -1.0), (1.5, 1.0), (-1.5, 1.0), (-1.5, -1.0))


def trajectory_2_xy(n: int = 2000) -> np.ndarray:
    s = np.linspace(0.0, 2.0 * np.pi, n)
    return np.column_stack([1.5 * np.sin(s), 1.0 * np.sin(2.0 * s)])


def along_path(path_xy, speed_mps: float, t_s) -> np.ndarray:
    """Positions (…, 2) at times ``t_s`` on the closed path ``path_xy (n, 2)`` at constant speed."""
    p = np.asarray(path_xy, float)
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    arc = np.mod(speed_mps * np.asarray(t_s, float), s[-1])
    return np.stack([np.interp(arc, s, p[:, 0]), np.interp(arc, s, p[:, 1])], axis=-1)


def random_walk(rng: np.random.Generator, bounds_m, speed_range_mps, t_s) -> np.ndarray:
    """Positions (len(t_s), 2) of the bouncing random walk at the times ``t_s`` (≥ 0).

    The straight segments are drawn first (start time, start point, velocity), up to max(t_s);
    a position is then the start of its segment plus velocity × elapsed time.
    """
    x0, y0, x1, y1 = bounds_m
    t = np.asarray(t_s, float)
    pos = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])
    ang, speed = rng.uniform(-np.pi, np.pi), rng.uniform(*speed_range_mps)
    starts, points, vels = [0.0], [pos], []
    now, t_max = 0.0, float(t.max(initial=0.0))
    while True:
        v = speed * np.array([np.cos(ang), np.sin(ang)])
        vels.append(v)
        tx = (x1 - pos[0]) / v[0] if v[0] > 0 else ((x0 - pos[0]) / v[0] if v[0] < 0 else np.inf)
        ty = (y1 - pos[1]) / v[1] if v[1] > 0 else ((y0 - pos[1]) / v[1] if v[1] < 0 else np.inf)
        hit = max(min(tx, ty), 0.0)
        now += hit
        if now > t_max:
            break
        pos = np.clip(pos + v * hit, [x0, y0], [x1, y1])
        normal = np.array([-np.sign(v[0]), 0.0]) if tx <= ty else np.array([0.0, -np.sign(v[1])])
        ang = np.arctan2(normal[1], normal[0]) + rng.uniform(-np.pi / 2 + 1e-3, np.pi / 2 - 1e-3)
        speed = rng.uniform(*speed_range_mps)
        starts.append(now)
        points.append(pos)
    k = np.searchsorted(np.asarray(starts), t, side="right") - 1
    return np.asarray(points)[k] + np.asarray(vels)[k] * (t - np.asarray(starts)[k])[:, None]


__all__ = ["Room", "PRESETS", "TRAJECTORY_1_XY", "trajectory_2_xy", "along_path", "random_walk"]

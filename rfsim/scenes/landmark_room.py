"""A room of landmark tags on the floor under the reader's panel antenna(s), and the sense-a-tag
(ST) paths through it (AURIS ch. 4; auris-sense-a-tag.md §3.3; seeds/003 L4493-L4501,
L5375-L5383, L5600-L5641).

Presets: the room is centred on the origin, the landmark tags sit at the centres of an nx × ny
grid of equal cells on the floor (z = 0, as the ST), the reader's panel antennas hang at 2 m
facing the floor.

Trajectories 1 and 2 exist only as drawings (Fig. 4.10, L4587-L4630); this replica defines them:

* **1** (:data:`TRAJECTORY_1_XY`): a rectangle loop through the corners (±1.5, ±1.0) m (10 m
  long, anticlockwise from (−1.5, −1.0)), at constant speed;
* **2** (:func:`trajectory_2_xy`): a figure-eight x = 1.5 sin s, y = 1.0 sin 2s (Lissajous 1:2),
  at constant speed (a polyline of 2000 points);
* the random walk of L4638-L4648 is :func:`rfsim.core.trajectories.random_walk`.

Both paths are traversed at constant speed by arc length
(:func:`rfsim.core.trajectories.along_path`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.trajectories import along_path, random_walk


@dataclass(frozen=True)
class Room:
    """A room preset: floor, landmark grid and reader antennas.

    Attributes
    ----------
    size_m : tuple of float, length 2
        Floor size (x, y) [m], centred on the origin.
    grid : tuple of int, length 2
        Landmark grid (nx, ny): one landmark at the centre of each cell.
    antennas_xyz_m : tuple of tuple of float
        Reader antenna positions (x, y, z) [m].
    """

    size_m: tuple[float, float]
    grid: tuple[int, int]
    antennas_xyz_m: tuple[tuple[float, float, float], ...]

    @property
    def bounds_m(self) -> tuple[float, float, float, float]:
        """(x0, y0, x1, y1) [m] of the floor, centred on the origin."""
        w, h = self.size_m
        return (-w / 2, -h / 2, w / 2, h / 2)

    def landmarks_xy(self) -> np.ndarray:
        """Return the landmark positions at the cell centres.

        Returns
        -------
        ndarray, shape (nx·ny, 2)
            (x, y) [m], x-major (index = ix·ny + iy).
        """
        (w, h), (nx, ny) = self.size_m, self.grid
        x = -w / 2 + (np.arange(nx) + 0.5) * w / nx
        y = -h / 2 + (np.arange(ny) + 0.5) * h / ny
        gx, gy = np.meshgrid(x, y, indexing="ij")
        return np.column_stack([gx.ravel(), gy.ravel()])

    def check_waypoints(self, key: str, points_xy, name: str = "") -> None:
        """Check that ``points_xy`` are at least 2 points inside the floor.

        Parameters
        ----------
        key : str
            Config key named in the error.
        points_xy : array_like, shape (n, 2)
            Waypoints (x, y) [m].
        name : str, optional
            The room's name, named in the error (default none).

        Raises
        ------
        rfsim.core.errors.ConfigError
            Fewer than 2 waypoints, or a waypoint outside :attr:`bounds_m`.
        """
        x0, y0, x1, y1 = self.bounds_m
        pts = np.asarray(points_xy, float).reshape(-1, 2)
        if pts.shape[0] < 2:
            raise ConfigError(key, [list(p) for p in pts], "at least 2 waypoints (x, y) in m")
        out = ~((pts[:, 0] >= x0) & (pts[:, 0] <= x1) & (pts[:, 1] >= y0) & (pts[:, 1] <= y1))
        if out.any():
            room = f"{name} room" if name else "room"
            raise ConfigError(key, list(pts[np.argmax(out)]), f"waypoints inside the {room} x in [{x0:g}, {x1:g}], "
                                                              f"y in [{y0:g}, {y1:g}] m (the trajectory leaves the room)")

    def with_grid(self, grid: tuple[int, int] | None) -> Room:
        """Return the same room and antennas with another landmark grid.

        Parameters
        ----------
        grid : tuple of int, length 2, or None
            The landmark grid (nx, ny); None keeps this room's.

        Returns
        -------
        Room
            The room (``self`` when ``grid`` is None).
        """
        return self if grid is None else Room(self.size_m, tuple(grid), self.antennas_xyz_m)


#: The source's rooms: PF-AA (4 × 3.2 m, L4493), SQLAM (5 × 4 m, L5375) and the lab with four
#: antennas (10 × 8 m, L5600-L5641).
PRESETS = {
    "pfaa": Room((4.0, 3.2), (9, 5), ((0.0, 0.0, 2.0),)),
    "sqlam": Room((5.0, 4.0), (7, 6), ((0.0, 0.0, 2.0),)),
    "lab": Room((10.0, 8.0), (11, 9), ((-2.5, -2.0, 2.0), (2.5, -2.0, 2.0), (-2.5, 2.0, 2.0), (2.5, 2.0, 2.0))),
}

#: Trajectory 1: the closed rectangle loop (x, y) [m].
TRAJECTORY_1_XY = ((-1.5, -1.0), (1.5, -1.0), (1.5, 1.0), (-1.5, 1.0), (-1.5, -1.0))


def trajectory_2_xy(n: int = 2000) -> np.ndarray:
    r"""Return trajectory 2: the closed figure-eight (Lissajous 1:2) as a polyline.

    :math:`x = 1.5 \sin s`, :math:`y = \sin 2s` [m], :math:`s \in [0, 2\pi]` (this
    replica's definition; the source only draws it).

    Parameters
    ----------
    n : int, optional
        Number of points, default 2000 (the first and last coincide).

    Returns
    -------
    ndarray, shape (n, 2)
        Points (x, y) [m].
    """
    s = np.linspace(0.0, 2.0 * np.pi, n)
    return np.column_stack([1.5 * np.sin(s), 1.0 * np.sin(2.0 * s)])


def path_positions(trajectory: str, t_s, *, speed_mps: float, trajectory_1_xy, bounds_m, walk_speed_mps,
                   walk_rng) -> np.ndarray:
    """Return the ST's true positions at given times on a trajectory.

    Parameters
    ----------
    trajectory : str
        ``"1"`` (the polyline ``trajectory_1_xy``, closed if it is not), ``"2"``
        (:func:`trajectory_2_xy`), both at ``speed_mps`` by arc length; any other value:
        the random walk (:func:`rfsim.core.trajectories.random_walk`).
    t_s : array_like
        Times [s], any shape.
    speed_mps : float
        Speed along trajectories 1 and 2 [m/s].
    trajectory_1_xy : array_like, shape (n, 2)
        Waypoints (x, y) of trajectory 1 [m].
    bounds_m : tuple of float, length 4
        (x0, y0, x1, y1) of the random walk [m].
    walk_speed_mps : sequence of float, length 2
        (v_min, v_max) of the random walk's speeds [m/s].
    walk_rng : callable
        Returns a fresh generator of the random walk at each call (the same walk every call).

    Returns
    -------
    ndarray, shape t_s.shape + (2,)
        Positions (x, y) [m].
    """
    if trajectory == "1":
        pts = np.asarray(trajectory_1_xy, float)
        return along_path(pts if np.array_equal(pts[0], pts[-1]) else np.vstack([pts, pts[:1]]), speed_mps, t_s)
    if trajectory == "2":
        return along_path(trajectory_2_xy(), speed_mps, t_s)
    flat = np.asarray(t_s, float).ravel()
    return random_walk(walk_rng(), bounds_m, walk_speed_mps, flat).reshape(np.shape(t_s) + (2,))


__all__ = ["Room", "PRESETS", "TRAJECTORY_1_XY", "trajectory_2_xy", "path_positions"]

"""Trajectories as callables of time: position, velocity, acceleration, heading and turn rate.

A trajectory is an object whose call ``traj(t_s)`` returns :class:`Kinematics` on the
time array ``t_s`` (s). Planar motion in the horizontal x–y plane at a constant height;
the *heading* ψ is the direction of the moving body's y^B axis in that plane (for the
HIMR boom the direction of the tangential velocity, π at the start: seed 000 L1100;
wave2-specs.md §H, erratum 13 default), unwrapped, in rad.

Profiles (himr-tag.md §1.15, §3.1, §3.3):

* :func:`trapezoid_profile`: rest, constant acceleration for t_acc, cruise for t_cruise,
  constant deceleration for t_acc, rest (seed 000 App. C L1857–L1874, with the erratum-10
  correction θ_f − θ_i = θ̇_cruise·(t_acc + t_cruise)): for a travel d,
  v = d/(t_acc + t_cruise), a = v/t_acc.
* :class:`LinearTrapezoid`: the 1-D positioner (L610): start 1 m from the reader, ±7.35 m/s²
  to 1.2 m/s, 355 ms cruise. Travel = v·(t_acc + t_cruise) = 0.622 m with t_acc = v/a =
  0.1633 s; the seed's "0.61 m" needs a 0.3451 s cruise (erratum 9):
  ``preserve = "cruise"`` (default) keeps the printed cruise, ``"distance"`` the 0.61 m.
* :class:`RotatingBoom`: the 2-D boom (L997, L1014): radius 0.31 m, one counter-clockwise 2π
  stroke in 0.5 s / 0.2 s / 0.5 s, starting at the top of the circle, (2, 1.8048) m heading
  π (L1159, L1100), centre (2, 1.4948) m [derived, H§3.3]; ``lag_s`` delays the motion (the
  actual trajectory ran 150 ms behind the programmed one, L1014).

Planar paths as position arrays only (no heading): :func:`along_path` (a closed polyline at
constant speed) and :func:`random_walk` (straight lines bouncing off the walls of a rectangle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError


@dataclass(frozen=True, eq=False)
class Kinematics:
    """Kinematics on a time array of n samples.

    Attributes
    ----------
    t_s : ndarray, shape (n,)
        Times [s].
    position_m : ndarray, shape (n, 3)
        Position in the fixed frame [m].
    velocity_mps : ndarray, shape (n, 3)
        Velocity in the fixed frame [m/s].
    acceleration_mps2 : ndarray, shape (n, 3)
        Acceleration in the fixed frame [m/s²].
    heading_rad : ndarray, shape (n,)
        Heading ψ, the direction of the body's y^B axis, unwrapped [rad].
    rate_rad_s : ndarray, shape (n,)
        Turn rate dψ/dt [rad/s].
    angular_accel_rad_s2 : ndarray, shape (n,)
        Angular acceleration d²ψ/dt² [rad/s²].
    """

    t_s: np.ndarray
    position_m: np.ndarray
    velocity_mps: np.ndarray
    acceleration_mps2: np.ndarray
    heading_rad: np.ndarray
    rate_rad_s: np.ndarray
    angular_accel_rad_s2: np.ndarray

    def state_2d(self) -> np.ndarray:
        """State of the 2-D HIMR model (himr-tag.md §1.9).

        Returns
        -------
        numpy.ndarray
            ``(n, 9)`` [x ẋ ẍ y ẏ ÿ ψ ψ̇ ψ̈] [m, m/s, m/s², m, m/s, m/s², rad, rad/s, rad/s²].
        """
        p, v, a = self.position_m, self.velocity_mps, self.acceleration_mps2
        return np.column_stack([p[:, 0], v[:, 0], a[:, 0], p[:, 1], v[:, 1], a[:, 1],
                                self.heading_rad, self.rate_rad_s, self.angular_accel_rad_s2])

    def state_1d(self, axis: int = 0) -> np.ndarray:
        """State [z ż z̈] along a fixed-frame axis (1-D HIMR model, §1.5).

        Parameters
        ----------
        axis : int
            Fixed-frame axis 0, 1 or 2.

        Returns
        -------
        numpy.ndarray
            ``(n, 3)`` [m, m/s, m/s²].
        """
        return np.column_stack([self.position_m[:, axis], self.velocity_mps[:, axis],
                                self.acceleration_mps2[:, axis]])


def trapezoid_profile(t_s, *, travel: float, t_acc_s: float, t_cruise_s: float):
    """Trapezoidal velocity profile starting at t = 0.

    s goes from 0 (t ≤ 0) to ``travel`` (t ≥ 2·t_acc + t_cruise); cruise speed
    v = travel/(t_acc + t_cruise), acceleration a = v/t_acc (module docstring).

    Parameters
    ----------
    t_s : array_like
        Times [s].
    travel : float
        Distance travelled, unit of s (e.g. [m] or [rad]).
    t_acc_s : float
        Duration of each ramp [s].
    t_cruise_s : float
        Duration of the cruise [s].

    Returns
    -------
    s, s_dot, s_ddot : numpy.ndarray
        Position, speed and acceleration at ``t_s`` [unit, unit/s, unit/s²].
    """
    t = np.asarray(t_s, dtype=float)
    v = travel / (t_acc_s + t_cruise_s)
    a = v / t_acc_s
    t_end = 2.0 * t_acc_s + t_cruise_s
    tau = np.clip(t, 0.0, t_end)
    back = t_end - tau
    s = np.where(tau < t_acc_s, 0.5 * a * tau ** 2,
                 np.where(tau < t_acc_s + t_cruise_s, 0.5 * a * t_acc_s ** 2 + v * (tau - t_acc_s),
                          travel - 0.5 * a * back ** 2))
    sd = np.where(tau < t_acc_s, a * tau, np.where(tau < t_acc_s + t_cruise_s, v, a * back))
    sdd = np.where((t > 0) & (t < t_acc_s), a,
                   np.where((t >= t_acc_s + t_cruise_s) & (t < t_end), -a, 0.0))
    return s, np.where(t > 0, sd, 0.0), sdd


@dataclass(frozen=True)
class LinearTrapezoid:
    """1-D positioner: straight-line trapezoid along ``direction`` (see the module docstring).

    Calling it on times ``t_s`` [s] gives :class:`Kinematics` (heading: the direction of travel
    in the x–y plane, constant). Defaults are the seed's positioner (seed 000 L610).

    Parameters
    ----------
    start_m : tuple of float, default (1.0, 0.0, 0.0)
        Start position (x, y, z) [m].
    direction : tuple of float, default (1.0, 0.0, 0.0)
        Direction of travel (normalised here; must not be zero).
    accel_mps2 : float, default 7.35
        Magnitude of the acceleration and deceleration [m/s²] (0.75 g, L610), > 0.
    speed_mps : float, default 1.2
        Cruise speed [m/s] (L610), > 0.
    cruise_s : float, default 0.355
        Cruise duration [s] (L610), used when ``preserve = "cruise"``.
    distance_m : float, default 0.61
        Travel [m], used when ``preserve = "distance"``; at least v²/a.
    preserve : {"cruise", "distance"}, default "cruise"
        Keep the printed cruise duration or the printed distance (erratum 9).
    t_start_s : float, default 0.0
        Start of the motion [s].

    Raises
    ------
    rfsim.core.errors.ConfigError
        For a value out of range, a zero ``direction`` or a ``distance_m`` shorter than v²/a.
    """

    start_m: tuple[float, float, float] = param((1.0, 0.0, 0.0), unit="m", doc="start position")
    direction: tuple[float, float, float] = param((1.0, 0.0, 0.0), doc="direction of travel (normalised)")
    accel_mps2: float = param(7.35, lo=0.0, lo_open=True, unit="m/s^2", doc="|acceleration| (0.75 g, L610)")
    speed_mps: float = param(1.2, lo=0.0, lo_open=True, unit="m/s", doc="cruise speed (L610)")
    cruise_s: float = param(0.355, lo=0.0, unit="s", doc="cruise duration (L610)")
    distance_m: float = param(0.61, lo=0.0, lo_open=True, unit="m", doc="travel if preserve = distance")
    preserve: Literal["cruise", "distance"] = param("cruise", doc="keep the printed cruise or distance")
    t_start_s: float = param(0.0, lo=0.0, unit="s", doc="motion start")

    def __post_init__(self):
        check_fields(self, "trajectory")
        if not np.linalg.norm(self.direction) > 0:
            raise ConfigError("trajectory.direction", self.direction, "a non-zero vector")
        if self.preserve == "distance" and self.cruise_time_s < 0:
            raise ConfigError("trajectory.distance_m", self.distance_m,
                              f"at least v²/a = {self.speed_mps ** 2 / self.accel_mps2:g} m")

    @property
    def t_acc_s(self) -> float:
        """Duration of each ramp, t_acc = v/a [s]."""
        return self.speed_mps / self.accel_mps2

    @property
    def cruise_time_s(self) -> float:
        """Cruise duration [s]: ``cruise_s``, or d/v − t_acc when the distance is preserved."""
        if self.preserve == "cruise":
            return self.cruise_s
        return self.distance_m / self.speed_mps - self.t_acc_s

    @property
    def travel_m(self) -> float:
        """Distance travelled, v·(t_acc + t_cruise) [m]."""
        return self.speed_mps * (self.t_acc_s + self.cruise_time_s)

    @property
    def duration_s(self) -> float:
        """Time at which the motion ends, t_start + 2·t_acc + t_cruise [s]."""
        return self.t_start_s + 2 * self.t_acc_s + self.cruise_time_s

    def __call__(self, t_s) -> Kinematics:
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        u = np.asarray(self.direction, float) / np.linalg.norm(self.direction)
        s, sd, sdd = trapezoid_profile(t - self.t_start_s, travel=self.travel_m, t_acc_s=self.t_acc_s,
                                       t_cruise_s=self.cruise_time_s)
        zero = np.zeros_like(t)
        return Kinematics(t, np.asarray(self.start_m, float) + s[:, None] * u, sd[:, None] * u,
                          sdd[:, None] * u, zero + math.atan2(u[1], u[0]), zero, zero.copy())


@dataclass(frozen=True)
class RotatingBoom:
    """2-D rotating boom: the tag on a circle, trapezoidal angle profile (see the module docstring).

    Calling it on times ``t_s`` [s] gives :class:`Kinematics`. Defaults are the seed's boom
    (seed 000 L997, L1014).

    Parameters
    ----------
    centre_m : tuple of float, default (2.0, 1.4948)
        Circle centre (x, y) [m] (derived, H§3.3).
    radius_m : float, default 0.31
        Boom length [m] (L997), > 0.
    start_angle_rad : float, default π/2
        Polar angle of the start [rad] (the top of the circle).
    travel_rad : float, default 2π
        Stroke angle [rad], > 0.
    t_acc_s : float, default 0.5
        Duration of each angular ramp [s] (L1014), > 0.
    t_cruise_s : float, default 0.2
        Duration of the cruise [s] (L1014).
    direction : {"ccw", "cw"}, default "ccw"
        Sense of rotation (L999: ccw).
    lag_s : float, default 0.0
        Delay of the motion [s] in [0, 1] (the actual run: 0.15, L1014).
    height_m : float, default 0.0
        Constant z [m].

    Raises
    ------
    rfsim.core.errors.ConfigError
        For a value out of range.
    """

    centre_m: tuple[float, float] = param((2.0, 1.4948), unit="m", doc="circle centre (derived, H§3.3)")
    radius_m: float = param(0.31, lo=0.0, lo_open=True, unit="m", doc="boom length (L997)")
    start_angle_rad: float = param(math.pi / 2, unit="rad", doc="polar angle of the start (top of the circle)")
    travel_rad: float = param(2 * math.pi, lo=0.0, lo_open=True, unit="rad", doc="stroke angle")
    t_acc_s: float = param(0.5, lo=0.0, lo_open=True, unit="s", doc="acceleration phase (L1014)")
    t_cruise_s: float = param(0.2, lo=0.0, unit="s", doc="cruise phase (L1014)")
    direction: Literal["ccw", "cw"] = param("ccw", doc="sense of rotation (L999: ccw)")
    lag_s: float = param(0.0, lo=0.0, hi=1.0, unit="s", doc="delay of the motion (actual: 0.15, L1014)")
    height_m: float = param(0.0, unit="m", doc="constant z")

    def __post_init__(self):
        check_fields(self, "trajectory")

    @property
    def duration_s(self) -> float:
        """Time at which the motion ends, lag + 2·t_acc + t_cruise [s]."""
        return self.lag_s + 2 * self.t_acc_s + self.t_cruise_s

    def __call__(self, t_s) -> Kinematics:
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        sign = 1.0 if self.direction == "ccw" else -1.0
        s, sd, sdd = trapezoid_profile(t - self.lag_s, travel=self.travel_rad, t_acc_s=self.t_acc_s,
                                       t_cruise_s=self.t_cruise_s)
        ang, w, al = self.start_angle_rad + sign * s, sign * sd, sign * sdd
        c, sn, r = np.cos(ang), np.sin(ang), self.radius_m
        pos = np.column_stack([self.centre_m[0] + r * c, self.centre_m[1] + r * sn, np.full_like(t, self.height_m)])
        vel = np.column_stack([-r * sn * w, r * c * w, np.zeros_like(t)])
        acc = np.column_stack([-r * c * w ** 2 - r * sn * al, -r * sn * w ** 2 + r * c * al, np.zeros_like(t)])
        return Kinematics(t, pos, vel, acc, ang + sign * math.pi / 2, w, al)


def check_inside(traj, *, t_end_s: float, room_min_m, room_max_m, key: str = "trajectory",
                 dt_s: float = 1e-3) -> None:
    """Check that ``traj`` stays inside the box [room_min, room_max].

    Checked every ``dt_s`` from 0 to ``t_end_s``, on 2 or 3 coordinates.

    Parameters
    ----------
    traj : callable
        ``t_s → Kinematics``.
    t_end_s : float
        End of the check [s].
    room_min_m, room_max_m : array_like
        Corners of the room, 2 or 3 coordinates [m].
    key : str
        Configuration key named in the error.
    dt_s : float
        Time step of the check [s].

    Raises
    ------
    ConfigError
        One line, naming the first position outside and its time.
    """
    lo, hi = np.asarray(room_min_m, float), np.asarray(room_max_m, float)
    t = np.arange(0.0, float(t_end_s) + 0.5 * dt_s, dt_s)
    p = traj(t).position_m[:, :lo.size]
    bad = np.nonzero(np.any((p < lo) | (p > hi), axis=1))[0]
    if bad.size:
        i = int(bad[0])
        where = ", ".join(f"{v:.3f}" for v in p[i])
        raise ConfigError(key, f"position ({where}) m at t = {t[i]:.3f} s",
                          f"a trajectory inside the room {lo.tolist()}–{hi.tolist()} m")


def along_path(path_xy, speed_mps: float, t_s) -> np.ndarray:
    """Positions on a closed polyline traversed at constant speed by arc length.

    Parameters
    ----------
    path_xy : array_like of float, shape (n, 2)
        Waypoints [m]; the path is closed when the last equals the first (otherwise the motion
        jumps back to the first waypoint after the last).
    speed_mps : float
        Speed along the path [m/s].
    t_s : array_like of float
        Times [s], any shape; the arc length s = speed·t is taken modulo the path's length.

    Returns
    -------
    ndarray of float, shape t_s.shape + (2,)
        Positions [m], linearly interpolated in arc length between the waypoints.
    """
    p = np.asarray(path_xy, float)
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    arc = np.mod(speed_mps * np.asarray(t_s, float), s[-1])
    return np.stack([np.interp(arc, s, p[:, 0]), np.interp(arc, s, p[:, 1])], axis=-1)


def random_walk(rng: np.random.Generator, bounds_m, speed_range_mps, t_s) -> np.ndarray:
    """Positions of a bouncing random walk in a rectangle.

    Straight lines at constant speed; at a wall the walker turns into a uniformly random
    inward direction (±(π/2 − 10⁻³) about the wall's inward normal) with a new speed
    ~ U[v_min, v_max] (AURIS ch. 4 random track, seed 003 L4638–L4648).

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws, in order: the start point (x, y uniform in the rectangle), the first heading
        (uniform in [−π, π)) and speed, then per bounce the new heading and speed.
    bounds_m : sequence of float, length 4
        The rectangle (x0, y0, x1, y1) [m].
    speed_range_mps : sequence of float, length 2
        (v_min, v_max) [m/s].
    t_s : array_like of float, shape (n,)
        Times [s], ≥ 0; the segments (start time, start point, velocity) are drawn first, up
        to max(t_s).

    Returns
    -------
    ndarray of float, shape (n, 2)
        Positions [m]: the start of each time's segment plus velocity × elapsed time.
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


__all__ = ["Kinematics", "trapezoid_profile", "LinearTrapezoid", "RotatingBoom", "check_inside", "along_path",
           "random_walk"]

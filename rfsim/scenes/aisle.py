"""The warehouse aisle of the reader-free tag-to-tag network (Geng ch. 6, binary-detection.md
§1.11 and §2.4, seeds/004 L1203-L1212; wave2-specs.md §X): the mobile tag's true motion between
two shelves.

**Motion** (6.1): ``x = [x, ẋ, y, ẏ]``, ``x_{k+1} = A x_k + B u_k`` on a grid of ``dt_s``,
u ~ N(0, diag(q, q)) piecewise-constant acceleration (q = 0.01 m²/s⁴, L1203); A, B those of
:func:`rfsim.estimators.proximity.cv_transition`. The tag enters the aisle at ``start_xy_m``
with speed U[v_min, v_max] (L1203: "[0.1, 1] m/s") along +x; it cannot pass through the
shelves: its y is reflected (and ẏ reversed) at ± ``y_limit_m`` (aisle half width − clearance).
``initial_velocity = "vector"`` reads L1203's "[0.1, 1] m/s" as a velocity vector instead (as
"1 m/s for both velocity components" at L836): ``initial_velocity_mps`` = (along, across) the
aisle, default (1, 0.1) m/s (the literal (x, y) = (0.1, 1) is (0.1, 1.0)).

**Reference tags.** L1203 gives 10 tags "on a portal and shelves", the aisle 2 m wide; the
layout is only drawn in Fig. 6.3, not in the text. ``tag_layout`` names the readings tried
(:data:`NAMED_LAYOUTS`); ``"custom"`` (default) takes ``tags_xy_m`` as given, whose default is
``"every-2m"``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError

#: Default reference tags: 5 per shelf face at y = ±1 m, x = 0, 2, …, 8 m (the layout of Fig. 6.3
#: is not in the text; the pair at x = 0 is the portal).
DEFAULT_TAGS_XY_M = tuple((2.0 * i, s) for s in (-1.0, 1.0) for i in range(5))

#: Readings of L1203's "10 reference tags placed on a portal and shelves" (y = ±1 m, the shelf
#: faces of the 2 m aisle; the mobile tag enters at x = 0 and covers 1.2-12 m in 12 s):
#: "every-2m" the default (x = 0…8 m), "every-3m" the 12 m path covered (x = 0, 3, …, 12 m),
#: "portal-4-per-face" a portal pair at x = 0 and 4 per face at x = 1.5, 4.5, 7.5, 10.5 m,
#: "staggered" the two faces alternating along 0…10.8 m (one tag every 1.2 m), "short-1m" a field shorter than the path (x = 0…4 m, 1 m apart).
NAMED_LAYOUTS = {
    "every-2m": DEFAULT_TAGS_XY_M,
    "every-3m": tuple((3.0 * i, s) for s in (-1.0, 1.0) for i in range(5)),
    "portal-4-per-face": ((0.0, -1.0), (0.0, 1.0)) + tuple((1.5 + 3.0 * i, s) for s in (-1.0, 1.0) for i in range(4)),
    "staggered": tuple((round(1.2 * i, 9), -1.0 if i % 2 == 0 else 1.0) for i in range(10)),
    "short-1m": tuple((1.0 * i, s) for s in (-1.0, 1.0) for i in range(5)),
}


@dataclass(frozen=True)
class AisleConfig:
    """The aisle: reference tags on the shelf faces, the shelves, the exciter.

    A named ``tag_layout`` replaces ``tags_xy_m`` by its :data:`NAMED_LAYOUTS` entry.

    Raises
    ------
    rfsim.core.errors.ConfigError
        A named ``tag_layout`` together with custom ``tags_xy_m``.
    """

    tags_xy_m: tuple[tuple[float, float], ...] = param(
        DEFAULT_TAGS_XY_M, unit="m", doc="reference-tag positions (x, y); default 5 per shelf face at y = ±1 m")
    aisle_width_m: float = param(2.0, lo=0.1, hi=100.0, unit="m", doc="width between the shelves (L1203)")
    shelf_clearance_m: float = param(0.1, lo=0.0, hi=10.0, unit="m",
                                     doc="closest approach of the mobile tag to a shelf face (y reflected there)")
    exciter_xyz_m: tuple[float, float, float] = param((4.0, 0.0, 2.0), unit="m",
                                                      doc="exciter position (the seed gives none, B§0.2)")
    tag_layout: Literal["custom", "every-2m", "every-3m", "portal-4-per-face", "staggered", "short-1m"] = param(
        "custom", doc="named reference-tag layout (NAMED_LAYOUTS; replaces tags_xy_m) or 'custom' = tags_xy_m")

    def __post_init__(self):
        if self.tag_layout != "custom":
            if tuple(map(tuple, self.tags_xy_m)) not in (DEFAULT_TAGS_XY_M, NAMED_LAYOUTS[self.tag_layout]):
                raise ConfigError("layout.tag_layout", self.tag_layout, "'custom' when layout.tags_xy_m is set")
            object.__setattr__(self, "tags_xy_m", NAMED_LAYOUTS[self.tag_layout])

    @property
    def y_limit_m(self) -> float:
        """|y| at which the mobile tag is reflected [m]: half the width minus the clearance."""
        return self.aisle_width_m / 2.0 - self.shelf_clearance_m


@dataclass(frozen=True)
class MotionConfig:
    """The mobile tag's motion (6.1) (module docstring)."""

    duration_s: float = param(12.0, lo=0.1, hi=3600.0, unit="s", doc="tracking time per trajectory (L1212)")
    dt_s: float = param(0.05, lo=1e-4, hi=1.0, unit="s", doc="grid of the true motion (6.1)")
    accel_var: float = param(0.01, lo=0.0, hi=100.0, unit="m2/s4", doc="q of u ~ N(0, diag(q, q)) (L1203)")
    speed_min_mps: float = param(0.1, lo=0.0, hi=10.0, unit="m/s", doc="initial speed lower bound (L1203)")
    speed_max_mps: float = param(1.0, lo=0.0, hi=10.0, unit="m/s", doc="initial speed upper bound (L1203)")
    start_xy_m: tuple[float, float] = param((0.0, 0.0), unit="m", doc="where the mobile tag enters the aisle")
    initial_velocity: Literal["speed", "vector"] = param(
        "speed", doc="L1203 '[0.1, 1] m/s' read as a speed range along +x ('speed') or as the velocity vector "
                     "initial_velocity_mps ('vector')")
    initial_velocity_mps: tuple[float, float] = param((1.0, 0.1), lo=-10.0, hi=10.0, unit="m/s",
                                                      doc="(x, y) initial velocity when initial_velocity = 'vector'")

    @property
    def initial_velocity_xy_mps(self):
        """The fixed (x, y) initial velocity [m/s], or None for a speed drawn along +x."""
        return tuple(self.initial_velocity_mps) if self.initial_velocity == "vector" else None


def simulate_motion(rng: np.random.Generator, *, duration_s: float, dt_s: float, start_xy_m, speed_range_mps,
                    accel_var: float, y_limit_m: float, velocity_xy_mps=None) -> tuple[np.ndarray, np.ndarray]:
    r"""Draw one trajectory of (6.1) on the grid ``t = 0, dt, …, duration`` (module docstring).

    The constant-velocity model with piecewise-constant acceleration (Geng ch. 6, eq. 6.1):

    .. math::

        p_{k+1} = p_k + \Delta t\, v_k + \tfrac{1}{2} \Delta t^2 u_k, \qquad
        v_{k+1} = v_k + \Delta t\, u_k, \qquad u_k \sim \mathcal{N}(0, q I_2),

    with y reflected (and ẏ reversed) at ± ``y_limit_m``.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the initial speed (one uniform draw), then (n − 1, 2) standard normals of u.
    duration_s : float
        Time span [s].
    dt_s : float
        Grid step [s].
    start_xy_m : sequence of float, length 2
        (x, y) where the tag enters [m].
    speed_range_mps : sequence of float, length 2
        (v_min, v_max) of the initial speed along +x [m/s].
    accel_var : float
        q [m²/s⁴].
    y_limit_m : float
        |y| at which the tag is reflected [m].
    velocity_xy_mps : sequence of float, length 2, optional
        (vx, vy) initial velocity [m/s] replacing the drawn speed (the draw is still made, so
        the noise u is the same); None (default) keeps the drawn speed along +x.

    Returns
    -------
    t_s : ndarray, shape (n,)
        Grid times [s], n = round(duration_s / dt_s) + 1.
    state : ndarray, shape (n, 4)
        ``[x, ẋ, y, ẏ]`` [m, m/s, m, m/s].
    """
    n = int(round(duration_s / dt_s)) + 1
    x = np.array([start_xy_m[0], rng.uniform(*speed_range_mps), start_xy_m[1], 0.0])
    if velocity_xy_mps is not None:
        x[1], x[3] = velocity_xy_mps
    u = rng.standard_normal((n - 1, 2)) * np.sqrt(accel_var)
    out = np.empty((n, 4))
    out[0] = x
    for k in range(n - 1):
        x[0::2] += dt_s * x[1::2] + 0.5 * dt_s * dt_s * u[k]
        x[1::2] += dt_s * u[k]
        if abs(x[2]) > y_limit_m:  # reflected at the shelf
            x[2] = np.sign(x[2]) * 2.0 * y_limit_m - x[2]
            x[3] = -x[3]
        out[k + 1] = x
    return np.arange(n) * dt_s, out


def position_at(t_grid, states, t_s) -> np.ndarray:
    """Interpolate the (x, y) positions of a trajectory at given times.

    Parameters
    ----------
    t_grid : ndarray, shape (n,)
        The motion grid's times [s] (increasing).
    states : ndarray, shape (n, 4)
        ``[x, ẋ, y, ẏ]`` on that grid (:func:`simulate_motion`).
    t_s : array_like, shape (m,)
        Times at which to read the positions [s] (clamped to the grid's ends).

    Returns
    -------
    ndarray, shape (m, 2)
        Positions (x, y) [m], linearly interpolated.
    """
    return np.stack([np.interp(t_s, t_grid, states[:, 0]), np.interp(t_s, t_grid, states[:, 2])], axis=1)


__all__ = ["DEFAULT_TAGS_XY_M", "NAMED_LAYOUTS", "AisleConfig", "MotionConfig", "simulate_motion", "position_at"]

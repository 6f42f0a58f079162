"""The warehouse aisle of the reader-free tag-to-tag network (Geng ch. 6, binary-detection.md
§1.11 and §2.4, seeds/004 L1203-L1212; wave2-specs.md §X): the mobile tag's true motion between
two shelves.

**Motion** (6.1): ``x = [x, ẋ, y, ẏ]``, ``x_{k+1} = A x_k + B u_k`` on a grid of ``dt_s``,
u ~ N(0, diag(q, q)) piecewise-constant acceleration (q = 0.01 m²/s⁴, L1203); A, B those of
:func:`rfsim.estimators.proximity.cv_transition`. The tag enters the aisle at ``start_xy_m``
with speed U[v_min, v_max] (L1203: "[0.1, 1] m/s") along +x; it cannot pass through the
shelves: its y is reflected (and ẏ reversed) at ± ``y_limit_m`` (aisle half width − clearance).
The source gives no layout beyond Fig. 6.3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.core.config import param

#: Default reference tags: 5 per shelf face at y = ±1 m, x = 0, 2, …, 8 m (the layout of Fig. 6.3
#: is not in the text; the pair at x = 0 is the portal).
DEFAULT_TAGS_XY_M = tuple((2.0 * i, s) for s in (-1.0, 1.0) for i in range(5))


@dataclass(frozen=True)
class AisleConfig:
    """The aisle: reference tags on the shelf faces, the shelves, the exciter."""

    tags_xy_m: tuple[tuple[float, float], ...] = param(
        DEFAULT_TAGS_XY_M, unit="m", doc="reference-tag positions (x, y); default 5 per shelf face at y = ±1 m")
    aisle_width_m: float = param(2.0, lo=0.1, hi=100.0, unit="m", doc="width between the shelves (L1203)")
    shelf_clearance_m: float = param(0.1, lo=0.0, hi=10.0, unit="m",
                                     doc="closest approach of the mobile tag to a shelf face (y reflected there)")
    exciter_xyz_m: tuple[float, float, float] = param((4.0, 0.0, 2.0), unit="m",
                                                      doc="exciter position (the seed gives none, B§0.2)")

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


def simulate_motion(rng: np.random.Generator, *, duration_s: float, dt_s: float, start_xy_m, speed_range_mps,
                    accel_var: float, y_limit_m: float) -> tuple[np.ndarray, np.ndarray]:
    """One trajectory of (6.1) on the grid ``t = 0, dt, …, duration`` (module docstring).

    Parameters
    ----------
    rng : the initial speed (one uniform draw), then (n − 1, 2) standard normals of u
    duration_s, dt_s : time span and grid step [s]
    start_xy_m : (x, y) where the tag enters [m]
    speed_range_mps : (v_min, v_max) of the initial speed along +x [m/s]
    accel_var : q [m²/s⁴]
    y_limit_m : |y| at which the tag is reflected [m]

    Returns
    -------
    t : (n,) [s]; state : (n, 4) ``[x, ẋ, y, ẏ]`` [m, m/s]
    """
    n = int(round(duration_s / dt_s)) + 1
    x = np.array([start_xy_m[0], rng.uniform(*speed_range_mps), start_xy_m[1], 0.0])
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
    """Positions (len(t_s), 2) [m] at the times ``t_s`` [s], linearly interpolated on the motion
    grid ``t_grid`` (n,) of ``states`` (n, 4)."""
    return np.stack([np.interp(t_s, t_grid, states[:, 0]), np.interp(t_s, t_grid, states[:, 2])], axis=1)


__all__ = ["DEFAULT_TAGS_XY_M", "AisleConfig", "MotionConfig", "simulate_motion", "position_at"]

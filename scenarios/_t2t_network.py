"""The reader-free tag-to-tag network of ``tag-to-tag-tracking``: the mobile tag's motion, the
reference tags' slotted-Aloha broadcasts and which of them the mobile tag decodes.

Geng ch. 6 (binary-detection.md §1.11 and §2.4, seeds/004 L1068-L1091, L1203-L1219;
wave2-specs.md §X).

**Motion** (6.1): ``x = [x, ẋ, y, ẏ]``, ``x_{k+1} = A x_k + B u_k`` on a grid of ``dt_s``,
u ~ N(0, diag(q, q)) piecewise-constant acceleration (q = 0.01 m²/s⁴, L1203). The tag enters the
aisle at ``start_xy_m`` with speed U[v_min, v_max] (L1203: "[0.1, 1] m/s") along +x; it cannot
pass through the shelves: its y is reflected (and ẏ reversed) at ± (aisle half width −
clearance). The seed gives no layout beyond Fig. 6.3; this one is recorded in the dataset.

**Broadcasts** ("all-tag-talk", L1068, L1084): time is cut into periods of T_s = 0.5 s, each of
``n_slots`` slots of T_s/n_slots; every reference tag picks one slot per period uniformly, and
its frame (its location) ends at the end of the slot. Two or more tags in one slot collide.
The seed gives no slot count.

**Reception** (whether the mobile tag decodes a broadcast at distance d):

* ``disc``: d ≤ r (L1068, "within its sensing range r");
* ``logistic``: with probability p(d) = 1/(1 + exp(a1 + a2·d)) (Eq. 6.5), a1, a2 from the
  ``exciter-link`` fit, optionally stretched so that p(r) = 0.5 (a2 → −a1/r).

Collisions (``collision_model``): ``loss`` — every collided broadcast is lost (L1084);
``physical`` — see :mod:`rfsim.scenarios._t2t_physical`.
"""

from __future__ import annotations

import numpy as np


def simulate_motion(rng: np.random.Generator, *, duration_s: float, dt_s: float, start_xy_m, speed_range_mps,
                    accel_var: float, y_limit_m: float) -> tuple[np.ndarray, np.ndarray]:
    """One trajectory of (6.1) on the grid ``t = 0, dt, …``: ``(t (n,), state (n, 4))``."""
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
    """Positions (len(t_s), 2) linearly interpolated on the motion grid."""
    return np.stack([np.interp(t_s, t_grid, states[:, 0]), np.interp(t_s, t_grid, states[:, 2])], axis=1)


def aloha_schedule(rng: np.random.Generator, *, n_tags: int, duration_s: float, period_s: float,
                   n_slots: int) -> dict[str, np.ndarray]:
    """Every broadcast of every reference tag, sorted by time.

    Returns columns ``period``, ``tag``, ``slot``, ``t_s`` (end of the slot, ≤ duration) and
    ``n_in_slot`` (broadcasts sharing the slot; ≥ 2 is a collision).
    """
    n_periods = int(np.ceil(duration_s / period_s))
    slot = rng.integers(0, n_slots, size=(n_periods, n_tags))
    period = np.repeat(np.arange(n_periods), n_tags)
    tag = np.tile(np.arange(n_tags), n_periods)
    slot = slot.ravel()
    t = period * period_s + (slot + 1) * (period_s / n_slots)
    key = period * n_slots + slot
    counts = np.bincount(key, minlength=n_periods * n_slots)[key]
    keep = t <= duration_s + 1e-12
    order = np.lexsort((tag[keep], t[keep]))
    return {"period": period[keep][order], "tag": tag[keep][order], "slot": slot[keep][order],
            "t_s": t[keep][order], "n_in_slot": counts[keep][order]}


def logistic_coefficients(a1: float, a2_per_m: float, range_m: float, scale_to_range: bool) -> tuple[float, float]:
    """(a1, a2) of Eq. (6.5) used at sensing range r: as fitted, or stretched so p(r) = 0.5."""
    return (float(a1), -float(a1) / range_m) if scale_to_range else (float(a1), float(a2_per_m))


def logistic_p(d_m, a1: float, a2: float) -> np.ndarray:
    """Eq. (6.5): p(d) = 1/(1 + exp(a1 + a2·d))."""
    return 1.0 / (1.0 + np.exp(a1 + a2 * np.asarray(d_m, float)))


def in_range(distance_m, *, model: str, range_m: float, a1: float, a2: float,
             rng: np.random.Generator) -> np.ndarray:
    """(n,) bool: the broadcast would be decoded on its own (no collision), by ``model``."""
    d = np.asarray(distance_m, float)
    if model == "disc":
        return d <= range_m
    return rng.random(d.shape) < logistic_p(d, a1, a2)


__all__ = ["simulate_motion", "position_at", "aloha_schedule", "logistic_coefficients", "logistic_p", "in_range"]

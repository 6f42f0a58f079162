"""The MAC of the reader-free tag-to-tag network (Geng ch. 6, binary-detection.md §1.11, §2.4;
seeds/004 L1068, L1084; wave2-specs.md §X): "all-tag-talk" slotted Aloha of the reference tags'
broadcasts.

Time is cut into periods of T_s (0.5 s in the source), each of ``n_slots`` slots of
T_s/n_slots; every reference tag picks one slot per period uniformly, and its frame (its
location) ends at the end of the slot. Two or more tags in one slot collide (the source loses
every collided broadcast, L1084). The source gives no slot count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.core.config import param


@dataclass(frozen=True)
class AlohaConfig:
    """The all-tag-talk slotted Aloha of the reference tags (module docstring)."""

    period_s: float = param(0.5, lo=1e-3, hi=100.0, unit="s", doc="broadcast period T_s of every tag (L1203)")
    n_slots: int = param(50, lo=1, hi=100000, doc="Aloha slots per period (not in the seed)")


def aloha_schedule(rng: np.random.Generator, *, n_tags: int, duration_s: float, period_s: float,
                   n_slots: int) -> dict[str, np.ndarray]:
    r"""Every broadcast of every reference tag in ``[0, duration_s]``, sorted by time (then tag).

    "All-tag-talk" slotted Aloha (Geng ch. 6; binary-detection.md §1.11, §2.4; seeds/004
    L1068, L1084): in period p every tag picks slot s uniformly from ``n_slots`` and broadcasts
    at the slot's end, :math:`t = p\,T_s + (s + 1)\,T_s/n_{slots}`.

    Parameters
    ----------
    rng : numpy.random.Generator
        One draw of ``n_tags`` slots per period.
    n_tags : int
        Number of reference tags.
    duration_s : float
        Time span [s].
    period_s : float
        Broadcast period T_s [s].
    n_slots : int
        Aloha slots per period.

    Returns
    -------
    dict of str to ndarray
        Columns ``period``, ``tag``, ``slot``, ``t_s`` (end of the slot [s], ≤ duration) and
        ``n_in_slot`` (broadcasts sharing the slot; ≥ 2 is a collision), one row per broadcast.
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


__all__ = ["AlohaConfig", "aloha_schedule"]

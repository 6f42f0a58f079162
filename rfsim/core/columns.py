"""Column tables as dicts of equal-length arrays: concatenating the parts that workers return,
and the unit of a column read from its name's suffix (``distance_m`` → m)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

#: Name suffix → unit of the columns of the link scenarios.
UNITS = {"_v": "V", "_m": "m", "_rad": "rad", "_w": "W", "_hz": "Hz"}


def unit_of(key: str, units: Mapping[str, str] = UNITS) -> str:
    """Unit of a column from its name's suffix.

    Parameters
    ----------
    key : str
        Column name, e.g. ``"distance_m"``.
    units : mapping of str to str, default :data:`UNITS`
        Name suffix → unit; the first suffix (in the mapping's order) that ends ``key`` wins.

    Returns
    -------
    str
        The unit, e.g. ``"m"``; ``"1"`` (dimensionless) when no suffix matches.
    """
    return next((u for suf, u in units.items() if key.endswith(suf)), "1")


def concat(parts: Sequence[Mapping[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Concatenate column dicts with the same keys into one.

    The keys keep the order of the first non-empty part. Empty dicts (parts without rows or
    columns) are skipped.

    Parameters
    ----------
    parts : sequence of mapping of str to ndarray
        The parts, e.g. as returned by the workers; each maps a column name to an array whose
        first axis is the rows.

    Returns
    -------
    dict of str to ndarray
        Each column concatenated along its first axis over the parts; ``{}`` when every part
        is empty (or there are none).
    """
    parts = [p for p in parts if p]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]} if parts else {}


__all__ = ["UNITS", "unit_of", "concat"]

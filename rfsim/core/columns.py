"""Column tables as dicts of equal-length arrays: concatenating the parts that workers return,
and the unit of a column read from its name's suffix (``distance_m`` → m)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

#: Name suffix → unit of the columns of the link scenarios.
UNITS = {"_v": "V", "_m": "m", "_rad": "rad", "_w": "W", "_hz": "Hz"}


def unit_of(key: str, units: Mapping[str, str] = UNITS) -> str:
    """Unit of a column from its name's suffix: the first entry of ``units`` whose suffix ends
    ``key`` ("1" when none does)."""
    return next((u for suf, u in units.items() if key.endswith(suf)), "1")


def concat(parts: Sequence[Mapping[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Concatenate column dicts with the same keys (in the keys' order of the first) into one; empty
    dicts (parts without rows or columns) are skipped, and nothing gives ``{}``."""
    parts = [p for p in parts if p]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]} if parts else {}


__all__ = ["UNITS", "unit_of", "concat"]

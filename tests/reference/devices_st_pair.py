"""Reference twins of :mod:`rfsim.devices.st_pair`: the λ/4 pair's port coupling as a plain ``einsum``, the
ASK stamp's comparator transitions row by row."""

from __future__ import annotations

import numpy as np

from rfsim.devices import st_receiver as sr


def couple_ports_reference(mix, x) -> np.ndarray:
    """Plain NumPy twin of :func:`rfsim.devices.st_pair.couple_ports` (``einsum``)."""
    return np.einsum("ij,nj...->ni...", mix, x)


def ask_stamp_transitions_reference(bandpassed_v, frame: sr.StampFrame, threshold_v: float) -> np.ndarray:
    """Plain twin of :func:`rfsim.devices.st_pair.ask_stamp_transitions` (the comparator row by row)."""
    mid = (frame.start + frame.ask_stop) // 2
    return np.array([np.count_nonzero(np.diff(sr.comparator(row, threshold_v=threshold_v)[0][mid - frame.start:]))
                     for row in bandpassed_v[:, frame.start:frame.ask_stop]], dtype=np.int64)


__all__ = ["couple_ports_reference", "ask_stamp_transitions_reference"]

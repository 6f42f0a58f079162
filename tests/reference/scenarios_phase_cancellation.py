"""Reference twin of :mod:`rfsim.scenarios.phase_cancellation` (the ASK stamp's comparator
transitions, row by row)."""

from __future__ import annotations

import numpy as np

from rfsim.devices import st_receiver as sr


def ask_stamp_transitions_reference(bandpassed_v, frame: sr.StampFrame, threshold_v: float) -> np.ndarray:
    """Plain twin of :func:`rfsim.scenarios.phase_cancellation.ask_stamp_transitions` (the comparator row by row)."""
    mid = (frame.start + frame.ask_stop) // 2
    return np.array([np.count_nonzero(np.diff(sr.comparator(row, threshold_v=threshold_v)[0][mid - frame.start:]))
                     for row in bandpassed_v[:, frame.start:frame.ask_stop]], dtype=np.int64)


__all__ = ["ask_stamp_transitions_reference"]

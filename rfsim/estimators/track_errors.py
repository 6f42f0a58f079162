"""Error measures of a tracker over Monte-Carlo runs of unequal lengths.

A tracker's rows are (step t, error e = ‖x̂_t − x_t‖) pooled over runs. The RMS error at step t
is RMSE_t = sqrt(mean over the runs that reach t of e²) (AURIS ch. 4's RMSE over realizations,
seeds/003 L4507-L4513); its time average is :func:`mean_rms_error`.
"""

from __future__ import annotations

import numpy as np


def _sums(step, error_m) -> tuple[np.ndarray, np.ndarray]:
    step = np.asarray(step, dtype=np.intp)
    n_steps = int(step.max()) + 1 if step.size else 0
    e2 = np.zeros(n_steps)
    cnt = np.zeros(n_steps)
    np.add.at(e2, step, np.asarray(error_m) ** 2)
    np.add.at(cnt, step, 1)
    return e2, cnt


def rms_per_step(step, error_m) -> np.ndarray:
    """RMS error per step over the runs that reach it.

    RMSE_t = sqrt(Σ e² / n_t) per step t = 0 … max(step) (AURIS ch. 4, seeds/003 L4507-L4513).

    Parameters
    ----------
    step : array_like of int
        ``(n,)`` the step of each row.
    error_m : array_like of float
        ``(n,)`` position error of each row [m].

    Returns
    -------
    numpy.ndarray
        ``(max(step) + 1,)`` RMSE [m], NaN where no run has step t.
    """
    e2, cnt = _sums(step, error_m)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(e2 / cnt)


def mean_rms_error(step, error_m) -> float:
    """Time average of :func:`rms_per_step` over the steps some run has.

    Parameters
    ----------
    step : array_like of int
        ``(n,)`` the step of each row.
    error_m : array_like of float
        ``(n,)`` position error of each row [m].

    Returns
    -------
    float
        Mean RMSE [m]; NaN when there are no rows.
    """
    e2, cnt = _sums(step, error_m)
    ok = cnt > 0
    return float(np.mean(np.sqrt(e2[ok] / cnt[ok]))) if ok.any() else float("nan")


__all__ = ["rms_per_step", "mean_rms_error"]

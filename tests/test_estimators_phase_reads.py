"""Read-log helpers of the phase-tracking estimators (rfsim.estimators.phase_tracking): first and
latest value per antenna, unwrapping-jump flags, error statistics — on hand-made logs whose
answers are worked out in the comments."""

from __future__ import annotations

import numpy as np
import pytest


def test_first_and_latest_value_per_antenna_skip_failed_reads():
    from rfsim.estimators.phase_tracking import first_per_antenna, latest_per_antenna

    nan = np.nan
    ant = np.array([0, 1, 0, 2, 1, 0])
    val = np.array([nan, -50.0, -40.0, nan, -45.0, -41.0])
    first = first_per_antenna(ant, val, 3)
    assert first[0] == -40.0 and first[1] == -50.0 and np.isnan(first[2])
    latest = latest_per_antenna(ant, val, 3)
    expect = np.array([[nan, nan, nan], [nan, -50.0, nan], [-40.0, -50.0, nan], [-40.0, -50.0, nan],
                       [-40.0, -45.0, nan], [-41.0, -45.0, nan]])
    assert np.array_equal(latest, expect, equal_nan=True)


def test_unwrap_jumps_flag_offset_steps_above_a_quarter_wavelength_per_antenna():
    from rfsim.estimators.phase_tracking import unwrap_jumps

    lam = 0.4
    ant = np.array([0, 1, 0, 1, 0, 0])
    # antenna 0: 0 → 0.05 (no) → NaN skipped → 0.26 (step 0.21 > 0.1: jump); antenna 1: 0 → 0.2 (jump)
    off = np.array([0.0, 0.0, 0.05, 0.2, np.nan, 0.26])
    assert unwrap_jumps(ant, off, wavelength_m=lam, n_antennas=2).tolist() == [False, False, False, True, False, True]


def test_error_stats_of_a_hand_computed_sample():
    from rfsim.estimators.phase_tracking import error_stats

    st = error_stats(np.array([3.0, np.nan, 4.0]))
    assert st["rmse_m"] == pytest.approx(np.sqrt(12.5)) and st["mean_m"] == 3.5 and st["median_m"] == 3.5
    assert st["max_m"] == 4.0 and st["std_m"] == 0.5 and st["p90_m"] == pytest.approx(3.9)

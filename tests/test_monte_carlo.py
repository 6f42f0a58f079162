"""rfsim.core.monte_carlo: the run size (paper size overrides the two counts) and the loop over
cells × repetitions (task order cells outer, repetitions inner; the same columns on one or two
worker processes)."""

from __future__ import annotations

import numpy as np

from rfsim.core.monte_carlo import MonteCarloConfig, run_cells


def _cell(config, cell, rep, seed):
    # two rows per task, written out so the expected order can be spelled out by hand
    return {"cell": np.array([cell, cell]), "rep": np.array([rep, rep]),
            "value": np.array([config * 100 + 10 * cell + rep, seed], dtype=float)}


def test_full_size_overrides_the_counts():
    mc = MonteCarloConfig(positions_per_cell=7, repetitions=2)
    assert (mc.n_positions, mc.n_repetitions) == (7, 2)
    full = MonteCarloConfig(full=True, positions_per_cell=7, repetitions=2)
    assert (full.n_positions, full.n_repetitions) == (300, 3)


def test_cells_concatenate_in_task_order_whatever_the_workers():
    one = run_cells(_cell, 4, 3, MonteCarloConfig(repetitions=2, workers=1), seed=9)
    np.testing.assert_array_equal(one["cell"], [0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2])
    np.testing.assert_array_equal(one["rep"], [0, 0, 1, 1] * 3)
    np.testing.assert_array_equal(one["value"], [400, 9, 401, 9, 410, 9, 411, 9, 420, 9, 421, 9])
    two = run_cells(_cell, 4, 3, MonteCarloConfig(repetitions=2, workers=2), seed=9)
    assert two.keys() == one.keys()
    for k in one:
        np.testing.assert_array_equal(two[k], one[k])

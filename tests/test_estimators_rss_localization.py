"""The RSS localization estimators and the Özkaya rooms outside the scenario: hand-derived
values for the wall reflection, RSSI smoothing, error statistics, the scored steps, the floor
plan overrides, the per-beacon log and the block-built tables."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.core.dataset import Dataset, read_table, write_dataset
from rfsim.core.errors import ConfigError
from rfsim.core.rows import IndexedText, RowTables, read_block
from rfsim.estimators.rss_localization import error_statistics, reflect_into, smooth_rssi
from rfsim.scenes.rss_rooms import (CaseData, beacon_log, epc, home_plan, random_walk, scored_steps, simulation_plan,
                                    with_overrides)


def test_reflect_into_mirrors_at_the_crossed_edge():
    bounds = (0.0, 0.0, 5.0, 8.0)
    p = np.array([[-1.0, 2.0], [6.0, 9.5], [2.0, 3.0], [-20.0, 1.0]])
    # x = -1 → 1; (6, 9.5) → (4, 6.5); inside unchanged; -20 → 20 (lower edge) → -10 (upper) → clipped to 0
    np.testing.assert_array_equal(reflect_into(p, bounds), [[1.0, 2.0], [4.0, 6.5], [2.0, 3.0], [0.0, 1.0]])


def test_smooth_rssi_corrects_by_the_heavy_reference_tags_only():
    # one epoch, 2 readers, 2 reference tags; the target equals tag 0's reading → all weight on it
    z = np.array([[[-60.0, -70.0]]])
    ref_z = np.array([[[[-60.0, -50.0], [-70.0, -50.0]]]])          # (B, T, J, I)
    ref_expected = np.array([[[[-62.0, -55.0], [-73.0, -55.0]]]])
    # e_0 = ref_z - expected of tag 0 = (2, 3) dB, weight 1 > 0.4 → z - e_0
    np.testing.assert_array_equal(smooth_rssi(z, ref_z, ref_expected), [[[-62.0, -73.0]]])
    # equal distances (E² = 100 and 100) → w = 0.5 each, both above 0.4: z − 0.5·(e_0 + e_1)
    z2 = np.array([[[-55.0, -60.0]]])
    ref2 = np.array([[[[-55.0, -55.0], [-50.0, -70.0]]]])             # E²: 0+100, 0+100
    exp2 = np.array([[[[-57.0, -59.0], [-52.0, -70.0]]]])             # e_0 = (2, 2), e_1 = (4, 0)
    np.testing.assert_allclose(smooth_rssi(z2, ref2, exp2), [[[-55.0 - 3.0, -60.0 - 1.0]]])


def test_error_statistics_by_hand():
    s = error_statistics([3.0, 4.0])
    assert s["rmse_m"] == pytest.approx(np.sqrt(12.5))
    assert (s["mean_m"], s["median_m"], s["std_m"]) == (3.5, 3.5, 0.5)
    assert s["p90_m"] == pytest.approx(3.9)


def test_scored_steps():
    np.testing.assert_array_equal(scored_steps("fixed", 3, 5), [0, 0, 1, 0, 0])
    np.testing.assert_array_equal(scored_steps("mobile", 3, 5), [1, 1, 1, 0, 0])


def test_overrides_are_validated_with_the_key():
    plan = simulation_plan(5.0, 8.0, 3, -52.0, 2.3)
    with pytest.raises(ConfigError, match=r"readers_xy\[1\]"):
        with_overrides(plan, readers_xy=((1.0, 1.0), (6.0, 1.0)))
    with pytest.raises(ConfigError, match=r"walls_xy\[0\]"):
        with_overrides(plan, walls_xy=((1.0, 1.0, 1.0, 1.0),))
    two = with_overrides(home_plan(), readers_xy=((1.0, 1.0), (2.0, 2.0)))
    assert two.reader_params == (home_plan().reader_params[0],) * 2      # count changed: the first reader's


def test_random_walk_stays_inside():
    w = random_walk((0.1, 0.1), 200, 1.0, (0.0, 0.0, 1.0, 1.0), rng=np.random.default_rng(3))
    assert w.shape == (200, 2) and w.min() >= 0.0 and w.max() <= 1.0


def test_beacon_log_rows_and_epc():
    b, t, j, i = 1, 2, 2, 1
    data = CaseData(truth_xy=np.array([[[1.0, 2.0], [1.5, 2.0]]]), rss_dbm=np.full((b, t, j), -60.0),
                    reported_dbm=np.array([[[-60.0, np.nan], [-61.0, -62.0]]]), ref_rss_dbm=np.full((b, t, j, i), -50.0),
                    ref_reported_dbm=np.full((b, t, j, i), -50.0), pattern_map_dbm=None)
    log = beacon_log(data, np.array([[3.0, 3.0]]), tag_z_m=1.0, case=7)
    assert log["t_s"].size == b * t * j * (1 + i)
    assert epc(0) == "3000" + "0" * 16 + "0001" and len(epc(0)) == 24
    np.testing.assert_array_equal(log["detected"], [True, True, False, True, True, True, True, True])
    np.testing.assert_array_equal(log["x_m"], [1.0, 3.0, 1.0, 3.0, 1.5, 3.0, 1.5, 3.0])
    np.testing.assert_array_equal(log["epc"].strings()[:2], [epc(0), epc(1)])


def test_row_tables_join_blocks_and_read_one_back(tmp_path):
    rows = RowTables()
    rows.extend("t", case=0, x=np.array([1.0, 2.0]), name="a", tag=IndexedText(np.array([0, 1]), lambda k: f"T{k}"))
    rows.extend("t", case=1, x=np.array([3.0]), name="b", tag=IndexedText(np.array([1]), lambda k: f"T{k}"))
    ds = Dataset(title="rows")
    rows.write(ds, {"x": ("m", "a length")}, {"t": "a table"})
    path = write_dataset(tmp_path / "r.h5", ds, {"seed": 0})
    tab = read_table(path, "t")
    np.testing.assert_array_equal(tab["case"], [0, 0, 1])
    np.testing.assert_array_equal(tab["x"], [1.0, 2.0, 3.0])
    assert list(tab["name"]) == ["a", "a", "b"] and list(tab["tag"]) == ["T0", "T1", "T1"]
    blk = read_block(path, "t", "case", 1, ("x", "tag"))
    np.testing.assert_array_equal(blk["x"], [3.0])
    assert list(blk["tag"]) == ["T1"]

"""Batched two-tag capture sweep (issue 19, items 2 and 5): physics limits, reproducibility,
tables.

Expectations from the superposition y = h1·s1 + h2·s2 + n: at 15 dB the weaker reply's
amplitude is 0.18 of the stronger, below any decision margin of the coherent decoder, so the
stronger RN16 is read and the weaker never; two identical tags in lock-step at equal power add
to a third waveform whose bits are neither tag's where they differ (the bits differ in 8 of 16
on average, so both RN16s are rarely right). Tolerances: binomial with the trial counts given.
"""

from __future__ import annotations

import numpy as np

from rfsim.scenes.capture_sweep import CaptureSweepConfig, simulate_point, tables

CFG = CaptureSweepConfig(trials=150, ratios_db=(0.0, 15.0), thresholds_db=(0.0, 7.0, 20.0))


def test_strong_reply_is_captured_and_the_weak_never_at_15_db():
    for name in CFG.profiles:
        for spread in (False, True):
            pt = simulate_point(CFG, name, spread, 15.0, seed=2, point=1)
            # p ≥ 0.99 measured at 2000 trials; 150 trials: P(k < 140 | p = 0.99) < 1e-3
            assert np.sum(pt.decoded == 0) >= 140
            assert np.sum(pt.decoded == 1) == 0
            assert np.all(pt.detected)


def test_lock_step_equal_tags_rarely_give_one_tags_rn16():
    # measured ≈ 0.1 (both profiles) at 2000 trials; 150 trials: P(k > 40 | p = 0.12) < 1e-4
    for name in CFG.profiles:
        pt = simulate_point(CFG, name, False, 0.0, seed=2, point=0)
        assert np.sum(pt.decoded >= 0) <= 40
        assert np.all(pt.blf_error == 0.0) and np.ptp(pt.t1_s) == 0.0


def test_spread_points_draw_each_tags_blf_and_t1_and_repeat_bit_for_bit():
    a = simulate_point(CFG, "miller4-320k", True, 0.0, seed=3, point=5)
    b = simulate_point(CaptureSweepConfig(trials=150, threads=1), "miller4-320k", True, 0.0, seed=3, point=5)
    np.testing.assert_array_equal(a.decoded, b.decoded)
    np.testing.assert_array_equal(a.decision_ebn0_db, b.decision_ebn0_db)
    assert np.all(np.abs(a.blf_error) <= 0.10) and np.std(a.blf_error) > 0.02  # FrT 10 %, σ = 3.3 %
    assert np.all(a.blf_error[:, 0] != a.blf_error[:, 1])


def test_tables_count_captures_false_acks_and_the_threshold_trade_off():
    pts = [simulate_point(CFG, name, sp, r, seed=4, point=i)
           for i, (name, sp, r) in enumerate([(n, s, r) for n in CFG.profiles for s in (False, True)
                                              for r in CFG.ratios_db])]
    rows, trials, acc = tables(CFG, pts)
    assert len(rows["p_capture"]) == len(pts) and trials["point"].size == 150 * len(pts)
    for i, pt in enumerate(pts):
        ok = pt.detected & (pt.decision_ebn0_db >= rows["threshold_db"][i])
        assert rows["p_capture"][i] == np.mean(ok & (pt.decoded >= 0))
        assert rows["ci_lo"][i] <= rows["p_capture"][i] <= rows["ci_hi"][i]
    # a higher threshold accepts fewer: false ACKs fall, missed captures rise
    fa = np.array(acc["false_ack_rate"]).reshape(-1, 3)
    miss = np.array(acc["missed_capture_rate"]).reshape(-1, 3)
    assert np.all(np.diff(fa, axis=1) <= 0) and np.all(np.diff(miss, axis=1) >= 0)
    assert np.all(miss[:, -1] > 0.5)  # 20 dB is above the 20 dB Eb/N0 of the stronger reply

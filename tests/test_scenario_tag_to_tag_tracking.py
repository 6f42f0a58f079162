"""Scenario tag-to-tag-tracking (Geng ch. 6): Aloha schedule, reception rules, motion limits,
bad input, and (slow) Table 6.2 of seeds/004 L1242-L1249 with its orderings (L1221, L1228)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.rng import trial_rng
from rfsim.protocols.tag_to_tag import aloha_schedule
from rfsim.scenes import reference_tags as ph
from rfsim.estimators.proximity_trackers import prior_for, run_tracker
from rfsim.scenes.aisle import NAMED_LAYOUTS, AisleConfig, simulate_motion
from rfsim.scenarios import tag_to_tag_tracking as t2t

PUBLISHED = {  # Table 6.2, seeds/004 L1247-L1249 (copied from the source, not from the module)
    1.5: (1.0720, 0.5611, 0.6466, 0.5484, 0.5183),
    2.0: (1.3391, 0.8203, 0.7351, 0.5886, 0.5340),
    2.5: (1.5643, 1.0782, 0.8046, 0.6513, 0.5812),
}


def test_every_tag_broadcasts_once_per_period_and_collisions_follow_aloha():
    """L tags, S slots: P(collision) = 1 − (1 − 1/S)^(L−1); 2000 periods × 10 tags = 20000
    broadcasts, binomial std ≈ 0.0026 — tolerance 4 σ."""
    b = aloha_schedule(trial_rng(3, 0), n_tags=10, duration_s=1000.0, period_s=0.5, n_slots=20)
    counts = np.bincount(b["period"] * 10 + b["tag"])
    assert counts.size == 20000 and np.all(counts == 1)
    assert np.all(np.diff(b["t_s"]) >= 0)
    expected = 1.0 - (1.0 - 1.0 / 20) ** 9
    assert abs(np.mean(b["n_in_slot"] > 1) - expected) < 4 * np.sqrt(expected * (1 - expected) / 20000)


def test_motion_stays_between_the_shelves_and_starts_at_the_portal():
    t, s = simulate_motion(trial_rng(1, 0), duration_s=60.0, dt_s=0.05, start_xy_m=(0.0, 0.0),
                           speed_range_mps=(0.1, 1.0), accel_var=0.5, y_limit_m=0.9)
    assert t.size == 1201 and s[0, 0] == 0 and 0.1 <= s[0, 1] <= 1.0
    assert np.max(np.abs(s[:, 2])) <= 0.9 and np.max(np.abs(s[:, 2])) > 0.5  # it did reach a shelf


def test_named_layouts_are_ten_tags_on_the_shelf_faces_and_exclude_custom_tags():
    """L1203: 10 reference tags on a portal and the shelves of a 2 m aisle; each named reading
    puts 10 tags on the faces y = ±1 m, starting at the portal x = 0."""
    for name, tags in NAMED_LAYOUTS.items():
        xy = np.array(AisleConfig(tag_layout=name).tags_xy_m)
        assert xy.shape == (10, 2) and np.all(np.abs(xy[:, 1]) == 1.0) and xy[:, 0].min() == 0.0, name
        assert np.unique(xy, axis=0).shape[0] == 10, name
    assert AisleConfig().tags_xy_m == AisleConfig(tag_layout="every-2m").tags_xy_m
    assert np.array(AisleConfig(tag_layout="every-3m").tags_xy_m)[:, 0].max() == 12.0
    with pytest.raises(t2t.ConfigError):
        AisleConfig(tags_xy_m=((0.0, 1.0),), tag_layout="staggered")
    # a named layout survives replacing another field (the config's overrides do that)
    kept = dataclasses.replace(AisleConfig(tag_layout="staggered"), aisle_width_m=2.0)
    assert kept.tags_xy_m == NAMED_LAYOUTS["staggered"]


def test_velocity_vector_reading_starts_with_that_velocity_and_the_same_noise():
    kw = dict(duration_s=2.0, dt_s=0.05, start_xy_m=(0.0, 0.0), speed_range_mps=(0.1, 1.0), accel_var=0.01,
              y_limit_m=10.0)
    t, s = simulate_motion(trial_rng(4, 0), **kw)
    _, v = simulate_motion(trial_rng(4, 0), velocity_xy_mps=(0.1, 1.0), **kw)
    assert tuple(v[0, [1, 3]]) == (0.1, 1.0)
    # same accelerations: the velocity differences stay those of the initial state (no reflection here)
    np.testing.assert_allclose(v[:, 1] - s[:, 1], 0.1 - s[0, 1], atol=1e-12)
    np.testing.assert_allclose(v[:, 3] - s[:, 3], 1.0, atol=1e-12)


def test_first_decode_prior_starts_the_kf_at_the_first_decoded_tag():
    """prior = 'first-decode': the estimate at t_1 is l_i (the posterior of a flat prior after
    y_1 = l_i is N(l_i, G)); 'portal': the prior mean is the entry point with zero velocity."""
    times, obs = np.array([0.7, 1.2, 1.9]), np.array([[2.0, 1.0], [2.0, -1.0], [4.0, 1.0]])
    truth0 = np.array([0.0, 0.5, 0.0, 0.0])
    t0, mean, sd = prior_for("first-decode", truth0, (0.0, 0.0), times, obs, range_m=2.0, position_std_m=0.3,
                             velocity_std_mps=0.3)
    assert t0 == 0.7 and tuple(mean) == (2.0, 0.0, 1.0, 0.0) and sd[0] == pytest.approx(2.0 / np.sqrt(2.0))
    est = run_tracker("kf", times, obs, mean, m=0, n_runs=1, range_m=2.0, accel_var=0.01, a1=-2.5, a2=1.25,
                      position_std_m=sd[0], velocity_std_mps=sd[1], rng=None, t0_s=t0, from_first=True)
    assert est.shape == (1, 3, 2) and tuple(est[0, 0]) == (2.0, 1.0)
    _, mean, _ = prior_for("portal", truth0, (0.0, 0.0), times, obs, range_m=2.0, position_std_m=0.3,
                           velocity_std_mps=0.3)
    assert tuple(mean) == (0.0, 0.0, 0.0, 0.0)
    _, mean, _ = prior_for("truth", truth0, (0.0, 0.0), times, obs, range_m=2.0, position_std_m=0.3,
                           velocity_std_mps=0.3)
    assert tuple(mean) == tuple(truth0)


@pytest.fixture(scope="module")
def tiny():
    config = t2t.Config(trajectories=4, filter_runs=3, workers=1)
    return config, t2t.monte_carlo(config, seed=2)


def test_disc_decodes_exactly_the_uncollided_broadcasts_within_r(tiny):
    config, tables = tiny
    rec, b = tables["receptions"], tables["broadcasts"]
    n_b = b["t_s"].size
    for i, r in enumerate(config.ranges_m):
        sel = rec["range_m"] == r
        assert sel.sum() == n_b
        assert np.array_equal(rec["decoded"][sel], (rec["distance_m"][sel] <= r) & ~b["collided"])
        assert (tables["observations"]["range_m"] == r).sum() == rec["decoded"][sel].sum()
    # at most L/T_s = 20 decodes per second (L1203)
    per_s = np.bincount(np.floor(tables["observations"]["t_s"]).astype(int) +
                        100 * tables["observations"]["trajectory"] + 10000 * np.searchsorted(
                            config.ranges_m, tables["observations"]["range_m"]))
    assert per_s.max() <= 20


def test_runs_are_identical_on_one_and_two_workers(tiny):
    config, tables = tiny
    again = t2t.monte_carlo(t2t.Config(trajectories=4, filter_runs=3, workers=2), seed=2)
    for name in ("observations", "runs"):
        for k, v in tables[name].items():
            assert np.array_equal(v, again[name][k]), (name, k)


@pytest.mark.slow
def test_physical_threshold_calibration_holds_on_fresh_positions():
    """The calibrated threshold decodes about half of 200 new listener positions at r around the
    reference tag (binomial std 0.035 — tolerance 4 σ), nearly all at r/3 and none at 3r."""
    cfg = t2t.Config()
    pc, tags, ex = cfg.physical, cfg.layout.tags_xy_m, cfg.layout.exciter_xyz_m
    r = 2.0
    th, lo, hi = ph.calibrate_threshold(pc, ex, tags, r, trial_rng(8, 0))
    assert lo <= 0.5 <= hi
    d_e = np.hypot(np.hypot(np.array(tags)[:, 0] - ex[0], np.array(tags)[:, 1] - ex[1]), ex[2] - pc.height_m)
    ref = int(np.argsort(d_e)[(len(tags) - 1) // 2])
    phi = trial_rng(8, 1).uniform(-np.pi, np.pi, 200)
    fractions = []
    for d in (r, r / 3, 3 * r):
        lis = np.array(tags[ref]) + d * np.column_stack([np.cos(phi), np.sin(phi)])
        x, frames = ph.listener_inputs(pc, ex, tags, (ref,), lis, trial_rng(8, 2))
        fractions.append(np.mean(ph.decode_rows(pc, x, frames, (ref,), th) == ref))
    assert abs(fractions[0] - 0.5) <= 4 * 0.035
    assert fractions[1] > 0.7 and fractions[2] == 0.0


def test_physical_collision_captures_only_a_dominant_frame():
    """Two tags in one slot. A listener 0.2 m from tag 0 and 3.8 m from tag 2 decodes tag 0 in
    some of 40 draws (capture; the single-antenna comparator chain still loses most of them to
    the weak frame's added transitions) and never tag 2."""
    cfg = t2t.Config()
    pc, tags, ex = cfg.physical, cfg.layout.tags_xy_m, cfg.layout.exciter_xyz_m
    pc = dataclasses.replace(pc, calibration_positions=24)
    th, _, _ = ph.calibrate_threshold(pc, ex, tags, 2.0, trial_rng(9, 0))
    near = np.array(tags[0]) + np.column_stack([np.full(40, 0.2), np.zeros(40)])
    x, frames = ph.listener_inputs(pc, ex, tags, (0, 2), near, trial_rng(9, 1))
    got = ph.decode_rows(pc, x, frames, (0, 2), th)
    assert np.mean(got == 0) >= 0.1 and not np.any(got == 2)


BAD = [
    (["--set", "layout.tags_xy_m=[]"], "layout.tags_xy_m"),
    (["--set", "trackers.particles=[0, 10]"], "trackers.particles"),
    (["--set", "trackers.rbpf_particles=[0]"], "trackers.rbpf_particles"),
    (["--set", "protocol.n_slots=0"], "protocol.n_slots"),
    (["--set", "ranges_m=[0.0, 2.0]"], "ranges_m"),
    (["--set", "ranges_m=[-1.5]"], "ranges_m"),
    (["--set", "motion.start_xy_m=[0.0, 1.5]"], "motion.start_xy_m"),
    (["--set", "range_model=circle"], "range_model"),
]


@pytest.mark.parametrize("extra,key", BAD)
def test_bad_input_one_line_exit_2(extra, key, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "tag-to-tag-tracking", *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim: error: ") and key in err
    assert not list(tmp_path.glob("**/*.h5"))


# ----------------------------------------------------------------------------- Table 6.2 (slow)


@pytest.fixture(scope="module")
def full():
    config = t2t.Config(workers=2)  # 100 trajectories × 50 filter runs (L1214-L1219)
    tables = t2t.monte_carlo(config, seed=1)
    return t2t.summarize(config, tables)


def _row(s, r):
    return int(np.flatnonzero(s["range_m"] == r)[0])


@pytest.mark.slow
@pytest.mark.parametrize("r", [1.5, 2.0, 2.5])
def test_table_6_2_nn_and_pf_within_25_percent(full, r):
    i = _row(full, r)
    for label, pub in zip(("nn", "pf10", "pf20", "pf30"), np.take(PUBLISHED[r], [0, 2, 3, 4])):
        assert abs(full[f"{label}_rmse_m"][i] / pub - 1.0) <= 0.25, (label, full[f"{label}_rmse_m"][i], pub)


@pytest.mark.slow
def test_pf_error_falls_with_m_and_rbpf_equals_pf30(full):
    for r in (1.5, 2.0, 2.5):
        i = _row(full, r)
        assert full["pf10_rmse_m"][i] > full["pf20_rmse_m"][i] > full["pf30_rmse_m"][i]
        assert abs(full["rbpf30_rmse_m"][i] / full["pf30_rmse_m"][i] - 1.0) <= 0.10  # L1221


@pytest.mark.slow
def test_pf30_error_rises_from_r_1_5_to_larger_r(full):
    """L1228: r = 1.5 m tracks better than 2 and 2.5 m (Table 6.2's PF30: 0.518 < 0.534, 0.581)."""
    assert full["pf30_rmse_m"][_row(full, 1.5)] < min(full["pf30_rmse_m"][_row(full, 2.0)],
                                                      full["pf30_rmse_m"][_row(full, 2.5)])


# The KF rows of Table 6.2 are not reproduced (scenario docstring: the KF the text fixes —
# y = l_i, G = diag(r²/2, r²/2), updates at decodes only, Δt = t2 − t1, Q = diag(0.01, 0.01),
# the PF's prior — gives 0.294/0.289/0.320 m at r = 1.5/2/2.5 m, flat in r; none of the open
# readings tried makes it grow like the published 0.561/0.820/1.078 m). The Monte-Carlo standard
# error of the KF mean over the 100 trajectories is 0.008-0.010 m (per-trajectory sd 0.08-0.10 m),
# (PF30: 0.007-0.008 m): each of the three tests below misses its bound by 10 or more standard
# errors at its closest r, so they are strict xfails that turn into failures if the KF reproduces.
_KF_NOT_REPRODUCED = ("not reproduced: the KF fixed by the text reaches 0.29-0.32 m at every r (published "
                      "0.56/0.82/1.08 m, growing with r). Tried (seed 1, 100 trajectories, KF at r = 1.5/2/2.5 m): "
                      "5 layouts x 3 priors with the speed reading 0.20-0.78 m, never within 25 % at every r; the "
                      "velocity read as the vector (0.1, 1) m/s reproduces the KF row (short-1m 0.64/0.78/0.96 m) but "
                      "puts PF30 at 2.54-3.02 m; along the aisle with an unknown velocity KF 0.61-1.03 m, PF30 "
                      "1.27-1.49 m; no reading gives the KF row with PF30 < KF (docs page table)")


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=_KF_NOT_REPRODUCED)
def test_table_6_2_kf_within_25_percent(full):
    for r in (1.5, 2.0, 2.5):
        i = _row(full, r)
        assert abs(full["kf_rmse_m"][i] / PUBLISHED[r][1] - 1.0) <= 0.25, (r, full["kf_rmse_m"][i])


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=_KF_NOT_REPRODUCED + " (NN − KF = 0.87/1.12/1.32 m)")
def test_nn_minus_kf_about_half_a_metre(full):
    """L1228: "an average improvement of 0.5 m" (Table 6.2: 0.511/0.519/0.486 m), ±0.15 m (wave2-specs §X)."""
    for r in (1.5, 2.0, 2.5):
        i = _row(full, r)
        assert abs(full["nn_rmse_m"][i] - full["kf_rmse_m"][i] - 0.505) <= 0.15, r


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=_KF_NOT_REPRODUCED + " (PF30 0.41-0.50 m > KF)")
def test_pf30_beats_kf(full):
    """Table 6.2: PF M = 30 0.518/0.534/0.581 m < KF 0.561/0.820/1.078 m at every r."""
    for r in (1.5, 2.0, 2.5):
        i = _row(full, r)
        assert full["pf30_rmse_m"][i] < full["kf_rmse_m"][i], r


@pytest.mark.slow
def test_kf_row_follows_the_velocity_reading():
    """Cause of the KF row of Table 6.2 (0.561/0.820/1.078 m, growing × 1.9 with r): read as the
    velocity vector (x, y) = (0.1, 1) m/s (L1203 "[0.1, 1] m/s", as L836's "both velocity
    components"), the mobile tag bounces between the shelves, which the KF's constant-velocity
    model cannot follow, and the KF is within 25 % at every r (measured 0.64/0.78/0.96 m,
    layout ``short-1m``, true prior, seed 1, 100 trajectories; seeds 2, 3 within ± 0.015 m) with
    NN − KF within 0.5 ± 0.15 m; switched back to the speed reading (U[0.1, 1] m/s along the
    aisle) it falls below 60 % of the published at every r (measured 0.20/0.32/0.51 m)."""
    def kf_nn(**motion):
        cfg = t2t.Config(filter_runs=1, write_estimates=False, layout=AisleConfig(tag_layout="short-1m"),
                         motion=t2t.MotionConfig(**motion), trackers=t2t.TrackerConfig(particles=(), rbpf_particles=()))
        s = t2t.summarize(cfg, t2t.monte_carlo(cfg, seed=1))
        return s["kf_rmse_m"], s["nn_rmse_m"]

    pub = np.array([PUBLISHED[r][1] for r in (1.5, 2.0, 2.5)])
    kf, nn = kf_nn(initial_velocity="vector", initial_velocity_mps=(0.1, 1.0))
    assert np.all(np.abs(kf / pub - 1.0) <= 0.25), kf
    assert np.all(np.abs(nn - kf - 0.505) <= 0.15), nn - kf
    kf, _ = kf_nn()
    assert np.all(kf < 0.6 * pub), kf

"""Scenario st-localization (AURIS ch. 4): detection geometry, the Binomial surrogate, the bias
compensation, PF-AA on a still ST, trajectories, bad input; (slow) the published targets
(seeds/003 L4605, L4624, L4650, L5415)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.rng import trial_rng
from rfsim.core.trajectories import along_path, random_walk
from rfsim.detection.landmark_rts import draw_landmark_detections, rts_fixed_logit, rts_landmark_probability
from rfsim.estimators.landmark_pf import bias_compensate, binomial_log_likelihood, pf_aa
from rfsim.scenes import landmark_room as paths
from rfsim.scenarios import st_localization as st


def test_rts_probability_below_the_antenna_is_eq_4_6_by_hand():
    """Landmark right under the 2 m antenna: D = 2, θ = φ = 0; at d = 0 and 0.5 m
    p = 1/(1 + exp(−1.462 + 0.4941·2 + 2.506·d)) (coefficients L3854-L3873)."""
    room = paths.Room((1.0, 1.0), (1, 1), ((0.0, 0.0, 2.0),))
    base = rts_fixed_logit(room.antennas_xyz_m, room.landmarks_xy())
    for d in (0.0, 0.5):
        assert rts_landmark_probability(base[0, 0], d) == pytest.approx(1 / (1 + math.exp(-1.462 + 0.9882 + 2.506 * d)), rel=1e-12)
    # a landmark 1 m off along y: D = √5, θ = arcsin(1/√5), φ = 0
    room = paths.Room((4.0, 2.0), (1, 2), ((0.0, -0.5, 2.0),))
    lm = room.landmarks_xy()  # (0, −0.5) and (0, 0.5)
    base = rts_fixed_logit(room.antennas_xyz_m, lm)
    expected = -1.462 + 0.4941 * math.sqrt(5) + 0.0126 * math.asin(1 / math.sqrt(5))
    assert base[0, 1] == pytest.approx(expected, rel=1e-12)


def test_a_still_st_sees_binomial_counts():
    """Surrogate with the ST still: n ~ Binomial(10, p); 4000 periods, mean and variance within
    4 standard errors."""
    config = st.Config(preset="pfaa")
    room = config.room
    lm = room.landmarks_xy()
    base = rts_fixed_logit(room.antennas_xyz_m, lm)
    pos = np.broadcast_to(lm[22] + [0.1, 0.0], (4000, 10, 2))
    out = draw_landmark_detections(base, lm, room.antennas_xyz_m, pos, period_s=0.3, rng=trial_rng(4, 0))
    n = out["counts"][:, 22]
    p = rts_landmark_probability(base[0, 22], 0.1)
    assert abs(n.mean() - 10 * p) < 4 * math.sqrt(10 * p * (1 - p) / 4000)
    assert abs(n.var() / (10 * p * (1 - p)) - 1) < 4 * math.sqrt(2 / 4000)
    # the mean detection time is inside each period
    t = out["mean_detection_s"]
    ok = np.isfinite(t)
    assert np.all((t[ok] > np.flatnonzero(ok) * 0.3) & (t[ok] < (np.flatnonzero(ok) + 1) * 0.3))


def test_bias_compensation_removes_a_constant_velocity_lag():
    """x̂ lags the truth by v·(t − t̂); with v̂ = v, b0 + b1 = 1 and |v| above the threshold the
    compensated estimate (Eqs. 4.23-4.24) is the truth; below the threshold nothing changes."""
    v = np.array([2.0, -1.0])
    t_end = np.arange(1, 11) * 0.3
    t_hat = t_end - 0.15
    truth = v * t_end[:, None]
    x_hat = (truth - v * 0.15)[None]
    v_hat = np.broadcast_to(v, x_hat.shape)
    got = bias_compensate(x_hat, v_hat, period_end_s=t_end, mean_detection_s=t_hat[None], b0=0.8, b1=0.2,
                          v_threshold_mps=1.2)
    assert np.allclose(got[0, 1:], truth[1:])
    same = bias_compensate(x_hat, v_hat, period_end_s=t_end, mean_detection_s=t_hat[None], b0=0.8, b1=0.2,
                           v_threshold_mps=10.0)
    assert np.array_equal(same, x_hat)


def test_binomial_log_likelihood_is_the_sum_over_landmarks():
    p = np.array([[[0.2, 0.7]]])
    got = binomial_log_likelihood(np.array([[3, 9]]), p, 10)
    assert got[0, 0] == pytest.approx(3 * math.log(0.2) + 7 * math.log(0.8) + 9 * math.log(0.7) + math.log(0.3))


def test_pf_aa_finds_a_still_st():
    """30 periods of surrogate detections of a still ST at (0.7, −0.4): PF-AA's last estimate is
    within 0.2 m in each of 5 runs (the RTS model's 50 % radius near the centre is ≈ 0.19 m)."""
    config = st.Config(preset="pfaa")
    room = config.room
    lm = room.landmarks_xy()
    base = rts_fixed_logit(room.antennas_xyz_m, lm)
    truth = np.array([0.7, -0.4])
    counts = np.stack([draw_landmark_detections(base, lm, room.antennas_xyz_m, np.broadcast_to(truth, (30, 10, 2)),
                                                period_s=0.3, rng=trial_rng(5, b))["counts"] for b in range(5)])

    def probability(p, t):
        return rts_landmark_probability(base[0][None, None, :], np.linalg.norm(p[:, :, None, :] - lm, axis=-1))

    x, _ = pf_aa(counts, lm, n_particles=200, period_s=0.3, q_std_m=0.3, init_std_m=0.3, b0=0.8, b1=0.2,
                 n_rounds=10, probability=probability, rng=trial_rng(5, 99))
    assert np.all(np.linalg.norm(x[:, -1] - truth, axis=-1) < 0.2)


def test_trajectories_are_closed_constant_speed_and_the_walk_stays_in_the_room():
    t = np.linspace(0, 20, 2001)
    p1 = along_path(np.array(paths.TRAJECTORY_1_XY), 0.5, t)
    assert np.allclose(np.linalg.norm(np.diff(p1, axis=0), axis=1)[:900], 0.005, atol=1e-9)  # 10 m loop, 0.5 m/s
    assert np.allclose(along_path(np.array(paths.TRAJECTORY_1_XY), 1.0, [0.0, 10.0]), [[-1.5, -1.0]] * 2)
    w = random_walk(trial_rng(2, 0), (-2, -1.6, 2, 1.6), (0.1, 3.0), np.linspace(0, 600, 20001))
    assert np.all(np.abs(w[:, 0]) <= 2 + 1e-9) and np.all(np.abs(w[:, 1]) <= 1.6 + 1e-9)
    step = np.linalg.norm(np.diff(w, axis=0), axis=1) / 0.03
    assert step.max() <= 3.0 + 1e-6 and np.ptp(w[:, 0]) > 3.0


BAD = [
    (["--set", "landmark_grid=[0, 5]"], "landmark_grid"),
    (["--set", "filters.particles=0"], "filters.particles"),
    (["--set", "trajectory_1_xy_m=[[0.0, 0.0], [3.0, 0.0]]"], "trajectory_1_xy_m"),
    (["--set", "preset=hall"], "preset"),
    (["--set", "rounds=0"], "rounds"),
    (["--set", "walk_speed_mps=[2.0, 1.0]"], "walk_speed_mps"),
]


@pytest.mark.parametrize("extra,key", BAD)
def test_bad_input_one_line_exit_2(extra, key, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "st-localization", *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim: error: ") and key in err
    assert not list(tmp_path.glob("**/*.h5"))


# ----------------------------------------------------------------------------- published targets (slow)


def _summary(**kw):
    config = st.Config(**kw)
    return st.summarize(config, st.monte_carlo(config, seed=1))


@pytest.fixture(scope="module")
def half_metre():
    """Trajectory 2 at 0.5 m/s, 100 realizations (L4616-L4624): the source's average RMSE per
    tracker, and the standard error of it from the spread of the realizations' own averages."""
    config = st.Config(experiments=("trajectory-2",), trajectory_2_speeds_mps=(0.5,), realizations=100)
    tables = st.monte_carlo(config, seed=1)
    s, _ = st.summarize(config, tables)
    est = tables["estimates"]
    se = {}
    for label in ("pfbin", "pfaa", "wcl"):
        sel = est["tracker"] == label
        per = np.bincount(est["realization"][sel], est["error_m"][sel]) / np.bincount(est["realization"][sel])
        se[label] = float(np.std(per, ddof=1) / math.sqrt(per.size))
    return dict(zip(s["tracker"], s["mean_error_m"])), se


@pytest.mark.slow
def test_pfbin_and_pfaa_at_half_a_metre_per_second_beat_wcl(half_metre):
    """Figs. 4.12-4.13: both particle filters well below the weighted centroid at 0.5 m/s."""
    m, _ = half_metre
    assert max(m["pfbin"], m["pfaa"]) < 0.85 * m["wcl"]


@pytest.mark.slow
def test_pfbin_and_pfaa_at_half_a_metre_per_second_within_3_cm(half_metre):
    """L4624: PF-BIN 0.1681, PF-AA 0.1717 m (±0.03 m), |Δ| ≤ 0.02 m (wave2-specs.md §R), in the
    source's measure (the l2 error averaged over realizations and time, L4507-L4513). The
    standard error of the 100-realization means (their spread over realizations, measured
    0.0014 / 0.0008 m) is far inside the spec's ±0.03 m: the check is not decided by the
    Monte-Carlo noise. Measured (seed 1) PF-BIN 0.179 m, PF-AA 0.188 m."""
    m, se = half_metre
    assert 4.0 * max(se["pfbin"], se["pfaa"]) < 0.03
    assert abs(m["pfbin"] - 0.1681) <= 0.03 and abs(m["pfaa"] - 0.1717) <= 0.03
    assert abs(m["pfbin"] - m["pfaa"]) <= 0.02


@pytest.mark.slow
def test_bias_compensation_crossover_near_1_2_m_per_s():
    """L4605: compensation helps above ≈ 1.2 m/s (±0.3 m/s)."""
    _, a = _summary(experiments=("speed-sweep",), realizations=20)
    assert abs(a["crossover_mps"] - 1.2) <= 0.3


@pytest.mark.slow
def test_pfaa_beats_wcl_by_about_36_percent_over_1500_s():
    """L4650: cumulated RMSE −36.6 % against WCL at 1500 s (±10 percentage points)."""
    _, a = _summary(experiments=("random-walk",))
    assert abs(a["pfaa_vs_wcl_percent"] - (-36.6)) <= 10.0


@pytest.mark.slow
def test_sqlam_beats_wcl_by_about_42_percent_over_500_s():
    """L5415: −41.9 % over 500 s, 100 random tracks in the 5 × 4 m room (here 20; ±10 pp)."""
    _, a = _summary(preset="sqlam", realizations=20)
    assert abs(a["sqlam_vs_wcl_percent"] - (-41.9)) <= 10.0


# ----------------------------------------------------------------------------- sample level


def _listen(grid, centre, rounds, seed=1):
    from rfsim.devices.sense_a_tag import SenseATagConfig
    from rfsim.scenes.landmark_listening import SampleLevelConfig, listen_track

    room = paths.Room((4.0, 3.2), grid, ((0.0, 0.0, 2.0),))
    sl = SampleLevelConfig(duration_s=1e-3, max_periods=1)
    return room, sl, listen_track(room, lambda t: np.asarray(centre, float), rounds=rounds, sl=sl,
                                  st_config=SenseATagConfig(), seed=seed, key=(0,))


def test_sample_level_st_beside_a_landmark_hears_it_every_round_and_not_the_far_one():
    # landmarks at (-1, 0) and (1, 0); the ST 0.1 m above the first (5 cm off): every QT round
    # reads both landmarks, the ST decodes the near EPC each time and never the one 2 m away
    # (its backscatter at the ST stays below the 5 mV comparator)
    _, _, res = _listen((2, 1), (-1.0, 0.05, 0.1), rounds=3)
    assert res.reads_per_period.tolist() == [6]
    assert res.counts.tolist() == [[3, 0]]
    assert np.all((res.times_s > 0) & (res.times_s < res.t_end_s[0]))


def test_sample_level_period_is_bounded_by_the_gen2_air_time_of_its_slots():
    from rfsim.gen2.commands import ACK, QueryRep
    from rfsim.gen2.link import profile, t1

    room, sl, res = _listen((3, 2), (0.0, 0.0, 0.1), rounds=2)
    lk = profile(sl.link_profile)
    slots, reads = int(res.slots_per_period[0]), int(res.reads_per_period[0])
    assert reads == 2 * 6  # every landmark read in each of the two QT rounds
    # every slot opens with at least a QueryRep; every read adds RN16, ACK and PC+EPC+CRC-16
    rep, ack = lk.command_duration_s(QueryRep(session=0)), lk.command_duration_s(ACK(0))
    lo = slots * rep + reads * (lk.reply_duration_s(16) + ack + lk.reply_duration_s(128))
    # and at most, per slot besides those: a Query (22 bits of ≤ 2 Tari, preamble, a QueryRep's
    # frame-sync) and a NAK, two T1max, two T2 (10 Tpri each), two Tari of CW lead, two RTcal
    per_slot = (2 * lk.command_duration_s(QueryRep(session=0)) + 22 * lk.tari_s * 2 + 2 * t1(lk).max_s
                + 20 * lk.tpri_s + 2 * lk.tari_s + 2 * lk.rtcal_s)
    hi = lo + slots * per_slot
    assert lo < res.t_end_s[0] < hi


SAMPLE_BAD = [
    (["--set", "mode=sample-level", "--set", "preset=lab"], "mode"),
    (["--set", "mode=sample-level", "--set", "st.technique=stamp"], "st.technique"),
    (["--set", "mode=sample-level", "--set", "sample_level.duration_s=0"], "sample_level.duration_s"),
    (["--set", "mode=sample-level", "--set", "sample_level.st_step_m=0"], "sample_level.st_step_m"),
    (["--set", "mode=sample-level", "--set", "sample_level.realizations=0"], "sample_level.realizations"),
    (["--set", "mode=sample_level"], "mode"),
]


@pytest.mark.parametrize("extra,key", SAMPLE_BAD)
def test_sample_level_bad_input_one_line_exit_2(extra, key, capsys, tmp_path, monkeypatch):
    test_bad_input_one_line_exit_2(extra, key, capsys, tmp_path, monkeypatch)


def test_sample_level_run_feeds_the_trackers_with_the_measured_period():
    from rfsim.scenes.landmark_listening import SampleLevelConfig

    cfg = st.Config(mode="sample-level", landmark_grid=(3, 2), rounds=2, trajectory_2_speeds_mps=(0.5,),
                    sample_level=SampleLevelConfig(duration_s=0.4), workers=1)
    tables = st.monte_carlo(cfg, seed=1)
    per = tables["periods"]
    # periods of two QT rounds over 6 landmarks, back to back from t = 0 until 0.4 s is passed
    assert np.all(per["reads"] == 12) and per["t_end_s"][-2] < 0.4 <= per["t_end_s"][-1]
    np.testing.assert_allclose(np.cumsum(per["period_duration_s"]), per["t_end_s"], rtol=1e-12)
    est = tables["estimates"]
    assert sorted(set(est["tracker"])) == ["pfaa", "pfbin", "wcl"]
    assert est["error_m"].size == 3 * per["t_end_s"].size and np.all(np.isfinite(est["error_m"]))
    # the truth is the trajectory-2 position at each measured period end
    want = along_path(paths.trajectory_2_xy(), 0.5, per["t_end_s"])
    np.testing.assert_allclose(np.column_stack([per["x_true_m"], per["y_true_m"]]), want, atol=1e-12)


def test_sample_level_reader_side_equals_the_engine_inventory():
    """The ST only listens: an inventory through ListeningAir gives the same slots and reads, to
    the bit, as rfsim.protocols.inventory.EngineAir (run_exchange) on the same devices and streams."""
    from dataclasses import replace

    from rfsim.channels import ApdpModel, Channel, Scene
    from rfsim.devices.reader import Reader, ReaderConfig
    from rfsim.devices.sense_a_tag import SenseATag, SenseATagConfig, st_antenna_positions
    from rfsim.devices.tag import PassiveTag, TagConfig
    from rfsim.protocols.inventory import EngineAir, InventoryConfig, run_inventory
    from rfsim.scenes import landmark_listening as sl

    room = paths.Room((4.0, 3.2), (3, 2), ((0.0, 0.0, 2.0),))
    c = sl.SampleLevelConfig()

    def build():
        rc = ReaderConfig(link_profile=c.link_profile, fs_hz=c.fs_hz, ptx_dbm=c.ptx_dbm, hopping=True)
        reader = Reader(rc, [sl.panel((0.0, 0.0, 2.0), c)], rng=trial_rng(5, 0))
        tags = [PassiveTag(replace(TagConfig(), epc_hex=sl.landmark_epc_hex(i)), sl.flat_dipole((x, y, 0.0)),
                           rng=trial_rng(5, 100 + i)) for i, (x, y) in enumerate(room.landmarks_xy())]
        return reader, tags, Channel(Scene(apdp=ApdpModel()))

    log_engine = run_inventory(EngineAir(*build(), rng=trial_rng(5, 1)), InventoryConfig())
    stc = SenseATagConfig()
    centre = np.array([0.05, -0.8, 0.1])  # beside landmark 2 at (0, -0.8); the others ≥ 1.3 m away
    st_dev = SenseATag(stc, [sl.flat_dipole(p) for p in st_antenna_positions(centre, spacing_m=stc.spacing_m)],
                       rng=trial_rng(5, 3), fs_hz=c.fs_hz)
    air = sl.ListeningAir(*build(), st_dev, lambda t: centre, st_config=stc, rng=trial_rng(5, 1),
                          st_rng=trial_rng(5, 2), epcs={sl.landmark_epc_hex(i): i for i in range(6)})
    log_st = run_inventory(air, InventoryConfig())
    assert len(log_engine.reads["tag"]) == 6
    for table in ("slots", "reads"):
        a, b = getattr(log_engine, table), getattr(log_st, table)
        for k in a:
            x, y = np.asarray(a[k]), np.asarray(b[k])
            assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), (table, k)
    # and the ST heard the one read of its neighbour, during that read's EPC slot
    assert [k for _, k in air.detections] == [2]
    i = log_st.reads["tag"].index(2)
    assert log_st.reads["time_s"][i] < air.detections[0][0] < log_st.reads["time_s"][i] + 0.02


@pytest.mark.slow
def test_sample_level_ten_rounds_over_45_landmarks_take_far_longer_than_0_3_s():
    """wave2-specs.md §R: 10 QT rounds over the 45 landmarks take ≥ ≈ 1.1 s, not the source's
    0.3 s; here bounded below by the replies' and commands' air time alone (link profile
    formulas), with every landmark read in every round."""
    from rfsim.gen2.commands import ACK, QueryRep
    from rfsim.gen2.link import profile

    room, sl, res = _listen((9, 5), (0.2, 0.1, 0.1), rounds=10)
    lk = profile(sl.link_profile)
    slots, reads = int(res.slots_per_period[0]), int(res.reads_per_period[0])
    assert reads == 450
    lo = (slots * lk.command_duration_s(QueryRep(session=0))
          + reads * (lk.reply_duration_s(16) + lk.command_duration_s(ACK(0)) + lk.reply_duration_s(128)))
    assert 1.1 < lo < res.t_end_s[0]
    # the ST hears its nearest landmarks and not those across the room
    d = np.linalg.norm(room.landmarks_xy() - [0.2, 0.1], axis=1)
    assert res.counts[0][d < 0.5].sum() > 0 and res.counts[0][d > 1.5].sum() == 0

"""Landmark tracking pieces of the library: the RTS surrogate's likelihood model and antenna
selection, the tracker dispatch, the per-step RMS error, the room's paths and checks, and the
rows of a track (AURIS ch. 4; seeds/003 L4493-L4650, L5633-L5641)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.core.errors import ConfigError
from rfsim.core.rng import trial_rng
from rfsim.core.trajectories import along_path
from rfsim.detection.landmark_rts import (draw_landmark_detections, rts_fixed_logit, rts_landmark_probability,
                                          rts_likelihood_model)
from rfsim.estimators.landmark_pf import LandmarkFilterConfig, pf_aa, run_tracker, wcl_track
from rfsim.estimators.track_errors import mean_rms_error, rms_per_step
from rfsim.scenes.landmark_room import Room, path_positions
from rfsim.scenes.landmark_tracks import detection_rows, estimate_rows, period_rows, surrogate_track


def test_rms_per_step_by_hand():
    # step 0: errors 3 and 4 → sqrt(12.5); step 1: none → NaN; step 2: 2
    r = rms_per_step([0, 2, 0], [3.0, 2.0, 4.0])
    assert r[0] == pytest.approx(math.sqrt(12.5)) and math.isnan(r[1]) and r[2] == 2.0
    assert mean_rms_error([0, 2, 0], [3.0, 2.0, 4.0]) == pytest.approx((math.sqrt(12.5) + 2.0) / 2)
    assert math.isnan(mean_rms_error([], []))


def test_likelihood_model_uses_each_runs_active_antenna():
    """Two antennas at (±2, 0, 2) m, one landmark at the origin: run 0 with antenna 0 and run 1
    with antenna 1 see the same D = √8 and |φ| = π/4 (φ = arcsin(Δx/D)); at d = 0.3 m
    p = 1/(1 + exp(−1.462 + 0.4941·√8 + 2.506·0.3 + 0.0523·π/4))."""
    ant = ((-2.0, 0.0, 2.0), (2.0, 0.0, 2.0))
    lm = np.zeros((1, 2))
    base = rts_fixed_logit(ant, lm)
    prob = rts_likelihood_model(base, np.array([[0], [1]]), lm)
    p = prob(np.array([[[0.3, 0.0]], [[0.0, 0.3]]]), 0)
    want = 1 / (1 + math.exp(-1.462 + 0.4941 * math.sqrt(8) + 2.506 * 0.3 + 0.0523 * math.pi / 4))
    np.testing.assert_allclose(p, want, rtol=1e-12)


def test_the_active_antenna_follows_the_previous_centroid():
    """L5633-L5641: the first period uses the antenna nearest to (0, 0); once the ST (still,
    beside the landmark under antenna 1) is detected, antenna 1 stays active."""
    ant = ((-1.0, 0.0, 2.0), (4.0, 0.0, 2.0))
    lm = np.array([[-1.0, 0.0], [4.0, 0.0]])
    base = rts_fixed_logit(ant, lm)
    pos = np.broadcast_to([4.0, 0.05], (20, 10, 2))
    out = draw_landmark_detections(base, lm, ant, pos, period_s=0.3, rng=trial_rng(3, 0))
    assert out["active"][0] == 0
    first = int(np.flatnonzero(out["counts"].sum(axis=1) > 0)[0])
    assert np.all(out["active"][first + 1:] == 1)
    assert out["counts"][:, 0].sum() == 0  # landmark 0 is 5 m from the ST: p ≈ 0
    assert rts_landmark_probability(base[1, 0], 5.0) < 1e-5


def test_run_tracker_dispatches_to_the_filters():
    room = Room((2.0, 2.0), (3, 3), ((0.0, 0.0, 2.0),))
    lm = room.landmarks_xy()
    counts = np.zeros((2, 4, lm.shape[0]), np.int64)
    counts[:, :, 4] = 5   # the centre landmark only
    counts[1, 2] = 0      # run 1, period 2: nothing
    base = rts_fixed_logit(room.antennas_xyz_m, lm)
    prob = rts_likelihood_model(base, np.zeros((2, 4), np.int64), lm)
    f = LandmarkFilterConfig(particles=50)
    t_end = np.tile(np.arange(1, 5) * 0.3, (2, 1))
    kw = dict(config=f, period_s=0.3, n_rounds=10, probability=prob, initial_state=np.zeros((2, 4)),
              period_end_s=t_end, mean_detection_s=t_end - 0.15)
    wcl = run_tracker("wcl", counts, lm, v_threshold_mps=0.0, rng=trial_rng(1, 0), **kw)
    np.testing.assert_array_equal(wcl, wcl_track(counts, lm, np.mean(lm, axis=0)))
    x = run_tracker("pfaa", counts, lm, v_threshold_mps=np.inf, rng=trial_rng(1, 1), **kw)
    ref, _ = pf_aa(counts, lm, n_particles=50, period_s=0.3, q_std_m=f.q_std_m, init_std_m=f.init_std_m, b0=f.b0,
                   b1=f.b1, n_rounds=10, probability=prob, rng=trial_rng(1, 1))
    np.testing.assert_array_equal(x, ref)
    assert run_tracker("pfbin", counts, lm, v_threshold_mps=0.0, rng=trial_rng(1, 2), **kw).shape == (2, 4, 2)


def test_paths_close_trajectory_1_and_stay_in_the_room():
    open_pts = ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0))
    t = np.linspace(0.0, 10.0, 101)
    got = path_positions("1", t, speed_mps=0.7, trajectory_1_xy=open_pts, bounds_m=(-2, -2, 2, 2),
                         walk_speed_mps=(0.1, 1.0), walk_rng=None)
    np.testing.assert_array_equal(got, along_path(open_pts + open_pts[:1], 0.7, t))
    walk = path_positions("random-walk", t.reshape(101, 1), speed_mps=0.0, trajectory_1_xy=open_pts,
                          bounds_m=(-2, -1, 2, 1), walk_speed_mps=(0.5, 1.0), walk_rng=lambda: trial_rng(2, 0))
    assert walk.shape == (101, 1, 2)
    assert np.all(np.abs(walk[..., 0]) <= 2 + 1e-9) and np.all(np.abs(walk[..., 1]) <= 1 + 1e-9)


def test_room_waypoint_check_names_the_key():
    room = Room((4.0, 3.2), (9, 5), ((0.0, 0.0, 2.0),))
    room.check_waypoints("k", ((0.0, 0.0), (1.9, 1.5)))
    with pytest.raises(ConfigError, match="k"):
        room.check_waypoints("k", ((0.0, 0.0), (2.1, 0.0)))
    with pytest.raises(ConfigError, match="at least 2"):
        room.check_waypoints("k", ((0.0, 0.0),))


def test_surrogate_track_grid_start_and_rows():
    """5 periods of 0.3 s; on a straight segment at 0.5 m/s the start state is the position at
    t = 0 and the velocity (0.5, 0) m/s; the rows count what the track holds."""
    room = Room((4.0, 3.2), (9, 5), ((0.0, 0.0, 2.0),))
    path = ((-1.5, 0.0), (1.5, 0.0), (-1.5, 0.0))
    track = surrogate_track(room, lambda t: along_path(path, 0.5, t), duration_s=1.5, period_s=0.3, rounds=10,
                            rng=trial_rng(7, 0))
    np.testing.assert_allclose(track["t_end_s"], [0.3, 0.6, 0.9, 1.2, 1.5], rtol=1e-12)
    np.testing.assert_allclose(track["start"], [-1.5, 0.0, 0.5, 0.0], atol=1e-9)
    np.testing.assert_allclose(track["truth"][:, 0], -1.5 + 0.5 * track["t_end_s"], atol=1e-12)
    per = period_rows(3, 1, track)
    np.testing.assert_allclose(per["period_duration_s"], 0.3, rtol=1e-9)
    assert per["detections"].sum() == track["counts"].sum()
    det = detection_rows(3, 1, track)
    assert det["count"].sum() == track["counts"].sum() and np.all(det["count"] > 0) and np.all(det["case"] == 3)
    rows = estimate_rows(3, 1, track, {"truth": track["truth"], "shifted": track["truth"] + [0.3, 0.4]})
    assert [r["tracker"][0] for r in rows] == ["truth", "shifted"]
    np.testing.assert_allclose(rows[0]["error_m"], 0.0)
    np.testing.assert_allclose(rows[1]["error_m"], 0.5, rtol=1e-12)

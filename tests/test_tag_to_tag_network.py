"""The reader-free tag-to-tag network: Eq. (6.5) (rfsim.detection.tag_to_tag), the reception
rules of the reference-tag scene (rfsim.scenes.reference_tags), the tracker set of Table 6.2
(rfsim.estimators.proximity_trackers) and the generic figure pieces they draw with."""

from __future__ import annotations

import math

import numpy as np

from rfsim.core.plots import grouped_bars, pyplot, step_cdf
from rfsim.detection.tag_to_tag import Eq65Config, in_range, logistic_coefficients, logistic_p
from rfsim.estimators.proximity_trackers import TrackerConfig, prior_particles, run_tracker
from rfsim.scenes.aisle import AisleConfig, position_at
from rfsim.scenes.reference_tags import ReferenceTagsConfig, receive_broadcasts


def test_eq65_is_one_half_at_d50_and_stretches_to_the_range():
    assert logistic_p(0.5, -2.5, 5.0) == 0.5
    assert math.isclose(float(logistic_p(0.0, -2.5, 5.0)), 1 / (1 + math.exp(-2.5)), rel_tol=1e-15)
    a1, a2 = logistic_coefficients(-2.5, 5.0, 2.0, True)
    assert (a1, a2) == (-2.5, 1.25) and logistic_p(2.0, a1, a2) == 0.5
    assert logistic_coefficients(-2.5, 5.0, 2.0, False) == (-2.5, 5.0)
    assert Eq65Config(logistic_a1=-3.0, scale_to_range=True).coefficients(1.5) == (-3.0, 2.0)


def test_in_range_disc_is_a_threshold_and_logistic_a_bernoulli_draw():
    d = np.array([0.5, 1.0, 1.5])
    assert in_range(d, model="disc", range_m=1.0, a1=0, a2=0, rng=None).tolist() == [True, True, False]
    hits = in_range(np.full(20000, 1.0), model="logistic", range_m=1.0, a1=-1.0, a2=0.0, rng=np.random.default_rng(3))
    p = 1 / (1 + math.exp(-1.0))
    assert abs(hits.mean() - p) < 4 * math.sqrt(p * (1 - p) / 20000)


def test_disc_and_loss_decode_the_uncollided_broadcasts_within_r():
    b = {"period": np.array([0, 0, 0, 1]), "slot": np.array([3, 3, 7, 1]), "tag": np.array([0, 1, 2, 0]),
         "n_in_slot": np.array([2, 2, 1, 1])}
    reach, decoded = receive_broadcasts(ReferenceTagsConfig(), (0, 0, 2), [(0, 0), (1, 0), (2, 0)], b,
                                        np.zeros((4, 2)), np.array([0.5, 0.5, 2.5, 1.5]), range_model="disc",
                                        collision_model="loss", range_m=2.0, a1=0.0, a2=0.0, n_slots=10,
                                        threshold_v=float("nan"), rng=np.random.default_rng(0))
    assert reach.tolist() == [True, True, False, True]
    assert decoded.tolist() == [False, False, False, True]


def test_trackers_nn_is_the_association_and_the_rbpf_prior_holds_the_mean_velocity():
    t = np.array([0.5, 1.0, 1.5])
    obs = np.array([[0.0, 1.0], [2.0, 1.0], [2.0, -1.0]])
    x0 = np.array([0.0, 0.5, 0.0, 0.0])
    common = dict(m=0, n_runs=1, range_m=2.0, accel_var=0.01, a1=-2.5, a2=1.25, position_std_m=0.3,
                  velocity_std_mps=0.3, rng=np.random.default_rng(1))
    assert np.array_equal(run_tracker("nn", t, obs, x0, **common), obs[None])
    kf = run_tracker("kf", t, obs, x0, **common)
    assert kf.shape == (1, 3, 2) and np.all(np.abs(kf) < 3.0)
    p = prior_particles(x0, np.random.default_rng(2), 3, 4000, position_std_m=0.3, velocity_std_mps=0.2,
                        rao_blackwellised=True)
    assert p.shape == (3, 4000, 4) and np.all(p[..., 1::2] == x0[1::2])
    assert abs(p[..., 0].std() - 0.3) < 0.3 * 0.05
    labels = TrackerConfig(particles=(5,), rbpf_particles=(7, 9)).labels
    assert labels == [("nn", "nn", 0), ("kf", "kf", 0), ("pf5", "pf", 5), ("rbpf7", "rbpf", 7), ("rbpf9", "rbpf", 9)]


def test_aisle_limit_and_interpolated_positions():
    assert AisleConfig(aisle_width_m=3.0, shelf_clearance_m=0.25).y_limit_m == 1.25
    states = np.array([[0.0, 1.0, 0.0, 0.0], [1.0, 1.0, 0.5, 0.0]])
    assert position_at(np.array([0.0, 1.0]), states, [0.5]).tolist() == [[0.5, 0.25]]


def test_step_cdf_and_grouped_bars_draw_what_they_are_given():
    plt = pyplot()
    fig, ax = plt.subplots()
    step_cdf(ax, [3.0, 1.0, 2.0], label="x")
    step_cdf(ax, [], label="empty")
    (line,) = ax.get_lines()
    assert line.get_xdata().tolist() == [1.0, 2.0, 3.0] and line.get_ydata().tolist() == [1 / 3, 2 / 3, 1.0]
    grouped_bars(ax, ["a", "b"], [("g1", [1.0, 2.0], [1.1, np.nan]), ("g2", [3.0, 4.0], [3.3, 4.4])], mark_label="ref")
    heights = [p.get_height() for p in ax.patches]
    assert heights == [1.0, 2.0, 3.0, 4.0]
    assert np.allclose([p.get_x() + p.get_width() / 2 for p in ax.patches], [-0.2, 0.8, 0.2, 1.2], rtol=0, atol=1e-12)
    plt.close(fig)


def test_physical_collisions_decode_at_most_one_sender_per_slot():
    """Tags 0 and 1 share a slot, tag 2 is alone; the mobile tag sits 0.3 m from tag 0. With the
    disc range and physical collisions, the lone broadcast follows the disc, and of the collided
    pair at most one is decoded (the slot decodes as one frame or none), never the far tag 1."""
    tags = [(0.0, -1.0), (8.0, 1.0), (2.0, -1.0)]
    b = {"period": np.array([0, 0, 0]), "slot": np.array([3, 3, 5]), "tag": np.array([0, 1, 2]),
         "n_in_slot": np.array([2, 2, 1])}
    pos = np.tile([0.3, -1.0], (3, 1))
    dist = np.linalg.norm(pos - np.array(tags), axis=1)
    reach, decoded = receive_broadcasts(ReferenceTagsConfig(), (4.0, 0.0, 2.0), tags, b, pos, dist,
                                        range_model="disc", collision_model="physical", range_m=2.0, a1=0.0, a2=0.0,
                                        n_slots=50, threshold_v=1e-3, rng=np.random.default_rng(4))
    assert reach.tolist() == [True, False, True] and decoded[2]
    assert not decoded[1] and decoded[:2].sum() <= 1

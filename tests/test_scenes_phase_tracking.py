"""The phase-tracking scene (rfsim.scenes.phase_tracking): the polygon path, the jittered motion,
the one-carrier rule, the geometry checks — against positions and speeds worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.core.errors import ConfigError
from rfsim.devices.reader_config import ReaderConfig
from rfsim.scenes.phase_tracking import (GeometryConfig, TagMotion, TrajectoryConfig, carrier_hz, check_scene,
                                         polygon_path, reader_antennas)

SQUARE = ((1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0))


def test_polygon_path_walks_the_square_at_constant_speed_and_closes():
    # perimeter 4 m at 0.5 m/s: corner k at t = 2k s, midpoints at odd seconds, back at t = 8 s
    t = np.array([0.0, 1.0, 2.0, 3.0, 5.0, 7.0, 8.0, 9.0])
    p = polygon_path(t, SQUARE, 0.5)
    expect = [(1.0, 1.0), (1.5, 1.0), (2.0, 1.0), (2.0, 1.5), (1.5, 2.0), (1.0, 1.5), (1.0, 1.0), (1.5, 1.0)]
    assert np.allclose(p, expect, atol=1e-12)


def test_motion_jitter_has_the_configured_rms_and_none_when_off():
    tr = TrajectoryConfig(corners_xy_m=SQUARE, speed_mps=0.2, duration_s=20.0, jitter_rms_m=0.02)
    m = TagMotion(tr, rng=np.random.default_rng(1))
    assert math.sqrt(np.mean(np.sum(m.jitter ** 2, axis=1))) == pytest.approx(0.02, rel=1e-12)
    still = TagMotion(TrajectoryConfig(corners_xy_m=SQUARE, duration_s=20.0, jitter_rms_m=0.0),
                      rng=np.random.default_rng(1))
    t = np.linspace(0.0, 19.0, 7)
    assert np.array_equal(still.true(t), still.intended(t))


def test_radial_speed_of_a_straight_pass_is_the_path_speed_towards_an_anchor_on_its_line():
    # the first side runs along y = 1 at 0.2 m/s; an anchor at (0, 1) sees the range grow at 0.2 m/s
    tr = TrajectoryConfig(corners_xy_m=SQUARE, speed_mps=0.2, duration_s=4.0, jitter_rms_m=0.0)
    v = TagMotion(tr, rng=np.random.default_rng(0)).max_radial_speed_mps(np.array([[0.0, 1.0]]))
    assert v == pytest.approx(0.2, rel=1e-9)


def test_antennas_face_the_room_centre():
    ants = reader_antennas(GeometryConfig())
    yaws = [a.orientation[0] for a in ants]
    assert np.allclose(yaws, [math.pi / 4, 3 * math.pi / 4, -3 * math.pi / 4, -math.pi / 4])
    assert all(a.position_m[2] == 1.5 for a in ants)


def test_one_carrier_rule_and_geometry_checks_name_the_key():
    assert carrier_hz(ReaderConfig(region="custom", channels_hz=(890e6,), hopping=False)) == 890e6
    with pytest.raises(ConfigError, match="reader.hopping"):
        carrier_hz(ReaderConfig(region="custom", channels_hz=(890e6, 900e6), hopping=True))
    with pytest.raises(ConfigError, match=r"geometry.antennas_xy_m\[1\]"):
        check_scene(GeometryConfig(antennas_xy_m=((0.0, 0.0), (4.0, 0.0), (3.0, 3.0))), TrajectoryConfig(),
                    read_period_s=2.5e-3)
    with pytest.raises(ConfigError, match="trajectory.duration_s"):
        check_scene(GeometryConfig(), TrajectoryConfig(duration_s=0.05), read_period_s=0.02)

"""rfsim.scenes.tag_listening: where the ST antennas go (disc, radial tracks, near field), the
null spacing along a track from the geometry alone, the minima of a sampled track — against
values derived by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.scenes import tag_listening as tl

LAMBDA_915_M = 299792458.0 / 915e6


def test_null_spacing_along_tracks_from_the_path_difference():
    # 0° (towards the reader): R̃ − r = x_tag − 2d turns by 2 m per metre → a null every λ/4;
    # 90°, tag at 2 m, 0.04–1 m: R̃ − r goes from hypot(2, 0.04) − 0.04 = 1.960400 to
    # hypot(2, 1) − 1 = 1.236068, so (0.96 m)·(0.163821 m)/0.724332 m = 0.217122 m; 180°: R̃ − r = 2 m, no nulls
    assert tl.geometric_null_spacing_m(0.0, 0.04, 1.0, 2.0, 915e6) == pytest.approx(LAMBDA_915_M / 4, rel=1e-9)
    dp = (math.hypot(2.0, 0.04) - 0.04) - (math.hypot(2.0, 1.0) - 1.0)
    assert dp == pytest.approx(0.724332, abs=1e-6)
    assert tl.geometric_null_spacing_m(90.0, 0.04, 1.0, 2.0, 915e6) == pytest.approx(0.217122, abs=1e-6)
    assert tl.geometric_null_spacing_m(180.0, 0.04, 1.0, 2.0, 915e6) == math.inf


def test_radial_track_points_and_near_field():
    tag = np.array([2.0, 0.0, 1.0])
    d = np.array([0.05, 0.5])
    pts = tl.radial_track_positions(tag, [0.0, 90.0], d)
    np.testing.assert_allclose(pts[0], [[1.95, 0.0, 1.0], [1.5, 0.0, 1.0]], atol=1e-15)  # towards the reader
    np.testing.assert_allclose(pts[1], [[2.0, -0.05, 1.0], [2.0, -0.5, 1.0]], atol=1e-15)
    # λ/2π = 0.052146 m at 915 MHz: 0.05 m is inside, 0.055 m outside
    near = tl.in_near_field(np.array([[[1.95, 0.0, 1.0]], [[1.945, 0.0, 1.0]]]), tag, 915e6)
    assert LAMBDA_915_M / (2 * math.pi) == pytest.approx(0.052146, abs=1e-6)
    np.testing.assert_array_equal(near, [True, False])


def test_sts_in_disc_stay_in_the_disc_with_their_pair_spacing():
    tag = np.array([3.0, 0.0, 1.0])
    centres, orient, sa_pos = tl.sts_in_disc(np.random.default_rng(4), tag, 500, radius_m=0.5, n_antennas=2,
                                             spacing_m=0.082)
    assert np.all(np.hypot(*(centres - tag)[:, :2].T) <= 0.5) and np.all(centres[:, 2] == 1.0)
    np.testing.assert_allclose(np.linalg.norm(sa_pos[:, 1] - sa_pos[:, 0], axis=-1), 0.082, rtol=1e-12)
    axis = sa_pos[:, 1] - sa_pos[:, 0]
    np.testing.assert_allclose(np.arctan2(axis[:, 1], axis[:, 0]), orient, atol=1e-12)
    # uniform in area: half the centres within r = 0.5/sqrt(2) (500 draws: ±3 sd = ±0.067)
    inner = np.mean(np.hypot(*(centres - tag)[:, :2].T) < 0.5 / math.sqrt(2))
    assert abs(inner - 0.5) < 0.067


def test_minima_spacing_of_a_sampled_track():
    d = np.linspace(0.0, 1.0, 101)
    y = np.abs(np.cos(2 * np.pi * d / 0.2))  # minima at 0.05, 0.15, ..., 0.95 m: spacing 0.1 m
    pos, spacing = tl.minima_spacing_m(d, y)
    np.testing.assert_allclose(pos, np.arange(0.05, 1.0, 0.1), atol=1e-12)
    assert spacing == pytest.approx(0.1, abs=1e-12)
    assert math.isnan(tl.minima_spacing_m(d, d)[1])


def test_pass_tag_pattern_is_kept_while_its_file_is_unchanged_and_read_again_when_changed(reference_data,
                                                                                         tmp_path):
    import os
    import shutil

    from rfsim.devices.pass_tag import PASS_TAG_ANTENNA_FILE
    from rfsim.scenes.tag_listening import pass_tag_pattern

    source = reference_data / "pass-characteristics" / PASS_TAG_ANTENNA_FILE
    if not source.is_file():
        pytest.skip(f"{source} not found")
    shutil.copyfile(source, tmp_path / PASS_TAG_ANTENNA_FILE)
    first = pass_tag_pattern(str(tmp_path))
    assert pass_tag_pattern(str(tmp_path)) is first  # unchanged file: the pattern read before
    st = (tmp_path / PASS_TAG_ANTENNA_FILE).stat()
    os.utime(tmp_path / PASS_TAG_ANTENNA_FILE, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    again = pass_tag_pattern(str(tmp_path))
    assert again is not first  # a changed file is read again
    for name in ("az_rad", "el_rad", "az_cut", "el_cut", "table"):  # the same file's contents
        a, b = getattr(again, name), getattr(first, name)
        assert (a is None and b is None) or np.array_equal(a, b), name

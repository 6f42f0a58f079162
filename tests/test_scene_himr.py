"""HIMR tags and pylons in scene files (issue 31 item 1): ``[[himr_tag]]``, ``[[pylon]]`` and
``[himr_radio]`` run the HIMR sample-level path of the ``himr-1d``/``himr-2d`` scenarios for a
deployment the user writes down; bad keys are one line naming the key."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from rfsim.cli import main

STATIC = """
[[himr_tag]]
name = "T"
packet_format = "9axis-2d"
  [himr_tag.trajectory]
  kind = "static"
  position_m = [1.5, 0.5, 0.0]

[[pylon]]
position_m = [0.0, 0.0, 0.0]

[[pylon]]
position_m = [3.0, 2.0, 0.0]

[himr_radio]
receiver_noise = false
rss_calibration = "link-budget"

[run]
duration_s = 0.03
"""


def _run(tmp_path: Path, text: str, *extra: str) -> Path:
    scene = tmp_path / "himr.toml"
    scene.write_text(text)
    out = tmp_path / "himr.h5"
    assert main(["run", str(scene), "--seed", "3", "--no-plot", "-q", "-o", str(out), *extra]) == 0
    return out


def _table(path: Path, name: str) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as f:
        return {k: v[()] for k, v in f[name].items()}


def test_a_static_tag_without_noise_measures_its_true_range_at_every_pylon(tmp_path):
    """Free space, no receiver noise, K_u from the link budget: the RSS range (eq. 22) of every
    packet is the geometric distance pylon → tag computed here from the scene's coordinates."""
    packets = _table(_run(tmp_path, STATIC), "himr_packets")
    truth = {1: math.dist((0, 0, 0), (1.5, 0.5, 0)), 2: math.dist((3, 2, 0), (1.5, 0.5, 0))}
    assert set(packets["pylon"]) == {1, 2} and packets["crc_ok"].all()
    for u, d in truth.items():
        m = packets["pylon"] == u
        np.testing.assert_allclose(packets["true_range_m"][m], d, rtol=1e-12)
        np.testing.assert_allclose(packets["range_rss_m"][m], d, rtol=0.01)
    # 0.03 s at 141 packets/s: packets start at 0, 7.09, 14.18, 21.28 and 28.37 ms
    assert sorted(set(packets["packet"])) == [0, 1, 2, 3, 4]


def test_each_himr_tag_has_its_own_random_streams(tmp_path):
    """A second tag added after the first leaves the first tag's measurements bit-identical
    (tag i draws from trial_rng(s, 7, i, ...))."""
    noisy = STATIC.replace("receiver_noise = false", "receiver_noise = true")
    one = _table(_run(tmp_path, noisy), "himr_packets")
    second = noisy.replace("[[pylon]]", """[[himr_tag]]
name = "U"
  [himr_tag.trajectory]
  kind = "linear"
  start_m = [1.0, 1.5, 0.0]
  t_start_s = 0.005

[[pylon]]""", 1)
    two = _table(_run(tmp_path, second), "himr_packets")
    first = two["himr_tag"] == 0
    for k in ("h_re", "h_im", "t_s", "range_rss_m"):
        np.testing.assert_array_equal(two[k][first], one[k], err_msg=k)
    assert (two["himr_tag"] == 1).any()


@pytest.mark.parametrize("change, key", [
    (("kind = \"static\"", "kind = \"circle\""), "'himr_tag[0].trajectory.kind'"),
    (("packet_format = \"9axis-2d\"", "packet_format = \"12axis\""), "'himr_tag[0].packet_format'"),
    (("position_m = [0.0, 0.0, 0.0]", "position_m = [1.5, 0.5, 0.0]"), "'pylon[0].position_m'"),
    (("receiver_noise = false", "fs_hz = 1e6"), "'himr_radio.fs_hz'"),
    (("[himr_radio]", "[himr_radio]\nsnr = 3"), "'himr_radio.snr'"),
    (("duration_s = 0.03", "duration_s = 0.005"), "'run.duration_s'"),
])
def test_bad_himr_keys_exit_2_with_one_line_naming_the_key(tmp_path, capsys, change, key):
    text = STATIC.replace(*change)
    assert text != STATIC
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    assert main(["run", str(scene), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and key in err, err
    assert not (tmp_path / "x.h5").exists()


def test_tags_without_pylons_and_pylons_without_tags_are_refused(tmp_path, capsys):
    for text, key in ((STATIC.split("[[pylon]]")[0], "'pylon'"),
                      ("[[pylon]]\nposition_m = [0.0, 0.0, 1.0]\n", "'himr_tag'")):
        scene = tmp_path / "bad.toml"
        scene.write_text(text)
        assert main(["run", str(scene), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and key in err, err


def test_rfsim_plot_draws_a_scene_dataset(tmp_path, capsys):
    """`rfsim plot` on a dataset a scene file wrote (its scenario is named after the file, not a
    registered scenario) draws the scene figures."""
    out = _run(tmp_path, STATIC)
    assert main(["plot", str(out), "--out-dir", str(tmp_path)]) == 0
    for what in ("geometry", "himr-ranges"):
        assert (tmp_path / f"himr-{what}.png").is_file()

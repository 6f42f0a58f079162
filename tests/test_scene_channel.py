"""The channel of a scene file beyond walls and floor (issue 31 item 1): reflecting surfaces
(``[[channel.surface]]``) and spatially correlated log-normal shadowing
(``channel.shadowing_sigma_db``), each checked against geometry worked out here."""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from rfsim.channels.antennas import Antenna
from rfsim.channels.scene import Channel
from rfsim.cli import main
from rfsim.scenes.scene_file import channel_scene, parse_scene, scene_config

C_M_S = 299_792_458.0
SCENE = """
[[reader]]
  [[reader.antenna]]
  position_m = [0.0, 0.0, 1.0]
  pattern = "isotropic"
  gain_dbi = 6.0

[[tag]]
position_m = [3.0, 0.0, 1.0]
pattern = "isotropic"

[run]
max_rounds = 4
"""
CEILING = """
[[channel.surface]]
point_m = [0.0, 0.0, 3.0]
normal = [0.0, 0.0, 1.0]
eps_r = 1e6
"""


def _spec(tmp_path: Path, text: str):
    path = tmp_path / "s.toml"
    path.write_text(text)
    return parse_scene(json.loads(scene_config(path).scene_json))


def _reads(tmp_path: Path, text: str, seed: int = 1) -> dict[str, np.ndarray]:
    path = tmp_path / "s.toml"
    path.write_text(text)
    out = tmp_path / f"s{seed}.h5"
    assert main(["run", str(path), "--seed", str(seed), "--no-plot", "-q", "-o", str(out)]) == 0
    with h5py.File(out, "r") as f:
        return {k: v[()] for k, v in f["reads"].items()}


def test_a_ceiling_adds_its_image_path_with_the_delay_of_the_geometry(tmp_path):
    """Reader at (0, 0, 1) m, tag at (3, 0, 1) m, ceiling z = 3 m: the image of the tag in the
    ceiling is at (3, 0, 5) m, so the reflected path is √(3² + 4²) = 5 m long (delay 5 m / c),
    beside the 3 m line of sight."""
    spec = _spec(tmp_path, SCENE + "[channel]\n" + CEILING)
    paths = Channel(channel_scene(spec, seed=1)).link(Antenna((0.0, 0.0, 1.0)), Antenna((3.0, 0.0, 1.0)),
                                                     fc_hz=915e6)
    np.testing.assert_allclose(np.sort(paths.delay_s), np.array([3.0, 5.0]) / C_M_S, rtol=1e-12)
    los, image = np.argsort(paths.delay_s)
    # a near-perfect conductor at grazing-free incidence reflects almost all: |Γ| ≈ 1, so the
    # amplitude ratio is the spreading ratio 3/5
    assert abs(paths.gain[image]) / abs(paths.gain[los]) == pytest.approx(3 / 5, rel=0.02)
    no_ceiling = Channel(channel_scene(_spec(tmp_path, SCENE), seed=1)).link(
        Antenna((0.0, 0.0, 1.0)), Antenna((3.0, 0.0, 1.0)), fc_hz=915e6)
    assert no_ceiling.delay_s.size == 1


def test_a_finite_surface_reflects_only_where_its_rectangle_is_hit(tmp_path):
    """A 1 m × 1 m metal plate in the ceiling plane: centred above the midpoint it holds the
    specular point (1.5, 0, 3) m; moved 3 m aside it does not."""
    ends = (Antenna((0.0, 0.0, 1.0)), Antenna((3.0, 0.0, 1.0)))
    for centre_y, n_paths in ((0.0, 2), (3.0, 1)):
        plate = CEILING.replace("[0.0, 0.0, 3.0]", f"[1.5, {centre_y}, 3.0]") + "half_size_m = [0.5, 0.5]\n"
        spec = _spec(tmp_path, SCENE + "[channel]\n" + plate)
        assert Channel(channel_scene(spec, seed=1)).link(*ends, fc_hz=915e6).delay_s.size == n_paths


def test_shadowing_moves_the_rssi_by_one_field_per_run_and_none_at_zero(tmp_path):
    """σ = 0 dB leaves the reads as without the keys; σ = 4 dB shifts every read of a static
    link by the same field value (one quasi-static realisation per run, from the run's seed),
    and another seed draws another field."""
    near = SCENE.replace("[3.0, 0.0, 1.0]", "[1.5, 0.0, 1.0]")
    base = _reads(tmp_path, near)
    zero = _reads(tmp_path, near + "[channel]\nshadowing_sigma_db = 0.0\n")
    np.testing.assert_array_equal(base["peak_rssi_dbm"], zero["peak_rssi_dbm"])
    shadowed = near + "[channel]\nshadowing_sigma_db = 4.0\nshadowing_decorrelation_m = 2.0\n"
    a, b = _reads(tmp_path, shadowed, seed=1), _reads(tmp_path, shadowed, seed=2)
    shift_a = a["true_incident_power_dbm"] - base["true_incident_power_dbm"]
    assert len(base["time_s"]) == len(a["time_s"]) >= 1
    assert np.ptp(shift_a) < 1e-6 and abs(shift_a[0]) > 1e-3  # one field value, on every read
    again = _reads(tmp_path, shadowed, seed=1)
    np.testing.assert_array_equal(a["true_incident_power_dbm"], again["true_incident_power_dbm"])
    assert not math.isclose(a["true_incident_power_dbm"][0], b["true_incident_power_dbm"][0], abs_tol=1e-6)


@pytest.mark.parametrize("text, key", [
    ("[channel]\n[[channel.surface]]\nnormal = [0.0, 0.0, 0.0]\n", "'channel.surface[0].normal'"),
    ("[channel]\n[[channel.surface]]\nhalf_size_m = [1.0, 0.0]\n", "'channel.surface[0].half_size_m'"),
    ("[channel]\n[[channel.surface]]\neps = 3\n", "'channel.surface[0].eps'"),
    ("[channel]\nshadowing_sigma_db = -2\n", "'channel.shadowing_sigma_db'"),
])
def test_bad_channel_keys_exit_2_naming_the_key(tmp_path, capsys, text, key):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE + text)
    assert main(["run", str(path), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and key in err, err

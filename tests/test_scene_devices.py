"""Scene files with devices on their own schedules (exciters, sense-a-tags, active beacons) and
the docs' ``link`` scenario written as a scene file."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from rfsim.cli import main
from rfsim.scenarios import link
from rfsim.scenes.scene_file import parse_scene, read_scene

ROOT = Path(__file__).resolve().parents[1]
LINK_SCENE = ROOT / "docs" / "tutorials" / "link-scene.toml"
C_M_S = 299_792_458.0


def _read(path: Path, table: str) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as f:
        return {k: v[()] for k, v in f[table].items()}


def _friis_dbm(p_dbm: float, gains_dbi: float, d_m: float, fc_hz: float) -> float:
    """Free-space received power: P + G − 20·log10(4π·d/λ) [dBm]."""
    return p_dbm + gains_dbi - 20.0 * math.log10(4.0 * math.pi * d_m * fc_hz / C_M_S)


DEVICES = """
[[exciter]]
position_m = [0.0, 0.0, 1.0]
pattern = "patch"
gain_dbi = 6.0
eirp_dbm = 35.0
fc_hz = 915e6
schedule_s = [0.0, 0.15]

[[sense_a_tag]]
name = "talker"
position_m = [1.0, 0.0, 1.0]
period_s = 0.1

[[sense_a_tag]]
name = "ear"
position_m = [1.2, -0.3, 1.0]

[[beacon]]
tag_id = 7
position_m = [4.0, 1.0, 1.2]
period_s = 0.1
jitter_s = 0.0
offset_s = 0.02

[[beacon_reader]]
position_m = [5.0, 0.0, 1.2]

[run]
duration_s = 0.2
"""


def test_exciter_schedule_sense_a_tags_and_beacons_in_free_space(tmp_path):
    scene = tmp_path / "devices.toml"
    scene.write_text(DEVICES)
    out = tmp_path / "devices.h5"
    assert main(["run", str(scene), "--seed", "3", "--no-plot", "-q", "-o", str(out)]) == 0
    det = _read(out, "detections")
    # the talker broadcasts at 0 and 0.1 s (CW on) and the ear listens; no row for the talker hearing itself
    np.testing.assert_array_equal(det["time_s"], [0.0, 0.1])
    np.testing.assert_array_equal(det["broadcaster"], [0, 0])
    np.testing.assert_array_equal(det["listener"], [1, 1])
    np.testing.assert_allclose(det["distance_m"], math.hypot(0.2, 0.3), rtol=1e-12)
    # incident CW at the talker: 35 dBm EIRP on the boresight, 1 m, vertical half-wave dipole (2.15 dBi)
    np.testing.assert_allclose(det["tag_incident_power_dbm"], _friis_dbm(35.0, 2.15, 1.0, 915e6), atol=0.05)
    assert det["broadcaster_replied"].all()
    bf = _read(out, "beacon_frames")
    # one burst per period at offset 0.02 s (no jitter), heard by the one reader
    np.testing.assert_allclose(bf["time_s"], [0.02, 0.12], atol=1e-9)
    assert bf["decoded"].all() and bf["tag_id"].tolist() == [7, 7] and bf["seq"].tolist() == [0, 1]
    d = math.dist((4.0, 1.0, 1.2), (5.0, 0.0, 1.2))
    np.testing.assert_allclose(bf["distance_m"], d, rtol=1e-12)
    # the reader's RSSI: 5 dBm from isotropic antennas at 868 MHz, free space (receiver noise: ±0.5 dB)
    np.testing.assert_allclose(bf["rssi_dbm"], _friis_dbm(5.0, 0.0, d, 868e6), atol=0.5)
    assert _read(out, "exciters")["x_m"].tolist() == [0.0]
    assert _read(out, "sense_a_tags")["name"].astype(str).tolist() == ["talker", "ear"]


def test_no_cw_no_broadcast(tmp_path):
    """The exciter's schedule switches it off at 0.15 s: a broadcast at 0.2 s finds no CW."""
    scene = tmp_path / "off.toml"
    scene.write_text(DEVICES.replace("duration_s = 0.2", "duration_s = 0.25")
                     .replace("period_s = 0.1\n\n[[sense_a_tag]]", "period_s = 0.2\n\n[[sense_a_tag]]"))
    out = tmp_path / "off.h5"
    assert main(["run", str(scene), "--no-plot", "-q", "-o", str(out)]) == 0
    det = _read(out, "detections")
    np.testing.assert_array_equal(det["time_s"], [0.0, 0.2])
    assert det["broadcaster_replied"].tolist() == [True, False] and not det["decoded"][1]
    assert det["tag_incident_power_dbm"][1] == -np.inf


def _bad(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("edit, key", [
    (("eirp_dbm = 35.0", "eirp_dbm = 99.0"), "'exciter[0].eirp_dbm'"),
    (("gain_dbi = 6.0", "gian_dbi = 6.0"), "'exciter[0].gian_dbi'"),
    (("period_s = 0.1\n\n[[sense_a_tag]]", "period_s = -0.1\n\n[[sense_a_tag]]"), "'sense_a_tag[0].period_s'"),
    (('name = "ear"', 'name = "talker"'), "'sense_a_tag.name'"),
    (("tag_id = 7", "tag_id = -7"), "'beacon[0].tag_id'"),
    (("offset_s = 0.02", "offset_s = \"soon\""), "'beacon[0].offset_s'"),
    (("[[beacon_reader]]\nposition_m = [5.0, 0.0, 1.2]", ""), "'beacon_reader'"),
    (("[[beacon_reader]]\n", "[[beacon_reader]]\nfs_hz = 1.1e6\n"), "'beacon_reader[0].fs_hz'"),
    (("[[exciter]]\nposition_m = [0.0, 0.0, 1.0]", "[[nothing]]\nposition_m = [0.0, 0.0, 1.0]"), "'nothing'"),
    (("[run]", "[frame]\nblf_hz = 1.0\n[run]"), "'frame.blf_hz'"),
    (("[run]", "[frame]\nnoise_nf_db = -3.0\n[run]"), "'frame.noise_nf_db'"),
    (("[run]", "[frame]\nnoise_level = 1.0\n[run]"), "'frame.noise_level'"),
])
def test_bad_device_keys_exit_2_with_one_line_naming_the_key(tmp_path, capsys, edit, key):
    old, new = edit
    assert old in DEVICES
    path = _bad(tmp_path, DEVICES.replace(old, new, 1))
    assert main(["run", str(path), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and key in err, err
    assert not (tmp_path / "x.h5").exists()


def test_a_broadcasting_sense_a_tag_needs_an_exciter(tmp_path, capsys):
    text = DEVICES.split("[[sense_a_tag]]", 1)[1]
    path = _bad(tmp_path, "[[sense_a_tag]]" + text)
    assert main(["run", str(path), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'exciter'" in err, err


def test_the_link_scene_of_the_docs_is_links_deployment_with_links_defaults():
    spec = parse_scene(read_scene(LINK_SCENE))
    cfg = link.Config()
    assert spec.readers[0].config == cfg.reader
    assert spec.tags[0].config == cfg.tag
    ant = spec.readers[0].antennas[0]
    g = cfg.geometry
    assert (ant.pattern, ant.gain_dbi, ant.beamwidth_deg, ant.polarization) == (
        g.reader_antenna, g.reader_gain_dbi, g.reader_beamwidth_deg, g.reader_polarization)
    assert ant.position_m == (0.0, 0.0, g.height_m) and spec.tags[0].antenna.position_m[0] in g.distances_m
    assert (spec.channel.floor, spec.channel.apdp, spec.channel.floor_eps_r) == (
        cfg.channel.floor, cfg.channel.apdp, cfg.channel.floor_eps_r)
    assert spec.inventory.max_rounds == cfg.rounds_per_point


def test_the_link_scene_of_the_docs_runs(tmp_path):
    out = tmp_path / "link-scene.h5"
    assert main(["run", str(LINK_SCENE), "--set", "run.max_rounds=3", "--seed", "1", "--out-dir", str(tmp_path),
                 "-q", "-o", str(out)]) == 0
    reads = _read(out, "reads")
    assert reads["round"].tolist() == [0, 1, 2]
    np.testing.assert_array_equal(reads["true_distance_m"], 2.0)
    assert (tmp_path / "link-scene-geometry.png").is_file()
    doc = (ROOT / "docs" / "tutorials" / "own-scene.md").read_text()
    assert "```{literalinclude} link-scene.toml" in doc


def test_gen2_readers_and_beacons_in_one_scene(tmp_path):
    """A scene with a Gen2 reader and beacons runs both: reads and beacon frames."""
    base = (ROOT / "examples" / "scenes" / "one-reader-one-tag.toml").read_text()
    scene = tmp_path / "both.toml"
    scene.write_text(base.replace("max_rounds = 20", "max_rounds = 2")
                     + "\n[[beacon]]\nposition_m = [0.0, 3.0, 1.0]\nperiod_s = 0.05\n"
                     + "\n[[beacon_reader]]\nposition_m = [0.0, 5.0, 1.0]\n")
    out = tmp_path / "both.h5"
    assert main(["run", str(scene), "--no-plot", "-q", "-o", str(out)]) == 0
    assert len(_read(out, "reads")["time_s"]) == 2
    bf = _read(out, "beacon_frames")
    assert len(bf["time_s"]) == 1 and bf["decoded"].all() and bf["tag_id"].tolist() == [1]

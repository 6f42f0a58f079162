"""Scene files (issue 31 item 1): ``rfsim run my-scene.toml`` runs a Gen2 deployment the user
describes in TOML (readers with antenna ports, tags, channel, inventory); every key is
validated with a one-line error naming it (exit 2); the examples in ``examples/scenes`` run."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

import rfsim
from rfsim.channels.antennas import Antenna, HalfWaveDipole, Patch
from rfsim.channels.scene import Channel, Scene
from rfsim.cli import main
from rfsim.core.rng import trial_rng
from rfsim.devices.reader import Reader
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.tag import PassiveTag
from rfsim.devices.tag_config import TagConfig
from rfsim.protocols.inventory import EngineAir, InventoryConfig, run_inventory
from rfsim.runs import registry
from rfsim.scenes.scene_file import scene_config

SCENES = Path(__file__).resolve().parents[1] / "examples" / "scenes"
EXAMPLES = sorted(SCENES.glob("*.toml"))
#: --set overrides that keep each example small
SMALL = {
    "one-reader-one-tag": ["--set", "run.max_rounds=3"],
    "shelf": ["--set", "run.max_rounds=2", "--set", "tag.0.count=6"],
    "trolley-portal": ["--set", "run.duration_s=0.02", "--set", "tag.0.position_m=[-0.2, 0.0, 0.9]"],
    "exciter-sense-a-tags": ["--set", "run.duration_s=0.12", "--set", "beacon.0.period_s=0.06",
                             "--set", "beacon.1.period_s=0.06"],
    "himr-pylons": ["--set", "run.duration_s=0.05"],
}


def _read(path: Path, table: str) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as f:
        return {k: v[()] for k, v in f[table].items()}


def test_there_are_five_examples_and_a_readme_naming_every_key():
    assert [p.stem for p in EXAMPLES] == sorted(SMALL)
    readme = (SCENES / "README.md").read_text()
    for key in ("position_m", "orientation_deg", "pattern", "gain_dbi", "beamwidth_deg", "velocity_m_s", "count",
                "step_m", "large_scale", "path_loss_exponent", "floor", "apdp", "attenuation_db", "duration_s",
                "session", "q_initial", "link_profile", "ptx_dbm", "sensitivity_dbm", "eirp_dbm", "schedule_s",
                "period_s", "offset_s", "word", "threshold_v", "blf_hz", "tag_id", "tx_power_dbm", "jitter_s",
                "lbt_listen_s", "noise_figure_db", "[[himr_tag]]", "[[pylon]]", "[himr_radio]", "packet_format", "kind",
                "heading_deg", "fc_hz", "snr_db", "fs_hz", "shadowing_sigma_db", "shadowing_decorrelation_m",
                "[[channel.surface]]", "point_m", "normal", "eps_r", "half_size_m"):
        assert f"`{key}`" in readme, key


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.stem)
def test_each_example_runs_through_rfsim_run(example, tmp_path, capsys):
    out = tmp_path / f"{example.stem}.h5"
    assert main(["run", str(example), *SMALL[example.stem], "--seed", "2", "-q", "--out-dir", str(tmp_path),
                 "-o", str(out)]) == 0
    reads, tags, ports = _read(out, "reads"), _read(out, "tags"), _read(out, "readers")
    with h5py.File(out, "r") as f:
        himr = "himr_packets" in f
    if himr:  # HIMR tags and pylons only: packets decoded by the pylons instead of reads
        packets = _read(out, "himr_packets")
        assert packets["crc_ok"].any() and set(packets["himr_tag"]) == set(range(len(_read(out, "himr_tags")["name"])))
        assert (tmp_path / f"{example.stem}-himr-ranges.png").is_file()
    elif len(ports["x_m"]) == 0:  # schedule-driven devices only: detections and beacon frames instead of reads
        assert _read(out, "detections")["decoded"].any() and _read(out, "beacon_frames")["decoded"].any()
        assert (tmp_path / f"{example.stem}-detections.png").is_file()
    else:
        assert len(reads["time_s"]) > 0
    assert np.all(np.diff(reads["time_s"][reads["reader"] == 0]) > 0)
    phase = reads["phase_angle_rad"]
    assert np.all(np.isfinite(reads["peak_rssi_dbm"])) and np.all((phase >= 0) & (phase < 2 * np.pi))
    # the EPC read is the EPC of the tag the row names
    epcs = tags["epc_hex"].astype(str)
    assert [e.decode() if isinstance(e, bytes) else e for e in reads["epc"]] == [epcs[t] for t in reads["tag"]]
    assert set(reads["antenna_port"]) <= set(ports["antenna"])
    for what in ("geometry", "reads", "rssi-phase"):
        assert (tmp_path / f"{example.stem}-{what}.png").is_file()


def test_the_shelf_uses_both_readers_and_both_ports_and_reads_every_tag(tmp_path):
    out = tmp_path / "shelf.h5"
    assert main(["run", str(SCENES / "shelf.toml"), *SMALL["shelf"], "--no-plot", "-q", "-o", str(out)]) == 0
    reads, slots = _read(out, "reads"), _read(out, "slots")
    assert set(slots["reader"]) == {0, 1} and set(slots["antenna"]) == {1, 2}
    assert set(reads["tag"]) == set(range(6))
    walls = _read(out, "walls")
    assert walls["start_x_m"].tolist() == [2.5] and walls["end_y_m"].tolist() == [3.0]
    assert walls["attenuation_db"].tolist() == [3.0]
    # true distance from the reading port to the tag, recomputed from the file's geometry
    tags, ports = _read(out, "tags"), _read(out, "readers")
    k = 0
    port = np.flatnonzero((ports["reader"] == reads["reader"][k]) & (ports["antenna"] == reads["antenna_port"][k]))[0]
    t = reads["tag"][k]
    d = math.dist((ports["x_m"][port], ports["y_m"][port], ports["z_m"][port]),
                  (tags["x_m"][t], tags["y_m"][t], tags["z_m"][t]))
    assert reads["true_distance_m"][k] == pytest.approx(d, rel=1e-12)


def test_the_trolley_tag_moves_with_its_velocity(tmp_path):
    out = tmp_path / "t.h5"
    assert main(["run", str(SCENES / "trolley-portal.toml"), *SMALL["trolley-portal"], "--no-plot", "-q",
                 "-o", str(out)]) == 0
    reads = _read(out, "reads")
    moving = reads["tag"] == 0
    assert moving.any()
    # tag 0 starts at (-0.2, 0, 0.9) moving at 3 m/s along x; port 1 at (0, -1, 1)
    t = reads["time_s"][moving]
    port = np.where(reads["antenna_port"][moving] == 1, -1.0, 1.0)
    expect = np.sqrt((-0.2 + 3.0 * t) ** 2 + port ** 2 + 0.1 ** 2)
    np.testing.assert_allclose(reads["true_distance_m"][moving], expect, rtol=1e-12)
    assert np.all(np.abs(reads["doppler_frequency_hz"][moving]) < 50.0)  # 3 m/s at 928 MHz: |2v/λ| ≤ 18.6 Hz, plus noise


def test_one_reader_one_tag_equals_the_same_deployment_built_in_python(tmp_path):
    seed = 5
    out = tmp_path / "x.h5"
    assert main(["run", str(SCENES / "one-reader-one-tag.toml"), "--set", "run.max_rounds=4", "--seed", str(seed),
                 "--no-plot", "-q", "-o", str(out)]) == 0
    reads = _read(out, "reads")
    # the same deployment written directly against the library (streams as documented)
    reader = Reader(ReaderConfig(link_profile="miller4-320k", ptx_dbm=30.0, region="FCC", hopping=True),
                    [Antenna(position_m=(0.0, 0.0, 1.0), orientation=(0.0, 0.0, 0.0), pattern=Patch(6.0, 70.0),
                             polarization="circular")], rng=trial_rng(seed, 1, 0))
    tag = PassiveTag(TagConfig(epc_hex="300833B2DDD9014000000027", sensitivity_dbm=-18.0),
                     Antenna(position_m=(2.0, 0.0, 1.0), orientation=(math.pi, 0.0, 0.0), pattern=HalfWaveDipole(),
                             polarization="linear"), rng=trial_rng(seed, 3, 0))
    air = EngineAir(reader, [tag], Channel(Scene()), rng=trial_rng(seed, 2, 0))
    log = run_inventory(air, InventoryConfig(session=0, q_mode="fixed", q_initial=0.0, max_rounds=4,
                                             select_before_round=True))
    assert len(log.reads["time_s"]) == 4
    for k, schema in (("time_s", "time_s"), ("rssi_dbm", "peak_rssi_dbm"), ("phase_rad", "phase_angle_rad"),
                      ("doppler_hz", "doppler_frequency_hz"), ("frequency_hz", "frequency_hz"),
                      ("channel_index", "channel_index"), ("antenna", "antenna_port")):
        np.testing.assert_array_equal(reads[schema], np.asarray(log.reads[k]), err_msg=k)
    np.testing.assert_array_equal(reads["true_distance_m"], 2.0)


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad-scene.toml"
    base = (SCENES / "one-reader-one-tag.toml").read_text()
    path.write_text(base + text if not text.startswith("!") else text[1:])
    return path


@pytest.mark.parametrize("text, key", [
    ("[[himr]]\nposition_m = [0, 0, 0]\n", "'himr'"),
    ("[[reader]]\nname = \"R2\"\nptx_dbm = 50.0\n[[reader.antenna]]\n", "'reader[1].ptx_dbm'"),
    ("[[reader]]\nname = \"R2\"\n[[reader.antenna]]\nposition_m = [0, 1]\n", "'reader[1].antenna[0].position_m'"),
    ("[[reader]]\nname = \"R2\"\n[[reader.antenna]]\npatern = \"patch\"\n", "'reader[1].antenna[0].patern'"),
    ("[[reader]]\nname = \"R2\"\n", "'reader[1].antenna'"),
    ("[[tag]]\nsensitivity_dbm = \"low\"\n", "'tag[1].sensitivity_dbm'"),
    ("[[tag]]\nvelocity = [1, 0, 0]\n", "'tag[1].velocity'"),
    ("[[tag]]\nepc_hex = \"300833B2DDD9014000000027\"\n", "'tag.epc_hex'"),
    ("[[channel.wall]]\nstart_m = [0, 0]\nend_m = [1, 0]\nattenuation_db = -3\n", "'channel.wall[0].attenuation_db'"),
    ("!" + "[[reader]]\n[[reader.antenna]]\n[[tag]]\n[channel]\nlarge_scale = \"hata\"\n", "'channel.large_scale'"),
    ("!" + "[[reader]]\nregion = \"ETSI\"\nfixed_channel = 9\nhopping = false\n[[reader.antenna]]\n[[tag]]\n",
     "'reader[0].fixed_channel'"),
    ("!" + "[[reader]]\n[[reader.antenna]]\n[[tag]]\n[run]\nsession = 4\n", "'run.session'"),
    ("!" + "[[reader]]\n[[reader.antenna]]\n[[tag]]\n[run]\nduration_s = -1\n", "'run.duration_s'"),
    ("!" + "[[reader]]\n[[reader.antenna]]\n", "'tag'"),
])
def test_bad_keys_and_values_exit_2_with_one_line_naming_the_key(tmp_path, capsys, text, key):
    path = _write(tmp_path, text)
    assert main(["run", str(path), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and key in err, err
    assert not (tmp_path / "x.h5").exists()


def test_a_config_toml_is_not_a_scene_and_a_scene_takes_no_config_file(tmp_path, capsys):
    cfg = tmp_path / "cfg.toml"
    cfg.write_text("[reader]\nptx_dbm = 20.0\n")
    assert main(["run", str(cfg), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
    assert "not a scene file" in capsys.readouterr().err
    assert main(["run", str(SCENES / "shelf.toml"), "-c", str(cfg), "--no-plot", "-o", str(tmp_path / "x.h5")]) == 2
    assert "its own config" in capsys.readouterr().err
    assert main(["run", str(tmp_path / "missing.toml"), "--no-plot"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_the_scenario_is_named_after_the_file_and_config_prints_it(capsys):
    module = registry.get_scenario(str(SCENES / "shelf.toml"))
    assert module.NAME == "shelf" and "shelf of 20 tags" in module.DESCRIPTION
    assert main(["config", str(SCENES / "shelf.toml"), "--set", "run.session=2"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("scene_json = ") and '\\"session\\": 2' in out


def test_the_link_scene_of_the_readme_runs(tmp_path):
    readme = (SCENES / "README.md").read_text()
    block = readme.split("```toml\n", 1)[1].split("```", 1)[0]
    assert "[[reader]]" in block
    path = tmp_path / "link-2m.toml"
    path.write_text(block)
    out = tmp_path / "link-2m.h5"
    assert main(["run", str(path), "--set", "run.max_rounds=2", "--no-plot", "-q", "-o", str(out)]) == 0
    reads = _read(out, "reads")
    assert reads["round"].tolist() == [0, 1] and np.all(reads["true_distance_m"] == 2.0)


def test_rfsim_run_in_python_gives_the_reads_of_the_command_line(tmp_path):
    path = SCENES / "one-reader-one-tag.toml"
    out = tmp_path / "x.h5"
    assert main(["run", str(path), "--set", "run.max_rounds=2", "--seed", "7", "--no-plot", "-q", "-o", str(out)]) == 0
    result = rfsim.run(str(path), seed=7, config=scene_config(path, ["run.max_rounds=2"]), progress=False)
    np.testing.assert_array_equal(result.table("reads")["peak_rssi_dbm"].to_numpy(), _read(out, "reads")["peak_rssi_dbm"])


def test_rfsim_run_takes_a_scene_file_with_overrides_and_no_config():
    """``rfsim.run("scene.toml", **overrides)`` reads the scene as its own config; the overrides
    are the command line's ``--set`` keys; a bad one is a one-line ConfigError naming it."""
    path = SCENES / "one-reader-one-tag.toml"
    a = rfsim.run(str(path), seed=7, progress=False, **{"run.max_rounds": 2})
    b = rfsim.run(str(path), seed=7, config=scene_config(path, ["run.max_rounds=2"]), progress=False)
    for name in ("time_s", "peak_rssi_dbm", "phase_angle_rad"):
        np.testing.assert_array_equal(a.dataset.tables["reads"][name].data, b.dataset.tables["reads"][name].data)
    with pytest.raises(rfsim.core.errors.UserError, match="reader"):
        rfsim.run(str(path), progress=False, **{"reader.0.ptx": 20})

"""rfsim.Simulation, the scripting facade: the README's example runs as printed, and what it
returns obeys the physics (free-space monostatic backscatter) and the engine's own records."""

from __future__ import annotations

import contextlib
import io
import math
import re

import numpy as np
import pytest

from rfsim.channels import Antenna, Channel, Isotropic, Scene
from rfsim.devices import PassiveTag, Reader, ReaderConfig, TagConfig
from rfsim import Simulation
from rfsim.core.dataset import read_table
from rfsim.core.rng import trial_rng
from rfsim.core.units import C_M_S


def readme_example(project_root) -> str:
    text = (project_root / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- api-example:begin -->\s*```python\n(.*?)```\s*<!-- api-example:end -->", text, re.S)
    assert block, "README has no api-example block"
    return block.group(1)


def test_the_readme_example_runs_and_prints_rssi_and_phase(project_root):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(readme_example(project_root), "README.md", "exec"), {"__name__": "readme"})
    lines = out.getvalue().splitlines()
    assert [line.split()[:2] for line in lines] == [["Query", "ok"], ["ACK", "ok"]]
    for line in lines:
        rssi = float(re.search(r"RSSI\s+(-?[\d.]+) dBm", line).group(1))
        phase = float(re.search(r"phase (-?[\d.]+) rad", line).group(1))
        # a tag 3 m from a 30 dBm / 6 dBi reader: between the free-space bounds of -30 and -60 dBm
        assert -60.0 < rssi < -30.0 and 0.0 <= phase < 2 * math.pi


def _sim(distance_m: float, *, seed: int = 3) -> Simulation:
    reader = Reader(ReaderConfig(hopping=False, noise_figure_db=0.0),
                    [Antenna(position_m=(0.0, 0.0, 1.0), pattern=Isotropic())], rng=trial_rng(seed, 0))
    tag = PassiveTag(TagConfig(), Antenna(position_m=(distance_m, 0.0, 1.0), orientation=(math.pi, 0.0, 0.0),
                                          pattern=Isotropic()), rng=trial_rng(seed, 1))
    return Simulation(reader, [tag], Channel(Scene(image_order=0)), seed=seed)


def test_free_space_backscatter_falls_40_db_per_decade_and_turns_the_phase_by_4_pi_d_over_lambda():
    """Independent check (radar equation, monostatic): P_rx ∝ d⁻⁴, so doubling d costs
    40·log10(2) = 12.04 dB; the round-trip phase 4π·fc·d/c grows with d (mod 2π)."""
    near, far = _sim(1.5), _sim(3.0)
    a, b = near.query_round()[-1], far.query_round()[-1]
    assert a.command == b.command == "ACK" and not a.failure_reason and not b.failure_reason
    assert a.read.rssi_dbm - b.read.rssi_dbm == pytest.approx(40.0 * math.log10(2.0), abs=0.1)
    assert a.fc_hz == b.fc_hz
    expected = (4 * math.pi * a.fc_hz * (3.0 - 1.5) / C_M_S) % (2 * math.pi)
    turned = (b.read.phase_rad - a.read.phase_rad) % (2 * math.pi)
    assert min(abs(turned - expected), 2 * math.pi - abs(turned - expected)) < 0.05


def test_records_table_dataset_and_file_are_the_engine_records(tmp_path):
    sim = _sim(2.0)
    sim.query_round()
    sim.query_round(q=3, ack=False)  # Q = 3: the tag picks a slot, most likely not 0 -> no reply or RN16 only
    table = sim.table()
    assert list(table["round"]) == [0, 0, 1] and list(table["command"]) == ["Query", "ACK", "Query"]
    for row, ex in enumerate(sim.records):
        assert table["failure_reason"][row] == ex.failure_reason
        assert table["time_s"][row] == ex.time_s
        if not ex.failure_reason:
            assert table["rssi_dbm"][row] == ex.read.rssi_dbm
        else:
            assert np.isnan(table["rssi_dbm"][row])
    assert sim.records[2].time_s >= sim.round_period_s  # round 1 starts one period later
    path = sim.save(tmp_path / "script.h5")
    back = read_table(path, "exchanges")
    assert set(back) == set(table)
    for k in table:
        np.testing.assert_array_equal(back[k], table[k])


def test_same_seed_same_bits_other_seed_other_noise():
    one, two, other = _sim(2.0, seed=5), _sim(2.0, seed=5), _sim(2.0, seed=6)
    for s in (one, two, other):
        s.query_round()
    assert one.table()["snr_db"][0] == two.table()["snr_db"][0]
    assert one.table()["snr_db"][0] != other.table()["snr_db"][0]


def test_bad_round_period_is_refused():
    with pytest.raises(ValueError, match="round_period_s"):
        Simulation(None, [], None, round_period_s=0.0)


def test_the_readme_exciter_example_runs_and_the_listener_decodes_the_frame(project_root):
    """The README's exciter + sense-a-tag block: the passive tag (no reader, so no command)
    stays silent, the listening sense-a-tag decodes exactly the 16 bits the sender was given."""
    text = (project_root / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- exciter-example:begin -->\s*```python\n(.*?)```\s*<!-- exciter-example:end -->",
                      text, re.S)
    assert block, "README has no exciter-example block"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(block.group(1), "README.md", "exec"), {"__name__": "readme"})
    lines = out.getvalue().splitlines()
    assert lines[0] == "passive tag replied: False"
    decoded, sent = re.fullmatch(r"listener decoded: ([01]{16}) sent: ([01]{16})", lines[1]).groups()
    assert sent == "1011001011100010" and decoded == sent

"""Detection scenes (rfsim.scenes.reader_queries, rfsim.scenes.st_detection) and the ST's
batch decoding (rfsim.devices.sense_a_tag_rows) against link budgets worked by hand.

Friis at 915 MHz (λ = 0.3276 m): free-space loss 20·log10(4π·d/λ) = 31.7 dB at 1 m and
65.7 dB at 50 m. Reader 30 dBm into a 6 dBi circular patch, tag dipole 2.15 dBi, 3 dB
circular-to-linear: the tag's CW is ≈ +3.5 dBm at 1 m (above the −12.8 dBm sensitivity by 16 dB,
read every time) and ≈ −30.5 dBm at 50 m (never powered).
"""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.channels import Antenna, HalfWaveDipole, Patch
from rfsim.channels.scene import Channel, Scene
from rfsim.devices.reader import Reader
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.sense_a_tag_rows import NOT_DETECTED, chain_names
from rfsim.devices.tag import PassiveTag
from rfsim.devices.tag_config import TagConfig
from rfsim.scenes.reader_queries import repeated_queries
from rfsim.scenes.st_detection import Devices, Placement, run_rounds

READER = ReaderConfig(link_profile="pass-miller2-48k", fs_hz=1e6, ptx_dbm=30.0, hopping=True)
PATCH = Antenna(position_m=(0.0, 0.0, 0.0), pattern=Patch(6.0, 70.0), polarization="circular")


def _tag_antenna(x_m):
    return Antenna(position_m=(x_m, 0.0, 0.0), orientation=(np.pi, 0.0, 0.0), pattern=HalfWaveDipole())


@pytest.mark.parametrize("distance_m, reads", [(1.0, 6), (50.0, 0)])
def test_repeated_queries_read_near_and_never_far(distance_m, reads):
    rng = np.random.default_rng(4)
    reader = Reader(READER, [PATCH], rng=rng)
    tag = PassiveTag(TagConfig(), _tag_antenna(distance_m), rng=np.random.default_rng(5))
    times = np.linspace(0.0, 0.5, 6)
    r = repeated_queries(reader, tag, PATCH, Channel(Scene()), times, np.ones(6, complex),
                         channel_rng=np.random.default_rng(6), noise_rng=np.random.default_rng(7), query_block=4)
    assert r.n_reads == r.n_replied == r.n_powered == reads
    assert r.max_incident_power_dbm == pytest.approx(3.5 if distance_m == 1.0 else -30.5, abs=1.0)
    assert 1 <= r.n_channels <= 6 and 902.75e6 <= r.frequency_hz <= 927.25e6


def test_st_rounds_detect_a_near_tag_and_nothing_from_a_silent_one():
    st = SenseATagConfig(technique="selection")
    dev = Devices(READER, TagConfig(), st, PATCH, Scene())
    near, far = np.array([1.5, 0.0, 0.0]), np.array([50.0, 0.0, 0.0])
    placements = [Placement(p, p + np.array([0.0, 0.15, 0.0]), 0.3, _tag_antenna(p[0])) for p in (near, far)]
    rngs = [[np.random.default_rng(10 * i + k) for k in range(6)] for i in range(2)]
    rec = run_rounds(dev, placements, rngs)
    assert rec[0]["tag_replied"] and rec[0]["reader_detected"] and rec[0]["st_detected"]
    assert rec[0]["d_m"] == pytest.approx(0.15, rel=1e-12) and rec[0]["D_m"] == pytest.approx(1.5, rel=1e-12)
    assert rec[0]["st_diff_sa2_v"] > 0.005  # above the 5 mV threshold
    assert not rec[1]["tag_powered"] and not rec[1]["tag_replied"]
    assert {k: rec[1][k] for k in NOT_DETECTED} == NOT_DETECTED


def test_chain_names_follow_the_technique():
    assert chain_names(SenseATagConfig(technique="selection")) == ["sa2", "sa1"]
    assert chain_names(SenseATagConfig(technique="combination")) == ["sa2", "sa1", "combined"]
    assert chain_names(SenseATagConfig(technique="single", n_antennas=1)) == ["sa2"]

"""The gen2-waveforms scenario: its waveforms decode back to the frames it claims."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.core.config import load_config
from rfsim.core.errors import ConfigError
from rfsim.gen2.commands import ACK, Query, parse
from rfsim.gen2.crc import crc16_ok
from rfsim.gen2.linecode import decode_reply
from rfsim.gen2.link import profile
from rfsim.gen2.pie import pie_decode
from rfsim.gen2.bits import bits_to_int, bits_to_str
from rfsim.scenarios import gen2_waveforms as scenario


@pytest.fixture(scope="module")
def dataset():
    config = load_config(scenario.Config, None, ["q=7", "session=2", "fs_hz=6e6"])
    return config, scenario.run(config, seed=11)


def test_every_profile_exchange_decodes(dataset):
    config, ds = dataset
    names = list(ds.tables["profiles"]["profile"].data)
    assert names == list(config.profiles) and len(names) == 4
    rn16 = int(ds.attrs["rn16"])
    for name in names:
        link = profile(name)
        ex = ds.tables[f"exchange_{name}"]
        frames = pie_decode(ex["reader_envelope"].data)
        assert len(frames) == 2, name
        query, ack = parse(frames[0].bits), parse(frames[1].bits)
        assert query == Query(dr=link.dr, m=link.m, trext=link.trext, session=2, q=7)
        assert ack == ACK(rn16)
        # Measured Tari/RTcal/TRcal (in samples) equal the profile's within one sample.
        fs = config.fs_hz
        assert abs(frames[0].tari - link.tari_s * fs) <= 1.0
        assert abs(frames[0].rtcal - link.rtcal_s * fs) <= 1.0
        assert abs(frames[0].trcal - link.trcal_s * fs) <= 1.0
        # The tag's two replies, decoded from its backscatter state alone.
        tag = ex["tag_state"].data.astype(complex)
        t = ex["time_s"].data
        rows = {f: i for i, (p, f) in enumerate(zip(ds.tables["frames"]["profile"].data,
                                                     ds.tables["frames"]["frame"].data)) if p == name}
        starts = ds.tables["frames"]["start_s"].data
        i_rn16 = np.searchsorted(t, starts[rows["RN16"]])
        i_epc = np.searchsorted(t, starts[rows["EPC"]])
        got_rn16 = decode_reply(tag[i_rn16 - 20:i_epc], n_bits=16, m=link.m, trext=link.trext,
                                blf_hz=link.blf_hz, fs_hz=fs)
        assert bits_to_int(got_rn16.bits) == rn16
        got_epc = decode_reply(tag[i_epc - 20:], n_bits=128, m=link.m, trext=link.trext,
                               blf_hz=link.blf_hz, fs_hz=fs)
        assert crc16_ok(got_epc.bits)
        assert bits_to_int(got_epc.bits[:16]) == 0x3000  # StoredPC of a 96-bit EPC: 6 words << 11
        assert bits_to_str(got_epc.bits[16:112]) == bits_to_str(
            np.unpackbits(np.frombuffer(bytes.fromhex(config.epc_hex), np.uint8)))


def test_timing_table_matches_the_frames(dataset):
    _, ds = dataset
    timing, frames = ds.tables["timing"], ds.tables["frames"]
    for i, name in enumerate(timing["profile"].data):
        sel = frames["profile"].data == name
        dur = dict(zip(frames["frame"].data[sel], (frames["end_s"].data - frames["start_s"].data)[sel]))
        np.testing.assert_allclose(dur["Query"], timing["query_s"].data[i], rtol=1e-12)
        np.testing.assert_allclose(dur["RN16"], timing["rn16_reply_s"].data[i], rtol=1e-12)
        np.testing.assert_allclose(dur["EPC"], timing["epc_reply_s"].data[i], rtol=1e-12)
        start = dict(zip(frames["frame"].data[sel], frames["start_s"].data[sel]))
        end = dict(zip(frames["frame"].data[sel], frames["end_s"].data[sel]))
        # The tag answers T1 (nominal) after the end of the reader's command.
        np.testing.assert_allclose(start["RN16"] - end["Query"], timing["t1_nom_s"].data[i], rtol=1e-9)
        t2 = start["ACK"] - end["RN16"]
        assert timing["t2_min_s"].data[i] <= t2 <= timing["t2_max_s"].data[i] + 1 / 6e6


def test_seed_draws_the_rn16_and_is_reproducible():
    config = load_config(scenario.Config, None, ["profiles=['fm0-40k']", "fs_hz=1e6"])
    a, b, c = (scenario.run(config, seed=s).attrs["rn16"] for s in (5, 5, 6))
    assert a == b and a != c
    fixed = load_config(scenario.Config, None, ["profiles=['fm0-40k']", "fs_hz=1e6", "rn16=4660"])
    assert scenario.run(fixed, seed=5).attrs["rn16"] == 4660


def test_epc_longer_than_the_pc_length_field_is_a_config_error():
    # the PC word's 5-bit length field holds at most 31 words (496 bits)
    scenario.Config(epc_hex="AB12" * 31)
    with pytest.raises(ConfigError, match="epc_hex"):
        scenario.Config(epc_hex="AB12" * 32)

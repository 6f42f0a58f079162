"""Trial batching (issue 16, item 1): B exchanges in one batch equal B separate runs exactly.

The reference is the single-exchange engine itself, run B times on fresh, identically built
devices with the same generators (``trial_rng(seed, b)``): the batch must give every record
field and every array bit for bit (``np.array_equal`` on the reads' bits and ``==`` on every
float, no tolerance). The canonical setting is the ``link`` scenario's channel (Friis,
concrete floor, APDP drawn anew per trial), receiver noise on, distances chosen so that the
batch holds successful reads, an ACK sub-batch, and trials that fail (out of range, noise).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from channels import Channel
from devices.reader import Reader, ReaderConfig
from devices.tag import PassiveTag, TagConfig
from rfsim.batch import run_exchanges, singulate_batch
from rfsim.engine import run_exchange, singulate
from rfsim.gen2.commands import Query
from rfsim.rng import trial_rng
from scenarios import link as link_scenario

SEED = 11


def devices(distances_m, *, link_profile="miller4-320k"):
    """A reader, one tag per trial (own RN16 stream), the link scenario's channel."""
    cfg = link_scenario.Config()
    reader = Reader(ReaderConfig(link_profile=link_profile), [link_scenario.reader_antenna(cfg.geometry)],
                    rng=trial_rng(SEED, 0))
    tags = [[PassiveTag(TagConfig(), link_scenario.tag_antenna(cfg.geometry, d), rng=trial_rng(SEED, 1, b))]
            for b, d in enumerate(distances_m)]
    return reader, tags, Channel(link_scenario.scene(cfg.channel))


def assert_same_exchange(a, b):
    fa, fb = dataclasses.asdict(a), dataclasses.asdict(b)
    ra, rb = fa.pop("read"), fb.pop("read")
    assert fa == fb
    assert (ra is None) == (rb is None)
    if ra is None:
        return
    assert ra.keys() == rb.keys()
    for k in ra:
        va, vb = ra[k], rb[k]
        if isinstance(va, np.ndarray) or isinstance(vb, np.ndarray):
            assert np.array_equal(va, vb), k
        elif isinstance(va, float) and math.isnan(va):
            assert isinstance(vb, float) and math.isnan(vb), k
        else:
            assert va == vb, k


# 1–3 m read, 25 m is out of range (not powered), 14 m near the edge of the forward link
DISTANCES = (1.0, 2.0, 3.0, 25.0, 14.0, 3.0, 6.0, 2.5)


def query_of(reader, target="A"):
    lk = reader.link
    return Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0, target=target)


def test_run_exchanges_equals_separate_run_exchange_calls():
    reader, tags, channel = devices(DISTANCES)
    batch = run_exchanges(reader, tags, channel, query_of(reader), t_s=0.25,
                          rngs=[trial_rng(SEED, 2, b) for b in range(len(DISTANCES))], reply_bits=16,
                          expect_crc=False, round_index=3)
    reader2, tags2, channel2 = devices(DISTANCES)
    single = [run_exchange(reader2, tags2[b], channel2, query_of(reader2), t_s=0.25, rng=trial_rng(SEED, 2, b),
                           reply_bits=16, expect_crc=False, round_index=3) for b in range(len(DISTANCES))]
    reasons = {ex.failure_reason for ex in single}
    assert "" in reasons and "not powered" in reasons  # the batch mixes reads and failures
    for a, b in zip(batch, single):
        assert_same_exchange(a, b)
    # the tags' states went the same way (RN16 drawn, slot, handle)
    for tb, ts in zip(tags, tags2):
        assert tb[0].state.rn16 == ts[0].state.rn16


@pytest.mark.parametrize("link_profile, block", [("miller4-320k", 64), ("fm0-640k", 64), ("miller4-320k", 3)])
def test_singulate_batch_equals_separate_singulations(link_profile, block, monkeypatch):
    monkeypatch.setattr("rfsim.batch.BLOCK", block)  # 3: the trials run in blocks of 3, 3, 2
    reader, tags, channel = devices(DISTANCES, link_profile=link_profile)
    rngs = [trial_rng(SEED, 3, b) for b in range(len(DISTANCES))]
    batch = singulate_batch(reader, tags, channel, t_s=0.0, rngs=rngs, query=query_of(reader), round_index=1)
    reader2, tags2, channel2 = devices(DISTANCES, link_profile=link_profile)
    single = [singulate(reader2, tags2[b], channel2, t_s=0.0, rng=trial_rng(SEED, 3, b),
                        query=query_of(reader2), round_index=1) for b in range(len(DISTANCES))]
    assert any(len(s) == 2 and s[1].success for s in single)  # some trials went on to a good EPC read
    assert any(len(s) == 1 for s in single)
    for a, b in zip(batch, single):
        assert [e.command for e in a] == [e.command for e in b]
        for ea, eb in zip(a, b):
            assert_same_exchange(ea, eb)
    # the generators are left where the single runs leave them
    assert [r.standard_normal() for r in rngs] == [
        _rng_after_single(b, link_profile) for b in range(len(DISTANCES))]


def _rng_after_single(b, link_profile):
    reader, tags, channel = devices(DISTANCES, link_profile=link_profile)
    rng = trial_rng(SEED, 3, b)
    singulate(reader, tags[b], channel, t_s=0.0, rng=rng, query=query_of(reader), round_index=1)
    return rng.standard_normal()


def test_per_trial_readers_commands_and_times():
    """One reader per trial (hop sequences of their own), per-trial times: the batch
    still equals the separate runs."""
    cfg = link_scenario.Config()
    make = lambda b: Reader(cfg.reader, [link_scenario.reader_antenna(cfg.geometry)], rng=trial_rng(SEED, 5, b))  # noqa: E731
    n = 4
    readers = [make(b) for b in range(n)]
    _, tags, channel = devices(DISTANCES[:n])
    times = [0.0, 0.41, 0.83, 1.7]
    batch = run_exchanges(readers, tags, channel, [query_of(r, "AB"[b % 2]) for b, r in enumerate(readers)],
                          t_s=times, rngs=[trial_rng(SEED, 6, b) for b in range(n)], reply_bits=16,
                          expect_crc=False)
    readers2 = [make(b) for b in range(n)]
    _, tags2, channel2 = devices(DISTANCES[:n])
    for b in range(n):
        ref = run_exchange(readers2[b], tags2[b], channel2, query_of(readers2[b], "AB"[b % 2]), t_s=times[b],
                           rng=trial_rng(SEED, 6, b), reply_bits=16, expect_crc=False)
        assert_same_exchange(batch[b], ref)
    assert len({ex.fc_hz for ex in batch}) > 1  # the trials hopped to different carriers


def test_mismatched_lengths_are_one_line_errors():
    reader, tags, channel = devices(DISTANCES[:2])
    with pytest.raises(ValueError, match="t_s: 3 values for 2 trials"):
        run_exchanges(reader, tags, channel, query_of(reader), t_s=[0.0, 0.1, 0.2],
                      rngs=[trial_rng(1, 0), trial_rng(1, 1)], reply_bits=16, expect_crc=False)
    with pytest.raises(ValueError, match="tags: 2 tag lists for 1 trials"):
        run_exchanges(reader, tags, channel, query_of(reader), t_s=0.0, rngs=[trial_rng(1, 0)], reply_bits=16,
                      expect_crc=False)


def test_bench_exchange_batch_reports_its_measurements():
    from rfsim.bench.exchange import bench_exchange_batch
    from rfsim.cli.bench import BENCHMARKS

    assert BENCHMARKS["exchange-batch"][:2] == ("rfsim.bench.exchange", "bench_exchange_batch")
    out = bench_exchange_batch(batch=3, n_batches=2)
    # at 3 m the canonical link reads every round (tests/test_engine.py bench test); the two
    # batches target A then B, so every tag answers both
    assert out["batch"] == 3 and out["read_rate"] == 1.0
    assert out["air_time_per_cpu_s"] > 0 and out["cpu_s_per_trial"] > 0

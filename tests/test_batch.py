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

from rfsim.channels import Channel
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.devices.tag import PassiveTag, TagConfig
from rfsim.protocols.batch import run_exchanges, singulate_batch
from rfsim.protocols.engine import run_exchange, singulate
from rfsim.gen2.commands import Query
from rfsim.core.rng import trial_rng
from rfsim.scenarios import link as link_scenario

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
    monkeypatch.setattr("rfsim.protocols.engine.BLOCK", block)  # 3: the trials run in blocks of 3, 3, 2
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


# ----------------------------------------------------------------------------- propagate_batch


def air_scene(b, *, noise_w, shared_rng=None, link_rng_is_noise=False, keep=False, decide=True):
    """Step b of a batch, built afresh: a reader's Query segment, one tag, as receivers the
    reader's port and two listening antennas (each with noise ``noise_w``), links drawn from
    the step's own link stream (or, ``link_rng_is_noise``, from its noise generator)."""
    from rfsim.channels.antennas import vertical_dipole
    from rfsim.air.step import AntennaPort, FixedEmitter, LinkTable
    from rfsim.protocols.batch import AirStep
    from rfsim.protocols.engine import ReaderPort

    cfg = link_scenario.Config()
    ra = link_scenario.reader_antenna(cfg.geometry)
    reader = Reader(ReaderConfig(), [ra], rng=trial_rng(SEED, 7, b))
    tag = PassiveTag(TagConfig(), link_scenario.tag_antenna(cfg.geometry, DISTANCES[b]), rng=trial_rng(SEED, 8, b))
    lk = reader.link
    tx = reader.transmit(query_of(reader), t0_s=0.0, cw_after_s=0.9e-3)
    noise = shared_rng if shared_rng is not None else trial_rng(SEED, 9, b)
    links = LinkTable(Channel(link_scenario.scene(cfg.channel)),
                      rng=noise if link_rng_is_noise else trial_rng(SEED, 10, b))
    port = ReaderPort(reader, ra, tx, reply_bits=16, expect_crc=False)
    listeners = [AntennaPort(vertical_dipole((0.5 + 0.3 * k, 0.4, 1.0)), noise_power_w=noise_w) for k in range(2)]
    receivers = [listeners[0], port, listeners[1]] if not link_rng_is_noise else [listeners[0], port]
    if link_rng_is_noise:  # only the last receiver has noise: its links come before its noise
        listeners[0].noise_power_w = 0.0
    return AirStep([FixedEmitter(ra, tx, device=reader)], [tag], receivers, links, t0_s=0.0, fs_hz=tx.fs_hz,
                   n_samples=tx.samples.size, rng=noise, bandwidth_hz=2.0 * lk.blf_hz, decide=decide,
                   keep_components=keep)


def separate(step):
    from rfsim.air.step import propagate

    return propagate(step.emitters, step.reflectors, step.receivers, step.links, t0_s=step.t0_s, fs_hz=step.fs_hz,
                     n_samples=step.n_samples, rng=step.rng, bandwidth_hz=step.bandwidth_hz,
                     propagation=step.propagation, decide=step.decide, keep_components=step.keep_components)


def assert_same_air(a, b):
    assert len(a.inputs) == len(b.inputs)
    for sa, sb in zip(a.inputs, b.inputs):
        assert (sa.t0_s, sa.fs_hz, sa.fc_hz) == (sb.t0_s, sb.fs_hz, sb.fc_hz)
        assert np.array_equal(sa.samples, sb.samples)
    for ra, rb in zip(a.reflections, b.reflections):
        assert ra.incident_power_dbm == rb.incident_power_dbm and ra.powered == rb.powered
        assert (ra.gamma is None) == (rb.gamma is None)
    for oa, ob in zip(a.outputs, b.outputs):
        if oa is None or ob is None:
            assert oa is ob
        elif hasattr(oa, "samples"):
            assert np.array_equal(oa.samples, ob.samples)
        else:
            assert_same_read(oa, ob)
    assert a.dropped == b.dropped and a.fc_ref_hz == b.fc_ref_hz
    for name in ("direct", "noise"):
        xa, xb = getattr(a, name), getattr(b, name)
        assert (xa is None) == (xb is None)
        for va, vb in zip(xa or (), xb or ()):
            assert (va is None and vb is None) or np.array_equal(va, vb), name


def assert_same_read(ra, rb):
    fa, fb = dataclasses.asdict(ra), dataclasses.asdict(rb)
    assert fa.keys() == fb.keys()
    for k in fa:
        if isinstance(fa[k], np.ndarray) or isinstance(fb[k], np.ndarray):
            assert np.array_equal(fa[k], fb[k]), k
        elif isinstance(fa[k], float) and math.isnan(fa[k]):
            assert math.isnan(fb[k]), k
        else:
            assert fa[k] == fb[k], k


@pytest.mark.parametrize("keep", [False, True])
def test_propagate_batch_equals_separate_steps_with_noise_at_several_receivers(keep):
    from rfsim.protocols.batch import propagate_batch

    n, noise_w = 5, 1e-9
    batch = propagate_batch([air_scene(b, noise_w=noise_w, keep=keep) for b in range(n)])
    single = [separate(air_scene(b, noise_w=noise_w, keep=keep)) for b in range(n)]
    quiet = separate(air_scene(0, noise_w=0.0))
    assert not np.array_equal(quiet.inputs[0].samples, single[0].inputs[0].samples)  # the listeners' noise is on
    assert any(air.reflections[0].gamma is not None for air in single)  # some tags replied
    for a, b in zip(batch, single):
        assert_same_air(a, b)
        assert a.outputs[1] is not None  # decide: the reader port's read, formed after the noise


def test_propagate_batch_steps_sharing_one_noise_generator_equal_the_sequence():
    """Steps drawing noise from one generator (a trial's queries): drawn in step order."""
    from rfsim.protocols.batch import propagate_batch

    shared = trial_rng(SEED, 12)
    batch = propagate_batch([air_scene(b, noise_w=1e-9, shared_rng=shared) for b in range(4)])
    shared2 = trial_rng(SEED, 12)
    single = [separate(air_scene(b, noise_w=1e-9, shared_rng=shared2)) for b in range(4)]
    for a, b in zip(batch, single):
        assert_same_air(a, b)
    assert shared.standard_normal() == shared2.standard_normal()


def test_propagate_batch_links_and_noise_from_one_generator():
    """The engine's case (the links' draws come before the one noisy receiver's noise) is
    exact; where the batch would move a noise draw before a link draw it refuses."""
    from rfsim.protocols.batch import propagate_batch

    batch = propagate_batch([air_scene(b, noise_w=1e-9, link_rng_is_noise=True) for b in range(3)])
    single = [separate(air_scene(b, noise_w=1e-9, link_rng_is_noise=True)) for b in range(3)]
    for a, b in zip(batch, single):
        assert_same_air(a, b)
    bad = air_scene(0, noise_w=1e-9)
    bad.links.rng = bad.rng  # the second listener's links would be drawn after the first one's noise
    with pytest.raises(ValueError, match=r"steps\[0\]\.links: draws from a generator that receiver noise"):
        propagate_batch([bad])


def test_counter_noise_batch_equals_separate_singulations():
    # with the counter-based noise (one key per step from the trial's generator, noise only on
    # the samples the reader reads) a trial's records do not depend on the batch it ran in
    from rfsim.air.cache import AirCache, Strategy

    def with_counter(made):
        made[0].air_cache = AirCache(strategy=Strategy(noise="counter"))
        return made

    reader, tags, channel = with_counter(devices(DISTANCES))
    rngs = [trial_rng(SEED, 3, b) for b in range(len(DISTANCES))]
    batch = singulate_batch(reader, tags, channel, t_s=0.0, rngs=rngs, query=query_of(reader), round_index=1)
    reader2, tags2, channel2 = with_counter(devices(DISTANCES))
    single = [singulate(reader2, tags2[b], channel2, t_s=0.0, rng=trial_rng(SEED, 3, b),
                        query=query_of(reader2), round_index=1) for b in range(len(DISTANCES))]
    assert any(len(s) == 2 and s[1].success for s in single)
    for a, b in zip(batch, single):
        assert [e.command for e in a] == [e.command for e in b]
        for ea, eb in zip(a, b):
            assert_same_exchange(ea, eb)
    # and the noise is not the trial generator's own draws: some measurement differs from a pcg64 run
    reader3, tags3, channel3 = devices(DISTANCES)
    reader3.air_cache = AirCache(strategy=Strategy(noise="pcg64"))
    pcg = singulate_batch(reader3, tags3, channel3, t_s=0.0, rngs=[trial_rng(SEED, 3, b) for b in range(len(DISTANCES))],
                          query=query_of(reader3), round_index=1)
    assert any(a[0].read is not None and b[0].read is not None and a[0].read.snr_db != b[0].read.snr_db
               for a, b in zip(batch, pcg))


def test_singulate_batch_with_the_statistic_receiver_reads_as_window_by_window(monkeypatch):
    """A statistic-level reader in a batched singulation: its RN16 reads (one time base) go
    through ``receive_many`` in one call, its EPC reads (each trial's own ACK, own time base)
    window by window; the records equal those of the same batch read window by window
    (``ReaderPort.receive_batch`` replaced by one ``receive`` per input), so the batched entry
    keeps the receiver's draws in trial order. Fails when the batch entry is handed the
    windows' per-trial times as one value or reads them out of order."""
    import rfsim.devices.reader_statistic as rs
    from rfsim.protocols.engine import ReaderPort

    def run():
        reader, tags, channel = devices(DISTANCES)
        reader = Reader(dataclasses.replace(reader.config, rx_model="statistic"), reader.antennas,
                        rng=trial_rng(SEED, 0))
        rngs = [trial_rng(SEED, 3, b) for b in range(len(DISTANCES))]
        return singulate_batch(reader, tags, channel, t_s=0.0, rngs=rngs, query=query_of(reader), round_index=1)

    calls = []
    real_many = rs.receive_many
    monkeypatch.setattr(rs, "receive_many", lambda *a, **k: calls.append(len(a[1])) or real_many(*a, **k))
    batched = run()
    assert calls and max(calls) > 1  # the RN16 reads went through the batch entry
    monkeypatch.setattr(ReaderPort, "receive_batch", lambda self, inputs, ports=None: [
        (p or self).receive(x) for p, x in zip(ports or (None,) * len(inputs), inputs)])
    one_by_one = run()
    assert any(len(s) == 2 and s[1].success for s in one_by_one)
    for a, b in zip(batched, one_by_one):
        assert [e.command for e in a] == [e.command for e in b]
        for ea, eb in zip(a, b):
            assert_same_exchange(ea, eb)

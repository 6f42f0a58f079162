"""The default receiver noise (``Strategy()``: counter-based, drawn where read, the compiled
static exchange; :mod:`rfsim.air.noise`) keeps a trial's records the same bit for bit whether the
trial runs alone, in a batch of any size or on another worker process, and is what the default
runs draw."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rfsim.air import step as air_step
from rfsim.air.cache import AirCache, Strategy
from rfsim.core.rng import trial_rng
from rfsim.protocols.batch import singulate_batch
from rfsim.protocols.engine import singulate
from rfsim.scenarios import detection_probability as dp
from test_batch import DISTANCES, SEED, assert_same_exchange, devices, query_of
from test_scenario_detection_probability import TINY


def test_default_strategy_is_counter_noise_and_the_compiled_exchange():
    assert (AirCache().strategy.noise, AirCache().strategy.exchange) == ("counter", "compiled")


def _batch(strategy: Strategy | None, seed_point: int = 5):
    reader, tags, channel = devices(DISTANCES)
    if strategy is not None:
        reader.air_cache = AirCache(strategy=strategy)
    rngs = [trial_rng(SEED, seed_point, b) for b in range(len(DISTANCES))]
    return singulate_batch(reader, tags, channel, t_s=0.0, rngs=rngs, query=query_of(reader), round_index=1)


def test_default_batch_equals_separate_runs_and_the_two_stage_counter_noise():
    default = _batch(None)
    reader, tags, channel = devices(DISTANCES)  # every trial alone, the default strategy
    single = [singulate(reader, tags[b], channel, t_s=0.0, rng=trial_rng(SEED, 5, b), query=query_of(reader),
                        round_index=1) for b in range(len(DISTANCES))]
    two_stage = _batch(Strategy(noise="counter", exchange="sample"))
    assert any(len(s) == 2 and s[1].success for s in single)
    for a, b, c in zip(default, single, two_stage):
        assert [e.command for e in a] == [e.command for e in b] == [e.command for e in c]
        for ea, eb, ec in zip(a, b, c):
            assert_same_exchange(ea, eb)
            assert_same_exchange(ea, ec)
    # the pcg64 draws give other measurements of the same replies
    pcg = _batch(Strategy(noise="pcg64"))
    assert any(a[0].read is not None and b[0].read is not None and a[0].read.snr_db != b[0].read.snr_db
               for a, b in zip(default, pcg))


def test_default_noise_rows_do_not_depend_on_workers_or_block_size(monkeypatch):
    """detection-probability at its default strategy: one block in this process (counter keys
    drawn: spied), blocks of 4 samples on 2 worker processes, and blocks run one by one give the
    same rows to the bit."""
    keys = []
    real_key = air_step.noise_key
    monkeypatch.setattr(air_step, "noise_key", lambda rng: keys.append(1) or real_key(rng))
    cfg = replace(TINY, samples=dp.SampleConfig(count=12, seed=9, workers=1))
    one = dp.simulate(cfg, seed=1)
    assert keys  # the default draws counter-based noise
    monkeypatch.setattr(air_step, "noise_key", real_key)
    monkeypatch.setattr(dp, "ST_BLOCK", 4)
    monkeypatch.setattr(dp, "WARM_BLOCK", 3)
    pooled = dp.simulate(replace(cfg, samples=replace(cfg.samples, workers=2)), seed=1)
    blocks = [dp.simulate(replace(cfg, samples=dp.SampleConfig(first=f, count=4, seed=9, workers=1)), seed=100 + f)
              for f in (0, 4, 8)]
    assert one["tag_replied"].any()
    for k in dp.FIELDS:
        np.testing.assert_array_equal(pooled[k], one[k], err_msg=k)
        np.testing.assert_array_equal(np.concatenate([b[k] for b in blocks]), one[k], err_msg=k)

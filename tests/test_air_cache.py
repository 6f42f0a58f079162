"""The run's cache of the air step (:mod:`rfsim.air.cache`): its tables, their eviction, and the
readers of one run sharing it."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.air.cache import AirCache, Strategy, Waveform
from rfsim.core.errors import ConfigError


def test_derived_is_computed_once_per_source_and_function():
    cache, calls = AirCache(), []

    def make(x):
        calls.append(x)
        return [len(x)]

    a, b = ("a", "b"), ("a", "b", "c")
    assert cache.derived(a, make) is cache.derived(a, make)
    assert cache.derived(b, make) == [3]
    assert calls == [a, b]
    assert cache.derived(a, lambda x: "other") == "other"  # another function: its own entry


def test_waveform_hit_needs_the_same_makers_and_moves_to_the_end():
    cache = AirCache(max_entries=2)
    config, link = object(), object()
    w = Waveform(samples=np.zeros(3, dtype=np.complex128), makers=(config, link))
    cache.remember(cache.waveforms, "q", w)
    cache.remember(cache.waveforms, "ack", Waveform(samples=np.ones(3, dtype=np.complex128), makers=(config, link)))
    assert cache.waveform("q", (config, link)) is w
    assert cache.waveform("q", (object(), link)) is None  # other makers: no hit
    cache.remember(cache.waveforms, "ack2", Waveform(samples=np.ones(3, dtype=np.complex128), makers=(config, link)))
    assert list(cache.waveforms) == ["q", "ack2"]  # the least recently used ("ack") dropped


def test_strategy_noise_is_checked():
    with pytest.raises(ConfigError) as err:
        Strategy(noise="mt19937")
    assert err.value.key == "air.strategy.noise"


def test_readers_of_one_run_share_its_cache():
    from rfsim.channels import Antenna
    from rfsim.core.rng import trial_rng
    from rfsim.devices.reader import Reader, ReaderConfig
    from rfsim.gen2.commands import QueryRep

    cache, cfg = AirCache(), ReaderConfig()
    r1 = Reader(cfg, [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(1, 0), air_cache=cache)
    r2 = Reader(cfg, [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(1, 1), air_cache=cache)
    assert r1.config is r2.config and r1.config == cfg  # validated once for the run
    t1 = r1.transmit(QueryRep(session=1), t0_s=0.0, cw_after_s=2e-4)
    t2 = r2.transmit(QueryRep(session=1), t0_s=0.0, cw_after_s=2e-4)
    assert t1.samples is t2.samples and t1.memo is t2.memo
    r3 = Reader(cfg, [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(1, 2))  # another run
    assert r3.transmit(QueryRep(session=1), t0_s=0.0, cw_after_s=2e-4).samples is not t1.samples

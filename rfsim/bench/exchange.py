"""Benchmark of the canonical sample-level exchange (issue 4 "Speed").

The canonical exchange: link profile ``miller4-320k`` (Tari 12.5 µs, DR 64/3, TRcal 66.7 µs,
BLF 320 kHz, Miller-4, PR-ASK) at 4 MS/s, reader (30 dBm, 6 dBi circular patch) and a
dipole tag at 3 m over the ``link`` scenario's default channel (Friis + concrete floor by
the image method + exponential APDP, drawn anew every round), receiver noise (NF 10 dB),
the full reader receive chain (detection, Viterbi decoding, CRC, RSSI/phase/Doppler/SNR).
One round is a singulation Query → RN16 → ACK → PC+EPC+CRC (:func:`rfsim.protocols.engine.singulate`).
"""

from __future__ import annotations

import time
import tracemalloc


def bench_exchange(*, n_rounds: int = 200, distance_m: float = 3.0, seed: int = 0, noise: str | None = None,
                   exchange: str | None = None) -> dict:
    """Measure simulated air time per wall-clock second of the canonical exchange, on one core.

    Air time = the samples the engine simulated (the reader's segments: CW lead-in, command,
    T1max + reply + 3 Tpri, for the Query and the ACK) divided by fs; silent time between rounds
    is not counted (the engine skips it). Compile time is excluded (one warm-up round first).

    Parameters
    ----------
    n_rounds : int, default 200
        Timed singulation rounds.
    distance_m : float, default 3.0
        Reader–tag distance [m].
    seed : int, default 0
        Root seed (round r draws from ``trial_rng(seed, 2, r)``).
    noise : {"counter", "pcg64"} or None, default None
        How the reader's noise is drawn (:attr:`rfsim.air.cache.Strategy.noise`); None: the
        strategy's default (``"counter"``).
    exchange : {"compiled", "sample"} or None, default None
        How the reader's input is formed (:attr:`rfsim.air.cache.Strategy.exchange`; "compiled"
        needs ``noise="counter"``); None: the strategy's default for ``noise``.

    Returns
    -------
    dict
        ``air_time_per_wall_s`` (real-time factor), ``air_time_per_cpu_s`` (the same per second
        of process CPU time: less sensitive to other load on a shared machine),
        ``rounds_per_s``, ``air_time_per_round_s`` [s], ``samples_per_round``, ``read_rate`` and
        ``peak_traced_mb`` [MiB], the peak of Python/NumPy allocations during up to 20 rounds
        (``tracemalloc``, measured in a second, separate pass so that the tracing does not slow
        the timed one).
    """
    from rfsim.protocols.engine import singulate
    from rfsim.core.rng import trial_rng

    reader, make_tag, channel, query = _canonical(distance_m, seed, noise, exchange)
    tag = make_tag(None)
    state = {"t": 0.0, "r": 0}

    def one_round():
        r = state["r"]
        ex = singulate(reader, [tag], channel, t_s=state["t"], rng=trial_rng(seed, 2, r), query=query(r),
                       round_index=r)
        state["t"] += 20e-3
        state["r"] += 1
        return ex

    one_round()  # warm-up: numba compilation / cache load
    samples, ok = 0, 0
    c0 = time.process_time()
    t0 = time.perf_counter()
    for _ in range(int(n_rounds)):
        ex = one_round()
        samples += sum(e.n_samples for e in ex)
        ok += ex[-1].command == "ACK" and ex[-1].success
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    air = samples / reader.fs_hz

    tracemalloc.start()
    for _ in range(min(int(n_rounds), 20)):
        one_round()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {
        "air_time_per_wall_s": air / wall,
        "air_time_per_cpu_s": air / cpu,
        "rounds_per_s": n_rounds / wall,
        "air_time_per_round_s": air / n_rounds,
        "samples_per_round": samples / n_rounds,
        "read_rate": ok / n_rounds,
        "peak_traced_mb": peak / 2**20,
    }


def _canonical(distance_m: float, seed: int, noise: str | None = None, exchange: str | None = None):
    """The canonical exchange's reader (its receiver noise drawn by ``noise``,
    :attr:`rfsim.air.cache.Strategy.noise`, its input formed by ``exchange``,
    :attr:`rfsim.air.cache.Strategy.exchange`; None: the strategy's defaults), a maker of its tag (``trial_rng(seed, 1)``, trial b
    of a batch ``trial_rng(seed, 1, b)``; every tag on the same antenna), the channel and the
    round's Query (target A/B alternating)."""
    # imported here: rfsim does not import devices/channels/scenarios at module level
    from rfsim.air.cache import AirCache, Strategy
    from rfsim.channels import Channel
    from rfsim.devices.reader import Reader, ReaderConfig
    from rfsim.devices.tag import PassiveTag, TagConfig
    from rfsim.gen2.commands import Query
    from rfsim.core.rng import trial_rng
    from rfsim.scenarios import link as link_scenario

    cfg = link_scenario.Config()
    reader = Reader(ReaderConfig(link_profile="miller4-320k"), [link_scenario.reader_antenna(cfg.geometry)],
                    rng=trial_rng(seed, 0))
    chosen = {k: v for k, v in (("noise", noise), ("exchange", exchange)) if v is not None}
    reader.air_cache = AirCache(strategy=Strategy(**chosen))
    antenna = link_scenario.tag_antenna(cfg.geometry, distance_m)
    channel = Channel(link_scenario.scene(cfg.channel))
    lk = reader.link

    def make_tag(b: int | None):
        return PassiveTag(TagConfig(), antenna, rng=trial_rng(seed, 1) if b is None else trial_rng(seed, 1, b))

    def query(r: int):
        return Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0, target="AB"[r % 2])

    return reader, make_tag, channel, query


def bench_exchange_batch(*, batch: int = 256, n_batches: int = 4, distance_m: float = 3.0, seed: int = 0,
                         noise: str | None = None, exchange: str | None = None) -> dict:
    """Measure aggregate air time per second of the canonical exchange run in batches, on one core.

    Batches of ``batch`` independent singulations (:func:`rfsim.protocols.batch.singulate_batch`:
    B tags at the same place, trial b of batch k drawing its channel and noise from
    ``trial_rng(seed, 2, k, b)``). Air time as in :func:`bench_exchange` (the samples of every
    trial's Query and ACK segments / fs); one warm-up batch of 4 other tags first.

    Parameters
    ----------
    batch : int, default 256
        Trials per batch B.
    n_batches : int, default 4
        Timed batches (they alternate target A and B).
    distance_m : float, default 3.0
        Reader–tag distance [m].
    seed : int, default 0
        Root seed.
    noise : {"counter", "pcg64"} or None, default None
        How the reader's noise is drawn (:attr:`rfsim.air.cache.Strategy.noise`); None: the
        strategy's default.
    exchange : {"compiled", "sample"} or None, default None
        How the reader's input is formed (:attr:`rfsim.air.cache.Strategy.exchange`); None: the
        strategy's default for ``noise``.

    Returns
    -------
    dict
        ``batch``, ``air_time_per_wall_s``, ``air_time_per_cpu_s``, ``trials_per_s``,
        ``cpu_s_per_trial`` [s] and ``read_rate``.
    """
    from rfsim.protocols.batch import singulate_batch
    from rfsim.core.rng import trial_rng

    reader, make_tag, channel, query = _canonical(distance_m, seed, noise, exchange)
    tags = [[make_tag(b)] for b in range(int(batch) + 4)]

    def one_batch(k: int, trials: list):
        return singulate_batch(reader, trials, channel, t_s=k * 20e-3,
                               rngs=[trial_rng(seed, 2, k, b) for b in range(len(trials))], query=query(k),
                               round_index=k)

    one_batch(0, tags[int(batch):])  # warm-up (tags of its own): numba compilation / cache load
    samples, ok = 0, 0
    c0 = time.process_time()
    t0 = time.perf_counter()
    for k in range(int(n_batches)):  # a read flips a tag's S0 flag: batches alternate target A and B
        for ex in one_batch(k, tags[:int(batch)]):
            samples += sum(e.n_samples for e in ex)
            ok += ex[-1].command == "ACK" and ex[-1].success
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    air = samples / reader.fs_hz
    n = int(batch) * int(n_batches)
    return {"batch": int(batch), "air_time_per_wall_s": air / wall, "air_time_per_cpu_s": air / cpu,
            "trials_per_s": n / wall, "cpu_s_per_trial": cpu / n, "read_rate": ok / n}


def bench_exchange_pcg64(**kwargs) -> dict:
    """:func:`bench_exchange` with the receiver noise of every sample from the trial's PCG64
    generator and the two-stage air step (``Strategy(noise="pcg64", exchange="sample")``,
    :class:`rfsim.air.cache.Strategy`): the default before the counter-based noise.

    Parameters
    ----------
    **kwargs
        :func:`bench_exchange`'s ``n_rounds``, ``distance_m`` and ``seed``.

    Returns
    -------
    dict
        As :func:`bench_exchange`.
    """
    return bench_exchange(**kwargs, noise="pcg64", exchange="sample")


def bench_exchange_batch_pcg64(**kwargs) -> dict:
    """:func:`bench_exchange_batch` with PCG64 receiver noise and the two-stage air step (as
    :func:`bench_exchange_pcg64`).

    Parameters
    ----------
    **kwargs
        :func:`bench_exchange_batch`'s ``batch``, ``n_batches``, ``distance_m`` and ``seed``.

    Returns
    -------
    dict
        As :func:`bench_exchange_batch`.
    """
    return bench_exchange_batch(**kwargs, noise="pcg64", exchange="sample")


__all__ = ["bench_exchange", "bench_exchange_batch", "bench_exchange_pcg64", "bench_exchange_batch_pcg64"]

"""Benchmark of the canonical sample-level exchange (issue 4 "Speed").

The canonical exchange: link profile ``miller4-320k`` (Tari 12.5 µs, DR 64/3, TRcal 66.7 µs,
BLF 320 kHz, Miller-4, PR-ASK) at 4 MS/s, reader (30 dBm, 6 dBi circular patch) and a
dipole tag at 3 m over the ``link`` scenario's default channel (Friis + concrete floor by
the image method + exponential APDP, drawn anew every round), receiver noise (NF 10 dB),
the full reader receive chain (detection, Viterbi decoding, CRC, RSSI/phase/Doppler/SNR).
One round is a singulation Query → RN16 → ACK → PC+EPC+CRC (:func:`rfsim.engine.singulate`).
"""

from __future__ import annotations

import time
import tracemalloc


def bench_exchange(*, n_rounds: int = 200, distance_m: float = 3.0, seed: int = 0) -> dict:
    """Simulated air time per wall-clock second of the canonical exchange, on one core.

    Air time = the samples the engine simulated (the reader's segments: CW lead-in,
    command, T1max + reply + 3 Tpri, for the Query and the ACK) divided by fs; silent time
    between rounds is not counted (the engine skips it). Compile time is excluded (one
    warm-up round first). ``peak_traced_mb`` is the peak of Python/NumPy allocations during
    the timed rounds (``tracemalloc``, measured in a second, separate pass so that the
    tracing does not slow the timed one).

    Returns
    -------
    dict with ``air_time_per_wall_s`` (real-time factor), ``air_time_per_cpu_s`` (the same
    per second of process CPU time: less sensitive to other load on a shared machine),
    ``rounds_per_s``,
    ``air_time_per_round_s``, ``samples_per_round``, ``read_rate``, ``peak_traced_mb``.
    """
    # imported here: rfsim does not import devices/channels/scenarios at module level
    from channels import Channel
    from devices.reader import Reader, ReaderConfig
    from devices.tag import PassiveTag, TagConfig
    from rfsim.engine import singulate
    from rfsim.gen2.commands import Query
    from rfsim.rng import trial_rng
    from scenarios import link as link_scenario

    cfg = link_scenario.Config()
    reader = Reader(ReaderConfig(link_profile="miller4-320k"), [link_scenario.reader_antenna(cfg.geometry)],
                    rng=trial_rng(seed, 0))
    tag = PassiveTag(TagConfig(), link_scenario.tag_antenna(cfg.geometry, distance_m), rng=trial_rng(seed, 1))
    channel = Channel(link_scenario.scene(cfg.channel))
    lk = reader.link
    state = {"t": 0.0, "r": 0}

    def one_round():
        r = state["r"]
        q = Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0, target="AB"[r % 2])
        ex = singulate(reader, [tag], channel, t_s=state["t"], rng=trial_rng(seed, 2, r), query=q,
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


__all__ = ["bench_exchange"]

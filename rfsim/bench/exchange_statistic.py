"""Benchmark of the canonical exchange with the reader's statistic-level receiver model
(``reader.rx_model = "statistic"``, :mod:`rfsim.devices.reader_statistic`) against the
sample-level one, batched.

The canonical exchange of :mod:`rfsim.bench.exchange` (``miller4-320k`` at 4 MS/s, a dipole tag
at 3 m over the ``link`` scenario's channel, a singulation Query → RN16 → ACK → PC+EPC+CRC),
run as batches of independent singulations (:func:`rfsim.protocols.batch.singulate_batch`, trial
b of batch k from ``trial_rng(seed, 2, k, b)``), once per receiver model. Besides the whole
exchange's air time per CPU second, the CPU time spent in the reader's reads (``receive`` and
``receive_batch``: the receiver model itself, its noise draws included for ``"statistic"``) is
timed per window read, and the CPU time of the air
step's receiver noise is what ``"sample"`` spends in ``add_awgn`` (not timed separately here:
the difference of the two totals).
"""

from __future__ import annotations

import dataclasses
import time

from rfsim.bench.exchange import _canonical

__all__ = ["bench_exchange_statistic"]


class _TimedReceive:
    """A reader's reads (``receive`` and ``receive_batch``) that add their process CPU time to
    ``cpu_s`` and count the windows read in ``calls`` (a ``receive_batch`` that reads window by
    window through ``receive`` is timed once)."""

    def __init__(self, reader):
        self.cpu_s, self.calls, self._depth = 0.0, 0, 0
        reader.receive = self._timed(reader.receive, lambda args: 1)
        reader.receive_batch = self._timed(reader.receive_batch, lambda args: len(args[0]))

    def _timed(self, read, windows):
        def call(*args, **kwargs):
            self._depth += 1
            c0 = time.process_time()
            try:
                return read(*args, **kwargs)
            finally:
                self._depth -= 1
                if self._depth == 0:
                    self.cpu_s += time.process_time() - c0
                    self.calls += windows(args)
        return call


def _run(rx_model: str, batch: int, n_batches: int, distance_m: float, seed: int) -> dict:
    from rfsim.core.rng import trial_rng
    from rfsim.devices.reader import Reader
    from rfsim.protocols.batch import singulate_batch

    canon, make_tag, channel, query = _canonical(distance_m, seed)
    reader = Reader(dataclasses.replace(canon.config, rx_model=rx_model), canon.antennas, rng=trial_rng(seed, 0))
    timed = _TimedReceive(reader)  # the engine's ReaderPort calls reader.receive and reader.receive_batch
    tags = [[make_tag(b)] for b in range(batch + 4)]

    def one_batch(k: int, trials: list):
        return singulate_batch(reader, trials, channel, t_s=k * 20e-3,
                               rngs=[trial_rng(seed, 2, k, b) for b in range(len(trials))], query=query(k),
                               round_index=k)

    one_batch(0, tags[batch:])  # warm-up: numba compilation / cache load
    timed.cpu_s, timed.calls = 0.0, 0
    samples = ok = 0
    c0 = time.process_time()
    for k in range(n_batches):
        for ex in one_batch(k, tags[:batch]):
            samples += sum(e.n_samples for e in ex)
            ok += ex[-1].command == "ACK" and ex[-1].success
    cpu = time.process_time() - c0
    air = samples / reader.fs_hz
    n = batch * n_batches
    return {"air_time_per_cpu_s": air / cpu, "cpu_s_per_trial": cpu / n,
            "receive_cpu_s_per_call": timed.cpu_s / max(timed.calls, 1),
            "air_time_per_receive_cpu_s": air / timed.cpu_s if timed.cpu_s > 0 else float("inf"),
            "read_rate": ok / n}


def bench_exchange_statistic(*, batch: int = 256, n_batches: int = 4, distance_m: float = 3.0,
                             seed: int = 0, models: tuple = ("sample", "statistic")) -> dict:
    """Measure air time per CPU second of the canonical exchange, batched, per receiver model.

    Parameters
    ----------
    batch : int, default 256
        Trials per batch.
    n_batches : int, default 4
        Timed batches per model.
    distance_m : float, default 3.0
        Reader–tag distance [m].
    seed : int, default 0
        Root seed (trial b of batch k from ``trial_rng(seed, 2, k, b)``).
    models : tuple of str, default ("sample", "statistic")
        Receiver models (``reader.rx_model``) to run.

    Returns
    -------
    dict
        Per model in ``models`` (keys prefixed by the model): ``air_time_per_cpu_s`` (the whole
        exchange: simulated air time per second of process CPU time), ``cpu_s_per_trial`` [s],
        ``receive_cpu_s_per_call`` [s] (CPU time of the reader's reads per window read),
        ``air_time_per_receive_cpu_s`` (air time per CPU second spent in the receiver alone)
        and ``read_rate``; and ``batch``.
    """
    out: dict = {"batch": int(batch)}
    for model in models:
        for key, value in _run(model, int(batch), int(n_batches), distance_m, seed).items():
            out[f"{model}_{key}"] = value
    return out

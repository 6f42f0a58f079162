"""Measured floors of the canonical exchange (:mod:`rfsim.bench.exchange`): what one round
costs at the least, whatever the orchestration.

Two costs every sample-level round pays on the samples it simulates (the reader's segments
of its Query and its ACK, ≈ 11,800 complex samples, 2.96 ms of air at 4 MS/s):

* **one memory pass**: read and write every complex128 sample once (``np.multiply(y, g,
  out=y)``); a round needs a few dozen such passes (modulation, channel, tag, receiver);
* **the receiver noise**: 2 × n standard normal draws from the trial's own PCG64 stream and
  their sum into the samples (:func:`rfsim.air.noise.add_awgn`: PCG64 and NumPy's ziggurat
  compiled by numba on the generator's state), with a new generator per round as the engine
  spawns one per trial.

The noise alone bounds a round with fresh receiver noise at
``air_time / noise_cpu_s`` real time per CPU second, batched or not: trials do not share
noise, so a batch of B rounds draws B times as many numbers.
"""

from __future__ import annotations

import time


def bench_floor(*, n_rounds: int = 400, seed: int = 0, distance_m: float = 3.0) -> dict:
    """Measure the CPU time per round of one memory pass and of the receiver noise.

    Over the samples of the canonical round, with the real-time factors they bound (module
    docstring). The segment lengths are those of one warm-up round of the canonical exchange of
    :mod:`rfsim.bench.exchange` (Query and ACK; the sizes do not change from round to round).

    Parameters
    ----------
    n_rounds : int, default 400
        Timed rounds of each cost.
    seed : int, default 0
        Root seed (round r's noise from ``trial_rng(seed, 3, r)``).
    distance_m : float, default 3.0
        Reader–tag distance of the warm-up round [m].

    Returns
    -------
    dict
        ``samples_per_round``, ``air_time_per_round_s`` [s], ``pass_cpu_s_per_round`` [s],
        ``noise_cpu_s_per_round`` [s], ``noise_over_pass_cpu`` (how many memory passes the noise
        costs; > 1: a normal draw costs ≥ 1 ns, a complex sample's pass well below that),
        ``noise_ns_per_sample`` [ns], ``noise_bound_air_time_per_cpu_s`` (the ceiling set by the
        noise draws alone) and ``passes_25_bound_air_time_per_cpu_s`` (that of 25 memory passes).
    """
    import numpy as np

    from rfsim.bench.exchange import _canonical
    from rfsim.protocols.engine import singulate
    from rfsim.air.noise import add_awgn
    from rfsim.core.rng import trial_rng

    reader, make_tag, channel, query = _canonical(distance_m, seed)
    ex = singulate(reader, [make_tag(None)], channel, t_s=0.0, rng=trial_rng(seed, 2, 0), query=query(0))
    sizes = [int(e.n_samples) for e in ex]
    n = sum(sizes)
    air = n / reader.fs_hz
    ys = [np.zeros(k, dtype=np.complex128) for k in sizes]
    gain = np.complex128(0.999 + 0.001j)
    rounds = int(n_rounds)

    for y in ys:  # warm-up: numba's cache load
        add_awgn(y, 1e-12, trial_rng(seed, 3, 0))
    rngs = [trial_rng(seed, 3, r) for r in range(rounds)]  # spawned before the clock starts
    c0 = time.process_time()
    for rng in rngs:
        for y in ys:
            add_awgn(y, 1e-12, rng)
    noise = (time.process_time() - c0) / rounds

    c0 = time.process_time()
    for _ in range(rounds):
        for y in ys:
            np.multiply(y, gain, out=y)
    one_pass = (time.process_time() - c0) / rounds
    return {"samples_per_round": n, "air_time_per_round_s": air, "pass_cpu_s_per_round": one_pass,
            "noise_cpu_s_per_round": noise, "noise_over_pass_cpu": noise / one_pass if one_pass > 0 else float("inf"),
            "noise_ns_per_sample": noise / n * 1e9,
            "noise_bound_air_time_per_cpu_s": air / noise,
            "passes_25_bound_air_time_per_cpu_s": air / (25.0 * one_pass)}


__all__ = ["bench_floor"]

"""Trial batching: B independent exchanges in one pass, each as a separate run would give it.

A Monte Carlo over exchanges (a link budget's read rate, a detection probability, a BER
curve) runs many *independent trials* of the same kind of exchange: the same devices and
command, a different channel draw, receiver noise and tag RN16 in every trial. Link-level
simulators batch such trials along a leading array dimension so that the per-call cost is
paid once per batch (Sionna's convention); here :func:`run_exchanges` does the same for the
sample-level exchange of :func:`rfsim.engine.run_exchange`:

1. per trial b the reader's segment (made once when every trial sends the same command at
   the same time and round), the tags' links drawn from the trial's own generator ``rngs[b]``
   (as the single run draws them, in the same order) and the tags' reactions — the air step
   :func:`rfsim.air.propagate` without receiver noise;
2. the receiver noise of each trial of the block (blocks of :data:`BLOCK` trials bound the
   memory), drawn from ``rngs[b]`` by :func:`rfsim.noise.add_awgn` with the numbers the single
   run draws there (real part then imaginary part, after the trial's link draws);
3. the reader's reads of the trials with a reply (:meth:`devices.reader.Reader.receive`);
4. the records (:class:`rfsim.engine.Exchange`), as the single run forms them.

Each trial's record is bit-identical to ``run_exchange`` with the same devices and
``rng = rngs[b]`` (tests/test_batch.py): the same numbers are drawn from the same streams
in the same order, and every floating-point operation of the air step is the same
elementwise operation (the noise is added as ``y.real += a; y.imag += b`` there too).
Reproducibility follows the rule of :mod:`rfsim.rng`: trial b's stream is its own spawned
generator (e.g. ``trial_rng(seed, point, b)``), so a trial's result does not depend on the
batch it ran in, nor on B.

Held links. With ``draw_channel=False`` a trial's links come from its own ``link_caches[b]``
(the draw of its Query, for the ACK); a link missing there is the channel's held draw, and a
channel holds one draw per antenna pair, the last trial's: trials whose tags share antenna
objects need their link caches filled (as :func:`singulate_batch` fills them) or a channel
each.

A reader keeps no state between the trials of a batch when its ``blf_search`` is "off"
(the default); with a BLF search the RN16's BLF is kept for the EPC reply that follows, so
:func:`singulate_batch` then needs one reader per trial.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rfsim.air import Segment
from rfsim.engine import Exchange, _prepare, _air_step, _record, _transmit, _truth
from rfsim.noise import add_awgn


def _per_trial(value, n: int, name: str) -> list:
    """``value`` for each of ``n`` trials: a list/tuple of n values, or one value for all."""
    if isinstance(value, (list, tuple)):
        if len(value) != n:
            raise ValueError(f"{name}: {len(value)} values for {n} trials (give one value or one per trial)")
        return list(value)
    return [value] * n


def run_exchanges(reader, tags: Sequence[Sequence], channel, cmd, *, t_s, rngs: Sequence[np.random.Generator],
                  reply_bits: int, expect_crc: bool, motions: Sequence | None = None, round_index=0,
                  draw_channel: bool = True, propagation: str = "auto",
                  link_caches: Sequence[dict] | None = None) -> list[Exchange]:
    """B independent exchanges as one batch (module docstring); ``[Exchange] * B``.

    Parameters
    ----------
    reader, channel, cmd, t_s, round_index : as for :func:`rfsim.engine.run_exchange`; each
        one value for every trial or a list of B values (one per trial)
    tags : B sequences of reflectors, trial b's tags (their own state and RN16 stream)
    rngs : B generators: trial b's channel draw and receiver noise
    reply_bits, expect_crc, motions, draw_channel, propagation : as for ``run_exchange``
        (the same for every trial)
    link_caches : None or B dicts, trial b's ``link_cache``
    """
    n = len(rngs)
    if len(tags) != n:
        raise ValueError(f"tags: {len(tags)} tag lists for {n} trials (one per generator in rngs)")
    readers = _per_trial(reader, n, "reader")
    channels = _per_trial(channel, n, "channel")
    cmds = _per_trial(cmd, n, "cmd")
    times = _per_trial(t_s, n, "t_s")
    rounds = _per_trial(round_index, n, "round_index")
    caches = _per_trial(None, n, "link_caches") if link_caches is None else _per_trial(list(link_caches), n,
                                                                                       "link_caches")
    segments: dict = {}  # the reader's segment, once per distinct reader, command, time and round
    out: list = []
    for k0 in range(0, n, BLOCK):  # blocks of trials: the memory of a large batch stays bounded
        # 1. per trial: the segment, the links, the reactions (the air step without noise)
        preps, truths, inputs = [], [], []
        for b in range(k0, min(n, k0 + BLOCK)):
            key = (id(readers[b]), id(cmds[b]), float(times[b]), rounds[b])
            tx = segments.get(key)
            if tx is None:
                if len(segments) >= BLOCK:
                    segments.clear()
                tx = segments[key] = _transmit(readers[b], cmds[b], t_s=times[b], reply_bits=reply_bits,
                                               round_index=rounds[b])
            prep = _prepare(readers[b], tags[b], channels[b], cmds[b], t_s=times[b], rng=rngs[b],
                            reply_bits=reply_bits, expect_crc=expect_crc, motions=motions, round_index=rounds[b],
                            draw_channel=draw_channel, propagation=propagation, link_cache=caches[b], tx=tx)
            noise_w = prep.port.noise_power_w
            prep.port.noise_power_w = 0.0  # the noise is added below, after the block's air steps
            air = _air_step(prep, rng=None)
            prep.port.noise_power_w = noise_w
            preps.append(prep)
            truths.append(_truth(air, prep.members))
            inputs.append(air.inputs[0])
        # 2. the receiver noise of each trial, from its own generator
        noisy = []
        for k, (prep, seg) in enumerate(zip(preps, inputs)):
            y = np.array(seg.samples, dtype=np.complex128)
            if prep.port.noise_power_w > 0:
                if rngs[k0 + k] is None:
                    raise ValueError("a generator per trial is needed when the receiver has noise")
                add_awgn(y, prep.port.noise_power_w, rngs[k0 + k])
            noisy.append(Segment(seg.t0_s, seg.fs_hz, seg.fc_hz, y))
        # 3.–4. the reads of the trials with a reply, the records
        for k, prep in enumerate(preps):
            read = prep.port.receive(noisy[k]) if truths[k][0] else None
            out.append(_record(prep, truths[k], read))
    return out


#: Trials run together: their air steps, then their noise, then their reads
#: (bounds the memory of a large batch: a few segments per trial of the block).
BLOCK = 64


def singulate_batch(reader, tags: Sequence[Sequence], channel, *, t_s, rngs: Sequence[np.random.Generator],
                    query, round_index=0, motions: Sequence | None = None, epc_bits: int = 128,
                    draw_channel: bool = True) -> list[list[Exchange]]:
    """B independent singulations (:func:`rfsim.engine.singulate`) as two batches: the
    Queries of all trials, then the ACKs of the trials whose RN16 the reader accepted (each
    with the RN16 it decoded, T2 after that trial's reply). Returns per trial its exchanges
    (one or two), each bit-identical to ``singulate`` with ``rng = rngs[b]``.

    ``reader``, ``channel``, ``t_s``, ``round_index``, ``query``: one value or one per trial.
    """
    from rfsim.gen2.bits import bits_to_int
    from rfsim.gen2.commands import ACK

    n = len(rngs)
    readers = _per_trial(reader, n, "reader")
    if len({id(r) for r in readers}) < n and any(r.config.blf_search != "off" for r in readers):
        raise ValueError("reader: a reader with blf_search keeps the RN16's BLF for the ACK; give one reader per "
                         "trial")
    caches = [{} for _ in range(n)]  # each trial's Query draw, held for its ACK
    first = run_exchanges(readers, tags, channel, query, t_s=t_s, rngs=rngs, reply_bits=16, expect_crc=False,
                          motions=motions, round_index=round_index, draw_channel=draw_channel, link_caches=caches)
    go = [b for b, ex in enumerate(first) if ex.read is not None and ex.read.success]
    out = [[ex] for ex in first]
    if not go:
        return out
    channels = _per_trial(channel, n, "channel")
    rounds = _per_trial(round_index, n, "round_index")
    acks, t_acks = [], []
    for b in go:
        lk = readers[b].link
        acks.append(ACK(bits_to_int(first[b].read.bits)))
        t_acks.append(first[b].read.start_s + lk.reply_duration_s(16) + 10.0 * lk.tpri_s)
    second = run_exchanges([readers[b] for b in go], [tags[b] for b in go], [channels[b] for b in go], acks,
                           t_s=t_acks, rngs=[rngs[b] for b in go], reply_bits=epc_bits, expect_crc=True,
                           motions=motions, round_index=[rounds[b] for b in go], draw_channel=False,
                           link_caches=[caches[b] for b in go])
    for b, ex in zip(go, second):
        out[b].append(ex)
    return out


__all__ = ["run_exchanges", "singulate_batch"]

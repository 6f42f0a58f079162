"""Trial batching: B independent exchanges in one pass, each as a separate run would give it.

A Monte Carlo over exchanges (a link budget's read rate, a detection probability, a BER
curve) runs many *independent trials* of the same kind of exchange: the same devices and
command, a different channel draw, receiver noise and tag RN16 in every trial. Link-level
simulators batch such trials along a leading array dimension so that the per-call cost is
paid once per batch (Sionna's convention); here :func:`run_exchanges` does the same for the
sample-level exchange of :func:`rfsim.protocols.engine.run_exchange`, on the batched air step
:func:`propagate_batch` (B prepared steps of :func:`rfsim.air.step.propagate`, :class:`AirStep`):

1. per trial b the reader's segment (made once when every trial sends the same command at
   the same time and round), the tags' links drawn from the trial's own generator ``rngs[b]``
   (as the single run draws them, in the same order) and the tags' reactions — the air step
   :func:`rfsim.air.step.propagate` without receiver noise;
2. the receiver noise of each trial of the block (blocks of :data:`BLOCK` trials bound the
   memory), drawn from ``rngs[b]`` by :func:`rfsim.air.noise.add_awgn` with the numbers the single
   run draws there (real part then imaginary part, after the trial's link draws);
3. the reader's reads of the trials with a reply (:meth:`rfsim.devices.reader.Reader.receive`);
4. the records (:class:`rfsim.protocols.engine.Exchange`), as the single run forms them.

Each trial's record is bit-identical to ``run_exchange`` with the same devices and
``rng = rngs[b]`` (tests/test_batch.py): the same numbers are drawn from the same streams
in the same order, and every floating-point operation of the air step is the same
elementwise operation (the noise is added as ``y.real += a; y.imag += b`` there too).
Reproducibility follows the rule of :mod:`rfsim.core.rng`: trial b's stream is its own spawned
generator (e.g. ``trial_rng(seed, point, b)``), so a trial's result does not depend on the
batch it ran in, nor on B.

The air step of a batch (:func:`propagate_batch`) runs the air of every step first (emit,
links, reflections, superposition: ``propagate`` with its receivers' noise off), then each
step's receiver noise, receiver by receiver, from the step's own generator (the numbers
``propagate`` draws there: :func:`rfsim.air.noise.add_awgn` on the same sums), then the
receivers' decisions. It equals the steps run one after another by ``propagate`` whenever
that leaves the draws of every generator in their order: the air of a step draws nothing
from a generator that an earlier step drew noise from, nor from its own noise generator
after a receiver with noise. That holds when the links draw from generators of their own
(:class:`rfsim.air.step.LinkTable` with another ``rng``, held links), and for the engine's
exchange, whose one generator per trial draws the links before the noise of its one
receiver (the reader's port); a link table drawing from a noise generator otherwise is a
one-line error. Steps may share a noise generator (the queries of one trial): their noise
is drawn in step order, as the sequence of separate steps draws it.

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
from dataclasses import dataclass
from typing import Any

import numpy as np

from rfsim.air.step import AirResult, propagate
from rfsim.protocols.engine import Exchange, _ack_delays_s, _air_arguments, _prepare, _record, _transmit, _truth
from rfsim.core.errors import ConfigError
from rfsim.air.noise import add_awgn


def _per_trial(value, n: int, name: str) -> list:
    """``value`` for each of ``n`` trials: a list/tuple of n values, or one value for all."""
    if isinstance(value, (list, tuple)):
        if len(value) != n:
            raise ValueError(f"{name}: {len(value)} values for {n} trials (give one value or one per trial)")
        return list(value)
    return [value] * n


@dataclass
class AirStep:
    """One air step prepared for :func:`propagate_batch`: the arguments of
    :func:`rfsim.air.step.propagate` (the same names and meanings)."""

    emitters: Sequence
    reflectors: Sequence
    receivers: Sequence
    links: Any
    t0_s: float
    fs_hz: float
    n_samples: int
    rng: np.random.Generator | None = None
    fc_ref_hz: float | None = None
    bandwidth_hz: float | None = None
    propagation: str = "auto"
    decide: bool = True
    keep_components: bool = False


class _Quiet:
    """A receiver as the noiseless air step sees it: its antenna, carrier and coupling,
    noise power 0 (the noise is added by :func:`propagate_batch` afterwards)."""

    noise_power_w = 0.0

    def __init__(self, receiver):
        self.antenna, self.fc_hz = receiver.antenna, getattr(receiver, "fc_hz", None)
        coupling = getattr(receiver, "coupling", None)
        if coupling is not None:
            self.coupling = coupling


def propagate_batch(steps: Sequence[AirStep]) -> list[AirResult]:
    """B air steps as one batch (module docstring): the air of every step, then every
    step's receiver noise (receivers in order, from the step's ``rng``), then the
    decisions of the steps with ``decide``. Returns per step its :class:`rfsim.air.step.AirResult`,
    bit-identical to ``propagate`` of that step run after the steps before it
    (tests/test_batch.py)."""
    steps = list(steps)
    _check_noise_order(steps)
    airs = [propagate(s.emitters, s.reflectors, [_Quiet(r) for r in s.receivers], s.links, t0_s=s.t0_s,
                      fs_hz=s.fs_hz, n_samples=s.n_samples, rng=None, fc_ref_hz=s.fc_ref_hz,
                      bandwidth_hz=s.bandwidth_hz, propagation=s.propagation, decide=False,
                      keep_components=s.keep_components) for s in steps]
    for s, air in zip(steps, airs):
        for k, rcv in enumerate(s.receivers):
            noise_w = float(rcv.noise_power_w)
            if noise_w > 0:
                if s.rng is None:
                    raise ConfigError("air.rng", None, "a numpy Generator when a receiver has noise")
                ab = add_awgn(air.inputs[k].samples, noise_w, s.rng,  # the step's own sum, in place
                              keep=s.keep_components)
                if s.keep_components:
                    air.noise[k] = ab[0] + 1j * ab[1]
    for s, air in zip(steps, airs):
        if s.decide:
            air.outputs = [rcv.receive(seg) for rcv, seg in zip(s.receivers, air.inputs)]
    return airs


def _check_noise_order(steps: Sequence[AirStep]) -> None:
    """A one-line error where a step's link table draws from a noise generator in a way the
    batch would reorder (module docstring)."""
    noisy = [[k for k, r in enumerate(s.receivers) if float(r.noise_power_w) > 0] for s in steps]
    noisy_rngs = {}  # id(generator) -> index of the first step that draws noise from it
    for b, s in enumerate(steps):
        if noisy[b] and s.rng is not None:
            noisy_rngs.setdefault(id(s.rng), b)
    for b, s in enumerate(steps):
        link_rng = getattr(s.links, "rng", None)
        if link_rng is None or id(link_rng) not in noisy_rngs:
            continue
        own_last = s.rng is link_rng and noisy[b] == [len(s.receivers) - 1] and noisy_rngs[id(link_rng)] == b
        shared = sum(1 for t in steps if t.rng is link_rng) > 1
        if not own_last or shared:
            raise ValueError(f"steps[{b}].links: draws from a generator that receiver noise is drawn from; the batch "
                             "draws the noise after the links (give the links a generator of their own)")


def run_exchanges(reader, tags: Sequence[Sequence], channel, cmd, *, t_s, rngs: Sequence[np.random.Generator],
                  reply_bits: int, expect_crc: bool, motions: Sequence | None = None, round_index=0,
                  draw_channel: bool = True, propagation: str = "auto",
                  link_caches: Sequence[dict] | None = None) -> list[Exchange]:
    """B independent exchanges as one batch (module docstring); ``[Exchange] * B``.

    Parameters
    ----------
    reader, channel, cmd, t_s, round_index : as for :func:`rfsim.protocols.engine.run_exchange`; each
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
        # 1. per trial: the segment, the port, the links (the air step prepared)
        preps = []
        for b in range(k0, min(n, k0 + BLOCK)):
            key = (id(readers[b]), id(cmds[b]), float(times[b]), rounds[b])
            tx = segments.get(key)
            if tx is None:
                if len(segments) >= BLOCK:
                    segments.clear()
                tx = segments[key] = _transmit(readers[b], cmds[b], t_s=times[b], reply_bits=reply_bits,
                                               round_index=rounds[b])
            preps.append(_prepare(readers[b], tags[b], channels[b], cmds[b], t_s=times[b], rng=rngs[b],
                                  reply_bits=reply_bits, expect_crc=expect_crc, motions=motions,
                                  round_index=rounds[b], draw_channel=draw_channel, propagation=propagation,
                                  link_cache=caches[b], tx=tx))
        # 2. the air steps of the block, then their noise (each trial's own generator)
        airs = propagate_batch([AirStep(**_air_arguments(prep), rng=rngs[k0 + k]) for k, prep in enumerate(preps)])
        # 3.–4. the reads of the trials with a reply, the records
        for prep, air in zip(preps, airs):
            truth = _truth(air, prep.members)
            read = prep.port.receive(air.inputs[0]) if truth[0] else None
            out.append(_record(prep, truth, read))
    return out


#: Trials run together: their air steps, then their noise, then their reads
#: (bounds the memory of a large batch: a few segments per trial of the block).
BLOCK = 64


def singulate_batch(reader, tags: Sequence[Sequence], channel, *, t_s, rngs: Sequence[np.random.Generator],
                    query, round_index=0, motions: Sequence | None = None, epc_bits: int = 128,
                    draw_channel: bool = True) -> list[list[Exchange]]:
    """B independent singulations (:func:`rfsim.protocols.engine.singulate`) as two batches: the
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
        reply_s, t2_s = _ack_delays_s(lk)
        t_acks.append(first[b].read.start_s + reply_s + t2_s)
    second = run_exchanges([readers[b] for b in go], [tags[b] for b in go], [channels[b] for b in go], acks,
                           t_s=t_acks, rngs=[rngs[b] for b in go], reply_bits=epc_bits, expect_crc=True,
                           motions=motions, round_index=[rounds[b] for b in go], draw_channel=False,
                           link_caches=[caches[b] for b in go])
    for b, ex in zip(go, second):
        out[b].append(ex)
    return out


__all__ = ["AirStep", "propagate_batch", "run_exchanges", "singulate_batch"]

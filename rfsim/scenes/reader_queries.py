"""A reader querying one tag again and again over a held, slowly fading channel: the reads a
detection-probability campaign counts (binary-detection.md §1.6, §4 item 1; seed 004
L612-L666).

Query q at ``times_s[q]`` is one sample-level Query round (Q = 0, the link's DR, M, TRext, the
CW kept on for an RN16 reply, :func:`rfsim.gen2.link.reply_window_s`) on the hop channel the
reader is on at that instant. The links are drawn once per hop channel
(:meth:`rfsim.channels.scene.Channel.backscatter_links`, held within the dwell; the hop
spacing exceeds the coherence bandwidth of a room) and every query multiplies the held links,
both ways (reciprocal), by its gain ``h_q`` (e.g. the moving-scatterer process
:func:`rfsim.channels.small_scale.rician_gains`). Each query is one air step
(:class:`rfsim.channels.HeldLinks`, :func:`rfsim.protocols.batch.propagate_batch`, the queries in
blocks): the tag's PIE decoding and a fresh RN16 as Γ(t), the backscatter, and the reader's
port (:class:`rfsim.protocols.engine.ReaderPort`: leakage, receiver noise, decoder), which
decodes only when the tag replied, as :func:`rfsim.protocols.engine.run_exchange`. A read is
**the reader decoded the tag's RN16 exactly** (the ACK/EPC exchange and the inventoried flags
are not simulated).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rfsim.air import step as _air
from rfsim.channels import scene as _scene
from rfsim.channels.antennas import Antenna
from rfsim.devices.reader import Reader
from rfsim.devices.tag import PassiveTag
from rfsim.gen2 import commands as _commands
from rfsim.gen2 import link as _link
from rfsim.protocols import batch as _batch
from rfsim.protocols import engine as _engine

#: Queries run as one batch of air steps (bounds the memory of long runs of queries).
QUERY_BLOCK = 64


@dataclass(frozen=True)
class QueryCounts:
    """What the queries of :func:`repeated_queries` gave.

    Attributes
    ----------
    n_reads : int
        Queries whose RN16 the reader decoded exactly.
    n_replied : int
        Queries the tag answered.
    n_powered : int
        Queries in which the tag was powered.
    max_incident_power_dbm : float
        Largest CW power incident at the tag antenna port [dBm].
    n_channels : int
        Hop channels visited.
    channel_index : int
        1-based hop channel of the last query.
    frequency_hz : float
        Carrier of the last query [Hz].
    """

    n_reads: int
    n_replied: int
    n_powered: int
    max_incident_power_dbm: float
    n_channels: int
    channel_index: int
    frequency_hz: float


def repeated_queries(reader: Reader, tag: PassiveTag, reader_antenna: Antenna, channel: _scene.Channel, times_s,
                     gains, *, channel_rng: np.random.Generator, noise_rng: np.random.Generator,
                     query_block: int = QUERY_BLOCK) -> QueryCounts:
    """Query the tag at ``times_s`` over the held links times ``gains`` and count the reads.

    Each query is a Q = 0 Query round on the hop channel of its instant; a read is the
    reader decoding the tag's RN16 exactly (module docstring).

    Parameters
    ----------
    reader : rfsim.devices.reader.Reader
        The reader (its hop table sets each query's channel).
    tag : rfsim.devices.tag.PassiveTag
        The tag (its state carries from one query to the next).
    reader_antenna : rfsim.channels.antennas.Antenna
        The reader's antenna.
    channel : rfsim.channels.scene.Channel
        The scene's channel.
    times_s : array_like of float, shape (N,)
        Query instants [s], N ≥ 1.
    gains : array_like of complex, shape (N,)
        Per-query gain of the held links (both ways) [linear, amplitude].
    channel_rng : numpy.random.Generator
        Draws the links, once per hop channel (held within the dwell).
    noise_rng : numpy.random.Generator
        The reader port's receiver noise, drawn query by query.
    query_block : int, optional
        Queries per batch of air steps, default :data:`QUERY_BLOCK` (the results do not
        depend on it).

    Returns
    -------
    QueryCounts
        The counts of reads, replies and powered queries, and the channels visited.
    """
    lk = reader.link
    q = _commands.Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0)
    ant, tag_ant = reader_antenna, tag.antenna
    drawn: dict = {}  # one link draw per hop channel (held within the dwell)
    channels = set()

    def query_step(j: int) -> tuple:
        # query j at t_j: the reader's segment on the channel of t_j; the held links of that
        # channel times the gain h_j, both ways (reciprocal); one air step (reader port:
        # leakage, backscatter, receiver noise from noise_rng every query)
        t_j = float(times_s[j])
        seg = reader.transmit(q, t0_s=t_j, cw_after_s=_link.reply_window_s(lk, 16))
        channels.add(seg.channel_index)
        if seg.fc_hz not in drawn:
            drawn[seg.fc_hz] = channel.backscatter_links(ant, tag_ant, fc_hz=seg.fc_hz, rng=channel_rng)
        fwd, bwd = drawn[seg.fc_hz]
        links = _scene.HeldLinks([(ant, tag_ant, replace(fwd, gain=fwd.gain * gains[j])),
                                  (tag_ant, ant, replace(bwd, gain=bwd.gain * gains[j]))])
        port = _engine.ReaderPort(reader, ant, seg, reply_bits=16, expect_crc=False)
        return seg, _batch.AirStep([_air.FixedEmitter(ant, seg, device=reader)], [tag], [port], links, t0_s=t_j,
                                   fs_hz=seg.fs_hz, n_samples=seg.samples.size, rng=noise_rng,
                                   bandwidth_hz=2.0 * lk.blf_hz, decide=False)

    # the queries in blocks: their air steps in query order (the tag's state carried from one
    # to the next), then their noise from noise_rng in query order, then the reads
    n_reads = n_replied = n_powered = 0
    p_inc = -np.inf
    n = len(times_s)
    for j0 in range(0, n, query_block):
        txs, steps = zip(*[query_step(j) for j in range(j0, min(n, j0 + query_block))])
        for step, air in zip(steps, _batch.propagate_batch(steps)):
            resp = air.reflections[0]
            p_inc = max(p_inc, float(resp.incident_power_dbm))
            n_powered += bool(resp.powered)
            if resp.gamma is None:
                continue  # nothing to decode (the engine's reader listens only when a tag replied)
            n_replied += 1
            read = step.receivers[0].receive(air.inputs[0])
            n_reads += bool(read.bits is not None and read.success
                            and np.array_equal(read.bits, np.asarray(resp.reply.bits, np.uint8)))
    tx = txs[-1]  # the last query's segment
    return QueryCounts(n_reads, n_replied, n_powered, p_inc, len(channels), tx.channel_index, tx.fc_hz)


__all__ = ["QUERY_BLOCK", "QueryCounts", "repeated_queries"]

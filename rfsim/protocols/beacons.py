"""Beacon MAC of active tags: listen-before-talk, collisions, reception through the air step.

The protocol layer of the one-way active-RFID link (rssi-localization.md §2.1, seeds/002
L1768–L1775; DESIGN.md "The air interface": autonomous packet schedules sit on top of the
air step). Tags (``rfsim.devices.ActiveTag`` or anything with ``antenna``, ``config`` with
``lbt_listen_s``, ``lbt_threshold_dbm``, ``backoff_max_s``, ``max_attempts``, ``burst_s``,
``due_times``, ``next_seq``, ``send``, ``clear``, ``emit``) and receivers (``rfsim.devices.ActiveReader``)
meet a channel's links (:class:`rfsim.air.step.LinkTable`) here:

1. **Due beacons.** Every tag's due times in [t0, t1) (``tag.due_times``) enter one event
   queue, in time order (ties: tag order).
2. **Listen-before-talk.** At a due time t the tag listens over [t − T_LBT, t). If no decided
   burst of another tag overlaps that window the channel is idle (only receiver noise, far
   below any threshold that matters: silent gaps are not sampled). Otherwise one air step
   over the window, with the overlapping tags as emitters and the listening tag's antenna as
   the receiver (noise-free energy detection), gives the mean received power; above
   ``lbt_threshold_dbm`` the channel is busy: the attempt moves to t + U(0, backoff_max) or,
   after ``max_attempts``, the beacon is dropped (``lbt_dropped``). Tags that start within
   less than the listening time of each other can both find the channel idle: that is how
   beacons still collide.
3. **Reception.** Decided bursts are grouped into clusters of bursts overlapping in time
   (with ``margin_s`` on both sides); every cluster is one air step with its tags as
   emitters and every receiver listening: each receiver decodes what it can (a collision
   fails the CRC or is captured by the stronger beacon).

Randomness: due-time jitter, back-offs and oscillator phases come from the tags' own
generators; the receiver noise of cluster c from ``rng`` in cluster order.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np

from rfsim.air.step import AntennaPort, propagate
from rfsim.core.errors import ConfigError
from rfsim.core.units import w_to_dbm


@dataclass(frozen=True)
class BurstRecord:
    """One due beacon and what became of it.

    Attributes
    ----------
    tag : int
        Index of the tag.
    due_s : float
        Due time [s].
    t_s : float
        Start time of the burst [s]; NaN when it was dropped.
    attempts : int
        Listen-before-talk attempts made.
    seq : int
        Sequence number of the beacon.
    lbt_dropped : bool
        Whether listen-before-talk dropped it (after ``max_attempts``).
    collided : bool
        Whether it overlaps another tag's burst.
    """

    tag: int
    due_s: float
    t_s: float
    attempts: int
    seq: int
    lbt_dropped: bool
    collided: bool


@dataclass
class BeaconRun:
    """What :func:`run_beacons` produced.

    Attributes
    ----------
    bursts : list of BurstRecord
        One per due beacon, in start order.
    reads : list of list
        Per receiver, the list of its beacon reads.
    steps : int
        Air steps of reception.
    lbt_steps : int
        Air steps of carrier sensing.
    """

    bursts: list = field(default_factory=list)
    reads: list = field(default_factory=list)
    steps: int = 0
    lbt_steps: int = 0


def _overlapping(decided, t_a, t_b, exclude):
    return [(k, tb) for k, tb, dur in decided if k != exclude and tb < t_b and tb + dur > t_a]


def sense_power_dbm(tags, listener, links, *, t0_s: float, t1_s: float, fs_hz: float) -> float:
    r"""Mean power an antenna receives from a set of tags over a time window.

    One noise-free air step (:func:`rfsim.air.step.propagate`) over [t0, t1):
    :math:`P = \frac{1}{n}\sum_i |y_i|^2` with n = round((t1 − t0)·fs) ≥ 1 samples.

    Parameters
    ----------
    tags : sequence
        The emitting tags (their decided bursts).
    listener : object
        The listening device (its ``antenna`` and ``fc_hz``).
    links : Links
        The channel side of the air step (:class:`rfsim.air.step.LinkTable`).
    t0_s, t1_s : float
        The window [s].
    fs_hz : float
        Sample rate of the step [Hz].

    Returns
    -------
    float
        Mean received power [dBm]; −inf when nothing arrives.
    """
    n = max(1, int(round((t1_s - t0_s) * fs_hz)))
    port = AntennaPort(listener.antenna, 0.0, fc_hz=listener.fc_hz)
    res = propagate(tags, [], [port], links, t0_s=t0_s, fs_hz=fs_hz, n_samples=n, decide=False)
    p = float(np.mean(np.abs(res.inputs[0].samples) ** 2))
    return float(w_to_dbm(p)) if p > 0 else -math.inf


def run_beacons(tags, receivers, links, *, t0_s: float, t1_s: float, fs_hz: float,
                rng: np.random.Generator, offsets_s=None, margin_s: float = 50e-6) -> BeaconRun:
    """Schedule, sense and receive every beacon due in [t0, t1) (module docstring).

    Parameters
    ----------
    tags : sequence
        Active tags (their decided bursts are cleared first).
    receivers : sequence
        Receivers (``rfsim.devices.ActiveReader``), all at ``fs_hz``.
    links : Links
        The channel side of the air step (:class:`rfsim.air.step.LinkTable`).
    t0_s, t1_s : float
        Time window of due beacons [s].
    fs_hz : float
        Sample rate of the air steps [Hz].
    rng : numpy.random.Generator
        Generator of the receiver noise (keyword-only).
    offsets_s : array_like, optional
        Per tag the phase of its schedule [s] (default 0).
    margin_s : float, default 50e-6
        Silence kept before and after every reception cluster [s].

    Returns
    -------
    BeaconRun
        Per due beacon its record, per receiver its reads, and the number of air steps.

    Raises
    ------
    ConfigError
        No tags or no receivers.
    """
    tags, receivers = list(tags), list(receivers)
    if not tags:
        raise ConfigError("beacons.tags", [], "at least one active tag")
    if not receivers:
        raise ConfigError("beacons.receivers", [], "at least one reader")
    offsets = np.zeros(len(tags)) if offsets_s is None else np.asarray(offsets_s, float)
    out = BeaconRun(reads=[[] for _ in receivers])
    queue = []
    for i, tag in enumerate(tags):
        tag.clear()
        for t in tag.due_times(t0_s, t1_s, float(offsets[i])):
            heapq.heappush(queue, (float(t), i, float(t), 1))
    decided = []    # (tag, start, duration)
    records = []
    while queue:
        t, i, due, attempt = heapq.heappop(queue)
        tag = tags[i]
        cfg = tag.config
        listen = cfg.lbt_listen_s
        busy = False
        if listen > 0:
            near = _overlapping(decided, t - listen, t, i)
            if near:
                out.lbt_steps += 1
                emitters = [tags[k] for k in sorted({k for k, _ in near})]
                busy = sense_power_dbm(emitters, tag, links, t0_s=t - listen, t1_s=t, fs_hz=fs_hz) > cfg.lbt_threshold_dbm
        if busy:
            if attempt < cfg.max_attempts:
                heapq.heappush(queue, (t + float(tag.rng.uniform(0.0, cfg.backoff_max_s)), i, due, attempt + 1))
            else:
                records.append((i, due, math.nan, attempt, -1, True))
            continue
        seq = tag.next_seq()
        tag.send(t, seq)
        decided.append((i, t, tag.burst_s))
        records.append((i, due, t, attempt, seq, False))
    # collisions: bursts of different tags overlapping in time
    spans = sorted(decided, key=lambda r: r[1])
    collided = set()
    for a in range(len(spans)):
        for b in range(a + 1, len(spans)):
            if spans[b][1] >= spans[a][1] + spans[a][2]:
                break
            if spans[b][0] != spans[a][0]:
                collided.update({(spans[a][0], spans[a][1]), (spans[b][0], spans[b][1])})
    out.bursts = sorted((BurstRecord(i, due, ts, att, seq, dropped, (i, ts) in collided)
                         for i, due, ts, att, seq, dropped in records),
                        key=lambda r: (math.inf if math.isnan(r.t_s) else r.t_s, r.tag))
    # reception: one air step per cluster of overlapping bursts
    cluster = []
    end = -math.inf
    for k, tb, dur in spans + [(None, math.inf, 0.0)]:
        if cluster and tb - margin_s > end + margin_s:
            start = min(c[1] for c in cluster) - margin_s
            n = int(math.ceil((end + margin_s - start) * fs_hz))
            emitters = [tags[j] for j in sorted({c[0] for c in cluster})]
            res = propagate(emitters, [], receivers, links, t0_s=start, fs_hz=fs_hz, n_samples=n, rng=rng)
            out.steps += 1
            for r, reads in enumerate(res.outputs):
                out.reads[r].extend(reads)
            cluster, end = [], -math.inf
        if k is not None:
            cluster.append((k, tb, dur))
            end = max(end, tb + dur)
    return out


__all__ = ["BurstRecord", "BeaconRun", "run_beacons", "sense_power_dbm"]

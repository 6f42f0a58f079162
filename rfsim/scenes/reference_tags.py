"""Reference tags that broadcast in slots, powered by an exciter, and a mobile tag that listens:
the sample-level scene of the reader-free tag-to-tag network (Geng ch. 6; wave2-specs.md §X).

Scene of one slot: the exciter (CW, 3.28 W EIRP at 915 MHz, vertical dipole at ``exciter_xyz``)
powers every broadcasting reference tag (the PASS UCODE-class chip of
:mod:`rfsim.devices.tag_chip`: power-up at picmin + 2.5 dB, reflection states following its
absorbed power); each sends its 16-bit index and CRC-16 (32 bits, Miller-2 with pilot at
48 kHz) from the slot start (:class:`rfsim.devices.own_schedule.OwnSchedule`); the mobile tag
listens with the single-antenna sense-a-tag chain (detector, band-pass, comparator, Miller
decoder; :mod:`rfsim.devices.st_receiver`) and receiver noise kT·fs·F. Friis + the exponential
APDP (PASS ST-room curves), one channel draw per slot. Frames of one slot superpose at the
listener's antenna (first-order backscatter, :func:`rfsim.air.step.propagate`): the slot is
decoded as the tag whose 32 bits come out exactly, so a collision is lost unless one frame
dominates (capture).

Range calibration (wave2-specs.md §X: "calibrate p = 0.5 at r for the median d_exciter and report
the spread"): the backscatter at the listener falls with d_tt, so the decoding distance grows as
the comparator threshold falls. :func:`calibrate_threshold` bisects (in log V) the threshold at
which the mobile tag decodes half of ``calibration_positions`` listener positions at distance r
(uniform azimuth) around the reference tag at the median exciter distance, one channel draw
per position; the decode fraction at r over all tags is returned as the spread.

Events: (listener position, sending tags) per slot; slots are grouped by their set of senders,
and each group is one air step with all its listener positions as a batched receiver
(:func:`decode_events`, :func:`decode_slots`).

Measured in the scenario ``tag-to-tag-tracking`` with ``range_model = "physical"`` and
``collision_model = "physical"`` (10 trajectories × 10 runs, seed 1): the physical range is
soft — P(decode) ≈ 0.8 within 1 m (the single-antenna listener's phase cancellation, AURIS
ch. 3), ≈ 0.5 at r, still 0.05-0.4 up to r + 0.5 m, and 0.2-0.6 at r over the ten tags
(attributes ``physical_p_at_r*``) — so NN grows (1.34/1.47/1.61 m), fewer decodes arrive
(3.2/4.1/5.0 per s against 3.4/5.4/7.0 with the disc) and the PF30 error is flat in r
(0.53 m); physical collisions keep 10-17 % of the collided broadcasts (capture of a dominant
frame), which adds ≈ 5 % decodes to the loss model and leaves the errors within their
Monte-Carlo spread.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from rfsim.core.config import param
from rfsim.core.lazy import lazy_import
from rfsim.detection.tag_to_tag import in_range
from rfsim.devices.exciter import Exciter, ExciterConfig
from rfsim.devices.own_schedule import FrameConfig, OwnSchedule, build_frame
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.st_rows import RowsChain
from rfsim.scenes.exciter import NoiseConfig, measured_tag, room, single_listener
from rfsim.scenes.links import BatchAntenna, DrawnLinks, add_drawn_link

_antennas = lazy_import("rfsim.channels.antennas")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
_air = lazy_import("rfsim.air.step")
_bits = lazy_import("rfsim.gen2.bits")
_crc = lazy_import("rfsim.gen2.crc")


@dataclass(frozen=True)
class ReferenceTagsConfig:
    """The sample-level scene of the reference tags and the listening mobile tag."""

    height_m: float = param(1.0, lo=0.1, hi=10.0, unit="m", doc="height of the tags and the mobile tag")
    calibration_positions: int = param(80, lo=4, hi=100000, doc="listener positions of the threshold calibration")
    max_distance_factor: float = param(3.0, lo=1.0, hi=100.0,
                                       doc="slots whose nearest sender is beyond this × r are not simulated "
                                           "(counted as not decoded)")
    apdp: bool = param(True, doc="exponential APDP small scale (PASS ST-room curves)")
    exciter: ExciterConfig = param(ExciterConfig(), doc="RF exciter (CW)")
    frame: FrameConfig = param(FrameConfig(), doc="the reference tags' frame")
    listener: SenseATagConfig = param(single_listener(), doc="the mobile tag's receive chain")
    noise: NoiseConfig = param(NoiseConfig(), doc="receiver noise at the mobile tag")


def payload(tag: int) -> np.ndarray:
    """Return the 32 bits a reference tag broadcasts: its 16-bit index and CRC-16.

    Parameters
    ----------
    tag : int
        Index of the reference tag, 0 ≤ tag < 2**16.

    Returns
    -------
    ndarray of uint8, shape (32,)
        The index (MSB first) followed by its CRC-16 (EPC Gen2 CRC-16, :mod:`rfsim.gen2.crc`).
    """
    return _crc.append_crc16(_bits.int_to_bits(int(tag), 16))


def listener_inputs(config: ReferenceTagsConfig, exciter_xyz, tags_xy, senders, listeners_xy,
                    rng: np.random.Generator):
    """Run one air step: ``senders`` broadcast together, the mobile tag listens at n positions.

    The listeners form one batched receiver with narrowband links; a batch holding a link that
    needs exact delays (:class:`rfsim.scenes.links.BatchLink`) is split in halves, down to
    single listeners on exact path sets.

    Parameters
    ----------
    config : ReferenceTagsConfig
        The scene's settings.
    exciter_xyz : array_like, shape (3,)
        Position of the exciter [m].
    tags_xy : array_like, shape (n_tags, 2)
        Positions (x, y) of the reference tags [m] (at ``config.height_m``).
    senders : sequence of int
        Indices of the broadcasting tags.
    listeners_xy : array_like, shape (n, 2)
        Positions (x, y) of the listening mobile tag [m].
    rng : numpy.random.Generator
        Draws the links (exciter → listeners, then per sender exciter → tag and tag →
        listeners), the tags' streams and the noise.

    Returns
    -------
    inputs : ndarray of complex, shape (n, n_samples)
        The listener's input at each position [√W].
    frames : list
        The senders' frames (:func:`rfsim.devices.own_schedule.build_frame`), in sender order.
    """
    fr = config.frame
    lis_pos = np.column_stack([np.asarray(listeners_xy, float), np.full(len(listeners_xy), config.height_m)])
    frames = [build_frame(payload(i), fr, stamp_cycles=0) for i in senders]
    return _inputs(config, exciter_xyz, tags_xy, senders, frames, lis_pos, rng), frames


def _inputs(config, exciter_xyz, tags_xy, senders, frames, lis_pos, rng) -> np.ndarray:
    h, fr = config.height_m, config.frame
    n_samples = frames[0].n_samples
    ex_ant = _antennas.vertical_dipole(np.asarray(exciter_xyz, float))
    exciter = Exciter(config.exciter, ex_ant)
    sc, fc = room(config.apdp), config.exciter.fc_hz
    single = lis_pos.shape[0] == 1
    links = DrawnLinks()
    lis = (_antennas.vertical_dipole(lis_pos[0]) if single
           else BatchAntenna(_antennas.vertical_dipole(np.zeros(3)), lis_pos))
    add_drawn_link(links, sc, ex_ant, lis, fc_hz=fc, rng=rng)
    reflectors = []
    for i, frame in zip(senders, frames):
        ant = _antennas.vertical_dipole(np.array([tags_xy[i][0], tags_xy[i][1], h]))
        reflectors.append(OwnSchedule(measured_tag(ant, rng=rng), frame))
        add_drawn_link(links, sc, ex_ant, ant, fc_hz=fc, rng=rng)
        add_drawn_link(links, sc, ant, lis, fc_hz=fc, rng=rng)
    try:
        air = _air.propagate([exciter], reflectors, [_air.AntennaPort(lis, noise_power_w=config.noise.power_w(fr.fs_hz))],
                             links, t0_s=0.0, fs_hz=fr.fs_hz, n_samples=n_samples, rng=rng,
                             bandwidth_hz=2.0 * fr.blf_hz, decide=False)
    except ValueError as err:
        if single or "narrowband" not in str(err):
            raise
        half = lis_pos.shape[0] // 2
        return np.concatenate([_inputs(config, exciter_xyz, tags_xy, senders, frames, lis_pos[:half], rng),
                               _inputs(config, exciter_xyz, tags_xy, senders, frames, lis_pos[half:], rng)])
    return np.broadcast_to(air.inputs[0].samples, (lis_pos.shape[0], n_samples))


def decode_rows(config: ReferenceTagsConfig, x, frames, senders, threshold_v: float) -> np.ndarray:
    """Decode each listener input with the mobile tag's receive chain.

    Parameters
    ----------
    config : ReferenceTagsConfig
        The scene's settings.
    x : ndarray of complex, shape (n, n_samples)
        Listener inputs (:func:`listener_inputs`) [√W].
    frames : list
        The senders' frames.
    senders : sequence of int
        Tag index of each frame.
    threshold_v : float
        Comparator threshold of the chain [V].

    Returns
    -------
    ndarray of int64, shape (n,)
        The sender whose 32 bits come out exactly in each row
        (:meth:`rfsim.devices.st_rows.RowsChain.matched`), −1 for none.
    """
    fr = config.frame
    listener = dataclasses.replace(config.listener, threshold_v=float(threshold_v))
    rx = _sense_a_tag.make_receiver(listener, fs_hz=fr.fs_hz, blf_hz=fr.blf_hz, m=fr.m, trext=fr.trext)
    j = RowsChain.run(rx, x).matched(rx, frames)
    return np.where(j >= 0, np.asarray(senders, dtype=np.int64)[np.maximum(j, 0)], -1)


def calibrate_threshold(config: ReferenceTagsConfig, exciter_xyz, tags_xy, range_m: float,
                        rng: np.random.Generator) -> tuple[float, float, float]:
    """Calibrate the listener threshold at which a tag is decoded at ``range_m`` half of the time.

    The tag is the one at the median exciter distance. Bisection in log V over [1e-7, 1] V,
    14 steps, on ``config.calibration_positions`` listener positions at distance r (uniform
    azimuth) around each tag (module docstring).

    Parameters
    ----------
    config : ReferenceTagsConfig
        The scene's settings.
    exciter_xyz : array_like, shape (3,)
        Position of the exciter [m].
    tags_xy : array_like, shape (n_tags, 2)
        Positions (x, y) of the reference tags [m] (at ``config.height_m``).
    range_m : float
        The calibration range r [m].
    rng : numpy.random.Generator
        Draws the azimuths, then every tag's links, streams and noise.

    Returns
    -------
    threshold_v : float
        The threshold [V].
    min_fraction : float
        Smallest decode fraction at r over all tags at that threshold.
    max_fraction : float
        Largest decode fraction at r over all tags at that threshold.
    """
    tags = np.asarray(tags_xy, float)
    n = config.calibration_positions
    d_e = np.hypot(np.hypot(tags[:, 0] - exciter_xyz[0], tags[:, 1] - exciter_xyz[1]), exciter_xyz[2] - config.height_m)
    ref = int(np.argsort(d_e)[(tags.shape[0] - 1) // 2])
    phi = rng.uniform(-np.pi, np.pi, (tags.shape[0], n))
    inputs = []
    for i in range(tags.shape[0]):
        lis = tags[i] + range_m * np.column_stack([np.cos(phi[i]), np.sin(phi[i])])
        inputs.append(listener_inputs(config, exciter_xyz, tags, (i,), lis, rng))
    lo, hi = np.log(1e-7), np.log(1.0)
    x, frames = inputs[ref]
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        frac = np.mean(decode_rows(config, x, frames, (ref,), np.exp(mid)) == ref)
        lo, hi = (lo, mid) if frac < 0.5 else (mid, hi)
    th = float(np.exp(0.5 * (lo + hi)))
    fr = [np.mean(decode_rows(config, x, f, (i,), th) == i) for i, (x, f) in enumerate(inputs)]
    return th, float(np.min(fr)), float(np.max(fr))


def decode_events(config: ReferenceTagsConfig, exciter_xyz, tags_xy, slot_senders, listeners_xy, range_m: float,
                  threshold_v: float, rng: np.random.Generator) -> np.ndarray:
    """Decode events (listener position, sending tags) at sample level.

    Events with the same set of senders are one air step with a batched receiver
    (:func:`listener_inputs`), groups in sorted order. Events beyond
    ``config.max_distance_factor``·r of every sender are not simulated (not decoded).

    Parameters
    ----------
    config : ReferenceTagsConfig
        The scene's settings.
    exciter_xyz : array_like, shape (3,)
        Position of the exciter [m].
    tags_xy : array_like, shape (n_tags, 2)
        Positions (x, y) of the reference tags [m] (at ``config.height_m``).
    slot_senders : sequence of tuple of int
        One tuple of sender indices per event.
    listeners_xy : array_like, shape (n_events, 2)
        The mobile tag's position at each event [m].
    range_m : float
        The range r [m].
    threshold_v : float
        Comparator threshold of the listener [V].
    rng : numpy.random.Generator
        Draws every group's links, streams and noise.

    Returns
    -------
    ndarray of int64, shape (n_events,)
        Decoded tag per event, −1 for none.
    """
    tags = np.asarray(tags_xy, float)
    lis = np.asarray(listeners_xy, float)
    out = np.full(len(slot_senders), -1, dtype=np.int64)
    near = np.array([np.min(np.linalg.norm(tags[list(s)] - p, axis=1)) <= config.max_distance_factor * range_m
                     for s, p in zip(slot_senders, lis)], dtype=bool)
    groups: dict[tuple, list[int]] = {}
    for e in np.flatnonzero(near):
        groups.setdefault(tuple(sorted(slot_senders[e])), []).append(int(e))
    for senders in sorted(groups):
        idx = np.asarray(groups[senders])
        x, frames = listener_inputs(config, exciter_xyz, tags, senders, lis[idx], rng)
        out[idx] = decode_rows(config, x, frames, senders, threshold_v)
    return out


def decode_slots(config: ReferenceTagsConfig, exciter_xyz, tags_xy, broadcasts, positions_xy, slots, *,
                 n_slots: int, range_m: float, threshold_v: float, rng: np.random.Generator) -> np.ndarray:
    """Decode the broadcasts marked in ``slots`` at sample level.

    Each marked slot is one event (its senders, the mobile tag where it is at the first of
    them, :func:`decode_events`); a slot decodes as at most one of its senders.

    Parameters
    ----------
    config : ReferenceTagsConfig
        The scene's settings.
    exciter_xyz : array_like, shape (3,)
        Position of the exciter [m].
    tags_xy : array_like, shape (n_tags, 2)
        Positions (x, y) of the reference tags [m] (at ``config.height_m``).
    broadcasts : dict of str to ndarray
        The columns ``period``, ``slot``, ``tag`` of
        :func:`rfsim.protocols.tag_to_tag.aloha_schedule`, n broadcasts.
    positions_xy : ndarray, shape (n, 2)
        The mobile tag at each broadcast [m].
    slots : ndarray of bool, shape (n,)
        Broadcasts to simulate (their whole slots are).
    n_slots : int
        Slots per period.
    range_m : float
        The range r [m].
    threshold_v : float
        Comparator threshold of the listener [V].
    rng : numpy.random.Generator
        Draws the events' links, streams and noise.

    Returns
    -------
    ndarray of bool, shape (n,)
        Decoded, per broadcast (False where ``slots`` is False).
    """
    b = broadcasts
    key = b["period"] * n_slots + b["slot"]
    uniq, first = np.unique(key[slots], return_index=True)
    members = [tuple(b["tag"][slots][key[slots] == k]) for k in uniq]
    where = positions_xy[np.flatnonzero(slots)[first]]
    got = decode_events(config, exciter_xyz, tags_xy, members, where, range_m, threshold_v, rng)
    won = dict(zip(uniq.tolist(), got.tolist()))
    return np.array([won.get(int(k), -1) == t for k, t in zip(key, b["tag"])]) & slots


def receive_broadcasts(config: ReferenceTagsConfig, exciter_xyz, tags_xy, broadcasts, positions_xy, distance_m, *,
                       range_model: str, collision_model: str, range_m: float, a1: float, a2: float, n_slots: int,
                       threshold_v: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Decide which broadcasts reach the mobile tag and which it decodes.

    Parameters
    ----------
    config : ReferenceTagsConfig
        The scene's settings.
    exciter_xyz : array_like, shape (3,)
        Position of the exciter [m].
    tags_xy : array_like, shape (n_tags, 2)
        Positions (x, y) of the reference tags [m] (at ``config.height_m``).
    broadcasts : dict of str to ndarray
        The columns of :func:`rfsim.protocols.tag_to_tag.aloha_schedule` (``period``,
        ``slot``, ``tag``, ``n_in_slot``), n broadcasts.
    positions_xy : ndarray, shape (n, 2)
        The mobile tag at each broadcast [m].
    distance_m : ndarray, shape (n,)
        Distance from the sender to the mobile tag [m] (the statistical range models).
    range_model : {"disc", "logistic", "physical"}
        "disc" or "logistic": :func:`rfsim.detection.tag_to_tag.in_range` (Geng Eq. (6.5)
        with ``a1``, ``a2``); "physical": every slot at sample level (:func:`decode_slots`).
    collision_model : {"loss", "physical"}
        "loss": a collided broadcast is lost (seeds/004 L1084); "physical": collided slots
        at sample level (the strongest frame may still decode).
    range_m : float
        The range r [m].
    a1 : float
        Coefficient a1 of Eq. (6.5).
    a2 : float
        Coefficient a2 of Eq. (6.5).
    n_slots : int
        Slots per period.
    threshold_v : float
        Listener threshold of the physical models [V].
    rng : numpy.random.Generator
        Draws the statistical range model, then the sample-level slots.

    Returns
    -------
    reached : ndarray of bool, shape (n,)
        Whether the mobile tag would decode the broadcast alone (with ``range_model =
        "physical"``: whether it decoded it).
    decoded : ndarray of bool, shape (n,)
        Whether it decoded it.
    """
    single = broadcasts["n_in_slot"] == 1
    if range_model != "physical":
        reach = in_range(distance_m, model=range_model, range_m=range_m, a1=a1, a2=a2, rng=rng)
        decoded = reach & single
        slots = ~single if collision_model == "physical" else np.zeros_like(single)
    else:
        reach = np.zeros_like(single)
        decoded = np.zeros_like(single)
        slots = np.ones_like(single)
    if slots.any():
        hit = decode_slots(config, exciter_xyz, tags_xy, broadcasts, positions_xy, slots, n_slots=n_slots,
                           range_m=range_m, threshold_v=threshold_v, rng=rng)
        decoded = decoded | hit
        if range_model == "physical":
            reach = hit
    return reach, decoded


__all__ = ["ReferenceTagsConfig", "payload", "listener_inputs", "decode_rows", "calibrate_threshold",
           "decode_events", "decode_slots", "receive_broadcasts"]

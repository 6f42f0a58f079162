"""Sample-level decoding for ``tag-to-tag-tracking``: the broadcasts of a slot go through the air
interface and the mobile tag's receive chain (``range_model = "physical"``, and collided slots
with ``collision_model = "physical"``).

Scene of one slot (as in ``exciter-link``; wave2-specs.md §X): the exciter (CW, 3.28 W EIRP at
915 MHz, vertical dipole at ``layout.exciter_xyz_m``) powers every broadcasting reference tag
(the PASS UCODE-class chip of :mod:`rfsim.devices.tag_chip`: power-up at picmin + 2.5 dB, reflection
states following its absorbed power); each sends its 16-bit index and CRC-16 (32 bits,
Miller-2 with pilot at 48 kHz) from the slot start (:class:`rfsim.scenarios._exciter_scene.OwnSchedule`);
the mobile tag listens with the single-antenna sense-a-tag chain (detector, band-pass,
comparator, Miller decoder; :mod:`rfsim.devices.st_receiver`) and receiver noise kT·fs·F. Friis +
the exponential APDP (PASS ST-room curves), one channel draw per slot. Frames of one slot
superpose at the listener's antenna (first-order backscatter, :func:`rfsim.air.step.propagate`): the
slot is decoded as the tag whose 32 bits come out exactly, so a collision is lost unless one
frame dominates (capture).

Range calibration (wave2-specs.md §X: "calibrate p = 0.5 at r for the median d_exciter and report
the spread"): the backscatter at the listener falls with d_tt, so the decoding distance grows as
the comparator threshold falls. :func:`calibrate_threshold` bisects (in log V) the threshold at
which the mobile tag decodes half of ``calibration_positions`` listener positions at distance r
(uniform azimuth) around the reference tag at the median exciter distance, one channel draw
per position; the decode fraction at r over all tags is returned as the spread.

Events: (listener position, sending tags) per slot; slots are grouped by their set of senders,
and each group is one air step with all its listener positions as a batched receiver.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from rfsim.devices.exciter import Exciter, ExciterConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.core.config import param
from rfsim.scenarios._exciter_scene import (BatchAntenna, BatchLink, DrawnLinks, FrameConfig, NoiseConfig, OwnSchedule,
                                      RowsChain, build_frame, room)
from rfsim.core.lazy import lazy_import

_antennas = lazy_import("rfsim.channels.antennas")
_bulk = lazy_import("rfsim.channels.bulk")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
_tag = lazy_import("rfsim.devices.tag")
_tag_chip = lazy_import("rfsim.devices.tag_chip")
_air = lazy_import("rfsim.air.step")
_bits = lazy_import("rfsim.gen2.bits")
_crc = lazy_import("rfsim.gen2.crc")
_linecode = lazy_import("rfsim.gen2.linecode")


def _listener_default() -> SenseATagConfig:
    return SenseATagConfig(n_antennas=1, technique="single")


@dataclass(frozen=True)
class PhysicalConfig:
    height_m: float = param(1.0, lo=0.1, hi=10.0, unit="m", doc="height of the tags and the mobile tag")
    calibration_positions: int = param(80, lo=4, hi=100000, doc="listener positions of the threshold calibration")
    max_distance_factor: float = param(3.0, lo=1.0, hi=100.0,
                                       doc="slots whose nearest sender is beyond this × r are not simulated "
                                           "(counted as not decoded)")
    apdp: bool = param(True, doc="exponential APDP small scale (PASS ST-room curves)")
    exciter: ExciterConfig = param(ExciterConfig(), doc="RF exciter (CW)")
    frame: FrameConfig = param(FrameConfig(), doc="the reference tags' frame")
    listener: SenseATagConfig = param(_listener_default(), doc="the mobile tag's receive chain")
    noise: NoiseConfig = param(NoiseConfig(), doc="receiver noise at the mobile tag")


def payload(tag: int) -> np.ndarray:
    """32 bits a reference tag broadcasts: its 16-bit index and CRC-16."""
    return _crc.append_crc16(_bits.int_to_bits(int(tag), 16))


def listener_inputs(config: PhysicalConfig, exciter_xyz, tags_xy, senders, listeners_xy, rng: np.random.Generator):
    """One air step: ``senders`` (tag indices) broadcast together, the mobile tag listens at each of
    ``listeners_xy (n, 2)``. Returns the listener inputs (n, samples) and the frames.

    The listeners form one batched receiver with narrowband links; a batch holding a link that
    needs exact delays (:class:`rfsim.scenarios._exciter_scene.BatchLink`) is split in halves, down to
    single listeners on exact path sets."""
    fr = config.frame
    lis_pos = np.column_stack([np.asarray(listeners_xy, float), np.full(len(listeners_xy), config.height_m)])
    frames = [build_frame(payload(i), fr, stamp_cycles=0) for i in senders]
    return _inputs(config, exciter_xyz, tags_xy, senders, frames, lis_pos, rng), frames


def _inputs(config, exciter_xyz, tags_xy, senders, frames, lis_pos, rng) -> np.ndarray:
    h, fr = config.height_m, config.frame
    n_samples = frames[0].n_samples
    ex_ant = _antennas.vertical_dipole(np.asarray(exciter_xyz, float))
    exciter = Exciter(config.exciter, ex_ant)
    template = _antennas.vertical_dipole(np.zeros(3))
    sc, fc = room(config.apdp), config.exciter.fc_hz
    single = lis_pos.shape[0] == 1
    links = DrawnLinks()
    lis = _antennas.vertical_dipole(lis_pos[0]) if single else BatchAntenna(template, lis_pos)

    def listener_link(tx_pos, tx_ant):
        bulk = _bulk.draw_links(sc, tx_pos, lis_pos, fc_hz=fc, rng=rng, tx_antenna=tx_ant, rx_antenna=template)
        return bulk.pathset(0) if single else BatchLink(bulk)

    links.add(ex_ant, lis, listener_link(ex_ant.position_m, ex_ant))
    reflectors = []
    for i, frame in zip(senders, frames):
        pos = np.array([tags_xy[i][0], tags_xy[i][1], h])
        ant = _antennas.vertical_dipole(pos)
        tag = _tag.PassiveTag(dataclasses.replace(TagConfig(), structural_mode=0.0), ant, rng=rng,
                              chip=_tag_chip.PowerDependentChip.pass_default())
        reflectors.append(OwnSchedule(tag, frame))
        links.add(ex_ant, ant, _bulk.draw_links(sc, ex_ant.position_m, pos, fc_hz=fc, rng=rng, tx_antenna=ex_ant,
                                                rx_antenna=ant).pathset(0))
        links.add(ant, lis, listener_link(pos, ant))
    try:
        air = _air.propagate([exciter], reflectors, [_air.AntennaPort(lis, noise_power_w=config.noise.power_w(fr.fs_hz))], links,
                             t0_s=0.0, fs_hz=fr.fs_hz, n_samples=n_samples, rng=rng, bandwidth_hz=2.0 * fr.blf_hz,
                             decide=False)
    except ValueError as err:
        if single or "narrowband" not in str(err):
            raise
        half = lis_pos.shape[0] // 2
        return np.concatenate([_inputs(config, exciter_xyz, tags_xy, senders, frames, lis_pos[:half], rng),
                               _inputs(config, exciter_xyz, tags_xy, senders, frames, lis_pos[half:], rng)])
    return np.broadcast_to(air.inputs[0].samples, (lis_pos.shape[0], n_samples))


def decode_rows(config: PhysicalConfig, x, frames, senders, threshold_v: float) -> np.ndarray:
    """(n,) the sender whose 32 bits the chain (comparator at ``threshold_v``) decodes exactly, −1 none."""
    fr = config.frame
    listener = dataclasses.replace(config.listener, threshold_v=float(threshold_v))
    rx = _sense_a_tag.make_receiver(listener, fs_hz=fr.fs_hz, blf_hz=fr.blf_hz, m=fr.m, trext=fr.trext)
    chain = RowsChain.run(rx, x)
    start = frames[0].stamp.reply_start
    search = int(2 * rx.fs_hz / rx.blf_hz)
    out = np.full(x.shape[0], -1, dtype=np.int64)
    toggles = np.count_nonzero(np.diff(chain.comparator[:, start:], axis=1), axis=1)
    for row in np.flatnonzero(toggles >= rx.min_toggles):
        try:
            det = _linecode.decode_reply(chain.comparator[row, start:].astype(np.complex128), n_bits=32, m=rx.m, trext=rx.trext,
                                         blf_hz=rx.blf_hz, fs_hz=rx.fs_hz, method=rx.method, search_samples=search)
        except ValueError:
            continue
        if det.corr < rx.min_corr:
            continue
        for i, frame in zip(senders, frames):
            if np.array_equal(det.bits, frame.bits):
                out[row] = i
    return out


def calibrate_threshold(config: PhysicalConfig, exciter_xyz, tags_xy, range_m: float,
                        rng: np.random.Generator) -> tuple[float, float, float]:
    """(threshold [V], decode fraction at r around the tag at the median exciter distance — 0.5 —,
    and the smallest / largest fraction over all tags at that threshold as ``(lo, hi)``).

    Returns (threshold_v, min_fraction, max_fraction)."""
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


def decode_events(config: PhysicalConfig, exciter_xyz, tags_xy, slot_senders, listeners_xy, range_m: float,
                  threshold_v: float, rng: np.random.Generator) -> np.ndarray:
    """Decoded tag per event (−1: none). ``slot_senders``: one tuple of sender indices per event;
    events beyond ``max_distance_factor``·r of every sender are not simulated."""
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


__all__ = ["PhysicalConfig", "payload", "listener_inputs", "decode_rows", "calibrate_threshold", "decode_events"]

"""A reader's Query round to one tag with a sense-a-tag (ST) listening nearby, many placements
as one batch (auris-sense-a-tag.md §3.3 "Detection-model data"; seed 003 L3811-3906).

One round: the reader sends a Query (Q = 0, the link's DR, M, TRext) and keeps the CW on for
an RN16 reply (:func:`rfsim.gen2.link.reply_window_s`); the tag
(:class:`rfsim.devices.tag.PassiveTag`) receives it through its forward link, decodes it and
answers its RN16 with Γ(t). One step of the air interface carries the round
(:func:`rfsim.protocols.batch.propagate_batch`, the rounds of a batch at once): the reader's
port (:class:`rfsim.protocols.engine.ReaderPort`: TX leakage, backscatter through the reciprocal
forward link, receiver noise) decodes only when the tag replied, as
:func:`rfsim.protocols.engine.run_exchange`. Only then the ST antennas (vertical dipoles,
:func:`rfsim.devices.sense_a_tag.st_antenna_positions`) are received over the same channel, as
receivers of the same step after the reader's port (their links drawn after the reader's, from
the same stream; the tag's reaction replayed; no noise at the ST: its threshold decides), and
the ST decodes with its technique (:func:`rfsim.devices.sense_a_tag_rows.detect_replies`).

Every placement draws only from its own generators, so a batch gives, placement by placement,
the rows of that placement alone. The carrier-independent geometry of the reader → tag,
reader → SA_k and tag → SA_k links of a batch is evaluated at once
(:func:`rfsim.channels.bulk.static_placements`, bit-identical to the channel's own).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.air import step as _air
from rfsim.channels import bulk as _bulk
from rfsim.channels import scene as _scene
from rfsim.channels.antennas import Antenna, HalfWaveDipole
from rfsim.detection.models import st_features
from rfsim.devices import reader as _reader
from rfsim.devices import sense_a_tag as _sense_a_tag
from rfsim.devices import tag as _tag
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.sense_a_tag_rows import detect_replies
from rfsim.devices.tag_config import TagConfig
from rfsim.gen2 import commands as _commands
from rfsim.gen2 import link as _link
from rfsim.protocols import batch as _batch
from rfsim.protocols import engine as _engine


@dataclass(frozen=True)
class Placement:
    """Where one round's devices are: the tag (its antenna included) and the ST.

    Attributes
    ----------
    tag_m : ndarray, shape (3,)
        Tag position [m].
    st_m : ndarray, shape (3,)
        ST centre [m].
    st_azimuth_rad : float
        Azimuth of the ST's SA1 → SA2 axis [rad].
    tag_antenna : Antenna
        The tag's antenna at ``tag_m``.
    """

    tag_m: np.ndarray
    st_m: np.ndarray
    st_azimuth_rad: float
    tag_antenna: Antenna


@dataclass(frozen=True)
class Devices:
    """The configurations of one scene: reader, tag, ST, the reader's antenna and the scene.

    ``scene`` is immutable and shared by every round of a batch.

    Attributes
    ----------
    reader : ReaderConfig
        The reader.
    tag : TagConfig
        The tag.
    st : SenseATagConfig
        The sense-a-tag (technique, threshold, antennas and their spacing).
    reader_antenna : Antenna
        The reader's antenna.
    scene : Scene
        The propagation scene (shared by every round).
    st_pattern : object, default ``HalfWaveDipole()``
        The pattern of the ST's antennas, each vertical and linearly polarised at its position
        (:func:`st_antenna`): a vertical half-wave dipole by default, or e.g.
        ``Isotropic(HALF_WAVE_DIPOLE_PEAK)`` for the source's omnidirectional ST antennas
        (seed 003 L2873).
    """

    reader: ReaderConfig
    tag: TagConfig
    st: SenseATagConfig
    reader_antenna: Antenna
    scene: _scene.Scene
    st_pattern: object = HalfWaveDipole()


def run_rounds(devices: Devices, placements: list[Placement], rngs: list[list]) -> list[dict]:
    """The rounds of many placements as one batch.

    Parameters
    ----------
    devices : Devices
        The scene's devices.
    placements : list of Placement
        One placement per round.
    rngs : list of list of numpy.random.Generator
        Per round its generators: ``[1]`` the reader (hop table), ``[2]`` the tag, ``[3]`` the
        channel (all links), ``[4]`` the reader's receiver noise (the others unused).

    Returns
    -------
    list of dict
        One record per round: the features ``D_m``, ``d_m``, ``theta_rad``, ``phi_rad``
        (:func:`rfsim.detection.st_features`), the positions (``tag_x_m`` …, ``st_x_m`` …,
        ``st_orientation_rad``), ``channel_index``, ``frequency_hz``,
        ``tag_incident_power_dbm``, ``tag_powered``, ``tag_replied``, ``reader_detected`` (the
        reader decoded the RN16 bits exactly) and the ST outcomes of
        :func:`rfsim.devices.sense_a_tag_rows.detect_replies`.
    """
    ra, sc = devices.reader_antenna, devices.scene
    reader_tag = _bulk.static_placements(sc, ra, [p.tag_antenna for p in placements])
    prepared = [prepare_round(devices, p, r, held) for p, r, held in zip(placements, rngs, reader_tag)]
    airs = _batch.propagate_batch([p[0] for p in prepared])
    # the features of the batch at once (element by element the same operations)
    features = list(zip(*(v.tolist() for v in st_features([p.tag_m for p in placements],
                                                           [p.st_m for p in placements]))))
    rounds = [reader_outcome(devices, p, pl, air, f) for p, pl, air, f in zip(prepared, placements, airs, features)]
    # the ST links of every round whose tag replied at once: reader → SA_k and tag → SA_k
    steps = [r[1] for r in rounds if r[1] is not None]
    sa = [a for step in steps for a in step[4]]
    from_reader = _bulk.static_placements(sc, ra, sa)
    from_tag = _bulk.static_placements(sc, [step[1] for step in steps for _ in step[4]], sa)
    j = 0
    for emitter, tag_ant, _, links, antennas, _, _ in steps:
        for a in antennas:
            links.channel.hold_placement(emitter.antenna, a, from_reader[j])
            links.channel.hold_placement(tag_ant, a, from_tag[j])
            j += 1
    inputs = iter(st_inputs(steps))
    listenings = [(None if step is None else next(inputs), tx, resp, bits) for _, step, tx, resp, bits in rounds]
    t1_max = _link.t1(_link.profile(devices.reader.link_profile)).max_s
    return [{**r[0], **det} for r, det in zip(rounds, detect_replies(devices.st, listenings, t1_max_s=t1_max))]


def prepare_round(devices: Devices, placement: Placement, rngs: list, reader_tag: tuple | None = None) -> tuple:
    """Prepare the air step of one round and the reader's segment.

    The step (:class:`rfsim.protocols.batch.AirStep`) carries the reader's segment (a Query of
    :func:`query_round` and the CW for the reply), the tag and the reader's port
    (:class:`rfsim.protocols.engine.ReaderPort`); its links are drawn from ``rngs[3]``, the
    port's noise from ``rngs[4]``.

    Parameters
    ----------
    devices : Devices
        The scene's devices.
    placement : Placement
        Where the round's tag is.
    rngs : list of numpy.random.Generator
        The round's generators (:func:`run_rounds`).
    reader_tag : tuple or None, default None
        The carrier-independent geometry of the reader → tag link
        (:func:`rfsim.channels.bulk.static_placements`); evaluated by the channel when None.

    Returns
    -------
    step : rfsim.air.batch.AirStep
        The round's air step.
    tx : TxSegment
        The reader's transmitted segment (:meth:`rfsim.devices.reader.Reader.transmit`).
    """
    ra = devices.reader_antenna
    reader = _reader.Reader(devices.reader, [ra], rng=rngs[1])
    tag = _tag.PassiveTag(devices.tag, placement.tag_antenna, rng=rngs[2])
    lk = reader.link
    q, cw_after_s = query_round(lk)
    tx = reader.transmit(q, t0_s=0.0, cw_after_s=cw_after_s)
    port = _engine.ReaderPort(reader, ra, tx, reply_bits=16, expect_crc=False)
    # links drawn in the step's order: reader→tag (held both ways), then reader→SA_k, tag→SA_k
    channel = _scene.Channel(devices.scene)
    if reader_tag is not None:
        channel.hold_placement(ra, tag.antenna, reader_tag)
    links = _air.LinkTable(channel, rng=rngs[3], reciprocal=True)
    emitter = _air.FixedEmitter(ra, tx, device=reader)
    step = _batch.AirStep([emitter], [tag], [port], links, t0_s=0.0, fs_hz=tx.fs_hz, n_samples=tx.samples.size,
                          rng=rngs[4], bandwidth_hz=2.0 * lk.blf_hz, decide=False)
    return step, tx


def query_round(lk) -> tuple:
    """The round's Query and the CW after it for an RN16 reply.

    Parameters
    ----------
    lk : LinkProfile
        The (immutable) link profile.

    Returns
    -------
    query : rfsim.gen2.commands.Query
        Q = 0 with the link's DR, M and TRext.
    cw_after_s : float
        CW after the command [s], :func:`rfsim.gen2.link.reply_window_s` for 16 bits.
    """
    return _commands.Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0), _link.reply_window_s(lk, 16)


def reader_outcome(devices: Devices, prepared: tuple, placement: Placement, air, features: tuple) -> tuple:
    """The reader's read of a round of :func:`prepare_round`, and the ST's part of the round.

    The reader decodes only when the tag replied, as :func:`rfsim.protocols.engine.run_exchange`;
    then the ST's antennas (:func:`st_antenna` with ``devices.st_pattern`` at
    :func:`rfsim.devices.sense_a_tag.st_antenna_positions`) are set up for :func:`st_inputs`.

    Parameters
    ----------
    devices : Devices
        The scene's devices.
    prepared : tuple
        ``(step, tx)`` of :func:`prepare_round`.
    placement : Placement
        The round's placement.
    air : rfsim.air.step.AirResult
        The propagated step (:func:`rfsim.protocols.batch.propagate_batch`).
    features : tuple of float
        The round's (D [m], d [m], θ [rad], φ [rad]).

    Returns
    -------
    record : dict
        The round's features, positions, carrier and tag/reader outcomes (:func:`run_rounds`).
    st_step : tuple or None
        An item of :func:`st_inputs`' input, None when the tag did not reply.
    tx : TxSegment
        The reader's segment.
    response : Reflection
        The tag's reaction.
    bits : ndarray of uint8 or None
        The tag's RN16 bits, None when it did not reply.
    """
    step, tx = prepared
    st = devices.st
    emitter, tag, port, links = step.emitters[0], step.reflectors[0], step.receivers[0], step.links
    resp = air.reflections[0]
    replied = resp.gamma is not None
    bits = np.asarray(resp.reply.bits, np.uint8) if replied else None
    reader_ok = False
    st_step = None
    if replied:  # the reader decodes only when a tag replied, as run_exchange
        read = port.receive(air.inputs[0])
        reader_ok = read.bits is not None and read.success and np.array_equal(read.bits, bits)
        sa_pos = _sense_a_tag.st_antenna_positions(placement.st_m, n_antennas=st.n_antennas, spacing_m=st.spacing_m,
                                                   orientation_rad=placement.st_azimuth_rad)
        st_step = (emitter, tag.antenna, resp, links, [st_antenna(p, devices.st_pattern) for p in sa_pos], tx,
                   port.reader.link)
    big_d, small_d, theta, phi = features
    tag_pos, st_pos = placement.tag_m, placement.st_m
    record = dict(tag_x_m=tag_pos[0], tag_y_m=tag_pos[1], tag_z_m=tag_pos[2], st_x_m=st_pos[0],
                  st_y_m=st_pos[1], st_z_m=st_pos[2], st_orientation_rad=placement.st_azimuth_rad, D_m=big_d,
                  d_m=small_d, theta_rad=theta, phi_rad=phi, channel_index=tx.channel_index, frequency_hz=tx.fc_hz,
                  tag_incident_power_dbm=float(resp.incident_power_dbm), tag_powered=bool(resp.powered),
                  tag_replied=replied, reader_detected=bool(reader_ok))
    return record, st_step, tx, resp, bits


def st_antenna(position_m, pattern=HalfWaveDipole()) -> Antenna:
    """One ST antenna: vertical (unrotated), linearly polarised along ``+z``, with ``pattern``.

    With the default half-wave dipole it is
    :func:`rfsim.channels.antennas.vertical_dipole`, omnidirectional in azimuth; an isotropic
    pattern makes it omnidirectional in elevation too (seed 003 L2873: "the radiation pattern of
    ST antennas are modelled as omnidirectional"). The polarisation is kept: between two
    vertical linear antennas the mismatch is 1 for every non-vertical line of sight.

    Parameters
    ----------
    position_m : array_like, shape (3,)
        Position [m].
    pattern : object, default ``HalfWaveDipole()``
        Any pattern with ``gain(az_rad, el_rad)`` (linear power gain, local frame).

    Returns
    -------
    Antenna
        The antenna.
    """
    return Antenna(position_m=position_m, orientation=(0.0, 0.0, 0.0), pattern=pattern, polarization="linear")


def st_inputs(st_steps: list) -> list[np.ndarray]:
    """The ST antennas' inputs from the listening start of many rounds.

    One batch of air steps: the ST antennas are the receivers of each round's step, after the
    reader's port (no noise), the tag's reaction replayed (:class:`Replayed`).

    Parameters
    ----------
    st_steps : list of tuple
        Per round ``(emitter, tag antenna, tag reaction, links, ST antennas, tx, link
        profile)``, the ST step of :func:`reader_outcome`.

    Returns
    -------
    list of ndarray
        Per round the complex baseband inputs, shape (n_antennas, n_samples), from the ST's
        listening start (:func:`rfsim.devices.sense_a_tag.listen_start_sample`).
    """
    steps = []
    for emitter, tag_ant, resp, links, st_ants, tx, lk in st_steps:
        steps.append(_batch.AirStep([emitter], [Replayed(tag_ant, resp)], [_air.AntennaPort(a) for a in st_ants],
                                    links, t0_s=0.0, fs_hz=tx.fs_hz, n_samples=tx.samples.size,
                                    bandwidth_hz=2.0 * lk.blf_hz, decide=False))
    out = []
    for st_step, st_air in zip(st_steps, _batch.propagate_batch(steps)):
        tx = st_step[5]
        i0 = _sense_a_tag.listen_start_sample(tx.cmd_end_s, t0_s=tx.t0_s, fs_hz=tx.fs_hz)
        out.append(np.stack([seg.samples[i0:] for seg in st_air.inputs]))
    return out


class Replayed:
    """A reflector that gives again the reaction a tag had in a step.

    Its re-radiation on the step's time base, without a second pass through the tag's state
    machine.

    Parameters
    ----------
    antenna : Antenna
        The tag's antenna.
    reflection : Reflection
        The tag's reaction in the step.
    """

    def __init__(self, antenna, reflection):
        self.antenna, self._reflection = antenna, reflection

    def reflect(self, incident):
        """Return the recorded reaction, whatever the incident segment.

        Parameters
        ----------
        incident : Segment
            The incident segment (unused: the step's time base is the recorded one's).

        Returns
        -------
        Reflection
            The tag's reaction recorded at construction.
        """
        return self._reflection


__all__ = ["Placement", "Devices", "run_rounds", "prepare_round", "query_round", "reader_outcome", "st_antenna",
           "st_inputs", "Replayed"]

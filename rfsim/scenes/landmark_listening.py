"""A sense-a-tag (ST) listening to a reader's inventory of landmark tags at sample level: the
reader inventories the landmark tags in real Gen2 rounds, the ST listens to every EPC reply
with its envelope receiver, and the detections that result (and the time they take) feed a
tracker (``st-localization``'s sample-level mode) (auris-sense-a-tag.md §1.1
"ST locator protocol", §7.2; seeds/003 L4040-L4060 (N rounds of QT, then QS), L4169-L4199
(Eq. 4.10: detections and their instants), L5405-L5409 (the query period grows with the tag
population); wave2-specs.md §R "sample-level").

Scene. A room of :mod:`rfsim.scenes.landmark_room`: landmark tags on the floor (z = 0) as
half-wave dipoles lying along x (a tag label flat on the floor), the reader's panel antenna(s)
at the preset position facing down (:class:`rfsim.channels.EllipticalPanel`,
9 dBic, 70°, 20 dB front-to-back, 30 dBm, link profile ``pass-miller2-48k`` at 1 MS/s as the source's PASS runs,
FCC hopping, L3811-L3817), channel "room": free space with the PASS exponential APDP
(:class:`rfsim.channels.ApdpModel`). The ST's two antennas (SA1, SA2, λ/4 apart along x) are
half-wave dipoles parallel to the landmarks' at ``st_height_m`` above the floor (the source's
vertical ST dipoles are cross-polarised to a tag lying on the floor); technique: path selection
(:class:`rfsim.devices.sense_a_tag.SenseATag`, Algorithm 1).

Query period. One period is N QT rounds; each QT round is a Gen2 inventory of all landmarks
(:func:`rfsim.protocols.inventory.run_inventory`: Q algorithm from Q = 4, RN16 → ACK → PC+EPC+CRC-16 per
slot, rounds until a round without a reply), after a CW interruption that returns every
landmark's S0 flag to A (``EngineAir.cw_off``) so that each round reads every landmark again.
Its duration follows from the exchanges (command durations of the link profile, detected
reply starts, T2, T4; silent air time is skipped, not sampled) plus the CW-off time
``cw_off_s`` per round; the ST's QS report round is not simulated. The measured period
replaces the source's 0.3 s (10 rounds over 45 landmarks take ≈ 1.1 s or more at these links,
wave2-specs.md §R [derived]).

One exchange is one step of the air interface (:func:`rfsim.air.step.propagate`): the reader's
segment, every landmark (its own front end and Gen2 state machine, Γ(t) when it replies) and as
receivers the reader's port (:class:`rfsim.protocols.engine.ReaderPort`: leakage, backscatter, noise) and
the ST's antennas (no noise; the ST's 5 mV comparator decides, as in ``detection-probability``).
The ST decodes the reader's command on SA2 (:meth:`SenseATag.listen`: link parameters, what
reply to expect) and, after an ACK, the EPC reply on SA1/SA2 (:meth:`SenseATag.observe`); a
CRC-valid EPC equal to landmark k's is a detection of k at the reply's start. It listens only
in the exchanges that matter to it (Query: link parameters; ACK: the EPC reply); in the others
it is no receiver of the step. The ST is not a reflector of the step (its own scatter at the
reader and the landmarks is neglected), so the reader's records are those of
:class:`rfsim.protocols.inventory.EngineAir` on the same streams, to the bit (test). The ST's position is
its trajectory's at the exchange start, snapped to ``st_step_m`` (1 cm; it moves ≤ 1 cm within
one exchange at 3 m/s). Links: reader ↔ landmark drawn at the first exchange of every inventory
round and held for the round (quasi-static, as ``EngineAir``); reader → ST and landmark → ST
drawn at every new ST position and held while it stays (a simplification: their diffuse part
decorrelates over 1 cm instead of ≈ λ/2).

Cost (CPU, seed 1, pfaa, N = 10): ≈ 6 s per period for a still ST, ≈ 20 s per 4.7 s period at
0.5 m/s (the ST's 92 links at every new position dominate; ``st_step_m`` trades it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.protocols.inventory import AirExchange, EngineAir, InventoryConfig, epc_hex_of, run_inventory
from rfsim.core.rng import trial_rng
from rfsim.core.lazy import lazy_import

_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_antennas = lazy_import("rfsim.channels.antennas")
_reader = lazy_import("rfsim.devices.reader")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
_tag = lazy_import("rfsim.devices.tag")
_air = lazy_import("rfsim.air.step")
_engine = lazy_import("rfsim.protocols.engine")
_commands = lazy_import("rfsim.gen2.commands")
_link = lazy_import("rfsim.gen2.link")

#: Orientation (az, el, roll) [rad] of a dipole lying along x (local z → global x).
ALONG_X = (0.0, math.pi / 2, 0.0)
#: Panel facing the floor (boresight local +x → global −z).
FACING_DOWN = (0.0, -math.pi / 2, 0.0)
#: Front-to-back ratio [dB] of the reader's panel: :data:`rfsim.channels.antennas.PANEL_FRONT_TO_BACK_DB`.
PANEL_FRONT_TO_BACK_DB = _antennas.PANEL_FRONT_TO_BACK_DB


@dataclass(frozen=True)
class SampleLevelConfig:
    """Reader, channel, ST placement and track length of the listening scene (validated; in
    ``st-localization`` its errors name ``sample_level.<key>``; the scenario's ``full`` does not
    apply: its cases have ``realizations`` tracks of ``duration_s``)."""

    link_profile: str = param("pass-miller2-48k", doc="reader link profile (PASS: Miller-2, BLF 48 kHz)")
    fs_hz: float = param(1e6, lo=2e5, hi=2e8, unit="Hz", doc="sample rate of the exchanges")
    ptx_dbm: float = param(30.0, lo=-20.0, hi=36.0, unit="dBm", doc="reader conducted power (L3815)")
    panel_gain_dbic: float = param(9.0, lo=0.0, hi=15.0, unit="dBic", doc="panel peak gain")
    panel_beamwidth_deg: float = param(70.0, lo=20.0, hi=170.0, unit="deg", doc="panel half-power beamwidth")
    apdp: bool = param(True, doc="exponential APDP small scale (the PASS 'room' channel)")
    q_initial: float = param(4.0, lo=0.0, hi=15.0, doc="initial Qfp of each QT round (Q algorithm, C = 0.3)")
    cw_off_s: float = param(0.0, lo=0.0, hi=1.0, unit="s",
                            doc="CW interruption before each QT round (counted in the period)")
    st_step_m: float = param(0.01, lo=1e-4, hi=0.5, unit="m",
                             doc="the ST's position is updated (and its links drawn anew) in steps of this size")
    st_height_m: float = param(0.1, lo=0.01, hi=3.0, unit="m", doc="height of the ST's antennas above the floor")
    duration_s: float = param(15.0, lo=0.1, hi=1e5, unit="s",
                              doc="tracked time on each trajectory (periods until this time is passed)")
    realizations: int = param(1, lo=1, hi=10000, doc="tracks per case (each its own landmarks, reader, ST streams)")
    max_periods: int = param(1000, lo=1, hi=10**6, doc="stop after this many query periods")


def panel(position_m, c: SampleLevelConfig) -> _antennas.Antenna:
    """Return the reader's circular panel at ``position_m`` facing the floor.

    A patch pattern of ``c.panel_gain_dbic`` and ``c.panel_beamwidth_deg`` with
    :data:`PANEL_FRONT_TO_BACK_DB`, axial ratio growing off boresight
    (:class:`rfsim.channels.EllipticalPanel` defaults).

    Parameters
    ----------
    position_m : array_like, shape (3,)
        Position of the panel [m].
    c : SampleLevelConfig
        The scene's settings (panel gain and beamwidth).

    Returns
    -------
    rfsim.channels.antennas.EllipticalPanel
        The panel, boresight along −z.
    """
    pattern = _antennas.Patch(c.panel_gain_dbic, c.panel_beamwidth_deg, PANEL_FRONT_TO_BACK_DB)
    return _antennas.EllipticalPanel(position_m=tuple(float(v) for v in position_m), orientation=FACING_DOWN,
                                     pattern=pattern, polarization="circular",
                                     half_beamwidth_rad=math.radians(0.5 * c.panel_beamwidth_deg))


def flat_dipole(position_m) -> _antennas.Antenna:
    """Return a linearly polarized half-wave dipole lying along x.

    Parameters
    ----------
    position_m : array_like, shape (3,)
        Position of the dipole [m].

    Returns
    -------
    rfsim.channels.antennas.Antenna
        The dipole (orientation :data:`ALONG_X`).
    """
    return _antennas.Antenna(position_m=tuple(float(v) for v in position_m), orientation=ALONG_X,
                             pattern=_antennas.HalfWaveDipole(), polarization="linear")


def landmark_epc_hex(k: int) -> str:
    """Return the EPC of landmark ``k``.

    Parameters
    ----------
    k : int
        0-based landmark index.

    Returns
    -------
    str
        96-bit EPC as 24 upper-case hex digits, the number k + 1 (e.g. ``"000…001"`` for k = 0).
    """
    return format(k + 1, "024X")


class ListeningAir(EngineAir):
    """The sample-level air of :func:`rfsim.protocols.inventory.run_inventory` with an ST listening.

    ``exchange`` runs one air step with the reader port and the ST's antennas as receivers
    and records the ST's detections in :attr:`detections` (module docstring).

    Parameters
    ----------
    reader : rfsim.devices.reader.Reader
        The reader.
    tags : list of rfsim.devices.tag.PassiveTag
        The landmark tags.
    channel : rfsim.channels.scene.Channel
        The room's channel (reader ↔ landmark links, held per round).
    st : rfsim.devices.sense_a_tag.SenseATag
        The listening sense-a-tag.
    st_center : callable
        ``t_s → (3,)`` position of the ST's centre [m].
    st_config : rfsim.devices.sense_a_tag_config.SenseATagConfig
        The ST's settings (antenna count, spacing, orientation).
    rng : numpy.random.Generator
        The air's stream (round links, reader noise).
    st_rng : numpy.random.Generator
        Draws the ST's links (reader → ST, landmark → ST).
    epcs : dict of str to int
        EPC hex → landmark index.
    st_step_m : float, optional
        The ST's position is snapped to this step [m], default 0.01.

    Attributes
    ----------
    detections : list of tuple of (float, int)
        The ST's detections: (reply start [s], landmark index), in time order.
    """

    def __init__(self, reader, tags, channel, st: _sense_a_tag.SenseATag, st_center, *, st_config: SenseATagConfig,
                 rng: np.random.Generator, st_rng: np.random.Generator, epcs: dict, st_step_m: float = 0.01):
        super().__init__(reader, tags, channel, rng=rng, fast=True)
        self.st_channel = _scene.Channel(channel.scene)  # the ST's links (reader → ST, landmark → ST) on their own
        self.st, self.st_center, self.st_config = st, st_center, st_config
        self.st_rng, self.epcs, self.st_step_m = st_rng, epcs, float(st_step_m)
        self.detections: list[tuple[float, int]] = []
        self._st_key, self._st_ants = None, []

    def _st_antennas(self, t_s: float):
        """The ST's antennas at its centre at ``t_s`` snapped to ``st_step_m``, and whether they
        moved since the last call (new position: the ST's links are drawn anew, the held draws
        of the old position are dropped)."""
        c, step = self.st_config, self.st_step_m
        centre = np.round(np.asarray(self.st_center(t_s), float) / step) * step
        key = tuple(centre.tolist())
        if key == self._st_key:
            return self._st_ants, False
        pos = _sense_a_tag.st_antenna_positions(centre, n_antennas=c.n_antennas, spacing_m=c.spacing_m,
                                                orientation_rad=math.radians(c.orientation_deg))
        self._st_key, self._st_ants = key, [flat_dipole(p) for p in pos]
        self.st_channel.forget()
        return self._st_ants, True

    def exchange(self, cmd, *, t_s: float, reply_bits: int, expect_crc: bool, round_index: int = 0,
                 new_round: bool = False) -> AirExchange:
        """Run one command and its reply window as one air step, with the ST listening.

        The ST decodes a Query's link parameters, and after an ACK with a single reply the
        EPC on its antennas; a CRC-valid EPC of a landmark is appended to
        :attr:`detections`.

        Parameters
        ----------
        cmd : object
            The reader's command (a :mod:`rfsim.gen2.commands` dataclass: ``Query``, ``ACK``, ...).
        t_s : float
            Start of the reader's segment [s].
        reply_bits : int
            Length of the expected reply [bits] (sets the listening window).
        expect_crc : bool
            The reply carries a CRC-16 to check.
        round_index : int, optional
            Index of the inventory round (selects the reader antenna), default 0.
        new_round : bool, optional
            First exchange of a round: the reader ↔ landmark links are drawn anew, default False.

        Returns
        -------
        rfsim.protocols.inventory.AirExchange
            What the reader got back (the ST's listening does not change it).
        """
        reader, link = self.reader, self.link
        antenna = reader.antennas[reader.antenna_index(round_index)]
        listen = getattr(reader, "listen_window_s", None)  # as run_exchange: a BLF-searching reader listens longer
        window_s = listen(int(reply_bits)) if listen is not None else _link.reply_window_s(link, reply_bits)
        tx = reader.transmit(cmd, t0_s=t_s, cw_after_s=window_s, round_index=round_index)
        port = _engine.ReaderPort(reader, antenna, tx, reply_bits=reply_bits, expect_crc=expect_crc)
        # the ST needs the Query's link parameters and the ACK's reply
        listens = isinstance(cmd, (_commands.ACK, _commands.Query))
        st_ants, moved = self._st_antennas(t_s) if listens else ([], False)
        if new_round:
            self._round_links.clear()
        links = _Links(self._channel, self.st_channel, antenna, st_ants, self.rng if new_round else None,
                       self.st_rng if moved else None, self._round_links, new_round)
        air = _air.propagate([_air.FixedEmitter(antenna, tx, device=reader)], self._reflectors,
                             [port, *[_air.AntennaPort(a) for a in st_ants]], links, t0_s=t_s, fs_hz=tx.fs_hz,
                             n_samples=tx.samples.size, rng=self.rng, bandwidth_hz=2.0 * link.blf_hz, decide=False)
        n = len(self.tags)
        responses = [air.reflections[j] for j in range(n)]
        replied = tuple(j for j, r in enumerate(responses) if r.gamma is not None)
        read = port.receive(air.inputs[0]) if replied else None
        detected = read is not None and read.bits is not None
        if listens:
            st_inputs = np.array([s.samples for s in air.inputs[1:]])
            self.st.listen(st_inputs[-1], t0_s=t_s, fs_hz=tx.fs_hz)
            if isinstance(cmd, _commands.ACK) and len(replied) == 1:
                i0 = _sense_a_tag.listen_start_sample(tx.cmd_end_s, t0_s=t_s, fs_hz=tx.fs_hz)
                obs = self.st.observe(st_inputs, start_sample=i0)
                k = self.epcs.get(epc_hex_of(obs.bits)) if (obs.detected and obs.bits is not None) else None
                if k is not None:
                    self.detections.append((float(responses[replied[0]].reply_start_s), int(k)))
        return AirExchange(type(cmd).__name__, float(t_s), float(tx.cmd_end_s), replied, detected,
                           read.bits if detected else None, bool(read is not None and read.success),
                           "" if replied else "no reply", read.start_s if detected else math.nan,
                           reader.antenna_index(round_index), tx.channel_index, tx.fc_hz, read,
                           tuple(float(r.incident_power_dbm) for r in responses))


class _LandmarkLinks(NamedTuple):
    """A landmark's round links (reader → landmark, landmark → reader), kept with the
    landmark's antenna whose identity keys them."""

    antenna: object
    forward: object
    backward: object


class _Links:
    """Links of one exchange: reader ↔ landmark from the round's held draw (the engine's
    round channel; ``cache``: ``(id(landmark antenna), fc_hz)`` → :class:`_LandmarkLinks`),
    reader → ST and landmark → ST drawn anew (``st_rng``)."""

    def __init__(self, round_channel, channel, antenna, st_antennas, rng, st_rng, cache, new_round):
        self.round, self.channel, self.antenna = round_channel, channel, antenna
        self.st = tuple(st_antennas)
        self.rng, self.st_rng, self.cache, self.new_round = rng, st_rng, cache, new_round

    def paths(self, tx, rx, *, fc_hz, t_s):
        if any(rx is a for a in self.st):
            return self.channel.link(tx, rx, fc_hz=fc_hz, rng=self.st_rng if self.channel.scene.apdp else None,
                                     t_s=t_s)
        if tx is self.antenna:
            key = (id(rx), fc_hz)
            hit = None if self.new_round else self._held(key, rx)
            if hit is None:
                forward, backward = self.round.backscatter_links(self.antenna, rx, fc_hz=fc_hz, rng=self.rng, t_s=t_s)
                hit = self.cache[key] = _LandmarkLinks(rx, forward, backward)
            return hit.forward
        if rx is self.antenna:
            hit = self._held((id(tx), fc_hz), tx)
            return hit.backward if hit is not None else None
        return None

    def _held(self, key, antenna) -> _LandmarkLinks | None:
        hit = self.cache.get(key)
        return hit if (hit is not None and hit.antenna is antenna) else None


@dataclass(frozen=True, eq=False)
class Listened:
    """One sample-level track of T query periods over L landmarks.

    Attributes
    ----------
    t_end_s : ndarray, shape (T,)
        End time of each query period [s].
    counts : ndarray of int, shape (T, L)
        Detections of each landmark in each period.
    mean_detection_s : ndarray, shape (T,)
        Mean instant of the period's detections [s]; NaN for none.
    times_s : ndarray, shape (D,)
        Every detection's instant (reply start) [s].
    landmarks : ndarray of int, shape (D,)
        Every detection's landmark index.
    slots_per_period : ndarray of int, shape (T,)
        Inventory slots per period.
    reads_per_period : ndarray of int, shape (T,)
        The reader's EPC reads per period.
    read_log : dict of str to ndarray
        The reader's read log: the inventory's per-read columns
        (:data:`rfsim.protocols.inventory.READ_FIELDS`) and ``period``, one entry per EPC read.
    """

    t_end_s: np.ndarray
    counts: np.ndarray
    mean_detection_s: np.ndarray
    times_s: np.ndarray
    landmarks: np.ndarray
    slots_per_period: np.ndarray
    reads_per_period: np.ndarray
    read_log: dict = field(default_factory=dict)


def listen_track(room, st_center, *, rounds: int, sl: SampleLevelConfig, st_config: SenseATagConfig,
                 seed: int, key: tuple[int, ...], tag_config: TagConfig = TagConfig()) -> Listened:
    """Run query periods of ``rounds`` QT rounds until ``sl.duration_s`` (or ``sl.max_periods``).

    Each QT round follows a CW interruption (every landmark's S0 flag back to A) and is a
    Gen2 inventory of all landmarks; the ST listens to it (:class:`ListeningAir`). A
    detection belongs to the first period that ends at or after its instant.

    Parameters
    ----------
    room : rfsim.scenes.landmark_room.Room
        Landmark positions and reader antenna positions.
    st_center : callable
        ``t_s → (3,)`` position of the ST's centre [m].
    rounds : int
        QT rounds per query period (N ≥ 1).
    sl : SampleLevelConfig
        The scene's settings.
    st_config : rfsim.devices.sense_a_tag_config.SenseATagConfig
        The ST's settings.
    seed : int
        Root seed.
    key : tuple of int
        Stream key of the track: ``trial_rng(seed, *key, k)`` with k = 0 reader, 1 air
        (round links, reader noise), 2 ST links, 3 ST device, 100 + i landmark i.
    tag_config : rfsim.devices.tag_config.TagConfig, optional
        The landmarks' settings (their EPCs are :func:`landmark_epc_hex`), default ``TagConfig()``.

    Returns
    -------
    Listened
        The track's periods, detections and reads.

    Raises
    ------
    rfsim.core.errors.ConfigError
        ``rounds`` < 1.
    """
    if rounds < 1:
        raise ConfigError("rounds", rounds, "at least 1 QT round per query period")
    lm = room.landmarks_xy()
    rc = ReaderConfig(link_profile=sl.link_profile, fs_hz=sl.fs_hz, ptx_dbm=sl.ptx_dbm, hopping=True)
    reader = _reader.Reader(rc, [panel(p, sl) for p in room.antennas_xyz_m], rng=trial_rng(seed, *key, 0))
    tags = [_tag.PassiveTag(replace(tag_config, epc_hex=landmark_epc_hex(i)), flat_dipole((x, y, 0.0)),
                            rng=trial_rng(seed, *key, 100 + i)) for i, (x, y) in enumerate(lm)]
    epcs = {landmark_epc_hex(i): i for i in range(len(tags))}
    channel = _scene.Channel(_scene.Scene(apdp=_small_scale.ApdpModel() if sl.apdp else None))
    st_ants = _sense_a_tag.st_antenna_positions(np.asarray(st_center(0.0), float), n_antennas=st_config.n_antennas,
                                                spacing_m=st_config.spacing_m,
                                                orientation_rad=math.radians(st_config.orientation_deg))
    st = _sense_a_tag.SenseATag(st_config, [flat_dipole(p) for p in st_ants], rng=trial_rng(seed, *key, 3),
                                fs_hz=sl.fs_hz)
    air = ListeningAir(reader, tags, channel, st, st_center, st_config=st_config, rng=trial_rng(seed, *key, 1),
                       st_rng=trial_rng(seed, *key, 2), epcs=epcs, st_step_m=sl.st_step_m)
    inv = InventoryConfig(q_initial=sl.q_initial)
    t, ends, slots, reads, read_log = 0.0, [], [], [], {}
    while t < sl.duration_s and len(ends) < sl.max_periods:
        slots.append(0)
        reads.append(0)
        for _ in range(rounds):
            air.cw_off(t)
            t += sl.cw_off_s
            log = run_inventory(air, inv, t0_s=t)
            slots[-1] += log.n_slots
            reads[-1] += len(log.reads["tag"])
            for k, v in {**log.reads, "period": [len(ends)] * len(log.reads["tag"])}.items():
                read_log.setdefault(k, []).extend(v)
            t = log.t_end_s
        ends.append(t)
    t_end = np.asarray(ends)
    det = np.asarray(air.detections, float).reshape(-1, 2)
    times, which = det[:, 0], det[:, 1].astype(np.int64)
    period = np.searchsorted(t_end, times, side="left")
    T, L = t_end.size, lm.shape[0]
    counts = np.zeros((T, L), dtype=np.int64)
    np.add.at(counts, (period, which), 1)
    tsum = np.zeros(T)
    np.add.at(tsum, period, times)
    total = counts.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_t = np.where(total > 0, tsum / total, np.nan)
    return Listened(t_end, counts, mean_t, times, which, np.asarray(slots), np.asarray(reads),
                    {k: np.asarray(v) for k, v in read_log.items()})


__all__ = ["SampleLevelConfig", "ListeningAir", "Listened", "listen_track", "panel", "flat_dipole",
           "landmark_epc_hex", "PANEL_FRONT_TO_BACK_DB", "ALONG_X", "FACING_DOWN"]

"""A tag population in a room read by one reader, and two tags on the boresight of a patch.

Geometry: a rectangular room (floor at z = 0); tags uniformly inside it (margin 0.5 m),
heights uniform in ``tag_height_m``, vertical half-wave dipoles with a random azimuth; one to
four reader patch antennas in the middle of the walls at ``reader_height_m``, facing the room
centre, used in turn per round. Channel: Friis LoS, optional floor reflection (image method,
concrete ε_r = 5.3) and the exponential APDP (PASS room curves), drawn per round and held
within it (:class:`rfsim.channels.scene.Scene`).

Tags are :class:`rfsim.devices.tag.PassiveTag` numbered by their EPC; with an enabled
:class:`rfsim.devices.tag_spread.TagSpreadConfig` every tag draws its own BLF error, T1, chip
states and antenna yaw/roll offsets. The inventory itself runs through
:class:`rfsim.protocols.inventory.EngineAir` (sample level).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.core.lazy import lazy_import
from rfsim.core.progress import track
from rfsim.core.reads import reads_table
from rfsim.core.rng import trial_rng
from rfsim.core.units import C_M_S
from rfsim.devices.tag_spread import TagSpreadConfig, orientation_offsets_rad
from rfsim.protocols.inventory import EngineAir, InventoryConfig, run_inventory

_antennas = lazy_import("rfsim.channels.antennas")
_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_surfaces = lazy_import("rfsim.channels.surfaces")
_reader = lazy_import("rfsim.devices.reader")
_sweep = lazy_import("rfsim.scenes.capture_sweep")
_tag = lazy_import("rfsim.devices.tag")


@dataclass(frozen=True)
class RoomConfig:
    """The room and the reader's antennas (errors name ``room.<key>``)."""

    length_m: float = param(8.0, lo=2.0, hi=100.0, unit="m", doc="room extent along x")
    width_m: float = param(6.0, lo=2.0, hi=100.0, unit="m", doc="room extent along y")
    tag_height_m: tuple[float, float] = param((0.5, 1.5), lo=0.05, hi=10.0, unit="m", doc="tag height range")
    reader_height_m: float = param(1.5, lo=0.1, hi=10.0, unit="m", doc="reader antenna height")
    n_antennas: int = param(1, lo=1, hi=4, doc="reader antennas (middle of walls x=0, x=L, y=0, y=W)")
    reader_gain_dbi: float = param(6.0, lo=0.0, hi=15.0, unit="dBi", doc="patch peak gain")
    reader_beamwidth_deg: float = param(70.0, lo=20.0, hi=180.0, unit="deg", doc="patch beamwidth")
    floor: bool = param(True, doc="floor reflection (image method, concrete eps_r 5.3)")
    apdp: bool = param(True, doc="exponential APDP diffuse taps (PASS room curves)")

    def __post_init__(self):
        check_fields(self, "room")


def tag_epc_hex(template: str, k: int) -> str:
    """Return the EPC of tag ``k``: the template's length, the number k + 1 in its last digits.

    Parameters
    ----------
    template : str
        Template EPC in hex (spaces ignored); only its length is used.
    k : int
        0-based tag index.

    Returns
    -------
    str
        Upper-case hex of k + 1, zero-padded (or truncated) to the template's length
        (unique EPCs while k + 1 fits).

    Examples
    --------
    >>> tag_epc_hex("3000 0000", 10)
    '0000000B'
    """
    n = len(template.replace(" ", ""))
    return format(k + 1, f"0{n}X")[-n:]


def make_tags(config, antennas, *, seed: int, key: tuple[int, ...], spread: TagSpreadConfig | None = None,
              link=None, records: list | None = None) -> list:
    """Make one PassiveTag per antenna, tag k with its own stream ``trial_rng(seed, *key, k)``.

    Parameters
    ----------
    config : rfsim.devices.tag_config.TagConfig
        Template; tag k gets the EPC :func:`tag_epc_hex` ``(config.epc_hex, k)``.
    antennas : sequence of rfsim.channels.antennas.Antenna
        One per tag.
    seed : int
        Root seed.
    key : tuple of int
        Stream key of the population.
    spread : rfsim.devices.tag_spread.TagSpreadConfig, optional
        When enabled, tag k draws its own BLF error, T1, chip states and antenna yaw/roll
        offsets from its spread sub-stream ``trial_rng(seed, *key, k, 0)``. Default None
        (identical tags).
    link : rfsim.gen2.link.LinkProfile, optional
        The link the spread is drawn on (needed with an enabled ``spread``).
    records : list, optional
        Each spread draw's record is appended to it.

    Returns
    -------
    list of rfsim.devices.tag.PassiveTag
        The tags, in antenna order.
    """
    tags = []
    for k, a in enumerate(antennas):
        cfg = replace(config, epc_hex=tag_epc_hex(config.epc_hex, k))
        if spread is not None and spread.enabled:
            cfg, rec = spread.draw(cfg, link, rng=trial_rng(seed, *key, k, 0))
            off = orientation_offsets_rad(rec)
            a = replace(a, orientation=tuple(o + d for o, d in zip(a.orientation, off)))
            if records is not None:
                records.append(rec)
        tags.append(_tag.PassiveTag(cfg, a, rng=trial_rng(seed, *key, k)))
    return tags


def tag_antenna(position_m, azimuth_rad: float):
    """Return a tag antenna: a vertical half-wave dipole, linearly polarized.

    Parameters
    ----------
    position_m : array_like, shape (3,)
        Position [m].
    azimuth_rad : float
        Yaw of the antenna [rad].

    Returns
    -------
    rfsim.channels.antennas.Antenna
        The dipole.
    """
    return _antennas.Antenna(position_m=tuple(float(v) for v in position_m), orientation=(float(azimuth_rad), 0.0, 0.0),
                             pattern=_antennas.HalfWaveDipole(), polarization="linear", pol_tilt_rad=0.0)


def reader_antennas(room: RoomConfig) -> list:
    """Return the reader's circular patches in the middle of the walls, facing inwards.

    Parameters
    ----------
    room : RoomConfig
        The room (size, reader height, patch gain and beamwidth, ``n_antennas``).

    Returns
    -------
    list of rfsim.channels.antennas.Antenna
        The first ``room.n_antennas`` of the patches on the walls x = 0, x = L, y = 0,
        y = W (in that order).
    """
    L, W, h = room.length_m, room.width_m, room.reader_height_m
    spots = [((0.0, W / 2, h), 0.0), ((L, W / 2, h), math.pi), ((L / 2, 0.0, h), math.pi / 2),
             ((L / 2, W, h), -math.pi / 2)]
    return [_antennas.Antenna(position_m=p, orientation=(yaw, 0.0, 0.0),
                              pattern=_antennas.Patch(room.reader_gain_dbi, room.reader_beamwidth_deg),
                              polarization="circular")
            for p, yaw in spots[: room.n_antennas]]


def room_scene(room: RoomConfig):
    """Return the room's channel scene: Friis LoS, the floor and the APDP as enabled.

    Parameters
    ----------
    room : RoomConfig
        ``floor``: a concrete floor at z = 0 (ε_r = 5.3, image order 1); ``apdp``: the
        exponential APDP with the PASS room curves.

    Returns
    -------
    rfsim.channels.scene.Scene
        The scene.
    """
    surfaces = (_surfaces.Surface(point_m=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), eps_r=5.3),) if room.floor else ()
    return _scene.Scene(surfaces=surfaces, apdp=_small_scale.ApdpModel() if room.apdp else None, image_order=1)


def random_tag_antennas(room: RoomConfig, n: int, *, rng: np.random.Generator) -> list:
    """Place ``n`` tag antennas uniformly in the room.

    Parameters
    ----------
    room : RoomConfig
        The room: x, y uniform at least 0.5 m from the walls, z uniform in ``tag_height_m``.
    n : int
        Number of tags.
    rng : numpy.random.Generator
        Draws the n x, then y, z and azimuths (uniform in [−π, π)).

    Returns
    -------
    list of rfsim.channels.antennas.Antenna
        The tag antennas (:func:`tag_antenna`).
    """
    x = rng.uniform(0.5, room.length_m - 0.5, n)
    y = rng.uniform(0.5, room.width_m - 0.5, n)
    z = rng.uniform(*room.tag_height_m, n)
    yaw = rng.uniform(-math.pi, math.pi, n)
    return [tag_antenna((x[k], y[k], z[k]), yaw[k]) for k in range(n)]


def room_population(room: RoomConfig, reader_config, tag_config, n: int, antennas, *, seed: int,
                    key: tuple[int, ...], spread: TagSpreadConfig | None = None, records: list | None = None):
    """Place ``n`` tags at random in the room and the reader on ``antennas``.

    Parameters
    ----------
    room : RoomConfig
        The room.
    reader_config : rfsim.devices.reader_config.ReaderConfig
        The reader.
    tag_config : rfsim.devices.tag_config.TagConfig
        The tags' template (:func:`make_tags`).
    n : int
        Number of tags.
    antennas : list of rfsim.channels.antennas.Antenna
        The reader's antennas (:func:`reader_antennas`).
    seed : int
        Root seed. Streams: tag positions ``trial_rng(seed, *key, 0)``, the reader
        ``trial_rng(seed, *key, 1)``, tag k ``trial_rng(seed, *key, 3, k)`` (its spread
        ``..., 3, k, 0``).
    key : tuple of int
        Stream key of the population.
    spread : rfsim.devices.tag_spread.TagSpreadConfig, optional
        The tags' spread (:func:`make_tags`), default None.
    records : list, optional
        Receives the spread draws.

    Returns
    -------
    reader : rfsim.devices.reader.Reader
        The reader.
    tags : list of rfsim.devices.tag.PassiveTag
        The tags.
    """
    tag_ants = random_tag_antennas(room, n, rng=trial_rng(seed, *key, 0))
    reader = _reader.Reader(reader_config, antennas, rng=trial_rng(seed, *key, 1))
    tags = make_tags(tag_config, tag_ants, seed=seed, key=key + (3,), spread=spread, link=reader.link, records=records)
    return reader, tags


def room_air(room: RoomConfig, reader, tags, *, seed: int, key: tuple[int, ...], keep_exchanges: bool = False):
    """Return the sample-level air interface of the room.

    Parameters
    ----------
    room : RoomConfig
        The room (its channel scene, :func:`room_scene`).
    reader : rfsim.devices.reader.Reader
        The reader.
    tags : list of rfsim.devices.tag.PassiveTag
        The tags.
    seed : int
        Root seed.
    key : tuple of int
        Stream key: channel and receiver noise from ``trial_rng(seed, *key, 2)``.
    keep_exchanges : bool, optional
        Keep every exchange in the air's ``exchanges``, default False.

    Returns
    -------
    rfsim.protocols.inventory.EngineAir
        The air interface.
    """
    return EngineAir(reader, tags, _scene.Channel(room_scene(room)), rng=trial_rng(seed, *key, 2),
                     keep_exchanges=keep_exchanges)


def boresight_pair_slot(room: RoomConfig, reader_config, tag_config, *, near_m: float, far_m: float,
                        session: int, seed: int, key: tuple[int, ...]) -> dict:
    """One Q = 0 slot with a near and a far tag on the boresight of a patch; both reply.

    A circular patch (``room``'s gain and beamwidth) at (0, 0, h), h = ``room.reader_height_m``,
    faces +x; the tags are :func:`tag_antenna` dipoles at (``near_m``, 0, h) and (``far_m``, 0, h)
    facing it, in free space.

    Parameters
    ----------
    room : RoomConfig
        Reader height, patch gain and beamwidth.
    reader_config : rfsim.devices.reader_config.ReaderConfig
        The reader.
    tag_config : rfsim.devices.tag_config.TagConfig
        The tags' template.
    near_m : float
        Distance of the near tag [m].
    far_m : float
        Distance of the far tag [m].
    session : int
        Gen2 session of the Query (0–3).
    seed : int
        Root seed. Streams: the tags ``trial_rng(seed, *key, 0, k)``, the reader
        ``trial_rng(seed, *key, 1)``, the channel and noise ``trial_rng(seed, *key, 2)``.
    key : tuple of int
        Stream key of the slot.

    Returns
    -------
    dict
        ``ratio_db``: 2·(P_inc,near − P_inc,far) [dB] from the Query's incident CW powers
        (monostatic: the backscatter power ratio at the reader); ``far_m``; ``n_replies`` (tags
        that replied); ``captured`` (an EPC read although both replied); ``captured_tag``
        (0 near, 1 far, −1 none).
    """
    h = room.reader_height_m
    reader_ant = _antennas.Antenna(position_m=(0.0, 0.0, h), orientation=(0.0, 0.0, 0.0),
                                   pattern=_antennas.Patch(room.reader_gain_dbi, room.reader_beamwidth_deg),
                                   polarization="circular")
    ants = [tag_antenna((near_m, 0.0, h), math.pi), tag_antenna((far_m, 0.0, h), math.pi)]
    tags = make_tags(tag_config, ants, seed=seed, key=key + (0,))
    reader = _reader.Reader(reader_config, [reader_ant], rng=trial_rng(seed, *key, 1))
    air = EngineAir(reader, tags, _scene.Channel(_scene.Scene()), rng=trial_rng(seed, *key, 2), keep_exchanges=True)
    log = run_inventory(air, InventoryConfig(q_mode="fixed", q_initial=0.0, max_rounds=1, session=session))
    p_inc = air.exchanges[0].incident_power_dbm  # the Query
    tag = log.slots["tag"][0]
    n = log.slots["n_replies"][0]  # the reader ACKs only an RN16 its own gate accepted (none by default)
    return dict(ratio_db=2.0 * (p_inc[0] - p_inc[1]), far_m=far_m, n_replies=n,
                captured=bool(_sweep.captured(n, tag, True)), captured_tag=tag)


CAPTURE_FIELDS = {
    "point": ("1", "index of the nominal power ratio"),
    "trial": ("1", "trial at this ratio"),
    "nominal_ratio_db": ("dB", "nominal backscatter power ratio near/far, 40·log10(d_far/d_near)"),
    "ratio_db": ("dB", "modulated power ratio of the two replies at the reader: near/far, the capture_sweep's "
                       "x-axis, 2·(P_inc,near − P_inc,far) from the Query's incident CW powers, exact for these "
                       "identical fixed-state tags on reciprocal free-space links"),
    "far_m": ("m", "distance of the far tag (with a random sub-wavelength offset)"),
    "n_replies": ("1", "tags that replied with an RN16 in the slot"),
    "captured": ("1", "capture (rfsim.scenes.capture_sweep.captured): both replied, the RN16 was one tag's and "
                      "accepted (this reader has no gate: reader.rn16_false_accept = 0), that tag's EPC was read"),
    "captured_tag": ("1", "0 = near tag, 1 = far tag, -1 = none"),
}


def boresight_capture_rows(room: RoomConfig, reader_config, tag_config, *, near_m: float, ratios_db, trials: int,
                           session: int, seed: int) -> dict[str, list]:
    r"""Simulate the boresight capture trials: ``trials`` slots of :func:`boresight_pair_slot` per ratio.

    The far tag sits at :math:`d_{near} 10^{r/40}` plus a uniform offset in ±λ/4 (λ at
    915 MHz): the round-trip phase difference 4π·Δd/λ then spans a full turn, so the
    relative phase of the two replies is random, as it is between real tags.

    Parameters
    ----------
    room : RoomConfig
        Reader height, patch gain and beamwidth.
    reader_config : rfsim.devices.reader_config.ReaderConfig
        The reader.
    tag_config : rfsim.devices.tag_config.TagConfig
        The tags' template.
    near_m : float
        Distance of the near tag [m].
    ratios_db : sequence of float
        Nominal backscatter power ratios r [dB] (40·log10(d_far/d_near)).
    trials : int
        Slots per ratio.
    session : int
        Gen2 session of the Query (0–3).
    seed : int
        Root seed. Streams: ratio i, trial j: ``trial_rng(seed, 10**6 + i, j, ...)`` (the
        offset from ``..., 3``).

    Returns
    -------
    dict of str to list
        One row per trial, columns of :data:`CAPTURE_FIELDS`.
    """
    rows: dict[str, list] = {k: [] for k in CAPTURE_FIELDS}
    lam = C_M_S / 915e6
    for i, r_db in enumerate(track(ratios_db, desc="capture", unit="ratios")):
        for j in range(trials):
            key = (10**6 + i, j)
            off = trial_rng(seed, *key, 3).uniform(-lam / 4, lam / 4)
            far = near_m * 10.0 ** (r_db / 40.0) + off
            out = boresight_pair_slot(room, reader_config, tag_config, near_m=near_m, far_m=far, session=session,
                                      seed=seed, key=key)
            for k, v in dict(point=i, trial=j, nominal_ratio_db=r_db, **out).items():
                rows[k].append(v)
    return rows


def room_reads(reads, fields, tag_rows, room: RoomConfig) -> dict:
    """The ``inventory`` scenario's reads table in the per-read schema (:func:`rfsim.core.reads.reads_table`).

    The ground truth of a read is its tag's position and the distance from the reading
    antenna (:func:`reader_antennas`); NaN where the tag is not known (index −1).

    Parameters
    ----------
    reads : dict of str to array_like
        The inventories' read logs with ``population`` and ``run``.
    fields : dict of str to tuple of (str, str)
        (unit, description) of the extra columns kept from ``reads``.
    tag_rows : dict of str to array_like
        One row per tag of every inventory (``population``, ``run``, ``tag``, ``x_m``,
        ``y_m``, ``z_m``) [m].
    room : RoomConfig
        The room (its reader antennas).

    Returns
    -------
    dict of str to rfsim.core.dataset.Column
        The table's columns (:func:`rfsim.core.reads.reads_table`), with
        ``true_position_m`` (n, 3) and ``true_distance_m`` (n,) [m].
    """
    row = {key: i for i, key in enumerate(zip(tag_rows["population"], tag_rows["run"], tag_rows["tag"]))}
    xyz = np.vstack([np.column_stack([tag_rows["x_m"], tag_rows["y_m"], tag_rows["z_m"]]), np.full((1, 3), np.nan)])
    at = np.array([row.get(key, -1) for key in zip(reads["population"], reads["run"], reads["tag"])], dtype=np.int64)
    position = xyz[at]  # -1 (a tag not known): the last row, NaN
    ports = np.asarray([a.position_m for a in reader_antennas(room)], float)
    distance = np.linalg.norm(position - ports[np.asarray(reads["antenna"], np.int64) - 1], axis=1)
    return reads_table(reads, fields, true_position_m=position, true_distance_m=distance,
                       notes={"first_seen_timestamp_us": "start of the ACK segment; time restarts at 0 in each "
                                                         "inventory (population, run)",
                              "true_incident_power_dbm": "during the ACK"})


__all__ = ["CAPTURE_FIELDS", "boresight_capture_rows", "RoomConfig", "tag_epc_hex", "make_tags", "tag_antenna", "reader_antennas", "room_scene",
           "random_tag_antennas", "room_population", "room_air", "boresight_pair_slot", "room_reads"]

"""Scene-file devices that run on their own schedules: RF exciters, sense-a-tags and active
beacon tags (the sections ``[[exciter]]``, ``[[sense_a_tag]]``, ``[frame]``, ``[[beacon]]`` and
``[[beacon_reader]]`` of a scene file, :mod:`rfsim.scenes.scene_file`).

No reader command is involved; each device follows its own schedule through the air step
(:func:`rfsim.air.step.propagate`):

* **Exciters** (:class:`rfsim.devices.exciter.Exciter`) radiate CW by their ``schedule_s``
  (on/off switching times; empty: always on).
* **Sense-a-tags** listen with the single-antenna sense-a-tag receive chain (linear detector,
  band-pass, comparator, Miller/FM0 decoder: :func:`rfsim.devices.sense_a_tag.make_receiver`,
  :class:`rfsim.devices.st_rows.RowsChain`) on a vertical half-wave dipole. A sense-a-tag with
  ``period_s > 0`` also broadcasts: at ``offset_s + k·period_s`` it backscatters the exciters'
  CW with a frame of its 16-bit ``word`` and the CRC-16
  (:class:`rfsim.devices.own_schedule.OwnSchedule` over the PASS tag front end of
  :func:`rfsim.scenes.exciter.measured_tag`: it sends only when the CW it absorbs powers it),
  as the tag of the ``exciter-link`` scenario does. Each broadcast is one air step with every
  exciter, the broadcaster and every other sense-a-tag as listener (receiver noise kT·fs·F);
  a listener *decodes* the frame when its chain returns the payload bits exactly.
* **Active beacon tags** (:class:`rfsim.devices.active_tag.ActiveTag`: Manchester MSK, their own
  period, jitter and listen-before-talk) are heard by **beacon readers**
  (:class:`rfsim.devices.active_reader.ActiveReader`); :func:`rfsim.protocols.beacons.run_beacons`
  schedules them, senses the channel and runs one air step per cluster of overlapping bursts.

The channel is the scene's ``[channel]`` (walls, floor, large scale, APDP). Time runs over
``[0, run.duration_s)``; with ``duration_s = 0`` every broadcaster sends once (its first
scheduled time) and every beacon once in its first period.

Randomness (root seed s, :func:`rfsim.core.rng.trial_rng`): broadcast k (in time order) of the
sense-a-tags draws its links from ``trial_rng(s, 4, k, 0)``, its receiver noise from
``trial_rng(s, 4, k, 1)``, the broadcaster's front end from ``trial_rng(s, 4, k, 2)``; exciter i
its phase noise from ``trial_rng(s, 5, i)``; the beacons (schedule jitter, back-off) and their
readers' noise from ``trial_rng(s, 6, 0)`` and ``trial_rng(s, 6, 1)``, the beacon links' channel
draws from ``trial_rng(s, 6, 2)``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.config import from_dict, param
from rfsim.core.errors import ConfigError
from rfsim.core.figure_style import OKABE_ITO, figure, legend_outside
from rfsim.core.lazy import lazy_import
from rfsim.core.rng import trial_rng
from rfsim.devices.active_reader import ActiveReaderConfig
from rfsim.devices.active_tag import ActiveTagConfig
from rfsim.devices.exciter import ExciterConfig
from rfsim.devices.own_schedule import FrameConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.scenes.exciter import NoiseConfig

_antennas = lazy_import("rfsim.channels.antennas")
_scene = lazy_import("rfsim.channels.scene")
_air = lazy_import("rfsim.air.step")
_links = lazy_import("rfsim.air.links")
_exciter = lazy_import("rfsim.devices.exciter")
_own = lazy_import("rfsim.devices.own_schedule")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
_st_rows = lazy_import("rfsim.devices.st_rows")
_active_tag = lazy_import("rfsim.devices.active_tag")
_active_reader = lazy_import("rfsim.devices.active_reader")
_beacons = lazy_import("rfsim.protocols.beacons")
_scenes_exciter = lazy_import("rfsim.scenes.exciter")
_scenes_links = lazy_import("rfsim.scenes.links")
_bits = lazy_import("rfsim.gen2.bits")
_crc = lazy_import("rfsim.gen2.crc")

#: Sections of a scene file that this module reads.
DEVICE_SECTIONS = ("exciter", "sense_a_tag", "frame", "beacon", "beacon_reader")
V_PER_SQRT_W = math.sqrt(2.0 * 50.0)  # RF peak volts per √W at the 50 Ω detector (rfsim.devices.st_receiver)


@dataclass(frozen=True)
class Pose:
    """Where a device stands (errors name ``<section>[i].<key>``)."""

    position_m: tuple[float, float, float] = param((0.0, 0.0, 1.0), lo=-1e4, hi=1e4, unit="m",
                                                   doc="antenna position (x, y, z)")


@dataclass(frozen=True)
class ExciterPose:
    """Antenna of an ``[[exciter]]`` (the rest of its keys are ExciterConfig's)."""

    position_m: tuple[float, float, float] = param((0.0, 0.0, 1.0), lo=-1e4, hi=1e4, unit="m",
                                                   doc="antenna position (x, y, z)")
    orientation_deg: tuple[float, float, float] = param((0.0, 0.0, 0.0), lo=-360.0, hi=360.0, unit="deg",
                                                        doc="(azimuth, elevation, roll) of the boresight")
    pattern: str = param("patch", doc="patch (boresight local +x) or dipole (vertical half-wave)")
    gain_dbi: float = param(6.0, lo=0.0, hi=30.0, unit="dBi", doc="patch peak gain")
    beamwidth_deg: float = param(70.0, lo=10.0, hi=180.0, unit="deg", doc="patch half-power beamwidth")

    def __post_init__(self):
        if self.pattern not in ("patch", "dipole"):
            raise ConfigError("pattern", self.pattern, "one of 'patch', 'dipole'")

    def antenna(self):
        """Build the exciter's antenna.

        Returns
        -------
        rfsim.channels.antennas.Antenna
            At ``position_m`` [m], oriented by ``orientation_deg`` converted to rad, linear
            polarization; pattern :class:`~rfsim.channels.antennas.Patch` (``gain_dbi``,
            ``beamwidth_deg``) or :class:`~rfsim.channels.antennas.HalfWaveDipole`.
        """
        a = _antennas
        pattern = a.Patch(self.gain_dbi, self.beamwidth_deg) if self.pattern == "patch" else a.HalfWaveDipole()
        return a.Antenna(position_m=self.position_m, orientation=tuple(math.radians(v) for v in self.orientation_deg),
                         pattern=pattern, polarization="linear")


@dataclass(frozen=True)
class SenseATagSpec:
    """A ``[[sense_a_tag]]``: a listener that may also broadcast on its own schedule."""

    position_m: tuple[float, float, float] = param((1.0, 0.0, 1.0), lo=-1e4, hi=1e4, unit="m",
                                                   doc="antenna position (vertical half-wave dipole)")
    period_s: float = param(0.0, lo=0.0, hi=3600.0, unit="s", doc="broadcast period (0: listens only)")
    offset_s: float = param(0.0, lo=0.0, hi=3600.0, unit="s", doc="time of the first broadcast")
    word: int = param(0x0A5C, lo=0, hi=0xFFFF, doc="16-bit word broadcast (followed by its CRC-16)")
    threshold_v: float = param(SenseATagConfig().threshold_v, lo=0.0, hi=1.0, unit="V", doc="comparator threshold")
    detector_gain: float = param(1.0, lo=0.0, hi=1000.0, lo_open=True, doc="detector output per RF peak volt")

    def receiver_config(self) -> SenseATagConfig:
        """Return the config of this sense-a-tag's single-antenna receive chain.

        Returns
        -------
        rfsim.devices.sense_a_tag_config.SenseATagConfig
            One antenna, ``technique="single"`` (no combining), this spec's ``threshold_v``
            [V] and ``detector_gain``; other settings at their defaults.
        """
        return SenseATagConfig(n_antennas=1, technique="single", threshold_v=self.threshold_v,
                               detector_gain=self.detector_gain)


@dataclass(frozen=True)
class DeviceSpec:
    """The schedule-driven devices of a scene file (all tuples may be empty).

    Attributes
    ----------
    exciter_names : tuple of str
        Names of the exciters (``E1``, ``E2``, ... by default).
    exciters : tuple of (rfsim.devices.exciter.ExciterConfig, ExciterPose)
        Each exciter's settings and antenna, in file order.
    sense_a_tag_names : tuple of str
        Names of the sense-a-tags (``ST1``, ``ST2``, ... by default).
    sense_a_tags : tuple of SenseATagSpec
        The sense-a-tags, in file order.
    frame : rfsim.devices.own_schedule.FrameConfig
        The sense-a-tags' frames and the air steps' sample rate (``[frame]``).
    noise : rfsim.scenes.exciter.NoiseConfig
        Receiver noise at the listening sense-a-tags (``[frame]`` keys ``noise_*``).
    beacons : tuple of (rfsim.devices.active_tag.ActiveTagConfig, float, Pose)
        Each beacon's settings, schedule offset [s] and pose.
    beacon_readers : tuple of (rfsim.devices.active_reader.ActiveReaderConfig, Pose)
        Each beacon reader's settings and pose.
    """

    exciter_names: tuple[str, ...] = ()
    exciters: tuple[tuple[ExciterConfig, ExciterPose], ...] = ()
    sense_a_tag_names: tuple[str, ...] = ()
    sense_a_tags: tuple[SenseATagSpec, ...] = ()
    frame: FrameConfig = FrameConfig()
    noise: NoiseConfig = NoiseConfig()
    beacons: tuple[tuple[ActiveTagConfig, float, Pose], ...] = ()
    beacon_readers: tuple[tuple[ActiveReaderConfig, Pose], ...] = ()

    @property
    def empty(self) -> bool:
        """True when the scene has no exciter, sense-a-tag, beacon or beacon reader."""
        return not (self.exciters or self.sense_a_tags or self.beacons or self.beacon_readers)


# ------------------------------------------------------------------------------ parsing


def _entries(data, key: str) -> list:
    if data is None:
        return []
    if not isinstance(data, list) or not all(isinstance(d, dict) for d in data):
        raise ConfigError(key, data, f"an array of tables ([[{key}]])")
    return data


def names(entries: list, key: str, default: str) -> tuple[str, ...]:
    """Pop the ``name`` of each entry of an array of tables.

    Parameters
    ----------
    entries : list of dict
        The tables; their ``name`` key is removed (in place).
    key : str
        The section, for error messages (``<key>[i].name``).
    default : str
        Name prefix: entry i without a name is ``<default><i + 1>``.

    Returns
    -------
    tuple of str
        The names, in entry order.

    Raises
    ------
    rfsim.core.errors.ConfigError
        An empty or non-string name, or a name used twice (one line).
    """
    names = []
    for i, e in enumerate(entries):
        name = e.pop("name", f"{default}{i + 1}")
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{key}[{i}].name", name, "a non-empty string")
        names.append(name)
    if len(set(names)) != len(names):
        raise ConfigError(f"{key}.name", names, "distinct names")
    return tuple(names)


def _checked(cls, table: dict, prefix: str):
    """``from_dict`` whose errors name ``<prefix>.<key>`` also for the checks a device config
    makes of itself (which name the key in their own namespace)."""
    try:
        return from_dict(cls, table, prefix=prefix)
    except ConfigError as err:
        if err.key.startswith(prefix + ".") and err.key[len(prefix) + 1:].split(".")[0] in _fields(cls):
            raise
        raise ConfigError(f"{prefix}.{err.key.rsplit('.', 1)[-1]}", err.value, err.allowed) from None


def _two(cls_a, cls_b, table: dict, prefix: str, split):
    a, b = split(table, _fields(cls_a), _fields(cls_b), prefix)
    return _checked(cls_a, a, prefix), _checked(cls_b, b, prefix)


def _fields(cls) -> set[str]:
    return {f.name for f in dataclasses.fields(cls) if f.init}


def parse_devices(data: dict, split) -> DeviceSpec:
    """Validate the device sections of a scene file's tables.

    Reads ``[[exciter]]``, ``[[sense_a_tag]]``, ``[frame]``, ``[[beacon]]`` and
    ``[[beacon_reader]]`` (:data:`DEVICE_SECTIONS`); the other sections are left to the caller.

    Parameters
    ----------
    data : dict
        The scene file's tables (not modified).
    split : callable
        ``split(table, a, b, prefix)`` divides a table's keys between the field names ``a``
        and ``b`` of two dataclasses, raising a one-line
        :class:`~rfsim.core.errors.ConfigError` for an unknown key.

    Returns
    -------
    DeviceSpec
        The devices (empty tuples for absent sections).

    Raises
    ------
    rfsim.core.errors.ConfigError
        On an invalid key or value (one line naming it, e.g. ``exciter[0].eirp_dbm``); a
        broadcasting sense-a-tag without an exciter; exciters on different carriers; duplicate
        names or beacon tag IDs; beacons without beacon readers or the reverse; beacon readers
        of different sample rates.
    """
    ex = [dict(e) for e in _entries(data.get("exciter"), "exciter")]
    ex_names = names(ex, "exciter", "E")
    exciters = tuple(_two(ExciterConfig, ExciterPose, e, f"exciter[{i}]", split) for i, e in enumerate(ex))
    st = [dict(e) for e in _entries(data.get("sense_a_tag"), "sense_a_tag")]
    st_names = names(st, "sense_a_tag", "ST")
    sts = tuple(_checked(SenseATagSpec, e, f"sense_a_tag[{i}]") for i, e in enumerate(st))
    fr = data.get("frame", {})
    if not isinstance(fr, dict):
        raise ConfigError("frame", fr, "a table")
    fr = dict(fr)
    try:
        noise = from_dict(NoiseConfig, {k[len("noise_"):]: fr.pop(k) for k in list(fr) if k.startswith("noise_")},
                          prefix="frame")
    except ConfigError as err:  # the file's keys are frame.noise_<key>
        raise ConfigError(f"frame.noise_{err.key.rsplit('.', 1)[-1]}", err.value, err.allowed) from None
    frame = from_dict(FrameConfig, fr, prefix="frame")
    frame.check("frame")
    if any(s.period_s > 0 for s in sts) and not exciters:
        raise ConfigError("exciter", [], "at least one [[exciter]]: a broadcasting sense-a-tag backscatters its CW")
    fcs = {c.fc_hz for c, _ in exciters}
    if len(fcs) > 1:
        raise ConfigError("exciter.fc_hz", sorted(fcs), "one carrier shared by every exciter")
    beacons = []
    for i, e in enumerate(_entries(data.get("beacon"), "beacon")):
        e = dict(e)
        offset_s = e.pop("offset_s", None)
        pose_d = {k: e.pop(k) for k in list(e) if k == "position_m"}
        e.setdefault("tag_id", i + 1)
        cfg = _checked(ActiveTagConfig, e, f"beacon[{i}]")
        if offset_s is None:
            offset_s = cfg.jitter_s
        if isinstance(offset_s, bool) or not isinstance(offset_s, (int, float)) or not 0.0 <= offset_s <= 3600.0:
            raise ConfigError(f"beacon[{i}].offset_s", offset_s, "a number in [0, 3600] s")
        beacons.append((cfg, float(offset_s), from_dict(Pose, pose_d, prefix=f"beacon[{i}]")))
    ids = [c.tag_id for c, _, _ in beacons]
    if len(set(ids)) != len(ids):
        raise ConfigError("beacon.tag_id", ids, "distinct tag IDs")
    readers = []
    for i, e in enumerate(_entries(data.get("beacon_reader"), "beacon_reader")):
        e = dict(e)
        pose_d = {k: e.pop(k) for k in list(e) if k == "position_m"}
        readers.append((_checked(ActiveReaderConfig, e, f"beacon_reader[{i}]"),
                        from_dict(Pose, pose_d, prefix=f"beacon_reader[{i}]")))
    if bool(beacons) != bool(readers):
        missing = "beacon_reader" if beacons else "beacon"
        raise ConfigError(missing, [], f"at least one [[{missing}]] (beacons and beacon readers come together)")
    if readers and len({c.fs_hz for c, _ in readers}) > 1:
        raise ConfigError("beacon_reader.fs_hz", [c.fs_hz for c, _ in readers], "one sample rate for every reader")
    return DeviceSpec(ex_names, exciters, st_names, sts, frame, noise, tuple(beacons), tuple(readers))


# ------------------------------------------------------------------------------ running


def broadcast_times(spec: DeviceSpec, duration_s: float) -> list[tuple[float, int]]:
    """List the sense-a-tag broadcasts in ``[0, duration_s)``.

    Sense-a-tag i with ``period_s`` :math:`T_i > 0` broadcasts at
    :math:`t = o_i + k T_i` (:math:`o_i` = ``offset_s``, k = 0, 1, ...).

    Parameters
    ----------
    spec : DeviceSpec
        The devices.
    duration_s : float
        End of the time span [s]; 0: each broadcaster once, at its ``offset_s``.

    Returns
    -------
    list of (float, int)
        (time [s], sense-a-tag index) of every broadcast, sorted by time (then index).
    """
    out = []
    for i, s in enumerate(spec.sense_a_tags):
        if s.period_s <= 0:
            continue
        if duration_s <= 0:
            out.append((s.offset_s, i))
            continue
        k = 0
        while s.offset_s + k * s.period_s < duration_s:
            out.append((s.offset_s + k * s.period_s, i))
            k += 1
    return sorted(out)


def run_broadcasts(spec: DeviceSpec, scene, *, duration_s: float, seed: int) -> dict[str, list]:
    """Run every sense-a-tag broadcast, one air step each (module docstring).

    Broadcast k (:func:`broadcast_times`) is one :func:`rfsim.air.step.propagate` step of
    the frame's length: every exciter radiates, the broadcaster (the PASS tag front end under
    :class:`~rfsim.devices.own_schedule.OwnSchedule`) backscatters its word and CRC-16 when
    powered, and every other sense-a-tag listens with receiver noise kT·fs·F; a listener
    decodes when its receive chain returns the payload bits exactly.

    Parameters
    ----------
    spec : DeviceSpec
        The devices (at least one exciter when a sense-a-tag broadcasts).
    scene : rfsim.channels.scene.Scene
        The scene's channel.
    duration_s : float
        Time span [s] (:func:`broadcast_times`).
    seed : int
        Root seed: broadcast k draws its links from ``trial_rng(seed, 4, k, 0)``, receiver
        noise from ``trial_rng(seed, 4, k, 1)``, the broadcaster's front end from
        ``trial_rng(seed, 4, k, 2)``; exciter i its phase noise from ``trial_rng(seed, 5, i)``.

    Returns
    -------
    dict of str to list
        Columns :data:`DETECTION_COLUMNS`, one row per (broadcast, listening sense-a-tag);
        powers in dBm (``tag_incident_power_dbm`` is -inf when no CW reached the broadcaster).
    """
    rows: dict[str, list] = {k: [] for k in DETECTION_COLUMNS}
    times = broadcast_times(spec, duration_s)
    if not times:
        return rows
    fr = spec.frame
    exciters = [_exciter.Exciter(c, p.antenna(), rng=trial_rng(seed, 5, i)) for i, (c, p) in enumerate(spec.exciters)]
    fc_hz = spec.exciters[0][0].fc_hz
    noise_w = spec.noise.power_w(fr.fs_hz)
    sts = spec.sense_a_tags
    for k, (t_s, b) in enumerate(times):
        listeners = [j for j in range(len(sts)) if j != b]
        frame = _own.build_frame(_crc.append_crc16(_bits.int_to_bits(sts[b].word, 16)), fr, stamp_cycles=0)
        tag_ant = _antennas.vertical_dipole(np.asarray(sts[b].position_m, float))
        device = _scenes_exciter.measured_tag(tag_ant, rng=trial_rng(seed, 4, k, 2))
        reflector = _own.OwnSchedule(device, frame)
        if listeners:
            batch = _scenes_links.BatchAntenna(_antennas.vertical_dipole(np.zeros(3)),
                                               np.array([sts[j].position_m for j in listeners], float))
        links = _scenes_links.DrawnLinks()
        link_rng = trial_rng(seed, 4, k, 0)
        for e in exciters:
            _scenes_links.add_drawn_link(links, scene, e.antenna, tag_ant, fc_hz=fc_hz, rng=link_rng)
        if listeners:
            for e in exciters:
                _scenes_links.add_drawn_link(links, scene, e.antenna, batch, fc_hz=fc_hz, rng=link_rng)
            _scenes_links.add_drawn_link(links, scene, tag_ant, batch, fc_hz=fc_hz, rng=link_rng)
        ports = [_air.AntennaPort(batch, noise_power_w=noise_w)] if listeners else []
        air = _air.propagate(exciters, [reflector], ports, links, t0_s=t_s, fs_hz=fr.fs_hz,
                             n_samples=frame.n_samples, rng=trial_rng(seed, 4, k, 1), bandwidth_hz=2.0 * fr.blf_hz,
                             decide=False)
        p_inc_w = float(np.mean(np.abs(air.incident[0].samples) ** 2)) if air.incident[0] is not None else 0.0
        replied = air.reflections[0].reason == ""
        if not listeners:
            continue
        x = np.broadcast_to(air.inputs[0].samples, (len(listeners), frame.n_samples))
        for n, j in enumerate(listeners):
            rx = _sense_a_tag.make_receiver(sts[j].receiver_config(), fs_hz=fr.fs_hz, blf_hz=fr.blf_hz, m=fr.m,
                                            trext=fr.trext)
            decoded = bool(replied and _st_rows.RowsChain.run(rx, np.ascontiguousarray(x[n:n + 1])).decoded(
                rx, frame, rows=np.array([True]))[0])
            pb, pl = np.asarray(sts[b].position_m), np.asarray(sts[j].position_m)
            for key, v in (("time_s", t_s), ("broadcaster", b), ("listener", j), ("broadcaster_x_m", pb[0]),
                           ("broadcaster_y_m", pb[1]), ("broadcaster_z_m", pb[2]), ("listener_x_m", pl[0]),
                           ("listener_y_m", pl[1]), ("listener_z_m", pl[2]),
                           ("distance_m", float(np.linalg.norm(pb - pl))),
                           ("tag_incident_power_dbm", 10.0 * math.log10(p_inc_w) + 30.0 if p_inc_w > 0 else -math.inf),
                           ("listener_power_dbm", 10.0 * math.log10(float(np.mean(np.abs(x[n]) ** 2))) + 30.0),
                           ("broadcaster_replied", replied), ("decoded", decoded)):
                rows[key].append(v)
    return rows


def run_beacon_devices(spec: DeviceSpec, scene, *, duration_s: float, seed: int) -> dict[str, list]:
    """Run every beacon due in the time span through :func:`rfsim.protocols.beacons.run_beacons`.

    Parameters
    ----------
    spec : DeviceSpec
        The devices (beacons and beacon readers come together).
    scene : rfsim.channels.scene.Scene
        The scene's channel.
    duration_s : float
        Beacons due in ``[0, duration_s)`` [s]; 0: one period of the slowest beacon.
    seed : int
        Root seed: the beacons (schedule jitter, back-off) draw from ``trial_rng(seed, 6, 0)``,
        the readers' noise from ``trial_rng(seed, 6, 1)``, the channel from
        ``trial_rng(seed, 6, 2)``.

    Returns
    -------
    dict of str to list
        Columns :data:`BEACON_COLUMNS`, one row per (burst sent, beacon reader); bursts
        dropped by listen-before-talk are left out. ``rssi_dbm`` and ``rssi_reported_dbm``
        [dBm] are NaN when that reader did not decode the burst.
    """
    rows: dict[str, list] = {k: [] for k in BEACON_COLUMNS}
    if not spec.beacons:
        return rows
    rng = trial_rng(seed, 6, 0)
    tags = [_active_tag.ActiveTag(c, _antennas.Antenna(p.position_m), rng=rng) for c, _, p in spec.beacons]
    readers = [_active_reader.ActiveReader(c, _antennas.Antenna(p.position_m)) for c, p in spec.beacon_readers]
    t1_s = duration_s if duration_s > 0 else max(c.period_s for c, _, _ in spec.beacons)
    links = _links.LinkTable(_scene.Channel(scene), rng=trial_rng(seed, 6, 2))
    run = _beacons.run_beacons(tags, readers, links, t0_s=0.0, t1_s=t1_s, fs_hz=spec.beacon_readers[0][0].fs_hz,
                               rng=trial_rng(seed, 6, 1), offsets_s=[o for _, o, _ in spec.beacons])
    by_id = {c.tag_id: i for i, (c, _, _) in enumerate(spec.beacons)}
    for burst in run.bursts:
        if math.isnan(burst.t_s):
            continue
        pb = np.asarray(spec.beacons[burst.tag][2].position_m)
        for j, reads in enumerate(run.reads):
            hit = [r for r in reads if r.crc_ok and by_id.get(r.tag_id) == burst.tag and r.seq == burst.seq]
            pr = np.asarray(spec.beacon_readers[j][1].position_m)
            for key, v in (("time_s", burst.t_s), ("beacon", burst.tag), ("tag_id", spec.beacons[burst.tag][0].tag_id),
                           ("reader", j), ("seq", burst.seq), ("beacon_x_m", pb[0]), ("beacon_y_m", pb[1]),
                           ("beacon_z_m", pb[2]), ("reader_x_m", pr[0]), ("reader_y_m", pr[1]), ("reader_z_m", pr[2]),
                           ("distance_m", float(np.linalg.norm(pb - pr))),
                           ("rssi_dbm", hit[0].rssi_dbm if hit else math.nan),
                           ("rssi_reported_dbm", hit[0].rssi_reported_dbm if hit else math.nan),
                           ("collided", burst.collided), ("decoded", bool(hit))):
                rows[key].append(v)
    return rows


def run_devices(spec: DeviceSpec, scene, *, duration_s: float, seed: int) -> dict[str, dict[str, list]]:
    """Run the scene's schedule-driven devices.

    Parameters
    ----------
    spec : DeviceSpec
        The devices.
    scene : rfsim.channels.scene.Scene
        The scene's channel.
    duration_s : float
        Time span [s] (``run.duration_s``; 0: see :func:`broadcast_times` and
        :func:`run_beacon_devices`).
    seed : int
        Root seed (module docstring).

    Returns
    -------
    dict of str to dict of str to list
        ``{"detections": ...}`` of :func:`run_broadcasts` and ``{"beacon_frames": ...}`` of
        :func:`run_beacon_devices`.
    """
    return {"detections": run_broadcasts(spec, scene, duration_s=duration_s, seed=seed),
            "beacon_frames": run_beacon_devices(spec, scene, duration_s=duration_s, seed=seed)}


# ------------------------------------------------------------------------------ dataset

DETECTION_COLUMNS = {
    "time_s": ("s", "start of the broadcast (its air step)"),
    "broadcaster": ("1", "broadcasting sense-a-tag (0-based index into table sense_a_tags)"),
    "listener": ("1", "listening sense-a-tag (0-based index into table sense_a_tags)"),
    **{f"{who}_{c}_m": ("m", f"{who} {c}") for who in ("broadcaster", "listener") for c in "xyz"},
    "distance_m": ("m", "true distance broadcaster -> listener"),
    "tag_incident_power_dbm": ("dBm", "mean CW power incident at the broadcaster over the frame"),
    "listener_power_dbm": ("dBm", "mean power at the listener's antenna (CW, backscatter and noise)"),
    "broadcaster_replied": ("1", "the broadcaster was powered and sent its frame"),
    "decoded": ("1", "the listener's chain decoded the payload bits exactly"),
}
BEACON_COLUMNS = {
    "time_s": ("s", "start of the burst"),
    "beacon": ("1", "beacon (0-based index into table beacons)"),
    "tag_id": ("1", "the beacon's 32-bit tag ID"),
    "reader": ("1", "beacon reader (0-based index into table beacon_readers)"),
    "seq": ("1", "sequence number of the burst"),
    **{f"{who}_{c}_m": ("m", f"{who} {c}") for who in ("beacon", "reader") for c in "xyz"},
    "distance_m": ("m", "true distance beacon -> reader"),
    "rssi_dbm": ("dBm", "power the reader measured over the frame (NaN: not decoded)"),
    "rssi_reported_dbm": ("dBm", "RSSI the reader reports (quantised; NaN below its floor or not decoded)"),
    "collided": ("1", "the burst overlapped another beacon's burst"),
    "decoded": ("1", "the reader decoded this burst (CRC ok, its tag ID and sequence number)"),
}
_INT = {"broadcaster", "listener", "beacon", "tag_id", "reader", "seq"}
_BOOL = {"broadcaster_replied", "decoded", "collided"}


def add_device_tables(ds, d, spec: DeviceSpec, rows: dict[str, dict[str, list]]) -> None:
    """Add the device tables (:data:`DEVICE_TABLES`) to a dataset.

    Parameters
    ----------
    ds : rfsim.core.dataset.Dataset
        The dataset, extended in place.
    d : module
        :mod:`rfsim.core.dataset` (its ``column``).
    spec : DeviceSpec
        The devices: tables ``exciters``, ``sense_a_tags``, ``beacons`` and
        ``beacon_readers`` (positions [m], one row per device, possibly none).
    rows : dict of str to dict of str to list
        The rows of :func:`run_devices`: tables ``detections`` and ``beacon_frames``.
    """

    def table(src, columns):
        out = {}
        for k, (unit, doc) in columns.items():
            dt = np.int64 if k in _INT else (bool if k in _BOOL else float)
            out[k] = d.column(np.asarray(src.get(k, []), dtype=dt), unit, doc)
        return out

    def xyz(points, what):
        p = np.asarray(points, float).reshape(-1, 3)
        return {f"{c}_m": d.column(p[:, k], "m", f"{what} {c}") for k, c in enumerate("xyz")}

    ds.add_table("detections", table(rows["detections"], DETECTION_COLUMNS),
                 "one (sense-a-tag broadcast, listening sense-a-tag) pair")
    ds.add_table("beacon_frames", table(rows["beacon_frames"], BEACON_COLUMNS), "one (beacon burst sent, beacon reader) pair")
    ds.add_table("exciters", {
        "name": d.column(np.array(spec.exciter_names, dtype=str).reshape(-1), "", "exciter name"),
        **xyz([p.position_m for _, p in spec.exciters], "exciter antenna"),
        "eirp_dbm": d.column(np.array([c.eirp_dbm for c, _ in spec.exciters], float), "dBm", "EIRP"),
        "fc_hz": d.column(np.array([c.fc_hz for c, _ in spec.exciters], float), "Hz", "CW carrier"),
    }, "one RF exciter")
    ds.add_table("sense_a_tags", {
        "name": d.column(np.array(spec.sense_a_tag_names, dtype=str).reshape(-1), "", "sense-a-tag name"),
        **xyz([s.position_m for s in spec.sense_a_tags], "antenna"),
        "period_s": d.column(np.array([s.period_s for s in spec.sense_a_tags], float), "s",
                             "broadcast period (0: listens only)"),
    }, "one sense-a-tag")
    ds.add_table("beacons", {
        "tag_id": d.column(np.array([c.tag_id for c, _, _ in spec.beacons], np.int64), "1", "32-bit tag ID"),
        **xyz([p.position_m for _, _, p in spec.beacons], "antenna"),
        "period_s": d.column(np.array([c.period_s for c, _, _ in spec.beacons], float), "s", "beacon period"),
        "tx_power_dbm": d.column(np.array([c.tx_power_dbm for c, _, _ in spec.beacons], float), "dBm", "TX power"),
    }, "one active beacon tag")
    ds.add_table("beacon_readers", xyz([p.position_m for _, p in spec.beacon_readers], "antenna"),
                 "one beacon reader")


#: Tables :func:`add_device_tables` writes.
DEVICE_TABLES = ("detections", "beacon_frames", "exciters", "sense_a_tags", "beacons", "beacon_readers")


def read_device_tables(path, read_table) -> dict[str, dict[str, np.ndarray]]:
    """Read the device tables of a dataset.

    Parameters
    ----------
    path : str or pathlib.Path
        The dataset file.
    read_table : callable
        ``read_table(path, name)`` returning a table's columns and raising ``KeyError`` for
        a missing table (:func:`rfsim.core.dataset.read_table`).

    Returns
    -------
    dict of str to dict of str to ndarray
        The tables of :data:`DEVICE_TABLES` by name; empty when any is missing (a dataset
        written without :func:`add_device_tables`).
    """
    out = {}
    for name in DEVICE_TABLES:
        try:
            out[name] = read_table(path, name)
        except KeyError:
            return {}
    return out


def plot_devices(ax, tables: dict) -> None:
    """Draw exciters, sense-a-tags, beacons and beacon readers on the geometry axes.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The top view (x, y in m).
    tables : dict of str to dict of str to ndarray
        :func:`read_device_tables` output; absent or empty tables are skipped.
    """
    for name, marker, colour, label in (("exciters", "^", OKABE_ITO[5], "exciters"),
                                        ("sense_a_tags", "D", OKABE_ITO[1], "sense-a-tags"),
                                        ("beacons", "v", OKABE_ITO[0], "beacons"),
                                        ("beacon_readers", "P", OKABE_ITO[3], "beacon readers")):
        t = tables.get(name)
        if t is not None and len(t["x_m"]):
            ax.plot(t["x_m"], t["y_m"], marker, color=colour, ls="none", label=label)


def plot_detections(tables: dict):
    """Plot sense-a-tag detections and beacon frames over time.

    Parameters
    ----------
    tables : dict of str to dict of str to ndarray
        :func:`read_device_tables` output (tables ``detections`` and ``beacon_frames``).

    Returns
    -------
    matplotlib.figure.Figure or None
        One row per (sender, receiver) pair: decoded (filled circle) and missed (cross)
        frames against time [s]; None when neither table has a row.
    """
    det, bf = tables.get("detections"), tables.get("beacon_frames")
    n_det = len(det["time_s"]) if det is not None else 0
    n_bf = len(bf["time_s"]) if bf is not None else 0
    if not (n_det or n_bf):
        return None
    fig, ax = figure(columns=1, height_in=2.8)
    labels, named = [], set()
    for t, a, b, prefix in ((det, "broadcaster", "listener", "ST"), (bf, "beacon", "reader", "B")):
        if t is None or not len(t["time_s"]):
            continue
        pairs = sorted(set(zip(t[a].tolist(), t[b].tolist())))
        for (i, j) in pairs:
            sel = (t[a] == i) & (t[b] == j)
            y = len(labels)
            ok = sel & t["decoded"].astype(bool)
            for mask, marker, colour, label in ((ok, "o", OKABE_ITO[2], "decoded"),
                                                (sel & ~ok, "x", OKABE_ITO[5], "missed")):
                if mask.any():
                    ax.plot(t["time_s"][mask], np.full(mask.sum(), y), marker, ms=3, color=colour,
                            label=None if label in named else label)
                    named.add(label)
            labels.append(f"{prefix}{i}→{'ST' if prefix == 'ST' else 'R'}{j}")
    ax.set_yticks(range(len(labels)), labels, fontsize=7)
    ax.set(xlabel="time $t$ [s]", ylabel="sender → receiver", title="Detections over time")
    legend_outside(ax)
    return fig


__all__ = ["DEVICE_SECTIONS", "Pose", "ExciterPose", "SenseATagSpec", "DeviceSpec", "parse_devices",
           "broadcast_times", "run_broadcasts", "run_beacon_devices", "run_devices", "DETECTION_COLUMNS",
           "BEACON_COLUMNS", "DEVICE_TABLES", "read_device_tables", "add_device_tables", "plot_devices", "plot_detections"]

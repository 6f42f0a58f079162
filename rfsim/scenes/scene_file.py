"""Scene files: a Gen2 deployment described in TOML and run as a scenario.

``rfsim run my-scene.toml`` runs the deployment a user writes down: readers with antenna
ports, passive tags (static or moving on a straight line), the channel, and the Gen2
inventory settings. A TOML file is a scene file when its top level has ``[[reader]]``
(:func:`is_scene_file`); a scenario's ``-c`` config never has that table. The keys, with
units, are listed in ``examples/scenes/README.md``; every key is validated like a scenario
config (a one-line :class:`~rfsim.core.errors.ConfigError` naming the key, e.g.
``reader[1].antenna[0].position_m``).

Sections:

* ``[scene]``: ``description`` (optional text).
* ``[[reader]]``: any :class:`rfsim.devices.reader_config.ReaderConfig` key (``link_profile``,
  ``ptx_dbm``, ``region``, ``channels_hz``, ``hopping``, ``dwell_s``, ``fixed_channel``, ...)
  plus ``name`` and one or more ``[[reader.antenna]]`` ports (:class:`AntennaSpec`), used in
  turn, one per inventory round (round robin, :meth:`rfsim.devices.reader.Reader.antenna_index`).
* ``[[tag]]``: any :class:`rfsim.devices.tag_config.TagConfig` key (``epc_hex``,
  ``sensitivity_dbm``, ``modulation``, ...) plus the pose and motion of :class:`TagSpec`
  (``count`` tags in a row ``step_m`` apart; ``velocity_m_s`` moves them on a straight line
  from ``position_m`` at t = 0).
* ``[channel]``: :class:`ChannelSpec` (large scale, floor reflection, APDP, spatially correlated
  log-normal shadowing) with optional ``[[channel.wall]]`` tables (:class:`WallSpec`) and
  ``[[channel.surface]]`` tables (:class:`SurfaceSpec`: reflecting planes or rectangles).
* ``[run]``: any :class:`rfsim.protocols.inventory.InventoryConfig` key (``session``,
  ``q_initial``, ``q_mode``, ``target``, ``max_rounds``, ...) plus ``duration_s``.
* ``[[exciter]]``, ``[[sense_a_tag]]``, ``[frame]``, ``[[beacon]]``, ``[[beacon_reader]]``:
  devices that run on their own schedules (:mod:`rfsim.scenes.scene_devices`; tables
  ``detections`` and ``beacon_frames``). A scene of these alone needs no ``[[reader]]``.

How it runs (:func:`run_scene`): the readers take turns (time division; one transmits at a
time, no reader-to-reader interference is modelled). Reader i runs one inventory
(:func:`rfsim.protocols.inventory.run_inventory` over a sample-level
:class:`~rfsim.protocols.inventory.EngineAir`: rounds until one without a reply, at most
``run.max_rounds``), then switches its CW off (every tag loses power) and hands over to reader
i + 1. With ``duration_s = 0`` every reader runs once; with ``duration_s > 0`` the cycle of
readers repeats until the air time reaches ``duration_s``.

Randomness (``seed`` is the run's root seed, :func:`rfsim.core.rng.trial_rng`): reader i
(its hop table) ``trial_rng(seed, 1, i)``; tag k (in file order, rows expanded)
``trial_rng(seed, 3, k)``; the channel draws and receiver noise of reader i
``trial_rng(seed, 2, i)``; the shadowing field (one per run) ``trial_rng(seed, 8)``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from types import ModuleType
from typing import Any, Literal

import numpy as np

from rfsim.core.config import from_dict, param, parse_override
from rfsim.core.errors import ConfigError, UserError, did_you_mean
from rfsim.core.lazy import lazy_import
from rfsim.core.figure_style import OKABE_ITO, figure, legend_outside, paper_style, series_style, source_note
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.records import READ_MEASUREMENT_FIELDS
from rfsim.core.rng import trial_rng
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.protocols.inventory import EngineAir, InventoryConfig, run_inventory
from rfsim.scenes import scene_devices, scene_himr

_antennas = lazy_import("rfsim.channels.antennas")
_large_scale = lazy_import("rfsim.channels.large_scale")
_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_surfaces = lazy_import("rfsim.channels.surfaces")
_reader = lazy_import("rfsim.devices.reader")
_tag = lazy_import("rfsim.devices.tag")
_dataset = lazy_import("rfsim.core.dataset")
_reads = lazy_import("rfsim.core.reads")

#: Top-level sections of a scene file.
SECTIONS = ("scene", "reader", "tag", "channel", "run", *scene_devices.DEVICE_SECTIONS, *scene_himr.HIMR_SECTIONS)
#: Arrays of tables that make a TOML file a scene file.
DEVICE_KINDS = ("reader", "exciter", "sense_a_tag", "beacon", "himr_tag", "pylon")


@dataclass(frozen=True)
class AntennaSpec:
    """One antenna port of a reader or the antenna of a tag (errors name ``…antenna[j].<key>``)."""

    position_m: tuple[float, float, float] = param((0.0, 0.0, 1.0), lo=-1e4, hi=1e4, unit="m",
                                                   doc="antenna position (x, y, z)")
    orientation_deg: tuple[float, float, float] = param(
        (0.0, 0.0, 0.0), lo=-360.0, hi=360.0, unit="deg",
        doc="(azimuth, elevation, roll): boresight direction (azimuth from +x towards +y)")
    pattern: Literal["isotropic", "dipole", "patch"] = param(
        "patch", doc="isotropic, half-wave dipole (axis along local z) or patch (boresight local +x)")
    gain_dbi: float = param(6.0, lo=-20.0, hi=30.0, unit="dBi", doc="patch peak gain (isotropic: its gain)")
    beamwidth_deg: float = param(70.0, lo=10.0, hi=180.0, unit="deg", doc="patch half-power beamwidth")
    polarization: Literal["linear", "circular"] = param("circular", doc="antenna polarization")

    def antenna(self):
        """Build the antenna this spec describes.

        Returns
        -------
        rfsim.channels.antennas.Antenna
            At ``position_m`` [m], oriented by ``orientation_deg`` converted to rad; pattern
            :class:`~rfsim.channels.antennas.Patch` (``gain_dbi``, ``beamwidth_deg``),
            :class:`~rfsim.channels.antennas.HalfWaveDipole` or
            :class:`~rfsim.channels.antennas.Isotropic` of linear gain
            :math:`10^{G/10}` (G = ``gain_dbi``).
        """
        a = _antennas
        if self.pattern == "patch":
            pattern = a.Patch(self.gain_dbi, self.beamwidth_deg)
        elif self.pattern == "dipole":
            pattern = a.HalfWaveDipole()
        else:
            pattern = a.Isotropic(10.0 ** (self.gain_dbi / 10.0))
        return a.Antenna(position_m=self.position_m, orientation=tuple(math.radians(v) for v in self.orientation_deg),
                         pattern=pattern, polarization=self.polarization)


@dataclass(frozen=True)
class TagSpec:
    """Pose, antenna and motion of a ``[[tag]]`` entry (the rest of its keys are TagConfig's)."""

    position_m: tuple[float, float, float] = param((1.0, 0.0, 1.0), lo=-1e4, hi=1e4, unit="m",
                                                   doc="position of the (first) tag at t = 0")
    orientation_deg: tuple[float, float, float] = param(
        (180.0, 0.0, 0.0), lo=-360.0, hi=360.0, unit="deg", doc="(azimuth, elevation, roll) of the tag antenna")
    pattern: Literal["isotropic", "dipole"] = param("dipole", doc="tag antenna pattern (half-wave dipole)")
    polarization: Literal["linear", "circular"] = param("linear", doc="tag antenna polarization")
    count: int = param(1, lo=1, hi=10000, doc="tags in a row: tag n at position_m + n·step_m, EPCs numbered")
    step_m: tuple[float, float, float] = param((0.05, 0.0, 0.0), lo=-1e3, hi=1e3, unit="m",
                                               doc="spacing of the row (count > 1)")
    velocity_m_s: tuple[float, float, float] = param((0.0, 0.0, 0.0), lo=-100.0, hi=100.0, unit="m/s",
                                                     doc="straight-line motion: position_m + v·t")


@dataclass(frozen=True)
class WallSpec:
    """A vertical wall over a floor-plan segment (``[[channel.wall]]``)."""

    start_m: tuple[float, float] = param((0.0, 0.0), lo=-1e4, hi=1e4, unit="m", doc="segment start (x, y)")
    end_m: tuple[float, float] = param((1.0, 0.0), lo=-1e4, hi=1e4, unit="m", doc="segment end (x, y)")
    attenuation_db: float = param(5.0, lo=0.0, hi=100.0, unit="dB", doc="loss per crossing (WAF)")


@dataclass(frozen=True)
class SurfaceSpec:
    """A flat reflecting surface (``[[channel.surface]]``): a ceiling, a metal shelf, a wall that
    reflects (:class:`rfsim.channels.surfaces.Surface`, image method of order 1)."""

    point_m: tuple[float, float, float] = param((0.0, 0.0, 3.0), lo=-1e4, hi=1e4, unit="m",
                                                doc="a point of the plane (the rectangle's centre when finite)")
    normal: tuple[float, float, float] = param((0.0, 0.0, 1.0), lo=-1.0, hi=1.0, unit="1", doc="plane normal")
    eps_r: float = param(5.3, lo=1.0, hi=1e7, unit="1", doc="relative permittivity (concrete 5.3; metal: large)")
    half_size_m: tuple[float, float] = param((0.0, 0.0), lo=0.0, hi=1e4, unit="m",
                                             doc="half-widths of a finite rectangle ((0, 0): unbounded plane)")

    def __post_init__(self):
        if not any(self.normal):
            raise ConfigError("normal", list(self.normal), "a non-zero vector")
        if (min(self.half_size_m) == 0.0) != (max(self.half_size_m) == 0.0):
            raise ConfigError("half_size_m", list(self.half_size_m),
                              "two positive half-widths, or [0, 0] for an unbounded plane")

    def surface(self):
        """The channel's surface of this table.

        Returns
        -------
        rfsim.channels.surfaces.Surface
            The plane through ``point_m`` with normal ``normal``, permittivity ``eps_r``,
            unbounded or a rectangle of half-widths ``half_size_m``.
        """
        half = None if max(self.half_size_m) == 0.0 else self.half_size_m
        return _surfaces.Surface(point_m=self.point_m, normal=self.normal, eps_r=self.eps_r, half_size_m=half)


@dataclass(frozen=True)
class ChannelSpec:
    """The ``[channel]`` table."""

    large_scale: Literal["friis", "log_distance"] = param("friis", doc="large-scale path-loss model")
    path_loss_exponent: float = param(2.0, lo=1.0, hi=6.0, unit="1", doc="log_distance: exponent n")
    d0_m: float = param(1.0, lo=0.01, hi=100.0, unit="m", doc="log_distance: reference distance (free space there)")
    floor: bool = param(False, doc="floor reflection at z = 0 (image method)")
    floor_eps_r: float = param(5.3, lo=1.0, hi=100.0, unit="1", doc="floor relative permittivity (concrete 5.3)")
    apdp: bool = param(False, doc="exponential APDP diffuse taps, drawn per round (PASS room curves)")
    k_a_db: float = param(60.0, lo=-100.0, hi=200.0, unit="dB", doc="APDP K(d) = k_a_db·10^(−k_b·d) + k_c_db")
    k_b: float = param(0.02, lo=0.0, hi=10.0, unit="1/m", doc="APDP K-factor decay")
    k_c_db: float = param(-30.0, lo=-100.0, hi=100.0, unit="dB", doc="APDP K-factor offset")
    tau_max_s: float = param(70e-9, lo=0.0, hi=1e-5, lo_open=True, unit="s",
                             doc="APDP τrms(d) = tau_max_s·(1 − 10^(−tau_b·d))")
    tau_b: float = param(0.03, lo=0.0, hi=10.0, lo_open=True, unit="1/m", doc="APDP delay-spread growth")
    shadowing_sigma_db: float = param(0.0, lo=0.0, hi=30.0, unit="dB",
                                      doc="log-normal shadowing σ (0: none), spatially correlated")
    shadowing_decorrelation_m: float = param(3.0, lo=0.01, hi=1e3, unit="m",
                                             doc="shadowing decorrelation distance (Gudmundson exp(−Δ/d))")

    def scene(self, walls: tuple = (), surfaces: tuple = (), *, rng=None):
        """Build the channel scene of this table and the walls.

        Parameters
        ----------
        walls : tuple of WallSpec, default ()
            The ``[[channel.wall]]`` tables; each becomes a vertical wall over its floor-plan
            segment (:meth:`rfsim.channels.large_scale.Wall.segment_2d`).
        surfaces : tuple of SurfaceSpec, default ()
            The ``[[channel.surface]]`` tables, reflecting surfaces besides the floor.
        rng : numpy.random.Generator, optional
            Draws the shadowing field's realisation; needed when ``shadowing_sigma_db > 0``.

        Returns
        -------
        rfsim.channels.scene.Scene
            Image order 1; a floor at z = 0 of permittivity ``floor_eps_r`` when ``floor``;
            :class:`~rfsim.channels.large_scale.LogDistance` large scale for
            ``large_scale = "log_distance"`` (else None: Friis); the exponential
            :class:`~rfsim.channels.small_scale.ApdpModel` when ``apdp``; the surfaces; a
            :class:`~rfsim.channels.large_scale.ShadowingField` (σ, decorrelation distance;
            rssi-localization.md §1.9) when ``shadowing_sigma_db > 0``.
        """
        floor = ((_surfaces.Surface(point_m=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), eps_r=self.floor_eps_r),)
                 if self.floor else ())
        surfaces = floor + tuple(s.surface() for s in surfaces)
        shadowing = (_large_scale.ShadowingField(self.shadowing_sigma_db, self.shadowing_decorrelation_m, rng=rng)
                     if self.shadowing_sigma_db > 0 else None)
        large = (_large_scale.LogDistance(exponent=self.path_loss_exponent, d0_m=self.d0_m)
                 if self.large_scale == "log_distance" else None)
        apdp = (_small_scale.ApdpModel(k_a_db=self.k_a_db, k_b=self.k_b, k_c_db=self.k_c_db,
                                       tau_max_s=self.tau_max_s, tau_b=self.tau_b) if self.apdp else None)
        walls = tuple(_large_scale.Wall.segment_2d(w.start_m, w.end_m, w.attenuation_db) for w in walls)
        return _scene.Scene(surfaces=surfaces, walls=walls, large_scale=large, apdp=apdp, shadowing=shadowing,
                            image_order=1)


@dataclass(frozen=True)
class ReaderSpec:
    """One ``[[reader]]``: its name, config and antenna ports.

    Attributes
    ----------
    name : str
        Reader name (``R1``, ``R2``, ... by default; distinct).
    config : rfsim.devices.reader_config.ReaderConfig
        The reader's settings.
    antennas : tuple of AntennaSpec
        The antenna ports, used in turn, one per inventory round.
    """

    name: str
    config: ReaderConfig
    antennas: tuple[AntennaSpec, ...]


@dataclass(frozen=True)
class TagEntry:
    """One tag after the rows of ``[[tag]]`` are expanded.

    Attributes
    ----------
    config : rfsim.devices.tag_config.TagConfig
        The chip settings, with the tag's own (numbered or explicit) EPC.
    antenna : AntennaSpec
        The tag antenna at its position at t = 0 [m] (gain 0 dBi).
    velocity_m_s : tuple of float
        Straight-line velocity (vx, vy, vz) [m/s]: position at t is
        ``position_m + velocity_m_s·t``.
    """

    config: TagConfig
    antenna: AntennaSpec
    velocity_m_s: tuple[float, float, float]


@dataclass(frozen=True)
class SceneSpec:
    """A validated scene file (:func:`parse_scene`).

    Attributes
    ----------
    description : str
        ``[scene].description`` ("" when absent).
    readers : tuple of ReaderSpec
        The Gen2 readers, in file order (may be empty when the scene has other devices).
    tags : tuple of TagEntry
        The passive tags, rows expanded, in file order.
    channel : ChannelSpec
        The ``[channel]`` table.
    walls : tuple of WallSpec
        The ``[[channel.wall]]`` tables.
    inventory : rfsim.protocols.inventory.InventoryConfig
        The ``[run]`` inventory settings every reader uses.
    duration_s : float
        ``run.duration_s`` [s]; 0: every reader runs one inventory.
    devices : rfsim.scenes.scene_devices.DeviceSpec
        Exciters, sense-a-tags and beacons (empty by default).
    himr : rfsim.scenes.scene_himr.HimrSpec
        HIMR tags and pylons (empty by default).
    surfaces : tuple of SurfaceSpec
        The ``[[channel.surface]]`` tables (reflecting surfaces besides the floor).
    """

    description: str
    readers: tuple[ReaderSpec, ...]
    tags: tuple[TagEntry, ...]
    channel: ChannelSpec
    walls: tuple[WallSpec, ...]
    inventory: InventoryConfig
    duration_s: float
    devices: scene_devices.DeviceSpec = scene_devices.DeviceSpec()
    himr: scene_himr.HimrSpec = scene_himr.HimrSpec()
    surfaces: tuple[SurfaceSpec, ...] = ()


# ------------------------------------------------------------------------------ parsing


def is_scene_file(path: str | Path) -> bool:
    """Tell whether ``path`` is a scene file.

    A scene file is a readable ``.toml`` file whose top level has an array of tables of a
    device kind (:data:`DEVICE_KINDS`): ``[[reader]]``, ``[[exciter]]``, ``[[sense_a_tag]]``,
    ``[[beacon]]``, ``[[himr_tag]]`` or ``[[pylon]]``.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    bool
        True for a scene file; False for any other path, including a file that cannot be
        read or is not valid TOML (no error is raised).
    """
    p = Path(path)
    if p.suffix != ".toml" or not p.is_file():
        return False
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False
    return any(isinstance(data.get(k), list) for k in DEVICE_KINDS)


def _fields(cls) -> set[str]:
    return {f.name for f in dataclasses.fields(cls) if f.init}


def _unknown(key: str, value: Any, allowed: set[str]) -> ConfigError:
    hint = did_you_mean(key.rsplit(".", 1)[-1], allowed)
    return ConfigError(key, value, "a known key" + (hint or f" (one of {', '.join(sorted(allowed))})"))


def _table(data: Any, key: str) -> dict:
    if not isinstance(data, dict):
        raise ConfigError(key, data, "a table")
    return data


def _array_of_tables(data: Any, key: str, *, required: bool) -> list:
    if data is None:
        if required:
            raise ConfigError(key, None, f"at least one [[{key}]] table")
        return []
    if not isinstance(data, list) or not all(isinstance(d, dict) for d in data) or (required and not data):
        raise ConfigError(key, data, f"an array of tables ([[{key}]])")
    return data


def _split(data: dict, a: set[str], b: set[str], prefix: str, extra: tuple[str, ...] = ()) -> tuple[dict, dict]:
    """Split a table's keys between two sets of names (unknown keys: one-line error)."""
    left, right = {}, {}
    for k, v in data.items():
        if k in extra:
            continue
        if k in a:
            left[k] = v
        elif k in b:
            right[k] = v
        else:
            raise _unknown(f"{prefix}.{k}", v, a | b | set(extra))
    return left, right


def parse_scene(data: dict) -> SceneSpec:
    """Validate a scene file's tables into a :class:`SceneSpec`.

    Rows of ``[[tag]]`` are expanded (``count`` tags ``step_m`` apart); tags without an
    explicit ``epc_hex`` (and every tag of a row) are numbered in file order: tag k gets
    k + 1 in the template EPC's length. Each reader is built once with its ports to run the
    checks a :class:`rfsim.devices.reader.Reader` makes of its config.

    Parameters
    ----------
    data : dict
        The file's tables (:func:`tomllib.loads` output, e.g. from :func:`read_scene`).

    Returns
    -------
    SceneSpec
        The validated scene.

    Raises
    ------
    rfsim.core.errors.ConfigError
        On an unknown section or key, a wrong type or an out-of-range value (one line naming
        the key, e.g. ``reader[1].antenna[0].position_m``); on duplicate reader names or EPCs;
        without any reader or schedule-driven/HIMR device; ``run.duration_s`` outside
        [0, 3600] s.
    """
    for k in data:
        if k not in SECTIONS:
            form = f"[[{k}]]" if isinstance(data[k], list) else f"[{k}]" if isinstance(data[k], dict) else f"{k} = …"
            raise ConfigError(k, form, f"a scene section: one of [scene], [[reader]], [[tag]], [channel], [run], "
                                       "[[exciter]], [[sense_a_tag]], [frame], [[beacon]], [[beacon_reader]], "
                                       "[[himr_tag]], [[pylon]], [himr_radio]")
    scene = _table(data.get("scene", {}), "scene")
    for k in scene:
        if k != "description":
            raise _unknown(f"scene.{k}", scene[k], {"description"})
    description = scene.get("description", "")
    if not isinstance(description, str):
        raise ConfigError("scene.description", description, "a string")
    devices = scene_devices.parse_devices(data, _split)
    himr = scene_himr.parse_himr(data, scene_devices.names)
    # a scene of schedule-driven devices or HIMR tags alone needs no reader
    gen2 = (devices.empty and himr.empty) or "reader" in data

    readers = []
    for i, r in enumerate(_array_of_tables(data.get("reader"), "reader", required=gen2)):
        prefix = f"reader[{i}]"
        cfg, _ = _split(r, _fields(ReaderConfig), set(), prefix, extra=("name", "antenna"))
        name = r.get("name", f"R{i + 1}")
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{prefix}.name", name, "a non-empty string")
        ants = tuple(from_dict(AntennaSpec, a, prefix=f"{prefix}.antenna[{j}]")
                     for j, a in enumerate(_array_of_tables(r.get("antenna"), f"{prefix}.antenna", required=True)))
        spec = ReaderSpec(name, from_dict(ReaderConfig, cfg, prefix=prefix), ants)
        try:  # the checks a Reader makes of its config with its ports (dwell, channel, fs)
            _reader.Reader(spec.config, [a.antenna() for a in ants], rng=np.random.default_rng(0))
        except ConfigError as err:
            key = prefix + err.key[len("reader"):] if err.key.startswith("reader.") else f"{prefix}.{err.key}"
            raise ConfigError(key, err.value, err.allowed) from None
        readers.append(spec)
    if len({r.name for r in readers}) != len(readers):
        raise ConfigError("reader.name", [r.name for r in readers], "distinct reader names")

    tags = []
    for i, t in enumerate(_array_of_tables(data.get("tag"), "tag", required=gen2)):
        prefix = f"tag[{i}]"
        pose_d, cfg_d = _split(t, _fields(TagSpec), _fields(TagConfig), prefix)
        pose = from_dict(TagSpec, pose_d, prefix=prefix)
        cfg = from_dict(TagConfig, cfg_d, prefix=prefix)
        for n in range(pose.count):
            pos = tuple(p + n * s for p, s in zip(pose.position_m, pose.step_m))
            ant = AntennaSpec(position_m=pos, orientation_deg=pose.orientation_deg, pattern=pose.pattern,
                              gain_dbi=0.0, polarization=pose.polarization)
            epc = cfg.epc_hex if "epc_hex" in cfg_d and pose.count == 1 else None
            tags.append((cfg, ant, pose.velocity_m_s, epc))
    entries = []
    for k, (cfg, ant, vel, epc) in enumerate(tags):
        # tags without an explicit EPC are numbered in file order: the template's length with k + 1
        n_hex = len(cfg.epc_hex.replace(" ", ""))
        entries.append(TagEntry(replace(cfg, epc_hex=epc or format(k + 1, f"0{n_hex}X")[-n_hex:]), ant, vel))
    epcs = [e.config.epc_hex for e in entries]
    if len(set(epcs)) != len(epcs):
        raise ConfigError("tag.epc_hex", sorted({e for e in epcs if epcs.count(e) > 1}), "distinct EPCs")

    ch = dict(_table(data.get("channel", {}), "channel"))
    walls = tuple(from_dict(WallSpec, w, prefix=f"channel.wall[{j}]")
                  for j, w in enumerate(_array_of_tables(ch.pop("wall", None), "channel.wall", required=False)))
    surfaces = tuple(from_dict(SurfaceSpec, w, prefix=f"channel.surface[{j}]") for j, w in
                     enumerate(_array_of_tables(ch.pop("surface", None), "channel.surface", required=False)))
    channel = from_dict(ChannelSpec, ch, prefix="channel")

    run = dict(_table(data.get("run", {}), "run"))
    duration_s = run.pop("duration_s", 0.0)
    if isinstance(duration_s, bool) or not isinstance(duration_s, (int, float)) or not 0.0 <= duration_s <= 3600.0:
        raise ConfigError("run.duration_s", duration_s, "a number in [0, 3600] s (0: each reader one inventory)")
    for k in run:
        if k not in _fields(InventoryConfig):
            raise _unknown(f"run.{k}", run[k], _fields(InventoryConfig) | {"duration_s"})
    inventory = from_dict(InventoryConfig, run, prefix="run")
    scene_himr.check_himr(himr, float(duration_s))
    return SceneSpec(description, tuple(readers), tuple(entries), channel, walls, inventory, float(duration_s), devices,
                     himr, surfaces)


def channel_scene(spec: SceneSpec, *, seed: int):
    """The channel scene of a scene file: large scale, floor, surfaces, walls, APDP, shadowing.

    Parameters
    ----------
    spec : SceneSpec
        The validated scene file.
    seed : int
        The run's root seed; the shadowing field's realisation is drawn from
        ``trial_rng(seed, 8)`` (one quasi-static field for the whole run, the same for every
        reader and device).

    Returns
    -------
    rfsim.channels.scene.Scene
        :meth:`ChannelSpec.scene` of the ``[channel]`` table, its walls and surfaces.
    """
    return spec.channel.scene(spec.walls, spec.surfaces, rng=trial_rng(seed, 8))


def _apply_override(data: dict, text: str) -> None:
    """``--set a.b=value`` on the scene's tables (arrays of tables are addressed by index:
    ``reader.0.ptx_dbm=20``)."""
    path, value = parse_override(text)
    node: Any = data
    for depth, part in enumerate(path[:-1]):
        where = ".".join(path[: depth + 1])
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise UserError(f"--set {text!r}: {where!r} must index one of the {len(node)} entries")
            node = node[int(part)]
        elif isinstance(node, dict):
            node = node.setdefault(part, {})
        if not isinstance(node, (dict, list)):
            raise UserError(f"--set {text!r}: {where!r} is a plain value, not a table")
    if isinstance(node, list):
        raise UserError(f"--set {text!r}: name a key of one entry, e.g. reader.0.ptx_dbm=20")
    node[path[-1]] = value


def read_scene(path: str | Path, overrides=()) -> dict:
    """Read the tables of scene file ``path`` and apply ``--set`` overrides.

    Parameters
    ----------
    path : str or pathlib.Path
        The scene file.
    overrides : iterable of str, default ()
        ``key=value`` texts as given to ``--set``; arrays of tables are addressed by index
        (``reader.0.ptx_dbm=20``).

    Returns
    -------
    dict
        The file's tables (not validated: see :func:`parse_scene`).

    Raises
    ------
    rfsim.core.errors.UserError
        The file cannot be read or is not valid TOML, or an override addresses no key of
        one entry (one line).
    """
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except OSError as err:
        raise UserError(f"scene file {str(p)!r}: cannot be read ({err.strerror})") from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise UserError(f"scene file {str(p)!r}: not valid TOML ({err})") from None
    for text in overrides:
        _apply_override(data, text)
    return data


# ------------------------------------------------------------------------------ building


def build_readers(spec: SceneSpec, *, seed: int) -> list:
    """Build one reader per ``[[reader]]``.

    Parameters
    ----------
    spec : SceneSpec
        The scene.
    seed : int
        Root seed; reader i (its hop table) draws from ``trial_rng(seed, 1, i)``.

    Returns
    -------
    list of rfsim.devices.reader.Reader
        In file order, each with its antenna ports.
    """
    return [_reader.Reader(r.config, [a.antenna() for a in r.antennas], rng=trial_rng(seed, 1, i))
            for i, r in enumerate(spec.readers)]


def build_tags(spec: SceneSpec, *, seed: int) -> list:
    """Build one passive tag per tag of the scene (rows expanded).

    Parameters
    ----------
    spec : SceneSpec
        The scene.
    seed : int
        Root seed; tag k (0-based, file order) draws from ``trial_rng(seed, 3, k)``.

    Returns
    -------
    list of rfsim.devices.tag.PassiveTag
        In the order of ``spec.tags``, each at its position at t = 0.
    """
    return [_tag.PassiveTag(e.config, e.antenna.antenna(), rng=trial_rng(seed, 3, k)) for k, e in enumerate(spec.tags)]


def _true_position_m(tag_entry: TagEntry, t_s: float) -> np.ndarray:
    return np.asarray(tag_entry.antenna.position_m) + np.asarray(tag_entry.velocity_m_s) * t_s


def _true_distance_m(reader_ant, tag_entry: TagEntry, t_s: float) -> float:
    return float(np.linalg.norm(_true_position_m(tag_entry, t_s) - np.asarray(reader_ant.position_m)))


def run_scene(spec: SceneSpec, *, seed: int) -> dict[str, dict[str, list]]:
    """Run the Gen2 readers of the scene in turn (module docstring).

    Reader i runs one inventory (:func:`rfsim.protocols.inventory.run_inventory` over a
    sample-level :class:`~rfsim.protocols.inventory.EngineAir`), switches its CW off and hands
    over to reader i + 1; with ``spec.duration_s > 0`` the cycle repeats until the air time
    reaches it. Moving tags move during the exchanges.

    Parameters
    ----------
    spec : SceneSpec
        The scene (at least one reader).
    seed : int
        Root seed: readers ``trial_rng(seed, 1, i)``, tags ``trial_rng(seed, 3, k)``, channel
        and receiver noise of reader i ``trial_rng(seed, 2, i)``.

    Returns
    -------
    dict of str to dict of str to list
        ``{"reads": ..., "slots": ...}``: columns of the inventory logs, every row with
        ``reader`` (0-based index); reads also have ``true_distance_m`` (tag to reading port
        at the read time [m]) and ``true_position_m`` (ndarray, shape (3,) [m]), NaN when the
        tag is not unique (``tag`` = -1).
    """
    readers = build_readers(spec, seed=seed)
    tags = build_tags(spec, seed=seed)
    moving = any(any(v != 0.0 for v in e.velocity_m_s) for e in spec.tags)
    motions = [np.asarray(e.velocity_m_s, float) for e in spec.tags] if moving else None
    channel = _scene.Channel(channel_scene(spec, seed=seed))
    airs = [EngineAir(r, tags, channel, rng=trial_rng(seed, 2, i), motions=motions) for i, r in enumerate(readers)]
    reads: dict[str, list] = {}
    slots: dict[str, list] = {}
    t_s = 0.0
    while True:
        for i, air in enumerate(airs):
            log = run_inventory(air, spec.inventory, t0_s=t_s)
            t_s = log.t_end_s
            air.cw_off(t_s)
            for rows, part in ((reads, log.reads), (slots, log.slots)):
                n = len(next(iter(part.values())))
                rows.setdefault("reader", []).extend([i] * n)
                for k, v in part.items():
                    rows.setdefault(k, []).extend(v)
            ants = readers[i].antennas
            for tag, ant, t in zip(log.reads["tag"], log.reads["antenna"], log.reads["time_s"]):
                d = _true_distance_m(ants[ant - 1], spec.tags[tag], t) if tag >= 0 else math.nan
                reads.setdefault("true_distance_m", []).append(d)
                reads.setdefault("true_position_m", []).append(
                    _true_position_m(spec.tags[tag], t) if tag >= 0 else np.full(3, np.nan))
        if spec.duration_s <= 0.0 or t_s >= spec.duration_s:
            break
    reads.setdefault("true_distance_m", [])
    reads.setdefault("true_position_m", [])
    return {"reads": reads, "slots": slots}


# ------------------------------------------------------------------------------ dataset

#: Columns of the reads table beside the per-read schema (rfsim.core.reads).
READ_COLUMNS = {
    "time_s": ("s", "start of the ACK segment of the read"),
    "reader": ("1", "reader (0-based index in file order, see table readers)"),
    "snr_db": READ_MEASUREMENT_FIELDS["snr_db"],
    "tag": ("1", "tag (0-based index into table tags; -1 if not unique)"),
    "round": ("1", "inventory round of the reader's inventory (0-based)"),
    "n_replies": ("1", "tags that replied in the RN16 slot (> 1: capture)"),
}
SLOT_COLUMNS = {
    "time_s": ("s", "slot start (its command's segment)"),
    "duration_s": ("s", "slot duration"),
    "reader": ("1", "reader (0-based index)"),
    "antenna": ("1", "reader antenna port (1-based)"),
    "round": ("1", "inventory round (0-based)"),
    "q": ("1", "Q of the slot"),
    "slot_type": ("", "ground truth: empty, false_alarm, success, capture, collision or lost"),
    "reader_view": ("", "what the reader saw: empty, success or collision"),
    "n_replies": ("1", "tags that replied with an RN16"),
    "tag": ("1", "tag read (-1: none)"),
}


def _read_schema(reads: dict[str, list]) -> dict:
    """The per-read schema's columns of the scene's reads (every row a reported read)."""
    if not reads.get("time_s"):  # nothing read: empty columns of the schema's types
        reads = {"epc_hex": [], "antenna": [], "channel_index": [], "true_position_m": np.zeros((0, 3)), **{
            k: np.zeros(0) for k in ("time_s", "frequency_hz", "rssi_dbm", "phase_rad", "doppler_hz",
                                     "tag_incident_power_dbm", "true_distance_m")}}
    return _reads.log_read_columns(reads, notes={"first_seen_timestamp_us": "start of the ACK segment",
                                                 "true_incident_power_dbm": "during the ACK"})


def scene_dataset(spec: SceneSpec, rows: dict[str, dict[str, list]]):
    """Build the scene's dataset from the rows of :func:`run_scene`.

    Parameters
    ----------
    spec : SceneSpec
        The scene (its description is the title).
    rows : dict of str to dict of str to list
        ``{"reads": ..., "slots": ...}`` as :func:`run_scene` returns (empty dicts without
        readers).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``reads`` (the per-read schema of :mod:`rfsim.core.reads` plus
        :data:`READ_COLUMNS`), ``slots`` (:data:`SLOT_COLUMNS`), ``readers`` (one row per
        antenna port), ``tags`` (pose at t = 0 [m], velocity [m/s], sensitivity [dBm]) and
        ``walls``.
    """
    d = _dataset
    ds = d.Dataset(title=spec.description or "scene file: Gen2 inventory of a described deployment")

    def col(values, spec_, dtype=None):
        units, doc = spec_
        arr = np.asarray(values, dtype=dtype) if len(values) or dtype else np.asarray(values, dtype=float)
        return d.column(arr, units, doc)

    text_cols = {"epc_hex", "slot_type", "reader_view"}
    int_cols = {"reader", "antenna", "channel_index", "tag", "round", "n_replies", "q"}

    def table(src, columns):
        out = {}
        for k, s in columns.items():
            dt = str if k in text_cols else (np.int64 if k in int_cols else float)
            v = src.get(k, [])
            out[k] = d.column(np.asarray(v, dtype=dt) if v else np.zeros(0, dtype="U1" if dt is str else dt), *s)
        return out

    ds.add_table("reads", {**_read_schema(rows["reads"]), **table(rows["reads"], READ_COLUMNS)},
                 "one successful read (EPC decoded, CRC ok) in the per-read schema (rfsim.core.reads)")
    ds.add_table("slots", table(rows["slots"], SLOT_COLUMNS), "one inventory slot of a reader")
    ports = [(i, j, r.name, a) for i, r in enumerate(spec.readers) for j, a in enumerate(r.antennas)]
    ds.add_table("readers", {
        "reader": d.column(np.array([p[0] for p in ports], np.int64), "1", "reader (0-based)"),
        "name": d.column(np.array([p[2] for p in ports], str), "", "reader name"),
        "antenna": d.column(np.array([p[1] + 1 for p in ports], np.int64), "1", "antenna port (1-based)"),
        "x_m": d.column(np.array([p[3].position_m[0] for p in ports]), "m", "port antenna x"),
        "y_m": d.column(np.array([p[3].position_m[1] for p in ports]), "m", "port antenna y"),
        "z_m": d.column(np.array([p[3].position_m[2] for p in ports]), "m", "port antenna z"),
        "azimuth_deg": d.column(np.array([p[3].orientation_deg[0] for p in ports]), "deg", "boresight azimuth"),
        "ptx_dbm": d.column(np.array([spec.readers[p[0]].config.ptx_dbm for p in ports]), "dBm", "TX power"),
    }, "one reader antenna port")
    t = spec.tags
    ds.add_table("tags", {
        "epc_hex": d.column(np.array([e.config.epc_hex for e in t], str), "", "EPC"),
        **{f"{c}_m": d.column(np.array([e.antenna.position_m[k] for e in t]), "m", f"tag {c} at t = 0")
           for k, c in enumerate("xyz")},
        **{f"v{c}_m_s": d.column(np.array([e.velocity_m_s[k] for e in t]), "m/s", f"tag velocity along {c}")
           for k, c in enumerate("xyz")},
        "sensitivity_dbm": d.column(np.array([e.config.sensitivity_dbm for e in t]), "dBm", "chip sensitivity"),
    }, "one tag (index = tag column of reads)")
    w = spec.walls
    ds.add_table("walls", {
        **{f"{e}_{c}_m": d.column(np.array([getattr(x, f"{e}_m")[k] for x in w], float), "m", f"wall segment {e} {c}")
           for e in ("start", "end") for k, c in enumerate("xy")},
        "attenuation_db": d.column(np.array([x.attenuation_db for x in w], float), "dB", "loss per crossing"),
    }, "one vertical wall over a floor-plan segment")
    return ds


# ------------------------------------------------------------------------------ scenario contract

#: Description of a scene file's scenario when its ``[scene]`` has none.
DESCRIPTION = "a Gen2 deployment described in a scene file (readers, tags, channel, inventory)"


@dataclass(frozen=True)
class Config:
    """A scene file as a scenario config: its tables (with ``--set`` applied) as JSON text."""

    scene_json: str = param("{}", doc="the scene file's tables as JSON")


def scene_config(path: str | Path, overrides=()) -> Config:
    """Read, override and validate scene file ``path`` into its scenario config.

    Parameters
    ----------
    path : str or pathlib.Path
        The scene file.
    overrides : iterable of str, default ()
        ``--set`` texts (:func:`read_scene`).

    Returns
    -------
    Config
        The tables (overrides applied) as sorted-key JSON.

    Raises
    ------
    rfsim.core.errors.UserError
        The file cannot be read, is not TOML or a key is invalid
        (:class:`~rfsim.core.errors.ConfigError`); one line.
    """
    data = read_scene(path, overrides)
    parse_scene(data)
    return Config(scene_json=json.dumps(data, sort_keys=True))


def run(config: Config, *, seed: int):
    """Run the scene of ``config``: Gen2 readers, schedule-driven devices and HIMR tags.

    Parameters
    ----------
    config : Config
        The scene (:func:`scene_config`).
    seed : int
        Root seed (module docstring; devices :func:`rfsim.scenes.scene_devices.run_devices`,
        HIMR :func:`rfsim.scenes.scene_himr.run_himr`).

    Returns
    -------
    rfsim.core.dataset.Dataset
        The tables of :func:`scene_dataset` (empty ``reads`` and ``slots`` without readers),
        plus the device tables and the HIMR tables when the scene has those devices.
    """
    spec = parse_scene(json.loads(config.scene_json))
    ds = scene_dataset(spec, run_scene(spec, seed=seed) if spec.readers else {"reads": {}, "slots": {}})
    if not spec.devices.empty:
        scene = channel_scene(spec, seed=seed)
        rows = scene_devices.run_devices(spec.devices, scene, duration_s=spec.duration_s, seed=seed)
        scene_devices.add_device_tables(ds, _dataset, spec.devices, rows)
    if not spec.himr.empty:
        runs = scene_himr.run_himr(spec.himr, duration_s=spec.duration_s, seed=seed)
        scene_himr.add_himr_tables(ds, _dataset, spec.himr, runs)
    return ds


def plot(dataset_path, out_dir) -> list[Path]:
    """Draw the figures of a scene-file dataset, in the project style (:mod:`rfsim.core.figure_style`).

    Geometry (top view: ports, tags, velocities, walls, other devices), reads per tag over
    time, RSSI and phase per read, the devices' detections when the scene has any, and the
    HIMR ranges when it has HIMR tags.

    Parameters
    ----------
    dataset_path : str or pathlib.Path
        The dataset written by :func:`run`.
    out_dir : str or pathlib.Path
        Folder of the figures (:func:`rfsim.core.plots.figure_path`).

    Returns
    -------
    list of pathlib.Path
        The saved figures.
    """
    reads, ports, tags, walls = (_dataset.read_table(dataset_path, n) for n in ("reads", "readers", "tags", "walls"))
    device_tables = scene_devices.read_device_tables(dataset_path, _dataset.read_table)
    himr_tables = scene_himr.read_himr_tables(dataset_path, _dataset.read_table)
    out = []
    with paper_style():
        fig, ax = figure(columns=1, height_in=3.6)
        if len(tags["x_m"]):
            ax.plot(tags["x_m"], tags["y_m"], ls="none", marker="o", ms=3.5, color=OKABE_ITO[2], label="tags ($t$ = 0)")
        for k in range(len(walls["attenuation_db"])):
            ax.plot([walls["start_x_m"][k], walls["end_x_m"][k]], [walls["start_y_m"][k], walls["end_y_m"][k]], "-",
                    color="0.4", lw=3, label=f"wall {walls['attenuation_db'][k]:g} dB")
        moving = (tags["vx_m_s"] != 0) | (tags["vy_m_s"] != 0)
        for k in np.flatnonzero(moving):
            ax.arrow(tags["x_m"][k], tags["y_m"][k], tags["vx_m_s"][k], tags["vy_m_s"][k], width=0.01,
                     color=OKABE_ITO[2], length_includes_head=True)
        for k in range(len(ports["x_m"])):
            az, st = math.radians(ports["azimuth_deg"][k]), series_style(int(ports["reader"][k]))
            ax.plot(ports["x_m"][k], ports["y_m"][k], ls="none", marker="s", color=st["color"],
                    label=f"reader {ports['name'][k]}" if ports["antenna"][k] == 0 else None)
            ax.arrow(ports["x_m"][k], ports["y_m"][k], 0.3 * math.cos(az), 0.3 * math.sin(az), width=0.01,
                     color=st["color"])
            ax.annotate(f"{ports['name'][k]}:{ports['antenna'][k]}", (ports["x_m"][k], ports["y_m"][k]), fontsize=6)
        scene_devices.plot_devices(ax, device_tables)
        scene_himr.plot_himr_devices(ax, himr_tables)
        ax.set(xlabel="$x$ [m]", ylabel="$y$ [m]", title="Scene geometry (top view)")
        ax.set_aspect("equal", adjustable="datalim")
        legend_outside(ax, where="below", ncols=2)
        source_note(fig, "arrows: antenna boresight, tag velocity over 1 s")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "geometry")))

        fig, ax = figure(columns=1, height_in=2.6)
        for r in np.unique(reads["reader"]) if len(reads["time_s"]) else []:
            m = reads["reader"] == r
            ax.plot(reads["time_s"][m], reads["tag"][m], ls="none", ms=2.5, label=f"reader {int(r)}",
                    **{k: v for k, v in series_style(int(r)).items() if k != "linestyle"})
        ax.set(xlabel="time $t$ [s]", ylabel="tag index", title=f"Reads per tag over time ({len(reads['time_s'])} reads)")
        if len(reads["time_s"]):
            legend_outside(ax)
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "reads")))

        fig, (a1, a2) = figure(columns=1, nrows=2, height_in=3.6, sharex=True)
        for a, key, label in ((a1, "peak_rssi_dbm", "peak RSSI [dBm]"), (a2, "phase_angle_rad", r"phase $\phi$ [rad]")):
            sc = a.scatter(reads["time_s"], reads[key], s=4, c=reads["tag"], cmap="viridis")
            a.set(ylabel=label)
        a1.set_title("Per read (colour: tag index)")
        a2.set(xlabel="time $t$ [s]")
        if len(reads["time_s"]):
            fig.colorbar(sc, ax=[a1, a2], label="tag index")
        out.append(save_figure(fig, figure_path(dataset_path, out_dir, "rssi-phase")))
        fig = scene_devices.plot_detections(device_tables)
        if fig is not None:
            out.append(save_figure(fig, figure_path(dataset_path, out_dir, "detections")))
        if himr_tables:
            fig = scene_himr.plot_ranges(himr_tables)
            out.append(save_figure(fig, figure_path(dataset_path, out_dir, "himr-ranges")))
    return out


def scenario_module(path: str | Path) -> ModuleType:
    """Make the scenario of scene file ``path``.

    Parameters
    ----------
    path : str or pathlib.Path
        The scene file (read once here for its description).

    Returns
    -------
    types.ModuleType
        A module with ``NAME`` (the file's stem), ``DESCRIPTION`` (``[scene].description`` or
        :data:`DESCRIPTION`), ``Config``, ``run``, ``plot``, ``FIGURE_IMPORTS`` and
        ``scene_config(toml_path, overrides)``: the file's validated config; a ``-c`` config
        file (``toml_path`` not None) is refused with a
        :class:`~rfsim.core.errors.UserError`, the scene is its own config.

    Raises
    ------
    rfsim.core.errors.UserError
        The file cannot be read or is not valid TOML.
    """
    p = Path(path)
    data = read_scene(p)
    description = data.get("scene", {}).get("description", "") if isinstance(data.get("scene"), dict) else ""

    def config_of(toml_path=None, overrides=()) -> Config:
        if toml_path is not None:
            raise UserError(f"scene file {str(p)!r} is its own config: no -c file; change values with --set "
                            f"(e.g. --set run.session=1 or --set reader.0.ptx_dbm=20)")
        return scene_config(p, overrides)

    module = ModuleType(f"{__name__}:{p.stem}", f"scene file {p}")
    module.NAME = p.stem
    module.DESCRIPTION = description or DESCRIPTION
    module.Config, module.run, module.plot, module.scene_config = Config, run, plot, config_of
    module.FIGURE_IMPORTS = ()
    return module


__all__ = ["scenario_module", "AntennaSpec", "TagSpec", "WallSpec", "ChannelSpec", "ReaderSpec", "TagEntry", "SceneSpec", "SECTIONS",
           "is_scene_file", "parse_scene", "SurfaceSpec", "channel_scene", "read_scene", "build_readers", "build_tags", "run_scene", "scene_dataset",
           "Config", "scene_config", "run", "plot", "READ_COLUMNS", "SLOT_COLUMNS"]

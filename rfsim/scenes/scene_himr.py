"""Scene-file HIMR tags and their pylons: the sections ``[[himr_tag]]``, ``[[pylon]]`` and
``[himr_radio]`` of a scene file (:mod:`rfsim.scenes.scene_file`).

A HIMR tag (:class:`rfsim.devices.himr_tag.HimrTag`: battery-assisted, free-running, BOC
packets of IMU words; himr-tag.md §0.1, §2.1–2.2; seed 000 L411–L422, L713–L720) moves on a
trajectory and every pylon (:class:`rfsim.devices.himr_pylon.Pylon`: CW transmitter and
receiver on its own carrier) measures each packet it decodes: CRC, complex gain, RSS, phase,
RSS range (eq. 22) and phase-derived radial velocity (eq. 23), at sample level through the
air step (:func:`rfsim.scenes.himr_air.simulate`; the same path as the scenarios ``himr-1d``
and ``himr-2d``).

* ``[[himr_tag]]``: any :class:`rfsim.devices.himr_tag.HimrTagConfig` key (``packet_format``,
  ``tag_id``, ``packet_rate_hz``, ``jitter_rms_s``, ...), ``name``, an optional ``[himr_tag.imu]``
  (:class:`rfsim.devices.imu.ImuConfig`) and a ``[himr_tag.trajectory]`` with ``kind`` =
  ``"static"`` (:class:`StaticPose`: ``position_m``, ``heading_deg``), ``"linear"``
  (:class:`rfsim.core.trajectories.LinearTrapezoid`) or ``"boom"``
  (:class:`rfsim.core.trajectories.RotatingBoom`) and that class's keys.
* ``[[pylon]]``: ``name``, ``position_m`` (x, y, z) [m], ``fc_hz`` [Hz] (one carrier per pylon;
  default the HIMR carriers 5.79/5.80/5.81 GHz in file order, seed 000 L997).
* ``[himr_radio]``: any :class:`rfsim.scenes.himr_air.RadioConfig` key (sample rate, SNR
  calibration, antenna gains, noise figure, DSP windows).

Each HIMR tag runs alone with every pylon (no interference between HIMR tags is modelled),
from t = 0 to ``run.duration_s`` (0: until its trajectory ends, at least three packet periods).
Links are free space between isotropic antennas (the model of ``himr_air``); the scene's
``[channel]`` walls and APDP do not apply to the 5.8 GHz HIMR links.

Randomness (root seed s, :func:`rfsim.core.rng.trial_rng`): HIMR tag i draws its schedule and
IMU noise from ``trial_rng(s, 7, i, 0)`` and the receiver noise of its packet k at pylon u from
``trial_rng(s, 7, i, 1, k, u)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.config import check_fields, from_dict, param
from rfsim.core.errors import ConfigError
from rfsim.core.figure_style import OKABE_ITO, figure, legend_outside, series_style
from rfsim.core.trajectories import Kinematics, LinearTrapezoid, RotatingBoom
from rfsim.devices.himr_pylon import HIMR_CARRIERS_HZ
from rfsim.devices.himr_tag import HimrTag, HimrTagConfig
from rfsim.devices.imu import ImuConfig
from rfsim.scenes import himr_air

#: Sections of a scene file that this module reads.
HIMR_SECTIONS = ("himr_tag", "pylon", "himr_radio")
#: Trajectory kinds of a ``[himr_tag.trajectory]`` table.
TRAJECTORIES = {"linear": LinearTrapezoid, "boom": RotatingBoom}


@dataclass(frozen=True)
class StaticPose:
    """A tag at rest: constant position and heading (``kind = "static"``)."""

    position_m: tuple[float, float, float] = param((1.0, 0.0, 1.0), lo=-1e4, hi=1e4, unit="m",
                                                   doc="antenna position (x, y, z)")
    heading_deg: float = param(0.0, lo=-360.0, hi=360.0, unit="deg", doc="direction of the body's y axis")

    def __post_init__(self):
        check_fields(self, "trajectory")

    @property
    def duration_s(self) -> float:
        """Length of the motion [s]: 0 (the tag does not move)."""
        return 0.0

    def __call__(self, t_s) -> Kinematics:
        """Kinematics at the times ``t_s`` [s]: the pose, zero velocity and acceleration."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        zero = np.zeros((t.size, 3))
        return Kinematics(t, np.broadcast_to(np.asarray(self.position_m, float), (t.size, 3)).copy(), zero,
                          zero.copy(), np.full(t.size, math.radians(self.heading_deg)), np.zeros(t.size),
                          np.zeros(t.size))


@dataclass(frozen=True)
class PylonSpec:
    """A ``[[pylon]]``: where it stands and its carrier."""

    position_m: tuple[float, float, float] = param((0.0, 0.0, 1.0), lo=-1e4, hi=1e4, unit="m",
                                                   doc="antenna position (x, y, z)")
    fc_hz: float = param(HIMR_CARRIERS_HZ[0], lo=1e8, hi=1e10, unit="Hz", doc="carrier of the pylon's CW")


@dataclass(frozen=True)
class HimrSpec:
    """The HIMR devices of a scene file (all tuples may be empty).

    Attributes
    ----------
    tag_names : tuple of str
        Names of the HIMR tags (``H1``, ``H2``, ... by default).
    tags : tuple of (rfsim.devices.himr_tag.HimrTagConfig, trajectory, rfsim.devices.imu.ImuConfig)
        Each tag's config, trajectory (:class:`StaticPose`,
        :class:`~rfsim.core.trajectories.LinearTrapezoid` or
        :class:`~rfsim.core.trajectories.RotatingBoom`: a callable ``t_s → Kinematics``) and IMU.
    pylon_names : tuple of str
        Names of the pylons (``P1``, ``P2``, ... by default).
    pylons : tuple of PylonSpec
        The pylons, in file order.
    radio : rfsim.scenes.himr_air.RadioConfig
        The ``[himr_radio]`` table (shared by every pylon).
    """

    tag_names: tuple[str, ...] = ()
    tags: tuple[tuple[HimrTagConfig, object, ImuConfig], ...] = ()
    pylon_names: tuple[str, ...] = ()
    pylons: tuple[PylonSpec, ...] = ()
    radio: himr_air.RadioConfig = himr_air.RadioConfig()

    @property
    def empty(self) -> bool:
        """True when the scene has no HIMR tag."""
        return not self.tags


def _rename(err: ConfigError, i: int) -> ConfigError:
    """The error of a HIMR check with the scene file's key (``tag.`` → ``himr_tag[i].``, ...)."""
    key = err.key
    for old, new in (("tag.", f"himr_tag[{i}]."), ("trajectory", f"himr_tag[{i}].trajectory"),
                     ("radio.", "himr_radio."), ("scene.duration_s", "run.duration_s")):
        if key.startswith(old):
            key = new + key[len(old):]
            break
    if key.startswith("pylon[") and not key.endswith(".position_m"):
        key += ".position_m"
    return ConfigError(key, err.value, err.allowed)


def _trajectory(table, prefix: str):
    if not isinstance(table, dict):
        raise ConfigError(prefix, table, "a table with kind = 'static', 'linear' or 'boom'")
    table = dict(table)
    kind = table.pop("kind", "static")
    if kind == "static":
        return from_dict(StaticPose, table, prefix=prefix)
    if kind not in TRAJECTORIES:
        raise ConfigError(f"{prefix}.kind", kind, "one of 'static', 'linear', 'boom'")
    try:
        return from_dict(TRAJECTORIES[kind], table, prefix=prefix)
    except ConfigError as err:
        raise ConfigError(prefix + err.key[err.key.find("."):] if "." in err.key else prefix, err.value,
                          err.allowed) from None


def t_end_s(tag: HimrTag, duration_s: float) -> float:
    """Return the end of a HIMR tag's run.

    Parameters
    ----------
    tag : rfsim.devices.himr_tag.HimrTag
        The tag on its trajectory.
    duration_s : float
        ``run.duration_s`` [s].

    Returns
    -------
    float
        ``duration_s`` when positive; else the end of the trajectory (its ``duration_s``,
        0 for one without) but at least ``start_s + 3·period_s`` [s].
    """
    if duration_s > 0:
        return float(duration_s)
    cfg = tag.config
    return max(float(getattr(tag.trajectory, "duration_s", 0.0)), cfg.start_s + 3.0 * cfg.period_s)


def parse_himr(data: dict, names) -> HimrSpec:
    """Validate the HIMR sections of a scene file's tables.

    Reads ``[[himr_tag]]`` (with its ``[himr_tag.trajectory]``, default ``kind = "static"``,
    and ``[himr_tag.imu]``), ``[[pylon]]`` (``fc_hz`` by default the HIMR carriers
    5.79/5.80/5.81 GHz in turn, seed 000 L997) and ``[himr_radio]``. The runnability checks
    need the run's duration: :func:`check_himr`.

    Parameters
    ----------
    data : dict
        The scene file's tables (not modified).
    names : callable
        ``names(entries, key, default)`` pops and checks the entries' ``name`` keys
        (:func:`rfsim.scenes.scene_devices.names`).

    Returns
    -------
    HimrSpec
        The HIMR devices (empty when the file has none).

    Raises
    ------
    rfsim.core.errors.ConfigError
        On an invalid key or value (one line naming the scene file's key, e.g.
        ``himr_tag[0].trajectory.radius_m``); HIMR tags without pylons or the reverse.
    """
    from_entries = []
    for key in ("himr_tag", "pylon"):
        entries = data.get(key)
        if entries is not None and (not isinstance(entries, list) or not all(isinstance(d, dict) for d in entries)):
            raise ConfigError(key, entries, f"an array of tables ([[{key}]])")
        from_entries.append([dict(e) for e in entries or []])
    tags_d, pylons_d = from_entries
    tag_names, pylon_names = names(tags_d, "himr_tag", "H"), names(pylons_d, "pylon", "P")
    radio_d = data.get("himr_radio", {})
    if not isinstance(radio_d, dict):
        raise ConfigError("himr_radio", radio_d, "a table")
    try:
        radio = from_dict(himr_air.RadioConfig, radio_d, prefix="himr_radio")
    except ConfigError as err:
        raise _rename(err, 0) from None
    for j, p in enumerate(pylons_d):
        p.setdefault("fc_hz", HIMR_CARRIERS_HZ[j % len(HIMR_CARRIERS_HZ)])
    pylons = tuple(from_dict(PylonSpec, p, prefix=f"pylon[{j}]") for j, p in enumerate(pylons_d))
    if tags_d and not pylons:
        raise ConfigError("pylon", [], "at least one [[pylon]] (a HIMR tag is measured by pylons)")
    if pylons and not tags_d:
        raise ConfigError("himr_tag", [], "at least one [[himr_tag]] (pylons measure HIMR tags)")
    tags = []
    for i, t in enumerate(tags_d):
        prefix = f"himr_tag[{i}]"
        trajectory = _trajectory(t.pop("trajectory", {}), f"{prefix}.trajectory")
        imu = from_dict(ImuConfig, t.pop("imu", {}), prefix=f"{prefix}.imu")
        try:
            cfg = from_dict(HimrTagConfig, t, prefix=prefix)
        except ConfigError as err:
            raise (err if err.key.startswith(prefix) else _rename(err, i)) from None
        tags.append((cfg, trajectory, imu))
    return HimrSpec(tag_names, tuple(tags), pylon_names, pylons, radio)


def check_himr(spec: HimrSpec, duration_s: float) -> None:
    """Check that every HIMR tag can run with the pylons.

    Per tag, until :func:`t_end_s`: every pylon at least 5 cm off its track, the sample rate
    enough for its code and at least two packets in the run
    (:func:`rfsim.scenes.himr_air.check_scene`; the room is not bounded).

    Parameters
    ----------
    spec : HimrSpec
        The HIMR devices.
    duration_s : float
        ``run.duration_s`` [s] (0: see :func:`t_end_s`).

    Raises
    ------
    rfsim.core.errors.ConfigError
        The first failed check, with the scene file's key (``himr_tag[i].…``,
        ``pylon[u].position_m``, ``himr_radio.…`` or ``run.duration_s``).
    """
    positions = [p.position_m for p in spec.pylons]
    carriers = [p.fc_hz for p in spec.pylons]
    for i, (cfg, trajectory, imu) in enumerate(spec.tags):
        tag = HimrTag(cfg, trajectory, imu)
        end = t_end_s(tag, duration_s)
        try:
            himr_air.check_scene(spec.radio, tag, positions, carriers, t_end_s=end, room_min_m=(-1e4,) * 3,
                                 room_max_m=(1e4,) * 3, key="pylon")
        except ConfigError as err:
            raise _rename(err, i) from None


def run_himr(spec: HimrSpec, *, duration_s: float, seed: int) -> list:
    """Run every HIMR tag with every pylon, one tag at a time.

    Parameters
    ----------
    spec : HimrSpec
        The HIMR devices.
    duration_s : float
        ``run.duration_s`` [s]; each tag runs from 0 to :func:`t_end_s`.
    seed : int
        Root seed: tag i uses the streams ``trial_rng(seed, 7, i, ...)`` of
        :func:`rfsim.scenes.himr_air.simulate` (module docstring).

    Returns
    -------
    list of tuple
        Per tag ``(run, plan, imu)``: the :class:`rfsim.scenes.himr_air.AirRun`, the tag's
        :class:`rfsim.devices.himr_tag.HimrPlan` and its
        :func:`rfsim.scenes.himr_air.imu_table` (heading aligned with the trajectory's
        heading at t = 0).
    """
    out = []
    positions = np.array([p.position_m for p in spec.pylons], float)
    carriers = [p.fc_hz for p in spec.pylons]
    for i, (cfg, trajectory, imu_cfg) in enumerate(spec.tags):
        tag = HimrTag(cfg, trajectory, imu_cfg)
        run = himr_air.simulate(tag, positions, carriers, spec.radio, seed=seed, t_end_s=t_end_s(tag, duration_s),
                                desc=f"HIMR tag {spec.tag_names[i]}", stream=(7, i))
        plan = tag.current_plan
        heading0 = float(trajectory(np.array([0.0])).heading_rad[0])
        out.append((run, plan, himr_air.imu_table(run, plan, imu_cfg, heading_start_rad=heading0)))
    return out


def add_himr_tables(ds, d, spec: HimrSpec, runs: list) -> None:
    """Add the HIMR tables (:data:`HIMR_TABLES`) to a dataset.

    Parameters
    ----------
    ds : rfsim.core.dataset.Dataset
        The dataset, extended in place.
    d : module
        :mod:`rfsim.core.dataset` (its ``column``).
    spec : HimrSpec
        The HIMR devices: tables ``himr_tags`` (name, position at t = 0 [m], tag ID, format,
        packets sent, IMU samples decoded) and ``pylons`` (name, position [m], carrier [Hz]).
    runs : list of tuple
        :func:`run_himr` output: table ``himr_packets``, the columns of
        :data:`rfsim.scenes.himr_air.PACKET_COLUMNS` plus ``himr_tag`` (0-based).
    """
    cols: dict[str, list] = {}
    for i, (run, plan, _) in enumerate(runs):
        pk = himr_air.packets_table(run, plan)
        pk["himr_tag"] = np.full(pk["t_s"].size, i, dtype=np.int64)
        for k, v in pk.items():
            cols.setdefault(k, []).append(v)
    units = {**himr_air.PACKET_COLUMNS, "himr_tag": ("1", "HIMR tag (0-based index into table himr_tags)")}
    ds.add_table("himr_packets", {k: d.column(np.concatenate(v), *units[k]) for k, v in cols.items()},
                 "one row per (HIMR packet, pylon that decoded it): CRC, complex gain, RSS, phase, RSS range "
                 "(eq. 22), radial velocity (eq. 23), ground truth")
    start = np.array([tr(np.array([0.0])).position_m[0] for _, tr, _ in spec.tags], float).reshape(-1, 3)
    ds.add_table("himr_tags", {
        "name": d.column(np.array(spec.tag_names, dtype=str).reshape(-1), "", "HIMR tag name"),
        **{f"{c}_m": d.column(start[:, k], "m", f"tag antenna {c} at t = 0") for k, c in enumerate("xyz")},
        "tag_id": d.column(np.array([c.tag_id for c, _, _ in spec.tags], np.int64), "1", "2-byte tag ID"),
        "packet_format": d.column(np.array([c.packet_format for c, _, _ in spec.tags], dtype=str).reshape(-1), "",
                                  "packet format"),
        "packets_sent": d.column(np.array([r[1].start_s.size for r in runs], np.int64), "1",
                                 "packets the tag sent in the run"),
        "imu_samples_decoded": d.column(np.array([int(r[2]["valid"].sum()) for r in runs], np.int64), "1",
                                        "packets some pylon decoded with a good CRC (IMU words received)"),
    }, "one HIMR tag")
    p = np.array([s.position_m for s in spec.pylons], float).reshape(-1, 3)
    ds.add_table("pylons", {
        "name": d.column(np.array(spec.pylon_names, dtype=str).reshape(-1), "", "pylon name"),
        **{f"{c}_m": d.column(p[:, k], "m", f"pylon antenna {c}") for k, c in enumerate("xyz")},
        "fc_hz": d.column(np.array([s.fc_hz for s in spec.pylons], float), "Hz", "carrier"),
    }, "one HIMR pylon")


#: Tables :func:`add_himr_tables` writes.
HIMR_TABLES = ("himr_packets", "himr_tags", "pylons")


def read_himr_tables(path, read_table) -> dict[str, dict[str, np.ndarray]]:
    """Read the HIMR tables of a dataset.

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
        The tables of :data:`HIMR_TABLES` by name; empty when any is missing (a scene without
        HIMR tags).
    """
    try:
        return {name: read_table(path, name) for name in HIMR_TABLES}
    except KeyError:
        return {}


def plot_himr_devices(ax, tables: dict) -> None:
    """Draw the pylons and the HIMR tags' positions at t = 0 on the geometry axes.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The top view (x, y in m).
    tables : dict of str to dict of str to ndarray
        :func:`read_himr_tables` output; nothing is drawn when it is empty.
    """
    if not tables:
        return
    p, t = tables["pylons"], tables["himr_tags"]
    ax.plot(p["x_m"], p["y_m"], "h", ms=7, color=OKABE_ITO[3], ls="none", label="HIMR pylons")
    ax.plot(t["x_m"], t["y_m"], "*", ms=8, color=OKABE_ITO[0], ls="none", label="HIMR tags ($t$ = 0)")
    for table in (p, t):
        for x, y, name in zip(table["x_m"], table["y_m"], table["name"]):
            ax.annotate(name.decode() if isinstance(name, bytes) else str(name), (x, y), fontsize=6)


def plot_ranges(tables: dict):
    """Plot the RSS range and the true range over time per (HIMR tag, pylon).

    Parameters
    ----------
    tables : dict of str to dict of str to ndarray
        :func:`read_himr_tables` output (not empty).

    Returns
    -------
    matplotlib.figure.Figure
        RSS range ``range_rss_m`` (eq. 22; markers) and ``true_range_m`` (lines) [m] against
        the packet time [s], one series per (tag, pylon) pair.
    """
    packets = tables["himr_packets"]
    name = {k: [v.decode() if isinstance(v, bytes) else str(v) for v in tables[k]["name"]]
            for k in ("himr_tags", "pylons")}
    fig, ax = figure(columns=1, height_in=2.8)
    pairs = sorted(set(zip(packets["himr_tag"].tolist(), packets["pylon"].tolist())))
    for n, (i, u) in enumerate(pairs):
        m = (packets["himr_tag"] == i) & (packets["pylon"] == u)
        st = series_style(n)
        ax.plot(packets["t_s"][m], packets["true_range_m"][m], color=st["color"], lw=1)
        ax.plot(packets["t_s"][m], packets["range_rss_m"][m], ls="none", marker=st["marker"], ms=2.5,
                color=st["color"], label=f"{name['himr_tags'][i]} → {name['pylons'][u - 1]}")
    ax.set(xlabel="time $t$ [s]", ylabel="range [m]", title="HIMR: RSS range (markers), true range (lines)")
    if pairs:
        legend_outside(ax)
    return fig


__all__ = ["HIMR_SECTIONS", "StaticPose", "PylonSpec", "HimrSpec", "parse_himr", "check_himr", "run_himr",
           "t_end_s", "add_himr_tables", "HIMR_TABLES", "read_himr_tables", "plot_himr_devices", "plot_ranges"]

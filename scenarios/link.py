"""Scenario ``link``: one reader and one tag, the tag distance swept, N rounds per point.

Every round is a sample-level singulation (Query → RN16 → ACK → PC+EPC+CRC-16) through the
engine (:mod:`rfsim.protocols.engine`; round r of every distance point in one batch, :mod:`rfsim.protocols.batch`) over a fresh draw of the default channel: Friis large scale,
an optional floor reflection (image method, concrete) and the exponential APDP with the PASS
room curves K(d), τrms(d) (rfsim.channels.small_scale.ApdpModel defaults). The reader hops
channels, so rounds also differ by carrier frequency. Per round the dataset records what
a commercial reader reports for a read (gen2-and-validation-anchors.md §4.9) and why a
read failed, and the reader's report of it (``reader.report``, :mod:`rfsim.core.records`: EPC as
hex, µs time stamp, RSSI in its steps above the sensitivity floor, the 12-bit phase code with
the port's phase offset), one row per read sorted by time, in the per-read schema
(:mod:`rfsim.core.reads`).

Randomness: point i, round r uses ``trial_rng(seed, i, r)`` for the channel draw and the
receiver noise; the reader (hop sequence) and the tag (RN16, slot) of point i have their own
streams ``trial_rng(seed, i, n_rounds)`` and ``trial_rng(seed, i, n_rounds + 1)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.core.config import param
from rfsim.core.reads import reads_table
from rfsim.core.records import READ_MEASUREMENT_FIELDS, READ_REPORT_FIELDS, epc_hex, long_table, report_columns
from rfsim.core.progress import track
from rfsim.core.rng import trial_rng
from rfsim.core.figure_style import (OKABE_ITO, ci_errorbar, figure, legend_outside, paper_style, series_style,
                                     shade_no_data, source_note)
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.lazy import lazy_import

_antennas = lazy_import("rfsim.channels.antennas")
_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_surfaces = lazy_import("rfsim.channels.surfaces")
_reader = lazy_import("rfsim.devices.reader")
_tag = lazy_import("rfsim.devices.tag")
_dataset = lazy_import("rfsim.core.dataset")
_batch = lazy_import("rfsim.protocols.batch")
_commands = lazy_import("rfsim.gen2.commands")

NAME = "link"
DESCRIPTION = "reader + one tag at swept distance: per-read RSSI, phase, Doppler, SNR and read success"


@dataclass(frozen=True)
class GeometryConfig:
    """Placement of the reader antenna and the tag.

    The reader antenna stands at (0, 0, ``height_m``) with boresight +x; the tag, a vertical
    half-wave dipole facing the reader, at each distance along azimuth ``angle_deg``.

    Attributes
    ----------
    distances_m : tuple of float, default (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0)
        Reader-tag distances [m], in [0.05, 100].
    angle_deg : float, default 0.0
        Tag azimuth seen from the reader boresight [deg], in [-180, 180].
    height_m : float, default 1.0
        Height of reader antenna and tag [m], in [0.1, 10].
    reader_antenna : {"patch", "dipole", "isotropic"}, default "patch"
        Reader antenna.
    reader_gain_dbi : float, default 6.0
        Patch peak gain [dBi], in [0, 15].
    reader_beamwidth_deg : float, default 70.0
        Patch beamwidth [deg], in [20, 180].
    reader_polarization : {"linear", "circular"}, default "circular"
        Reader antenna polarization.
    """

    distances_m: tuple[float, ...] = param((0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0),
                                           lo=0.05, hi=100.0, unit="m", doc="reader-tag distances")
    angle_deg: float = param(0.0, lo=-180.0, hi=180.0, unit="deg",
                             doc="tag azimuth seen from the reader boresight")
    height_m: float = param(1.0, lo=0.1, hi=10.0, unit="m", doc="height of reader antenna and tag")
    reader_antenna: Literal["patch", "dipole", "isotropic"] = param("patch", doc="reader antenna")
    reader_gain_dbi: float = param(6.0, lo=0.0, hi=15.0, unit="dBi", doc="patch peak gain")
    reader_beamwidth_deg: float = param(70.0, lo=20.0, hi=180.0, unit="deg", doc="patch beamwidth")
    reader_polarization: Literal["linear", "circular"] = param("circular", doc="reader antenna polarization")


@dataclass(frozen=True)
class ChannelConfig:
    """Propagation: Friis large scale, optional floor reflection and optional APDP taps.

    Attributes
    ----------
    apdp : bool, default True
        Exponential APDP diffuse taps (PASS room curves).
    floor : bool, default True
        Floor reflection (image method).
    floor_eps_r : float, default 5.3
        Floor relative permittivity (concrete), in [1, 100].
    """

    apdp: bool = param(True, doc="exponential APDP diffuse taps (PASS room curves)")
    floor: bool = param(True, doc="floor reflection (image method)")
    floor_eps_r: float = param(5.3, lo=1.0, hi=100.0, doc="floor relative permittivity (concrete)")


@dataclass(frozen=True)
class Config:
    """Configuration of the ``link`` scenario.

    Attributes
    ----------
    geometry : GeometryConfig
        Placement of the reader antenna and the tag.
    channel : ChannelConfig
        Propagation terms.
    reader : rfsim.devices.reader_config.ReaderConfig
        Reader settings (power, link profile, hopping, report).
    tag : rfsim.devices.tag_config.TagConfig
        Tag settings.
    rounds_per_point : int, default 20
        Inventory rounds per distance, in [1, 100000].
    round_period_s : float, default 0.02
        Time between round starts (silent time is skipped) [s], in [0.001, 10].
    """

    geometry: GeometryConfig = param(GeometryConfig(), doc="placement")
    channel: ChannelConfig = param(ChannelConfig(), doc="propagation")
    reader: ReaderConfig = param(ReaderConfig(), doc="reader")
    tag: TagConfig = param(TagConfig(), doc="tag")
    rounds_per_point: int = param(20, lo=1, hi=100000, doc="inventory rounds per distance")
    round_period_s: float = param(20e-3, lo=1e-3, hi=10.0, unit="s",
                                  doc="time between round starts (silent time is skipped)")


def reader_antenna(g: GeometryConfig) -> _antennas.Antenna:
    """The reader antenna of the geometry: at (0, 0, height), boresight +x.

    Parameters
    ----------
    g : GeometryConfig
        Placement; its ``reader_antenna`` picks a patch (``reader_gain_dbi``,
        ``reader_beamwidth_deg``), a half-wave dipole or an isotropic pattern.

    Returns
    -------
    rfsim.channels.antennas.Antenna
        The antenna at (0, 0, ``g.height_m``) [m], polarization ``g.reader_polarization``.
    """
    if g.reader_antenna == "patch":
        pattern = _antennas.Patch(g.reader_gain_dbi, g.reader_beamwidth_deg)
    elif g.reader_antenna == "dipole":
        pattern = _antennas.HalfWaveDipole()
    else:
        pattern = _antennas.Isotropic()
    return _antennas.Antenna(position_m=(0.0, 0.0, g.height_m), orientation=(0.0, 0.0, 0.0), pattern=pattern,
                             polarization=g.reader_polarization)


def tag_antenna(g: GeometryConfig, distance_m: float) -> _antennas.Antenna:
    """A vertical half-wave dipole tag at ``distance_m`` and ``g.angle_deg`` facing the reader.

    Parameters
    ----------
    g : GeometryConfig
        Placement (azimuth ``angle_deg`` and ``height_m``).
    distance_m : float
        Horizontal distance from the reader antenna [m].

    Returns
    -------
    rfsim.channels.antennas.Antenna
        The tag antenna at (d cos a, d sin a, h) [m] (a = ``g.angle_deg``, h =
        ``g.height_m``), linearly polarized, boresight towards the reader.
    """
    a = np.deg2rad(g.angle_deg)
    pos = (distance_m * np.cos(a), distance_m * np.sin(a), g.height_m)
    # A dipole tag facing the reader, its axis vertical (local +z), boresight towards the reader.
    return _antennas.Antenna(position_m=pos, orientation=(a + np.pi, 0.0, 0.0), pattern=_antennas.HalfWaveDipole(),
                             polarization="linear", pol_tilt_rad=0.0)


def scene(c: ChannelConfig) -> _scene.Scene:
    """The default channel: Friis, optional concrete floor (image method), optional APDP.

    Parameters
    ----------
    c : ChannelConfig
        Which propagation terms to include.

    Returns
    -------
    rfsim.channels.scene.Scene
        A scene with the floor plane z = 0 (relative permittivity ``c.floor_eps_r``,
        first-order images) when ``c.floor``, and the PASS-room
        :class:`~rfsim.channels.small_scale.ApdpModel` when ``c.apdp``.
    """
    surfaces = (_surfaces.Surface(point_m=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), eps_r=c.floor_eps_r),) if c.floor else ()
    return _scene.Scene(surfaces=surfaces, apdp=_small_scale.ApdpModel() if c.apdp else None, image_order=1)


FIELDS = {
    "point": ("1", "index of the distance point"),
    "round": ("1", "inventory round at this point"),
    "time_s": ("s", "start of the round's Query"),
    "distance_m": ("m", "reader antenna to tag distance of the point (geometry.distances_m)"),
    **READ_MEASUREMENT_FIELDS,
    "success": ("1", "EPC decoded with CRC ok"),
    "failure_reason": ("", "why the read failed ('' = success)"),
    "tag_incident_power_dbm": ("dBm", "CW power incident at the tag antenna port (Query)"),
}
#: Columns of the read log: the round's context and measurements, then the reader's report (in the
#: dataset, those the per-read schema holds appear under its names: rfsim.core.reads).
READ_FIELDS = {**FIELDS, **READ_REPORT_FIELDS}


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate inventory rounds between one reader and one tag at each distance.

    Each round is a sample-level singulation (Query, RN16, ACK, PC+EPC+CRC-16) over a fresh
    channel draw and hop channel; rounds alternate target A and B (dual-target inventory).
    What a read reports follows gen2-and-validation-anchors.md §4.9 (see the module
    docstring for the channel and the random streams).

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed; point i, round r draws from ``trial_rng(seed, i, r)``.

    Returns
    -------
    rfsim.core.dataset.Dataset
        One table ``reads``: one row per round and distance in the per-read schema
        (:mod:`rfsim.core.reads`), sorted by time stamp — the reader's report (EPC, RSSI,
        phase, Doppler, SNR), success and failure reason, the true distance [m] and the CW
        power incident at the tag [dBm].
    """
    g = config.geometry
    n_rounds = config.rounds_per_point
    rows: dict[str, list] = {k: [] for k in FIELDS}
    rows["epc"] = []
    antenna = reader_antenna(g)
    n_points = len(g.distances_m)
    readers = [_reader.Reader(config.reader, [antenna], rng=trial_rng(seed, i, n_rounds)) for i in range(n_points)]
    tags = [[_tag.PassiveTag(config.tag, tag_antenna(g, d), rng=trial_rng(seed, i, n_rounds + 1))]
            for i, d in enumerate(g.distances_m)]
    channels = [_scene.Channel(scene(config.channel)) for _ in range(n_points)]
    lk = readers[0].link
    # Round r of every point in one batch (the points are independent trials; the rounds of a
    # point follow one another: its tag's S0 flag carries over).
    for r in track(range(n_rounds), desc="rounds", unit="rounds"):
        times = [(i * n_rounds + r) * config.round_period_s for i in range(n_points)]
        # Dual-target inventory: a read flips the tag's S0 flag, so rounds alternate
        # target A and B (as commercial readers do to read a tag again and again).
        query = _commands.Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0, target="AB"[r % 2])
        rngs = [trial_rng(seed, i, r) for i in range(n_points)]
        batch = _batch.singulate_batch(readers, tags, channels, t_s=times, rngs=rngs, query=query, round_index=r)
        for i, (d, exchanges) in enumerate(zip(g.distances_m, batch)):
            last = exchanges[-1]
            read = last.read if last.command == "ACK" else None
            ok = last.command == "ACK" and last.success
            _append(rows, point=i, round=r, time_s=times[i], distance_m=d, antenna=last.antenna + 1,
                    channel_index=last.channel_index, frequency_hz=last.fc_hz,
                    rssi_dbm=read.rssi_dbm if ok else np.nan,
                    phase_rad=read.phase_rad if ok else np.nan,
                    doppler_hz=read.doppler_hz if ok else np.nan,
                    snr_db=read.snr_db if ok else np.nan, success=ok, epc=epc_hex(read.bits) if ok else "",
                    failure_reason=last.failure_reason,
                    tag_incident_power_dbm=exchanges[0].incident_power_dbm[0])
    cols = {k: np.asarray(v) for k, v in rows.items()}
    cols.update(report_columns(config.reader.report, t_s=cols["time_s"], antenna=cols["antenna"],
                               rssi_dbm=cols["rssi_dbm"], phase_rad=cols["phase_rad"], success=cols["success"]))
    cols = long_table(cols)
    tag_m = np.array([tag_antenna(g, d).position_m for d in g.distances_m])[cols["point"]]
    reads = reads_table(cols, READ_FIELDS, true_position_m=tag_m,
                        notes={"true_distance_m": "the point's geometry.distances_m",
                               "true_incident_power_dbm": "during the round's Query"})
    ds = _dataset.Dataset(title="reader-tag link vs distance: per-read measurements")
    ds.add_table("reads", reads,
                 description="one row per inventory round (Query, RN16, ACK, EPC) at each distance: the reader's "
                             "per-read report (long format, sorted by time stamp), or why the read failed")
    return ds


def _append(rows: dict[str, list], **values) -> None:
    for k, v in values.items():
        rows[k].append(v)


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """RSSI, read rate, phase and Doppler against distance, ``<stem>-rssi-read-rate.png``.

    The distance axis is logarithmic (free-space RSSI is a straight line, −40 dB/decade
    monostatic) with plain metre ticks at the simulated distances. RSSI, phase and Doppler
    are drawn per successful read (small hollow markers) with the mean RSSI; the read rate
    with its Wilson 95 % interval. Distances without a successful read are hatched, and the
    caption gives the failure reason of most rounds there and the mean CW power at the tag.

    Parameters
    ----------
    dataset_path : pathlib.Path
        A dataset written by :func:`run`.
    out_dir : pathlib.Path
        Folder of the figure.

    Returns
    -------
    list of pathlib.Path
        The one written figure.
    """
    from matplotlib.ticker import FixedLocator, NullFormatter, NullLocator

    from rfsim.core.dataset import read_table
    from rfsim.detection.fit import wilson_interval

    t = read_table(dataset_path, "reads")
    d = np.unique(t["true_distance_m"])
    at = [t["true_distance_m"] == x for x in d]
    ok = t["success"]
    k = np.array([np.sum(ok[s]) for s in at])
    n = np.array([np.sum(s) for s in at])
    rssi = [t["peak_rssi_dbm"][s & ok] for s in at]
    mean = np.array([r.mean() if r.size else np.nan for r in rssi])
    with paper_style():
        fig, axes = figure(columns=2, nrows=2, ncols=2, sharex=True, height_in=4.6)
        (a1, a2), (a3, a4) = axes
        each = dict(ls="none", marker="o", ms=3, mfc="none", mew=0.6, color=OKABE_ITO[4])
        a1.plot(t["true_distance_m"][ok], t["peak_rssi_dbm"][ok], label="one read", **each)
        a1.plot(d, mean, label="mean of the reads", **series_style(0))
        a1.set(ylabel="RSSI [dBm]", title="RSSI of the EPC reply")
        lo, hi = wilson_interval(k, n)
        ci_errorbar(a2, d, k / n, lo, hi, scale=100.0, label="read rate,\nWilson 95 %", **series_style(0))
        a2.set(ylabel="read rate [%] (EPC, CRC ok)", ylim=(-3, 103), title="read rate")
        a3.plot(t["true_distance_m"][ok], np.degrees(t["phase_angle_rad"][ok]), **each)
        a3.set(ylabel=r"reported phase $\phi$ [°]", ylim=(-10, 370), yticks=[0, 90, 180, 270, 360],
               xlabel="reader–tag distance $d$ [m]", title="phase of the EPC reply")
        a4.plot(t["true_distance_m"][ok], t["doppler_frequency_hz"][ok], **each)
        a4.set(ylabel=r"Doppler $f_\mathrm{D}$ [Hz]", xlabel="reader–tag distance $d$ [m]",
               title="Doppler estimate (static tag)")
        missing = k == 0
        why = []
        for i in np.flatnonzero(missing):  # say why there is no read there instead of a silent gap
            reasons, counts = np.unique(t["failure_reason"][at[i]], return_counts=True)
            p_inc = float(np.mean(t["true_incident_power_dbm"][at[i]]))
            why.append(f"{d[i]:g} m: {reasons[np.argmax(counts)] or 'other'}, CW at the tag {p_inc:.1f} dBm")
        hatch = None
        for a in axes.flat:
            hatch = shade_no_data(a, d, missing, label="no read", log=True) or hatch
            a.set_xscale("log")
            a.xaxis.set_major_locator(FixedLocator(d))
            a.xaxis.set_major_formatter(lambda x, pos: f"{x:g}")
            a.xaxis.set_minor_locator(NullLocator())
            a.xaxis.set_minor_formatter(NullFormatter())
        for i in np.flatnonzero((k > 0) & (k < n)):
            a1.annotate(f"{k[i]}/{n[i]}", (d[i], mean[i]), textcoords="offset points", xytext=(0, 6),
                        ha="center", fontsize=6)
        handles = a1.get_legend_handles_labels()[0] + a2.get_legend_handles_labels()[0]
        legend_outside(a2, where="figure", handles=handles + ([hatch] if hatch is not None else []))
        fig.suptitle("Reader–tag link against distance (log distance axis)")
        note = f"{int(np.median(n))} rounds per distance, a fresh channel draw and hop channel each"
        if why:
            note += "; no read at " + "; ".join(why)
        source_note(fig, note)
        return [save_figure(fig, figure_path(dataset_path, out_dir, "rssi-read-rate"))]

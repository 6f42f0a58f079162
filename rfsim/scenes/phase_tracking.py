"""Särkkä et al.'s phase-tracking scene: reader antennas around a floor plan, a tag moving on a
polygon path with a smooth jitter, one carrier, an anechoic channel, one singulation per read
round (phase-tracking.md §2, wave2-specs.md §R; seeds/001 L57, L174–L178).

* :class:`GeometryConfig`, :func:`reader_antennas`: panels (or isotropic antennas) at given
  floor positions and one height, aimed at the room centre (the SPA 8090/75/8/0/V class: 8 dBi,
  75°); the tag a half-wave dipole tilted ``tag_tilt_deg`` from vertical.
* :class:`TrajectoryConfig`, :func:`polygon_path`, :class:`TagMotion`: the intended path
  (constant speed along a closed polygon) plus the manual movement's jitter (L203).
* :func:`carrier_hz`: the one carrier of a non-hopping reader (phase unwrapping needs one λ).
* :class:`RoundLinks`: the links of a chunk of rounds, drawn at once
  (:func:`rfsim.channels.bulk.draw_links`), held per round.
* :func:`simulate_rounds`: every round one Gen2 singulation (Query → RN16 → ACK → PC+EPC+CRC-16)
  through the engine (:func:`rfsim.protocols.engine.singulate`) at sample level, Query target
  alternating A/B after each successful read; the tag held at its position of the round start
  (quasi-static: at 0.2 m/s it moves 0.14 mm in a 0.71 ms singulation, a phase change ≤ 5 mrad).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.records import epc_hex
from rfsim.core.rng import trial_rng
from rfsim.devices.reader_config import ReaderConfig, frequency_plan

_ndimage = lazy_import("scipy.ndimage")
_antennas = lazy_import("rfsim.channels.antennas")
_scene = lazy_import("rfsim.channels.scene")
_bulk = lazy_import("rfsim.channels.bulk")
_reader = lazy_import("rfsim.devices.reader")
_tag = lazy_import("rfsim.devices.tag")
_engine = lazy_import("rfsim.protocols.engine")
_commands = lazy_import("rfsim.gen2.commands")


@dataclass(frozen=True)
class GeometryConfig:
    """Floor plan, reader antennas and tag antenna of the scene (each field's ``doc`` says what it is)."""

    room_m: tuple[float, float] = param((3.0, 3.0), lo=0.1, hi=100.0, unit="m",
                                        doc="floor plan [0, x] × [0, y]: antennas and tag must be inside")
    antennas_xy_m: tuple[tuple[float, float], ...] = param(
        ((0.0, 0.0), (3.0, 0.0), (3.0, 3.0), (0.0, 3.0)), lo=-1000.0, hi=1000.0, unit="m",
        doc="reader antenna positions (corners of the 3 m square, L174), aimed at the room centre")
    height_m: float = param(1.5, lo=0.0, hi=10.0, unit="m", doc="height of antennas and tag (L174, L176)")
    antenna_pattern: Literal["patch", "isotropic"] = param("patch", doc="reader antenna pattern")
    antenna_gain_dbi: float = param(8.0, lo=0.0, hi=15.0, unit="dBi", doc="panel peak gain (SPA 8090/75/8)")
    antenna_beamwidth_deg: float = param(75.0, lo=20.0, hi=179.0, unit="deg", doc="panel half-power beamwidth")
    antenna_polarization: Literal["circular", "linear"] = param("circular", doc="reader antenna polarization "
                                                                "('linear': vertical)")
    tag_tilt_deg: float = param(50.0, lo=0.0, hi=90.0, unit="deg",
                                doc="tilt of the tag's dipole axis from vertical towards +x (90: lying along x)")


@dataclass(frozen=True)
class TrajectoryConfig:
    """The tag's intended path and the jitter of the manual movement (each field's ``doc``)."""

    corners_xy_m: tuple[tuple[float, float], ...] = param(
        ((1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0)), lo=-1000.0, hi=1000.0, unit="m",
        doc="closed polygon the tag follows (the intended path), first corner at t = 0")
    speed_mps: float = param(0.2, lo=0.0, hi=100.0, lo_open=True, unit="m/s", doc="speed along the path")
    duration_s: float = param(60.0, lo=0.05, hi=3600.0, unit="s", doc="length of the run")
    jitter_rms_m: float = param(0.015, lo=0.0, hi=0.5, unit="m",
                                doc="RMS 2-D deviation of the true from the intended path (manual movement, L203)")
    jitter_time_s: float = param(0.5, lo=0.01, hi=100.0, unit="s",
                                 doc="std of the Gaussian smoothing kernel of the jitter (its correlation time)")


def reader_antennas(g: GeometryConfig) -> list[_antennas.Antenna]:
    """Return the reader antennas at ``antennas_xy_m`` and ``height_m``, boresight towards the room centre.

    Parameters
    ----------
    g : GeometryConfig
        The geometry (positions, height, pattern, gain, beamwidth, polarization). An
        antenna at the room centre keeps boresight +x.

    Returns
    -------
    list of rfsim.channels.antennas.Antenna
        One antenna per position, in the order of ``antennas_xy_m``.
    """
    cx, cy = 0.5 * g.room_m[0], 0.5 * g.room_m[1]
    out = []
    for x, y in g.antennas_xy_m:
        pattern = _antennas.Patch(g.antenna_gain_dbi, g.antenna_beamwidth_deg) if g.antenna_pattern == "patch" else _antennas.Isotropic()
        yaw = math.atan2(cy - y, cx - x) if (cx, cy) != (x, y) else 0.0
        out.append(_antennas.Antenna(position_m=(x, y, g.height_m), orientation=(yaw, 0.0, 0.0), pattern=pattern,
                                     polarization=g.antenna_polarization))
    return out


def polygon_path(t_s, corners_xy_m, speed_mps: float) -> np.ndarray:
    """Return positions on a closed polygon traversed at constant speed.

    The path starts at the first corner at t = 0 and wraps around after one lap.

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Times [s].
    corners_xy_m : array_like, shape (k, 2)
        The polygon's corners (x, y) [m]; the last connects back to the first.
    speed_mps : float
        Speed along the path [m/s].

    Returns
    -------
    ndarray, shape (n, 2)
        Positions (x, y) [m].
    """
    c = np.asarray(corners_xy_m, float)
    ends = np.roll(c, -1, axis=0)
    seg = np.linalg.norm(ends - c, axis=1)
    cum = np.concatenate(([0.0], np.cumsum(seg)))
    s = np.mod(np.asarray(t_s, float) * speed_mps, cum[-1])
    k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, c.shape[0] - 1)
    frac = (s - cum[k]) / seg[k]
    return c[k] + frac[:, None] * (ends[k] - c[k])


class TagMotion:
    """Intended path plus the smooth jitter of a manual movement (L203).

    The jitter is white noise on a 10 ms grid (to ``duration_s`` + 2 s), Gaussian-smoothed
    (std ``jitter_time_s``, wrapped) and scaled so that the realised 2-D RMS equals
    ``jitter_rms_m``.

    Parameters
    ----------
    tr : TrajectoryConfig
        The path and the jitter's settings.
    rng : numpy.random.Generator
        Draws the white noise.

    Attributes
    ----------
    t_grid : ndarray, shape (n,)
        The jitter's time grid [s].
    jitter : ndarray, shape (n, 2)
        The jitter (x, y) on that grid [m].
    """

    GRID_S = 0.01

    def __init__(self, tr: TrajectoryConfig, *, rng: np.random.Generator):
        self.tr = tr
        self.t_grid = np.arange(0.0, tr.duration_s + 2.0, self.GRID_S)
        jit = _ndimage.gaussian_filter1d(rng.standard_normal((self.t_grid.size, 2)), tr.jitter_time_s / self.GRID_S,
                                axis=0, mode="wrap")
        rms = math.sqrt(np.mean(np.sum(jit ** 2, axis=1)))
        self.jitter = jit * (tr.jitter_rms_m / rms) if tr.jitter_rms_m > 0 else np.zeros_like(jit)

    def intended(self, t_s) -> np.ndarray:
        """Return the intended positions (:func:`polygon_path`) at ``t_s``.

        Parameters
        ----------
        t_s : float or array_like, shape (n,)
            Times [s].

        Returns
        -------
        ndarray, shape (n, 2)
            Positions (x, y) [m].
        """
        return polygon_path(np.atleast_1d(t_s), self.tr.corners_xy_m, self.tr.speed_mps)

    def true(self, t_s) -> np.ndarray:
        """Return the true positions at ``t_s``: intended path plus the interpolated jitter.

        Parameters
        ----------
        t_s : float or array_like, shape (n,)
            Times [s].

        Returns
        -------
        ndarray, shape (n, 2)
            Positions (x, y) [m].
        """
        t = np.atleast_1d(np.asarray(t_s, float))
        j = np.column_stack([np.interp(t, self.t_grid, self.jitter[:, k]) for k in range(2)])
        return self.intended(t) + j

    def max_radial_speed_mps(self, anchors_xy_m, *, dt_s: float = 1e-3) -> float:
        r"""Return the largest radial speed of the true path towards any anchor.

        :math:`\max_{t, i} |\mathrm{d}\,|p(t) - a_i| / \mathrm{d}t|` over the run, by central
        differences on a ``dt_s`` grid (``np.gradient``); to be compared with the unwrapping
        limit λ/(4Δt) (:func:`rfsim.estimators.phase_tracking.unwrap_limit_mps`).

        Parameters
        ----------
        anchors_xy_m : array_like, shape (s, 2)
            The anchors (x, y) [m], e.g. the reader antennas.
        dt_s : float, optional
            Grid step [s], default 1e-3.

        Returns
        -------
        float
            The largest radial speed [m/s].
        """
        t_fine = np.arange(0.0, self.tr.duration_s, dt_s)
        p_fine = self.true(t_fine)
        radial = np.gradient(np.linalg.norm(p_fine[:, None, :] - anchors_xy_m, axis=2), t_fine, axis=0)
        return float(np.abs(radial).max())


def check_scene(g: GeometryConfig, tr: TrajectoryConfig, *, read_period_s: float) -> None:
    """Check the scene's geometry and length.

    Parameters
    ----------
    g : GeometryConfig
        The floor plan and antennas.
    tr : TrajectoryConfig
        The path and run length.
    read_period_s : float
        Time between two reads [s].

    Raises
    ------
    rfsim.core.errors.ConfigError
        An antenna or a corner outside the room, fewer than 2 corners or two consecutive
        equal ones, fewer than 3 antennas, or a run shorter than one read per antenna (one
        line naming the key).
    """
    w, ln = g.room_m
    for i, (x, y) in enumerate(g.antennas_xy_m):
        if not (0.0 <= x <= w and 0.0 <= y <= ln):
            raise ConfigError(f"geometry.antennas_xy_m[{i}]", [x, y], f"a position inside the room [0, {w:g}] × [0, {ln:g}] m")
    for i, (x, y) in enumerate(tr.corners_xy_m):
        if not (0.0 <= x <= w and 0.0 <= y <= ln):
            raise ConfigError(f"trajectory.corners_xy_m[{i}]", [x, y], f"a corner inside the room [0, {w:g}] × [0, {ln:g}] m")
    c = np.asarray(tr.corners_xy_m, float)
    if c.shape[0] < 2 or np.any(np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1) == 0):
        raise ConfigError("trajectory.corners_xy_m", [list(p) for p in tr.corners_xy_m],
                          "at least 2 corners, no two consecutive ones equal")
    a = np.asarray(g.antennas_xy_m, float)
    if a.shape[0] < 3:
        raise ConfigError("geometry.antennas_xy_m", [list(p) for p in g.antennas_xy_m],
                          "at least 3 antennas (a 2-D fix from ranges)")
    if read_period_s * a.shape[0] > tr.duration_s:
        raise ConfigError("trajectory.duration_s", tr.duration_s, "long enough for one read per antenna")


def carrier_hz(rc: ReaderConfig) -> float:
    """Return the one carrier of a non-hopping reader (phase unwrapping needs one wavelength, L178).

    Parameters
    ----------
    rc : rfsim.devices.reader_config.ReaderConfig
        The reader's settings (region, channel plan, hopping, fixed channel).

    Returns
    -------
    float
        The carrier [Hz]: the fixed channel's, or the only one of the plan.

    Raises
    ------
    rfsim.core.errors.ConfigError
        Hopping over a plan of more than one channel, or a fixed channel beyond the plan.
    """
    plan = frequency_plan(rc.region, rc.channels_hz)
    if rc.hopping and plan.size > 1:
        raise ConfigError("reader.hopping", True, f"false (or a one-carrier plan): phase tracking needs one carrier, "
                                                  f"the plan has {plan.size}")
    if rc.fixed_channel > plan.size:
        raise ConfigError("reader.fixed_channel", rc.fixed_channel, f"1…{plan.size}")
    return float(plan[(rc.fixed_channel - 1) if not rc.hopping else 0])


class _HeldRound(NamedTuple):
    """The round :class:`RoundLinks` answers for, with the tag antenna the engine will ask about."""

    round: int
    tag: object


class RoundLinks:
    """The channel of a chunk (the engine's ``backscatter_links``): the anechoic link of every
    round's antenna to the tag at its held position, drawn for all rounds at once by
    :func:`rfsim.channels.bulk.draw_links` (the physics of :meth:`rfsim.channels.scene.Channel.link`,
    vectorised: LoS amplitude g_ls(d, fc)·√(G_tx·G_rx)·√PLF, delay d/c; no image or diffuse
    path, so no random draw). Monostatic and reciprocal: the backward link is the forward one.
    :meth:`hold` selects the round; a link asked of another antenna pair is an error.

    Parameters
    ----------
    scene : rfsim.channels.scene.Scene
        The (anechoic) scene.
    antennas : list of rfsim.channels.antennas.Antenna
        The reader's antennas.
    tag_antenna : rfsim.channels.antennas.Antenna
        The tag's antenna (its position is replaced by ``tag_xyz_m``).
    antenna_of_round : ndarray of int, shape (n_rounds,)
        0-based reader antenna of each round.
    tag_xyz_m : ndarray, shape (n_rounds, 3)
        The tag's held position in each round [m].
    fc_hz : float
        The carrier [Hz].
    """

    def __init__(self, scene: _scene.Scene, antennas, tag_antenna: _antennas.Antenna, antenna_of_round: np.ndarray,
                 tag_xyz_m: np.ndarray, *, fc_hz: float):
        self.fc_hz = float(fc_hz)
        self.antennas, self.antenna_of_round = antennas, antenna_of_round
        self._paths = np.empty(antenna_of_round.size, dtype=object)
        for i, ant in enumerate(antennas):
            rows = np.flatnonzero(antenna_of_round == i)
            if rows.size == 0:
                continue
            bulk = _bulk.draw_links(scene, ant.position_m, tag_xyz_m[rows], fc_hz=self.fc_hz, rng=np.random.default_rng(0),
                                    tx_antenna=ant, rx_antenna=tag_antenna)
            for k, j in enumerate(rows):
                self._paths[j] = bulk.pathset(k)
        self._held = None

    def hold(self, j: int, tag: _antennas.Antenna) -> None:
        """Select round ``j`` for the next :meth:`backscatter_links` calls.

        Parameters
        ----------
        j : int
            Round, 0-based within the chunk.
        tag : rfsim.channels.antennas.Antenna
            The tag antenna of that round (the one the engine will ask about).
        """
        self._held = _HeldRound(j, tag)

    def backscatter_links(self, emitter: _antennas.Antenna, tag: _antennas.Antenna, *, fc_hz: float, rng=None, t_s: float = 0.0,
                          tag_motion=None):
        """Return the held round's link, forward and backward (the same path set).

        Parameters
        ----------
        emitter : rfsim.channels.antennas.Antenna
            Must be the held round's reader antenna.
        tag : rfsim.channels.antennas.Antenna
            Must be the held tag antenna.
        fc_hz : float
            Must be the carrier [Hz].
        rng : numpy.random.Generator, optional
            Unused (the links have no random part).
        t_s : float, optional
            Unused, default 0.
        tag_motion : None
            Must be None (the tag is held still in a round).

        Returns
        -------
        forward : rfsim.channels.paths.PathSet
            Reader → tag.
        backward : rfsim.channels.paths.PathSet
            Tag → reader (the same object).

        Raises
        ------
        ValueError
            Another antenna pair, carrier, or a moving tag.
        """
        j = self._held.round
        if tag is not self._held.tag or emitter is not self.antennas[self.antenna_of_round[j]] or fc_hz != self.fc_hz \
                or tag_motion is not None:
            raise ValueError("RoundLinks holds one static link per round: its antenna, tag and carrier")
        p = self._paths[j]
        return p, p


def simulate_rounds(geometry: GeometryConfig, trajectory: TrajectoryConfig, reader_config, tag_config, *,
                    read_period_s: float, seed: int, chunk: int, r_lo: int, r_hi: int) -> dict[str, np.ndarray]:
    """Rounds [``r_lo``, ``r_hi``) of a run, one Gen2 singulation per round (module docstring).

    Round r starts at r·``read_period_s`` [s] on the reader's antenna of round r; the tag is
    held at its true position of the round start.

    Parameters
    ----------
    geometry : GeometryConfig
        Floor plan and antennas.
    trajectory : TrajectoryConfig
        The tag's path.
    reader_config : rfsim.devices.reader_config.ReaderConfig
        The reader (one carrier, :func:`carrier_hz`).
    tag_config : rfsim.devices.tag_config.TagConfig
        The tag.
    read_period_s : float
        Time between round starts [s].
    seed : int
        Root seed. Streams: the jitter ``trial_rng(seed, 0)`` (the same for every chunk),
        this chunk's reader ``trial_rng(seed, 1 + chunk, 0)``, tag
        ``trial_rng(seed, 1 + chunk, 1)`` and round r ``trial_rng(seed, 1 + chunk, 2, r)``.
    chunk : int
        Index of the chunk (its streams).
    r_lo : int
        First round of the chunk.
    r_hi : int
        One past the last round of the chunk.

    Returns
    -------
    dict of (r_hi − r_lo,) arrays
        ``time_s`` (the EPC reply's start, the round start for a failed read), ``antenna``
        (1-based), ``channel_index``, ``frequency_hz``, ``rssi_dbm``, ``phase_rad``,
        ``doppler_hz``, ``snr_db`` (NaN for a failed read), ``success``, ``failure_reason``,
        ``epc``, ``round_end_s``, ``round_start_s`` and the true (``x_m``, ``y_m``) and intended
        (``intended_x_m``, ``intended_y_m``) positions at the round start [m].
    """
    g, c = geometry, chunk
    motion = TagMotion(trajectory, rng=trial_rng(seed, 0))
    antennas = reader_antennas(g)
    reader = _reader.Reader(reader_config, antennas, rng=trial_rng(seed, 1 + c, 0))
    tag_antenna = _antennas.Antenna(position_m=(0.0, 0.0, g.height_m), orientation=(0.0, math.radians(g.tag_tilt_deg), 0.0),
                                    pattern=_antennas.HalfWaveDipole(), polarization="linear")
    t_round = np.arange(r_lo, r_hi) * read_period_s
    truth, intended = motion.true(t_round), motion.intended(t_round)
    tag = _tag.PassiveTag(tag_config, tag_antenna, rng=trial_rng(seed, 1 + c, 1), t0_s=float(t_round[0]))
    rounds = np.arange(r_lo, r_hi)
    antenna_of_round = np.array([reader.antenna_index(r) for r in rounds])
    tag_xyz = np.column_stack([truth, np.full(rounds.size, g.height_m)])
    channel = RoundLinks(_scene.Scene(image_order=0), antennas, tag_antenna, antenna_of_round, tag_xyz,
                         fc_hz=carrier_hz(reader_config))
    link = reader.link
    rows: dict[str, list] = {k: [] for k in ("time_s", "antenna", "channel_index", "frequency_hz", "rssi_dbm",
                                             "phase_rad", "doppler_hz", "snr_db", "success", "failure_reason",
                                             "epc", "round_end_s")}
    target = 0
    for j, r in enumerate(range(r_lo, r_hi)):
        t_s = float(t_round[j])
        tag.antenna = dataclasses.replace(tag_antenna, position_m=(truth[j, 0], truth[j, 1], g.height_m))
        channel.hold(j, tag.antenna)
        query = _commands.Query(dr=link.dr, m=link.m, trext=link.trext, q=0, target="AB"[target])
        ex = _engine.singulate(reader, [tag], channel, t_s=t_s, rng=trial_rng(seed, 1 + c, 2, r), query=query, round_index=r)
        last = ex[-1]
        ok = last.command == "ACK" and last.success
        target ^= int(ok)
        read = last.read
        rows["time_s"].append(read.start_s if ok else t_s)
        rows["antenna"].append(last.antenna + 1)
        rows["channel_index"].append(last.channel_index)
        rows["frequency_hz"].append(last.fc_hz)
        for k in ("rssi_dbm", "phase_rad", "doppler_hz", "snr_db"):
            rows[k].append(getattr(read, k) if ok else np.nan)
        rows["success"].append(ok)
        rows["failure_reason"].append(last.failure_reason)
        rows["epc"].append(epc_hex(read.bits) if ok else "")
        rows["round_end_s"].append(last.end_s)
    out = {k: np.asarray(v) for k, v in rows.items()}
    out.update(round_start_s=t_round, x_m=truth[:, 0], y_m=truth[:, 1], intended_x_m=intended[:, 0],
               intended_y_m=intended[:, 1])
    return out


__all__ = ["GeometryConfig", "TrajectoryConfig", "reader_antennas", "polygon_path", "TagMotion", "carrier_hz", "check_scene",
           "RoundLinks", "simulate_rounds"]

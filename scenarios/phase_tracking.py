"""Scenario ``phase-tracking``: Särkkä et al.'s 890 MHz phase tracking, read at sample level.

Setup (phase-tracking.md §2, wave2-specs.md §R; seeds/001 L57, L174–L178): four panel antennas
(8 dBi, 75°, vertical polarization, the SPA 8090/75/8/0/V class) at the corners of a 3 m square,
1.5 m high, aimed at the centre; a vertical-dipole tag at 1.5 m moving along a square path at
0.2 m/s with a smooth ground-truth jitter (the manual movement, 1–2 cm RMS, L203); one carrier,
890 MHz (custom carrier plan); an anechoic channel (Friis free space: no APDP, no surfaces,
L174); a constant phase offset per reader port (P§1.2 [not in source]).

Reads (L57, L178: CW from one antenna at a time, 100 reads/s per antenna): every read is one
Gen2 singulation (Query → RN16 → ACK → PC+EPC+CRC-16) through the engine at sample level on a
**fixed schedule** — round r starts at r·``schedule.read_period_s`` (2.5 ms: 400 reads/s, 100
per antenna) on antenna r mod 4 (round robin), with the fm0-640k link (a singulation ≈ 0.71 ms
fits the slot; miller4-320k takes ≈ 2.98 ms and reaches only ≈ 84 reads/s per antenna). Rounds
alternate target A/B after each successful read (the tag's S0 flag flips). The tag is held
at its position of the round start for the round (quasi-static: it moves ≤ 0.2 m/s·0.71 ms =
0.14 mm, a phase change ≤ 5 mrad), so the channel's narrowband held-link path applies; silent
time between rounds is not simulated. The links of a chunk's rounds are drawn at once
(:class:`RoundLinks`, ``rfsim.channels.bulk.draw_links``). The run is cut into chunks of
``schedule.chunk_s`` simulated in parallel (each with its own reader and tag, reproducible
whatever the number of workers: the chunks are part of the config); round 0 alone runs first
in the leading process (the slot check, and the kernels the workers inherit), then every chunk
in the pool.

The reader reports (``reader.report``, rfsim.core.records): RSSI in 1 dB steps, the 12-bit phase
code with the port's offset, µs time stamps. Estimators (rfsim.estimators.phase_tracking):
the eq. (13) RSSI fix of the first read cycle gives p̂₀; the reported phases are unwrapped to
pseudo-ranges (eq. 4–5) from r̂₀ = |p̂₀ − a_i|; the CWNA + bias EKF per read, the RTS smoother
and ``estimator.passes`` passes (L205); the RSSI-only track is eq. (13) applied to the latest
RSSI of every antenna at each read (Fig. 8, L207).

Randomness: the jitter from ``trial_rng(seed, 0)``; chunk c's reader, tag and rounds from
``trial_rng(seed, 1 + c, 0)``, ``trial_rng(seed, 1 + c, 1)`` and ``trial_rng(seed, 1 + c, 2, r)``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.devices.reader_config import ReaderConfig, frequency_plan
from rfsim.devices.tag_config import TagConfig
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.procs import map_in_order
from rfsim.core.progress import stage
from rfsim.core.records import READ_MEASUREMENT_FIELDS, READ_REPORT_FIELDS, ReportConfig, epc_hex, long_table, report_columns
from rfsim.core.rng import trial_rng
from rfsim.core.units import wavelength_m

_ndimage = lazy_import("scipy.ndimage")
_antennas = lazy_import("rfsim.channels.antennas")
_scene = lazy_import("rfsim.channels.scene")
_bulk = lazy_import("rfsim.channels.bulk")
_reader = lazy_import("rfsim.devices.reader")
_tag = lazy_import("rfsim.devices.tag")
_rfsim_dataset = lazy_import("rfsim.core.dataset")
_engine = lazy_import("rfsim.protocols.engine")
_phase_tracking = lazy_import("rfsim.estimators.phase_tracking")
_commands = lazy_import("rfsim.gen2.commands")

NAME = "phase-tracking"
DESCRIPTION = ("Särkkä's 890 MHz phase tracking: 4 corner antennas read a moving tag at sample level; "
               "unwrapped pseudo-ranges, CWNA+bias EKF, RTS, iterations, RSSI-only fix")

#: Published RMSEs of experiment 1 (L203–L207) [m]: (estimator, pass) → value.
PUBLISHED_RMSE_M = {("EKF", 1): 0.032, ("EKF", 2): 0.022, ("RTS", 1): 0.015, ("RTS", 2): 0.015,
                    ("RTS", 3): 0.015, ("RSSI eq. 13", 0): 0.35}


@dataclass(frozen=True)
class GeometryConfig:
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
    corners_xy_m: tuple[tuple[float, float], ...] = param(
        ((1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0)), lo=-1000.0, hi=1000.0, unit="m",
        doc="closed polygon the tag follows (the intended path), first corner at t = 0")
    speed_mps: float = param(0.2, lo=0.0, hi=100.0, lo_open=True, unit="m/s", doc="speed along the path")
    duration_s: float = param(60.0, lo=0.05, hi=3600.0, unit="s", doc="length of the run")
    jitter_rms_m: float = param(0.015, lo=0.0, hi=0.5, unit="m",
                                doc="RMS 2-D deviation of the true from the intended path (manual movement, L203)")
    jitter_time_s: float = param(0.5, lo=0.01, hi=100.0, unit="s",
                                 doc="std of the Gaussian smoothing kernel of the jitter (its correlation time)")


@dataclass(frozen=True)
class ScheduleConfig:
    read_period_s: float = param(2.5e-3, lo=1e-4, hi=1.0, unit="s",
                                 doc="start-to-start time of two reads (antennas in turn): 2.5 ms = 100 reads/s per antenna")
    chunk_s: float = param(15.0, lo=0.01, hi=3600.0, unit="s",
                           doc="the run is simulated in chunks of this length (own reader and tag each)")
    workers: int = param(0, lo=0, hi=256, doc="processes for the chunks (0 = all cores, 1 = serial)")


@dataclass(frozen=True)
class EstimatorConfig:
    q_v: float = param(1.0, lo=0.0, lo_open=True, hi=1e6, unit="m^2/s^3", doc="CWNA velocity noise density (P§6)")
    q_b: float = param(1e-4, lo=0.0, lo_open=True, hi=10.0, unit="m^2/s", doc="bias random-walk density (P§6)")
    sigma_m: float = param(0.01, lo=0.0, lo_open=True, hi=10.0, unit="m", doc="pseudo-range noise std of the EKF")
    pos_std_m: float = param(3.0, lo=0.0, lo_open=True, hi=100.0, unit="m", doc="prior position std (L203)")
    bias_std_m: float = param(1.0, lo=0.0, lo_open=True, hi=100.0, unit="m", doc="prior bias std (P§6)")
    vel_std_mps: float = param(0.5, lo=0.0, lo_open=True, hi=100.0, unit="m/s", doc="prior velocity std (P§6)")
    passes: int = param(3, lo=1, hi=20, doc="filter + smoother passes (L205: 2; Fig. 8: 3)")


def _reader_defaults() -> ReaderConfig:
    return ReaderConfig(link_profile="fm0-640k", region="custom", channels_hz=(890e6,), hopping=False, fs_hz=2e6,
                        report=ReportConfig(rssi_step_db=1.0, phase_bits=12,
                                            port_phase_offsets_rad=(0.61, 2.23, -1.37, 3.9)))


@dataclass(frozen=True)
class Config:
    geometry: GeometryConfig = param(GeometryConfig(), doc="antennas and room")
    trajectory: TrajectoryConfig = param(TrajectoryConfig(), doc="tag motion")
    schedule: ScheduleConfig = param(ScheduleConfig(), doc="read schedule and chunks")
    reader: ReaderConfig = param(_reader_defaults(), doc="reader (fm0-640k, one 890 MHz carrier, 2 MS/s)")
    tag: TagConfig = param(TagConfig(), doc="tag")
    estimator: EstimatorConfig = param(EstimatorConfig(), doc="EKF/RTS tuning")


# ----------------------------------------------------------------------------- geometry and motion


def reader_antennas(g: GeometryConfig) -> list[_antennas.Antenna]:
    """The reader antennas at ``antennas_xy_m`` and ``height_m``, boresight towards the room centre."""
    cx, cy = 0.5 * g.room_m[0], 0.5 * g.room_m[1]
    out = []
    for x, y in g.antennas_xy_m:
        pattern = _antennas.Patch(g.antenna_gain_dbi, g.antenna_beamwidth_deg) if g.antenna_pattern == "patch" else _antennas.Isotropic()
        yaw = math.atan2(cy - y, cx - x) if (cx, cy) != (x, y) else 0.0
        out.append(_antennas.Antenna(position_m=(x, y, g.height_m), orientation=(yaw, 0.0, 0.0), pattern=pattern,
                                     polarization=g.antenna_polarization))
    return out


def polygon_path(t_s, corners_xy_m, speed_mps: float) -> np.ndarray:
    """(n, 2) positions [m] at ``t_s`` on the closed polygon ``corners`` at constant speed."""
    c = np.asarray(corners_xy_m, float)
    ends = np.roll(c, -1, axis=0)
    seg = np.linalg.norm(ends - c, axis=1)
    cum = np.concatenate(([0.0], np.cumsum(seg)))
    s = np.mod(np.asarray(t_s, float) * speed_mps, cum[-1])
    k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, c.shape[0] - 1)
    frac = (s - cum[k]) / seg[k]
    return c[k] + frac[:, None] * (ends[k] - c[k])


class TagMotion:
    """Intended path plus the smooth jitter: white noise on a 10 ms grid, Gaussian-smoothed
    (std ``jitter_time_s``) and scaled so that the realised 2-D RMS equals ``jitter_rms_m``."""

    GRID_S = 0.01

    def __init__(self, tr: TrajectoryConfig, *, rng: np.random.Generator):
        self.tr = tr
        self.t_grid = np.arange(0.0, tr.duration_s + 2.0, self.GRID_S)
        jit = _ndimage.gaussian_filter1d(rng.standard_normal((self.t_grid.size, 2)), tr.jitter_time_s / self.GRID_S,
                                axis=0, mode="wrap")
        rms = math.sqrt(np.mean(np.sum(jit ** 2, axis=1)))
        self.jitter = jit * (tr.jitter_rms_m / rms) if tr.jitter_rms_m > 0 else np.zeros_like(jit)

    def intended(self, t_s) -> np.ndarray:
        return polygon_path(np.atleast_1d(t_s), self.tr.corners_xy_m, self.tr.speed_mps)

    def true(self, t_s) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t_s, float))
        j = np.column_stack([np.interp(t, self.t_grid, self.jitter[:, k]) for k in range(2)])
        return self.intended(t) + j


def carrier_hz(rc: ReaderConfig) -> float:
    """The one carrier of the reader [Hz]; hopping over several is a one-line ``ConfigError``
    (phase unwrapping needs one wavelength, L178)."""
    plan = frequency_plan(rc.region, rc.channels_hz)
    if rc.hopping and plan.size > 1:
        raise ConfigError("reader.hopping", True, f"false (or a one-carrier plan): phase tracking needs one carrier, "
                                                  f"the plan has {plan.size}")
    if rc.fixed_channel > plan.size:
        raise ConfigError("reader.fixed_channel", rc.fixed_channel, f"1…{plan.size}")
    return float(plan[(rc.fixed_channel - 1) if not rc.hopping else 0])


def check_geometry(config: Config) -> None:
    """One-line ``ConfigError`` for antennas or a path outside the room, a degenerate path."""
    g, tr = config.geometry, config.trajectory
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
    if config.schedule.read_period_s * a.shape[0] > config.trajectory.duration_s:
        raise ConfigError("trajectory.duration_s", tr.duration_s, "long enough for one read per antenna")


# ----------------------------------------------------------------------------- reads


class RoundLinks:
    """The channel of a chunk (the engine's ``backscatter_links``): the anechoic link of every
    round's antenna to the tag at its held position, drawn for all rounds at once by
    :func:`rfsim.channels.bulk.draw_links` (the physics of :meth:`rfsim.channels.scene.Channel.link`,
    vectorised: LoS amplitude g_ls(d, fc)·√(G_tx·G_rx)·√PLF, delay d/c; no image or diffuse
    path, so no random draw). Monostatic and reciprocal: the backward link is the forward one.
    :meth:`hold` selects the round; a link asked of another antenna pair is an error."""

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
        """Round ``j`` (0-based within the chunk), its tag antenna ``tag``."""
        self._held = (j, tag)

    def backscatter_links(self, emitter: _antennas.Antenna, tag: _antennas.Antenna, *, fc_hz: float, rng=None, t_s: float = 0.0,
                          tag_motion=None):
        j, held_tag = self._held
        if tag is not held_tag or emitter is not self.antennas[self.antenna_of_round[j]] or fc_hz != self.fc_hz \
                or tag_motion is not None:
            raise ValueError("RoundLinks holds one static link per round: its antenna, tag and carrier")
        p = self._paths[j]
        return p, p


def _simulate_chunk(task) -> dict[str, np.ndarray]:
    """Rounds [r_lo, r_hi) of the run: one singulation per round (module docstring)."""
    config, seed, c, r_lo, r_hi = task
    g, sch = config.geometry, config.schedule
    motion = TagMotion(config.trajectory, rng=trial_rng(seed, 0))
    antennas = reader_antennas(g)
    reader = _reader.Reader(config.reader, antennas, rng=trial_rng(seed, 1 + c, 0))
    tag_antenna = _antennas.Antenna(position_m=(0.0, 0.0, g.height_m), orientation=(0.0, math.radians(g.tag_tilt_deg), 0.0),
                                    pattern=_antennas.HalfWaveDipole(), polarization="linear")
    t_round = np.arange(r_lo, r_hi) * sch.read_period_s
    truth, intended = motion.true(t_round), motion.intended(t_round)
    tag = _tag.PassiveTag(config.tag, tag_antenna, rng=trial_rng(seed, 1 + c, 1), t0_s=float(t_round[0]))
    rounds = np.arange(r_lo, r_hi)
    antenna_of_round = np.array([reader.antenna_index(r) for r in rounds])
    tag_xyz = np.column_stack([truth, np.full(rounds.size, g.height_m)])
    channel = RoundLinks(_scene.Scene(image_order=0), antennas, tag_antenna, antenna_of_round, tag_xyz,
                         fc_hz=carrier_hz(config.reader))
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


READ_FIELDS = {
    "t_s": ("s", "time of the read: start of the EPC reply (the round start for a failed read)"),
    **READ_REPORT_FIELDS,
    **{k: v for k, v in READ_MEASUREMENT_FIELDS.items()},
    "success": ("1", "EPC decoded with CRC ok"),
    "failure_reason": ("", "why the read failed ('' = success, rfsim.protocols.engine.FAILURE_REASONS)"),
    "round": ("1", "read round (0-based); round r starts at r·schedule.read_period_s on antenna r mod s"),
    "tx_power_dbm": ("dBm", "conducted reader transmit power at the antenna port"),
    "x_m": ("m", "true tag x during the round (intended path + jitter), held from the round start"),
    "y_m": ("m", "true tag y during the round (intended path + jitter), held from the round start"),
    "z_m": ("m", "height of the tag above the floor (geometry.height_m, constant)"),
    "intended_x_m": ("m", "intended (marked) path x at the round start, what the paper's RMSE refers to"),
    "intended_y_m": ("m", "intended (marked) path y at the round start"),
    "trial": ("1", "trial index of the run (one trajectory: 0)"),
}


def _read_task(task) -> dict[str, np.ndarray]:
    """:func:`_simulate_chunk` of ``task[:5]``; with ``task[5]`` (the probe) the slot is checked."""
    out = _simulate_chunk(task[:5])
    if task[5]:
        _check_slot(task[0], float(np.max(out["round_end_s"] - out["round_start_s"])))
    return out


def _check_slot(config: Config, singulation_s: float) -> None:
    if singulation_s > config.schedule.read_period_s:
        raise ConfigError("schedule.read_period_s", config.schedule.read_period_s,
                          f"a period ≥ one singulation ({singulation_s * 1e3:.3g} ms with reader.link_profile "
                          f"{config.reader.link_profile!r})")


def _cycle_first_fix(antenna0: np.ndarray, rssi: np.ndarray, anchors: np.ndarray) -> np.ndarray:
    """Eq. (13) on the first reported RSSI of every antenna: the initial position p̂₀."""
    first = np.full(anchors.shape[0], np.nan)
    for i in range(anchors.shape[0]):
        idx = np.flatnonzero((antenna0 == i) & np.isfinite(rssi))
        if idx.size == 0:
            raise ConfigError("geometry.antennas_xy_m", f"antenna {i + 1} reported no read",
                              "antennas that can read the tag (check range, power and pattern)")
        first[i] = rssi[idx[0]]
    return _phase_tracking.rssi_fix(first, anchors)[0]


def _latest_rssi(antenna0: np.ndarray, rssi: np.ndarray, n_antennas: int) -> np.ndarray:
    """(N, s): at each read, the latest reported RSSI of every antenna (NaN before its first)."""
    out = np.full((rssi.size, n_antennas), np.nan)
    idx = np.arange(rssi.size)
    for i in range(n_antennas):
        have = (antenna0 == i) & np.isfinite(rssi)
        last = np.maximum.accumulate(np.where(have, idx, -1))
        out[:, i] = np.where(last >= 0, rssi[np.maximum(last, 0)], np.nan)
    return out


def _stats(err: np.ndarray) -> dict[str, float]:
    e = err[np.isfinite(err)]
    return {"rmse_m": float(np.sqrt(np.mean(e ** 2))), "mean_m": float(e.mean()), "median_m": float(np.median(e)),
            "p90_m": float(np.quantile(e, 0.9)), "max_m": float(e.max()), "std_m": float(e.std())}


def run(config: Config, *, seed: int) -> _rfsim_dataset.Dataset:
    check_geometry(config)
    carrier_hz(config.reader)
    g, tr, sch, est = config.geometry, config.trajectory, config.schedule, config.estimator
    anchors = np.asarray(g.antennas_xy_m, float)
    s = anchors.shape[0]
    lam = float(wavelength_m(carrier_hz(config.reader)))
    n_rounds = int(math.floor(tr.duration_s / sch.read_period_s + 1e-9))
    per_chunk = max(1, int(round(sch.chunk_s / sch.read_period_s)))
    tasks = [(config, seed, c, lo, min(lo + per_chunk, n_rounds)) for c, lo in enumerate(range(0, n_rounds, per_chunk))]

    # the unwrapping limit of the true motion (warn and flag, do not stop)
    dt_antenna = s * sch.read_period_s
    limit = float(_phase_tracking.unwrap_limit_mps(lam, dt_antenna))
    motion = TagMotion(tr, rng=trial_rng(seed, 0))
    t_fine = np.arange(0.0, tr.duration_s, 1e-3)
    p_fine = motion.true(t_fine)
    radial = np.gradient(np.linalg.norm(p_fine[:, None, :] - anchors, axis=2), t_fine, axis=0)
    v_radial = float(np.abs(radial).max())
    exceeded = v_radial >= limit
    if exceeded:
        stage(f"warning: the tag's radial speed reaches {v_radial:.3g} m/s, above the unwrapping limit "
              f"λ/(4Δt) = {limit:.3g} m/s for reads {dt_antenna * 1e3:.3g} ms apart per antenna: "
              "pseudo-ranges will jump by λ/2 (flagged in the dataset)")

    stage(f"reading: {n_rounds} singulations at sample level, {len(tasks)} chunks")
    # The probe (round 0 alone) is the first task: map_in_order runs it alone before the pool
    # starts, so a singulation too long for the slot stops the run at once, and the kernels it
    # compiles are loaded here once and inherited by the workers; every chunk then runs in the pool.
    parts = map_in_order(_read_task, [(config, seed, 0, 0, 1, True)] + [t + (False,) for t in tasks], sch.workers,
                         desc="chunks", unit="chunks")[1:]
    cols = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    busy = cols.pop("round_end_s") - cols["round_start_s"]
    _check_slot(config, float(busy.max()))
    cols["round"] = np.arange(n_rounds)
    cols.update(report_columns(config.reader.report, t_s=cols["time_s"], antenna=cols["antenna"],
                               rssi_dbm=cols["rssi_dbm"], phase_rad=cols["phase_rad"], success=cols["success"]))
    cols["t_s"] = cols.pop("time_s")
    cols["tx_power_dbm"] = np.full(n_rounds, config.reader.ptx_dbm)
    cols["z_m"] = np.full(n_rounds, g.height_m)
    cols["trial"] = np.zeros(n_rounds, dtype=np.int64)
    reads = long_table(cols)

    # ---------------------------------------------------------------- estimators
    stage("estimating: RSSI fix, unwrapping, EKF + RTS passes")
    t = reads["t_s"]
    ant0 = reads["antenna"].astype(np.int64) - 1
    rssi = reads["rssi_reported_dbm"]
    phase = reads["phase_reported_rad"]
    truth = np.column_stack([reads["x_m"], reads["y_m"]])
    intended = np.column_stack([reads["intended_x_m"], reads["intended_y_m"]])
    p0 = _cycle_first_fix(ant0, rssi, anchors)
    r0 = np.linalg.norm(p0 - anchors, axis=1)
    z = _phase_tracking.unwrap_pseudoranges(ant0, phase, wavelength_m=lam, r0_m=r0)
    true_range = np.linalg.norm(truth - anchors[ant0], axis=1)
    offset = z - true_range
    jump = np.zeros(t.size, dtype=bool)
    for i in range(s):
        idx = np.flatnonzero((ant0 == i) & np.isfinite(z))
        jump[idx[1:]] = np.abs(np.diff(offset[idx])) > lam / 4
    x0, P0 = _phase_tracking.initial_state(p0, s, pos_std_m=est.pos_std_m, bias_std_m=est.bias_std_m, vel_std_mps=est.vel_std_mps)
    passes = _phase_tracking.track_phase(t, ant0, z, anchors, x0, P0, q_v=est.q_v, q_b=est.q_b, sigma_m=est.sigma_m,
                                         passes=est.passes, keep_covariances=False)
    rssi_track, _ = _phase_tracking.rssi_fix(_latest_rssi(ant0, rssi, s), anchors)
    rssi_track[~np.all(np.isfinite(_latest_rssi(ant0, rssi, s)), axis=1)] = np.nan

    estimates = {"t_s": t, "antenna": reads["antenna"], "x_m": truth[:, 0], "y_m": truth[:, 1],
                 "intended_x_m": intended[:, 0], "intended_y_m": intended[:, 1]}
    tracks = []
    for k, ps in enumerate(passes, start=1):
        for name, x in (("ekf", ps.x_filt), ("rts", ps.x_smooth)):
            estimates[f"{name}{k}_x_m"], estimates[f"{name}{k}_y_m"] = x[:, 0], x[:, 1]
            tracks.append((name.upper(), k, x[:, :2]))
    estimates["rssi_x_m"], estimates["rssi_y_m"] = rssi_track[:, 0], rssi_track[:, 1]
    tracks.append(("RSSI eq. 13", 0, rssi_track))

    summary: dict[str, list] = {k: [] for k in ("estimator", "pass", "rmse_m", "rmse_true_m", "mean_m", "median_m",
                                                "p90_m", "max_m", "std_m", "published_rmse_m")}
    for name, k, xy in tracks:
        st = _stats(np.linalg.norm(xy - intended, axis=1))
        summary["estimator"].append(name)
        summary["pass"].append(k)
        for key, v in st.items():
            summary[key].append(v)
        summary["rmse_true_m"].append(_stats(np.linalg.norm(xy - truth, axis=1))["rmse_m"])
        summary["published_rmse_m"].append(PUBLISHED_RMSE_M.get((name, k), np.nan))
    return _dataset(config, reads, z, true_range, offset, jump, estimates, summary, anchors=anchors, lam=lam,
                    limit=limit, v_radial=v_radial, exceeded=exceeded, p0=p0, busy=busy)


def _dataset(config, reads, z, true_range, offset, jump, estimates, summary, *, anchors, lam, limit, v_radial,
             exceeded, p0, busy) -> _rfsim_dataset.Dataset:
    est, sch = config.estimator, config.schedule
    s = anchors.shape[0]
    ds = _rfsim_dataset.Dataset(title="Särkkä 890 MHz phase tracking: sample-level reads, pseudo-ranges, EKF/RTS tracks")
    ds.add_table("reads", {k: _rfsim_dataset.column(reads[k], *READ_FIELDS[k]) for k in READ_FIELDS},
                 description="one row per read round (Query, RN16, ACK, EPC) in the long per-read format, sorted "
                             "by time stamp: the reader's measurements and report, and the true tag position")
    ds.add_table("pseudoranges", {
        "t_s": _rfsim_dataset.column(reads["t_s"], *READ_FIELDS["t_s"]),
        "antenna": _rfsim_dataset.column(reads["antenna"], *READ_FIELDS["antenna"]),
        "pseudorange_m": _rfsim_dataset.column(z, "m", "unwrapped pseudo-range r̂ of eq. (4)-(5) from the reported phase "
                                        "(NaN for a failed read)"),
        "true_range_m": _rfsim_dataset.column(true_range, "m", "true distance from the antenna to the tag"),
        "offset_m": _rfsim_dataset.column(offset, "m", "pseudo-range minus true range: the constant bias b_i of eq. (6) plus noise"),
        "jump": _rfsim_dataset.column(jump, "1", "the offset changed by more than λ/4 since this antenna's previous read "
                                  "(an unwrapping jump of λ/2)"),
    }, description="one row per read: the unwrapped pseudo-range of eq. (4)-(5) beside the true range")
    desc = {"t_s": ("s", "time of the read"), "antenna": READ_FIELDS["antenna"], "x_m": READ_FIELDS["x_m"],
            "y_m": READ_FIELDS["y_m"], "intended_x_m": READ_FIELDS["intended_x_m"],
            "intended_y_m": READ_FIELDS["intended_y_m"],
            "rssi_x_m": ("m", "RSSI-only position x: eq. (13) on the latest RSSI of every antenna (NaN until each has one)"),
            "rssi_y_m": ("m", "RSSI-only position y: eq. (13) on the latest RSSI of every antenna")}
    for k in estimates:
        if k not in desc:  # ekf<k>_x_m, rts<k>_y_m, ...
            name, axis = k.split("_")[:2]
            kind = "EKF (filtered, eq. 16-17)" if name.startswith("ekf") else "RTS (smoothed, eq. 19)"
            desc[k] = ("m", f"{kind} position {axis} at the read, pass {name[3:]}")
    ds.add_table("estimates", {k: _rfsim_dataset.column(v, *desc[k]) for k, v in estimates.items()},
                 description="one row per read: the tracks of every estimator and pass beside the true and intended path")
    sdesc = {"estimator": ("", "estimator: EKF (eq. 16-17), RTS (eq. 19) or RSSI eq. 13 (point-wise)"),
             "pass": ("1", "filter + smoother pass (1 = from the RSSI fix; k+1 starts from pass k's smoothed state; "
                           "0 for the RSSI fix)"),
             "rmse_m": ("m", "RMS position error against the intended path (as the paper)"),
             "rmse_true_m": ("m", "RMS position error against the true (jittered) path"),
             "mean_m": ("m", "mean position error against the intended path"),
             "median_m": ("m", "median position error against the intended path"),
             "p90_m": ("m", "90th percentile of the position error against the intended path"),
             "max_m": ("m", "largest position error against the intended path"),
             "std_m": ("m", "standard deviation of the position error against the intended path"),
             "published_rmse_m": ("m", "RMSE of experiment 1 in Särkkä et al. 2012 (L203-L207; NaN where none is given)")}
    ds.add_table("summary", {k: _rfsim_dataset.column(np.asarray(v), *sdesc[k]) for k, v in summary.items()},
                 description="one row per estimator and pass: position error statistics beside the published RMSE")
    F, L, Qc = _phase_tracking.continuous_model(2, s, q_v=est.q_v, q_b=est.q_b)
    A, W = _phase_tracking.discrete_model(sch.read_period_s, 2, s, q_v=est.q_v, q_b=est.q_b)
    reported = reads["reported"].astype(bool)
    rmse = {(n, k): r for n, k, r in zip(summary["estimator"], summary["pass"], summary["rmse_m"])}
    last = est.passes
    ds.attrs.update({
        "state_order": "x, y, b_1..b_s, v_x, v_y (positions [m], biases [m], velocities [m/s])",
        "F": F, "F_description": "continuous-time dynamics matrix of eq. (12), dx/dt = F x + L w",
        "L": L, "Qc": Qc, "Qc_description": "spectral density of w: diag(q_b I_s, q_v I_d) (m²/s, m²/s³)",
        "Q_dt": W, "A_dt": A, "dt_s": sch.read_period_s,
        "Q_dt_description": "W(Δt) of eq. (14) and A(Δt) = exp(FΔt) at Δt = dt_s (closed form); the EKF uses each "
                            "read's own Δt",
        "antennas_xyz_m": np.column_stack([anchors, np.full(s, config.geometry.height_m)]),
        "wavelength_m": lam, "unwrap_limit_mps": limit, "max_radial_speed_mps": v_radial,
        "unwrap_limit_exceeded": int(exceeded), "unwrap_jumps": int(jump.sum()),
        "schedule": f"fixed: round r at r·{sch.read_period_s:g} s on antenna (r mod {s}) + 1, "
                    f"link {config.reader.link_profile}",
        "singulation_max_s": float(busy.max()),
        "reads_per_s_per_antenna": float(reported.sum() / (s * config.trajectory.duration_s)),
        "read_success_rate": float(reported.mean()),
        "initial_fix_error_m": float(np.linalg.norm(p0 - np.array([reads["intended_x_m"][0], reads["intended_y_m"][0]]))),
        "rts_rmse_m": rmse[("RTS", last)], "ekf_rmse_m": rmse[("EKF", last)],
        "ekf1_rmse_m": rmse[("EKF", 1)], "rts1_rmse_m": rmse[("RTS", 1)],
        "rssi_rmse_m": rmse[("RSSI eq. 13", 0)],
    })
    if est.passes >= 2:
        ds.attrs["ekf2_rmse_m"] = rmse[("EKF", 2)]
    return ds


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Phase and pseudo-range vs time per antenna, true vs estimated tracks, error CDFs."""
    from rfsim.scenarios._phase_figures import plot_all

    return plot_all(dataset_path, out_dir)

"""Scenario ``phase-tracking``: Särkkä et al.'s 890 MHz phase tracking, read at sample level.

Setup (phase-tracking.md §2, wave2-specs.md §R; seeds/001 L57, L174–L178): four panel antennas
(8 dBi, 75°, vertical polarization, the SPA 8090/75/8/0/V class) at the corners of a 3 m square,
1.5 m high, aimed at the centre; a vertical-dipole tag at 1.5 m moving along a square path at
0.2 m/s with a smooth ground-truth jitter (the manual movement, 1–2 cm RMS, L203); one carrier,
890 MHz (custom carrier plan); an anechoic channel (Friis free space: no APDP, no surfaces,
L174); a constant phase offset per reader port (P§1.2 [not in source]).

Reads (L57, L178: CW from one antenna at a time, 100 reads/s per antenna; the scene
:mod:`rfsim.scenes.phase_tracking`): one Gen2 singulation per round at sample level on a **fixed
schedule** — round r starts at r·``schedule.read_period_s`` (2.5 ms: 100 reads/s per antenna)
on antenna r mod 4, with the fm0-640k link (a singulation ≈ 0.71 ms fits the slot; miller4-320k
takes ≈ 2.98 ms and reaches only ≈ 84 reads/s per antenna); the tag held at its position of the
round start; silent time between rounds is not simulated. The run is cut into chunks of
``schedule.chunk_s`` simulated in parallel (each with its own reader and tag, reproducible
whatever the number of workers: the chunks are part of the config); round 0 alone runs first
in the leading process (the slot check, and the kernels the workers inherit), then every chunk
in the pool.

The reader reports (``reader.report``, rfsim.core.records): RSSI in 1 dB steps, the 12-bit phase
code with the port's offset, µs time stamps. Estimators (rfsim.estimators.phase_tracking):
the eq. (13) RSSI fix of the first read cycle gives p̂₀; the reported phases are unwrapped to
pseudo-ranges (eq. 4–5) from ``r̂₀ = |p̂₀ − a_i|``; the CWNA + bias EKF per read, the RTS smoother
and ``estimator.passes`` passes (L205); the RSSI-only track is eq. (13) applied to the latest
RSSI of every antenna at each read (Fig. 8, L207). Accuracy against the paper, the first pass's gap
and its measured cause: the docs page and attribute ``first_pass_note``.

Randomness: the jitter from ``trial_rng(seed, 0)``; chunk c's reader, tag and rounds from
``trial_rng(seed, 1 + c, 0)``, ``trial_rng(seed, 1 + c, 1)`` and ``trial_rng(seed, 1 + c, 2, r)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.procs import map_in_order
from rfsim.core.progress import stage
from rfsim.core.reads import reads_table
from rfsim.core.records import READ_MEASUREMENT_FIELDS, READ_REPORT_FIELDS, ReportConfig, long_table, report_columns
from rfsim.core.rng import trial_rng
from rfsim.core.units import wavelength_m
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.scenes.phase_tracking import (GeometryConfig, RoundLinks, TagMotion, TrajectoryConfig,  # noqa: F401
                                         carrier_hz, check_scene, reader_antennas, simulate_rounds)

_rfsim_dataset = lazy_import("rfsim.core.dataset")
_phase_tracking = lazy_import("rfsim.estimators.phase_tracking")

NAME = "phase-tracking"
DESCRIPTION = ("Särkkä's 890 MHz phase tracking: 4 corner antennas read a moving tag at sample level; "
               "unwrapped pseudo-ranges, CWNA+bias EKF, RTS, iterations, RSSI-only fix")

#: Published RMSEs of experiment 1 (L203–L207) [m]: (estimator, pass) → value.
PUBLISHED_RMSE_M = {("EKF", 1): 0.032, ("EKF", 2): 0.022, ("RTS", 1): 0.015, ("RTS", 2): 0.015,
                    ("RTS", 3): 0.015, ("RSSI eq. 13", 0): 0.35}


@dataclass(frozen=True)
class ScheduleConfig:
    """The fixed read schedule and the chunks the run is simulated in.

    Attributes
    ----------
    read_period_s : float, default 0.0025
        Start-to-start time of two reads [s] (antennas in turn): 2.5 ms = 100 reads/s
        per antenna; in [1e-4, 1].
    chunk_s : float, default 15.0
        The run is simulated in chunks of this length (own reader and tag each) [s], in
        [0.01, 3600].
    workers : int, default 0
        Processes for the chunks (0 = all cores, 1 = serial), in [0, 256].
    """

    read_period_s: float = param(2.5e-3, lo=1e-4, hi=1.0, unit="s",
                                 doc="start-to-start time of two reads (antennas in turn): 2.5 ms = 100 reads/s per antenna")
    chunk_s: float = param(15.0, lo=0.01, hi=3600.0, unit="s",
                           doc="the run is simulated in chunks of this length (own reader and tag each)")
    workers: int = param(0, lo=0, hi=256, doc="processes for the chunks (0 = all cores, 1 = serial)")


@dataclass(frozen=True)
class EstimatorConfig:
    """Tuning of the CWNA + bias EKF and the RTS smoother (phase-tracking.md, P§6).

    Attributes
    ----------
    q_v : float, default 1.0
        CWNA velocity noise density (P§6) [m^2/s^3], in (0, 1e6].
    q_b : float, default 1e-4
        Bias random-walk density (P§6) [m^2/s], in (0, 10].
    sigma_m : float, default 0.01
        Pseudo-range noise std of the EKF [m], in (0, 10].
    pos_std_m : float, default 3.0
        Prior position std (L203) [m], in (0, 100].
    bias_std_m : float, default 1.0
        Prior bias std (P§6) [m], in (0, 100].
    vel_std_mps : float, default 0.5
        Prior velocity std (P§6) [m/s], in (0, 100].
    passes : int, default 3
        Filter + smoother passes (L205: 2; Fig. 8: 3), in [1, 20].
    """

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
    """Configuration of the ``phase-tracking`` scenario.

    The reader defaults to the fm0-640k link on one 890 MHz carrier (custom plan, no hopping)
    at 2 MS/s, RSSI in 1 dB steps, a 12-bit phase code and one phase offset per port.

    Attributes
    ----------
    geometry : rfsim.scenes.phase_tracking.GeometryConfig
        Antennas and room.
    trajectory : rfsim.scenes.phase_tracking.TrajectoryConfig
        Tag motion.
    schedule : ScheduleConfig
        Read schedule and chunks.
    reader : rfsim.devices.reader_config.ReaderConfig
        Reader (fm0-640k, one 890 MHz carrier, 2 MS/s).
    tag : rfsim.devices.tag_config.TagConfig
        Tag settings.
    estimator : EstimatorConfig
        EKF/RTS tuning.
    """

    geometry: GeometryConfig = param(GeometryConfig(), doc="antennas and room")
    trajectory: TrajectoryConfig = param(TrajectoryConfig(), doc="tag motion")
    schedule: ScheduleConfig = param(ScheduleConfig(), doc="read schedule and chunks")
    reader: ReaderConfig = param(_reader_defaults(), doc="reader (fm0-640k, one 890 MHz carrier, 2 MS/s)")
    tag: TagConfig = param(TagConfig(), doc="tag")
    estimator: EstimatorConfig = param(EstimatorConfig(), doc="EKF/RTS tuning")


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
    "intended_x_m": ("m", "intended (marked) path x at the round start, what the paper's RMSE refers to"),
    "intended_y_m": ("m", "intended (marked) path y at the round start"),
    "trial": ("1", "trial index of the run (one trajectory: 0)"),
}


def _read_task(task) -> dict[str, np.ndarray]:
    """Rounds [r_lo, r_hi) of chunk c (:func:`rfsim.scenes.phase_tracking.simulate_rounds`), ``task`` =
    (config, seed, c, r_lo, r_hi, probe); the probe (round 0 alone) also checks the slot."""
    config, seed, c, r_lo, r_hi, probe = task
    out = simulate_rounds(config.geometry, config.trajectory, config.reader, config.tag,
                          read_period_s=config.schedule.read_period_s, seed=seed, chunk=c, r_lo=r_lo, r_hi=r_hi)
    if probe:
        _check_slot(config, float(np.max(out["round_end_s"] - out["round_start_s"])))
    return out


def _check_slot(config: Config, singulation_s: float) -> None:
    if singulation_s > config.schedule.read_period_s:
        raise ConfigError("schedule.read_period_s", config.schedule.read_period_s,
                          f"a period ≥ one singulation ({singulation_s * 1e3:.3g} ms with reader.link_profile "
                          f"{config.reader.link_profile!r})")


def run(config: Config, *, seed: int) -> _rfsim_dataset.Dataset:
    """Simulate Särkkä et al.'s 890 MHz phase tracking with sample-level reads, then track the tag.

    Reproduces experiment 1 of Särkkä et al. 2012 (phase-tracking.md §2; seeds/001 L57,
    L174–L178, RMSEs L203–L207, Fig. 8): four corner antennas read the moving tag in turn
    on a fixed schedule; the reported phases are unwrapped to pseudo-ranges and tracked by
    the CWNA + bias EKF and the RTS smoother over ``estimator.passes`` passes, beside the
    RSSI-only fix of eq. (13).

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed (the streams of the module docstring).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``reads`` (one row per read round in the per-read schema, with the true
        position [m]), ``pseudoranges`` (per read: unwrapped pseudo-range, true range and
        their offset [m], unwrapping-jump flag), ``estimates`` (per read: the RSSI-only,
        EKF and RTS positions of every pass [m] beside the true and intended path) and
        ``summary`` (per estimator and pass: RMSE, mean, median, 90th percentile, max and
        std of the position error [m] beside the published RMSE); root attributes with the
        model matrices (F, L, Qc, A(Δt), W(Δt)), antenna positions, wavelength, unwrapping
        limit, read rate and the RMSEs.

    Raises
    ------
    rfsim.core.errors.ConfigError
        The scene does not fit (:func:`rfsim.scenes.phase_tracking.check_scene`), the reader
        hops over several carriers, or one singulation does not fit into
        ``schedule.read_period_s``.
    """
    check_scene(config.geometry, config.trajectory, read_period_s=config.schedule.read_period_s)
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
    v_radial = TagMotion(tr, rng=trial_rng(seed, 0)).max_radial_speed_mps(anchors)
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
    first = _phase_tracking.first_per_antenna(ant0, rssi, s)
    if np.isnan(first).any():
        raise ConfigError("geometry.antennas_xy_m", f"antenna {int(np.flatnonzero(np.isnan(first))[0]) + 1} reported "
                          "no read", "antennas that can read the tag (check range, power and pattern)")
    p0 = _phase_tracking.rssi_fix(first, anchors)[0]  # eq. (13) on the first RSSI of every antenna
    r0 = np.linalg.norm(p0 - anchors, axis=1)
    z = _phase_tracking.unwrap_pseudoranges(ant0, phase, wavelength_m=lam, r0_m=r0)
    true_range = np.linalg.norm(truth - anchors[ant0], axis=1)
    offset = z - true_range
    jump = _phase_tracking.unwrap_jumps(ant0, offset, wavelength_m=lam, n_antennas=s)
    x0, P0 = _phase_tracking.initial_state(p0, s, pos_std_m=est.pos_std_m, bias_std_m=est.bias_std_m, vel_std_mps=est.vel_std_mps)
    passes = _phase_tracking.track_phase(t, ant0, z, anchors, x0, P0, q_v=est.q_v, q_b=est.q_b, sigma_m=est.sigma_m,
                                         passes=est.passes, keep_covariances=False)
    latest = _phase_tracking.latest_per_antenna(ant0, rssi, s)
    rssi_track, _ = _phase_tracking.rssi_fix(latest, anchors)
    rssi_track[~np.all(np.isfinite(latest), axis=1)] = np.nan

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
        row = {"estimator": name, "pass": k, **_phase_tracking.error_stats(np.linalg.norm(xy - intended, axis=1)),
               "rmse_true_m": _phase_tracking.error_stats(np.linalg.norm(xy - truth, axis=1))["rmse_m"],
               "published_rmse_m": PUBLISHED_RMSE_M.get((name, k), np.nan)}
        for key, v in row.items():
            summary[key].append(v)
    return _dataset(config, reads, z, true_range, offset, jump, estimates, summary, anchors=anchors, lam=lam,
                    limit=limit, v_radial=v_radial, exceeded=exceeded, p0=p0, busy=busy)


def _dataset(config, reads, z, true_range, offset, jump, estimates, summary, *, anchors, lam, limit, v_radial,
             exceeded, p0, busy) -> _rfsim_dataset.Dataset:
    est, sch = config.estimator, config.schedule
    s = anchors.shape[0]
    ds = _rfsim_dataset.Dataset(title="Särkkä 890 MHz phase tracking: sample-level reads, pseudo-ranges, EKF/RTS tracks")
    ds.add_table("reads", reads_table(reads, READ_FIELDS, true_distance_m=true_range),  # the schema: rfsim.core.reads
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
        "first_pass_note": ("seed 1: RTS 1.48 cm is the injected jitter (0.016 cm against the true path); first pass "
                            "EKF/RTS 6.66/3.25 cm vs 3.2/1.5 cm: the start-fix transient (0.41 m off), docs page"),
    })
    if est.passes >= 2:
        ds.attrs["ekf2_rmse_m"] = rmse[("EKF", 2)]
    return ds


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Phase and pseudo-range vs time per antenna, true vs estimated tracks, error CDFs.

    Parameters
    ----------
    dataset_path : pathlib.Path
        A dataset written by :func:`run`.
    out_dir : pathlib.Path
        Folder of the figures.

    Returns
    -------
    list of pathlib.Path
        The written figure files.
    """
    from rfsim.scenarios._phase_figures import plot_all

    return plot_all(dataset_path, out_dir)

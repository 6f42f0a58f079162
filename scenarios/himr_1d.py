"""Scenario ``himr-1d``: 1-D hybrid inertial microwave reflectometry — a 6-axis HIMR tag on the
linear positioner moving away from one 5.8 GHz pylon, every packet at sample level, and the
1-D CARE observer against the raw RSS range and the double integration of the accelerometer
(himr-tag.md §1.5–1.8, §2.1, §3.1–3.2, §6.4; wave2-specs.md §H; seed 000 L411–L660).

Scene: one pylon (:mod:`rfsim.devices.himr_pylon`, monostatic, 9.5 dBi TX and RX, L632) at the
origin on 5.8 GHz; the tag (:class:`rfsim.devices.himr_tag.HimrTag`, ``6axis-1d``: 96-bit packets,
BOC 64 chips/bit at 5 Mcps = 78,125 b/s, ≈ 300 packets/s, L411; accelerometer words only) on
:class:`rfsim.core.trajectories.LinearTrapezoid` — from 1 m straight away from the pylon, ±7.35 m/s²
to 1.2 m/s, 355 ms cruise (L610; travel 0.622 m, erratum 9: ``preserve = "distance"`` gives the
printed 0.61 m), after ``t_start_s`` at rest. Transmit power calibrated to a per-sample SNR of
31.6 dB at 1 m (L646); the packets go through the air step and the per-packet DSP
(:mod:`rfsim.scenes.himr_air`). The R⁻⁴ law then gives 31.6 − 40·log10(1.62) = 23.2 dB at the
end, not the 29.4 dB the source measured (erratum 14, not reproduced).

Measurements per packet: [RSS range (eq. 22), phase-derived radial velocity (eq. 23; the
limit λ/(4Δt) = 3.877 m/s at 300 packets/s is far above 1.2 m/s), the accelerometer's y^B
reading (the body y axis points along the travel, heading 0)]. Estimators (``estimates``):

* ``himr``: the 1-D observer (eq. 20), L of (18) from W = 5·10⁴·diag(3, 1, 1), V = I₃ (L571),
  forward Euler at the packet epochs (T ≈ 1/300 s; stable above 193.6 packets/s), x̂₀ = the
  known start [1 m, 0, 0] (L616–L624);
* ``rss``: the RSS range alone;
* ``double-integration``: the accelerometer integrated twice from the known start (the
  source's Fig. 13, 2.5 cm drift over 0.6 m, L628).

The source's 1 mm (simulation, L640) and 9 mm peak (experiment, L652) are the targets for the
HIMR error; both are ≪ the drift of the double integration (qualitative, wave2-specs.md §H).
Measured (defaults, seed 1): HIMR max 4.6 mm, final 0.4 mm; RSS range alone max 4.4 mm;
double integration max 14.7 mm, 21.6 mm at the end. The RSS range carries a motion bias: the
round-trip phase turns 4π·v·T_air/λ = 0.36 rad during the 1.23 ms packet at 1.2 m/s, the
constant-gain fit of the packet loses 1 − sinc²(0.18) ≈ 1.1 % of the power, so the range reads
≈ 0.27 % (≈ 3 mm) long while cruising — and the observer, which weights the position channel
most (W), follows it; the receiver noise itself is far smaller at this SNR.

Randomness: ``trial_rng(seed, 0)`` the tag's schedule and IMU noise, ``trial_rng(seed, 1, k, 0)``
the receiver noise of packet k.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfsim.devices.himr_tag import HimrTag, HimrTagConfig
from rfsim.devices.imu import ImuConfig
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.progress import stage
from rfsim.core.references import cite
from rfsim.core.trajectories import LinearTrapezoid
from rfsim.core.units import wavelength_m
from rfsim.scenes.himr_air import RadioConfig, check_scene, simulate
from rfsim.core.lazy import lazy_import

_dataset = lazy_import("rfsim.core.dataset")
_himr_model = lazy_import("rfsim.estimators.himr_model")
_observer = lazy_import("rfsim.estimators.observer")
_himr_figures = lazy_import("rfsim.scenarios._himr_figures")
_himr_air = lazy_import("rfsim.scenes.himr_air")

NAME = "himr-1d"
DESCRIPTION = ("1-D HIMR: 6-axis tag on the linear positioner, one 5.8 GHz pylon at sample level, CARE observer "
               "vs raw RSS range and double integration")

ESTIMATORS = ("himr", "rss", "double-integration")
#: The source's numbers (L628, L640, L652) [m]: simulated and measured peak HIMR error, drift.
SOURCE_ERROR_M = {"himr": 0.001, "rss": float("nan"), "double-integration": 0.025}


@dataclass(frozen=True)
class SceneConfig:
    """The pylon and the test range of the 1-D run.

    Attributes
    ----------
    pylon_m : tuple of (float, float, float), default (0.0, 0.0, 0.0)
        Position of the pylon [m].
    carrier_hz : float, default 5.8e9
        Carrier of the pylon (L632) [Hz], in [1e8, 1e10].
    room_min_m : tuple of (float, float), default (-1.0, -1.0)
        Lower-left corner of the test range [m].
    room_max_m : tuple of (float, float), default (3.0, 1.0)
        Upper-right corner of the test range [m].
    duration_s : float, default 1.0
        Length of the run [s], in [0.05, 30].
    """

    pylon_m: tuple[float, float, float] = param((0.0, 0.0, 0.0), unit="m", doc="position of the pylon")
    carrier_hz: float = param(5.8e9, lo=1e8, hi=1e10, unit="Hz", doc="carrier of the pylon (L632)")
    room_min_m: tuple[float, float] = param((-1.0, -1.0), unit="m", doc="lower-left corner of the test range")
    room_max_m: tuple[float, float] = param((3.0, 1.0), unit="m", doc="upper-right corner of the test range")
    duration_s: float = param(1.0, lo=0.05, hi=30.0, unit="s", doc="length of the run")


@dataclass(frozen=True)
class Config:
    """Configuration of the ``himr-1d`` scenario.

    The tag must use the ``6axis-1d`` packet format; the run must last longer than the rest
    before the motion, and the pylon and the trajectory must fit the test range
    (:func:`rfsim.scenes.himr_air.check_scene`).

    Attributes
    ----------
    tag : HimrTagConfig
        The HIMR tag (packet format, rate, framing).
    imu : ImuConfig
        The tag's IMU.
    trajectory : LinearTrapezoid
        The positioner profile (L610).
    scene : SceneConfig
        Pylon and test range.
    radio : RadioConfig
        Pylon radio and DSP.
    """

    tag: HimrTagConfig = param(HimrTagConfig(packet_format="6axis-1d"), doc="the HIMR tag (packet format, rate, framing)")
    imu: ImuConfig = param(ImuConfig(), doc="the tag's IMU")
    trajectory: LinearTrapezoid = param(LinearTrapezoid(t_start_s=0.05), doc="the positioner profile (L610)")
    scene: SceneConfig = param(SceneConfig(), doc="pylon and test range")
    radio: RadioConfig = param(RadioConfig(fs_hz=20e6), doc="pylon radio and DSP")

    def __post_init__(self):
        if self.tag.packet_format != "6axis-1d":
            raise ConfigError("tag.packet_format", self.tag.packet_format, "'6axis-1d' (the 1-D tag)")
        sc = self.scene
        if sc.duration_s <= self.trajectory.t_start_s:
            raise ConfigError("scene.duration_s", sc.duration_s,
                              f"longer than the rest before the motion ({self.trajectory.t_start_s} s)")
        tag = HimrTag(self.tag, self.trajectory, self.imu)
        check_scene(self.radio, tag, [sc.pylon_m], [sc.carrier_hz], t_end_s=sc.duration_s, room_min_m=sc.room_min_m,
                    room_max_m=sc.room_max_m, key="scene.pylon_m")


def estimate(t_s, y, z0_m: float) -> dict:
    """The three estimators of the module docstring: ``{name: (n, 3) [z ż z̈]}``.

    Parameters
    ----------
    t_s : array_like, shape (n,)
        Epochs: the scheduled packet starts [s].
    y : ndarray, shape (n, 3)
        Measurements per epoch: RSS range [m] (eq. 22), phase-derived radial velocity [m/s]
        (eq. 23) and accelerometer reading along the travel [m/s²]; NaN where missing.
    z0_m : float
        Known start distance to the pylon [m].

    Returns
    -------
    dict of str to ndarray, shape (n, 3)
        Per estimator (``"himr"``: the 1-D observer of eq. 20,
        :func:`rfsim.estimators.observer.observe_1d`; ``"rss"``: the measurements as they
        are; ``"double-integration"``: the accelerometer, gaps interpolated, integrated twice
        by the trapezoidal rule from ``[z0_m, 0]``) the states [z, ż, z̈]
        [m, m/s, m/s²].
    """
    t = np.asarray(t_s, float)
    x0 = np.array([z0_m, 0.0, 0.0])
    ok = ~np.isnan(y[:, 2])
    a = np.interp(t, t[ok], y[ok, 2]) if ok.any() else np.zeros_like(t)
    dt = np.diff(t)
    v = np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * dt)])
    z = z0_m + np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    return {"himr": _observer.observe_1d(t, y, x0=x0),
            "rss": np.column_stack([y[:, 0], y[:, 1], y[:, 2]]),
            "double-integration": np.column_stack([z, v, a])}


def _add_estimates(ds, est: dict, t, z, moving) -> list[tuple]:
    """The ``estimates`` table; per estimator (name, max, final, RMS error, the source's error)."""
    rows = {"estimator": [], "t_s": [], "z_hat_m": [], "z_dot_hat_mps": [], "z_ddot_hat_mps2": [], "error_m": []}
    summary = []
    for name in ESTIMATORS:
        e = est[name]
        err = e[:, 0] - z
        rows["estimator"].append(np.full(t.size, name))
        rows["t_s"].append(t)
        rows["z_hat_m"].append(e[:, 0])
        rows["z_dot_hat_mps"].append(e[:, 1])
        rows["z_ddot_hat_mps2"].append(e[:, 2])
        rows["error_m"].append(err)
        a = np.abs(err[moving & ~np.isnan(err)])
        summary.append((name, float(a.max()) if a.size else float("nan"), float(np.abs(err[-1])),
                        float(np.sqrt(np.nanmean(err[moving] ** 2))), SOURCE_ERROR_M[name]))
    rows = {k: np.concatenate(v) for k, v in rows.items()}
    ds.add_table("estimates", {
        "estimator": _dataset.column(rows["estimator"], "1", "himr observer, raw rss range or double integration"),
        "t_s": _dataset.column(rows["t_s"], "s", "epoch of the estimate"),
        "z_hat_m": _dataset.column(rows["z_hat_m"], "m", "estimated distance to the pylon"),
        "z_dot_hat_mps": _dataset.column(rows["z_dot_hat_mps"], "m/s", "estimated radial velocity"),
        "z_ddot_hat_mps2": _dataset.column(rows["z_ddot_hat_mps2"], "m/s^2",
                                           "estimated acceleration along the travel (third state)"),
        "error_m": _dataset.column(rows["error_m"], "m", "estimated minus true distance")},
        description="one row per (estimator, epoch): the estimate and its error")
    return summary


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate the 1-D HIMR run and compare the observer with the RSS range and double integration.

    The tag moves away from the pylon on the linear positioner; every packet goes through the
    air step and the pylon's DSP at sample level, and the three estimators of
    :func:`estimate` run on the decoded measurements (himr-tag.md §1.5–1.8, §2.1, §3.1–3.2;
    the source's Sec. 2.5–2.7, Figs. 12–16; seed 000 L411–L660).

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed: ``trial_rng(seed, 0)`` for the tag's schedule and IMU noise,
        ``trial_rng(seed, 1, k, 0)`` for the receiver noise of packet k.

    Returns
    -------
    rfsim.core.dataset.Dataset
        The per-packet tables of the air run (``packets``, the IMU words; see
        :func:`rfsim.scenes.himr_air.add_run_tables`); ``measurements`` (per epoch: RSS
        range, radial velocity, acceleration with validity flags), ``truth`` (true
        z, ż, z̈), ``estimates`` (per estimator and epoch: estimate and
        distance error [m]), ``summary`` (per estimator: max, final and RMS error beside the
        source's numbers [m]), the grid ``gains`` (observer gain L and the eigenvalues of
        A − LC) and ``diagnostics`` (Euler step [s] and its spectral radius); root attributes
        with the errors, travel, packet size, SNR at the end, aliasing limit, CRC-ok fraction
        and the source citation.
    """
    sc = config.scene
    tag = HimrTag(config.tag, config.trajectory, config.imu)
    stage(f"sample level: {config.tag.format.n_bits}-bit packets at {config.radio.fs_hz / 1e6:g} MS/s")
    air = simulate(tag, [sc.pylon_m[:2]], [sc.carrier_hz], config.radio, seed=seed, t_end_s=sc.duration_s,
                   height_m=sc.pylon_m[2])
    plan = tag.current_plan
    stage("observer")
    tick = time.perf_counter()
    imu = _himr_air.imu_table(air, plan, config.imu, heading_start_rad=0.0)
    m, idx = air.measurements[0], air.packet_index[0]
    n = plan.start_s.size
    y = np.full((n, 3), np.nan)
    ok = m.crc_ok
    y[idx[ok], 0] = m.range_m[ok]
    y[idx[ok], 1] = m.radial_velocity_mps[ok]
    y[:, 2] = imu["accel_y"]
    t = plan.start_s
    direction = np.asarray(config.trajectory.direction, float)
    kin = config.trajectory(t)
    rel = kin.position_m - np.asarray(sc.pylon_m, float)
    z = np.linalg.norm(rel, axis=1)
    u = rel / z[:, None]
    zd = np.sum(kin.velocity_mps * u, axis=1)
    zdd = kin.acceleration_mps2 @ (direction / np.linalg.norm(direction))
    est = estimate(t, y, float(z[0]))
    observer_s = time.perf_counter() - tick
    moving = t <= config.trajectory.duration_s

    ds = _dataset.Dataset(title="1-D HIMR: linear positioner, one pylon at sample level, CARE observer vs RSS and double "
                       "integration")
    _himr_air.add_run_tables(ds, air, plan, imu, packets="one row per packet decoded at the pylon: CRC, complex gain, RSS, "
                             "phase, radial velocity (eq. 23), RSS range (eq. 22), aliasing flag, ground truth",
                             imu_description="one row per scheduled packet: the accelerometer words it carried (raw int16 "
                                             "and SI) as decoded by the pylon")
    ds.add_table("measurements", {
        "t_s": _dataset.column(t, "s", "epoch: scheduled start of the packet (observer time step)"),
        "range_m": _dataset.column(y[:, 0], "m", "RSS range r = (K_u/|h|^2)^(1/4), eq. 22 (NaN: packet lost)"),
        "radial_velocity_mps": _dataset.column(y[:, 1], "m/s", "phase-derived radial velocity, eq. 23 (NaN: lost or first)"),
        "accel_mps2": _dataset.column(y[:, 2], "m/s^2", "accelerometer reading along the travel (body y axis)"),
        "valid_range": _dataset.column(~np.isnan(y[:, 0]), "1", "the RSS range was measured at this epoch"),
        "valid_radial_velocity": _dataset.column(~np.isnan(y[:, 1]), "1", "the radial velocity was measured at this epoch"),
        "valid_accel": _dataset.column(~np.isnan(y[:, 2]), "1", "the accelerometer word arrived at this epoch")},
        description="one row per epoch: the observer's outputs [range, radial velocity, acceleration] with flags")
    ds.add_table("truth", {"t_s": _dataset.column(t, "s", "epoch (scheduled packet start)"),
                           "z_m": _dataset.column(z, "m", "true distance pylon - tag"),
                           "z_dot_mps": _dataset.column(zd, "m/s", "true radial velocity"),
                           "z_ddot_mps2": _dataset.column(zdd, "m/s^2", "true acceleration along the travel")},
                 description="one row per epoch: the true state [z z_dot z_ddot] of the 1-D model")
    summary = _add_estimates(ds, est, t, z, moving)
    ds.add_table("summary", {
        "estimator": _dataset.column(np.array([s[0] for s in summary]), "1", "estimator of the row"),
        "max_error_m": _dataset.column(np.array([s[1] for s in summary]), "m", "largest |distance error| until the motion ends"),
        "final_error_m": _dataset.column(np.array([s[2] for s in summary]), "m", "|distance error| at the last epoch"),
        "rms_error_m": _dataset.column(np.array([s[3] for s in summary]), "m", "RMS distance error until the motion ends"),
        "source_error_m": _dataset.column(np.array([s[4] for s in summary]), "m", "the source's figure: HIMR 1 mm (simulation, "
                                                                          "L640), drift 2.5 cm (L628); NaN: none")},
        description="one row per estimator: max, final and RMS error beside the source's numbers")
    g = _observer.gain_1d()
    names = ("z", "z_dot", "z_ddot")
    outs = ("range", "radial_velocity", "accel")
    ds.add_grid("gains", {"state": _dataset.column(np.array(names), "1", "state of the 1-D model (row of L)"),
                          "output": _dataset.column(np.array(outs), "1", "measured output (column of L)"),
                          "mode": _dataset.column(np.arange(1, 4), "1", "index of the eigenvalue of A - L C, by real part")},
                {"L": _dataset.column(g.L, "1", "CARE gain L = Y C' inv(V), W = 5e4 diag(3, 1, 1), V = I3 (eq. 17-18)",
                                      dims=("state", "output")),
                 "eig_real": _dataset.column(g.eigenvalues.real, "1/s", "real part of eig(A - L C), eq. 19", dims=("mode",)),
                 "eig_imag": _dataset.column(g.eigenvalues.imag, "1/s", "imaginary part of eig(A - L C), eq. 19",
                                             dims=("mode",))},
                description="the 1-D observer gain L[state, output] and the eigenvalues of its error matrix")
    T = np.append(np.diff(t), np.diff(t)[-1:])
    rho = np.array([np.abs(np.linalg.eigvals(np.eye(3) + Tk * (_himr_model.A3 - g.L))).max() for Tk in T])
    ds.add_table("diagnostics", {
        "t_s": _dataset.column(t, "s", "epoch: scheduled start of the packet"),
        "step_s": _dataset.column(T, "s", "Euler step T of the epoch (packet interval)"),
        "max_real_eig": _dataset.column(np.full(n, g.eigenvalues.real.max()), "1/s",
                                        "largest real part of eig(A - L C) (constant: the 1-D model is linear)"),
        "euler_spectral_radius": _dataset.column(rho, "1", "spectral radius of I + T (A - L C): the Euler step is stable "
                                                  "below 1")},
        description="one row per epoch: eigenvalues of the error dynamics and the stability of its Euler step")
    a = ds.attrs
    for s in summary:
        key = s[0].replace("-", "_")
        a[f"max_error_m_{key}"], a[f"final_error_m_{key}"] = s[1], s[2]
    a["travel_m"] = config.trajectory.travel_m
    a["packet_bits"] = config.tag.format.n_bits
    a["air_time_s"] = config.tag.air_time_s
    a.update(air.run_attrs(n), observers_s=observer_s)
    a["k_u_w_m4"] = float(air.k_u[0])
    a["snr_db_end"] = float(np.median(m.snr_db[-5:]))
    a["aliasing_limit_mps"] = float(wavelength_m(sc.carrier_hz) * (1 / config.tag.period_s) / 4)
    a["crc_ok_fraction"] = float(np.mean(m.crc_ok))
    a["source"] = cite("himr", "Sec. 2.5-2.7, Figs. 12-16")
    return ds


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """True vs estimated distance, error vs time per estimator, RSS and radial velocity, stability of the
    Euler step (:mod:`rfsim.scenarios._himr_figures`).

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
    return _himr_figures.plot_1d(Path(dataset_path), Path(out_dir), ESTIMATORS)


__all__ = ["NAME", "DESCRIPTION", "Config", "SceneConfig", "run", "plot", "estimate", "ESTIMATORS"]

"""Scenario ``himr-2d``: 2-D hybrid inertial microwave reflectometry — a 9-axis HIMR tag on the
rotating boom, three pylons at 5.79/5.80/5.81 GHz, every packet at sample level, and the
fixed-gain observers of the source with its seven analysis cases (himr-tag.md §1.9–1.12, §3.3–3.5,
§4.3, §5, §6; wave2-specs.md §H; seed 000 Ch. IV, L993–L1404).

Scene: the tag (:class:`rfsim.devices.himr_tag.HimrTag`, ``9axis-2d``: 192-bit packets, BOC 8 chips/bit
at 4 Mcps, 141 packets/s, IMU words of :mod:`rfsim.devices.imu`) on the boom
(:class:`rfsim.core.trajectories.RotatingBoom`: R = 0.31 m, one counter-clockwise 2π stroke in
0.5/0.2/0.5 s from (2, 1.8048) m heading π; ``lag_s`` 0.15 s by default, the actual trajectory
the source compares with, L1014–L1020); pylons (:mod:`rfsim.devices.himr_pylon`) at Table 7's
(−0.1, 1.5), (2, 3.05), (2.7, −0.03) m (L1006–L1008) on 5.79, 5.80, 5.81 GHz (L997; the
per-pylon mapping is not stated). The packets go through the air step and the per-packet DSP
(:mod:`rfsim.scenes.himr_air`, :mod:`rfsim.himr.dsp`).

Measurement stream (:func:`rfsim.estimators.himr_cases.measurement_stream`, one epoch per
scheduled packet, [r₁ ṙ₁ r₂ ṙ₂ r₃ ṙ₃ a₁ a₂ θ_z ω_z], errata 1–3): NaN where a pylon's copy failed
its CRC; the IMU words from the first pylon that decoded the packet (L783). The radial velocity is phase-derived and aliases above λ/(4Δt) (1.822 m/s at
141 packets/s; the boom reaches 2.78 m/s; ``packets.aliased``). ``observer.dealias``
(:func:`rfsim.estimators.himr_cases.observe_case`): ``"gated"`` (default) wraps the
radial-velocity innovations while every range innovation is below ``gate_m`` — the aliasing
"calibrated out using the other sensors" (L779); ``"innovation"`` always wraps (it can lock onto
a wrong alias after an outage — measured: Cases 2, 4, 5 end 14 cm off); ``"none"``; ``"oracle"``.

Observers (:mod:`rfsim.estimators.observer`): the CARE gain at the Table 8 point
(``tuning`` D.2 = diag(579, 137, 149, 479, 127, 119, 191, 67, 67) or D.1 = 965·I₉, V = I₁₀),
forward Euler at the packet epochs from IC #1–#3 of Table 9; variants ``literal`` (the seed's
estimator), ``prerotated`` (accelerations rotated into the fixed frame with the measured
heading) and ``ekf``. Cases 1–7 (:mod:`rfsim.estimators.himr_cases`) post-process the recorded
stream; Case 6 re-derives the radial velocities from every other packet (limit 0.911 m/s).

What the literal observer gives (the source reports a ≈ 10 cm initial x error, Case 1,
L1176–L1224): its frozen error dynamics A − L·C(x(t)) are unstable while the heading is more
than 90° from the linearisation value π (cos ψ in the acceleration rows flips sign, 0.42–0.78 s
of the programmed stroke, 0.57–0.93 s of the actual one; ``diagnostics``). Run with the aliases
picked from ground truth (``dealias = "oracle"``, always added for the literal variant) its
transient reaches 1.53 m in x and 1.04 m in y (seed 1) and converges once the heading is back
near π (final 4.6 mm) — himr-tag.md §6.3 [derived]: ≈ 1.5–1.6 m, ≈ 1.1 m. With the measured,
aliased velocities the metre-size transient leaves the region where a wrapped velocity can be
resolved and it diverges (``max_error_m_literal`` ≈ 1.4 km). The ``prerotated`` variant gives
the source's magnitudes: max 1.8 cm, final 1.1 mm (seed 1); the ``ekf`` 0.85 cm, 1.0 mm.

Measured with the defaults, seed 1 (max y error while moving, prerotated): Case 2 55 cm, Case 3
20 cm, Case 4 11 cm, Case 5 58 cm (source: 50, 30, 5 cm, "similar to Case 2"), every case back
within 2 mm at the end; error above ``observer.converged_m`` (5 mm, docs page) until 1.16 s (Case 1),
1.35 s (Case 6), 1.29 s (Case 7) from each IC of Table 9 (source: 0.8, 1.2, 1.1 s, "within 2 cm").

Cross-carrier terms (``radio.cross_carrier``): by default each pylon runs alone ("ignore"; at
16 MS/s the other carriers, 10–20 MHz away, would be dropped by the air step anyway). A
``joint`` run at 50 MS/s with the 3 MHz channel filter (seed 1) shows the harmonic bias the
tag's square wave puts on the subcarrier: RSS-range error 17 mm RMS instead of 1.9 mm, the
prerotated observer's max/final error 3.1 cm / 3.8 mm instead of 2.0 cm / 0.4 mm.

Randomness: ``trial_rng(seed, 0)`` the tag's schedule and IMU noise, ``trial_rng(seed, 1, k, u)``
the receiver noise of packet k at pylon u (``joint``: u = 0 for the step of all pylons).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.devices.himr_tag import HimrTag, HimrTagConfig
from rfsim.himr.packet import PACKET_BITS_NOTE
from rfsim.devices.himr_pylon import HIMR_CARRIERS_HZ
from rfsim.devices.imu import ImuConfig
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.estimators.himr_cases import (CASES, SOURCE_CONVERGENCE_S, SOURCE_MAX_ERROR_M, measurement_stream,
                                         observe_case)
from rfsim.estimators.himr_model import INITIAL_CONDITIONS, PYLONS_M, STATE_NAMES, initial_state, output_names
from rfsim.estimators.observer import VARIANTS, W_D1, W_D2, eig_along, gain_2d, ranks_along, unstable_intervals
from rfsim.core.progress import stage
from rfsim.core.references import cite
from rfsim.core.trajectories import RotatingBoom
from rfsim.scenes.himr_air import RadioConfig, check_scene, simulate
from rfsim.core.lazy import lazy_import

_dataset = lazy_import("rfsim.core.dataset")
_himr_figures = lazy_import("rfsim.scenarios._himr_figures")
_himr_air = lazy_import("rfsim.scenes.himr_air")

NAME = "himr-2d"
DESCRIPTION = ("2-D HIMR: 9-axis tag on the rotating boom, 3 pylons at 5.79/5.80/5.81 GHz at sample level, "
               "literal/prerotated/EKF observers and the seven outage cases")

@dataclass(frozen=True)
class SceneConfig:
    """The three pylons and the room of the 2-D run.

    Attributes
    ----------
    pylons_m : tuple of (float, float), default ((-0.1, 1.5), (2.0, 3.05), (2.7, -0.03))
        Pylon positions (Table 7, L1006-L1008) [m].
    carriers_hz : tuple of float, default (5.79e9, 5.8e9, 5.81e9)
        Carrier of each pylon (L997) [Hz].
    room_min_m : tuple of (float, float), default (-0.5, -0.5)
        Lower-left corner of the room [m].
    room_max_m : tuple of (float, float), default (4.5, 3.5)
        Upper-right corner of the room [m].
    duration_s : float, default 1.6
        Length of the run [s], in [0.05, 30].
    """

    pylons_m: tuple[tuple[float, float], ...] = param(tuple(map(tuple, PYLONS_M.tolist())), unit="m",
                                                      doc="pylon positions (Table 7, L1006-L1008)")
    carriers_hz: tuple[float, ...] = param(HIMR_CARRIERS_HZ, unit="Hz", doc="carrier of each pylon (L997)")
    room_min_m: tuple[float, float] = param((-0.5, -0.5), unit="m", doc="lower-left corner of the room")
    room_max_m: tuple[float, float] = param((4.5, 3.5), unit="m", doc="upper-right corner of the room")
    duration_s: float = param(1.6, lo=0.05, hi=30.0, unit="s", doc="length of the run")


@dataclass(frozen=True)
class ObserverConfig:
    """The observers, their tuning and initial condition, and the analysis cases.

    Attributes
    ----------
    tuning : {"D.2", "D.1"}, default "D.2"
        W of the CARE: D.2 diag(579..67) (Cases 1-6) or D.1 965 I.
    initial_condition : {1, 2, 3}, default 1
        IC of Table 9 (L1196-L1206).
    variants : tuple of str, default ("literal", "prerotated", "ekf")
        Observer variants: literal, prerotated, ekf.
    cases : tuple of int, default (1, 2, 3, 4, 5, 6, 7)
        Analysis cases 1-7 (run with the prerotated variant).
    outage_s : tuple of (float, float), default (0.39, 0.75)
        Outage window of Cases 2-5 (L1243) [s].
    dealias : {"gated", "innovation", "none", "oracle"}, default "gated"
        Radial-velocity aliasing: 'innovation' wraps the innovation into +-lambda/(4
        dt); 'gated' does so only while every RSS-range innovation is below gate_m (else
        the measured value as is); 'none' uses the wrapped values as measured; 'oracle'
        takes the alias nearest the true velocity (ground truth: the bound a perfect
        dealiasing reaches).
    gate_m : float, default 0.05
        Range-innovation gate of dealias = 'gated' [m], in (0, ∞).
    converged_m : float, default 0.005
        Converged below this error (docs page) [m], in (0, ∞).
    """

    tuning: Literal["D.2", "D.1"] = param("D.2", doc="W of the CARE: D.2 diag(579..67) (Cases 1-6) or D.1 965 I")
    initial_condition: Literal[1, 2, 3] = param(1, doc="IC of Table 9 (L1196-L1206)")
    variants: tuple[str, ...] = param(VARIANTS, doc="observer variants: literal, prerotated, ekf")
    cases: tuple[int, ...] = param(tuple(CASES), doc="analysis cases 1-7 (run with the prerotated variant)")
    outage_s: tuple[float, float] = param((0.39, 0.75), unit="s", doc="outage window of Cases 2-5 (L1243)")
    dealias: Literal["gated", "innovation", "none", "oracle"] = param(
        "gated", doc="radial-velocity aliasing: 'innovation' wraps the innovation into +-lambda/(4 dt); 'gated' "
                     "does so only while every RSS-range innovation is below gate_m (else the measured value as "
                     "is); 'none' uses the wrapped values as measured; 'oracle' takes the alias nearest the true "
                     "velocity (ground truth: the bound a perfect dealiasing reaches)")
    gate_m: float = param(0.05, lo=0.0, lo_open=True, unit="m", doc="range-innovation gate of dealias = 'gated'")
    converged_m: float = param(0.005, lo=0.0, lo_open=True, unit="m", doc="converged below this error (docs page)")


@dataclass(frozen=True)
class Config:
    """Configuration of the ``himr-2d`` scenario.

    Checked on construction: three distinct pylons with one carrier each, the ``9axis-2d``
    packet format, known variants and cases (case 1 included), an outage window inside the
    run, and a scene that fits the room (:func:`rfsim.scenes.himr_air.check_scene`).

    Attributes
    ----------
    tag : rfsim.devices.himr_tag.HimrTagConfig
        The HIMR tag (packet format, rate, framing).
    imu : rfsim.devices.imu.ImuConfig
        The tag's IMU.
    trajectory : rfsim.core.trajectories.RotatingBoom
        The boom (actual trajectory: 150 ms lag).
    scene : SceneConfig
        Pylons and room.
    radio : rfsim.scenes.himr_air.RadioConfig
        Pylon radios and DSP.
    observer : ObserverConfig
        Observers and cases.
    """

    tag: HimrTagConfig = param(HimrTagConfig(packet_format="9axis-2d"), doc="the HIMR tag (packet format, rate, framing)")
    imu: ImuConfig = param(ImuConfig(), doc="the tag's IMU")
    trajectory: RotatingBoom = param(RotatingBoom(lag_s=0.15), doc="the boom (actual trajectory: 150 ms lag)")
    scene: SceneConfig = param(SceneConfig(), doc="pylons and room")
    radio: RadioConfig = param(RadioConfig(), doc="pylon radios and DSP")
    observer: ObserverConfig = param(ObserverConfig(), doc="observers and cases")

    def __post_init__(self):
        sc = self.scene
        if len(sc.pylons_m) != 3:
            raise ConfigError("scene.pylons_m", sc.pylons_m, "three (x, y) positions (the 2-D model has 3 pylons)")
        if len(sc.carriers_hz) != len(sc.pylons_m):
            raise ConfigError("scene.carriers_hz", sc.carriers_hz, "one carrier per pylon")
        check_distinct_pylons(sc.pylons_m)
        if self.tag.packet_format != "9axis-2d":
            raise ConfigError("tag.packet_format", self.tag.packet_format, "'9axis-2d' (the 2-D tag carries gyro and compass words)")
        for v in self.observer.variants:
            if v not in VARIANTS:
                raise ConfigError("observer.variants", v, "one of " + ", ".join(map(repr, VARIANTS)))
        for c in self.observer.cases:
            if c not in CASES:
                raise ConfigError("observer.cases", c, f"cases in {sorted(CASES)}")
        if 1 not in self.observer.cases:
            raise ConfigError("observer.cases", self.observer.cases, "a list that includes case 1")
        lo, hi = self.observer.outage_s
        if not 0 < lo < hi < sc.duration_s:
            raise ConfigError("observer.outage_s", self.observer.outage_s, f"0 < start < end < {sc.duration_s} s")
        check_scene(self.radio, HimrTag(self.tag, self.trajectory, self.imu),
                    [(x, y, self.trajectory.height_m) for x, y in sc.pylons_m], sc.carriers_hz, t_end_s=sc.duration_s,
                    room_min_m=sc.room_min_m, room_max_m=sc.room_max_m, key="scene.pylons_m")


#: closest two pylons may be [m]: the observer's gain needs range geometry from distinct pylons
MIN_PYLON_SEPARATION_M = 0.05


def check_distinct_pylons(pylons_m) -> None:
    """Every two pylons at least :data:`MIN_PYLON_SEPARATION_M` apart: two pylons at one point
    give the range outputs of a case without the third pylon one direction, and the filter CARE
    of its gain has no finite solution.

    Parameters
    ----------
    pylons_m : sequence of (float, float)
        Pylon positions (x, y) [m].

    Raises
    ------
    rfsim.core.errors.ConfigError
        Two pylons closer than :data:`MIN_PYLON_SEPARATION_M`; names ``scene.pylons_m[j]``.
    """
    for j, q in enumerate(pylons_m):
        for i, p in enumerate(pylons_m[:j]):
            if math.dist(p, q) < MIN_PYLON_SEPARATION_M:
                raise ConfigError(f"scene.pylons_m[{j}]", list(q), f"a position ≥ {MIN_PYLON_SEPARATION_M} m from "
                                  f"pylon {i} at {list(p)} (two pylons at one point leave the observer's gain "
                                  "without a solution)")


def run_observers(config: Config, run, plan, imu: dict, fc_hz) -> tuple[list, list]:
    """Every (variant, case) run: a list of estimate tables and a list of summary rows.

    The variants of ``observer.variants`` run on Case 1; Cases 2–7 with the prerotated variant;
    the literal variant once more with ``dealias = "oracle"`` when it is asked for with another
    dealiasing (:func:`rfsim.estimators.himr_cases.observe_case`).

    Parameters
    ----------
    config : Config
        Scenario configuration (``observer``, ``scene.pylons_m``, ``trajectory``).
    run : rfsim.scenes.himr_air.AirRun
        The sample-level air run of :func:`sample_level`.
    plan : rfsim.devices.himr_tag.HimrPlan
        The tag's packet schedule.
    imu : dict
        The IMU table of the run (:func:`rfsim.scenes.himr_air.imu_table`).
    fc_hz : sequence of float
        Carrier of each pylon [Hz].

    Returns
    -------
    estimates : list of dict of str to ndarray
        Per run, columns over its epochs: variant, case, dealias, ``t_s`` [s], the nine
        estimated states ``<state>_hat`` and the errors ``error_x_m``, ``error_y_m`` [m],
        ``error_psi_rad`` [rad], ``error_m`` [m].
    summary : list of dict
        Per run: max (while moving), max x, max y and final error [m], convergence time [s]
        (last epoch above ``observer.converged_m``), and the source's numbers for the case.
    """
    ob = config.observer
    W, pyl, x0 = (W_D2 if ob.tuning == "D.2" else W_D1), np.asarray(config.scene.pylons_m, float), initial_state(ob.initial_condition)
    motion_end = config.trajectory.duration_s
    streams = {1: measurement_stream(run, plan, imu), 6: measurement_stream(run, plan, imu, every=2)}
    runs = [(v, 1, ob.dealias) for v in ob.variants] + [("prerotated", c, ob.dealias) for c in ob.cases if c != 1]
    if "literal" in ob.variants and ob.dealias != "oracle":
        runs.append(("literal", 1, "oracle"))  # what the literal observer gives without aliasing
    estimates, summary = [], []
    for variant, case, dealias in runs:
        cs, est = observe_case(variant, case, dealias, streams, x0=x0, W=W, pylons_m=pyl, fc_hz=fc_hz,
                               outage_s=ob.outage_s, gate_m=ob.gate_m)
        truth = config.trajectory(cs.t_s).state_2d()
        dx, dy, moving = est[:, 0] - truth[:, 0], est[:, 3] - truth[:, 3], cs.t_s <= motion_end
        ex, ey, e = np.abs(dx), np.abs(dy), np.hypot(dx, dy)
        above = np.nonzero(e > ob.converged_m)[0]
        conv = float(cs.t_s[above[-1]]) if above.size else 0.0
        n = cs.t_s.size
        estimates.append({"variant": np.full(n, variant), "case": np.full(n, case), "dealias": np.full(n, dealias),
                          "t_s": cs.t_s, **{f"{s}_hat": est[:, i] for i, s in enumerate(STATE_NAMES)},
                          "error_x_m": dx, "error_y_m": dy,
                          "error_psi_rad": est[:, 6] - truth[:, 6], "error_m": e})
        sx, sy = SOURCE_MAX_ERROR_M[case]
        summary.append({"variant": variant, "case": case, "dealias": dealias, "case_name": CASES[case],
                        "max_error_m": float(e[moving].max()), "max_error_x_m": float(ex[moving].max()),
                        "max_error_y_m": float(ey[moving].max()), "final_error_m": float(e[-1]),
                        "convergence_s": conv, "source_max_error_x_m": sx, "source_max_error_y_m": sy,
                        "source_convergence_s": SOURCE_CONVERGENCE_S[case]})
    return estimates, summary


# ----------------------------------------------------------------------------- run


def sample_level(config: Config, *, seed: int):
    """The packets through the air and the DSP: ``(AirRun, the tag's plan, imu table)``.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed: ``trial_rng(seed, 0)`` for the tag, ``trial_rng(seed, 1, k, u)`` for the
        receiver noise of packet k at pylon u.

    Returns
    -------
    air : rfsim.scenes.himr_air.AirRun
        Every packet through the air step and each pylon's DSP.
    plan : rfsim.devices.himr_tag.HimrPlan
        The tag's packet schedule.
    imu : dict
        The IMU words of each packet, from the first pylon with a good CRC
        (:func:`rfsim.scenes.himr_air.imu_table`).
    """
    tag, sc = HimrTag(config.tag, config.trajectory, config.imu), config.scene
    stage(f"sample level: {config.tag.format.n_bits}-bit packets at {config.radio.fs_hz / 1e6:g} MS/s, "
          f"{len(sc.pylons_m)} pylons")
    air = simulate(tag, sc.pylons_m, sc.carriers_hz, config.radio, seed=seed, t_end_s=sc.duration_s,
                   height_m=config.trajectory.height_m)
    plan = tag.current_plan
    imu = _himr_air.imu_table(air, plan, config.imu, heading_start_rad=float(config.trajectory(0.0).heading_rad[0]))
    return air, plan, imu


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate the 2-D HIMR run: the boom tag, three pylons at sample level, observers and cases.

    Reproduces the source's 2-D study (himr-tag.md §1.9–1.12, §3.3–3.5, §4.3, §5, §6; seed 000
    Ch. IV, Figs. 68–96, Tables 7–9): :func:`sample_level` then :func:`dataset`.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed (the streams of the module docstring).

    Returns
    -------
    rfsim.core.dataset.Dataset
        The dataset of :func:`dataset`.
    """
    return dataset(config, *sample_level(config, seed=seed))


def dataset(config: Config, air, plan, imu: dict) -> _dataset.Dataset:
    """Observers, cases, diagnostics and the tables of the dataset (module docstring).

    Parameters
    ----------
    config : Config
        Scenario configuration.
    air : rfsim.scenes.himr_air.AirRun
        The sample-level run of :func:`sample_level`.
    plan : rfsim.devices.himr_tag.HimrPlan
        The tag's packet schedule.
    imu : dict
        The IMU table of the run.

    Returns
    -------
    rfsim.core.dataset.Dataset
        The per-packet tables of the air run (:func:`rfsim.scenes.himr_air.add_run_tables`);
        ``measurements`` (per epoch: the ten outputs r₁ ṙ₁ r₂ ṙ₂ r₃ ṙ₃ a₁ a₂ θ_z ω_z with
        validity flags), ``truth`` (the true 9-state), ``estimates`` (per variant, case and
        epoch: the estimated states and the x, y, heading and Euclidean errors),
        ``summary`` (per run: max, final error [m] and convergence time [s] beside the
        source's numbers), the grid ``gains`` (CARE gain L at the Table 8 point and the
        eigenvalues of A − LC) and ``diagnostics`` (per epoch: largest real eigenvalue of the
        literal and prerotated error matrices [1/s], observability rank); root attributes
        with the Case 1 errors, the literal observer's unstable interval [s], CRC-ok and
        aliased fractions and the source citation.
    """
    sc = config.scene
    tick = time.perf_counter()
    stage("observers and cases")
    stream = measurement_stream(air, plan, imu)
    estimates, summary = run_observers(config, air, plan, imu, sc.carriers_hz)
    W, pyl = (W_D2 if config.observer.tuning == "D.2" else W_D1), np.asarray(sc.pylons_m, float)
    g = gain_2d(W, pylons_m=pyl)
    truth = config.trajectory(stream["t_s"]).state_2d()
    mr_lit = eig_along(truth, g.L, pylons_m=pyl).real.max(axis=1)
    g_pre = gain_2d(W, pylons_m=pyl, accel="prerotated")
    mr_pre = eig_along(truth, g_pre.L, pylons_m=pyl, accel="prerotated").real.max(axis=1)
    ranks = ranks_along(truth, pylons_m=pyl)
    observer_s = time.perf_counter() - tick

    ds = _dataset.Dataset(title="2-D HIMR: rotating-boom tag, three pylons at sample level, fixed-gain observers and cases")
    pk = _himr_air.add_run_tables(ds, air, plan, imu, packets="one row per packet decoded at one pylon: CRC, complex gain, "
                                  "RSS, phase, radial velocity (eq. 23), RSS range (eq. 22), aliasing flag, ground truth",
                                  imu_description="one row per scheduled packet: the IMU words it carried (raw int16 and SI) "
                                                  "as decoded by the first pylon with a good CRC")
    names, y = output_names(3), stream["y"]
    rdot = "phase-derived radial velocity to pylon {} (eq. 23, wrapped: aliased above the limit)"
    out_desc = {**{f"r{u}": ("m", f"RSS range to pylon {u} (eq. 22)") for u in "123"},
                **{f"r{u}_dot": ("m/s", rdot.format(u)) for u in "123"},
                "a1": ("m/s^2", "a1 = accelerometer y^B reading (body frame)"),
                "a2": ("m/s^2", "a2 = minus the accelerometer x^B reading"),
                "theta_z": ("rad", "compass heading theta_z of the body y axis"), "omega_z": ("rad/s", "gyroscope rate omega_z")}
    mcols = {"t_s": _dataset.column(stream["t_s"], "s", "epoch: scheduled start of the packet (observer time step)"),
             "packet": _dataset.column(stream["packet"], "1", "index of the packet in the tag's schedule")}
    for j, nm in enumerate(names):
        unit, desc = out_desc[nm]
        mcols[nm] = _dataset.column(y[:, j], unit, desc + " (NaN: not measured at this epoch)")
        mcols[f"valid_{nm}"] = _dataset.column(~np.isnan(y[:, j]), "1", f"{desc} was measured at this epoch")
    ds.add_table("measurements", mcols, description="one row per epoch: the observer's outputs "
                                                    "[r1 r1_dot r2 r2_dot r3 r3_dot a1 a2 theta_z omega_z] with "
                                                    "validity flags")
    tunits = ("m", "m/s", "m/s^2", "m", "m/s", "m/s^2", "rad", "rad/s", "rad/s^2")
    ds.add_table("truth", {"t_s": _dataset.column(stream["t_s"], "s", "epoch (scheduled packet start)"),
                           **{s: _dataset.column(truth[:, i], tunits[i], f"true state {s} of the 9-state model at the epoch")
                              for i, s in enumerate(STATE_NAMES)}},
                 description="one row per epoch: the true 9-state [x x_dot x_ddot y y_dot y_ddot psi psi_dot psi_ddot]")
    cat = {k: np.concatenate([e[k] for e in estimates]) for k in estimates[0]}
    ecols = {"variant": _dataset.column(cat["variant"], "1", "observer variant: literal, prerotated or ekf"),
             "dealias": _dataset.column(cat["dealias"], "1", "how the radial-velocity aliasing was treated (observer.dealias; "
                                                    "oracle: ground truth picks the alias)"),
             "case": _dataset.column(cat["case"], "1", "analysis case 1-7 of the source (L1050-L1072)"),
             "t_s": _dataset.column(cat["t_s"], "s", "epoch of the estimate")}
    for i, s in enumerate(STATE_NAMES):
        ecols[f"{s}_hat"] = _dataset.column(cat[f"{s}_hat"], tunits[i], f"estimated state {s} at the epoch")
    for k, u, d in (("error_x_m", "m", "estimated minus true x"), ("error_y_m", "m", "estimated minus true y"),
                    ("error_psi_rad", "rad", "estimated minus true heading psi"),
                    ("error_m", "m", "Euclidean position error of the estimate")):
        ecols[k] = _dataset.column(cat[k], u, d)
    ds.add_table("estimates", ecols, description="one row per (variant, case, epoch): the observer's estimate "
                                                 "and its error")
    sdesc = {"variant": ("1", "observer variant of the run: literal, prerotated or ekf"), "case": ("1", "analysis case 1-7"),
             "dealias": ("1", "radial-velocity aliasing treatment of the run (oracle: ground truth picks the alias)"),
             "case_name": ("1", "what the case does to the recorded stream"),
             "max_error_m": ("m", "largest Euclidean position error while the boom moves"),
             "max_error_x_m": ("m", "largest |x error| while the boom moves"), "max_error_y_m": ("m", "largest |y error| while "
                                                                                             "the boom moves"),
             "final_error_m": ("m", "Euclidean position error at the last epoch"),
             "convergence_s": ("s", "last epoch with a position error above observer.converged_m (docs page)"),
             "source_max_error_x_m": ("m", "max x error the source prints for the case (NaN: not printed)"),
             "source_max_error_y_m": ("m", "max y error the source prints for the case (NaN: not printed)"),
             "source_convergence_s": ("s", "convergence time the source states for the case (NaN: not stated)")}
    scols = {k: _dataset.column(np.array([r[k] for r in summary]), u, d) for k, (u, d) in sdesc.items()}
    ds.add_table("summary", scols, description="one row per (variant, case) run: max, final error and convergence "
                                               "beside the source's printed numbers")
    ds.add_grid("gains", {"state": _dataset.column(np.array(STATE_NAMES), "1", "state of the 9-state model (row of L)"),
                          "output": _dataset.column(np.array(names), "1", "output in observer order (column of L)"),
                          "mode": _dataset.column(np.arange(1, 10), "1", "index of the eigenvalue of A - L C, by real part")},
                {"L": _dataset.column(g.L, "1", f"CARE gain L = Y C' inv(V) at the Table 8 point, tuning "
                                       f"{config.observer.tuning}, V = I (the source prints L')",
                                      dims=("state", "output")),
                 **{f"eig_{k}": _dataset.column(getattr(g.eigenvalues, k), "1/s", f"{w} part of eig(A - L C) at the Table 8 "
                                                "point", dims=("mode",)) for k, w in (("real", "real"), ("imag", "imaginary"))}},
                description="the observer gain L[state, output] at the linearisation point and the eigenvalues of "
                            "its error matrix")
    ds.add_table("diagnostics", {
        "t_s": _dataset.column(stream["t_s"], "s", "epoch: scheduled start of the packet"),
        "max_real_eig_literal": _dataset.column(mr_lit, "1/s", "largest real part of eig(A - L C(x(t))) of the literal model "
                                                      "along the true trajectory (positive: locally unstable)"),
        "max_real_eig_prerotated": _dataset.column(mr_pre, "1/s", "the same with the prerotated accelerations (constant rows)"),
        "observability_rank": _dataset.column(ranks, "1", "rank of O = [C; CA; CA^2] at the true state (9: observable)")},
        description="one row per epoch: frozen-time eigenvalues and observability along the true trajectory (Fig. 82)")

    a = ds.attrs
    for r in summary:
        if r["case"] == 1:
            tail = "" if r["dealias"] == config.observer.dealias else f"_{r['dealias']}_dealias"
            a[f"max_error_m_{r['variant']}{tail}"] = r["max_error_m"]
            a[f"final_error_m_{r['variant']}{tail}"] = r["final_error_m"]
    win = unstable_intervals(stream["t_s"], mr_lit)
    a["literal_unstable_from_s"], a["literal_unstable_to_s"] = (win[0][0], win[-1][1]) if win else (math.nan, math.nan)
    for key in ("literal_unstable_from_s", "literal_unstable_to_s"):
        if not np.isfinite(a[key]):
            a[f"{key}_meaning"] = "NaN: the literal error matrix stays stable along this trajectory"
    a["literal_observer_note"] = (
        "the source reports a ~10 cm initial x error for Case 1 (L1176-L1224); the literal observer's frozen error "
        "matrix A - L C(x(t)) is unstable while the heading is > 90 deg from pi (literal_unstable_from_s..to_s), so "
        "its transient is max_error_m_literal (himr-tag.md 6.3 [derived]: ~1.5 m x, ~1.1 m y); the prerotated "
        "variant reaches the source's magnitudes")
    a["dealias"] = config.observer.dealias
    a["packet_bits"] = config.tag.format.n_bits
    a["packet_bits_note"] = PACKET_BITS_NOTE
    a["air_time_s"] = config.tag.air_time_s
    a.update(air.run_attrs(plan.start_s.size), observers_s=observer_s)
    a["dropped_contributions"] = air.dropped
    a["aliased_fraction"] = float(np.mean(pk["aliased"]))
    a["crc_ok_fraction"] = float(np.mean(pk["crc_ok"]))
    for u, k in enumerate(air.k_u):
        a[f"k_u_pylon{u + 1}_w_m4"] = float(k)
    a["source"] = cite("himr", "Ch. IV, Figs. 68-96, Tables 7-9")
    return ds


# ----------------------------------------------------------------------------- plot


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """True vs estimated track, error vs time per case and variant, RSS and radial velocity per pylon,
    eigenvalues along the trajectory (:mod:`rfsim.scenarios._himr_figures`).

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
    return _himr_figures.plot_2d(Path(dataset_path), Path(out_dir))


__all__ = ["NAME", "DESCRIPTION", "Config", "SceneConfig", "ObserverConfig", "run", "plot", "sample_level", "dataset",
           "measurement_stream", "run_observers", "INITIAL_CONDITIONS", "SOURCE_MAX_ERROR_M"]

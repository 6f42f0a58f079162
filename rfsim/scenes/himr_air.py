"""Sample-level HIMR packets through the air: a free-running HIMR tag on a trajectory, N
pylons (:mod:`rfsim.devices.himr_pylon`), one :func:`rfsim.air.step.propagate` step per packet and
pylon (``cross_carrier = "ignore"``) or per packet with every pylon (``"joint"``), and the
per-packet DSP of :mod:`rfsim.himr.dsp` on each pylon's input, and the run's per-packet and IMU
tables (wave2-specs.md §H "Datasets"). Used by the scenarios ``himr-1d`` and ``himr-2d``.

Physics per step (wave2-specs.md §H "Pylons", "Per-packet DSP"; himr-tag.md §1.1–1.3):

* time base: the packet's air time plus ``margin_s`` on both sides, at ``fs_hz`` (which must
  reach the BOC bandwidth 2·(f_sc + R_b) and at least 8·f_sc, wave2-specs.md §H);
* links: free space (Friis, no image paths) between antennas with isotropic patterns of the
  configured gains and vertical polarization (PLF 1); the tag antenna moves along the
  trajectory (``rfsim.channels.Channel`` with a motion callable: the geometry at the step's start,
  the Doppler shift over the step); monostatic round trip (a reciprocal link, one path both
  ways);
* the tag re-radiates r(t) = A_s − Γ(t) (:class:`rfsim.devices.himr_tag.HimrTag`); each pylon's
  input is its CW leakage, the backscatter and its thermal noise;
* ``"ignore"``: each pylon with only its own carrier — the others are 10–20 MHz away, outside
  ±fs/2 for fs < 20 MS/s, where the air step drops them; ``"joint"``: all pylons in one step,
  every carrier inside ±fs/2 enters every receiver (fs ≥ 50 MS/s: 20 MHz offsets inside), so
  the tag's square-wave harmonics mix the other carriers onto a pylon's subcarrier
  (wave2-specs.md §H: the 9th/11th harmonics of an ideal 2 MHz subcarrier, −19.1/−20.8 dB, put
  the 5.81 GHz carrier on the 5.79 GHz pylon's ±2 MHz);
* ``"joint"`` filters every pylon's input (channel filter, ``rx_cutoff_hz``, default f_sc + 2·R_b,
  :class:`rfsim.devices.himr_pylon.Pylon`): the other pylons' direct CW would otherwise dominate;
* the receiver's packet detector is given the scheduled start to within ±``search_s``
  (preamble correlation finds it; acquisition from scratch is not modelled).

Transmit power: every pylon gets the P_T that gives the per-sample SNR |h|²/N =
``snr_db`` at ``snr_distance_m`` (seed 000 L646: 31.6 dB at 1 m, 1-D experiment), with
N = k·T₀·F·fs (:func:`rfsim.himr.link.ptx_for_snr_w`). RSS range constant K_u of eq. 22:
``"link-budget"`` — P_T·G_T·G_R·G_t²·λ⁴/(4π)⁴ of the configured radio; ``"start-pose"`` —
|h₀|²·d₀⁴ from the first decoded packet at the known start distance d₀.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.himr.dsp import PacketMeasurements, decode_packet, packet_table
from rfsim.core.progress import track
from rfsim.core.rng import trial_rng
from rfsim.core.trajectories import check_inside
from rfsim.core.lazy import lazy_import

_antennas = lazy_import("rfsim.channels.antennas")
_scene = lazy_import("rfsim.channels.scene")
_himr_pylon = lazy_import("rfsim.devices.himr_pylon")
_himr_tag = lazy_import("rfsim.devices.himr_tag")
_air = lazy_import("rfsim.air.step")
_air_links = lazy_import("rfsim.air.links")
_himr_link = lazy_import("rfsim.himr.link")
_noise = lazy_import("rfsim.air.noise")
_imu = lazy_import("rfsim.devices.imu")
_dataset = lazy_import("rfsim.core.dataset")


@dataclass(frozen=True)
class RadioConfig:
    """Sampling, power calibration and DSP of the pylons (module docstring)."""

    fs_hz: float = param(16e6, lo=1e5, hi=2e8, unit="Hz", doc="complex sample rate of every pylon (shared clock)")
    cross_carrier: Literal["ignore", "joint"] = param(
        "ignore", doc="'ignore': one air step per packet and pylon, other carriers left out; 'joint': one step "
                      "per packet with every pylon (needs fs > 2x the largest carrier offset to show it)")
    snr_db: float = param(31.6, lo=-20.0, hi=120.0, unit="dB", doc="per-sample SNR at snr_distance_m (L646)")
    snr_distance_m: float = param(1.0, lo=0.05, hi=100.0, unit="m", doc="distance of the SNR calibration")
    pylon_gain_dbi: float = param(9.5, lo=-10.0, hi=30.0, unit="dBi", doc="pylon TX and RX antenna gain (L632)")
    tag_gain_dbi: float = param(2.0, lo=-10.0, hi=20.0, unit="dBi", doc="tag antenna gain (monopole, L1001)")
    noise_figure_db: float = param(6.0, lo=0.0, hi=40.0, unit="dB", doc="receiver noise figure")
    receiver_noise: bool = param(True, doc="add the receivers' thermal noise (false: noise-free inputs; P_T is "
                                           "still calibrated to snr_db)")
    coupling_db: float = param(-40.0, lo=-200.0, hi=0.0, unit="dB", doc="TX -> RX leakage of a pylon's own CW")
    rss_calibration: Literal["start-pose", "link-budget"] = param(
        "start-pose", doc="K_u of eq. 22: from the first packet at the known start distance or from the link budget")
    margin_s: float = param(4e-6, lo=0.0, hi=1e-3, unit="s", doc="time base beyond the packet on each side")
    search_s: float = param(2e-6, lo=0.0, hi=1e-4, unit="s", doc="half-width of the packet start search")
    rx_cutoff_hz: float | None = param(None, lo=1e4, hi=1e8, unit="Hz",
                                       doc="pylon channel filter cut-off (None: none; 'joint' default: f_sc + 2 R_b)")

    def __post_init__(self):
        need = math.ceil(self.search_s * self.fs_hz) + 2
        if math.floor(self.margin_s * self.fs_hz) < need:
            raise ConfigError("radio.margin_s", self.margin_s,
                              f"≥ radio.search_s + 2 samples = {need / self.fs_hz:.6g} s at radio.fs_hz = "
                              f"{self.fs_hz:g} Hz (the start search must lie inside the packet's time base)")


def check_sample_rate(radio: RadioConfig, tag: _himr_tag.HimrTag, pylon_fc_hz) -> None:
    """Check that the pylons' sample rate suits the tag's BOC code.

    fs must reach 8·f_sc (wave2-specs.md §H) and the BOC bandwidth 2·(f_sc + R_b)
    (:meth:`rfsim.himr.boc.BocCode.check_fs`). A ``joint`` run below twice the carrier spread
    is allowed: the air step drops the carriers outside ±fs/2 and the run counts them
    (:attr:`AirRun.dropped`).

    Parameters
    ----------
    radio : RadioConfig
        The pylons' radio (``fs_hz`` [Hz]).
    tag : rfsim.devices.himr_tag.HimrTag
        The tag (its config's code: subcarrier f_sc [Hz], bit rate R_b [bit/s]).
    pylon_fc_hz : array_like, shape (n_pylons,)
        The pylons' carriers [Hz] (not used by the checks).

    Raises
    ------
    rfsim.core.errors.ConfigError
        The rate is too low; the error names ``tag.subcarrier_hz`` or ``tag.chip_rate_hz``
        when the user set that rate on the tag, else ``radio.fs_hz``.
    """
    code = tag.config.code
    try:
        code.check_fs(radio.fs_hz, key="radio.fs_hz")
        need = 8.0 * code.subcarrier_hz_value
        if radio.fs_hz < need * (1 - 1e-12):
            raise ConfigError("radio.fs_hz", radio.fs_hz, f"a sample rate ≥ 8·f_sc = {need:g} Hz (wave2-specs §H)")
    except ConfigError as err:  # a rate the user set on the tag is named, not the sample rate it outgrew
        for key in ("subcarrier_hz", "chip_rate_hz"):
            value = getattr(tag.config, key)
            if value is not None:
                raise ConfigError(f"tag.{key}", value, f"a lower rate at radio.fs_hz = {radio.fs_hz:g} Hz (the rule: "
                                                        f"{err.allowed}), or a higher radio.fs_hz") from None
        raise


def check_pylons_off_the_track(positions_m, tag: _himr_tag.HimrTag, t_end_s: float, *, min_distance_m: float = 0.05,
                               key: str = "pylons.positions_m") -> None:
    """Check that no pylon lies on (or within ``min_distance_m`` of) the tag's track.

    Such a pylon has no far-field link. The track is sampled every 1 ms from 0 to
    ``t_end_s``.

    Parameters
    ----------
    positions_m : array_like, shape (n_pylons, 3)
        Pylon positions (x, y, z) [m].
    tag : rfsim.devices.himr_tag.HimrTag
        The tag (its ``trajectory``).
    t_end_s : float
        End of the run [s].
    min_distance_m : float, default 0.05
        Smallest allowed distance pylon to tag [m].
    key : str, default "pylons.positions_m"
        Config key named in the error (as ``<key>[u]``).

    Raises
    ------
    rfsim.core.errors.ConfigError
        A pylon closer than ``min_distance_m`` to the track (the message gives the closest
        distance and its time).
    """
    t = np.arange(0.0, t_end_s + 5e-4, 1e-3)
    p = tag.trajectory(t).position_m
    for u, q in enumerate(np.asarray(positions_m, float)):
        d = np.linalg.norm(p - q, axis=1)
        i = int(np.argmin(d))
        if d[i] < min_distance_m:
            raise ConfigError(f"{key}[{u}]", tuple(q.tolist()),
                              f"a position ≥ {min_distance_m} m from the tag (it passes {d[i]:.3f} m away at "
                              f"t = {t[i]:.3f} s)")


def check_scene(radio: RadioConfig, tag: _himr_tag.HimrTag, pylons_m, carriers_hz, *, t_end_s: float, room_min_m,
                room_max_m, key: str = "pylons.positions_m") -> None:
    """Check that the air step can run the scene.

    The tag's trajectory stays inside the room until ``t_end_s``
    (:func:`rfsim.core.trajectories.check_inside`), every pylon is off its track
    (:func:`check_pylons_off_the_track`), the sample rate is enough for the tag's code
    (:func:`check_sample_rate`) and the run holds two packets (:func:`check_two_packets`).

    Parameters
    ----------
    radio : RadioConfig
        The pylons' radio.
    tag : rfsim.devices.himr_tag.HimrTag
        The tag on its trajectory.
    pylons_m : array_like, shape (n_pylons, 3)
        Pylon positions (x, y, z) [m].
    carriers_hz : array_like, shape (n_pylons,)
        The pylons' carriers [Hz].
    t_end_s : float
        End of the run [s].
    room_min_m, room_max_m : array_like, shape (2,) or (3,)
        Corners of the room [m].
    key : str, default "pylons.positions_m"
        Config key of the pylon positions, named in errors.

    Raises
    ------
    rfsim.core.errors.ConfigError
        The first check that fails (one line naming the key).
    """
    check_inside(tag.trajectory, t_end_s=t_end_s, room_min_m=room_min_m, room_max_m=room_max_m)
    check_pylons_off_the_track(pylons_m, tag, t_end_s, key=key)
    check_sample_rate(radio, tag, carriers_hz)
    check_two_packets(tag, t_end_s)


def check_two_packets(tag: _himr_tag.HimrTag, t_end_s: float) -> None:
    """Check that the run holds at least two packets (the observers need two).

    The second packet, one period and six RMS jitters after the first, must end before the
    run does: ``start_s + period_s + air_time_s + 6·jitter_rms_s < t_end_s``.

    Parameters
    ----------
    tag : rfsim.devices.himr_tag.HimrTag
        The tag (its config's schedule).
    t_end_s : float
        End of the run [s].

    Raises
    ------
    rfsim.core.errors.ConfigError
        Too short a run; the error names the tag's packet rate, its start or the run's length
        (``scene.duration_s``), whichever the user set.
    """
    cfg = tag.config
    need_s = cfg.start_s + cfg.period_s + cfg.air_time_s + 6.0 * cfg.jitter_rms_s
    if need_s >= t_end_s:
        key, value = (("tag.packet_rate_hz", cfg.packet_rate_hz) if cfg.packet_rate_hz is not None else
                      ("tag.start_s", cfg.start_s) if cfg.start_s > 0 else ("scene.duration_s", t_end_s))
        raise ConfigError(key, value, f"at least two packets in the run: tag.start_s + 1/packet rate + air time + "
                                      f"6 jitter = {need_s:.6g} s before scene.duration_s = {t_end_s:g} s")


@dataclass(frozen=True, eq=False)
class AirRun:
    """What the pylons measured: per pylon its packet table, plus the run's bookkeeping."""

    pylons: list                 #: the :class:`rfsim.devices.himr_pylon.Pylon` objects
    measurements: list           #: per pylon :class:`rfsim.himr.dsp.PacketMeasurements`
    packet_index: list           #: per pylon (P_u,) index of each row's packet in the tag's plan
    true_range_m: list           #: per pylon (P_u,) true distance at the packet's middle [m]
    k_u: np.ndarray              #: (N,) K_u used [W·m⁴]
    ptx_w: float                 #: transmit power of every pylon [W]
    noise_power_w: float         #: receiver noise per sample [W]
    samples_per_step: int        #: samples of one step's time base
    n_steps: int                 #: air steps run
    dropped: int                 #: carrier contributions the steps dropped (outside ±fs/2)
    wall_s: float                #: wall time of the steps and the DSP [s]
    cpu_s: float                 #: CPU time of this process in the steps and the DSP [s]

    def run_attrs(self, n_packets: int) -> dict:
        """Return the run's bookkeeping as dataset attributes.

        Parameters
        ----------
        n_packets : int
            Packets the tag scheduled in the run.

        Returns
        -------
        dict
            ``n_packets``, ``air_steps``, ``samples_per_step``, ``sample_level_s`` (wall
            time [s]), ``sample_level_cpu_s`` [s], ``time_per_packet_s`` (wall time per
            scheduled packet [s]), ``ptx_w`` [W] and ``noise_power_w`` [W].
        """
        return {"n_packets": int(n_packets), "air_steps": self.n_steps, "samples_per_step": self.samples_per_step,
                "sample_level_s": self.wall_s, "sample_level_cpu_s": self.cpu_s,
                "time_per_packet_s": self.wall_s / max(n_packets, 1), "ptx_w": self.ptx_w,
                "noise_power_w": self.noise_power_w}


class _Memo:
    """A motion callable remembering its last positions (the pylons of one packet ask the
    same times)."""

    def __init__(self, fn):
        self.fn, self.seen = fn, {}

    def __call__(self, t_s: float):
        hit = self.seen.get(t_s)
        if hit is None:
            if len(self.seen) > 64:
                self.seen.clear()
            hit = self.seen[t_s] = self.fn(t_s)
        return hit


def pylon_antennas(positions_m, height_m: float, gain_dbi: float) -> list:
    """Build the pylons' isotropic antennas.

    Parameters
    ----------
    positions_m : array_like, shape (n_pylons, 2) or (n_pylons, 3)
        Positions [m]: (x, y) rows at ``height_m``, or (x, y, z) rows at their own height.
    height_m : float
        Height of (x, y) rows [m].
    gain_dbi : float
        Antenna gain [dBi] (linear 10^(gain_dbi/10)).

    Returns
    -------
    list of rfsim.channels.antennas.Antenna
        One isotropic antenna per row (default polarization).
    """
    p = np.asarray(positions_m, float)
    z = p[:, 2] if p.shape[1] == 3 else np.full(p.shape[0], float(height_m))
    return [_antennas.Antenna(position_m=(float(x), float(y), float(h)), pattern=_antennas.Isotropic(10 ** (gain_dbi / 10)))
            for (x, y), h in zip(p[:, :2], z)]


def simulate(tag: _himr_tag.HimrTag, positions_m, carriers_hz, radio: RadioConfig, *, seed: int, t_end_s: float,
             height_m: float = 0.0, desc: str = "packets", stream: tuple[int, ...] = ()) -> AirRun:
    r"""Plan the tag's packets up to ``t_end_s`` and run them through the air and the DSP.

    Every pylon transmits the power P_T that gives the per-sample SNR ``radio.snr_db`` at
    ``radio.snr_distance_m`` (eq. 3 solved for P_T, :func:`rfsim.himr.link.ptx_for_snr_w`;
    wave2-specs.md §H, seed 000 L646):

    .. math::

        P_T = \frac{\mathrm{SNR}\, N\, (4\pi d)^4}{G_T G_R G_t^2 \lambda^4}, \qquad N = k T_0 F f_s

    with λ of the mean carrier. Packet k is one air step per pylon (``cross_carrier =
    "ignore"``) or one with every pylon (``"joint"``) on the packet's air time plus
    ``radio.margin_s`` each side; each pylon's input goes through
    :func:`rfsim.himr.dsp.decode_packet` and, per pylon, :func:`rfsim.himr.dsp.packet_table`
    with the RSS constant K_u of eq. 22 (``radio.rss_calibration``: the link budget
    :func:`rfsim.himr.link.rss_constant`, or :math:`K_u = |h_0|^2 d_0^4` of the pylon's first
    decoded packet at its true range; NaN when it decoded none).

    Parameters
    ----------
    tag : rfsim.devices.himr_tag.HimrTag
        The tag on its trajectory. Its ``antenna`` is replaced by an isotropic antenna of
        gain ``radio.tag_gain_dbi`` and its plan is drawn here.
    positions_m : array_like, shape (n_pylons, 2) or (n_pylons, 3)
        Pylon positions [m] (:func:`pylon_antennas`).
    carriers_hz : array_like, shape (n_pylons,)
        The pylons' carriers [Hz].
    radio : RadioConfig
        Sampling, power calibration and DSP.
    seed : int
        Root seed: the plan (schedule jitter, IMU noise) draws from
        ``trial_rng(seed, *stream, 0)``, the air step of packet k with pylon group starting at
        pylon u (0-based) from ``trial_rng(seed, *stream, 1, k, u)``.
    t_end_s : float
        End of the run [s].
    height_m : float, default 0.0
        Pylon height for (x, y) positions [m].
    desc : str, default "packets"
        Label of the progress bar.
    stream : tuple of int, default ()
        Prefix of the stream keys.

    Returns
    -------
    AirRun
        Per pylon its decoded packets (CRC passed or not) and their true ranges, with K_u,
        P_T [W], the noise power per sample [W] and the run's bookkeeping (steps, dropped
        carriers, wall and CPU time).
    """
    plan = tag.plan(t_end_s, rng=trial_rng(seed, *stream, 0))
    fs, code, fmt = radio.fs_hz, tag.config.code, tag.config.format
    g_p, g_t = 10 ** (radio.pylon_gain_dbi / 10), 10 ** (radio.tag_gain_dbi / 10)
    noise_w = float(_noise.thermal_noise_power_w(fs, radio.noise_figure_db))
    ptx = _himr_link.ptx_for_snr_w(radio.snr_db, radio.snr_distance_m, noise_power_w=noise_w, fc_hz=float(np.mean(carriers_hz)),
                                   g_tx=g_p, g_rx=g_p, g_tag=g_t)
    ants = pylon_antennas(positions_m, height_m, radio.pylon_gain_dbi)
    pylons = []
    cutoff = radio.rx_cutoff_hz
    if cutoff is None and radio.cross_carrier == "joint":
        cutoff = code.subcarrier_hz_value + 2 * code.bit_rate_bps
    for u, (ant, fc) in enumerate(zip(ants, carriers_hz)):
        p = _himr_pylon.Pylon(_himr_pylon.PylonConfig(fc_hz=float(fc), ptx_w=ptx, noise_figure_db=radio.noise_figure_db,
                                                      coupling_db=radio.coupling_db), ant, name=f"pylon {u + 1}", rx_cutoff_hz=cutoff)
        if radio.receiver_noise:
            p.set_sample_rate(fs)
        pylons.append(p)
    p0 = tag.position_m(0.0)
    tag.antenna = _antennas.Antenna(position_m=p0, pattern=_antennas.Isotropic(g_t))
    channel = _scene.Channel(_scene.Scene(image_order=0))
    air_s = tag.config.air_time_s
    n = int(math.ceil((air_s + 2 * radio.margin_s) * fs))
    decoded = [[] for _ in pylons]
    index = [[] for _ in pylons]
    dropped, steps = 0, 0
    tick, cpu = time.perf_counter(), time.process_time()
    motion = _Memo(tag.position_m)
    groups = [[u] for u in range(len(pylons))] if radio.cross_carrier == "ignore" else [list(range(len(pylons)))]
    for k in track(range(plan.start_s.size), desc=desc, unit="packets"):
        t_k = float(plan.start_s[k])
        t0 = t_k - radio.margin_s
        for grp in groups:
            devs = [pylons[u] for u in grp]
            links = _air.LinkTable(channel, motions=[_air_links.AntennaMotion(tag.antenna, motion)])
            res = _air.propagate(devs, [tag], devs, links, t0_s=t0, fs_hz=fs, n_samples=n,
                                 rng=trial_rng(seed, *stream, 1, k, grp[0]), bandwidth_hz=code.bandwidth_hz / 2)
            steps += 1
            dropped += len(res.dropped)
            for u, seg in zip(grp, res.outputs):
                d = decode_packet(seg.samples, t0_s=t0, fs_hz=fs, fmt=fmt, framing=tag.config.framing, code=code,
                                  expected_start_s=t_k, search_s=radio.search_s)
                if d is not None:
                    decoded[u].append(d)
                    index[u].append(k)
    wall, cpu = time.perf_counter() - tick, time.process_time() - cpu
    mids = plan.start_s + 0.5 * air_s
    pos = tag.trajectory(mids).position_m
    out, true_r, k_us = [], [], []
    for u, p in enumerate(pylons):
        idx = np.asarray(index[u], dtype=np.int64)
        r_true = np.linalg.norm(pos[idx] - p.antenna.position_m, axis=1)
        v_true = np.full(idx.size, np.nan)
        v_true[1:] = np.diff(r_true) / np.diff(plan.start_s[idx])
        if radio.rss_calibration == "link-budget":
            k_u = _himr_link.rss_constant(fc_hz=p.fc_hz, ptx_w=ptx, g_tx=g_p, g_rx=g_p, g_tag=g_t)
        else:
            k_u = _himr_link.calibrate_rss_constant(abs(decoded[u][0].gain) ** 2, r_true[0]) if idx.size else float("nan")
        k_us.append(k_u)
        out.append(packet_table(decoded[u], fc_hz=p.fc_hz, fmt=fmt, framing=tag.config.framing, k_u=k_u,
                                true_radial_velocity_mps=v_true))
        true_r.append(r_true)
        index[u] = idx
    return AirRun(pylons=pylons, measurements=out, packet_index=index, true_range_m=true_r, k_u=np.array(k_us),
                  ptx_w=ptx, noise_power_w=noise_w, samples_per_step=n, n_steps=steps, dropped=dropped, wall_s=wall,
                  cpu_s=cpu)


# ----------------------------------------------------------------------------- tables


def packets_table(run, plan) -> dict:
    """Gather the pylons' packet measurements into one table.

    Parameters
    ----------
    run : AirRun
        The run of :func:`simulate`.
    plan : rfsim.devices.himr_tag.HimrPlan
        The tag's plan of that run (``start_s`` [s] of every scheduled packet).

    Returns
    -------
    dict of str to ndarray
        The columns of :data:`PACKET_COLUMNS`, one row per (packet, pylon) decoded, pylon by
        pylon (pylons numbered from 1); ``true_radial_velocity_mps`` is the true range's
        difference over the start times' difference to the pylon's previous decoded packet
        [m/s] (NaN for its first).
    """
    cols: dict[str, list] = {}
    for u, (p, m) in enumerate(zip(run.pylons, run.measurements)):
        idx = run.packet_index[u]
        r_true = run.true_range_m[u]
        v_true = np.full(idx.size, np.nan)
        v_true[1:] = np.diff(r_true) / np.diff(plan.start_s[idx])
        part = {
            "t_s": m.start_s, "packet": idx, "pylon": np.full(idx.size, u + 1),
            "carrier_hz": np.full(idx.size, p.fc_hz),
            "crc_ok": m.crc_ok, "h_re": m.gain.real, "h_im": m.gain.imag, "rss_dbm": m.rss_dbm, "snr_db": m.snr_db,
            "phase_rad": m.phase_rad, "dphase_rad": m.dphase_rad, "range_rss_m": m.range_m,
            "radial_velocity_mps": m.radial_velocity_mps, "aliasing_limit_mps": m.aliasing_limit_mps,
            "aliased": m.aliased, "true_range_m": r_true, "true_radial_velocity_mps": v_true,
            "true_start_s": plan.start_s[idx]}
        for k, v in part.items():
            cols.setdefault(k, []).append(np.asarray(v))
    return {k: np.concatenate(v) for k, v in cols.items()}


PACKET_COLUMNS = {
    "t_s": ("s", "packet start found by the pylon's preamble correlation (shared clock)"),
    "packet": ("1", "index of the packet in the tag's schedule (its sequence number, from 0)"),
    "pylon": ("1", "pylon (receiver) number 1..N, Table 7 order"),
    "carrier_hz": ("Hz", "carrier of the pylon that measured the packet"),
    "crc_ok": ("1", "the decoded packet passed its CRC-8 (else its IMU words and RF reading are not used)"),
    "h_re": ("sqrt(W)", "real part of the least-squares complex gain h of the modulated backscatter"),
    "h_im": ("sqrt(W)", "imaginary part of the least-squares complex gain h of the modulated backscatter"),
    "rss_dbm": ("dBm", "received signal strength of the modulated part, 10 log10(|h|^2) + 30"),
    "snr_db": ("dB", "per-sample SNR |h|^2 / residual noise power of the packet fit"),
    "phase_rad": ("rad", "phase phi = -arg h of the packet (eq. 1 convention: grows as the tag recedes)"),
    "dphase_rad": ("rad", "wrapped phase difference to the pylon's previous packet (NaN for its first)"),
    "range_rss_m": ("m", "RSS range (K_u/|h|^2)^(1/4), eq. 22 (NaN without K_u)"),
    "radial_velocity_mps": ("m/s", "lambda wrap(dphi) / (4 pi dt), eq. 23, positive receding (NaN for the first)"),
    "aliasing_limit_mps": ("m/s", "largest unambiguous radial speed lambda / (4 dt) for this packet interval"),
    "aliased": ("1", "the true mean radial speed over the interval reaches the aliasing limit (wrapped value wrong)"),
    "true_range_m": ("m", "ground truth: distance pylon - tag at the middle of the packet"),
    "true_radial_velocity_mps": ("m/s", "ground truth: mean radial velocity over the packet interval"),
    "true_start_s": ("s", "ground truth: start of the packet in the tag's schedule"),
}


def imu_table(run, plan, imu_cfg, *, heading_start_rad: float) -> dict:
    """Build the IMU table: one row per scheduled packet.

    The IMU words of a packet are those of the first pylon (lowest number) whose copy passed
    its CRC; a packet no pylon decoded with a good CRC has zero words and NaN readings.

    Parameters
    ----------
    run : AirRun
        The run of :func:`simulate`.
    plan : rfsim.devices.himr_tag.HimrPlan
        The tag's plan of that run.
    imu_cfg : rfsim.devices.imu.ImuConfig
        Word scaling to SI (:func:`rfsim.devices.imu.words_to_si`) and the magnetic
        declination [rad].
    heading_start_rad : float
        Heading at the start pose [rad]: the unwrapped compass heading is shifted by a multiple
        of 2π to start nearest to it.

    Returns
    -------
    dict of str to ndarray
        ``t_s`` (scheduled start [s]), ``packet``, ``decoded_by`` (pylon 1..N, 0: lost),
        ``valid``, then per IMU word ``<name>_raw`` (int16) and ``<name>`` in SI units
        (m/s², rad/s, µT); with nine words also ``heading_rad`` (heading of the body y axis
        from the compass x, y words, unwrapped [rad]).
    """
    n = plan.start_s.size
    n_words = plan.words.shape[1]
    words = np.zeros((n, n_words), dtype=np.int16)
    by = np.zeros(n, dtype=np.int64)
    for u in range(len(run.pylons) - 1, -1, -1):  # the first pylon wins
        m, idx = run.measurements[u], run.packet_index[u]
        ok = m.crc_ok
        words[idx[ok]] = m.words[ok]
        by[idx[ok]] = u + 1
    valid = by > 0
    si = _imu.words_to_si(words, imu_cfg).astype(float)
    si[~valid] = np.nan
    out = {"t_s": plan.start_s, "packet": np.arange(n), "decoded_by": by, "valid": valid}
    names = _imu.WORD_NAMES[:n_words]
    for j, name in enumerate(names):
        out[f"{name}_raw"] = words[:, j]
    for j, name in enumerate(names):
        out[name] = si[:, j]
    if n_words == 9:
        head = np.full(n, np.nan)
        if valid.any():
            h = np.unwrap(_imu.heading_from_compass(si[valid, 6], si[valid, 7], imu_cfg.declination_rad))
            head[valid] = h + 2 * np.pi * np.round((heading_start_rad - h[0]) / (2 * np.pi))
        out["heading_rad"] = head
    return out


_IMU_UNITS = {"accel": ("m/s^2", "accelerometer specific force along body axis"),
              "gyro": ("rad/s", "gyroscope rate about body axis"),
              "compass": ("uT", "magnetometer field along body axis")}


def imu_columns(table: dict) -> dict:
    """Describe the columns of an :func:`imu_table` for a dataset.

    Parameters
    ----------
    table : dict of str to ndarray
        The output of :func:`imu_table`.

    Returns
    -------
    dict of str to rfsim.core.dataset.Column
        Each column with its unit and description (:func:`rfsim.core.dataset.column`).
    """
    cols = {"t_s": _dataset.column(table["t_s"], "s", "scheduled start of the packet that carried the IMU sample"),
            "packet": _dataset.column(table["packet"], "1", "index of the packet in the tag's schedule"),
            "decoded_by": _dataset.column(table["decoded_by"], "1",
                                 "pylon whose copy passed the CRC first (0: none, sample lost)"),
            "valid": _dataset.column(table["valid"], "1", "some pylon decoded the packet with a good CRC (else NaN readings)")}
    for k, v in table.items():
        if k in cols:
            continue
        if k == "heading_rad":
            cols[k] = _dataset.column(v, "rad",
                             "heading of the body y axis from the compass x, y words, unwrapped, start pose pi")
            continue
        sensor, axis = k.split("_")[0], k.split("_")[1]
        unit, text = _IMU_UNITS[sensor]
        if k.endswith("_raw"):
            cols[k] = _dataset.column(v, "1", f"raw int16 word of the {sensor} {axis} axis as decoded from the packet")
        else:
            cols[k] = _dataset.column(v, unit, f"{text} {axis} from the int16 word (NaN when the packet was lost)")
    return cols


def add_run_tables(ds, run: AirRun, plan, imu: dict, *, packets: str, imu_description: str) -> dict:
    """Add the run's ``packets`` and ``imu`` tables to a dataset.

    Parameters
    ----------
    ds : rfsim.core.dataset.Dataset
        The dataset, extended in place.
    run : AirRun
        The run of :func:`simulate`.
    plan : rfsim.devices.himr_tag.HimrPlan
        The tag's plan of that run.
    imu : dict of str to ndarray
        The run's :func:`imu_table`.
    packets : str
        Description of table ``packets`` (:func:`packets_table`, :data:`PACKET_COLUMNS`).
    imu_description : str
        Description of table ``imu`` (:func:`imu_columns`).

    Returns
    -------
    dict of str to ndarray
        The packet table's arrays (:func:`packets_table`).
    """
    pk = packets_table(run, plan)
    ds.add_table("packets", {k: _dataset.column(v, *PACKET_COLUMNS[k]) for k, v in pk.items()}, description=packets)
    ds.add_table("imu", imu_columns(imu), description=imu_description)
    return pk


__all__ = ["RadioConfig", "AirRun", "simulate", "check_sample_rate", "check_pylons_off_the_track", "check_scene",
           "pylon_antennas", "PacketMeasurements", "packets_table", "PACKET_COLUMNS", "imu_table", "imu_columns", "add_run_tables"]

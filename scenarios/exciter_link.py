"""Scenario ``exciter-link``: the tag-to-tag link an RF exciter enables, swept over the
exciter→tag distance d_e and the tag→listener distance d_tt, with the logistic detection model
of the reader-free network fitted (binary-detection.md §1.11 Eq. (6.5), seed 004 L1049-1127;
wave2-specs.md §X "Geng ch. 6"; auris-sense-a-tag.md ch. 5 for the exciter).

Scene: an exciter at the origin (:class:`rfsim.devices.exciter.Exciter`, CW only, 3.28 W EIRP at
915 MHz by default, patch with boresight +x); a passive tag at (d_e, 0) that harvests the
exciter's CW and backscatters a frame on its own schedule — a 16-bit word (its "location",
L1089) with its CRC-16, Miller-2 with pilot, no command involved (Geng's reference tags,
L1051, L1068); a listener with the sense-a-tag receive chain (single antenna: linear detector,
band-pass, 5 mV comparator, Miller decoder, :mod:`rfsim.devices.st_receiver`) at distance d_tt from
the tag, azimuth uniform, all at ``height_m``; receiver noise kT·fs·F at the listener. Channel:
Friis + the exponential APDP with the PASS ST-room curves.

Physics per draw (sample level, one :func:`rfsim.air.step.propagate` step per (d_e, draw) with the
listeners of every d_tt as one batched receiver): the tag's incident power P_inc = the CW power
of its incident segment through the drawn exciter→tag link; with the default ``measured`` tag
(the PASS UCODE-class chip of :mod:`rfsim.devices.tag_chip`, re-radiating Γ·incident) it runs iff its
absorbed power reaches picmin + 2.5 dB, and its two reflection states follow P_chip; the
listener gets the exciter's direct CW plus the tag's (A_s − Γ(t))·incident through its links
and its noise; ``decoded`` = the chain decodes the 32 bits exactly. The envelope difference
``diff_v`` is measured on the detector output (settled states), ``closed_diff_v`` is Eq. 3.3
from the step's phasors, ``sync_v`` the same with the CW synchronised (its upper bound).
The backscatter at the listener scales as 1/(d_e·d_tt) (Eq. 4.2: power ∝ 1/(D²·d²)) for fixed
reflection states; the measured chip's states are not fixed — its modulation deepens as its
power falls (``|Γ_m − Γ_u|`` = 0.26 at 1 mW available, ≈ 0.6 at its power-up limit of 0.13 mW,
:mod:`rfsim.devices.tag_chip`), which offsets most of the 1/d_e: the full run (seed 1) finds the 50 %
range d50 ≈ 0.4 m for every d_e from 1.5 to 5 m (1.2 m at 0.5 m) and nothing beyond the tag's
power-up limit (it runs in most draws up to 5 m, in a few at 5.5 m). d_tt below ≈ λ/2 = 0.16 m
is at the edge of the far-field link model.

Fits (:func:`rfsim.detection.fit_logistic`, maximum likelihood on k decodes of m draws per
point, standard errors from the inverse Fisher information):

* Eq. (6.5) per d_e row: p(d_tt) = 1/(1 + exp(a1 + a2·d_tt)), with the 50 % range
  d50 = −a1/a2 and its delta-method standard error; rows where the data are separated (all or
  nothing decoded) have no finite maximum and get NaN (``fit_status``); ``d50_in_range`` marks
  the rows whose p crosses 0.5 inside the swept d_tt.
* Eq. (6.5) pooled over the points of the rows where the tag runs (it ran in at least half the
  draws; Geng's reference tags are placed where the exciter powers them) — the seed's form, one
  (a1, a2) for the whole network.
* Eq. (6.5) with a d_e term over the same rows, p = 1/(1 + exp(a1 + a2·d_tt + a3·d_e)): its
  50 % contour d_tt = −(a1 + a3·d_e)/a2 is the dashed line in the figure.

wave2-specs.md §X asks to calibrate p = 0.5 at r for the median d_exciter and report the
spread: root attributes ``d50_at_median_exciter_distance_m`` and ``d50_min_m``/``d50_max_m``
over the rows with d50 in range.

Randomness: (d_e row i, draw k) uses ``trial_rng(seed, i, k, j)``: j = 0 listener azimuths,
1 links (exciter→tag, then exciter→listeners, tag→listeners), 2 receiver noise, 3 the tag's
own stream, 4 exciter phase noise. Draws at the same (i, k) share the exciter→tag draw across
the d_tt values (one step); the points' draws are independent across k.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.core.columns import concat, unit_of
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.procs import map_in_order
from rfsim.core.rng import trial_rng
from rfsim.detection.tag_to_tag import fit_eq65
from rfsim.devices.exciter import Exciter, ExciterConfig
from rfsim.devices.own_schedule import FrameConfig, OwnSchedule, build_frame
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.st_rows import RowsChain
from rfsim.devices.tag_chip import PASS_POWER_MARGIN_DB
from rfsim.devices.tag_config import TagConfig
from rfsim.scenes.exciter import NoiseConfig, check_exciter_on, exciter_antenna, measured_tag, room, single_listener, tag_broadcast_step
from rfsim.scenes.links import BatchAntenna

_antennas = lazy_import("rfsim.channels.antennas")
sa = lazy_import("rfsim.devices.st_analytic")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
_tag = lazy_import("rfsim.devices.tag")
_dataset = lazy_import("rfsim.core.dataset")
_detection = lazy_import("rfsim.detection")
_bits = lazy_import("rfsim.gen2.bits")
_crc = lazy_import("rfsim.gen2.crc")
_figures = lazy_import("rfsim.scenarios._exciter_link_figures")

NAME = "exciter-link"
DESCRIPTION = ("exciter-powered tag-to-tag link vs exciter-tag and tag-listener distance: incident power, "
               "envelope difference, decode probability, Eq. (6.5) logistic fit")

V_PER_SQRT_W = math.sqrt(2.0 * 50.0)  # RF peak volts per √W at the 50 Ω detector (rfsim.devices.st_receiver)


@dataclass(frozen=True)
class SweepConfig:
    """The distances swept and the draws per point.

    Both distance lists need at least 2 strictly increasing values (checked by :class:`Config`).

    Attributes
    ----------
    full : bool, default False
        Full size: 100 draws per point (overrides draws_per_point).
    exciter_distance_m : tuple of float, default (0.5, 1.0, ..., 8.0)
        Exciter→tag distances d_e [m], in [0.1, 100]; default every 0.5 m.
    tag_distance_m : tuple of float, default (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0)
        Tag→listener distances d_tt [m], in [0.02, 50].
    draws_per_point : int, default 20
        Channel draws (and listener azimuths) per point, in [1, 100000].
    workers : int, default 2
        Worker processes (0 = all cores, 1 = in process), in [0, 256].
    """

    full: bool = param(False, doc="full size: 100 draws per point (overrides draws_per_point)")
    exciter_distance_m: tuple[float, ...] = param(tuple(0.5 * i for i in range(1, 17)), lo=0.1, hi=100.0,
                                                  unit="m", doc="exciter→tag distances d_e")
    tag_distance_m: tuple[float, ...] = param((0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0), lo=0.02,
                                              hi=50.0, unit="m", doc="tag→listener distances d_tt")
    draws_per_point: int = param(20, lo=1, hi=100000, doc="channel draws (and listener azimuths) per point")
    workers: int = param(2, lo=0, hi=256, doc="worker processes (0 = all cores, 1 = in process)")

    @property
    def n_draws(self) -> int:
        """Channel draws per point: 100 with ``full``, else ``draws_per_point``."""
        return 100 if self.full else self.draws_per_point


@dataclass(frozen=True)
class GeometryConfig:
    """Placement height, the exciter's antenna and the channel's small scale.

    Attributes
    ----------
    height_m : float, default 1.0
        Height of exciter, tag and listener [m], in [0.1, 10].
    exciter_antenna : {"patch", "dipole"}, default "patch"
        Patch (boresight +x, towards the tag) or vertical dipole.
    exciter_gain_dbi : float, default 6.0
        Patch peak gain [dBi], in [0, 15].
    apdp : bool, default True
        Exponential APDP small scale (PASS ST-room curves).
    """

    height_m: float = param(1.0, lo=0.1, hi=10.0, unit="m", doc="height of exciter, tag and listener")
    exciter_antenna: Literal["patch", "dipole"] = param("patch", doc="patch (boresight +x, towards the tag) "
                                                                   "or vertical dipole")
    exciter_gain_dbi: float = param(6.0, lo=0.0, hi=15.0, unit="dBi", doc="patch peak gain")
    apdp: bool = param(True, doc="exponential APDP small scale (PASS ST-room curves)")


@dataclass(frozen=True)
class TagModelConfig:
    """The broadcasting tag's physics and payload.

    Attributes
    ----------
    model : {"measured", "chip"}, default "measured"
        'measured' = the PASS UCODE chip (impedance vs absorbed power, Gamma*incident,
        power-up at picmin + margin; rfsim.devices.tag_chip); 'chip' = the tag config's
        fixed states and sensitivity with its structural mode.
    power_margin_db : float, default 2.5
        'measured': power-up margin on the chip's minimum power (PASS: 2.5 dB) [dB], in
        [0, 20].
    word : int, default 0x0A5C
        16-bit word the tag broadcasts (followed by its CRC-16), in [0, 65535].
    """

    model: Literal["measured", "chip"] = param(
        "measured", doc="'measured' = the PASS UCODE chip (impedance vs absorbed power, Gamma*incident, power-up "
                        "at picmin + margin; rfsim.devices.tag_chip); 'chip' = the tag config's fixed states and "
                        "sensitivity with its structural mode")
    power_margin_db: float = param(PASS_POWER_MARGIN_DB, lo=0.0, hi=20.0, unit="dB",
                                   doc="'measured': power-up margin on the chip's minimum power (PASS: 2.5 dB)")
    word: int = param(0x0A5C, lo=0, hi=0xFFFF, doc="16-bit word the tag broadcasts (followed by its CRC-16)")


@dataclass(frozen=True)
class Config:
    """Configuration of the ``exciter-link`` scenario.

    Checked on construction: increasing distance lists, a single-antenna listener, a valid
    frame, and an exciter schedule that is on during the frame.

    Attributes
    ----------
    sweep : SweepConfig
        Distances and draws.
    geometry : GeometryConfig
        Placement and channel.
    exciter : rfsim.devices.exciter.ExciterConfig
        RF exciter (CW).
    frame : rfsim.devices.own_schedule.FrameConfig
        The tag's frame (sample rate, BLF, line code).
    tag : rfsim.devices.tag_config.TagConfig
        The broadcasting tag.
    tag_model : TagModelConfig
        Tag physics and payload.
    listener : rfsim.devices.sense_a_tag_config.SenseATagConfig
        Listener receive chain (threshold, detector gain).
    noise : rfsim.scenes.exciter.NoiseConfig
        Receiver noise.
    """

    sweep: SweepConfig = param(SweepConfig(), doc="distances and draws")
    geometry: GeometryConfig = param(GeometryConfig(), doc="placement and channel")
    exciter: ExciterConfig = param(ExciterConfig(), doc="RF exciter (CW)")
    frame: FrameConfig = param(FrameConfig(), doc="the tag's frame (sample rate, BLF, line code)")
    tag: TagConfig = param(TagConfig(), doc="the broadcasting tag")
    tag_model: TagModelConfig = param(TagModelConfig(), doc="tag physics and payload")
    listener: SenseATagConfig = param(single_listener(), doc="listener receive chain (threshold, detector gain)")
    noise: NoiseConfig = param(NoiseConfig(), doc="receiver noise")

    def __post_init__(self):
        sw = self.sweep
        for key in ("exciter_distance_m", "tag_distance_m"):
            v = getattr(sw, key)
            if len(v) < 2 or any(b <= a for a, b in zip(v, v[1:])):
                raise ConfigError(f"sweep.{key}", v, "at least 2 strictly increasing distances")
        if self.listener.n_antennas != 1:
            raise ConfigError("listener.n_antennas", self.listener.n_antennas, "1 (single-antenna listener)")
        self.frame.check("frame")
        if self.exciter.schedule_s:
            frame = build_frame(payload(self), self.frame, stamp_cycles=0)
            check_exciter_on(self.exciter, fs_hz=self.frame.fs_hz, n_samples=frame.n_samples)


# ----------------------------------------------------------------------------- one (d_e, draw)


def payload(config: Config) -> np.ndarray:
    """The broadcast bits: the 16-bit word and its CRC-16 (32 bits).

    Parameters
    ----------
    config : Config
        Scenario configuration (``tag_model.word``).

    Returns
    -------
    ndarray of uint8, shape (32,)
        The word's 16 bits followed by their CRC-16 (:func:`rfsim.gen2.crc.append_crc16`).
    """
    return _crc.append_crc16(_bits.int_to_bits(config.tag_model.word, 16))


def make_tag(config: Config, antenna, rng) -> _tag.PassiveTag:
    """The broadcasting tag at ``antenna`` by ``tag_model.model`` (module docstring).

    Parameters
    ----------
    config : Config
        Scenario configuration (``tag``, ``tag_model``).
    antenna : rfsim.channels.antennas.Antenna
        The tag's antenna.
    rng : numpy.random.Generator
        The tag's own stream.

    Returns
    -------
    rfsim.devices.tag.PassiveTag
        ``"measured"``: the PASS UCODE-class chip re-radiating Γ·incident, powered at picmin +
        ``power_margin_db`` (:func:`rfsim.scenes.exciter.measured_tag`); ``"chip"``: a tag
        with the config's fixed reflection states and sensitivity.
    """
    tm = config.tag_model
    if tm.model == "measured":  # PASS tag: Γ·incident, its chip sets the states and power-up
        return measured_tag(antenna, rng=rng, tag=config.tag, margin_db=tm.power_margin_db)
    return _tag.PassiveTag(config.tag, antenna, rng=rng)


def simulate_row(config: Config, row: int, seed: int) -> dict[str, np.ndarray]:
    """Every draw of the d_e value ``row``, each one air step with all d_tt listeners.

    Per draw k the listeners stand at distance d_tt around the tag at uniform azimuths; one
    :func:`rfsim.air.step.propagate` step carries the exciter's CW and the tag's frame to all of
    them, then the sense-a-tag receive chain decodes every listener's input at once.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    row : int
        Index of d_e in ``config.sweep.exciter_distance_m``.
    seed : int
        Root seed; draw k uses ``trial_rng(seed, row, k, j)`` (module docstring).

    Returns
    -------
    dict of str to ndarray, shape (n_draws * n_dtt,)
        One entry per (draw, d_tt): the distances [m], draw, listener azimuth [rad], the
        tag's incident and chip power [W], whether it replied, the CW and backscatter
        amplitudes at the listener [V], the backscatter phase [rad], the envelope
        differences ``sync_v``, ``closed_diff_v`` (Eq. 3.3) and ``diff_v`` [V], and
        ``decoded``.
    """
    g, fr, sw = config.geometry, config.frame, config.sweep
    d_e = sw.exciter_distance_m[row]
    d_tt = np.asarray(sw.tag_distance_m, float)
    n = d_tt.size
    frame = build_frame(payload(config), fr, stamp_cycles=0)
    rx = _sense_a_tag.make_receiver(config.listener, fs_hz=fr.fs_hz, blf_hz=fr.blf_hz, m=fr.m, trext=fr.trext)
    exciter = Exciter(config.exciter, exciter_antenna(g.exciter_antenna, g.exciter_gain_dbi, g.height_m),
                      rng=trial_rng(seed, row, 0, 4))
    tag_pos = np.array([d_e, 0.0, g.height_m])
    tag_ant = _antennas.vertical_dipole(tag_pos)
    template = _antennas.vertical_dipole(np.zeros(3))
    sc, fc = room(g.apdp), config.exciter.fc_hz
    noise_w = config.noise.power_w(fr.fs_hz)
    i1, i2 = int(np.flatnonzero(frame.stamp.levels > 0)[-1]), int(np.flatnonzero(frame.stamp.levels < 0)[-1])
    parts, inputs = [], []
    for k in range(sw.n_draws):
        phi = trial_rng(seed, row, k, 0).uniform(-np.pi, np.pi, n)
        lis = BatchAntenna(template, tag_pos + np.stack([d_tt * np.cos(phi), d_tt * np.sin(phi), np.zeros(n)], axis=1))
        device = make_tag(config, tag_ant, trial_rng(seed, row, k, 3))
        air = tag_broadcast_step(sc, exciter, OwnSchedule(device, frame), lis, fc_hz=fc, fs_hz=fr.fs_hz,
                                 n_samples=frame.n_samples, bandwidth_hz=2.0 * fr.blf_hz, noise_power_w=noise_w,
                                 link_rng=trial_rng(seed, row, k, 1), noise_rng=trial_rng(seed, row, k, 2),
                                 keep_components=True)
        resp = air.reflections[0]
        op = device.operating_point
        cw = V_PER_SQRT_W * np.broadcast_to(air.direct[0][..., i1], (n,))
        b1 = V_PER_SQRT_W * np.broadcast_to(air.backscatter[0][0][..., i1], (n,))
        b2 = V_PER_SQRT_W * np.broadcast_to(air.backscatter[0][0][..., i2], (n,))
        g_det = config.listener.detector_gain
        replied = resp.reason == ""
        parts.append(dict(
            exciter_distance_m=np.full(n, d_e), tag_distance_m=d_tt, draw=np.full(n, k), listener_azimuth_rad=phi,
            tag_incident_power_w=np.full(n, float(np.mean(np.abs(air.incident[0].samples) ** 2))),
            tag_chip_power_w=np.full(n, op.p_chip_w if op is not None else np.nan),
            tag_replied=np.full(n, replied),
            a_r_v=np.abs(cw), a_t1_v=np.abs(b1), a_t2_v=np.abs(b2), theta_rad=np.angle(b1 * np.conj(cw)),
            sync_v=g_det * np.abs(np.abs(b1) - np.abs(b2)),
            closed_diff_v=g_det * np.abs(np.abs(cw + b1) - np.abs(cw + b2))))
        inputs.append(np.broadcast_to(air.inputs[0].samples, (n, frame.n_samples)))
    out = concat(parts)
    # the receive chain on every draw of the row at once; a silent tag sends nothing to decode
    chain = RowsChain.run(rx, np.concatenate(inputs))
    replied = out["tag_replied"]
    out["diff_v"] = np.where(replied, chain.level_difference_v(rx, frame), 0.0)
    out["decoded"] = chain.decoded(rx, frame, rows=replied)
    return out


def _task(args):
    return simulate_row(*args)


def monte_carlo(config: Config, *, seed: int) -> dict[str, np.ndarray]:
    """Every d_e row on ``config.sweep.workers`` processes, concatenated in row order.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed.

    Returns
    -------
    dict of str to ndarray
        The columns of :func:`simulate_row` for every row, concatenated.
    """
    tasks = [(config, i, seed) for i in range(len(config.sweep.exciter_distance_m))]
    return concat(map_in_order(_task, tasks, config.sweep.workers, desc="monte carlo", unit="rows"))


# ----------------------------------------------------------------------------- statistics and fits


def point_grid(samples, d_e, d_tt) -> dict[str, np.ndarray]:
    """(n_de, n_dtt) per point: decodes k, draws m, p = k/m with its Clopper–Pearson 95 %
    interval (:func:`rfsim.devices.st_analytic.cancellation_probability`, a binomial proportion),
    medians of the incident power and the envelope differences, the tag's reply fraction.

    Parameters
    ----------
    samples : dict of str to ndarray
        The per-draw columns of :func:`monte_carlo`.
    d_e : ndarray, shape (n_de,)
        Swept exciter→tag distances [m], increasing.
    d_tt : ndarray, shape (n_dtt,)
        Swept tag→listener distances [m], increasing.

    Returns
    -------
    dict of str to ndarray, shape (n_de, n_dtt)
        ``p_decoded``, ``ci_lo``, ``ci_hi``, ``draws`` (m), ``decoded_count`` (k),
        ``median_tag_incident_power_w`` [W], ``median_diff_v``, ``median_sync_v`` [V] and
        ``tag_replied_fraction``.
    """
    i = np.searchsorted(d_e, samples["exciter_distance_m"])
    j = np.searchsorted(d_tt, samples["tag_distance_m"])
    shape = (len(d_e), len(d_tt))
    keys = {"p_decoded": None, "ci_lo": None, "ci_hi": None, "draws": None, "decoded_count": None,
            "median_tag_incident_power_w": "tag_incident_power_w", "median_diff_v": "diff_v",
            "median_sync_v": "sync_v", "tag_replied_fraction": "tag_replied"}
    out = {k: np.empty(shape) for k in keys}
    for a in range(shape[0]):
        for b in range(shape[1]):
            sel = (i == a) & (j == b)
            dec = samples["decoded"][sel]
            out["p_decoded"][a, b], out["ci_lo"][a, b], out["ci_hi"][a, b], out["draws"][a, b] = (
                sa.cancellation_probability(dec))
            out["decoded_count"][a, b] = dec.sum()
            for k, src in keys.items():
                if src is not None:
                    v = samples[src][sel]
                    out[k][a, b] = v.mean() if src == "tag_replied" else np.median(v)
    out["draws"] = out["draws"].astype(int)
    out["decoded_count"] = out["decoded_count"].astype(int)
    return out


def fits(grid, d_e, d_tt) -> dict:
    """Per-row Eq. (6.5) fits, and over the rows where the tag runs (it ran in at least half
    of the draws) the pooled fit and the fit with a d_e term (module docstring).

    Parameters
    ----------
    grid : dict of str to ndarray
        The point grid of :func:`point_grid`.
    d_e : ndarray, shape (n_de,)
        Exciter→tag distances [m].
    d_tt : ndarray, shape (n_dtt,)
        Tag→listener distances [m].

    Returns
    -------
    dict
        ``"rows"``: one :class:`~rfsim.detection.tag_to_tag.Eq65Fit` per d_e row, p(d_tt) =
        1/(1 + exp(a1 + a2·d_tt)); ``"pooled"``: the same over the rows where the tag runs;
        ``"extended"``: with a d_e term, 1/(1 + exp(a1 + a2·d_tt + a3·d_e)), over those rows;
        ``"runs"``: bool ndarray, shape (n_de,), the rows where the tag runs.
    """
    k, m = grid["decoded_count"], grid["draws"]
    rows = [fit_eq65(_detection.ts_design(d_tt), k[a], m[a]) for a in range(len(d_e))]
    runs = grid["tag_replied_fraction"].mean(axis=1) >= 0.5
    dd_e, dd_tt = np.meshgrid(d_e[runs], d_tt, indexing="ij")
    kk, mm = k[runs].ravel(), m[runs].ravel()
    pooled = fit_eq65(_detection.ts_design(dd_tt.ravel()), kk, mm)
    extended = fit_eq65(np.column_stack([np.ones(dd_e.size), dd_tt.ravel(), dd_e.ravel()]), kk, mm)
    return {"rows": rows, "pooled": pooled, "extended": extended, "runs": runs}


# ----------------------------------------------------------------------------- run


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate the exciter-powered tag-to-tag link over (d_e, d_tt) and fit the logistic model.

    The decode probability of Geng's reader-free network (binary-detection.md §1.11
    Eq. (6.5); seed 004 L1049–1127; auris-sense-a-tag.md ch. 5 for the exciter) at sample
    level, with the Eq. (6.5) fits of :func:`fits`.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed (the streams of the module docstring).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Table ``samples`` (one row per draw and point), grid ``points`` over (d_e, d_tt)
        (decode probability with Clopper–Pearson 95 % interval, medians), table
        ``eq65_rows`` (per d_e: a1, a2 with standard errors, d50 [m], fit status, whether
        d50 lies in the sweep, whether the tag runs); root attributes with the pooled and
        extended fits, d50 at the median exciter distance and its spread [m], the exciter
        EIRP and the noise power [W].
    """
    samples = monte_carlo(config, seed=seed)
    d_e = np.asarray(config.sweep.exciter_distance_m, float)
    d_tt = np.asarray(config.sweep.tag_distance_m, float)
    ds = _dataset.Dataset(title="exciter-powered tag-to-tag link: decode probability vs d_e, d_tt and Eq. (6.5) fits")
    ds.add_table("samples", {k: _dataset.column(v, unit_of(k), _describe(k)) for k, v in samples.items()},
                 description=_GROUPS["samples"])
    grid = point_grid(samples, d_e, d_tt)
    dims = ("exciter_distance_m", "tag_distance_m")
    ds.add_grid("points", {"exciter_distance_m": _dataset.column(d_e, "m", "exciter -> tag distance d_e"),
                           "tag_distance_m": _dataset.column(d_tt, "m", "tag -> listener distance d_tt")},
                {k: _dataset.column(v, unit_of(k), _describe(k), dims=dims) for k, v in grid.items()},
                description=_GROUPS["points"])
    f = fits(grid, d_e, d_tt)
    rows = f["rows"]
    d50 = np.array([r.d50_m for r in rows])
    in_range = np.array([r.status == "ok" for r in rows]) & (d50 >= d_tt[0]) & (d50 <= d_tt[-1])
    ds.add_table("eq65_rows", {
        "exciter_distance_m": _dataset.column(d_e, "m", "exciter -> tag distance d_e of the row"),
        "a1": _dataset.column(np.array([r.coefficients[0] for r in rows]), "1", "Eq. (6.5) a1 (NaN: no finite fit)"),
        "a2": _dataset.column(np.array([r.coefficients[1] for r in rows]), "1/m", "Eq. (6.5) a2 on d_tt"),
        "a1_stderr": _dataset.column(np.array([r.stderr[0] for r in rows]), "1", "standard error of a1"),
        "a2_stderr": _dataset.column(np.array([r.stderr[1] for r in rows]), "1/m", "standard error of a2"),
        "d50_m": _dataset.column(np.array([r.d50_m for r in rows]), "m", "d_tt where the fitted p = 0.5 (-a1/a2)"),
        "d50_stderr_m": _dataset.column(np.array([r.d50_stderr_m for r in rows]), "m", "delta-method standard error of d50"),
        "fit_status": _dataset.column(np.array([r.status for r in rows]), "1", "ok, or why the fit has no finite maximum"),
        "d50_in_range": _dataset.column(in_range, "1", "fit ok and d50 inside the swept d_tt (p crosses 0.5 in the sweep)"),
        "tag_runs": _dataset.column(f["runs"], "1", "the tag ran in at least half of the draws (row used by the pooled fits)")},
        description=_GROUPS["eq65_rows"])
    for name, fit in (("pooled", f["pooled"]), ("extended", f["extended"])):
        ds.attrs[f"eq65_{name}_status"] = fit.status
        for c, (a, se) in enumerate(zip(fit.coefficients, fit.stderr)):
            ds.attrs[f"eq65_{name}_a{c + 1}"] = float(a)
            ds.attrs[f"eq65_{name}_a{c + 1}_stderr"] = float(se)
    ds.attrs["eq65_pooled_d50_m"] = f["pooled"].d50_m
    ds.attrs["eq65_fit_rows_max_exciter_distance_m"] = float(d_e[f["runs"]].max()) if f["runs"].any() else float("nan")
    if in_range.any():
        med = float(np.median(d_e[in_range]))
        ds.attrs["median_exciter_distance_m"] = med
        ds.attrs["d50_at_median_exciter_distance_m"] = float(np.interp(med, d_e[in_range], d50[in_range]))
        ds.attrs["d50_min_m"], ds.attrs["d50_max_m"] = float(np.min(d50[in_range])), float(np.max(d50[in_range]))
    ds.attrs["tag_runs_up_to_m"] = float(d_e[f["runs"]].max()) if f["runs"].any() else float("nan")
    ds.attrs["exciter_eirp_w"] = float(10.0 ** ((config.exciter.eirp_dbm - 30.0) / 10.0))
    ds.attrs["noise_power_w"] = config.noise.power_w(config.frame.fs_hz)
    for key in [k for k, v in ds.attrs.items() if isinstance(v, float) and not np.isfinite(v)]:
        ds.attrs[f"{key}_meaning"] = ("NaN: not estimable from this run (the fit has no finite maximum — see "
                                      "its _status — or no swept row where the tag runs)")
    return ds


_TEXT = {
    "tag_incident_power_w": "CW power incident at the tag antenna port",
    "tag_chip_power_w": "power absorbed by the tag chip ('measured' model; NaN otherwise)",
    "tag_replied": "the tag was powered and sent its frame",
    "a_r_v": "exciter CW amplitude at the listener (50 ohm peak)",
    "a_t1_v": "tag backscatter amplitude at the listener, state +1 (50 ohm peak)",
    "a_t2_v": "tag backscatter amplitude at the listener, state -1 (50 ohm peak)",
    "theta_rad": "phase of the backscatter (state +1) relative to the CW at the listener",
    "sync_v": "detector difference with the CW synchronised to the backscatter, g*||B1|-|B2||",
    "closed_diff_v": "closed-form detector difference g*||C+B1|-|C+B2|| (Eq. 3.3) from the step's phasors",
    "diff_v": "sample-level envelope-detector difference |A(+1)-A(-1)| over the reply",
    "decoded": "the listener decoded the 32 bits exactly",
    "p_decoded": "decode probability k/m",
    "ci_lo": "Clopper-Pearson 95% lower bound of p_decoded",
    "ci_hi": "Clopper-Pearson 95% upper bound of p_decoded",
    "decoded_count": "number of draws at the point in which the listener decoded the frame exactly (k)",
    "draws": "number of channel draws simulated at the point (m)",
    "tag_replied_fraction": "fraction of the point's draws in which the tag was powered and sent its frame",
    "draw": "index of the channel draw at its (d_e, d_tt) point",
    "exciter_distance_m": "distance d_e from the exciter to the tag",
    "tag_distance_m": "distance d_tt from the tag to the listener",
    "listener_azimuth_rad": "azimuth of the listener around the tag, uniform in [0, 2 pi)",
}

#: Description of each table and grid.
_GROUPS = {
    "samples": "one row per channel draw at every (d_e, d_tt) point: incident power, amplitudes and envelope "
               "differences at the listener, decoded or not",
    "points": "the (d_e, d_tt) grid: decode counts and probability with Clopper-Pearson intervals, medians of "
              "the incident power and the envelope differences",
    "eq65_rows": "the Eq. (6.5) logistic fit p = 1/(1 + exp(-(a1 + a2 d_tt))) per exciter distance d_e, with "
                 "standard errors and d50",
}


def _describe(key: str) -> str:
    base = key[7:] if key.startswith("median_") else key
    text = _TEXT.get(base, base.replace("_", " "))
    return f"median over draws: {text}" if key.startswith("median_") else text


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """``<stem>-heatmap.png``: left, the decode probability over (d_e, d_tt) with the fitted
    50 % contours (Eq. (6.5) per d_e with its standard error, and the pooled fit with the d_e
    term), cells where the tag never replied (not powered) hatched instead of drawn as 0 %;
    right, the decode probability against d_tt at three exciter distances with its
    Clopper-Pearson 95 % intervals and the Eq. (6.5) fit of that row.

    Drawn by :mod:`rfsim.scenarios._exciter_link_figures`.

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
    return _figures.plot(dataset_path, out_dir)


__all__ = ["NAME", "DESCRIPTION", "Config", "run", "plot", "simulate_row", "point_grid", "fits", "payload"]

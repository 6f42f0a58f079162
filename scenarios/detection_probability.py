"""Scenario ``detection-probability``: does a sense-a-tag (ST) near a tag decode the tag's
reply? A dataset for the ST-to-tag detection models TS and RTS and their maximum-likelihood
fits (auris-sense-a-tag.md §2.2 Eqs. 4.6-4.8, §3.3 "Detection-model data", §4.2 R4-1; seed
003 L3811-3906).

Geometry (§3.3, L3823-3833): reader antenna at the origin, boresight +x; tag uniform in the
cuboid x ∈ [1, 8] m, y, z ∈ [−4, 4] m; ST centre uniform in a ball of radius 2 m around the
tag. *Sampling rule*: isotropic direction and distance r **uniform in [0, 2] m** by default
(``geometry.st_sampling = "radius"``); ``"volume"`` draws r = 2·u^(1/3) (uniform in the ball's
volume). The source says only "random in a sphere" (L3831-3833). The choice matters: the
published models' expected cross-entropy on the source geometry (Monte Carlo over 2·10⁵
draws of this geometry, p from the published coefficients) is RTS 0.169 / TS 0.210 with
radius sampling and 0.062 / 0.077 with volume sampling, against the published test values
0.1278 / 0.1502 — radius sampling is the closer reading (volume sampling puts 7/8 of the
STs beyond 1 m, where p ≈ 0, and leaves few detections to fit). The ST is the dual-antenna
device of the source (L3819-3821): two vertical λ/2 dipoles λ/4 apart at a uniformly random
azimuth (:mod:`rfsim.devices.sense_a_tag`), technique ``st.technique`` (default: receiving-path
selection, Algorithm 1). The tag is a vertical half-wave dipole facing the reader antenna.

Reader antenna: a circularly polarised panel like the RFMAX S9028PCRJ (902-928 MHz,
L3811-3817; its pattern, Fig. 4.3, is not in the text), modelled analytically by
:class:`rfsim.channels.Patch` with 9 dBic peak gain, 70° half-power beamwidth in both planes and
20 dB front-to-back ratio (the panel's data-sheet class; the pattern is rotationally
symmetric, ``G(ψ) = G₀[(1 − b)cos^q ψ + b]``), 30 dBm at its port (L3815). Its polarisation
is elliptical with an axial ratio growing off boresight (:class:`EllipticalPanel`, 1 dB on
boresight, 3 dB at the beam edge, ``geometry.axial_ratio_db``), and the tag dipole is rolled
about its line to the panel by a uniform ±90° (``geometry.tag_roll_deg``; the source does not
say how its tags were oriented), so the polarisation mismatch follows the two orientations
(between 1/(1 + r²) and r²/(1 + r²), r = 1/AR) instead of the constant 3 dB of an ideal
circular panel. Channel "room" (L3817): Friis and the
exponential APDP with the PASS room curves (:class:`rfsim.channels.ApdpModel` defaults), no
surfaces (the source's cuboid spans z = −4…4 m around the antenna: no floor).

One sample = one sample-level Query round with a fresh channel draw and a random hop
channel (FCC plan, the reader's random hop table): the reader sends a Query (Q = 0, link
profile ``pass-miller2-48k`` at 1 MS/s, as the source's PASS runs); the tag receives it
through its forward link, decodes it and answers its RN16 with Γ(t)
(:class:`rfsim.devices.tag.PassiveTag`). One step of the air interface (:func:`rfsim.air.step.propagate`)
carries the round: the ST antennas receive the reader's segment and the tag's re-radiated
field (A_s − Γ(t))·incident, the ST receive chain (linear detector, band-pass, 5 mV
comparator, Miller decoder) runs from the end of the command and the outcome ``st_detected``
is "the ST decoded the tag's RN16 exactly". In the same step the reader's port
(:class:`rfsim.protocols.engine.ReaderPort`) hears the reply through the reciprocal backward link with
TX leakage and receiver noise (``reader_detected``: RN16 bits exact, as
:func:`rfsim.protocols.engine.run_exchange` judges them). No noise at the ST (the source's threshold decides, as in
``phase-cancellation``).

Features (:func:`rfsim.detection.st_features`): D = |tag − antenna|, d = |ST − tag|,
θ = arcsin(v_y/D), φ = arcsin(v_z/D), v = tag − antenna. Samples with index < ``n_train``
form the training set, the rest the test set (3000 + 1000 by default, L3825-3829, L3900).

Differences from the source (R4-1) and why. A default run (seed 1; 4000 samples) detects
5.7 % of the samples; the tag replies in only 44 % of them: the tag (the project's
UCODE-class chip, −12.8 dBm, on a half-wave dipole) is often not powered where the panel
pattern and the dipole's pattern are low. The orientation-dependent polarisation mismatch
(elliptical panel, rolled tags) replaced the constant 3 dB without changing that (42 % of
the samples replied before): the angle terms still dominate. Fits side by side (train 3000,
test 1000): RTS fit a = (−8.20, 0.773, 7.39, 4.10, 5.76), test cross-entropy 0.136, against
the published (−1.462, 0.4941, 2.506, 0.0126, 0.0523) and 0.1278 (the published coefficients
score 0.164 on this test set); TS fit (0.019, 5.37), 0.181, against (0.8970, 2.4443) and
0.1502 (published coefficients here: 0.181). Ordering: the source has a2 ≫ a1 ≫ a3, a4 ("orientation
matters little", L3858-3869: its tags were evidently powered throughout the cuboid); here
a2 > a4 > a3 > a1. The ST's reach is set by the 5 mV threshold with ``st.detector_gain`` = 1;
the fitted d coefficient (7.4 /m) is steeper than the published 2.5 /m (a hard threshold on
a deterministic backscatter level, softened only by the APDP draw, the hop channel and phase
cancellation). The published TS and RTS imply different base rates: TS never exceeds
p = 0.29 (a0 > 0) while RTS reaches 0.72 at D = 1 m, d = 0, so the two cannot both describe
the same data's detection rate near the tag. Curves at θ = φ = 0 lie far above
angle-averaged binned data, so the plot draws them at the samples' median angles and also
shows the fitted models averaged over each bin's samples. Every run writes the comparison
(coefficients with standard errors beside the published, cross-entropies, the order of the
coefficients by size) to the attribute ``fits_vs_published`` and the cause to
``fits_difference_cause``; the slow test
``test_default_run_fits_pin_the_documented_difference_from_the_published_models`` pins it.

Randomness: sample i draws everything from ``trial_rng(s, i, k)``, s = ``samples.seed``
(or the run seed when it is −1): k = 0 geometry, 1 reader (hop table), 2 tag, 3 channel
(all links), 4 reader noise, 5 tag roll. A run over ``samples.first``…``first + count − 1`` therefore
gives the same rows as any split of that range into blocks (the sweep
``examples/sweeps/detection-probability.toml`` runs blocks in parallel; the merged
``samples`` table is the full table and :func:`fit_file` fits it). A run itself simulates its samples in
blocks (32, then 256 each) on ``samples.workers`` processes (default 2), with the same rows for any number.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.channels import Antenna, HalfWaveDipole, Patch
from rfsim.channels.antennas import vertical_dipole
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.core.config import param
from rfsim.core.errors import ConfigError, UserError
from rfsim.core.procs import map_in_order
from rfsim.core.progress import stage
from rfsim.core.rng import trial_rng, trial_rng_grid
from rfsim.core.plots import figure_path, pyplot, save_figure
from rfsim.core.references import cite
from rfsim.core.lazy import lazy_import

_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_bulk = lazy_import("rfsim.channels.bulk")
sa = lazy_import("rfsim.devices.st_analytic")
_reader = lazy_import("rfsim.devices.reader")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
_tag = lazy_import("rfsim.devices.tag")
_air = lazy_import("rfsim.air.step")
_batch = lazy_import("rfsim.protocols.batch")
_dataset = lazy_import("rfsim.core.dataset")
_detection = lazy_import("rfsim.detection")
_commands = lazy_import("rfsim.gen2.commands")
_engine = lazy_import("rfsim.protocols.engine")
_link = lazy_import("rfsim.gen2.link")

#: modules the figures use (imported by the runner while the simulation runs)
FIGURE_IMPORTS = ("rfsim.detection", "scipy.special")
NAME = "detection-probability"
DESCRIPTION = ("sense-a-tag detection of a tag's reply vs (D, d, θ, φ): 3000 + 1000 sample-level Query "
               "rounds, ML fits of the TS and RTS models (AURIS dissertation Eqs. 4.6-4.8)")

PANEL_GAIN_DBIC = 9.0
PANEL_BEAMWIDTH_DEG = 70.0
PANEL_FRONT_TO_BACK_DB = 20.0
MODELS = ("RTS", "TS")
RTS_NAMES = ("a0", "a1_D", "a2_d", "a3_abs_theta", "a4_abs_phi")
TS_NAMES = ("a0", "a1_d")


@dataclass(frozen=True)
class SampleConfig:
    first: int = param(0, lo=0, hi=10**9, doc="index of the first sample of this run")
    count: int = param(4000, lo=1, hi=10**7, doc="samples in this run (first … first+count-1)")
    n_train: int = param(3000, lo=0, hi=10**7, doc="samples with index < n_train are training, the rest test")
    seed: int = param(-1, lo=-1, hi=2**62, doc="seed of the sample streams; -1 = the run seed (set it in sweeps)")
    workers: int = param(2, lo=0, hi=256, doc="worker processes for the blocks of samples (0 = all cores, 1 = in "
                                              "process); the rows do not depend on it")


@dataclass(frozen=True)
class GeometryConfig:
    tag_x_m: tuple[float, float] = param((1.0, 8.0), lo=0.05, hi=100.0, unit="m", doc="tag x range")
    tag_y_m: tuple[float, float] = param((-4.0, 4.0), lo=-100.0, hi=100.0, unit="m", doc="tag y range")
    tag_z_m: tuple[float, float] = param((-4.0, 4.0), lo=-100.0, hi=100.0, unit="m", doc="tag z range")
    st_radius_m: float = param(2.0, lo=0.05, hi=20.0, unit="m", doc="ST centre within this distance of the tag")
    st_sampling: Literal["volume", "radius"] = param(
        "radius", doc="ST centre uniform in the ball's volume, or distance uniform in [0, radius]")
    min_st_distance_m: float = param(0.05, lo=0.0, hi=1.0, unit="m",
                                     doc="ST centres closer to the tag are redrawn (near field, λ/2π)")
    reader_gain_dbic: float = param(PANEL_GAIN_DBIC, lo=0.0, hi=15.0, unit="dBic", doc="panel peak gain")
    reader_beamwidth_deg: float = param(PANEL_BEAMWIDTH_DEG, lo=20.0, hi=170.0, unit="deg",
                                        doc="panel half-power beamwidth")
    apdp: bool = param(True, doc="exponential APDP small scale (PASS room curves)")
    axial_ratio_db: tuple[float, float] = param(
        (1.0, 3.0), lo=0.0, hi=40.0, unit="dB",
        doc="panel axial ratio on boresight and at half the beamwidth off it (grows with the square of the "
            "angle; data-sheet class of circular panels); (0, 0) = ideal circular (3 dB to a linear tag)")
    tag_roll_deg: float = param(90.0, lo=0.0, hi=180.0, unit="deg",
                                doc="tag roll about its horizontal line to the reader, uniform in +-this "
                                    "(tag orientation unknown in the source; 0 = vertical dipoles)")

    def __post_init__(self):
        for key in ("tag_x_m", "tag_y_m", "tag_z_m"):
            lo, hi = getattr(self, key)
            if not lo < hi:
                raise ConfigError(f"geometry.{key}", getattr(self, key), "[low, high] with low < high")


def _reader_default() -> ReaderConfig:
    # PASS link (Miller-2, BLF 48 kHz) at 1 MS/s, 30 dBm, FCC hopping (L3815)
    return ReaderConfig(link_profile="pass-miller2-48k", fs_hz=1e6, ptx_dbm=30.0, hopping=True)


@dataclass(frozen=True)
class Config:
    samples: SampleConfig = param(SampleConfig(), doc="which samples this run simulates")
    geometry: GeometryConfig = param(GeometryConfig(), doc="placement, reader panel, channel")
    reader: ReaderConfig = param(_reader_default(), doc="reader")
    tag: TagConfig = param(TagConfig(), doc="tag")
    st: SenseATagConfig = param(SenseATagConfig(), doc="sense-a-tag (technique, threshold, detector gain)")
    fits: bool = param(True, doc="fit TS/RTS on the run's samples (off for sample blocks of a sweep)")

    def __post_init__(self):
        if self.st.technique == "stamp":
            raise ConfigError("st.technique", self.st.technique, "'single', 'combination' or 'selection'")


# ----------------------------------------------------------------------------- one sample


@dataclass(frozen=True, eq=False)
class EllipticalPanel(Antenna):
    """A circularly polarised panel whose axial ratio grows off boresight.

    ``AR(ψ) [dB] = AR0 + (AR1 − AR0)·(ψ/(BW/2))²`` for the angle ψ between the boresight axis
    and the propagation line (data-sheet class of patch panels: ≈ 1 dB on boresight, ≈ 3 dB at
    the beam edge). The polarisation vector for propagation along k is the ellipse
    ``(û − j·h·r·v̂)/sqrt(1 + r²)``, r = 1/AR (field ratio, linear), major axis û along the
    panel's vertical projected ⊥ k, ``v̂ = k × û``, h = +1 for RHCP. Against a linear antenna
    whose axis makes the angle τ with û the mismatch is ``(cos²τ + r²·sin²τ)/(1 + r²)``: 1/2
    for AR = 0 dB (the constant 3 dB), between ``1/(1 + r²)`` and ``r²/(1 + r²)`` otherwise.
    """

    axial_ratio_db: tuple = (1.0, 3.0)
    half_beamwidth_rad: float = math.radians(35.0)

    @functools.cached_property
    def _boresight_and_up(self) -> tuple[np.ndarray, np.ndarray]:
        """The panel's boresight axis and its vertical in the global frame (rotation of local x, z)."""
        return self.rotation @ np.array([1.0, 0.0, 0.0]), self.rotation @ np.array([0.0, 0.0, 1.0])

    def polarization_vector(self, k) -> np.ndarray:
        k = np.asarray(k, float)
        k = k / np.linalg.norm(k, axis=-1, keepdims=True)
        axis, up = self._boresight_and_up
        psi = np.arccos(np.clip(np.abs(k @ axis), 0.0, 1.0))
        ar0, ar1 = self.axial_ratio_db
        ar_db = ar0 + (ar1 - ar0) * (psi / self.half_beamwidth_rad) ** 2
        r = 10.0 ** (-ar_db / 20.0)[..., None]
        u = up - np.sum(up * k, axis=-1, keepdims=True) * k
        n = np.linalg.norm(u, axis=-1, keepdims=True)
        u = np.where(n > 1e-9, u / np.where(n > 1e-9, n, 1.0), np.array([0.0, 1.0, 0.0]))
        # v = k × u, written out (np.cross's own elementwise products and differences, without
        # its axis handling, which costs more than the products for one direction)
        v = np.stack([k[..., 1] * u[..., 2] - k[..., 2] * u[..., 1], k[..., 2] * u[..., 0] - k[..., 0] * u[..., 2],
                      k[..., 0] * u[..., 1] - k[..., 1] * u[..., 0]], axis=-1)
        h = 1.0 if self.handedness == "rhcp" else -1.0
        return (u - 1j * h * r * v) / np.sqrt(1.0 + r * r)


def reader_antenna(g: GeometryConfig) -> Antenna:
    """The reader panel at the origin, boresight +x, circular polarisation with the axial ratio
    of ``geometry.axial_ratio_db`` (:class:`EllipticalPanel`; module docstring)."""
    return EllipticalPanel(position_m=(0.0, 0.0, 0.0), orientation=(0.0, 0.0, 0.0),
                           pattern=Patch(g.reader_gain_dbic, g.reader_beamwidth_deg, PANEL_FRONT_TO_BACK_DB),
                           polarization="circular", axial_ratio_db=tuple(g.axial_ratio_db),
                           half_beamwidth_rad=math.radians(0.5 * g.reader_beamwidth_deg))


def tag_antenna(position_m, roll_rad: float = 0.0) -> Antenna:
    """A half-wave dipole at ``position_m`` facing the antenna at the origin, rolled by
    ``roll_rad`` about its horizontal line to the antenna (0: vertical)."""
    p = np.asarray(position_m, float)
    return Antenna(position_m=p, orientation=(math.atan2(-p[1], -p[0]), 0.0, float(roll_rad)),
                   pattern=HalfWaveDipole(), polarization="linear")


def scene(g: GeometryConfig) -> _scene.Scene:
    """Free space with the PASS room APDP (no surfaces)."""
    return _scene.Scene(apdp=_small_scale.ApdpModel() if g.apdp else None)


def draw_geometry(g: GeometryConfig, *, rng: np.random.Generator):
    """Tag position, ST centre and ST azimuth of one sample.

    Returns
    -------
    tag_m, st_m : (3,) float64 [m]; orientation_rad : float, azimuth of the SA1→SA2 axis
    """
    tag = np.array([rng.uniform(*g.tag_x_m), rng.uniform(*g.tag_y_m), rng.uniform(*g.tag_z_m)])
    while True:
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        v = rng.random()
        r = g.st_radius_m * (v ** (1.0 / 3.0) if g.st_sampling == "volume" else v)
        if r >= g.min_st_distance_m:
            break
    return tag, tag + r * u, float(rng.uniform(-np.pi, np.pi))


def simulate_sample(config: Config, index: int, seed: int) -> dict[str, float]:
    """One Query round for sample ``index`` (module docstring): geometry, outcomes, features.

    One air step (:func:`rfsim.air.step.propagate`): the reader's segment, the tag, and as receivers
    the reader's own port (TX→RX leakage, backscatter through the reciprocal forward link,
    receiver noise; :class:`rfsim.protocols.engine.ReaderPort`) and the ST antennas (no noise). The ST
    antennas are received in a second call over the same links and the tag's reaction
    replayed, only when the tag replied (the same inputs as receivers of the one step: each
    receiver's input is formed on its own, their links are drawn after the reader's)."""
    return _st_outcomes(config, [_air_sample(config, index, seed)])[0]


#: Random streams of a sample (module docstring, "Randomness"): k = 0 … 5
N_STREAMS = 6


def sample_rngs(index: int, seed: int) -> list:
    """The generators ``trial_rng(seed, index, k)``, k = 0 … :data:`N_STREAMS` − 1, of sample ``index``."""
    return [trial_rng(seed, index, k) for k in range(N_STREAMS)]


def sample_placement(g: GeometryConfig, index: int, seed: int, rngs: list | None = None) -> tuple:
    """Tag position, ST centre, ST azimuth and the rolled tag antenna of sample ``index``
    (streams 0 and 5 of the sample; ``rngs``: its :func:`sample_rngs`, drawn when None)."""
    rngs = sample_rngs(index, seed) if rngs is None else rngs
    tag_pos, st_pos, orient = draw_geometry(g, rng=rngs[0])
    roll = math.radians(g.tag_roll_deg) * rngs[5].uniform(-1.0, 1.0)
    return tag_pos, st_pos, orient, tag_antenna(tag_pos, roll)


def _air_sample(config: Config, index: int, seed: int, ra: Antenna | None = None) -> tuple:
    """The air step and the reader's read of sample ``index`` (:func:`simulate_sample`):
    ``(record without the ST outcomes, ST inputs (k, n) from the listening start or None
    when the tag did not reply, tx, tag response, RN16 bits or None)``. ``ra``: the reader
    antenna (default :func:`reader_antenna` of the geometry; the same for every sample)."""
    record, st_step, tx, resp, bits = _reader_round(config, index, seed, ra)
    return record, None if st_step is None else _st_inputs(st_step), tx, resp, bits


def _reader_round(config: Config, index: int, seed: int, ra: Antenna | None = None, placed: tuple | None = None,
                  reader_tag: tuple | None = None) -> tuple:
    """The first part of :func:`_air_sample`: the step with the reader's port and its read,
    ``(record, ST step or None when the tag did not reply, tx, tag response, RN16 bits or None)``;
    the ST step is the argument of :func:`_st_inputs`. ``placed``: :func:`sample_placement` of
    the sample (drawn when None); ``reader_tag``: the carrier-independent geometry of the
    reader → tag link (:func:`rfsim.channels.bulk.static_placements`; evaluated by the channel when None)."""
    prepared = _reader_step(config, index, seed, ra, placed, reader_tag)
    return _reader_outcome(config, prepared, _batch.propagate_batch([prepared[0]])[0])


def _reader_step(config: Config, index: int, seed: int, ra: Antenna | None, placed: tuple | None,
                 reader_tag: tuple | None, rngs: list | None = None, sc: "_scene.Scene | None" = None) -> tuple:
    """The air step of sample ``index`` prepared (:class:`rfsim.protocols.batch.AirStep`: the reader's
    segment, the tag, the reader's port; links drawn from stream 3, the port's noise from
    stream 4) and what :func:`_reader_outcome` needs of it. ``rngs``: the sample's
    :func:`sample_rngs` (drawn when None; streams 0 and 5 unused when ``placed`` is given);
    ``sc``: the (immutable) :func:`scene` of the geometry, shared by a block's samples."""
    g = config.geometry
    rngs = sample_rngs(index, seed) if rngs is None else rngs
    tag_pos, st_pos, orient, tag_ant = sample_placement(g, index, seed, rngs) if placed is None else placed
    ra = reader_antenna(g) if ra is None else ra
    reader = _reader.Reader(config.reader, [ra], rng=rngs[1])
    tag = _tag.PassiveTag(config.tag, tag_ant, rng=rngs[2])
    lk = reader.link
    q, cw_after_s = _query_round(lk)
    tx = reader.transmit(q, t0_s=0.0, cw_after_s=cw_after_s)
    port = _engine.ReaderPort(reader, ra, tx, reply_bits=16, expect_crc=False)
    # links drawn in the step's order: reader→tag (held both ways), then reader→SA_k, tag→SA_k
    channel = _scene.Channel(scene(g) if sc is None else sc)
    if reader_tag is not None:
        channel.hold_placement(ra, tag.antenna, reader_tag)
    links = _air.LinkTable(channel, rng=rngs[3], reciprocal=True)
    emitter = _air.FixedEmitter(ra, tx, device=reader)
    step = _batch.AirStep([emitter], [tag], [port], links, t0_s=0.0, fs_hz=tx.fs_hz, n_samples=tx.samples.size,
                   rng=rngs[4], bandwidth_hz=2.0 * lk.blf_hz, decide=False)
    return step, index, tag_pos, st_pos, orient, tx


@functools.lru_cache(maxsize=8)
def _query_round(lk) -> tuple:
    """The round's Query (Q = 0, the link's DR, M, TRext) and the CW after it for an RN16
    reply (:func:`rfsim.gen2.link.reply_window_s`) of the (immutable) link profile ``lk``."""
    return _commands.Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0), _link.reply_window_s(lk, 16)


def _reader_outcome(config: Config, prepared: tuple, air, features: tuple | None = None) -> tuple:
    """The reader's read of a step of :func:`_reader_step` (only when the tag replied, as
    :func:`rfsim.protocols.engine.run_exchange`), the sample's record and its ST step. ``features``:
    the sample's (D, d, θ, φ) (:func:`rfsim.detection.st_features`; evaluated when None)."""
    step, index, tag_pos, st_pos, orient, tx = prepared
    st = config.st
    emitter, tag, port, links = step.emitters[0], step.reflectors[0], step.receivers[0], step.links
    resp = air.reflections[0]
    replied = resp.gamma is not None
    bits = np.asarray(resp.reply.bits, np.uint8) if replied else None
    reader_ok = False
    st_step = None
    if replied:  # the reader decodes only when a tag replied, as run_exchange
        read = port.receive(air.inputs[0])
        reader_ok = read.bits is not None and read.success and np.array_equal(read.bits, bits)
        sa_pos = _sense_a_tag.st_antenna_positions(st_pos, n_antennas=st.n_antennas, spacing_m=st.spacing_m,
                                      orientation_rad=orient)
        st_step = (emitter, tag.antenna, resp, links, [vertical_dipole(p) for p in sa_pos], tx, port.reader.link)
    if features is None:
        features = tuple(float(v[0]) for v in _detection.st_features(tag_pos, st_pos))
    big_d, small_d, theta, phi = features
    record = dict(sample=index, tag_x_m=tag_pos[0], tag_y_m=tag_pos[1], tag_z_m=tag_pos[2], st_x_m=st_pos[0],
                  st_y_m=st_pos[1], st_z_m=st_pos[2], st_orientation_rad=orient, D_m=big_d, d_m=small_d,
                  theta_rad=theta, phi_rad=phi, channel_index=tx.channel_index, frequency_hz=tx.fc_hz,
                  tag_incident_power_dbm=float(resp.incident_power_dbm), tag_powered=bool(resp.powered),
                  tag_replied=replied, reader_detected=bool(reader_ok))
    return record, st_step, tx, resp, bits


def _st_inputs(st_step: tuple) -> np.ndarray:
    """The ST antennas' inputs (k, n) from the listening start: the ST antennas as the
    receivers of the same step, after the reader's port (the links drawn after the reader's,
    from the same stream; the tag's reaction replayed). Only when the tag replied: a silent
    tag leaves nothing for an ST to decode, so their links are not drawn then."""
    return _st_inputs_batch([st_step])[0]


def _st_inputs_batch(st_steps: list) -> list[np.ndarray]:
    """:func:`_st_inputs` of many samples as one batch of air steps (:func:`rfsim.protocols.batch.propagate_batch`;
    the ST antennas have no noise)."""
    steps = []
    for emitter, tag_ant, resp, links, st_ants, tx, lk in st_steps:
        steps.append(_batch.AirStep([emitter], [_Replayed(tag_ant, resp)], [_air.AntennaPort(a) for a in st_ants], links,
                             t0_s=0.0, fs_hz=tx.fs_hz, n_samples=tx.samples.size, bandwidth_hz=2.0 * lk.blf_hz,
                             decide=False))
    out = []
    for st_step, st_air in zip(st_steps, _batch.propagate_batch(steps)):
        tx = st_step[5]
        i0 = _sense_a_tag.listen_start_sample(tx.cmd_end_s, t0_s=tx.t0_s, fs_hz=tx.fs_hz)
        out.append(np.stack([seg.samples[i0:] for seg in st_air.inputs]))
    return out


class _Replayed:
    """A reflector that gives again the reaction a tag had in a step (its re-radiation on
    the step's time base), without a second pass through the tag's state machine."""

    def __init__(self, antenna, reflection):
        self.antenna, self._reflection = antenna, reflection

    def reflect(self, incident):
        return self._reflection


def _st_outcomes(config: Config, samples: list) -> list[dict]:
    """The ST chains on SA2 (and SA1, SA1+SA2) of many samples from :func:`_air_sample`, from
    the end of the command, and each sample's technique outcome; the records completed.

    The chains of every sample whose tag replied run as the rows of one
    :func:`rfsim.devices.sense_a_tag.chain_rows` call per receive chain (row by row the same
    filters from the same start states as one sample alone), then each sample is decoded."""
    st = config.st
    two = st.n_antennas == 2
    names = ["sa2"] + (["sa1"] + (["combined"] if st.technique == "combination" else []) if two else [])
    groups: dict = {}  # (BLF, M, TRext, fs, samples) -> indices of the samples whose tag replied
    for k, (_, y, tx, resp, bits) in enumerate(samples):
        if bits is not None:
            groups.setdefault((resp.blf_hz, resp.m, resp.trext, tx.fs_hz, y.shape[1]), []).append(k)
    chains: dict = {}
    for (blf, m, trext, fs, _), ks in groups.items():
        rx = _sense_a_tag.make_receiver(st, fs_hz=fs, blf_hz=blf, m=m, trext=trext)
        rows = []
        for k in ks:
            y = samples[k][1]
            rows.append(y[-1:])
            if two:
                rows.append(y[:1])
                if st.technique == "combination":
                    rows.append(y[:1] + y[-1:])
        env, bp, cmp, tog = _sense_a_tag.chain_rows(rx, np.concatenate(rows))
        for j, k in enumerate(ks):
            sl = slice(j * len(names), (j + 1) * len(names))
            chains[k] = (rx, env[sl], bp[sl], cmp[sl], tog[sl])
    out = []
    t1_max = t1_max_s(config)
    for k, (record, y, tx, resp, bits) in enumerate(samples):
        det = {"st_detected": False, "st_detected_sa2": False, "st_detected_sa1": False, "st_diff_sa2_v": 0.0}
        if bits is not None:
            det = _st_decode(config, chains[k], names, y.shape[1], tx, resp, bits, t1_max)
        out.append({**record, **det})
    return out


def _st_decode(config: Config, chain: tuple, names: list, n: int, tx, resp, bits, t1_max: float) -> dict:
    """Decoding of one sample's ST chain outputs (rows ``names``, ``n`` samples from the
    listening start; every row decoded on its own) and the technique outcome; ``t1_max``:
    :func:`t1_max_s` of the config [s]."""
    st = config.st
    fs = tx.fs_hz
    rx, env, bp, cmp, tog = chain
    i0 = _sense_a_tag.listen_start_sample(tx.cmd_end_s, t0_s=tx.t0_s, fs_hz=fs)
    out = {"st_detected": False, "st_detected_sa2": False, "st_detected_sa1": False, "st_diff_sa2_v": 0.0}
    search = int(math.ceil((t1_max + 2.0 / resp.blf_hz) * fs))
    from rfsim.gen2.linecode import reply_waveform

    t_rel = resp.reply_start_s - i0 / fs
    levels = reply_waveform(resp.reply.bits, m=resp.m, trext=resp.trext, blf_hz=resp.blf_hz, fs_hz=fs,
                            t0_s=t_rel, n_samples=n)
    out["st_diff_sa2_v"] = float(np.abs(_sense_a_tag.level_differences(env[:1], levels, rx))[0])  # row 0: SA2
    ok = _sense_a_tag.decode_rows(rx, env, bp, cmp, tog, rows=np.ones(len(names), bool), expected_bits=bits,
                                  start_sample=0, search_samples=search)
    dec = {name: bool(ok[j]) for j, name in enumerate(names)}
    out["st_detected_sa2"] = dec["sa2"]
    out["st_detected_sa1"] = dec.get("sa1", False)
    if st.technique == "single" or st.n_antennas != 2:
        out["st_detected"] = dec["sa2"]
    elif st.technique == "combination":
        out["st_detected"] = dec["combined"]
    else:
        out["st_detected"] = bool(sa.select_detected(np.array([dec["sa1"]]), np.array([dec["sa2"]]))[0])
    return out


def t1_max_s(config: Config) -> float:
    from rfsim.gen2.link import profile

    return _link.t1(profile(config.reader.link_profile)).max_s


# ----------------------------------------------------------------------------- run and fits


FIELDS = {
    "sample": ("1", "sample index (trial index of the sample's random streams)"),
    "is_test": ("1", "True: test set (index >= samples.n_train); False: training set"),
    "tag_x_m": ("m", "tag x (reader-antenna frame, boresight +x)"),
    "tag_y_m": ("m", "tag y (reader-antenna frame), uniform in the geometry's tag_y_m range"),
    "tag_z_m": ("m", "tag z (reader-antenna frame), uniform in the geometry's tag_z_m range"),
    "st_x_m": ("m", "ST centre x"),
    "st_y_m": ("m", "ST centre y"),
    "st_z_m": ("m", "ST centre z"),
    "st_orientation_rad": ("rad", "azimuth of the ST's SA1->SA2 axis"),
    "D_m": ("m", "D: reader antenna -> tag distance"),
    "d_m": ("m", "d: tag -> ST centre distance"),
    "theta_rad": ("rad", "theta: azimuth, angle between the antenna X-Z plane and antenna->tag"),
    "phi_rad": ("rad", "phi: elevation, angle between the antenna X-Y plane and antenna->tag"),
    "channel_index": ("1", "1-based FCC hop channel of the round"),
    "frequency_hz": ("Hz", "carrier frequency of the round (random FCC hop channel)"),
    "tag_incident_power_dbm": ("dBm", "CW power incident at the tag antenna port"),
    "tag_powered": ("1", "tag powered up"),
    "tag_replied": ("1", "tag decoded the Query and replied its RN16"),
    "reader_detected": ("1", "reader decoded the tag's RN16 exactly"),
    "st_detected": ("1", "ST decoded the tag's RN16 exactly with its technique (the model outcome y)"),
    "st_detected_sa2": ("1", "SA2 (full ST path) alone decoded the RN16"),
    "st_detected_sa1": ("1", "SA1 (receive-only path) alone decoded the RN16 (False with one antenna)"),
    "st_diff_sa2_v": ("V", "sample-level envelope difference |A(+1)-A(-1)| at SA2's detector"),
}


#: Samples whose ST chains run as one batch of rows (:func:`_st_outcomes`).
ST_BLOCK = 256
#: Samples of the first block (run in this process before the pool starts).
WARM_BLOCK = 32


def simulate(config: Config, *, seed: int) -> dict[str, np.ndarray]:
    """Samples ``first … first + count − 1`` as columns (see :data:`FIELDS`).

    The samples run in blocks (the first of :data:`WARM_BLOCK` samples, then of
    :data:`ST_BLOCK`) on ``samples.workers`` processes (:func:`rfsim.core.procs.map_in_order`; the
    first block alone first), concatenated in order: every sample draws only from its own streams and a block
    is the batch of its ST chains, so the rows do not depend on the number of workers."""
    s = config.samples
    base = seed if s.seed < 0 else s.seed
    end = s.first + s.count
    # a small first block runs in this process before the pool (imports, kernels loaded; the
    # workers forked afterwards inherit them), so that little of the run is spent on one core
    cuts = [s.first, *range(min(s.first + WARM_BLOCK, end), end, ST_BLOCK), end]
    tasks = [(config, base, lo, hi) for lo, hi in zip(cuts[:-1], cuts[1:]) if hi > lo]
    parts = map_in_order(_block_task, tasks, s.workers, desc="monte carlo", unit="blocks")
    rows = [r for p in parts for r in p]
    out = {k: np.array([r[k] for r in rows]) for k in FIELDS if k != "is_test"}
    out["is_test"] = out["sample"] >= s.n_train
    return {k: out[k] for k in FIELDS}


def _block_task(args) -> list[dict]:
    """The records of samples ``lo … hi − 1`` (one batch of ST chains, :func:`_st_outcomes`)."""
    config, base, lo, hi = args
    g = config.geometry
    ra = reader_antenna(g)
    rngs = trial_rng_grid(base, range(lo, hi), range(N_STREAMS))  # the samples' streams, seeded at once
    placed = [sample_placement(g, i, base, rngs[i - lo]) for i in range(lo, hi)]
    # the reader → tag geometry of the whole block at once (bit-identical to the channel's own)
    sc = scene(g)
    reader_tag = _bulk.static_placements(sc, ra, [p[3] for p in placed])
    # the air steps of the block's samples as one batch, then each sample's read
    prepared = [_reader_step(config, i, base, ra, placed[i - lo], reader_tag[i - lo], rngs[i - lo], sc)
                for i in range(lo, hi)]
    airs = _batch.propagate_batch([p[0] for p in prepared])
    # the features of the block's samples at once (element by element the same operations)
    features = list(zip(*(v.tolist() for v in _detection.st_features([p[0] for p in placed], [p[1] for p in placed]))))
    rounds = [_reader_outcome(config, p, air, f) for p, air, f in zip(prepared, airs, features)]
    # the ST links of every sample whose tag replied at once: reader → SA_k and tag → SA_k
    steps = [r[1] for r in rounds if r[1] is not None]
    sa = [a for step in steps for a in step[4]]
    from_reader = _bulk.static_placements(sc, ra, sa)
    from_tag = _bulk.static_placements(sc, [step[1] for step in steps for _ in step[4]], sa)
    j = 0
    for emitter, tag_ant, _, links, antennas, _, _ in steps:
        for a in antennas:
            links.channel.hold_placement(emitter.antenna, a, from_reader[j])
            links.channel.hold_placement(tag_ant, a, from_tag[j])
            j += 1
    inputs = iter(_st_inputs_batch(steps))
    return _st_outcomes(config, [(rec, None if step is None else next(inputs), tx, resp, bits)
                                 for rec, step, tx, resp, bits in rounds])


def fit_models(samples: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """ML fits of RTS and TS on the training rows, cross-entropies on both sets.

    Parameters
    ----------
    samples : dict with ``D_m``, ``d_m``, ``theta_rad``, ``phi_rad``, ``st_detected``, ``is_test``

    Returns
    -------
    dict of (4,) columns, rows (RTS fit, RTS published, TS fit, TS published): ``model``,
    ``source``, ``a0`` … ``a4`` (NaN where the model has no such term; RTS order
    1, D, d, |θ|, |φ|; TS 1, d), ``se_a0`` … ``se_a4`` (NaN for published rows),
    ``train_cross_entropy``, ``test_cross_entropy`` (Eq. 4.8 [nat]; the published rows give the
    published coefficients evaluated on this data, and ``published_test_cross_entropy`` the
    source's value), ``expected_test_cross_entropy`` (entropy of the fitted model's own
    predictions on the test features), ``n_train``, ``n_test``, ``n_train_detected``,
    ``n_test_detected``.

    Raises
    ------
    UserError
        when a set is empty or the training outcomes are all equal (no finite ML estimate).
    """
    y = np.asarray(samples["st_detected"], bool)
    test = np.asarray(samples["is_test"], bool)
    train = ~test
    if train.sum() < 3 or test.sum() < 1:
        raise UserError(f"fits need training and test samples (have {train.sum()} / {test.sum()})")
    if y[train].all() or not y[train].any():
        raise UserError("fits need both outcomes in the training set")
    x_rts = _detection.rts_design(samples["D_m"], samples["d_m"], samples["theta_rad"], samples["phi_rad"])
    x_ts = _detection.ts_design(samples["d_m"])
    cols: dict[str, list] = {k: [] for k in ("model", "source", *[f"a{i}" for i in range(5)],
                                             *[f"se_a{i}" for i in range(5)], "train_cross_entropy",
                                             "test_cross_entropy", "published_test_cross_entropy",
                                             "expected_test_cross_entropy", "n_train", "n_test",
                                             "n_train_detected", "n_test_detected")}
    for name, x, pub, pub_ce in (("RTS", x_rts, _detection.RTS_COEFFICIENTS, _detection.RTS_TEST_CROSS_ENTROPY),
                                 ("TS", x_ts, _detection.TS_COEFFICIENTS, _detection.TS_TEST_CROSS_ENTROPY)):
        fit = _detection.fit_logistic(x[train], y[train].astype(float))
        for source, coef, se in (("fit", fit.coefficients, fit.stderr), ("published", pub, np.full(pub.size, np.nan))):
            cols["model"].append(name)
            cols["source"].append(source)
            for i in range(5):
                cols[f"a{i}"].append(float(coef[i]) if i < coef.size else np.nan)
                cols[f"se_a{i}"].append(float(se[i]) if i < coef.size else np.nan)
            cols["train_cross_entropy"].append(_detection.cross_entropy(y[train], _detection.predict_proba(x[train], coef)))
            cols["test_cross_entropy"].append(_detection.cross_entropy(y[test], _detection.predict_proba(x[test], coef)))
            cols["published_test_cross_entropy"].append(pub_ce)
            cols["expected_test_cross_entropy"].append(_detection.expected_cross_entropy(_detection.predict_proba(x[test], coef))[0])
            cols["n_train"].append(int(train.sum()))
            cols["n_test"].append(int(test.sum()))
            cols["n_train_detected"].append(int(y[train].sum()))
            cols["n_test_detected"].append(int(y[test].sum()))
    return {k: np.array(v) for k, v in cols.items()}


FIT_UNITS = {"a1": "1/m", "a2": "1/m", "a3": "1/rad", "a4": "1/rad"}


def _fits_table(fits: dict[str, np.ndarray]) -> dict:
    desc = {"model": "RTS (Eq. 4.6) or TS (Eq. 4.7)", "source": "'fit' (ML on the training set) or 'published' (R4-1)",
            "train_cross_entropy": "Eq. 4.8 on the training set", "test_cross_entropy": "Eq. 4.8 on the test set",
            "published_test_cross_entropy": "the source's test cross-entropy (RTS 0.1278, TS 0.1502)",
            "expected_test_cross_entropy": "mean binary entropy of the model's test predictions",
            "n_train": "training samples (index < samples.n_train) the fit used",
            "n_test": "test samples (index >= samples.n_train) the cross-entropy is taken over",
            "n_train_detected": "training samples in which the ST detected the tag (y = 1)",
            "n_test_detected": "test samples in which the ST detected the tag (y = 1)"}
    out = {}
    for k, v in fits.items():
        base = k[3:] if k.startswith("se_") else k
        unit = "nat" if "cross_entropy" in k else FIT_UNITS.get(base, "1")
        if k.startswith("a") and k[1:].isdigit():
            text = f"coefficient {k} of p = 1/(1+exp(x.a)); RTS x = (1, D, d, |theta|, |phi|), TS x = (1, d)"
        elif k.startswith("se_"):
            text = f"standard error of {base} (inverse Fisher information)"
        else:
            text = desc.get(k, k.replace("_", " "))
        out[k] = _dataset.column(v, unit, text)
    return out


def fit_file(path) -> dict[str, np.ndarray]:
    """:func:`fit_models` on the ``samples`` table of a dataset file (a run or a merged sweep).

    Rows are ordered by sample index first and duplicate indices rejected (a merged sweep
    holds each block once).
    """
    from rfsim.core.dataset import read_table

    s = read_table(path, "samples")
    order = np.argsort(s["sample"], kind="stable")
    if np.unique(s["sample"]).size != s["sample"].size:
        raise UserError(f"{path}: duplicate sample indices in the samples table")
    return fit_models({k: np.asarray(v)[order] for k, v in s.items()})


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    samples = simulate(config, seed=seed)
    ds = _dataset.Dataset(title="sense-a-tag detection probability vs (D, d, theta, phi) (AURIS dissertation Eqs. 4.6-4.8)")
    ds.add_table("samples", {k: _dataset.column(v, *FIELDS[k]) for k, v in samples.items()},
                 description="one row per sample: one Query round with a fresh geometry and channel; features "
                             "D, d, theta, phi and whether the ST (and the reader) decoded the tag's RN16")
    ds.attrs["st_sampling"] = (f"ST centre uniform in the {config.geometry.st_radius_m:g} m ball's "
                               + ("volume (r = R u^(1/3))" if config.geometry.st_sampling == "volume"
                                  else "radius (r = R u)") + ", isotropic direction")
    ds.attrs["reader_antenna"] = (f"analytic circular panel (RFMAX S9028PCRJ class): {config.geometry.reader_gain_dbic:g} "
                                  f"dBic, {config.geometry.reader_beamwidth_deg:g} deg beamwidth, "
                                  f"{PANEL_FRONT_TO_BACK_DB:g} dB front-to-back")
    ds.attrs["p_st_detected"] = float(samples["st_detected"].mean())
    ds.attrs["p_reader_detected"] = float(samples["reader_detected"].mean())
    ds.attrs["p_tag_replied"] = float(samples["tag_replied"].mean())
    if config.fits:
        stage("fitting the RTS and TS models")
        try:
            fits = fit_models(samples)
        except UserError as exc:
            ds.attrs["fits_skipped"] = str(exc)
        else:
            ds.add_table("fits", _fits_table(fits), description="one row per (model, source): coefficients of "
                         "the RTS and TS logistic models fitted here and published (AURIS dissertation R4-1), "
                         "standard errors and cross-entropies")
            for i in range(fits["model"].size):
                if fits["source"][i] == "fit":
                    ds.attrs[f"{fits['model'][i]}_test_cross_entropy"] = float(fits["test_cross_entropy"][i])
            ds.attrs["fits_vs_published"] = fits_comparison(fits)
            ds.attrs["fits_difference_cause"] = FITS_DIFFERENCE_CAUSE
    return ds


#: Why the fits differ from the published ones (module docstring, "Differences from the source";
#: test_default_run_fits_pin_the_documented_difference_from_the_published_models)
FITS_DIFFERENCE_CAUSE = (
    "the tag replies in under half of the samples (UCODE-class chip at -12.8 dBm on a half-wave dipole, the panel's "
    "and the dipole's pattern, the rolled tag's polarisation mismatch), so where the ST decodes is set by the "
    "tag's power-up, which depends on the angles: the angle coefficients a3, a4 come out > 10x the published ones "
    "(the source: 'orientation matters little', its tags powered throughout the cuboid); on the samples where the "
    "tag replied they fall below half (seed 1: a3 4.10 -> 1.59, a4 5.76 -> 1.83 /rad), still above the published; and the ST's 5 mV threshold on a nearly deterministic backscatter "
    "level makes the d coefficient steeper than published")


def fits_comparison(fits: dict[str, np.ndarray]) -> str:
    """One line per model: fitted vs published coefficients (± standard error), test
    cross-entropies (fit, published coefficients on this test set, published value) and the
    order of the non-constant coefficients by size."""
    lines = []
    for model in MODELS:
        rows = {fits["source"][i]: i for i in range(fits["model"].size) if fits["model"][i] == model}
        f, p = rows["fit"], rows["published"]
        n = 5 if model == "RTS" else 2
        names = RTS_NAMES if model == "RTS" else TS_NAMES
        coef = ", ".join(f"{names[j]} {fits[f'a{j}'][f]:.4g} +- {fits[f'se_a{j}'][f]:.2g} (published "
                         f"{fits[f'a{j}'][p]:.4g})" for j in range(n))

        def order(i):
            return " > ".join(names[j] for j in sorted(range(1, n), key=lambda j: -abs(fits[f"a{j}"][i])))

        lines.append(f"{model}: {coef}; test cross-entropy {fits['test_cross_entropy'][f]:.4f} (published "
                     f"coefficients on this test set {fits['test_cross_entropy'][p]:.4f}, published value "
                     f"{fits['published_test_cross_entropy'][f]:.4f}); order by size: fit {order(f)}, published "
                     f"{order(p)}")
    return "; ".join(lines)


# ----------------------------------------------------------------------------- plots


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """AURIS dissertation Fig. 4.7 analogues, ``<stem>-fig4_7.png``: P(ST detects) vs D
    (d ∈ [0.4, 1] m, 0.3 m bins) and vs d (D ∈ [2, 4] m, 0.2 m bins), binned with Wilson 95 %
    intervals, with the fitted and published RTS and TS curves and the fitted models averaged
    over each bin's samples.

    The RTS curves are drawn at the other distance fixed (d = 0.6 m / D = 3 m) and at the
    *median* |θ| and |φ| of the selected samples. At θ = φ = 0 (as first drawn) the fitted
    RTS curve lay far above the data: the fit gives |θ| and |φ| large coefficients (≈ 5-7 per
    rad, the tag is often unpowered off the panel's and the dipole's main lobes) while the
    binned samples have median angles ≈ 0.4 rad; θ = φ = 0 is the best direction, not a
    typical one (seed 1, 4000 samples: near θ = φ = 0 the detected fraction is ≈ 0.6 at
    D < 3 m against ≈ 0.35 over all angles)."""
    plt = pyplot()

    from rfsim.core.dataset import read_table

    s = read_table(dataset_path, "samples")
    try:
        fits = fit_file(dataset_path)
    except UserError:
        fits = None
    y = s["st_detected"].astype(float)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.6))
    for ax, var, sel, edges, xlab, fixed in (
            (a1, "D_m", (s["d_m"] >= 0.4) & (s["d_m"] <= 1.0), np.arange(1.0, 10.01, 0.3), "D [m]", 0.6),
            (a2, "d_m", (s["D_m"] >= 2.0) & (s["D_m"] <= 4.0), np.arange(0.0, 2.01, 0.2), "d [m]", 3.0)):
        b = _detection.binned_probability(s[var][sel], y[sel], edges)
        ok = b.trials > 0
        err = np.clip(np.vstack([b.p_hat[ok] - b.lower[ok], b.upper[ok] - b.p_hat[ok]]), 0.0, None)
        ax.errorbar(b.centers[ok], b.p_hat[ok], yerr=err,
                    fmt="o", capsize=3, label=f"simulated ({int(sel.sum())} samples, Wilson 95 %)")
        x = np.linspace(edges[0], edges[-1], 200)
        th = float(np.median(np.abs(s["theta_rad"][sel]))) if sel.any() else 0.0
        ph = float(np.median(np.abs(s["phi_rad"][sel]))) if sel.any() else 0.0
        at = f"|theta| = {th:.2f}, |phi| = {ph:.2f} rad (medians)"
        if var == "D_m":
            x_rts, x_ts = _detection.rts_design(x, fixed, th, ph), _detection.ts_design(np.full_like(x, fixed))
            ax.set_title(f"vs D, d in [0.4, 1] m; curves at d = 0.6 m,\n{at}", fontsize=9)
        else:
            x_rts, x_ts = _detection.rts_design(fixed, x, th, ph), _detection.ts_design(x)
            ax.set_title(f"vs d, D in [2, 4] m; curves at D = 3 m,\n{at}", fontsize=9)
        if fits is not None:
            for i in range(fits["model"].size):
                coef = np.array([fits[f"a{j}"][i] for j in range(5)])
                coef = coef[np.isfinite(coef)]
                xx = x_rts if fits["model"][i] == "RTS" else x_ts
                ls = "-" if fits["source"][i] == "fit" else ":"
                ax.plot(x, _detection.predict_proba(xx, coef), ls, label=f"{fits['model'][i]} {fits['source'][i]}")
        if fits is not None:
            # the fitted models averaged over the samples of each bin (the binned data mix all
            # angles and the other distance, the curves above fix them)
            xs = s[var][sel]
            feats = {"RTS": _detection.rts_design(s["D_m"][sel], s["d_m"][sel], s["theta_rad"][sel], s["phi_rad"][sel]),
                     "TS": _detection.ts_design(s["d_m"][sel])}
            for i in range(fits["model"].size):
                if fits["source"][i] != "fit":
                    continue
                coef = np.array([fits[f"a{j}"][i] for j in range(5)])
                pr = _detection.predict_proba(feats[fits["model"][i]], coef[np.isfinite(coef)])
                k = np.clip(np.searchsorted(edges, xs, side="right") - 1, 0, edges.size - 2)
                mean_pr = np.bincount(k, pr, minlength=edges.size - 1) / np.maximum(b.trials, 1)
                ax.plot(b.centers[ok], mean_pr[ok], "s--", ms=3,
                        label=f"{fits['model'][i]} fit, mean over the bin's samples")
        ax.set(xlabel=xlab, ylabel="detection probability", ylim=(-0.02, 1.02))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"P(ST detects the tag's RN16) — {cite('auris', 'Fig. 4.7')} (RTS/TS models, Eqs. 4.6-4.7)",
                 fontsize=11)
    return [save_figure(fig, figure_path(dataset_path, out_dir, "fig4_7"), dpi=110)]

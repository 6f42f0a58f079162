"""Scenario ``detection-probability``: does a sense-a-tag (ST) near a tag decode the tag's
reply? A dataset for the ST-to-tag detection models TS and RTS and their maximum-likelihood
fits (auris-sense-a-tag.md §2.2 Eqs. 4.6-4.8, §3.3 "Detection-model data", §4.2 R4-1; seed
003 L3811-3906).

Geometry (§3.3, L3823-3833): reader antenna at the origin, boresight +x; tag uniform in the
cuboid x ∈ [1, 8] m, y, z ∈ [−4, 4] m; ST centre within 2 m of the tag, isotropic direction,
distance r **uniform in [0, 2] m** by default (``geometry.st_sampling = "radius"``;
``"volume"``: r = 2·u^(1/3)). The source says only "random in a sphere" (L3831-3833); radius
sampling is the closer reading: the published models' expected cross-entropy on this geometry
(2·10⁵ draws) is RTS 0.169 / TS 0.210 with it and 0.062 / 0.077 with volume sampling, against
the published 0.1278 / 0.1502 (volume sampling puts 7/8 of the STs beyond 1 m, where p ≈ 0).
The ST (L3819-3821): two vertical λ/2 dipoles λ/4 apart at a uniformly random azimuth,
technique ``st.technique`` (default: receiving-path selection, Algorithm 1);
``geometry.st_pattern = "isotropic"`` gives them the dipole's 2.15 dBi in every direction (the
source models the ST antennas as omnidirectional, L2873). The tag: a half-wave dipole facing
the reader antenna in azimuth, rolled about its horizontal line to the panel by a uniform ±90°
(``geometry.tag_roll_deg``; the source does not say how its tags were oriented);
``geometry.tag_pattern = "isotropic"``: the same 2.15 dBi in every direction, polarisation
kept; ``geometry.tag_facing = "reader"``: pitched as well, so that the reader is broadside to
the dipole at any elevation; ``"random"``: a uniformly random orientation.

Reader antenna: a circularly polarised panel like the RFMAX S9028PCRJ (902-928 MHz,
L3811-3817; its pattern, Fig. 4.3, is not in the text): :class:`rfsim.channels.Patch`, 9 dBic,
70° half-power beamwidth, 20 dB front-to-back (data-sheet class), 30 dBm at its port (L3815),
with an axial ratio growing off boresight (:class:`rfsim.channels.EllipticalPanel`, 1 dB on
boresight, 3 dB at the beam edge, ``geometry.axial_ratio_db``): the polarisation mismatch
follows both orientations instead of the constant 3 dB of an ideal circular panel. Channel
"room" (L3817): Friis and the exponential APDP with the PASS room curves
(:class:`rfsim.channels.ApdpModel` defaults), no surfaces (the cuboid spans z = −4…4 m).

One sample = one sample-level Query round (link profile ``pass-miller2-48k`` at 1 MS/s, as the
source's PASS runs) with a fresh channel draw and a random FCC hop channel, in the scene
:mod:`rfsim.scenes.st_detection` (one air step; the ST chain — linear detector, band-pass, 5 mV
comparator, Miller decoder — from the end of the command; no noise at the ST).
``st_detected``: the ST decoded the tag's RN16 exactly; ``reader_detected``: the reader's port
did (reciprocal backward link, TX leakage, receiver noise). Features
(:func:`rfsim.detection.st_features`): D = ‖tag − antenna‖, d = ‖ST − tag‖, θ = arcsin(v_y/D),
φ = arcsin(v_z/D), v = tag − antenna. Samples with index < ``n_train`` are the training set,
the rest the test set (3000 + 1000 by default, L3825-3829, L3900).

Differences from the source (R4-1) and why. A default run (seed 1; 4000 samples) detects
5.7 % of the samples; the tag replies in only 44 % (42 % with a constant 3 dB mismatch): the
tag (UCODE-class chip, −12.8 dBm, on a half-wave dipole) is often not powered where the panel
pattern and the dipole's pattern are low. Fits (train 3000, test 1000; seeds 1-3, mean ± sd
over seeds; the published in brackets): RTS a = (−8.27 ± 1.22, 0.81 ± 0.10, 6.92 ± 0.97,
4.12 ± 0.68, 5.88 ± 0.48) (−1.462, 0.4941, 2.506, 0.0126, 0.0523), test cross-entropy
0.111 ± 0.022 (0.1278; the published coefficients score 0.152 ± 0.012 here); TS
(0.21 ± 0.22, 4.89 ± 0.58) (0.8970, 2.4443), 0.156 ± 0.023 (0.1502; published coefficients
here 0.164 ± 0.015). RTS beats TS on every seed, as published. The source has
a2 > a1 > a4 > a3 ("orientation matters little", L3858-3869); here a2 > a4 > a3 > a1: the
angle coefficients are 300× and 100× the published, 8-10 of the fit's standard errors away.

Their cause, measured by switching (3 seeds each, a3 / a4 in 1/rad): the reader panel's
pattern over the cuboid (down to −19 dB at its corners) *and* the tag's power-up, together.
Tag powered throughout (``tag.sensitivity_dbm = -40``, ``geometry.tag_roll_deg = 0``): a3
2.92 ± 0.21, a4 3.80 ± 0.77. Pattern nearly flat (170°, 3 dBic: −2.2 dB at most over the
cuboid), tag as default: 1.14 ± 0.53, 3.79 ± 0.26. Both (``geometry.antenna_model =
"pass-like"``, :data:`PASS_LIKE`): a3 0.56 ± 0.48 (0.011 / 0.78 / 0.90, each within 2.3 of its
standard errors ≈ 0.4 of the published 0.0126), a4 2.00 ± 0.76, test cross-entropies
0.130 ± 0.003 / 0.153 ± 0.005 (0.1278 / 0.1502). The pass-like reading is what the text says
the runs had — orientation mattering little because of the antenna pattern and the sampling
space (L3862-3866), which needs a pattern nearly flat over the cuboid and a tag powered
throughout it — but not the antenna it names (an RFMAX S9028PCRJ panel, L3811-3813, a
≈ 70° class beam), so the panel stays the default. It leaves a4 at 2.00 ± 0.77, 40× the
published, and the d slope at 11.5 ± 1.2 /m.

The elevation coefficient a4: its cause is the tag's vertical dipole seen from an elevated
reader. The reader sees the tag at elevation φ, where the dipole's gain is
[cos(π/2·sin φ)/cos φ]² of its broadside gain (−1.8 dB at 30°, −5.1 dB at 50°; at any azimuth θ
it is broadside), on the power-up link and again on the backscatter. Switched off
(``geometry.tag_pattern = "isotropic"``, pass-like otherwise; seeds 1-3): a4 2.00 ± 0.77 →
0.20 ± 0.97 /rad (per seed 1.46 / 2.88 / 1.67 → 0.01 / 1.24 / −0.66, standard errors ≈ 0.4;
published 0.0523); over seeds 1-5 2.17 ± 0.59 → 0.32 ± 0.73, a move of 1.85 ± 0.42 (standard
error of the difference of the means) against a gap of 2.12. Under the panel default the same
switch takes a4 from 5.88 ± 0.48 to 4.89 ± 0.57 (seeds 1-3): there the panel's pattern and the
tag's power-up carry the rest, as for a3. Tilting the dipole to face the reader (``geometry.tag_facing = "reader"``)
does not remove it (a4 1.68 ± 0.49; 1.35 / 2.24 / 1.44): the tilt moves the loss to the
polarisation of the tag → ST link (the tilted tag against the ST's vertical dipoles, the
mismatch ≈ cos²φ). A uniformly random tag orientation (``geometry.tag_facing = "random"``,
reader pattern flat, tag powered) removes it as well (seed 1: a4 −0.21 ± 0.45), but detects
fewer rounds (test cross-entropies 0.079 / 0.079). Omnidirectional ST antennas (``geometry.st_pattern = "isotropic"``, L2873)
are not its cause (seed 1: a4 1.46 → 2.04). The source's link budget carries one tag gain G_T
for both links with no angle (Eqs. 4.1-4.2, L3591-3658), and its text finds orientation of
little weight (L3862-3866), but it names no tag antenna pattern or orientation; the isotropic
tag is therefore a documented setting (``--set geometry.antenna_model=pass-like --set
geometry.tag_pattern=isotropic``), not the default. With it, a3 and a4 are both within the
seed spread of the published and the order is a2 > a1 > a3 ≈ a4 (published a2 > a1 > a4 > a3),
but the ST detects more (13 % against 9 %) and the test cross-entropies rise to
0.145 ± 0.006 / 0.181 ± 0.007 (0.1278 / 0.1502).

The d slope (ML 11.5 against 2.506 /m) is not moved to the published by any switch of the
simulation (below); its measured cause is the fitting method (next paragraph). The published RTS puts
p = 0.72 at D = 1 m with the ST on the tag (d = 0) and 0.50 at D = 3 m: a quarter to a half
of the rounds missed with nothing between tag and ST, and a soft fall with d. On this
geometry it predicts P(detect) = 0.18 for d < 0.2 m (0.49 with D < 3 m) and 0.054 overall;
the runs here detect 0.26-0.33 (panel, seeds 1-3; 0.054 overall, as published), 0.65-0.71 (pass-like,
seeds 2-5) and 0.83-0.90 (pass-like, isotropic tag, seeds 2-5) for d < 0.2 m, and 0.79-1.00
with D < 3 m in pass-like. Here the ST
decodes when the tag's backscatter difference at its detector exceeds 5 mV, an amplitude
∝ 1/(D·d) with a nearly deterministic channel at these ranges (K ≥ 25 dB), so the edge in d
is sharp (seed 2, pass-like with isotropic tag: P(detect) 0.96 for d < 0.1 m, 0.14 at
0.4-0.5 m, 0.03 at 0.7-0.8 m). Switched at seed 1 from that base (a2 = 11.8 ± 0.7): ST
antennas isotropic 15.3 (steeper), tag roll ±90° 11.7, the tag's own power-up
(``tag.sensitivity_dbm = -12.8``) 8.6, a single ST antenna (phase cancellation) 9.8, simple
combination 6.1 (cross-entropies 0.24 / 0.28), ST centre uniform in the ball's volume 10.1,
no small-scale fading (``geometry.apdp = false``) 11.4; a uniformly random orientation of the
dipole tag (flat reader pattern) 12.3 with the tag powered, 7.8 with its power-up (test
cross-entropies 0.020 / 0.035); none closes the gap. The source's Ch. 4 names no detection
criterion ("the detection y of ST-to-tag ... are recorded", L3835-3838; the 5 mV threshold on
the detector output difference is Ch. 3's, L3443-3445, L3500-3502) and leaves phase
cancellation out of the model as insignificant with its dual-antenna ST (L3745-3758); here the
ST antennas receive the reader's CW and the backscatter in one air step, so the cancellation is
in the data and the single-antenna switch above measures it. Receiver noise
is not it either: PASS's receiver noise (n0 = −47 dBm per 3 kHz scaled by fs/frxs,
pass-paris-simulator.md §2.4) is at most ≈ −92 dBm in the ST's 2·BLF = 96 kHz band, against
−36 dBm for a 5 mV peak at 50 Ω.

The d slope's cause: the source's fits are gradient descent (L3854, "We apply gradient descent
method to estimate the model coefficient"; no learning rate, iterations, start or feature
scaling given), which stopped early is the ML fit shrunk towards zero: a soft edge in d, a
small intercept, a low probability at the tag. ``fit_gd_iterations = n`` (with
``fit_gd_learning_rate`` α, default 0.1) fits both models so, from a = 0 on the raw regressors
(D, d in m, ``|θ|``, ``|φ|`` in rad, as Eq. 4.6 writes them); for small α the result depends on α·n
only (α = 0.01, n = 10⁴ and α = 0.1, n = 10³ agree to 3 decimals). One number calibrates the
stop: TS reaches the published a1 = 2.444 at n = 491 / 555 / 525 (pass-like, seeds 1-3). At
n = 500 (seeds 1-3, mean ± sd; ML in brackets): pass-like RTS a2 2.13 ± 0.10 /m (11.5; published
2.506), a3 0.02 ± 0.06, a4 0.14 ± 0.06 /rad (0.0126, 0.0523), TS (0.77 ± 0.11, 2.41 ± 0.05)
(0.897, 2.444), and the model's mean P(detect) for d < 0.2 m is 0.25 ± 0.02 (the published
RTS's 0.18 on this geometry; the data's 0.68). What it does not reproduce: a0 −0.00 ± 0.04
(−1.462), a1 0.14 ± 0.02 /m (0.494), and the test cross-entropies 0.202 ± 0.010 /
0.203 ± 0.011 (0.1278 / 0.1502; the ML fit of the same data reaches 0.130 / 0.153). With the
isotropic tag: a2 2.54 ± 0.09, TS (0.13 ± 0.12, 2.63 ± 0.06), a0 −0.29 ± 0.06, a1
0.09, cross-entropies 0.234 / 0.241; panel default: a2 1.46 ± 0.06, TS (1.41, 2.06), cross-entropies
0.162 / 0.168 (at the stop where its TS reaches 2.444, n = 847-1086: a2 2.05 ± 0.04, a3 0.46,
a4 0.73, 0.152 / 0.164). The gradient descent thus reproduces the published d slope, the TS
pair and the small angle coefficients together from the runs' data with one stopping number,
but not the intercept, the D slope and the published cross-entropies (an early-stopped fit on
these data loses 0.07 nat against the ML fit; the published coefficients reach 0.1278 on their
own data, 0.21 on these). Since the source gives neither the step size nor the steps, the
default stays ML (``fit_gd_iterations = 0``); ``--set fit_gd_iterations=500`` is the documented
reading (tests ``test_gradient_descent_stopped_early_gives_the_published_d_slope_on_sharp_data``,
default tier, and ``test_gradient_descent_fit_of_the_pass_like_run_gives_the_published_d_slope_and_ts``,
slow). Ruled out with it: the regressors' scaling. Scaling a regressor scales its coefficient
and leaves the intercept (ML −6.8 / −7.4, pass-like seeds 1 / 2, against −1.462); standardised
regressors (centred, per sd: D sd 1.7 m, d sd 0.57 m) give a2 7.3 / 6.0 per sd and an intercept
of +10.6 / +9.1 (p ≈ 0 at the mean sample, where the published −1.462 says 0.81).

Coefficients (seeds 1-3, 3000 + 1000 samples, mean ± sd over seeds; a1, a2 per m, a3, a4 per rad of
the absolute angles; CE: test cross-entropy, Eq. 4.8):

=====================  ============  ===========  ==========  ===========  ===========  ============  ===========  =============  =============
reading                a0            a1 (D)       a2 (d)      a3 (θ)       a4 (φ)       TS a0         TS a1        CE RTS         CE TS
=====================  ============  ===========  ==========  ===========  ===========  ============  ===========  =============  =============
published (R4-1)       −1.462        0.4941       2.506       0.0126       0.0523       0.8970        2.4443       0.1278         0.1502
panel (default)        −8.27 ± 1.22  0.81 ± 0.10  6.9 ± 1.0   4.12 ± 0.68  5.88 ± 0.48  0.21 ± 0.22   4.89 ± 0.58  0.111 ± 0.022  0.156 ± 0.023
pass-like              −6.74 ± 0.63  0.63 ± 0.08  11.5 ± 1.2  0.56 ± 0.48  2.00 ± 0.77  −1.73 ± 0.34  9.63 ± 0.93  0.130 ± 0.003  0.153 ± 0.005
pass-like, iso. tag    −7.92 ± 0.23  0.76 ± 0.04  11.6 ± 1.0  0.63 ± 0.09  0.20 ± 0.97  −2.50 ± 0.28  9.15 ± 0.60  0.145 ± 0.006  0.181 ± 0.007
pass-like, GD 500      −0.00 ± 0.04  0.14 ± 0.02  2.13 ± 0.1  0.02 ± 0.06  0.14 ± 0.06  0.77 ± 0.11   2.41 ± 0.05  0.202 ± 0.010  0.203 ± 0.011
=====================  ============  ===========  ==========  ===========  ===========  ============  ===========  =============  =============

Order of the RTS coefficients (published a2 > a1 > a4 > a3): panel a2 > a4 > a3 > a1 (every
seed); pass-like a2 > a4 > a3, a1 (every seed); pass-like with the isotropic tag a2 > a1 > a3,
a4 at seeds 1 and 3, a2 > a4 > a1 > a3 at seed 2. RTS has the lower test cross-entropy in
every run, as published. The published coefficients score 0.152 ± 0.012 / 0.164 ± 0.015 on the
panel's test sets, 0.208 / 0.206 on pass-like's, 0.28 / 0.28 with the isotropic tag.

The published TS and RTS are one model's two fits, not a contradiction: TS fitted to outcomes
drawn from the published RTS on this geometry gives a0 = 1.15 ± 0.13, a1 = 2.40 ± 0.22 (10
draws of 3000) against the published 0.897 / 2.444 (test
``test_published_ts_is_what_ts_fits_to_data_of_the_published_rts``). Every run writes the
comparison to the attribute ``fits_vs_published`` and the cause to ``fits_difference_cause``;
the slow tests ``test_regression_default_run_fits_and_the_documented_difference_from_the_published_models``
and ``test_angle_coefficients_follow_the_reader_pattern_and_the_tag_power_up`` pin them.

Randomness: sample i draws everything from ``trial_rng(s, i, k)``, s = ``samples.seed``
(or the run seed when it is −1): k = 0 geometry, 1 reader (hop table), 2 tag, 3 channel
(all links), 4 reader noise, 5 tag roll. A run over ``samples.first``…``first + count − 1`` therefore
gives the same rows as any split of that range into blocks (the sweep
``examples/sweeps/detection-probability.toml`` runs blocks in parallel; the merged
``samples`` table is the full table and :func:`fit_file` fits it). A run itself simulates its samples in
blocks (32, then 256 each) on ``samples.workers`` processes (default 2), with the same rows for any number.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.channels import Antenna, HalfWaveDipole, Isotropic, Patch
from rfsim.channels.antennas import HALF_WAVE_DIPOLE_PEAK, PANEL_FRONT_TO_BACK_DB, EllipticalPanel
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.core.config import param
from rfsim.core.errors import ConfigError, UserError
from rfsim.core.procs import map_in_order
from rfsim.core.progress import stage
from rfsim.core.rng import trial_rng_grid
from rfsim.core.lazy import lazy_import

_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_st_scene = lazy_import("rfsim.scenes.st_detection")
_dataset = lazy_import("rfsim.core.dataset")
_detection = lazy_import("rfsim.detection")
_figures = lazy_import("rfsim.scenarios._detection_probability_figures")

#: modules the figures use (imported by the runner while the simulation runs)
FIGURE_IMPORTS = ("rfsim.detection", "scipy.special")
NAME = "detection-probability"
DESCRIPTION = ("sense-a-tag detection of a tag's reply vs (D, d, θ, φ): 3000 + 1000 sample-level Query "
               "rounds, ML fits of the TS and RTS models (AURIS dissertation Eqs. 4.6-4.8)")

PANEL_GAIN_DBIC = 9.0
PANEL_BEAMWIDTH_DEG = 70.0

#: ``geometry.antenna_model = "pass-like"`` (module docstring, "Differences from the source"):
#: a reader pattern nearly flat over the cuboid (−2.2 dB at most, against −19 dB for the panel), 3 dBic (30 dBm +
#: 3 dBic − 3 dB to a linear tag = 30 dBm, as PASS's EIRP setting with a pattern normalised to
#: 1), vertical tag dipoles, the tag powered throughout the cuboid (L3858-3866).
PASS_LIKE = {"reader_beamwidth_deg": 170.0, "reader_gain_dbic": 3.0, "tag_roll_deg": 0.0, "tag_sensitivity_dbm": -40.0}


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
    tag_pattern: Literal["dipole", "isotropic"] = param(
        "dipole", doc="tag antenna pattern: half-wave dipole, or isotropic at the dipole's peak gain (2.15 dBi; "
                      "linear polarisation kept)")
    tag_facing: Literal["azimuth", "reader", "random"] = param(
        "azimuth", doc="tag turned towards the reader antenna in azimuth only (axis vertical at roll 0), "
                       "tilted as well so that the reader antenna is on its boresight (its axis perpendicular "
                       "to the line to the reader), or in a uniformly random orientation (tag_roll_deg unused)")
    st_pattern: Literal["dipole", "isotropic"] = param(
        "dipole", doc="pattern of the ST's two vertical antennas: half-wave dipole, or isotropic at the dipole's "
                      "peak gain (the source's omnidirectional ST antennas, seed 003 L2873)")
    antenna_model: Literal["panel", "pass-like"] = param(
        "panel", doc="'panel': the settings above; 'pass-like': the reading of the PASS runs under which "
                     "orientation matters little (PASS_LIKE: reader pattern nearly flat over the cuboid, "
                     "170 deg / 3 dBic, vertical tag dipoles, tag powered throughout, tag.sensitivity_dbm -40); "
                     "it replaces reader_beamwidth_deg, reader_gain_dbic, tag_roll_deg and tag.sensitivity_dbm and keeps "
                     "tag_pattern, tag_facing and st_pattern (with tag_pattern = 'isotropic' it reproduces a3 and a4)")

    def __post_init__(self):
        if self.antenna_model == "pass-like":
            for key in ("reader_beamwidth_deg", "reader_gain_dbic", "tag_roll_deg"):
                object.__setattr__(self, key, PASS_LIKE[key])
        for key in ("tag_x_m", "tag_y_m", "tag_z_m"):
            lo, hi = getattr(self, key)
            if not lo < hi:
                raise ConfigError(f"geometry.{key}", getattr(self, key), "[low, high] with low < high")
        # draw_geometry redraws every ST distance r < min_st_distance_m, r < st_radius_m: with
        # min_st_distance_m ≥ st_radius_m no draw is ever kept
        if not self.min_st_distance_m < self.st_radius_m:
            raise ConfigError("geometry.min_st_distance_m", self.min_st_distance_m,
                              f"below geometry.st_radius_m ({self.st_radius_m:g} m): no ST centre could be drawn")


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
    fit_gd_iterations: int = param(0, lo=0, hi=10**7, doc="0: maximum-likelihood fits; n > 0: n steps of "
                                   "gradient descent from zero instead (the source's method, seed 003 L3854)")
    fit_gd_learning_rate: float = param(0.1, lo=1e-6, hi=1.0, doc="gradient-descent step size (with "
                                        "fit_gd_iterations > 0)")

    def __post_init__(self):
        if self.geometry.antenna_model == "pass-like":
            object.__setattr__(self, "tag", replace(self.tag, sensitivity_dbm=PASS_LIKE["tag_sensitivity_dbm"]))
        if self.st.technique == "stamp":
            raise ConfigError("st.technique", self.st.technique, "'single', 'combination' or 'selection'")


# ----------------------------------------------------------------------------- one sample


def reader_antenna(g: GeometryConfig) -> Antenna:
    """The reader panel at the origin, boresight +x, circular polarisation.

    Pattern :class:`rfsim.channels.Patch` (``geometry.reader_gain_dbic``,
    ``geometry.reader_beamwidth_deg``, 20 dB front-to-back) with the axial ratio of
    ``geometry.axial_ratio_db`` growing off boresight (:class:`rfsim.channels.EllipticalPanel`;
    module docstring: an RFMAX S9028PCRJ-class panel, seed 003 L3811-3817).

    Parameters
    ----------
    g : GeometryConfig
        The run's geometry settings.

    Returns
    -------
    EllipticalPanel
        The reader's antenna.
    """
    return EllipticalPanel(position_m=(0.0, 0.0, 0.0), orientation=(0.0, 0.0, 0.0),
                           pattern=Patch(g.reader_gain_dbic, g.reader_beamwidth_deg, PANEL_FRONT_TO_BACK_DB),
                           polarization="circular", axial_ratio_db=tuple(g.axial_ratio_db),
                           half_beamwidth_rad=math.radians(0.5 * g.reader_beamwidth_deg))


def antenna_pattern(kind: str):
    """The pattern of ``geometry.tag_pattern`` / ``geometry.st_pattern``.

    Parameters
    ----------
    kind : {"dipole", "isotropic"}
        ``"dipole"``: :class:`rfsim.channels.HalfWaveDipole`,
        :math:`G(\\psi) = 1.64\\,[\\cos(\\tfrac{\\pi}{2}\\cos\\psi)/\\sin\\psi]^2` with ψ the angle from
        the dipole's axis; ``"isotropic"``: :class:`rfsim.channels.Isotropic` at the dipole's
        peak gain 1.64 (2.15 dBi), the same gain broadside and no fall towards the axis.

    Returns
    -------
    HalfWaveDipole or Isotropic
        The pattern.
    """
    return HalfWaveDipole() if kind == "dipole" else Isotropic(HALF_WAVE_DIPOLE_PEAK)


def tag_antenna(position_m, roll_rad: float = 0.0, pattern=HalfWaveDipole(), facing: str = "azimuth") -> Antenna:
    """The tag's antenna: linearly polarised, facing the reader antenna at the origin.

    ``facing = "azimuth"``: its boresight (local +x) is the horizontal direction to the reader
    antenna; its axis (and its polarisation) is vertical at ``roll_rad = 0``, rolled by
    ``roll_rad`` about that horizontal line otherwise. ``facing = "reader"``: its boresight is
    the direction to the reader antenna itself (pitched by the elevation of the reader seen from
    the tag), so that the reader is broadside to the dipole's axis at any elevation.

    Parameters
    ----------
    position_m : array_like, shape (3,)
        Tag position [m].
    roll_rad : float, default 0.0
        Roll about the horizontal line to the reader antenna [rad].
    pattern : object, default ``HalfWaveDipole()``
        Its pattern (:func:`antenna_pattern`).
    facing : {"azimuth", "reader"}, default "azimuth"
        ``geometry.tag_facing``.

    Returns
    -------
    Antenna
        The tag's antenna.
    """
    p = np.asarray(position_m, float)
    pitch = math.atan2(-p[2], math.hypot(p[0], p[1])) if facing == "reader" else 0.0
    return Antenna(position_m=p, orientation=(math.atan2(-p[1], -p[0]), pitch, float(roll_rad)),
                   pattern=pattern, polarization="linear")


def scene(g: GeometryConfig) -> _scene.Scene:
    """Free space with the PASS room APDP (no surfaces).

    Parameters
    ----------
    g : GeometryConfig
        The run's geometry settings (``apdp``: the exponential APDP of
        :class:`rfsim.channels.ApdpModel`, PASS "room" curves, seed 003 L3817; off: Friis only).

    Returns
    -------
    Scene
        The propagation scene.
    """
    return _scene.Scene(apdp=_small_scale.ApdpModel() if g.apdp else None)


def draw_geometry(g: GeometryConfig, *, rng: np.random.Generator):
    """Tag position, ST centre and ST azimuth of one sample.

    The tag is uniform in the cuboid ``tag_x_m × tag_y_m × tag_z_m``; the ST centre lies at
    distance r from it in an isotropic direction, with r = R·u (``st_sampling = "radius"``) or
    r = R·u^(1/3) (``"volume"``), R = ``st_radius_m``, u uniform in [0, 1); draws with
    r < ``min_st_distance_m`` are redrawn (seed 003 L3823-3833).

    Parameters
    ----------
    g : GeometryConfig
        The run's geometry settings.
    rng : numpy.random.Generator
        The sample's geometry stream (stream 0).

    Returns
    -------
    tag_m : ndarray, shape (3,)
        Tag position [m].
    st_m : ndarray, shape (3,)
        ST centre [m].
    orientation_rad : float
        Azimuth of the ST's SA1 → SA2 axis [rad], uniform in [−π, π).
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


#: Random streams of a sample (module docstring, "Randomness"): k = 0 … 5
N_STREAMS = 6


def sample_placement(g: GeometryConfig, rngs: list):
    """The placement of one sample: tag position, ST centre and azimuth, the rolled tag antenna.

    Parameters
    ----------
    g : GeometryConfig
        The run's geometry settings.
    rngs : list of numpy.random.Generator
        The sample's :data:`N_STREAMS` generators; stream 0 draws the geometry
        (:func:`draw_geometry`), stream 5 the tag's roll, uniform in ±``tag_roll_deg``, and
        with ``tag_facing = "random"`` then its orientation (azimuth uniform, sine of the
        elevation uniform, roll uniform: a uniformly random rotation).

    Returns
    -------
    rfsim.scenes.st_detection.Placement
        The placement, its tag antenna of :func:`tag_antenna` with ``geometry.tag_pattern``.
    """
    tag_pos, st_pos, orient = draw_geometry(g, rng=rngs[0])
    roll = math.radians(g.tag_roll_deg) * rngs[5].uniform(-1.0, 1.0)
    if g.tag_facing == "random":  # uniform rotation: boresight uniform on the sphere, roll uniform
        u = rngs[5].uniform(-1.0, 1.0, size=3)
        return _st_scene.Placement(tag_pos, st_pos, orient, Antenna(
            position_m=tag_pos, orientation=(math.pi * u[0], math.asin(u[1]), math.pi * u[2]),
            pattern=antenna_pattern(g.tag_pattern), polarization="linear"))
    return _st_scene.Placement(tag_pos, st_pos, orient, tag_antenna(tag_pos, roll, antenna_pattern(g.tag_pattern),
                                                                         g.tag_facing))


def simulate_sample(config: Config, index: int, seed: int) -> dict[str, float]:
    """One Query round for sample ``index`` (module docstring), a block of one sample.

    Parameters
    ----------
    config : Config
        The run's configuration.
    index : int
        The sample index (the trial index of its random streams).
    seed : int
        The seed of the sample streams.

    Returns
    -------
    dict
        The sample's record: the columns of :data:`FIELDS` but ``is_test``, each a scalar.
    """
    return _block_task((config, seed, index, index + 1))[0]


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


#: Samples whose ST chains run as one batch of rows (:func:`rfsim.scenes.st_detection.run_rounds`).
ST_BLOCK = 256
#: Samples of the first block (run in this process before the pool starts).
WARM_BLOCK = 32


def simulate(config: Config, *, seed: int) -> dict[str, np.ndarray]:
    """Samples ``first … first + count − 1`` as columns (see :data:`FIELDS`).

    In blocks (the first of :data:`WARM_BLOCK` samples, alone first, then of :data:`ST_BLOCK`;
    each one batch of :func:`rfsim.scenes.st_detection.run_rounds`) on ``samples.workers``
    processes, concatenated in order: every sample draws only from its own streams, so the rows
    do not depend on the workers.

    Parameters
    ----------
    config : Config
        The run's configuration.
    seed : int
        The run seed (the seed of the sample streams unless ``samples.seed`` ≥ 0).

    Returns
    -------
    dict of str to ndarray
        One column per key of :data:`FIELDS`, shape (``samples.count``,), in sample order.
    """
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
    """The records of samples ``lo … hi − 1`` (one batch of rounds)."""
    config, base, lo, hi = args
    g = config.geometry
    devices = _st_scene.Devices(config.reader, config.tag, config.st, reader_antenna(g), scene(g),
                                st_pattern=antenna_pattern(g.st_pattern))
    rngs = trial_rng_grid(base, range(lo, hi), range(N_STREAMS))  # the samples' streams, seeded at once
    placed = [sample_placement(g, r) for r in rngs]
    return [{"sample": i, **r} for i, r in zip(range(lo, hi), _st_scene.run_rounds(devices, placed, rngs))]


# ----------------------------------------------------------------------------- run and fits


def fit_file(path) -> dict[str, np.ndarray]:
    """Fit the RTS and TS models to the ``samples`` table of a dataset file (a run or a merged sweep).

    Rows are ordered by sample index first and duplicate indices rejected (a merged sweep
    holds each block once); then :func:`rfsim.detection.fit_st_models`.

    Parameters
    ----------
    path : str or os.PathLike
        The dataset file.

    Returns
    -------
    dict of str to ndarray
        The fits table of :func:`rfsim.detection.fit_st_models` (rows RTS fit, RTS published,
        TS fit, TS published).

    Raises
    ------
    UserError
        When the table holds a sample index twice, or the fit has no finite estimate.
    """
    s = _dataset.read_table(path, "samples")
    order = np.argsort(s["sample"], kind="stable")
    if np.unique(s["sample"]).size != s["sample"].size:
        raise UserError(f"{path}: duplicate sample indices in the samples table")
    return _detection.fit_st_models({k: np.asarray(v)[order] for k, v in s.items()})


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate the samples and fit the models: the scenario's dataset.

    Parameters
    ----------
    config : Config
        The run's configuration.
    seed : int
        The run seed.

    Returns
    -------
    Dataset
        Tables ``samples`` (:data:`FIELDS`) and, with ``config.fits``, ``fits`` (RTS/TS fitted
        and published, :func:`rfsim.detection.fit_st_models`); attributes: the ST sampling, the
        reader antenna, the antenna patterns, the detected fractions, the test cross-entropies,
        ``fits_vs_published``, ``fits_difference_cause`` and, with ``fit_gd_iterations`` > 0,
        ``fit_method``.
    """
    samples = simulate(config, seed=seed)
    ds = _dataset.Dataset(title="sense-a-tag detection probability vs (D, d, theta, phi) (AURIS dissertation Eqs. 4.6-4.8)")
    ds.add_table("samples", {k: _dataset.column(v, *FIELDS[k]) for k, v in samples.items()},
                 description="one row per sample: one Query round with a fresh geometry and channel; features "
                             "D, d, theta, phi and whether the ST (and the reader) decoded the tag's RN16")
    ds.attrs["st_sampling"] = (f"ST centre uniform in the {config.geometry.st_radius_m:g} m ball's "
                               + ("volume (r = R u^(1/3))" if config.geometry.st_sampling == "volume"
                                  else "radius (r = R u)") + ", isotropic direction")
    pass_like = config.geometry.antenna_model == "pass-like"
    ds.attrs["reader_antenna"] = (("pass-like reading (geometry.antenna_model): " if pass_like else "") +
                                  f"analytic circular panel (RFMAX S9028PCRJ class): {config.geometry.reader_gain_dbic:g} "
                                  f"dBic, {config.geometry.reader_beamwidth_deg:g} deg beamwidth, "
                                  f"{PANEL_FRONT_TO_BACK_DB:g} dB front-to-back")
    g = config.geometry
    ds.attrs["tag_antenna"] = (("half-wave dipole" if g.tag_pattern == "dipole" else "isotropic at the half-wave "
                                "dipole's peak gain (2.15 dBi), linear polarisation")
                               + {"azimuth": ", facing the reader antenna in azimuth, vertical at roll 0",
                                  "reader": ", pitched so that the reader antenna is on its boresight",
                                  "random": ", in a uniformly random orientation"}[g.tag_facing]
                               + ("" if g.tag_facing == "random" else f", roll uniform in +-{g.tag_roll_deg:g} deg")
                               + " (geometry.tag_pattern, tag_facing, tag_roll_deg)")
    ds.attrs["st_antennas"] = ("two vertical half-wave dipoles" if g.st_pattern == "dipole" else
                               "two vertical antennas, isotropic at the half-wave dipole's peak gain (2.15 dBi; the "
                               "source's omnidirectional ST antennas)") + " (geometry.st_pattern)"
    for key in ("st_detected", "reader_detected", "tag_replied"):
        ds.attrs[f"p_{key}"] = float(samples[key].mean())
    if config.fits:
        stage("fitting the RTS and TS models")
        try:
            gd = (config.fit_gd_learning_rate, config.fit_gd_iterations) if config.fit_gd_iterations else None
            fits = _detection.fit_st_models(samples, gradient_descent=gd)
        except UserError as exc:
            ds.attrs["fits_skipped"] = str(exc)
        else:
            spec = _detection.st_fit_columns(fits)
            ds.add_table("fits", {k: _dataset.column(v, *spec[k]) for k, v in fits.items()},
                         description="one row per (model, source): coefficients of the RTS and TS logistic models "
                         "fitted here and published (AURIS dissertation R4-1), standard errors and cross-entropies")
            for i in range(fits["model"].size):
                if fits["source"][i] == "fit":
                    ds.attrs[f"{fits['model'][i]}_test_cross_entropy"] = float(fits["test_cross_entropy"][i])
            if gd is not None:
                ds.attrs["fit_method"] = (f"gradient descent (fit_gd_iterations = {gd[1]}, fit_gd_learning_rate = {gd[0]:g}, "
                                          "from zero), not maximum likelihood; standard errors NaN")
            ds.attrs["fits_vs_published"] = _detection.st_fits_comparison(fits)
            ds.attrs["fits_difference_cause"] = FITS_DIFFERENCE_CAUSE
    return ds


#: Why the fits differ from the published ones (module docstring, "Differences from the source";
#: test_regression_default_run_fits_and_the_documented_difference_from_the_published_models)
FITS_DIFFERENCE_CAUSE = (
    "the angle coefficients a3, a4 (> 100x the published) come from the reader panel's pattern over the cuboid "
    "(down to -19 dB at its corners) together with the tag's power-up (UCODE-class chip at -12.8 dBm on a rolled "
    "half-wave dipole, replying in under half of the samples): seeds 1-3, a3 4.12 +- 0.68 /rad; tag powered "
    "throughout 2.92 +- 0.21; pattern nearly flat 1.14 +- 0.53; both (geometry.antenna_model = 'pass-like', the "
    "text's 'orientation matters little') 0.56 +- 0.48 (published 0.0126, within 2.3 standard errors) with test "
    "cross-entropies 0.130 / 0.153 (published 0.1278 / 0.1502). The elevation coefficient a4 (pass-like 2.00 +- 0.77, "
    "published 0.0523) comes from the tag's vertical dipole seen from an elevated reader (gain "
    "[cos(pi/2 sin phi)/cos phi]^2 of broadside): with geometry.tag_pattern = 'isotropic' (pass-like otherwise) a4 is "
    "0.20 +- 0.97 (seeds 1-3; seeds 1-5 2.17 +- 0.59 -> 0.32 +- 0.73), with test cross-entropies 0.145 / 0.181; tilting the dipole to face the reader "
    "(geometry.tag_facing = 'reader') leaves 1.68 +- 0.49 (the loss moves to the tag-ST polarisation), a random tag "
    "orientation removes it too (-0.21, seed 1, tag powered) with cross-entropies 0.079 / 0.079, isotropic ST "
    "antennas leave 2.04 (seed 1). The source names no tag pattern or orientation, so the isotropic tag is a "
    "documented setting, not the default. The d slope (ML 11.5 +- 1.2 /m, published 2.506) comes from the fitting "
    "method: the source fits by gradient descent (seed 003 L3854; step size and steps not given), which stopped early "
    "shrinks the ML fit. fit_gd_iterations = 500 (learning rate 0.1, from zero, raw regressors; the stop where TS "
    "reaches the published a1) gives on pass-like seeds 1-3 a2 2.13 +- 0.10, a3 0.02 +- 0.06, a4 0.14 +- 0.06, TS "
    "(0.77 +- 0.11, 2.41 +- 0.05) (published 0.897, 2.444) and P(detect | d < 0.2 m) 0.25 from the model (published "
    "RTS 0.18, data 0.68), but not a0 (-0.00 +- 0.04 vs -1.462), a1 (0.14 vs 0.494) or the test cross-entropies "
    "(0.202 / 0.203 vs 0.1278 / 0.1502; ML 0.130 / 0.153); the default stays ML. No switch of the simulation moves the "
    "ML slope to 2.5 (ST pattern, tag roll or orientation, tag power-up, one ST antenna, simple combination, volume "
    "sampling, small-scale fading: 6.1-15.3), nor does the regressors' scaling (it leaves the intercept). The "
    "published TS is what TS fits "
    "to data of the published RTS (a0 1.15 +- 0.13, a1 2.40 +- 0.22): the two published models are consistent")


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """AURIS dissertation Fig. 4.7 analogues, ``<stem>-fig4_7.png``: P(ST detects) vs the
    reader–tag distance D (d ∈ [0.4, 1] m) and vs the ST–tag distance d (D ∈ [2, 4] m), binned
    with Wilson 95 % intervals (0.3 m / 0.2 m bins, merged until each holds at least
    ``MIN_BIN_SAMPLES`` samples; the horizontal bar is the bin), the fitted and published RTS
    and TS curves at the other distance fixed (d = 0.6 m / D = 3 m) and the *median* |θ|, |φ|
    of the selected samples (at θ = φ = 0, the best direction, not a typical one, the fitted
    RTS lies far above the data: its angle coefficients are ≈ 5-7 /rad, the median angles
    ≈ 0.4 rad), and the fitted models averaged over each bin's samples.

    Drawn by :mod:`rfsim.scenarios._detection_probability_figures`.

    Parameters
    ----------
    dataset_path : pathlib.Path
        The run's dataset file.
    out_dir : pathlib.Path
        Folder of the figures.

    Returns
    -------
    list of pathlib.Path
        The figure files written.
    """
    return _figures.plot(dataset_path, out_dir, fit_file=fit_file)

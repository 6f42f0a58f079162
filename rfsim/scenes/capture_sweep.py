"""Two-tag capture from physics, batched: P(capture) against the power ratio of two RN16
replies in one slot, and the reader's RN16 acceptance measured on the same trials.

One trial is one collided slot of a Q = 0 Query: two tags answer with their RN16s. Each tag
replies at its own BLF and T1 (the rules of :meth:`rfsim.devices.tag.TagConfig.reply_timing`,
vectorised: BLF = f_clk/N_BLF·(1 + ε), T1 = the counted T1 + offset) with the spread of
:class:`rfsim.devices.tag_spread.TagSpreadConfig` or, without spread, at the nominal BLF and T1
(identical tags in lock-step). The reader's input over the RN16 window is the superposition

    y(t) = h1·s1(t) + h2·s2(t) + c + n(t),

s_i = ±1 the line code of tag i during its reply and −1 around it (the tag rests in its
absorbing state), which is the tag's re-radiation A_s − Γ_i(t) = (A_s − (Γ_A + Γ_B)/2) −
((Γ_B − Γ_A)/2)·s_i(t) (rfsim.devices.tag step 6) through a narrowband link, up to the constant c
(carrier leakage and static scattering, removed by the receiver); h_i = −g_i(Γ_B − Γ_A)/2 for
a link gain g_i. |h1| = 1, |h2| = 10^(−ratio/20): the **ratio is the ratio of the two replies'
modulated powers at the reader**, |h1|²/|h2|², set exactly (the simulated ratio is the plotted
one). Chip spread and antenna orientation change |h_i| and arg h_i only, so for a given ratio
they are absorbed in it and in the phases, drawn uniform in [0, 2π) per tag. n(t) is complex
white noise with the stronger reply at Eb/N0 = ``strong_ebn0_db``.

The reader decodes each window with its BLF search (:func:`rfsim.devices.reader.search_decode`: the
kernel of ``Reader.receive`` with ``blf_search = "preamble"``, here on a stacked array of
windows) over the T1 window of the link, detects with the preamble-correlation threshold
(false-alarm probability ``false_alarm_probability`` per window, union over BLFs and lags,
:func:`rfsim.gen2.capture.preamble_threshold`) and accepts the RN16 when its Eb/(N0 + I)
statistic reaches the threshold of the stated false-accept probability
(:func:`rfsim.devices.reader.rn16_threshold_db`). **Capture** = the reader accepts the RN16 and it is
exactly one tag's RN16: it ACKs that tag, the other leaves the slot (wrong RN16 → Arbitrate),
and the EPC that follows is a single reply. **False ACK** = accepted bits that no tag sent.

Sample rate: ``samples_per_element`` samples per half subcarrier cycle (fs = 2·BLF·that;
≥ 2.5 keeps each element resolved), not the engine's 4 MS/s: the decoder's statistics depend
on the samples per element, and the batch runs at event-level speed this way.

**What the curve is**: per collided slot of two tags whose RN16 replies reach the reader with
the given modulated power ratio, the probability that this reader (its BLF search, Viterbi
decoder and acceptance gate, the stronger reply at Eb/N0 = ``strong_ebn0_db``) ACKs one of
them with that tag's own RN16 — a receiver-level capture probability, not a channel-level
threshold. With the default seed and 2000 collisions per point (acceptance at 7.2 dB): tags in
lock-step capture in 4–5 % of the slots at 0 dB (the equal-power sum is a waveform neither tag
sent), ≥ 50 % from 1–2 dB and ≥ 90 % from 6–7 dB; with their own BLF and T1 the replies are
asynchronous and the random carrier phase leaves the stronger one decodable far more often:
32 % (FM0) and 63 % (Miller-4) at 0 dB, ≥ 90 % from 6 dB (FM0) and 3 dB (Miller-4, whose
subcarrier decorrelates two tags whose BLFs differ). **Published measurements**: the
reference pages and seed documents hold no measured capture curve, and none was checked
here; capture-aware anti-collision studies (e.g. B. Li, Y. Yang, J. Wang, "Anti-collision
issue analysis in Gen2 protocol", Auto-ID Labs white paper WP-HARDWARE-047, 2009) treat
capture as a probability per collided slot. The curve is therefore a model result, not
validated against measurement.

**Default acceptance**: p = 1e-2 (threshold 7.2 dB), chosen from the ``acceptance`` table of
the default run (all ratios 0–15 dB pooled, 32 000 collisions per case): at its nearest
threshold, 7.0 dB, the false-ACK rate is 1.4 / 2.1 / 4.0 / 1.2 % of collided slots (FM0 lock-step / FM0 spread / Miller-4 lock-step /
Miller-4 spread) against missed captures 10 / 8.7 / 7.1 / 3.0 %, near the threshold where the
worst case's (Miller-4 lock-step) two rates cross (≈ 6–7 dB); 9 dB would halve the false ACKs
and double the missed captures.

Randomness: point p (profile, spread, ratio in that order) draws everything from
``trial_rng(seed, 2_000_000 + p)``, vectorised over its trials in a fixed order (bits, BLF
errors, T1, phases, noise): a point's results depend only on (seed, p).

**Why the windows are built here and not by the air step** (:func:`rfsim.air.step.propagate`,
:func:`rfsim.protocols.batch.propagate_batch`). The air step cannot give these windows with the
same arithmetic in the same order, so the recorded datasets would change; a later change that
routes the sweep through the air step has to accept new numbers. What differs:

1. *Order of the sums.* Here the noise is drawn into the window first, scaled by √(σ²/2), and
   the replies are added to it tag by tag: y = ((n + h1·s1) + h2·s2). The air step sums the
   paths first and adds the receiver noise last (:func:`rfsim.air.noise.add_awgn`):
   y = (Σ paths) + n. Floating-point addition is not associative, so the samples differ in
   their last bits.
2. *Signal model.* Here each reply is the bare line code s_i = ±1 (−1 around the reply) times
   one complex gain h_i with |h1|²/|h2|² set exactly and a uniform phase. The air step forms
   r_j(t)·L{x}(t) with the tag's re-radiation factor r = A_s − Γ(t) (chip states, structural
   mode), the reader's CW segment, the links' path gains g·e^{−j2π·fc·τ} and the carrier
   leakage c, which the receiver removes; the power ratio would then follow from geometry and
   chips instead of being set.
3. *Timing and rate.* Each reply here starts at its drawn T1 with its drawn BLF, written by
   :func:`rfsim.gen2.linecode.reply_waveform` at fs = 2·BLF·``samples_per_element``; in the air
   step a tag device answers a reader command on the reader's sample rate (4 MS/s), its
   timing set by its own modulator.
4. *Batch shape.* Here one (trials, samples) array per point is decoded at once by
   :func:`rfsim.devices.reader.search_decode`; the air step produces one receiver segment per
   exchange (or per batch member), each through the reader's own receive path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.devices.tag_config import TagConfig
from rfsim.devices.tag_spread import TagSpreadConfig
from rfsim.core.config import check_fields, param
from rfsim.gen2.link import profile, t1
from rfsim.core.progress import track
from rfsim.core.rng import trial_rng
from rfsim.core.lazy import lazy_import

_reader = lazy_import("rfsim.devices.reader")
_decoder = lazy_import("rfsim.gen2.reply_decoder")
_st_analytic = lazy_import("rfsim.devices.st_analytic")
_linecode = lazy_import("rfsim.gen2.linecode")

#: First point index of the sweep's streams (apart from the engine capture points at 10**6 + i).
SEED_OFFSET = 2_000_000
#: Bits of an RN16.
RN16_BITS = 16


@dataclass(frozen=True)
class CaptureSweepConfig:
    """Batched two-tag capture sweep (module docstring; errors name ``capture_sweep.<key>``)."""

    enabled: bool = param(True, doc="run the batched capture sweep")
    profiles: tuple[str, ...] = param(("fm0-40k", "miller4-320k"), doc="link profiles (line codes) swept")
    ratios_db: tuple[float, ...] = param(tuple(float(r) for r in range(16)), lo=0.0, hi=40.0, unit="dB",
                                         doc="modulated power ratios of the two replies at the reader")
    trials: int = param(2000, lo=1, hi=10**6, doc="collisions per point")
    strong_ebn0_db: float = param(20.0, lo=-10.0, hi=60.0, unit="dB", doc="Eb/N0 of the stronger reply")
    samples_per_element: float = param(3.0, lo=2.5, hi=20.0, doc="samples per half subcarrier cycle (fs = 2·BLF·this)")
    spread: TagSpreadConfig = param(TagSpreadConfig(enabled=True), doc="the tags' spread in the 'with spread' case")
    false_alarm_probability: float = param(1e-3, lo=0.0, hi=1.0, lo_open=True, hi_open=True,
                                           doc="preamble detection false-alarm probability per window")
    rn16_false_accept: float = param(1e-2, lo=0.0, hi=0.5, lo_open=True, hi_open=True,
                                     doc="stated RN16 false-accept probability (sets the acceptance threshold; "
                                         "1e-2 = 7.2 dB, chosen from the acceptance table)")
    threads: int = param(2, lo=1, hi=64, doc="threads of the decoding kernel (results do not depend on it)")
    thresholds_db: tuple[float, ...] = param(tuple(0.5 * k for k in range(41)), lo=-20.0, hi=60.0, unit="dB",
                                             doc="acceptance thresholds of the false-ACK / missed-capture table")

    def __post_init__(self):
        check_fields(self, "capture_sweep")
        for name in self.profiles:
            profile(name)


#: Why the ``inventory`` scenario's two capture tables differ (measured; both tables' descriptions).
TABLES_COMPARED = (
    "The capture and capture_sweep tables share the definition of capture (rfsim.scenes.capture_sweep.captured) and "
    "the x-axis (modulated power ratio of the two replies at the reader), not the reader: the engine's capture table "
    "reads Miller-4 (miller4-320k) tags in lock-step with the nominal BLF and no RN16 gate (reader.rn16_false_accept "
    "= 0), the stronger reply at Eb/N0 = 35.0-35.2 dB (its EPC reads, noise figure 40 dB at 3 m); capture_sweep's "
    "p_capture gates at 7.2 dB with the stronger reply at 20 dB. Measured, seed 1, Miller-4 lock-step, 300 collisions "
    "per point: the sweep at the engine's settings (Eb/N0 35 dB, no gate: p_decoded) gives 0.14 / 0.47 / 0.83 / 0.96 "
    "/ 0.99 / 1.0 at 0 / 0.1 / 0.2 / 0.3 / 0.45 / 1 dB, 0.81 averaged over the engine's 69 trials with |ratio| < 1 dB "
    "(they spread over 0-0.93 dB), where the engine measured 0.80 [0.68, 0.88]; at the sweep's own settings the same "
    "trials average 0.33 (20 dB, no gate) and 0.19 (20 dB, 7.2 dB gate), and its exact 0 dB point is 0.04: the 20x "
    "between 0.80 and 0.04 is the SNR, the gate and the pooling of 0.1-1 dB ratios, not the capture rule")


def captured(n_replies, decoded_tag, accepted) -> np.ndarray:
    """Tell whether a collided slot ends in capture.

    The one definition of both capture tables of the ``inventory`` scenario (this sweep's
    ``capture_sweep`` and the engine's ``capture``): at least two tags replied in the slot,
    the reader accepted the RN16 (its acceptance gate; none with
    ``reader.rn16_false_accept = 0``) and the bits are exactly one replying tag's RN16
    (``decoded_tag`` ≥ 0), so the reader ACKs that tag, which then answers alone.

    Parameters
    ----------
    n_replies : int or array_like of int, shape (n,)
        Number of tags that replied in the slot.
    decoded_tag : int or array_like of int, shape (n,)
        Index of the tag whose RN16 the reader decoded exactly, −1 for none.
    accepted : bool or array_like of bool, shape (n,)
        The reader accepted the RN16 (its acceptance gate passed).

    Returns
    -------
    ndarray of bool, shape (n,) or ()
        True where the slot ended in capture (broadcast over the three inputs).
    """
    return (np.asarray(n_replies) >= 2) & np.asarray(accepted, bool) & (np.asarray(decoded_tag) >= 0)


@dataclass
class CapturePoint:
    """The records of one point (profile, spread, ratio): per-trial arrays.

    Attributes
    ----------
    profile : str
        Link profile name (:data:`rfsim.gen2.link.PROFILES`).
    spread : bool
        Tags with their own BLF error and T1 (True) or identical in lock-step (False).
    ratio_db : float
        Modulated power ratio of the two replies at the reader [dB].
    detected : ndarray of bool, shape (trials,)
        The preamble correlation passed its false-alarm threshold.
    decoded : ndarray of int, shape (trials,)
        0: the stronger tag's RN16 decoded exactly, 1: the weaker's, −1: neither.
    ebn0_db : ndarray, shape (trials,)
        Eb/N0 of the decoded RN16 from the residual noise power, 10·log10(|h|²·(2M/ρ)/σ²) [dB].
    decision_ebn0_db : ndarray, shape (trials,)
        Acceptance statistic: Eb/(N0 + I) in the decision domain [dB].
    corr : ndarray, shape (trials,)
        The coarse normalised preamble correlation at the decoded BLF and start.
    blf_error : ndarray, shape (trials, 2)
        BLF error of each tag (stronger first), a fraction.
    t1_s : ndarray, shape (trials, 2)
        T1 of each tag [s].
    """

    profile: str
    spread: bool
    ratio_db: float
    detected: np.ndarray
    decoded: np.ndarray  # 0 = stronger tag's RN16, 1 = weaker's, -1 = neither
    ebn0_db: np.ndarray
    decision_ebn0_db: np.ndarray
    corr: np.ndarray
    blf_error: np.ndarray  # (trials, 2) fractions
    t1_s: np.ndarray  # (trials, 2)


def _window(link, fs_hz: float):
    """(t0 [s after the command's last edge], samples, lo, hi): the RN16 window, from T1min
    minus 8 samples to T1max plus the reply at the slowest BLF plus 3 Tpri, and the start
    lags of the T1 window (±1 sample)."""
    tr = t1(link)
    t0 = tr.min_s - 8.0 / fs_hz
    dur = link.reply_duration_s(RN16_BITS) / (1.0 - link.frt) + 3.0 * link.tpri_s
    n = int(math.ceil((tr.max_s + dur - t0) * fs_hz))
    lo = max(0, int(math.floor((tr.min_s - t0) * fs_hz)) - 1)
    hi = int(math.ceil((tr.max_s - t0) * fs_hz)) + 1
    return t0, n, lo, hi


def simulate_point(cfg: CaptureSweepConfig, name: str, spread: bool, ratio_db: float, *, seed: int,
                   point: int) -> CapturePoint:
    r"""Simulate and decode all ``cfg.trials`` collisions of one point (module docstring).

    The reader input is :math:`y(t) = h_1 s_1(t) + h_2 s_2(t) + n(t)` with
    :math:`|h_1| = 1`, :math:`|h_2| = 10^{-\mathrm{ratio}/20}`, uniform phases, and
    complex white noise setting the stronger reply at Eb/N0 = ``cfg.strong_ebn0_db``
    (the project's own model, module docstring).

    Parameters
    ----------
    cfg : CaptureSweepConfig
        The sweep's settings.
    name : str
        Link profile name (:data:`rfsim.gen2.link.PROFILES`).
    spread : bool
        Draw each tag's BLF error and T1 from ``cfg.spread`` (True) or use the nominal
        BLF and T1 (False, tags in lock-step).
    ratio_db : float
        Modulated power ratio of the two replies at the reader [dB].
    seed : int
        Root seed.
    point : int
        Index of the point; its stream is ``trial_rng(seed, SEED_OFFSET + point)``.

    Returns
    -------
    CapturePoint
        The per-trial records.
    """
    link = profile(name)
    fs = 2.0 * link.blf_hz * cfg.samples_per_element
    t0, n, lo, hi = _window(link, fs)
    nt = cfg.trials
    rng = trial_rng(seed, SEED_OFFSET + point)
    bits = rng.integers(0, 2, (nt, 2, RN16_BITS), dtype=np.uint8)
    sp = cfg.spread if spread else TagSpreadConfig()
    tag = TagConfig()
    blf0, t1_0 = tag.reply_timing(link)  # the tag rules without spread (exact counts)
    eps = sp.blf_errors(link.frt, 2 * nt, rng=rng).reshape(nt, 2)
    t1v = sp.t1_values_s(link, 2 * nt, tick_s=1.0 / tag.clock.f_hz, rng=rng).reshape(nt, 2)
    t1_s = t1_0 + (t1v - t1(link).nom_s)  # counted T1 + the tag's offset
    phases = rng.uniform(0.0, 2.0 * math.pi, (nt, 2))
    amp = np.array([1.0, 10.0 ** (-ratio_db / 20.0)])
    h = amp * np.exp(1j * phases)
    sigma2 = (link.m * fs / link.blf_hz) / 10.0 ** (cfg.strong_ebn0_db / 10.0)  # |h1|²·(samples/bit)/σ² = Eb/N0
    # √(σ²/2)·(a + j·b), a then b drawn from rng, built in place (no full-size temporaries)
    y = np.empty((nt, n), dtype=np.complex128)
    draw = np.empty((nt, n))
    rng.standard_normal(out=draw)
    y.real = draw
    rng.standard_normal(out=draw)
    y.imag = draw
    del draw
    y *= math.sqrt(sigma2 / 2.0)
    for j in range(nt):
        for k in range(2):
            s = _linecode.reply_waveform(bits[j, k], m=link.m, trext=link.trext, blf_hz=blf0 * (1.0 + eps[j, k]), fs_hz=fs,
                                         t0_s=t1_s[j, k] - t0, n_samples=n)
            s[s == 0] = -1.0
            y[j] += h[j, k] * s
    # the reader's BLF search ("blf" plan of the one decoder) on the windows as drawn
    plan = _decoder.LinkPlans(link).plan("blf", fs, "viterbi", cfg.false_alarm_probability, dc_from_lead=False)
    out = _decoder.decode(y, plan, lo=lo, hi=hi, n_bits=RN16_BITS, threads=cfg.threads)
    detected = out.found
    match = np.all(out.bits[:, None, :] == bits, axis=2)  # (nt, 2)
    decoded = np.where(match[:, 0], 0, np.where(match[:, 1], 1, -1))
    return CapturePoint(name, spread, float(ratio_db), detected, decoded, out.extra["ebn0_db"], out.decision_ebn0_db, out.corr,
                        eps, t1_s)


def run_sweep(cfg: CaptureSweepConfig, *, seed: int) -> list[CapturePoint]:
    """Simulate every point: profiles × (without, with spread) × ratios, in that order.

    Parameters
    ----------
    cfg : CaptureSweepConfig
        The sweep's settings.
    seed : int
        Root seed; point p draws from ``trial_rng(seed, SEED_OFFSET + p)``.

    Returns
    -------
    list of CapturePoint
        One per point, in the order above.
    """
    plan = [(name, spread, r) for name in cfg.profiles for spread in (False, True) for r in cfg.ratios_db]
    return [simulate_point(cfg, name, spread, r, seed=seed, point=p)
            for p, (name, spread, r) in enumerate(track(plan, desc="capture sweep", unit="points"))]


POINT_FIELDS = {
    "profile": ("", "link profile (line code and BLF)"),
    "line_code": ("", "FM0 or Miller-M"),
    "spread": ("1", "tags with their own BLF error and T1 (1) or identical in lock-step (0)"),
    "ratio_db": ("dB", "modulated power ratio of the two replies at the reader: as simulated (the x-axis of the "
                       "engine's capture table too)"),
    "trials": ("1", "number of collided slots simulated at this point"),
    "p_capture": ("1", "P(capture) (rfsim.scenes.capture_sweep.captured): RN16 accepted at threshold_db and exactly "
                        "one tag's (the reader ACKs a tag that sent it)"),
    "ci_lo": ("1", "Clopper-Pearson 95 % lower bound of p_capture"),
    "ci_hi": ("1", "Clopper-Pearson 95 % upper bound of p_capture"),
    "p_capture_weak": ("1", "fraction of collisions in which the weaker tag was captured"),
    "p_decoded": ("1", "fraction decoded exactly (one tag's RN16), before the acceptance gate: P(capture) of a "
                       "reader without gate, the engine's capture table's rule"),
    "p_false_ack": ("1", "fraction accepted although the bits are neither tag's RN16 (false ACK)"),
    "p_detected": ("1", "fraction with a preamble detected"),
    "threshold_db": ("dB", "the acceptance threshold used (Eb/(N0+I) of the decoded RN16)"),
}

TRIAL_FIELDS = {
    "point": ("1", "row of the capture_sweep table"),
    "decoded": ("1", "0: the stronger tag's RN16 decoded, 1: the weaker's, -1: neither"),
    "detected": ("1", "the reader's preamble correlation passed its false-alarm threshold"),
    "ebn0_db": ("dB", "acceptance statistic: Eb/(N0+I) of the decoded RN16 in the decision domain"),
    "blf_error_1": ("1", "BLF error of the stronger tag (fraction)"),
    "blf_error_2": ("1", "BLF error of the weaker tag (fraction)"),
    "t1_1_s": ("s", "T1 of the stronger tag"),
    "t1_2_s": ("s", "T1 of the weaker tag"),
}

ACCEPT_FIELDS = {
    "profile": ("", "link profile name (rfsim.gen2.link.PROFILES) of the pooled collisions"),
    "spread": ("1", "tags with spread (1) or in lock-step (0)"),
    "threshold_db": ("dB", "acceptance threshold on Eb/(N0+I)"),
    "false_ack_rate": ("1", "accepted with bits no tag sent, per collided slot (all ratios pooled)"),
    "missed_capture_rate": ("1", "rejected although the RN16 was one tag's, per such slot"),
    "capture_rate": ("1", "accepted and one tag's RN16, per collided slot"),
    "collisions": ("1", "collided slots pooled"),
    "captures": ("1", "collided slots whose decoded RN16 was one tag's (the missed-capture rate's denominator)"),
}


def _line_code(m: int) -> str:
    return "FM0" if m == 1 else f"Miller-{m}"


def tables(cfg: CaptureSweepConfig, points: list[CapturePoint]) -> tuple[dict, dict, dict]:
    """Build the sweep's three tables from its points.

    Parameters
    ----------
    cfg : CaptureSweepConfig
        The sweep's settings (acceptance threshold from ``rn16_false_accept``, the
        thresholds of the acceptance table).
    points : list of CapturePoint
        The points of :func:`run_sweep`.

    Returns
    -------
    capture_sweep : dict of str to list
        One row per point, columns of :data:`POINT_FIELDS` (P(capture) with its
        Clopper-Pearson 95 % interval, ...).
    capture_trials : dict of str to ndarray
        One row per trial, columns of :data:`TRIAL_FIELDS`.
    acceptance : dict of str to list
        One row per (profile, spread, threshold), all ratios pooled, columns of
        :data:`ACCEPT_FIELDS`.
    """
    gamma = _reader.rn16_threshold_db(cfg.rn16_false_accept)
    rows: dict[str, list] = {k: [] for k in POINT_FIELDS}
    trials: dict[str, list] = {k: [] for k in TRIAL_FIELDS}
    for i, pt in enumerate(points):
        acc = pt.detected & (pt.decision_ebn0_db >= gamma)
        cap = captured(2, pt.decoded, acc)
        p, lo, hi, n = _st_analytic.cancellation_probability(cap)
        vals = dict(profile=pt.profile, line_code=_line_code(profile(pt.profile).m), spread=int(pt.spread),
                    ratio_db=pt.ratio_db, trials=int(n), p_capture=float(p), ci_lo=float(lo), ci_hi=float(hi),
                    p_capture_weak=float(np.mean(acc & (pt.decoded == 1))), p_decoded=float(np.mean(pt.decoded >= 0)),
                    p_false_ack=float(np.mean(acc & (pt.decoded < 0))), p_detected=float(np.mean(pt.detected)),
                    threshold_db=gamma)
        for k, v in vals.items():
            rows[k].append(v)
        m = pt.decoded.size
        for k, v in dict(point=np.full(m, i), decoded=pt.decoded, detected=pt.detected.astype(np.uint8),
                         ebn0_db=pt.decision_ebn0_db, blf_error_1=pt.blf_error[:, 0], blf_error_2=pt.blf_error[:, 1],
                         t1_1_s=pt.t1_s[:, 0], t1_2_s=pt.t1_s[:, 1]).items():
            trials[k].append(np.asarray(v))
    trials = {k: np.concatenate(v) if v else np.zeros(0) for k, v in trials.items()}
    accept: dict[str, list] = {k: [] for k in ACCEPT_FIELDS}
    for name in cfg.profiles:
        for spread in (False, True):
            sel = [pt for pt in points if pt.profile == name and pt.spread == spread]
            if not sel:
                continue
            det = np.concatenate([pt.detected for pt in sel])
            dec = np.concatenate([pt.decoded for pt in sel])
            st = np.concatenate([pt.decision_ebn0_db for pt in sel])
            right = dec >= 0
            for g in cfg.thresholds_db:
                a = det & (st >= g)
                for k, v in dict(profile=name, spread=int(spread), threshold_db=float(g),
                                 false_ack_rate=float(np.mean(a & ~right)),
                                 missed_capture_rate=float(np.sum(~a & right) / max(1, np.sum(right))),
                                 capture_rate=float(np.mean(a & right)), collisions=int(dec.size),
                                 captures=int(np.sum(right))).items():
                    accept[k].append(v)
    return rows, trials, accept


__all__ = ["TABLES_COMPARED", "captured", "CaptureSweepConfig", "CapturePoint", "simulate_point", "run_sweep", "tables", "POINT_FIELDS", "TRIAL_FIELDS",
           "ACCEPT_FIELDS"]

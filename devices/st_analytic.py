"""Closed forms of phase cancellation at a sense-a-tag (ST) and of its dual-antenna remedies.

The ST hears the reader's CW (amplitude ``A_R``) and a tag's backscatter in two reflection
states (amplitudes ``A_T1``, ``A_T2`` for ASK; one amplitude ``A_T`` and a phase step ψ for
PSK) with a relative phase θ; an envelope detector sees ``A_i = |A_R + A_Ti·e^{jθ}|`` and
the modulation it can detect is ``|A1 − A2|``. All amplitudes are in the same unit (V at
the ST antenna or detector in the source tables); angles in rad. Every function
broadcasts over NumPy arrays.

Sources: auris-sense-a-tag.md §1.3 (ASK, Eq. 3.3–3.5, seed L2491-2662), §1.4 (PSK,
Eq. 3.8–3.11, L2663-2815), §1.5 (simple combination, Eq. 3.15/3.17/3.21/3.22,
L2854-3121), §1.6 (Algorithm 1, L3182-3196; spatial null model Eq. 3.23, L3205-3289),
§4.1 R3-5 (phase-cancellation probability, L3472-3502), §5 (ASK-PSK stamp, L5874-6023).

Antenna convention (as in the source): SA1 feeds the receive-only path P1, SA2 the full ST
path P2 (with the backscatter modulator). A single-antenna ST is the P2 path alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


from rfsim.core.errors import ConfigError
from rfsim.core.units import wavelength_m
from rfsim.core.lazy import lazy_import

_optimize = lazy_import("scipy.optimize")
_stats = lazy_import("scipy.stats")

#: Phase-cancellation threshold on the envelope-detector output difference [V]
#: (auris-sense-a-tag.md §3.1, seed L3443-3445, L3500-3502).
THRESHOLD_V = 5e-3


# ----------------------------------------------------------------------------- single antenna


def envelope_amplitude(a_r, a_t, theta_rad):
    """Envelope of CW + one backscatter state, Eq. 3.3 (seed L2532-2560).

    ``A = sqrt(A_R² + 2·A_R·A_T·cos θ + A_T²) = |A_R + A_T·e^{jθ}|``.
    """
    a_r, a_t, th = np.asarray(a_r, float), np.asarray(a_t, float), np.asarray(theta_rad, float)
    return np.sqrt(np.maximum(a_r * a_r + 2.0 * a_r * a_t * np.cos(th) + a_t * a_t, 0.0))


def ask_envelope_difference(a_r, a_t1, a_t2, theta_rad):
    """ASK envelope difference ``|A1 − A2|``, Eq. 3.4 (seed L2562-2595).

    ``|A_T1 − A_T2|·|A_T1 + A_T2 + 2·A_R·cos θ| / (A1 + A2)`` with ``A_i`` from Eq. 3.3
    (the rationalised form: no cancellation of nearly equal square roots near the null).

    Parameters
    ----------
    a_r : CW amplitude at the ST antenna [V]
    a_t1, a_t2 : backscatter amplitudes of the two reflection states [V]
    theta_rad : relative phase between the CW and the backscatter [rad]
    """
    a_r, a_t1, a_t2 = (np.asarray(v, float) for v in (a_r, a_t1, a_t2))
    c = np.cos(np.asarray(theta_rad, float))
    den = envelope_amplitude(a_r, a_t1, theta_rad) + envelope_amplitude(a_r, a_t2, theta_rad)
    num = np.abs(a_t1 - a_t2) * np.abs(a_t1 + a_t2 + 2.0 * a_r * c)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def ask_cancel_angle(a_r, a_t1, a_t2):
    """Cancellation angle ``θ_cancel = arccos(−(A_T1 + A_T2)/(2·A_R))``, Eq. 3.5 (L2597-2608).

    Nulls of Eq. 3.4 lie at ``θ = ±θ_cancel`` (mod 2π). NaN where no null exists
    (``A_T1 + A_T2 > 2·A_R``).
    """
    a_r, a_t1, a_t2 = (np.asarray(v, float) for v in (a_r, a_t1, a_t2))
    x = -(a_t1 + a_t2) / (2.0 * a_r)
    with np.errstate(invalid="ignore"):
        return np.where(np.abs(x) <= 1.0, np.arccos(np.clip(x, -1.0, 1.0)), np.nan)


def psk_envelope_difference(a_r, a_t, psi_rad, theta_rad):
    """PSK envelope difference ``|A1 − A2|``, Eq. 3.9 (seed L2735-2762).

    ``2·A_R·A_T·|cos θ − cos(θ+ψ)| / (A1 + A2)`` with ``A1 = |A_R + A_T e^{jθ}|``,
    ``A2 = |A_R + A_T e^{j(θ+ψ)}|`` (Eq. 3.8, with the seed's ``A_T2`` misprint read as
    ``A_T``, reference §0.4).
    """
    a_r, a_t = np.asarray(a_r, float), np.asarray(a_t, float)
    th, psi = np.asarray(theta_rad, float), np.asarray(psi_rad, float)
    den = envelope_amplitude(a_r, a_t, th) + envelope_amplitude(a_r, a_t, th + psi)
    num = 2.0 * a_r * a_t * np.abs(np.cos(th) - np.cos(th + psi))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def psk_cancel_angles(psi_rad, k=(0, 1)):
    """PSK null angles ``θ_cancel = −ψ/2 + k·π``, Eq. 3.10/3.11 (seed L2764-2775).

    Returns the angles for the integers ``k`` (broadcast against ``psi_rad``).
    """
    return -0.5 * np.asarray(psi_rad, float)[..., None] + np.pi * np.asarray(k, float)


def psk_peak_difference(a_t, psi_rad):
    """Maximum over θ of Eq. 3.9: ``2·A_T·sin(ψ/2)`` (Fig. 3.5, reference §1.4).

    The envelope difference of two phasors is at most the length of the chord between the
    backscatter states, ``|A_T − A_T·e^{jψ}|``; the bound is reached where the chord points
    at the origin, which exists when ``A_R ≥ A_T·cos(ψ/2)``.
    """
    return 2.0 * np.asarray(a_t, float) * np.abs(np.sin(0.5 * np.asarray(psi_rad, float)))


# ----------------------------------------------------------------------------- dual antenna


@dataclass(frozen=True)
class CombinedSignal:
    """Simple-combination phasors of Eq. 3.15 (arrays broadcast from the inputs).

    Attributes
    ----------
    a_r, alpha_rad : ``Â_R·e^{jα} = A_R + A_R′·e^{jθ1}`` [V], [rad]
    a_t1, beta1_rad : ``Â_T1·e^{jβ1} = A_T1 + A_T1′·e^{j(θ1+θ′−θ)}``
    a_t2, beta2_rad : ``Â_T2·e^{jβ2} = A_T2 + A_T2′·e^{j(θ1+θ′−θ)}``
    theta_rad : θ of SA1 (the combined relative phase is ``β + θ − α``)
    """

    a_r: np.ndarray
    alpha_rad: np.ndarray
    a_t1: np.ndarray
    beta1_rad: np.ndarray
    a_t2: np.ndarray
    beta2_rad: np.ndarray
    theta_rad: np.ndarray

    @property
    def beta_rad(self) -> np.ndarray:
        """β = β1 (= β2 when ``A_T1/A_T1′ = A_T2/A_T2′``, Eq. 3.17)."""
        return self.beta1_rad

    @property
    def relative_phase_rad(self) -> np.ndarray:
        """Relative phase of the combined signal ``β + θ − α`` (Eq. 3.18-3.21)."""
        return self.beta1_rad + self.theta_rad - self.alpha_rad


def combine_dual(a_r, a_t1, a_t2, theta_rad, a_r_p, a_t1_p, a_t2_p, theta_p_rad, theta1_rad):
    """RF sum of the two ST antennas, Eq. 3.14/3.15 (seed L2901-2943).

    Parameters
    ----------
    a_r, a_t1, a_t2, theta_rad : CW amplitude, state amplitudes and relative phase at SA1
    a_r_p, a_t1_p, a_t2_p, theta_p_rad : the same at SA2 (primed quantities)
    theta1_rad : CW phase at SA2 relative to SA1

    Returns
    -------
    CombinedSignal
    """
    th, thp, th1 = (np.asarray(v, float) for v in (theta_rad, theta_p_rad, theta1_rad))
    r = np.asarray(a_r, float) + np.asarray(a_r_p, float) * np.exp(1j * th1)
    rot = np.exp(1j * (th1 + thp - th))
    t1 = np.asarray(a_t1, float) + np.asarray(a_t1_p, float) * rot
    t2 = np.asarray(a_t2, float) + np.asarray(a_t2_p, float) * rot
    return CombinedSignal(a_r=np.abs(r), alpha_rad=np.angle(r), a_t1=np.abs(t1), beta1_rad=np.angle(t1),
                          a_t2=np.abs(t2), beta2_rad=np.angle(t2), theta_rad=np.broadcast_to(th, r.shape))


def combined_envelope_difference(comb: CombinedSignal):
    """``|A1 − A2|`` of the combined signal, Eq. 3.21 (seed L3074-3089).

    Eq. 3.4 with ``A_R → Â_R``, ``A_Ti → Â_Ti`` and ``θ → β + θ − α``; β1 and β2 are kept
    separate (exact for any amplitudes): ``A_i = |Â_R + Â_Ti·e^{j(βi+θ−α)}|``.
    """
    a1 = envelope_amplitude(comb.a_r, comb.a_t1, comb.beta1_rad + comb.theta_rad - comb.alpha_rad)
    a2 = envelope_amplitude(comb.a_r, comb.a_t2, comb.beta2_rad + comb.theta_rad - comb.alpha_rad)
    same = np.isclose(comb.beta1_rad, comb.beta2_rad, rtol=0.0, atol=1e-12)
    eq321 = ask_envelope_difference(comb.a_r, comb.a_t1, comb.a_t2, comb.relative_phase_rad)
    return np.where(same, eq321, np.abs(a1 - a2))


def combined_cancel_angle(comb: CombinedSignal):
    """Cancellation condition of the combination, Eq. 3.22 (seed L3091-3096).

    Returns ``arccos(−(Â_T1 + Â_T2)/(2·Â_R))``; the combined signal cancels when
    ``β + θ − α`` equals ± this value.
    """
    return ask_cancel_angle(comb.a_r, comb.a_t1, comb.a_t2)


# ----------------------------------------------------------------------------- Eq. 3.23 null map


@dataclass(frozen=True)
class NullMapModel:
    """Spatial model of Eq. 3.23 (seed L3205-3262) with the PASS-measured constants.

    ``A_T1 = A_T1_bsk/r``, ``A_T2 = A_T2_bsk/r``, ``A_R = A_R_trans/R̃`` and
    ``θ = 2π(R̃ − r)/λ + θ_C``, where R̃ is the reader–ST and r the tag–ST distance [m].
    Defaults: reader (0, 0), tag (0, 2), 915 MHz (reference §1.6, L3256-3262).
    """

    a_t1_bsk: float = 0.0526
    a_t2_bsk: float = 0.0485
    a_r_trans: float = 2.5612
    theta_c_rad: float = np.pi / 8
    reader_xy_m: tuple[float, float] = (0.0, 0.0)
    tag_xy_m: tuple[float, float] = (0.0, 2.0)
    fc_hz: float = 915e6

    def __post_init__(self):
        for key in ("a_t1_bsk", "a_t2_bsk", "a_r_trans", "fc_hz"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v > 0):
                raise ConfigError(key, v, "> 0")

    @property
    def wavelength_m(self) -> float:
        return float(wavelength_m(self.fc_hz))

    def amplitudes(self, x_m, y_m):
        """``(A_R, A_T1, A_T2, θ)`` at ST positions ``(x_m, y_m)`` (broadcast arrays)."""
        x, y = np.asarray(x_m, float), np.asarray(y_m, float)
        rr = np.hypot(x - self.reader_xy_m[0], y - self.reader_xy_m[1])
        r = np.hypot(x - self.tag_xy_m[0], y - self.tag_xy_m[1])
        with np.errstate(divide="ignore"):
            a_r, a_t1, a_t2 = self.a_r_trans / rr, self.a_t1_bsk / r, self.a_t2_bsk / r
        theta = 2.0 * np.pi * (rr - r) / self.wavelength_m + self.theta_c_rad
        return a_r, a_t1, a_t2, theta

    def envelope_difference(self, x_m, y_m):
        """Map of ``|A1 − A2|`` (Eq. 3.4 with Eq. 3.23), Fig. 3.8 [V]."""
        return ask_envelope_difference(*self.amplitudes(x_m, y_m))

    def axis_point(self, s_m):
        """Point at distance ``s_m`` from the reader along the reader→tag axis."""
        p0, p1 = np.asarray(self.reader_xy_m, float), np.asarray(self.tag_xy_m, float)
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        s = np.asarray(s_m, float)[..., None]
        q = p0 + s * u
        return q[..., 0], q[..., 1]

    def _null_function(self, s_m):
        # cos θ + (A_T1 + A_T2)/(2 A_R): zero exactly where A_T1 + A_T2 + 2 A_R cos θ = 0
        a_r, a_t1, a_t2, th = self.amplitudes(*self.axis_point(s_m))
        return np.cos(th) + (a_t1 + a_t2) / (2.0 * a_r)

    def axis_nulls_m(self, s_min_m: float, s_max_m: float, *, step_m: float = 1e-3) -> np.ndarray:
        """Positions of the nulls along the reader→tag axis [m from the reader].

        Roots of ``A_T1 + A_T2 + 2·A_R·cos θ`` (the numerator of Eq. 3.4) between
        ``s_min_m`` and ``s_max_m``, bracketed on a ``step_m`` grid and refined with Brent's
        method. Between reader and tag ``R̃ − r`` grows by 2 m per m, so θ turns by π every
        λ/4 and the nulls (θ = ±θ_cancel) are spaced ≈ λ/4 (reference §1.6, L3271-3280).
        Beyond the tag ``R̃ − r`` is constant and there are no nulls on the axis.
        """
        if not 0 <= s_min_m < s_max_m:
            raise ValueError(f"need 0 <= s_min_m < s_max_m, got {s_min_m}, {s_max_m}")
        s = np.arange(s_min_m, s_max_m + 0.5 * step_m, step_m)
        f = self._null_function(s)
        idx = np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)
        f1 = lambda v: float(self._null_function(np.array([v]))[0])  # noqa: E731
        return np.array([_optimize.brentq(f1, s[i], s[i + 1], xtol=1e-12) for i in idx])


# ----------------------------------------------------------------------------- decisions


def select_path(id1, id2):
    """Receiving-path selection, Algorithm 1 (seed L3182-3196).

    ``return ID2 if ID2 != NULL else ID1`` — ``None`` stands for NULL (nothing decoded).
    P2 is the full ST path (SA2), P1 the receive-only path (SA1).
    """
    return id2 if id2 is not None else id1


def select_detected(detected_p1, detected_p2):
    """Vectorised Algorithm 1 on detection flags: detected if P2 or (else) P1 decodes."""
    return np.logical_or(np.asarray(detected_p2, bool), np.asarray(detected_p1, bool))


def stamp_select(ask_diff_p2_v, ask_diff_p1_v, psk_diff_p2_v=None, *, threshold_v: float = THRESHOLD_V):
    """ASK-PSK stamp path switching of chapter 5 (seed L5874-6023), on envelope differences.

    The active path is P2; its decoded ASK stamp symbol is ``'-'`` when its ASK envelope
    difference is below the threshold, and then the ST switches to P1 (L5984-5990,
    L6019-6023). The PSK stamp symbol (``psk_diff_p2_v`` above threshold) tells a
    cancellation ('-' in ASK but PSK present) from an absent signal.

    Returns
    -------
    detected : bool array, the ASK data frame is detected on the chosen path
    use_p1 : bool array, the stamp made the ST switch to P1
    cancel_flagged : bool array or None, ASK '-' while the PSK stamp is present

    With ideal decisions this equals :func:`select_detected` (both pick the path whose ASK
    difference exceeds the threshold, P2 first); the source reports the two within 0.1 %
    (R5-1).
    """
    a2, a1 = np.asarray(ask_diff_p2_v, float), np.asarray(ask_diff_p1_v, float)
    use_p1 = ~(a2 > threshold_v)
    detected = np.where(use_p1, a1 > threshold_v, True)
    flagged = None
    if psk_diff_p2_v is not None:
        flagged = use_p1 & (np.asarray(psk_diff_p2_v, float) > threshold_v)
    return detected, use_p1, flagged


def phase_cancelled(diff_v, diff_sync_v, *, threshold_v: float = THRESHOLD_V):
    """Per-sample phase-cancellation flag of R3-5 (reference §4.1, seed L3472-3502).

    A sample is cancelled when the envelope difference with the CW synchronised to the
    backscatter (θ forced to 0, ``diff_sync_v``) exceeds the threshold but the actual
    difference ``diff_v`` does not. (Operational reading of the source's condition; the
    denominator of the probability is every sample of the cell.)
    """
    return (np.asarray(diff_sync_v, float) > threshold_v) & ~(np.asarray(diff_v, float) > threshold_v)


def cancellation_probability(flags, *, axis=None, confidence: float = 0.95):
    """Probability of phase cancellation with its Clopper–Pearson interval.

    Parameters
    ----------
    flags : bool array (e.g. (cells, samples)) from :func:`phase_cancelled`
    axis : axis holding the samples (None = all)
    confidence : two-sided level of the exact binomial interval

    Returns
    -------
    p, lo, hi, n : arrays (or scalars): k/n and the interval ``Beta(α/2; k, n−k+1)``,
    ``Beta(1−α/2; k+1, n−k)``.
    """
    if not 0 < confidence < 1:
        raise ConfigError("confidence", confidence, "0 < confidence < 1")
    f = np.asarray(flags, bool)
    k = f.sum(axis=axis)
    n = f.size if axis is None else f.shape[axis]
    if n == 0:
        raise ValueError("no samples")
    a = 1.0 - confidence
    k = np.asarray(k, float)
    lo = np.where(k > 0, _stats.beta.ppf(a / 2, np.maximum(k, 1), n - k + 1), 0.0)
    hi = np.where(k < n, _stats.beta.ppf(1 - a / 2, k + 1, np.maximum(n - k, 1)), 1.0)
    return k / n, lo, hi, n


def sync_envelope_difference(a_t1, a_t2):
    """Envelope difference with the CW in phase with collinear ASK states (θ = 0):
    ``|A_T1 − A_T2|`` (for complex states use :func:`synchronised_difference`)."""
    return np.abs(np.asarray(a_t1, float) - np.asarray(a_t2, float))


def synchronised_difference(cw, bs1, bs2, *, n_grid: int = 64, n_refine: int = 40):
    """Detectability: envelope difference with the CW synchronised to the backscatter [V].

    ``D_sync = max over φ of ||c·e^{jφ} + b1| − |c·e^{jφ} + b2||`` for the CW phasor ``c``
    and the backscatter phasors ``b1``, ``b2`` of the two reflection states at one antenna
    (the source's condition for a detectable sample, R3-5: "the envelope detector output of
    the superimposed signal of tag's backscattering signal and synchronized Reader's CW",
    seed L3490-3502; reference §4.1). The CW's phase is free, its amplitude is not.

    Closed form. By the triangle inequality ``D_sync ≤ |b1 − b2|``, with equality where the
    point ``p = −c·e^{jφ}`` lies on the line ``b1 + s·(b2 − b1)`` outside the open segment
    (0 < s < 1): then ``b1 − p`` and ``b2 − p`` are parallel and their lengths differ by
    ``|b1 − b2|``. The line meets the circle ``|p| = |c|`` where
    ``|d|²s² + 2·Re(b1*·d)·s + |b1|² − |c|² = 0`` (``d = b2 − b1``); whenever a real root
    lies outside (0, 1) — always when ``|c| ≥ max(|b1|, |b2|)``, the CW-dominant regime of
    the ST — ``D_sync = |b1 − b2|`` exactly (≈ |b1 − b2| for weak backscatter as the issue
    states; ``|A_T1 − A_T2|`` for collinear ASK states). Otherwise (backscatter stronger
    than the CW, e.g. an ST antenna millimetres from the tag) the maximum is found
    numerically: an ``n_grid``-point grid over φ, then ``n_refine`` golden-section steps in
    the bracket around the best grid point.

    Parameters
    ----------
    cw, bs1, bs2 : complex phasors (broadcast) [V]

    Returns
    -------
    float64 array, ``D_sync`` [V]
    """
    c, b1, b2 = np.broadcast_arrays(*(np.asarray(v, complex) for v in (cw, bs1, bs2)))
    d = b2 - b1
    dd = np.abs(d) ** 2
    rc = np.abs(c)
    half_b = (np.conj(b1) * d).real
    disc = half_b ** 2 - dd * (np.abs(b1) ** 2 - rc ** 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        s_lo, s_hi = (-half_b - sq) / dd, (-half_b + sq) / dd
    exact = (dd == 0) | ((disc >= 0) & ((s_lo <= 0) | (s_hi >= 1)))
    out = np.where(exact, np.sqrt(dd), 0.0)
    if np.all(exact):
        return out
    idx = np.flatnonzero(~exact.ravel())
    cc, x1, x2 = c.ravel()[idx, None], b1.ravel()[idx, None], b2.ravel()[idx, None]

    def f(phi):
        p = cc * np.exp(1j * phi)
        return np.abs(np.abs(p + x1) - np.abs(p + x2))

    step = 2.0 * np.pi / n_grid
    grid = np.arange(n_grid) * step
    best = np.argmax(f(grid[None, :]), axis=1)
    a, b = (grid[best] - step)[:, None], (grid[best] + step)[:, None]
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    for _ in range(n_refine):
        m1, m2 = b - g * (b - a), a + g * (b - a)
        left = f(m1) > f(m2)
        b = np.where(left, m2, b)
        a = np.where(left, a, m1)
    flat = out.ravel().copy()
    flat[idx] = np.maximum(f(0.5 * (a + b))[:, 0], f(grid[best][:, None])[:, 0])
    return flat.reshape(out.shape)


@dataclass(frozen=True)
class TechniqueOutcome:
    """Envelope differences [V] and phase-cancellation flags of the four ST techniques
    (arrays broadcast from the inputs).

    Attributes
    ----------
    diff_sa1_v, diff_sa2_v, diff_combined_v : actual ``|A1 − A2|`` at SA1, SA2, of the RF sum
    sync_sa1_v, sync_sa2_v, sync_combined_v : the same with the CW synchronised (θ = 0)
    cancelled_single, cancelled_combination, cancelled_selection, cancelled_stamp : R3-5 flags
    """

    diff_sa1_v: np.ndarray
    diff_sa2_v: np.ndarray
    diff_combined_v: np.ndarray
    sync_sa1_v: np.ndarray
    sync_sa2_v: np.ndarray
    sync_combined_v: np.ndarray
    cancelled_single: np.ndarray
    cancelled_combination: np.ndarray
    cancelled_selection: np.ndarray
    cancelled_stamp: np.ndarray


def technique_outcomes(cw_sa1, bs1_sa1, bs2_sa1, cw_sa2, bs1_sa2, bs2_sa2, *, detector_gain: float = 1.0,
                       threshold_v: float = THRESHOLD_V, transfer=None) -> TechniqueOutcome:
    """Closed-form outcome of single / combination / selection / stamp from complex phasors.

    Parameters
    ----------
    cw_sa1, bs1_sa1, bs2_sa1 : complex phasors [V] at SA1 of the CW and of the backscatter in
        reflection states 1 and 2 (any common phase reference)
    cw_sa2, bs1_sa2, bs2_sa2 : the same at SA2 (the single-antenna ST is SA2 = path P2)
    detector_gain : envelope-detector output per input volt (linear regime)
    threshold_v : phase-cancellation threshold on the detector output difference [V]
    transfer : optional detector law ``v_out = transfer(V_peak)`` [V → V] (e.g. the diode's
        ``n·V_T·ln I0(G_v·V/(n·V_T))``, :meth:`rfsim.devices.st_receiver.EnvelopeDetector.transfer_v`);
        replaces ``detector_gain``. Actual differences ``|f(|c + b1|) − f(|c + b2|)|``;
        synchronised ``|f(|c| + D/2) − f(|c| − D/2)|`` with ``D`` = :func:`synchronised_difference`
        (the secant of the law across the swing around the CW level; exact for a linear law)

    Notes
    -----
    Actual differences: ``|A1 − A2|`` (Eq. 3.3/3.4) per antenna, and of the RF sum
    (Eq. 3.14/3.21). Synchronised differences (R3-5): :func:`synchronised_difference`
    ``max_φ ||c·e^{jφ} + b1| − |c·e^{jφ} + b2||`` per antenna and of the RF sum (= |b1 − b2|
    when the CW dominates; for collinear ASK states ``|A_T1 − A_T2|``, the no-CW limit
    ``||b1| − |b2||`` only then). Flags: one detectability condition for every
    technique — the single-antenna ST (SA2) would detect the tag with the CW synchronised
    (``sync_sa2_v > threshold``) — and the technique does not detect it: single = SA2,
    combination = the RF sum, selection = Algorithm 1 over SA1/SA2, stamp =
    :func:`stamp_select` (identical to selection with ideal decisions). With a common
    condition the techniques are compared on the same samples (selection ≤ single always).
    """
    g = float(detector_gain)
    c1, b11, b12, c2, b21, b22 = (np.asarray(v, complex) for v in (cw_sa1, bs1_sa1, bs2_sa1, cw_sa2, bs1_sa2,
                                                                  bs2_sa2))

    def diff(c, b1, b2):
        if transfer is not None:  # the detector law on the two envelopes
            return np.abs(transfer(np.abs(c + b1)) - transfer(np.abs(c + b2)))
        # Eq. 3.4 with θ = arg(b1/c) (= arg(b2/c) for ASK); general complex states: direct form
        th = np.angle(b1 * np.conj(c))
        same_phase = np.isclose(np.angle(b2 * np.conj(b1)), 0.0, atol=1e-12)
        eq34 = ask_envelope_difference(np.abs(c), np.abs(b1), np.abs(b2), th)
        return g * np.where(same_phase, eq34, np.abs(np.abs(c + b1) - np.abs(c + b2)))

    def sync(c, b1, b2):
        d = synchronised_difference(c, b1, b2)
        if transfer is None:
            return g * d
        a = np.abs(c)
        return np.abs(transfer(a + 0.5 * d) - transfer(np.maximum(a - 0.5 * d, 0.0)))

    d1, d2 = diff(c1, b11, b12), diff(c2, b21, b22)
    dc = diff(c1 + c2, b11 + b21, b12 + b22)
    s1, s2, sc = sync(c1, b11, b12), sync(c2, b21, b22), sync(c1 + c2, b11 + b21, b12 + b22)
    thr = threshold_v
    sel_detected = select_detected(d1 > thr, d2 > thr)
    stamp_detected = stamp_select(d2, d1, threshold_v=thr)[0]
    detectable = s2 > thr
    return TechniqueOutcome(
        diff_sa1_v=d1, diff_sa2_v=d2, diff_combined_v=dc, sync_sa1_v=s1, sync_sa2_v=s2, sync_combined_v=sc,
        cancelled_single=phase_cancelled(d2, s2, threshold_v=thr),
        cancelled_combination=detectable & ~(dc > thr),
        cancelled_selection=detectable & ~sel_detected,
        cancelled_stamp=detectable & ~stamp_detected,
    )


# ----------------------------------------------------------------------------- antenna pair coupling

#: Self impedance of a thin half-wave dipole [Ω] (Balanis, *Antenna Theory*, §4.6 / §8.6)
DIPOLE_Z11_OHM = complex(73.1, 42.5)
#: Mutual impedance of two parallel side-by-side half-wave dipoles λ/4 apart [Ω] (induced-EMF
#: method, Balanis §8.6 Fig. 8.20; the issue's 40.8 − j28.3 Ω)
DIPOLE_Z12_QUARTER_WAVE_OHM = complex(40.8, -28.3)


def mutual_impedance_half_wave_ohm(spacing_m, fc_hz: float = 915e6):
    """Mutual impedance of two parallel side-by-side half-wave dipoles [Ω] (induced-EMF method,
    Balanis *Antenna Theory* Eq. 8.71): with k = 2π/λ, l = λ/2, u0 = k·d,
    u1,2 = k·(sqrt(d² + l²) ± l), η/(4π) = 30 Ω:
    ``R12 = 30·[2·Ci(u0) − Ci(u1) − Ci(u2)]``, ``X12 = −30·[2·Si(u0) − Si(u1) − Si(u2)]``.
    λ/4 at 915 MHz: 40.4 − j28.4 Ω (the tabulated 40.8 − j28.3 Ω)."""
    from scipy.special import sici

    lam = float(wavelength_m(fc_hz))
    k, l = 2.0 * np.pi / lam, 0.5 * lam
    d = np.asarray(spacing_m, float)
    h = np.sqrt(d * d + l * l)
    (s0, c0), (s1, c1), (s2, c2) = sici(k * d), sici(k * (h + l)), sici(k * (h - l))
    return 30.0 * (2.0 * c0 - c1 - c2) - 30.0j * (2.0 * s0 - s1 - s2)


def coupling_matrix(z11_ohm: complex = DIPOLE_Z11_OHM, z12_ohm: complex = DIPOLE_Z12_QUARTER_WAVE_OHM,
                    z_load_ohm: complex | None = None) -> np.ndarray:
    """2×2 matrix taking the uncoupled port voltages of an antenna pair to the coupled ones.

    Two identical antennas with self impedance Z11, mutual impedance Z12, each terminated in
    ``Z_L`` (default the conjugate match of one antenna alone, ``Z11*``): their open-circuit
    voltages V_oc (what each would deliver alone, the engine's port signals) drive
    ``V_oc = (Z + Z_L·I)·I_port`` with ``Z = [[Z11, Z12], [Z12, Z11]]``, and the loads see
    ``V_L = Z_L·I_port``. Normalised so that Z12 = 0 gives the identity (the port signals
    already carry the single antenna's matched level):
    ``M = (Z11 + Z_L)·(Z + Z_L·I)⁻¹ = [[1, −c], [−c, 1]]/(1 − c²)``, ``c = Z12/(Z11 + Z_L)``
    (λ/4 dipoles, conjugate match: c = 0.28 − j0.19). Coupling mixes the CW and the
    backscatter alike, so it changes the relative phase θ between the two ports and with it
    which antenna is in a null. Neighbouring scatterers other than the pair (the ST body) are
    not modelled.
    """
    z11, z12 = complex(z11_ohm), complex(z12_ohm)
    zl = z11.conjugate() if z_load_ohm is None else complex(z_load_ohm)
    c = z12 / (z11 + zl)
    return np.array([[1.0, -c], [-c, 1.0]], dtype=complex) / (1.0 - c * c)


__all__ = [
    "THRESHOLD_V", "envelope_amplitude", "ask_envelope_difference", "ask_cancel_angle",
    "psk_envelope_difference", "psk_cancel_angles", "psk_peak_difference", "CombinedSignal",
    "combine_dual", "combined_envelope_difference", "combined_cancel_angle", "NullMapModel",
    "select_path", "select_detected", "stamp_select", "phase_cancelled", "cancellation_probability",
    "sync_envelope_difference", "synchronised_difference", "DIPOLE_Z11_OHM", "DIPOLE_Z12_QUARTER_WAVE_OHM",
    "mutual_impedance_half_wave_ohm", "coupling_matrix", "TechniqueOutcome", "technique_outcomes",
]

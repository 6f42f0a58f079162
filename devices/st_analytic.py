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
# the beta quantile as the inverse regularised incomplete beta function: scipy.special is light, scipy.stats
# costs ≈ 1 s of CPU to import (same values: both are Boost's ibeta_inv)
_special = lazy_import("scipy.special")

#: Phase-cancellation threshold on the envelope-detector output difference [V]
#: (auris-sense-a-tag.md §3.1, seed L3443-3445, L3500-3502).
THRESHOLD_V = 5e-3


# ----------------------------------------------------------------------------- single antenna


def envelope_amplitude(a_r, a_t, theta_rad):
    r"""Envelope of the CW plus one backscatter state, Eq. 3.3 (seed L2532-2560).

    .. math::

        A = \sqrt{A_R^2 + 2 A_R A_T \cos\theta + A_T^2} = |A_R + A_T e^{j\theta}|

    (auris-sense-a-tag.md §1.3). The radicand is clipped at 0 against rounding.

    Parameters
    ----------
    a_r : float or array_like
        CW amplitude at the ST antenna [V].
    a_t : float or array_like
        Backscatter amplitude of the reflection state [V].
    theta_rad : float or array_like
        Relative phase between the CW and the backscatter [rad].

    Returns
    -------
    numpy.ndarray
        Envelope amplitude ``A`` [V], broadcast shape of the inputs.
    """
    a_r, a_t, th = np.asarray(a_r, float), np.asarray(a_t, float), np.asarray(theta_rad, float)
    return np.sqrt(np.maximum(a_r * a_r + 2.0 * a_r * a_t * np.cos(th) + a_t * a_t, 0.0))


def ask_envelope_difference(a_r, a_t1, a_t2, theta_rad):
    r"""ASK envelope difference ``|A1 − A2|``, Eq. 3.4 (seed L2562-2595).

    .. math::

        |A_1 - A_2| = \frac{|A_{T1} - A_{T2}|\,|A_{T1} + A_{T2} + 2 A_R \cos\theta|}{A_1 + A_2}

    with ``A_i`` from Eq. 3.3 (the rationalised form: no cancellation of nearly equal square
    roots near the null; auris-sense-a-tag.md §1.3). Where ``A1 + A2 = 0`` the result is 0.

    Parameters
    ----------
    a_r : float or array_like
        CW amplitude at the ST antenna [V].
    a_t1, a_t2 : float or array_like
        Backscatter amplitudes of the two reflection states [V].
    theta_rad : float or array_like
        Relative phase between the CW and the backscatter [rad].

    Returns
    -------
    numpy.ndarray
        Envelope difference ``|A1 − A2|`` [V], broadcast shape of the inputs.
    """
    a_r, a_t1, a_t2 = (np.asarray(v, float) for v in (a_r, a_t1, a_t2))
    c = np.cos(np.asarray(theta_rad, float))
    den = envelope_amplitude(a_r, a_t1, theta_rad) + envelope_amplitude(a_r, a_t2, theta_rad)
    num = np.abs(a_t1 - a_t2) * np.abs(a_t1 + a_t2 + 2.0 * a_r * c)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def ask_cancel_angle(a_r, a_t1, a_t2):
    r"""Cancellation angle of ASK backscatter, Eq. 3.5 (seed L2597-2608).

    .. math::

        \theta_{cancel} = \arccos\left(-\frac{A_{T1} + A_{T2}}{2 A_R}\right)

    The nulls of Eq. 3.4 lie at ``θ = ±θ_cancel`` (mod 2π) (auris-sense-a-tag.md §1.3).

    Parameters
    ----------
    a_r : float or array_like
        CW amplitude at the ST antenna [V].
    a_t1, a_t2 : float or array_like
        Backscatter amplitudes of the two reflection states [V].

    Returns
    -------
    numpy.ndarray
        ``θ_cancel`` in [0, π] [rad]; NaN where no null exists (``A_T1 + A_T2 > 2·A_R``).
    """
    a_r, a_t1, a_t2 = (np.asarray(v, float) for v in (a_r, a_t1, a_t2))
    x = -(a_t1 + a_t2) / (2.0 * a_r)
    with np.errstate(invalid="ignore"):
        return np.where(np.abs(x) <= 1.0, np.arccos(np.clip(x, -1.0, 1.0)), np.nan)


def psk_envelope_difference(a_r, a_t, psi_rad, theta_rad):
    r"""PSK envelope difference ``|A1 − A2|``, Eq. 3.9 (seed L2735-2762).

    .. math::

        |A_1 - A_2| = \frac{2 A_R A_T |\cos\theta - \cos(\theta + \psi)|}{A_1 + A_2}

    with ``A1 = |A_R + A_T e^{jθ}|``, ``A2 = |A_R + A_T e^{j(θ+ψ)}|`` (Eq. 3.8, with the
    seed's ``A_T2`` misprint read as ``A_T``, reference §0.4; auris-sense-a-tag.md §1.4).
    Where ``A1 + A2 = 0`` the result is 0.

    Parameters
    ----------
    a_r : float or array_like
        CW amplitude at the ST antenna [V].
    a_t : float or array_like
        Backscatter amplitude, common to both PSK states [V].
    psi_rad : float or array_like
        Phase step ψ between the two reflection states [rad].
    theta_rad : float or array_like
        Relative phase between the CW and the backscatter of state 1 [rad].

    Returns
    -------
    numpy.ndarray
        Envelope difference ``|A1 − A2|`` [V], broadcast shape of the inputs.
    """
    a_r, a_t = np.asarray(a_r, float), np.asarray(a_t, float)
    th, psi = np.asarray(theta_rad, float), np.asarray(psi_rad, float)
    den = envelope_amplitude(a_r, a_t, th) + envelope_amplitude(a_r, a_t, th + psi)
    num = 2.0 * a_r * a_t * np.abs(np.cos(th) - np.cos(th + psi))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def psk_cancel_angles(psi_rad, k=(0, 1)):
    r"""PSK null angles, Eq. 3.10/3.11 (seed L2764-2775).

    .. math::

        \theta_{cancel} = -\psi/2 + k\pi

    (auris-sense-a-tag.md §1.4).

    Parameters
    ----------
    psi_rad : float or array_like
        Phase step ψ between the two reflection states [rad].
    k : sequence of int, default (0, 1)
        The integers ``k`` of the null family.

    Returns
    -------
    numpy.ndarray, shape psi_rad.shape + (len(k),)
        Null angles [rad]: the last axis runs over ``k``.
    """
    return -0.5 * np.asarray(psi_rad, float)[..., None] + np.pi * np.asarray(k, float)


def psk_peak_difference(a_t, psi_rad):
    r"""Maximum over θ of the PSK envelope difference, Eq. 3.9 (Fig. 3.5, reference §1.4).

    .. math::

        \max_\theta |A_1 - A_2| = 2 A_T |\sin(\psi/2)|

    The envelope difference of two phasors is at most the length of the chord between the
    backscatter states, ``|A_T − A_T·e^{jψ}|``; the bound is reached where the chord points
    at the origin, which exists when ``A_R ≥ A_T·cos(ψ/2)``.

    Parameters
    ----------
    a_t : float or array_like
        Backscatter amplitude, common to both PSK states [V].
    psi_rad : float or array_like
        Phase step ψ between the two reflection states [rad].

    Returns
    -------
    numpy.ndarray
        Peak envelope difference [V], broadcast shape of the inputs.
    """
    return 2.0 * np.asarray(a_t, float) * np.abs(np.sin(0.5 * np.asarray(psi_rad, float)))


# ----------------------------------------------------------------------------- dual antenna


@dataclass(frozen=True)
class CombinedSignal:
    """Simple-combination phasors of Eq. 3.15 (arrays broadcast from the inputs).

    Built by :func:`combine_dual` (auris-sense-a-tag.md §1.5).

    Attributes
    ----------
    a_r, alpha_rad : numpy.ndarray
        ``Â_R·e^{jα} = A_R + A_R′·e^{jθ1}``: combined CW amplitude [V] and phase α [rad].
    a_t1, beta1_rad : numpy.ndarray
        ``Â_T1·e^{jβ1} = A_T1 + A_T1′·e^{j(θ1+θ′−θ)}`` [V], [rad].
    a_t2, beta2_rad : numpy.ndarray
        ``Â_T2·e^{jβ2} = A_T2 + A_T2′·e^{j(θ1+θ′−θ)}`` [V], [rad].
    theta_rad : numpy.ndarray
        θ of SA1 [rad] (the combined relative phase is ``β + θ − α``).
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
    r"""RF sum of the two ST antennas, Eq. 3.14/3.15 (seed L2901-2943).

    .. math::

        \hat A_R e^{j\alpha} = A_R + A_R' e^{j\theta_1}, \qquad
        \hat A_{Ti} e^{j\beta_i} = A_{Ti} + A_{Ti}' e^{j(\theta_1 + \theta' - \theta)}

    (auris-sense-a-tag.md §1.5). All inputs broadcast against each other.

    Parameters
    ----------
    a_r, a_t1, a_t2 : float or array_like
        CW amplitude and backscatter amplitudes of reflection states 1 and 2 at SA1 [V].
    theta_rad : float or array_like
        Relative phase between CW and backscatter at SA1 [rad].
    a_r_p, a_t1_p, a_t2_p : float or array_like
        The same amplitudes at SA2 (primed quantities) [V].
    theta_p_rad : float or array_like
        Relative phase θ′ at SA2 [rad].
    theta1_rad : float or array_like
        CW phase at SA2 relative to SA1, θ1 [rad].

    Returns
    -------
    CombinedSignal
        Amplitudes [V] and phases [rad] of the combined phasors.
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

    Eq. 3.4 with ``A_R → Â_R``, ``A_Ti → Â_Ti`` and ``θ → β + θ − α``; where β1 and β2 differ
    (by more than 1e-12 rad) the direct form ``|A1 − A2|`` with
    ``A_i = |Â_R + Â_Ti·e^{j(βi+θ−α)}|`` is used (exact for any amplitudes;
    auris-sense-a-tag.md §1.5).

    Parameters
    ----------
    comb : CombinedSignal
        Combined phasors from :func:`combine_dual`.

    Returns
    -------
    numpy.ndarray
        Envelope difference of the RF sum [V].
    """
    a1 = envelope_amplitude(comb.a_r, comb.a_t1, comb.beta1_rad + comb.theta_rad - comb.alpha_rad)
    a2 = envelope_amplitude(comb.a_r, comb.a_t2, comb.beta2_rad + comb.theta_rad - comb.alpha_rad)
    same = np.isclose(comb.beta1_rad, comb.beta2_rad, rtol=0.0, atol=1e-12)
    eq321 = ask_envelope_difference(comb.a_r, comb.a_t1, comb.a_t2, comb.relative_phase_rad)
    return np.where(same, eq321, np.abs(a1 - a2))


def combined_cancel_angle(comb: CombinedSignal):
    r"""Cancellation condition of the combination, Eq. 3.22 (seed L3091-3096).

    .. math::

        \beta + \theta - \alpha = \pm\arccos\left(-\frac{\hat A_{T1} + \hat A_{T2}}{2 \hat A_R}\right)

    Parameters
    ----------
    comb : CombinedSignal
        Combined phasors from :func:`combine_dual`.

    Returns
    -------
    numpy.ndarray
        ``arccos(−(Â_T1 + Â_T2)/(2·Â_R))`` [rad]; the combined signal cancels when
        ``β + θ − α`` equals ± this value. NaN where no null exists.
    """
    return ask_cancel_angle(comb.a_r, comb.a_t1, comb.a_t2)


# ----------------------------------------------------------------------------- Eq. 3.23 null map


@dataclass(frozen=True)
class NullMapModel:
    r"""Spatial model of Eq. 3.23 (seed L3205-3262) with the PASS-measured constants.

    .. math::

        A_{T1} = A_{T1,bsk}/r, \quad A_{T2} = A_{T2,bsk}/r, \quad A_R = A_{R,trans}/\tilde R,
        \quad \theta = 2\pi(\tilde R - r)/\lambda + \theta_C

    where R̃ is the reader–ST and r the tag–ST distance [m]. Defaults: reader (0, 0),
    tag (0, 2), 915 MHz (auris-sense-a-tag.md §1.6, L3256-3262).

    Parameters
    ----------
    a_t1_bsk, a_t2_bsk : float, default 0.0526, 0.0485
        Backscatter amplitudes of the two states at 1 m from the tag [V·m] (> 0).
    a_r_trans : float, default 2.5612
        Reader CW amplitude at 1 m from the reader [V·m] (> 0).
    theta_c_rad : float, default π/8
        Constant phase offset θ_C [rad].
    reader_xy_m : tuple of float, default (0.0, 0.0)
        Reader position (x, y) [m].
    tag_xy_m : tuple of float, default (0.0, 2.0)
        Tag position (x, y) [m].
    fc_hz : float, default 915e6
        Carrier frequency [Hz] (> 0).

    Raises
    ------
    ConfigError
        If an amplitude or ``fc_hz`` is not finite and > 0.
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
        """Amplitudes and relative phase of Eq. 3.23 at ST positions.

        Parameters
        ----------
        x_m, y_m : float or array_like
            ST coordinates [m] (broadcast against each other).

        Returns
        -------
        a_r : numpy.ndarray
            CW amplitude ``A_R_trans/R̃`` [V] (inf on the reader).
        a_t1, a_t2 : numpy.ndarray
            Backscatter amplitudes ``A_Ti_bsk/r`` [V] (inf on the tag).
        theta : numpy.ndarray
            Relative phase ``2π(R̃ − r)/λ + θ_C`` [rad].
        """
        x, y = np.asarray(x_m, float), np.asarray(y_m, float)
        rr = np.hypot(x - self.reader_xy_m[0], y - self.reader_xy_m[1])
        r = np.hypot(x - self.tag_xy_m[0], y - self.tag_xy_m[1])
        with np.errstate(divide="ignore"):
            a_r, a_t1, a_t2 = self.a_r_trans / rr, self.a_t1_bsk / r, self.a_t2_bsk / r
        theta = 2.0 * np.pi * (rr - r) / self.wavelength_m + self.theta_c_rad
        return a_r, a_t1, a_t2, theta

    def envelope_difference(self, x_m, y_m):
        """Map of ``|A1 − A2|`` (Eq. 3.4 with Eq. 3.23), Fig. 3.8.

        Parameters
        ----------
        x_m, y_m : float or array_like
            ST coordinates [m] (broadcast against each other).

        Returns
        -------
        numpy.ndarray
            Envelope difference [V] at each position.
        """
        return ask_envelope_difference(*self.amplitudes(x_m, y_m))

    def axis_point(self, s_m):
        """Point at distance ``s_m`` from the reader along the reader→tag axis.

        Parameters
        ----------
        s_m : float or array_like
            Distance from the reader along the axis [m].

        Returns
        -------
        x_m, y_m : numpy.ndarray
            Coordinates of the points [m], shape of ``s_m``.
        """
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

        Roots of ``A_T1 + A_T2 + 2·A_R·cos θ`` (the numerator of Eq. 3.4) between ``s_min_m``
        and ``s_max_m``, bracketed on a ``step_m`` grid and refined with Brent's method. Between
        reader and tag ``R̃ − r`` grows by 2 m per m, so θ turns by π every λ/4 and the nulls
        (θ = ±θ_cancel) are spaced ≈ λ/4 (reference §1.6, L3271-3280). Beyond the tag ``R̃ − r``
        is constant and there are no nulls on the axis.

        Parameters
        ----------
        s_min_m, s_max_m : float
            Search interval along the axis [m], ``0 <= s_min_m < s_max_m``.
        step_m : float, default 1e-3
            Bracketing grid step [m]; two nulls closer than this may be missed.

        Returns
        -------
        numpy.ndarray, shape (n_nulls,)
            Null positions [m from the reader], ascending.

        Raises
        ------
        ValueError
            If not ``0 <= s_min_m < s_max_m``.
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

    ``return ID2 if ID2 != NULL else ID1``; ``None`` stands for NULL (nothing decoded).
    P2 is the full ST path (SA2), P1 the receive-only path (SA1) (auris-sense-a-tag.md §1.6).

    Parameters
    ----------
    id1 : object or None
        Tag ID decoded on path P1, or None.
    id2 : object or None
        Tag ID decoded on path P2, or None.

    Returns
    -------
    object or None
        ``id2`` if it is not None, else ``id1``.
    """
    return id2 if id2 is not None else id1


def select_detected(detected_p1, detected_p2):
    """Vectorised Algorithm 1 on detection flags: detected if P2 or (else) P1 decodes.

    Parameters
    ----------
    detected_p1 : bool or array_like of bool
        Detection on the receive-only path P1 (SA1).
    detected_p2 : bool or array_like of bool
        Detection on the full ST path P2 (SA2).

    Returns
    -------
    numpy.ndarray of bool
        ``detected_p2 or detected_p1``, broadcast shape of the inputs.
    """
    return np.logical_or(np.asarray(detected_p2, bool), np.asarray(detected_p1, bool))


def stamp_select(ask_diff_p2_v, ask_diff_p1_v, psk_diff_p2_v=None, *, threshold_v: float = THRESHOLD_V):
    """ASK-PSK stamp path switching of chapter 5 (seed L5874-6023), on envelope differences.

    The active path is P2; its decoded ASK stamp symbol is ``'-'`` when its ASK envelope
    difference is below the threshold, and then the ST switches to P1 (L5984-5990,
    L6019-6023). The PSK stamp symbol (``psk_diff_p2_v`` above threshold) tells a
    cancellation ('-' in ASK but PSK present) from an absent signal
    (auris-sense-a-tag.md §5).

    Parameters
    ----------
    ask_diff_p2_v : float or array_like
        ASK envelope difference on P2 [V].
    ask_diff_p1_v : float or array_like
        ASK envelope difference on P1 [V].
    psk_diff_p2_v : float or array_like, optional
        PSK envelope difference on P2 [V]; None skips the cancellation flag.
    threshold_v : float, default THRESHOLD_V (5 mV)
        Decision threshold on the envelope difference [V].

    Returns
    -------
    detected : numpy.ndarray of bool
        The ASK data frame is detected on the chosen path.
    use_p1 : numpy.ndarray of bool
        The stamp made the ST switch to P1.
    cancel_flagged : numpy.ndarray of bool or None
        ASK '-' while the PSK stamp is present; None without ``psk_diff_p2_v``.

    Notes
    -----
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

    Parameters
    ----------
    diff_v : float or array_like
        Actual envelope difference [V].
    diff_sync_v : float or array_like
        Envelope difference with the CW synchronised [V].
    threshold_v : float, default THRESHOLD_V (5 mV)
        Decision threshold [V].

    Returns
    -------
    numpy.ndarray of bool
        ``diff_sync_v > threshold_v and not diff_v > threshold_v``.
    """
    return (np.asarray(diff_sync_v, float) > threshold_v) & ~(np.asarray(diff_v, float) > threshold_v)


def cancellation_probability(flags, *, axis=None, confidence: float = 0.95):
    r"""Probability of phase cancellation with its Clopper–Pearson interval.

    .. math::

        \hat p = k/n, \quad lo = B^{-1}(\alpha/2; k, n-k+1), \quad
        hi = B^{-1}(1-\alpha/2; k+1, n-k)

    with ``α = 1 − confidence`` (lo = 0 when k = 0, hi = 1 when k = n).

    Parameters
    ----------
    flags : array_like of bool
        Cancellation flags (e.g. shape (n_cells, n_samples)) from :func:`phase_cancelled`.
    axis : int, optional
        Axis holding the samples (None = all elements).
    confidence : float, default 0.95
        Two-sided level of the exact binomial interval, in (0, 1).

    Returns
    -------
    p : numpy.ndarray or float
        Fraction ``k/n`` of flagged samples.
    lo, hi : numpy.ndarray or float
        Lower and upper bounds of the interval.
    n : int
        Number of samples per estimate.

    Raises
    ------
    ConfigError
        If ``confidence`` is not in (0, 1).
    ValueError
        If there are no samples.
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
    lo = np.where(k > 0, _special.betaincinv(np.maximum(k, 1), n - k + 1, a / 2), 0.0)
    hi = np.where(k < n, _special.betaincinv(k + 1, np.maximum(n - k, 1), 1 - a / 2), 1.0)
    return k / n, lo, hi, n


def sync_envelope_difference(a_t1, a_t2):
    """Envelope difference with the CW in phase with collinear ASK states (θ = 0).

    ``|A_T1 − A_T2|`` (for complex states use :func:`synchronised_difference`).

    Parameters
    ----------
    a_t1, a_t2 : float or array_like
        Backscatter amplitudes of the two reflection states [V].

    Returns
    -------
    numpy.ndarray
        ``|A_T1 − A_T2|`` [V].
    """
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
    cw, bs1, bs2 : complex or array_like of complex
        CW phasor and backscatter phasors of reflection states 1 and 2 (broadcast) [V].
    n_grid : int, default 64
        Points of the grid over φ in the numerical branch.
    n_refine : int, default 40
        Golden-section steps after the grid in the numerical branch.

    Returns
    -------
    numpy.ndarray of float64
        ``D_sync`` [V], broadcast shape of the inputs.
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
    cw_sa1, bs1_sa1, bs2_sa1 : complex or array_like of complex
        Phasors [V] at SA1 of the CW and of the backscatter in reflection states 1 and 2 (any
        common phase reference); all inputs broadcast against each other.
    cw_sa2, bs1_sa2, bs2_sa2 : complex or array_like of complex
        The same at SA2 [V] (the single-antenna ST is SA2 = path P2).
    detector_gain : float, default 1.0
        Envelope-detector output per input volt (linear regime) [V/V].
    threshold_v : float, default THRESHOLD_V (5 mV)
        Phase-cancellation threshold on the detector output difference [V].
    transfer : callable, optional
        Detector law ``v_out = transfer(V_peak)`` [V → V] (e.g. the diode's
        ``n·V_T·ln I0(G_v·V/(n·V_T))``,
        :meth:`rfsim.devices.st_receiver.EnvelopeDetector.transfer_v`); replaces
        ``detector_gain``. Actual differences ``|f(|c + b1|) − f(|c + b2|)|``; synchronised
        ``|f(|c| + D/2) − f(|c| − D/2)|`` with ``D`` = :func:`synchronised_difference` (the
        secant of the law across the swing around the CW level; exact for a linear law).

    Returns
    -------
    TechniqueOutcome
        Actual and synchronised envelope differences [V] at SA1, SA2 and of the RF sum, and
        the cancellation flags of the four techniques.

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
    r"""Mutual impedance of two parallel side-by-side half-wave dipoles (induced-EMF method).

    Balanis, *Antenna Theory*, Eq. 8.71: with ``k = 2π/λ``, ``l = λ/2``, ``u0 = k·d``,
    ``u1,2 = k·(sqrt(d² + l²) ± l)`` and ``η/(4π) = 30 Ω``,

    .. math::

        R_{12} = 30\,[2\,\mathrm{Ci}(u_0) - \mathrm{Ci}(u_1) - \mathrm{Ci}(u_2)], \qquad
        X_{12} = -30\,[2\,\mathrm{Si}(u_0) - \mathrm{Si}(u_1) - \mathrm{Si}(u_2)]

    λ/4 at 915 MHz gives 40.4 − j28.4 Ω (the tabulated 40.8 − j28.3 Ω).

    Parameters
    ----------
    spacing_m : float or array_like
        Distance d between the dipoles [m] (> 0).
    fc_hz : float, default 915e6
        Carrier frequency [Hz].

    Returns
    -------
    numpy.ndarray of complex
        ``Z12 = R12 + j·X12`` [Ω], shape of ``spacing_m``.
    """
    from scipy.special import sici

    lam = float(wavelength_m(fc_hz))
    k, l = 2.0 * np.pi / lam, 0.5 * lam
    d = np.asarray(spacing_m, float)
    h = np.sqrt(d * d + l * l)
    (s0, c0), (s1, c1), (s2, c2) = sici(k * d), sici(k * (h + l)), sici(k * (h - l))
    return 30.0 * (2.0 * c0 - c1 - c2) - 30.0j * (2.0 * s0 - s1 - s2)


def coupling_matrix(z11_ohm: complex = DIPOLE_Z11_OHM, z12_ohm: complex = DIPOLE_Z12_QUARTER_WAVE_OHM,
                    z_load_ohm: complex | None = None) -> np.ndarray:
    r"""2×2 matrix taking the uncoupled port voltages of an antenna pair to the coupled ones.

    Two identical antennas with self impedance Z11, mutual impedance Z12, each terminated in
    ``Z_L`` (default the conjugate match of one antenna alone, ``Z11*``): their open-circuit
    voltages V_oc (what each would deliver alone, the engine's port signals) drive
    ``V_oc = (Z + Z_L·I)·I_port`` with ``Z = [[Z11, Z12], [Z12, Z11]]``, and the loads see
    ``V_L = Z_L·I_port``. Normalised so that Z12 = 0 gives the identity (the port signals
    already carry the single antenna's matched level):

    .. math::

        M = (Z_{11} + Z_L)(Z + Z_L I)^{-1} = \frac{1}{1 - c^2}
        \begin{pmatrix} 1 & -c \\ -c & 1 \end{pmatrix}, \qquad c = \frac{Z_{12}}{Z_{11} + Z_L}

    (λ/4 dipoles, conjugate match: c = 0.28 − j0.19). Coupling mixes the CW and the
    backscatter alike, so it changes the relative phase θ between the two ports and with it
    which antenna is in a null. Neighbouring scatterers other than the pair (the ST body) are
    not modelled.

    Parameters
    ----------
    z11_ohm : complex, default DIPOLE_Z11_OHM (73.1 + j42.5 Ω)
        Self impedance of each antenna [Ω].
    z12_ohm : complex, default DIPOLE_Z12_QUARTER_WAVE_OHM (40.8 − j28.3 Ω)
        Mutual impedance of the pair [Ω].
    z_load_ohm : complex, optional
        Load impedance of each port [Ω]; None = ``conj(z11_ohm)``.

    Returns
    -------
    numpy.ndarray, shape (2, 2), complex
        Coupling matrix ``M``: coupled port voltages = ``M @ uncoupled``.
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

"""Small-scale fading: the exponential average power-delay profile (APDP) with a LoS spike.

Model (Witrisal, IEEE TCOM 49(10) 2001; auris-sense-a-tag.md §1.7 Eq. 2.46–2.48;
gen2-and-validation-anchors.md §4.7), normalised to unit total power::

    P(τ) = K/(K+1)·δ(τ) + 1/(K+1)·γ·e^{−γτ},     τ ≥ 0 (relative to the LoS delay)
    mean delay τ̄ = 1/((K+1)γ),   τrms = √(2K+1)/((K+1)γ)  ⇒  γ = √(2K+1)/((K+1)·τrms)

K (linear) is the LoS power over the total NLoS power; τrms [s] is the RMS delay spread of
the whole profile, LoS included. Both depend on the link distance through :class:`ApdpModel`
(PASS room defaults, pass-paris-simulator.md §2.4 / auris-sense-a-tag.md §1.7):
``K(d) [dB] = 60·10^(−0.02 d) − 30`` and ``τrms(d) = 70 ns·(1 − 10^(−0.03 d))``.

Sampling follows PASS ``channel_small`` (pass-paris-simulator.md §2.4): the NLoS tail on
[0, t_max] is cut into n equal bins; each bin becomes one tap placed at the bin's centre of
gravity and carrying the bin's exact integrated power. n starts at ⌈2·B/f_res⌉ + 1 and grows
by the factor 1 + √((relerr − ε_τ)/ε_τ) until the profile's τrms is within ``eps_trms``
(relative) of the target, or ``max_taps`` / ``max_iter`` is reached. Two deliberate
differences from PASS: the truncated tail is renormalised so the NLoS power (hence K) is
exact, and the bins are refined with t_max held fixed (t_max already covers all but a
fraction ε/(1+ε) of the tail, ε = min(ε_K, (ε_τ/3)^√2)); if the tap budget runs out, t_max
is shortened to that truncation point (PASS keeps t_max ≥ 1/f_res and fails instead). Delays are exact floats unless
``fs_hz`` is given, in which case they are rounded to the sample grid and NLoS taps that fall
on the same sample are power-summed (PASS-compatible mode; the LoS tap is never merged).

In time, :func:`rician_gains` draws a held link's slow variation: a Rician gain process with the
Jakes (Clarke) correlation J0(2π·f_D·Δt) of scatterers moving in the room.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.memo import PureCache
from rfsim.core.units import db_to_lin

_special = lazy_import("scipy.special")

__all__ = [
    "ApdpModel",
    "apdp_decay_rate",
    "average_profile",
    "profile_statistics",
    "draw_taps",
    "TapTerms",
    "tap_terms",
    "draw_nlos_taps",
    "rician_gains",
]


@dataclass(frozen=True)
class ApdpModel:
    """Distance dependence of the APDP parameters.

    ``K(d) [dB] = k_a_db·10^(−k_b·d) + k_c_db`` and ``τrms(d) = tau_max_s·(1 − 10^(−tau_b·d))``
    with d in metres (PASS ``sensatag_room.m``/``phasecan.m`` curves,
    auris-sense-a-tag.md §1.7). The profile-sampling options are passed on to
    :func:`average_profile`.

    Parameters
    ----------
    k_a_db, k_b, k_c_db : K-factor curve coefficients [dB, 1/m, dB]
    tau_max_s, tau_b : delay-spread curve coefficients [s, 1/m]
    bandwidth_hz, fres_hz : starting tap count ⌈2·B/f_res⌉ + 1 of the profile sampling
    max_taps, max_iter, eps_k, eps_trms : sampling limits and tolerances
    """

    k_a_db: float = 60.0
    k_b: float = 0.02
    k_c_db: float = -30.0
    tau_max_s: float = 70e-9
    tau_b: float = 0.03
    bandwidth_hz: float = 50e6
    fres_hz: float = 5e6
    max_taps: int = 1000
    max_iter: int = 1000
    eps_k: float = 1e-3
    eps_trms: float = 1e-2

    def __post_init__(self):
        if not self.tau_max_s > 0:
            raise ConfigError("apdp.tau_max_s", self.tau_max_s, "a positive delay in s")
        if self.max_taps < 2:
            raise ConfigError("apdp.max_taps", self.max_taps, "an integer ≥ 2")
        if not (self.bandwidth_hz > 0 and self.fres_hz > 0):
            raise ConfigError("apdp.bandwidth_hz", self.bandwidth_hz, "positive bandwidth and fres")
        if not (0 < self.eps_trms < 1 and 0 < self.eps_k < 1):
            raise ConfigError("apdp.eps_trms", self.eps_trms, "tolerances in (0, 1)")

    def k_db_at(self, distance_m):
        """K-factor ``K(d) = k_a_db·10^(−k_b·d) + k_c_db`` (auris-sense-a-tag.md §1.7).

        Parameters
        ----------
        distance_m : array_like
            Distance d [m].

        Returns
        -------
        numpy.ndarray
            K [dB].
        """
        d = np.asarray(distance_m, dtype=float)
        return self.k_a_db * np.power(10.0, -self.k_b * d) + self.k_c_db

    def k_lin_at(self, distance_m):
        """K-factor as a linear power ratio at ``distance_m``.

        Parameters
        ----------
        distance_m : array_like
            Distance d [m].

        Returns
        -------
        numpy.ndarray
            K [1].
        """
        return db_to_lin(self.k_db_at(distance_m))

    def tau_rms_s_at(self, distance_m):
        """RMS delay spread ``τrms(d) = tau_max_s·(1 − 10^(−tau_b·d))``.

        Floored at 1e−15 s so γ stays finite at d = 0.

        Parameters
        ----------
        distance_m : array_like
            Distance d [m].

        Returns
        -------
        numpy.ndarray
            τrms [s].
        """
        d = np.asarray(distance_m, dtype=float)
        return np.maximum(self.tau_max_s * (1.0 - np.power(10.0, -self.tau_b * d)), 1e-15)

    @property
    def profile_options(self) -> dict:
        """Keyword arguments for :func:`average_profile` / :func:`draw_taps`."""
        return dict(
            bandwidth_hz=self.bandwidth_hz,
            fres_hz=self.fres_hz,
            max_taps=self.max_taps,
            max_iter=self.max_iter,
            eps_k=self.eps_k,
            eps_trms=self.eps_trms,
        )

    @property
    def profile_items(self) -> tuple:
        """:attr:`profile_options` as a tuple of ``(name, value)`` (a key of :func:`tap_terms`; formed
        once: the model is immutable, a channel asks it at every draw)."""
        items = self.__dict__.get("_profile_items")
        if items is None:
            items = self.__dict__["_profile_items"] = (
                ("bandwidth_hz", self.bandwidth_hz), ("fres_hz", self.fres_hz), ("max_taps", self.max_taps),
                ("max_iter", self.max_iter), ("eps_k", self.eps_k), ("eps_trms", self.eps_trms))
        return items

    def profile_at(self, distance_m: float):
        """The average profile at one distance (:func:`average_profile`).

        Parameters
        ----------
        distance_m : float
            Distance d [m].

        Returns
        -------
        powers : numpy.ndarray
            Tap powers [1] (unit total).
        delays_s : numpy.ndarray
            Tap delays [s].
        """
        return average_profile(
            float(self.k_lin_at(distance_m)), float(self.tau_rms_s_at(distance_m)), **self.profile_options
        )


def apdp_decay_rate(k_lin, tau_rms_s):
    """Decay rate γ = √(2K+1)/((K+1)·τrms) of the APDP tail (auris-sense-a-tag.md §1.7, derived Eq. 2.48).

    Parameters
    ----------
    k_lin : array_like
        K-factor [1].
    tau_rms_s : array_like
        RMS delay spread [s].

    Returns
    -------
    numpy.ndarray
        γ [1/s].
    """
    k = np.asarray(k_lin, dtype=float)
    return np.sqrt(2.0 * k + 1.0) / ((k + 1.0) * np.asarray(tau_rms_s, dtype=float))


def profile_statistics(powers, delays_s):
    """K (first tap over the rest) and RMS delay spread of a discrete profile.

    Parameters
    ----------
    powers : array_like
        ``(n,) float64`` tap powers; ``powers[0]`` is the LoS tap.
    delays_s : array_like
        ``(n,) float64`` tap delays [s].

    Returns
    -------
    k : float
        K [1] (inf without NLoS power).
    tau_rms_s : float
        RMS delay spread [s].
    """
    p = np.asarray(powers, dtype=float)
    t = np.asarray(delays_s, dtype=float)
    total = p.sum()
    mean = (p * t).sum() / total
    var = (p * (t - mean) ** 2).sum() / total
    nlos = total - p[0]
    k = p[0] / nlos if nlos > 0 else np.inf
    return k, math.sqrt(max(var, 0.0))


def binned_tail(gamma, t_max, n):
    """Bin powers and centre-of-gravity delays of γe^{−γτ} on n bins of [0, t_max].

    Bin power ∫_a^{a+Δ} γe^{−γτ} dτ = e^{−γa}(1 − e^{−γΔ}); centre of gravity
    a + 1/γ − Δ/(e^{γΔ} − 1) (series Δ/2 − γΔ²/12 for small γΔ).

    Parameters
    ----------
    gamma : float
        Decay rate γ [1/s].
    t_max : float
        End of the last bin [s].
    n : int
        Number of bins.

    Returns
    -------
    powers : numpy.ndarray
        ``(n,)`` bin powers, unit total [1].
    delays_s : numpy.ndarray
        ``(n,)`` centre-of-gravity delays [s].
    """
    delta = t_max / n
    a = np.arange(n) * delta
    gd = gamma * delta
    # ∫_a^{a+Δ} γe^{−γτ} dτ = e^{−γa}(1 − e^{−γΔ})
    pw = np.exp(-gamma * a) * (-math.expm1(-gd))
    # centre of gravity of the exponential on [a, a+Δ]: a + 1/γ − Δ/(e^{γΔ} − 1)
    if gd > 1e-6:
        cog = 1.0 / gamma - delta / math.expm1(gd)
    else:  # series to avoid cancellation: Δ/2 − γΔ²/12
        cog = delta / 2.0 - gamma * delta * delta / 12.0
    return pw / pw.sum(), a + cog


def average_profile(
    k_lin: float,
    tau_rms_s: float,
    *,
    bandwidth_hz: float = 50e6,
    fres_hz: float = 5e6,
    fs_hz: float | None = None,
    max_taps: int = 1000,
    max_iter: int = 1000,
    eps_k: float = 1e-3,
    eps_trms: float = 1e-2,
):
    """Deterministic sampled APDP (centre-of-gravity taps), unit total power.

    Parameters
    ----------
    k_lin : K-factor, linear (LoS power / NLoS power), ≥ 0 (``inf``: LoS only)
    tau_rms_s : RMS delay spread [s] of the whole profile, > 0
    bandwidth_hz, fres_hz : the first pass uses ⌈2·B/f_res⌉ + 1 NLoS bins, t_max ≥ 1/f_res
    fs_hz : if given, NLoS delays are rounded to multiples of 1/fs and merged (PASS mode)
    max_taps : cap on the number of taps (LoS included)
    max_iter : cap on refinement passes
    eps_k : K tolerance; sets the tail truncation ε = min(eps_k, (eps_trms/3)^√2)
    eps_trms : relative τrms tolerance the refinement aims for

    Returns
    -------
    powers : (n,) float64, tap powers (sum 1); ``powers[0] = K/(K+1)`` is the LoS tap
    delays_s : (n,) float64, tap delays [s] relative to the LoS (``delays_s[0] = 0``)

    If the τrms tolerance cannot be met within ``max_taps``/``max_iter`` (or with sample
    rounding) the best profile found is returned; check with :func:`profile_statistics`.

    A pure function of its arguments: results are kept in :data:`AVERAGE_PROFILE_CACHE`
    (bounded, 4096 entries) and returned as fresh copies.
    """
    powers, delays = AVERAGE_PROFILE_CACHE(float(k_lin), float(tau_rms_s), float(bandwidth_hz),
                                      float(fres_hz), None if fs_hz is None else float(fs_hz),
                                      int(max_taps), int(max_iter), float(eps_k), float(eps_trms))
    return powers.copy(), delays.copy()


def _average_profile(k_lin, tau_rms_s, bandwidth_hz, fres_hz, fs_hz, max_taps, max_iter, eps_k,
                     eps_trms):
    """The body of :func:`average_profile` (arguments normalised by it), kept in
    :data:`AVERAGE_PROFILE_CACHE`."""
    k = float(k_lin)
    tr = float(tau_rms_s)
    if not k >= 0:
        raise ValueError(f"k_lin must be ≥ 0, got {k_lin!r}")
    if not tr > 0:
        raise ValueError(f"tau_rms_s must be > 0, got {tau_rms_s!r}")
    if max_taps < 2:
        raise ValueError("max_taps must be ≥ 2")
    if math.isinf(k):
        return np.ones(1), np.zeros(1)
    p_los = k / (k + 1.0)
    p_nlos = 1.0 / (k + 1.0)
    gamma = math.sqrt(2.0 * k + 1.0) / ((k + 1.0) * tr)
    eps = min(eps_k, (eps_trms / 3.0) ** math.sqrt(2.0))
    n = min(int(math.ceil(2.0 * bandwidth_hz / fres_hz)) + 1, max_taps - 1)
    n = max(n, 1)
    t_trunc = -math.log(eps / (1.0 + eps)) / gamma
    t_max = min(max((n - 1) / (n * fres_hz), t_trunc), 250.0 / gamma)

    best = None
    for _ in range(max(int(max_iter), 1)):
        pw, tau = binned_tail(gamma, t_max, n)
        pw = pw * p_nlos
        if fs_hz is not None:
            idx = np.rint(tau * fs_hz).astype(np.int64)
            uniq, inv = np.unique(idx, return_inverse=True)
            pw = np.bincount(inv, weights=pw)
            tau = uniq / float(fs_hz)
        powers = np.concatenate(([p_los], pw))
        delays = np.concatenate(([0.0], tau))
        _, tr_hat = profile_statistics(powers, delays)
        relerr = abs(tr_hat - tr) / tr
        if best is None or relerr < best[0]:
            best = (relerr, powers, delays)
        if relerr <= eps_trms:
            break
        if n >= max_taps - 1:
            if t_max > t_trunc * (1.0 + 1e-9):
                t_max = t_trunc  # out of taps: spend them on the significant part of the tail
                continue
            break
        grow = 1.0 + math.sqrt((relerr - eps_trms) / eps_trms)
        n = min(int(math.ceil(n * grow)), max_taps - 1)
    return best[1], best[2]


#: :func:`average_profile` by its (normalised) arguments: a pure function of K, τrms and the
#: profile options, not run state (:class:`rfsim.core.memo.PureCache`).
AVERAGE_PROFILE_CACHE = PureCache(_average_profile, 4096)


def draw_taps(k_lin: float, tau_rms_s: float, *, rng: np.random.Generator, n_draws: int = 1,
              los_phase_rad: float = 0.0, **profile_options):
    """Random Rician tap sets drawn from the average profile (vectorised over draws).

    Tap 0 (LoS) is deterministic: amplitude √(K/(K+1)) and phase ``los_phase_rad`` (default 0:
    the LoS phase comes from geometry, ``exp(−j2π·fc·τ_LoS)``, when the taps are applied as a
    :class:`~rfsim.channels.paths.PathSet`). NLoS taps are independent zero-mean circular complex
    Gaussian, ``g_i ~ CN(0, P_i)`` with P_i the average-profile powers; their phases and
    amplitudes are the only random quantities. Delays are the (deterministic) profile delays.

    Parameters
    ----------
    k_lin, tau_rms_s : see :func:`average_profile`
    rng : numpy Generator (keyword-only)
    n_draws : number of independent realisations
    los_phase_rad : phase of the LoS tap [rad]
    **profile_options : passed to :func:`average_profile`

    Returns
    -------
    gains : (n_draws, n_taps) complex128, amplitude gains [linear]; E[Σ|g|²] = 1
    delays_s : (n_taps,) float64 [s], relative to the LoS delay
    """
    powers, delays = average_profile(k_lin, tau_rms_s, **profile_options)
    n_taps = powers.size
    gains = np.empty((int(n_draws), n_taps), dtype=np.complex128)
    gains[:, 0] = math.sqrt(powers[0]) * np.exp(1j * los_phase_rad)
    if n_taps > 1:
        z = rng.standard_normal((int(n_draws), n_taps - 1, 2))
        scale = np.sqrt(powers[1:] / 2.0)
        gains[:, 1:] = (z[..., 0] + 1j * z[..., 1]) * scale
    return gains, delays


class TapTerms(NamedTuple):
    """What :func:`draw_taps` forms from the average profile alone (one ``n_draws=1`` draw with
    ``los_phase_rad=0``): the same every draw of a link (:func:`tap_terms`).

    Attributes
    ----------
    nlos_delays_s : ndarray, shape (n_taps − 1,), float64
        The profile's NLoS tap delays relative to the LoS [s] (its delays but the first).
    los_amplitude : numpy.float64
        |g_0| of the LoS tap √P_0·e^{j0} as a complex128 [1].
    scale : ndarray, shape (n_taps − 1,), float64
        √(P_i/2) of the NLoS taps [1].
    paired_scale : ndarray, shape (2·(n_taps − 1),), float64
        ``scale`` with every value twice, for the real and imaginary parts [1].
    """

    nlos_delays_s: np.ndarray
    los_amplitude: np.float64
    scale: np.ndarray
    paired_scale: np.ndarray


def tap_terms(k_lin: float, tau_rms_s: float, options: tuple) -> TapTerms:
    """The parts of :func:`draw_taps` that depend on the profile alone (a channel keeps them per
    profile: :class:`rfsim.channels.scene.Channel`).

    Parameters
    ----------
    k_lin, tau_rms_s : float
        As for :func:`average_profile`.
    options : tuple of (str, value)
        The profile options (``tuple(ApdpModel.profile_options.items())``).

    Returns
    -------
    TapTerms
        NLoS delays, LoS amplitude and NLoS scales (read-only arrays), the values :func:`draw_taps`
        forms for them.
    """
    powers, delays = average_profile(k_lin, tau_rms_s, **dict(options))
    los = np.empty(1, dtype=np.complex128)
    los[0] = math.sqrt(powers[0]) * np.exp(1j * 0.0)
    scale = np.sqrt(powers[1:] / 2.0)
    nlos_delays = delays[1:].copy()
    paired = np.repeat(scale, 2)
    for a in (scale, nlos_delays, paired):
        a.setflags(write=False)
    return TapTerms(nlos_delays, abs(los[0]), scale, paired)


def draw_nlos_taps(terms: TapTerms, rng: np.random.Generator) -> np.ndarray:
    """One draw of the NLoS taps of a profile: the numbers of ``draw_taps(..., n_draws=1)[0][0, 1:]``.

    Parameters
    ----------
    terms : TapTerms
        The profile's terms (:func:`tap_terms`).
    rng : numpy.random.Generator
        The generator; 2·(n_taps − 1) standard normals are drawn (none for a LoS-only profile),
        as :func:`draw_taps` draws them.

    Returns
    -------
    ndarray, shape (n_taps − 1,), complex128
        The taps g_i ~ CN(0, P_i) [1].
    """
    n = terms.scale.size
    if n == 0:
        return np.empty(0, dtype=np.complex128)
    z = rng.standard_normal(2 * n)  # the normals of draw_taps' (1, n, 2) draw, in its order
    # (z_re·s, z_im·s) as complex: the numbers of draw_taps' (z_re + j·z_im)·s, whose products
    # with the zero imaginary parts are exact zeros, formed without its complex casts
    return (z * terms.paired_scale).view(np.complex128)


def rician_gains(times_s, *, doppler_hz: float, k_db: float, rng: np.random.Generator) -> np.ndarray:
    """A time-variant Rician gain process sampled at ``times_s``: E|h|² = 1.

    ``h_q = sqrt(K/(K+1))·e^{jφ} + sqrt(1/(K+1))·g_q``, K = 10^(``k_db``/10) the power ratio of
    the constant part to the time-variant part (people moving in the room), φ uniform in
    [−π, π). ``g_q`` is circular complex Gaussian, unit power, with the Jakes (Clarke)
    correlation ``E[g_q g_p*] = J0(2π·f_D·(t_q − t_p))`` of scatterers moving at up to
    f_D·λ (people: 1 m/s at 915 MHz is 3 Hz; Clarke, Bell Syst. Tech. J. 47(6), 1968;
    Jakes, *Microwave Mobile Communications*, 1974, ch. 1), drawn exactly by a Cholesky factor
    of that Toeplitz matrix (a 10⁻⁹ diagonal load keeps it positive definite for nearly equal
    times).

    Parameters
    ----------
    times_s : (n,) float64, sample instants [s]
    doppler_hz : maximum Doppler shift f_D [Hz]; ≤ 0: a constant gain ``e^{jφ}`` (held channel)
    k_db : Rician K of the process [dB]
    rng : numpy Generator (keyword-only); draw order: φ, then 2·n normals (real, imaginary)

    Returns
    -------
    (n,) complex128, amplitude gains [linear]
    """
    t = np.asarray(times_s, float)
    k = 10.0 ** (k_db / 10.0)
    phi = rng.uniform(-np.pi, np.pi)
    w = rng.standard_normal((2, t.size))
    if doppler_hz <= 0:
        return np.full(t.size, np.exp(1j * phi), dtype=complex)
    r = _special.j0(2.0 * np.pi * doppler_hz * np.abs(t[:, None] - t[None, :]))
    lower = np.linalg.cholesky(r + 1e-9 * np.eye(t.size))
    g = lower @ ((w[0] + 1j * w[1]) / math.sqrt(2.0))
    return math.sqrt(k / (k + 1.0)) * np.exp(1j * phi) + math.sqrt(1.0 / (k + 1.0)) * g

"""Passive-tag front-end physics: power-up, reflection-coefficient states, tag clock and BLF.

Three small pieces, each a frozen dataclass with the equations in its docstring:

* :class:`PowerUp` — power delivered to the chip, P_chip = τ·P_av with the power
  transmission coefficient τ = 4·R_c·R_a / |Z_c + Z_a|² (Nikitin & Rao, IEEE T-MTT 53(9),
  2005; gen2-and-validation-anchors.md §4.7), compared with the chip's minimum operating
  power.
* :class:`ReflectionStates` — the two backscatter states as power-wave (Kurokawa)
  reflection coefficients Γ = (Z_c − Z_a*) / (Z_c + Z_a), the modulation factor
  M = |Γ_A − Γ_B|²/4 (Griffin & Durgin, IEEE AP Magazine 51(2), 2009; anchors §4.7) and the
  differential RCS.
* :class:`TagClock` — the tag oscillator (nominal 1.92 MHz as in PASS, pass-paris-simulator.md
  §2.2 ``tag_clock``) with a static frequency error and white tick jitter, and the backscatter
  link frequency the tag derives from TRcal.

Default chip numbers come from the PASS measurements of an NXP UCODE G2XM-class chip
(pass-paris-simulator.md §5.2, files ``meas_tag_picmin``, ``meas_tag_zic``,
``meas_tag_zmod-act``), read at 900 MHz and at the chip's minimum operating power; the
files themselves are not part of rfsim — :func:`rfsim.devices.tag_chip.load_pass_tag_characteristics` reads them
from a folder the user has.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.units import dbm_to_w, w_to_dbm
from rfsim.core.lazy import lazy_import

_commands = lazy_import("rfsim.gen2.commands")

#: Minimum operating chip power at 900 MHz [W] (PASS ``meas_tag_picmin.mat``: 52.709 µW,
#: −12.78 dBm; the file spans 48.7 µW at 700 MHz … 69.7 µW at 1.2 GHz). PASS itself adds a
#: 2.5 dB margin on top (pass-paris-simulator.md §2.2 step 4); rfsim does not.
PASS_PICMIN_900MHZ_W = 52.709e-6
#: Unmodulated chip input impedance at 900 MHz and P_chip = 52.7 µW [Ω] (PASS
#: ``meas_tag_zic.mat``, interpolated linearly in log P_chip).
PASS_ZIC_900MHZ_OHM = complex(32.0, -198.6)
#: "Active" modulation impedance at 900 MHz and P_chip = 52.7 µW [Ω] (PASS
#: ``meas_tag_zmod-act.mat``); the modulating chip state is Z_ic ∥ Z_mod.
PASS_ZMOD_900MHZ_OHM = complex(122.2, 3.4)
#: Commonly quoted read sensitivity of UCODE-G2XM-class chips [dBm]; an alternative to the
#: PASS value for users who want a datasheet-style figure.
TYPICAL_SENSITIVITY_DBM = -15.0
#: Nominal tag clock [Hz] (PASS ``tag_clock`` default ``fcenter``).
PASS_TAG_CLOCK_HZ = 1.92e6
#: PASS tag clock jitter: σ = 5/3 % of a period (3σ = 5 %).
PASS_TAG_JITTER_RMS = 0.05 / 3


# --------------------------------------------------------------------------- impedances


def parallel_ohm(z1_ohm, z2_ohm):
    """Parallel combination of two impedances, ``Z1·Z2 / (Z1 + Z2)``.

    Parameters
    ----------
    z1_ohm, z2_ohm : complex or array_like of complex
        Impedances [Ω] (broadcast against each other).

    Returns
    -------
    numpy.ndarray of complex
        ``Z1 ∥ Z2`` [Ω] (a 0-d array for scalar inputs).
    """
    z1, z2 = np.asarray(z1_ohm, dtype=complex), np.asarray(z2_ohm, dtype=complex)
    return z1 * z2 / (z1 + z2)


def power_transmission_coefficient(z_chip_ohm, z_ant_ohm):
    r"""Power transmission coefficient between antenna and chip.

    .. math::

        \tau = \frac{4 R_c R_a}{|Z_c + Z_a|^2}

    the share of the antenna's available power that the chip absorbs (Nikitin & Rao 2005;
    gen2-and-validation-anchors.md §4.7). τ = 1 for ``Z_c = Z_a*``; τ = 1 − |Γ|² with Γ the
    power-wave reflection coefficient of :func:`reflection_coefficient`.

    Parameters
    ----------
    z_chip_ohm : complex or array_like of complex
        Chip impedance Z_c [Ω].
    z_ant_ohm : complex or array_like of complex
        Antenna impedance Z_a [Ω], Re > 0.

    Returns
    -------
    float or numpy.ndarray
        τ in [0, 1] (a float for scalar inputs).
    """
    zc, za = np.asarray(z_chip_ohm, dtype=complex), np.asarray(z_ant_ohm, dtype=complex)
    tau = 4.0 * zc.real * za.real / np.abs(zc + za) ** 2
    return float(tau) if tau.ndim == 0 else tau


def reflection_coefficient(z_chip_ohm, z_ant_ohm):
    r"""Power-wave (Kurokawa) reflection coefficient.

    .. math::

        \Gamma = \frac{Z_c - Z_a^*}{Z_c + Z_a}

    Γ = 0 for a conjugate match; |Γ| = 1 for a reactive chip load; Γ = −1 for a short with a
    real antenna impedance (pass-paris-simulator.md §5.2 "Physics of the reflection table").

    Parameters
    ----------
    z_chip_ohm : complex or array_like of complex
        Chip (load) impedance Z_c [Ω].
    z_ant_ohm : complex or array_like of complex
        Antenna impedance Z_a [Ω].

    Returns
    -------
    complex or numpy.ndarray of complex
        Γ (a complex for scalar inputs).
    """
    zc, za = np.asarray(z_chip_ohm, dtype=complex), np.asarray(z_ant_ohm, dtype=complex)
    gamma = (zc - np.conj(za)) / (zc + za)
    return complex(gamma) if gamma.ndim == 0 else gamma


def modulation_factor(gamma_a, gamma_b):
    r"""Modulation factor of two reflection states.

    .. math::

        M = \frac{|\Gamma_A - \Gamma_B|^2}{4}

    (Griffin & Durgin 2009; gen2-and-validation-anchors.md §4.7): the share of the power the
    tag could scatter that ends up in the modulated (data-bearing) signal for square-wave
    switching between the two states. M = 1/4 for Γ ∈ {0, −1}; at most 1 (Γ = ±1).

    Parameters
    ----------
    gamma_a, gamma_b : complex or array_like of complex
        Reflection coefficients of the two states.

    Returns
    -------
    float or numpy.ndarray
        M (a float for scalar inputs).
    """
    d = np.asarray(gamma_a, dtype=complex) - np.asarray(gamma_b, dtype=complex)
    m = np.abs(d) ** 2 / 4.0
    return float(m) if m.ndim == 0 else m


def differential_rcs_m2(gamma_a, gamma_b, *, gain_lin, wavelength_m):
    r"""Differential radar cross-section of a tag [m²].

    .. math::

        \Delta\sigma = \frac{\lambda^2 G^2 |\Gamma_A - \Gamma_B|^2}{4\pi}

    For a minimum-scattering antenna loaded with Z_c the antenna-mode scattered field is
    proportional to A = 2R_a/(Z_c + Z_a) = 1 − Γ, so the two states differ by |Γ_A − Γ_B|
    (Nikitin et al., "Differential RCS of RFID tag", Electron. Lett. 43(8), 2007). The
    modulated backscatter power of the radar equation uses Δσ/4 = λ²G²M/(4π), which
    reproduces the Griffin–Durgin link budget of gen2-and-validation-anchors.md §4.7.

    Parameters
    ----------
    gamma_a, gamma_b : complex or array_like of complex
        Reflection coefficients of the two states.
    gain_lin : float or array_like
        Tag antenna gain G (linear).
    wavelength_m : float or array_like
        Carrier wavelength λ [m].

    Returns
    -------
    float or numpy.ndarray
        Δσ [m²] (a float for scalar inputs).
    """
    d = np.asarray(gamma_a, dtype=complex) - np.asarray(gamma_b, dtype=complex)
    rcs = np.asarray(wavelength_m, float) ** 2 * np.asarray(gain_lin, float) ** 2 * np.abs(d) ** 2 / (4 * np.pi)
    return float(rcs) if rcs.ndim == 0 else rcs


# --------------------------------------------------------------------------- power-up


@dataclass(frozen=True)
class PowerUp:
    """Power-up of the chip: powered ⇔ P_chip = τ·P_av ≥ ``chip_sensitivity_w``.

    ``P_av`` (the argument called ``p_incident_w``) is the power the tag antenna makes
    available, P_av = P_T·G_T·G_tag·(λ/4πd)² in free space (anchors §4.7); τ is the power
    transmission coefficient between antenna and chip (:func:`power_transmission_coefficient`).

    Parameters
    ----------
    chip_sensitivity_w : float, default :data:`PASS_PICMIN_900MHZ_W`
        Minimum power absorbed by the chip for operation [W].
    z_chip_ohm : complex, default :data:`PASS_ZIC_900MHZ_OHM`
        Chip input impedance [Ω] (unmodulated state).
    z_ant_ohm : complex or None
        Antenna impedance [Ω]; ``None`` = conjugate match to ``z_chip_ohm`` (τ = 1).
    """

    chip_sensitivity_w: float = PASS_PICMIN_900MHZ_W
    z_chip_ohm: complex = PASS_ZIC_900MHZ_OHM
    z_ant_ohm: complex | None = None

    def __post_init__(self):
        s = self.chip_sensitivity_w
        if isinstance(s, bool) or not isinstance(s, (int, float)) or not s > 0:
            raise ConfigError("tag.chip_sensitivity_w", s, "a positive power in W")
        object.__setattr__(self, "z_chip_ohm", complex(self.z_chip_ohm))
        za = complex(np.conj(self.z_chip_ohm)) if self.z_ant_ohm is None else complex(self.z_ant_ohm)
        if not za.real > 0:
            raise ConfigError("tag.z_ant_ohm", self.z_ant_ohm, "an impedance with a positive real part")
        object.__setattr__(self, "z_ant_ohm", za)

    @classmethod
    def from_dbm(cls, sensitivity_dbm: float, **kw) -> PowerUp:
        """A :class:`PowerUp` with the chip sensitivity given in dBm.

        Parameters
        ----------
        sensitivity_dbm : float
            Minimum chip power for operation [dBm] (e.g. :data:`TYPICAL_SENSITIVITY_DBM`).
        **kw
            Other fields (``z_chip_ohm``, ``z_ant_ohm``).

        Returns
        -------
        PowerUp
            The power-up rule.
        """
        return cls(chip_sensitivity_w=float(dbm_to_w(sensitivity_dbm)), **kw)

    @property
    def tau(self) -> float:
        """Power transmission coefficient τ between antenna and chip."""
        return power_transmission_coefficient(self.z_chip_ohm, self.z_ant_ohm)

    @property
    def sensitivity_dbm(self) -> float:
        """Chip sensitivity [dBm]."""
        return float(w_to_dbm(self.chip_sensitivity_w))

    @property
    def threshold_available_w(self) -> float:
        """Smallest available antenna power P_av that powers the chip [W] = P_min / τ."""
        return self.chip_sensitivity_w / self.tau

    def chip_power_w(self, p_incident_w):
        """Power absorbed by the chip, ``P_chip = τ·P_av`` [W].

        Parameters
        ----------
        p_incident_w : float or array_like
            Available power at the antenna P_av [W].

        Returns
        -------
        numpy.ndarray
            P_chip [W], shape of ``p_incident_w``.
        """
        return self.tau * np.asarray(p_incident_w, dtype=float)

    def is_powered(self, p_incident_w):
        """Whether the chip runs: ``τ·P_av ≥ chip_sensitivity_w``.

        Parameters
        ----------
        p_incident_w : float or array_like
            Available power at the antenna P_av [W].

        Returns
        -------
        bool or numpy.ndarray of bool
            True where powered (a bool for a scalar input).
        """
        ok = self.chip_power_w(p_incident_w) >= self.chip_sensitivity_w
        return bool(ok) if np.ndim(ok) == 0 else ok


# --------------------------------------------------------------------------- reflection


@dataclass(frozen=True)
class ReflectionStates:
    """The tag's two reflection coefficients.

    Backscatter state 0 ↦ Γ_A, 1 ↦ Γ_B (:meth:`gamma`). A passive load cannot reflect more
    than it receives: |Γ| ≤ 1 is enforced.

    Parameters
    ----------
    gamma_a : complex, default 0
        Γ_A of the absorbing / unmodulated state.
    gamma_b : complex, default −1
        Γ_B of the modulating state.

    Raises
    ------
    ConfigError
        If |Γ| > 1 for either state.
    """

    gamma_a: complex = 0j
    gamma_b: complex = -1 + 0j

    def __post_init__(self):
        for name in ("gamma_a", "gamma_b"):
            g = complex(getattr(self, name))
            if not abs(g) <= 1.0 + 1e-12:
                raise ConfigError(f"tag.{name}", g, "a complex reflection coefficient with |Γ| ≤ 1")
            object.__setattr__(self, name, g)

    @classmethod
    def from_impedances(cls, z_chip_a_ohm, z_chip_b_ohm, z_ant_ohm) -> ReflectionStates:
        """Reflection states of two chip impedances against one antenna impedance (Kurokawa).

        Parameters
        ----------
        z_chip_a_ohm : complex
            Chip impedance of the absorbing state [Ω].
        z_chip_b_ohm : complex
            Chip impedance of the modulating state [Ω].
        z_ant_ohm : complex
            Antenna impedance [Ω].

        Returns
        -------
        ReflectionStates
            Γ_A, Γ_B from :func:`reflection_coefficient`.
        """
        return cls(reflection_coefficient(z_chip_a_ohm, z_ant_ohm), reflection_coefficient(z_chip_b_ohm, z_ant_ohm))

    @classmethod
    def ask(cls, gamma_a: float = 0.0, gamma_b: float = -1.0) -> ReflectionStates:
        """Ohmic (ASK) tag: real-valued states, default matched / short (M = 1/4).

        Parameters
        ----------
        gamma_a : float, default 0.0
            Γ_A (real).
        gamma_b : float, default -1.0
            Γ_B (real).

        Returns
        -------
        ReflectionStates
            The states.

        Raises
        ------
        ConfigError
            If a value is complex.
        """
        if np.iscomplexobj(gamma_a) or np.iscomplexobj(gamma_b):
            raise ConfigError("tag.gamma", (gamma_a, gamma_b), "real values for an ASK tag")
        return cls(complex(gamma_a), complex(gamma_b))

    @classmethod
    def psk(cls, magnitude: float, phase_rad: float) -> ReflectionStates:
        """Capacitive (PSK) tag: equal magnitudes, opposite phases.

        ``Γ_A,B = |Γ|·e^(±jφ)``, so M = |Γ|²·sin²φ.

        Parameters
        ----------
        magnitude : float
            |Γ| of both states (≤ 1).
        phase_rad : float
            φ [rad].

        Returns
        -------
        ReflectionStates
            The states.
        """
        return cls(magnitude * np.exp(1j * phase_rad), magnitude * np.exp(-1j * phase_rad))

    @classmethod
    def pass_default(cls) -> ReflectionStates:
        """UCODE G2XM-class chip at 900 MHz, 52.7 µW (PASS measurements).

        ``Z_A = Z_ic``, ``Z_B = Z_ic ∥ Z_mod``, against a conjugate-matched antenna
        ``Z_a = Z_ic*`` (so Γ_A = 0; pass-paris-simulator.md §5.2).

        Returns
        -------
        ReflectionStates
            The states of :data:`PASS_ZIC_900MHZ_OHM` and :data:`PASS_ZMOD_900MHZ_OHM`.
        """
        if cls is ReflectionStates and _PASS_DEFAULT_STATES is not None:
            return _PASS_DEFAULT_STATES  # formed once at import (frozen): a constant of the model
        za = np.conj(PASS_ZIC_900MHZ_OHM)
        return cls.from_impedances(PASS_ZIC_900MHZ_OHM, parallel_ohm(PASS_ZIC_900MHZ_OHM, PASS_ZMOD_900MHZ_OHM), za)

    @property
    def modulation_factor(self) -> float:
        """M = |Γ_A − Γ_B|²/4."""
        return modulation_factor(self.gamma_a, self.gamma_b)

    def differential_rcs_m2(self, *, gain_lin: float, wavelength_m: float) -> float:
        """Differential RCS ``Δσ = λ²G²|Γ_A − Γ_B|²/(4π)`` of the two states, see :func:`differential_rcs_m2`.

        Parameters
        ----------
        gain_lin : float
            Tag antenna gain (linear).
        wavelength_m : float
            Carrier wavelength [m].

        Returns
        -------
        float
            Δσ [m²].
        """
        return differential_rcs_m2(self.gamma_a, self.gamma_b, gain_lin=gain_lin, wavelength_m=wavelength_m)

    def gamma(self, state) -> np.ndarray:
        """Reflection coefficient for backscatter states.

        Parameters
        ----------
        state : array_like, shape (n,)
            Backscatter state per sample (0 → Γ_A, nonzero → Γ_B).

        Returns
        -------
        numpy.ndarray, shape (n,), complex128
            Γ per sample.
        """
        s = np.asarray(state)
        return np.where(s.astype(bool), self.gamma_b, self.gamma_a).astype(np.complex128)


_PASS_DEFAULT_STATES = None
#: :meth:`ReflectionStates.pass_default`, formed once (every ASK tag's config reads it).
_PASS_DEFAULT_STATES = ReflectionStates.pass_default()


# --------------------------------------------------------------------------- clock


@dataclass(frozen=True)
class TagClock:
    """Tag oscillator: f = f_nominal·(1 + freq_error_ppm·10⁻⁶), ticks with white jitter.

    Tick k lies at t_k = t0 + k/f + σ·ε_k/f, ε_k ~ N(0, 1) i.i.d., σ = ``jitter_rms``: a
    non-accumulating jitter around an ideal grid as in PASS ``tag_clock`` (σ = 5/3 % there,
    pass-paris-simulator.md §2.2), plus the static frequency error PASS lacks. The period
    (cycle-to-cycle) jitter is then √2·σ/f RMS.

    Parameters
    ----------
    f_nominal_hz : float, default 1.92 MHz
    freq_error_ppm : float
        Static relative frequency error in ppm (10 % = 100 000 ppm); > −10⁶.
    jitter_rms : float
        σ of each tick's deviation from the grid, as a fraction of a period (≥ 0, < 0.5).
    """

    f_nominal_hz: float = PASS_TAG_CLOCK_HZ
    freq_error_ppm: float = 0.0
    jitter_rms: float = 0.0

    def __post_init__(self):
        if not self.f_nominal_hz > 0:
            raise ConfigError("tag.clock.f_nominal_hz", self.f_nominal_hz, "a positive frequency in Hz")
        if not self.freq_error_ppm > -1e6:
            raise ConfigError("tag.clock.freq_error_ppm", self.freq_error_ppm, "a number > -1e6")
        if not 0 <= self.jitter_rms < 0.5:
            raise ConfigError("tag.clock.jitter_rms", self.jitter_rms, "a fraction in [0, 0.5)")

    @property
    def f_hz(self) -> float:
        """Actual clock frequency [Hz]."""
        return self.f_nominal_hz * (1.0 + self.freq_error_ppm * 1e-6)

    @property
    def period_s(self) -> float:
        """Actual clock period [s]."""
        return 1.0 / self.f_hz

    def tick_times_s(self, n_ticks: int, *, rng: np.random.Generator, t0_s: float = 0.0) -> np.ndarray:
        """Times of the first clock ticks [s].

        ``t_k = t0 + k/f + σ·ε_k/f`` (class docstring).

        Parameters
        ----------
        n_ticks : int
            Number of ticks (≥ 0).
        rng : numpy.random.Generator
            Stream of the jitter draws (unused without jitter).
        t0_s : float, default 0.0
            Ideal time of tick 0 [s].

        Returns
        -------
        numpy.ndarray, shape (n_ticks,), float64
            Tick times [s].

        Raises
        ------
        ValueError
            If ``n_ticks < 0``.
        """
        n = int(n_ticks)
        if n < 0:
            raise ValueError(f"n_ticks must be >= 0, got {n_ticks}")
        grid = t0_s + np.arange(n, dtype=np.float64) * self.period_s
        if self.jitter_rms == 0.0:
            return grid
        return grid + self.jitter_rms * self.period_s * rng.standard_normal(n)

    def count_ticks(self, duration_s: float) -> int:
        """Clock periods in an interval, rounded to the nearest integer: ``round(duration·f)``.

        Parameters
        ----------
        duration_s : float
            Interval [s].

        Returns
        -------
        int
            Number of ticks.
        """
        return int(round(float(duration_s) * self.f_hz))

    def blf_divider(self, trcal_s: float, dr, *, trcal_ticks: int | None = None) -> int:
        """Subcarrier period in clock ticks, ``N = round(N_TRcal / DR)``, N ≥ 1.

        N_TRcal is the tag's count of TRcal in its own ticks (``trcal_ticks`` when a PIE
        decoder measured it, else :meth:`count_ticks`). Rule: the tag divides its clock by an
        integer, the nearest one to N_TRcal/DR (as PASS: ``round(fclk/LF)`` ticks per period,
        modulated half floor(N/2), unmodulated half ceil(N/2) ticks; pass-paris-simulator.md
        §2.2).

        Parameters
        ----------
        trcal_s : float
            TRcal [s] (used when ``trcal_ticks`` is None).
        dr : str, int or fractions.Fraction
            Divide ratio DR of the Query (``"8"``, ``"64/3"``, 8 or ``Fraction(64, 3)``; floats
            are refused).
        trcal_ticks : int, optional
            TRcal already counted in ticks.

        Returns
        -------
        int
            Divider N ≥ 1.

        Raises
        ------
        ValueError
            If the TRcal count is below 1 tick.
        """
        n_trcal = self.count_ticks(trcal_s) if trcal_ticks is None else int(trcal_ticks)
        ratio = _DR_RATIOS.get(dr) if isinstance(dr, str) else None  # a DR name: no Fraction made
        if ratio is None:
            ratio = _DR_RATIOS[_commands.normalize_dr(dr, "link.dr")]
        if n_trcal < 1:
            raise ValueError(f"TRcal count must be >= 1 tick, got {n_trcal}")
        return _divider(n_trcal, *ratio)

    def blf_hz(self, trcal_s: float, dr, *, trcal_ticks: int | None = None) -> float:
        """Backscatter link frequency the tag produces, ``f / N`` with N from :meth:`blf_divider`.

        Nominally BLF = DR / TRcal (gen2-and-validation-anchors.md §4.2); the clock error cancels
        in N_TRcal up to the integer rounding of N.

        Parameters
        ----------
        trcal_s : float
            TRcal [s].
        dr : str, int or fractions.Fraction
            Divide ratio DR of the Query (as for :meth:`blf_divider`).
        trcal_ticks : int, optional
            TRcal already counted in ticks.

        Returns
        -------
        float
            BLF [Hz].
        """
        return self.f_hz / self.blf_divider(trcal_s, dr, trcal_ticks=trcal_ticks)


#: Divide ratios by name as integer pairs (numerator, denominator) of
#: :data:`rfsim.gen2.commands.DR_VALUES`: a module constant formed once at import.
_DR_RATIOS: dict[str, tuple[int, int]] = {name: (frac.numerator, frac.denominator)
                                          for name, frac in _commands.DR_VALUES.items()}


def _divider(n_trcal: int, dr_num: int, dr_den: int) -> int:
    """N = max(1, round(N_TRcal / DR)) for DR = dr_num / dr_den, in exact integer arithmetic.

    N_TRcal / DR = N_TRcal·dr_den / dr_num; the quotient is rounded to the nearest integer, a
    tie to the even one (as :func:`round` of the :class:`fractions.Fraction`;
    :meth:`TagClock.blf_divider`).
    """
    q, r = divmod(n_trcal * dr_den, dr_num)
    if 2 * r > dr_num or (2 * r == dr_num and q % 2 == 1):
        q += 1
    return max(1, q)


# --------------------------------------------------------------------------- PASS files


__all__ = [
    "PASS_PICMIN_900MHZ_W",
    "PASS_ZIC_900MHZ_OHM",
    "PASS_ZMOD_900MHZ_OHM",
    "TYPICAL_SENSITIVITY_DBM",
    "PASS_TAG_CLOCK_HZ",
    "PASS_TAG_JITTER_RMS",
    "parallel_ohm",
    "power_transmission_coefficient",
    "reflection_coefficient",
    "modulation_factor",
    "differential_rcs_m2",
    "PowerUp",
    "ReflectionStates",
    "TagClock",
]

"""A tag chip whose impedance depends on the power it absorbs: the operating point and the
two reflection states of the PASS tag model (pass-paris-simulator.md §2.2 steps 1–4, §5.2
"Physics of the reflection table"; auris-sense-a-tag.md §6.1 "Tag").

The UCODE-class chip's input impedance moves with its absorbed power (its rectifier and
shunt limiter load the antenna harder as the power rises): Z_ic = 11.9 − j205 Ω at 10 µW,
46.8 − j185 Ω at 100 µW, 69.4 − j93.8 Ω at 1 mW (900 MHz, ``meas_tag_zic``, §5.2). PASS builds
its tag's reflection table from these measurements:

    Z_in   = Z_ic(P_chip) ∥ Z_at,          Z_at = 1/(jωC_at)   (assembly capacitance 450 fF)
    Z_in,m = Z_in ∥ Z_mod(P_chip)                               (modulating state)
    Γ_u, Γ_m = (Z − Z_a*)/(Z + Z_a)  for Z = Z_in, Z_in,m       (Kurokawa, antenna Z_a)
    P_chip = (1 − |Γ_u(P_chip)|²)·P_av                           (self-consistent)
    powered ⇔ P_chip ≥ P_min·10^(margin/10)                      (PASS: margin 2.5 dB)

with the antenna impedance of PASS's tag antenna (``meas_tag_za-v6``: 30.3 + j157 Ω at
915 MHz). The states are complex: near the reader both reflect strongly and differ little,
far away the unmodulated state absorbs more and the modulation deepens (with the full
tables A_T1/A_T2 = |Γ_m/Γ_u| falls to the 1.03 of Tables 3.1/3.2 only near P_av = 20 mW).
PASS re-radiates Γ·incident with no structural term; the chip power splits 98 % / 2 % between the unmodulated and modulating states
(``pfnc_bias``), here 100 % unmodulated.

Default tables: the three chip impedances quoted above and the modulation impedance at the
chip's minimum operating power (:data:`rfsim.devices.tag_frontend.PASS_ZMOD_900MHZ_OHM`), held
outside the quoted range. :meth:`PowerDependentChip.from_pass_files` reads the full measured
tables (601 powers × 11 frequencies) from a folder holding the PASS characteristic files.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from rfsim.devices.tag_frontend import (PASS_PICMIN_900MHZ_W, PASS_ZMOD_900MHZ_OHM, PowerUp, ReflectionStates,
                                  parallel_ohm, reflection_coefficient)
from rfsim.core.errors import ConfigError, UserError

#: Chip input impedance vs chip power at 900 MHz quoted from ``meas_tag_zic`` [(W, Ω)]
#: (pass-paris-simulator.md §5.2).
PASS_ZIC_900MHZ_POINTS = ((10e-6, complex(11.9, -205.0)), (100e-6, complex(46.8, -185.0)),
                          (1e-3, complex(69.4, -93.8)))
#: PASS tag antenna impedance at 915 MHz (``meas_tag_za-v6``, §5.2) [Ω]
PASS_ZA_915MHZ_OHM = complex(30.3, 157.0)
#: PASS tag assembly capacitance parallel to the chip (``Cat``, §2.2/§3.2) [F]
PASS_ASSEMBLY_CAPACITANCE_F = 450e-15
#: PASS power-up margin added to the minimum chip power (§2.2 step 4) [dB]
PASS_POWER_MARGIN_DB = 2.5


@dataclass(frozen=True)
class ChipOperatingPoint:
    """The chip at one available power (pass-paris-simulator.md §2.2 steps 1–4).

    Attributes
    ----------
    p_available_w : float
        Available power at the antenna port P_av [W].
    p_chip_w : float
        Power absorbed by the chip P_chip [W] (the self-consistent solution).
    gamma_unmod : complex
        Reflection coefficient Γ_u of the unmodulated state.
    gamma_mod : complex
        Reflection coefficient Γ_m of the modulating state.
    powered : bool
        Whether ``P_chip ≥ P_min·10^(margin/10)``.
    """

    p_available_w: float
    p_chip_w: float
    gamma_unmod: complex
    gamma_mod: complex
    powered: bool


@dataclass(frozen=True)
class PowerDependentChip:
    """Chip impedance tables vs chip power at one frequency, antenna and assembly.

    Attributes
    ----------
    p_chip_w : (n,) increasing chip powers of the tables [W]
    z_chip_ohm, z_mod_ohm : (n,) complex chip and modulation impedances [Ω] at those powers
        (interpolated linearly in log P_chip, held outside)
    z_ant_ohm : antenna impedance [Ω]
    fc_hz : frequency of the tables [Hz]
    assembly_capacitance_f : capacitance parallel to the chip [F] (0 = none)
    assembly_resistance_ohm : resistance R_at parallel to the chip [Ω] (inf = none); PASS's
        assembly Z_at = R_at ∥ C_at (pass-paris-simulator.md §5.2) absorbs the share
        ``Re(Y_at)/Re(Y_ic + Y_at)`` of the absorbed power, so ``P_chip`` is the rest
    picmin_w : minimum operating chip power [W]
    margin_db : power-up margin on ``picmin_w`` [dB]
    """

    p_chip_w: tuple
    z_chip_ohm: tuple
    z_mod_ohm: tuple
    z_ant_ohm: complex = PASS_ZA_915MHZ_OHM
    fc_hz: float = 915e6
    assembly_capacitance_f: float = PASS_ASSEMBLY_CAPACITANCE_F
    picmin_w: float = PASS_PICMIN_900MHZ_W
    margin_db: float = PASS_POWER_MARGIN_DB
    assembly_resistance_ohm: float = math.inf

    def __post_init__(self):
        p = np.asarray(self.p_chip_w, float)
        if p.ndim != 1 or p.size < 1 or np.any(p <= 0) or np.any(np.diff(p) <= 0):
            raise ConfigError("tag_chip.p_chip_w", self.p_chip_w, "increasing positive powers in W")
        for name in ("z_chip_ohm", "z_mod_ohm"):
            if np.asarray(getattr(self, name)).shape != p.shape:
                raise ConfigError(f"tag_chip.{name}", getattr(self, name), f"{p.size} impedances, one per power")
        if not complex(self.z_ant_ohm).real > 0:
            raise ConfigError("tag_chip.z_ant_ohm", self.z_ant_ohm, "an impedance with a positive real part")

    @classmethod
    def pass_default(cls, *, margin_db: float = PASS_POWER_MARGIN_DB) -> PowerDependentChip:
        """The quoted 900 MHz points (module docstring), Z_mod constant.

        Parameters
        ----------
        margin_db : float, default PASS_POWER_MARGIN_DB (2.5 dB)
            Power-up margin on the minimum chip power [dB].

        Returns
        -------
        PowerDependentChip
            Chip with the three quoted impedances of ``meas_tag_zic`` and
            :data:`rfsim.devices.tag_frontend.PASS_ZMOD_900MHZ_OHM`.
        """
        p = tuple(pt[0] for pt in PASS_ZIC_900MHZ_POINTS)
        return cls(p, tuple(pt[1] for pt in PASS_ZIC_900MHZ_POINTS), (PASS_ZMOD_900MHZ_OHM,) * len(p),
                   margin_db=margin_db)

    @classmethod
    def from_pass_files(cls, folder, *, fc_hz: float = 915e6, zmod: str = "act", antenna: str = "v6",
                        margin_db: float = PASS_POWER_MARGIN_DB) -> PowerDependentChip:
        """Full measured tables from the PASS tag characteristic files.

        Reads ``meas_tag_zic``, ``meas_tag_zmod-<zmod>``, ``meas_tag_za-<antenna>`` and
        ``meas_tag_picmin`` (``.mat``) in ``folder``, interpolated linearly in frequency at
        ``fc_hz`` (pass-paris-simulator.md §5.2); repeated chip powers are dropped.

        Parameters
        ----------
        folder : str or path-like
            Folder holding the characteristic files.
        fc_hz : float, default 915e6
            Frequency of the tables [Hz].
        zmod : str, default 'act'
            Suffix of the modulation-impedance file.
        antenna : str, default 'v6'
            Suffix of the antenna-impedance file.
        margin_db : float, default PASS_POWER_MARGIN_DB (2.5 dB)
            Power-up margin on the minimum chip power [dB].

        Returns
        -------
        PowerDependentChip
            The chip at ``fc_hz``.

        Raises
        ------
        rfsim.core.errors.UserError
            When a file is missing (one line naming it).
        """
        from scipy.io import loadmat

        folder = Path(folder)

        def load(name):
            path = folder / f"{name}.mat"
            if not path.is_file():
                raise UserError(f"tag characteristic file not found: {path} (needs meas_tag_zic, "
                                f"meas_tag_zmod-{zmod}, meas_tag_za-{antenna}, meas_tag_picmin)")
            return loadmat(path, squeeze_me=True)

        zic, zm = load("meas_tag_zic"), load(f"meas_tag_zmod-{zmod}")
        za, pm = load(f"meas_tag_za-{antenna}"), load("meas_tag_picmin")

        def at_fc(table, f_axis):
            order = np.argsort(f_axis)
            f, t = np.asarray(f_axis, float)[order], np.asarray(table, float)[:, order]
            return np.array([np.interp(fc_hz, f, row) for row in t])

        p = np.asarray(zic["pic"], float)
        keep = np.concatenate([[True], np.diff(p) > 0])
        z_chip = at_fc(zic["ric"], zic["fic"]) + 1j * at_fc(zic["xic"], zic["fic"])
        z_mod = at_fc(zm["rmod"], zm["fic"]) + 1j * at_fc(zm["xmod"], zm["fic"])
        fa = np.asarray(za["fa"], float)
        z_ant = complex(np.interp(fc_hz, fa, za["ra"]), np.interp(fc_hz, fa, za["xa"]))
        picmin = float(np.interp(fc_hz, np.asarray(pm["f"], float), np.asarray(pm["p"], float)))
        return cls(tuple(p[keep]), tuple(z_chip[keep]), tuple(z_mod[keep]), z_ant, float(fc_hz),
                   picmin_w=picmin, margin_db=margin_db)

    @property
    def threshold_w(self) -> float:
        """Chip power needed to run [W] = P_min·10^(margin/10)."""
        return self.picmin_w * 10.0 ** (self.margin_db / 10.0)

    @cached_property
    def _table(self) -> tuple[np.ndarray, ...]:
        """ln P_chip, Re/Im Z_ic, Re/Im Z_mod of the table as arrays (made once per chip;
        the operating point's bisection asks for the impedances 120 times)."""
        zc, zm = np.asarray(self.z_chip_ohm, complex), np.asarray(self.z_mod_ohm, complex)
        out = tuple(np.ascontiguousarray(a) for a in (np.log(np.asarray(self.p_chip_w, float)), zc.real, zc.imag,
                                                      zm.real, zm.imag))
        for a in out:
            a.setflags(write=False)
        return out

    def impedances(self, p_chip_w: float) -> tuple[complex, complex]:
        """Chip and modulation impedances at a chip power.

        Interpolated linearly in log P_chip, held outside the table.

        Parameters
        ----------
        p_chip_w : float
            Chip power [W].

        Returns
        -------
        z_ic : complex
            Chip input impedance Z_ic [Ω].
        z_mod : complex
            Modulation impedance Z_mod [Ω].
        """
        lp, zc_re, zc_im, zm_re, zm_im = self._table
        x = math.log(min(max(p_chip_w, self.p_chip_w[0]), self.p_chip_w[-1]))
        return (complex(np.interp(x, lp, zc_re), np.interp(x, lp, zc_im)),
                complex(np.interp(x, lp, zm_re), np.interp(x, lp, zm_im)))

    def states(self, p_chip_w: float) -> tuple[complex, complex]:
        r"""Reflection states at a chip power: chip ∥ assembly (∥ Z_mod) against the antenna.

        .. math::

            \Gamma = \frac{Z - Z_a^*}{Z + Z_a}, \qquad Z_{in} = Z_{ic} \parallel Z_{at},
            \quad Z_{in,m} = Z_{in} \parallel Z_{mod}

        (Kurokawa power waves; pass-paris-simulator.md §5.2).

        Parameters
        ----------
        p_chip_w : float
            Chip power [W].

        Returns
        -------
        gamma_u : complex
            Γ_u of the unmodulated state (``Z = Z_in``).
        gamma_m : complex
            Γ_m of the modulating state (``Z = Z_in,m``).
        """
        z_ic, z_mod = self.impedances(p_chip_w)
        z_in = complex(1.0 / (1.0 / z_ic + self._assembly_admittance()))
        return (reflection_coefficient(z_in, self.z_ant_ohm),
                reflection_coefficient(complex(parallel_ohm(z_in, z_mod)), self.z_ant_ohm))

    def _assembly_admittance(self) -> complex:
        """Y_at = 1/R_at + jωC_at [S]."""
        return (1.0 / self.assembly_resistance_ohm if math.isfinite(self.assembly_resistance_ohm) else 0.0) + \
            2j * math.pi * self.fc_hz * self.assembly_capacitance_f

    def chip_share(self, p_chip_w: float) -> float:
        """Share of the absorbed power that reaches the chip, ``Re(Y_ic)/Re(Y_ic + Y_at)``.

        Parameters
        ----------
        p_chip_w : float
            Chip power [W] (sets Z_ic).

        Returns
        -------
        float
            Fraction in (0, 1] (1 without an assembly resistance).
        """
        y_ic = 1.0 / self.impedances(p_chip_w)[0]
        return y_ic.real / (y_ic.real + self._assembly_admittance().real)

    def operating_point(self, p_available_w: float) -> ChipOperatingPoint:
        r"""The chip's operating point at an available power.

        Solves :math:`P_{chip} = (1 - |\Gamma_u(P_{chip})|^2)\,P_{av}\,s(P_{chip})`
        (``s`` = :meth:`chip_share`) by bisection in log P_chip (60 halvings: relative error
        < 1e-15 of the bracket [P_av·1e-9, P_av]); powered when
        ``P_chip ≥ P_min·10^(margin/10)`` (module docstring).

        Parameters
        ----------
        p_available_w : float
            Available power at the antenna port P_av [W].

        Returns
        -------
        ChipOperatingPoint
            P_av, P_chip, Γ_u, Γ_m and the power state (unpowered with P_chip = 0 and the states
            of the smallest table power when ``P_av ≤ 0``).
        """
        pav = float(p_available_w)
        if not pav > 0:
            u, m = self.states(self.p_chip_w[0])
            return ChipOperatingPoint(pav, 0.0, u, m, False)

        def excess(log_p):
            u = self.states(math.exp(log_p))[0]
            return math.log((1.0 - abs(u) ** 2) * pav * self.chip_share(math.exp(log_p))) - log_p

        lo, hi = math.log(pav * 1e-9), math.log(pav)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if excess(mid) > 0:
                lo = mid
            else:
                hi = mid
        p_chip = math.exp(0.5 * (lo + hi))
        u, m = self.states(p_chip)
        return ChipOperatingPoint(pav, p_chip, u, m, p_chip >= self.threshold_w)


@dataclass(frozen=True)
class PassTagCharacteristics:
    """Chip and antenna numbers read from the PASS tag characteristic files at one
    (frequency, chip power) point.

    Attributes
    ----------
    fc_hz, p_chip_w : the operating point
    z_chip_ohm : unmodulated chip impedance Z_ic [Ω]
    z_mod_ohm : modulation impedance Z_mod [Ω] (modulating state Z_ic ∥ Z_mod)
    z_ant_ohm : antenna impedance Z_a [Ω]
    picmin_w : minimum operating chip power at fc [W]
    """

    fc_hz: float
    p_chip_w: float
    z_chip_ohm: complex
    z_mod_ohm: complex
    z_ant_ohm: complex
    picmin_w: float

    def power_up(self) -> PowerUp:
        """Power-up rule of these numbers.

        Returns
        -------
        rfsim.devices.tag_frontend.PowerUp
            Chip sensitivity ``picmin_w`` with the chip and antenna impedances (τ from their
            mismatch).
        """
        return PowerUp(chip_sensitivity_w=self.picmin_w, z_chip_ohm=self.z_chip_ohm, z_ant_ohm=self.z_ant_ohm)

    def reflection_states(self) -> ReflectionStates:
        """Reflection states of these numbers: Z_ic (absorbing) and Z_ic ∥ Z_mod (modulating) against Z_a.

        Returns
        -------
        rfsim.devices.tag_frontend.ReflectionStates
            Γ_A and Γ_B (:meth:`ReflectionStates.from_impedances`).
        """
        return ReflectionStates.from_impedances(self.z_chip_ohm, parallel_ohm(self.z_chip_ohm, self.z_mod_ohm),
                                                self.z_ant_ohm)


def load_pass_tag_characteristics(folder, *, fc_hz: float, p_chip_w: float, zmod: str = "act",
                                  antenna: str = "v6") -> PassTagCharacteristics:
    """Read the PASS tag characteristic files and interpolate them at (fc, P_chip).

    Files ``meas_tag_zic``, ``meas_tag_zmod-<zmod>``, ``meas_tag_za-<antenna>``,
    ``meas_tag_picmin`` in ``folder``; linear in frequency, linear in log P_chip
    (pass-paris-simulator.md §5.2), through
    :meth:`rfsim.devices.tag_chip.PowerDependentChip.from_pass_files`. The measured range is
    0.7–1.2 GHz and 0.147 µW–8.1 mW; outside it values are held.

    Parameters
    ----------
    folder : str or path-like
        Folder holding the characteristic files.
    fc_hz : float
        Frequency [Hz].
    p_chip_w : float
        Chip power [W].
    zmod : str, default 'act'
        Suffix of the modulation-impedance file.
    antenna : str, default 'v6'
        Suffix of the antenna-impedance file.

    Returns
    -------
    PassTagCharacteristics
        Impedances and minimum chip power at the point.

    Raises
    ------
    rfsim.core.errors.UserError
        When a file is missing.
    """
    chip = PowerDependentChip.from_pass_files(folder, fc_hz=fc_hz, zmod=zmod, antenna=antenna)
    z_chip, z_mod = chip.impedances(p_chip_w)
    return PassTagCharacteristics(float(fc_hz), float(p_chip_w), z_chip, z_mod, chip.z_ant_ohm, chip.picmin_w)


__all__ = ["PASS_ZIC_900MHZ_POINTS", "PASS_ZA_915MHZ_OHM", "PASS_ASSEMBLY_CAPACITANCE_F", "PASS_POWER_MARGIN_DB",
           "ChipOperatingPoint", "PowerDependentChip", "PassTagCharacteristics", "load_pass_tag_characteristics"]

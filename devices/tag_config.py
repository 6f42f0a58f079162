"""Settings of one passive tag (:class:`TagConfig`: sensitivity, clock, reflection states,
reply timing, chip spread), apart from the sample-level tag (:mod:`rfsim.devices.tag`) so that a
scenario's config is read without importing it (``rfsim config NAME``). The physics of the
fields is described in :mod:`rfsim.devices.tag`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from rfsim.devices.tag_frontend import PASS_PICMIN_900MHZ_W, PASS_TAG_CLOCK_HZ, PowerUp, ReflectionStates, TagClock
from rfsim.devices.tag_spread import spread_gamma_b
from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.core.units import dbm_to_w, w_to_dbm
from rfsim.gen2.memory import ChipName

#: Default chip sensitivity [dBm]: the PASS minimum operating chip power at 900 MHz
#: (:data:`rfsim.devices.tag_frontend.PASS_PICMIN_900MHZ_W`, −12.78 dBm, no PASS margin).
DEFAULT_SENSITIVITY_DBM = float(w_to_dbm(PASS_PICMIN_900MHZ_W))

@dataclass(frozen=True)
class TagConfig:
    """Parameters of one passive tag (validated on construction; errors name ``tag.<key>``).

    The clock-error range keeps the subcarrier divider meaningful; the BLF stays within the
    Gen2 tolerance FrT over the whole TRcal table for |error| ≤ 10 % at 1.92 MHz (tested
    in the tag front end); larger errors simulate out-of-spec tags. The physics of the
    fields is described in :mod:`rfsim.devices.tag`.

    Parameters
    ----------
    epc_hex : str
        EPC in hex, a multiple of 16 bits, at most 496 bits.
    sensitivity_dbm : float, default DEFAULT_SENSITIVITY_DBM (−12.78 dBm)
        Minimum chip power for operation [dBm].
    clock_hz : float, default PASS_TAG_CLOCK_HZ
        Nominal tag clock [Hz].
    clock_error_percent : float, default 0.0
        Static relative frequency error of the tag clock [%].
    clock_jitter_rms : float, default 0.0
        RMS tick jitter [fraction of a clock period] (PASS: 1/60).
    modulation : {'ASK', 'PSK'}, default 'ASK'
        Backscatter states: ASK (ohmic, PASS chip) or PSK (capacitive).
    psk_gamma_magnitude : float, default 0.5
        PSK: |Γ| of both states.
    psk_phase_deg : float, default 45.0
        PSK: φ of ``Γ_A,B = |Γ|·exp(±jφ)`` [deg].
    envelope_rc_s : float, default 0.0
        RC time constant of the envelope detector [s] (0 = ideal |x|).
    structural_mode : float, default 1.0
        Antenna structural-mode scattering A_s (1: minimum-scattering antenna; 0: antenna
        mode only).
    blf_error_percent : float, default 0.0
        The tag's own BLF error ε [%]: BLF = f_clk/N_BLF·(1 + ε).
    t1_offset_s : float, default 0.0
        Added to the T1 the tag counts [s].
    chip_gain_db : float, default 0.0
        Chip spread: gain of Γ_B − Γ_A [dB] (:mod:`rfsim.devices.tag_spread`).
    chip_phase_deg : float, default 0.0
        Chip spread: phase of Γ_B − Γ_A [deg].
    memory_chip : str, default "generic"
        Chip model of the tag's memory (:data:`rfsim.gen2.memory.CHIP_MODELS`): its write
        time per word and write power threshold (write minus read sensitivity), which the
        access commands use (:func:`rfsim.gen2.access.execute`). The default "generic" chip is
        the project's assumption (3 ms per word, 3 dB; the datasheets' chips, e.g. Impinj
        Monza 4: 1.7 ms, 2.8 dB, are in ``CHIP_MODELS`` with their sources). The threshold
        applies to the chip's power above ``sensitivity_dbm``.

    Raises
    ------
    ConfigError
        If a value is out of range, ``epc_hex`` is not valid hex of whole 16-bit words, or
        the chip spread makes |Γ_B| > 1.
    """

    epc_hex: str = param("300833B2DDD9014000000027", doc="EPC (hex, a multiple of 16 bits)")
    sensitivity_dbm: float = param(DEFAULT_SENSITIVITY_DBM, lo=-40.0, hi=10.0, unit="dBm",
                                   doc="minimum chip power for operation (PASS picmin at 900 MHz)")
    clock_hz: float = param(PASS_TAG_CLOCK_HZ, lo=1e6, hi=100e6, unit="Hz", doc="nominal tag clock")
    clock_error_percent: float = param(0.0, lo=-20.0, hi=20.0, unit="%",
                                       doc="static relative frequency error of the tag clock")
    clock_jitter_rms: float = param(0.0, lo=0.0, hi=0.5, hi_open=True, unit="period",
                                    doc="RMS tick jitter (fraction of a clock period; PASS: 1/60)")
    modulation: Literal["ASK", "PSK"] = param("ASK", doc="backscatter states: ASK (ohmic) or PSK (capacitive)")
    psk_gamma_magnitude: float = param(0.5, lo=0.0, hi=1.0, lo_open=True, doc="PSK: |Γ| of both states")
    psk_phase_deg: float = param(45.0, lo=0.0, hi=90.0, lo_open=True, unit="deg",
                                 doc="PSK: Γ_A,B = |Γ|·exp(±jφ)")
    envelope_rc_s: float = param(0.0, lo=0.0, hi=1e-6, unit="s",
                                 doc="RC time constant of the envelope detector (0 = ideal |x|)")
    structural_mode: float = param(1.0, lo=0.0, hi=1.0,
                                   doc="antenna structural-mode scattering A_s (1: minimum-scattering "
                                       "antenna; 0: antenna mode only)")
    blf_error_percent: float = param(0.0, lo=-30.0, hi=30.0, unit="%",
                                     doc="the tag's own BLF error: BLF = f_clk/N_BLF·(1 + error) (Gen2: within FrT)")
    t1_offset_s: float = param(0.0, lo=-100e-6, hi=100e-6, unit="s",
                               doc="added to the T1 the tag counts (its own T1 within [T1min, T1max])")
    chip_gain_db: float = param(0.0, lo=-10.0, hi=10.0, unit="dB",
                                doc="chip spread: gain of Γ_B − Γ_A (rfsim.devices.tag_spread)")
    chip_phase_deg: float = param(0.0, lo=-180.0, hi=180.0, unit="deg",
                                  doc="chip spread: phase of Γ_B − Γ_A (rfsim.devices.tag_spread)")
    memory_chip: ChipName = param("generic", doc="chip model of the memory: write time and write power "
                                                 "threshold (rfsim.gen2.memory.CHIP_MODELS; generic: "
                                                 "the project's assumptions, 3 ms/word, 3 dB)")

    def __post_init__(self):
        check_fields(self, "tag")
        text = self.epc_hex.replace(" ", "")
        if not text or len(text) % 4 or len(text) > 124 or any(c not in "0123456789abcdefABCDEF" for c in text):
            raise ConfigError("tag.epc_hex", self.epc_hex,
                              "hex digits, a multiple of 4 (16-bit words), at most 496 bits")
        if self.chip_gain_db or self.chip_phase_deg:
            st = self._base_states()
            g = spread_gamma_b(st.gamma_a, st.gamma_b, self.chip_gain_db, self.chip_phase_deg)
            if abs(g) > 1.0:
                raise ConfigError("tag.chip_gain_db", self.chip_gain_db,
                                  f"a gain keeping |Γ_B| ≤ 1 (|Γ_B| = {abs(g):.3f} with chip_phase_deg "
                                  f"{self.chip_phase_deg:g})")

    @property
    def clock(self) -> TagClock:
        """The tag oscillator (:class:`rfsim.devices.tag_frontend.TagClock`)."""
        return TagClock(f_nominal_hz=self.clock_hz, freq_error_ppm=self.clock_error_percent * 1e4,
                        jitter_rms=self.clock_jitter_rms)

    @property
    def reflection_states(self) -> ReflectionStates:
        """Γ_A (absorbing) and Γ_B (modulating), see the module docstring; with a chip
        spread (``chip_gain_db``, ``chip_phase_deg``) Γ_B moves about Γ_A
        (:func:`rfsim.devices.tag_spread.spread_gamma_b`)."""
        return chip_spread(self._base_states(), self.chip_gain_db, self.chip_phase_deg)

    def _base_states(self) -> ReflectionStates:
        if self.modulation == "ASK":
            return ReflectionStates.pass_default()
        return ReflectionStates.psk(self.psk_gamma_magnitude, math.radians(self.psk_phase_deg))

    @property
    def tau(self) -> float:
        """Power transmission coefficient of the absorbing state, τ = 1 − |Γ_A|²."""
        return 1.0 - abs(self.reflection_states.gamma_a) ** 2

    @property
    def power_up(self) -> PowerUp:
        """Chip sensitivity as a :class:`rfsim.devices.tag_frontend.PowerUp` (compared with τ·P_inc)."""
        return PowerUp(chip_sensitivity_w=float(dbm_to_w(self.sensitivity_dbm)))

    def reply_timing(self, link) -> tuple[float, float]:
        r"""BLF and T1 of this tag's reply to a Query of ``link``.

        The tag counts RTcal and TRcal exactly (PIE edges on ideal times): the rules of
        :meth:`PassiveTag.listen` steps 3–4,

        .. math::

            BLF = \frac{f_{clk}}{N_{BLF}}(1 + \varepsilon), \qquad
            T_1 = \frac{\max(N_{RTcal}, 10 N_{BLF})}{f_{clk}} + t_{1,offset}

        (gen2-and-validation-anchors.md §4.2/§4.3).

        Parameters
        ----------
        link : rfsim.gen2.link.LinkProfile
            Link profile of the Query (``rtcal_s``, ``trcal_s``, ``dr``).

        Returns
        -------
        blf_hz : float
            The tag's backscatter link frequency [Hz].
        t1_s : float
            The tag's reply delay T1 [s].
        """
        clock = self.clock
        f_clk = clock.f_hz
        n_trcal = clock.count_ticks(link.trcal_s)
        n_blf = clock.blf_divider(link.trcal_s, link.dr, trcal_ticks=n_trcal)
        blf_hz = f_clk / n_blf * (1.0 + 0.01 * self.blf_error_percent)
        return blf_hz, max(clock.count_ticks(link.rtcal_s), 10 * n_blf) / f_clk + self.t1_offset_s

    @property
    def threshold_incident_dbm(self) -> float:
        """Smallest incident (available) power that powers the tag [dBm] = sensitivity / τ."""
        return self.sensitivity_dbm - 10.0 * math.log10(self.tau)


def chip_spread(states: ReflectionStates, gain_db: float, phase_deg: float) -> ReflectionStates:
    """Reflection states with Γ_B moved by the chip spread.

    ``Γ_B' = Γ_A + (Γ_B − Γ_A)·10^(g/20)·e^(jφ)``
    (:func:`rfsim.devices.tag_spread.spread_gamma_b`), scaled back onto |Γ_B'| = 1 when it
    would exceed 1 (a power-dependent chip's state near |Γ| = 1 stays passive).

    Parameters
    ----------
    states : rfsim.devices.tag_frontend.ReflectionStates
        Γ_A and Γ_B before the spread.
    gain_db : float
        Gain g of Γ_B − Γ_A [dB].
    phase_deg : float
        Phase φ of Γ_B − Γ_A [deg].

    Returns
    -------
    rfsim.devices.tag_frontend.ReflectionStates
        The spread states; ``states`` itself (the same object) when both are 0.
    """
    if not (gain_db or phase_deg):
        return states
    gb = spread_gamma_b(states.gamma_a, states.gamma_b, gain_db, phase_deg)
    if abs(gb) > 1.0:  # a power-dependent chip's state near |Γ| = 1: stays passive
        gb /= abs(gb)
    return ReflectionStates(states.gamma_a, gb)


__all__ = ["TagConfig", "DEFAULT_SENSITIVITY_DBM", "chip_spread"]

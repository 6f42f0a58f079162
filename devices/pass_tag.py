"""The tag of the sense-a-tag phase-cancellation scenes: which reflection states it has (the
PASS simulator's measured chip, the generic chip, or the source's quoted states) and how it is
built, with PASS's tag replication (its antenna file and assembly resistance).

Tag states (:class:`TagStatesConfig`, ``model``): by default ``"measured"``, the source's own tag
physics (:mod:`rfsim.devices.tag_chip`): the UCODE chip's impedance moves with its absorbed power,
so the reflection states Γ_u, Γ_m follow the available power (|Γ_u| ≈ 0.72, |Γ_m| ≈ 0.84 at
1 m from a 3.28 W EIRP reader; 0.53 / 0.78 near 5 m, complex, not pure ASK), the tag
re-radiates Γ·incident as PASS does (no structural term), and it runs only where
P_chip ≥ picmin + 2.5 dB (≈ 5 m at 3.28 W EIRP). A tag that does not run keeps reflecting Γ_u.
``characteristics_dir`` points at the PASS characteristic files for the full 601-power tables
instead of the three quoted impedances. ``"chip"`` is the generic tag (fixed states against a
matched minimum-scattering antenna, A_s = 1): its deep modulation (|r_A − r_B| = |Γ_B| ≈ 0.67)
keeps every cell of the phase-cancellation scenario detectable to 7 m. ``"source"`` uses Table
3.1's ratio A_T1/A_T2 = 1.03 with a fixed |Γ| ≈ 0.7 (auris-sense-a-tag.md R3-2).

PASS replication (:class:`PassReplicationConfig`): PASS's tag antenna file 'l2-dipole' (peak
amplitude 2.0 = 6.02 dBi, a full-wave pattern, pass-paris-simulator.md §3.2, §5.1) instead of
the physical half-wave dipole, the full measured chip tables and the assembly resistance R_at
(:func:`q_matched_assembly_resistance_ohm`). The pattern file itself is read by the scene
(antennas are channel models); this module names it (:data:`PASS_TAG_ANTENNA_FILE`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np

from typing import TYPE_CHECKING

from rfsim.core.memo import PureCache
from rfsim.devices.tag_config import TagConfig
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import

if TYPE_CHECKING:
    from rfsim.devices.tag import PassiveTag
    from rfsim.devices.tag_chip import PowerDependentChip

# the tag's physics loads on first use, so that the configs here stay light ('rfsim config')
_tag = lazy_import("rfsim.devices.tag")
_chip = lazy_import("rfsim.devices.tag_chip")
_frontend = lazy_import("rfsim.devices.tag_frontend")

#: PASS's tag antenna pattern file (amplitude, peak 2.0: 6.02 dBi)
PASS_TAG_ANTENNA_FILE = "channelchar_directivity_l2-dipole.mat"


@dataclass(frozen=True)
class TagStatesConfig:
    """Which reflection states the tag has (module docstring)."""

    model: Literal["measured", "chip", "source"] = param(
        "measured", doc="tag reflection states: 'measured' = the PASS tag (UCODE chip impedance vs absorbed "
                        "power on PASS's antenna, Gamma*incident, power-up with the PASS margin; "
                        "rfsim.devices.tag_chip); 'chip' = the tag config's fixed states with structural mode A_s; "
                        "'source' = two strong re-radiated ASK states with A_T1/A_T2 = 1.03 (Tables 3.1/3.2)")
    characteristics_dir: str = param("", doc="'measured': folder with the PASS tag files (meas_tag_zic, "
                                             "meas_tag_zmod-act, meas_tag_za-v6, meas_tag_picmin); empty = the "
                                             "three quoted chip impedances")
    power_margin_db: float = param(2.5, lo=0.0, hi=20.0, unit="dB",
                                   doc="'measured': power-up margin on the chip's minimum power (PASS: 2.5 dB)")
    source_gamma_a: float = param(-0.70, lo=-1.0, hi=1.0,
                                  doc="'source': re-radiated state A (the source's Gamma_A, no structural term)")
    source_gamma_b: float = param(-0.721, lo=-1.0, hi=1.0,
                                  doc="'source': re-radiated state B (the source's Gamma_B, no structural term)")

    def __post_init__(self):
        d = self.characteristics_dir
        if d and not Path(d).is_dir():
            raise ConfigError("tag_states.characteristics_dir", d, "an existing folder with the PASS tag files, "
                                                                    "or empty for the quoted impedances")


@dataclass(frozen=True)
class PassReplicationConfig:
    """Replicate PASS's tag: its antenna file, its chip tables and its assembly resistance."""

    enabled: bool = param(False, doc="replicate PASS's tag: its 'l2-dipole' antenna file (peak amplitude 2.0 = "
                                     "6.02 dBi, a full-wave pattern) instead of the physical half-wave dipole "
                                     "(2.15 dBi), the full measured chip tables and the assembly resistance R_at")
    characteristics_dir: str = param("", doc="folder with the PASS characteristic files "
                                             "(channelchar_directivity_l2-dipole.mat, meas_tag_*.mat)")
    assembly_resistance_ohm: float = param(0.0, lo=0.0, hi=1e9, unit="ohm",
                                           doc="R_at parallel to the chip; 0 = PASS's 'Q-matched' optimum read as "
                                               "Q(R_at || C_at) = Q of the chip at its minimum power (2.4 kOhm with the full tables)")
    st_antenna_file: bool = param(False, doc="also give the ST antennas PASS's 'l2-dipole' file (PASS's sensatag "
                                             "uses the tag's antenna file, pass-paris-simulator.md §3.2): A_R and "
                                             "A_T at the ST 2/1.28 = 1.56x the physical dipole's")

    def __post_init__(self):
        if self.enabled:
            d = Path(self.characteristics_dir) if self.characteristics_dir else None
            if d is None or not (d / PASS_TAG_ANTENNA_FILE).is_file():
                raise ConfigError("pass_replication.characteristics_dir", self.characteristics_dir,
                                  f"a folder holding {PASS_TAG_ANTENNA_FILE} and the meas_tag_* files when "
                                  "pass_replication.enabled")


def q_matched_assembly_resistance_ohm(chip: PowerDependentChip) -> float:
    """Compute PASS's "Rat Q-matched at 915 MHz" assembly resistance.

    PASS's "Rat Q-matched at 915 MHz" (pass-paris-simulator.md §5.2; ``tagchar_modulator_adsm``:
    R_at shifts in % "from optimum"), read as the R_at whose parallel Q with C_at equals the
    chip's parallel Q at its minimum power:

    .. math:: R_{at} = \\frac{|\\operatorname{Im} Y_{ic}| / \\operatorname{Re} Y_{ic}}{\\omega C_{at}}

    with :math:`Y_{ic}` the chip admittance at ``picmin``. Checked on PASS's synthetic
    characteristic (``tagchar_modulator_synth01``: 463 Ω from its tables vs its stored 437 Ω,
    6 %). For the UCODE tables at 915 MHz 2.41 kΩ.

    Parameters
    ----------
    chip : rfsim.devices.tag_chip.PowerDependentChip
        The chip (impedances, ``picmin_w``, ``fc_hz``, ``assembly_capacitance_f``).

    Returns
    -------
    float
        R_at [Ω].
    """
    y = 1.0 / chip.impedances(chip.picmin_w)[0]
    return (abs(y.imag) / y.real) / (2.0 * math.pi * chip.fc_hz * chip.assembly_capacitance_f)


def chip_model(characteristics_dir: str, fc_hz: float, margin_db: float,
               assembly_resistance_ohm: float = math.inf) -> PowerDependentChip:
    """Build the 'measured' tag chip: full PASS tables from a folder, else the quoted points.

    With ``assembly_resistance_ohm`` = 0 the Q-matched R_at
    (:func:`q_matched_assembly_resistance_ohm`). Kept by its arguments (folder name,
    frequency, margin, R_at) in :data:`CHIP_MODEL_CACHE`: every cell of a run builds the same chip
    (the folder is read once per process).

    Parameters
    ----------
    characteristics_dir : str
        Folder with the PASS tag files; empty for the three quoted chip impedances.
    fc_hz : float
        Carrier [Hz].
    margin_db : float
        Power-up margin on the chip's minimum power [dB].
    assembly_resistance_ohm : float, optional
        R_at parallel to the chip [Ω]; 0 the Q-matched value; default inf (none).

    Returns
    -------
    rfsim.devices.tag_chip.PowerDependentChip
        The chip.
    """
    return CHIP_MODEL_CACHE(characteristics_dir, fc_hz, margin_db, assembly_resistance_ohm)


def _chip_model(characteristics_dir: str, fc_hz: float, margin_db: float,
                assembly_resistance_ohm: float) -> PowerDependentChip:
    """:func:`chip_model`, computed."""
    if characteristics_dir:
        chip = _chip.PowerDependentChip.from_pass_files(characteristics_dir, fc_hz=fc_hz, margin_db=margin_db)
    else:
        chip = _chip.PowerDependentChip.pass_default(margin_db=margin_db)
    if assembly_resistance_ohm == 0.0:
        assembly_resistance_ohm = q_matched_assembly_resistance_ohm(chip)
    return replace(chip, assembly_resistance_ohm=float(assembly_resistance_ohm))


#: :func:`chip_model` by its arguments: configuration parsed into an immutable chip, the same in
#: every run, not run state (:class:`rfsim.core.memo.PureCache`).
CHIP_MODEL_CACHE = PureCache(_chip_model, 8)


def tag_chip(states: TagStatesConfig, pr: PassReplicationConfig, fc_hz: float) -> PowerDependentChip:
    """Return the 'measured' chip of these settings (:func:`chip_model`).

    Parameters
    ----------
    states : TagStatesConfig
        Folder of the tag files and power-up margin.
    pr : PassReplicationConfig
        When enabled, PASS's tables and its R_at replace the folder of ``states``.
    fc_hz : float
        Carrier [Hz] (rounded to 1 mHz for the memo).

    Returns
    -------
    rfsim.devices.tag_chip.PowerDependentChip
        The chip.
    """
    if pr.enabled:
        return chip_model(pr.characteristics_dir, round(fc_hz, 3), states.power_margin_db, pr.assembly_resistance_ohm)
    return chip_model(states.characteristics_dir, round(fc_hz, 3), states.power_margin_db)


def make_tag(tag: TagConfig, states: TagStatesConfig, pr: PassReplicationConfig, antenna, fc_hz: float,
             rng: np.random.Generator) -> PassiveTag:
    """Build the passive tag of the tag-states model (module docstring).

    ``"source"``: the tag config's chip with the re-radiated ASK states −Γ_A, −Γ_B and no
    structural term; ``"measured"``: the measured chip (:func:`tag_chip`), no structural
    term; ``"chip"``: the tag config as it is.

    Parameters
    ----------
    tag : rfsim.devices.tag_config.TagConfig
        The tag's settings.
    states : TagStatesConfig
        The tag-states model.
    pr : PassReplicationConfig
        PASS replication settings.
    antenna : rfsim.channels.antennas.Antenna
        The tag's antenna.
    fc_hz : float
        Carrier [Hz] (for the measured chip).
    rng : numpy.random.Generator
        The tag's own generator.

    Returns
    -------
    rfsim.devices.tag.PassiveTag
        The tag.
    """
    if states.model == "source":
        # The source re-radiates Γ·incident (no structural term): its states are the
        # re-radiated states r = A_s − Γ, i.e. A_s = 0 and chip states −Γ_source. Backscatter
        # only; power-up keeps the tag config's chip model (the source's tag replies in
        # every cell).
        out = _tag.PassiveTag(replace(tag, structural_mode=0.0), antenna, rng=rng)
        out.reflection_states = _frontend.ReflectionStates.ask(-states.source_gamma_a, -states.source_gamma_b)
        return out
    if states.model == "measured":
        # PASS tag: Γ·incident (no structural term); its chip sets the states and power-up
        return _tag.PassiveTag(replace(tag, structural_mode=0.0), antenna, rng=rng, chip=tag_chip(states, pr, fc_hz))
    return _tag.PassiveTag(tag, antenna, rng=rng)


def tag_attributes(states: TagStatesConfig, pr: PassReplicationConfig, fc_hz: float) -> dict:
    """Describe the tag and ST antennas of these settings, and R_at when replicating PASS.

    Parameters
    ----------
    states : TagStatesConfig
        The tag-states model.
    pr : PassReplicationConfig
        PASS replication settings.
    fc_hz : float
        Carrier [Hz] (for R_at).

    Returns
    -------
    dict
        Dataset attributes: ``tag_states``, ``tag_antenna`` and ``st_antenna`` (str), and
        ``tag_assembly_resistance_ohm`` (float, [Ω]) when replicating PASS.
    """

    out = {"tag_states": {"measured": "measured UCODE chip impedance vs absorbed power on the PASS antenna "
                                      "(Gamma*incident, power-up at picmin + 2.5 dB)",
                          "chip": "fixed chip states with structural mode A_s (deep modulation: P rises with "
                                  "distance)",
                          "source": "source-like re-radiated states, A_T1/A_T2 = 1.03 (backscatter only)",
                          }[states.model],
           "tag_antenna": ("PASS channelchar_directivity_l2-dipole (peak amplitude 2.0, 6.02 dBi: a full-wave "
                           "pattern)" if pr.enabled else "physical half-wave dipole (2.15 dBi)")}
    if pr.enabled:
        out["tag_assembly_resistance_ohm"] = float(tag_chip(states, pr, fc_hz).assembly_resistance_ohm)
    out["st_antenna"] = ("PASS channelchar_directivity_l2-dipole (PASS's sensatag antenna)"
                         if pr.enabled and pr.st_antenna_file else "physical half-wave dipoles")
    return out


__all__ = ["PASS_TAG_ANTENNA_FILE", "TagStatesConfig", "PassReplicationConfig", "q_matched_assembly_resistance_ohm",
           "chip_model", "tag_chip", "make_tag", "tag_attributes"]

"""Tag-to-tag spread: every tag of a population draws its own link and chip parameters.

Real tags are not identical: their backscatter link frequency, their reply delay T1, their
reflection states and their antenna orientation differ from tag to tag, so two replies in
one slot drift against each other in timing and phase (the physics of capture). A
:class:`TagSpreadConfig` draws, for one tag, from the tag's own stream:

* **BLF error** ε_BLF: the tag's BLF is (f_clk / N_BLF)·(1 + ε_BLF) (``TagConfig.
  blf_error_percent``, rfsim.devices.tag step 3). Gen2 only bounds it, |ε_BLF| ≤ FrT of the link
  (gen2-and-validation-anchors.md §4.2: FrT from DR and TRcal, e.g. ±10 % for Miller-4 at
  320 kHz, ±4 % for FM0 at 40 kHz; :func:`rfsim.gen2.link.frt_fraction`). The reference pages
  hold no measured distribution over a tag population, so the default is an *assumption*:
  ε_BLF ~ N(0, (FrT/3)²) truncated to ±FrT (a population whose conformance limit is its 3σ
  point); ``blf_distribution = "uniform"`` spreads it evenly over ±``blf_spread_frt``·FrT.
* **T1**: uniform over [T1min + 1 tick, T1max − 1 tick] of the link (§4.3, T1 =
  max(RTcal, 10·Tpri)·(1 ± FrT) ± 2 µs; the tick, 1/f_clk, keeps the tag's own half-tick
  rounding of RTcal inside the window). Stored as ``TagConfig.t1_offset_s`` = T1 − T1nom,
  T1nom = max(RTcal, 10/BLF) of the link: the tag adds it to the T1 it counts.
* **Chip spread**: the modulated reflection state moves by a gain g ~ N(0, σ_g²) [dB] and a
  phase φ ~ N(0, σ_φ²) [deg] about the absorbing one, Γ_B' = Γ_A + (Γ_B − Γ_A)·10^(g/20)·e^(jφ)
  (``TagConfig.chip_gain_db``, ``chip_phase_deg``; rfsim.devices.tag). Assumption (no measured
  chip-to-chip spread in the reference pages): σ_g = 0.5 dB, σ_φ = 5°; draws that would make
  |Γ_B'| > 1 (a passive load cannot reflect more than it receives) are drawn again.
* **Antenna orientation**: yaw and roll offsets uniform in ±``orientation_deg`` added to the
  antenna the scenario places (:func:`orientation_offsets_rad`).

Randomness: :meth:`TagSpreadConfig.draw` takes the tag's own spread stream — by convention
the sub-stream ``trial_rng(seed, *tag_key, 0)`` of tag key ``tag_key`` (rfsim/core/rng.py: nested
paths key sub-streams), so the tag's protocol stream (slot counters, RN16s) is the same with
and without spread.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.gen2.link import t1

#: Columns of the per-tag spread record (:meth:`TagSpreadConfig.record`): (unit, description).
SPREAD_FIELDS = {
    "blf_error_percent": ("%", "the tag's BLF error against DR/TRcal (its BLF = f_clk/N_BLF·(1 + error))"),
    "t1_s": ("s", "the tag's reply delay T1 after the command's last rising edge (nominal T1 + offset)"),
    "t1_offset_s": ("s", "T1 − T1nom of the link, added by the tag to the T1 it counts"),
    "chip_gain_db": ("dB", "gain of the modulated reflection state about the absorbing one (chip spread)"),
    "chip_phase_deg": ("deg", "phase of the modulated reflection state about the absorbing one (chip spread)"),
    "yaw_offset_deg": ("deg", "antenna yaw offset drawn for the tag"),
    "roll_offset_deg": ("deg", "antenna roll offset drawn for the tag"),
}


@dataclass(frozen=True)
class TagSpreadConfig:
    """How the tags of a population differ (module docstring; errors name ``spread.<key>``).

    Parameters
    ----------
    enabled : bool, default False
        Draw every tag's own BLF error, T1, chip states and orientation.
    blf_distribution : {'normal', 'uniform'}, default 'normal'
        BLF error: normal σ = FrT/3 truncated to ±FrT, or uniform over
        ±``blf_spread_frt``·FrT (an assumption: no measured distribution).
    blf_spread_frt : float, default 1.0
        Largest |BLF error| as a fraction of FrT, in [0, 1].
    t1_spread : bool, default True
        T1 uniform over [T1min, T1max] (else the nominal T1).
    chip_gain_sigma_db : float, default 0.5
        σ of the chip's modulation gain [dB].
    chip_phase_sigma_deg : float, default 5.0
        σ of the chip's modulation phase [deg].
    orientation_deg : float, default 0.0
        Antenna yaw and roll offsets uniform in ± this [deg].

    Raises
    ------
    ConfigError
        If a value is out of range.
    """

    enabled: bool = param(False, doc="draw every tag's own BLF error, T1, chip states and orientation")
    blf_distribution: Literal["normal", "uniform"] = param(
        "normal", doc="BLF error: normal σ = FrT/3 truncated to ±FrT, or uniform over ±blf_spread_frt·FrT")
    blf_spread_frt: float = param(1.0, lo=0.0, hi=1.0, doc="largest |BLF error| as a fraction of FrT")
    t1_spread: bool = param(True, doc="T1 uniform over [T1min, T1max] (else the nominal T1)")
    chip_gain_sigma_db: float = param(0.5, lo=0.0, hi=6.0, unit="dB", doc="σ of the chip's modulation gain")
    chip_phase_sigma_deg: float = param(5.0, lo=0.0, hi=90.0, unit="deg", doc="σ of the chip's modulation phase")
    orientation_deg: float = param(0.0, lo=0.0, hi=180.0, unit="deg",
                                   doc="antenna yaw and roll offsets uniform in ± this")

    def __post_init__(self):
        check_fields(self, "spread")

    def blf_error(self, frt: float, *, rng: np.random.Generator) -> float:
        """One BLF error ε (fraction), ``|ε| ≤ blf_spread_frt·FrT`` (module docstring).

        Normal with σ = FrT/3 truncated by rejection, or uniform, per ``blf_distribution``
        (gen2-and-validation-anchors.md §4.2 bounds it by FrT; the distribution is an
        assumption).

        Parameters
        ----------
        frt : float
            Frequency tolerance FrT of the link (fraction, e.g. 0.1 for ±10 %).
        rng : numpy.random.Generator
            The tag's spread stream.

        Returns
        -------
        float
            ε as a fraction (0 when the limit is 0).
        """
        lim = self.blf_spread_frt * frt
        if lim == 0.0:
            return 0.0
        if self.blf_distribution == "uniform":
            return float(rng.uniform(-lim, lim))
        while True:  # truncated normal by rejection (P(|z| > 3) = 0.27 %)
            e = float(rng.normal(0.0, frt / 3.0))
            if abs(e) <= lim:
                return e

    def blf_errors(self, frt: float, n: int, *, rng: np.random.Generator) -> np.ndarray:
        """``n`` BLF errors at once, from the distribution of :meth:`blf_error`.

        Vectorised: rejected normal draws are replaced in further passes (so the values differ
        from ``n`` calls of :meth:`blf_error` on the same stream).

        Parameters
        ----------
        frt : float
            Frequency tolerance FrT of the link (fraction).
        n : int
            Number of errors.
        rng : numpy.random.Generator
            Spread stream.

        Returns
        -------
        numpy.ndarray, shape (n,), float64
            ε as fractions; zeros when disabled or the limit is 0.
        """
        lim = self.blf_spread_frt * frt
        if lim == 0.0 or not self.enabled:
            return np.zeros(int(n))
        if self.blf_distribution == "uniform":
            return rng.uniform(-lim, lim, int(n))
        e = rng.normal(0.0, frt / 3.0, int(n))
        bad = np.abs(e) > lim
        while bad.any():
            e[bad] = rng.normal(0.0, frt / 3.0, int(bad.sum()))
            bad = np.abs(e) > lim
        return e

    def t1_values_s(self, link, n: int, *, tick_s: float, rng: np.random.Generator) -> np.ndarray:
        """``n`` T1 values at once, uniform over [T1min + tick, T1max − tick] of ``link``.

        T1 range of Gen2 (gen2-and-validation-anchors.md §4.3, :func:`rfsim.gen2.link.t1`).

        Parameters
        ----------
        link : rfsim.gen2.link.LinkProfile
            Link profile.
        n : int
            Number of values.
        tick_s : float
            Tag clock period 1/f_clk [s] (margin at both ends).
        rng : numpy.random.Generator
            Spread stream.

        Returns
        -------
        numpy.ndarray, shape (n,), float64
            T1 [s]; the nominal T1 when disabled or without ``t1_spread``.
        """
        tr = t1(link)
        if not (self.enabled and self.t1_spread):
            return np.full(int(n), tr.nom_s)
        return rng.uniform(tr.min_s + tick_s, tr.max_s - tick_s, int(n))

    def draw(self, tag_config, link, *, rng: np.random.Generator, states=None) -> tuple:
        """One tag's own spread on ``link``: its config and a record of the draws.

        The draws are made in a fixed order (BLF, T1, chip gain and phase, orientation)
        whatever is switched off, so a tag's stream stays aligned across settings.

        Parameters
        ----------
        tag_config : rfsim.devices.tag_config.TagConfig
            The tag's config (its ``reflection_states`` bound the chip gain unless ``states``
            is given; its clock sets the T1 tick).
        link : rfsim.gen2.link.LinkProfile
            Link profile (FrT, T1 range).
        rng : numpy.random.Generator
            The tag's spread stream.
        states : rfsim.devices.tag_frontend.ReflectionStates, optional
            Reflection states bounding the chip spread (|Γ_B'| ≤ 1).

        Returns
        -------
        config : rfsim.devices.tag_config.TagConfig
            ``tag_config`` with ``blf_error_percent``, ``t1_offset_s``, ``chip_gain_db``,
            ``chip_phase_deg`` set (unchanged when disabled).
        record : dict of str to float
            The keys of :data:`SPREAD_FIELDS` (zeros and the nominal T1 when disabled).
        """
        t1_range = t1(link)
        eps = self.blf_error(link.frt, rng=rng)
        tick_s = 1.0 / tag_config.clock.f_hz
        u = float(rng.uniform())
        lo, hi = t1_range.min_s + tick_s, t1_range.max_s - tick_s
        offset = (lo + u * (hi - lo)) - t1_range.nom_s if self.t1_spread else 0.0
        st = states if states is not None else tag_config.reflection_states
        gain_db, phase_deg = self._chip(st, rng)
        yaw, roll = rng.uniform(-1.0, 1.0, 2) * self.orientation_deg
        if not self.enabled:
            eps, offset, gain_db, phase_deg, yaw, roll = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        cfg = replace(tag_config, blf_error_percent=100.0 * eps, t1_offset_s=offset, chip_gain_db=gain_db,
                      chip_phase_deg=phase_deg) if self.enabled else tag_config
        rec = dict(blf_error_percent=100.0 * eps, t1_s=t1_range.nom_s + offset, t1_offset_s=offset,
                   chip_gain_db=gain_db, chip_phase_deg=phase_deg, yaw_offset_deg=float(yaw),
                   roll_offset_deg=float(roll))
        return cfg, rec

    def _chip(self, states, rng: np.random.Generator) -> tuple[float, float]:
        """(gain [dB], phase [deg]) of the chip spread, redrawn while |Γ_B'| > 1."""
        for _ in range(1000):
            g = float(rng.normal(0.0, self.chip_gain_sigma_db)) if self.chip_gain_sigma_db > 0 else 0.0
            p = float(rng.normal(0.0, self.chip_phase_sigma_deg)) if self.chip_phase_sigma_deg > 0 else 0.0
            if abs(spread_gamma_b(states.gamma_a, states.gamma_b, g, p)) <= 1.0:
                return g, p
        return 0.0, 0.0  # σ so large that no passive draw is found: no chip spread


def spread_gamma_b(gamma_a: complex, gamma_b: complex, gain_db: float, phase_deg: float) -> complex:
    r"""The chip spread of the modulated state.

    .. math::

        \Gamma_B' = \Gamma_A + (\Gamma_B - \Gamma_A)\,10^{g/20}\,e^{j\varphi}

    (the project's own model, module docstring).

    Parameters
    ----------
    gamma_a : complex
        Absorbing-state reflection coefficient Γ_A.
    gamma_b : complex
        Modulating-state reflection coefficient Γ_B.
    gain_db : float
        Gain g [dB].
    phase_deg : float
        Phase φ [deg].

    Returns
    -------
    complex
        Γ_B'.
    """
    return complex(gamma_a + (gamma_b - gamma_a) * 10.0 ** (gain_db / 20.0) * np.exp(1j * math.radians(phase_deg)))


def orientation_offsets_rad(record: dict) -> tuple[float, float, float]:
    """Orientation offsets of a spread record, to add to an antenna's orientation.

    Parameters
    ----------
    record : dict
        Spread record of :meth:`TagSpreadConfig.draw` (``yaw_offset_deg``,
        ``roll_offset_deg``).

    Returns
    -------
    tuple of float
        ``(yaw, 0, roll)`` offsets [rad].
    """
    return (math.radians(record["yaw_offset_deg"]), 0.0, math.radians(record["roll_offset_deg"]))


__all__ = ["TagSpreadConfig", "SPREAD_FIELDS", "spread_gamma_b", "orientation_offsets_rad"]

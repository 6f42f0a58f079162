"""The sense-a-tag's envelope detector as a configurable part: its law (diode, linear, PASS's
AGC characteristic), the diode's parameters and the front-end noise, and the receive chain built
from them.

Detector and noise (auris-sense-a-tag.md §3.1, §6): the ST's diode,
``v = n·V_T·ln I0(G_v·V/(n·V_T))`` (:class:`rfsim.devices.st_receiver.EnvelopeDetector`, n = 1.05,
290 K) with the matching gain G_v = 0.96 that meets the source's two quoted conversions within
1 % (R3-1: Table 3.1's 0.0015 V → "0.01 V"; R3-4: 0.0019 V → 0.012 V, in source volts, i.e.
√50× smaller than the 50 Ω peak volts here; derivation in :mod:`rfsim.devices.st_receiver`);
the threshold is 5 mV at the detector output. ``linear`` is the unit-gain detector of the
closed forms (+6 %, +12 % on the two conversions), ``agc`` PASS's demodulator characteristic
(``meas_tag_agc``; 0.0084 V and 0.029 V). Noise: k·T0·fs·F per sample at every ST antenna
(F = 15 dB, an assumption: the source has no ST noise) — microvolts at the detector output
against the 5 mV threshold, so the threshold, not the noise, decides.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.devices import st_receiver as sr
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import

_io = lazy_import("scipy.io")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")

#: PASS ST chip impedance (``sensatag_modulation.m``: Zic = 70.085 − j111.36 Ω, §6.3): the
#: AGC's chip voltage is sqrt(2P·R_p), R_p the parallel resistance of Z_ic
PASS_ST_ZIC_OHM = complex(70.085, -111.36)


@dataclass(frozen=True)
class DetectorConfig:
    """ST envelope detector law, diode parameters and front-end noise.

    The laws and the default diode constants are those of the module docstring
    (auris-sense-a-tag.md §3.1, §6).

    Parameters
    ----------
    law : {'diode', 'linear', 'agc'}, default 'diode'
        Detector law: ``'diode'`` = ``n·V_T·ln I0(G_v·V/(n·V_T))``
        (:class:`rfsim.devices.st_receiver.EnvelopeDetector`); ``'linear'`` =
        ``st.detector_gain·V`` (the closed forms' unit-gain detector); ``'agc'`` = PASS's
        demodulator characteristic ``meas_tag_agc`` (needs ``agc_dir``).
    matching_gain : float, default DEFAULT_MATCHING_GAIN (0.96)
        ``'diode'``: matching-network voltage gain G_v, in [0.01, 100].
    ideality : float, default DEFAULT_IDEALITY (1.05)
        ``'diode'``: ideality factor n, in [1, 3].
    temperature_k : float, default DEFAULT_TEMPERATURE_K (290 K)
        ``'diode'``: diode temperature T [K], in [1, 500].
    noise_figure_db : float, default 15.0
        ST front-end noise figure referred to the antenna port [dB]: thermal noise
        ``k·T0·fs·F`` per sample at each ST antenna (an assumption: the source has no ST noise).
    noise : bool, default True
        Add the ST thermal/detector noise.
    agc_dir : str, default ''
        ``'agc'``: folder holding ``meas_tag_agc.mat`` (PASS characteristics).

    Raises
    ------
    ConfigError
        If ``law = 'agc'`` and ``agc_dir`` holds no ``meas_tag_agc.mat``, or a value is out of
        its range.
    """

    law: Literal["diode", "linear", "agc"] = param(
        "diode", doc="ST envelope detector: 'diode' = n*V_T*ln I0(G_v*V/(n*V_T)) (rfsim.devices.st_receiver); "
                     "'linear' = st.detector_gain*V (the closed forms' unit-gain detector); 'agc' = PASS's "
                     "demodulator characteristic meas_tag_agc (needs agc_dir)")
    matching_gain: float = param(sr.DEFAULT_MATCHING_GAIN, lo=0.01, hi=100.0,
                                 doc="'diode': matching-network voltage gain G_v (default fits R3-1/R3-4)")
    ideality: float = param(sr.DEFAULT_IDEALITY, lo=1.0, hi=3.0, doc="'diode': ideality factor n")
    temperature_k: float = param(sr.DEFAULT_TEMPERATURE_K, lo=1.0, hi=500.0, unit="K", doc="'diode': T")
    noise_figure_db: float = param(15.0, lo=0.0, hi=60.0, unit="dB",
                                   doc="ST front-end noise figure referred to the antenna port: thermal noise "
                                       "k*T0*fs*F per sample at each ST antenna (diode detector with the CW as "
                                       "its local oscillator: conversion loss and video noise; assumption, the "
                                       "source has no ST noise)")
    noise: bool = param(True, doc="add the ST thermal/detector noise")
    agc_dir: str = param("", doc="'agc': folder with meas_tag_agc.mat (PASS characteristics)")

    def __post_init__(self):
        if self.law == "agc" and not (self.agc_dir and (Path(self.agc_dir) / "meas_tag_agc.mat").is_file()):
            raise ConfigError("detector.agc_dir", self.agc_dir, "a folder holding meas_tag_agc.mat when "
                                                                "detector.law = 'agc'")


def make_detector(dc: DetectorConfig, st: SenseATagConfig, blf_hz: float) -> sr.EnvelopeDetector:
    """The ST's envelope detector from the detector settings.

    The RC time constant is ``τ = 1/(2π·4·BLF)`` (a low-pass at four times the BLF). For
    ``'agc'``: PASS's ``meas_tag_agc`` table at Vdda = 2 V, the chip voltage
    ``sqrt(2P·R_p)`` of :data:`PASS_ST_ZIC_OHM` against the 50 Ω peak voltage here
    (``agc_scale = sqrt(R_p/50 Ω)``).

    Parameters
    ----------
    dc : DetectorConfig
        Detector law, diode parameters and AGC table folder.
    st : SenseATagConfig
        Sense-a-tag settings (``detector_gain`` of the linear law).
    blf_hz : float
        Backscatter link frequency [Hz].

    Returns
    -------
    rfsim.devices.st_receiver.EnvelopeDetector
        The detector of the chosen law.
    """
    tau = 1.0 / (2.0 * math.pi * 4.0 * blf_hz)
    if dc.law == "linear":
        return sr.EnvelopeDetector(tau_s=tau, gain=st.detector_gain)
    if dc.law == "agc":
        agc = _io.loadmat(str(Path(dc.agc_dir) / "meas_tag_agc.mat"), squeeze_me=True)
        venv = np.asarray(agc["venv"], float)[:, list(np.atleast_1d(agc["vdda"])).index(2.0)]
        r_p = 1.0 / (1.0 / PASS_ST_ZIC_OHM).real
        return sr.EnvelopeDetector(tau_s=tau, law="agc", agc_vrf_v=tuple(np.asarray(agc["vrf"], float)),
                                   agc_venv_v=tuple(venv), agc_scale=math.sqrt(r_p / sr.REFERENCE_IMPEDANCE_OHM))
    return sr.EnvelopeDetector(tau_s=tau, law="diode", matching_gain=dc.matching_gain, ideality=dc.ideality,
                               temperature_k=dc.temperature_k)


def make_st_receiver(dc: DetectorConfig, st: SenseATagConfig, *, fs_hz: float, blf_hz: float, m: int,
                     trext: bool) -> sr.STReceiver:
    """The ST receive chain with this detector: band-pass, comparator, decoder.

    The comparator threshold is ``st.threshold_v``; the linear law gives the chain of
    :func:`rfsim.devices.sense_a_tag.make_receiver`.

    Parameters
    ----------
    dc : DetectorConfig
        Detector law and parameters.
    st : SenseATagConfig
        Sense-a-tag settings (threshold, linear detector gain).
    fs_hz : float
        Sample rate [Hz].
    blf_hz : float
        Backscatter link frequency [Hz].
    m : int
        Miller subcarrier cycles per symbol (1 = FM0, 2, 4, 8).
    trext : bool
        Whether the reply carries the extended (TRext) pilot tone.

    Returns
    -------
    rfsim.devices.st_receiver.STReceiver
        The receive chain.
    """
    if dc.law == "linear":
        return _sense_a_tag.make_receiver(st, fs_hz=fs_hz, blf_hz=blf_hz, m=m, trext=trext)
    return sr.STReceiver(fs_hz=fs_hz, blf_hz=blf_hz, m=m, trext=trext, threshold_v=st.threshold_v,
                         detector=make_detector(dc, st, blf_hz))


__all__ = ["PASS_ST_ZIC_OHM", "DetectorConfig", "make_detector", "make_st_receiver"]

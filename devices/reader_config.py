"""Reader settings (:class:`ReaderConfig`) and the frequency plans they name, apart from
the reader's signal processing (:mod:`rfsim.devices.reader`) so that a scenario's config is read
without importing it (``rfsim config NAME``).

Frequency plan (gen2-and-validation-anchors.md §4.7, §4.9; :mod:`rfsim.air.carriers`): FCC 50
channels ``902.75 + 0.5·k`` MHz, ETSI EN 302 208 four channels 865.7/866.3/866.9/867.5 MHz,
or an explicit list (``region = "custom"``, ``channels_hz``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.air.carriers import frequency_plan as _plan
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.gen2.link import profile
from rfsim.core.records import ReportConfig


def frequency_plan(region: str, channels_hz=()) -> np.ndarray:
    """Return the channel centre frequencies of a frequency plan.

    ``"FCC"``: 50 channels 902.75 + 0.5·k MHz (k = 0…49); ``"ETSI"``: 865.7, 866.3, 866.9,
    867.5 MHz (gen2-and-validation-anchors.md §4.7); ``"custom"``: the explicit list
    ``channels_hz`` (:func:`rfsim.air.carriers.frequency_plan`, validated against the
    supported carrier range).

    Parameters
    ----------
    region : {"FCC", "ETSI", "custom"}
        The plan.
    channels_hz : sequence of float, optional
        Carriers of the ``"custom"`` plan [Hz]; default empty.

    Returns
    -------
    ndarray of float64, shape (n_channels,)
        Channel centre frequencies [Hz].

    Raises
    ------
    ConfigError
        On ``reader.*`` for an unknown region or an invalid custom list.
    """

    return _plan(region, channels_hz, key="reader")


@dataclass(frozen=True)
class ReaderConfig:
    """Reader settings (validated by :class:`Reader`, see :func:`rfsim.core.config.validate`)."""

    link_profile: str = param("miller4-320k", doc="link profile name (rfsim.gen2.link.PROFILES)")
    ptx_dbm: float = param(30.0, lo=-20.0, hi=36.0, unit="dBm", doc="conducted TX power at the antenna port")
    region: Literal["FCC", "ETSI", "custom"] = param("FCC", doc="frequency plan ('custom': channels_hz)")
    channels_hz: tuple[float, ...] = param((), unit="Hz", doc="explicit carrier list of region 'custom' "
                                                              "(e.g. [890e6] or [5.79e9, 5.80e9, 5.81e9])")
    hopping: bool = param(True, doc="frequency hopping (FCC random hop table, ETSI cyclic)")
    dwell_s: float = param(0.4, lo=0.0, hi=4.0, lo_open=True, unit="s",
                           doc="time on one channel (FCC: at most 0.4 s)")
    fixed_channel: int = param(1, lo=1, hi=1000, doc="1-based channel index used without hopping")
    isolation_db: float = param(30.0, lo=0.0, hi=120.0, unit="dB", doc="TX→RX leakage attenuation")
    noise_figure_db: float = param(10.0, lo=0.0, hi=40.0, unit="dB", doc="receiver noise figure")
    fs_hz: float = param(4e6, lo=2e5, hi=2e8, unit="Hz", doc="baseband sample rate of TX and RX")
    decoder: Literal["viterbi", "bitwise"] = param("viterbi", doc="reply decoder")
    pie_rise_fall_tari: float = param(0.1, lo=0.0, hi=0.33, unit="Tari", doc="10-90 % PIE edge time")
    false_alarm_probability: float = param(1e-3, lo=0.0, hi=1.0, lo_open=True, hi_open=True,
                                           doc="preamble detection false-alarm probability per reply window")
    report: ReportConfig = param(ReportConfig(), doc="what the reader reports of a read: RSSI step, sensitivity "
                                                     "floor, phase code, per-port phase offsets (rfsim.core.records)")
    blf_search: Literal["off", "preamble"] = param(
        "off", doc="'preamble': estimate each reply's BLF within FrT (tags with their own BLF); 'off': nominal BLF")
    rn16_false_accept: float = param(0.0, lo=0.0, hi=0.5, hi_open=True,
                                     doc="RN16 acceptance: stated probability that an accepted RN16 is wrong, sets "
                                         "the Eb/N0 threshold (0: no gate, every detected RN16 is ACKed)")
    track_timing: bool = param(
        False, doc="follow the tag's clock: each reply found is decoded again on a tracked timing (start, BLF, linear "
                   "BLF drift; the capture decoder's tracking step) and measured there, so a reply whose BLF drifts "
                   "within the Gen2 tolerance decodes; no Doppler then, slower; needs rx_model 'sample' and "
                   "rn16_false_accept 0")
    rx_model: Literal["sample", "statistic"] = param(
        "sample", doc="receiver noise model: 'sample' draws noise per sample; 'statistic' draws the statistics the "
                      "receiver reads, same distribution, fewer draws but today more CPU time than 'sample' "
                      "(rfsim.devices.reader_statistic; the figures in the documentation's performance page; "
                      "needs blf_search 'off')")

    def __post_init__(self):
        try:  # checked when the config is loaded, so the message names this key
            profile(self.link_profile)
        except ConfigError as err:
            raise ConfigError("link_profile", err.value, err.allowed) from None
        # The carrier plan is checked when the config is made, so a bad carrier stops a run
        # before anything is simulated (one-line ConfigError on reader.region / reader.channels_hz).
        frequency_plan(self.region, self.channels_hz)
        if self.rn16_false_accept > 0 and self.blf_search != "preamble":
            raise ConfigError("reader.rn16_false_accept", self.rn16_false_accept,
                              "0 unless reader.blf_search = 'preamble' (its decoder computes the statistic)")
        if not isinstance(self.track_timing, (bool, np.bool_)):
            raise ConfigError("reader.track_timing", self.track_timing, "true or false")
        if self.track_timing and self.rx_model != "sample":
            raise ConfigError("reader.track_timing", self.track_timing,
                              "false with reader.rx_model = 'statistic' (it draws the statistics of fixed timing)")
        if self.track_timing and self.rn16_false_accept > 0:
            raise ConfigError("reader.track_timing", self.track_timing,
                              "false with reader.rn16_false_accept > 0 (the tracked decoder computes no RN16 statistic)")
        if self.rx_model not in ("sample", "statistic"):
            raise ConfigError("reader.rx_model", self.rx_model, "one of 'sample', 'statistic'")
        if self.rx_model == "statistic" and self.blf_search != "off":
            raise ConfigError("reader.rx_model", self.rx_model,
                              "'sample' with reader.blf_search = 'preamble' ('statistic' needs blf_search 'off')")


__all__ = ["ReaderConfig", "frequency_plan"]

"""Settings of one sense-a-tag (:class:`SenseATagConfig`: identity, antennas, technique,
threshold, detector gain), apart from the device (:mod:`rfsim.devices.sense_a_tag`) so that a
scenario's config is read without importing it (``rfsim config NAME``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from rfsim.devices.st_analytic import THRESHOLD_V
from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError

#: Default antenna spacing λ/4 at 915 MHz, as the source quotes it (L3420-3422) [m].
DEFAULT_SPACING_M = 0.082


@dataclass(frozen=True)
class SenseATagConfig:
    """Parameters of one sense-a-tag (validated; errors name ``st.<key>``)."""

    st_id: int = param(0x5354, lo=0, hi=0xFFFF, doc="16-bit ST identity (EPC word 0, QS mask)")
    n_antennas: int = param(2, lo=1, hi=2, doc="1 = SA2 only (full ST path), 2 = SA1 + SA2")
    spacing_m: float = param(DEFAULT_SPACING_M, lo=0.005, hi=2.0, unit="m", doc="SA1-SA2 spacing")
    orientation_deg: float = param(0.0, lo=-360.0, hi=360.0, unit="deg",
                                   doc="azimuth of the SA1→SA2 axis in the horizontal plane")
    technique: Literal["single", "combination", "selection", "stamp"] = param(
        "selection", doc="single antenna, simple combination, path selection (Algorithm 1), ASK-PSK stamp")
    threshold_v: float = param(THRESHOLD_V, lo=0.0, hi=1.0, unit="V", doc="comparator threshold")
    detector_gain: float = param(1.0, lo=0.0, hi=1000.0, lo_open=True, doc="detector output per RF peak volt")
    sensitivity_dbm: float = param(-40.0, lo=-40.0, hi=10.0, unit="dBm",
                                   doc="command-detection floor of the PIE path (semi-passive)")
    modulation: Literal["ASK", "PSK"] = param("ASK", doc="reflection states of the ST's own modulator")

    def __post_init__(self):
        check_fields(self, "st")
        if self.n_antennas == 1 and self.technique != "single":
            raise ConfigError("st.technique", self.technique, "'single' with one antenna")

    @property
    def identity_epc_hex(self) -> str:
        """EPC of the ST before any report: ``st_id`` and a zero count."""
        return f"{self.st_id:04X}0000"


__all__ = ["SenseATagConfig", "DEFAULT_SPACING_M"]

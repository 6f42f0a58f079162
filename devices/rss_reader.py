"""What an active-RFID reader reports of a beacon's received power.

Özkaya's readers (rssi-localization.md §2.1, §7 P0.3; seeds/002 L957, L1785–L1787) output a
digital RSSI with **1 dB** resolution and hear nothing below their **−90 dBm** sensitivity;
Impinj-class readers report dBm×100 (0.01 dB steps, wave2-specs.md "What a per-read dataset
should look like"). The reported value is::

    RSSI_rep = step·round(P_rx/step)    if P_rx ≥ floor,   else no read (NaN)

with ``step = 0`` meaning no quantization. This is the reader's report stage of both modes:
the statistical log-distance mode applies it to the model's received power, the sample-level
reader (rfsim.devices.active_reader: MSK beacons through the air interface) to the power it
measures over each frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.core.config import param
from rfsim.core.records import quantize_rssi_dbm


@dataclass(frozen=True)
class RssReport:
    """Reader measurement stage: RSSI quantization step and sensitivity floor.

    Attributes
    ----------
    step_db : float
        RSSI resolution [dB], default 1.0 (the thesis's readers; 0.01 = Impinj, 0 = none).
    floor_dbm : float
        Reader sensitivity [dBm], default −90.0: no read below.
    """

    step_db: float = param(1.0, lo=0.0, hi=10.0, unit="dB",
                           doc="RSSI resolution (1 = the thesis's readers, 0.01 = Impinj, 0 = none)")
    floor_dbm: float = param(-90.0, lo=-150.0, hi=0.0, unit="dBm", doc="reader sensitivity: no read below")

    def report(self, rss_dbm) -> np.ndarray:
        """Return the reported RSSI of true received powers.

        :math:`\\mathrm{RSSI}_{rep} = \\mathrm{step} \\cdot \\mathrm{round}(P_{rx}/\\mathrm{step})`
        when :math:`P_{rx} \\ge` floor, else NaN (module docstring;
        :func:`rfsim.core.records.quantize_rssi_dbm`).

        Parameters
        ----------
        rss_dbm : float or array_like of float
            True received powers [dBm], any shape.

        Returns
        -------
        ndarray of float
            Reported RSSI [dBm], the shape of ``rss_dbm``; NaN = not heard.
        """

        p = np.asarray(rss_dbm, float)
        return np.where(p >= self.floor_dbm, quantize_rssi_dbm(p, self.step_db), np.nan)


__all__ = ["RssReport"]

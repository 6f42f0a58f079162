"""Carrier frequencies: regulatory plans, explicit lists, and the range the models support.

Plans (gen2-and-validation-anchors.md §4.7 "Regulatory", §4.9): FCC Part 15.247, 50 channels
``902.75 + 0.5·k`` MHz (k = 0…49); ETSI EN 302 208, four channels 865.7/866.3/866.9/867.5 MHz;
or any explicit list of carriers (a single 890 MHz carrier, the HIMR receivers' 5.79/5.80/
5.81 GHz, wave2-specs.md §X), each checked against :data:`SUPPORTED_CARRIER_RANGE_HZ`.

Supported range: 100 MHz – 10 GHz. The propagation models (Friis/log-distance, image method,
exponential APDP) and the baseband device models (PIE, FM0/Miller, BOC backscatter, envelope
detectors) hold at any carrier well above the simulated bandwidth (≤ 200 MS/s); the range is
that of the devices rfsim models — UHF RFID (860–960 MHz), its sub-GHz neighbours and the
5.8 GHz ISM band of the HIMR tag — with margin. The measured tag-chip tables
(rfsim.devices.tag_chip) cover 0.7–1.2 GHz only and hold their end values outside.
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core.errors import ConfigError

#: Carriers the models are used for [Hz] (module docstring).
SUPPORTED_CARRIER_RANGE_HZ = (1e8, 1e10)
#: FCC Part 15.247 plan: 50 channels of 500 kHz, 902.75 … 927.25 MHz (anchors §4.7).
FCC_CHANNELS_HZ = 902.75e6 + 0.5e6 * np.arange(50)
#: ETSI EN 302 208 (4-channel plan): 865.7, 866.3, 866.9, 867.5 MHz (anchors §4.7).
ETSI_CHANNELS_HZ = np.array([865.7e6, 866.3e6, 866.9e6, 867.5e6])
#: Names of the plans; "custom" is an explicit list of carriers.
PLANS = ("FCC", "ETSI", "custom")


def check_carriers(key: str, carriers_hz) -> np.ndarray:
    """Validate a list of carrier frequencies.

    Parameters
    ----------
    key : str
        Config key named in the error message.
    carriers_hz : float or array_like
        Carrier frequencies [Hz].

    Returns
    -------
    ndarray, shape (n,), float64
        The carriers [Hz], each finite, distinct and inside :data:`SUPPORTED_CARRIER_RANGE_HZ`.

    Raises
    ------
    ConfigError
        Not numbers, empty or not 1-D, a carrier outside the supported range, or duplicates.
    """
    lo, hi = SUPPORTED_CARRIER_RANGE_HZ
    try:
        f = np.atleast_1d(np.asarray(carriers_hz, dtype=float))
    except (TypeError, ValueError):
        raise ConfigError(key, carriers_hz, "a list of carrier frequencies [Hz]") from None
    if f.ndim != 1 or f.size == 0:
        raise ConfigError(key, carriers_hz, "a non-empty list of carrier frequencies [Hz]")
    for v in f.tolist():
        if not (math.isfinite(v) and lo <= v <= hi):
            raise ConfigError(key, v, f"carriers in [{lo:g}, {hi:g}] Hz (the range the models support)")
    if np.unique(f).size != f.size:
        raise ConfigError(key, carriers_hz, "distinct carriers")
    return f


def frequency_plan(region: str, channels_hz=(), *, key: str = "reader") -> np.ndarray:
    """Channel centre frequencies of a regulatory plan or an explicit list.

    FCC Part 15.247: :math:`f_k = 902.75 + 0.5 k` MHz, k = 0…49; ETSI EN 302 208: 865.7, 866.3,
    866.9, 867.5 MHz (gen2-and-validation-anchors.md §4.7).

    Parameters
    ----------
    region : {"FCC", "ETSI", "custom"}
        The plan; "custom" takes the explicit list ``channels_hz``.
    channels_hz : array_like, default ()
        Explicit carriers [Hz] for ``region="custom"``; must be empty otherwise.
    key : str, default "reader"
        Config prefix of the error messages (``<key>.region`` / ``<key>.channels_hz``).

    Returns
    -------
    ndarray, shape (n,), float64
        Channel centre frequencies [Hz] (a copy).

    Raises
    ------
    ConfigError
        Unknown region, an empty list for "custom", a list for "FCC"/"ETSI", or an invalid
        carrier (:func:`check_carriers`).
    """
    if region not in PLANS:
        raise ConfigError(f"{key}.region", region, "'FCC', 'ETSI' or 'custom' (with channels_hz)")
    if region == "custom":
        if len(channels_hz) == 0:
            raise ConfigError(f"{key}.channels_hz", tuple(channels_hz), "a non-empty carrier list for region 'custom'")
        return check_carriers(f"{key}.channels_hz", channels_hz)
    if len(channels_hz):
        raise ConfigError(f"{key}.channels_hz", tuple(channels_hz), f"empty for region {region!r} "
                                                                     "(set region = 'custom' for an explicit list)")
    return (FCC_CHANNELS_HZ if region == "FCC" else ETSI_CHANNELS_HZ).copy()


def channel_index(plan_hz, fc_hz: float, *, key: str) -> int:
    """Find the 1-based channel index of a carrier in a frequency plan.

    Parameters
    ----------
    plan_hz : array_like, shape (n,)
        Channel centre frequencies [Hz].
    fc_hz : float
        Carrier [Hz], matched exactly.
    key : str
        Config key named in the error message.

    Returns
    -------
    int
        1-based index of the first channel equal to ``fc_hz``.

    Raises
    ------
    ConfigError
        No channel of the plan has that carrier.
    """
    plan = np.asarray(plan_hz, dtype=float)
    hit = np.flatnonzero(plan == float(fc_hz))
    if hit.size == 0:
        shown = ", ".join(f"{v:.10g}" for v in plan[:6]) + (", …" if plan.size > 6 else "")
        raise ConfigError(key, fc_hz, f"a carrier of the frequency plan ({shown} Hz)")
    return int(hit[0]) + 1


__all__ = ["SUPPORTED_CARRIER_RANGE_HZ", "FCC_CHANNELS_HZ", "ETSI_CHANNELS_HZ", "PLANS", "check_carriers",
           "frequency_plan", "channel_index"]

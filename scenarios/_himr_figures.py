"""The RSS/phase figure shared by the HIMR scenarios (``himr-1d``, ``himr-2d``). The per-packet and
IMU tables are :mod:`rfsim.scenes.himr_air`'s, the measurement stream and the cases
:mod:`rfsim.estimators.himr_cases`'."""

from __future__ import annotations

import numpy as np


def plot_rss_phase(plt, packets: dict, title: str):
    """RSS and phase per pylon vs time."""
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for u in np.unique(packets["pylon"]):
        s = packets["pylon"] == u
        f = packets["carrier_hz"][s][0] / 1e9
        a1.plot(packets["t_s"][s], packets["rss_dbm"][s], ".-", ms=2, lw=0.6, label=f"pylon {u} ({f:.2f} GHz)")
        a2.plot(packets["t_s"][s], packets["phase_rad"][s], ".", ms=2, label=f"pylon {u}")
        al = s & (packets["aliased"] > 0)
        a2.plot(packets["t_s"][al], packets["phase_rad"][al], "kx", ms=3)
    a1.set(ylabel="RSS of the modulated part [dBm]", title=title)
    a2.set(xlabel="time [s]", ylabel="phase -arg h [rad] (x: aliased interval)")
    a1.legend(fontsize=7)
    return fig


__all__ = ["plot_rss_phase"]

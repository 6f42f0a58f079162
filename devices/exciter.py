"""RF exciter: a CW source with no intelligence (an emitter of the air interface).

An exciter powers passive tags and sense-a-tags for tag-to-tag and ST-to-ST links
(binary-detection.md "exciter"; auris-sense-a-tag.md ch. 5, Fig. 5.8: 3.28 W EIRP at
915 MHz). It sends no commands: a Gen2 tag powered only by an exciter never replies.

Signal (complex baseband at its own carrier f_c, √W at the antenna port)::

    x(t) = √P · u(t) · e^{jφ(t)},   P = EIRP / G_peak

with G_peak the peak power gain of the antenna it is handed (the channel applies the
antenna's pattern towards each receiver, so the EIRP is P·G_peak in the main lobe), u(t) ∈
{0, 1} the on/off schedule and φ(t) the oscillator phase noise: a Wiener process with
Lorentzian linewidth Δν (full width at half maximum), φ[n] = φ[n−1] + w[n],
w ~ N(0, 2π·Δν/fs) (the increments of a free-running oscillator with white frequency noise;
Δν = 0: no phase noise). The phase is carried from one segment to the next; over a gap
of Δt between segments it advances by N(0, 2π·Δν·Δt).

Schedule: ``schedule_s`` lists switching times t_0 < t_1 < …; the exciter is on in
[t_0, t_1), [t_2, t_3), … (and from the last time on when the count is odd); empty = always
on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.air.carriers import SUPPORTED_CARRIER_RANGE_HZ
from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.core.memo import PureCache
from rfsim.core.units import dbm_to_w
from rfsim.core.lazy import lazy_import

_air = lazy_import("rfsim.air.step")

#: Carrier range the models support [Hz] (rfsim.air.carriers).
CARRIER_RANGE_HZ = SUPPORTED_CARRIER_RANGE_HZ
#: The AURIS ST-to-ST exciter (ch. 5, Fig. 5.8): 3.28 W EIRP = 35.16 dBm.
AURIS_EIRP_DBM = 10.0 * math.log10(3.28e3)


@dataclass(frozen=True)
class ExciterConfig:
    """Exciter settings (validated; errors name ``exciter.<key>``)."""

    fc_hz: float = param(915e6, lo=CARRIER_RANGE_HZ[0], hi=CARRIER_RANGE_HZ[1], unit="Hz", doc="CW carrier")
    eirp_dbm: float = param(AURIS_EIRP_DBM, lo=-30.0, hi=50.0, unit="dBm",
                            doc="EIRP in the antenna's main lobe")
    linewidth_hz: float = param(0.0, lo=0.0, hi=1e6, unit="Hz",
                                doc="phase-noise Lorentzian linewidth (0 = a clean carrier)")
    schedule_s: tuple[float, ...] = param((), unit="s", doc="on/off switching times t0 < t1 < … "
                                                            "(on in [t0, t1), …; empty = always on)")

    def __post_init__(self):
        check_fields(self, "exciter")
        t = tuple(float(v) for v in self.schedule_s)
        if any(not math.isfinite(v) for v in t) or any(b <= a for a, b in zip(t, t[1:])):
            raise ConfigError("exciter.schedule_s", self.schedule_s, "finite, strictly increasing times [s]")
        object.__setattr__(self, "schedule_s", t)


def peak_gain_lin(antenna, *, step_deg: float = 1.0) -> float:
    """Peak power gain of ``antenna``'s pattern over a direction grid in its own frame.

    The grid holds every azimuth and elevation in ``step_deg`` steps (boresight and the axes
    included), so a pattern whose peak lies on an axis (patch, dipole) is exact; the local
    frame makes it independent of the antenna's orientation. Remembered per hashable pattern
    (:data:`PEAK_GAIN_CACHE`).

    Parameters
    ----------
    antenna : rfsim.channels.Antenna
        The antenna; its ``pattern.gain(az_rad, el_rad)`` gives the power gain.
    step_deg : float, optional
        Keyword-only: grid step in azimuth and elevation [deg], default 1.0.

    Returns
    -------
    float
        The largest power gain on the grid [linear, 1].
    """
    pattern = antenna.pattern
    try:
        return PEAK_GAIN_CACHE(pattern, float(step_deg))
    except TypeError:  # an unhashable pattern (e.g. a measured table): no memo
        return _peak_gain(pattern, float(step_deg))


def _peak_gain(pattern, step_deg: float) -> float:
    """:func:`peak_gain_lin` of a pattern on a ``step_deg`` grid [linear, 1]."""
    az = np.radians(np.arange(-180.0, 180.0, step_deg))
    el = np.radians(np.arange(-90.0, 90.0 + 0.5 * step_deg, step_deg))
    a, e = np.meshgrid(az, el)
    return float(np.max(pattern.gain(a.ravel(), e.ravel())))


#: :func:`peak_gain_lin` by (pattern, step): a pure function of a (hashable, immutable) pattern
#: and the grid, not run state (:class:`rfsim.core.memo.PureCache`).
PEAK_GAIN_CACHE = PureCache(_peak_gain, 64)


class Exciter:
    """A CW exciter (module docstring).

    Parameters
    ----------
    config : ExciterConfig
        Carrier, EIRP, linewidth and on/off schedule.
    antenna : rfsim.channels.Antenna
        The antenna it radiates from (position, orientation, pattern); its pattern's peak gain
        converts the EIRP to the conducted power, :math:`P = \\mathrm{EIRP} / G_{peak}` (an
        antenna without a pattern counts as G_peak = 1).
    rng : numpy.random.Generator or None, optional
        Keyword-only: generator of the phase noise, needed when ``linewidth_hz > 0``; default
        None.

    Attributes
    ----------
    fc_hz : float
        Carrier [Hz].
    power_w : float
        Conducted CW power at the antenna port [W].

    Raises
    ------
    TypeError
        When ``config`` is not an :class:`ExciterConfig`.
    ConfigError
        ``exciter.linewidth_hz`` when a linewidth is set without an ``rng``.
    """

    def __init__(self, config: ExciterConfig, antenna, *, rng: np.random.Generator | None = None):
        if not isinstance(config, ExciterConfig):
            raise TypeError(f"config must be an ExciterConfig, got {type(config).__name__}")
        if config.linewidth_hz > 0 and rng is None:
            raise ConfigError("exciter.linewidth_hz", config.linewidth_hz, "0 without an rng for the phase noise")
        self.config, self.antenna, self.rng = config, antenna, rng
        self.fc_hz = float(config.fc_hz)
        g = peak_gain_lin(antenna) if hasattr(antenna, "pattern") else 1.0
        #: conducted CW power at the antenna port [W]
        self.power_w = float(dbm_to_w(config.eirp_dbm)) / g
        self._phase = (None, 0.0)  # (time just after the last emitted sample [s], phase [rad])

    def is_on(self, t_s) -> np.ndarray:
        """Evaluate the on/off schedule u(t) at given times.

        With switching times :math:`t_0 < t_1 < \\dots` the exciter is on in
        :math:`[t_0, t_1), [t_2, t_3), \\dots` (and from the last time on when their count is
        odd); always on when the schedule is empty.

        Parameters
        ----------
        t_s : float or array_like of float
            Times [s], any shape.

        Returns
        -------
        ndarray of bool
            u(t), the shape of ``t_s``: True where the exciter is on.
        """
        t = np.asarray(t_s, dtype=float)
        sw = self.config.schedule_s
        if not sw:
            return np.ones(t.shape, dtype=bool)
        return np.searchsorted(np.asarray(sw), t, side="right") % 2 == 1

    def emit(self, *, t0_s: float, fs_hz: float, n_samples: int) -> _air.Segment | None:
        """Emit the exciter's segment on a time base.

        The samples are :math:`x[n] = \\sqrt{P}\\, u(t_n)\\, e^{j\\varphi[n]}` (module
        docstring); the phase noise advances the exciter's phase state, carried across
        segments.

        Parameters
        ----------
        t0_s : float
            Keyword-only (like the others): time of the first sample [s].
        fs_hz : float
            Sample rate [Hz].
        n_samples : int
            Number of samples.

        Returns
        -------
        rfsim.air.segment.Segment or None
            The segment on the exciter's carrier (samples shape (n_samples,) [√W]); None when
            the exciter is off throughout.
        """

        n = int(n_samples)
        t = float(t0_s) + np.arange(n) / float(fs_hz)
        on = self.is_on(t)
        if not on.any():
            return None
        x = np.full(n, math.sqrt(self.power_w), dtype=np.complex128)
        if self.config.linewidth_hz > 0:
            x *= np.exp(1j * self._phase_noise(float(t0_s), float(fs_hz), n))
        if not on.all():
            x[~on] = 0.0
        return _air.Segment(t0_s, fs_hz, self.fc_hz, x)

    def _phase_noise(self, t0_s: float, fs_hz: float, n: int) -> np.ndarray:
        var = 2.0 * math.pi * self.config.linewidth_hz / fs_hz
        t_end, phi = self._phase
        if t_end is not None and t0_s > t_end:  # the phase walks on through the gap
            phi += math.sqrt(2.0 * math.pi * self.config.linewidth_hz * (t0_s - t_end)) * float(
                self.rng.standard_normal())
        steps = math.sqrt(var) * self.rng.standard_normal(n)
        steps[0] = 0.0
        ph = phi + np.cumsum(steps)
        self._phase = (t0_s + n / fs_hz, float(ph[-1]))
        return ph


__all__ = ["ExciterConfig", "Exciter", "peak_gain_lin", "CARRIER_RANGE_HZ", "AURIS_EIRP_DBM"]

"""HIMR receiver "pylon": a coherent homodyne SDR transceiver on its own carrier — an
emitter of CW and an I/Q receiver in one device of the air step (:mod:`rfsim.air.step`).

Model (himr-tag.md §2.3; wave2-specs.md §H "Pylons"; seed 000 L447, L997, L1024–L1030):

* **Emitter**: a CW of power P_T [W] on the pylon's carrier f_c (5.79, 5.80 or 5.81 GHz in
  the 2-D experiment, L997; which pylon has which carrier is not stated: the default is pylon
  u on 5.79 + 0.01·(u − 1) GHz). Complex baseband √P_T·e^{jφ_0} on every sample, φ_0 the
  oscillator phase (``lo_phase_rad``, 0 by default; the same oscillator drives the receiver,
  so it cancels in the round trip of the pylon's own carrier, L432).
* **Receiver**: the same oscillator down-converts (coherent homodyne I/Q, L1024) and the
  USRP samples at the step's rate; its input is the superposition the air step forms plus
  complex white noise of power N = k·T₀·F·fs per sample (the whole simulated band is the
  noise bandwidth; noise figure ``noise_figure_db``). The seed gives no Tx power, gains or
  sample rate (H§0.2): the scenarios calibrate P_T to an SNR at a reference distance
  (:func:`rfsim.himr.link.ptx_for_snr_w`).
* **Co-located TX/RX** (monostatic, "co-located bi-static", L447): one antenna position for
  both; the direct TX → RX path of its own CW is the leakage ``coupling_db`` (amplitude
  10^(coupling_db/20)·e^{j·coupling_phase}); another pylon's CW reaches it through the
  channel (a tone at the carrier offset, dropped outside ±fs/2 by the air step).
* **Shared clock** (10 MHz + 1 PPS, L1024–L1030): every pylon samples on the step's common
  time base; the packets' time stamps of different pylons agree.

* **Channel filter** (optional, ``rx_cutoff_hz``): a linear-phase FIR low-pass (Kaiser window,
  80 dB stop band from 1.6·cutoff, :func:`scipy.signal.firwin`, zero delay) before the DSP. It
  removes the other pylons' direct CW (tones at the 10–20 MHz carrier offsets, ≈ 50 dB above the
  backscatter at 2 m) in a run with every carrier in band, and keeps the tag's subcarrier
  (±f_sc with its bit sidebands) — and whatever the other carriers put there.

``receive`` returns the (filtered) input :class:`rfsim.air.step.Segment`; the per-packet DSP
(:mod:`rfsim.himr.dsp`) runs on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.core.lazy import lazy_import
from rfsim.core.memo import PureCache

_signal = lazy_import("scipy.signal")
_air = lazy_import("rfsim.air.step")
_carriers = lazy_import("rfsim.air.carriers")
_noise = lazy_import("rfsim.air.noise")

#: Carriers of the 2-D experiment (L997) [Hz].
HIMR_CARRIERS_HZ = (5.79e9, 5.80e9, 5.81e9)


@dataclass(frozen=True)
class PylonConfig:
    """Radio of one pylon (errors name ``pylon.<key>``)."""

    fc_hz: float = param(5.8e9, lo=1e8, hi=1e10, unit="Hz", doc="carrier (its own oscillator)")
    ptx_w: float = param(0.1, lo=0.0, lo_open=True, hi=100.0, unit="W", doc="CW power at the antenna port")
    noise_figure_db: float = param(6.0, lo=0.0, hi=40.0, unit="dB", doc="receiver noise figure")
    coupling_db: float = param(-40.0, lo=-200.0, hi=0.0, unit="dB", doc="TX -> RX leakage of its own CW")
    coupling_phase_rad: float = param(0.3, unit="rad", doc="phase of the leakage")
    lo_phase_rad: float = param(0.0, unit="rad", doc="oscillator phase of the CW")

    def __post_init__(self):
        check_fields(self, "pylon")
        _carriers.check_carriers("pylon.fc_hz", [self.fc_hz])


class Pylon:
    """Emitter and receiver of one pylon (module docstring).

    Parameters
    ----------
    config : PylonConfig
        Carrier, CW power, noise figure, TX → RX leakage and oscillator phase.
    antenna : rfsim.channels.Antenna
        Its antenna (TX and RX co-located).
    name : str, optional
        Keyword-only: label used in error messages and tables, default ``"pylon"``.
    rx_cutoff_hz : float or None, optional
        Keyword-only: cut-off of the receive channel filter [Hz] (:func:`lowpass_taps`);
        default None, no filter.

    Attributes
    ----------
    fc_hz : float
        Carrier [Hz].
    noise_power_w : float
        Receiver noise power per complex sample [W] (0 until :meth:`set_sample_rate`).
    """

    def __init__(self, config: PylonConfig, antenna, *, name: str = "pylon", rx_cutoff_hz: float | None = None):
        self.config, self.antenna, self.name = config, antenna, name
        self.fc_hz = float(config.fc_hz)
        self.rx_cutoff_hz = rx_cutoff_hz
        self.noise_power_w = 0.0

    def set_sample_rate(self, fs_hz: float) -> None:
        """Set the receiver noise power for a sample rate: :math:`N = k T_0 F f_s`.

        Parameters
        ----------
        fs_hz : float
            Sample rate of the air step [Hz]; ``noise_power_w`` becomes N [W per complex
            sample].
        """
        self.noise_power_w = float(_noise.thermal_noise_power_w(fs_hz, self.config.noise_figure_db))

    def emit(self, *, t0_s: float, fs_hz: float, n_samples: int) -> _air.Segment:
        """Emit the CW :math:`\\sqrt{P_T} e^{j\\varphi_0}` on the step's time base.

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
        rfsim.air.segment.Segment
            The constant segment on the pylon's carrier, samples shape (n_samples,) [√W].
        """
        c = self.config
        level = math.sqrt(c.ptx_w) * complex(math.cos(c.lo_phase_rad), math.sin(c.lo_phase_rad))
        return _air.Segment(t0_s, fs_hz, self.fc_hz, np.full(int(n_samples), level, dtype=np.complex128))

    def coupling(self, emitter) -> complex | None:
        """Return the direct TX → RX leakage of an emitter into the pylon's receiver.

        Parameters
        ----------
        emitter : object
            An emitter of the air step.

        Returns
        -------
        complex or None
            For the pylon itself the amplitude gain
            :math:`10^{c/20} e^{j\\phi_c}` (c = ``coupling_db``, φ_c = ``coupling_phase_rad``);
            None for any other emitter (it reaches the pylon through the channel).
        """
        if emitter is not self:
            return None
        c = self.config
        a = 10.0 ** (c.coupling_db / 20.0)
        return complex(a * math.cos(c.coupling_phase_rad), a * math.sin(c.coupling_phase_rad))

    def receive(self, input: _air.Segment) -> _air.Segment:
        """Pass the received segment through the optional channel filter.

        Parameters
        ----------
        input : rfsim.air.segment.Segment
            The superposition at the antenna port, noise included (samples shape
            (n_samples,) [√W]).

        Returns
        -------
        rfsim.air.segment.Segment
            ``input`` itself without ``rx_cutoff_hz``, else its zero-delay low-pass filtered
            copy (:func:`lowpass_taps`) on the same time base.
        """
        if self.rx_cutoff_hz is None:
            return input
        taps = LOWPASS_TAPS_CACHE(self.rx_cutoff_hz, input.fs_hz)
        y = np.convolve(input.samples, taps, mode="same")
        return _air.Segment(input.t0_s, input.fs_hz, input.fc_hz, y)


def lowpass_taps(cutoff_hz: float, fs_hz: float) -> np.ndarray:
    """Design the odd-length Kaiser FIR low-pass of the pylon's channel filter.

    Pass band to ``cutoff_hz``, 80 dB stop band from 1.6·cutoff (:func:`scipy.signal.kaiserord`
    for the length and β, :func:`scipy.signal.firwin` with the cut-off at 1.3·cutoff).

    Parameters
    ----------
    cutoff_hz : float
        Edge of the pass band [Hz].
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    ndarray of float, shape (n_taps,)
        The taps (odd length: a centred, zero-delay filter in ``"same"`` convolution).
    """

    width = 0.6 * cutoff_hz / (0.5 * fs_hz)
    n, beta = _signal.kaiserord(80.0, width)
    n += 1 - n % 2
    return _signal.firwin(n, 1.3 * cutoff_hz, window=("kaiser", beta), fs=fs_hz)


#: :func:`lowpass_taps` by (cut-off, rate), the pylon's filter: a pure function of config values,
#: not run state (:class:`rfsim.core.memo.PureCache`).
LOWPASS_TAPS_CACHE = PureCache(lowpass_taps, 8)


__all__ = ["PylonConfig", "Pylon", "HIMR_CARRIERS_HZ"]

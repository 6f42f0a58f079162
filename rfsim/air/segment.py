"""Segments of the air step: complex baseband samples in √W on a carrier, on one time base.

A :class:`Segment` is what an emitter radiates, what a reflector sees incident and what a
receiver gets (:func:`rfsim.air.step.propagate`); a *scaled copy* (``Segment.scaled``) holds a
base segment and a complex gain, its samples formed only when asked (the narrowband, static
links of the step). :func:`carrier_shift` moves a baseband to another carrier's baseband.
"""

from __future__ import annotations

import numpy as np

from rfsim.core.errors import ConfigError

__all__ = ["Segment", "carrier_shift"]


class Segment:
    """A waveform segment: complex baseband samples in √W on a carrier.

    Parameters
    ----------
    t0_s : float
        Absolute time of sample 0 [s].
    fs_hz : float
        Sample rate [Hz], > 0.
    fc_hz : float
        Carrier frequency of the baseband [Hz].
    samples : array_like, shape (..., n), optional
        Complex baseband [√W] (leading batch dimensions allowed, n ≥ 1; stored as complex128),
        or None together with ``base``.
    base : Segment, optional
        Makes a scaled copy ``gain · base.samples`` (``Segment.scaled``), formed only when
        :attr:`samples` is read.
    gain : complex, default 1.0
        Gain of the scaled copy.

    Attributes
    ----------
    memo : dict
        Data derived from the samples that several devices share (a reflector's decoding of a
        segment it sees scaled copies of); it belongs to the segment.
    n_samples : int
        Samples per row (n).

    Raises
    ------
    ConfigError
        fs ≤ 0, or samples without a last dimension of at least one sample.
    ValueError
        Both ``samples`` and ``base`` given.
    """

    __slots__ = ("t0_s", "fs_hz", "fc_hz", "_samples", "base", "gain", "memo", "n_samples")

    def __init__(self, t0_s: float, fs_hz: float, fc_hz: float, samples=None, *, base: "Segment | None" = None,
                 gain: complex = 1.0):
        self.t0_s, self.fs_hz, self.fc_hz = float(t0_s), float(fs_hz), float(fc_hz)
        if not self.fs_hz > 0:
            raise ConfigError("segment.fs_hz", fs_hz, "a sample rate > 0 Hz")
        self.memo: dict = {}
        if base is not None:
            if samples is not None:
                raise ValueError("give samples or base, not both")
            while base.base is not None:  # a scaled copy of a scaled copy
                gain = gain * base.gain
                base = base.base
            self.base, self.gain, self._samples = base, complex(gain), None
            self.n_samples = base.n_samples
            return
        x = np.asarray(samples)
        if x.ndim < 1 or x.shape[-1] < 1:
            raise ConfigError("segment.samples", x.shape, "an array (..., n) with n ≥ 1 samples")
        if x.dtype != np.complex128:
            x = x.astype(np.complex128)
        self.base, self.gain, self._samples = None, 1.0 + 0j, x
        self.n_samples = int(x.shape[-1])

    @classmethod
    def scaled(cls, base: "Segment", gain: complex, fc_hz: float | None = None) -> "Segment":
        """Make the scaled copy ``gain · base`` on the time base of ``base``.

        The samples are formed when first read.

        Parameters
        ----------
        base : Segment
            The segment scaled (a scaled copy of a scaled copy refers to the original base).
        gain : complex
            Complex gain.
        fc_hz : float or None, default None
            Carrier of the copy [Hz]; None: that of ``base``.

        Returns
        -------
        Segment
            The scaled copy.
        """
        if base.base is not None:
            return cls(base.t0_s, base.fs_hz, base.fc_hz if fc_hz is None else fc_hz, base=base, gain=gain)
        out = cls.__new__(cls)  # the hot path of the air step: no re-validation of a valid base
        out.t0_s, out.fs_hz, out.fc_hz = base.t0_s, base.fs_hz, base.fc_hz if fc_hz is None else float(fc_hz)
        out.base, out.gain, out._samples, out.memo, out.n_samples = base, complex(gain), None, {}, base.n_samples
        return out

    @classmethod
    def own(cls, t0_s: float, fs_hz: float, fc_hz: float, samples: np.ndarray) -> "Segment":
        """Make a segment that holds ``samples`` itself, without the constructor's checks.

        For an array its caller has just formed on a valid time base (the air step's receiver
        inputs): (..., n) complex128 with n ≥ 1, ``fs_hz`` > 0.

        Parameters
        ----------
        t0_s : float
            Time of the first sample [s].
        fs_hz : float
            Sample rate [Hz] (> 0).
        fc_hz : float
            Carrier [Hz].
        samples : ndarray, shape (..., n), complex128
            The samples [√W], held (not copied).

        Returns
        -------
        Segment
            The segment.
        """
        out = cls.__new__(cls)
        out.t0_s, out.fs_hz, out.fc_hz = float(t0_s), float(fs_hz), float(fc_hz)
        out.base, out.gain, out._samples, out.memo, out.n_samples = None, 1.0 + 0j, samples, {}, samples.shape[-1]
        return out

    @property
    def samples(self) -> np.ndarray:
        """(..., n) complex128 [√W]."""
        if self._samples is None:
            self._samples = self.gain * self.base.samples
        return self._samples

    @property
    def batch_shape(self) -> tuple:
        """Leading (batch) dimensions of the samples."""
        src = self.base if self.base is not None else self
        return tuple(src._samples.shape[:-1])

    @property
    def end_s(self) -> float:
        """Time just after the last sample [s]."""
        return self.t0_s + self.n_samples / self.fs_hz

    def same_time_base(self, t0_s: float, fs_hz: float, n_samples: int) -> bool:
        """Tell whether the segment lies exactly on the given time base.

        Parameters
        ----------
        t0_s : float
            Start time [s].
        fs_hz : float
            Sample rate [Hz].
        n_samples : int
            Number of samples.

        Returns
        -------
        bool
            True when start time, sample rate and length are all equal.
        """
        return self.t0_s == float(t0_s) and self.fs_hz == float(fs_hz) and self.n_samples == int(n_samples)

    def __repr__(self) -> str:
        kind = "scaled" if self.base is not None else "samples"
        return (f"Segment(t0_s={self.t0_s!r}, fs_hz={self.fs_hz!r}, fc_hz={self.fc_hz!r}, "
                f"n_samples={self.n_samples}, {kind})")


def carrier_shift(x: np.ndarray, offset_hz: float, *, t0_s: float, fs_hz: float) -> np.ndarray:
    r"""Move a baseband to the baseband of another carrier.

    :math:`x[n]\,e^{j 2\pi \Delta t_n}` with :math:`t_n = t_0 + n/f_s` absolute time, the phase
    reduced modulo one cycle (term by term, so that large t·Δ keep their precision).

    Parameters
    ----------
    x : ndarray, shape (..., n), complex
        Samples [√W].
    offset_hz : float
        Carrier offset Δ = f_emitter − f_receiver [Hz].
    t0_s : float
        Time of sample 0 [s].
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    ndarray, shape (..., n), complex128
        The shifted samples [√W].
    """
    n = x.shape[-1]
    cycles = np.mod(offset_hz * t0_s, 1.0) + np.mod(offset_hz / fs_hz, 1.0) * np.arange(n)
    return x * np.exp(2j * np.pi * np.mod(cycles, 1.0))

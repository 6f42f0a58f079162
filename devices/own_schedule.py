"""A backscattering device that sends a frame on its own schedule: the frame
(:class:`FrameConfig`, :class:`Frame`, :func:`build_frame`) and the reflector of the air step
that modulates it (:class:`OwnSchedule`). Used by exciter-powered links: reference tags that
broadcast without a command, a sense-a-tag that answers with an ASK-PSK stamp.

The frame (auris-sense-a-tag.md §5, seed L6011-6023; wave2-specs.md §X): CW rest state,
``stamp_cycles`` subcarrier cycles at BLF alternating S1/S2 (ASK stamp), as many alternating
S1/S3 (PSK stamp), then a Gen2 reply of the payload bits (TRext pilot, preamble, data,
dummy 1) in FM0/Miller-M with line-code level +1 → S1 and −1 → S2
(:func:`rfsim.devices.st_receiver.stamp_frame`). The three-state modulator (L5914-5923) has the
reflection coefficients S1 = Γ_B (modulating), S2 = Γ_A (absorbing), S3 = Γ_B·e^{jψ} (the PSK
state, ψ = 180° ideally, L6017-6019); the device re-radiates r(t) = A_s − Γ(t).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import

sr = lazy_import("rfsim.devices.st_receiver")
_linecode = lazy_import("rfsim.gen2.linecode")


@dataclass(frozen=True)
class FrameConfig:
    """The frame a device backscatters on its own schedule (module docstring)."""

    fs_hz: float = param(1e6, lo=2e5, hi=2e7, unit="Hz", doc="sample rate of the simulated segment")
    blf_hz: float = param(48e3, lo=5e3, hi=640e3, unit="Hz",
                          doc="subcarrier / link frequency of the device (PASS Miller-2 profile: 48 kHz)")
    m: Literal[1, 2, 4, 8] = param(2, doc="line code: 1 = FM0, 2/4/8 = Miller-M (source: Miller-2)")
    trext: bool = param(True, doc="pilot tone before the preamble")
    lead_cycles: int = param(8, lo=2, hi=1000, doc="CW (rest state) before the frame, in subcarrier cycles")
    tail_cycles: int = param(4, lo=1, hi=1000, doc="CW after the frame, in subcarrier cycles")

    def check(self, prefix: str = "frame") -> None:
        """Check that the receive chain's band-pass (up to 4·BLF) fits below fs/2.

        Parameters
        ----------
        prefix : str, optional
            Key prefix of the error, default ``"frame"``.

        Raises
        ------
        ConfigError
            ``<prefix>.blf_hz`` unless 8·BLF < fs.
        """
        if not 8.0 * self.blf_hz < self.fs_hz:
            raise ConfigError(f"{prefix}.blf_hz", self.blf_hz,
                              f"< {prefix}.fs_hz/8 = {self.fs_hz / 8:g} Hz (receiver band-pass up to 4 x BLF < fs/2)")


@dataclass(frozen=True, eq=False)
class Frame:
    """A sampled frame: the modulator state per sample and where its parts are.

    Attributes
    ----------
    stamp : rfsim.devices.st_receiver.StampFrame
        ``states`` (n,) int8 labels S1/S2/S3, ``levels`` (n,) ±1 inside the reply, indices of
        the stamp and reply parts.
    bits : ndarray of uint8, shape (k,)
        Payload bits.
    n_samples : int
        Segment length.
    """

    stamp: sr.StampFrame
    bits: np.ndarray
    n_samples: int

    @property
    def end(self) -> int:
        """First sample after the reply (the frame is ``[stamp.start, end)``)."""
        return int(np.flatnonzero(self.stamp.levels != 0)[-1]) + 1

    def gamma(self, gamma_s1: complex, gamma_s2: complex, psi_rad: float) -> np.ndarray:
        """Return Γ(t) of the three-state modulator on the frame's samples.

        S1, S2 and S3 = S1·e^{jψ} inside the frame (auris-sense-a-tag.md §5, L5914-5923), the
        rest state S2 (= Γ_A, absorbing) before and after it.

        Parameters
        ----------
        gamma_s1 : complex
            Reflection coefficient of S1 (Γ_B, modulating).
        gamma_s2 : complex
            Reflection coefficient of S2 (Γ_A, absorbing).
        psi_rad : float
            Phase ψ of the PSK state S3 relative to S1 [rad].

        Returns
        -------
        ndarray of complex128, shape (n_samples,)
            Γ per sample [1].
        """
        table = np.array([gamma_s1, gamma_s2, gamma_s1 * np.exp(1j * psi_rad)], dtype=np.complex128)
        states = self.stamp.states.copy()
        states[:self.stamp.start] = sr.STAMP_S2
        states[self.end:] = sr.STAMP_S2
        return table[states]


class OwnSchedule:
    """A device that backscatters ``frame`` on its own schedule (a reflector of :mod:`rfsim.air.step`).

    The device's own front end decides first (``device.reflect``: the incident power, a
    harvesting tag's power-up and its chip's reflection states; a semi-passive sense-a-tag is
    always powered); a powered device then modulates the frame with its reflection states
    (``reflection_states`` of a :class:`rfsim.devices.tag.PassiveTag`, of ``device.tag`` for a
    :class:`rfsim.devices.sense_a_tag.SenseATag`) as S1 = Γ_B, S2 = Γ_A, S3 = Γ_B·e^{jψ} (module
    docstring). An unpowered device keeps its front end's answer (rest state, no reply).

    Parameters
    ----------
    device : object
        A reflector of the air step with ``antenna`` and ``reflect(incident)``.
    frame : Frame
        The frame on the segment's sample grid.
    psi_rad : float, optional
        Keyword-only: phase ψ of the PSK state S3 [rad], default π (the ideal stamp).
    """

    def __init__(self, device, frame: Frame, *, psi_rad: float = math.pi):
        self.device, self.frame, self.psi_rad = device, frame, float(psi_rad)
        self.antenna = device.antenna

    def reflect(self, incident):
        """Respond to an incident segment with Γ(t) of the frame when the device is powered.

        Parameters
        ----------
        incident : rfsim.air.segment.Segment
            The incident field on the frame's sample grid.

        Returns
        -------
        rfsim.devices.tag_response.TagResponse
            The device's own response, and when it is powered with ``gamma`` = Γ(t) of
            :meth:`Frame.gamma`, the reply's start and end times [s] and the rest state Γ_A.

        Raises
        ------
        ValueError
            When the segment's length differs from the frame's.
        """
        resp = self.device.reflect(incident)
        if not resp.powered:
            return resp
        states = getattr(self.device, "tag", self.device).reflection_states
        if incident.n_samples != self.frame.n_samples:
            raise ValueError(f"the frame has {self.frame.n_samples} samples, the segment {incident.n_samples}")
        fs = incident.fs_hz
        return dataclasses.replace(resp, gamma=self.frame.gamma(states.gamma_b, states.gamma_a, self.psi_rad),
                                   reason="", reply_start_s=incident.t0_s + self.frame.stamp.reply_start / fs,
                                   reply_end_s=incident.t0_s + self.frame.end / fs, gamma_rest=states.gamma_a)


def build_frame(bits, frame: FrameConfig, *, stamp_cycles: int) -> Frame:
    """The frame of ``bits`` on the sample grid of ``frame`` (module docstring).

    Parameters
    ----------
    bits : array_like of {0, 1}, shape (k,)
        Payload bits.
    frame : FrameConfig
        Sample rate, BLF, line code, CW lead and tail in subcarrier cycles.
    stamp_cycles : int
        Keyword-only: subcarrier cycles of each stamp part (ASK, PSK), or 0: no stamp, the
        reply alone (all stamp indices at the reply start).

    Returns
    -------
    Frame
        The sampled frame (:func:`rfsim.devices.st_receiver.stamp_frame` with a stamp).
    """

    cycle_s = 1.0 / frame.blf_hz
    b = np.asarray(bits, np.uint8)
    t0_s, tail_s = frame.lead_cycles * cycle_s, frame.tail_cycles * cycle_s
    if stamp_cycles > 0:
        st = sr.stamp_frame(b, m=frame.m, trext=frame.trext, blf_hz=frame.blf_hz, fs_hz=frame.fs_hz,
                            n_stamp_cycles=stamp_cycles, t0_s=t0_s, tail_s=tail_s)
    else:
        n = int(math.ceil((t0_s + tail_s + _linecode.reply_duration_s(b.size, m=frame.m, trext=frame.trext,
                                                                blf_hz=frame.blf_hz)) * frame.fs_hz)) + 1
        levels = _linecode.reply_waveform(b, m=frame.m, trext=frame.trext, blf_hz=frame.blf_hz, fs_hz=frame.fs_hz,
                                          t0_s=t0_s, n_samples=n)
        states = np.where(levels < 0, sr.STAMP_S2, sr.STAMP_S1).astype(np.int8)
        start = int(math.ceil(t0_s * frame.fs_hz))
        st = sr.StampFrame(states, levels, start, start, start, start)
    return Frame(st, b, int(st.states.size))


__all__ = ["FrameConfig", "Frame", "OwnSchedule", "build_frame"]

"""Pieces shared by the exciter scenarios ``st-to-st`` and ``exciter-link``: the frame a
backscattering device sends on its own schedule (:class:`OwnSchedule`), the exciter antenna and
the room, uniform placement in a disc, many receiving antennas as one batched receiver of the
air step (:class:`BatchAntenna`, :class:`BatchLink`, :class:`DrawnLinks`), the receive-chain
decisions on many inputs at once (:class:`RowsChain`), receiver noise, and running tasks on
worker processes.

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
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import

sr = lazy_import("rfsim.devices.st_receiver")
_antennas = lazy_import("rfsim.channels.antennas")
_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_noise = lazy_import("rfsim.channels.noise")
_paths = lazy_import("rfsim.channels.paths")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
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
        """The receive chain's band-pass (up to 4·BLF) must fit below fs/2."""
        if not 8.0 * self.blf_hz < self.fs_hz:
            raise ConfigError(f"{prefix}.blf_hz", self.blf_hz,
                              f"< {prefix}.fs_hz/8 = {self.fs_hz / 8:g} Hz (receiver band-pass up to 4 x BLF < fs/2)")


@dataclass(frozen=True)
class NoiseConfig:
    """Receiver noise at the listening antennas: kT·fs·F per complex sample
    (:func:`rfsim.channels.noise.thermal_noise_power_w` over the simulated bandwidth fs)."""

    enabled: bool = param(True, doc="receiver noise at the listening antennas")
    nf_db: float = param(10.0, lo=0.0, hi=60.0, unit="dB", doc="noise figure; N = kT·fs·F per complex sample")

    def power_w(self, fs_hz: float) -> float:
        """Noise power per complex sample [W] (0 when disabled)."""
        return float(_noise.thermal_noise_power_w(fs_hz, self.nf_db)) if self.enabled else 0.0


@dataclass(frozen=True, eq=False)
class Frame:
    """A sampled frame: the modulator state per sample and where its parts are.

    Attributes
    ----------
    stamp : :class:`rfsim.devices.st_receiver.StampFrame` — ``states`` (n,) int8 labels S1/S2/S3,
        ``levels`` (n,) ±1 inside the reply, indices of the stamp and reply parts
    bits : (k,) uint8 payload bits
    n_samples : segment length
    """

    stamp: sr.StampFrame
    bits: np.ndarray
    n_samples: int

    @property
    def end(self) -> int:
        """First sample after the reply (the frame is ``[stamp.start, end)``)."""
        return int(np.flatnonzero(self.stamp.levels != 0)[-1]) + 1

    def gamma(self, gamma_s1: complex, gamma_s2: complex, psi_rad: float) -> np.ndarray:
        """Γ(t) of the three-state modulator, (n,) complex128: S1, S2, S3 = S1·e^{jψ} inside
        the frame, the rest state S2 (= Γ_A, absorbing) before and after it."""
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
    """

    def __init__(self, device, frame: Frame, *, psi_rad: float = math.pi):
        self.device, self.frame, self.psi_rad = device, frame, float(psi_rad)
        self.antenna = device.antenna

    def reflect(self, incident):
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
    """The frame of ``bits`` on the sample grid of ``frame`` (module docstring), with an ASK-PSK
    stamp of ``stamp_cycles`` cycles per part, or none (``stamp_cycles = 0``: the reply alone,
    all stamp indices at the reply start)."""
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


def exciter_antenna(kind: str, gain_dbi: float, height_m: float):
    """The exciter's antenna at (0, 0, height): a patch (``gain_dbi``, 70° beamwidth) with
    boresight +x, or a vertical half-wave dipole (``rfsim.channels.Antenna``)."""
    pattern = _antennas.Patch(gain_dbi, 70.0) if kind == "patch" else _antennas.HalfWaveDipole()
    return _antennas.Antenna(position_m=(0.0, 0.0, height_m), orientation=(0.0, 0.0, 0.0), pattern=pattern,
                             polarization="linear")


def room(apdp: bool) -> _scene.Scene:
    """Friis, plus the exponential APDP with the PASS ST-room curves when ``apdp``."""
    return _scene.Scene(apdp=_small_scale.ApdpModel() if apdp else None)


def uniform_disc(rng: np.random.Generator, n: int, radius_m: float) -> tuple[np.ndarray, np.ndarray]:
    """n points uniform in a disc of radius ``radius_m`` around the origin: (dx, dy) [m].

    r = R·√u, φ ~ U(−π, π) (area-uniform).
    """
    r = radius_m * np.sqrt(rng.random(n))
    phi = rng.uniform(-np.pi, np.pi, n)
    return r * np.cos(phi), r * np.sin(phi)


@dataclass(frozen=True, eq=False)
class RowsChain:
    """The receive chain run on many inputs: detector output, band-pass, comparator (r, n)."""

    envelope_v: np.ndarray
    bandpassed_v: np.ndarray
    comparator: np.ndarray
    toggles: np.ndarray

    @classmethod
    def run(cls, rx: sr.STReceiver, x) -> "RowsChain":
        return cls(*_sense_a_tag.chain_rows(rx, x))

    def decoded(self, rx: sr.STReceiver, frame: Frame, rows=None) -> np.ndarray:
        """(r,) bool: the payload decoded exactly from the reply start on, in ``rows`` (default all).

        The decision of :func:`rfsim.devices.sense_a_tag.decode_rows` (comparator toggles at least
        ``rx.min_toggles`` times, preamble correlation ≥ ``rx.min_corr``, bits equal), without
        its envelope-level measurement (:meth:`level_difference_v` does that for all rows at once).
        """
        rows = np.ones(self.comparator.shape[0], bool) if rows is None else np.asarray(rows, bool)
        start = frame.stamp.reply_start
        search = int(2 * rx.fs_hz / rx.blf_hz)
        toggles = np.count_nonzero(np.diff(self.comparator[:, start:], axis=1), axis=1)
        out = np.zeros(rows.size, dtype=bool)
        for i in np.flatnonzero(rows & (toggles >= rx.min_toggles)):
            try:
                det = _linecode.decode_reply(self.comparator[i, start:].astype(np.complex128), n_bits=frame.bits.size,
                                             m=rx.m, trext=rx.trext, blf_hz=rx.blf_hz, fs_hz=rx.fs_hz, method=rx.method,
                                             search_samples=search)
            except ValueError:
                continue
            out[i] = det.corr >= rx.min_corr and np.array_equal(det.bits, frame.bits)
        return out

    def level_difference_v(self, rx: sr.STReceiver, frame: Frame) -> np.ndarray:
        """(r,) |A(+1) − A(−1)| of the settled detector output over the reply [V]."""
        return np.abs(_sense_a_tag.level_differences(self.envelope_v, frame.stamp.levels, rx))

    def stamp_symbols(self, rx: sr.STReceiver, frame: Frame, min_transitions: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Decoded ASK and PSK stamp symbols, (r,) bool each (True = '1', False = '-').

        A stamp part decodes as '1' when the comparator makes at least ``min_transitions``
        transitions in it; 0 means one per subcarrier cycle of the part (half the transitions of
        an undisturbed part), the rule of :func:`rfsim.devices.st_receiver.receive_stamp`.
        """
        st = frame.stamp
        need = min_transitions or max(1, int(round((st.ask_stop - st.start) * rx.blf_hz / rx.fs_hz)))
        d = np.diff(self.comparator, axis=1) != 0
        ask = d[:, st.start:st.ask_stop - 1].sum(axis=1) >= need
        psk = d[:, st.ask_stop:st.psk_stop - 1].sum(axis=1) >= need
        return ask, psk


# ----------------------------------------------------------------------------- batched links


class BatchAntenna:
    """The same antenna at n positions: one receiver of :func:`rfsim.air.step.propagate` whose
    input has a leading batch dimension of n (one row per position).

    ``template`` gives pattern, orientation and polarization (``rfsim.channels.Antenna``);
    ``positions_m`` (n, 3) [m]. ``position_m`` is None: the step's distance check does not
    apply; :func:`rfsim.channels.bulk.draw_links` rejects a receiver at its transmitter instead.
    """

    position_m = None

    def __init__(self, template, positions_m):
        self.template = template
        self.positions_m = np.atleast_2d(np.asarray(positions_m, dtype=float))


class BatchLink:
    """n links drawn at once (:class:`rfsim.channels.bulk.BulkPaths`) as one narrowband, static link of
    the air step: its constant gain is the (n, 1) column of per-row gains Σ_p g_p·e^{−j2π·fc·τ_p}.

    Every row is judged by the one narrowband rule of :func:`rfsim.channels.paths.propagation_method`
    (relative RMS envelope error ≤ :data:`rfsim.channels.paths.NARROWBAND_TOLERANCE`); a batch with a
    row that needs exact delays is refused (the static ST links of these scenes are
    narrowband with errors of ≈ 0.001–0.01 at B = 2·BLF = 96 kHz).
    """

    static = True

    def __init__(self, bulk):
        self.bulk = bulk
        self._method: dict = {}

    def method(self, bandwidth_hz: float, propagation: str = "auto") -> str:
        key = (float(bandwidth_hz), propagation)
        if key not in self._method:
            b = self.bulk
            # rfsim.channels.paths.narrowband_rms_error of every row at once (padded slots have g = 0)
            tau0 = np.where(b.valid, b.delay_s, np.inf).min(axis=1, keepdims=True)
            p = np.abs(b.gain) ** 2
            rel2 = np.where(b.valid, (2.0 * np.pi * bandwidth_hz * (b.delay_s - tau0)) ** 2, 0.0)
            err = np.sqrt((p * rel2).sum(axis=1) / np.maximum(p.sum(axis=1), 1e-300))
            if propagation == "exact" or np.any(err > _paths.NARROWBAND_TOLERANCE):
                raise ValueError(f"batched links need narrowband propagation at B = {bandwidth_hz:g} Hz "
                                 f"(largest envelope error {err.max():.3g} > {_paths.NARROWBAND_TOLERANCE})")
            self._method[key] = "narrowband"
        return self._method[key]

    def constant_gain(self, fc_hz: float) -> np.ndarray:
        return self.bulk.narrowband_gain(fc_hz)[:, None]

    def apply(self, x, *, fs_hz, fc_hz, t0_s=0.0, method="narrowband"):
        return self.constant_gain(fc_hz) * x


class DrawnLinks:
    """The ``Links`` of :mod:`rfsim.air.step` for links drawn beforehand: ``paths(tx, rx)`` looks the
    antenna pair up (either direction: the channel is reciprocal)."""

    def __init__(self):
        self._table: dict = {}

    def add(self, tx, rx, paths) -> None:
        self._table[(id(tx), id(rx))] = (tx, rx, paths)

    def paths(self, tx, rx, *, fc_hz: float, t_s: float):
        hit = self._table.get((id(tx), id(rx))) or self._table.get((id(rx), id(tx)))
        return None if hit is None else hit[2]


_UNITS = {"_v": "V", "_m": "m", "_rad": "rad", "_w": "W", "_hz": "Hz"}


def unit_of(key: str) -> str:
    """Unit of a dataset column from its name's suffix ("1" when it has none)."""
    return next((u for suf, u in _UNITS.items() if key.endswith(suf)), "1")


def concat(parts: Sequence[dict]) -> dict[str, np.ndarray]:
    """Concatenate per-task column dicts (same keys) into one."""
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


__all__ = ["FrameConfig", "NoiseConfig", "Frame", "OwnSchedule", "build_frame", "exciter_antenna", "room", "uniform_disc", "RowsChain", "BatchAntenna", "BatchLink",
           "DrawnLinks", "concat", "unit_of"]

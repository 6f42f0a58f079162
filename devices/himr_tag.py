"""HIMR inertial tag: a battery-assisted, free-running backscatter tag that sends packets of
IMU words with a BOC line code through two RF states, open and short.

Model (himr-tag.md §0.1, §2.1–2.2; wave2-specs.md §H; seed 000 L411–L422, L713–L720):

* **Battery-assisted, not Gen2** (L411, L713): the tag neither powers up from nor listens
  to the reader's field; it backscatters on its own schedule whatever the incident field.
* **Packet size**: ``9axis-2d`` is 192 bit (24 B: 3 header + 2 ID + 6 accel + 6 gyro + 6 compass
  + 1 CRC, the byte counts of seed 000 Table 5 / L715), air time 0.384 ms at 8 chips/bit and
  4 Mcps; the issue's and reference pages' "240 bit, 0.48 ms" (30 B) does not follow from those
  byte counts, so the bytes of the source are kept (:mod:`rfsim.himr.packet`; the HIMR datasets
  say so in ``packet_bits_note``). ``6axis-1d`` is 96 bit (12 B, Table 2), 1.2288 ms.
* **Schedule**: packet k starts at t_k = t_{k−1} + T + σ_j·ε_k, ε_k ~ N(0, 1), t_0 =
  ``start_s``, T = 1/packet rate (141 packets/s for ``9axis-2d``, L715; ≈ 300 for
  ``6axis-1d``, L411). The jitter models the variable MCU/sensor access time that sets the
  packet rate (L1354–L1360; no figure given: ``jitter_rms_s``, default 0). A period never
  falls below the air time (the tag sends one packet at a time).
* **IMU words** are sampled at the packet start (the MCU reads the sensor, then sends) by
  :func:`rfsim.devices.imu.imu_words`, packed by :func:`rfsim.himr.packet.build_packets`; the
  ``6axis-1d`` format carries the three accelerometer words only.
* **RF states** (L432, L715): Γ_open = +1 on a +1 chip, Γ_short = −1 on a −1 chip
  (:func:`rfsim.himr.boc.boc_train`); between packets the switch rests in ``rest_state``.
  Re-radiation factor r(t) = A_s − Γ(t) (structural-mode term A_s, ``structural_mode``,
  default 0: antenna mode only), the convention of :mod:`rfsim.devices.tag`.

As a reflector of the air step: :meth:`HimrTag.plan` draws the schedule and the IMU words
once per run (from the run's generator), then :meth:`HimrTag.reflection` returns Γ(t) on
any time base ``t = t0_s + n/fs_hz``, n < n_samples (only the packets overlapping it are
sampled), and :meth:`HimrTag.reradiation` the factor r(t) that multiplies the incident field.
:meth:`HimrTag.reflect` offers the same through the reflector protocol of the air step
(``reflect(incident)`` with an incident segment carrying ``t0_s``, ``fs_hz``,
``n_samples``; the incident field itself is ignored: the tag is battery-assisted) and
:meth:`HimrTag.position_m` the antenna position along the trajectory (a motion callable
``t → (3,)`` for moving links).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.himr.packet import Framing, PacketFormat, build_packets, packet_format
from rfsim.core.trajectories import Kinematics
from rfsim.core.lazy import lazy_import

_imu = lazy_import("rfsim.devices.imu")
_boc = lazy_import("rfsim.himr.boc")

GAMMA_OPEN = 1.0 + 0j
GAMMA_SHORT = -1.0 + 0j


@dataclass(frozen=True)
class HimrTagConfig:
    """Parameters of one HIMR tag (errors name ``tag.<key>``)."""

    packet_format: Literal["9axis-2d", "6axis-1d"] = param("9axis-2d", doc="packet format")
    tag_id: int = param(1, lo=0, hi=65535, doc="2-byte tag ID")
    packet_rate_hz: float | None = param(None, lo=0.0, lo_open=True, unit="1/s",
                                         doc="packets per second (None: the format's nominal rate)")
    jitter_rms_s: float = param(0.0, lo=0.0, hi=1e-3, unit="s", doc="RMS jitter of each packet period")
    start_s: float = param(0.0, lo=0.0, unit="s", doc="start of the first packet")
    chip_rate_hz: float | None = param(None, lo=0.0, lo_open=True, unit="chip/s",
                                       doc="override of the format's chip rate")
    subcarrier_hz: float | None = param(None, lo=0.0, lo_open=True, unit="Hz",
                                        doc="BOC subcarrier (None: chip rate / 2)")
    rest_state: Literal["open", "short"] = param("open", doc="switch state between packets")
    structural_mode: float = param(0.0, lo=-1.0, hi=1.0, doc="structural-mode term A_s of r = A_s − Γ")
    framing: Framing = param(Framing(), doc="preamble, CRC-8, bit and byte order")

    def __post_init__(self):
        check_fields(self, "tag")
        code = self.code  # validates chip rate against the subcarrier
        air = code.duration_s(self.format.n_bits)
        if air > self.period_s:
            raise ConfigError("tag.packet_rate_hz", self.packet_rate_hz,
                              f"at most 1/air time = {1 / air:g} packets/s")

    @property
    def format(self) -> PacketFormat:
        return packet_format(self.packet_format)

    @property
    def code(self) -> _boc.BocCode:
        return self.format.code(chip_rate_hz=self.chip_rate_hz, subcarrier_hz=self.subcarrier_hz, key="tag")

    @property
    def period_s(self) -> float:
        rate = self.format.packet_rate_hz if self.packet_rate_hz is None else self.packet_rate_hz
        return 1.0 / rate

    @property
    def air_time_s(self) -> float:
        return self.code.duration_s(self.format.n_bits)

    @property
    def gamma_rest(self) -> complex:
        return GAMMA_OPEN if self.rest_state == "open" else GAMMA_SHORT


@dataclass(frozen=True, eq=False)
class HimrPlan:
    """What the tag sends in one run.

    Attributes
    ----------
    start_s : ndarray of float, shape (P,)
        Packet start times [s].
    words : ndarray of int16, shape (P, n_words)
        The IMU words carried.
    bits : ndarray of uint8, shape (P, n_bits)
        The packets on the air.
    truth : rfsim.core.trajectories.Kinematics
        The true kinematics at ``start_s``.
    """

    start_s: np.ndarray
    words: np.ndarray
    bits: np.ndarray
    truth: Kinematics


@dataclass(frozen=True, eq=False)
class HimrReflection:
    """What the tag scatters on one time base: r(t) = A_s − Γ(t) (air-step reflection).

    Attributes
    ----------
    samples : ndarray of complex128, shape (n_samples,)
        r(t) on the time base.
    scatters : bool
        Always True: the tag re-radiates whatever the incident field.
    """

    samples: np.ndarray  #: (n,) complex128
    scatters: bool = True

    @property
    def constant_reradiation(self) -> complex | None:
        """r as one number when no packet overlaps the time base, else None."""
        s = self.samples
        return complex(s[0]) if s.size and np.all(s == s[0]) else None

    def reradiation(self, n_samples: int) -> np.ndarray:
        """Return the re-radiation factor r(t) on the time base.

        Parameters
        ----------
        n_samples : int
            Number of samples the air step expects.

        Returns
        -------
        ndarray of complex128, shape (n_samples,)
            :attr:`samples`.

        Raises
        ------
        ValueError
            When ``n_samples`` differs from the length of :attr:`samples`.
        """
        if n_samples != self.samples.size:
            raise ValueError(f"reflection has {self.samples.size} samples, asked for {n_samples}")
        return self.samples


class HimrTag:
    """A HIMR tag on a trajectory (module docstring).

    Parameters
    ----------
    config : HimrTagConfig
        Packet format, rate, jitter, chip rate, rest state, structural mode, framing.
    trajectory : callable
        ``t_s → Kinematics`` for an array of times [s] (:mod:`rfsim.core.trajectories`).
    imu : rfsim.devices.imu.ImuConfig or None, optional
        The IMU's errors; default None, ``ImuConfig()``.
    antenna : object, optional
        Keyword-only: the tag's antenna object for a channel (its position is the
        trajectory's, see :meth:`position_m`); default None.
    """

    def __init__(self, config: HimrTagConfig, trajectory, imu: _imu.ImuConfig | None = None, *, antenna=None):
        self.config = config
        self.trajectory = trajectory
        self.imu = _imu.ImuConfig() if imu is None else imu
        self.antenna = antenna
        self._plan: HimrPlan | None = None

    def position_m(self, t_s: float) -> np.ndarray:
        """Return the antenna position on the trajectory at a time.

        Parameters
        ----------
        t_s : float
            Time [s].

        Returns
        -------
        ndarray of float, shape (3,)
            Position [m].
        """
        return self.trajectory(np.array([float(t_s)])).position_m[0]

    def schedule(self, t_end_s: float, *, rng: np.random.Generator) -> np.ndarray:
        """Draw the packet start times in [start_s, t_end_s).

        :math:`t_k = t_{k-1} + \\max(T + \\sigma_j \\varepsilon_k, T_{air})`,
        :math:`\\varepsilon_k \\sim N(0, 1)`, :math:`t_0` = ``start_s`` (module docstring;
        himr-tag.md §2.1–2.2).

        Parameters
        ----------
        t_end_s : float
            End of the schedule [s] (exclusive).
        rng : numpy.random.Generator
            Keyword-only: generator of the jitter (drawn even when σ_j = 0; nothing is drawn
            when ``t_end_s`` ≤ ``start_s``).

        Returns
        -------
        ndarray of float64, shape (P,)
            Start times [s]; empty when ``t_end_s`` ≤ ``start_s``.
        """
        cfg = self.config
        span = float(t_end_s) - cfg.start_s
        if span <= 0:
            return np.zeros(0)
        n_max = int(math.ceil(span / max(cfg.period_s - 6 * cfg.jitter_rms_s, cfg.air_time_s))) + 1
        periods = cfg.period_s + cfg.jitter_rms_s * rng.standard_normal(n_max)
        periods = np.maximum(periods, cfg.air_time_s)
        starts = cfg.start_s + np.concatenate([[0.0], np.cumsum(periods[:-1])])
        return starts[starts < t_end_s]

    def plan(self, t_end_s: float, *, rng: np.random.Generator) -> HimrPlan:
        """Draw the schedule and the IMU words up to ``t_end_s`` and keep them (one per run).

        The IMU words are sampled at each packet start (:func:`rfsim.devices.imu.imu_words`,
        only the format's words kept) and packed by :func:`rfsim.himr.packet.build_packets`.

        Parameters
        ----------
        t_end_s : float
            End of the run [s].
        rng : numpy.random.Generator
            Keyword-only: the run's generator (schedule jitter, then IMU noise).

        Returns
        -------
        HimrPlan
            The plan, also kept as :attr:`current_plan`.
        """
        cfg, fmt = self.config, self.config.format
        starts = self.schedule(t_end_s, rng=rng)
        truth = self.trajectory(starts)
        words = _imu.imu_words(truth, self.imu, rng=rng)[:, : fmt.n_words]
        bits = build_packets(fmt, cfg.framing, cfg.tag_id, words)
        self._plan = HimrPlan(start_s=starts, words=words, bits=bits, truth=truth)
        return self._plan

    @property
    def current_plan(self) -> HimrPlan:
        if self._plan is None:
            raise RuntimeError("call HimrTag.plan(t_end_s, rng=...) first")
        return self._plan

    def reflection(self, t0_s: float, fs_hz: float, n_samples: int) -> np.ndarray:
        """Γ(t) at t = t0_s + n/fs_hz, n = 0 … n_samples−1: (n_samples,) complex128.

        +1 (open) / −1 (short) on the chips of every packet of the plan overlapping the time
        base, ``gamma_rest`` elsewhere; ``fs_hz`` must reach the BOC bandwidth
        (:func:`rfsim.himr.boc.boc_train`).

        Parameters
        ----------
        t0_s : float
            Time of the first sample [s].
        fs_hz : float
            Sample rate [Hz].
        n_samples : int
            Number of samples.

        Returns
        -------
        ndarray of complex128, shape (n_samples,)
            Γ(t) [1].

        Raises
        ------
        RuntimeError
            When :meth:`plan` has not been called.
        """
        plan, cfg = self.current_plan, self.config
        t1 = t0_s + n_samples / fs_hz
        lo = np.searchsorted(plan.start_s, t0_s - cfg.air_time_s, side="left")
        hi = np.searchsorted(plan.start_s, t1, side="right")
        return _boc.boc_train(plan.start_s[lo:hi], plan.bits[lo:hi], cfg.code, t0_s=t0_s, fs_hz=fs_hz,
                              n_samples=n_samples, level_plus=GAMMA_OPEN, level_minus=GAMMA_SHORT,
                              rest=cfg.gamma_rest)

    def reradiation(self, t0_s: float, fs_hz: float, n_samples: int) -> np.ndarray:
        """Return the re-radiation factor :math:`r(t) = A_s - \\Gamma(t)` on a time base.

        The factor multiplies the incident field (the convention of :mod:`rfsim.devices.tag`).

        Parameters
        ----------
        t0_s : float
            Time of the first sample [s].
        fs_hz : float
            Sample rate [Hz].
        n_samples : int
            Number of samples.

        Returns
        -------
        ndarray of complex128, shape (n_samples,)
            r(t) [1].
        """
        return self.config.structural_mode - self.reflection(t0_s, fs_hz, n_samples)

    def reflect(self, incident) -> HimrReflection:
        """Reflect an incident segment (the air step's reflector protocol).

        Parameters
        ----------
        incident : rfsim.air.segment.Segment
            The incident field; only its time base (``t0_s``, ``fs_hz``, ``n_samples``) is
            used (the tag is battery-assisted).

        Returns
        -------
        HimrReflection
            r(t) on that time base.
        """

        return HimrReflection(self.reradiation(incident.t0_s, incident.fs_hz, incident.n_samples))


__all__ = ["HimrTagConfig", "HimrTag", "HimrPlan", "HimrReflection", "GAMMA_OPEN", "GAMMA_SHORT"]

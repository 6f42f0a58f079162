"""MPU-9250-class inertial measurement unit: body-frame specific force, angular rate and
magnetic field as int16 words.

The seed names the sensor (InvenSense MPU9250, seed 000 L713–L715) but gives no noise,
bias or quantisation figures (himr-tag.md §0.2); the defaults are datasheet-class values
[not in source; wave2-specs.md §H]: accelerometer ±2/4/8/16 g, 300 µg/√Hz; gyroscope
±250/500/1000/2000 °/s, 0.01 °/s/√Hz; magnetometer (AK8963) 0.6 µT/LSB (14 bit,
±8190 LSB).

Body frame (wave2-specs.md §H, erratum 13 default): heading ψ is the direction of y^B,
x^B = (sin ψ, −cos ψ, 0), y^B = (cos ψ, sin ψ, 0), z^B = (0, 0, 1) up (right-handed).

Measured quantities at the sample times t (:class:`rfsim.core.trajectories.Kinematics`):

* accelerometer, specific force f = a − g with g = (0, 0, −9.80665) m/s²:
  f_x = a·x^B, f_y = a·y^B, f_z = a_z + 9.80665 [m/s²];
* gyroscope ω = (0, 0, ψ̇) [rad/s] (planar motion);
* magnetometer, Earth's field m = (B_h cos δ, B_h sin δ, B_z) in the fixed frame projected
  on the body axes [µT]; heading from it: ψ = δ + atan2(m_x, m_y)
  (:func:`heading_from_compass`; m·y^B = B_h cos(ψ − δ), m·x^B = B_h sin(ψ − δ)).

Errors: a constant bias per axis (configurable, zero by default) plus white noise of
standard deviation σ = noise density·√(noise bandwidth) (the digital low-pass filter's
equivalent noise bandwidth, ``noise_bandwidth_hz``) — the ``datasheet`` mode; ``none``
adds nothing; ``seed-noise`` replaces the accelerometer noise by 0.05·N(0, 1) m/s² (the
seed's 1-D simulation scale, L616, units not stated there; the 0.03 amplitude and 0.08
phase-difference scales of that mode belong to the receiver). Then quantisation
word = clip(round(value/LSB), int16 range), LSB = range/32768 for the accelerometer and
gyroscope, 0.6 µT for the magnetometer (clipped to ±8190).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.core.trajectories import Kinematics

G_MPS2 = 9.80665
#: Words per IMU sample: accel x y z, gyro x y z, compass x y z.
WORD_NAMES = ("accel_x", "accel_y", "accel_z", "gyro_x", "gyro_y", "gyro_z",
              "compass_x", "compass_y", "compass_z")
MAG_LSB_UT = 0.6
MAG_MAX_LSB = 8190


@dataclass(frozen=True)
class ImuConfig:
    """MPU-9250-class IMU (module docstring for models and sources)."""

    accel_range_g: Literal[2, 4, 8, 16] = param(8, doc="accelerometer full scale [g]")
    gyro_range_dps: Literal[250, 500, 1000, 2000] = param(1000, doc="gyroscope full scale [°/s]")
    accel_noise_ug_rthz: float = param(300.0, lo=0.0, unit="ug/sqrt(Hz)", doc="accelerometer noise density")
    gyro_noise_dps_rthz: float = param(0.01, lo=0.0, unit="deg/s/sqrt(Hz)", doc="gyroscope noise density")
    mag_noise_ut: float = param(0.6, lo=0.0, unit="uT", doc="magnetometer noise std (one LSB)")
    noise_bandwidth_hz: float = param(92.0, lo=0.0, lo_open=True, hi=4000.0, unit="Hz",
                                      doc="equivalent noise bandwidth of the sensor's low-pass filter")
    accel_bias_mps2: tuple[float, float, float] = param((0.0, 0.0, 0.0), unit="m/s^2", doc="accelerometer bias")
    gyro_bias_dps: tuple[float, float, float] = param((0.0, 0.0, 0.0), unit="deg/s", doc="gyroscope bias")
    noise: Literal["datasheet", "seed-noise", "none"] = param("datasheet", doc="noise model")
    field_horizontal_ut: float = param(22.0, lo=0.0, lo_open=True, hi=4800.0, unit="uT", doc="Earth field B_h")
    field_vertical_ut: float = param(-40.0, lo=-4800.0, hi=4800.0, unit="uT", doc="Earth field B_z (up)")
    declination_rad: float = param(0.0, unit="rad", doc="direction δ of the horizontal field in the room")

    def __post_init__(self):
        check_fields(self, "imu")

    @property
    def accel_lsb_mps2(self) -> float:
        return self.accel_range_g * G_MPS2 / 32768.0

    @property
    def gyro_lsb_rad_s(self) -> float:
        return math.radians(self.gyro_range_dps) / 32768.0

    @property
    def accel_sigma_mps2(self) -> float:
        if self.noise == "none":
            return 0.0
        if self.noise == "seed-noise":
            return 0.05
        return self.accel_noise_ug_rthz * 1e-6 * G_MPS2 * math.sqrt(self.noise_bandwidth_hz)

    @property
    def gyro_sigma_rad_s(self) -> float:
        if self.noise != "datasheet":
            return 0.0
        return math.radians(self.gyro_noise_dps_rthz) * math.sqrt(self.noise_bandwidth_hz)

    @property
    def mag_sigma_ut(self) -> float:
        return 0.0 if self.noise != "datasheet" else self.mag_noise_ut


def true_readings(kin: Kinematics, cfg: ImuConfig) -> np.ndarray:
    """Compute the noise-free IMU readings in SI units (module docstring).

    Specific force :math:`f_x = a \\cdot x^B`, :math:`f_y = a \\cdot y^B`,
    :math:`f_z = a_z + g`; angular rate :math:`\\omega = (0, 0, \\dot\\psi)`; the Earth's field
    :math:`m = (B_h \\cos\\delta, B_h \\sin\\delta, B_z)` projected on the body axes
    (wave2-specs.md §H).

    Parameters
    ----------
    kin : rfsim.core.trajectories.Kinematics
        Heading [rad], heading rate [rad/s] and acceleration [m/s²] at n sample times.
    cfg : ImuConfig
        The field (``field_horizontal_ut``, ``field_vertical_ut``, ``declination_rad``).

    Returns
    -------
    ndarray of float, shape (n, 9)
        ``f_x f_y f_z`` [m/s²], ``ω_x ω_y ω_z`` [rad/s], ``m_x m_y m_z`` [µT], in
        :data:`WORD_NAMES` order.
    """
    psi = kin.heading_rad
    xb = np.column_stack([np.sin(psi), -np.cos(psi)])
    yb = np.column_stack([np.cos(psi), np.sin(psi)])
    a = kin.acceleration_mps2
    d = cfg.declination_rad
    m_fixed = cfg.field_horizontal_ut * np.array([math.cos(d), math.sin(d)])
    n = psi.size
    out = np.zeros((n, 9))
    out[:, 0] = np.sum(a[:, :2] * xb, axis=1)
    out[:, 1] = np.sum(a[:, :2] * yb, axis=1)
    out[:, 2] = a[:, 2] + G_MPS2
    out[:, 5] = kin.rate_rad_s
    out[:, 6] = xb @ m_fixed
    out[:, 7] = yb @ m_fixed
    out[:, 8] = cfg.field_vertical_ut
    return out


def imu_words(kin: Kinematics, cfg: ImuConfig, *, rng: np.random.Generator) -> np.ndarray:
    """Sample the IMU at ``kin.t_s`` as int16 words.

    The readings of :func:`true_readings` plus bias and white noise (σ = noise density ·
    √(noise bandwidth) in the ``datasheet`` mode), quantised
    :math:`\\mathrm{word} = \\mathrm{clip}(\\mathrm{round}(v / \\mathrm{LSB}))` to the int16
    range (±8190 for the magnetometer).

    Parameters
    ----------
    kin : rfsim.core.trajectories.Kinematics
        Kinematics at n sample times.
    cfg : ImuConfig
        Ranges, noise, biases and field.
    rng : numpy.random.Generator
        Keyword-only: generator of the noise (accelerometer, gyroscope, magnetometer draws,
        each (n, 3), drawn even when their σ is 0).

    Returns
    -------
    ndarray of int16, shape (n, 9)
        The words in :data:`WORD_NAMES` order.
    """
    si = true_readings(kin, cfg)
    n = si.shape[0]
    si[:, 0:3] += np.asarray(cfg.accel_bias_mps2) + cfg.accel_sigma_mps2 * rng.standard_normal((n, 3))
    si[:, 3:6] += np.radians(cfg.gyro_bias_dps) + cfg.gyro_sigma_rad_s * rng.standard_normal((n, 3))
    si[:, 6:9] += cfg.mag_sigma_ut * rng.standard_normal((n, 3))
    lsb = np.repeat([cfg.accel_lsb_mps2, cfg.gyro_lsb_rad_s, MAG_LSB_UT], 3)
    hi = np.repeat([32767, 32767, MAG_MAX_LSB], 3)
    lo = np.repeat([-32768, -32768, -MAG_MAX_LSB], 3)
    return np.clip(np.rint(si / lsb), lo, hi).astype(np.int16)


def words_to_si(words, cfg: ImuConfig) -> np.ndarray:
    """Convert IMU words to SI readings: word · LSB.

    Parameters
    ----------
    words : array_like of int, shape (..., 9) or (..., 3)
        Words in :data:`WORD_NAMES` order, or the first 3 (accelerometer only).
    cfg : ImuConfig
        The ranges that set the LSBs.

    Returns
    -------
    ndarray of float, shape of ``words``
        Specific force [m/s²], angular rate [rad/s], magnetic field [µT].

    Raises
    ------
    ConfigError
        ``imu.words`` when the last dimension is neither 3 nor 9.
    """
    w = np.asarray(words, dtype=float)
    if w.shape[-1] not in (3, 9):
        raise ConfigError("imu.words", w.shape, "3 (accelerometer) or 9 words per sample")
    lsb = np.repeat([cfg.accel_lsb_mps2, cfg.gyro_lsb_rad_s, MAG_LSB_UT], 3)[: w.shape[-1]]
    return w * lsb


def heading_from_compass(m_x_ut, m_y_ut, declination_rad: float = 0.0) -> np.ndarray:
    """Compute the heading from the compass: :math:`\\psi = \\delta + \\operatorname{atan2}(m_x, m_y)`.

    From :math:`m \\cdot y^B = B_h \\cos(\\psi - \\delta)` and
    :math:`m \\cdot x^B = B_h \\sin(\\psi - \\delta)` (module docstring).

    Parameters
    ----------
    m_x_ut, m_y_ut : float or array_like of float
        Body-frame field components [µT] (broadcast together).
    declination_rad : float, optional
        Direction δ of the horizontal field in the room [rad], default 0.0.

    Returns
    -------
    ndarray of float
        Heading ψ wrapped to (−π, π] [rad], the broadcast shape.
    """

    psi = declination_rad + np.arctan2(np.asarray(m_x_ut, float), np.asarray(m_y_ut, float))
    return np.angle(np.exp(1j * psi))


__all__ = ["ImuConfig", "WORD_NAMES", "G_MPS2", "true_readings", "imu_words", "words_to_si",
           "heading_from_compass"]

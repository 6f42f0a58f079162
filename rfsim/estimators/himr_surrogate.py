"""Geometric surrogate of the HIMR measurement stream — NOT the sample-level receivers.

For testing the observers on their own: the outputs of the 2-D model are computed from the
true state, y = h(x(t_k)) + v_k (eq. 28, :func:`~rfsim.estimators.himr_model.h_2d`), i.e.
ideal RSS ranges (|tag − pylon|), ideal phase-derived radial velocities (the true
instantaneous ṙ, no wrapping or averaging over the packet interval), ideal body-frame
accelerations, heading and rate, plus white Gaussian noise v_k of the standard deviations of
himr-tag.md §6.3 [not in source]: 5 cm range, 5 cm/s radial velocity, 0.5 m/s²
accelerations, 0.05 rad compass, 0.3 rad/s gyroscope. The sample-level stream (BOC decode,
least-squares gain, RSS and phase per receiver) replaces it once the receivers exist.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.estimators.himr_model import PYLONS_M, h_2d


@dataclass(frozen=True)
class SurrogateNoise:
    """Standard deviations of the surrogate's white noise (himr-tag.md §6.3)."""

    range_m: float = 0.05
    radial_velocity_mps: float = 0.05
    accel_mps2: float = 0.5
    heading_rad: float = 0.05
    rate_rad_s: float = 0.3

    def sigmas(self, n_pylons: int) -> np.ndarray:
        """Standard deviations in observer order (himr-tag.md §6.3).

        Parameters
        ----------
        n_pylons : int
            Number of pylons P.

        Returns
        -------
        numpy.ndarray
            ``(2P + 4,)``: per pylon range [m] and radial velocity [m/s], then two accelerations
            [m/s²], heading [rad] and rate [rad/s].
        """
        rf = [self.range_m, self.radial_velocity_mps] * n_pylons
        return np.array(rf + [self.accel_mps2, self.accel_mps2, self.heading_rad, self.rate_rad_s])


def geometric_measurements(states, *, pylons_m=PYLONS_M, noise: SurrogateNoise | None = None,
                           rng: np.random.Generator | None = None) -> np.ndarray:
    """Surrogate outputs of true states: y = h(x(t_k)) + v_k (eq. 28, module docstring).

    Parameters
    ----------
    states : array_like
        ``(n, 9)`` true states of the 2-D model (:mod:`rfsim.estimators.himr_model`).
    pylons_m : array_like
        ``(P, 2)`` pylon positions [m].
    noise : SurrogateNoise or None
        White-noise standard deviations; None: noise-free.
    rng : numpy.random.Generator or None
        Noise source; required with ``noise``.

    Returns
    -------
    numpy.ndarray
        ``(n, 2P + 4)`` outputs in observer order (units of :meth:`SurrogateNoise.sigmas`).

    Raises
    ------
    ValueError
        If ``noise`` is given without ``rng``.
    """
    y = h_2d(states, pylons_m, "literal")
    if noise is None:
        return y
    if rng is None:
        raise ValueError("a noisy surrogate needs rng=")
    return y + noise.sigmas(np.asarray(pylons_m).shape[0]) * rng.standard_normal(y.shape)


__all__ = ["SurrogateNoise", "geometric_measurements"]

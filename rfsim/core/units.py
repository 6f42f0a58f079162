"""Physical constants and unit conversions used everywhere in rfsim.

SI units inside the simulator; names carry a suffix where a unit could be ambiguous
(``distance_m``, ``ptx_dbm``, ``fc_hz``). Power in decibels: dB for ratios, dBm for
power referred to 1 mW, dBi for antenna gain over isotropic.
"""

from __future__ import annotations

import numpy as np

#: Speed of light in vacuum [m/s] (exact: it defines the metre, SI 2019; equals
#: ``scipy.constants.c``, which is not imported here because it costs start-up time).
C_M_S: float = 299_792_458.0
#: Boltzmann constant [J/K] (exact: it defines the kelvin, SI 2019; equals ``scipy.constants.k``).
K_BOLTZMANN_J_K: float = 1.380649e-23
#: Reference noise temperature [K] for kTB noise.
T0_K: float = 290.0


def db_to_lin(x_db):
    """Power ratio from decibels: ``10**(x/10)``.

    Parameters
    ----------
    x_db : array_like
        Ratio [dB].

    Returns
    -------
    numpy.ndarray
        Power ratio [1].
    """
    return np.power(10.0, np.asarray(x_db, dtype=float) / 10.0)


def lin_to_db(x):
    """Decibels from a power ratio: ``10·log10(x)``.

    Parameters
    ----------
    x : array_like
        Power ratio [1].

    Returns
    -------
    numpy.ndarray
        Ratio [dB].
    """
    return 10.0 * np.log10(np.asarray(x, dtype=float))


def dbm_to_w(p_dbm):
    """Power in W from dBm: ``10**(p/10 − 3)``.

    Parameters
    ----------
    p_dbm : array_like
        Power [dBm].

    Returns
    -------
    numpy.ndarray
        Power [W].
    """
    return np.power(10.0, np.asarray(p_dbm, dtype=float) / 10.0 - 3.0)


def w_to_dbm(p_w):
    """Power in dBm from W: ``10·log10(p) + 30``.

    Parameters
    ----------
    p_w : array_like
        Power [W].

    Returns
    -------
    numpy.ndarray
        Power [dBm].
    """
    return 10.0 * np.log10(np.asarray(p_w, dtype=float)) + 30.0


def wavelength_m(fc_hz):
    """Free-space wavelength λ = c / f.

    Parameters
    ----------
    fc_hz : array_like
        Frequency [Hz].

    Returns
    -------
    numpy.ndarray
        λ [m].
    """
    return C_M_S / np.asarray(fc_hz, dtype=float)


def wrap_phase_rad(phi_rad):
    """Wrap a phase to [0, 2π).

    Parameters
    ----------
    phi_rad : array_like
        Phase [rad].

    Returns
    -------
    numpy.ndarray
        Phase in [0, 2π) [rad].
    """
    return np.mod(np.asarray(phi_rad, dtype=float), 2.0 * np.pi)


__all__ = [
    "C_M_S",
    "K_BOLTZMANN_J_K",
    "T0_K",
    "db_to_lin",
    "lin_to_db",
    "dbm_to_w",
    "w_to_dbm",
    "wavelength_m",
    "wrap_phase_rad",
]

"""The ST's band-pass: a digital Butterworth band-pass as second-order sections and the
steady state of its sections (the band-pass of :class:`rfsim.devices.st_receiver.STReceiver`).

Design (the bilinear-transform Butterworth design of ``scipy.signal.butter``): analog
prototype pole ``p = −1`` (order 1), edges pre-warped ``ω = 4·tan(π·f/fs)`` (normalised
sample rate 2), low-pass → band-pass ``s → (s² + ω0²)/(B·s)`` with ``ω0 = sqrt(ω_lo·ω_hi)``,
``B = ω_hi − ω_lo``: poles ``B/2·p ± sqrt((B/2·p)² − ω0²)``, one zero at 0, gain B; bilinear
``z = (4 + s)/(4 − s)`` (zeros at +1 and, from the zero at infinity, −1), gain
``B·Π(4 − z_s)/Π(4 − p_s)``; one section ``b = k·(1, −(z1 + z2), z1·z2)``,
``a = (1, −(p1 + p2), p1·p2)``. For order 1 (the ST's default, one section) it is evaluated
here with NumPy, operation for operation as SciPy does it (the same coefficients, bit for
bit: ``tests/test_st_bandpass.py`` compares them over a grid of edges and rates), so a run
need not import ``scipy.signal`` (≈ 0.6 s CPU per process); other orders are SciPy's.

Steady state (``scipy.signal.sosfilt_zi``): the state ``zi`` of a section in direct form II
transposed that a constant unit input leaves unchanged, ``(I − Aᵀ)·zi = b[1:] − a[1:]·b[0]``
with A the companion matrix of a.
"""

from __future__ import annotations

import numpy as np

from rfsim.core.lazy import lazy_import

_signal = lazy_import("scipy.signal")


def butter_bandpass_sos(order: int, low_hz: float, high_hz: float, fs_hz: float) -> np.ndarray:
    """Butterworth band-pass ``[low_hz, high_hz]`` at ``fs_hz`` as second-order sections.

    Equal to ``scipy.signal.butter(order, [low, high], "bandpass", fs=fs, output="sos")``;
    order 1 is computed here with NumPy (the design of the module docstring), other orders
    call SciPy (:func:`butter_bandpass_sos_reference`).

    Parameters
    ----------
    order : int
        Order of the analog low-pass prototype (the band-pass has twice as many poles).
    low_hz, high_hz : float
        Lower and upper −3 dB band edges [Hz], ``0 < low_hz < high_hz < fs_hz/2``.
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    numpy.ndarray, shape (n_sections, 6), float64
        Sections ``[b0, b1, b2, a0, a1, a2]`` (one section for order 1).

    Raises
    ------
    ValueError
        If the band edges are not ``0 < low_hz < high_hz < fs_hz/2``.
    """
    if int(order) != 1:
        return butter_bandpass_sos_reference(order, low_hz, high_hz, fs_hz)
    fs = float(fs_hz)
    wn = np.asarray([low_hz, high_hz], dtype=np.float64) / (fs / 2)
    if not (0 < wn[0] < wn[1] < 1):
        raise ValueError(f"band edges must satisfy 0 < low < high < fs/2, got {low_hz}, {high_hz} at {fs_hz}")
    warped = 2 * 2.0 * np.tan(np.pi * wn / 2.0)
    bw = float(warped[1] - warped[0])
    wo = float(np.sqrt(warped[0] * warped[1]))
    # analog prototype (order 1) → band-pass
    p = -np.exp(1j * np.pi * np.arange(0, 1, 2, dtype=np.float64) / 2)
    p_lp = p * bw / 2
    p_bp = np.concatenate((p_lp + np.sqrt(p_lp ** 2 - wo ** 2), p_lp - np.sqrt(p_lp ** 2 - wo ** 2)))
    z_bp = np.zeros(1, dtype=np.complex128)
    k_bp = 1.0 * bw ** 1
    # bilinear transform (normalised rate 2: fs2 = 4)
    fs2 = 4.0
    z_z = np.concatenate(((fs2 + z_bp) / (fs2 - z_bp), -np.ones(1)))
    p_z = (fs2 + p_bp) / (fs2 - p_bp)
    k_z = k_bp * np.real(np.prod(fs2 - z_bp) / np.prod(fs2 - p_bp))
    # one section: the pole nearest the unit circle first, the zero nearest it, then the rest
    z = _sorted_real(z_z)
    p_re = _sorted_real(p_z)
    if p_re is not None:
        i = int(np.argmin(np.abs(1 - np.abs(p_re))))
        p1, p2 = p_re[i], p_re[1 - i]
    else:
        p1 = _upper_conjugate(p_z)
        p2 = p1.conj()
    j = int(np.argsort(np.abs(z - p1))[0])
    sos = np.zeros((1, 6))
    k = np.asarray(1, dtype=np.result_type(np.real(z), np.real(np.asarray([p1, p2])), 1))
    sos[0, :3] = np.multiply(np.atleast_1d(k), _poly(np.asarray([z[j], z[1 - j]])))
    sos[0, 3:] = _poly(np.asarray([p1, p2]))
    sos[0][:3] *= np.asarray(k_z).real
    return sos


def butter_bandpass_sos_reference(order: int, low_hz: float, high_hz: float, fs_hz: float) -> np.ndarray:
    """SciPy's design (the twin of :func:`butter_bandpass_sos`).

    Parameters
    ----------
    order : int
        Order of the analog low-pass prototype.
    low_hz, high_hz : float
        Lower and upper −3 dB band edges [Hz].
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    numpy.ndarray, shape (n_sections, 6), float64
        ``scipy.signal.butter(order, [low_hz, high_hz], btype="bandpass", fs=fs_hz, output="sos")``.
    """
    return _signal.butter(int(order), [low_hz, high_hz], btype="bandpass", fs=fs_hz, output="sos")


def sos_steady_state(sos) -> np.ndarray:
    """Steady state per unit input of second-order sections (``scipy.signal.sosfilt_zi``).

    The state ``zi`` of a section in direct form II transposed that a constant unit input
    leaves unchanged, ``(I − Aᵀ)·zi = b[1:] − a[1:]·b[0]`` with A the companion matrix of a;
    one normalised section (``a0 = 1``) is solved here, anything else by SciPy
    (:func:`sos_steady_state_reference`).

    Parameters
    ----------
    sos : array_like, shape (n_sections, 6)
        Second-order sections ``[b0, b1, b2, a0, a1, a2]``.

    Returns
    -------
    numpy.ndarray, shape (n_sections, 2), float64
        Initial state per section for a unit step (scale by the first input sample).
    """
    sos = np.asarray(sos, dtype=np.float64)
    if sos.shape[0] != 1 or sos[0, 3] != 1.0:
        return sos_steady_state_reference(sos)
    b, a = sos[0, :3], sos[0, 3:]
    companion = np.zeros((2, 2))
    companion[0, :] = -a[1:] / (1.0 * a[0:1])
    companion[1, 0] = 1
    zi = np.empty((1, 2))
    zi[0] = 1.0 * np.linalg.solve(np.eye(2) - companion.T, b[1:] - a[1:] * b[0])
    return zi


def sos_steady_state_reference(sos) -> np.ndarray:
    """SciPy's ``sosfilt_zi`` (the twin of :func:`sos_steady_state`).

    Parameters
    ----------
    sos : array_like, shape (n_sections, 6)
        Second-order sections ``[b0, b1, b2, a0, a1, a2]``.

    Returns
    -------
    numpy.ndarray, shape (n_sections, 2)
        ``scipy.signal.sosfilt_zi(sos)``.
    """
    return _signal.sosfilt_zi(sos)


def _sorted_real(roots) -> np.ndarray | None:
    """The roots sorted by real part as float64 when all are real (|imag| ≤ 100·eps·|root|),
    else None."""
    r = roots[np.lexsort((np.abs(roots.imag), roots.real))]
    tol = 100 * np.finfo(np.float64).eps
    if np.all(np.abs(r.imag) <= tol * np.abs(r)):
        return r.real
    return None


def _upper_conjugate(roots) -> complex:
    """The root of a conjugate pair with positive imaginary part, as the mean of it and the
    conjugate of its partner."""
    r = roots[np.lexsort((np.abs(roots.imag), roots.real))]
    zp, zn = r[r.imag > 0], r[r.imag < 0]
    if zp.size != 1 or zn.size != 1:
        raise ValueError(f"poles {roots} are neither real nor a conjugate pair")
    return ((zp + zn.conj()) / 2)[0]


def _poly(roots) -> np.ndarray:
    """Coefficients of ``Π(x − r)``, highest power first (real when the roots are real or
    conjugate pairs): the product formed factor by factor with ``np.convolve``."""
    a = np.ones((1,), dtype=roots.dtype)
    one = np.ones_like(roots[0])
    for r in roots:
        a = np.convolve(a, np.stack((one, -r)), mode="full")
    if np.iscomplexobj(a):
        im = np.asarray(roots, dtype=np.complex128).imag
        if np.all(np.sort(im) == np.sort(-im)):
            a = np.real(a).copy()
    return a


__all__ = ["butter_bandpass_sos", "butter_bandpass_sos_reference", "sos_steady_state",
           "sos_steady_state_reference"]

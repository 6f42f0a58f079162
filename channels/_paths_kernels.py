"""Compiled loops behind :func:`rfsim.channels.paths.apply_paths` (see there for the model)."""

from __future__ import annotations

import math

from rfsim.core._jit import njit

#: Samples between exact re-evaluations of the Doppler phasor (recurrence in between).
_REANCHOR = 4096


@njit
def fir_rows_kernel(x, taps, starts, lengths, w_rad, phi0_rad, y):
    """Accumulate ``y[n] += e^{j(φ0_r + w_r·n)} · Σ_j taps[r, j]·x[n − starts[r] − j]`` over rows r.

    Parameters
    ----------
    x : (N,) complex128, input samples (zero outside [0, N))
    taps : (R, Lmax) complex128, FIR rows (only the first ``lengths[r]`` entries are used)
    starts : (R,) int64, sample offset of tap 0 of each row (may be negative)
    lengths : (R,) int64, used length of each row
    w_rad : (R,) float64, Doppler phase increment per sample [rad]
    phi0_rad : (R,) float64, Doppler phase at n = 0 [rad]
    y : (N,) complex128, accumulated in place (returned)
    """
    n_samp = x.shape[0]
    for r in range(taps.shape[0]):
        s = starts[r]
        ln = lengths[r]
        rotate = w_rad[r] != 0.0 or phi0_rad[r] != 0.0
        step = complex(math.cos(w_rad[r]), math.sin(w_rad[r]))
        rot = 1.0 + 0j
        for n in range(n_samp):
            jlo = n - s - n_samp + 1
            if jlo < 0:
                jlo = 0
            jhi = n - s + 1
            if jhi > ln:
                jhi = ln
            acc = 0j
            for j in range(jlo, jhi):
                acc += taps[r, j] * x[n - s - j]
            if rotate:
                if n % _REANCHOR == 0:
                    ph = phi0_rad[r] + w_rad[r] * n
                    rot = complex(math.cos(ph), math.sin(ph))
                else:
                    rot *= step
                acc *= rot
            y[n] += acc
    return y


@njit
def narrowband_kernel(x, coef, w_rad, phi0_rad, y):
    """``y[n] += x[n] · Σ_p coef[p]·e^{j(φ0_p + w_p·n)}`` (narrowband: envelope delays dropped)."""
    n_samp = x.shape[0]
    static = 0j
    for p in range(coef.shape[0]):
        if w_rad[p] == 0.0 and phi0_rad[p] == 0.0:
            static += coef[p]
    for n in range(n_samp):
        y[n] += static * x[n]
    for p in range(coef.shape[0]):
        if w_rad[p] == 0.0 and phi0_rad[p] == 0.0:
            continue
        step = complex(math.cos(w_rad[p]), math.sin(w_rad[p]))
        rot = 1.0 + 0j
        for n in range(n_samp):
            if n % _REANCHOR == 0:
                ph = phi0_rad[p] + w_rad[p] * n
                rot = complex(math.cos(ph), math.sin(ph))
            else:
                rot *= step
            y[n] += coef[p] * rot * x[n]
    return y

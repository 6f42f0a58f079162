"""numba kernels of the active beacon's MSK modulator and the reader's FM discriminator
(wrapped and documented in :mod:`rfsim.devices.msk_beacon`; NumPy twins in the tests'
``reference.devices_msk_beacon``).
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit


@njit
def msk_phase_kernel(chips, sps, offset_chips, phase_out, on_out):
    """MSK phase at samples n = 0…N−1 of a burst (module :mod:`rfsim.devices.msk_beacon`).

    ``u = offset_chips + n/sps`` is the time of sample n in chips since the burst start; in
    chip k = ⌊u⌋ the phase is ``Φ_k + a_k·(π/2)·(u − k)`` with ``Φ_k = (π/2)·Σ_{i<k} a_i``;
    ``on_out[n]`` is 1 inside the burst (0 ≤ u < K), 0 outside (phase 0 there).
    """
    n_chips = chips.size
    cum = 0.0
    starts = np.empty(n_chips + 1)
    for k in range(n_chips):
        starts[k] = cum
        cum += 0.5 * math.pi * chips[k]
    starts[n_chips] = cum
    for n in range(phase_out.size):
        u = offset_chips + n / sps
        k = int(math.floor(u))
        if 0 <= k < n_chips:
            phase_out[n] = starts[k] + 0.5 * math.pi * chips[k] * (u - k)
            on_out[n] = 1
        else:
            phase_out[n] = 0.0
            on_out[n] = 0


@njit
def discriminator_kernel(y, y_prev, out):
    """FM discriminator ``out[n] = arg(y[n]·conj(y[n−1]))`` (``y[−1] = y_prev``) [rad/sample]."""
    prev = y_prev
    for n in range(y.size):
        cur = y[n]
        re = cur.real * prev.real + cur.imag * prev.imag
        im = cur.imag * prev.real - cur.real * prev.imag
        out[n] = math.atan2(im, re)
        prev = cur

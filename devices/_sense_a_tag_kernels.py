"""numba kernel of the sense-a-tag's many-positions receive chain (wrapped and documented in
:func:`rfsim.devices.sense_a_tag.chain_rows`; its NumPy/SciPy twin is
:func:`reference.devices_sense_a_tag.chain_rows_reference` in the tests).
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.devices._st_receiver_kernels import comparator_kernel, i0e_kernel, section_step
from rfsim.core._jit import njit, njit_inline


@njit_inline
def _diode_output(x_abs, v_per_sqrt_w, matching_gain, nvt, x, y, out):
    """The diode law's output ``u = (ln i0e(x) + x)·nvt`` [V] of one row ``x_abs`` (n,) [√W] into
    ``out``, with ``x = (G_v·v_per_sqrt_w·|x|)/nvt`` (``x``, ``y``: (n,) work arrays)."""
    for t in range(x_abs.size):
        x[t] = (matching_gain * (v_per_sqrt_w * x_abs[t])) / nvt
    i0e_kernel(x, y)
    for t in range(x_abs.size):
        out[t] = (math.log(y[t]) + x[t]) * nvt


@njit
def diode_chain_rows_kernel(x_abs, v_per_sqrt_w, matching_gain, nvt, a, sos, zi, v_high, v_low, env, bp, cmp,
                            tog):
    """Diode detector, RC, band-pass and comparator of every row of ``x_abs`` (r, n) [√W].

    Per row: the RF peak ``V = v_per_sqrt_w·|x|`` [V], the diode law's argument
    ``x = (G_v·V)/nvt`` (nvt = n·V_T [V]) and output ``u = (ln i0e(x) + x)·nvt`` [V] (the steps
    of :meth:`rfsim.devices.st_receiver.EnvelopeDetector.transfer_v`); the RC
    ``env[t] = env[t−1]·(1 − a) + a·u[t]`` from ``env[−1] = u[0]`` (in the operation order of
    SciPy's ``lfilter``: state ``(1 − a)·y``, output ``state + a·u``); the second-order
    sections ``sos`` (s, 6) from the state ``zi`` (s, 2) times ``env[0]`` (SciPy's
    ``sosfilt`` recursion); the hysteresis comparator from −1 (``toggles`` into ``tog``).

    Rows go two at a time through the recursions (RC with the first section, then each further
    section over the whole rows), their states in registers: the two rows' dependency chains
    (≈ 16 cycles a sample for one section) interleave. Each row's operations and their order
    are those of one row alone, so the results are equal bit for bit; with an odd row count
    the last pair is that row twice.
    """
    r, n = x_abs.shape
    n_sec = sos.shape[0]
    x = np.empty(n)
    y = np.empty(n)
    b = 1.0 - a
    for i in range(0, r, 2):
        j = min(i + 1, r - 1)
        _diode_output(x_abs[i], v_per_sqrt_w, matching_gain, nvt, x, y, env[i])
        _diode_output(x_abs[j], v_per_sqrt_w, matching_gain, nvt, x, y, env[j])
        # RC (env holds u until overwritten) and the first section
        ui = env[i, 0]
        uj = env[j, 0]
        si = b * ui
        sj = b * uj
        ei = si + a * ui
        ej = sj + a * uj
        zi0, zi1, zj0, zj1 = zi[0, 0] * ei, zi[0, 1] * ei, zi[0, 0] * ej, zi[0, 1] * ej
        for t in range(n):
            ei = si + a * env[i, t]
            ej = sj + a * env[j, t]
            si = ei * b
            sj = ej * b
            env[i, t] = ei
            env[j, t] = ej
            bp[i, t], zi0, zi1 = section_step(sos, 0, ei, zi0, zi1)
            bp[j, t], zj0, zj1 = section_step(sos, 0, ej, zj0, zj1)
        # further sections, in place, from the steady state times the first envelope sample
        for s in range(1, n_sec):
            zi0, zi1, zj0, zj1 = zi[s, 0] * env[i, 0], zi[s, 1] * env[i, 0], zi[s, 0] * env[j, 0], zi[s, 1] * env[j, 0]
            for t in range(n):
                vi = bp[i, t]
                vj = bp[j, t]
                bp[i, t], zi0, zi1 = section_step(sos, s, vi, zi0, zi1)
                bp[j, t], zj0, zj1 = section_step(sos, s, vj, zj0, zj1)
        _, tog[i] = comparator_kernel(bp[i], v_high, v_low, -1, cmp[i])
        _, tog[j] = comparator_kernel(bp[j], v_high, v_low, -1, cmp[j])

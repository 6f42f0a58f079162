"""numba kernel of the sense-a-tag's many-positions receive chain (wrapped and documented in
:func:`rfsim.devices.sense_a_tag.chain_rows`; its NumPy/SciPy twin is
:func:`reference.devices_sense_a_tag.chain_rows_reference` in the tests).
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.devices._st_receiver_kernels import comparator_kernel, i0e_kernel, sos_sample
from rfsim.core._jit import njit


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
    """
    r, n = x_abs.shape
    n_sec = sos.shape[0]
    x = np.empty(n)
    y = np.empty(n)
    z = np.empty((n_sec, 2))
    b = 1.0 - a
    for i in range(r):
        for t in range(n):
            x[t] = (matching_gain * (v_per_sqrt_w * x_abs[i, t])) / nvt
        i0e_kernel(x, y)
        state = 0.0
        for t in range(n):
            u = (math.log(y[t]) + x[t]) * nvt
            if t == 0:
                state = b * u
                for s in range(n_sec):
                    z[s, 0] = zi[s, 0] * (state + a * u)
                    z[s, 1] = zi[s, 1] * (state + a * u)
            e = state + a * u
            state = e * b
            env[i, t] = e
            bp[i, t] = sos_sample(sos, z, e)
        _, tog[i] = comparator_kernel(bp[i], v_high, v_low, -1, cmp[i])

"""numba kernels of the dual-antenna sense-a-tag (wrapped and documented in
:func:`rfsim.devices.st_pair.couple_ports` and :func:`rfsim.devices.st_pair.ask_stamp_transitions`;
their NumPy twins are the tests' ``couple_ports_reference`` and ``ask_stamp_transitions_reference``).
"""

from __future__ import annotations

import numpy as np

from rfsim.devices._st_receiver_kernels import comparator_kernel
from rfsim.core._jit import njit


@njit
def couple_ports_kernel(mix, x, out):
    """``out[a, i, t] = mix[i, 0]·x[a, 0, t] + mix[i, 1]·x[a, 1, t]`` for complex128 ``x``,
    ``out`` (N, 2, n) and ``mix`` (2, 2): the two products added in turn to a sum started at
    +0 (the operations of ``np.einsum("ij,nj...->ni...", mix, x)``; +0 makes a zero sum +0)."""
    n_pos, k, n = x.shape
    for a in range(n_pos):
        for i in range(k):
            m0 = mix[i, 0]
            m1 = mix[i, 1]
            for t in range(n):
                acc = 0j
                acc += m0 * x[a, 0, t]
                acc += m1 * x[a, 1, t]
                out[a, i, t] = acc


@njit
def comparator_changes_rows_kernel(v, v_high, v_low, skip, out):
    """Per row of ``v`` (r, n): the hysteresis comparator from −1
    (:func:`rfsim.devices._st_receiver_kernels.comparator_kernel`, levels ``v_high``/``v_low``) and
    the number of changes of its output after sample ``skip``, ``out[i] = Σ_{t > skip}
    [c[t] ≠ c[t−1]]`` (``count_nonzero(diff(c[skip:]))``)."""
    r, n = v.shape
    c = np.empty(n)
    for i in range(r):
        comparator_kernel(v[i], v_high, v_low, -1, c)
        k = 0
        for t in range(skip + 1, n):
            if c[t] != c[t - 1]:
                k += 1
        out[i] = k

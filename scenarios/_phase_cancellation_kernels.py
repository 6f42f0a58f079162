"""numba kernel of the phase-cancellation scenario (wrapped and documented in
:func:`scenarios.phase_cancellation.couple_ports`; its NumPy twin there is
:func:`scenarios.phase_cancellation.couple_ports_reference`).
"""

from __future__ import annotations

from rfsim._jit import njit


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

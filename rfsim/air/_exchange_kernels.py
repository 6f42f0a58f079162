"""numba kernel of the compiled exchange strategy (:attr:`rfsim.air.cache.Strategy.exchange`).

A receiver of a static narrowband exchange (one emitter x, its own constant coupling or direct
link c, one modulating reflector with forward and backward link constants g and b and
re-radiation r(t) = A_s − Γ(t)) gets

    y(t) = c·x(t) + b·((A_s − Γ(t))·(g·x(t))) + n(t)    [√W],

the noise n only on the samples it reads (from ``start`` on). The kernel forms the sum with
:func:`rfsim.air._step_kernels.cmul` (the products of the fused backscatter kernel) and adds the
counter-based noise of :func:`rfsim.air._counter_noise_kernels.normal_pair` (pair i for sample
i, the stream of :func:`rfsim.air.noise.add_counter_awgn`) in the same pass: the same
operations in the same order as those two kernels one after the other, so the result is the
same to the bit (tests/test_air_exchange.py).
"""

from __future__ import annotations

import numpy as np

from rfsim.core._jit import njit_vector
from rfsim.air._step_kernels import cmul
from rfsim.air._counter_noise_kernels import normal_pair


@njit_vector
def backscatter_noise_kernel(x, c, g, a_s, gamma, b, key, start, scale, out):
    """out[i] = c·x[i] + b·((a_s − gamma[i])·(g·x[i])), plus scale·(a + j·b') from the normal
    pair i of the stream ``key`` (uint64) for i ≥ ``start`` (module docstring); ``out`` (n,)
    complex128."""
    n0 = min(max(start, 0), out.size)
    for i in range(n0):
        xi = x[i]
        out[i] = cmul(c, xi) + cmul(b, cmul(a_s - gamma[i], cmul(g, xi)))
    for i in range(n0, out.size):  # the samples read: the sum and its noise in one pass
        xi = x[i]
        v = cmul(c, xi) + cmul(b, cmul(a_s - gamma[i], cmul(g, xi)))
        na, nb = normal_pair(key, np.uint64(i))
        out[i] = complex(v.real + scale * na, v.imag + scale * nb)

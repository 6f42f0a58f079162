"""numba kernels of the sense-a-tag receive chain (wrapped and documented in
:mod:`rfsim.devices.st_receiver`; NumPy twins in the tests' ``reference.devices_st_receiver``).
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.core._jit import njit, njit_inline


@njit
def rc_lowpass_kernel(u, a, y0, out):
    """First-order RC low-pass ``y[n] = y[n−1] + a·(u[n] − y[n−1])``; returns the last y."""
    y = y0
    for n in range(u.size):
        y += a * (u[n] - y)
        out[n] = y
    return y


@njit
def comparator_kernel(v, v_high, v_low, state0, out):
    """Hysteresis comparator: goes to +1 above ``v_high``, to −1 below ``v_low``, else holds.

    Fills ``out`` with ±1.0 and returns ``(last state, number of toggles)``.
    """
    state = state0
    toggles = 0
    for n in range(v.size):
        if state < 0 and v[n] > v_high:
            state = 1
            toggles += 1
        elif state > 0 and v[n] < v_low:
            state = -1
            toggles += 1
        out[n] = state
    return state, toggles


#: Chebyshev coefficients of exp(−x)·I0(x) on [0, 8] (Cephes ``i0.c``, S. L. Moshier; the
#: tables of scipy.special.i0e and numpy.i0), first coefficient first.
I0E_A = np.array([
    -4.41534164647933937950E-18, 3.33079451882223809783E-17, -2.43127984654795469359E-16,
    1.71539128555513303061E-15, -1.16853328779934516808E-14, 7.67618549860493561688E-14,
    -4.85644678311192946090E-13, 2.95505266312963983461E-12, -1.72682629144155570723E-11,
    9.67580903537323691224E-11, -5.18979560163526290666E-10, 2.65982372468238665035E-9,
    -1.30002500998624804212E-8, 6.04699502254191894932E-8, -2.67079385394061173391E-7,
    1.11738753912010371815E-6, -4.41673835845875056359E-6, 1.64484480707288970893E-5,
    -5.75419501008210370398E-5, 1.88502885095841655729E-4, -5.76375574538582365885E-4,
    1.63947561694133579842E-3, -4.32430999505057594430E-3, 1.05464603945949983183E-2,
    -2.37374148058994688156E-2, 4.93052842396707084878E-2, -9.49010970480476444210E-2,
    1.71620901522208775349E-1, -3.04682672343198398683E-1, 6.76795274409476084995E-1])
#: Chebyshev coefficients of exp(−x)·sqrt(x)·I0(x) in 8/x on (8, ∞) (Cephes ``i0.c``).
I0E_B = np.array([
    -7.23318048787475395456E-18, -4.83050448594418207126E-18, 4.46562142029675999901E-17,
    3.46122286769746109310E-17, -2.82762398051658348494E-16, -3.42548561967721913462E-16,
    1.77256013305652638360E-15, 3.81168066935262242075E-15, -9.55484669882830764870E-15,
    -4.15056934728722208663E-14, 1.54008621752140982691E-14, 3.85277838274214270114E-13,
    7.18012445138366623367E-13, -1.79417853150680611778E-12, -1.32158118404477131188E-11,
    -3.14991652796324136454E-11, 1.18891471078464383424E-11, 4.94060238822496958910E-10,
    3.39623202570838634515E-9, 2.26666899049817806459E-8, 2.04891858946906374183E-7,
    2.89137052083475648297E-6, 6.88975834691682398426E-5, 3.36911647825569408990E-3,
    8.04490411014108831608E-1])


#: Samples per block of :func:`i0e_kernel` (its work arrays stay in the L1 cache)
I0E_BLOCK = 256


@njit_inline
def clenshaw_pairs(c, stop, y, p, q, count):
    """The first Clenshaw steps of the Chebyshev series ``c`` over ``count`` samples at once:
    b0 = c[0], b1 = b2 = 0, then two steps b0 ← y·b1 − b2 + c[i] per pass for i in [1, ``stop``)
    (``stop`` odd), leaving b1 in ``p`` and b2 in ``q`` for the caller's last step(s); ``y``,
    ``p``, ``q`` are (≥ count,) work arrays (Cephes ``chbevl``, in its operation order)."""
    for j in range(count):
        p[j] = c[0]
        q[j] = 0.0
    for i in range(1, stop, 2):
        ci = c[i]
        di = c[i + 1]
        for j in range(count):
            b = y[j] * p[j] - q[j] + ci
            p[j] = y[j] * b - p[j] + di
            q[j] = b


@njit
def i0e_kernel(x, out):
    """``out[n] = exp(−|x|)·I0(x)`` for ``x`` (n,) float64: Cephes ``i0e``, the Clenshaw sum
    (``chbevl``: b0 = c[0], then b0 ← y·b1 − b2 + c[i], result (b0 − b2)/2) of :data:`I0E_A` at
    ``|x|/2 − 2`` for |x| ≤ 8, else of :data:`I0E_B` at ``32/|x| − 2`` divided by sqrt|x| — the
    operations in the order of scipy.special.i0e, so the results are equal.

    Block by block (:data:`I0E_BLOCK` samples): the samples of each series are gathered and
    each series runs over its samples at once, one coefficient at a time (independent
    samples: SIMD, no latency chain), the divisions as ufuncs (no zero check: the (8, ∞)
    argument is > 8 or NaN). About 1.7× faster than one sample at a time."""
    n = x.size
    w = np.empty(I0E_BLOCK)
    y = np.empty(I0E_BLOCK)
    p = np.empty(I0E_BLOCK)
    q = np.empty(I0E_BLOCK)
    r = np.empty(I0E_BLOCK)
    big = np.empty(I0E_BLOCK, dtype=np.int64)
    small = np.empty(I0E_BLOCK, dtype=np.int64)
    for s in range(0, n, I0E_BLOCK):
        m = min(I0E_BLOCK, n - s)
        n_big = 0
        n_small = 0
        for j in range(m):
            v = abs(x[s + j])
            if v <= 8.0:
                small[n_small] = j
                n_small += 1
            else:
                big[n_big] = j
                w[n_big] = v
                n_big += 1
        # (8, ∞): b0 = c[0], b1 = b2 = 0; two steps b0 ← y·b1 − b2 + c[i] per pass (p = b1, q = b2)
        np.divide(32.0, w[:n_big], y[:n_big])
        for j in range(n_big):
            y[j] = y[j] - 2.0
        clenshaw_pairs(I0E_B, 23, y, p, q, n_big)
        c = I0E_B[23]
        d = I0E_B[24]
        for j in range(n_big):
            b = y[j] * p[j] - q[j] + c
            p[j] = 0.5 * ((y[j] * b - p[j] + d) - p[j])
            w[j] = math.sqrt(w[j])
        np.divide(p[:n_big], w[:n_big], r[:n_big])
        for j in range(n_big):
            out[s + big[j]] = r[j]
        # [0, 8]: 29 steps, the same way
        for j in range(n_small):
            y[j] = abs(x[s + small[j]]) / 2.0 - 2.0
        clenshaw_pairs(I0E_A, 29, y, p, q, n_small)
        c = I0E_A[29]
        for j in range(n_small):
            out[s + small[j]] = 0.5 * ((y[j] * p[j] - q[j] + c) - q[j])


@njit_inline
def section_step(sos, s, x, z0, z1):
    """One input sample ``x`` through the second-order section ``sos[s]`` (6,) in direct form II
    transposed (the recursion of ``scipy.signal.sosfilt``, in its operation order) from the
    state ``(z0, z1)``; returns ``(output, new z0, new z1)``."""
    y = sos[s, 0] * x + z0
    return y, sos[s, 1] * x - sos[s, 4] * y + z1, sos[s, 2] * x - sos[s, 5] * y


@njit_inline
def sos_sample(sos, z, x):
    """One input sample ``x`` through the second-order sections ``sos`` (s, 6)
    (:func:`section_step` each), the states ``z`` (s, 2) updated in place; returns the output
    sample."""
    for s in range(sos.shape[0]):
        x, z[s, 0], z[s, 1] = section_step(sos, s, x, z[s, 0], z[s, 1])
    return x


@njit
def chain_rows_kernel(u, rc_b0, rc_a1, sos, sos_zi, v_high, v_low, env, bp, cmp, toggles):
    """RC low-pass, band-pass and hysteresis comparator of every row of ``u`` (r, n) in one
    pass (the detector output before the RC, [V]).

    RC: the first-order recursion ``y[n] = b0·u[n] + z``, ``z ← 0·u[n] − a1·y[n]`` (direct
    form II transposed, the operations of ``scipy.signal.lfilter([b0], [1, a1])``), started
    from ``z = −a1·u[0]`` (the steady state of the first sample). Band-pass: the cascade
    of second-order sections ``sos`` (s, 6) in direct form II transposed, the operations of
    ``scipy.signal.sosfilt``, started from ``sos_zi·env[0]`` (the steady state,
    ``sosfilt_zi`` (s, 2)). Comparator: :func:`comparator_kernel` from −1. Fills ``env``,
    ``bp``, ``cmp`` (r, n) and ``toggles`` (r,)."""
    n_sections = sos.shape[0]
    z = np.empty((n_sections, 2))
    for r in range(u.shape[0]):
        w = -rc_a1 * u[r, 0]
        for n in range(u.shape[1]):
            x = u[r, n]
            y = w + rc_b0 * x
            w = x * 0.0 - y * rc_a1
            env[r, n] = y
        e0 = env[r, 0]
        for s in range(n_sections):
            z[s, 0] = sos_zi[s, 0] * e0
            z[s, 1] = sos_zi[s, 1] * e0
        for n in range(u.shape[1]):
            bp[r, n] = sos_sample(sos, z, env[r, n])
        _, toggles[r] = comparator_kernel(bp[r], v_high, v_low, -1, cmp[r])

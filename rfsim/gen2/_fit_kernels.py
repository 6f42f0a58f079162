"""numba kernel of the least-squares gain and offset of a known reference,
:func:`rfsim.gen2.capture.fit_gain_offset` (wrapped and documented there; the NumPy twin is
``reference.gen2_capture.fit_gain_offset_reference`` in the tests), also called by the reader's
receiver (``rfsim.gen2._receive_kernels``)."""

from __future__ import annotations

from rfsim.core._jit import njit
from rfsim.gen2._reply_kernels import _ls_gain_offset


@njit
def fit_gain_offset_kernel(r, s):
    """Least squares of r ≈ h·s + c over r, s ((n,) complex128, (n,) float64): the sums
    Σs², Σs, Σr·s, Σr (sample by sample, in order) and the closed form of the 2×2 normal
    equations. Returns ``(h, c, ok)``, ok False (h = c = 0) when s is constant."""
    r1 = 0j
    rs = 0j
    s1 = 0.0
    ss = 0.0
    for i in range(s.size):
        v = s[i]
        z = r[i]
        r1 += z
        rs += z * v
        s1 += v
        ss += v * v
    return _ls_gain_offset(ss, s1, float(s.size), rs, r1)

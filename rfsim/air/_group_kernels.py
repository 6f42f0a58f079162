"""numba kernel of a tag population's held constant at a receiver (:func:`rfsim.air.groups.masked_sum`;
its reference is the left-to-right Python sum, tests/test_fast_paths.py)."""

from __future__ import annotations

from rfsim.core._jit import njit


@njit
def masked_sum_kernel(start, values, use):
    """``start + values[i0] + values[i1] + …`` strictly left to right over the ``i`` where
    ``use[i]`` (complex additions, each the IEEE sums of the real and of the imaginary parts,
    as ``numpy.add.accumulate`` and Python form them); returns ``(count of i, sum)``."""
    acc = start
    n = 0
    for i in range(values.size):
        if use[i]:
            acc += values[i]
            n += 1
    return n, acc

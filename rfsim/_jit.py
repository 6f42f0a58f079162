"""The one numba policy of rfsim.

Every compiled kernel is declared with :data:`njit` from here, so the caching and
fastmath choices live in one place. Kernels are plain loops over preallocated
arrays; the validating, allocating wrapper lives next to them in a public module,
and each kernel has a plain-NumPy reference used by the tests.
"""

from __future__ import annotations

import numba

#: ``@njit`` with on-disk caching; no fastmath, so results are bit-reproducible.
njit = numba.njit(cache=True, nogil=True)

__all__ = ["njit"]

"""Reference of :func:`rfsim.gen2._generator_words_kernels.draw_words_kernel`: each word drawn
through its generator's own public method, one Python call per draw."""

from __future__ import annotations

import numpy as np


def draw_words_reference(rngs, index) -> np.ndarray:
    """``rngs[i].integers(0, 2**32, dtype=np.uint32)`` for i in ``index``, in order, as int64."""
    return np.array([int(rngs[i].integers(0, 1 << 32, dtype=np.uint32)) for i in index], dtype=np.int64)

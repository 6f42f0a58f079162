"""32-bit words drawn from many NumPy generators at once: a population's slot-counter draws.

On a QueryAdjust every tag of the round loads a new slot counter from its own generator
(:func:`rfsim.gen2.tag_draws.slot_draw`: the top Q bits of one 32-bit word of the tag's bit
generator). :class:`GeneratorWords` draws those words for any subset of the tags in one
compiled loop (:mod:`rfsim.gen2._generator_words_kernels`: each generator's own C
``next_uint32``), so the cost of a redraw does not grow by a Python call per tag. Each
generator ends in the same state, and gives the same word, as ``rng.integers(0, 2**32,
dtype=np.uint32)`` would (tested); the slot counters are then :func:`rfsim.gen2.tag_draws._top_bits`
of those words, the one rule.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence

import numpy as np

from rfsim.core.lazy import lazy_import

_kernels = lazy_import("rfsim.gen2._generator_words_kernels")


def _addresses(rng) -> tuple[int, int] | None:
    """``(address of next_uint32, address of the state)`` of a generator's bit generator, or
    None when it has no C interface."""
    ct = getattr(getattr(rng, "bit_generator", None), "ctypes", None)
    if ct is None:
        return None
    return ctypes.cast(ct.next_uint32, ctypes.c_void_p).value, int(ct.state_address)


class GeneratorWords:
    """Draw 32-bit words from many generators, each from its own.

    Parameters
    ----------
    rngs : sequence of numpy.random.Generator
        The generators (kept alive here: their C states are addressed while this object
        lives).

    Attributes
    ----------
    usable : bool
        Every generator has NumPy's C interface (``bit_generator.ctypes``); otherwise
        :meth:`draw` raises and the caller draws through each generator.
    """

    def __init__(self, rngs: Sequence):
        self.rngs = list(rngs)
        found = [_addresses(r) for r in self.rngs]
        self.usable = None not in found
        self._functions = np.array([f for f, _ in found] if self.usable else [], dtype=np.intp)
        self._states = np.array([s for _, s in found] if self.usable else [], dtype=np.intp)

    def __len__(self) -> int:
        return len(self.rngs)

    def draw(self, index) -> np.ndarray:
        """Draw one 32-bit word from each generator of ``index``, in that order.

        Parameters
        ----------
        index : array_like of int, shape (m,)
            Generators to draw from (0 ≤ i < len(self)); a generator listed twice draws twice,
            in order.

        Returns
        -------
        numpy.ndarray, shape (m,), int64
            The words, 0 ≤ w < 2^32: ``rngs[index[k]].integers(0, 2**32, dtype=np.uint32)``.

        Raises
        ------
        ValueError
            When not every generator has NumPy's C interface (:attr:`usable`), or an index is
            out of range.
        """
        if not self.usable:
            raise ValueError("a generator without NumPy's C interface (bit_generator.ctypes): draw through it")
        idx = np.ascontiguousarray(index, dtype=np.intp)
        if idx.size and (idx.min() < 0 or idx.max() >= len(self.rngs)):
            raise ValueError(f"generator index out of range 0..{len(self.rngs) - 1}")
        out = np.empty(idx.size, dtype=np.uint32)
        if idx.size:
            _kernels.draw_words_kernel(self._functions, self._states, idx, out)
        return out.astype(np.int64)


__all__ = ["GeneratorWords"]

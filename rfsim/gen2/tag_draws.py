"""The tag's random draws: slot counters (Q bits) and RN16s (handles, Req_RN replies), from the
tag's own generator. One definition used by the tag state machine
(:mod:`rfsim.devices.gen2_tag_state`), a population's arrays and the access commands
(:mod:`rfsim.gen2.access`).
"""

from __future__ import annotations

import numpy as np


def slot_draw(rng: np.random.Generator, q: int) -> int:
    """Draw a slot counter uniform in [0, 2^Q − 1], the number ``rng.integers(0, 2**q)`` returns.

    For a power-of-two range numpy's bounded draw (Lemire's multiply-shift) never rejects:
    it returns the top Q bits of one 32-bit word of the bit generator, ``next_uint32 >> (32
    − Q)``, and Q = 0 draws nothing. The word is read here through the bit generator's
    ctypes interface — the same word, the same generator state afterwards (tested against
    ``integers``), without the method's argument handling (a fifth of its cost; an inventory
    draws a counter per tag on every QueryAdjust), and without the generator's lock (a tag's
    generator is its own, used by one thread). A generator without that interface is asked
    through ``integers``.

    Parameters
    ----------
    rng : numpy.random.Generator
        The tag's own generator (advanced by one 32-bit word when Q > 0).
    q : int
        Q, 0–16 (16 draws an RN16).

    Returns
    -------
    int
        The slot counter, 0 ≤ slot < 2^Q (0 without a draw when Q ≤ 0).
    """
    if q <= 0:
        return 0
    ct = getattr(getattr(rng, "bit_generator", None), "ctypes", None)
    if ct is None:
        return int(rng.integers(0, 1 << q))
    return _top_bits(ct.next_uint32(ct.state), q)


def _top_bits(word: int, q: int) -> int:
    """The top Q bits of a 32-bit word: the slot counter numpy's bounded draw makes of it."""
    return word >> (32 - q)


def _slot_drawer(rng):
    """``q → slot_draw(rng, q)`` with the bit generator's ctypes interface looked up once."""
    ct = getattr(getattr(rng, "bit_generator", None), "ctypes", None)
    if ct is None:
        return lambda q: slot_draw(rng, q)
    word, state = ct.next_uint32, ct.state
    return lambda q: _top_bits(word(state), q) if q > 0 else 0


def draw_rn16(rng: np.random.Generator) -> int:
    """Draw a 16-bit random number (an RN16 or handle), ``rng.integers(0, 2**16)``.

    :func:`slot_draw` with Q = 16 (EPC Gen2: a tag's RN16s and handles are 16-bit random
    numbers).

    Parameters
    ----------
    rng : numpy.random.Generator
        The tag's own generator (advanced by one 32-bit word).

    Returns
    -------
    int
        0 ≤ RN16 < 2^16.
    """
    return slot_draw(rng, 16)


__all__ = ["slot_draw", "draw_rn16"]

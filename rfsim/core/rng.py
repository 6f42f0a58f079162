"""Reproducible randomness: one ``SeedSequence`` per run, one child per trial.

Every stochastic function in rfsim takes ``rng: numpy.random.Generator`` as a
keyword argument. A run owns one :class:`numpy.random.SeedSequence` built from its
integer seed; trial *i* (or sweep point *i*) uses the generator of the child
``SeedSequence(entropy=seed, spawn_key=(i,))`` — exactly what ``SeedSequence.spawn``
would hand out as its i-th child — so a trial's stream depends only on (seed, i),
never on which worker, process or machine ran it, nor on how many ran before.
There is no global RNG and no clock seeding anywhere in rfsim.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rfsim.core.memo import PureCache


def _checked_seed(seed: int) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def run_seed_sequence(seed: int) -> np.random.SeedSequence:
    """Root ``SeedSequence`` of a run.

    Parameters
    ----------
    seed : int
        The run's seed, ≥ 0.

    Returns
    -------
    numpy.random.SeedSequence
        ``SeedSequence(seed)``.

    Raises
    ------
    ValueError
        If ``seed`` is not a non-negative integer (bool included).
    """
    return np.random.SeedSequence(_checked_seed(seed))


def trial_seed_sequence(seed: int, *index: int) -> np.random.SeedSequence:
    """Child ``SeedSequence`` of a trial of a run.

    ``trial_seed_sequence(s, i)`` equals ``SeedSequence(s).spawn(i + 1)[i]``; nested paths
    (``(point, repetition)``) key sub-streams of a trial.

    Parameters
    ----------
    seed : int
        The run's seed, ≥ 0.
    *index : int
        The trial's path of non-negative indices (the ``spawn_key``).

    Returns
    -------
    numpy.random.SeedSequence
        ``SeedSequence(seed, spawn_key=index)``.

    Raises
    ------
    ValueError
        If ``seed`` or an index is negative or ``seed`` is not an integer.
    """
    entropy = _checked_seed(seed)  # the root's entropy; its spawn key is ()
    key = tuple(int(i) for i in index)
    if any(i < 0 for i in key):
        raise ValueError(f"trial index must be non-negative, got {index!r}")
    return np.random.SeedSequence(entropy, spawn_key=key)


def trial_rng(seed: int, *index: int) -> np.random.Generator:
    """Generator of a trial of a run.

    Parameters
    ----------
    seed : int
        The run's seed, ≥ 0.
    *index : int
        The trial's path of non-negative indices (:func:`trial_seed_sequence`).

    Returns
    -------
    numpy.random.Generator
        A PCG64 generator seeded as by :func:`trial_seed_sequence` (its seed words formed in
        Python integers, the run's part of the pool remembered: :func:`_seed_words`; it spawns
        as that SeedSequence does).

    Raises
    ------
    ValueError
        If ``seed`` or an index is negative or ``seed`` is not an integer.
    """
    entropy = _checked_seed(seed)
    key = tuple(int(i) for i in index)
    if any(i < 0 for i in key):
        raise ValueError(f"trial index must be non-negative, got {index!r}")
    return np.random.Generator(np.random.PCG64(_SeedWords(_seed_words(entropy, key), entropy, key)))


def trial_rngs(seed: int, indices: Sequence[int]) -> list[np.random.Generator]:
    """Generators for several trial indices of one run.

    Parameters
    ----------
    seed : int
        The run's seed, ≥ 0.
    indices : sequence of int
        Non-negative trial indices.

    Returns
    -------
    list of numpy.random.Generator
        ``trial_rng(seed, i)`` for each ``i`` in ``indices``, in order.
    """
    return [trial_rng(seed, i) for i in indices]


def trial_rng_grid(seed: int, indices: Sequence[int], streams: Sequence[int]) -> list[list[np.random.Generator]]:
    """Generators ``[[trial_rng(seed, i, k) for k in streams] for i in indices]``, seeded at once.

    The same generators (the same states, draw for draw) as :func:`trial_rng`, their seeds
    formed for all of them at once. A PCG64 is seeded with
    ``SeedSequence(seed, spawn_key=(i, k)).generate_state(4, uint64)``; :func:`_pcg64_seed_words`
    evaluates NumPy's SeedSequence (hash mixing of the entropy words into a pool of 4, then
    the pool hashed into the output words; O'Neill's seed_seq design) with one NumPy operation
    per step over every (i, k), instead of one SeedSequence object each (≈ 25 µs per
    generator); the tests compare the states with :func:`trial_rng`'s. Indices and streams of
    2³² or more take the one-by-one path.

    Parameters
    ----------
    seed : int
        The run's seed, ≥ 0.
    indices : sequence of int
        Non-negative trial indices (rows of the result).
    streams : sequence of int
        Non-negative stream indices within each trial (columns of the result).

    Returns
    -------
    list of list of numpy.random.Generator
        ``len(indices)`` lists of ``len(streams)`` PCG64 generators.

    Raises
    ------
    ValueError
        If ``seed`` or an index is negative or ``seed`` is not an integer.
    """
    entropy = _checked_seed(seed)
    keys = [(int(i), int(k)) for i in indices for k in streams]
    if any(i < 0 or k < 0 for i, k in keys):
        raise ValueError(f"trial index must be non-negative, got {min(min(key) for key in keys)}")
    n_streams = len(streams)
    if not keys:
        return [[] for _ in indices]
    if max(max(key) for key in keys) >= 2 ** 32:
        return [[trial_rng(seed, int(i), int(k)) for k in streams] for i in indices]
    run_words = _uint32_words(entropy)
    run_words = run_words + [0] * max(_POOL_SIZE - len(run_words), 0)
    entropy_words = np.empty((len(keys), len(run_words) + 2), dtype=np.uint32)
    entropy_words[:, :len(run_words)] = run_words
    entropy_words[:, len(run_words):] = keys
    words = _pcg64_seed_words(entropy_words)
    gens = [np.random.Generator(np.random.PCG64(_SeedWords(w, entropy, key))) for w, key in zip(words, keys)]
    return [gens[j:j + n_streams] for j in range(0, len(gens), n_streams)]


# NumPy's SeedSequence constants (numpy/random/bit_generator.pyx; M. E. O'Neill's seed_seq)
_POOL_SIZE = 4
_INIT_A, _MULT_A = 0x43B0D7E5, 0x931E8875
_INIT_B, _MULT_B = 0x8B51F9DD, 0x58F38DED
_MIX_MULT_L, _MIX_MULT_R = 0xCA01F9DD, 0x4973F715
_XSHIFT = 16
_MASK32 = 0xFFFFFFFF
#: The running constant of ``generate_state`` for its 8 output words: (h before, h after ·MULT_B).
_OUTPUT_HASH = tuple((_INIT_B * _MULT_B ** i & _MASK32, _INIT_B * _MULT_B ** (i + 1) & _MASK32) for i in range(8))


def _uint32_words(value: int) -> list[int]:
    """A non-negative int as 32-bit words, least significant first (0 → [0]), as SeedSequence
    splits its entropy."""
    words = []
    while True:
        words.append(value & _MASK32)
        value >>= 32
        if not value:
            return words


def _seed_words(entropy: int, spawn_key: tuple[int, ...]) -> np.ndarray:
    """``SeedSequence(entropy, spawn_key=spawn_key).generate_state(4, uint64)``, (4,) uint64, in
    Python integers: the entropy words assembled as SeedSequence assembles them (the run's words,
    padded to the pool size when there is a spawn key, then the key's words), the pool after all
    words but the last taken from :func:`_mixed_pool` (the same for every trial of a run's
    stream), the last word mixed in and the pool hashed into eight 32-bit output words (the
    operations of :func:`_pcg64_seed_words`, one sequence)."""
    run_words = [entropy] if entropy <= _MASK32 else _uint32_words(entropy)
    key_words = (list(spawn_key) if max(spawn_key, default=0) <= _MASK32  # one word each
                 else [w for i in spawn_key for w in _uint32_words(i)])
    if key_words and len(run_words) < _POOL_SIZE:
        run_words = run_words + [0] * (_POOL_SIZE - len(run_words))
    words = run_words + key_words
    if len(words) > _POOL_SIZE:
        pool, h = _mix_word(*MIXED_POOL_CACHE(tuple(words[:-1])), words[-1])
    else:
        pool, h = MIXED_POOL_CACHE(tuple(words))
    out = [v ^ (v >> _XSHIFT) for v in [((src ^ h_in) * h_out) & _MASK32
                                         for src, (h_in, h_out) in zip(pool + pool, _OUTPUT_HASH)]]
    # uint32 pairs as little-endian uint64 (SeedSequence's view)
    return np.array([out[0] | out[1] << 32, out[2] | out[3] << 32, out[4] | out[5] << 32, out[6] | out[7] << 32],
                    dtype=np.uint64)


def _mix_word(pool: tuple[int, ...], h: int, value: int) -> tuple[tuple[int, ...], int]:
    """The pool with one more entropy word mixed into every pool word, in order
    (``pool[i] = mix(pool[i], hashmix(value))``), and the running hash constant after it."""
    out = []
    for p in pool:
        h_next = (h * _MULT_A) & _MASK32
        v = ((value ^ h) * h_next) & _MASK32
        h = h_next
        r = (_MIX_MULT_L * p - _MIX_MULT_R * (v ^ (v >> _XSHIFT))) & _MASK32
        out.append(r ^ (r >> _XSHIFT))
    return tuple(out), h


def _mixed_pool(words: tuple[int, ...]) -> tuple[tuple[int, ...], int]:
    """SeedSequence's pool after the entropy words ``words`` (fewer than 4: the missing ones
    hash as 0), with the running hash constant h: the first four hashed and cross-mixed, every
    further word mixed in (:func:`_mix_word`). A pure function of the words (a run's seed and a
    trial's stream), the same for every trial of that stream."""
    if len(words) > _POOL_SIZE:
        return _mix_word(*MIXED_POOL_CACHE(words[:-1]), words[-1])
    h = _INIT_A
    pool = []
    for i in range(_POOL_SIZE):
        v = (words[i] if i < len(words) else 0) ^ h
        h = (h * _MULT_A) & _MASK32
        v = (v * h) & _MASK32
        pool.append(v ^ (v >> _XSHIFT))
    for i_src in range(_POOL_SIZE):
        for i_dst in range(_POOL_SIZE):
            if i_src != i_dst:
                v = pool[i_src] ^ h
                h = (h * _MULT_A) & _MASK32
                v = (v * h) & _MASK32
                v ^= v >> _XSHIFT
                r = (_MIX_MULT_L * pool[i_dst] - _MIX_MULT_R * v) & _MASK32
                pool[i_dst] = r ^ (r >> _XSHIFT)
    return tuple(pool), h


#: :func:`_mixed_pool` by its entropy words: a pure function of a seed and a stream (the same in
#: every run given them), not run state (:class:`rfsim.core.memo.PureCache`).
MIXED_POOL_CACHE = PureCache(_mixed_pool, 256)


def _pcg64_seed_words(entropy_words: np.ndarray) -> np.ndarray:
    """``SeedSequence.generate_state(4, uint64)`` of the assembled entropy words of many
    sequences (rows of ``entropy_words`` (n, m) uint32, pool size 4), (n, 4) uint64.

    ``hashmix(v) = ((v ⊕ h)·h') ⊕ ((v ⊕ h)·h' ≫ 16)`` with the running constant h (h' = h·MULT_A),
    ``mix(x, y) = (L·x − R·y) ⊕ ((L·x − R·y) ≫ 16)``, all mod 2³²; the constants' sequence is
    the same for every row, the rows are one array each step."""
    e = np.asarray(entropy_words, dtype=np.uint32)
    n, m = e.shape
    h = _INIT_A

    def hashmix(value):
        nonlocal h
        value = value ^ np.uint32(h)
        h = (h * _MULT_A) & _MASK32
        value = value * np.uint32(h)
        return value ^ (value >> np.uint32(_XSHIFT))

    def mix(x, y):
        r = np.uint32(_MIX_MULT_L) * x - np.uint32(_MIX_MULT_R) * y
        return r ^ (r >> np.uint32(_XSHIFT))

    pool = [hashmix(e[:, i] if i < m else np.zeros(n, np.uint32)) for i in range(_POOL_SIZE)]
    for i_src in range(_POOL_SIZE):
        for i_dst in range(_POOL_SIZE):
            if i_src != i_dst:
                pool[i_dst] = mix(pool[i_dst], hashmix(pool[i_src]))
    for i_src in range(_POOL_SIZE, m):
        for i_dst in range(_POOL_SIZE):
            pool[i_dst] = mix(pool[i_dst], hashmix(e[:, i_src]))
    out = np.empty((n, 8), dtype=np.uint32)
    h = _INIT_B
    for i_dst in range(8):
        v = pool[i_dst % _POOL_SIZE] ^ np.uint32(h)
        h = (h * _MULT_B) & _MASK32
        v = v * np.uint32(h)
        out[:, i_dst] = v ^ (v >> np.uint32(_XSHIFT))
    lo, hi = out[:, 0::2].astype(np.uint64), out[:, 1::2].astype(np.uint64)
    return lo | (hi << np.uint64(32))  # uint32 pairs as little-endian uint64 (SeedSequence's view)


class _SeedWords(np.random.bit_generator.ISpawnableSeedSequence):
    """The seed words of one PCG64, formed beforehand (:func:`trial_rng_grid`).

    It stands for ``SeedSequence(entropy, spawn_key=spawn_key)`` and spawns as that sequence
    would (children ``SeedSequence(entropy, spawn_key=spawn_key + (j,))``, counted from 0), so a
    generator of :func:`trial_rng_grid` spawns the same streams as :func:`trial_rng`'s.
    """

    def __init__(self, words: np.ndarray, entropy: int, spawn_key: tuple[int, ...]):
        self._words = words
        self.entropy = entropy
        self.spawn_key = spawn_key
        self.n_children_spawned = 0

    def generate_state(self, n_words, dtype=np.uint32):
        if n_words != 4 or np.dtype(dtype) != np.uint64:
            raise ValueError("only the 4 uint64 words a PCG64 asks for were formed")
        return self._words.copy()

    def spawn(self, n_children):
        first = self.n_children_spawned
        self.n_children_spawned += n_children
        return [np.random.SeedSequence(self.entropy, spawn_key=self.spawn_key + (j,))
                for j in range(first, first + n_children)]


__all__ = ["run_seed_sequence", "trial_seed_sequence", "trial_rng", "trial_rngs", "trial_rng_grid"]

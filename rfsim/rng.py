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


def run_seed_sequence(seed: int) -> np.random.SeedSequence:
    """The root ``SeedSequence`` of a run with integer ``seed`` (≥ 0)."""
    return np.random.SeedSequence(run_seed_sequence_entropy(seed))


def trial_seed_sequence(seed: int, *index: int) -> np.random.SeedSequence:
    """Child ``SeedSequence`` of trial ``index`` (a path of non-negative ints).

    ``trial_seed_sequence(s, i)`` equals ``SeedSequence(s).spawn(i + 1)[i]``;
    nested paths (``(point, repetition)``) key sub-streams of a trial.
    """
    key = tuple(int(i) for i in index)
    if any(i < 0 for i in key):
        raise ValueError(f"trial index must be non-negative, got {index!r}")
    # the root's entropy is the seed itself and its spawn key empty (run_seed_sequence), so
    # the child is made at once, without making the root first
    return np.random.SeedSequence(int(run_seed_sequence_entropy(seed)), spawn_key=key)


def run_seed_sequence_entropy(seed: int) -> int:
    """The entropy of :func:`run_seed_sequence` (``seed``, checked) without making the sequence."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def trial_rng(seed: int, *index: int) -> np.random.Generator:
    """``numpy.random.Generator`` (PCG64) of trial ``index`` of the run ``seed``."""
    return np.random.Generator(np.random.PCG64(trial_seed_sequence(seed, *index)))


def trial_rngs(seed: int, indices: Sequence[int]) -> list[np.random.Generator]:
    """Generators for several trial indices of one run."""
    return [trial_rng(seed, i) for i in indices]


__all__ = ["run_seed_sequence", "trial_seed_sequence", "trial_rng", "trial_rngs"]

"""One SeedSequence per run, one spawned child per trial; no global or clock seeding."""

from __future__ import annotations

import re

import numpy as np
import pytest

from rfsim.core.rng import trial_rng, trial_rng_grid, trial_seed_sequence

SOURCE_PACKAGES = ("rfsim", "channels", "devices", "scenarios")


def test_trial_streams_equal_spawned_children():
    children = np.random.SeedSequence(1234).spawn(10)
    for i in (0, 3, 9):
        ours = trial_rng(1234, i).random(5)
        ref = np.random.Generator(np.random.PCG64(children[i])).random(5)
        np.testing.assert_array_equal(ours, ref)


def test_streams_depend_only_on_seed_and_index():
    a = [trial_rng(5, i).integers(0, 2**63) for i in range(50)]
    b = [trial_rng(5, i).integers(0, 2**63) for i in reversed(range(50))][::-1]
    assert a == b
    assert len(set(a)) == 50
    assert trial_rng(5, 0).random() != trial_rng(6, 0).random()
    assert trial_seed_sequence(5, 2, 1).spawn_key == (2, 1)


@pytest.mark.parametrize("seed", [0, 1, 2**32 - 1, 2**32, 2**130 + 3])
@pytest.mark.parametrize("key", [(), (0,), (2, 17), (0, 0, 0), (3, 2**32 + 1), (2**64, 1, 2, 3), (1, 2, 3, 4, 5)])
def test_trial_rng_is_numpys_seed_sequence(seed, key):
    # the seed words formed in Python integers equal NumPy's SeedSequence for one- and
    # many-word seeds and keys (twice: the second call reads the remembered pool)
    for _ in range(2):
        ours = trial_rng(seed, *key)
        ref = np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=key)))
        assert ours.bit_generator.state == ref.bit_generator.state
        np.testing.assert_array_equal(ours.spawn(2)[1].integers(0, 2**62, 4), ref.spawn(2)[1].integers(0, 2**62, 4))


@pytest.mark.parametrize("bad", [-1, 1.5, "3", True])
def test_bad_seeds_are_rejected(bad):
    with pytest.raises(ValueError):
        trial_rng(bad, 0)


FORBIDDEN = [
    (r"np\.random\.seed|numpy\.random\.seed", "global numpy seeding"),
    (r"np\.random\.(rand|randn|randint|random|normal|uniform|choice|shuffle|permutation|"
     r"exponential|poisson|binomial|standard_normal)\(", "legacy global numpy RNG"),
    (r"RandomState\(", "legacy RandomState"),
    (r"default_rng\(\s*\)", "OS-entropy generator"),
    (r"SeedSequence\(\s*\)", "OS-entropy SeedSequence"),
    (r"^\s*(import random\b|from random import)", "stdlib random module"),
    (r"seed\w*\s*=\s*.*\b(time\.time|time\.perf_counter|time_ns|datetime\.now|os\.getpid|os\.urandom)",
     "clock/pid seeding"),
]


def test_no_global_or_clock_seeding_anywhere(project_root):
    files = [p for pkg in SOURCE_PACKAGES for p in (project_root / pkg).rglob("*.py")]
    assert len(files) >= 10, "the source tree was not found"
    offences = []
    for path in files:
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for pattern, what in FORBIDDEN:
                if re.search(pattern, line):
                    offences.append(f"{path.relative_to(project_root)}:{lineno}: {what}: {line.strip()}")
    assert not offences, "\n".join(offences)


@pytest.mark.parametrize("seed", [0, 1, 2**32 - 1, 2**32, 2**63 + 5])
def test_trial_rng_grid_gives_the_generators_of_trial_rng(seed):
    # reference: NumPy's own SeedSequence for every (trial, stream), one by one
    indices, streams = [0, 1, 7, 2**31, 2**32 - 1], [0, 3, 5, 40]
    grid = trial_rng_grid(seed, indices, streams)
    assert [len(row) for row in grid] == [len(streams)] * len(indices)
    for row, i in zip(grid, indices):
        for rng, k in zip(row, streams):
            ref = np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(i, k))))
            assert type(rng.bit_generator) is np.random.PCG64
            assert rng.bit_generator.state == ref.bit_generator.state
            np.testing.assert_array_equal(rng.standard_normal(20), ref.standard_normal(20))


def test_trial_rng_grid_large_indices_and_empty():
    big = trial_rng_grid(3, [2**33], [1])[0][0]
    assert big.bit_generator.state == trial_rng(3, 2**33, 1).bit_generator.state
    assert trial_rng_grid(3, [], [0, 1]) == []
    with pytest.raises(ValueError):
        trial_rng_grid(3, [-1], [0])


def test_grid_generators_spawn_the_streams_of_trial_rng():
    """A generator of trial_rng_grid spawns as SeedSequence(seed, spawn_key=(i, k)) does: the
    children's draws equal those of trial_rng(seed, i, k).spawn (the statistic receiver of a
    reader spawns its stream from the reader's generator)."""
    grid = trial_rng_grid(7, [0, 3], [1, 4])
    for row, i in zip(grid, [0, 3]):
        for gen, k in zip(row, [1, 4]):
            ref = trial_rng(7, i, k)
            for _ in range(2):  # two successive spawns continue the child count
                a, b = gen.spawn(2), ref.spawn(2)
                for x, y in zip(a, b):
                    assert np.array_equal(x.integers(0, 2**63, 8), y.integers(0, 2**63, 8))

"""Words from many generators at once (rfsim.gen2.generator_words) against each generator's own draws."""

from __future__ import annotations

import numpy as np
import pytest

from reference.gen2_generator_words import draw_words_reference
from rfsim.gen2.generator_words import GeneratorWords
from rfsim.gen2.tag_draws import _top_bits, slot_draw


def _same_state(a, b) -> bool:
    """Two bit-generator states (nested dicts, arrays for MT19937) are equal."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same_state(a[k], b[k]) for k in a)
    return bool(np.array_equal(a, b))


def _pair(n, seed=7, bit_generator=np.random.PCG64):
    """Two lists of n generators in the same states."""
    seeds = np.random.SeedSequence(seed).spawn(n)
    return ([np.random.Generator(bit_generator(s)) for s in seeds],
            [np.random.Generator(bit_generator(s)) for s in seeds])


@pytest.mark.parametrize("bit_generator", [np.random.PCG64, np.random.PCG64DXSM, np.random.MT19937,
                                           np.random.Philox, np.random.SFC64])
def test_words_equal_the_generators_own_draws_and_leave_the_same_states(bit_generator):
    """Subsets drawn in turn (some generators twice in a row, so PCG64's buffered half is
    used): the words and every generator's state afterwards equal one-by-one draws."""
    mine, ref = _pair(50, bit_generator=bit_generator)
    words = GeneratorWords(mine)
    assert words.usable
    for index in ([0, 1, 2], list(range(50)), [3, 3, 3, 49], list(range(0, 50, 7)), []):
        got = words.draw(index)
        assert got.dtype == np.int64 and got.shape == (len(index),)
        assert np.array_equal(got, draw_words_reference(ref, index))
    for a, b in zip(mine, ref):
        assert _same_state(a.bit_generator.state, b.bit_generator.state)


def test_top_bits_of_the_words_are_the_slot_draws():
    """The top Q bits of the words are the slot counters slot_draw gives (Q = 1..16), the
    generators then in the same states."""
    mine, ref = _pair(40, seed=3)
    words = GeneratorWords(mine)
    for q in range(1, 17):
        index = np.arange(40)[q % 3::2]
        got = _top_bits(words.draw(index), q)
        assert got.tolist() == [slot_draw(ref[i], q) for i in index.tolist()]
    for a, b in zip(mine, ref):
        assert _same_state(a.bit_generator.state, b.bit_generator.state)


def test_a_generator_without_c_interface_is_not_usable():
    class Plain:
        def integers(self, lo, hi):
            return 0

    words = GeneratorWords([np.random.default_rng(1), Plain()])
    assert not words.usable
    with pytest.raises(ValueError, match="C interface"):
        words.draw([0])


def test_an_index_out_of_range_raises():
    words = GeneratorWords([np.random.default_rng(1)])
    with pytest.raises(ValueError, match="out of range"):
        words.draw([1])
    with pytest.raises(ValueError, match="out of range"):
        words.draw([-1])

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


class _NoInterface:
    """A generator without NumPy's C interface (no ``bit_generator``): drawn through ``integers``."""

    def __init__(self, rng):
        self._rng = rng

    def integers(self, *args, **kw):
        return self._rng.integers(*args, **kw)


def test_redraws_over_arrays_equal_with_and_without_the_c_interface():
    """An inventory at protocol level over the tags' state arrays (QueryAdjusts redraw many
    tags at once): tags whose generators have NumPy's C interface (the words drawn in one
    loop) and the same tags whose generators lack it (each counter through its generator's
    ``integers``) give the same slots, reads and generator states."""
    from rfsim.core.rng import trial_rng
    from rfsim.devices.gen2_tag_arrays import StateArrays
    from rfsim.devices.gen2_tag_state import TagState
    from rfsim.gen2.link import profile
    from rfsim.protocols.inventory import InventoryConfig, ProtocolAir, run_inventory

    n = 60
    plain = [(TagState(f"{k + 1:024X}"), trial_rng(33, k)) for k in range(n)]
    wrapped = [(TagState(f"{k + 1:024X}"), _NoInterface(trial_rng(33, k))) for k in range(n)]
    air = ProtocolAir(profile("miller4-320k"), plain, arrays=StateArrays)
    assert air._arrays._words is not None and air._arrays._words.usable
    log_a = run_inventory(air, InventoryConfig())
    other = ProtocolAir(profile("miller4-320k"), wrapped, arrays=StateArrays)
    assert other._arrays._words is None
    log_b = run_inventory(other, InventoryConfig())
    assert log_a.slots == log_b.slots and log_a.reads == log_b.reads
    assert len(log_a.tags_read()) == n
    assert sum(1 for c in log_a.slots["command"] if c == "QueryAdjust") >= 3
    for (_, ga), (_, gb) in zip(plain, wrapped):
        assert _same_state(ga.bit_generator.state, gb._rng.bit_generator.state)

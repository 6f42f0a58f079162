"""A population's power decisions at a new carrier made at once (PassiveTag.quiet_points): per tag
what its own ``quiet_point(fe, g, decide=True)`` decides, to the bit, and remembered as it would be."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rfsim.core.rng import trial_rng
from rfsim.devices.tag import PassiveTag, QuietPoint, SharedFrontEnd, TagConfig
from rfsim.devices.tag_chip import PowerDependentChip


def _front_end(cw=0.6 - 0.2j):
    x = np.full(3000, cw, dtype=np.complex128)
    x[400:480] = 0.1 * cw  # one PIE-like low pulse; the CW plateau stays long
    return SharedFrontEnd(x, fs_hz=4e6)


def _tags(n, *, chip_every=0, seed=3):
    cfgs = [TagConfig(epc_hex=f"{k + 1:024X}", sensitivity_dbm=-20.0 + 0.5 * (k % 7)) for k in range(n)]
    chip = PowerDependentChip.pass_default() if chip_every else None
    return [PassiveTag(c, None, rng=trial_rng(seed, k), chip=chip if chip_every and k % chip_every == 0 else None)
            for k, c in enumerate(cfgs)]


def _gains(n, seed):
    rng = np.random.default_rng(seed)
    # incident powers from far below to far above the sensitivities (-40 ... +10 dBm at |x_m| ~ 0.63)
    return list((rng.normal(size=n) + 1j * rng.normal(size=n)) * 10.0 ** rng.uniform(-2.0, 0.5, n))


def _same(a, b):
    """Two decisions equal field by field, floats to the bit."""
    if a is None or b is None:
        return a is b
    if type(a) is not type(b):
        return False
    if dataclasses.is_dataclass(a):  # the unpowered TagResponse (compared by identity): field by field
        a, b = dataclasses.astuple(a), dataclasses.astuple(b)
    for u, v in zip(a, b):
        if dataclasses.is_dataclass(u) and not isinstance(u, type) and hasattr(u, "reason"):
            if not _same(u, v):
                return False
        elif isinstance(u, float):
            if not (u == v and math.copysign(1.0, u) == math.copysign(1.0, v)) and not (u == v == -math.inf):
                return False
        elif u != v:
            return False
    return True


@pytest.mark.parametrize("chip_every", [0, 3])
def test_batch_equals_each_tags_own_decision(chip_every):
    fe, n = _front_end(), 200
    gains = _gains(n, 11)
    one, each = _tags(n, chip_every=chip_every), _tags(n, chip_every=chip_every)
    batch = PassiveTag.quiet_points(one, fe, gains)
    own = [t.quiet_point(fe, g, decide=True) for t, g in zip(each, gains)]
    assert all(type(q) is QuietPoint for q in batch)
    assert all(_same(a, b) for a, b in zip(batch, own))
    powered = [q.powered for q in batch]
    assert any(powered) and not all(powered)  # both sides of the threshold are exercised
    # the config rule written out: τ_pu·(τ·|g·x_m|²) ≥ P_sens, P_inc [dBm] = 10·log10(P) + 30
    xm = fe.cw_sample
    for t, g, q in zip(one, gains, batch):
        if t.chip is None:
            p = abs(complex(np.complex128(g) * np.complex128(xm))) ** 2
            assert q.p_dbm == pytest.approx(10.0 * math.log10(p) + 30.0, abs=1e-9)
            pu = t.config.power_up
            assert q.powered == (pu.tau * (t.config.tau * p) >= pu.chip_sensitivity_w)
            assert (q.unpowered is None) == q.powered


def test_batch_decisions_are_remembered_and_reused():
    fe, n = _front_end(), 50
    gains = _gains(n, 12)
    tags = _tags(n)
    first = PassiveTag.quiet_points(tags, fe, gains)
    # each tag's own call without ``decide`` finds the decision made for it
    assert all(t.quiet_point(fe, g) is q for t, g, q in zip(tags, gains, first))
    assert all(a is b for a, b in zip(PassiveTag.quiet_points(tags, fe, gains), first))


def test_a_decision_of_another_config_at_this_power_is_not_used():
    fe = _front_end()
    gains = _gains(4, 13)
    tags = _tags(4)
    PassiveTag.quiet_points(tags, fe, gains)
    tags[1].config = TagConfig(epc_hex="AB" * 12, sensitivity_dbm=-5.0)
    out = PassiveTag.quiet_points(tags, fe, gains)
    assert out[1] is None and tags[1].quiet_point(fe, gains[1], decide=True) is None
    assert all(q is not None for k, q in enumerate(out) if k != 1)


def test_tags_that_do_not_share_front_ends_or_a_segment_without_plateau():
    fe, gains = _front_end(), _gains(3, 14)
    tags = _tags(3)
    tags[2].shared_front_end = False
    out = PassiveTag.quiet_points(tags, fe, gains)
    assert out[2] is None and out[0] is not None
    ramp = SharedFrontEnd(np.linspace(0.1, 1.0, 3000).astype(np.complex128), fs_hz=4e6)
    assert ramp.plateau is None and PassiveTag.quiet_points(tags, ramp, gains) == [None] * 3


def test_powers_w_equals_the_scalar_product_to_the_bit():
    fe = _front_end(0.7071 + 0.31j)
    gains = np.asarray(_gains(2000, 15))
    batch = fe.powers_w(gains)
    xm = fe.x[fe.plateau:fe.plateau + 1]
    mags = [float(np.abs(complex(g) * xm)[0]) for g in gains]  # one tag's |g·x_m|, as numpy computes it
    one = np.array([v * v for v in mags])
    assert all(fe.power_w(complex(g)) == p for g, p in zip(gains[:50], one[:50]))
    assert np.array_equal(batch.view(np.int64), one.view(np.int64))
    # |g·x_m|² written out (exact to rounding)
    ref = np.abs(gains * complex(fe.cw_sample)) ** 2
    np.testing.assert_allclose(batch, ref, rtol=4e-16)


def test_a_tag_remembers_only_its_last_few_carriers():
    fe, tag = _front_end(), _tags(1)[0]
    for k in range(40):
        PassiveTag.quiet_points([tag], fe, [0.3 + 0.01 * k])
    assert 1 <= len(tag._quiet) <= 4

"""Per-link large-scale models (rfsim.channels.large_scale.LinkLargeScale) in the Scene: Özkaya's
per-reader α_j, n_j (Table 6.1) reached through the channel's links, reciprocity, precedence,
and the one-model scenes unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.channels import Antenna, Channel, LinkLargeScale, LogDistance, Scene, Surface, Wall
from rfsim.core.errors import ConfigError

FC = 868e6
P_TX_DBM = 5.0
# Table 6.1 (seeds/002 L1002–L1007): α [dBm], n per reader
TABLE_6_1 = [(-42.0, 2.3), (-52.0, 2.3), (-45.0, 2.5)]


def _rx_dbm(paths):
    return P_TX_DBM + 20 * np.log10(abs(paths.narrowband_gain(FC)))


def test_each_reader_link_follows_its_own_alpha_and_exponent():
    """Pr_j(d) = α_j − 10·n_j·log10 d − nW·WAF (eq. 6.4) at 1–8 m for every reader, through and
    not through a 2 dB wall, with LogDistance(n_j, pl_d0 = P_t − α_j) per reader (isotropic)."""
    readers = [Antenna([0.0, 0.0, 1.0]), Antenna([9.0, 0.0, 1.0]), Antenna([0.0, 9.0, 1.0])]
    models = [LogDistance(n, 1.0, pl_d0_db=P_TX_DBM - a) for a, n in TABLE_6_1]
    wall = Wall.segment_2d((4.5, -20.0), (4.5, 20.0), 2.0)
    ch = Channel(Scene(walls=(wall,), large_scale=LinkLargeScale(by_antenna=zip(readers, models)),
                       image_order=0))
    checked = 0
    for d in (1.0, 2.0, 3.5, 8.0):
        for r, (a, n) in zip(readers, TABLE_6_1):
            direction = np.array([1.0, 0.0, 0.0]) if r.position_m[0] == 0 else np.array([-1.0, 0.0, 0.0])
            if r.position_m[1] > 0:
                direction = np.array([0.0, -1.0, 0.0])
            tag = Antenna(r.position_m + d * direction)
            walls = int(abs(np.sign(tag.position_m[0] - 4.5) - np.sign(r.position_m[0] - 4.5)) == 2)
            expected = a - 10 * n * np.log10(d) - 2.0 * walls
            assert abs(_rx_dbm(ch.link(tag, r, fc_hz=FC)) - expected) < 1e-9
            assert abs(_rx_dbm(ch.link(r, tag, fc_hz=FC)) - expected) < 1e-9   # reciprocal
            checked += 1
    assert checked == 12


def test_pair_beats_antenna_beats_default_and_ambiguity_raises():
    a, b, c = Antenna([0.0, 0.0, 1.0]), Antenna([3.0, 0.0, 1.0]), Antenna([0.0, 4.0, 1.0])
    m_pair = LogDistance(2.0, 1.0, pl_d0_db=40.0)
    m_a = LogDistance(3.0, 1.0, pl_d0_db=50.0)
    m_b = LogDistance(2.5, 1.0, pl_d0_db=45.0)
    m_def = LogDistance(2.0, 1.0, pl_d0_db=60.0)
    ls = LinkLargeScale(m_def, by_antenna=[(a, m_a), (b, m_b)], by_pair=[(b, a, m_pair)])
    assert ls.model(a, b) is m_pair and ls.model(b, a) is m_pair
    assert ls.model(a, c) is m_a and ls.model(c, a) is m_a
    assert ls.model(c, b) is m_b
    other = Antenna([5.0, 5.0, 1.0])
    assert ls.model(c, other) is m_def
    assert LinkLargeScale().model(a, c) is None
    # antennas compare by value: an equal antenna finds the same model
    assert ls.model(Antenna([0.0, 0.0, 1.0]), c) is m_a
    with pytest.raises(ConfigError, match="by_pair"):
        LinkLargeScale(by_antenna=[(a, m_a), (c, m_b)]).model(a, c)
    with pytest.raises(ConfigError, match="amplitude_gain"):
        LinkLargeScale(by_antenna=[(a, 3.0)])
    # 40 dB at 1 m and 20 dB/decade: the pair's model at d = 3 m, Friis for a model-free pair
    g = ls.link_amplitude_gain(a, b, 3.0, FC)
    assert abs(-20 * np.log10(g) - (40.0 + 20 * np.log10(3.0))) < 1e-12
    lam = 299792458.0 / FC
    assert abs(LinkLargeScale().link_amplitude_gain(a, c, 4.0, FC) - lam / (4 * np.pi * 4.0)) < 1e-15


def test_image_paths_use_the_link_model_and_one_model_scenes_are_unchanged():
    """The image path of a per-link scene carries the link's model at the path length; a
    LinkLargeScale whose default is the one model gives bit-identical links to the one-model
    scene (the existing behaviour)."""
    floor = Surface([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], eps_r=4.0)
    tx, rx = Antenna([0.0, 0.0, 1.0]), Antenna([5.0, 0.0, 1.5])
    one = LogDistance(2.7, 1.0, pl_d0_db=35.0)
    ref = Channel(Scene(surfaces=(floor,), large_scale=one)).link(tx, rx, fc_hz=FC)
    same = Channel(Scene(surfaces=(floor,), large_scale=LinkLargeScale(one))).link(tx, rx, fc_hz=FC)
    np.testing.assert_array_equal(ref.gain, same.gain)
    np.testing.assert_array_equal(ref.delay_s, same.delay_s)
    per = Channel(Scene(surfaces=(floor,), large_scale=LinkLargeScale(by_antenna=[(rx, one)]))).link(
        tx, rx, fc_hz=FC)
    np.testing.assert_array_equal(ref.gain, per.gain)
    friis = Channel(Scene(surfaces=(floor,))).link(tx, rx, fc_hz=FC)
    assert ref.gain.size == friis.gain.size == 2
    ell = ref.delay_s[1] * 299792458.0
    ratio = abs(ref.gain[1]) / abs(friis.gain[1])
    expected = one.amplitude_gain(ell, FC) / (299792458.0 / (4 * np.pi * FC * ell))
    assert abs(ratio / expected - 1) < 1e-12

"""Tag-to-tag spread (issue 19, item 1): each tag its own BLF error, T1, chip states and
orientation; the reply generated at the tag's own BLF and T1 with fractional-sample timing.

Expected values come from the Gen2 limits (anchors §4.2 FrT, §4.3 T1) and from an independent
sampling of the line code (element index floor((t − t_start)·2·BLF) of the tag's half-symbol
sequence), not from the device's outputs.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from rfsim.devices.tag import PassiveTag, TagConfig
from rfsim.devices.tag_spread import TagSpreadConfig, spread_gamma_b
from rfsim.core.errors import ConfigError
from rfsim.gen2.link import PROFILES, t1
from rfsim.gen2.linecode import halfsymbols
from rfsim.core.rng import trial_rng

from test_tag_device import FS_HZ, query_segment


@pytest.mark.parametrize("name", ["miller4-320k", "fm0-40k"])
@pytest.mark.parametrize("blf_error_percent, t1_offset_s", [(3.7, 2.345e-6), (-6.1, -3.9e-6)])
def test_reply_at_the_tags_own_blf_and_t1_fractional(name, blf_error_percent, t1_offset_s):
    link = PROFILES[name]
    if abs(blf_error_percent) > 100 * link.frt:
        blf_error_percent = math.copysign(100 * link.frt * 0.9, blf_error_percent)
    base = PassiveTag(TagConfig(), None, rng=np.random.default_rng(1))
    tag = PassiveTag(TagConfig(blf_error_percent=blf_error_percent, t1_offset_s=t1_offset_s), None,
                     rng=np.random.default_rng(1))
    x, _ = query_segment(link)
    r0 = base.listen(x, t0_s=0.0, fs_hz=FS_HZ)
    r = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
    # the same RN16 (same protocol stream), its own BLF and T1
    np.testing.assert_array_equal(r.reply.bits, r0.reply.bits)
    assert r.blf_hz == pytest.approx(r0.blf_hz * (1 + blf_error_percent / 100), rel=1e-12)
    assert r.reply_start_s - r0.reply_start_s == pytest.approx(t1_offset_s, abs=1e-15)
    # independent sampling: element k = floor((t_n − t_start)·2·BLF) of the half-symbol sequence
    el = halfsymbols(r.reply.bits, m=r.m, trext=r.trext).astype(float)  # one value per 1/(2·BLF)
    t = np.arange(x.size) / FS_HZ
    u = (t - r.reply_start_s) * 2.0 * r.blf_hz
    k = np.floor(u + 1e-9).astype(int)
    inside = (u >= 0) & (k < el.size)
    # skip samples within 1e-6 element of an edge (float round-off of the two computations)
    clear = inside & (np.abs(u - np.round(u)) > 1e-6)
    rs = tag.reflection_states
    expect = np.where(el[k[clear]] > 0, rs.gamma_b, rs.gamma_a)
    np.testing.assert_array_equal(r.gamma[clear], expect)
    assert np.all(r.gamma[~inside] == rs.gamma_a)
    # the start is not on the sample grid (fractional timing is kept)
    assert abs(r.reply_start_s * FS_HZ - round(r.reply_start_s * FS_HZ)) > 1e-3


def test_default_spread_config_changes_nothing():
    cfg = TagConfig()
    out, rec = TagSpreadConfig().draw(cfg, PROFILES["miller4-320k"], rng=trial_rng(5, 0))
    assert out is cfg
    assert rec["blf_error_percent"] == 0.0 and rec["t1_offset_s"] == 0.0 and rec["chip_gain_db"] == 0.0


@pytest.mark.parametrize("name", ["miller4-320k", "fm0-40k", "fm0-640k"])
def test_spread_draws_inside_the_gen2_limits(name):
    """800 tags: |BLF error| ≤ FrT, T1 inside [T1min, T1max], |Γ_B| ≤ 1; the normal's σ is
    FrT/3 (the truncation at 3σ removes 0.27 %, σ² of the truncated normal is 0.9733·σ²);
    T1 uniform: its mean is the window centre within 4 standard errors."""
    link = PROFILES[name]
    sp = TagSpreadConfig(enabled=True)
    tr = t1(link)
    recs = [sp.draw(TagConfig(), link, rng=trial_rng(11, k, 0))[1] for k in range(800)]
    e = np.array([r["blf_error_percent"] for r in recs]) / 100
    t1s = np.array([r["t1_s"] for r in recs])
    assert np.all(np.abs(e) <= link.frt)
    assert np.all((t1s > tr.min_s) & (t1s < tr.max_s))
    sigma = link.frt / 3 * math.sqrt(0.9733)
    se = sigma / math.sqrt(2 * (e.size - 1))  # standard error of a sample σ
    assert abs(e.std(ddof=1) - sigma) < 4 * se
    width = tr.max_s - tr.min_s
    assert abs(t1s.mean() - 0.5 * (tr.min_s + tr.max_s)) < 4 * width / math.sqrt(12 * t1s.size)
    for r in recs[:200]:
        cfg = replace(TagConfig(), chip_gain_db=r["chip_gain_db"], chip_phase_deg=r["chip_phase_deg"])
        assert abs(cfg.reflection_states.gamma_b) <= 1.0


def test_spread_tags_reply_inside_t1_and_states_move():
    link = PROFILES["miller4-320k"]
    x, end_rel = query_segment(link)
    sp = TagSpreadConfig(enabled=True)
    tr = t1(link)
    for k in range(20):
        cfg, rec = sp.draw(TagConfig(), link, rng=trial_rng(3, k, 0))
        tag = PassiveTag(cfg, None, rng=trial_rng(3, k))
        r = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
        t1_true = r.reply_start_s - end_rel
        assert tr.min_s <= t1_true <= tr.max_s
        assert r.blf_hz == pytest.approx(link.blf_hz * (1 + rec["blf_error_percent"] / 100), rel=1e-9)
        base = TagConfig().reflection_states
        assert tag.reflection_states.gamma_b == pytest.approx(
            base.gamma_a + (base.gamma_b - base.gamma_a) * 10 ** (rec["chip_gain_db"] / 20)
            * np.exp(1j * np.radians(rec["chip_phase_deg"])))


def test_uniform_blf_distribution_and_chip_gain_limit():
    link = PROFILES["fm0-640k"]
    sp = TagSpreadConfig(enabled=True, blf_distribution="uniform", blf_spread_frt=0.5)
    e = np.array([sp.draw(TagConfig(), link, rng=trial_rng(2, k, 0))[1]["blf_error_percent"]
                  for k in range(500)]) / 100
    assert np.all(np.abs(e) <= 0.5 * link.frt) and e.max() > 0.45 * link.frt and e.min() < -0.45 * link.frt
    assert abs(spread_gamma_b(0j, 0.5 + 0j, 20 * math.log10(2), 90.0) - 1j) < 1e-12
    with pytest.raises(ConfigError, match="tag.chip_gain_db"):
        TagConfig(chip_gain_db=3.0)  # |Γ_B| = 0.838·1.41 > 1

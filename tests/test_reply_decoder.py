"""The one reply decoder's plan (:mod:`rfsim.gen2.reply_decoder`) and the line-code constant tables."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.gen2 import linecode as L
from rfsim.gen2.link import profile
from rfsim.gen2.reply_core import n_pre_elements
from rfsim.gen2.reply_decoder import DecodePlan, LinkPlans


def test_plan_rejects_an_unknown_search_and_tracking_outside_the_link_search():
    with pytest.raises(ValueError, match="search"):
        DecodePlan("blind", 4e6)
    with pytest.raises(ValueError, match="tracking"):
        DecodePlan("known", 4e6, track_timing=True)
    with pytest.raises(ValueError, match="tracking"):
        DecodePlan("link", 4e6)
    with pytest.raises(ValueError, match="method"):
        DecodePlan("known", 4e6, method="ml")


def test_plan_keeps_the_search_arrays_it_made_equal_to_fresh_ones():
    """A plan's kept arrays are those made anew, and the same object on the next call."""
    plan = DecodePlan("known", 4e6, m=4, trext=False, blf_hz=320e3)
    a = plan.arrays(320e3)
    assert plan.arrays(320e3) is a
    fresh = L.search_arrays(4, False, 2.0 * 320e3 / 4e6)
    for name in a._fields:
        np.testing.assert_array_equal(np.asarray(getattr(a, name)), np.asarray(getattr(fresh, name)), err_msg=name)
    assert not a.templates.flags.writeable


def test_link_plans_make_each_plan_once_per_setting():
    link = profile("miller4-320k")
    plans = LinkPlans(link)
    p = plans.plan("blf", 4e6, "viterbi", 1e-3)
    assert plans.plan("blf", 4e6, "viterbi", 1e-3) is p
    assert plans.plan("blf", 4e6, "viterbi", 1e-2) is not p
    assert p.blf_grid_hz[0] == pytest.approx(link.blf_range_hz[0]) and p.blf_grid_hz[-1] == pytest.approx(
        link.blf_range_hz[1])
    assert not p.blf_grid_hz.flags.writeable


def test_detection_threshold_of_the_plan_is_the_closed_form():
    """γ = √(1 − (P_FA/(2·n_lags))^(1/(n − 2))), n = ⌊elements·fs/(2·BLF)⌋: Miller-4 without the long
    pilot, 4·(8 + 12) = 80 elements, 500 samples at 4 MS/s and 320 kHz."""
    plan = DecodePlan("known", 4e6, m=4, trext=False, false_alarm_probability=1e-3, blf_hz=320e3)
    n = 500
    det = plan.detection(44, 320e3)
    assert det.preamble_samples == n
    assert det.threshold == pytest.approx(np.sqrt(1.0 - (1e-3 / 88) ** (1.0 / (n - 2))), rel=1e-12)


@pytest.mark.parametrize("m", L.M_VALUES)
@pytest.mark.parametrize("trext", [False, True])
def test_preamble_table_holds_the_preamble_of_each_line_code(m, trext):
    levels, state = L.PREAMBLES(m, trext)
    assert not levels.flags.writeable
    np.testing.assert_array_equal(levels, L.preamble_levels(m=m, trext=trext)[0])
    assert n_pre_elements(m, trext) == levels.size * m
    # pilot: 12 FM0 data-0 bits (24 half-bits) or 16·M Miller subcarrier cycles (32 half-bits)
    pilot = (24 if m == 1 else 32) if trext else (0 if m == 1 else 8)
    assert levels.size == pilot + (12 if m == 1 else 12)


def test_preamble_table_rejects_other_line_codes():
    with pytest.raises(ValueError):
        L.PREAMBLES(3, False)

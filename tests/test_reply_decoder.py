"""The one reply decoder's plan (:mod:`rfsim.gen2.reply_decoder`) and the line-code constant tables."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.gen2 import linecode as L
from rfsim.gen2.link import profile
from rfsim.gen2.reply_core import n_pre_elements
from rfsim.gen2.reply_decoder import DecodePlan, LinkPlans


def test_plan_rejects_an_unknown_search_a_link_search_without_tracking_and_a_tracked_refit():
    with pytest.raises(ValueError, match="search"):
        DecodePlan("blind", 4e6)
    with pytest.raises(ValueError, match="tracks timing"):
        DecodePlan("link", 4e6)
    with pytest.raises(ValueError, match="refit"):
        DecodePlan("blf", 4e6, refit=True, track_timing=True)
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


# ----------------------------------------------------------------- the reader's timing tracking


def test_reader_tracking_selects_the_decoders_track_variant():
    """``ReaderConfig.track_timing`` selects, through the reader's plans, the same "track" timing
    step (and its decisions and measurement) the capture decoder's "link" plan runs; off, the
    reader's plans are those of before (no tracking, the BLF search's refit)."""
    from rfsim.channels.antennas import vertical_dipole
    from rfsim.devices.reader import Reader, ReaderConfig
    from rfsim.gen2 import reply_decoder as rd
    from rfsim.gen2.reply_search import LinkHypothesis

    link_plan = DecodePlan("link", 2e6, hypotheses=(LinkHypothesis(4, False, 2e5, 3e5),), track_timing=True)
    for blf_search in ("off", "preamble"):
        plans = {}
        for track in (False, True):
            cfg = ReaderConfig(hopping=False, blf_search=blf_search, track_timing=track)
            reader = Reader(cfg, [vertical_dipole((0.0, 0.0, 0.0))], rng=np.random.default_rng(0))
            plans[track] = reader._decode_plan("known" if blf_search == "off" else "blf")
        assert plans[False].variants.timing == "none" and not plans[False].track_timing
        assert plans[True].variants.timing == "track" and plans[True].track_timing
        i = rd.STEPS.index("timing")
        assert plans[True].steps[i:i + 3] == link_plan.steps[i:i + 3]  # timing, decisions, measure
        assert plans[True].steps[:3] == (rd.VARIANTS["condition"]["lead"],) + plans[False].steps[1:3]
    assert plans[False].refit and not plans[True].refit


@pytest.mark.parametrize("kw, match", [(dict(track_timing=3), "true or false"),
                                       (dict(track_timing=True, rx_model="statistic"), "statistic"),
                                       (dict(track_timing=True, blf_search="preamble", rn16_false_accept=1e-3),
                                        "rn16_false_accept")])
def test_reader_tracking_config_errors(kw, match):
    from rfsim.core.errors import ConfigError
    from rfsim.devices.reader_config import ReaderConfig

    with pytest.raises(ConfigError, match=match) as err:
        ReaderConfig(**kw)
    assert "reader.track_timing" in str(err.value) and "\n" not in str(err.value)


def _drifting_window(reader, rng, drift, ebn0_db=15.0, n_bits=128):
    """A reader window ``c + h·s(t) + noise`` with one EPC-length reply (CRC-16 appended) whose
    element clock is u(τ) = 2·BLF·(τ + drift·τ²/(2·T)) (T its nominal duration: the BLF changes
    linearly by the factor 1 + drift across it), starting inside the T1 window; rest level −1
    around it, leakage 30× the reply. Returns (x, bits, cmd_end_s)."""
    import math

    from rfsim.gen2.crc import append_crc16
    from rfsim.gen2.link import t1
    from rfsim.gen2.linecode import halfsymbols

    lk, fs = reader.link, reader.fs_hz
    bits = append_crc16(rng.integers(0, 2, n_bits - 16, dtype=np.uint8))
    el = halfsymbols(np.concatenate([bits, [1]]).astype(np.uint8), m=lk.m, trext=lk.trext).astype(np.float64)
    win = t1(lk)
    cmd_end_s = (40 - win.min_s * fs) / fs
    dur = el.size / (2.0 * lk.blf_hz)
    n = int(math.ceil((cmd_end_s + win.max_s) * fs + 1.3 * dur * fs)) + 60
    start = cmd_end_s + win.min_s + rng.uniform(0.25, 0.75) * (win.max_s - win.min_s)
    tau = np.arange(n) / fs - start
    u = 2.0 * lk.blf_hz * (tau + drift * tau * tau / (2.0 * dur))
    k = np.floor(u).astype(np.int64)
    on = (u >= 0) & (k < el.size)
    s = -np.ones(n)
    s[on] = el[k[on]]
    sigma2 = 1e-12
    amp = math.sqrt(10 ** (ebn0_db / 10) * sigma2 / (fs * lk.m / lk.blf_hz))
    x = 30.0 * amp * np.exp(2.1j) + amp * np.exp(0.7j) * s
    return x + math.sqrt(sigma2 / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n)), bits, cmd_end_s


@pytest.mark.parametrize("blf_search", ["off", "preamble"])
def test_reader_tracking_decodes_replies_whose_blf_drifts(blf_search):
    """Miller-4 at 320 kHz, 128-bit replies at Eb/N0 = 15 dB whose BLF drifts linearly by +1 % or −2 %
    across the reply (Gen2 allows 2.5 % during a reply, FrS): the reader with ``track_timing``
    decodes every one (CRC ok, the bits sent); the fixed-timing reader decodes none (its timing
    error grows to ≈ drift/2 of the reply's ≈ 1,100 elements, 5–11 elements at the end). Without
    drift both decode all 8 and give the same bits. Fails when the tracking is not selected
    (both then fail alike) or does not follow the drift."""
    from rfsim.channels.antennas import vertical_dipole
    from rfsim.devices.reader import Reader, ReaderConfig

    n = 8
    ok = {}
    for track in (False, True):
        cfg = ReaderConfig(link_profile="miller4-320k", fs_hz=4e6, hopping=False, blf_search=blf_search,
                           track_timing=track)
        reader = Reader(cfg, [vertical_dipole((0.0, 0.0, 0.0))], rng=np.random.default_rng(0))
        for drift in (0.0, 0.01, -0.02):
            rng = np.random.default_rng(5)
            good = 0
            for _ in range(n):
                x, bits, cmd_end_s = _drifting_window(reader, rng, drift)
                res = reader.receive(x, t0_s=0.0, n_bits=bits.size, expect_crc=True, cmd_end_s=cmd_end_s)
                good += bool(res.success and np.array_equal(res.bits, bits))
                if track:
                    assert np.isnan(res.doppler_hz)
            ok[track, drift] = good
    assert ok[False, 0.0] == ok[True, 0.0] == n
    for drift in (0.01, -0.02):
        assert ok[True, drift] == n and ok[False, drift] == 0, ok

"""Link profiles, durations and T1–T7 against the computed tables of
gen2-and-validation-anchors.md §3.4–3.5 and the FrT table of §4.2 (cross-checked with the
BLF-keyed table of PASS's epc_protocol_timings.m, pass-paris-simulator.md §2.5)."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import bits_to_str, str_to_bits
from rfsim.gen2.commands import ACK, Query, QueryRep, encode
from rfsim.gen2.link import (
    PROFILES,
    LinkProfile,
    backscatter_duration_s,
    frt_fraction,
    pie_duration_s,
    profile,
    t1,
    t1_range,
    t2,
    t2_range,
    t3,
    t4,
    t5,
    t6,
    t7,
)


def _printed(value_s: float, printed_us: str) -> bool:
    """True when value_s [s] rounds to the printed µs figure (to its last printed digit)."""
    decimals = len(printed_us.split(".")[1]) if "." in printed_us else 0
    return abs(value_s * 1e6 - float(printed_us)) <= 0.5 * 10.0 ** (-decimals) + 1e-9


# §3.5: profile name, Query bits, Query, QueryRep, RN16 reply, EPC reply (128 b),
#       T1 nom, T1 min, T1 max, T2 min, T2 max, T4   (µs, as printed); BLF [kHz]; FrT
TABLE_3_5 = {
    "fm0-40k": ("1000000000000010011101", "1012.5", "212.5", "575.0", "3375.0",
                "250", "238", "262", "75", "500", "150", 40, 0.04),
    "fm0-640k": ("1000100000000010000101", "220.833", "59.375", "35.9375", "210.9375",
                 "15.625", "11.281", "19.969", "4.6875", "31.25", "31.25", 640, 0.15),
    "miller4-320k": ("1000110000000010001001", "435.417", "106.25", "337.5", "1737.5",
                     "31.25", "26.125", "36.375", "9.375", "62.5", "62.5", 320, 0.10),
}


@pytest.mark.parametrize("name", list(TABLE_3_5))
def test_profiles_reproduce_table_3_5(name):
    (qbits, query, rep, rn16, epc, t1nom, t1min, t1max, t2min, t2max, t4min, blf_khz,
     frt) = TABLE_3_5[name]
    link = profile(name)
    assert link.blf_hz == pytest.approx(blf_khz * 1e3, rel=1e-12)
    assert link.frt == frt
    q = Query(dr=link.dr, m=link.m, trext=False, sel="all", session=0, target="A", q=4)
    assert bits_to_str(encode(q)) == qbits
    assert _printed(link.command_duration_s(q), query)
    assert _printed(link.command_duration_s(str_to_bits(qbits), preamble="query"), query)
    assert _printed(link.command_duration_s(QueryRep(session=0)), rep)
    assert _printed(link.reply_duration_s(16), rn16)
    assert _printed(link.reply_duration_s(128), epc)
    r1, r2 = t1(link), t2(link)
    assert _printed(r1.nom_s, t1nom) and _printed(r1.min_s, t1min) and _printed(r1.max_s, t1max)
    assert _printed(r2.min_s, t2min) and _printed(r2.max_s, t2max) and r2.nom_s is None
    assert _printed(t4(link).min_s, t4min) and t4(link).max_s is None


def test_durations_depend_on_bit_values():
    link = profile("fm0-40k")
    zeros, ones = np.zeros(18, np.uint8), np.ones(18, np.uint8)
    d = link.command_duration_s(ones, preamble="frame-sync") - link.command_duration_s(zeros, preamble="frame-sync")
    assert d == pytest.approx(18 * (50e-6 - 25e-6), rel=1e-12)
    assert link.command_duration_s(ACK(rn16=0xFFFF)) == pytest.approx(
        link.command_duration_s(encode(ACK(rn16=0xFFFF)), preamble="frame-sync"))
    with pytest.raises(ValueError):
        link.command_duration_s(ones)  # raw bits need an explicit lead-in


# §3.4: Tari 6.25, RTcal 15.625 (data-1 9.375), TRcal 17.875 µs, DR 64/3, FM0, CRC bits = 0.
# (BLF = 1.19 MHz is outside Gen2, so the low-level functions are used, not LinkProfile.)
TARI, DATA1, TRCAL, DELIM = 6.25e-6, 9.375e-6, 17.875e-6, 12.5e-6
BLF_3_4 = (64 / 3) / TRCAL


def _cmd(*parts: str) -> np.ndarray:
    return str_to_bits("".join(parts))


def test_placeholder_crc_command_durations():
    kw = dict(tari_s=TARI, data1_s=DATA1, delimiter_s=DELIM)
    query = _cmd("1000", "1", "00", "0", "00", "00", "0", "0100", "00000")  # DR 64/3, FM0, Q 4, CRC 0
    assert query.size == 22
    assert pie_duration_s(query, trcal_s=TRCAL, **kw) == pytest.approx(199.125e-6, rel=1e-12)
    assert pie_duration_s(_cmd("00", "00"), **kw) == pytest.approx(59.375e-6, rel=1e-12)
    ack = _cmd("01", "1" * 16)  # RN 0xFFFF
    assert pie_duration_s(ack, **kw) == pytest.approx(200.0e-6, rel=1e-12)
    req_rn = _cmd("11000001", "0" * 16, "0" * 16)
    assert pie_duration_s(req_rn, **kw) == pytest.approx(293.75e-6, rel=1e-12)
    # The Read golden fixes only the number of 1 bits (5, three of them in the command code);
    # fields chosen here: bank EPC (01), WordPtr 2 (EBV 00000010), WordCount 0, RN 0, CRC 0.
    read = _cmd("11000010", "01", "00000010", "00000000", "0" * 16, "0" * 16)
    assert read.size == 58
    assert pie_duration_s(read, **kw) == pytest.approx(412.5e-6, rel=1e-12)


def test_placeholder_reply_durations_and_timing():
    r = dict(blf_hz=BLF_3_4, m=1, trext=False)
    assert _printed(backscatter_duration_s(16, **r), "19.2715")  # RN16
    assert _printed(backscatter_duration_s(128, **r), "113.1152")  # PC + EPC + CRC-16
    assert _printed(backscatter_duration_s(32, **r), "32.6777")  # handle + CRC-16
    assert _printed(backscatter_duration_s(1 + 32 + 16 + 16, **r), "60.3281")  # Read reply, 2 words
    # the file's T1 limits correspond to FT = 15 % (11.28125 = 15.625·0.85 − 2)
    rng1 = t1_range(rtcal_s=TARI + DATA1, blf_hz=BLF_3_4, frt=0.15)
    assert rng1.min_s == pytest.approx(11.28125e-6, rel=1e-12)
    assert rng1.max_s == pytest.approx(19.96875e-6, rel=1e-12)
    rng2 = t2_range(blf_hz=BLF_3_4)
    assert _printed(rng2.min_s, "2.5137") and _printed(rng2.max_s, "16.7578")
    assert 2 * (TARI + DATA1) == pytest.approx(31.25e-6)  # T4


def test_preamble_goldens_3_4():
    # preamble: Tari 6.25, RTcal 18.75, TRcal 56.25 µs, delimiter 12.5 → 93.75 µs
    assert pie_duration_s([], tari_s=6.25e-6, data1_s=12.5e-6, delimiter_s=12.5e-6,
                          trcal_s=56.25e-6) == pytest.approx(93.75e-6)
    # frame-sync: Tari 12.5, RTcal 31.25, delimiter 13 → 56.75 µs
    assert pie_duration_s([], tari_s=12.5e-6, data1_s=18.75e-6, delimiter_s=13e-6) == pytest.approx(56.75e-6)
    # reply preambles (payload 0, no dummy bit)
    cases = [(320e3, 1, False, 18.75), (320e3, 1, True, 56.25), (40e3, 1, False, 150.0), (320e3, 2, False, 62.5),
             (320e3, 2, True, 137.5), (320e3, 4, False, 125.0), (320e3, 8, True, 550.0), (64e3, 2, False, 312.5)]
    for blf, m, trext, us in cases:
        assert backscatter_duration_s(0, blf_hz=blf, m=m, trext=trext, dummy_bit=False) == pytest.approx(us * 1e-6)


# ------------------------------------------------------------------ FrT


# (DR, TRcal µs, nominal FrT, extended-temperature FrT) from the §4.2 table
FRT_CASES = [
    ("64/3", 100 / 3, 0.15, 0.15), ("64/3", 50.0, 0.22, 0.22), ("64/3", 200 / 3, 0.10, 0.15),
    ("64/3", 75.0, 0.12, 0.15), ("64/3", 250 / 3, 0.10, 0.10), ("64/3", 100.0, 0.10, 0.12),
    ("64/3", 400 / 3, 0.10, 0.12), ("64/3", 150.0, 0.07, 0.07), ("64/3", 200.0, 0.07, 0.07),
    ("64/3", 210.0, 0.05, 0.05), ("64/3", 225.0, 0.05, 0.05),
    ("8", 17.2, 0.19, 0.19), ("8", 20.0, 0.19, 0.19), ("8", 25.0, 0.10, 0.15), ("8", 28.0, 0.12, 0.15),
    ("8", 31.25, 0.10, 0.10), ("8", 40.0, 0.10, 0.10), ("8", 50.0, 0.07, 0.07), ("8", 60.0, 0.07, 0.07),
    ("8", 75.0, 0.07, 0.07), ("8", 100.0, 0.04, 0.04), ("8", 200.0, 0.04, 0.04),
]


@pytest.mark.parametrize(("dr", "trcal_us", "nominal", "extended"), FRT_CASES)
def test_frt_table(dr, trcal_us, nominal, extended):
    assert frt_fraction(dr, trcal_us * 1e-6) == nominal
    assert frt_fraction(dr, trcal_us * 1e-6, extended_temperature=True) == extended


@pytest.mark.parametrize(("dr", "trcal_us"), [("8", 17.0), ("8", 201.0), ("64/3", 33.0), ("64/3", 226.0)])
def test_frt_outside_table(dr, trcal_us):
    with pytest.raises(ConfigError, match="link.trcal_s"):
        frt_fraction(dr, trcal_us * 1e-6)


# PASS epc_protocol_timings.m, keyed by BLF [kHz] (open intervals only; its edges are rounded)
PASS_FRT = {
    "64/3": [((320, 640), 0.22), ((256, 320), 0.12), ((160, 256), 0.10), ((107, 160), 0.07), ((95, 107), 0.05)],
    "8": [((320, 465), 0.19), ((256, 320), 0.12), ((160, 256), 0.10), ((107, 160), 0.07), ((40, 107), 0.04)],
}


def test_frt_agrees_with_pass_blf_table():
    n = 0
    for dr, rows in PASS_FRT.items():
        drv = 8.0 if dr == "8" else 64 / 3
        for (lo, hi), expected in rows:
            for blf_khz in np.linspace(lo, hi, 9)[1:-1]:
                if min(abs(blf_khz - lo) / lo, abs(blf_khz - hi) / hi) < 0.01:
                    continue  # PASS rounds the table edges (107 for 106.7 kHz)
                assert frt_fraction(dr, drv / (blf_khz * 1e3)) == expected, (dr, blf_khz)
                n += 1
    assert n >= 60


# ------------------------------------------------------------------ profiles and validation


def test_profile_properties():
    c = profile("miller4-320k")
    assert c.rtcal_s == pytest.approx(31.25e-6) and c.data1_s == pytest.approx(18.75e-6)
    assert c.tpri_s == pytest.approx(3.125e-6) and c.bitrate_bps == pytest.approx(80e3)
    lo, hi = c.blf_range_hz
    assert lo == pytest.approx(288e3) and hi == pytest.approx(352e3)
    assert c.pw_s == pytest.approx(6.25e-6) and c.delimiter_s == 12.5e-6
    assert c.preamble_s == pytest.approx(12.5e-6 + 12.5e-6 + 31.25e-6 + 200e-6 / 3)
    p = profile("pass-miller2-48k")
    assert p.blf_hz == pytest.approx(48e3) and p.rtcal_s == pytest.approx(75e-6) and p.trext
    assert p.reply_duration_s(16) == pytest.approx((22 + 16 + 1) * 2 / 48e3)
    for link in PROFILES.values():
        assert 40e3 * (1 - 1e-12) <= link.blf_hz <= 640e3 * (1 + 1e-12)
        assert 2.5 <= link.rtcal_s / link.tari_s <= 3.0


def test_t3_to_t7():
    a = profile("fm0-40k")
    assert t3(a).min_s == 0.0
    assert t5(a).min_s == pytest.approx(238e-6) and t5(a).max_s == 20e-3
    assert t6(a).min_s == t5(a).min_s and t6(a).max_s == 20e-3
    assert t7(a).min_s == pytest.approx(500e-6) and t7(a).max_s == 20e-3  # T2max = 500 µs > 250 µs
    b = profile("fm0-640k")
    assert t7(b).min_s == pytest.approx(250e-6)  # T2max = 31.25 µs < 250 µs


def test_profile_lookup_did_you_mean():
    with pytest.raises(ConfigError, match="did you mean 'fm0-640k'"):
        profile("fm0-640")


GOOD = dict(tari_s=12.5e-6, data1_tari=1.5, trcal_s=200e-6 / 3, dr="64/3", m=4)


@pytest.mark.parametrize(
    ("changes", "key"),
    [
        (dict(tari_s=5e-6), "link.tari_s"),
        (dict(tari_s=30e-6), "link.tari_s"),
        (dict(data1_tari=1.4), "link.data1_tari"),
        (dict(data1_tari=2.1), "link.data1_tari"),
        (dict(trcal_s=30e-6), "link.trcal_s"),  # < 1.1 RTcal
        (dict(trcal_s=100e-6), "link.trcal_s"),  # > 3 RTcal
        (dict(tari_s=6.25e-6, trcal_s=30e-6), "link.trcal_s"),  # BLF 711 kHz > 640 kHz
        (dict(tari_s=6.25e-6, dr="8", trcal_s=17.19e-6), "link.trcal_s"),  # DR 8 below the FrT range
        (dict(dr="16"), "link.dr"),
        (dict(dr=64 / 3), "link.dr"),
        (dict(m=3), "link.m"),
        (dict(trext="yes"), "link.trext"),
        (dict(modulation="ASK"), "link.modulation"),
        (dict(depth=0.7), "link.depth"),
        (dict(depth=1.1), "link.depth"),
        (dict(pw_s=2e-6), "link.pw_s"),  # < 0.265 Tari = 3.3 µs
        (dict(pw_s=7e-6), "link.pw_s"),  # > 0.525 Tari
        (dict(delimiter_s=15e-6), "link.delimiter_s"),
        (dict(tari_s=float("nan")), "link.tari_s"),
    ],
)
def test_validation_errors(changes, key):
    LinkProfile(**GOOD)  # the base profile is valid
    with pytest.raises(ConfigError) as err:
        LinkProfile(**{**GOOD, **changes})
    assert err.value.key == key
    assert key in str(err.value) and "\n" not in str(err.value)


def test_pw_limits_at_short_tari():
    # at Tari 6.25 µs the lower PW limit is the absolute 2 µs (0.265 Tari = 1.66 µs)
    kw = dict(tari_s=6.25e-6, data1_tari=1.5, trcal_s=(64 / 3) / 640e3, dr="64/3")
    assert LinkProfile(**kw, pw_s=2e-6).pw_s == 2e-6
    with pytest.raises(ConfigError, match="link.pw_s"):
        LinkProfile(**kw, pw_s=1.9e-6)


def test_dr_accepts_int_and_fraction():
    from fractions import Fraction

    assert LinkProfile(**{**GOOD, "dr": Fraction(64, 3)}).dr == "64/3"
    a = LinkProfile(tari_s=25e-6, data1_tari=2.0, trcal_s=200e-6, dr=8)
    assert a.dr == "8" and a.blf_hz == 40e3

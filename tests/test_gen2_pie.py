"""PIE envelope encoder and decoder: PASS golden decoding, analytic edge times, round
trips at arbitrary fs/scale/offset, numba kernels vs NumPy twins."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.io import loadmat

from rfsim.gen2.commands import ACK, Query, encode
from rfsim.gen2.link import PROFILES, pie_duration_s
from rfsim.core.rng import trial_rng
from rfsim.gen2.pie import (ask_baseband, command_ask_baseband, pie_decode, pie_decode_arrays, pie_envelope, pie_envelope_for_profile,
                            pie_lead_in, pie_timeline, pr_ask_baseband, timeline_envelope, two_level_threshold)
from reference.gen2_pie import pie_decode_reference, pie_envelope_reference, pie_timeline_reference

QUERY_Q0 = np.array([int(c) for c in "1000000000000000010000"], dtype=np.uint8)


def _timing(tari_s=12.5e-6, data1_tari=1.75, trcal_s=80e-6, pw_s=6e-6, delimiter_s=12.5e-6, **kw):
    return dict(tari_s=tari_s, data1_tari=data1_tari, trcal_s=trcal_s, pw_s=pw_s, delimiter_s=delimiter_s, **kw)


def _assert_frames_equal(a, b):
    assert len(a) == len(b)
    for fa, fb in zip(a, b):
        assert np.array_equal(fa.bits, fb.bits)
        for name in ("start", "end", "delimiter", "tari", "rtcal", "trcal"):
            va, vb = getattr(fa, name), getattr(fb, name)
            assert (math.isnan(va) and math.isnan(vb)) or va == pytest.approx(vb, rel=1e-12, abs=1e-9)


# ----------------------------------------------------------------- golden: PASS tag_decoding


@pytest.fixture(scope="module")
def pass_decoding(reference_data):
    m = loadmat(reference_data / "pass-selftest" / "results_tag_decoding.mat", squeeze_me=True,
                struct_as_record=False)
    return m["signals"], m["results"]


def test_pass_tag_decoding_all_2000(pass_decoding):
    """All 2000 binary demodulator outputs (1.92 MHz tag clock) decode to the stored bits, with
    Tari/RTcal/TRcal exactly equal to the stored tick counts (tari_s, rtcal_s, trcal_s are in
    ticks; tari, rtcal, trcal in seconds = ticks / 1.92 MHz)."""
    signals, results = pass_decoding
    assert len(signals) == len(results) == 2000
    n_query = n_ack = 0
    for sig, res in zip(signals, results):
        assert res.tari == pytest.approx(res.tari_s / 1.92e6)  # the *_s fields are ticks
        frames = pie_decode(sig)
        assert len(frames) == 1
        f = frames[0]
        assert np.array_equal(f.bits, res.data)
        assert f.tari == res.tari_s and f.rtcal == res.rtcal_s
        if res.command == "query":
            n_query += 1
            assert f.trcal == res.trcal_s
        else:
            n_ack += 1
            assert res.command == "ack" and math.isnan(res.trcal_s) and not f.has_trcal
    assert (n_query, n_ack) == (1000, 1000)


def test_pass_tag_decoding_kernel_equals_reference(pass_decoding):
    signals, _ = pass_decoding
    assert len(signals) == 2000
    for sig in signals:
        _assert_frames_equal(pie_decode(sig), pie_decode_reference(sig))


# ----------------------------------------------------------------- encoder


def test_timeline_duration_matches_link_module():
    """Independent duration formula (rfsim.gen2.link.pie_duration_s) for query and frame-sync."""
    bits = encode(Query(q=4))
    tl = pie_timeline(bits, **_timing())
    assert tl.duration_s == pytest.approx(
        pie_duration_s(bits, tari_s=12.5e-6, data1_s=1.75 * 12.5e-6, delimiter_s=12.5e-6, trcal_s=80e-6), rel=1e-12)
    ack = encode(ACK(rn16=0xBEEF))
    tl = pie_timeline(ack, preamble="frame-sync", **_timing(trcal_s=None))
    assert tl.duration_s == pytest.approx(
        pie_duration_s(ack, tari_s=12.5e-6, data1_s=1.75 * 12.5e-6, delimiter_s=12.5e-6), rel=1e-12)


def test_timeline_kernel_equals_reference():
    """Edge times of random commands: the kernel adds the same symbol lengths in the same order
    as numpy.cumsum (sequential), so the times agree bit for bit."""
    rng = trial_rng(71, 0)
    for k in range(40):
        bits = rng.integers(0, 2, int(rng.integers(0, 120))).astype(np.uint8)
        kw = _timing(tari_s=float(rng.uniform(6.25e-6, 25e-6)), data1_tari=float(rng.uniform(1.5, 2.0)),
                     preamble=("query", "frame-sync")[k % 2], cw_before_s=float(rng.uniform(0, 3e-5)),
                     cw_after_s=float(rng.uniform(0, 1e-3)))
        kw["trcal_s"] = 3.0 * kw["tari_s"] * (1.0 + kw["data1_tari"])
        kw["pw_s"] = 0.4 * kw["tari_s"]
        a, b = pie_timeline(bits, **kw), pie_timeline_reference(bits, **kw)
        np.testing.assert_array_equal(a.fall_s, b.fall_s)
        np.testing.assert_array_equal(a.rise_s, b.rise_s)
        assert a.duration_s == b.duration_s
        assert a.rise_s.size == (4 if kw["preamble"] == "query" else 3) + bits.size


@pytest.mark.parametrize("pr_ask", [False, True])
def test_ask_baseband_equals_envelope_times_amplitude(pr_ask):
    """One pass (envelope, PR-ASK sign, CW after ``modulated_s``) gives the samples of
    timeline_envelope and pr_ask_baseband of the whole timeline, bit for bit (exact: the same
    products in the same order)."""
    rng = trial_rng(71, 1 + pr_ask)
    fs = 3.3e6
    for _ in range(6):
        bits = rng.integers(0, 2, int(rng.integers(1, 50))).astype(np.uint8)
        tl = pie_timeline(bits, **_timing(cw_before_s=12.5e-6, cw_after_s=4e-4))
        e = timeline_envelope(tl, depth=0.85, fs_hz=fs, rise_fall_s=1.25e-6)
        ref = pr_ask_baseband(tl, e, amplitude=0.3, fs_hz=fs) if pr_ask else (0.3 * e).astype(np.complex128)
        for modulated_s in (None, float(tl.rise_s[-1] + 25e-6)):
            x = ask_baseband(tl, depth=0.85, fs_hz=fs, amplitude=0.3, pr_ask=pr_ask, rise_fall_s=1.25e-6,
                             modulated_s=modulated_s)
            assert x.dtype == np.complex128
            np.testing.assert_array_equal(x, ref)
        assert np.any(ref.real < 0) == pr_ask


@pytest.mark.parametrize("pr_ask", [False, True])
def test_command_ask_baseband_equals_ask_baseband_of_timeline(pr_ask):
    """Bits to samples in one kernel call (lead-in checked once) gives the samples of
    ask_baseband(pie_timeline(bits)) with modulated_s = last rising edge + modulated_after_s,
    bit for bit (the same kernels on the same edge times), over random timing, preamble, CW
    lengths, sample rates and ramps (hard and raised-cosine)."""
    rng = trial_rng(72, 1 + pr_ask)
    for _ in range(40):
        tari = float(rng.choice([6.25e-6, 12.5e-6, 25e-6]))
        kw = _timing(tari_s=tari, data1_tari=float(rng.uniform(1.5, 2.0)), pw_s=tari * float(rng.uniform(0.3, 0.5)),
                     preamble=str(rng.choice(["query", "frame-sync"])),
                     cw_before_s=float(rng.uniform(0, 2 * tari)))
        kw["trcal_s"] = 2.0 * tari * (1.0 + kw["data1_tari"])
        bits = rng.integers(0, 2, int(rng.integers(0, 40))).astype(np.uint8)
        cw_after = float(rng.uniform(0, 1e-3))
        mod_after = min(cw_after, 2.0 * tari)
        fs = float(rng.choice([2.5e6, 3.3e6, 4e6, 8e6]))
        ramp = float(rng.choice([0.0, 0.1 * tari]))
        tl = pie_timeline(bits, cw_after_s=cw_after, **kw)
        ref = ask_baseband(tl, depth=0.85, fs_hz=fs, amplitude=0.3, pr_ask=pr_ask, rise_fall_s=ramp,
                           modulated_s=float(tl.rise_s[-1] + mod_after))
        lead = pie_lead_in(**kw)
        x = command_ask_baseband(lead, bits, cw_after_s=cw_after, modulated_after_s=mod_after, amplitude=0.3,
                                 pr_ask=pr_ask, depth=0.85, fs_hz=fs, rise_fall_s=ramp)
        assert x.dtype == np.complex128 and x.shape == ref.shape
        np.testing.assert_array_equal(x, ref)
        # a list of bits is converted, the same samples
        np.testing.assert_array_equal(
            command_ask_baseband(lead, bits.tolist(), cw_after_s=cw_after, modulated_after_s=mod_after, amplitude=0.3,
                                 pr_ask=pr_ask, depth=0.85, fs_hz=fs, rise_fall_s=ramp), ref)


def test_command_ask_baseband_refuses_bad_bits_and_slow_edges():
    """The kernel's checks: a bit other than 0/1, edges slower than the shortest interval, as
    pie_timeline/ask_baseband refuse them; pie_lead_in refuses the timing pie_timeline refuses."""
    lead = pie_lead_in(**_timing(preamble="frame-sync", cw_before_s=12.5e-6))
    common = dict(cw_after_s=1e-4, modulated_after_s=2.5e-5, amplitude=1.0, pr_ask=True, depth=0.9, fs_hz=4e6)
    with pytest.raises(ValueError, match="only 0 and 1"):
        command_ask_baseband(lead, np.array([0, 1, 2], dtype=np.uint8), **common)
    with pytest.raises(ValueError, match="shortest low or high"):
        command_ask_baseband(lead, np.array([0, 1], dtype=np.uint8), rise_fall_s=6.5e-6, **common)
    with pytest.raises(ValueError, match="shortest low or high"):
        ask_baseband(pie_timeline([0, 1], **_timing(preamble="frame-sync", cw_before_s=12.5e-6, cw_after_s=1e-4)),
                     amplitude=1.0, pr_ask=True, depth=0.9, fs_hz=4e6, rise_fall_s=6.5e-6)
    with pytest.raises(ValueError, match="cw_after_s"):
        command_ask_baseband(lead, np.array([0, 1], dtype=np.uint8), **{**common, "cw_after_s": -1e-6})
    with pytest.raises(ValueError, match="trcal_s > RTcal"):
        pie_lead_in(**_timing(trcal_s=None, preamble="query"))
    with pytest.raises(ValueError, match="preamble"):
        pie_lead_in(**_timing(preamble="other"))


def test_ramp_width_and_sample_counts_are_one_rule_of_both_paths():
    """The edge check and ramp width (``ramp_width``) and the sample counts (``sample_counts``) are
    numba helpers that ask_baseband (Python) and the command kernel both call: their values equal
    the rules written out here (the shortest low/high interval of NumPy's min, ceil of the
    durations), an edge exactly as long as the shortest interval fits and the next float above it
    does not, on both paths; the source of the two paths holds no copy of either rule (no
    ``math.ceil``, no interval ``rise_s − fall_s``, no ``ramp_per_10_90`` product outside the helpers)."""
    import ast
    import inspect

    from rfsim.gen2 import _pie_kernels as k
    from rfsim.gen2 import pie

    rng = trial_rng(73, 0)
    for _ in range(30):
        tari = float(rng.choice([6.25e-6, 12.5e-6, 25e-6]))
        kw = _timing(tari_s=tari, data1_tari=float(rng.uniform(1.5, 2.0)), pw_s=tari * float(rng.uniform(0.3, 0.5)),
                     preamble="frame-sync", cw_before_s=float(rng.uniform(0, 2 * tari)))
        tl = pie_timeline(rng.integers(0, 2, int(rng.integers(0, 30))).astype(np.uint8),
                          cw_after_s=float(rng.uniform(0, 1e-3)), **kw)
        fs = float(rng.choice([2.5e6, 3.3e6, 4e6]))
        shortest = min((tl.rise_s - tl.fall_s).min(), (tl.fall_s[1:] - tl.rise_s[:-1]).min())
        per = math.pi / (2.0 * math.asin(0.8))
        for rf in (0.0, 0.5 * shortest, shortest):
            assert k.ramp_width(tl.fall_s, tl.rise_s, rf, per, fs) == rf * per * fs
            assert pie._ramp_width_samples(rf, fs, tl) == rf * per * fs
        slow = float(np.nextafter(shortest, np.inf))
        assert k.ramp_width(tl.fall_s, tl.rise_s, slow, per, fs) == -1.0
        with pytest.raises(ValueError, match="shortest low or high"):
            ask_baseband(tl, amplitude=1.0, pr_ask=False, depth=0.9, fs_hz=fs, rise_fall_s=slow)
        mod = float(tl.rise_s[-1] + rng.uniform(0, 1e-4))
        assert k.sample_counts(tl.duration_s, mod, fs) == (math.ceil(tl.duration_s * fs),
                                                           min(math.ceil(tl.duration_s * fs), math.ceil(mod * fs)))
        assert k.sample_counts(tl.duration_s, math.inf, fs) == (math.ceil(tl.duration_s * fs),) * 2
    for fn in (pie.ask_baseband, pie._ramp_width_samples, k.command_baseband_kernel.py_func):
        tree = ast.parse(inspect.getsource(fn).lstrip())
        text = ast.unparse(tree)
        intervals = [ast.unparse(n) for n in ast.walk(tree) if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Sub)
                     and {"rise_s", "fall_s"} <= set(ast.unparse(n).replace("[", " ").replace(".", " ").split())]
        assert "math.ceil" not in text and not intervals, (fn.__name__, intervals)
        assert "ramp_per_10_90 *" not in text and "_RAMP_WIDTH_PER_10_90 *" not in text, fn.__name__
        assert {"ramp_width", "sample_counts"} & {n.attr if isinstance(n, ast.Attribute) else n.id
                                                  for n in ast.walk(tree) if isinstance(n, (ast.Name, ast.Attribute))}


def test_decode_with_levels_refuses_non_finite_envelope():
    """With the levels given, the decoder itself refuses a non-finite envelope (no edges, no
    frames), as it does when it splits the levels itself."""
    env = pie_envelope(QUERY_Q0, **_timing(cw_after_s=20e-6), depth=0.9, fs_hz=4e6)
    levels = two_level_threshold(env)
    assert len(pie_decode(env, levels=levels)) == 1
    bad = env.copy()
    bad[-1] = np.nan
    for x in (pie_decode_arrays(bad, levels=levels), pie_decode_arrays(bad)):
        assert x.pos.size == x.start.size == x.bits.size == 0


@pytest.mark.parametrize("fs_hz", [1e6, 1.234567e6, 3.2e6, 7.77e6])
def test_envelope_edges_at_analytic_times(fs_hz):
    """Edges of the sampled envelope lie within one sample of the hand-computed edge times;
    no drift over a long command with non-integer samples per Tari."""
    tari, d1, trcal, pw, delim, cw0 = 6.25e-6, 1.5, 40e-6, 3.125e-6, 12.5e-6, 20e-6
    rng = np.random.default_rng(5)
    bits = rng.integers(0, 2, 200).astype(np.uint8)
    env = pie_envelope(bits, tari_s=tari, data1_tari=d1, trcal_s=trcal, pw_s=pw, delimiter_s=delim, depth=0.9,
                       fs_hz=fs_hz, cw_before_s=cw0, cw_after_s=20e-6)
    # hand-computed edge times: symbol k ends at t_k, its low pulse is [t_k − PW, t_k)
    falls, rises, t = [cw0], [cw0 + delim], cw0 + delim
    for length in [tari, tari * (1 + d1), trcal] + [tari * d1 if b else tari for b in bits]:
        t += length
        falls.append(t - pw)
        rises.append(t)
    assert set(np.round(np.unique(env), 12)) == {0.1, 1.0}
    low = env < 0.5
    got_f = np.flatnonzero(np.diff(low.astype(int)) == 1) + 1
    got_r = np.flatnonzero(np.diff(low.astype(int)) == -1) + 1
    assert got_f.size == got_r.size == len(falls) == bits.size + 4
    assert np.all(np.abs(got_f - np.array(falls) * fs_hz) <= 1.0)
    assert np.all(np.abs(got_r - np.array(rises) * fs_hz) <= 1.0)


@pytest.mark.parametrize("rise_fall_s", [0.0, 1e-6])
def test_envelope_kernel_equals_reference(rise_fall_s):
    bits = np.random.default_rng(1).integers(0, 2, 64)
    kw = dict(depth=0.85, fs_hz=2.718e6, rise_fall_s=rise_fall_s, cw_before_s=5e-6, cw_after_s=30e-6)
    a = pie_envelope(bits, **_timing(), **kw)
    b = pie_envelope_reference(bits, **_timing(), **kw)
    assert a.shape == b.shape
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-14)


def test_raised_cosine_rise_time():
    """The 10–90 % time of an edge equals rise_fall_s (measured at 1 GS/s, ±2 samples)."""
    fs, trf = 1e9, 2e-6
    env = pie_envelope([0], depth=1.0, fs_hz=fs, rise_fall_s=trf, preamble="frame-sync",
                       **_timing(trcal_s=None, cw_before_s=5e-6, cw_after_s=5e-6))
    first_fall = env[: int(10e-6 * fs)]
    t90 = np.argmax(first_fall < 0.9)
    t10 = np.argmax(first_fall < 0.1)
    assert abs((t10 - t90) - trf * fs) <= 2


def test_invalid_parameters():
    with pytest.raises(ValueError):
        pie_envelope([1], depth=0.9, fs_hz=1e6, **_timing(trcal_s=20e-6))  # TRcal < RTcal
    with pytest.raises(ValueError):
        pie_envelope([1], depth=0.9, fs_hz=-1, **_timing())
    with pytest.raises(ValueError):
        pie_envelope([1], depth=0.9, fs_hz=1e6, rise_fall_s=10e-6, **_timing())
    with pytest.raises(ValueError):
        pie_envelope([1], depth=0.9, fs_hz=1e6, preamble="sync", **_timing())


# ----------------------------------------------------------------- round trips


@pytest.mark.parametrize("fs_hz", [1.92e6, 2.5e6, 3.3333e6, 8e6])
@pytest.mark.parametrize("scale, offset", [(1.0, 0.0), (1e-3, 0.0), (0.5, 7.0), (42.0, -3.0)])
def test_round_trip_query_and_ack(fs_hz, scale, offset):
    """Query then ACK in one envelope at any fs, positive scale and offset."""
    kw = dict(tari_s=12.5e-6, data1_tari=1.5, pw_s=6.25e-6, delimiter_s=12.5e-6, depth=0.8, fs_hz=fs_hz,
              cw_after_s=100e-6, cw_before_s=30e-6)
    q, a = encode(Query(q=7, m=4)), encode(ACK(rn16=0x1234))
    env = np.concatenate([pie_envelope(q, trcal_s=66.7e-6, **kw),
                          pie_envelope(a, trcal_s=None, preamble="frame-sync", **kw)])
    frames = pie_decode(scale * env + offset)
    assert [f.bits.tolist() for f in frames] == [q.tolist(), a.tolist()]
    for f in frames:
        assert abs(f.tari - 12.5e-6 * fs_hz) <= 1.0
        assert abs(f.rtcal - 31.25e-6 * fs_hz) <= 1.0
    assert abs(frames[0].trcal - 66.7e-6 * fs_hz) <= 1.0 and not frames[1].has_trcal
    _assert_frames_equal(frames, pie_decode_reference(scale * env + offset))


def test_round_trip_profile_with_ramps_and_noise():
    """A LinkProfile envelope with raised-cosine edges and additive noise (σ = 5 % of the
    modulation step): decoded bits exact, kernel == reference."""
    prof = PROFILES["miller4-320k"]
    bits = encode(Query(q=3, m=4, dr="64/3"))
    fs = 4e6
    env = pie_envelope_for_profile(bits, prof, fs_hz=fs, rise_fall_s=0.2 * prof.tari_s,
                                   cw_before_s=20e-6, cw_after_s=50e-6)
    x = env + 0.05 * prof.depth * np.random.default_rng(3).standard_normal(env.size)
    frames = pie_decode(x)
    assert len(frames) == 1 and np.array_equal(frames[0].bits, bits)
    assert frames[0].rtcal == pytest.approx(prof.rtcal_s * fs, abs=1.5)
    _assert_frames_equal(frames, pie_decode_reference(x))


def test_decode_with_a_constant_tail_equals_reference():
    """The comparator stops after the first of the equal samples that end the input: a tail
    at the CW level, at the low level (its first sample an edge), inside the hysteresis band,
    or not finite, decodes as the reference does; complex samples with levels as their
    magnitude."""
    prof = PROFILES["miller4-320k"]
    fs = 4e6
    env = pie_envelope_for_profile(encode(ACK(rn16=0xBEEF)), prof, fs_hz=fs, rise_fall_s=0.2 * prof.tari_s,
                                   cw_before_s=prof.tari_s, cw_after_s=400e-6)
    assert np.all(env[-1000:] == env[-1])  # the CW after the command: a constant tail
    for tail in (None, 1.0 - prof.depth, 1.0 - 0.5 * prof.depth, np.inf, np.nan):
        x = env.copy()
        if tail is not None:
            x[-500:] = tail
        frames = pie_decode(x)
        _assert_frames_equal(frames, pie_decode_reference(x))
        if tail is None:
            assert len(frames) == 1 and np.array_equal(frames[0].bits, encode(ACK(rn16=0xBEEF)))
        if tail is not None and not np.isfinite(tail):
            assert frames == []
    z = (0.3 - 0.4j) * env
    levels = two_level_threshold(np.abs(z))
    got, want = pie_decode(z, levels=levels), pie_decode(np.abs(z), levels=levels)
    assert len(got) == len(want) == 1 and np.array_equal(got[0].bits, want[0].bits)
    assert got[0].end == pytest.approx(want[0].end, abs=1e-6)  # √(re² + im²) against hypot: ULPs


def test_decode_empty_and_flat_inputs():
    assert pie_decode(np.ones(100)) == [] and pie_decode_reference(np.ones(100)) == []
    assert pie_decode(np.zeros(0)) == []


@settings(max_examples=60, deadline=None)
@given(
    bits=st.lists(st.integers(0, 1), min_size=1, max_size=64),
    tari_us=st.floats(6.25, 25.0),
    data1_tari=st.floats(1.5, 2.0),
    trcal_rtcal=st.floats(1.1, 3.0),
    pw_frac=st.floats(0.0, 1.0),
    delim_us=st.floats(11.875, 13.125),
    depth=st.floats(0.8, 1.0),
    fs_mhz=st.floats(2.0, 10.0),
    ramp_frac=st.floats(0.0, 0.2),
    query=st.booleans(),
)
def test_round_trip_property(bits, tari_us, data1_tari, trcal_rtcal, pw_frac, delim_us, depth, fs_mhz,
                             ramp_frac, query):
    """Random payloads and in-spec link parameters (anchors §4.1) at random fs ≥ 2 MHz."""
    tari = tari_us * 1e-6
    rtcal = tari * (1 + data1_tari)
    pw_lo, pw_hi = max(0.265 * tari, 2e-6), 0.525 * tari
    fs = fs_mhz * 1e6
    env = pie_envelope(bits, tari_s=tari, data1_tari=data1_tari, trcal_s=trcal_rtcal * rtcal if query else None,
                       pw_s=pw_lo + pw_frac * (pw_hi - pw_lo), delimiter_s=delim_us * 1e-6, depth=depth, fs_hz=fs,
                       rise_fall_s=ramp_frac * tari, preamble="query" if query else "frame-sync",
                       cw_before_s=2 * tari, cw_after_s=2 * rtcal)
    frames = pie_decode(env)
    assert len(frames) == 1
    assert frames[0].bits.tolist() == list(bits)
    assert abs(frames[0].tari - tari * fs) <= 1.0
    assert abs(frames[0].rtcal - rtcal * fs) <= 1.0
    assert frames[0].has_trcal == query
    if query:
        assert abs(frames[0].trcal - trcal_rtcal * rtcal * fs) <= 1.0
    _assert_frames_equal(frames, pie_decode_reference(env))


def test_query_q0_golden_bits_round_trip():
    """The Query(Q=0) bits of anchors §3.3 survive PIE at the PASS tag clock (1.92 MHz)."""
    assert np.array_equal(encode(Query(q=0)), QUERY_Q0)
    env = pie_envelope(QUERY_Q0, tari_s=25e-6, data1_tari=2.0, trcal_s=200e-6, pw_s=12.5e-6, delimiter_s=12.5e-6,
                       depth=0.9, fs_hz=1.92e6, cw_after_s=50e-6, cw_before_s=10e-6)
    (frame,) = pie_decode(env)
    assert np.array_equal(frame.bits, QUERY_Q0)
    assert (frame.tari, frame.rtcal, frame.trcal) == (48.0, 144.0, 384.0)

"""What an exchange keeps by content in the run's cache (:mod:`rfsim.air.cache`): a reader's
command waveform, a tag's decoding of it and where a tag's reply modulates. A cached result
equals the uncached one bit for bit, a changed content misses, the tables are bounded, and
what a key leaves out (Γ_A, Γ_B; the link's gain) does not change the cached result."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import rfsim.devices.tag as tag_module
from rfsim.air.cache import AirCache, ReplyStates, run_cache
from rfsim.air.step import FixedEmitter
from rfsim.channels import Antenna
from rfsim.core.rng import trial_rng
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.devices.tag import PassiveTag, envelope, reply_gamma
from rfsim.gen2.commands import ACK, Query, QueryRep
from rfsim.gen2.linecode import reply_waveform
from rfsim.gen2.pie import pie_decode


def _bits(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 2, n).astype(np.uint8)


def _gamma_rule(bits, gamma_b, gamma_a, **kw) -> np.ndarray:
    """Γ(t) by the rule of the tag's step 5, written out: Γ_B where s > 0, Γ_A elsewhere."""
    s = reply_waveform(bits, **kw)
    out = np.full(s.size, complex(gamma_a), dtype=np.complex128)
    out[s > 0] = complex(gamma_b)
    return out


def _assert_same_bits(a: np.ndarray, b: np.ndarray) -> None:
    """Equal bit patterns (so +0.0 and −0.0 differ)."""
    assert a.dtype == b.dtype == np.complex128 and a.shape == b.shape
    np.testing.assert_array_equal(a.view(np.uint64), b.view(np.uint64))


REPLIES = [  # (bits, M, TRext, BLF [Hz], fs [Hz], start [s], samples)
    (_bits(16, 1), 1, False, 640e3, 4e6, 3.3e-5, 600),
    (_bits(128, 2), 4, False, 320e3 * (1 + 3e-3), 4e6, 3.6255051315681186e-4, 8459),
    (_bits(128, 2), 4, True, 320e3, 4e6, 1.0e-4 + 0.37 / 4e6, 7000),
    (_bits(32, 3), 8, False, 250e3, 2.5e6, 0.0, 3000),
    (_bits(48, 4), 2, True, 160e3, 10e6, 2.0e-5, 9000),
]
GAMMAS = [(0.6 - 0.2j, 0j), (0.6 - 0.2j, complex(-0.0, -0.0)), (0.3 * np.exp(0.7j), 0.3 * np.exp(-0.7j))]


def test_reply_gamma_from_the_cache_equals_the_uncached_one():
    """Miss then hit, for several replies and pairs (Γ_B, Γ_A): the same bits as without a
    cache and as the rule written out; one entry per reply content, whatever the pair."""
    cache = AirCache()
    for k, (bits, m, trext, blf, fs, t0, n) in enumerate(REPLIES):
        kw = dict(m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=t0, n_samples=n)
        for j, (gb, ga) in enumerate(GAMMAS):
            want = _gamma_rule(bits, gb, ga, **kw)
            _assert_same_bits(reply_gamma(bits, **kw, gamma_b=gb, gamma_a=ga), want)
            got = [reply_gamma(bits, **kw, gamma_b=gb, gamma_a=ga, cache=cache) for _ in range(3)]
            for g in got:
                _assert_same_bits(g, want)
            # the first pair's first call misses (a new array); a hit hands out the entry's Γ(t) of
            # this pair, read-only, the same array every time
            assert got[0].flags.writeable == (j == 0)
            assert not got[1].flags.writeable and got[2] is got[1]
            with pytest.raises(ValueError):
                got[1][0] = 0
        assert len(cache.replies) == k + 1
        entry = list(cache.replies.values())[-1]
        assert isinstance(entry, ReplyStates) and not entry.modulating.flags.writeable
        assert 0 < entry.modulating.sum() < n
        np.testing.assert_array_equal(entry.modulating, reply_waveform(bits, **kw) > 0)
        assert len(entry.gammas) == len(GAMMAS)  # Γ_A = −0 is another pair than Γ_A = +0


def test_reply_gamma_equals_the_rule_at_the_window_edges():
    """Γ(t) of a reply, kept (its mask too) or not (no cache, or drawn bits), equals the rule's
    bit for bit, also where the reply starts before the window, ends after it, lies past it,
    or starts a fraction of a sample into it."""
    rng = np.random.default_rng(7)
    for bits, m, trext, blf, fs, t0, n in REPLIES:
        dur = reply_waveform(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=0.0).size / fs
        starts = [t0, -0.5 * dur, -2.0 * dur, 0.9 * n / fs, 2.0 * n / fs, *(rng.uniform(-dur, n / fs, 4))]
        for start in starts:
            kw = dict(m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=float(start), n_samples=n)
            for gb, ga in GAMMAS:
                want = _gamma_rule(bits, gb, ga, **kw)
                _assert_same_bits(reply_gamma(bits, **kw, gamma_b=gb, gamma_a=ga), want)
                _assert_same_bits(reply_gamma(bits, **kw, gamma_b=gb, gamma_a=ga, cache=AirCache(), drawn=True),
                                  want)
                cache = AirCache()
                _assert_same_bits(reply_gamma(bits, **kw, gamma_b=gb, gamma_a=ga, cache=cache), want)
                (entry,) = cache.replies.values()
                np.testing.assert_array_equal(entry.modulating, reply_waveform(bits, **kw) > 0)
    assert reply_gamma(REPLIES[0][0], m=1, trext=False, blf_hz=640e3, fs_hz=4e6, t0_s=0.0, n_samples=0,
                       gamma_b=1j, gamma_a=0j).shape == (0,)


def test_reply_gamma_misses_on_every_changed_content():
    bits, m, trext, blf, fs, t0, n = REPLIES[1]
    base = dict(bits=bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=t0, n_samples=n)
    flipped = bits.copy()
    flipped[5] ^= 1
    changes = [dict(bits=flipped), dict(bits=bits[:-1]), dict(bits=bits.astype(np.int64)), dict(m=8),
               dict(trext=True), dict(blf_hz=np.nextafter(blf, 1e9)), dict(fs_hz=8e6),
               dict(t0_s=np.nextafter(t0, 1.0)), dict(n_samples=n + 1)]
    cache = AirCache(max_entries=len(changes) + 1)
    reply_gamma(**base, gamma_b=1j, gamma_a=0j, cache=cache)
    for k, change in enumerate(changes):
        kw = {**base, **change}
        got = reply_gamma(**kw, gamma_b=1j, gamma_a=0j, cache=cache)
        assert len(cache.replies) == k + 2, change  # a miss: a new entry
        b = kw.pop("bits")
        _assert_same_bits(got, _gamma_rule(b, 1j, 0j, **kw))


def test_reply_table_is_bounded_least_recently_used_first():
    cache = AirCache(max_entries=3)
    bits, m, trext, blf, fs, _, n = REPLIES[0]
    starts = [1e-5, 2e-5, 3e-5, 4e-5]
    for t0 in starts[:3]:
        reply_gamma(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=t0, n_samples=n, gamma_b=1j, gamma_a=0j,
                    cache=cache)
    first = next(iter(cache.replies))
    reply_gamma(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=starts[0], n_samples=n, gamma_b=1j, gamma_a=0j,
                cache=cache)  # a hit: now the most recently used
    assert list(cache.replies)[-1] == first and len(cache.replies) == 3
    reply_gamma(bits, m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=starts[3], n_samples=n, gamma_b=1j, gamma_a=0j,
                cache=cache)
    assert len(cache.replies) == 3 and first in cache.replies  # the start 2e-5 was dropped


def test_reply_gamma_of_drawn_bits_keeps_nothing():
    # an RN16 (bits drawn anew): the same Γ(t) as the rule, and neither the run's cache nor the line
    # code's element memo holds anything of it afterwards
    from rfsim.gen2 import linecode

    bits, m, trext, blf, fs, t0, n = REPLIES[0]
    kw = dict(m=m, trext=trext, blf_hz=blf, fs_hz=fs, t0_s=t0, n_samples=n)
    linecode._WAVEFORM_ELEMENTS.clear()
    cache = AirCache()
    got = reply_gamma(bits, **kw, gamma_b=0.6 - 0.2j, gamma_a=0j, cache=cache, drawn=True)
    assert not linecode._WAVEFORM_ELEMENTS and not cache.replies
    reply_gamma(bits, **kw, gamma_b=0.6 - 0.2j, gamma_a=0j)  # not drawn: its elements are kept
    assert len(linecode._WAVEFORM_ELEMENTS) == 1
    _assert_same_bits(got, _gamma_rule(bits, 0.6 - 0.2j, 0j, **kw))


def _same(a, b) -> bool:
    """Equal records: dataclasses field by field, arrays element by element, NaN equal to NaN."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(_same(getattr(a, f.name), getattr(b, f.name))
                                          for f in dataclasses.fields(a))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind in "fc")
    if isinstance(a, (tuple, list)):
        return isinstance(b, (tuple, list)) and len(a) == len(b) and all(map(_same, a, b))
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def _rounds(n_rounds: int) -> tuple[list, AirCache]:
    from rfsim.bench.exchange import _canonical
    from rfsim.protocols.engine import singulate

    reader, make_tag, channel, query = _canonical(3.0, 7)
    tag = make_tag(None)
    out = [singulate(reader, [tag], channel, t_s=r * 20e-3, rng=trial_rng(7, 2, r), query=query(r), round_index=r)
           for r in range(n_rounds)]
    return out, reader.air_cache


def test_singulations_with_the_reply_cache_equal_those_without(monkeypatch):
    """The canonical exchange, 40 rounds: the EPC reply is taken from the cache (fewer entries
    than replies) and every record is the same as with a tag that keeps nothing."""
    cached, cache = _rounds(40)
    # the RN16 replies (bits drawn anew) are not kept; at least 10 of the 40 EPC replies hit
    assert 0 < len(cache.replies) <= 30
    assert all(key[0] == "tag reply" and key[2] != (16,) for key in cache.replies)
    monkeypatch.setattr(tag_module, "reply_gamma",
                        lambda *a, cache=None, **kw: reply_gamma(*a, **kw, cache=None))
    plain, cache2 = _rounds(40)
    assert not cache2.replies
    assert sum(ex[-1].command == "ACK" and ex[-1].success for ex in cached) >= 35
    assert all(_same(a, b) for a, b in zip(cached, plain))


# ----------------------------------------------------------------------------- command waveform


def _reader(seed: int = 3, **cfg) -> Reader:
    return Reader(ReaderConfig(**cfg), [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(seed, 0))


def test_command_waveform_from_the_cache_equals_a_fresh_one_and_misses_on_changes():
    rd = _reader()
    lk = rd.link
    commands = [Query(dr=lk.dr, m=lk.m, q=0), Query(dr=lk.dr, m=lk.m, q=4, target="B"), ACK(0x1234), ACK(0x1235),
                QueryRep(session=2)]
    for k, cmd in enumerate(commands):
        a = rd.transmit(cmd, t0_s=0.01, cw_after_s=1e-4)
        b = rd.transmit(cmd, t0_s=0.03, cw_after_s=1e-4)  # a hit: the entry's samples
        assert b.samples is a.samples and b.memo is a.memo and len(rd.air_cache.waveforms) == k + 1
        fresh = _reader().transmit(cmd, t0_s=0.01, cw_after_s=1e-4)  # a reader of another run
        assert fresh.samples is not a.samples
        np.testing.assert_array_equal(a.samples.view(np.uint64), fresh.samples.view(np.uint64))
        assert run_cache(a.memo) is rd.air_cache  # the tag finds the run's cache through the memo
    n = len(rd.air_cache.waveforms)
    cmd = commands[2]
    rd.transmit(cmd, t0_s=0.0, cw_after_s=2e-4)  # other CW after
    rd.transmit(cmd, t0_s=0.0, cw_after_s=1e-4, cw_before_s=0.0)  # other CW before
    assert len(rd.air_cache.waveforms) == n + 2
    kept = rd.transmit(cmd, t0_s=0.0, cw_after_s=1e-4).samples
    rd.link = dataclasses.replace(lk, depth=0.85)  # another link profile (its maker): a miss
    other = np.abs(rd.transmit(cmd, t0_s=0.0, cw_after_s=1e-4).samples)
    assert np.isclose(other.min() / other.max(), 1 - 0.85) and not np.isclose(np.abs(kept).min(), other.min())
    assert len(rd.air_cache.waveforms) == n + 2  # the entry of that content is replaced
    rd.link = lk
    assert rd.transmit(cmd, t0_s=0.0, cw_after_s=1e-4).samples is not kept  # and made again
    other_fs = Reader(ReaderConfig(fs_hz=8e6), [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(3, 0),
                      air_cache=rd.air_cache)  # the same run, another sample rate
    assert other_fs.transmit(cmd, t0_s=0.0, cw_after_s=1e-4).samples.size > 1.9 * kept.size
    assert len(rd.air_cache.waveforms) == n + 3


def test_command_waveforms_are_bounded():
    rd = Reader(ReaderConfig(), [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(3, 0), air_cache=AirCache(max_entries=3))
    for rn16 in range(6):
        rd.transmit(ACK(rn16), t0_s=0.0, cw_after_s=1e-4)
    assert len(rd.air_cache.waveforms) == 3


# ----------------------------------------------------------------------------- the tag's decoding


def test_tag_decoding_is_kept_with_the_command_content():
    """Tags at any gain read one decoding per command content (the emitted samples' front end,
    in the waveform's memo); another command (bits) has its own."""
    rd = _reader()
    segs = [FixedEmitter(rd.antennas[0], rd.transmit(cmd, t0_s=0.0, cw_after_s=2e-4)).segment
            for cmd in (ACK(0x1234), ACK(0x1234), ACK(0x4321))]
    fes = [PassiveTag.front_end_of(s) for s in segs]
    assert fes[0] is fes[1] and fes[2] is not fes[0]
    assert fes[0].command(0.0)[0] == ACK(0x1234) and fes[2].command(0.0)[0] == ACK(0x4321)
    assert fes[0].command(0.0) is fes[1].command(0.0)  # decoded once


@pytest.mark.parametrize("rc_s", [0.0, 169e-9])
def test_decoding_a_scaled_copy_gives_the_cached_decoding(rc_s):
    """What the decoding's key leaves out, the link's gain g: decoding |g·x| gives the bits of the
    decoding of x, kept for the content, and its edge positions to rounding.

    Bound: an edge at p = (i − 1) + frac, frac = (thr − a)/d with thr, a, d each |g| times their
    unscaled values up to a few ε (a complex product, its magnitude, the isodata means, and for
    the RC detector its stable first-order recursion): |Δfrac| ≤ 16 ε, and the sum is rounded
    to half an ULP of p; a duration (a difference of two positions) is off by at most twice
    that. With p < 4096 here: |Δ| ≤ 2·(16 ε + ulp(4096)/2) < 2·ulp(4096)."""
    rd = _reader(link_profile="miller4-320k")
    lk = rd.link
    rng = np.random.default_rng(11)
    gains = 10 ** rng.uniform(-6, 1, 40) * np.exp(1j * rng.uniform(-np.pi, np.pi, 40))
    tol = 2 * np.spacing(4096.0)
    for cmd in (Query(dr=lk.dr, m=lk.m, q=0), ACK(0xBEEF), QueryRep(session=1)):
        x = rd.transmit(cmd, t0_s=0.0, cw_after_s=2e-4).samples
        (want,) = pie_decode(envelope(x, fs_hz=rd.fs_hz, rc_s=rc_s))
        for g in gains:
            (got,) = pie_decode(envelope(g * x, fs_hz=rd.fs_hz, rc_s=rc_s))
            np.testing.assert_array_equal(got.bits, want.bits)
            for name in ("start", "end", "delimiter", "tari", "rtcal", "trcal"):
                u, v = getattr(got, name), getattr(want, name)
                assert v < 4096 or math.isnan(v)
                assert (math.isnan(u) and math.isnan(v)) or abs(u - v) <= tol, (name, u, v)



def test_a_run_cache_is_freed_with_its_reader():
    """The memo names the run's cache weakly: no reference cycle keeps a finished run's
    waveforms alive until the cyclic collector runs."""
    import gc
    import weakref

    rd = _reader()
    seg = rd.transmit(ACK(0x1234), t0_s=0.0, cw_after_s=1e-4)
    gone = weakref.ref(rd.air_cache)
    enabled = gc.isenabled()
    gc.disable()
    try:
        del rd
        assert gone() is None and run_cache(seg.memo) is None
    finally:
        if enabled:
            gc.enable()

"""Engine: records of a Query/ACK singulation and every failure reason (issue 4, item 1).

Geometry: free space (no APDP, no surfaces), a 6 dBi circular patch reader antenna at 1 m
height and half-wave dipole tags at the same height facing it, the default ``miller4-320k``
link at 4 MS/s. Everything is deterministic (fixed seeds); the expected outcomes follow from
the link budget quoted in each test, not from a previous run.
"""

from __future__ import annotations

import dataclasses
import math

import crcmod.predefined
import numpy as np
import pytest

from rfsim.channels import Antenna, Channel, HalfWaveDipole, PathSet, Patch, Scene
from rfsim.devices.gen2_tag_state import Reply
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.devices.tag import PassiveTag, TagConfig
from rfsim.protocols.engine import FAILURE_REASONS, run_exchange, singulate
from rfsim.gen2.bits import bits_to_int, hex_to_bits
from rfsim.gen2.commands import ACK, Query
from rfsim.gen2.link import t1
from rfsim.core.rng import trial_rng

HEIGHT_M = 1.0
READER_ANTENNA = Antenna(position_m=(0.0, 0.0, HEIGHT_M), orientation=(0.0, 0.0, 0.0),
                         pattern=Patch(6.0, 70.0), polarization="circular")
# Gen2 CRC-16 = CRC-16/GENIBUS (poly 1021h, preset FFFFh, ones' complement), from crcmod,
# independent of rfsim.gen2.crc.
CRC16 = crcmod.predefined.mkPredefinedCrcFun("crc-16-genibus")  # check value D64Eh


def tag_antenna(x_m: float, y_m: float = 0.0) -> Antenna:
    """Vertical dipole at (x, y, HEIGHT_M) facing the reader (broadside towards it)."""
    return Antenna(position_m=(x_m, y_m, HEIGHT_M), orientation=(math.atan2(-y_m, -x_m), 0.0, 0.0),
                   pattern=HalfWaveDipole(), polarization="linear")


def make_reader(**overrides) -> Reader:
    cfg = ReaderConfig(**{"hopping": False, **overrides})
    return Reader(cfg, [READER_ANTENNA], rng=trial_rng(7, 0))


def make_tag(x_m: float, y_m: float = 0.0, seed_index: int = 1, **overrides) -> PassiveTag:
    return PassiveTag(TagConfig(**overrides), tag_antenna(x_m, y_m), rng=trial_rng(7, seed_index))


def query(reader: Reader, **kw) -> Query:
    lk = reader.link
    return Query(dr=lk.dr, m=lk.m, trext=lk.trext, **{"q": 0, **kw})


def run_round(reader, tags, *, seed=3, t_s=0.0, **qkw):
    return singulate(reader, tags, Channel(Scene()), t_s=t_s, rng=trial_rng(7, seed),
                     query=query(reader, **qkw))


def expected_epc_reply_bits(epc_hex: str) -> np.ndarray:
    """PC (L = EPC words, bits 10h–14h) + EPC + CRC-16, built with crcmod."""
    epc = hex_to_bits(epc_hex)
    pc = (epc.size // 16) << 11
    payload = bytes.fromhex(f"{pc:04X}" + epc_hex)
    crc = CRC16(payload)
    word = lambda v: np.array([(v >> (15 - k)) & 1 for k in range(16)], dtype=np.uint8)  # noqa: E731
    return np.concatenate([word(pc), epc, word(crc)])


def test_singulation_records_command_repliers_and_bits():
    reader, tag = make_reader(), make_tag(2.0)
    ex = run_round(reader, [tag])
    assert [e.command for e in ex] == ["Query", "ACK"]
    first, second = ex
    assert first.replied == (0,) and first.powered == (0,) and first.decoded_tag == 0
    assert first.failure_reason == "" and first.success
    assert first.bits.size == 16 and bits_to_int(first.bits) == tag.state.rn16
    assert second.failure_reason == "" and second.decoded_tag == 0
    np.testing.assert_array_equal(second.bits, expected_epc_reply_bits(TagConfig().epc_hex))
    assert first.timing_ok == (True,) and second.timing_ok == (True,)
    # the ACK follows the RN16 reply (T2 after its end), the records are in time order
    assert second.time_s > first.reply_start_s[0] + reader.link.reply_duration_s(16)
    assert second.time_s - (first.read.start_s + reader.link.reply_duration_s(16)) < 20 * reader.link.tpri_s
    assert first.end_s <= second.time_s
    assert set(e.failure_reason for e in ex) <= set(FAILURE_REASONS)


def test_not_powered_beyond_range():
    # Free space, 30 dBm, 6 dBi patch, 2.15 dBi dipole, circular→linear −3 dB: the incident
    # power at 30 m is 30 + 6 + 2.15 − 3 − 20·log10(4π·30/0.3277 m) ≈ −26 dBm ≪ −12.8 dBm.
    ex = run_round(make_reader(), [make_tag(30.0)])
    assert len(ex) == 1
    assert ex[0].failure_reason == "not powered"
    assert ex[0].powered == () and ex[0].replied == () and ex[0].read is None
    assert ex[0].incident_power_dbm[0] == pytest.approx(-26.0, abs=0.5)


def test_no_reply_when_not_addressed_and_sessions_are_separate():
    reader, tag = make_reader(), make_tag(2.0)
    # target B: the tag's S0 flag is A → powered, silent
    ex = run_round(reader, [tag], target="B")
    assert len(ex) == 1 and ex[0].failure_reason == "no reply" and ex[0].powered == (0,)
    # a read in S0 ...
    assert run_round(reader, [tag], t_s=1e-2, seed=4, target="A")[-1].success
    # ... then the next Query of S0 inverts its flag (A → B): target A gets no reply
    ex = run_round(reader, [tag], t_s=2e-2, seed=5, session=0, target="A")
    assert ex[0].failure_reason == "no reply"
    # S1 is untouched: its flag is still A
    ex = run_round(reader, [tag], t_s=3e-2, seed=6, session=1, target="A")
    assert [e.failure_reason for e in ex] == ["", ""]


def test_collision_of_two_equal_tags():
    # Two tags at the same distance (2 m), ±20° off boresight: equal path length, gain and
    # phase, so their RN16s superpose with equal weight and differ in random bits.
    a = math.radians(20.0)
    tags = [make_tag(2 * math.cos(a), 2 * math.sin(a), 1), make_tag(2 * math.cos(a), -2 * math.sin(a), 2)]
    reader = make_reader()
    ex = run_round(reader, tags)
    first = ex[0]
    assert first.replied == (0, 1)
    assert first.failure_reason == "collision" and first.decoded_tag is None
    assert tags[0].state.rn16 != tags[1].state.rn16
    if len(ex) == 2:  # the reader accepted a garbled RN16 and ACKed it: nobody answers
        assert ex[1].failure_reason == "no reply"


def test_capture_of_the_stronger_tag():
    # 1.5 m and 3 m on boresight: backscatter power falls as d⁻⁴, 40·log10(2) = 12 dB apart;
    # the weaker reply (amplitude ratio 1/4) cannot flip a coherent decision: capture.
    tags = [make_tag(1.5, 0.0, 1, epc_hex="E20000000000000000000001"),
            make_tag(3.0, 0.0, 2, epc_hex="E20000000000000000000002")]
    ex = run_round(make_reader(), tags)
    assert ex[0].replied == (0, 1)
    assert ex[0].decoded_tag == 0 and ex[0].failure_reason == ""
    assert ex[1].replied == (0,) and ex[1].failure_reason == ""
    np.testing.assert_array_equal(ex[1].bits, expected_epc_reply_bits("E20000000000000000000001"))


def test_preamble_not_found_in_noise():
    # NF 40 dB: noise k·T0·4 MHz·10⁴ = −68 dBm per sample. A −35 dBm tag at 40 m is powered
    # (incident ≈ −28.5 dBm) but its reply arrives at ≈ −94 dBm: per-sample SNR ≈ −26 dB,
    # expected normalised preamble correlation √(SNR) ≈ 0.05, below the 0.15 threshold.
    reader = make_reader(noise_figure_db=40.0)
    ex = run_round(reader, [make_tag(40.0, sensitivity_dbm=-35.0)])
    assert len(ex) == 1
    assert ex[0].powered == (0,) and ex[0].replied == (0,)
    assert ex[0].failure_reason == "preamble not found"
    assert ex[0].read.failure_reason == "preamble not found"


def test_crc_error_from_a_tag_with_a_bad_stored_crc():
    reader, tag = make_reader(), make_tag(2.0)
    on_command = tag.state.on_command

    def bad_crc(cmd, **kw):  # the tag's memory holds a wrong StoredCRC (last bit inverted)
        reply = on_command(cmd, **kw)
        if reply is not None and reply.kind == "EPC":
            bits = reply.bits.copy()
            bits[-1] ^= 1
            reply = Reply("EPC", bits)
        return reply

    tag.state.on_command = bad_crc
    ex = run_round(reader, [tag])
    assert [e.failure_reason for e in ex] == ["", "crc error"]
    # the reader decoded exactly what the tag sent; only the CRC check fails
    assert ex[1].decoded_tag == 0 and not ex[1].read.success


@dataclasses.dataclass
class LateTag:
    """A tag that starts its reply ``delay_s`` late (violating T1): the passive tag's Γ(t)
    shifted by whole samples, the absorbing state before it."""

    tag: PassiveTag
    delay_s: float

    @property
    def antenna(self):
        return self.tag.antenna

    def listen(self, incident, *, t0_s, fs_hz):
        r = self.tag.listen(incident, t0_s=t0_s, fs_hz=fs_hz)
        if r.gamma is None:
            return r
        k = int(round(self.delay_s * fs_hz))
        g = np.concatenate([np.full(k, r.gamma_rest), r.gamma[: r.gamma.size - k]])
        return dataclasses.replace(r, gamma=g, reply_start_s=r.reply_start_s + k / fs_hz,
                                   reply_end_s=r.reply_end_s + k / fs_hz)


@pytest.mark.parametrize("delay_s, ok", [(1e-6, True), (25e-6, False)])
def test_timing_violation_outside_t1(delay_s, ok):
    # miller4-320k: T1 = max(RTcal, 10·Tpri) = 31.25 µs, window 31.25·(1 ∓ FrT) ∓ 2 µs.
    # A reply 1 µs late is inside it; 25 µs late is far outside (the receiver searches the
    # T1 window only).
    reader = make_reader()
    lim = t1(reader.link)
    assert lim.max_s - 31.25e-6 < 25e-6 and lim.max_s - 31.25e-6 > 1e-6
    ex = run_exchange(reader, [LateTag(make_tag(2.0), delay_s)], Channel(Scene()), query(reader),
                      t_s=0.0, rng=trial_rng(7, 9), reply_bits=16, expect_crc=False)
    assert ex.replied == (0,)
    assert ex.timing_ok == (ok,)
    if ok:
        assert ex.failure_reason == "" and ex.decoded_tag == 0
    else:
        assert ex.failure_reason == "timing violation" and ex.decoded_tag is None


@dataclasses.dataclass
class CountingTag:
    """Passes everything to a tag and counts the samples it was given."""

    tag: PassiveTag
    samples: int = 0

    @property
    def antenna(self):
        return self.tag.antenna

    def listen(self, incident, *, t0_s, fs_hz):
        self.samples += int(np.asarray(incident).size)
        return self.tag.listen(incident, t0_s=t0_s, fs_hz=fs_hz)


def test_silent_time_is_not_sampled():
    reader = make_reader()
    lk, fs = reader.link, reader.fs_hz
    spy = CountingTag(make_tag(2.0))
    period_s, n_rounds = 1.0, 3
    exchanges, commands = [], []
    for r in range(n_rounds):
        q = query(reader, target="AB"[r % 2])
        ex = singulate(reader, [spy], Channel(Scene()), t_s=r * period_s, rng=trial_rng(7, 20 + r),
                       query=q, round_index=r)
        exchanges += ex
        commands += [q, ACK(bits_to_int(ex[0].bits))]
    assert [e.command for e in exchanges] == ["Query", "ACK"] * n_rounds
    assert all(e.success for e in exchanges)
    # each exchange: one Tari of CW, the command, T1max + reply + 3 Tpri (Gen2 durations)
    t1max = t1(lk).max_s
    for e, cmd in zip(exchanges, commands):
        n_bits = 16 if e.command == "Query" else 128
        expected = (lk.tari_s + lk.command_duration_s(cmd) + t1max + lk.reply_duration_s(n_bits)
                    + 3 * lk.tpri_s) * fs
        assert abs(e.n_samples - expected) <= 1
    total = sum(e.n_samples for e in exchanges)
    assert spy.samples == total  # the tag saw exactly the exchanges' samples
    # air time actually simulated ≈ 2.5 ms per round, vs 1 s between rounds
    assert total < 0.01 * n_rounds * period_s * fs


def test_time_is_float64_late_exchanges_equal_early_ones():
    # The same exchange at t = 0 and at t = 1000 s (fixed channel, static tag) gives the same
    # measurements: absolute time in float64 seconds does not degrade the carrier phase.
    out = []
    for t_s in (0.0, 1000.0):
        reader, tag = make_reader(noise_figure_db=0.0), make_tag(2.0)
        ex = run_exchange(reader, [tag], Channel(Scene()), query(reader), t_s=t_s, rng=trial_rng(7, 30),
                          reply_bits=16, expect_crc=False)
        out.append((ex.read.phase_rad, ex.read.rssi_dbm))
    assert out[0][0] == pytest.approx(out[1][0], abs=1e-6)
    assert out[0][1] == pytest.approx(out[1][1], abs=1e-6)


def test_bench_exchange_reports_its_measurements():
    from rfsim.bench.exchange import bench_exchange
    from rfsim.cli.bench import BENCHMARKS

    assert BENCHMARKS["exchange"][:2] == ("rfsim.bench.exchange", "bench_exchange")
    out = bench_exchange(n_rounds=2)
    assert out["read_rate"] == 1.0
    # Query + ACK segments of miller4-320k at 4 MS/s: ≈ 2.96 ms of air per round
    assert out["air_time_per_round_s"] == pytest.approx(2.96e-3, rel=0.02)
    assert out["air_time_per_wall_s"] > 0 and out["peak_traced_mb"] > 0


def test_bench_floor_works_on_the_canonical_rounds_samples():
    """The floor bench works on the canonical round's own samples (≈ 2.96 ms at 4 MS/s) and
    reports its CPU figures; how the noise compares with a memory pass
    (``noise_over_pass_cpu``) is a figure of ``rfsim bench floor``, not a test (CPU timings
    depend on the machine and its load)."""
    from rfsim.bench.floor import bench_floor
    from rfsim.cli.bench import BENCHMARKS

    assert BENCHMARKS["floor"][:2] == ("rfsim.bench.floor", "bench_floor")
    out = bench_floor(n_rounds=3)
    assert out["air_time_per_round_s"] == pytest.approx(2.96e-3, rel=0.02)
    assert out["samples_per_round"] == round(out["air_time_per_round_s"] * 4e6)
    assert {"pass_cpu_s_per_round", "noise_cpu_s_per_round", "noise_over_pass_cpu"} <= out.keys()


def test_a_new_draw_gives_its_link_constants_once_per_tag_and_they_serve_the_ack():
    """The Query's links (a new draw) are drawn once per tag, in member order, where the air step
    asks their constants; the ACK (no draw) finds those constants in the link cache."""
    from rfsim.protocols.engine import _EngineLinks

    channel, calls = Channel(Scene()), []

    class Counting:
        def backscatter_links(self, antenna, tag_antenna, **kw):
            calls.append(tag_antenna)
            return channel.backscatter_links(antenna, tag_antenna, **kw)

    tags = [make_tag(2.0), make_tag(3.0, 0.5, seed_index=2)]
    ants = tuple(t.antenna for t in tags)
    fc, bw, cache = 915e6, 640e3, {}
    query_links = _EngineLinks(Counting(), READER_ANTENNA, tags, tags, None, trial_rng(7, 9), 0.0, cache, True)
    forward = query_links.held_constants(READER_ANTENNA, ants, fc_hz=fc, bandwidth_hz=bw, propagation="auto",
                                         inbound=False)
    assert calls == list(ants)
    paths = [query_links.paths(READER_ANTENNA, a, fc_hz=fc, t_s=0.0) for a in ants]
    backward = query_links.held_constants(READER_ANTENNA, ants, fc_hz=fc, bandwidth_hz=bw, propagation="auto",
                                          inbound=True)
    assert len(calls) == 2  # asked again: the step's draw, not a new one
    expected = [channel.link(READER_ANTENNA, a, fc_hz=fc).constant_gain(fc) for a in ants]
    assert forward == [p.narrowband_constant(fc, bw, "auto") for p in paths] == expected
    assert backward == expected  # monostatic, reciprocal: the same link both ways
    ack_links = _EngineLinks(Counting(), READER_ANTENNA, tags, tags, None, None, 1e-3, cache, False)
    assert ack_links.held_constants(READER_ANTENNA, ants, fc_hz=fc, bandwidth_hz=bw, propagation="auto",
                                    inbound=False) is forward
    assert len(calls) == 2


def test_reciprocal_held_constants_are_remembered_for_both_directions_at_once(monkeypatch):
    """Monostatic links of a reciprocal channel (backward is forward): the forward call of a new draw
    remembers the same constants for the inbound call, which asks no link (fails when each direction
    forms its own list)."""
    from rfsim.protocols.engine import _EngineLinks

    tags = [make_tag(2.0), make_tag(3.0, 0.5, seed_index=2)]
    ants = tuple(t.antenna for t in tags)
    fc, bw, cache = 915e6, 640e3, {}
    links = _EngineLinks(Channel(Scene()), READER_ANTENNA, tags, tags, None, trial_rng(7, 9), 0.0, cache, True)
    forward = links.held_constants(READER_ANTENNA, ants, fc_hz=fc, bandwidth_hz=bw, propagation="auto",
                                   inbound=False)
    asked = []
    monkeypatch.setattr(_EngineLinks, "_pair", lambda self, *a: asked.append(a))  # the inbound call needs no link
    backward = links.held_constants(READER_ANTENNA, ants, fc_hz=fc, bandwidth_hz=bw, propagation="auto",
                                    inbound=True)
    assert backward is forward and asked == []
    assert forward == [Channel(Scene()).link(READER_ANTENNA, a, fc_hz=fc).constant_gain(fc) for a in ants]


def test_non_reciprocal_held_constants_are_formed_per_direction():
    """A bistatic-like channel whose backward link is not the forward one: the inbound constants are
    its own (the shortcut of the reciprocal case is not taken)."""
    from rfsim.protocols.engine import _EngineLinks

    channel = Channel(Scene())

    class OwnBackward:  # the same numbers as another PathSet object: not the forward link itself
        def backscatter_links(self, antenna, tag_antenna, **kw):
            fwd, _ = channel.backscatter_links(antenna, tag_antenna, **kw)
            return fwd, PathSet(fwd.gain * 0.5, fwd.delay_s, fwd.doppler_hz)

    tags = [make_tag(2.0)]
    ants = (tags[0].antenna,)
    fc, bw = 915e6, 640e3
    links = _EngineLinks(OwnBackward(), READER_ANTENNA, tags, tags, None, trial_rng(7, 9), 0.0, {}, True)
    forward = links.held_constants(READER_ANTENNA, ants, fc_hz=fc, bandwidth_hz=bw, propagation="auto",
                                   inbound=False)
    backward = links.held_constants(READER_ANTENNA, ants, fc_hz=fc, bandwidth_hz=bw, propagation="auto",
                                    inbound=True)
    assert backward is not forward
    assert backward == [links.paths(ants[0], READER_ANTENNA, fc_hz=fc, t_s=0.0).narrowband_constant(fc, bw, "auto")]
    assert backward[0] != forward[0]


def test_record_is_the_constructors_record():
    # the engine fills its frozen records in one step: every field of the dataclass set, nothing
    # else, equal (and hashing alike) to the record the constructor makes of the same values,
    # and still frozen
    reader = make_reader()
    exs = run_round(reader, [make_tag(2.0)])
    assert [e.command for e in exs] == ["Query", "ACK"]
    names = [f.name for f in dataclasses.fields(exs[0])]
    for ex in exs:
        assert list(vars(ex)) == names
        made = type(ex)(**{name: getattr(ex, name) for name in names})
        assert made == ex and repr(made) == repr(ex)
        with pytest.raises(dataclasses.FrozenInstanceError):
            ex.command = "other"

"""Passive tag device: power-up threshold, PIE decoding with the tag clock, reply timing T1,
BLF from TRcal, Γ(t) of the FM0/Miller reply, Query → RN16 → ACK → EPC, every link profile.

The tag is driven with reader-like segments built directly from the PIE envelope
(√P · e(t) · e^{jθ}, CW after the command), not with the reader device. Expectations are
derived from the Gen2 rules (anchors §4.1–4.3) and the waveform generator's exact edge
times (:func:`rfsim.gen2.pie.pie_timeline`), not from the device's own outputs.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.devices.tag import PassiveTag, TagConfig, TagResponse, envelope, incident_power_w
from rfsim.core.config import from_dict
from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import bits_to_int, hex_to_bits, int_to_bits
from rfsim.gen2.commands import ACK, Query, QueryRep, encode
from rfsim.gen2.crc import append_crc5, crc16_ok
from rfsim.gen2.link import PROFILES, frt_fraction, t1_range
from rfsim.gen2.linecode import decode_reply
from rfsim.gen2.pie import pie_envelope, pie_timeline
from rfsim.core.units import dbm_to_w

FS_HZ = 6e6          # 4.7 samples per reply element at 640 kHz, non-integer everywhere
CW_BEFORE_S = 20e-6
P_DBM = 0.0          # 12.8 dB above the default sensitivity
EPC_HEX = "300833B2DDD9014000000027"


def _timing(link):
    return dict(tari_s=link.tari_s, data1_tari=link.data1_tari, trcal_s=link.trcal_s, pw_s=link.pw_s,
                delimiter_s=link.delimiter_s)


def _cw_after_s(link, m, n_bits):
    """CW after the command: the longest T1 and reply a ±20 % clock can produce, plus margin."""
    t1_max = 1.3 * max(link.rtcal_s, 10 / link.blf_hz) + 10e-6
    n_half = 2 * (22 + n_bits + 1)
    return t1_max + 1.3 * n_half * m / (2 * link.blf_hz) + 50e-6


def segment(bits, link, *, preamble, m=None, n_reply_bits=16, p_dbm=P_DBM, phase_rad=0.7,
            rise_fall_tari=0.1, fs_hz=FS_HZ):
    """Incident field at the tag [√W] and the command's true end time (relative to sample 0)."""
    m = link.m if m is None else m
    kw = dict(_timing(link), preamble=preamble, cw_before_s=CW_BEFORE_S,
              cw_after_s=_cw_after_s(link, m, n_reply_bits))
    env = pie_envelope(bits, depth=link.depth, fs_hz=fs_hz, rise_fall_s=rise_fall_tari * link.tari_s, **kw)
    end_s = float(pie_timeline(bits, **kw).rise_s[-1])
    x = math.sqrt(float(dbm_to_w(p_dbm))) * np.exp(1j * phase_rad) * env
    return x, end_s


def query_segment(link, *, m=None, q=0, **kw):
    query = Query(dr=link.dr, m=link.m if m is None else m, trext=link.trext, q=q)
    return segment(encode(query), link, preamble="query", m=m, **kw)


def ack_segment(link, rn16, **kw):
    return segment(encode(ACK(rn16)), link, preamble="frame-sync", n_reply_bits=128, **kw)


def make_tag(seed=1, **cfg):
    return PassiveTag(TagConfig(**cfg), None, rng=np.random.default_rng(seed))


def reply_levels(resp: TagResponse, rs) -> np.ndarray:
    """±1 sequence recovered from Γ(t): +1 where Γ = Γ_B (modulating), −1 where Γ = Γ_A."""
    g = resp.gamma
    assert np.all((g == rs.gamma_a) | (g == rs.gamma_b))
    return np.where(g == rs.gamma_b, 1.0, -1.0)


def decode(resp: TagResponse, rs, n_bits, fs_hz=FS_HZ):
    s = reply_levels(resp, rs)
    det = decode_reply(s.astype(np.complex128), n_bits=n_bits, m=resp.m, trext=resp.trext,
                       blf_hz=resp.blf_hz, fs_hz=fs_hz)
    return det


# ----------------------------------------------------------------------------- Query → RN16


@pytest.mark.parametrize("name", ["miller4-320k", "fm0-40k"])
@pytest.mark.parametrize("clock_error_percent", [0.0, 5.0, -5.0])
def test_query_rn16_reply_timing_blf_and_gamma(name, clock_error_percent):
    link = PROFILES[name]
    tag = make_tag(clock_error_percent=clock_error_percent)
    rs = tag.reflection_states
    t0 = 1e-3
    x, end_rel = query_segment(link)
    r = tag.listen(x, t0_s=t0, fs_hz=FS_HZ)
    assert r.powered and r.reason == "" and r.reply.kind == "RN16"
    assert isinstance(r.command, Query) and r.command.m == link.m
    # Γ takes exactly the two states, both present
    assert r.gamma.shape == x.shape and r.gamma.dtype == np.complex128
    assert set(np.unique(r.gamma)) == {rs.gamma_a, rs.gamma_b}
    # the command end the tag found is the generator's last rising edge, up to the delay of
    # the comparator's hysteresis (10 % of the swing) on the raised-cosine edge: the largest
    # slope is π/(2w) swing per sample with w = 1.18·(10–90 % time)·fs, so the delay is
    # ≤ 0.1·2w/π samples, plus one sample of interpolation
    w = math.pi / (2 * math.asin(0.8)) * 0.1 * link.tari_s * FS_HZ
    edge_tol_s = (1 + 0.1 * 2 * w / math.pi) / FS_HZ
    assert abs(r.command_end_s - (t0 + end_rel)) <= edge_tol_s
    # BLF: f_clk / N with N the integer nearest to TRcal·f_clk / DR (± the half tick of the
    # TRcal count), and within FrT of DR/TRcal
    f_clk = 1.92e6 * (1 + clock_error_percent / 100)
    n_div = f_clk / r.blf_hz
    assert n_div == pytest.approx(round(n_div), abs=1e-9)
    assert abs(round(n_div) - link.trcal_s * f_clk / float(link.dr_value)) <= 0.5 + 0.5 / float(link.dr_value)
    assert abs(r.blf_hz / link.blf_hz - 1) <= frt_fraction(link.dr, link.trcal_s)
    # T1 = max(RTcal, 10 Tpri) with the tag's own Tpri, within one tag clock tick
    t1_expected = max(link.rtcal_s, 10 / r.blf_hz)
    t1 = r.reply_start_s - (t0 + end_rel)
    assert abs(t1 - t1_expected) <= 1 / f_clk + edge_tol_s
    # from the tag's own view of the command end: RTcal counted in ticks (half a tick)
    assert abs(r.reply_start_s - r.command_end_s - t1_expected) <= 0.5 / f_clk + 1e-12
    rng_t1 = t1_range(rtcal_s=link.rtcal_s, blf_hz=link.blf_hz, frt=frt_fraction(link.dr, link.trcal_s))
    assert rng_t1.min_s <= t1 <= rng_t1.max_s
    # the first modulated sample is at the reply start (Miller pilot / FM0 preamble start high)
    first = np.flatnonzero(r.gamma == rs.gamma_b)[0]
    assert abs(t0 + first / FS_HZ - r.reply_start_s) <= 1 / FS_HZ
    # decoding the ±1 sequence at the tag's BLF gives the RN16, starting at reply_start_s
    det = decode(r, rs, 16)
    np.testing.assert_array_equal(det.bits, r.reply.bits)
    assert abs(t0 + det.start_sample / FS_HZ - r.reply_start_s) <= 1 / FS_HZ
    assert tag.state.state == "reply" and bits_to_int(r.reply.bits) == tag.state.rn16


def test_reply_end_and_duration():
    link = PROFILES["fm0-640k"]
    tag = make_tag()
    x, _ = query_segment(link)
    r = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
    # FM0, TRext 0: 6 preamble + 16 + dummy-1 bits of 1/BLF each (anchors §4.2)
    assert r.reply_end_s - r.reply_start_s == pytest.approx((6 + 16 + 1) / r.blf_hz, rel=1e-12)
    last = np.flatnonzero(r.gamma != r.gamma_rest)[-1]
    assert abs(last / FS_HZ - r.reply_end_s) <= 1.5 / FS_HZ


# ----------------------------------------------------------------------------- ACK → EPC


@pytest.mark.parametrize("name", ["miller4-320k", "pass-miller2-48k"])
def test_ack_with_rn16_gives_epc_wrong_rn16_no_reply(name):
    link = PROFILES[name]
    for correct in (True, False):
        tag = make_tag(seed=7, epc_hex=EPC_HEX)
        rs = tag.reflection_states
        x, _ = query_segment(link)
        r1 = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
        rn16 = bits_to_int(decode(r1, rs, 16).bits)
        ack_rn = rn16 if correct else rn16 ^ 0x0400
        x2, _ = ack_segment(link, ack_rn)
        r2 = tag.listen(x2, t0_s=0.01, fs_hz=FS_HZ)
        assert isinstance(r2.command, ACK) and r2.command.rn16 == ack_rn
        if not correct:
            assert r2.reply is None and r2.gamma is None and r2.reason == "no reply"
            assert np.all(r2.reflection(x2.size) == rs.gamma_a)
            continue
        assert r2.reason == "" and r2.reply.kind == "EPC"
        bits = decode(r2, rs, 16 + 96 + 16).bits
        assert crc16_ok(bits)
        # PC = 3000h (96-bit EPC, 6 words in the 5 MSBs), then the EPC
        np.testing.assert_array_equal(bits[:16], int_to_bits(0x3000, 16))
        np.testing.assert_array_equal(bits[16:112], hex_to_bits(EPC_HEX))


# ----------------------------------------------------------------------------- power


@pytest.mark.parametrize("modulation", ["ASK", "PSK"])
def test_power_threshold_0p1_db(modulation):
    link = PROFILES["miller4-320k"]
    cfg = TagConfig(modulation=modulation, psk_gamma_magnitude=0.6, psk_phase_deg=40.0)
    # τ = 1 − |Γ_A|²: ASK (PASS chip on a conjugate-matched antenna) Γ_A = 0; PSK |Γ_A| = 0.6
    tau = 1.0 if modulation == "ASK" else 1 - 0.6 ** 2
    threshold_dbm = cfg.sensitivity_dbm - 10 * math.log10(tau)
    assert cfg.threshold_incident_dbm == pytest.approx(threshold_dbm, abs=1e-12)
    for delta_db, expect in ((0.1, True), (-0.1, False)):
        tag = PassiveTag(cfg, None, rng=np.random.default_rng(3))
        x, _ = query_segment(link, p_dbm=threshold_dbm + delta_db)
        r = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
        assert r.powered is expect
        assert r.incident_power_dbm == pytest.approx(threshold_dbm + delta_db, abs=1e-9)
        if expect:
            assert r.reply.kind == "RN16"
        else:
            assert r.reason == "not powered" and r.reply is None and r.gamma is None and r.command is None


def test_default_sensitivity_is_pass_picmin():
    assert TagConfig().sensitivity_dbm == pytest.approx(10 * math.log10(52.709e-6 / 1e-3), abs=1e-9)
    assert TagConfig().threshold_incident_dbm == pytest.approx(-12.78, abs=0.005)


def test_power_loss_resets_state():
    link = PROFILES["miller4-320k"]
    tag = make_tag(seed=5)
    x, _ = query_segment(link)
    r1 = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
    rn16 = bits_to_int(r1.reply.bits)
    assert tag.state.state == "reply"
    weak, _ = query_segment(link, p_dbm=-30.0)
    r2 = tag.listen(weak, t0_s=0.01, fs_hz=FS_HZ)
    assert not r2.powered and not tag.state.powered and tag.state.state == "ready"
    x3, _ = ack_segment(link, rn16)
    r3 = tag.listen(x3, t0_s=0.02, fs_hz=FS_HZ)
    assert r3.powered and isinstance(r3.command, ACK) and r3.reply is None and r3.reason == "no reply"
    # without the power loss the same ACK is answered
    tag2 = make_tag(seed=5)
    tag2.listen(x, t0_s=0.0, fs_hz=FS_HZ)
    assert tag2.listen(x3, t0_s=0.02, fs_hz=FS_HZ).reply.kind == "EPC"


def test_incident_power_estimate():
    link = PROFILES["fm0-40k"]
    x, _ = query_segment(link, p_dbm=-7.0)
    assert 10 * math.log10(incident_power_w(x) / 1e-3) == pytest.approx(-7.0, abs=1e-9)
    cw = np.full(1000, 0.01 + 0.02j)
    assert incident_power_w(cw) == pytest.approx(abs(0.01 + 0.02j) ** 2, rel=1e-12)
    r = make_tag().listen(np.zeros(100, complex), t0_s=0.0, fs_hz=FS_HZ)
    assert r.incident_power_dbm == -math.inf and not r.powered


# ----------------------------------------------------------------------------- profiles × M


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_every_profile_and_m_answers_and_decodes(name):
    link = PROFILES[name]
    tag = make_tag(seed=11)
    rs = tag.reflection_states
    t = 0.0
    for m in (1, 2, 4, 8):
        x, _ = query_segment(link, m=m)
        r = tag.listen(x, t0_s=t, fs_hz=FS_HZ)
        t += 0.05
        assert r.reason == "" and r.reply.kind == "RN16", (name, m, r.reason)
        assert r.m == m and r.trext == link.trext
        assert abs(r.blf_hz / link.blf_hz - 1) <= link.frt
        np.testing.assert_array_equal(decode(r, rs, 16).bits, r.reply.bits)


# ----------------------------------------------------------------------------- invariances


def test_envelope_scale_dc_and_phase_do_not_matter():
    link = PROFILES["miller4-320k"]
    bits = encode(Query(dr=link.dr, m=link.m, trext=link.trext, q=0))
    kw = dict(_timing(link), preamble="query", cw_before_s=CW_BEFORE_S, cw_after_s=_cw_after_s(link, 4, 16))
    env = pie_envelope(bits, depth=link.depth, fs_hz=FS_HZ, rise_fall_s=0.1 * link.tari_s, **kw)
    results = []
    for amp, dc, phase in ((1.0, 0.0, 0.0), (3.0, 0.0, 2.0), (0.5, 0.4, -1.0), (10.0, 1.5, 3.0)):
        x = amp * (env + dc) * np.exp(1j * phase)
        r = make_tag(seed=2, sensitivity_dbm=-40.0).listen(x, t0_s=0.0, fs_hz=FS_HZ)
        assert r.reason == ""
        results.append(r)
    ref = results[0]
    for r in results[1:]:
        assert r.reply == ref.reply and r.blf_hz == ref.blf_hz
        assert abs(r.reply_start_s - ref.reply_start_s) <= 0.05 / FS_HZ
        assert abs(r.command_end_s - ref.command_end_s) <= 0.05 / FS_HZ


def test_rc_envelope_detector_matches_loop_and_still_decodes():
    link = PROFILES["fm0-640k"]  # Tari 6.25 µs, the shortest pulses
    x, _ = query_segment(link)
    rc = 0.3e-6
    e = envelope(x, fs_hz=FS_HZ, rc_s=rc)
    a = math.exp(-1 / (rc * FS_HZ))
    ref = np.empty(x.size)
    prev = abs(x[0])
    for n, v in enumerate(np.abs(x)):
        prev = a * prev + (1 - a) * v
        ref[n] = prev
    np.testing.assert_allclose(e, ref, rtol=1e-12, atol=1e-15)
    tag = make_tag(envelope_rc_s=rc)
    r = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
    assert r.reason == "" and r.reply.kind == "RN16"
    np.testing.assert_array_equal(decode(r, tag.reflection_states, 16).bits, r.reply.bits)


# ----------------------------------------------------------------------------- errors


def test_decode_errors_and_no_reply():
    link = PROFILES["miller4-320k"]
    tag = make_tag()
    cw = np.full(20000, 0.03 + 0j)
    assert tag.listen(cw, t0_s=0.0, fs_hz=FS_HZ).reason == "decode error"
    good = encode(Query(dr=link.dr, m=link.m, trext=link.trext, q=0))
    bad = good.copy()
    bad[-1] ^= 1  # CRC-5 fails
    x, _ = segment(bad, link, preamble="query")
    r = tag.listen(x, t0_s=0.01, fs_hz=FS_HZ)
    assert r.powered and r.reason == "decode error" and r.command is None
    # a Query body without the TRcal preamble is not a Query
    x, _ = segment(append_crc5(good[:17]), link, preamble="frame-sync")
    assert tag.listen(x, t0_s=0.02, fs_hz=FS_HZ).reason == "decode error"
    # a QueryRep without a round: parsed, no reply
    x, _ = segment(encode(QueryRep(0)), link, preamble="frame-sync")
    r = tag.listen(x, t0_s=0.03, fs_hz=FS_HZ)
    assert isinstance(r.command, QueryRep) and r.reason == "no reply" and r.reply is None


def test_slot_counter_q_gives_no_immediate_reply_sometimes():
    # Q = 4: the slot is 0 with probability 1/16; over 64 tags (fixed seeds) some answer
    # and most do not (P(all answer or none answers) < 1.6e-2 + 1e-77).
    link = PROFILES["miller4-320k"]
    x, _ = query_segment(link, q=4)
    answered = sum(make_tag(seed=s).listen(x, t0_s=0.0, fs_hz=FS_HZ).reply is not None for s in range(64))
    assert 0 < answered < 64


# ----------------------------------------------------------------------------- config


@pytest.mark.parametrize("key,value", [
    ("clock_error_percent", 30.0), ("sensitivity_dbm", 20.0), ("modulation", "QAM"),
    ("clock_jitter_rms", 0.5), ("epc_hex", "XYZ1"), ("epc_hex", "123"), ("envelope_rc_s", -1.0),
    ("psk_gamma_magnitude", 1.5), ("clock_hz", "fast"),
])
def test_config_errors_name_the_key(key, value):
    with pytest.raises(ConfigError) as err:
        TagConfig(**{key: value})
    assert err.value.key == f"tag.{key}"
    with pytest.raises(ConfigError):
        from_dict(TagConfig, {key: value})


def test_config_from_dict_and_states():
    cfg = from_dict(TagConfig, {"clock_error_percent": 5, "modulation": "PSK", "psk_phase_deg": 30})
    assert cfg.clock_error_percent == 5.0 and cfg.clock.f_hz == pytest.approx(1.92e6 * 1.05)
    rs = cfg.reflection_states
    assert rs.gamma_a == pytest.approx(0.5 * np.exp(1j * math.pi / 6))
    assert rs.gamma_b == pytest.approx(0.5 * np.exp(-1j * math.pi / 6))
    assert cfg.tau == pytest.approx(0.75)
    ask = TagConfig().reflection_states
    assert ask.gamma_a == 0 and abs(ask.gamma_b) > 0


# ----------------------------------------------------------------------------- jitter


def test_clock_jitter_spreads_the_reply_start():
    # 200 replies with σ = 5 % of a period: the sample std of the start time estimates
    # σ/f_clk with relative standard error 1/√(2·199) = 5 %; allow 4 standard errors (20 %).
    link = PROFILES["miller4-320k"]
    sigma = 0.05
    x, end_rel = query_segment(link)
    starts = []
    for s in range(200):
        r = make_tag(seed=100 + s, clock_jitter_rms=sigma).listen(x, t0_s=0.0, fs_hz=FS_HZ)
        starts.append(r.reply_start_s)
    std = np.std(starts, ddof=1)
    assert std == pytest.approx(sigma / 1.92e6, rel=0.2)


# ----------------------------------------------------------------------------- reader-like variants


def test_pr_ask_phase_reversals_and_noise():
    # PR-ASK: the carrier phase reverses in every low pulse (depth 100 %, |x| is the PIE
    # envelope); plus complex AWGN at 25 dB CW SNR in the sampled band. The tag must still
    # decode, and its CW power estimate stays within 0.1 dB (the median of |√P + n|² is
    # P·(1 + O(1/SNR)) = +0.014 dB at 25 dB).
    link = PROFILES["miller4-320k"]
    bits = encode(Query(dr=link.dr, m=link.m, trext=link.trext, q=0))
    kw = dict(_timing(link), preamble="query", cw_before_s=CW_BEFORE_S, cw_after_s=_cw_after_s(link, 4, 16))
    env = pie_envelope(bits, depth=1.0, fs_hz=FS_HZ, rise_fall_s=0.1 * link.tari_s, **kw)
    tl = pie_timeline(bits, **kw)
    t = np.arange(env.size) / FS_HZ
    flips = np.searchsorted(0.5 * (tl.fall_s + tl.rise_s), t, side="right")
    p_w = float(dbm_to_w(-5.0))
    x = math.sqrt(p_w) * env * np.where(flips % 2 == 0, 1.0, -1.0)
    assert np.any(x.real < -0.5 * math.sqrt(p_w))  # the phase really reverses
    rng = np.random.default_rng(42)
    sigma2 = p_w / 10 ** 2.5
    x = x + math.sqrt(sigma2 / 2) * (rng.standard_normal(x.size) + 1j * rng.standard_normal(x.size))
    tag = make_tag(seed=9)
    r = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
    assert r.reason == "" and r.reply.kind == "RN16"
    assert abs(r.incident_power_dbm - (-5.0)) < 0.1
    np.testing.assert_array_equal(decode(r, tag.reflection_states, 16).bits, r.reply.bits)


def test_power_dependent_chip_sets_states_and_power_up():
    # PassiveTag(chip=...): the segment's CW power fixes the operating point, which decides
    # power-up (P_chip ≥ 52.709 µW + 2.5 dB) and the reflection states of the reply
    from rfsim.devices.tag_chip import PowerDependentChip

    link = PROFILES["miller4-320k"]
    chip = PowerDependentChip.pass_default()
    for p_dbm, expect in ((-3.0, True), (-12.0, False)):  # 0.50 mW: P_chip ≈ 0.3 mW; 63 µW: ≈ 43 µW
        tag = PassiveTag(TagConfig(), None, rng=np.random.default_rng(3), chip=chip)
        x, _ = query_segment(link, p_dbm=p_dbm)
        r = tag.listen(x, t0_s=0.0, fs_hz=FS_HZ)
        op = tag.operating_point
        assert op.p_available_w == pytest.approx(float(dbm_to_w(p_dbm)), rel=1e-9)
        assert r.powered is expect and op.powered is expect
        g_u, g_m = chip.states(op.p_chip_w)
        assert tag.reflection_states.gamma_a == g_u and tag.reflection_states.gamma_b == g_m
        if expect:
            assert r.reply.kind == "RN16" and r.gamma_rest == g_u
            assert np.any(np.isclose(r.gamma, g_m))


def test_reply_timing_memo_equals_the_rule_for_every_input_it_depends_on():
    # PassiveTag._timing keeps the last (BLF, counted T1) by clock, config, N_TRcal, DR and N_RTcal:
    # a sequence that changes one input at a time (and RTcal in its last bits only, as a Query's and
    # the ACK's measured RTcal do) gets what a tag without the memo computes; dropping DR or
    # N_TRcal from the key, or keying on the RTcal in samples, would fail one of the steps
    from fractions import Fraction

    def fresh(tag, dr, rtcal, fs):
        new = make_tag(clock_error_percent=tag.config.clock_error_percent,
                       blf_error_percent=tag.config.blf_error_percent)
        new._trcal_ticks = tag._trcal_ticks
        t = new._timing(dr, rtcal, fs)
        f_clk = new.clock.f_hz  # the rule written out: N_BLF, BLF·(1 + ε), max(N_RTcal, 10·N_BLF)/f_clk
        n_blf = round(tag._trcal_ticks / float(Fraction(dr if dr == "8" else "64/3")))
        assert t.blf_hz == f_clk / max(n_blf, 1) * (1.0 + 0.01 * tag.config.blf_error_percent)
        assert t.t1_ticks_s == max(round(rtcal * f_clk / fs), 10 * max(n_blf, 1)) / f_clk
        return t.blf_hz, t.t1_ticks_s

    tag = make_tag(clock_error_percent=3.0, blf_error_percent=-2.0)
    steps = [(200, "8", 125.0, 4e6), (200, "8", 124.99999999999997, 4e6), (200, "64/3", 125.0, 4e6),
             (330, "64/3", 125.0, 4e6), (330, "64/3", 700.0, 4e6), (330, "64/3", 700.0, 8e6),
             (330, "64/3", 1400.0, 8e6), (200, "8", 125.0, 4e6), (200, "8", 125.0, 4e6)]
    kept = []
    for trcal_ticks, dr, rtcal, fs in steps:
        tag._trcal_ticks = trcal_ticks
        t = tag._timing(dr, rtcal, fs)
        assert (t.blf_hz, t.t1_ticks_s) == fresh(tag, dr, rtcal, fs)
        kept.append(t)
    assert kept[1] is kept[0] and kept[-1] is kept[-2]  # RTcal's last bits, the same call: kept
    assert len({(t.blf_hz, t.t1_ticks_s) for t in kept}) >= 5  # the steps do change the timing

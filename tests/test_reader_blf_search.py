"""Reader BLF search, RN16 acceptance and NAK after a captured EPC with a bad CRC (issue 19,
items 1 and 3).

Windows are built from the line code directly (``reply_waveform`` at a known BLF and start,
rest level −1 around the reply, complex white noise of known power), so the expected bits,
BLF and Eb/N0 are known independently of the decoder.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from rfsim.channels import Channel, Scene
from rfsim.devices.gen2_tag_state import Reply
from rfsim.devices.reader import ReaderConfig, blf_grid_hz, rn16_threshold_db, search_decode
from rfsim.devices.tag_spread import TagSpreadConfig
from rfsim.core.errors import ConfigError
from rfsim.gen2.link import PROFILES, t1
from rfsim.gen2.linecode import reply_waveform
from rfsim.protocols.inventory import EngineAir, InventoryConfig, run_inventory
from reference.devices_reader import search_decode_reference
from rfsim.core.rng import trial_rng

from test_engine import make_reader, make_tag, run_round


def _windows(name, n_win, *, ebn0_db, spe=3.0, seed=1, second_db=None, spread=True):
    """(windows, truth bits (n, 16), BLFs, fs, lo, hi) of RN16 replies at BLF·(1 + ε), T1
    uniform in the T1 window; a second reply ``second_db`` below when given."""
    lk = PROFILES[name]
    fs = 2 * lk.blf_hz * spe
    rng = np.random.default_rng(seed)
    tr = t1(lk)
    t0 = tr.min_s - 8 / fs
    n = int(math.ceil((tr.max_s + lk.reply_duration_s(16) / (1 - lk.frt) + 3 / lk.blf_hz - t0) * fs))
    sigma2 = lk.m * fs / lk.blf_hz / 10 ** (ebn0_db / 10)  # |h| = 1
    y = math.sqrt(sigma2 / 2) * (rng.standard_normal((n_win, n)) + 1j * rng.standard_normal((n_win, n)))
    bits = rng.integers(0, 2, (n_win, 2, 16), dtype=np.uint8)
    eps = rng.uniform(-0.9, 0.9, (n_win, 2)) * lk.frt if spread else np.zeros((n_win, 2))
    t1s = rng.uniform(tr.min_s, tr.max_s, (n_win, 2))
    amp = [1.0, 0.0 if second_db is None else 10 ** (-second_db / 20)]
    for j in range(n_win):
        for k in range(2):
            s = reply_waveform(bits[j, k], m=lk.m, trext=lk.trext, blf_hz=lk.blf_hz * (1 + eps[j, k]), fs_hz=fs,
                               t0_s=t1s[j, k] - t0, n_samples=n)
            y[j] += amp[k] * np.exp(2j * np.pi * rng.uniform()) * np.where(s == 0, -1.0, s) + 0.3
    lo = int(math.floor((tr.min_s - t0) * fs)) - 1
    hi = int(math.ceil((tr.max_s - t0) * fs)) + 1
    return y, bits, lk.blf_hz * (1 + eps), fs, lo, hi


def _kw(name, fs, lo, hi):
    lk = PROFILES[name]
    return dict(m=lk.m, trext=lk.trext, n_bits=16, blfs_hz=blf_grid_hz(lk), fs_hz=fs, lo=lo, hi=hi)


@pytest.mark.parametrize("name", ["miller4-320k", "fm0-40k"])
def test_search_decode_kernel_equals_its_numpy_twin(name):
    y, _, _, fs, lo, hi = _windows(name, 3, ebn0_db=12.0, second_db=2.0)
    a = search_decode(y, **_kw(name, fs, lo, hi))
    b = search_decode_reference(y, **_kw(name, fs, lo, hi))
    np.testing.assert_array_equal(a.bits, b.bits)
    for f in ("blf_hz", "start", "corr", "gain", "sigma2", "sigma2_bit"):
        np.testing.assert_allclose(getattr(a, f), getattr(b, f), rtol=1e-9, atol=1e-12)
    # threads do not change the result
    c = search_decode(y, **_kw(name, fs, lo, hi), threads=2)
    np.testing.assert_array_equal(a.bits, c.bits)
    np.testing.assert_array_equal(a.decision_ebn0_db, c.decision_ebn0_db)


@pytest.mark.parametrize("name", ["miller4-320k", "fm0-40k"])
def test_single_reply_at_its_own_blf_is_decoded_and_measured(name):
    """40 replies, BLF errors up to ±0.9·FrT, any T1: every RN16 decoded exactly; the BLF
    within one element over the reply (|ΔBLF/BLF| ≤ 1/elements); at Eb/N0 = 14 dB the
    decision-domain statistic is Eb/N0 within 1.5 dB on average (steady samples only)."""
    y, bits, blf, fs, lo, hi = _windows(name, 40, ebn0_db=14.0)
    out = search_decode(y, **_kw(name, fs, lo, hi))
    np.testing.assert_array_equal(out.bits, bits[:, 0])
    lk = PROFILES[name]
    n_el = (20 * lk.m if lk.m > 1 else 12) + 2 * lk.m * 17  # pilot + preamble, 16 bits + dummy
    assert np.all(np.abs(out.blf_hz / blf[:, 0] - 1) <= 1.0 / n_el)
    assert abs(np.mean(out.decision_ebn0_db) - 14.0) < 1.5


def test_rn16_threshold_from_the_false_accept_probability():
    # independent: 16·Q(√(2γ)) = p solved with scipy's normal tail
    for p in (1e-1, 1e-2, 1e-3):
        gamma = 10 ** (rn16_threshold_db(p) / 10)
        assert 16 * norm.sf(math.sqrt(2 * gamma)) == pytest.approx(p, rel=1e-9)
    assert rn16_threshold_db(1e-2) == pytest.approx(7.2, abs=0.05)
    with pytest.raises(ValueError):
        rn16_threshold_db(0.0)


def test_acceptance_needs_the_searching_decoder():
    with pytest.raises(ConfigError, match="reader.rn16_false_accept"):
        ReaderConfig(rn16_false_accept=0.01)
    ReaderConfig(rn16_false_accept=0.01, blf_search="preamble")


@pytest.mark.parametrize("name", ["miller4-320k", "fm0-40k"])
def test_engine_reads_tags_with_their_own_blf_only_with_the_search(name):
    """A tag 0.8·FrT off in BLF and 3 µs off in T1: the searching reader reads RN16 and EPC;
    a reader decoding at the nominal BLF cannot (the reply slips by 0.8·FrT·elements)."""
    lk = PROFILES[name]
    for sign in (1, -1):
        tag = make_tag(2.0, blf_error_percent=sign * 80 * lk.frt, t1_offset_s=sign * 3e-6)
        ex = run_round(make_reader(link_profile=name, blf_search="preamble", rn16_false_accept=0.01), [tag])
        assert [e.failure_reason for e in ex] == ["", ""]
        assert ex[1].read.blf_hz == pytest.approx(lk.blf_hz * (1 + sign * 0.8 * lk.frt), rel=1e-3)
    tag = make_tag(2.0, blf_error_percent=80 * lk.frt)
    ex = run_round(make_reader(link_profile=name), [tag])
    assert ex[-1].failure_reason != ""


def test_collision_rejected_and_capture_with_bad_crc_is_nakked_from_waveforms():
    """Two tags in one Q = 0 slot, 12 dB apart (1.5 m and 3 m), each with its own BLF and T1
    (spread sub-streams). The stronger tag's memory holds a wrong StoredCRC. At sample level:
    the reader captures the stronger RN16 (accepted), ACKs it; only that tag answers (the other
    leaves the slot on a wrong RN16); the EPC's CRC-16 fails in the reader's decode of the
    waveform, so the reader sends a NAK and the tag returns to Arbitrate (not Acknowledged)."""
    from rfsim.devices.tag import TagConfig

    reader = make_reader(blf_search="preamble", rn16_false_accept=0.01)
    sp = TagSpreadConfig(enabled=True)
    tags = []
    for k, x in enumerate((1.5, 3.0)):
        _, rec = sp.draw(TagConfig(), reader.link, rng=trial_rng(9, k, 0))
        tags.append(make_tag(x, 0.0, k + 1, epc_hex=f"E2000000000000000000000{k + 1}",
                             **{f: rec[f] for f in ("blf_error_percent", "t1_offset_s", "chip_gain_db",
                                                    "chip_phase_deg")}))
    on_command = tags[0].state.on_command

    def bad_stored_crc(cmd, **kw):
        reply = on_command(cmd, **kw)
        if reply is not None and reply.kind == "EPC":
            bits = reply.bits.copy()
            bits[-1] ^= 1
            reply = Reply("EPC", bits)
        return reply

    tags[0].state.on_command = bad_stored_crc
    air = EngineAir(reader, tags, Channel(Scene()), rng=trial_rng(9, 5), keep_exchanges=True)
    log = run_inventory(air, InventoryConfig(q_mode="fixed", q_initial=0.0, max_rounds=1))
    names = [e.command for e in air.exchanges]
    assert names[:3] == ["Query", "ACK", "NAK"]
    first, ack = air.exchanges[0], air.exchanges[1]
    assert first.replied == (0, 1) and first.success  # both replied; the stronger RN16 accepted
    assert ack.replied == (0,) and ack.failure_reason == "crc error" and ack.read.blf_hz > 0
    assert log.slots["slot_type"][0] == "collision" and log.slots["tag"][0] == -1
    assert tags[0].state.state == "arbitrate" and tags[1].state.state == "arbitrate"

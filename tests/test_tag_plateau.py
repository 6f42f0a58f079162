"""The shared front end's CW plateau (rfsim.devices.tag: which sample the CW median lands on, and
whether the samples around it are ±one value) — the numba kernel against its NumPy twin."""

import numpy as np
import pytest

from rfsim.devices import _tag_kernels as _k
from rfsim.devices.tag import _MIN_MODULATION, _PLATEAU_MARGIN, _plateau, plateau_reference
from rfsim.gen2.pie import two_level_threshold


def _both(x):
    env = np.abs(x)
    levels = two_level_threshold(env)
    return _plateau(x, env, levels), plateau_reference(x, env, levels)


def _kernel_alone(x):
    """The kernel's own answer (−2: it leaves the case to the NumPy twin)."""
    env = np.abs(x)
    thr, lo, hi = two_level_threshold(env)
    n = env.size
    return int(_k.plateau_kernel(x, env, float(thr), bool(hi > 0 and hi - lo >= _MIN_MODULATION * hi),
                                 _PLATEAU_MARGIN, np.empty(n), np.empty(n, np.int64),
                                 np.empty(2 * _PLATEAU_MARGIN + 1, np.int64)))


def _pie_like(rng, n, cw, *, flip=True, edge_noise=True):
    """A CW of ±cw with low pulses (a PR-ASK-like segment) and optional odd edge samples."""
    x = np.full(n, cw, dtype=np.complex128)
    if flip:
        x[rng.integers(0, n // 2):] *= -1
    for start in rng.integers(0, n - 20, 6):
        x[start:start + 10] *= 0.1
        if edge_noise:
            x[start - 1] *= 0.6 + 0.3j
    return x


@pytest.mark.parametrize("seed", range(12))
def test_kernel_equals_reference_on_pie_like_segments(seed):
    rng = np.random.default_rng(seed)
    x = _pie_like(rng, int(rng.integers(40, 3000)), complex(*rng.normal(size=2)), flip=bool(seed % 2))
    got, want = _both(x)
    assert got == want
    assert got is not None  # a clean CW: the median is on the plateau
    assert x[got] == x[want]
    assert _kernel_alone(x) == got  # found by the kernel itself (the median is a candidate sample)


def test_a_median_that_is_no_candidate_is_left_to_the_twin():
    """Distinct magnitudes (the first, middle and last selected samples are not the median):
    the kernel answers −2 and the caller's answer is the twin's."""
    rng = np.random.default_rng(7)
    x = rng.uniform(1.0, 2.0, 101).astype(np.complex128)
    x[[0, 50, 100]] = [1.0, 1.01, 1.02]  # the three candidates all far below the median
    assert _kernel_alone(x) == -2
    assert _plateau(x, np.abs(x), two_level_threshold(np.abs(x))) == plateau_reference(
        x, np.abs(x), two_level_threshold(np.abs(x)))


@pytest.mark.parametrize("seed", range(12))
def test_kernel_equals_reference_without_a_plateau(seed):
    # Rayleigh-like magnitudes (no two equal) or a CW of a few distinct values around the median
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(17, 500))
    if seed % 3 == 0:
        x = rng.normal(size=n) + 1j * rng.normal(size=n)
    elif seed % 3 == 1:
        x = rng.choice(np.array([1.0, -1.0, 1.0j, 0.9]), size=n).astype(np.complex128)
    else:  # equal magnitudes, but not ± one value (a phase rotation)
        x = np.exp(1j * rng.uniform(0, 2 * np.pi, n))
    got, want = _both(x)
    assert got == want
    if seed % 3 == 2:
        assert got is None  # equal magnitudes are not enough


def test_ties_at_the_window_edge():
    # the median value's run is exactly 2·margin + 1 long, or one sample short, at various offsets
    for run in (16, 17, 18):
        for offset in range(-3, 4):
            n = 101
            x = np.linspace(1.0, 2.0, n).astype(np.complex128)  # distinct magnitudes
            mid = (n - 1) // 2 + offset
            x[mid - run // 2: mid - run // 2 + run] = 1.5
            x[mid - run // 2: mid - run // 2 + run: 3] *= -1
            got, want = _both(x)
            assert got == want
            if offset == 0:  # the run centred on the median: a plateau exactly when it spans the window
                assert (got is not None) == (run >= 17)


def test_too_few_samples_and_nan():
    assert _both(np.ones(16, complex)) == (None, None)
    assert _both(np.ones(17, complex)) == (8, 8)
    x = np.ones(40, complex)
    x[3] = np.nan  # unmodulated (the NaN makes the level split NaN): every sample counts
    got, want = _both(x)
    assert got == want
    assert _MIN_MODULATION > 0


def test_reflection_kernel_equals_reference():
    # Γ(t) of a reply from its ±1 waveform (0 outside the reply, a NaN taken as "not +1")
    from rfsim.devices.tag import _reflection
    from reference.devices_tag import reflection_reference

    rng = np.random.default_rng(4)
    s = rng.choice([-1.0, 0.0, 1.0], size=1001)
    s[[3, 500]] = np.nan
    for gb, ga in ((-0.6 + 0.3j, 0.2 - 0.1j), (1.0, 0j), (np.complex128(0.5j), complex(-0.25, 0.75))):
        out, ref = _reflection(s, gb, ga), reflection_reference(s, gb, ga)
        assert out.dtype == ref.dtype == np.complex128
        assert np.array_equal(out.view(np.float64), ref.view(np.float64))  # a selection: exact
        # from the stored mask of where s > 0 (a reply seen before), the same samples
        masked = _reflection(s > 0, gb, ga)
        assert np.array_equal(masked.view(np.float64), ref.view(np.float64))
    assert _reflection(s, 1j, 0j)[np.flatnonzero(s > 0)[0]] == 1j


def _separate(x):
    """The shared front end's levels and plateau from the separate steps (isodata split of
    |x|, then the plateau), each checked against its own twin elsewhere."""
    env = np.abs(x)
    levels = two_level_threshold(env)
    return levels, _plateau(x, env, levels)


@pytest.mark.parametrize("seed", range(16))
def test_front_end_in_one_call_equals_the_separate_steps(seed):
    # PIE-like, Rayleigh-like, too short, NaN-bearing and constant segments: levels and plateau
    # of SharedFrontEnd (one kernel call) equal those of the separate steps, bit for bit
    from rfsim.devices.tag import SharedFrontEnd

    rng = np.random.default_rng(300 + seed)
    kind = seed % 4
    if kind == 0:
        x = _pie_like(rng, int(rng.integers(40, 3000)), complex(*rng.normal(size=2)), flip=bool(seed % 8))
    elif kind == 1:
        n = int(rng.integers(1, 400))
        x = rng.normal(size=n) + 1j * rng.normal(size=n)
    elif kind == 2:
        x = np.full(int(rng.integers(1, 40)), complex(*rng.normal(size=2)))
    else:
        x = _pie_like(rng, 500, 1.0 + 0.5j)
        x[int(rng.integers(0, 500))] = np.nan
    fe = SharedFrontEnd(x, fs_hz=1e6)
    levels, plateau = _separate(x)
    assert np.array_equal(np.array(fe.levels), np.array(levels), equal_nan=True)
    assert fe.plateau == plateau
    if kind == 0:
        assert fe.plateau is not None and fe.cw_sample == x[fe.plateau]


@pytest.mark.parametrize("seed", range(12))
def test_kernel_equals_reference_with_a_cw_tail(seed):
    # a reader segment's shape: the command, then a long run of one CW sample; the median in
    # the tail or in the head, the window across their boundary, the tail below the threshold
    rng = np.random.default_rng(500 + seed)
    n_head, n_tail = int(rng.integers(20, 600)), int(rng.integers(1, 3000))
    cw = complex(*rng.normal(size=2))
    head = _pie_like(rng, n_head, cw, flip=bool(seed % 2), edge_noise=bool(seed % 3))
    tail_value = (cw, -cw, 0.1 * cw, cw * 1j)[seed % 4]
    x = np.concatenate([head, np.full(n_tail, tail_value)])
    got, want = _both(x)
    assert got == want
    assert _kernel_alone(x) in (got if got is not None else -1, -2)
    fe_levels, fe_plateau = _separate(x)
    from rfsim.devices.tag import SharedFrontEnd

    fe = SharedFrontEnd(x, fs_hz=1e6)
    assert fe.levels == fe_levels and fe.plateau == fe_plateau == want


def test_window_across_the_head_and_tail_boundary():
    # the median value's samples: a few at the end of the head, then the tail; the window of
    # 2·margin + 1 takes both (and ± the median sample: a plateau), or meets a sample that is
    # not ± it (no plateau)
    for k in range(0, 2 * _PLATEAU_MARGIN + 3):
        for odd in (False, True):
            x = np.concatenate([np.full(40, 0.2 + 0j), np.linspace(1.0, 2.0, 30).astype(complex),
                                np.full(k, -1.5 + 0j), np.full(80, 1.5 + 0j)])
            if odd and k:
                x[70] = 1.5j  # same magnitude, not ± the CW sample
            got, want = _both(x)
            assert got == want
            assert _kernel_alone(x) == (-1 if want is None else want)


def _frames_fields(frames):
    # exact bits of the durations (NaN TRcal of a frame-sync included), and the bits
    return [(np.array([f.start, f.end, f.delimiter, f.tari, f.rtcal, f.trcal]).tobytes(), f.bits.tolist())
            for f in frames]


@pytest.mark.parametrize("seed", range(12))
def test_shared_front_end_decodes_up_to_the_cw_tail_as_over_the_whole_segment(seed):
    # the decoder reads the envelope up to the first sample of the equal run that ends it: the
    # frames of that head equal those of the whole segment (zeros of both signs, NaN, no tail)
    from rfsim.devices.tag import SharedFrontEnd
    from rfsim.gen2.pie import pie_decode

    rng = np.random.default_rng(700 + seed)
    cw = complex(*rng.normal(size=2))
    head = _pie_like(rng, int(rng.integers(20, 600)), cw, flip=bool(seed % 2), edge_noise=bool(seed % 3))
    tail_value = (cw, -cw, 0.1 * cw, 0j, complex(-0.0, 0.0), np.nan)[seed % 6]
    x = np.concatenate([head, np.full(int(rng.integers(0, 3000)), tail_value)])
    fe = SharedFrontEnd(x, fs_hz=1e6)
    assert fe._decoded_env.size <= x.size
    want = pie_decode(np.abs(x), levels=two_level_threshold(np.abs(x)))
    assert _frames_fields(pie_decode(fe._decoded_env, levels=fe.levels)) == _frames_fields(want)


def _commands():
    """Every command kind and a few ACKs as DSB-ASK and PR-ASK segments (CW after of a few lengths,
    with and without edges' rise and fall), and where its constant CW starts."""
    from rfsim.gen2.commands import ACK, COMMAND_TYPES, encode
    from rfsim.gen2.pie import command_ask_baseband, pie_lead_in

    fs, tari = 4e6, 12.5e-6
    for cmd in [t() for t in COMMAND_TYPES] + [ACK(rn16=r) for r in (0, 0xFFFF, 0x5A3C)]:
        lead = pie_lead_in(tari_s=tari, data1_tari=1.75, trcal_s=3.0 * 2.75 * tari, pw_s=0.4 * tari,
                           delimiter_s=12.5e-6, preamble=cmd.PREAMBLE, cw_before_s=20e-6)
        for pr_ask, cw_after, rise in ((False, 200e-6, 0.1), (True, 30e-6, 0.0), (True, 500e-6, 0.33)):
            yield cmd, command_ask_baseband(lead, encode(cmd), cw_after_s=cw_after, modulated_after_s=tari,
                                            amplitude=0.3, pr_ask=pr_ask, depth=0.9, fs_hz=fs,
                                            rise_fall_s=rise * tari)


@pytest.mark.parametrize("seed", range(8))
def test_front_end_decoding_in_one_call_equals_the_decoder(seed):
    # SharedFrontEnd decodes the ideal detector's command in its front-end kernel call: the command
    # and the first frame equal those of rfsim.gen2.pie.pie_decode of |x| with its own levels, bit
    # for bit (every command kind; PIE-like segments with and without a CW tail, NaN, too short)
    from rfsim.devices.tag import SharedFrontEnd, _command_of
    from rfsim.gen2.pie import pie_decode

    if seed == 0:
        segments = [x for _, x in _commands()]
    else:
        rng = np.random.default_rng(900 + seed)
        cw = complex(*rng.normal(size=2))
        segments = []
        for k in range(20):
            head = _pie_like(rng, int(rng.integers(25, 600)), cw, flip=bool(k % 2), edge_noise=bool(k % 3))
            tail = np.full(int(rng.integers(0, 300)), (cw, -cw, 0j, np.nan)[k % 4])
            segments.append(np.concatenate([head, tail]))
        segments += [np.full(1, cw), np.full(2, cw), np.array([cw, 0.1 * cw])]
    n_frames = 0
    for x in segments:
        fe = SharedFrontEnd(x, fs_hz=4e6)
        env = np.abs(x)
        want = _command_of(pie_decode(env, levels=two_level_threshold(env)))
        got = fe.command(0.0)
        assert got.command == want.command
        assert (got.frame is None) == (want.frame is None)
        if want.frame is not None:
            n_frames += 1
            assert _frames_fields([got.frame]) == _frames_fields([want.frame])
    assert n_frames > 0 or seed > 0


def test_shared_decoding_is_keyed_by_content_and_rc_not_by_the_tags_power():
    # SharedFrontEnd.command(rc_s), kept per rc_s in the emitted segment's memo, is the decoding of every
    # scaled copy g·x a powered tag sees: the relative thresholds make it scale-invariant (exactly for
    # |g| a power of two, where the scaling is exact); it does depend on the detector's RC (a memo
    # keyed on the segment alone would fail the last assertion)
    from rfsim.devices.tag import SharedFrontEnd, _command_of, envelope
    from rfsim.gen2.commands import Query, encode
    from rfsim.gen2.pie import command_ask_baseband, pie_decode, pie_lead_in

    fs, tari = 4e6, 12.5e-6
    lead = pie_lead_in(tari_s=tari, data1_tari=1.75, trcal_s=3.0 * 2.75 * tari, pw_s=0.4 * tari, delimiter_s=12.5e-6,
                      cw_before_s=20e-6)
    x = command_ask_baseband(lead, encode(Query(q=3)), cw_after_s=200e-6, modulated_after_s=tari, amplitude=0.3,
                             pr_ask=False, depth=0.9, fs_hz=fs, rise_fall_s=0.1 * tari)
    fe = SharedFrontEnd(x, fs_hz=fs)
    by_rc = {}
    for rc in (0.0, 0.3e-6, 3e-6):
        got = fe.command(rc)
        assert fe.command(rc) is got  # kept
        for k in (-20, -3, 0, 5):  # the tag's power: a scaled copy, decoded on its own samples
            want = _command_of(pie_decode(envelope(2.0 ** k * x, fs_hz=fs, rc_s=rc)))
            assert got.command == want.command == Query(q=3)
            assert _frames_fields([got.frame]) == _frames_fields([want.frame])
        by_rc[rc] = _frames_fields([got.frame])
    assert by_rc[3e-6] != by_rc[0.0]  # the RC shifts the edges: the key needs rc_s


def _front_end_fields(fe):
    # everything the tags read of a shared front end, as exact bits
    cmd, frame = fe.command(0.0)
    return (np.array(fe.levels).tobytes(), fe.plateau, getattr(fe, "cw_sample", None),
            fe._decoded_env.tobytes(), cmd, None if frame is None else _frames_fields([frame]))


@pytest.mark.parametrize("modulation", ["DSB-ASK", "PR-ASK", "SSB-ASK"])
def test_head_only_front_end_equals_the_whole_segment_on_every_command(modulation):
    # a reader's cached command waveform names where its constant CW starts (Waveform.cw_from,
    # the memo's "cw_from"): those samples are all equal, and the tag's front end over the head
    # up to there gives what it gives over the whole segment, bit for bit, for every command
    # kind, CW length, link profile and sample rate; a tail that is not constant would show
    import dataclasses

    from rfsim.channels.antennas import Antenna
    from rfsim.core.rng import trial_rng
    from rfsim.devices.reader import Reader, ReaderConfig
    from rfsim.devices.tag import PassiveTag, SharedFrontEnd
    from rfsim.air.step import FixedEmitter
    from rfsim.gen2.commands import COMMAND_TYPES, ACK
    from rfsim.gen2.link import PROFILES

    n_known = n_head = 0
    for profile, fs, rise_fall in (("miller4-320k", 4e6, 0.1), ("fm0-40k", 1.3e6, 0.33), ("miller4-320k", 3.3e6, 0.0)):
        lk = dataclasses.replace(PROFILES[profile], modulation=modulation)
        rd = Reader(ReaderConfig(link_profile=profile, fs_hz=fs, pie_rise_fall_tari=rise_fall),
                    [Antenna([0.0, 0.0, 1.0])], rng=trial_rng(66, 1), link=lk)
        cmds = [t() for t in COMMAND_TYPES] + [ACK(rn16=r) for r in (0, 0xFFFF, 0x5A3C)]
        for cmd in cmds:
            for cw_after in (0.0, 1.9 * lk.tari_s, 2.1 * lk.tari_s, 3e-4, 1.7e-3):
                tx = rd.transmit(cmd, t0_s=0.0, cw_after_s=cw_after)
                x, c = tx.samples, tx.memo.get("cw_from")
                if modulation == "SSB-ASK" or cw_after <= 2.0 * lk.tari_s:
                    assert c is None  # no constant CW known (SSB), or none after the modulated span
                if c is None:
                    continue
                n_known += 1
                assert 0 < c < x.size and np.all(x[c:] == x[c])
                # the kernel's own modulated span ends at most a few samples before c
                assert np.any(x[c - 4:c] == x[c])
                head = SharedFrontEnd(x, fs_hz=tx.fs_hz, cw_from=c)
                whole = SharedFrontEnd(x, fs_hz=tx.fs_hz)
                assert _front_end_fields(head) == _front_end_fields(whole)
                assert head.env.tobytes() == np.abs(x).tobytes()
                assert _front_end_fields(PassiveTag.front_end_of(FixedEmitter(rd.antennas[0], tx).segment)) \
                    == _front_end_fields(whole)
                assert head.command(0.0)[0] == cmd
                if c == x.size - 1:
                    continue
                n_head += 1
                # a claim of a constant tail that is not: the whole segment's front end differs
                bad = x.copy()
                bad[-1] = 0.5 * bad[-1]
                assert _front_end_fields(SharedFrontEnd(bad, fs_hz=tx.fs_hz, cw_from=c)) \
                    != _front_end_fields(SharedFrontEnd(bad, fs_hz=tx.fs_hz))
    assert (n_known > 0) == (n_head > 0) == (modulation != "SSB-ASK")

"""The statistic-level receiver model (``reader.rx_model = "statistic"``,
:mod:`rfsim.devices.reader_statistic`) against the sample-level receiver and against its own
definition.

Equivalence (tests/statistic_trials.py): the same synthetic replies received by both models
over N trials per point; each summary (P(detected), packet success, BER, P(capture), RSSI and
phase mean and standard deviation) must agree within a two-sample interval from the trial
count: |p̂₁ − p̂₂| ≤ Z·√(p̄(1 − p̄)·2/N) + 1/N for proportions (normal approximation, p̄ the pooled
estimate); |m̂₁ − m̂₂| ≤ Z·√(s₁²/N₁ + s₂²/N₂) for means (the BER as the mean of the bit errors per
detected reply over the reply's bits: errors come in bursts, a reply is one trial); |ln(s₁/s₂)| ≤ Z·√(1/(2(N₁−1)) + 1/(2(N₂−1)))
for standard deviations. Z = 4 (two-sided 6e−5 per comparison: with ≈ 60 comparisons in the
slow tier a false failure has probability ≈ 4e−3). The default tier runs N = 300 per point at a
few points; the slow tier N = 10,000 per point over BER/PER vs Eb/N0 for FM0 and Miller-2/4/8,
P(detected) near the detection threshold, P(capture) at 0/3/6 dB.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.core.errors import ConfigError
from rfsim.devices import reader_statistic as rs
from rfsim.devices.reader import ReaderConfig
from rfsim.gen2._linecode_kernels import INDEX_EPS
from rfsim.gen2.linecode import reply_duration_s
from reference.ulp import assert_close_ulp
from reference.devices_reader_statistic import (block_cuts_reference, piece_map_reference, piece_moments_reference,
                                               receive_reference)

import statistic_trials as trials

Z = 4.0


# ----------------------------------------------------------------------------- configuration


def test_rx_model_default_is_sample_and_bad_values_are_one_line_errors():
    assert ReaderConfig().rx_model == "sample"
    with pytest.raises(ConfigError) as err:
        ReaderConfig(rx_model="stats")
    msg = str(err.value)
    assert "reader.rx_model" in msg and "'stats'" in msg and "'statistic'" in msg and "\n" not in msg
    with pytest.raises(ConfigError, match="blf_search"):
        ReaderConfig(rx_model="statistic", blf_search="preamble")


def test_statistic_reader_adds_no_air_noise_and_sample_reader_does():
    sample = trials.make_reader(4, "sample", 1)
    stat = trials.make_reader(4, "statistic", 1)
    assert stat.noise_power_w() == 0.0
    assert sample.noise_power_w() == pytest.approx(1.380649e-23 * 290.0 * 4e6 * 10.0, rel=1e-9)


# ----------------------------------------------------------------------------- pieces


@pytest.mark.parametrize("m", [1, 2, 4, 8])
def test_piece_map_matches_reference(m):
    rng = np.random.default_rng(m)
    n_checked = 0
    for _ in range(20):
        ratio = rng.uniform(0.05, 0.45)
        start = rng.uniform(10, 30)
        n_el = 2 * m * int(rng.integers(10, 40))
        n = int(start + n_el / ratio) + int(rng.integers(3, 20))
        i_first = int(rng.integers(int(start) + 1, int(start) + 60))
        got = rs.piece_map(n, i_first, start, ratio, m, n_el)
        want = piece_map_reference(n, i_first, start, ratio, m, n_el)
        for g, w in zip(got, want):  # the same exactly-rounded arithmetic on both sides
            np.testing.assert_array_equal(g, w)
        n_checked += 1
    assert n_checked == 20


def _elements(n, start, ratio):
    u = (np.arange(n) - start) * ratio
    return np.where(u < 0, -1, np.floor(u + INDEX_EPS)).astype(np.int64)


@pytest.mark.parametrize("m", [1, 2, 4, 8])
def test_spread_noise_gives_every_functional_of_the_receiver_its_exact_value(m):
    """On white noise n, the pieces' sums spread over the pieces (ñ) give the same half-bit sums
    Σσ_i·n_i, the same measurement sums Σ_steady s_i·n_i for any decoded levels, and the same rest
    sum as n itself: the receiver cannot tell ñ from n."""
    rng = np.random.default_rng(10 + m)
    ratio, start, n_half = 0.16 if m > 1 else 0.32, 17.3, 2 * 40
    n_el = n_half * m
    n = int(start + n_el / ratio) + 15
    i_first = 40
    noise = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    piece_of, sign, kind = rs.piece_map(n, i_first, start, ratio, m, n_el)
    sizes = np.bincount(piece_of, minlength=kind.size)
    sums = np.bincount(piece_of, sign * noise[i_first:].real, kind.size) + 1j * np.bincount(
        piece_of, sign * noise[i_first:].imag, kind.size)
    spread = noise.copy()
    spread[i_first:] = rs.spread(piece_of, sign, sums, sizes)
    k = _elements(n, start, ratio)
    sig = np.where((m > 1) & (k >= 0) & (k % 2 == 1), -1.0, 1.0)
    half = np.where((k >= 0) & (k < n_el), k // m, -1)
    levels = rng.choice([-1.0, 1.0], n_half)
    s = np.where(half >= 0, levels[np.maximum(half, 0)] * sig, 0.0)  # a reference reply, 0 outside
    lev = np.where(s == 0, -1.0, s)
    steady = np.zeros(n, bool)
    steady[1:-1] = (lev[1:-1] == lev[:-2]) & (lev[1:-1] == lev[2:])
    tol = 1e-12 * n  # sums of n terms of order 1 in a different order
    for j in range(n_half):
        sel = half == j
        np.testing.assert_allclose(np.sum(sig[sel] * spread[sel]), np.sum(sig[sel] * noise[sel]), atol=tol)
    # any set of whole half-bits (a block edge inside a piece is the bridge's: tested below)
    for ranges in (steady & (half >= 0) & (half < n_half // 3), steady & (half >= n_half // 3)):
        np.testing.assert_allclose(np.sum(s[ranges] * spread[ranges]), np.sum(s[ranges] * noise[ranges]), atol=tol)
    rest = steady & (k >= n_el)
    assert rest.sum() > 5
    np.testing.assert_allclose(np.sum(spread[rest]), np.sum(noise[rest]), atol=tol)


@pytest.mark.parametrize("m", [1, 2, 4, 8])
def test_block_cuts_and_spread_kernels_match_reference(m):
    """The measurement's block edges in the steady pieces (kernel) against the NumPy twin, on
    random replies; the in-place spread against :func:`spread`."""
    from rfsim.devices import _reader_statistic_kernels as sk
    from rfsim.devices.reader_measure import DOPPLER_BLOCKS

    rng = np.random.default_rng(20 + m)
    n_cut = 0
    for _ in range(10):
        ratio, start, n_half = rng.uniform(0.1, 0.3), rng.uniform(5, 9), 2 * int(rng.integers(20, 60))
        n_el = n_half * m
        n = int(start + n_el / ratio) + 12
        b1 = int(rng.integers(int(start) + 2, int(start) + 30))
        piece_of, sign, kind = rs.piece_map(n, b1, start, ratio, m, n_el)
        sizes = np.bincount(piece_of, minlength=kind.size)
        k = _elements(n, start, ratio)
        half = np.where((k >= 0) & (k < n_el), k // m, -1)
        sig = np.where((m > 1) & (k >= 0) & (k % 2 == 1), -1.0, 1.0)
        s = np.where(half >= 0, rng.choice([-1.0, 1.0], n_half)[np.maximum(half, 0)] * sig, 0.0)
        i0 = int(start) - 1
        got = rs.block_cuts(s[i0:], i0, b1, piece_of, kind, 10**6)
        want = block_cuts_reference(s[i0:], i0, b1, piece_of, kind, DOPPLER_BLOCKS)
        assert got[0] == want[0]
        for g, w in zip(got[1:], want[1:]):
            np.testing.assert_array_equal(g, w)
        n_cut += got[1].size
        sums = rng.standard_normal(kind.size) + 1j * rng.standard_normal(kind.size)
        r = np.zeros(n, np.complex128)
        sk.spread_add_kernel(r, b1, piece_of, sign, sums, sizes.astype(np.float64))
        # P/|p|: numba divides each part by the real |p| (one rounding), NumPy divides by the
        # complex |p| + 0j (Smith's algorithm: a ratio, a product, a sum and a division, ≤ 4
        # roundings per part); the sign is exact: ≤ 4 ULP
        assert_close_ulp(r[b1:], rs.spread(piece_of, sign, sums, sizes), 4)
    assert n_cut > 0  # edges did fall inside steady pieces


def test_bridge_split_has_the_conditional_law_of_partial_sums():
    """(A, B) given A + B = T for independent A ~ CN(0, σ²·a), B ~ CN(0, σ²·b): E[A | T] = T·a/(a+b),
    Var(Re A | T) = σ²·a·b/(2(a + b)); N = 40,000 draws, means within Z standard errors, variance
    within Z·√(2/N) relative."""
    rng = np.random.default_rng(5)
    n, a, b, sigma2 = 40_000, 7, 13, 2.5
    total = np.full(n, 3.0 - 1.0j)
    xa, xb = rs.bridge_split(total, np.full(n, a), np.full(n, b), sigma2, rng=rng)
    np.testing.assert_allclose(xa + xb, total, atol=1e-12)
    var = sigma2 * a * b / (2 * (a + b))
    se = math.sqrt(var / n)
    assert abs(xa.real.mean() - 3.0 * a / (a + b)) < Z * se
    assert abs(xa.imag.mean() + 1.0 * a / (a + b)) < Z * se
    assert abs(xa.real.var() / var - 1) < Z * math.sqrt(2 / n)
    assert abs(xa.imag.var() / var - 1) < Z * math.sqrt(2 / n)


@pytest.mark.parametrize("m", [1, 4])
def test_piece_moments_kernel_matches_reference(m):
    """The one pass over the noise-free input (per-piece sums of σu, u, σuδ, σuδ², |u|²) against
    bincount sums: the same up to the order of the sums; against the run-by-run sums of σ·u per
    sample in plain floats (the kernel's order): the same bits (σ = ±1 taken out of a run of one
    sign is exact); an inner-edge piece's sums other than Σσu left 0 unless ``every``."""
    from rfsim.devices import _reader_statistic_kernels as sk
    from rfsim.devices import _reader_statistic_piece_kernels as pk

    rng = np.random.default_rng(40 + m)
    n, b1, ratio = 900, 37, 0.16
    piece_of, sign, kind = rs.piece_map(n, b1, 61.3, ratio, m, 2 * m * 40)
    n_p = kind.size
    sizes = np.bincount(piece_of, minlength=n_p)
    anchor = np.floor(np.bincount(piece_of, weights=np.arange(b1, n), minlength=n_p) / sizes + 0.5)
    x = 5.0 + rng.standard_normal(n) + 1j * rng.standard_normal(n)
    runs = np.empty((3, piece_of.size), np.int64)
    runs = runs[:, :pk.piece_runs_kernel(piece_of, sign, kind, runs)]
    assert np.array_equal(np.concatenate([np.arange(a, b) for a, b in runs[:2].T]), np.arange(piece_of.size))
    got = sk.piece_moments_kernel(x, 4.5 + 0.5j, b1, piece_of, sign, anchor, n_p, runs, True)
    want = piece_moments_reference(x, 4.5 + 0.5j, b1, piece_of, sign, anchor, n_p)
    scale = np.max(np.abs(want[0][3]))
    np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(got[1], want[1], rtol=1e-12, atol=1e-12)
    mom, energy = np.zeros((4, n_p), complex), np.zeros(n_p)
    for a, b, _ in runs.T:  # per run in sample order, σ·u per sample
        p, acc = piece_of[a], np.zeros(9)
        for q in range(a, b):
            u = x[b1 + q] - (4.5 + 0.5j)
            d = float(b1 + q) - anchor[p]
            sr, si = sign[q] * u.real, sign[q] * u.imag
            for k, v in enumerate((sr, si, u.real, u.imag, sr * d, si * d, sr * d * d, si * d * d,
                                   u.real * u.real + u.imag * u.imag)):
                acc[k] += v
        mom[:, p] += acc[0:8:2] + 1j * acc[1:8:2]
        energy[p] += acc[8]
    assert np.array_equal(got[0].view(np.uint64), mom.view(np.uint64))
    assert np.array_equal(got[1].view(np.uint64), energy.view(np.uint64))
    light = sk.piece_moments_kernel(x, 4.5 + 0.5j, b1, piece_of, sign, anchor, n_p, runs, False)
    inner = kind == pk.INNER_EDGE
    assert inner.any() == (m > 1)
    assert np.array_equal(light[0][0], mom[0])
    assert np.array_equal(light[0][:, ~inner], mom[:, ~inner]) and np.array_equal(light[1][~inner], energy[~inner])
    assert not light[0][1:, inner].any() and not light[1][inner].any()


@pytest.mark.parametrize("m, doppler_hz", [(4, 300.0), (1, 300.0)])
def test_receive_kernel_matches_its_numpy_twin_with_a_doppler_rotation(m, doppler_hz):
    """As the twin test below with the reply rotated by a Doppler shift: the measurement's
    rotation over a piece taken to second order about its anchor (module docstring, step 5)
    still gives the sample-level values within 1e−8 relative."""
    x_all, reader, cmd_end_s = trials.inputs(m, 12, ebn0_db=12.0, seed=500 + m)
    ra, rb = np.random.default_rng(3), np.random.default_rng(3)
    for x in x_all:
        x = x[0] + (x - x[0]) * np.exp(2j * np.pi * doppler_hz * np.arange(x.size) / reader.fs_hz)
        a = rs.receive(reader, x, t0_s=0.0, n_bits=trials.PAYLOAD_BITS + 16, expect_crc=True, cmd_end_s=cmd_end_s,
                       rng=ra)
        b = receive_reference(reader, x, t0_s=0.0, n_bits=trials.PAYLOAD_BITS + 16, expect_crc=True,
                              cmd_end_s=cmd_end_s, rng=rb)
        assert (a.success, a.failure_reason) == (b.success, b.failure_reason)
        got = [a.rssi_dbm, a.phase_rad, a.doppler_hz, a.snr_db]
        want = [b.rssi_dbm, b.phase_rad, b.doppler_hz, b.snr_db]
        np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-8, equal_nan=True)
    assert ra.bit_generator.state == rb.bit_generator.state


@pytest.mark.parametrize("m, ebn0_db, second_db", [(4, 7.0, None), (1, 8.0, None), (2, 4.0, None), (8, 0.0, None),
                                                  (4, 20.0, 3.0), (1, -3.0, None), (4, 60.0, None)])
def test_receive_kernel_matches_its_numpy_twin(m, ebn0_db, second_db):
    """The one-call receiver (kernel) against its NumPy twin (the sample-level decoder's calls on
    x + ñ) on the same inputs and generator: the same draws (the generators end in the same
    state), the same decisions, failures and start, and the same measurements up to the order of
    the sums (the kernel sums sequentially, NumPy pairwise and by BLAS: sums of ≤ 10⁴ terms
    differ by ≤ 10⁴·ε relative, ≈ 2e−12; a tolerance of 1e−9 leaves room for the SNR's
    cancellation p/(p − residual) of a few hundred and still fails on any change of a step)."""
    x_all, reader, cmd_end_s = trials.inputs(m, 40, ebn0_db=ebn0_db, seed=300 + m, second_db=second_db)
    ra, rb = np.random.default_rng(9), np.random.default_rng(9)
    outcomes = set()
    for x in x_all:
        a = rs.receive(reader, x, t0_s=0.0, n_bits=trials.PAYLOAD_BITS + 16, expect_crc=True, cmd_end_s=cmd_end_s,
                       rng=ra)
        b = receive_reference(reader, x, t0_s=0.0, n_bits=trials.PAYLOAD_BITS + 16, expect_crc=True,
                              cmd_end_s=cmd_end_s, rng=rb)
        assert (a.success, a.failure_reason) == (b.success, b.failure_reason)
        assert (a.bits is None) == (b.bits is None)
        if a.bits is not None:
            np.testing.assert_array_equal(a.bits, b.bits)
        got = [a.start_s, a.corr, a.rssi_dbm, a.phase_rad, a.doppler_hz, a.snr_db, a.ebn0_db]
        want = [b.start_s, b.corr, b.rssi_dbm, b.phase_rad, b.doppler_hz, b.snr_db, b.ebn0_db]
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9, equal_nan=True)
        outcomes.add(a.failure_reason)
    assert ra.bit_generator.state == rb.bit_generator.state
    assert outcomes  # at least one reply received


def test_receive_kernel_reading_inner_edge_pieces_whole_matches_its_numpy_twin():
    """The branch of the kernel where the measurement reads an inner-edge piece whole (the pass
    over the input again with every piece's sums, ``every=True``) against the NumPy twin.

    At a valid sample rate (fs ≥ 2·BLF_max, under one element per sample) an inner-edge sample
    has a neighbour in the next element, of the opposite subcarrier sign, so the measurement
    never reads it and the branch is not taken. At two elements per sample (fs = BLF, set on
    the reader after its config check) a Miller-8 half-bit holds four samples; the middle two
    form an inner-edge piece whose neighbours lie two elements away, of the same sign: the
    measurement reads the piece whole, and where no block edge splits one the measurement is
    the exact one from the pieces' sums. Same tolerances as the twin test above."""
    from rfsim.devices import _reader_statistic_kernels as sk
    from rfsim.gen2.link import t1

    reader = trials.make_reader(8, "statistic", 5)
    lk = reader.link
    reader.fs_hz = lk.blf_hz  # 2·BLF/fs = 2 elements per sample (below the config's check)
    fs, n_bits = reader.fs_hz, trials.PAYLOAD_BITS + 16
    sigma2 = reader._fixed().noise_w
    amp = math.sqrt(10 ** (20.0 / 10) * sigma2 / (fs * lk.m / lk.blf_hz))  # Eb/N0 = 20 dB
    win = t1(lk)
    cmd_end_s = (40 - win.min_s * fs) / fs
    n = int(math.ceil((cmd_end_s + win.max_s) * fs + reply_duration_s(n_bits, m=lk.m, trext=lk.trext,
                                                                      blf_hz=lk.blf_hz) * fs)) + 60
    rng = np.random.default_rng(11)
    ra, rb = np.random.default_rng(3), np.random.default_rng(3)
    taken = 0
    for _ in range(12):
        x, _ = trials._input(reader, rng, amp, cmd_end_s, n, n_bits, None)
        a = rs.receive(reader, x, t0_s=0.0, n_bits=n_bits, expect_crc=True, cmd_end_s=cmd_end_s, rng=ra)
        b = receive_reference(reader, x, t0_s=0.0, n_bits=n_bits, expect_crc=True, cmd_end_s=cmd_end_s, rng=rb)
        assert (a.success, a.failure_reason) == (b.success, b.failure_reason)
        np.testing.assert_array_equal(a.bits, b.bits)
        got = [a.start_s, a.corr, a.rssi_dbm, a.phase_rad, a.doppler_hz, a.snr_db, a.ebn0_db]
        want = [b.start_s, b.corr, b.rssi_dbm, b.phase_rad, b.doppler_hz, b.snr_db, b.ebn0_db]
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9, equal_nan=True)
        # the memo slot this call used (the latest stamp): the exact measurement, an inner-edge piece read whole
        (call,) = reader.air_cache.derived(lk, rs._Plans).calls.values()
        slot = int(np.argmax(call.memo.flags[:, sk.MEMO_STAMP]))
        taken += bool(call.memo.mb[slot, sk.MB_EXACT] > 0 and call.memo.cut_memo[slot, 5, 1] > 0)
    assert ra.bit_generator.state == rb.bit_generator.state
    assert taken >= 1, taken  # the branch taken (in 3 of these 12 trials)


@pytest.mark.parametrize("m, ebn0_db", [(4, 60.0), (4, 6.0), (1, 8.0)])
def test_receive_with_the_runs_plans_equals_receive_without(m, ebn0_db):
    """What the receiver keeps by content in the run's cache (plans, per search window the piece
    map of the last start, the reference of the last bits, the block cuts, the CRC checks) gives
    the same results, bit for bit, and the same draws as a receiver that makes all of them anew
    on every call (a fresh cache per call): inputs repeated (the same start and bits again: kept
    entries reused) and interleaved with others and with a shorter reply (other entries)."""
    from rfsim.air.cache import AirCache

    bits = trials.PAYLOAD_BITS + 16
    epc, reader, cmd_end_s = trials.inputs(m, 4, ebn0_db=ebn0_db, seed=400 + m)
    rn16, _, _ = trials.inputs(m, 2, ebn0_db=ebn0_db, seed=500 + m, n_bits=16)
    order = [(epc[0], bits), (epc[0], bits), (rn16[0], 16), (epc[0], bits), (epc[1], bits), (rn16[0], 16),
             (rn16[1], 16), (epc[1], bits), (epc[2], bits), (epc[2], bits), (epc[3], bits), (epc[0], bits)]
    kept, fresh = np.random.default_rng(4), np.random.default_rng(4)
    shared = reader.air_cache
    for x, n_bits in order:
        got = []
        for rng, cache in ((kept, shared), (fresh, AirCache())):
            reader.air_cache = cache
            a = rs.receive(reader, x, t0_s=0.0, n_bits=n_bits, expect_crc=n_bits > 16, cmd_end_s=cmd_end_s, rng=rng)
            got.append(repr((a.success, a.failure_reason, None if a.bits is None else a.bits.tolist(), a.start_s,
                             a.corr, a.rssi_dbm, a.phase_rad, a.doppler_hz, a.snr_db, a.ebn0_db)))
        assert got[0] == got[1]
    assert kept.bit_generator.state == fresh.bit_generator.state


# ----------------------------------------------------------------------------- equivalence


def proportion_close(p1: float, p2: float, n: int) -> tuple[bool, float]:
    """Two-sample test of two proportions from n trials each (module docstring)."""
    p = 0.5 * (p1 + p2)
    tol = Z * math.sqrt(p * (1 - p) * 2 / n) + 1.0 / n
    return abs(p1 - p2) <= tol, tol


def mean_close(x1, x2) -> tuple[bool, float]:
    x1, x2 = x1[np.isfinite(x1)], x2[np.isfinite(x2)]
    tol = Z * math.sqrt(x1.var(ddof=1) / x1.size + x2.var(ddof=1) / x2.size)
    return abs(x1.mean() - x2.mean()) <= tol, tol


def std_close(x1, x2) -> tuple[bool, float]:
    x1, x2 = x1[np.isfinite(x1)], x2[np.isfinite(x2)]
    tol = Z * math.sqrt(1 / (2 * (x1.size - 1)) + 1 / (2 * (x2.size - 1)))
    return abs(math.log(x1.std(ddof=1) / x2.std(ddof=1))) <= tol, tol


def compare(m: int, n: int, *, ebn0_db: float, seed: int, second_db: float | None = None,
            measurements: bool = False) -> list[tuple]:
    """Rows ``(quantity, sample-level value, statistic-level value, tolerance, within)`` of every
    summary of one point (module docstring), each printed (``pytest -s`` shows the table)."""
    a = trials.run(m, "sample", n, ebn0_db=ebn0_db, seed=seed, second_db=second_db)
    b = trials.run(m, "statistic", n, ebn0_db=ebn0_db, seed=seed + 1, second_db=second_db)
    bits = trials.PAYLOAD_BITS + 16
    point = f"M={m} Eb/N0={ebn0_db:g} dB" + ("" if second_db is None else f" second tag -{second_db:g} dB")
    rows = []
    for name in ("detected", "success", "captured"):
        p1, p2 = getattr(a, name).mean(), getattr(b, name).mean()
        rows.append((name, p1, p2, *proportion_close(p1, p2, n)[::-1]))
    # BER: bit errors per detected reply (errors come in bursts: the reply is the trial), as a mean
    ok, tol = mean_close(a.bit_errors, b.bit_errors)
    rows.append(("ber", np.nanmean(a.bit_errors) / bits, np.nanmean(b.bit_errors) / bits, tol / bits, ok))
    if measurements:  # over the successful reads
        ok_a, ok_b = a.success > 0, b.success > 0
        err = [np.angle(np.exp(1j * (o.phase_rad[k] + trials.PHASE_RAD))) for o, k in ((a, ok_a), (b, ok_b))]
        # a read decoded from a start one Miller element off (the pilot is periodic; Miller
        # decisions do not depend on the sign) measures −h: its phase is π off. The rate of
        # these is compared as a proportion, the phase of the others by mean and std.
        flip = [np.abs(e) > 0.5 * math.pi for e in err]
        p1, p2 = flip[0].mean(), flip[1].mean()
        rows.append(("phase flipped by pi", p1, p2, *proportion_close(p1, p2, min(ok_a.sum(), ok_b.sum()))[::-1]))
        for name, x1, x2 in (("rssi_dbm", a.rssi_dbm[ok_a], b.rssi_dbm[ok_b]),
                             ("phase_err_rad", err[0][~flip[0]], err[1][~flip[1]])):
            ok, tol = mean_close(x1, x2)
            rows.append((name + " mean", x1.mean(), x2.mean(), tol, ok))
            ok, tol = std_close(x1, x2)
            rows.append((name + " std", x1.std(ddof=1), x2.std(ddof=1), tol, ok))
    for q, v1, v2, tol, ok in rows:
        print(f"{point} N={n} | {q} | {v1:.5g} | {v2:.5g} | {tol:.3g} | {'ok' if ok else 'OUTSIDE'}")
    return [r for r in rows if not r[4]]


@pytest.mark.parametrize("m, ebn0_db", [(4, 7.0), (1, 8.0)])
def test_statistic_receiver_matches_sample_receiver(m, ebn0_db):
    assert compare(m, 300, ebn0_db=ebn0_db, seed=100 + m, measurements=True) == []


def test_statistic_receiver_matches_sample_receiver_under_capture():
    assert compare(4, 300, ebn0_db=20.0, seed=200, second_db=3.0) == []


#: Slow-tier points: BER/packet error where the packet error is between ≈ 0.1 and 0.9 (FM0,
#: Miller-2/4/8), P(detected) near its midpoint, RSSI/phase at the higher Eb/N0.
SLOW_POINTS = [(1, 6.0), (1, 8.0), (2, 6.0), (2, 8.0), (4, 6.0), (4, 8.0), (8, 6.0), (8, 8.0),
               (1, 2.0), (2, -4.0), (4, 0.0), (8, 0.0)]
N_SLOW = 10_000


@pytest.mark.slow
@pytest.mark.parametrize("m, ebn0_db", SLOW_POINTS)
def test_statistic_receiver_matches_sample_receiver_slow(m, ebn0_db):
    assert compare(m, N_SLOW, ebn0_db=ebn0_db, seed=1000 + 10 * m, measurements=ebn0_db == 8.0) == []


@pytest.mark.slow
@pytest.mark.parametrize("second_db", [0.0, 3.0, 6.0])
def test_statistic_receiver_matches_sample_receiver_under_capture_slow(second_db):
    assert compare(4, N_SLOW, ebn0_db=20.0, seed=2000 + int(second_db), second_db=second_db) == []


# ----------------------------------------------------------------------------- through the engine


def _singulations(rx_model: str, n_rounds: int, distance_m: float) -> list:
    """Rounds of the link scenario's singulation (Query → RN16 → ACK → EPC) at ``distance_m``,
    round r's channel drawn from ``trial_rng(3, 2, r)`` (the same draws for either model: the
    statistic-level reader's noise does not come from that stream)."""
    from rfsim.channels import Channel
    from rfsim.core.rng import trial_rng
    from rfsim.devices.reader import Reader
    from rfsim.devices.tag import PassiveTag, TagConfig
    from rfsim.gen2.commands import Query
    from rfsim.protocols.engine import singulate
    from rfsim.scenarios import link

    cfg = link.Config()
    reader = Reader(ReaderConfig(rx_model=rx_model), [link.reader_antenna(cfg.geometry)], rng=trial_rng(3, 0))
    tag = PassiveTag(TagConfig(), link.tag_antenna(cfg.geometry, distance_m), rng=trial_rng(3, 1))
    channel = Channel(link.scene(cfg.channel))
    lk = reader.link
    return [singulate(reader, [tag], channel, t_s=r * 20e-3, rng=trial_rng(3, 2, r), round_index=r,
                      query=Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0, target="AB"[r % 2]))
            for r in range(n_rounds)]


def test_engine_rounds_read_alike_with_either_model():
    """At 3 m (SNR ≈ 60 dB) every round reads with either model, and per round the RSSI and
    phase agree to the noise's size (σ of the RSSI ≈ 4.3/√(2·E/N0) dB ≪ 0.01 dB, of the phase
    ≪ 1e−3 rad): the statistic-level reader got the same noise-free input plus its own noise."""
    a, b = _singulations("sample", 6, 3.0), _singulations("statistic", 6, 3.0)
    assert all(ex[-1].command == "ACK" and ex[-1].read.success for ex in a + b)
    for ea, eb in zip(a, b):
        ra, rb = ea[-1].read, eb[-1].read
        assert abs(ra.rssi_dbm - rb.rssi_dbm) < 0.01
        assert abs(np.angle(np.exp(1j * (ra.phase_rad - rb.phase_rad)))) < 1e-3
        assert ra.rssi_dbm != rb.rssi_dbm  # different noise draws


def test_reader_scenarios_take_the_key():
    """``reader.rx_model`` is a key of the ``link``, ``detection-probability`` and
    ``reader-detection`` configs (the reader section), loaded and validated like every other key."""
    from rfsim.core.config import from_dict
    from rfsim.scenarios import detection_probability, link, reader_detection

    for module in (link, detection_probability, reader_detection):
        cfg = from_dict(module.Config, {"reader": {"rx_model": "statistic"}})
        assert cfg.reader.rx_model == "statistic"
        with pytest.raises(ConfigError, match="rx_model"):
            from_dict(module.Config, {"reader": {"rx_model": "exact"}})


def test_link_scenario_runs_with_the_statistic_receiver():
    from rfsim.scenarios import link

    cfg = link.Config(geometry=link.GeometryConfig(distances_m=(1.0, 2.0)), rounds_per_point=3,
                      reader=ReaderConfig(rx_model="statistic"))
    ds = link.run(cfg, seed=1)
    success = np.asarray(ds.tables["reads"]["success"].data)
    assert success.size == 6 and success.all()


@pytest.mark.parametrize("m, ebn0_db", [(4, 6.0), (1, 8.0), (2, -3.0)])
def test_receive_many_equals_receive_trial_by_trial(m, ebn0_db):
    """The batch entry: B inputs of one plan and window in one kernel call give, trial by trial,
    what B calls of ``receive`` with the same generator give (results bit for bit, the
    generator's state at the end; carriers per trial), decoded and failed trials alike."""
    bits = trials.PAYLOAD_BITS + 16
    x_all, reader, cmd_end_s = trials.inputs(m, 12, ebn0_db=ebn0_db, seed=600 + m)
    carriers = [np.exp(0.3j * k) for k in range(len(x_all))]
    one, many = np.random.default_rng(8), np.random.default_rng(8)
    kw = dict(t0_s=0.0, n_bits=bits, expect_crc=True, cmd_end_s=cmd_end_s)
    want = [rs.receive(reader, x, carrier=c, rng=one, **kw) for x, c in zip(x_all, carriers)]
    got = rs.receive_many(reader, np.array(x_all), carriers=carriers, rng=many, **kw)

    def key(a):
        return repr((a.success, a.failure_reason, None if a.bits is None else a.bits.tolist(), a.start_s, a.corr,
                     a.rssi_dbm, a.phase_rad, a.doppler_hz, a.snr_db, a.ebn0_db))

    assert [key(a) for a in got] == [key(a) for a in want]
    assert one.bit_generator.state == many.bit_generator.state
    assert len({a.failure_reason for a in want}) >= 1 and any(a.bits is not None for a in want)


def _read_key(a):
    return repr((a.success, a.failure_reason, None if a.bits is None else a.bits.tolist(), a.start_s, a.corr,
                 a.rssi_dbm, a.phase_rad, a.doppler_hz, a.snr_db, a.ebn0_db))


@pytest.mark.parametrize("m, ebn0_db", [(4, 6.0), (1, 8.0)])
def test_receive_batch_is_receive_many_with_the_draws_of_window_by_window(monkeypatch, m, ebn0_db):
    """``Reader.receive_batch`` of a statistic-level reader is one ``receive_many`` call (no
    ``Reader.receive`` per window), and its reads and the receiver's generator afterwards equal
    those of ``Reader.receive`` window by window on a reader made alike (the same draws in the
    same order; the carrier the phase reference of every window)."""
    from rfsim.devices.reader import Reader

    bits = trials.PAYLOAD_BITS + 16
    x_all, _, cmd_end_s = trials.inputs(m, 10, ebn0_db=ebn0_db, seed=700 + m)
    kw = dict(t0_s=0.0, n_bits=bits, expect_crc=True, cmd_end_s=cmd_end_s, carrier=np.exp(0.7j))
    one, many = trials.make_reader(m, "statistic", 5), trials.make_reader(m, "statistic", 5)
    want = [one.receive(x, **kw) for x in x_all]
    calls = []
    real_many, real_receive = rs.receive_many, Reader.receive
    monkeypatch.setattr(rs, "receive_many", lambda *a, **k: calls.append(1) or real_many(*a, **k))
    monkeypatch.setattr(Reader, "receive", lambda self, *a, **k: calls.append(0) or real_receive(self, *a, **k))
    got = many.receive_batch(np.array(x_all), **kw)
    assert calls == [1]
    assert [_read_key(a) for a in got] == [_read_key(a) for a in want]
    assert one._rx_rng.bit_generator.state == many._rx_rng.bit_generator.state
    assert len({a.rssi_dbm for a in want}) == len(want)  # every window drew its own noise
    # the strategy fails when the windows' draws are taken in another order
    rev = trials.make_reader(m, "statistic", 5).receive_batch(np.array(x_all[::-1]), **kw)[::-1]
    assert [_read_key(a) for a in rev] != [_read_key(a) for a in want]


def test_batched_access_reads_with_header_bit_read_one_by_one_with_the_statistic_model():
    """A port whose replies carry a header bit re-reads an error reply right after its read; a
    statistic-level reader draws noise per read in call order, so its port reads window by
    window (the order of the draws of separate reads), a sample-level reader's in one batch."""
    from types import SimpleNamespace

    from rfsim.protocols.engine import ReaderPort

    tx = SimpleNamespace(cmd_end_s=0.0, samples=np.ones(4, complex))
    seen = []
    for model in ("sample", "statistic"):
        reader = trials.make_reader(4, model, 1)
        reader.receive_batch = lambda rx, **k: seen.append(("batch", model)) or [None] * len(rx)
        port = ReaderPort(reader, reader.antennas[0], tx, reply_bits=33, expect_crc=True, header_bit=True)
        port.receive = lambda x, model=model: seen.append(("one", model))
        port._error_reply = lambda read, row, kwargs: read
        inputs = [SimpleNamespace(t0_s=0.0, fs_hz=reader.fs_hz, samples=np.zeros(400, complex)) for _ in range(3)]
        port.receive_batch(inputs)
    assert seen == [("batch", "sample")] + [("one", "statistic")] * 3

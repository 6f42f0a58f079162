"""Reply BER through the reader's decoder against theory (issue 4, item 6).

The reader decodes with :func:`rfsim.gen2.linecode.decode_reply`; here it is given the true
reply start and channel gain (``start_sample``, ``gain``), so that the BER measures the
detector alone — detection of the preamble is tested separately (tests/test_reader.py
false-alarm and no-reply tests, tests/test_engine.py "preamble not found"); at 0 dB the
preamble search itself would often miss.

Signal: r[n] = h·s[n] + w[n], s = ±1 FM0/Miller waveform (reply_waveform), w complex white
Gaussian of variance σ² per sample. With sps = fs·M/BLF samples per bit, Eb = |h|²·sps and
N0 = σ² (same sample units), so Eb/N0 = |h|²·sps/σ². fs = 8·BLF makes every FM0/Miller
element exactly 4 samples and the start an integer sample, so the matched filter is exact.
Each reply is one air step (the waveform radiated over one path of gain h to a listening
antenna with noise σ²), the replies run as batches of :func:`rfsim.protocols.batch.propagate_batch`,
reply b drawing its bits, gain and noise from its own stream ``trial_rng(seed, b)``.

Theory (gen2-and-validation-anchors.md §4.8): bit-by-bit coherent detection compares the
signs of the two half-bit matched-filter outputs, each of energy Eb/2 → error p = Q(√(Eb/N0))
per half, P_b = 2p(1 − p); over flat Rayleigh fading with mean γ̄ (gain constant over a
reply, known to the detector): P_b = 1/2 − 1/t + (2/π)·atan(t)/t, t = √(1 + 2/γ̄). Viterbi
(ML sequence) detection uses the FM0/Miller memory and gains ≈ 3 dB.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import erfc

from rfsim.channels import HeldLinks, PathSet
from rfsim.channels.antennas import vertical_dipole
from rfsim.air.step import AntennaPort, FixedEmitter, Segment
from rfsim.protocols.batch import AirStep
from rfsim.gen2.linecode import decode_reply, reply_duration_s, reply_waveform
from rfsim.core.rng import trial_rng

BLF_HZ = 40e3
FC_HZ = 915e6
FS_HZ = 8 * BLF_HZ
START = 8  # samples of silence before the reply


def q_func(x):
    return 0.5 * erfc(np.asarray(x) / math.sqrt(2.0))


def pb_awgn(ebn0_db):
    p = q_func(np.sqrt(10 ** (np.asarray(ebn0_db) / 10)))
    return 2 * p * (1 - p)


def pb_rayleigh(mean_ebn0_db):
    t = math.sqrt(1 + 2 / 10 ** (mean_ebn0_db / 10))
    return 0.5 - 1 / t + (2 / math.pi) * math.atan(t) / t


def bit_errors(bits_per_reply: int, n_replies: int, *, ebn0_db: float, m: int, method: str, seed: int,
               rayleigh: bool = False) -> tuple[int, int]:
    """(errors, bits) over ``n_replies`` replies of random bits decoded with known start/gain.

    Reply b draws from its own stream ``trial_rng(seed, b)``: its bits, its gain h (Rayleigh),
    then the receiver noise. Each reply is one air step (:class:`rfsim.protocols.batch.AirStep`): the
    waveform s radiated, one path of gain h to a listening antenna with noise σ², the steps run
    in batches of :data:`REPLY_BLOCK` (:func:`rfsim.protocols.batch.propagate_batch`: the noise after the
    air of the batch, from each reply's stream)."""
    from rfsim.protocols.batch import propagate_batch

    sps = FS_HZ * m / BLF_HZ
    sigma2 = sps / 10 ** (ebn0_db / 10)  # for E|h|² = 1
    n = START + int(math.ceil(reply_duration_s(bits_per_reply, m=m, trext=False, blf_hz=BLF_HZ) * FS_HZ)) + 8
    errors = 0
    for b0 in range(0, n_replies, REPLY_BLOCK):
        replies = [_reply_step(trial_rng(seed, b), bits_per_reply, n, m=m, sigma2=sigma2, rayleigh=rayleigh)
                   for b in range(b0, min(n_replies, b0 + REPLY_BLOCK))]
        for (bits, h, _), air in zip(replies, propagate_batch([r[2] for r in replies])):
            det = decode_reply(air.inputs[0].samples, n_bits=bits_per_reply, m=m, trext=False, blf_hz=BLF_HZ,
                               fs_hz=FS_HZ, method=method, start_sample=float(START), gain=h)
            errors += int(np.count_nonzero(det.bits != bits))
    return errors, n_replies * bits_per_reply


#: Replies whose air steps run as one batch.
REPLY_BLOCK = 256

TX_ANTENNA, RX_ANTENNA = vertical_dipole((0.0, 0.0, 1.0)), vertical_dipole((1.0, 0.0, 1.0))


def _reply_step(rng: np.random.Generator, bits_per_reply: int, n: int, *, m: int, sigma2: float, rayleigh: bool):
    """``(bits, h, AirStep)`` of one reply: r[n] = h·s[n] + w[n] at a listening antenna of
    noise σ² per sample (the link one path of gain h, no delay: narrowband, the constant h)."""
    bits = rng.integers(0, 2, bits_per_reply).astype(np.uint8)
    s = reply_waveform(bits, m=m, trext=False, blf_hz=BLF_HZ, fs_hz=FS_HZ, t0_s=START / FS_HZ, n_samples=n)
    h = (rng.standard_normal() + 1j * rng.standard_normal()) / math.sqrt(2) if rayleigh else 1.0 + 0j
    link = HeldLinks([(TX_ANTENNA, RX_ANTENNA, PathSet(gain=[h], delay_s=[0.0]))])
    step = AirStep([FixedEmitter(TX_ANTENNA, Segment(0.0, FS_HZ, FC_HZ, s))], [],
                   [AntennaPort(RX_ANTENNA, noise_power_w=sigma2)], link, t0_s=0.0, fs_hz=FS_HZ, n_samples=n,
                   rng=rng, decide=False)
    return bits, h, step


def awgn_bits_needed(ebn0_db: float) -> int:
    """≥ 10⁵ bits and ≥ 1000 expected errors: relative std √((1 − P)/(n·P)) ≤ 3.2 %, so the
    10 % tolerance is ≥ 3.1 standard deviations."""
    return int(max(1e5, 1000 / pb_awgn(ebn0_db)))


def rayleigh_std(mean_ebn0_db: float, bits_per_reply: int, n_replies: int) -> float:
    """Std of the BER estimate with one Rayleigh gain per reply: per reply the error count
    has variance L·E[P(1−P)] + L²·Var(P) (bits independent given the gain; P(γ) = 2p(1−p)
    with γ exponential of mean γ̄), divided by n_replies·L²."""
    g = 10 ** (mean_ebn0_db / 10)
    pb = lambda x: float(pb_awgn(10 * math.log10(x))) if x > 0 else 0.5  # noqa: E731
    m1 = quad(lambda x: math.exp(-x / g) / g * pb(x), 0, np.inf)[0]
    m2 = quad(lambda x: math.exp(-x / g) / g * pb(x) ** 2, 0, np.inf)[0]
    L = bits_per_reply
    var_reply = L * (m1 - m2) + L * L * (m2 - m1 * m1)
    return math.sqrt(var_reply / n_replies) / L


# ----------------------------------------------------------------------------- AWGN


@pytest.mark.parametrize("ebn0_db, m", [(0.0, 1), (4.0, 1), (4.0, 4)])
def test_bitwise_ber_awgn_short(ebn0_db, m):
    # 2·10⁴ bits: relative std √((1 − P)/(n·P)) = 2.3 % at 0 dB, 3.9 % at 4 dB → 4 std.
    n_bits = 20_000
    err, n = bit_errors(2000, n_bits // 2000, ebn0_db=ebn0_db, m=m, method="bitwise", seed=100 + int(ebn0_db) + m)
    p = float(pb_awgn(ebn0_db))
    tol = 4 * math.sqrt((1 - p) / (n * p))
    assert abs(err / n / p - 1) < tol, (err / n, p, tol)


@pytest.mark.slow
@pytest.mark.parametrize("ebn0_db", [0.0, 2.0, 4.0, 6.0, 8.0, 10.0])
def test_bitwise_ber_awgn_within_10_percent(ebn0_db):
    n_bits = awgn_bits_needed(ebn0_db)
    per = 10_000
    err, n = bit_errors(per, -(-n_bits // per), ebn0_db=ebn0_db, m=1, method="bitwise", seed=200 + int(ebn0_db))
    assert n >= 1e5
    p = float(pb_awgn(ebn0_db))
    assert abs(err / n / p - 1) < 0.10, (ebn0_db, err / n, p)


# ----------------------------------------------------------------------------- Rayleigh


def test_bitwise_ber_rayleigh_short():
    L, n_replies, g = 64, 400, 4.0
    err, n = bit_errors(L, n_replies, ebn0_db=g, m=1, method="bitwise", seed=300, rayleigh=True)
    p = pb_rayleigh(g)
    tol = 4 * rayleigh_std(g, L, n_replies)
    assert abs(err / n - p) < tol, (err / n, p, tol)


@pytest.mark.slow
@pytest.mark.parametrize("mean_ebn0_db", [0.0, 2.0, 4.0, 6.0, 8.0, 10.0])
def test_bitwise_ber_rayleigh_within_10_percent(mean_ebn0_db):
    # as many replies as make the 10 % tolerance 4 std of the estimate (and ≥ 10⁵ bits)
    L = 64
    p = pb_rayleigh(mean_ebn0_db)
    n_replies = max(int(1e5 // L) + 1, int(math.ceil((rayleigh_std(mean_ebn0_db, L, 1) / (0.025 * p)) ** 2)))
    assert 0.1 * p >= 4 * rayleigh_std(mean_ebn0_db, L, n_replies) * 0.999
    err, n = bit_errors(L, n_replies, ebn0_db=mean_ebn0_db, m=1, method="bitwise", seed=400 + int(mean_ebn0_db),
                        rayleigh=True)
    assert n >= 1e5
    assert abs(err / n / p - 1) < 0.10, (mean_ebn0_db, err / n, p)


# ----------------------------------------------------------------------------- Viterbi


def ebn0_at_ber(ebn0_db, ber, target):
    """Eb/N0 [dB] where a measured BER curve crosses ``target`` (log-linear interpolation)."""
    lb = np.log10(np.maximum(ber, 1e-12))
    i = int(np.flatnonzero(lb <= math.log10(target))[0])
    x0, x1, y0, y1 = ebn0_db[i - 1], ebn0_db[i], lb[i - 1], lb[i]
    return x0 + (math.log10(target) - y0) * (x1 - x0) / (y1 - y0)


def test_viterbi_gain_short():
    # Viterbi BER at 4 dB must lie between the bit-by-bit theory at 6 dB (2 dB gain) and at
    # 8 dB (4 dB gain): 4.5e-2 and 1.2e-2. 2·10⁴ bits: ≥ 240 expected errors, std ≤ 6.5 %;
    # the bracket is ±60 % around its geometric centre.
    err, n = bit_errors(2000, 10, ebn0_db=4.0, m=1, method="viterbi", seed=500)
    assert pb_awgn(8.0) < err / n < pb_awgn(6.0), err / n


@pytest.mark.slow
def test_viterbi_is_about_3_db_better():
    # 3·10⁵ bits per point: ≥ 120 errors where the curves cross 1e−3 (relative std ≤ 9 %,
    # i.e. ≤ 0.05 dB on these slopes), far finer than the 2–4 dB bracket.
    grid = np.arange(0.0, 12.0, 1.0)
    bitwise, viterbi = [], []
    for i, x in enumerate(grid):
        for method, out in (("bitwise", bitwise), ("viterbi", viterbi)):
            err, n = bit_errors(10_000, 30, ebn0_db=x, m=1, method=method, seed=600 + i)
            out.append(err / n)
    gaps = [ebn0_at_ber(grid, np.array(bitwise), t) - ebn0_at_ber(grid, np.array(viterbi), t)
            for t in (1e-2, 1e-3)]
    print("Eb/N0 gap bitwise - Viterbi at BER 1e-2, 1e-3 [dB]:", gaps)
    assert all(2.0 <= g <= 4.0 for g in gaps), gaps


@pytest.mark.parametrize("noise", ["counter", "pcg64"])
def test_reply_air_step_is_the_signal_model(noise):
    """The reply's air step gives r = h·s + w, w = √(σ²/2)·(a + j·b), for every reply of a
    batch, drawn from the reply's stream after its bits and gain: by default (``"counter"``) one
    key k and (a_i, b_i) the normal pair i of the counter-based stream k
    (:func:`rfsim.air.noise.counter_normals`); with ``"pcg64"`` every a then every b."""
    from rfsim.air.cache import AirCache, Strategy
    from rfsim.air.noise import counter_normals
    from rfsim.protocols.batch import propagate_batch

    n, sigma2 = 300, 0.7
    steps = [_reply_step(trial_rng(9, b), 16, n, m=2, sigma2=sigma2, rayleigh=True) for b in range(3)]
    for _, _, step in steps:
        step.cache = AirCache(strategy=Strategy(noise=noise))
    for b, ((bits, h, _), air) in enumerate(zip(steps, propagate_batch([s[2] for s in steps]))):
        rng = trial_rng(9, b)
        assert np.array_equal(rng.integers(0, 2, 16).astype(np.uint8), bits)
        s = reply_waveform(bits, m=2, trext=False, blf_hz=BLF_HZ, fs_hz=FS_HZ, t0_s=START / FS_HZ, n_samples=n)
        assert h == (rng.standard_normal() + 1j * rng.standard_normal()) / math.sqrt(2)
        if noise == "counter":
            ab = counter_normals(int(rng.integers(0, 2**64, dtype=np.uint64)), 2 * n)
            a, b_ = ab[0::2], ab[1::2]
        else:
            a, b_ = rng.standard_normal(n), rng.standard_normal(n)
        w = math.sqrt(sigma2 / 2) * a + 1j * (math.sqrt(sigma2 / 2) * b_)
        assert np.array_equal(air.inputs[0].samples, h * s + w)

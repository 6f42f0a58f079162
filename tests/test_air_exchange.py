"""The compiled exchange strategy (``Strategy(exchange="compiled")``, :mod:`rfsim.air._exchange_kernels`):
its kernel against the fused sum followed by the counter-based noise, bit for bit; the exchange
with it against ``noise="counter"`` (the same numbers) and against the sample-level default
(``noise="pcg64"``: other noise draws, the same statistics)."""

import math

import numpy as np
import pytest

from rfsim.air import _exchange_kernels as ek
from rfsim.air import _step_kernels as sk
from rfsim.air.cache import Strategy
from rfsim.air.noise import add_counter_awgn
from rfsim.bench.exchange import _canonical
from rfsim.core.errors import ConfigError
from rfsim.core.rng import trial_rng
from rfsim.protocols.engine import singulate


@pytest.mark.parametrize("n,start", [(1, 0), (7, 3), (1000, 0), (1000, 999), (6013, 1767), (50, 80)])
def test_kernel_is_the_fused_sum_then_the_counter_noise_bit_for_bit(n, start):
    rng = np.random.default_rng(n + start)
    x = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * 0.7
    gamma = np.where(rng.random(n) < 0.5, 0.35 - 0.62j, -0.11 + 0.05j)
    c, g, a_s, b = 3e-3 - 1e-2j, 2.1e-2 + 7e-3j, 0.4 + 0.1j, -1.3e-2 + 4e-3j
    key, noise_w = 0x1234_5678_9ABC_DEF0, 2.5e-9
    ref = np.empty(n, dtype=np.complex128)
    sk.backscatter_kernel(x, c, g, a_s, gamma, b, ref)
    add_counter_awgn(ref, noise_w, key, start=start)
    out = np.empty(n, dtype=np.complex128)
    ek.backscatter_noise_kernel(x, c, g, a_s, gamma, b, np.uint64(key), start, math.sqrt(noise_w / 2), out)
    # the same float operations in the same order (no fastmath): equal to the bit
    assert np.array_equal(out.view(np.float64), ref.view(np.float64))
    clean = np.empty(n, dtype=np.complex128)
    sk.backscatter_kernel(x, c, g, a_s, gamma, b, clean)
    assert np.array_equal(out[:start], clean[:start])  # no noise where nobody reads
    assert np.all(out[start:] != clean[start:])  # noise on every read sample


def test_strategy_compiled_needs_counter_noise_and_the_fused_sum():
    with pytest.raises(ConfigError, match="exchange"):
        Strategy(noise="pcg64", exchange="compiled")
    with pytest.raises(ConfigError, match="exchange"):
        Strategy(noise="counter", exchange="compiled", fused_backscatter=False)
    with pytest.raises(ConfigError, match="exchange"):
        Strategy(noise="counter", exchange="fast")
    # the defaults: counter-based noise and the compiled exchange; the two-stage step where
    # the noise or the sum asks for it
    assert (Strategy().noise, Strategy().exchange) == ("counter", "compiled")
    assert Strategy(noise="pcg64").exchange == "sample"
    assert Strategy(fused_backscatter=False).exchange == "sample"
    assert Strategy(noise="counter", exchange="sample").exchange == "sample"


def _rounds(noise: str, exchange: str, n: int, *, boost_db: float = 0.0, seed: int = 0):
    """n singulation rounds of the canonical exchange; the reader's noise raised by ``boost_db``."""
    reader, make_tag, channel, query = _canonical(3.0, seed, noise, exchange)
    n0 = reader.noise_power_w()
    reader.noise_power_w = lambda: n0 * 10.0 ** (boost_db / 10.0)
    tag = make_tag(None)
    rounds = [singulate(reader, [tag], channel, t_s=r * 20e-3, rng=trial_rng(seed, 2, r), query=query(r),
                        round_index=r) for r in range(n)]
    return rounds


def _fields(ex):
    read = ex.read
    return (ex.command, ex.failure_reason, None if read is None else
            (read.success, None if read.bits is None else read.bits.tobytes(), read.rssi_dbm, read.phase_rad,
             read.snr_db, read.start_s))


@pytest.mark.parametrize("boost_db", [0.0, 58.0])
def test_exchange_compiled_gives_the_records_of_counter_noise(boost_db):
    a = _rounds("counter", "sample", 12, boost_db=boost_db)
    b = _rounds("counter", "compiled", 12, boost_db=boost_db)
    fa = [[_fields(e) for e in ex] for ex in a]
    fb = [[_fields(e) for e in ex] for ex in b]
    assert fa == fb


def _stats(rounds):
    """P(RN16 decoded), and of the decoded RN16s the RSSI [dBm] and phase [rad] arrays."""
    rn16 = [ex[0] for ex in rounds]
    ok = np.array([e.read is not None and e.read.success for e in rn16])
    rssi = np.array([e.read.rssi_dbm for e in rn16 if e.read is not None and e.read.success])
    phase = np.array([e.read.phase_rad for e in rn16 if e.read is not None and e.read.success])
    return ok, rssi, phase


def _equivalent(n: int, boost_read_db: float, boost_meas_db: float, z: float = 4.5):
    """Sample-level (pcg64) against compiled, n rounds each.

    P(RN16 decoded) at ``boost_read_db`` (on the transition): the two-proportion z statistic.
    At ``boost_meas_db`` (every RN16 decoded) the RSSI and phase errors against a noise-free run
    of the same seeds (the RN16's channel is drawn before any noise: the same in all three):
    their means equal within z standard errors of the difference, their variances within z
    standard errors of the log variance ratio (√(2/(n−1)) each for Gaussian errors; z absorbs
    the rest)."""
    ok_s = _stats(_rounds("pcg64", "sample", n, boost_db=boost_read_db))[0]
    ok_c = _stats(_rounds("counter", "compiled", n, boost_db=boost_read_db))[0]
    p = 0.5 * (ok_s.mean() + ok_c.mean())
    assert 0.05 < p < 0.95, p  # the point is on the transition
    se = math.sqrt(p * (1 - p) * 2.0 / n)
    assert abs(ok_s.mean() - ok_c.mean()) <= z * se, (ok_s.mean(), ok_c.mean(), se)
    r0, p0 = _stats(_rounds("pcg64", "sample", n, boost_db=-300.0))[1:]
    rs, ps = _stats(_rounds("pcg64", "sample", n, boost_db=boost_meas_db))[1:]
    rc, pc = _stats(_rounds("counter", "compiled", n, boost_db=boost_meas_db))[1:]
    assert r0.size == rs.size == rc.size == n  # every RN16 decoded: the rounds pair up
    for es, ec in ((rs - r0, rc - r0), (np.angle(np.exp(1j * (ps - p0))), np.angle(np.exp(1j * (pc - p0))))):
        vs, vc = np.var(es, ddof=1), np.var(ec, ddof=1)
        assert vs > 0 and vc > 0  # the noise moves the measurements at this point
        assert abs(es.mean() - ec.mean()) <= z * math.sqrt((vs + vc) / n), (es.mean(), ec.mean(), vs, vc)
        assert abs(math.log(vc / vs)) <= z * 2.0 / math.sqrt(n - 1), (vs, vc)
    return ok_s.mean(), ok_c.mean()


def test_exchange_compiled_statistically_equivalent_quick():
    _equivalent(300, 59.0, 40.0, z=4.0)


@pytest.mark.slow
@pytest.mark.parametrize("boost_read_db", [56.0, 59.0, 62.0])
def test_exchange_compiled_statistically_equivalent_slow(boost_read_db):
    _equivalent(10_000, boost_read_db, 40.0)

"""Statistical equivalence of the PCG64 receiver noise (rfsim.air.cache.Strategy
``noise="pcg64"``, the selectable alternative to the counter-based default) with the theory the
default generator is held to: the bit error rate of the air step's reply plus noise, decoded
bitwise, against the closed form (the experiment of tests/test_link_ber.py, which runs the
default, with the batched air step's strategy switched to PCG64 noise)."""

from __future__ import annotations

import math

import pytest

from rfsim.air import step as air_step
from rfsim.air.cache import AirCache, Strategy
from test_link_ber import awgn_bits_needed, bit_errors, pb_awgn


@pytest.fixture
def pcg64_noise(monkeypatch):
    """Every air step without a cache of its own (``propagate`` makes one) draws PCG64 noise."""
    monkeypatch.setattr(air_step, "AirCache", lambda: AirCache(strategy=Strategy(noise="pcg64")))


@pytest.mark.parametrize("ebn0_db, m", [(0.0, 1), (4.0, 1), (4.0, 4)])
def test_pcg64_noise_ber_awgn_short(pcg64_noise, ebn0_db, m):
    # 2·10⁴ bits: relative std √((1 − P)/(n·P)) = 2.3 % at 0 dB, 3.9 % at 4 dB → 4 std
    n_bits = 20_000
    err, n = bit_errors(2000, n_bits // 2000, ebn0_db=ebn0_db, m=m, method="bitwise", seed=300 + int(ebn0_db) + m)
    p = float(pb_awgn(ebn0_db))
    tol = 4 * math.sqrt((1 - p) / (n * p))
    assert abs(err / n / p - 1) < tol, (err / n, p, tol)


def test_pcg64_noise_is_what_the_steps_draw(pcg64_noise):
    # the fixture takes effect: the same replies give other errors than the default noise
    with_pcg64 = bit_errors(2000, 2, ebn0_db=2.0, m=1, method="bitwise", seed=7)
    air_step.AirCache = AirCache  # back to the default strategy (the fixture restores it too)
    assert AirCache().strategy.noise == "counter"
    assert bit_errors(2000, 2, ebn0_db=2.0, m=1, method="bitwise", seed=7) != with_pcg64


@pytest.mark.slow
@pytest.mark.parametrize("ebn0_db", [0.0, 2.0, 4.0, 6.0, 8.0])
def test_pcg64_noise_ber_awgn_within_10_percent(pcg64_noise, ebn0_db):
    # ≥ 10⁵ bits and ≥ 1000 expected errors: the 10 % tolerance is ≥ 3.1 standard deviations
    n_bits = awgn_bits_needed(ebn0_db)
    per = 10_000
    err, n = bit_errors(per, -(-n_bits // per), ebn0_db=ebn0_db, m=1, method="bitwise", seed=400 + int(ebn0_db))
    p = float(pb_awgn(ebn0_db))
    assert abs(err / n / p - 1) < 0.10, (ebn0_db, err / n, p)

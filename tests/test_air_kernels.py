"""The air step's fused backscatter kernel (:mod:`rfsim.air._step_kernels`) against its NumPy
reference, bit for bit, and the air step with and without it."""

import numpy as np
import pytest

from rfsim.air import _step_kernels as k
from reference.air_step_kernels import backscatter_reference, numpy_products_fused
from rfsim.air import fused as air_fused
from rfsim.air.segment import Segment

MATCH = numpy_products_fused(k.cmul_kernel)
needs_match = pytest.mark.skipif(not MATCH, reason="this CPU's NumPy complex product is not the kernel's fused one")


@needs_match
@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 8, 9, 17, 1000, 6013])
def test_backscatter_kernel_equals_reference_bit_for_bit(n):
    rng = np.random.default_rng(n)
    x = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * 0.7
    gamma = np.where(rng.random(n) < 0.5, 0.35 - 0.62j, -0.11 + 0.05j)
    c, g, a_s, b = 3e-3 - 1e-2j, 2.1e-2 + 7e-3j, 0.4 + 0.1j, -1.3e-2 + 4e-3j
    out = np.empty(n, dtype=np.complex128)
    k.backscatter_kernel(x, c, g, a_s, gamma, b, out)
    ref = backscatter_reference(x, c, g, a_s, gamma, b)
    # exact: where this test runs the kernel's products are NumPy's (the same fused, exactly rounded
    # multiply-adds, checked by numpy_products_fused), and the air step relies on that identity
    assert np.array_equal(out.view(np.float64), ref.view(np.float64))


def test_cmul_differs_from_the_plain_formula_somewhere():
    # the kernel's product is NumPy's fused one: on many random pairs at least one differs
    # in the last bit from (a_r·b_r − a_i·b_i) rounded twice, so the check can fail
    rng = np.random.default_rng(1)
    a = rng.standard_normal(2000) + 1j * rng.standard_normal(2000)
    b = rng.standard_normal(2000) * 1e3 + 1j * rng.standard_normal(2000)
    out = np.empty(2000, dtype=np.complex128)
    k.cmul_kernel(a, b, out)
    plain = (a.real * b.real - a.imag * b.imag) + 1j * (a.real * b.imag + a.imag * b.real)
    assert not np.array_equal(out, plain)


@needs_match
def test_exchange_same_with_and_without_the_fused_sum(monkeypatch):
    from rfsim.air.cache import AirCache, Strategy
    from rfsim.bench.exchange import _canonical
    from rfsim.protocols.engine import singulate
    from rfsim.core.rng import trial_rng

    def rounds(fused: bool):
        reader, make_tag, channel, query = _canonical(3.0, 0)
        reader.air_cache = AirCache(strategy=Strategy(fused_backscatter=fused, exchange="sample"))  # the two-stage sum
        tag = make_tag(None)
        out = []
        for r in range(4):
            for ex in singulate(reader, [tag], channel, t_s=r * 20e-3, rng=trial_rng(0, 2, r), query=query(r),
                                round_index=r):
                out.append((ex.command, ex.failure_reason, ex.read.bits.tobytes() if ex.read else None,
                            ex.read.rssi_dbm if ex.read else None, ex.read.phase_rad if ex.read else None,
                            ex.read.snr_db if ex.read else None))
        return out

    calls = []
    kernel = k.backscatter_kernel
    monkeypatch.setattr(air_fused._ak, "backscatter_kernel", lambda *a: (calls.append(1), kernel(*a)))
    fused = rounds(True)
    assert calls
    n_calls = len(calls)
    assert rounds(False) == fused
    assert len(calls) == n_calls  # the strategy turned the kernel off
    assert any(c == "ACK" and f == "" for c, f, *_ in fused)


def test_fused_sum_with_batched_constants_takes_the_array_operations():
    # a factor per batch row ((B, 1) constants on 1-D samples): no kernel, NumPy's broadcasting
    rng = np.random.default_rng(3)
    x = rng.standard_normal(50) + 1j * rng.standard_normal(50)
    gamma = np.where(rng.random(50) < 0.5, 0.3 + 0.2j, -0.1j)
    a = (rng.standard_normal((4, 1)) + 1j * rng.standard_normal((4, 1))) * 1e-2
    bs = air_fused.Backscatter(x, 2e-2 - 1e-2j, 0.4 + 0.1j, gamma, -1e-2 + 3e-3j)
    seg = Segment(0.0, 1e6, 915e6, x)
    parts = [bs]
    y = air_fused.fused_sum({0: a}, parts, [seg], 50)
    assert parts == [bs] and y.shape == (4, 50)
    assert np.array_equal(y, a * x)

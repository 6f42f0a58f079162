"""The receiver-noise kernel (:func:`rfsim.noise.add_awgn`) against its NumPy reference:
the same draws, sums and generator state, bit for bit."""

import numpy as np
import pytest

from rfsim.noise import add_awgn, add_awgn_reference


@pytest.mark.parametrize("shape", [(1,), (7,), (3, 5), (2, 2, 4)])
def test_kernel_equals_reference_bit_for_bit(shape):
    base = np.random.default_rng(3)
    y0 = base.standard_normal(shape) + 1j * base.standard_normal(shape)
    y_ref, y_k = y0.copy(), y0.copy()
    g_ref, g_k = np.random.default_rng(11), np.random.default_rng(11)
    ab_ref = add_awgn_reference(y_ref, 2.5e-13, g_ref)
    ab_k = add_awgn(y_k, 2.5e-13, g_k)
    assert ab_k.shape == ab_ref.shape == (2,) + shape
    assert np.array_equal(ab_k, ab_ref)
    assert np.array_equal(y_k.view(np.float64), y_ref.view(np.float64))
    # both generators advanced by the same draws
    assert g_k.standard_normal() == g_ref.standard_normal()


def test_noise_power_and_independence():
    # N = 1e-12 W per complex sample, 200,000 samples: the sample power's relative standard
    # error is 1/√200000 ≈ 0.22 %, so 1.5 % is ≈ 7 σ; real/imag correlation σ ≈ 0.0022
    y = np.zeros(200_000, dtype=np.complex128)
    add_awgn(y, 1e-12, np.random.default_rng(5))
    assert abs(np.mean(np.abs(y) ** 2) / 1e-12 - 1.0) < 0.015
    assert abs(np.corrcoef(y.real, y.imag)[0, 1]) < 0.015
    assert abs(np.var(y.real) / np.var(y.imag) - 1.0) < 0.03


def test_fallback_for_non_contiguous_input():
    y0 = (np.arange(20.0) + 1j).reshape(4, 5)
    y_ref = np.ascontiguousarray(y0.T)
    y_k = y0.copy().T  # a non-contiguous view: the reference path
    add_awgn_reference(y_ref, 1e-12, np.random.default_rng(2))
    add_awgn(y_k, 1e-12, np.random.default_rng(2))
    assert np.array_equal(y_k, y_ref)


def test_kernel_equals_reference_call_after_call():
    # new generators and lengths each time: the reference's draws and generator state
    for k, n in enumerate((5, 5, 12, 1, 300)):
        y0 = np.full(n, 0.25 - 0.5j)
        y_ref, y_k = y0.copy(), y0.copy()
        g_ref, g_k = np.random.default_rng(100 + k), np.random.default_rng(100 + k)
        assert np.array_equal(add_awgn(y_k, 1e-9, g_k), add_awgn_reference(y_ref, 1e-9, g_ref))
        assert np.array_equal(y_k.view(np.float64), y_ref.view(np.float64))
        assert g_k.bit_generator.state == g_ref.bit_generator.state


def test_ziggurat_rare_branches_and_buffered_uint32_equal_numpy():
    # 2·10⁵ draws: ≈ 1.2 % leave the layer rectangles (the wedge test, one uniform more) and
    # ≈ 0.01 % are tail draws |x| > r = 3.654 (two uniforms and log1p per try): both branches
    # are taken hundreds / tens of times, and every draw after them must still agree
    from rfsim import _noise_kernels as k

    g_ref, g_k = np.random.default_rng(7), np.random.default_rng(7)
    for g in (g_ref, g_k):  # a buffered 32-bit output the normals must leave alone
        g.integers(0, 2**31, dtype=np.int32)
    y_ref, y_k = np.zeros(100_000, complex), np.zeros(100_000, complex)
    ab_ref = add_awgn_reference(y_ref, 2.0, g_ref)
    ab_k = add_awgn(y_k, 2.0, g_k)
    assert np.array_equal(ab_k, ab_ref)
    assert np.sum(np.abs(ab_ref) > k.ziggurat_nor_r) >= 5  # the tail branch was taken
    assert g_k.bit_generator.state == g_ref.bit_generator.state
    assert g_k.integers(0, 2**31, dtype=np.int32) == g_ref.integers(0, 2**31, dtype=np.int32)


def test_standard_normal_kernel_equals_generator():
    from rfsim import _noise_kernels as k

    g = np.random.default_rng(12345)
    st, d = k.pcg64_state(g.bit_generator)
    out = np.empty(50_000)
    k.standard_normal_kernel(st, out)
    k.set_pcg64_state(g.bit_generator, st, d)
    ref = np.random.default_rng(12345)
    assert np.array_equal(out, ref.standard_normal(50_000))
    assert g.bit_generator.state == ref.bit_generator.state


def test_read_only_input_takes_the_reference_path():
    y = np.zeros(4, dtype=np.complex128)
    y.setflags(write=False)
    with pytest.raises(ValueError):  # NumPy refuses to add into a read-only array
        add_awgn(y, 1e-12, np.random.default_rng(0))


@pytest.mark.parametrize("n", [1, 6, 5000])
def test_without_kept_draws_same_sums_and_state(n):
    base = np.random.default_rng(8)
    y0 = base.standard_normal(n) + 1j * base.standard_normal(n)
    y_ref, y_k = y0.copy(), y0.copy()
    g_ref, g_k = np.random.default_rng(21), np.random.default_rng(21)
    add_awgn_reference(y_ref, 3e-12, g_ref)
    assert add_awgn(y_k, 3e-12, g_k, keep=False) is None
    assert np.array_equal(y_k.view(np.float64), y_ref.view(np.float64))
    assert g_k.bit_generator.state == g_ref.bit_generator.state

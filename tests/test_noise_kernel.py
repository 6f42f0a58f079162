"""The receiver-noise kernel (:func:`rfsim.air.noise.add_awgn`) against its NumPy reference:
the same draws, sums and generator state, bit for bit."""

import numpy as np
import pytest

from rfsim.air.noise import add_awgn, add_awgn_reference


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


def test_compiled_entry_point_equals_reference_call_after_call():
    # from the second call on the kernel's compiled entry point is called directly (no
    # dispatch): still the reference's draws, for new generators and lengths each time
    from rfsim.air import _noise_kernels

    for k, n in enumerate((5, 5, 12, 1, 300)):
        y0 = np.full(n, 0.25 - 0.5j)
        y_ref, y_k = y0.copy(), y0.copy()
        g_ref, g_k = np.random.default_rng(100 + k), np.random.default_rng(100 + k)
        assert np.array_equal(add_awgn(y_k, 1e-9, g_k), add_awgn_reference(y_ref, 1e-9, g_ref))
        assert np.array_equal(y_k.view(np.float64), y_ref.view(np.float64))
        assert g_k.bit_generator.state == g_ref.bit_generator.state
    assert _noise_kernels._ENTRY  # the entry point was found and kept


def test_read_only_input_takes_the_reference_path():
    y = np.zeros(4, dtype=np.complex128)
    y.setflags(write=False)
    with pytest.raises(ValueError):  # NumPy refuses to add into a read-only array
        add_awgn(y, 1e-12, np.random.default_rng(0))


def test_kernel_draws_numpys_normals_through_the_ziggurat_tails():
    # 2 × 400,000 normals: beyond the layers' fast path (≈ 0.7 % wedge tests) and the tail
    # |x| > r = 3.654 (≈ 2.5e-4 of the draws, ~200 here) — numbers and state as NumPy's own
    y = np.zeros(400_000, dtype=np.complex128)
    g_k, g_np = np.random.default_rng(2024), np.random.default_rng(2024)
    ab = add_awgn(y, 2.0, g_k)  # scale √(2/2) = 1: ab holds the draws themselves
    want = g_np.standard_normal((2, 400_000))
    assert np.array_equal(ab, want)
    assert np.sum(np.abs(want) > 3.6541528853610088) > 50  # the tail branch was taken
    assert g_k.bit_generator.state == g_np.bit_generator.state
    assert g_k.integers(0, 2**32, 3).tolist() == g_np.integers(0, 2**32, 3).tolist()


def test_kernel_keeps_the_buffered_32_bit_half():
    # a generator with a buffered 32-bit value (after an odd number of 32-bit draws) keeps it
    g_k, g_ref = np.random.default_rng(9), np.random.default_rng(9)
    for g in (g_k, g_ref):
        g.integers(0, 2**31, 1, dtype=np.int32)
    assert g_k.bit_generator.state["has_uint32"] == 1
    y_k, y_ref = np.zeros(33, dtype=np.complex128), np.zeros(33, dtype=np.complex128)
    add_awgn(y_k, 1e-12, g_k)
    add_awgn_reference(y_ref, 1e-12, g_ref)
    assert np.array_equal(y_k, y_ref)
    assert g_k.bit_generator.state == g_ref.bit_generator.state


@pytest.mark.parametrize("make", [np.random.PCG64, np.random.Philox])
def test_skip_advances_the_generator_as_adding_the_noise(make):
    from rfsim.air.noise import skip_awgn

    for shape in ((1,), (5000,), (3, 7)):
        g_add, g_skip = np.random.Generator(make(8)), np.random.Generator(make(8))
        add_awgn(np.zeros(shape, dtype=np.complex128), 1e-12, g_add)
        skip_awgn(shape, g_skip)
        # the same stream from here on (Philox's state holds arrays: compared by its draws)
        assert g_skip.standard_normal(5).tolist() == g_add.standard_normal(5).tolist()
        assert g_skip.integers(0, 2**32, 3).tolist() == g_add.integers(0, 2**32, 3).tolist()
    g_add, g_skip = np.random.default_rng(3), np.random.default_rng(3)
    add_awgn(np.zeros(1234, dtype=np.complex128), 1e-12, g_add)
    skip_awgn(1234, g_skip)  # an int is a length
    assert g_skip.bit_generator.state == g_add.bit_generator.state


@pytest.mark.parametrize("n", [1, 6, 1024, 1025, 5000])
def test_without_kept_draws_same_sums_and_state(n):
    base = np.random.default_rng(8)
    y0 = base.standard_normal(n) + 1j * base.standard_normal(n)
    y_ref, y_k = y0.copy(), y0.copy()
    g_ref, g_k = np.random.default_rng(21), np.random.default_rng(21)
    add_awgn_reference(y_ref, 3e-12, g_ref)
    assert add_awgn(y_k, 3e-12, g_k, keep=False) is None
    assert np.array_equal(y_k.view(np.float64), y_ref.view(np.float64))
    assert g_k.bit_generator.state == g_ref.bit_generator.state

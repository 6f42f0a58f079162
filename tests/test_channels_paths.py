"""Applying path sets: kernel vs reference, fractional delays, exact carrier phase, narrowband bound."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from rfsim.channels.paths import (
    PathSet,
    apply_backscatter,
    apply_paths,
    compose_backscatter,
    concatenate,
    narrowband_error_bound,
)
from reference.channels_paths import apply_paths_reference

FS = 4e6
FC = 915e6


def _tones(rel_freqs, seed):
    """A band-limited test signal: unit tones at rel_freqs·FS with random phases, and its analytic form."""
    rng = np.random.default_rng(seed)
    f = np.asarray(rel_freqs) * FS
    ph = rng.uniform(0, 2 * np.pi, f.size)

    def sig(t):
        return np.sum(np.exp(1j * (2 * np.pi * f[:, None] * np.asarray(t)[None, :] + ph[:, None])), axis=0)

    return sig


def test_kernel_matches_numpy_reference():
    rng = np.random.default_rng(5)
    x = rng.standard_normal(3000) + 1j * rng.standard_normal(3000)
    n = 12
    paths = PathSet(rng.standard_normal(n) + 1j * rng.standard_normal(n),
                    rng.uniform(0, 4e-6, n),
                    rng.choice([0.0, 2.5, -7.0], n))
    for t0 in (0.0, 0.0123):
        y = apply_paths(x, fs_hz=FS, fc_hz=FC, paths=paths, t0_s=t0)
        y_ref = apply_paths_reference(x, fs_hz=FS, fc_hz=FC, paths=paths, t0_s=t0)
        assert np.max(np.abs(y - y_ref)) <= 1e-12 * np.max(np.abs(y_ref))
    # spread-out delays (per-path rows) as well
    far = PathSet([1.0, 0.5j], [1e-7, 2e-4], [3.0, 3.0])
    np.testing.assert_allclose(apply_paths(x, fs_hz=FS, fc_hz=FC, paths=far),
                               apply_paths_reference(x, fs_hz=FS, fc_hz=FC, paths=far), atol=1e-12)


@pytest.mark.parametrize("delay_samples", [0.37, 12.731, 0.004, 5.5])
def test_fractional_delay_band_limited(delay_samples):
    """Tones up to 0.25·fs delayed by a fraction of a sample match the analytic delayed signal
    within 1e-4 of the tone amplitude (Kaiser β = 8, 16 taps per side; measured ≈ 3e-5)."""
    sig = _tones([0.013, 0.05, 0.11, 0.2, 0.25], seed=1)
    n = np.arange(3000)
    tau = delay_samples / FS
    y = apply_paths(sig(n / FS), fs_hz=FS, fc_hz=0.0, paths=PathSet([1.0], [tau]))
    err = np.abs(y - sig(n / FS - tau))[40:-40] / 5
    assert err.max() <= 1e-4


@pytest.mark.parametrize("tau_s", [123.456789e-9, 1.0 / 3.0 * 1e-6, 7.77e-9, 2.0e-5 + 1.23e-12])
def test_carrier_phase_exact(tau_s):
    """A single path rotates a CW by −2π·fc·τ exactly (1e-9 rad), τ not a multiple of 1/fs.
    Expected phase from rational arithmetic on the float inputs."""
    x = np.ones(400, dtype=complex)
    y = apply_paths(x, fs_hz=FS, fc_hz=FC, paths=PathSet([1.0], [tau_s]))
    frac = Fraction(FC) * Fraction(tau_s)
    expected = -2 * np.pi * float(frac - (frac.numerator // frac.denominator))
    got = np.angle(y[200])
    assert abs(np.angle(np.exp(1j * (got - expected)))) < 1e-9
    assert abs(y[200]) == pytest.approx(1.0, rel=1e-12)  # unit DC gain of the interpolator


def test_doppler_phase_evolution():
    fd = 37.5
    x = np.ones(40000, dtype=complex)
    y = apply_paths(x, fs_hz=FS, fc_hz=FC, paths=PathSet([1.0], [0.0], [fd]), t0_s=0.25)
    t = 0.25 + np.arange(x.size) / FS
    np.testing.assert_allclose(y, np.exp(2j * np.pi * fd * t), atol=1e-11)


def test_narrowband_fast_path_within_bound():
    """Narrowband approximation error ≤ Σ|g|·2πB·τ·max|x| (Bernstein), checked against the
    exact application for a signal of one-sided bandwidth B = 0.05·fs."""
    sig = _tones([0.01, -0.03, 0.05], seed=2)
    x = sig(np.arange(4000) / FS)
    paths = PathSet([1.0, 0.3 - 0.2j, 0.1j], [3.3e-9, 20e-9, 41e-9], [0.0, 4.0, -2.0])
    y_exact = apply_paths(x, fs_hz=FS, fc_hz=FC, paths=paths)
    y_nb = apply_paths(x, fs_hz=FS, fc_hz=FC, paths=paths, method="narrowband")
    bound = narrowband_error_bound(paths, 0.05 * FS) * np.max(np.abs(x))
    err = np.max(np.abs(y_exact - y_nb)[40:-40])
    assert err <= bound + 1e-4 * np.max(np.abs(x))  # + the interpolator's own error
    assert err > 0.05 * bound  # the bound is not vacuous here


def test_compose_backscatter_pairs():
    f = PathSet([1.0, 0.5j], [1e-8, 3e-8], [1.0, 2.0])
    b = PathSet([2.0, 1 - 1j, 0.1], [2e-8, 5e-8, 9e-8], [10.0, 20.0, 30.0])
    rt = compose_backscatter(f, b)
    assert rt.n_paths == 6
    np.testing.assert_allclose(rt.gain[4], 0.5j * (1 - 1j))
    assert rt.delay_s[4] == pytest.approx(8e-8)
    assert rt.doppler_hz[4] == 22.0
    # narrowband gain of the round trip = product of the one-way gains
    assert rt.narrowband_gain(FC, 0.01) == pytest.approx(f.narrowband_gain(FC, 0.01) * b.narrowband_gain(FC, 0.01))
    assert concatenate(f, b).n_paths == 5


def test_apply_backscatter_constant_gamma_equals_composed_paths():
    sig = _tones([0.01, 0.04], seed=3)
    x = sig(np.arange(3000) / FS)
    f = PathSet([1e-2, 2e-3j], [10e-9, 35e-9])
    b = PathSet([1e-2, 1e-3], [10e-9, 60e-9])
    gamma = 0.3 - 0.1j
    y = apply_backscatter(x, gamma, f, b, fs_hz=FS, fc_hz=FC)
    y_comp = gamma * apply_paths(x, fs_hz=FS, fc_hz=FC, paths=compose_backscatter(f, b))
    scale = np.max(np.abs(y_comp))
    assert np.max(np.abs(y - y_comp)[80:-80]) <= 1e-4 * scale


def test_pathset_validation():
    with pytest.raises(ValueError):
        PathSet([1.0, 2.0], [0.0])
    p = PathSet([1.0], [1e-9])
    assert p.doppler_hz.tolist() == [0.0]
    with pytest.raises(ValueError):
        p.gain[0] = 2.0  # read-only


def test_narrowband_kernel_matches_numpy():
    rng = np.random.default_rng(8)
    x = rng.standard_normal(9000) + 1j * rng.standard_normal(9000)
    paths = PathSet(rng.standard_normal(5) + 1j * rng.standard_normal(5), rng.uniform(0, 1e-7, 5),
                    [0.0, 0.0, 3.0, -11.0, 250.0])
    t0 = 0.37
    y = apply_paths(x, fs_hz=FS, fc_hz=FC, paths=paths, t0_s=t0, method="narrowband")
    t = t0 + np.arange(x.size) / FS
    c = paths.gain * np.exp(-2j * np.pi * FC * paths.delay_s)
    g = np.sum(c[:, None] * np.exp(2j * np.pi * paths.doppler_hz[:, None] * t[None, :]), axis=0)
    np.testing.assert_allclose(y, g * x, rtol=0, atol=1e-9 * np.max(np.abs(g * x)))

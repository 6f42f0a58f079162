"""Large-scale loss, walls and correlated shadowing: PASS golden data, analytic and statistical."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import loadmat

from rfsim.channels.large_scale import (
    LogDistance,
    ShadowingField,
    Wall,
    friis_amplitude_gain,
    pass_log_distance_gain,
    wall_crossings,
    wall_loss_db,
)
from rfsim.core.errors import ConfigError
from rfsim.core.rng import trial_rng

# --------------------------------------------------------------------------- golden


def test_pass_channel_large_golden(reference_data):
    """results_channel_large.mat: 1000 cases of g = min(1, (c/(4πdf))^{pl/2}), rtol 1e-9."""
    m = loadmat(reference_data / "pass-selftest" / "results_channel_large.mat",
                squeeze_me=True, struct_as_record=False)
    n_cases = n_gains = n_saturated = 0
    for s, r in zip(m["settings"], m["results"]):
        assert s.type == "log-dist"
        dist = np.atleast_2d(s.dist)                       # (n_tx, n_rx) [m]
        f0 = np.atleast_1d(s.f0)                           # per receiver column [Hz]
        ref = np.asarray(r.gain, float).reshape(dist.shape)
        got = pass_log_distance_gain(dist, f0[None, :], s.pl, s.c)
        np.testing.assert_allclose(got, ref, rtol=1e-9)
        n_cases += 1
        n_gains += ref.size
        n_saturated += int(np.sum(ref == 1.0))
    assert n_cases == 1000
    assert n_gains > 1000 and n_saturated > 0


# --------------------------------------------------------------------------- path loss


def test_friis_value_and_slope():
    fc = 915e6
    lam = 299792458.0 / fc
    assert friis_amplitude_gain(1.0, fc) == pytest.approx(lam / (4 * np.pi))
    d = np.array([1.0, 10.0, 100.0])
    pl_db = -20 * np.log10(friis_amplitude_gain(d, fc))
    np.testing.assert_allclose(np.diff(pl_db), 20.0, rtol=1e-12)     # 20 dB/decade
    assert pl_db[0] == pytest.approx(31.68, abs=0.01)                 # 915 MHz at 1 m


def test_log_distance_reduces_to_friis_and_has_slope_10n():
    fc = np.array([866e6, 915e6])
    d = np.geomspace(0.5, 50.0, 9)[:, None]
    np.testing.assert_allclose(LogDistance().amplitude_gain(d, fc),
                               friis_amplitude_gain(d, fc), rtol=1e-12)
    ld = LogDistance(exponent=3.2, d0_m=2.0, pl_d0_db=45.0)
    pl = ld.path_loss_db(np.array([2.0, 20.0, 200.0]), fc[0])
    np.testing.assert_allclose(pl, [45.0, 77.0, 109.0], rtol=1e-12)
    assert ld.amplitude_gain(20.0, fc[0]) == pytest.approx(10 ** (-77.0 / 20))
    # free-space reference at d0 with another exponent: equals Friis at d0 exactly
    ld2 = LogDistance(exponent=2.7, d0_m=1.5)
    assert ld2.amplitude_gain(1.5, 915e6) == pytest.approx(friis_amplitude_gain(1.5, 915e6))
    with pytest.raises(ConfigError):
        LogDistance(exponent=0.0)
    with pytest.raises(ValueError):
        LogDistance().amplitude_gain(0.0, 915e6)


# --------------------------------------------------------------------------- walls


def test_wall_crossings_in_a_floor_plan():
    # Two rooms split by x = 5 (3 dB), a door-less corridor wall y = 4 for x in [0, 10] (5 dB),
    # and a finite 1 m × 1 m glass pane (2 dB) in the plane z = 2.5 above (2, 2).
    walls = [
        Wall.segment_2d((5.0, 0.0), (5.0, 4.0), 3.0),
        Wall.segment_2d((0.0, 4.0), (10.0, 4.0), 5.0, z_range_m=(0.0, 3.0)),
        Wall.rectangle((1.5, 1.5, 2.5), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 2.0),
    ]
    tx = np.array([1.0, 1.0, 1.0])
    rx = np.array([
        [4.0, 1.0, 1.0],      # same room: 0
        [8.0, 1.0, 1.0],      # through x = 5: 3
        [8.0, 7.0, 1.0],      # through y = 4 only: 5
        [1.0, 7.0, 1.0],      # through y = 4: 5
        [1.0, 7.0, 5.0],      # meets y = 4 at z = 3.0, the wall's top edge (inclusive): 5
        [3.0, 3.0, 4.0],      # up through the glass pane: 2
        [11.0, 1.0, 1.0],     # x = 5 segment: 3
        [5.0, 1.0, 1.0],      # ends on the wall plane: not a crossing
    ])
    # independent expectations, derived by hand:
    # rx2: line (1,1)->(8,7): at x = 5, y = 1 + 6·4/7 = 4.43 > 4 → misses the x = 5 segment;
    #      at y = 4, x = 1 + 7·3/6 = 4.5 ∈ [0, 10], z = 1 → crosses the corridor wall: 5
    # rx4: z goes 1 → 5 while y goes 1 → 7: at y = 4, z = 3.0 (top edge, inclusive): 5;
    #      it meets z = 2.5 at (1, 3.25), outside the pane
    # rx5: at z = 2.5 (t = 0.5) the point is (2, 2), inside the pane [1.5, 2.5]²: 2
    expected = np.array([0.0, 3.0, 5.0, 5.0, 5.0, 2.0, 3.0, 0.0])
    np.testing.assert_allclose(wall_loss_db(tx, rx, walls), expected)
    cross = wall_crossings(tx, rx, walls)
    assert cross.shape == (8, 3)
    assert cross.sum() == 6
    # both directions give the same answer, and broadcasting over tx works
    np.testing.assert_allclose(wall_loss_db(rx, tx, walls), expected)
    assert wall_loss_db(np.zeros((4, 1, 3)), np.ones((1, 6, 3)) * 6.0, walls).shape == (4, 6)
    assert wall_loss_db(tx, rx, []).shape == (8,)


def test_wall_plane_counts_each_crossing_once():
    walls = [Wall.plane((float(x), 0.0, 0.0), (1.0, 0.0, 0.0), 4.0) for x in range(1, 6)]
    rx = np.stack([np.linspace(0.5, 6.5, 7), np.zeros(7), np.zeros(7)], axis=-1)
    # from x = 0 to x = 0.5, 1.5, …, 6.5 → 0, 1, 2, 3, 4, 5, 5 planes crossed
    np.testing.assert_allclose(wall_loss_db((0.0, 0.0, 0.0), rx, walls),
                               4.0 * np.array([0, 1, 2, 3, 4, 5, 5]))
    # a 2-D floor plan given as (..., 2) points (z = 0)
    w = Wall.segment_2d((1.0, -1.0), (1.0, 1.0), 7.0)
    np.testing.assert_allclose(wall_loss_db([0.0, 0.0], [[2.0, 0.5], [2.0, 3.0]], [w]), [7.0, 0.0])


# --------------------------------------------------------------------------- shadowing


def test_shadowing_is_a_fixed_function_of_position():
    f = ShadowingField(6.0, 5.0, rng=trial_rng(11, 0))
    pts = trial_rng(11, 1).uniform(-20, 20, (3000, 3))        # more than one 2048-point block
    v = f.value_db(pts)
    assert v.shape == (3000,)
    perm = trial_rng(11, 3).permutation(3000)
    np.testing.assert_array_equal(f.value_db(pts[perm]), v[perm])          # order-independent
    np.testing.assert_array_equal(f.value_db(pts[perm[:17]]), v[perm[:17]])
    assert f.value_db(pts[2900]) == v[2900]                               # same point, same value
    np.testing.assert_array_equal(f.value_db(pts.reshape(30, 100, 3)), v.reshape(30, 100))
    g = ShadowingField(6.0, 5.0, rng=trial_rng(11, 0))
    np.testing.assert_array_equal(g.value_db(pts), v)                      # same seed, same field
    f.redraw(trial_rng(11, 2))
    assert np.all(f.value_db(pts) != v)                                    # new realisation
    np.testing.assert_allclose(f.amplitude_gain(pts), 10 ** (-f.value_db(pts) / 20))
    with pytest.raises(ConfigError):
        ShadowingField(6.0, 0.0, rng=trial_rng(11, 0))


def test_shadowing_marginal_and_correlation_over_realisations():
    """Ensemble over R = 4000 independent realisations at fixed points.

    Marginal: the sample std of R N(0, σ²) values has relative s.e. 1/√(2R) = 1.1 %; tolerance
    5 % (> 4 s.e.). Correlation at lags Δ/d = 0, 0.5, 1, 2, 4 along a random direction: the
    estimator's s.e. ≤ (1 − ρ²)/√R ≤ 0.016; tolerance 0.065 (4 s.e.) around exp(−Δ/d).
    """
    sigma, dcorr, reps = 7.0, 3.0, 4000
    lags = np.array([0.0, 0.5, 1.0, 2.0, 4.0]) * dcorr
    u = np.array([0.48, -0.6, 0.64])
    x0 = np.array([1.0, -2.0, 0.5])
    pts = x0 + lags[:, None] * u[None, :]
    f = ShadowingField(sigma, dcorr, rng=trial_rng(5, 0), n_features=256)
    vals = np.empty((reps, lags.size))
    for i in range(reps):
        f.redraw(trial_rng(5, 1, i))
        vals[i] = f.value_db(pts)
    std = vals.std(axis=0)
    np.testing.assert_allclose(std, sigma, rtol=0.05)
    assert abs(vals.mean()) < 4 * sigma / np.sqrt(reps)
    rho = np.corrcoef(vals.T)[0]
    np.testing.assert_allclose(rho, np.exp(-lags / dcorr), atol=0.065)


def test_shadowing_correlation_within_one_realisation():
    """One realisation (M = 1024 features), 8000 point pairs spread over a 3 km cube.

    The realised kernel is (1/M)·Σcos(ω_m·Δ): error s.d. ≤ 1/√(2M) ≈ 0.022; the pair-sampling
    error over 8000 nearly independent pairs is ≈ 0.011. Tolerance 0.1 (> 4 combined s.d.).
    Marginal std over the same 8000 points: s.e. ≈ σ/√(2N) ≈ 0.8 %; tolerance 5 %.
    """
    sigma, dcorr, n = 5.0, 2.0, 8000
    rng = trial_rng(6, 0)
    f = ShadowingField(sigma, dcorr, rng=trial_rng(6, 1))
    a = rng.uniform(0.0, 3000.0, (n, 3))
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    va = f.value_db(a)
    assert va.std() == pytest.approx(sigma, rel=0.05)
    for lag in (0.5 * dcorr, dcorr, 2.0 * dcorr):
        vb = f.value_db(a + lag * dirs)
        rho = np.mean(va * vb) / sigma**2
        assert rho == pytest.approx(np.exp(-lag / dcorr), abs=0.1)


def test_friis_of_one_link_equals_the_array_form_bit_for_bit():
    # the float fast path (one link) against the array path, element by element with ==
    from rfsim.channels.large_scale import friis_amplitude_gain

    rng = np.random.default_rng(17)
    d, fc = rng.uniform(0.05, 80.0, 2000), rng.uniform(860e6, 960e6, 2000)
    arr = friis_amplitude_gain(d, fc)
    one = [friis_amplitude_gain(float(a), float(b)) for a, b in zip(d, fc)]
    assert all(type(v) is np.float64 for v in one)
    assert np.array_equal(np.array(one), arr)
    with pytest.raises(ValueError):
        friis_amplitude_gain(0.0, 915e6)
    with pytest.raises(ValueError):
        friis_amplitude_gain(float("nan"), 915e6)

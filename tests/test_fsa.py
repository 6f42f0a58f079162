"""FSA analytics (rfsim.protocols.fsa) against independent derivations: exhaustive enumeration of all
L^N slot choices, the anchors' quoted values (gen2-and-validation-anchors.md §4.6) and a
multinomial Monte-Carlo."""

import itertools
import math

import numpy as np
import pytest

from rfsim.protocols import fsa
from rfsim.core.rng import trial_rng
from reference.ulp import assert_close_ulp

SMALL_CASES = [(n, L) for n in range(0, 6) for L in (1, 2, 3, 4)]


def _enumerate(n, L):
    """Exact moments by enumerating all L^N equally likely assignments."""
    rows = []
    for choice in itertools.product(range(L), repeat=n):
        occ = np.bincount(np.asarray(choice, dtype=int), minlength=L) if n else np.zeros(L, int)
        rows.append(((occ == 0).sum(), (occ == 1).sum(), (occ >= 2).sum()))
    rows = np.array(rows, dtype=float)
    return rows.mean(axis=0), np.cov(rows.T, bias=True)


@pytest.mark.parametrize("n,L", SMALL_CASES)
def test_moments_equal_enumeration(n, L):
    mean, cov = _enumerate(n, L)
    assert np.allclose(fsa.expected_counts(n, L), mean, atol=1e-12)
    assert np.allclose(fsa.count_covariance(n, L), cov, atol=1e-12)


def test_pmf_is_binomial():
    from scipy.stats import binom

    for n, L in [(1, 4), (20, 16), (64, 64), (100, 8)]:
        pmf = fsa.slot_occupancy_pmf(n, L)
        assert pmf.shape == (n + 1,)
        assert np.allclose(pmf, binom.pmf(np.arange(n + 1), n, 1.0 / L), rtol=1e-10, atol=1e-15)
        e, s, _ = fsa.expected_counts(n, L)
        assert math.isclose(e, L * pmf[0], rel_tol=1e-12) and math.isclose(s, L * pmf[1], rel_tol=1e-12)


def test_anchor_values():
    # anchors §4.6: η(N = L) = 0.387 (N = 10), 0.370 (N = 100), → 1/e
    assert round(fsa.optimal_efficiency(10), 3) == 0.387
    assert round(fsa.optimal_efficiency(100), 3) == 0.370
    assert abs(fsa.optimal_efficiency(100000) - 1 / math.e) < 1e-5
    assert math.isclose(fsa.efficiency(100, 100), fsa.optimal_efficiency(100), rel_tol=1e-12)
    # η is maximal at L = N over all frame lengths
    effs = [fsa.efficiency(37, L) for L in range(1, 200)]
    assert int(np.argmax(effs)) + 1 == 37
    # power-of-two frames with ideal Q: worst case N/L = 2 ln 2 → η = ln2/2 = 0.3466
    L = 1 << 12
    assert abs(fsa.efficiency(int(round(2 * math.log(2) * L)), L) - math.log(2) / 2) < 1e-3
    assert fsa.schoute_estimate(3, 2) == pytest.approx(3 + 2 * 2.39)
    assert fsa.lower_bound_estimate(3, 2) == 7.0


def test_monte_carlo_multinomial():
    # 20000 frames of N = 20 in L = 16: sample means within 4 standard errors of the exact
    # means (standard error = sqrt(var / n_frames)), sample variances within 5 %.
    n, L, frames = 20, 16, 20000
    rng = trial_rng(7, 0)
    slots = rng.integers(0, L, size=(frames, n))
    occ = np.stack([np.bincount(r, minlength=L) for r in slots])
    counts = np.stack([(occ == 0).sum(1), (occ == 1).sum(1), (occ >= 2).sum(1)], axis=1).astype(float)
    mean = np.array(fsa.expected_counts(n, L))
    cov = fsa.count_covariance(n, L)
    se = np.sqrt(np.diag(cov) / frames)
    assert np.all(np.abs(counts.mean(0) - mean) < 4 * se)
    assert np.allclose(counts.var(0), np.diag(cov), rtol=0.05)


def test_frame_time_and_errors():
    """N = 5 tags in L = 4 slots, by hand: E[empty] = 4·(3/4)^5 = 243/256, E[single] =
    5·(3/4)^4 = 405/256, E[collided] = 4 − 648/256 = 376/256; with durations 1, 3, 2 s the
    frame lasts (243 + 3·405 + 2·376)/256 = 2210/256 s. Every value is a dyadic rational
    with few bits, so the float64 steps are exact but for ``pow`` (≤ 1 ULP, faithfully
    rounded), whose error the later sums carry: ≤ 4 ULP."""
    t = fsa.expected_frame_time_s(5, 4, empty_s=1.0, single_s=3.0, collided_s=2.0)
    assert_close_ulp(t, 2210 / 256, 4)
    with pytest.raises(ValueError):
        fsa.expected_counts(-1, 4)
    with pytest.raises(ValueError):
        fsa.expected_counts(3, 0)

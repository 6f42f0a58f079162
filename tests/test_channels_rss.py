"""Per-reader RSS channel, quasi-static shadowing, people term and the reader report stage."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.channels.large_scale import Wall
from rfsim.channels.rss import ReaderLink, RssChannel, people_term_db, quasi_static_shadowing_db
from rfsim.devices.rss_reader import RssReport
from rfsim.core.errors import ConfigError
from rfsim.core.rng import trial_rng


def _home_like():
    readers = [ReaderLink((0.0, 0.0, 1.0), -42.0, 2.3, 5.3), ReaderLink((6.0, 0.0, 1.0), -52.0, 2.5, 5.0)]
    return RssChannel(readers, [Wall.segment_2d((3.0, -5.0), (3.0, 5.0), 2.0)])


def test_mean_rss_is_log_distance_minus_walls_per_reader():
    ch = _home_like()
    pts = np.array([[1.0, 1.0, 1.0], [4.0, -2.0, 1.0]])
    got = ch.mean_rss_dbm(pts)
    # hand: point 0 is in reader 0's room (no wall), across the wall for reader 1; point 1 the opposite
    d00, d01 = np.sqrt(2.0), np.hypot(5.0, 1.0)
    d10, d11 = np.hypot(4.0, 2.0), np.hypot(2.0, 2.0)
    ref = np.array([[-42 - 23 * np.log10(d00), -52 - 25 * np.log10(d01) - 2],
                    [-42 - 23 * np.log10(d10) - 2, -52 - 25 * np.log10(d11)]])
    np.testing.assert_allclose(got, ref, atol=1e-12)
    # estimated parameters replace the readers' own
    np.testing.assert_allclose(ch.mean_rss_dbm(pts[0], alpha_dbm=[-40, -50], exponent=[2.0, 2.0]),
                               [-40 - 20 * np.log10(d00), -50 - 20 * np.log10(d01) - 2], atol=1e-12)


def test_bad_reader_parameters():
    with pytest.raises(ConfigError, match="sigma_db"):
        ReaderLink((0.0, 0.0, 0.0), -50.0, 2.0, -1.0)
    with pytest.raises(ConfigError, match="readers"):
        RssChannel([])
    with pytest.raises(ValueError, match="zero length"):
        Wall.segment_2d((1.0, 1.0), (1.0, 1.0), 2.0)


def test_independent_shadowing_is_quasi_static_and_has_sigma():
    """Equal positions share a value; distinct positions/readers are independent N(0, σ_j²):
    over K = 20000 draws the sample variance lies within 5 standard errors (σ²·√(2/K))."""
    rng = trial_rng(3, 0)
    k = 10000
    pts = np.repeat(rng.uniform(0, 5, size=(k, 3)), 2, axis=0)
    x = quasi_static_shadowing_db(pts, np.array([3.0, 7.0]), rng=rng)
    assert np.array_equal(x[0::2], x[1::2])
    u = x[0::2]
    var = u.var(axis=0)
    assert np.all(np.abs(var - [9.0, 49.0]) < 5 * np.array([9.0, 49.0]) * np.sqrt(2 / k))
    assert abs(np.corrcoef(u.T)[0, 1]) < 5 / np.sqrt(k)


@pytest.mark.parametrize("dcorr", [0.0, 2.0])
def test_shared_shadowing_is_one_term_scaled_per_reader(dcorr):
    rng = trial_rng(6, 0)
    pts = rng.uniform(0, 5, size=(50, 3))
    x = quasi_static_shadowing_db(pts, np.array([2.0, 6.0]), rng=rng, decorrelation_m=dcorr, shared=True)
    np.testing.assert_allclose(x[:, 1], 3.0 * x[:, 0], rtol=1e-12)
    assert np.std(x[:, 0]) > 0


def test_correlated_shadowing_follows_gudmundson():
    """Over R = 1500 environments, values 2 m apart with d_corr = 2 m correlate as e^-1 (± 5 SE,
    SE = (1 − ρ²)/√R); readers stay independent."""
    r, dcorr = 1500, 2.0
    pairs = np.array([[0.0, 0.0, 1.0], [2.0, 0.0, 1.0]])
    vals = np.array([quasi_static_shadowing_db(pairs, np.array([5.0, 5.0]), rng=trial_rng(4, i),
                                               decorrelation_m=dcorr) for i in range(r)])
    rho = np.corrcoef(vals[:, 0, 0], vals[:, 1, 0])[0, 1]
    assert abs(rho - np.exp(-1)) < 5 * (1 - np.exp(-2)) / np.sqrt(r)
    assert abs(np.corrcoef(vals[:, 0, 0], vals[:, 0, 1])[0, 1]) < 5 / np.sqrt(r)


def test_people_term_ar1():
    rng = trial_rng(5, 0)
    p = people_term_db(20000, 2, 4.0, rng=rng, correlation=0.8)
    n = p.shape[0]
    assert np.all(np.abs(p.var(axis=0) - 16.0) < 16.0 * 5 * np.sqrt(2 * (1 + 0.64) / (1 - 0.64) / n))
    lag1 = np.array([np.corrcoef(p[1:, j], p[:-1, j])[0, 1] for j in range(2)])
    assert np.all(np.abs(lag1 - 0.8) < 5 * (1 - 0.64) / np.sqrt(n))
    with pytest.raises(ConfigError, match="correlation"):
        people_term_db(3, 1, 1.0, rng=rng, correlation=1.0)


def test_reader_report_quantizes_and_floors():
    r = RssReport(step_db=1.0, floor_dbm=-90.0)
    got = r.report(np.array([-52.4, -52.6, -89.9, -90.2]))
    assert got[0] == -52.0 and got[1] == -53.0 and got[2] == -90.0 and np.isnan(got[3])
    fine = RssReport(step_db=0.01).report(np.array([-61.2345]))
    assert fine[0] == pytest.approx(-61.23, abs=1e-9)
    assert RssReport(step_db=0.0).report(np.array([-61.2345]))[0] == -61.2345

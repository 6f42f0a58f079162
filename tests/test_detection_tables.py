"""Fit tables of the detection models (rfsim.detection.tables): per-cell moments against a
table worked by hand, the ST fit table's rows, published cross-entropies and column units, the
published row of the reader fit table (auris-sense-a-tag.md §2.2 R4-1, binary-detection.md §1.6).
"""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.core.errors import UserError
from rfsim.detection import (PUBLISHED_READER_MODEL, cell_moments, fit_reader_models, fit_st_models,
                             reader_fit_columns, st_fit_columns, st_fits_comparison)


def test_cell_moments_against_a_hand_table():
    # room 0, 1 m, 0°: p̂ = 0.2, 0.4, 0.9 → mean 0.5, variance (ddof 1) (0.09 + 0.01 + 0.16)/2 = 0.13;
    # room 1, 2 m, 30°: one trial → mean 0.7, variance NaN; every other cell empty → NaN
    trials = dict(room=np.array([0, 0, 0, 1]), distance_m=np.array([1.0, 1.0, 1.0, 2.0]),
                  theta_deg=np.array([0.0, 0.0, 0.0, 30.0]), p_hat=np.array([0.2, 0.4, 0.9, 0.7]))
    cm = cell_moments(trials, (1.0, 2.0), (0.0, 30.0))
    assert cm["p_mean"].shape == cm["p_var"].shape == (2, 2, 2)
    assert cm["p_mean"][0, 0, 0] == pytest.approx(0.5, abs=1e-15)
    assert cm["p_var"][0, 0, 0] == pytest.approx(0.13, abs=1e-15)
    assert cm["p_mean"][1, 1, 1] == pytest.approx(0.7, abs=1e-15) and np.isnan(cm["p_var"][1, 1, 1])
    assert np.isnan(cm["p_mean"]).sum() == 6


def _st_samples(n=400, seed=1):
    rng = np.random.default_rng(seed)
    d = rng.uniform(0.05, 2.0, n)
    y = rng.random(n) < 1.0 / (1.0 + np.exp(-1.0 + 2.0 * d))  # TS with a = (-1, 2)
    return dict(D_m=rng.uniform(1, 8, n), d_m=d, theta_rad=rng.uniform(-1, 1, n), phi_rad=rng.uniform(-1, 1, n),
                st_detected=y, is_test=np.arange(n) >= 300)


def test_st_fit_table_rows_published_values_and_units():
    f = fit_st_models(_st_samples())
    assert list(zip(f["model"], f["source"])) == [("RTS", "fit"), ("RTS", "published"), ("TS", "fit"),
                                                   ("TS", "published")]
    # the published rows carry the published coefficients and test cross-entropies (R4-1)
    np.testing.assert_array_equal([f[f"a{j}"][1] for j in range(5)], [-1.462, 0.4941, 2.506, 0.0126, 0.0523])
    np.testing.assert_array_equal([f["a0"][3], f["a1"][3]], [0.8970, 2.4443])
    assert list(f["published_test_cross_entropy"]) == [0.1278, 0.1278, 0.1502, 0.1502]
    assert np.isnan(f["a2"][2]) and np.isnan(f["se_a0"][3])
    assert list(f["n_train"]) == [300] * 4 and list(f["n_test"]) == [100] * 4
    units = st_fit_columns(f)
    assert set(units) == set(f)
    assert units["a1"][0] == units["se_a2"][0] == "1/m" and units["a3"][0] == "1/rad"
    assert units["test_cross_entropy"][0] == "nat" and units["a0"][0] == "1"
    text = st_fits_comparison(f)
    assert text.startswith("RTS: a0 ") and "; TS: a0 " in text
    assert "published a2_d > a1_D > a4_abs_phi > a3_abs_theta" in text  # 2.506 > 0.4941 > 0.0523 > 0.0126


def test_st_fit_table_needs_both_outcomes():
    s = _st_samples()
    s["st_detected"] = np.zeros_like(s["st_detected"])
    with pytest.raises(UserError):
        fit_st_models(s)


def test_reader_fit_table_published_row_and_failed_fits():
    # two trials cannot be fitted: the moments and mle rows are NaN with the reasons; the
    # published row holds the published model and its d50 at the asked angles
    trials = dict(distance_m=np.array([1.0, 2.0]), theta_deg=np.array([0.0, 0.0]), n_reads=np.array([50, 40]),
                  n_queries=np.array([50, 50]))
    f = fit_reader_models(trials, d50_angles_deg=(0.0, 45.0))
    assert list(f["method"]) == ["published", "moments", "mle"]
    assert list(f["stderr_basis"]) == ["none", "failed", "failed"]
    assert f["a1"][0] == PUBLISHED_READER_MODEL.mean_coefficients[0]
    assert f["d50_45deg_m"][0] == pytest.approx(float(PUBLISHED_READER_MODEL.d50(45.0)), rel=1e-15)
    assert np.isnan(f["a1"][1]) and np.isnan(f["a1"][2])
    assert "moments:" in f["errors"] and "mle:" in f["errors"]
    cols = reader_fit_columns({k: v for k, v in f.items() if k != "errors"})
    assert list(cols)[:2] == ["method", "stderr_basis"]
    assert cols["a2"][0] == "1/m" and cols["c3"][0] == "1/m^2" and cols["d50_0deg_m"][0] == "m"
    assert cols["log_likelihood"][0] == "nat"

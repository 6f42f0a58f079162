"""Scenario ``reader-detection`` (campaign A replica): end to end on a tiny config
(trials table, cell grid, fits table, figures, xarray), determinism (same seed → same
bits, independent of the number of worker processes), the DA fit plumbing recovers a known
model on the campaign's own grid, and physical sanity (detection falls with distance and
with the angle off boresight).

References: binary-detection.md §1.6 (DA model, published coefficients, d50 6.63 / 3.97 /
1.30 m at 0° / 30° / 60°), §4 item 1 (campaign A: 27 dBm, 6 dBic patch, N = 50).
"""

from __future__ import annotations

import math
from dataclasses import replace

import h5py
import numpy as np
import pytest

from rfsim.core.dataset import read_dataset, read_table
from rfsim.detection import ReaderDetectionModel, fit_reader_models
from rfsim.runs.runner import run_scenario
from rfsim.scenarios import reader_detection as rd

TINY = rd.Config(campaign=rd.CampaignConfig(distances_m=(1.0, 9.0), angles_deg=(0.0, 90.0), repetitions=2,
                                            queries=5, workers=1))


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    return run_scenario(rd, TINY, seed=2, out_dir=tmp_path_factory.mktemp("rd"))


#: Regression pins of fitted coefficients: a fit is an iterative floating-point solution whose
#: last bits follow the BLAS/libm summation order of the installed NumPy/SciPy, so the pins
#: hold to a ULP bound (≈ 1e-12 relative), not bit for bit.
FIT_ULP = 4096


def test_tiny_run_layout(tiny_run):
    t = read_table(tiny_run.dataset_path, "trials")
    n = 2 * 2 * 2 * 2  # rooms x distances x angles x repetitions
    assert set(t) == set(rd.FIELDS) and all(v.shape == (n,) for v in t.values())
    assert np.all(t["n_queries"] == 5)
    assert np.all((t["n_reads"] >= 0) & (t["n_reads"] <= t["n_replied"]) & (t["n_replied"] <= t["n_powered"]))
    np.testing.assert_allclose(t["p_hat"], t["n_reads"] / 5)
    assert np.all(np.abs(np.column_stack([t["jitter_x_m"], t["jitter_y_m"], t["jitter_z_m"]])) <= 0.05)
    ds = read_dataset(tiny_run.dataset_path)
    coords, vars_ = ds.grids["cells"]
    assert vars_["p_mean"].data.shape == (2, 2, 2)
    sel = (t["room"] == 1) & (t["distance_m"] == 1.0) & (t["theta_deg"] == 0.0)
    assert vars_["p_mean"].data[1, 0, 0] == pytest.approx(t["p_hat"][sel].mean())
    f = read_table(tiny_run.dataset_path, "fits")
    assert list(f["method"]) == ["published", "moments", "mle"]
    # published row: the reference's d50 values (binary-detection.md §5 P0-2)
    np.testing.assert_allclose([f["d50_0deg_m"][0], f["d50_30deg_m"][0], f["d50_60deg_m"][0]],
                               rd.PUBLISHED_D50_M, atol=0.006)
    with h5py.File(tiny_run.dataset_path) as h:
        assert h["trials"]["distance_m"].attrs["units"] == "m"
        assert h["trials"]["theta_deg"].attrs["units"] == "deg"
        assert h["fits"]["a2"].attrs["units"] == "1/m"
    assert len(tiny_run.figure_paths) == 2 and all(p.stat().st_size > 1000 for p in tiny_run.figure_paths)


def test_dataset_opens_in_xarray(tiny_run):
    xr = pytest.importorskip("xarray")
    with xr.open_dataset(tiny_run.dataset_path, engine="h5netcdf", group="cells") as x:
        assert x["p_mean"].dims == ("room", "distance_m", "theta_deg")


def test_same_seed_same_bits_any_worker_count():
    cfg = replace(TINY, campaign=replace(TINY.campaign, distances_m=(2.0, 5.0), angles_deg=(30.0,)))
    a = rd.simulate(cfg, seed=6)
    b = rd.simulate(replace(cfg, campaign=replace(cfg.campaign, workers=2)), seed=6)
    for k in rd.FIELDS:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    c = rd.simulate(cfg, seed=7)
    assert not np.array_equal(a["jitter_x_m"], c["jitter_x_m"])


def test_fits_recover_a_known_model_on_the_campaign_grid():
    # the published DA model drawn on the full grid (18 x 13 cells, 20 trials each = both
    # rooms): the ML estimates of (a1, a2, a3) lie within 4 reported standard errors
    # (asymptotic normality: < 2e-4 failure probability for the three), and d50 within 5 %.
    truth = ReaderDetectionModel()
    dd, aa = np.meshgrid(rd.FULL_DISTANCES_M, rd.FULL_ANGLES_DEG, indexing="ij")
    dd, aa = np.repeat(dd.ravel(), 20), np.repeat(aa.ravel(), 20)
    n = truth.sample_reads(50, dd, aa, rng=np.random.default_rng(7))
    f = fit_reader_models(dict(distance_m=dd, theta_deg=aa, n_reads=n, n_queries=np.full(dd.size, 50)))
    assert f["errors"] == ""
    i = list(f["method"]).index("mle")
    for k, v in zip(("a1", "a2", "a3"), truth.mean_coefficients):
        assert abs(f[k][i] - v) < 4 * f["se_" + k][i], (k, f[k][i], f["se_" + k][i])
    np.testing.assert_allclose([f["d50_0deg_m"][i], f["d50_30deg_m"][i], f["d50_60deg_m"][i]],
                               truth.d50(np.array(rd.D50_ANGLES_DEG)), rtol=0.05)
    # moments fit (the source's method) ignores the dead zone: its mean is (1 - 0.05) mu,
    # so only the sign structure and a loose d50 are checked
    j = list(f["method"]).index("moments")
    assert f["a2"][j] > 0 and f["a3"][j] > 0
    assert f["d50_0deg_m"][j] == pytest.approx(6.63, rel=0.1)


def test_detection_falls_with_distance_and_angle():
    # 27 dBm, 6 dBic (3 dB polarisation loss): at 1 m on boresight the tag gets ~0 dBm,
    # at 9 m ~-18 dBm (below the chip's threshold); at 90° the patch is 20 dB down.
    cfg = replace(TINY, campaign=replace(TINY.campaign, distances_m=(1.0, 3.0, 9.0), angles_deg=(0.0, 90.0)))
    t = rd.simulate(cfg, seed=3)

    def p(d, a):
        sel = (t["distance_m"] == d) & (t["theta_deg"] == a)
        return t["p_hat"][sel].mean()

    assert p(1.0, 0.0) > 0.9
    assert p(1.0, 0.0) > p(9.0, 0.0) + 0.5
    assert p(3.0, 0.0) > p(3.0, 90.0) + 0.5


def test_unknown_tag_class_is_a_config_error():
    with pytest.raises(rd.ConfigError):
        rd.CampaignConfig(tag_class="unknown")


def test_d50_roles_say_which_angle_is_calibrated_and_which_predicted(tiny_run):
    """The dataset says which d50 is calibrated (0°: the chip sensitivity is set from it) and
    which predicted (30°: nothing set for it; 60°: from the assumed beamwidth)."""
    a = read_dataset(tiny_run.dataset_path).attrs
    assert a["d50_0deg_role"].startswith("calibrated:") and "6.63" in a["d50_0deg_role"]
    assert a["d50_30deg_role"].startswith("predicted:") and "3.97" in a["d50_30deg_role"]
    assert a["d50_60deg_role"].startswith("predicted from an assumption:") and "beamwidth" in a["d50_60deg_role"]


@pytest.fixture(scope="module")
def default_trials():
    return rd.simulate(rd.Config(), seed=1)


@pytest.mark.slow
def test_d50_roles_are_labelled_and_the_30_degree_prediction_holds(default_trials):
    """The one d50 no parameter is set for, 30° (published 3.97 m), from the ML fit of the
    default run (seed 1; measured 3.83 m): within 10 % (the source sets no tolerance; 10 % ≈ the
    fit's bootstrap spread, ± 0.37 m on the full campaign). Not independent of the other two:
    the mean model is linear in |θ|, so d50(30°) is the mean of d50(0°) (calibrated, short by the
    floor and fading) and d50(60°) (assumed beamwidth, long): checked here, the two errors
    have opposite signs."""
    f = fit_reader_models(default_trials)
    i = list(f["method"]).index("mle")
    d0, d30, d60 = (f[f"d50_{a}deg_m"][i] for a in (0, 30, 60))
    assert abs(d30 / rd.PUBLISHED_D50_M[1] - 1.0) <= 0.10, d30
    assert d30 == pytest.approx(0.5 * (d0 + d60), rel=1e-9)
    assert d0 < rd.PUBLISHED_D50_M[0] and d60 > rd.PUBLISHED_D50_M[2]
    assert rd.D50_ROLES[0].startswith("calibrated") and rd.D50_ROLES[30].startswith("predicted:")


@pytest.mark.slow
def test_default_campaign_gives_a_regular_ml_fit(default_trials):
    """Default run (224 trials × 50 queries, seed 1): with per-query fading and hops within a
    trial some trials read part of their queries, so the Beta-binomial ML fit is regular
    (before: p̂ ∈ {0, 1} and a singular fit). d50 against the published 6.63 / 3.97 / 1.30 m
    (binary-detection.md §1.6): the documented differences — shorter on boresight (chip
    threshold crossed by fading), longer at 60° (assumed 70° beamwidth) — are pinned loosely."""
    trials = default_trials
    p = trials["p_hat"]
    assert np.mean((p > 0) & (p < 1)) > 0.15
    assert np.all(trials["n_channels"] >= 1) and np.mean(trials["n_channels"] > 1) > 0.5
    f = fit_reader_models(trials)
    assert f["errors"] == ""
    i = list(f["method"]).index("mle")
    assert np.all(np.isfinite([f[k][i] for k in ("a1", "a2", "a3", "se_a1", "se_a2", "se_a3")]))
    d50 = [f[f"d50_{a}deg_m"][i] for a in (0, 30, 60)]
    assert 4.0 < d50[0] < 6.63 and 2.5 < d50[1] < 5.0 and d50[2] > 1.30
    assert d50[0] > d50[1] > d50[2]


def _d50_crossing_m(distance_m, p_hat) -> float:
    """Distance where the cell means of p̂ first fall below 1/2 (linear interpolation)."""
    ds = np.unique(distance_m)
    pm = np.array([p_hat[distance_m == v].mean() for v in ds])
    i = np.flatnonzero((pm[:-1] >= 0.5) & (pm[1:] < 0.5))[0]
    return float(ds[i] + (pm[i] - 0.5) / (pm[i] - pm[i + 1]) * (ds[i + 1] - ds[i]))


@pytest.mark.slow
def test_regression_full_campaign_fits_and_the_documented_difference_from_the_published_model():
    """Regression, not validation: the source's campaign size (4680 trials × 50 queries,
    seed 1; ≈ 150 s CPU, 6 min wall at load 5) as recorded at revision 35629ba. The source's
    method (moments: least squares on the 234 cell means) gives a1 = −6.525, a2 = 1.183 /m,
    a3 = 0.0642 /deg (standard errors 0.29, 0.051, 0.0030 from the residuals over the cells)
    and d50 = 5.52 / 3.89 / 2.26 m at 0/30/60°, pinned to the last bit (0 ULP: a rerun of the
    same code and build reproduces every bit; the numbers are this code's own, so a change
    means the simulation or the fit changed, to be re-recorded deliberately).

    What they document, against the published −3.27, 0.4931, 0.0438 and 6.63 / 3.97 / 1.30 m
    (binary-detection.md §1.6): the published coefficients lie more than 4 of the fit's
    standard errors away (our mean falls faster with distance — a chip threshold crossed by
    fading — and the 60° d50 is set by the assumed 70° patch beamwidth, see the next test).
    The ML fit (Eq. 4.11) has its maximum on the edge of the feasible region (σ² → 0+ in the
    far corner, λ̄ → 0): standard errors from the mean block only, flagged."""
    from reference.ulp import assert_close_ulp

    trials = rd.simulate(rd.Config(campaign=rd.CampaignConfig(full=True)), seed=1)
    assert trials["room"].size == 4680
    f = fit_reader_models(trials)
    j = list(f["method"]).index("moments")
    keys = ("a1", "a2", "a3", "se_a1", "se_a2", "se_a3", "d50_0deg_m", "d50_30deg_m", "d50_60deg_m")
    assert_close_ulp(np.array([f[k][j] for k in keys]),
                     np.array([-6.524859040709981, 1.1826334718255185, 0.06415041700500046, 0.28927131446624743,
                               0.05094873178786993, 0.0030328412847179342, 5.517228453409304, 3.88991740903363,
                               2.262606364657956]), FIT_ULP)
    published = dict(zip(("a1", "a2", "a3"), ReaderDetectionModel().mean_coefficients))
    for k in ("a1", "a2", "a3"):
        assert abs(f[k][j] - published[k]) > 4 * f["se_" + k][j], (k, f[k][j])
    # d50 = −(a1 + a3·θ)/a2; delta-method standard error at 60°: 0.044 m
    assert f["d50_60deg_m"][j] - rd.PUBLISHED_D50_M[2] > 10 * 0.044
    i = list(f["method"]).index("mle")
    assert f["stderr_basis"][i] == "mean block"
    assert np.isfinite([f["se_a1"][i], f["se_a2"][i], f["se_a3"][i]]).all() and np.isnan(f["se_c1"][i])


@pytest.mark.slow
def test_d50_at_60_degrees_follows_the_assumed_patch_beamwidth():
    """Cause of the 60° d50 (2.26 m here vs the published 1.30 m): the angle dependence is the
    reader patch's pattern (the antenna is rotated, the tag faces it), G(ψ)/G0 = (1 − b)cos^q ψ
    + b, b = 0.01 (20 dB front-to-back), q = ln((1/2 − b)/(1 − b))/ln cos(BW/2). Derived here:
    70° beamwidth (the assumed default): q = 3.53, G(60°)/G0 = −10.2 dB, so free-space Friis
    from the calibrated boresight d50 = 6.63 m gives 6.63·10^(−10.2/20) = 2.05 m; the published
    1.30 m = 6.63·10^(−14.1/20) needs −14.1 dB at 60°, i.e. BW = 58.6° (q = 5.14). Campaign at
    θ = 60° only (8 distances 0.5…4 m × 10 repetitions × 2 rooms × 50 queries, seed 1): the
    crossing of the cell means lies within 0.3 m of each prediction (3σ: a cell mean of 20
    nearly all-or-nothing trials has σ ≈ 0.11, the mean falls ≈ 1.1 per m near d50, so
    σ(d50) ≈ 0.1 m). The chip class moves every d50 by the Friis factor: PASS's UCODE
    (−12.78 dBm) instead of the Smartrac calibration (−16.0 dBm) gives 10^(−3.22/20) = 0.69×,
    2.05 → 1.42 m at 60°. Measured: 2.15, 1.22 and 1.21 m."""
    b = 0.01
    dists = tuple(0.5 * (i + 1) for i in range(8))
    for bw_deg, tag_class, expected_m in ((70.0, "smartrac-spine", 2.05), (58.6, "smartrac-spine", 1.30),
                                          (70.0, "pass-ucode", 1.42)):
        q = math.log((0.5 - b) / (1 - b)) / math.log(math.cos(math.radians(bw_deg / 2)))
        g60 = (1 - b) * math.cos(math.radians(60.0)) ** q + b
        chip_db = 0.0 if tag_class == "smartrac-spine" else -16.0 - (-12.78)
        assert 6.63 * math.sqrt(g60) * 10 ** (chip_db / 20) == pytest.approx(expected_m, abs=0.01)
        cfg = rd.Config(campaign=rd.CampaignConfig(distances_m=dists, angles_deg=(60.0,), repetitions=10,
                                                   tag_class=tag_class),
                        geometry=rd.GeometryConfig(reader_beamwidth_deg=bw_deg), fits=False)
        t = rd.simulate(cfg, seed=1)
        assert _d50_crossing_m(t["distance_m"], t["p_hat"]) == pytest.approx(expected_m, abs=0.3), (bw_deg, tag_class)

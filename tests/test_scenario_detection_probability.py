"""Scenario ``detection-probability``: end to end on a tiny config (dataset layout, units,
figure, xarray), determinism (same seed → same bits; sample blocks through the sweep
machinery equal one run over all samples), the TS/RTS fit plumbing recovers known
coefficients on the scenario's own geometry, and physical sanity (P(ST detects) falls
with the tag-ST distance d).

References: geometry and features of auris-sense-a-tag.md §2.2/§3.3 (tag cuboid
x ∈ [1, 8], y, z ∈ [−4, 4] m; ST within 2 m; θ = arcsin(v_y/D), φ = arcsin(v_z/D)).
"""

from __future__ import annotations

from dataclasses import replace

import h5py
import numpy as np
import pytest

from rfsim.core.dataset import read_table
from rfsim.detection import (fit_logistic, fit_logistic_gradient_descent, fit_st_models, predict_proba, rts_design,
                             rts_probability, st_features, ts_design)
from rfsim.core.rng import trial_rng
from rfsim.runs.runner import run_scenario
from rfsim.sweep.runner import run_sweep
from rfsim.sweep.spec import load_spec
from rfsim.scenarios import detection_probability as dp

TINY = dp.Config(samples=dp.SampleConfig(count=40, n_train=30))


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    return run_scenario(dp, TINY, seed=3, out_dir=tmp_path_factory.mktemp("dp"))


#: Regression pins of fitted coefficients: a fit is an iterative floating-point solution whose
#: last bits follow the BLAS/libm summation order of the installed NumPy/SciPy, so the pins
#: hold to a ULP bound (≈ 1e-12 relative), not bit for bit.
FIT_ULP = 4096


def test_tiny_run_dataset_and_figure(tiny_run):
    s = read_table(tiny_run.dataset_path, "samples")
    assert set(s) == set(dp.FIELDS)
    assert all(v.shape == (40,) for v in s.values())
    np.testing.assert_array_equal(s["sample"], np.arange(40))
    np.testing.assert_array_equal(s["is_test"], np.arange(40) >= 30)
    # the source's cuboid and 2 m ball
    assert np.all((s["tag_x_m"] >= 1) & (s["tag_x_m"] <= 8))
    assert np.all(np.abs(s["tag_y_m"]) <= 4) and np.all(np.abs(s["tag_z_m"]) <= 4)
    assert np.all((s["d_m"] >= 0.05) & (s["d_m"] <= 2.0))
    # features recomputed independently from the positions
    v = np.column_stack([s["tag_x_m"], s["tag_y_m"], s["tag_z_m"]])
    big_d = np.linalg.norm(v, axis=1)
    np.testing.assert_allclose(s["D_m"], big_d)
    np.testing.assert_allclose(s["theta_rad"], np.arcsin(v[:, 1] / big_d))
    np.testing.assert_allclose(s["phi_rad"], np.arcsin(v[:, 2] / big_d))
    st = np.column_stack([s["st_x_m"], s["st_y_m"], s["st_z_m"]])
    np.testing.assert_allclose(s["d_m"], np.linalg.norm(st - v, axis=1))
    # outcomes are consistent: nobody decodes a reply that was not sent
    assert not np.any(s["st_detected"] & ~s["tag_replied"])
    assert not np.any(s["reader_detected"] & ~s["tag_replied"])
    assert np.all((s["frequency_hz"] >= 902.75e6) & (s["frequency_hz"] <= 927.25e6))
    with h5py.File(tiny_run.dataset_path) as f:
        assert f["samples"]["D_m"].attrs["units"] == "m"
        assert f["samples"]["theta_rad"].attrs["units"] == "rad"
        assert f["samples"]["frequency_hz"].attrs["units"] == "Hz"
    assert len(tiny_run.figure_paths) == 1 and tiny_run.figure_paths[0].stat().st_size > 1000


def test_dataset_opens_in_xarray(tiny_run):
    xr = pytest.importorskip("xarray")
    with xr.open_dataset(tiny_run.dataset_path, engine="h5netcdf", group="samples") as x:
        assert x["d_m"].size == 40


def test_same_seed_same_bits_and_blocks_equal_one_run():
    one = dp.simulate(replace(TINY, samples=dp.SampleConfig(count=12, seed=9)), seed=1)
    again = dp.simulate(replace(TINY, samples=dp.SampleConfig(count=12, seed=9)), seed=1)
    blocks = [dp.simulate(replace(TINY, samples=dp.SampleConfig(first=f, count=4, seed=9)), seed=100 + f)
              for f in (0, 4, 8)]
    for k in dp.FIELDS:
        np.testing.assert_array_equal(one[k], again[k])
        np.testing.assert_array_equal(one[k], np.concatenate([b[k] for b in blocks]), err_msg=k)
    other = dp.simulate(replace(TINY, samples=dp.SampleConfig(count=12, seed=10)), seed=1)
    assert not np.array_equal(one["d_m"], other["d_m"])


def test_rows_do_not_depend_on_workers_or_block_size(monkeypatch):
    """Blocks of 4 samples on 2 worker processes (the pool path of simulate) give the same
    rows as one block of 12 in this process: each sample draws only from its own streams."""
    cfg = replace(TINY, samples=dp.SampleConfig(count=12, seed=9, workers=1))
    one = dp.simulate(cfg, seed=1)
    monkeypatch.setattr(dp, "ST_BLOCK", 4)
    monkeypatch.setattr(dp, "WARM_BLOCK", 3)
    pooled = dp.simulate(replace(cfg, samples=replace(cfg.samples, workers=2)), seed=1)
    assert one["tag_replied"].any()  # the ST chains ran for some samples
    for k in dp.FIELDS:
        np.testing.assert_array_equal(pooled[k], one[k], err_msg=k)


def test_sweep_over_sample_blocks_equals_one_run(tmp_path):
    spec_path = tmp_path / "dp.toml"
    spec_path.write_text(f'''scenario = "detection-probability"
seed = 8
output = "{tmp_path / 'sweep.h5'}"
[base]
fits = false
[base.samples]
count = 5
n_train = 10
seed = 77
[[axes]]
kind = "grid"
key = "samples.first"
values = [0, 5, 10]
''')
    report = run_sweep(load_spec(spec_path))
    merged = read_table(report.output, "samples")
    one = dp.simulate(replace(TINY, samples=dp.SampleConfig(count=15, n_train=10, seed=77)), seed=5)
    for k in dp.FIELDS:
        np.testing.assert_array_equal(merged[k], one[k], err_msg=k)
    # no ST detection among these 15 samples: fitting the merged file (rows sorted by sample
    # index, no duplicates, so no layout error) refuses for the reason fitting the single
    # run's samples directly refuses
    assert not one["st_detected"].any()
    with pytest.raises(dp.UserError) as direct:
        fit_st_models(one)
    with pytest.raises(dp.UserError) as merged_fit:
        dp.fit_file(report.output)
    assert str(merged_fit.value) == str(direct.value)


def test_fits_recover_known_coefficients_on_the_scenario_geometry():
    # 4000 samples of the scenario's geometry with y ~ Bernoulli(RTS(truth)); the ML
    # estimates are asymptotically normal with the reported standard errors, so each
    # |a_hat - a| < 4 SE fails with probability < 6.3e-5 (5 coefficients: < 3.2e-4).
    g = dp.GeometryConfig()
    geo = [dp.draw_geometry(g, rng=trial_rng(5, i, 0)) for i in range(4000)]
    tag = np.array([x[0] for x in geo])
    st = np.array([x[1] for x in geo])
    big_d, d, th, ph = st_features(tag, st)
    truth = np.array([-1.0, 0.5, 2.5, 0.3, 0.6])
    y = np.random.default_rng(3).random(4000) < rts_probability(big_d, d, th, ph, truth)
    s = dict(D_m=big_d, d_m=d, theta_rad=th, phi_rad=ph, st_detected=y, is_test=np.arange(4000) >= 3000)
    f = fit_st_models(s)
    assert list(f["model"]) == ["RTS", "RTS", "TS", "TS"]
    assert list(f["source"]) == ["fit", "published", "fit", "published"]
    est = np.array([f[f"a{j}"][0] for j in range(5)])
    se = np.array([f[f"se_a{j}"][0] for j in range(5)])
    assert np.all(np.abs(est - truth) < 4 * se), (est, se)
    # the true model family beats TS on the test set (the truth depends on D, θ, φ too)
    assert f["test_cross_entropy"][0] < f["test_cross_entropy"][2]
    assert f["n_train"][0] == 3000 and f["n_test"][0] == 1000
    assert np.isnan(f["se_a0"][1]) and np.isnan(f["a2"][2])


def test_published_ts_is_what_ts_fits_to_data_of_the_published_rts():
    """The published TS and RTS (seed 003 L3886, L3869-3871) can describe the same data: TS fitted
    by ML to outcomes drawn from the published RTS on the source's geometry (tag uniform in the
    cuboid x ∈ [1, 8], y, z ∈ [−4, 4] m; ST at a uniform distance r ∈ [0.05, 2] m in an isotropic
    direction; 3000 training samples as in the source) gives a0 = 1.15 ± 0.13, a1 = 2.40 ± 0.22
    (mean ± sd of single fits, 10 seeds) against the published 0.897 / 2.444. Over 8 draws each
    published value lies within 2.5 sd of a single fit from the mean of the fits (a0: 1.9 sd)."""
    fits = []
    for k in range(8):
        rng = np.random.default_rng(100 + k)
        tag = rng.uniform([1.0, -4.0, -4.0], [8.0, 4.0, 4.0], (3000, 3))
        u = rng.standard_normal((3000, 3))
        st = tag + rng.uniform(0.05, 2.0, (3000, 1)) * u / np.linalg.norm(u, axis=1, keepdims=True)
        big_d, d, th, ph = st_features(tag, st)
        y = rng.random(3000) < rts_probability(big_d, d, th, ph)  # the published RTS coefficients
        fits.append(fit_logistic(np.column_stack([np.ones(3000), d]), y.astype(float)).coefficients)
    a = np.array(fits)
    mean, sd = a.mean(axis=0), a.std(axis=0, ddof=1)
    assert np.all(np.abs(mean - np.array([0.8970, 2.4443])) < 2.5 * sd), (mean, sd)


def test_st_detection_falls_with_distance():
    # tag near the panel's boresight (always powered), 200 samples, ST distance uniform in
    # [0.05, 2] m. Within 0.3 m the tag's backscatter at the ST is ≥ 20 dB above the
    # 5 mV threshold, beyond 1.2 m it is near or below it.
    g = replace(dp.GeometryConfig(), tag_x_m=(1.0, 2.0), tag_y_m=(-0.5, 0.5), tag_z_m=(-0.5, 0.5))
    s = dp.simulate(replace(TINY, geometry=g, samples=dp.SampleConfig(count=200, seed=4)), seed=1)
    assert s["tag_replied"].mean() > 0.9
    near, far = s["d_m"] < 0.3, s["d_m"] > 1.2
    assert near.sum() >= 10 and far.sum() >= 50
    assert s["st_detected"][near].mean() > s["st_detected"][far].mean() + 0.3


def test_elliptical_panel_mismatch_against_a_rolled_dipole():
    # Ellipse of axial ratio AR (field ratio r = 1/AR) against a linear antenna at angle τ from
    # the major axis: PLF = (cos²τ + r²·sin²τ)/(1 + r²) (derived here); AR = 0 dB → 1/2 (the
    # constant 3 dB of an ideal circular panel). Boresight: AR = 1 dB; at the beam edge 3 dB.
    import math

    from rfsim.scenarios import detection_probability as dp

    g = dp.GeometryConfig()
    panel = dp.reader_antenna(g)
    for ar_db, x in ((1.0, 5.0), (3.0, None)):
        if x is None:  # 35° off boresight in azimuth (half of the 70° beamwidth)
            pos = 5.0 * np.array([math.cos(math.radians(35.0)), math.sin(math.radians(35.0)), 0.0])
        else:
            pos = np.array([x, 0.0, 0.0])
        r = 10 ** (-ar_db / 20)
        for roll_deg in (0.0, 30.0, 90.0):
            tag = dp.tag_antenna(pos, math.radians(roll_deg))
            tau = math.radians(roll_deg)
            expected = (math.cos(tau) ** 2 + r * r * math.sin(tau) ** 2) / (1 + r * r)
            assert float(panel.polarization_mismatch(tag)) == pytest.approx(expected, rel=1e-9), (ar_db, roll_deg)
    ideal = dp.reader_antenna(dp.GeometryConfig(axial_ratio_db=(0.0, 0.0)))
    assert float(ideal.polarization_mismatch(dp.tag_antenna(np.array([3.0, 1.0, 0.5]), 0.7))) == pytest.approx(0.5)


@pytest.mark.slow
def test_regression_default_run_fits_and_the_documented_difference_from_the_published_models():
    """Regression, not validation: the default run (4000 samples, seed 1: train 3000, test
    1000; ≈ 60 s CPU) as recorded at revision 35629ba: RTS and TS fits, test cross-entropies,
    the number of replying tags and the RTS refit on those samples, to the last bit (0 ULP: a
    rerun of the same code and build reproduces every bit; the numbers are this code's own, so
    a change means the simulation or the fit changed, to be re-recorded deliberately).

    What they document (auris-sense-a-tag.md R4-1: published RTS (−1.462, 0.4941, 2.506,
    0.0126, 0.0523), test cross-entropy 0.1278; TS (0.8970, 2.4443), 0.1502): the published
    RTS has a2 ≫ a1 ≫ a3, a4 ("orientation matters little"); the fit here has the angle
    terms more than 10× the published ones (checked against the published values with the
    fit's standard errors, inverse Fisher information). The tag replies in under half of the
    samples (1746 of 4000); the RTS refit on the samples where it replied is pinned too (a3
    4.10 → 1.59, a4 5.76 → 1.83 /rad) — a selection, not the cause: switching the tag's power-up
    and the reader pattern is ``test_angle_coefficients_follow_the_reader_pattern_and_the_tag_power_up``.
    The published coefficients score 0.1637 / 0.1809 on this test set."""
    from reference.ulp import assert_close_ulp

    from rfsim.detection import fit_logistic, rts_design

    s = dp.simulate(dp.Config(), seed=1)
    f = fit_st_models(s)
    i = {(m, src): k for k, (m, src) in enumerate(zip(f["model"], f["source"]))}
    rts, ts = i["RTS", "fit"], i["TS", "fit"]
    assert_close_ulp(np.array([f[f"a{j}"][rts] for j in range(5)]),
                     np.array([-8.197930379815883, 0.7724960646166029, 7.393547932719529, 4.095468398248811,
                               5.762307956271912]), FIT_ULP)
    assert_close_ulp(np.array([f["a0"][ts], f["a1"][ts]]), np.array([0.018607933322274874, 5.36770173803827]),
                     FIT_ULP)
    assert_close_ulp(np.array([f["test_cross_entropy"][rts], f["test_cross_entropy"][ts]]),
                     np.array([0.1355515922315379, 0.18120397455566356]), FIT_ULP)
    # angle terms > 10x the published ones, by more than 4 standard errors of the fit
    for j in (3, 4):
        pub = f[f"a{j}"][i["RTS", "published"]]
        assert f[f"a{j}"][rts] - 10 * pub > 4 * f[f"se_a{j}"][rts]
    # the cause: under half of the samples replied; fitted on those, the angle terms shrink
    replied = s["tag_replied"]
    assert int(replied.sum()) == 1746 and replied.size == 4000
    sub = replied & ~s["is_test"]
    x = rts_design(s["D_m"], s["d_m"], s["theta_rad"], s["phi_rad"])
    refit = fit_logistic(x[sub], s["st_detected"].astype(float)[sub]).coefficients
    assert_close_ulp(np.asarray(refit), np.array([-4.958759850064473, 0.3928458174298854, 7.458610752300888,
                                                  1.588817937964763, 1.8274512179696785]), FIT_ULP)


def test_pass_like_antenna_model_sets_the_flat_pattern_and_the_powered_tag():
    """``geometry.antenna_model = "pass-like"`` is the same configuration as the four settings
    it stands for (170°, 3 dBic, roll 0, tag sensitivity −40 dBm)."""
    preset = dp.Config(geometry=dp.GeometryConfig(antenna_model="pass-like"))
    explicit = dp.Config(geometry=dp.GeometryConfig(reader_beamwidth_deg=170.0, reader_gain_dbic=3.0, tag_roll_deg=0.0),
                         tag=replace(dp.TagConfig(), sensitivity_dbm=-40.0))
    assert replace(preset.geometry, antenna_model="panel") == explicit.geometry and preset.tag == explicit.tag
    assert dp.Config().geometry.reader_beamwidth_deg == 70.0
    assert preset.tag.sensitivity_dbm == -40.0 and dp.Config().tag.sensitivity_dbm > -20.0


@pytest.mark.slow
def test_angle_coefficients_follow_the_reader_pattern_and_the_tag_power_up():
    """Cause of the azimuth coefficient a3 (panel, default: 4.10 ± 0.50 /rad at seed 1, published
    0.0126, seed 003 L3886): switched on and off at seed 1 (4000 samples each, ≈ 60 s CPU each).
    With the tag powered throughout but the panel's pattern (down to −19 dB over the cuboid)
    a3 stays > 4 standard errors of the fit above the published (measured 3.13 ± 0.36); with the
    pattern flat over the cuboid as well (``pass-like``) it is within 2.5 standard errors
    (measured 0.011 ± 0.40; seeds 1-3: 0.56 ± 0.48) and the test cross-entropies are within
    0.01 of the published 0.1278 / 0.1502 (measured 0.1281 / 0.1488; seeds 1-3 0.130 ± 0.003 /
    0.153 ± 0.005), RTS below TS."""
    pub_a3, pub_ce = 0.0126, (0.1278, 0.1502)
    powered = dp.Config(geometry=dp.GeometryConfig(tag_roll_deg=0.0),
                        tag=replace(dp.TagConfig(), sensitivity_dbm=-40.0))
    passlike = dp.Config(geometry=dp.GeometryConfig(antenna_model="pass-like"))
    f = fit_st_models(dp.simulate(powered, seed=1))
    assert f["a3"][0] - pub_a3 > 4 * f["se_a3"][0], (f["a3"][0], f["se_a3"][0])
    f = fit_st_models(dp.simulate(passlike, seed=1))
    assert abs(f["a3"][0] - pub_a3) < 2.5 * f["se_a3"][0], (f["a3"][0], f["se_a3"][0])
    ce = (f["test_cross_entropy"][0], f["test_cross_entropy"][2])
    assert abs(ce[0] - pub_ce[0]) < 0.01 and abs(ce[1] - pub_ce[1]) < 0.01 and ce[0] < ce[1], ce


def test_tag_dipole_loses_gain_towards_the_reader_with_elevation_not_azimuth():
    """Mechanism of the elevation coefficient a4: the tag's vertical half-wave dipole, facing the
    reader, receives the reader's CW with the dipole's gain at the elevation φ of the reader seen
    from the tag, G(φ)/G(0) = [cos(π/2·sin φ)/cos φ]² (Balanis §4.6: −1.76 dB at 30°, −5.05 dB
    at 50°), and with its broadside gain at any azimuth θ (omnidirectional in azimuth). With
    ``geometry.tag_pattern = "isotropic"`` (the dipole's peak gain in every direction) the
    incident power does not depend on φ. Same placements and streams for both patterns, no
    small-scale fading: the incident powers differ by the dipole's elevation factor alone."""
    import math

    from rfsim.scenes.st_detection import Devices, Placement, run_rounds

    g = dp.GeometryConfig(antenna_model="pass-like", apdp=False)
    cfg = dp.Config(geometry=g)
    angles = [(0.0, 0.0), (0.0, 30.0), (0.0, 50.0), (50.0, 0.0)]  # (θ, φ) [deg]

    def incident_dbm(tag_pattern):
        dev = Devices(cfg.reader, cfg.tag, cfg.st, dp.reader_antenna(g), dp.scene(g))
        placements, rngs = [], []
        for i, (th, ph) in enumerate(angles):
            th, ph = math.radians(th), math.radians(ph)
            t = 3.0 * np.array([math.cos(ph) * math.cos(th), math.cos(ph) * math.sin(th), math.sin(ph)])
            placements.append(Placement(t, t + np.array([0.0, 0.3, 0.0]), 0.0,
                                        dp.tag_antenna(t, 0.0, dp.antenna_pattern(tag_pattern))))
            rngs.append([np.random.default_rng(100 + 10 * i + k) for k in range(dp.N_STREAMS)])
        return np.array([r["tag_incident_power_dbm"] for r in run_rounds(dev, placements, rngs)])

    loss_db = incident_dbm("dipole") - incident_dbm("isotropic")
    expected = [0.0, 10 * math.log10((math.cos(math.pi / 2 * 0.5) / math.cos(math.radians(30))) ** 2),
                10 * math.log10((math.cos(math.pi / 2 * math.sin(math.radians(50))) / math.cos(math.radians(50))) ** 2),
                0.0]
    assert expected[1] == pytest.approx(-1.761, abs=1e-3) and expected[2] == pytest.approx(-5.053, abs=1e-3)
    np.testing.assert_allclose(loss_db, expected, atol=1e-9)


@pytest.mark.slow
def test_elevation_coefficient_follows_the_tag_dipole_pattern_and_the_d_slope_stays():
    """Cause of the elevation coefficient a4 (published 0.0523 /rad, seed 003 L3886), switched
    on and off at seed 1 under ``pass-like`` (4000 samples each, ≈ 60 s CPU each): with the
    tag's vertical dipole a4 is more than 3 standard errors of the fit above the published
    (measured 1.46 ± 0.40; seeds 1-3 2.00 ± 0.77); with ``geometry.tag_pattern = "isotropic"``
    (the dipole's broadside gain in every direction, nothing else changed) it is within 2
    (measured 0.008 ± 0.37; seeds 1-3 0.20 ± 0.97). The ML d slope stays
    more than 8 standard errors above the published 2.506 /m either way (measured 12.9 ± 0.9 /
    11.8 ± 0.7): the switch is not its cause (the slope's is the fitting method:
    ``test_gradient_descent_stopped_early_gives_the_published_d_slope_on_sharp_data``)."""
    pub_a2, pub_a4 = 2.506, 0.0523
    dipole = fit_st_models(dp.simulate(dp.Config(geometry=dp.GeometryConfig(antenna_model="pass-like")), seed=1))
    flat = fit_st_models(dp.simulate(dp.Config(geometry=dp.GeometryConfig(antenna_model="pass-like",
                                                                          tag_pattern="isotropic")), seed=1))
    assert dipole["a4"][0] - pub_a4 > 3 * dipole["se_a4"][0], (dipole["a4"][0], dipole["se_a4"][0])
    assert abs(flat["a4"][0] - pub_a4) < 2 * flat["se_a4"][0], (flat["a4"][0], flat["se_a4"][0])
    for f in (dipole, flat):
        assert f["a2"][0] - pub_a2 > 8 * f["se_a2"][0], (f["a2"][0], f["se_a2"][0])


def test_random_tag_orientation_is_uniform_and_the_default_draws_are_kept():
    """``geometry.tag_facing = "random"``: a uniformly random rotation, so the dipole's axis
    (local z) is uniform on the sphere: each global component has mean 0 and mean square 1/3
    (variance of z² 4/45; 2000 draws, 5 standard errors ≈ 0.033). The default placement
    (facing in azimuth, vertical at roll 0) is unchanged by the option."""
    from rfsim.core.rng import trial_rng_grid

    rngs = trial_rng_grid(7, range(2000), range(dp.N_STREAMS))
    g = dp.GeometryConfig(tag_facing="random")
    axes = np.array([dp.sample_placement(g, r).tag_antenna.polarization_axis for r in rngs])
    assert np.all(np.abs(axes.mean(axis=0)) < 5 * np.sqrt(1 / 3 / 2000)), axes.mean(axis=0)
    assert np.all(np.abs((axes ** 2).mean(axis=0) - 1 / 3) < 5 * np.sqrt(4 / 45 / 2000)), (axes ** 2).mean(axis=0)
    rngs = trial_rng_grid(7, range(3), range(dp.N_STREAMS))
    flat = dp.GeometryConfig(tag_roll_deg=0.0)
    for r in rngs:
        p = dp.sample_placement(flat, r)
        np.testing.assert_array_equal(p.tag_antenna.polarization_axis, [0.0, 0.0, 1.0])


def test_gradient_descent_stopped_early_gives_the_published_d_slope_on_sharp_data():
    """Cause of the d slope (published a2 = 2.506 /m, TS a1 = 2.444 /m; seed 003 L3854 "We
    apply gradient descent method"): outcomes drawn from a logistic with the sharp edge in d of
    the ``pass-like`` runs (a = (−6.75, 0.63, 11.5, 0.56, 2.0), their ML fits over seeds 1-3) on
    the scenario's geometry, 3000 samples. Maximum likelihood recovers the sharp slope (measured
    12.96 at this seed; 11.8-13.0 over seeds 0-3); 500 steps of gradient descent from zero at
    α = 0.1 (the stop at which TS reaches the published a1 on the runs' data) give a2 = 2.04
    (1.96-2.06 over seeds 0-3) and TS (0.87, 2.42) (published 0.897, 2.444), a model that predicts
    P(detect | d < 0.2 m) = 0.23 where the data has 0.64 (published RTS: 0.18). With many more
    steps the descent converges to the ML fit (TS, 20000 steps at α = 1: within 1.3e-4 of (−2.089, 11.237))."""
    g = dp.GeometryConfig()
    geo = [dp.draw_geometry(g, rng=trial_rng(5, i, 0)) for i in range(3000)]
    big_d, d, th, ph = st_features(np.array([x[0] for x in geo]), np.array([x[1] for x in geo]))
    truth = np.array([-6.75, 0.63, 11.5, 0.56, 2.0])
    y = (np.random.default_rng(0).random(3000) < rts_probability(big_d, d, th, ph, truth)).astype(float)
    x_rts, x_ts = rts_design(big_d, d, th, ph), ts_design(d)
    ml = fit_logistic(x_rts, y)
    assert ml.coefficients[2] > 9.0, ml.coefficients
    gd = fit_logistic_gradient_descent(x_rts, y, learning_rate=0.1, iterations=500)
    ts = fit_logistic_gradient_descent(x_ts, y, learning_rate=0.1, iterations=500)
    assert 1.5 < gd[2] < 3.0 and abs(gd[3]) < 0.3, gd
    assert 0.5 < ts[0] < 1.2 and 2.1 < ts[1] < 2.8, ts
    near = d < 0.2
    assert y[near].mean() > 0.5 and predict_proba(x_rts[near], gd).mean() < 0.35
    converged = fit_logistic_gradient_descent(x_ts, y, learning_rate=1.0, iterations=20000)
    np.testing.assert_allclose(converged, fit_logistic(x_ts, y).coefficients, atol=1e-3)


@pytest.mark.slow
def test_gradient_descent_fit_of_the_pass_like_run_gives_the_published_d_slope_and_ts():
    """The d slope's cause on the scenario's own data (``pass-like``, seed 1, 4000 samples, ≈ 60 s
    CPU): the ML fit has a2 = 12.85 /m; ``fit_gd_iterations = 500`` (α = 0.1, the source's
    gradient descent stopped where TS reaches the published a1) gives a2 = 2.21 (published
    2.506; seeds 1-3 2.13 ± 0.10), TS (0.66, 2.46) (0.897, 2.444), |a3|, |a4| ≤ 0.11 (0.0126,
    0.0523). Not reproduced by it: a0 = −0.04 (−1.462), a1 = 0.13 (0.494) and the test
    cross-entropies 0.205 / 0.206 (0.1278 / 0.1502; the ML fit reaches 0.128 / 0.149)."""
    cfg = dp.Config(geometry=dp.GeometryConfig(antenna_model="pass-like"), fit_gd_iterations=500)
    samples = dp.simulate(cfg, seed=1)
    ml = fit_st_models(samples)
    gd = fit_st_models(samples, gradient_descent=(cfg.fit_gd_learning_rate, cfg.fit_gd_iterations))
    assert ml["a2"][0] > 8.0, ml["a2"][0]
    assert 1.8 < gd["a2"][0] < 2.8 and abs(gd["a3"][0]) < 0.3 and abs(gd["a4"][0]) < 0.3, gd
    assert 0.4 < gd["a0"][2] < 1.1 and 2.1 < gd["a1"][2] < 2.8, (gd["a0"][2], gd["a1"][2])
    # what it does not reproduce: the intercept, the D slope and the cross-entropies
    assert gd["a0"][0] > -0.5 and gd["a1"][0] < 0.3 and gd["test_cross_entropy"][0] > 0.18

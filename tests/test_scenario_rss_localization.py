"""Scenario rss-localization: the thesis's tables reproduced within the spec's tolerances
(wave2-specs.md §R) plus a Monte-Carlo margin from the trial count, dataset layout, seeds and
one-line errors for bad input."""

from __future__ import annotations


import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.config import from_dict
from rfsim.scenarios import rss_localization as rl


def _run(seed=7, **overrides):
    return rl.run(from_dict(rl.Config, overrides), seed=seed)


def _table(ds, name):
    return {k: c.data for k, c in ds.tables[name].items()}


def _rmse_and_se(est, name, motion, sigma0=None):
    """RMSE of the scored errors and its standard error, clustered by trial (steps of one
    track are correlated): SE(RMSE) = SE(mean e²)/(2·RMSE), SE(mean e²) from per-trial means."""
    m = (est["estimator"] == name) & (est["motion"] == motion) & est["scored"]
    if sigma0 is not None:
        m &= np.isclose(est["sigma0_db"], sigma0)
    e2 = est["error_m"][m] ** 2
    trials = est["trial"][m]
    per = np.bincount(trials, weights=e2) / np.maximum(np.bincount(trials), 1)
    per = per[np.bincount(trials) > 0]
    rmse = np.sqrt(e2.mean())
    return rmse, per.std(ddof=1) / np.sqrt(per.size) / (2 * rmse)


def test_nn_table_7_3_within_10_percent_and_monotone():
    """NN k = 4, 3 readers, σ0 = 3/5.2/7/9 dB (Table 7.3, L1214–L1218): 1.38/1.95/2.29/2.57 m,
    ±10 % (spec) + 3 SE of 1500 trials."""
    ds = _run(estimators=["nn"], motions=["fixed"], trials=1500)
    est = _table(ds, "estimates")
    published = {3.0: 1.38, 5.2: 1.95, 7.0: 2.29, 9.0: 2.57}
    got = []
    for s, p in published.items():
        rmse, se = _rmse_and_se(est, "nn", "fixed", s)
        got.append(rmse)
        assert abs(rmse - p) <= 0.10 * p + 3 * se, (s, rmse, p)
    assert np.all(np.diff(got) > 0)
    sm = _table(ds, "summary")
    np.testing.assert_allclose(sm["published_rmse_m"], list(published.values()))


def test_shared_noise_term_does_not_reproduce_table_7_3():
    """Why the noise is independent per reader: one term shared by all readers (the literal
    "noise on the target's transmit power") gives ≈ 1.6 m at σ0 = 5.2 dB, 20 % below the
    published 1.95 m — outside the ±10 % that the independent model meets (1000 trials)."""
    ds = _run(estimators=["nn"], motions=["fixed"], sigma0_db=[5.2], trials=1000,
              shadowing={"readers": "shared"})
    rmse, se = _rmse_and_se(_table(ds, "estimates"), "nn", "fixed")
    assert rmse + 3 * se < 0.9 * 1.95


@pytest.mark.parametrize("preset, readers, k, published", [
    ("sim-5x8", 4, 4, 1.74),       # Table 7.2
    ("sim-10x16", 3, 68, 3.73),    # Table 7.6
    ("sim-10x16", 4, 68, 3.39),
])
def test_nn_reader_count_and_large_room(preset, readers, k, published):
    """NN at σ0 = 5.2 dB with 4 readers and in the 10 × 16 m room: ±10 % + 3 SE of 600 trials."""
    ds = _run(preset=preset, n_readers=readers, nn_k=k, estimators=["nn"], motions=["fixed"],
              sigma0_db=[5.2], trials=600)
    rmse, se = _rmse_and_se(_table(ds, "estimates"), "nn", "fixed")
    assert abs(rmse - published) <= 0.10 * published + 3 * se


@pytest.mark.parametrize("family, trials, fixed_pub, fixed_tol, mobile_pub, mobile_tol", [
    ("grid", 600, 1.83, 0.10, 1.22, 0.15),   # Tables 7.11, 7.10 (D = 0.5 m, rt = 10)
    ("pf", 400, 2.00, 0.15, 1.14, 0.15),     # Tables 7.15, 7.16 (N = 250)
])
def test_bayesian_filters_fixed_and_mobile_at_5_2_db(family, trials, fixed_pub, fixed_tol, mobile_pub,
                                                      mobile_tol):
    """Grid Bayes and SIR at σ = σ0 = 5.2 dB, MMSE: fixed and mobile RMSE within the spec's
    tolerance + 3 SE of the trials; fixed > mobile; MMSE < MAP (Tables 7.7 and 7.14: 1.22 vs
    1.40, 1.14 vs 2.06)."""
    ds = _run(estimators=[family], sigma0_db=[5.2], trials=trials)
    est = _table(ds, "estimates")
    fixed, se_f = _rmse_and_se(est, f"{family}-mmse", "fixed")
    mobile, se_m = _rmse_and_se(est, f"{family}-mmse", "mobile")
    assert abs(fixed - fixed_pub) <= fixed_tol * fixed_pub + 3 * se_f
    assert abs(mobile - mobile_pub) <= mobile_tol * mobile_pub + 3 * se_m
    assert fixed > mobile
    assert _rmse_and_se(est, f"{family}-map", "mobile")[0] > mobile + se_m


def test_waveform_mode_reproduces_table_7_3_at_5_2_db_through_the_air():
    """rss_model = waveform: the beacons of the log-distance draws sent at sample level (MSK
    through per-reader log-distance links, ActiveReader RSSI). In the 5 × 8 m room every
    beacon is heard at ≥ 27 dB in-band SNR, so each reading equals the statistical power
    within 0.06 dB (filter loss 0.02 dB + noise); NN k = 4 then gives Table 7.3's 1.95 m
    within ±10 % + 3 SE of 300 trials, and its RMSE equals the paired log-distance run's
    within 1 %."""
    kw = dict(estimators=["nn"], motions=["fixed"], sigma0_db=[5.2], trials=300)
    wave, stat = _run(rss_model="waveform", **kw), _run(**kw)
    w, s = _table(wave, "rssi_wide"), _table(stat, "rssi_wide")
    for r in (1, 2, 3):
        diff = w[f"rssi_r{r}_dbm"] - s[f"rssi_r{r}_dbm"]
        assert np.all(np.isfinite(diff)) and np.max(np.abs(diff)) < 0.06
    counts = _table(wave, "waveform")
    assert counts["beacons_due"][0] == 300 and counts["reported"][0] == 900 and counts["lbt_dropped"][0] == 0
    rmse, se = _rmse_and_se(_table(wave, "estimates"), "nn", "fixed")
    assert abs(rmse - 1.95) <= 0.10 * 1.95 + 3 * se
    assert abs(rmse / _rmse_and_se(_table(stat, "estimates"), "nn", "fixed")[0] - 1) < 0.01
    assert wave.attrs["rss_model"] == "waveform" and "independent per reader" in wave.attrs["noise_model"]


def test_waveform_home_replica_with_reference_tags_walls_and_1_db_steps():
    """Home preset at sample level: 5 tags (target + 4 reference tags) beacon in every epoch
    with listen-before-talk; readers through the brick wall (WAF 2 dB); 1 dB steps. Every
    report is the 1 dB step of the statistical power (beacons table: ``rssi_dbm``) or one step
    off (a rounding boundary within the 0.06 dB of filter loss and noise), the latter in
    ≤ 10 % of the readings; ≥ 97 % of the beacons are reported."""
    ds = _run(preset="home-2room", motions=["fixed"], trials=1, home_steps=1, estimators=["nn"],
              rss_model="waveform")
    b = _table(ds, "beacons")
    assert b["rssi_dbm"].size == 25 * 5 * 3
    rep = b["rssi_reported_dbm"]
    heard = np.isfinite(rep)
    assert heard.mean() >= 0.97
    off = rep[heard] - np.round(b["rssi_dbm"][heard])
    assert np.all(np.isin(off, [-1.0, 0.0, 1.0])) and np.mean(off != 0) <= 0.10
    assert np.all(np.abs(rep[heard] - b["rssi_dbm"][heard]) <= 0.5 + 0.06)
    # time stamps: when each tag sent its beacon, inside its 1 s epoch, µs resolution
    assert np.all((b["t_s"] > b["step"]) & (b["t_s"] < b["step"] + 1))
    assert np.unique(b["t_s"]).size == 25 * 5 and np.all(np.abs(b["t_us"] - 1e6 * b["t_s"]) <= 0.5)
    counts = _table(ds, "waveform")
    assert counts["beacons_due"][0] == 25 * 5
    assert counts["reported"][0] == heard.sum()


@pytest.mark.slow
def test_waveform_apdp_adds_rician_fading_of_the_link_k_factor():
    """waveform.apdp: the exponential APDP (PASS room curves) redrawn per beacon puts a Rician
    factor |h|² on each link's power, K = ApdpModel().k_db_at(d) (12–22 dB in the 5 × 8 m
    room). The spread of (waveform − statistical) RSSI over 60 trials × 3 readers matches the
    spread of 10·log10|h|² drawn here with numpy at the same K's within ±30 % (sample std of
    180 values: ±16 % at 3 SE)."""
    from rfsim.channels import ApdpModel

    kw = dict(estimators=["nn"], motions=["fixed"], sigma0_db=[5.2], trials=60)
    wave = _run(rss_model="waveform", waveform={"apdp": True}, **kw)
    stat = _run(**kw)
    w, s = _table(wave, "rssi_wide"), _table(stat, "rssi_wide")
    diff = np.concatenate([w[f"rssi_r{r}_dbm"] - s[f"rssi_r{r}_dbm"] for r in (1, 2, 3)])
    readers = np.asarray(wave.attrs["readers_xy"])
    d = np.concatenate([np.hypot(w["x_m"] - x, w["y_m"] - y) for x, y in readers])
    k = 10 ** (ApdpModel().k_db_at(d) / 10)
    rng = np.random.default_rng(3)
    z = (rng.standard_normal((4000, d.size)) + 1j * rng.standard_normal((4000, d.size))) / np.sqrt(2)
    h2 = np.abs(np.sqrt(k / (k + 1)) + z / np.sqrt(k + 1)) ** 2
    expected = np.std(10 * np.log10(h2))
    assert diff.size == 180 and np.all(np.isfinite(diff))
    assert 0.7 * expected <= np.std(diff) <= 1.3 * expected, (np.std(diff), expected)


def test_offline_fit_recovers_table_6_1_and_waf():
    """Offline campaign (400 reads per distance at 1–3 m, Sec. 6.1): α ±1 dB, n ±0.1, σ and
    WAF = 2 dB within 4 standard errors of 2000 / 2 × 400 reads."""
    ds = _run(preset="home-2room", trials=1, motions=["mobile"], particles=50)
    cal = _table(ds, "calibration")
    off = cal["kind"] == "offline"
    table_6_1 = np.array([(-42.0, 2.3, 5.3), (-52.0, 2.3, 5.2), (-45.0, 2.5, 5.0)])
    assert off.sum() == 3
    np.testing.assert_allclose(cal["alpha_dbm"][off], table_6_1[:, 0], atol=1.0)
    np.testing.assert_allclose(cal["exponent"][off], table_6_1[:, 1], atol=0.1)
    sig = table_6_1[:, 2]
    assert np.all(np.abs(cal["sigma_db"][off] - sig) < 4 * sig / np.sqrt(2 * 2000))
    assert np.all(np.abs(cal["waf_db"][off] - 2.0) < 4 * sig * np.sqrt(2 / 400))
    online = cal["kind"] == "online"
    assert online.any() and np.all((cal["alpha_dbm"][online] >= -55) & (cal["alpha_dbm"][online] <= -40))


def test_dataset_layout_and_reproducibility():
    ds = _run(estimators=["nn", "grid"], sigma0_db=[5.2], trials=6)
    for name in ("beacons", "rssi_wide", "estimates", "summary"):
        assert name in ds.tables
    b = _table(ds, "beacons")
    assert b["epc"][0] == "300000000000000000000001" and len(b["epc"][0]) == 24
    assert set(np.unique(b["reader"])) == {1, 2, 3}
    w = _table(ds, "rssi_wide")
    assert {"rssi_r1_dbm", "rssi_r2_dbm", "rssi_r3_dbm", "x_m", "y_m"} <= set(w)
    again = _table(_run(estimators=["nn", "grid"], sigma0_db=[5.2], trials=6), "estimates")
    np.testing.assert_array_equal(_table(ds, "estimates")["x_est_m"], again["x_est_m"])
    other = _table(_run(seed=8, estimators=["nn", "grid"], sigma0_db=[5.2], trials=6), "estimates")
    assert not np.array_equal(other["x_est_m"], again["x_est_m"])
    # trial streams are keyed by index: the first 3 trials do not depend on how many run
    few = _table(_run(estimators=["nn"], sigma0_db=[5.2], trials=3), "rssi_wide")
    sel_few = (few["case"] == 0) & (few["step"] == 0)
    sel = (w["case"] == 0) & (w["trial"] < 3) & (w["step"] == 0)
    assert sel_few.sum() == sel.sum() == 3
    np.testing.assert_array_equal(few["rssi_r1_dbm"][sel_few], w["rssi_r1_dbm"][sel])


def test_figures_are_written(tmp_path):
    out = tmp_path / "out"
    assert main(["run", "rss-localization", "--out-dir", str(out), "--set", "trials=5",
                 "--set", "sigma0_db=[3.0, 5.2]"]) == 0
    names = sorted(p.name for p in out.glob("*.png"))
    assert names == ["rss-localization-cdf.png", "rss-localization-floorplan.png",
                     "rss-localization-rmse.png"]
    xr = pytest.importorskip("xarray")
    with xr.open_dataset(out / "rss-localization.h5", engine="h5netcdf", group="beacons") as b:
        assert b["epc"].values[0] == "300000000000000000000001"
        assert b["t_us"].values.max() == 9_000_000      # rt = 10 recursions at 5.2 dB, 1 beacon/s


@pytest.mark.parametrize("setting, fragment", [
    ("readers_xy=[[6.0, 1.0], [0.0, 0.0]]", "readers_xy[0]"),
    ("walls_xy=[[1.0, 1.0, 1.0, 1.0]]", "walls_xy[0]"),
    ("sigma0_db=[-1.0]", "sigma0_db[0]"),
    ("nn_k=29", "nn_k"),
    ("readers_xy=[]", "readers_xy"),
    ("rss_model=statistical", "rss_model"),
    ("waveform.fs_hz=2.1e6", "waveform.fs_hz"),
])
def test_bad_input_is_one_line_exit_2(setting, fragment, capsys, tmp_path):
    assert main(["run", "rss-localization", "--out-dir", str(tmp_path), "--set", setting]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim: error: ") and fragment in err
    assert not list(tmp_path.glob("*.h5"))


@pytest.mark.slow
def test_table_7_3_reproduction_4000_trials():
    """4 σ0 × 4000 trials, NN + grid Bayes (fixed target): NN within ±10 % of Table 7.3 and grid
    Bayes of Table 7.11 + 3 SE. (Its cost is a figure of ``rfsim bench``, not a test.)"""
    ds = _run(estimators=["nn", "grid"], motions=["fixed"], trials=4000, write_beacons=False)
    est = _table(ds, "estimates")
    for s, p in {3.0: 1.38, 5.2: 1.95, 7.0: 2.29, 9.0: 2.57}.items():
        rmse, se = _rmse_and_se(est, "nn", "fixed", s)
        assert abs(rmse - p) <= 0.10 * p + 3 * se
    for s, p in {3.0: 1.36, 5.2: 1.83, 7.0: 2.07, 9.0: 2.34}.items():
        rmse, se = _rmse_and_se(est, "grid-mmse", "fixed", s)
        assert abs(rmse - p) <= 0.10 * p + 3 * se


@pytest.mark.slow
def test_table_7_3_through_the_sweep_machinery(project_root, tmp_path):
    """The repeated Table 7.3 run as a sweep (examples/sweeps/rss-localization.toml: 4 σ0 points
    × 2 repetitions × 4000 trials, NN + grid Bayes), serial executor: the merged summary holds the 8 runs and every run's NN RMSE is within
    ±10 % + 3 SE of the published 1.38/1.95/2.29/2.57 m."""
    from rfsim.core.dataset import read_table
    from rfsim.sweep import SerialExecutor, load_spec, run_sweep

    text = (project_root / "examples" / "sweeps" / "rss-localization.toml").read_text()
    text = text.replace('output = "results/sweep-rss-localization.h5"', f'output = "{tmp_path / "sweep.h5"}"')
    spec_path = tmp_path / "sweep.toml"
    spec_path.write_text(text)
    report = run_sweep(load_spec(spec_path), SerialExecutor())
    sm = read_table(report.output, "summary")
    assert (sm["estimator"] == "nn").sum() == 8
    est = read_table(report.output, "estimates")
    published = {3.0: 1.38, 5.2: 1.95, 7.0: 2.29, 9.0: 2.57}
    checked = 0
    for point in np.unique(est["sweep_point"]):
        for rep in np.unique(est["sweep_repetition"]):
            sel = (est["sweep_point"] == point) & (est["sweep_repetition"] == rep)
            one = {k: v[sel] for k, v in est.items()}
            s0 = round(float(one["sigma0_db"][0]), 1)
            rmse, se = _rmse_and_se(one, "nn", "fixed")
            assert abs(rmse - published[s0]) <= 0.10 * published[s0] + 3 * se, (s0, rep, rmse)
            checked += 1
    assert checked == 8


@pytest.mark.slow
def test_grid_and_sir_sigma_sweeps():
    """Grid fixed/mobile (Tables 7.11/7.10) and SIR fixed/mobile (7.15/7.16) over σ0 = 1…9 dB
    within ±15 % + 3 SE of 1000 trials (fixed grid ±10 %, from 3 dB: at 1 dB this model gives
    0.73 m vs 0.65 m, +13 %, the distance to the nearest of the 28 interior cells for targets
    in the 1 m border strip dominating); MAP (Tables 7.7, 7.14) within ±15 % + 3 SE and above
    MMSE at every σ0."""
    ds = _run(estimators=["grid", "pf"], sigma0_db=[1.0, 3.0, 5.2, 7.0, 9.0], trials=1000, write_beacons=False)
    est = _table(ds, "estimates")
    tables = {("grid-mmse", "fixed"): ({3.0: 1.36, 5.2: 1.83, 7.0: 2.07, 9.0: 2.34}, 0.10),
              ("grid-mmse", "mobile"): ({1.0: 0.57, 3.0: 0.97, 5.2: 1.22, 7.0: 1.34, 9.0: 1.51}, 0.15),
              ("grid-map", "mobile"): ({1.0: 0.67, 3.0: 1.06, 5.2: 1.40}, 0.15),
              ("pf-mmse", "fixed"): ({1.0: 0.63, 3.0: 1.48, 5.2: 2.00, 7.0: 2.38, 9.0: 2.55}, 0.15),
              ("pf-mmse", "mobile"): ({1.0: 0.53, 3.0: 0.97, 5.2: 1.14, 7.0: 1.38, 9.0: 1.45}, 0.15),
              ("pf-map", "mobile"): ({1.0: 0.64, 3.0: 1.41, 5.2: 2.06}, 0.15)}
    checked = 0
    for (name, motion), (values, tol) in tables.items():
        for s, p in values.items():
            rmse, se = _rmse_and_se(est, name, motion, s)
            assert abs(rmse - p) <= tol * p + 3 * se, (name, motion, s, rmse, p)
            checked += 1
    assert checked == 25
    for family in ("grid", "pf"):
        for motion in ("fixed", "mobile"):
            for s in (1.0, 3.0, 5.2, 7.0, 9.0):
                mmse, se = _rmse_and_se(est, f"{family}-mmse", motion, s)
                assert _rmse_and_se(est, f"{family}-map", motion, s)[0] > mmse, (family, motion, s)


@pytest.mark.slow
def test_home_replica_mobile_ordering():
    """Home replica, mobile target (Table 7.42): grid + smoothing < grid + auto σ < grid <
    online NN < offline NN, and improved SIR < grid (800 scored estimates each); fixed target
    (Table 7.41, 3000 scored): the pattern (fingerprint) NN beats both parameter NNs and
    improved SIR beats grid Bayes. Not reproduced, and not asserted: the thesis's best mobile
    result (improved SIR + online σ + smoothing, 1.25 m; here ≈ 1.30 m, behind grid +
    smoothing ≈ 1.23 m) and its fixed-target grid Bayes above both NNs (2.04 vs 1.68/1.63 m;
    here 1.57 vs 1.57/1.43 m over 24 × 25 points, seed 1: 25 % of σ² is a people term that
    the 30 recursions average out; see test_home_fixed_grid_behind_the_nns_when_all_shadowing_persists)."""
    ds = _run(preset="home-2room", trials=4, write_beacons=False)
    est = _table(ds, "estimates")
    r = {n: _rmse_and_se(est, n, "mobile")[0] for n in np.unique(est["estimator"])}
    chain = ["grid-smoothing", "grid-auto-sigma", "grid", "nn-online", "nn-offline"]
    assert all(r[a] < r[b] for a, b in zip(chain, chain[1:])), r
    assert r["pf-improved"] < r["grid"]
    f = {n: _rmse_and_se(est, n, "fixed")[0] for n in np.unique(est["estimator"])}
    assert f["nn-pattern"] < min(f["nn-online"], f["nn-offline"]), f
    assert f["pf-improved"] < f["grid"], f


def _nearest_centre_mse_m2(length_m: float) -> float:
    """E[u²] along one axis: u the offset of a uniform point in [0, L] from the nearest of the
    cell centres 1, 2, …, L − 1 m (1 m spacing). The two edge cells span [c − 1, c + 0.5]
    (E[u²] = (1³ + 0.5³)/(3·1.5) = 0.25), the L − 3 m between them are cells of width 1
    (E[u²] = 1/12)."""
    edge = (1.0 ** 3 + 0.5 ** 3) / (3.0 * 1.5)
    return (2 * 1.5 * edge + (length_m - 3.0) / 12.0) / length_m


def test_grid_fixed_at_1_db_exceeds_the_thesis_through_the_border_strip():
    """Grid Bayes, fixed target, σ = σ0 = 1 dB (Table 7.11: 0.65 m; spec ±10 %): this model
    gives ≈ 0.73 m (+13 %). The cause is the 28-cell grid, not the filter: targets are uniform
    in the 5 × 8 m room (L1135) but the cell centres span only [1, 4] × [1, 7] m, and the MMSE, a
    convex combination of centres, cannot enter the 1 m strip along the walls (30 % of the room).
    The floor of any estimate on the centres, the RMS distance to the nearest one, is
    √(E[u_x²] + E[u_y²]) = 0.574 m in closed form. For the targets inside the centres' hull
    widened by half a cell ([0.5, 4.5] × [0.5, 7.5] m) the same run is within ±10 % + 3 SE of
    0.65 m; over the whole room it is above +5 % + 3 SE (1500 trials)."""
    floor = float(np.sqrt(_nearest_centre_mse_m2(5.0) + _nearest_centre_mse_m2(8.0)))
    assert abs(floor - 0.5737) < 1e-3
    ds = _run(estimators=["grid"], motions=["fixed"], sigma0_db=[1.0], trials=1500, write_beacons=False)
    est = _table(ds, "estimates")
    m = (est["estimator"] == "grid-mmse") & est["scored"]
    e, xy = est["error_m"][m], np.column_stack([est["x_true_m"][m], est["y_true_m"][m]])
    inner = np.all((xy >= 0.5) & (xy <= [4.5, 7.5]), axis=1)

    def rmse_se(err):
        r = float(np.sqrt(np.mean(err ** 2)))
        return r, float(np.std(err ** 2, ddof=1) / np.sqrt(err.size) / (2 * r))

    r_all, se_all = rmse_se(e)
    r_in, se_in = rmse_se(e[inner])
    assert r_all > 1.05 * 0.65 + 3 * se_all, r_all          # measured 0.73 m
    assert abs(r_in - 0.65) <= 0.10 * 0.65 + 3 * se_in, r_in  # measured 0.63 m
    assert r_all > floor and abs(inner.mean() - 28 / 40) < 0.05


@pytest.mark.slow
def test_home_fixed_grid_behind_the_nns_when_all_shadowing_persists():
    """Table 7.41's fixed-target ordering, grid Bayes (2.04 m) behind the offline and online NN
    (1.68/1.63 m), follows from the share of σ² that persists at a fixed point: the filter takes
    the 30 beacons as independent σ = 5.2 dB readings, so a persistent error pulls its posterior
    onto a wrong cell, while LANDMARC over all 36 cells stays near the centroid. With the
    replica's default (75 % quasi-static) grid ties the offline NN (1.57 vs 1.57 m); with all of
    σ² quasi-static (the thesis's real home: antenna patterns and multipath fixed per point) it
    is behind both (measured 1.73 vs 1.59/1.34 m, 12 × 25 points). The mobile chain of
    Table 7.42 then loses grid < online NN (1.66 vs 1.53 m), which is why the default keeps a
    people term."""
    ds = _run(preset="home-2room", trials=12, motions=["fixed"], write_beacons=False,
              estimators=["nn", "grid"], shadowing={"static_fraction": 1.0})
    est = _table(ds, "estimates")
    grid, se = _rmse_and_se(est, "grid", "fixed")
    for nn in ("nn-offline", "nn-online"):
        assert grid > _rmse_and_se(est, nn, "fixed")[0] + se, (nn, grid)

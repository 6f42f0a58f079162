"""Scenario ``phase-cancellation``: the default run (dataset layout, figures,
xarray), the radial tracks (λ/4 null spacing on the 0° track, R3-3 / Fig. 3.15), the Monte
Carlo's internal consistency (sample level vs closed forms, Algorithm 1 never worse than
SA2 alone) and its independence of the number of worker processes.

References: λ/4 = 0.08197 m at 915 MHz (auris-sense-a-tag.md §0.5, quoted 0.082 m);
Fig. 3.5 peaks 0.8 / 0.56569 / 0.30615 / 0.15607 and Fig. 3.3 peaks |A_T1 − A_T2| (§1.3,
§1.4 derived tables).
"""

from __future__ import annotations

import math
from dataclasses import replace

import h5py
import numpy as np
import pytest

from rfsim.core.dataset import read_dataset, read_table
from rfsim.runs.runner import run_scenario
from rfsim.devices import pass_tag, st_pair
from rfsim.scenarios import phase_cancellation as pc
from rfsim.devices.sense_a_tag import TECHNIQUES as TECHS
from rfsim.scenes.tag_listening import minima_spacing_m
from reference.devices_st_pair import ask_stamp_transitions_reference, couple_ports_reference

LAMBDA_915_M = 299792458.0 / 915e6


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("pc")
    return run_scenario(pc, pc.Config(), seed=1, out_dir=out)


def test_default_run_is_complete(default_run):
    """Figures and every column of the samples table; the run's time is a figure of
    ``rfsim bench scenarios`` (``phase-cancellation_wall_s``), not a test."""
    res = default_run
    assert len(res.figure_paths) == 4 and all(p.stat().st_size > 1000 for p in res.figure_paths)
    s = read_table(res.dataset_path, "samples")
    n = 13 * 100
    assert s["cell"].size == n
    for k in ("repetition", "st_x_m", "st_y_m", "sa1_x_m", "sa2_y_m", "theta_sa1_rad", "theta_sa2_rad",
              "a_r_sa2_v", "a_t1_sa2_v", "a_t2_sa2_v", "diff_sa1_v", "diff_sa2_v", "diff_combined_v",
              "detected_single", "detected_selection", "detected_stamp", "cancelled_combination"):
        assert s[k].shape == (n,), k
    # disc of radius 0.5 m around the tag, antennas λ/4 apart
    r = np.hypot(s["st_x_m"] - s["tag_x_m"], s["st_y_m"])
    assert r.max() <= 0.5
    np.testing.assert_allclose(np.hypot(s["sa2_x_m"] - s["sa1_x_m"], s["sa2_y_m"] - s["sa1_y_m"]), 0.082)
    cells = read_table(res.dataset_path, "cells")
    # near field (an antenna within λ/2π = 5.2 cm of the tag, ≈ 1 % of the positions):
    # excluded from the probabilities and counted
    r_min = np.minimum(np.hypot(s["sa1_x_m"] - s["tag_x_m"], s["sa1_y_m"]),
                       np.hypot(s["sa2_x_m"] - s["tag_x_m"], s["sa2_y_m"]))
    np.testing.assert_array_equal(s["near_field"], r_min < LAMBDA_915_M / (2 * np.pi))
    assert read_dataset(res.dataset_path).attrs["n_near_field"] == s["near_field"].sum()
    for t in TECHS:
        for c in range(13):
            sel = (s["cell"] == c) & ~s["near_field"]
            assert cells["n_samples"][c] == sel.sum()
            assert cells[f"p_{t}"][c] == pytest.approx(s[f"cancelled_{t}"][sel].mean())
            assert cells[f"ci_lo_{t}"][c] <= cells[f"p_{t}"][c] <= cells[f"ci_hi_{t}"][c]
    with h5py.File(res.dataset_path) as f:
        assert f["samples"]["diff_sa2_v"].attrs["units"] == "V"


def test_dataset_opens_in_xarray(default_run):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    res = default_run
    with xr.open_dataset(res.dataset_path, engine="h5netcdf", group="cells") as cells:
        assert cells["p_selection"].size == 13
    with xr.open_dataset(res.dataset_path, engine="h5netcdf", group="fig3_8") as m:
        assert m["diff_v"].dims == ("y_m", "x_m")


def test_analytic_grids_match_reference_tables(default_run):
    res = default_run
    ds = read_dataset(res.dataset_path)
    coords, var = ds.grids["fig3_5"]
    peaks = var["diff"].data.max(axis=1)
    np.testing.assert_allclose(peaks, [0.8, 0.56569, 0.30615, 0.15607], atol=2e-5)  # 721-point θ grid
    coords, var = ds.grids["fig3_3"]
    d, th = var["diff"].data, coords["theta_rad"].data
    # the four (A_T1, A_T2) pairs of the §1.3 derived table (A_R = 1) and their nulls at
    # ±θ_cancel = 1.9284, 1.7214, 2.5868, 1.6158 rad (the table's values, not the code's)
    np.testing.assert_allclose(np.c_[var["a_t1"].data, var["a_t2"].data],
                               [[0.4, 0.3], [0.2, 0.1], [0.9, 0.8], [0.05, 0.04]])
    pos = th > 0
    step = th[1] - th[0]
    np.testing.assert_allclose(th[pos][np.argmin(d[:, pos], axis=1)], [1.9284, 1.7214, 2.5868, 1.6158],
                               atol=step / 2 + 5e-5)
    np.testing.assert_allclose(th[~pos][np.argmin(d[:, ~pos], axis=1)], [-1.9284, -1.7214, -2.5868, -1.6158],
                               atol=step / 2 + 5e-5)
    # maxima at θ = 0 and ±π


def test_cw_at_the_st_matches_table_3_1_in_source_units(default_run):
    # Table 3.1/3.2 (L3372-3380, L3418-3470): A_R = 0.0802, 0.1087, 0.0976, 0.1247 V at
    # cell 1 in the source's unit (peak sqrt(2P) across 1 Ω), reader EIRP 3.28 W (§6.1).
    # The median over 100 positions within 0.5 m of the tag (reader distance 0.5–1.5 m,
    # A_R ∝ 1/d) lies within ±20 % of 1 m; the bounds are the tabulated range ±20 %.
    res = default_run
    ds = read_dataset(res.dataset_path)
    assert ds.attrs["reader_eirp_w"] == pytest.approx(3.28, rel=0.005)
    cells = read_table(res.dataset_path, "cells")
    a_r = cells["median_a_r_sa2_source_v"]
    assert a_r.size == 13
    assert 0.8 * 0.0802 <= a_r[0] <= 1.2 * 0.1247


def test_backscatter_level_at_the_st_against_table_3_1(default_run):
    # Table 3.1/3.2 (L3372-3380, L3418-3470), cell 1: A_T1 = 0.0576, 0.0585, 0.066, 0.1233 V
    # (source unit), A_T1/A_R = 0.54–0.99. Radar equation for the re-radiated state r_B at
    # an ST antenna r from the tag, both fed by the same reader (derived here): A_T1/A_R ≈
    # |r_B|·G_tag·λ/(4π·r)·(R̃/D) with G_tag = 1.64 (λ/2 dipole), R̃ / D the reader–ST /
    # reader–tag distances — ≈ 0.09 at the median r ≈ 0.35 m, so the physical dipole
    # puts A_T 6–14× below the tabulated points (documented difference; the source's
    # 6.02 dBi "dipole" file raises it 2.44×, pass-replication). The test pins the
    # model's ratio to the radar equation within 25 % (median over LoS-dominated cell 1,
    # small-scale fading on) and the documented gap to the table.
    res = default_run
    s = read_table(res.dataset_path, "samples")
    c0 = (s["cell"] == 0) & s["tag_replied"]
    r = np.hypot(s["sa2_x_m"] - s["tag_x_m"], s["sa2_y_m"])[c0]
    rr = np.hypot(s["sa2_x_m"], s["sa2_y_m"])[c0]
    d_tag = s["tag_x_m"][c0]
    ratio = (s["a_t1_sa2_v"] / s["a_r_sa2_v"])[c0]
    lam = LAMBDA_915_M
    r_b = s["rerad_b_abs"][c0]
    radar = r_b * 1.64 * lam / (4 * np.pi * r) * rr / d_tag
    assert np.median(ratio / radar) == pytest.approx(1.0, rel=0.25)
    cells = read_table(res.dataset_path, "cells")
    gap = 0.0576 / cells["median_a_t1_sa2_source_v"][0]
    assert 4.0 < gap < 14.0


def test_sample_level_matches_closed_form_in_the_monte_carlo(default_run):
    res = default_run
    s = read_table(res.dataset_path, "samples")
    for name in ("sa1", "sa2", "combined"):
        meas, closed = s[f"diff_{name}_v"], s[f"closed_diff_{name}_v"]
        big = closed > 1e-3
        assert big.sum() > 300
        np.testing.assert_allclose(meas[big], closed[big], rtol=0.01)
    # decoded flags against the closed-form threshold: disagreements only near 5 mV
    for t in TECHS:
        diff = s[f"cancelled_{t}"] != s[f"closed_cancelled_{t}"]
        assert diff.mean() < 0.03, t
    p = {t: s[f"cancelled_{t}"].mean() for t in TECHS}
    assert p["selection"] < p["single"] and p["combination"] < p["single"]


def test_single_antenna_probability_against_the_uniform_phase_closed_form(default_run):
    # Weak backscatter: the detector difference is ≈ |Δb|·|cos(θ − θ0)| with |Δb| the
    # synchronised difference (sync_sa2_v, detector output). With θ uniform over the disc
    # (it spans many wavelengths) P(cancel | Δb) = P(|cos| < t/|Δb|) = (2/π)·arcsin(t/|Δb|)
    # for |Δb| > t (derived here). The chain's decisions over 1300 samples must match the
    # mean of that within 3 binomial standard errors.
    res = default_run
    s = read_table(res.dataset_path, "samples")
    t = 5e-3
    db = s["sync_sa2_v"]
    closed = np.where(db > t, (2 / np.pi) * np.arcsin(np.minimum(t / np.where(db > 0, db, 1.0), 1.0)), 0.0)
    p_mc = s["cancelled_single"].mean()
    se = math.sqrt(p_mc * (1 - p_mc) / db.size)
    assert abs(closed.mean() - p_mc) < 3 * se


def test_measured_tag_powers_up_by_the_pass_rule_and_silent_tags_are_not_detectable(default_run):
    # 'measured' tag (default): runs ⇔ P_chip ≥ 52.709 µW·10^(2.5/10) = 93.73 µW (PASS picmin +
    # 2.5 dB, pass-paris-simulator.md §2.2); with EIRP 3.28 W that is ≈ 5 m (Friis), so the
    # near cells reply and the far ones do not
    res = default_run
    s = read_table(res.dataset_path, "samples")
    assert np.all(s["tag_chip_power_w"] < s["tag_available_power_w"])
    np.testing.assert_array_equal(s["tag_replied"], s["tag_chip_power_w"] >= 52.709e-6 * 10 ** 0.25)
    assert s["tag_replied"][s["cell"] == 0].all() and not s["tag_replied"][s["cell"] == 12].any()
    silent = ~s["tag_replied"]
    for t in TECHS:
        assert not s[f"cancelled_{t}"][silent].any(), t
    assert not s["detectable"][silent].any()
    cells = read_table(res.dataset_path, "cells")
    for c in range(13):
        sel = s["cell"] == c
        assert cells["tag_replied_fraction"][c] == pytest.approx(s["tag_replied"][sel].mean())
        assert cells["detectable_fraction"][c] == pytest.approx(s["detectable"][sel].mean())


def test_detectability_condition_removes_far_failures(default_run):
    """Fig. 3.16's fall with distance (L3484-3502) is the source's condition: a sample counts
    only when the synchronised difference exceeds 5 mV. Not every replying sample passes it (the
    module once said so): default run, 123 of 900, none at 1 m, 21 % over 3-5 m; the single chain
    fails on them (all 123; full run all but 1 of 1231), so the condition removes failures, more
    the farther the tag: over 3-5 m single antenna is 33 % with it and 54 % without (docs page)."""
    s = read_table(default_run.dataset_path, "samples")
    cell, far = s["cell"], ~s["near_field"]
    replied = s["tag_replied"] & far
    below = replied & ~s["detectable"]
    np.testing.assert_array_equal(s["cancelled_single"][far], (s["detectable"] & ~s["detected_single"])[far])
    assert not below[cell == 0].any()
    far_cells = np.isin(cell, [4, 5, 6, 7, 8])  # 3-5 m
    assert below[far_cells].sum() > 0.1 * replied[far_cells].sum()
    assert s["detected_single"][below].sum() <= 0.01 * below.sum()
    p_on = s["cancelled_single"][far_cells & far].mean()
    p_off = (replied & ~s["detected_single"])[far_cells & far].mean()
    assert p_off > p_on + 0.1


def test_radial_tracks_null_spacing_lambda_over_4():
    tr = pc.radial_tracks(pc.Config(), seed=3)
    assert list(tr["angle_deg"]) == [0.0, 45.0, 90.0, 180.0]
    d = tr["distance_m"]
    assert d.size == 49 and d[0] == pytest.approx(0.04) and d[-1] == pytest.approx(1.0)
    pos, spacing = minima_spacing_m(d, tr["diff_v"][0])
    assert pos.size >= 8
    assert abs(spacing - LAMBDA_915_M / 4) <= 0.05 * LAMBDA_915_M / 4
    # 45°, 90°, 180°: between two neighbouring nulls R̃ − r changes by λ/2 (θ turns by π,
    # θ_cancel ≈ π/2 for weak backscatter), R̃ reader–ST, r tag–ST, tag at (2, 0), reader at
    # the origin (geometry written out here). So between the first and the last minimum the
    # path difference turns by (n − 1)·λ/2, up to the 0.02 m grid at both ends.
    for i, a in enumerate(tr["angle_deg"]):
        pos, _ = minima_spacing_m(d, tr["diff_v"][i])
        u = np.array([np.cos(np.pi + np.radians(a)), np.sin(np.pi + np.radians(a))])
        path = lambda x: np.hypot(2.0 + x * u[0], x * u[1]) - x  # noqa: E731
        if a == 180.0:
            assert pos.size == 0  # R̃ − r = 2 m all along: no nulls
            continue
        turns = abs(path(pos[-1]) - path(pos[0])) / (LAMBDA_915_M / 2)
        slope = abs(path(pos[-1] + 0.01) - path(pos[-1] - 0.01)) / 0.02 + abs(path(pos[0] + 0.01) - path(pos[0] - 0.01)) / 0.02
        assert abs(turns - (pos.size - 1)) <= slope * 0.02 / (LAMBDA_915_M / 2), a
        # and the number of nulls over the track is the number of half-wave turns (±1)
        total = abs(path(d[-1]) - path(d[0])) / (LAMBDA_915_M / 2)
        assert abs(pos.size - total) <= 1.0, a
    big = tr["closed_diff_v"] > 0.2 * tr["closed_diff_v"].max()
    np.testing.assert_allclose(tr["diff_v"][big], tr["closed_diff_v"][big], rtol=0.01)


def test_workers_do_not_change_results():
    base = pc.Config()
    cfg = replace(base, geometry=replace(base.geometry, tag_x_m=(1.0, 5.0)), tracks=replace(base.tracks, cell=0),
                  mc=replace(base.mc, positions_per_cell=12, repetitions=2, workers=1))
    one = pc.monte_carlo(cfg, seed=7)
    two = pc.monte_carlo(replace(cfg, mc=replace(cfg.mc, workers=2)), seed=7)
    assert one.keys() == two.keys()
    for k in one:
        np.testing.assert_array_equal(one[k], two[k], err_msg=k)
    assert one["cell"].size == 2 * 2 * 12


@pytest.mark.slow
def test_paper_size_monte_carlo_orders_the_techniques():
    """3900 positions × 3 repetitions × all techniques: the probabilities' order and the exact
    interval of the selection probability (its time is a figure of ``rfsim bench campaigns``,
    not a test)."""
    from scipy.stats import binomtest

    base = pc.Config()
    cfg = replace(base, mc=replace(base.mc, full=True))
    s = pc.monte_carlo(cfg, seed=1)
    assert s["cell"].size == 13 * 300 * 3
    far = ~s["near_field"]
    p = {t: s[f"cancelled_{t}"][far].mean() for t in TECHS}
    assert p["selection"] < p["combination"] < p["single"] and p["stamp"] < p["single"]
    # overall selection probability with its exact 95 % interval (scipy's binomtest, not the
    # scenario's code): the documented deviation is that it lies above the source's "below
    # 1 %" (R3-5; attribute below_1_percent)
    k, n = int(s["cancelled_selection"][far].sum()), int(far.sum())
    ci = binomtest(k, n).proportion_ci(0.95, method="exact")
    assert ci.low > 0.01
    # stamp vs selection: identical in closed form; at sample level within 0.6 points (the
    # stamp commits to P2 from four subcarrier cycles where a reply at ±3 % of the threshold
    # then fails; documented in the module)
    np.testing.assert_array_equal(s["closed_cancelled_stamp"], s["closed_cancelled_selection"])
    assert abs(p["stamp"] - p["selection"]) < 0.006
    # single antenna against the uniform-phase closed form (2/π)·arcsin(t/|Δb|), 3 standard
    # errors of 11 700 samples (≈ 1.2 points)
    db = s["sync_sa2_v"][far]
    closed = np.where(db > 5e-3, (2 / np.pi) * np.arcsin(np.minimum(5e-3 / np.where(db > 0, db, 1.0), 1.0)), 0.0)
    assert abs(closed.mean() - p["single"]) < 3 * np.sqrt(p["single"] * (1 - p["single"]) / n)
    # per cell (Fig. 3.16 falls with distance, L3484-3502): the source's condition — a sample
    # counts only when the synchronised difference exceeds 5 mV — is what bends the curve. Among
    # cells whose tag runs in every repetition (1-5 m), single antenna rises from 1 m, then falls
    # from 3 m to 5 m (39 % -> 32 %); counting every replying sample instead (condition off) it
    # rises to 5 m (54 % -> 58 %), and path selection rises 9.5 -> 35 % instead of levelling
    # off at 18-20 %. 880 samples per cell: standard error ≤ 1.7 points per cell.
    cell, replied = s["cell"], s["tag_replied"]
    powered = [c for c in range(13) if replied[cell == c].all()]
    assert powered == list(range(9))  # 1 ... 5 m; from 5.5 m the tag does not always power up

    def per_cell(flag):
        return np.array([flag[(cell == c) & far].mean() for c in powered])

    on = {t: per_cell(s[f"cancelled_{t}"]) for t in ("single", "selection")}
    off = {t: per_cell(replied & ~s[f"detected_{t}"]) for t in ("single", "selection")}
    se = 0.017
    assert on["single"][4:8].mean() > on["single"][0] + 0.05
    assert on["single"][8] < on["single"][4] - 3 * se  # the fall, 3 m -> 5 m
    assert off["single"][8] > off["single"][4]  # without the condition: no fall
    assert off["selection"][5:9].mean() > on["selection"][5:9].mean() + 0.08
    assert abs(on["selection"][5:9].mean() - on["selection"][1:5].mean()) < 0.03
    # the samples the condition removes: replying, below 5 mV, and failed by the single chain
    # (all but 1 of 1231, at 0.98x the threshold)
    below = replied & far & ~s["detectable"]
    assert s["detected_single"][below].sum() <= 0.01 * below.sum()
    assert np.mean(below[(cell == 8) & far]) > np.mean(below[(cell == 1) & far]) + 0.1


def _tiny(**kw):
    base = pc.Config()
    return replace(base, geometry=replace(base.geometry, tag_x_m=(1.0,), apdp=False),
                   tracks=replace(base.tracks, cell=0), mc=replace(base.mc, positions_per_cell=6, workers=1), **kw)


def test_pass_replication_uses_the_6_dbi_file_and_the_assembly_resistance(reference_data):
    # PASS's 'l2-dipole' file has a peak amplitude of 2.0 = 6.02 dBi (reference-data README):
    # with it the tag's available power is 4/1.6409 = 2.44× the physical half-wave dipole's
    # (LoS, same geometry); the assembly resistance R_at takes its share of the absorbed power
    folder = reference_data / "pass-characteristics"
    pr = pc.PassReplicationConfig(enabled=True, characteristics_dir=str(folder))
    phys = pc.run_cell(_tiny(), 0, 0, 3)
    rep = pc.run_cell(_tiny(pass_replication=pr), 0, 0, 3)
    ratio = rep["tag_available_power_w"][0] / phys["tag_available_power_w"][0]
    assert ratio == pytest.approx(4.0 / 1.6409, rel=0.01)
    assert rep["tag_chip_power_w"][0] < rep["tag_available_power_w"][0]
    chip = pass_tag.chip_model(str(folder), 915.25e6, 2.5, 0.0)
    # R_at ∥ C_at with the chip's parallel Q at its minimum power (written out here)
    y = 1.0 / chip.impedances(chip.picmin_w)[0]
    r_at = (abs(y.imag) / y.real) / (2 * np.pi * chip.fc_hz * 450e-15)
    assert chip.assembly_resistance_ohm == pytest.approx(r_at, rel=1e-12)
    assert 1e3 < r_at < 5e3


def test_pass_replication_needs_the_characteristics_folder():
    from rfsim.core.errors import ConfigError

    with pytest.raises(ConfigError, match="pass_replication.characteristics_dir"):
        pc.PassReplicationConfig(enabled=True, characteristics_dir="")


def test_table_3_1_backscatter_level_is_passs_antenna_files_at_a_point_near_the_tag(reference_data):
    """Cause of A_T at the ST being 7× (physical dipoles) / 2.9× (PASS's file at the tag only)
    below Table 3.1's 0.0576 V: derived here by hand from the source's numbers, then checked
    against the model (cell 1, tag 1 m from the reader, 100 ST positions, LoS only, the pair's
    mutual coupling off: with it, the default, A_R and A_T at SA2 are a further ≈ 0.85×).
    Measured (seed 5): A_T1·r = 0.00309 / 0.00770 / 0.01202 V·m with physical dipoles / PASS's
    file at the tag / at tag and ST, gaps 6.77 / 2.71 / 1.74 (predicted 6.77 / 2.71 / 1.74).

    Source's convention: A_R_trans = sqrt(2·EIRP) = sqrt(2·3.28 W) = 2.5612 (Eq. 3.23 constant,
    L3256-3262: peak sqrt(2P) across 1 Ω). PASS's tag at R = 2 m with its 'l2-dipole' file
    (amplitude 2.0, pass-paris-simulator.md §5.1): P_av = 3.28·4·(λ/4πR)² = 2.23 mW (the log:
    2.28 mW), so A_T1_bsk = 0.0526 V = |ρ_m|·sqrt(2·P_av) gives |ρ_m| = 0.787. PASS's sensatag
    uses the same file (§3.2), so at the ST, r from the tag at D = 1 m:
    A_T1·r = |ρ_m|·sqrt(2·EIRP)·(2.0·λ/4π)·(2.0·2.0·λ/4π) = 0.0110 V·m. Table 3.2's point
    (A_T1/A_T1' = 0.5353 = r2/r1 at λ/4 spacing: r2 ≤ 0.0944 m) needs A_T1'·r2 ≤ 0.1233·0.0944
    = 0.0116 V·m — consistent (r2 = 0.089 m, r1 = 0.166 m); with physical λ/2 dipoles (amplitude
    sqrt(1.641) = 1.281 at all three places) A_T·r is (2/1.281)³ = 3.81× smaller and the point would
    lie at r2 = 0.023 m, inside the near field. Table 3.1's A_T1 = 0.0576 V is at r = 0.19 m from
    the tag in PASS's convention, while the model's median over the 0.5 m disc is at r ≈ 0.35 m.
    Hence gap = 0.0576/median A_T1 ≈ 3.81·(|ρ_m|/|r_B|)·(median r/0.19 m) — 7× with physical
    dipoles; PASS's file at the tag only removes 2.44× of it, at the ST as well 3.81×."""
    lam = LAMBDA_915_M
    k = lam / (4 * np.pi)
    eirp = 3.28
    assert math.sqrt(2 * eirp) == pytest.approx(2.5612, abs=1e-4)
    p_av_2m = eirp * 4.0 * (k / 2.0) ** 2
    assert p_av_2m == pytest.approx(2.28e-3, rel=0.03)
    rho_m = 0.0526 / math.sqrt(2 * p_av_2m)
    k_pass = rho_m * math.sqrt(2 * eirp) * (2.0 * k) * (2.0 * 2.0 * k)  # A_T1·r at D = 1 m [V·m]
    assert k_pass == pytest.approx(0.0110, abs=0.0002)
    r2_max = (lam / 4) / (1 / 0.5353 - 1)
    assert k_pass <= 0.1233 * r2_max
    g_dip = math.sqrt(1.6409)
    files_factor = (2.0 / g_dip) ** 3
    assert k_pass / files_factor / 0.1233 < lam / (2 * np.pi)
    r_point = k_pass / 0.0576

    folder = str(reference_data / "pass-characteristics")
    from rfsim.devices.st_receiver import to_source_volts

    base = replace(_tiny(), mc=replace(_tiny().mc, positions_per_cell=100),
                   geometry=replace(_tiny().geometry, pair_coupling=False))
    runs = {"physical": base,
            "tag file": replace(base, pass_replication=pc.PassReplicationConfig(enabled=True,
                                                                                characteristics_dir=folder)),
            "tag and ST files": replace(base, pass_replication=pc.PassReplicationConfig(
                enabled=True, characteristics_dir=folder, st_antenna_file=True))}
    expected_factor = {"physical": files_factor, "tag file": files_factor / (4.0 / 1.6409),
                       "tag and ST files": 1.0}
    for name, cfg in runs.items():
        s = pc.run_cell(cfg, 0, 0, 5)
        far = ~s["near_field"]
        a_t1 = to_source_volts(s["a_t1_sa2_v"][far])
        r = np.hypot(s["sa2_x_m"] - s["tag_x_m"], s["sa2_y_m"])[far]
        r_b = s["rerad_b_abs"][0]
        # the model's A_T1·r against PASS's, corrected for the antenna files and the tag state
        k_model = np.median(a_t1 * r)
        assert k_model * expected_factor[name] * rho_m / r_b == pytest.approx(k_pass, rel=0.05), name
        # and the gap of the medians = files x state x (median r / the point's r)
        gap = 0.0576 / np.median(a_t1)
        assert gap == pytest.approx(expected_factor[name] * (rho_m / r_b) * np.median(r) / r_point, rel=0.05), name


@pytest.mark.slow
def test_regression_below_one_percent_needs_passs_backscatter_level_at_the_st():
    """Regression, not validation: the source's "below 1 %" for path selection (R3-5) is
    reached when the backscatter at the ST stands to the 5 mV threshold as in PASS's antenna
    convention: (2/1.281)³ = 3.81× our A_T (derived in
    test_table_3_1_backscatter_level_is_passs_antenna_files_at_a_point_near_the_tag).
    Paper-size Monte Carlo, seed 1, with the threshold at 5 mV/3.81 and everything else ours,
    as recorded at revision 35629ba and re-recorded with the counter-based receiver noise as
    the default: of the 11 464 samples outside the near field, 110 cancelled with path
    selection (0.96 %, below the source's 1 %) and 843 with a single antenna (7.35 %; 842 with
    the PCG64 noise before). Counts, so exact: a rerun of the same code gives the same samples;
    a change means the simulation changed, to be re-recorded deliberately."""
    base = pc.Config()
    cfg = replace(base, mc=replace(base.mc, full=True), st=replace(base.st, threshold_v=base.st.threshold_v / 3.81))
    s = pc.monte_carlo(cfg, seed=1)
    far = ~s["near_field"]
    assert s["cell"].size == 11700 and int(far.sum()) == 11464
    assert int(s["cancelled_selection"][far].sum()) == 110
    assert int(s["cancelled_single"][far].sum()) == 843
    assert s["cancelled_selection"][far].mean() < 0.01


@pytest.mark.parametrize("shape", [(7, 2, 2467), (7, 2, 333), (5, 2, 2), (5, 2, 1), (1, 2, 40), (7, 2)])
def test_pair_coupling_kernel_equals_einsum_bit_for_bit(shape):
    """st_pair.couple_ports (numba) against its einsum twin on waveforms and on gains, with the
    default pair's coupling matrix (Z12 at λ/4) and inputs spanning six decades, zeros and
    negative zeros included."""
    from rfsim.devices import st_analytic as sa

    rng = np.random.default_rng(3)
    mix = sa.coupling_matrix(z12_ohm=complex(sa.mutual_impedance_half_wave_ohm(LAMBDA_915_M / 4, 915e6)))
    x = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * 10.0 ** rng.uniform(-6, 0, shape)
    zeros = np.array([0.0, -0.0, complex(-0.0, 0.0), complex(0.0, -0.0)])
    first = (0,) * (x.ndim - 2)
    x[(0, slice(None)) + first] = zeros[:2]  # both ports zero: a zero sum
    x[(-1, slice(None)) + first] = zeros[2:]
    got, want = st_pair.couple_ports(mix, x), couple_ports_reference(mix, x)
    assert got.shape == want.shape == x.shape
    np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
    assert not np.allclose(got, x)  # the coupling mixes the ports


def test_ask_stamp_transitions_kernel_equals_the_comparator_row_by_row():
    """The stamp decision's transition count (numba) against the comparator run row by row,
    on band-passed square waves of swings around the 5.15 mV hysteresis (some rows toggle at
    every edge, some never) with noise."""
    from rfsim.devices import st_receiver as sr

    fs, blf = 1e6, 48e3
    frame = sr.stamp_frame(np.zeros(16, np.uint8), m=2, trext=True, blf_hz=blf, fs_hz=fs, n_stamp_cycles=8,
                           t0_s=30e-6, n_settle_cycles=8)
    rng = np.random.default_rng(5)
    n = frame.states.size
    square = np.where(np.floor(np.arange(n) * 2 * blf / fs) % 2 == 0, 0.5, -0.5)
    swing = rng.uniform(0.003, 0.008, 40)
    bp = swing[:, None] * square[None, :] + 2e-4 * rng.standard_normal((40, n))
    thr = 1.03 * 0.005
    got = st_pair.ask_stamp_transitions(bp, frame, thr)
    want = ask_stamp_transitions_reference(bp, frame, thr)
    np.testing.assert_array_equal(got, want)
    assert got.min() == 0 and got.max() >= st_pair.STAMP_CYCLES - 1  # both decisions occur

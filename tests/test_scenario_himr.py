"""Scenarios ``himr-2d`` and ``himr-1d`` at sample level against the source's printed numbers
(wave2-specs.md §H table; himr-tag.md §3–§6; seed 000): framing, the aliasing limit, the
frozen-time unstable window, the prerotated observer's errors, what the literal observer
gives instead of the 10 cm transient, the outage-case and convergence orderings, the 1-D
observer against the double integration; and bad inputs (one line, exit 2).

Expected values are the source's (line numbers beside them) or derived in the docstring from
the source's equations, never read back from the code under test."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.scenarios import himr_1d, himr_2d

C = 299792458.0


@pytest.fixture(scope="module")
def two_d():
    """The default himr-2d run (seed 1): its packets once, observers from IC #1 (dataset); the
    prerotated Cases 1, 6, 7 again from IC #2 and #3 of Table 9 and, from IC #1, at the source's
    2 cm threshold (convergence ordering)."""
    cfg = himr_2d.Config()
    air, plan, imu = himr_2d.sample_level(cfg, seed=1)
    ds = himr_2d.dataset(cfg, air, plan, imu)
    conv = {}
    for ic, threshold_m in ((2, cfg.observer.converged_m), (3, cfg.observer.converged_m), (1, 0.02), (2, 0.02)):
        cfg2 = replace(cfg, observer=replace(cfg.observer, initial_condition=ic, variants=("prerotated",),
                                             cases=(1, 6, 7), converged_m=threshold_m))
        _, summary2 = himr_2d.run_observers(cfg2, air, plan, imu, cfg.scene.carriers_hz)
        conv[ic, threshold_m] = {r["case"]: r["convergence_s"] for r in summary2}
    return ds, conv


def _summary(ds) -> dict:
    s = {k: c.data for k, c in ds.tables["summary"].items()}
    return {(str(v), int(c), str(d)): i for i, (v, c, d) in enumerate(zip(s["variant"], s["case"], s["dealias"]))}, s


def test_2d_framing_and_aliasing_limit(two_d):
    """Table 5 (L715-L720): 3+2+6+6+6+1 bytes = 192 bit at 8 chips/bit, 4 Mcps: 0.384 ms
    (the spec's 240 bit / 0.48 ms does not follow from those bytes; recorded in the dataset).
    The aliasing limit λ·rate/4 at 141 packets/s (H§1.3): 1.822 m/s at 5.80 GHz (1e-3), and
    the boom (2.78 m/s radial) exceeds it: some packets are flagged aliased."""
    ds, _ = two_d
    a = ds.attrs
    assert a["packet_bits"] == 8 * (3 + 2 + 6 + 6 + 6 + 1) == 192
    assert a["air_time_s"] == pytest.approx(192 * 8 / 4e6, rel=1e-12)
    assert "192 bit" in a["packet_bits_note"] and "240" in a["packet_bits_note"]
    pk = {k: c.data for k, c in ds.tables["packets"].items()}
    lim = pk["aliasing_limit_mps"][(pk["pylon"] == 2) & np.isfinite(pk["aliasing_limit_mps"])]
    assert np.median(lim) == pytest.approx(1.822, abs=1e-3)
    assert 0.05 < a["aliased_fraction"] < 0.5
    assert a["crc_ok_fraction"] == 1.0
    assert a["n_packets"] == math.ceil(1.6 * 141)


def test_2d_unstable_window_of_the_literal_gain(two_d):
    """Frozen-time eig(A − L·C(x(t))) of the literal model with the D.2 gain is unstable while
    the heading is more than 90° from π (H§6.2 [derived]: 0.418–0.782 s of the programmed
    stroke); the actual trajectory runs 0.15 s behind (L1014): 0.568–0.932 s ± one packet
    interval; the prerotated rows stay stable."""
    ds, _ = two_d
    a = ds.attrs
    assert abs(a["literal_unstable_from_s"] - 0.568) <= 1 / 141 + 1e-9
    assert abs(a["literal_unstable_to_s"] - 0.932) <= 1 / 141 + 1e-9
    dg = ds.tables["diagnostics"]
    assert dg["max_real_eig_prerotated"].data.max() < 0
    assert np.all(dg["observability_rank"].data == 9)


def test_2d_gain_grid_is_the_printed_101(two_d):
    """gains L[state, output] at Table 8 with D.2: L' of (101) (L1997-L2007), r1 → x 23.38,
    ṙ1 → ẋ 11.4, a1 → ẍ −12.2, θz → ψ 13.85 (5 % or 0.02)."""
    ds, _ = two_d
    L = ds.grids["gains"][1]["L"].data
    for (state, out), printed in {(0, 0): 23.38, (1, 1): 11.4, (2, 6): -12.2, (6, 8): 13.85}.items():
        assert abs(L[state, out] - printed) <= max(0.05 * abs(printed), 0.02)


def test_2d_prerotated_case_1(two_d):
    """H§6.3: prerotated, noise-free surrogate: max ≤ 2.5 cm, final < 2 mm. At sample level
    (SNR 31.6 dB at 1 m, datasheet IMU noise) the errors are within the same bounds."""
    ds, _ = two_d
    assert ds.attrs["max_error_m_prerotated"] <= 0.025
    assert ds.attrs["final_error_m_prerotated"] < 0.002


def test_2d_literal_observer_cannot_give_the_10_cm_transient(two_d):
    """The source's Case 1 shows a ≈ 10 cm initial x error (L1176-L1224). The literal observer
    (D.2 gain, trigonometric acceleration rows) with aliasing resolved by ground truth gives
    ≈ 1.5–1.6 m in x and ≈ 1.1 m in y (H§6.3 [derived]; bounds 1.2–1.8 m, 0.8–1.3 m) and
    then converges (final < 2 cm); with the phase-derived velocities as measured (aliased
    above 1.822 m/s) its transient leaves the region where a wrapped velocity can be
    resolved and it diverges (> 10 m)."""
    ds, _ = two_d
    idx, s = _summary(ds)
    i = idx[("literal", 1, "oracle")]
    assert 1.2 <= s["max_error_x_m"][i] <= 1.8 and 0.8 <= s["max_error_y_m"][i] <= 1.3
    assert s["final_error_m"][i] < 0.02
    assert ds.attrs["max_error_m_literal"] > 10.0
    assert "10 cm" in ds.attrs["literal_observer_note"]


def test_2d_outage_case_ordering(two_d):
    """L1243-L1350, max y error: Case 4 (5 cm) < Case 3 (30 cm) < Case 2 (50 cm), Case 5
    "similar to Case 2" (±30 %); every case ends within 2 cm (L1255, L1275, L1328)."""
    ds, _ = two_d
    idx, s = _summary(ds)
    ey = {c: s["max_error_y_m"][idx[("prerotated", c, "gated")]] for c in (2, 3, 4, 5)}
    assert ey[4] < ey[3] < ey[2]
    assert abs(ey[5] / ey[2] - 1) < 0.3
    for c in range(1, 8):
        assert s["final_error_m"][idx[("prerotated", c, "gated")]] < 0.02, c


def test_2d_convergence_ordering(two_d):
    """L1354-L1404: Case 6 (70.5 packets/s, ≈ 1.2 s) and Case 7 (two pylons, ≈ 1.1 s) converge
    later than Case 1 (≈ 0.8 s), each case shown from the three initial conditions of Table 9
    (L1196-L1214). The scenario's own summary (IC #1, default ``converged_m`` 5 mm) and the same
    cases from IC #2 ((1, 1) m, ψ = π/2) and IC #3 ((2.5, 2.3) m, 3π/2) through the config key
    ``observer.initial_condition``: seed 1 gives 1.305 s (C1), 1.362 s (C6), 1.340 s (C7) from
    each. At one seed the order is strict but its margin is a draw (seeds 1-12: C6 − C1 from
    0.021 to 0.220 s, C7 − C1 from 0.014 to 0.206 s): the size of the gap is the slow test's
    statement over seeds (:func:`test_2d_convergence_ordering_over_seeds`).
    The cause of the 0 s the scenario gave before: at 2 cm (the source's threshold, 1/5 of its
    10 cm Case 1 error) the observer's in-motion error (≤ 1.8 cm) never counts, so Case 7 ties
    Case 1 (0 s from IC #1; the end of the initial transient, 0.15 s, from IC #2)."""
    ds, conv = two_d
    assert himr_2d.Config().observer.converged_m == 0.005
    idx, s = _summary(ds)
    own = {c: s["convergence_s"][idx[("prerotated", c, "gated")]] for c in (1, 6, 7)}
    for c in (own, conv[2, 0.005], conv[3, 0.005]):
        assert c[6] > c[1] and c[7] > c[1], c
    # the source's order needs more than the initial transient: at 2 cm Case 7 ties Case 1
    for ic in (1, 2):
        c = conv[ic, 0.02]
        assert abs(c[7] - c[1]) < 0.05 and c[1] < 0.2, (ic, c)


@pytest.mark.slow
def test_2d_convergence_ordering_over_seeds():
    """L1354-L1404 as a statement over draws: over seeds 1-8 (IC #1, 5 mm), Case 6 and Case 7
    never converge before Case 1, and their mean delay after it exceeds zero by more than three
    standard errors of the mean over the seeds (measured: C6 − C1 0.122 ± 0.030 s, C7 − C1
    0.090 ± 0.021 s; the source's gaps, ≈ 0.4 and 0.3 s, are larger: its Case 1 converges in
    0.8 s, ours in 1.16-1.37 s)."""
    cfg = himr_2d.Config()
    one = replace(cfg, observer=replace(cfg.observer, variants=("prerotated",), cases=(1, 6, 7)))
    d6, d7 = [], []
    for seed in range(1, 9):
        air, plan, imu = himr_2d.sample_level(cfg, seed=seed)
        _, summary = himr_2d.run_observers(one, air, plan, imu, cfg.scene.carriers_hz)
        c = {r["case"]: r["convergence_s"] for r in summary}
        d6.append(c[6] - c[1])
        d7.append(c[7] - c[1])
    for d in (np.array(d6), np.array(d7)):
        assert (d >= 0).all(), d
        assert d.mean() > 3 * d.std(ddof=1) / math.sqrt(d.size), d


def test_1d_observer_vs_double_integration():
    """1-D (L610-L652): 96-bit packets at 64 chips/bit, 5 Mcps (1.2288 ms, L411), travel
    0.622 m (erratum 9); the HIMR error stays below the experiment's 9 mm peak (L652) and far
    below the drift of the double-integrated accelerometer (2.5 cm in the source, L628): its
    final drift exceeds twice the HIMR peak."""
    ds = himr_1d.run(himr_1d.Config(), seed=1)
    a = ds.attrs
    assert a["packet_bits"] == 96 and a["air_time_s"] == pytest.approx(96 * 64 / 5e6, rel=1e-12)
    assert a["travel_m"] == pytest.approx(1.2 * (1.2 / 7.35 + 0.355), rel=1e-12)
    assert a["max_error_m_himr"] < 0.009
    assert a["final_error_m_double_integration"] > 2 * a["max_error_m_himr"]
    assert a["aliasing_limit_mps"] == pytest.approx(C / 5.8e9 * 300 / 4, rel=1e-9)
    g = ds.grids["gains"][1]
    np.testing.assert_allclose(g["eig_real"].data, [-387.3, -223.6, -223.6], rtol=1e-3)  # (19), L581


@pytest.mark.slow
def test_2d_joint_carriers_bias_the_rss_range():
    """wave2-specs §H: in a joint run at fs ≳ 50 MS/s the 9th/11th harmonics of the tag's
    square subcarrier put the other carriers on a pylon's subcarrier — a coherent bias absent
    when each pylon runs alone at the same rate and filter. Seed 1: RSS-range error RMS
    1.9 mm alone, 17 mm joint; asserted: joint > 3 × alone, and every packet still decodes."""
    rms = {}
    for mode in ("ignore", "joint"):
        cfg = himr_2d.Config()
        cfg = replace(cfg, radio=replace(cfg.radio, cross_carrier=mode, fs_hz=50e6, rx_cutoff_hz=3e6))
        air, _, _ = himr_2d.sample_level(cfg, seed=1)
        err = np.concatenate([m.range_m - r for m, r in zip(air.measurements, air.true_range_m)])
        rms[mode] = float(np.sqrt(np.mean(err ** 2)))
        assert all(m.crc_ok.all() for m in air.measurements)
    assert rms["joint"] > 3 * rms["ignore"]


BAD = [
    ("himr-2d", "tag.packet_format=9axis-3d", "tag.packet_format"),
    ("himr-2d", "tag.subcarrier_hz=1.5e6", "tag.chip_rate_hz"),
    ("himr-2d", "trajectory.radius_m=3.0", "trajectory"),
    ("himr-2d", "radio.fs_hz=4e6", "radio.fs_hz"),
    ("himr-2d", "scene.pylons_m=[[2.0, 1.8048], [2.0, 3.05], [2.7, -0.03]]", "scene.pylons_m[0]"),
    ("himr-2d", "observer.cases=[2, 8]", "observer.cases"),
    ("himr-1d", "tag.packet_format=9axis-2d", "tag.packet_format"),
    ("himr-1d", "scene.pylon_m=[1.3, 0.0, 0.0]", "scene.pylon_m[0]"),
    ("himr-1d", "trajectory.speed_mps=6.0", "trajectory"),
    ("himr-1d", "radio.fs_hz=5e6", "radio.fs_hz"),
]


@pytest.mark.parametrize("scenario,setting,key", BAD)
def test_bad_input_one_line_exit_2(scenario, setting, key, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", scenario, "--set", setting]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim: error: ") and f"'{key}'" in err
    assert not list(tmp_path.glob("**/*.h5"))

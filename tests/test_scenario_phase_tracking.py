"""``rfsim run phase-tracking`` (Särkkä et al. 2012 at sample level; issue 14 items 4, 6–8).

Default tier: short runs (≤ 0.5 s of trajectory) for the read schedule, the per-read format, the
pseudo-ranges against the true ranges, the unwrapping limit λ/(4Δt) = 8.42 m/s on both sides, and
the one-line errors. Slow tier: the published accuracy targets on the 60 s default run and
without ground-truth jitter.
"""

from __future__ import annotations

import contextlib
import io

import h5py
import numpy as np
import pytest
from scipy.linalg import expm

from rfsim.cli import main
from rfsim.core.dataset import read_table

LAMBDA_890 = 299792458.0 / 890e6


def _run(tmp_path, name, *sets, plot=False):
    path = tmp_path / f"{name}.h5"
    argv = ["run", "phase-tracking", "-o", str(path), "--out-dir", str(tmp_path), "--set", "schedule.workers=1"]
    if not plot:
        argv.append("--no-plot")
    for s in sets:
        argv += ["--set", s]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(argv)
    return rc, path, err.getvalue()


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    rc, path, err = _run(tmp_path_factory.mktemp("phase"), "short", "trajectory.duration_s=0.5", plot=True)
    assert rc == 0, err
    return path


def test_reads_follow_the_fixed_schedule_in_the_long_format(short):
    reads = read_table(short, "reads")
    n = reads["t_s"].size
    assert n == 200  # 0.5 s at 2.5 ms per read
    ant = reads["antenna_port"]
    np.testing.assert_array_equal(ant, np.arange(n) % 4 + 1)  # round robin
    assert all(np.sum(ant == a) == 50 for a in (1, 2, 3, 4))  # 100 reads/s per antenna
    assert np.all(np.diff(reads["first_seen_timestamp_us"]) > 0)
    assert reads["reported"].all()
    assert set(reads["epc"].astype(str)) == {"300833B2DDD9014000000027"}
    np.testing.assert_array_equal(reads["frequency_hz"], 890e6)
    # the reported phase carries the port's offset and the 12-bit code
    offsets = np.array([0.61, 2.23, -1.37, 3.9])
    code = np.mod(np.round(np.mod(reads["phase_angle_rad"] + offsets[ant - 1], 2 * np.pi) * 4096 / (2 * np.pi)), 4096)
    np.testing.assert_array_equal(reads["phase_code"], code)
    with h5py.File(short, "r") as f:
        assert f.attrs["reads_per_s_per_antenna"] == pytest.approx(100.0)
        assert f.attrs["singulation_max_s"] < 2.5e-3
        assert "fixed" in str(f.attrs["schedule"])
        # F, Q(Δt) as attributes, against the matrix exponential (Van Loan) of the CWNA + bias model
        F, L, Qc = f.attrs["F"], f.attrs["L"], f.attrs["Qc"]
        dt, n_x = float(f.attrs["dt_s"]), F.shape[0]
        assert n_x == 8 and np.array_equal(F[:2, 6:], np.eye(2)) and np.count_nonzero(F) == 2
        M = np.zeros((2 * n_x, 2 * n_x))
        M[:n_x, :n_x], M[:n_x, n_x:], M[n_x:, n_x:] = -F, L @ Qc @ L.T, F.T
        E = expm(M * dt)
        np.testing.assert_allclose(f.attrs["Q_dt"], E[n_x:, n_x:].T @ E[:n_x, n_x:], rtol=1e-9, atol=1e-20)
        np.testing.assert_allclose(f.attrs["antennas_xyz_m"][:, 2], 1.5)


def test_pseudoranges_are_true_range_plus_a_constant(short):
    """Eq. (6): r̂ − r = b_i, constant per antenna up to the phase noise and the 12-bit code
    (λ/4π·2π/4096/√12 = 0.012 mm) and the held position within a round (≤ 0.14 mm)."""
    pr = read_table(short, "pseudoranges")
    assert not pr["jump"].any()
    for a in (1, 2, 3, 4):
        off = pr["offset_m"][pr["antenna"] == a]
        assert np.ptp(off) < 1e-3, (a, np.ptp(off))


@pytest.mark.parametrize("speed, jumps", [(8.0, False), (9.0, True)])
def test_unwrapping_limit_is_lambda_over_4_dt(tmp_path, speed, jumps):
    """A diagonal path straight at antennas 1 and 3 (radial speed = path speed): below
    λ/(4·10 ms) = 8.42 m/s no λ/2 jump, above it jumps, a warning and the flag."""
    rc, path, err = _run(tmp_path, f"v{speed}", "trajectory.corners_xy_m=[[0.6, 0.6], [2.4, 2.4]]",
                         f"trajectory.speed_mps={speed}", "trajectory.jitter_rms_m=0", "trajectory.duration_s=0.4")
    assert rc == 0, err
    pr = read_table(path, "pseudoranges")
    with h5py.File(path, "r") as f:
        assert f.attrs["unwrap_limit_mps"] == pytest.approx(LAMBDA_890 / 0.04, rel=1e-9)
        assert bool(f.attrs["unwrap_limit_exceeded"]) == jumps
        assert (int(f.attrs["unwrap_jumps"]) > 0) == jumps
    assert bool(pr["jump"].any()) == jumps
    assert ("warning: the tag's radial speed" in err) == jumps


@pytest.mark.parametrize("override, fragment", [
    ("geometry.antennas_xy_m=[]", "geometry.antennas_xy_m"),
    ("geometry.antennas_xy_m=[[0, 0], [3, 0], [3, 3], [0, 4]]", "geometry.antennas_xy_m[3]"),
    ("trajectory.corners_xy_m=[[1, 1], [5, 1]]", "trajectory.corners_xy_m[1]"),
    ("trajectory.corners_xy_m=[[1, 1], [1, 1]]", "no two consecutive ones equal"),
    ("reader.hopping=true", "reader.hopping"),
    ("schedule.read_period_s=0.0005", "schedule.read_period_s"),
    ("estimator.q_b=-1", "estimator.q_b"),
])
def test_bad_inputs_exit_2_with_one_line(tmp_path, override, fragment):
    sets = [override]
    if override.startswith("reader.hopping"):
        sets.append("reader.channels_hz=[865.7e6, 866.3e6]")
    rc, _, err = _run(tmp_path, "bad", "trajectory.duration_s=0.1", *sets)
    assert rc == 2
    errors = [line for line in err.splitlines() if line.startswith("rfsim: error:")]
    assert len(errors) == 1 and fragment in errors[0], err
    assert "Traceback" not in err


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    """The 60 s default run (seed 1)."""
    rc, path, err = _run(tmp_path_factory.mktemp("full"), "full", "schedule.workers=0")
    assert rc == 0, err
    return path


@pytest.mark.slow
def test_published_accuracy_on_the_default_run(full_run):
    """60 s, 1.5 cm RMS jitter, RSSI fix start (L203–L207). The RTS error against the intended
    path (1.48 cm) is the injected jitter (trajectory.jitter_rms_m = 1.5 cm) and cannot test
    the estimator; what can is its error against the true (jittered) path: below 2 mm (measured
    0.16 mm; 12-bit phase code λ/4π·2π/4096/√12 = 0.012 mm per read). EKF pass 2 within ±30 %
    of 1.6–2.2 cm, RTS ≤ EKF on the first pass, RSSI-only ≥ 10× the RTS error."""
    with h5py.File(full_run, "r") as f:
        a = {k: float(f.attrs[k]) for k in ("rts_rmse_m", "ekf2_rmse_m", "rts1_rmse_m", "ekf1_rmse_m", "rssi_rmse_m")}
        assert int(f.attrs["unwrap_jumps"]) == 0
    summary = read_table(full_run, "summary")
    last = (summary["estimator"].astype(str) == "RTS") & (summary["pass"] == summary["pass"].max())
    assert float(summary["rmse_true_m"][last][0]) < 0.002, summary["rmse_true_m"][last]
    assert 0.7 * 0.016 <= a["ekf2_rmse_m"] <= 1.3 * 0.022, a
    assert a["rts1_rmse_m"] <= a["ekf1_rmse_m"]
    assert a["rssi_rmse_m"] >= 10 * a["rts_rmse_m"], a


def _first_pass(path, start_xy_m):
    """EKF and RTS RMSE [m] against the intended path of the first pass over the dataset's
    reported reads, started (prior mean and unwrapping origin) at ``start_xy_m``."""
    from rfsim.estimators import phase_tracking as pt

    reads = read_table(path, "reads")
    with h5py.File(path, "r") as f:
        anchors, lam = f.attrs["antennas_xyz_m"][:, :2], float(f.attrs["wavelength_m"])
    ant = reads["antenna_port"].astype(np.int64) - 1
    p0 = np.asarray(start_xy_m, float)
    z = pt.unwrap_pseudoranges(ant, reads["phase_reported_rad"], wavelength_m=lam, r0_m=np.linalg.norm(p0 - anchors, axis=1))
    x0, P0 = pt.initial_state(p0, anchors.shape[0])
    ps = pt.track_phase(reads["t_s"], ant, z, anchors, x0, P0, passes=1, keep_covariances=False)[0]
    intended = np.column_stack([reads["intended_x_m"], reads["intended_y_m"]])
    return tuple(float(np.sqrt(np.mean(np.sum((x[:, :2] - intended) ** 2, axis=1)))) for x in (ps.x_filt, ps.x_smooth))


@pytest.mark.slow
def test_first_pass_gap_is_the_start_transient(full_run):
    """First pass (L203): published EKF 3.2 cm, RTS 1.5 cm; from the eq. (13) RSSI fix (0.41 m
    off, seed 1) this run gives 6.66 / 3.25 cm. One trajectory is one trial, and its first-pass
    RMSE is the bias-convergence transient from the start fix averaged over the run: the same
    reads started at the true start position give 1.48 / 1.48 cm (the jitter alone), 0.2 m off
    2.1–2.5 / 1.48–1.65 cm over 8 directions, the source's stated ≈ 0.6 m off 8.0–12.1 / 1.5–6.1 cm
    (module docstring). So the gap is the transient: it closes when the start error does, and
    the source's 60 cm start gives no match here."""
    with h5py.File(full_run, "r") as f:
        ekf1, rts1 = float(f.attrs["ekf1_rmse_m"]), float(f.attrs["rts1_rmse_m"])
        fix_error = float(f.attrs["initial_fix_error_m"])
    reads = read_table(full_run, "reads")
    start = np.array([reads["intended_x_m"][0], reads["intended_y_m"][0]])
    assert 0.3 < fix_error < 0.5
    assert ekf1 > 1.5 * 0.032 and rts1 > 1.5 * 0.015  # the documented gap (not reproduced)
    e0, r0 = _first_pass(full_run, start)  # transient off
    assert e0 < 0.017 and r0 < 0.017
    ring = np.array([_first_pass(full_run, start + 0.2 * np.array([np.cos(a), np.sin(a)]))
                     for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)])
    assert np.all(ring[:, 0] < 0.032) and np.all(ring[:, 1] < 0.02)  # 0.2 m off: at or below the published
    far = np.array([_first_pass(full_run, start + 0.6 * np.array([np.cos(a), np.sin(a)]))
                    for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)])
    assert np.all(far[:, 0] > 2 * 0.032)  # the source's 60 cm start: no match


@pytest.mark.slow
def test_without_jitter_the_smoother_is_below_one_centimetre(tmp_path):
    rc, path, err = _run(tmp_path, "ideal", "trajectory.jitter_rms_m=0", "trajectory.duration_s=20",
                         "schedule.workers=0", "schedule.chunk_s=10")
    assert rc == 0, err
    with h5py.File(path, "r") as f:
        assert float(f.attrs["rts_rmse_m"]) < 0.01
        assert 0.15 < float(f.attrs["max_radial_speed_mps"]) <= 0.2 + 1e-6


def test_config_keys_show_the_scenarios_own_reader_defaults(capsys):
    """``rfsim config phase-tracking --keys`` lists the defaults this scenario gives its reader
    (fm0-640k at 890 MHz, per-port offsets), not the ReaderConfig class defaults."""
    assert main(["config", "phase-tracking", "--keys"]) == 0
    out = capsys.readouterr().out
    assert 'reader.link_profile = "fm0-640k"' in out
    assert "reader.channels_hz = [890000000.0]" in out
    assert "reader.report.port_phase_offsets_rad = [0.61, 2.23, -1.37, 3.9]" in out


def test_round_links_are_the_channel_links_of_each_round():
    """The chunk's links drawn at once (rfsim.channels.bulk) equal Channel.link of every round's
    antenna and tag position (free space, one LoS path), and refuse any other pair."""
    import dataclasses
    import math

    from rfsim.channels import Antenna, Channel, HalfWaveDipole, Scene
    from rfsim.scenes.phase_tracking import GeometryConfig, RoundLinks, reader_antennas

    g = GeometryConfig()
    antennas = reader_antennas(g)
    tag = Antenna(position_m=(0.0, 0.0, g.height_m), orientation=(0.0, math.radians(g.tag_tilt_deg), 0.0),
                  pattern=HalfWaveDipole(), polarization="linear")
    xyz = np.column_stack([np.random.default_rng(3).uniform(0.5, 2.5, (9, 2)), np.full(9, g.height_m)])
    which = np.arange(9) % 4
    links = RoundLinks(Scene(image_order=0), antennas, tag, which, xyz, fc_hz=890e6)
    ref = Channel(Scene(image_order=0))
    for j in range(9):
        t_j = dataclasses.replace(tag, position_m=tuple(xyz[j]))
        links.hold(j, t_j)
        fwd, bwd = links.backscatter_links(antennas[which[j]], t_j, fc_hz=890e6)
        want, _ = ref.backscatter_links(antennas[which[j]], t_j, fc_hz=890e6)
        assert bwd is fwd and fwd.n_paths == want.n_paths == 1
        np.testing.assert_allclose(fwd.gain, want.gain, rtol=1e-12, atol=0)
        np.testing.assert_allclose(fwd.delay_s, want.delay_s, rtol=1e-12, atol=0)
        assert not fwd.doppler_hz.any()
        with pytest.raises(ValueError, match="one static link per round"):
            links.backscatter_links(antennas[(which[j] + 1) % 4], t_j, fc_hz=890e6)

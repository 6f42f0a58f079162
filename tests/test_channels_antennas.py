"""Geometry, antenna patterns and polarization: golden PASS data and analytic checks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import loadmat

from rfsim.channels.antennas import (
    Antenna,
    EllipticalPanel,
    HalfWaveDipole,
    Isotropic,
    Patch,
    Tabulated,
    polarization_mismatch_factor,
)
from rfsim.channels.geometry import (
    Pose,
    direction_to,
    local_angles,
    pass_rotate_angles_deg,
    pass_spherical_deg,
    rotation_matrix,
    unit_vector,
)
from rfsim.core.errors import ConfigError


def _load(path):
    return loadmat(path, squeeze_me=True, struct_as_record=False)


def _sphere_integral(gain_fn, n_el=400, n_az=720):
    """∮ G dΩ by Gauss–Legendre in sin(el) (exact measure dΩ = d(sin el)·daz) × midpoint az."""
    x, w = np.polynomial.legendre.leggauss(n_el)          # x = sin(el) in (−1, 1)
    el = np.arcsin(x)
    az = (np.arange(n_az) + 0.5) * 2 * np.pi / n_az
    g = gain_fn(az[:, None], el[None, :])
    return float(np.sum(g * w[None, :]) * 2 * np.pi / n_az)


# --------------------------------------------------------------------------- geometry

def test_rotation_matrix_is_rz_ry_rx_product():
    def rz(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    def ry(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])

    def rx(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])

    rng = np.random.default_rng(1)
    angles = rng.uniform(-np.pi, np.pi, (50, 3))
    R = rotation_matrix(angles[:, 0], angles[:, 1], angles[:, 2])
    assert R.shape == (50, 3, 3)
    for (a, e, r), Ri in zip(angles, R):
        np.testing.assert_allclose(Ri, rz(a) @ ry(-e) @ rx(r), atol=1e-14)
        np.testing.assert_allclose(Ri @ Ri.T, np.eye(3), atol=1e-14)
        assert np.linalg.det(Ri) == pytest.approx(1.0)
        # boresight (local +x) points along (az, el)
        np.testing.assert_allclose(Ri[:, 0], unit_vector(a, e), atol=1e-14)


def test_direction_to_known_values_and_broadcasting():
    d, az, el = direction_to([1.0, 1.0, 0.0], [[2.0, 1.0, 0.0], [1.0, 3.0, 0.0], [1.0, 1.0, -4.0],
                                               [0.0, 0.0, np.sqrt(2.0)]])
    np.testing.assert_allclose(d, [1.0, 2.0, 4.0, 2.0])
    np.testing.assert_allclose(az, [0.0, np.pi / 2, 0.0, -3 * np.pi / 4], atol=1e-15)
    np.testing.assert_allclose(el, [0.0, 0.0, -np.pi / 2, np.pi / 4], atol=1e-15)
    d2, _, _ = direction_to(np.zeros((4, 1, 3)), np.ones((1, 5, 3)))
    assert d2.shape == (4, 5)


def test_local_angles_of_own_boresight_and_roll():
    pose = Pose((1.0, 2.0, 3.0), az_rad=0.7, el_rad=-0.3, roll_rad=1.1)
    target = pose.position_m + 5.0 * unit_vector(0.7, -0.3)
    dist, az, el = pose.local_angles_to(target)
    assert dist == pytest.approx(5.0)
    assert abs(az) < 1e-12 and abs(el) < 1e-12
    # a global "up" seen by an unrotated-but-rolled device (roll 90°: local z → global −y)
    az2, el2 = local_angles([0.0, -1.0, 0.0], rotation_matrix(0.0, 0.0, np.pi / 2))
    assert el2 == pytest.approx(np.pi / 2)
    assert pose == Pose((1.0, 2.0, 3.0), 0.7, -0.3, 1.1) and len({pose, pose}) == 1


def test_newpos_direct_partition_golden(reference_data):
    """PASS channel_newpos Direct partition: distance and (az, el from +z) per receiver."""
    m = _load(reference_data / "pass-selftest" / "results_channel_newpos.mat")
    part = m["partitioning"]
    assert str(part.names[0]) == "Direct"
    n_direct = int(part.indices[0])
    n_cases = n_rows = n_nan = 0
    for s, r in zip(m["settings"][:n_direct], m["results"][:n_direct]):
        def pts(p, n):
            a = np.array([np.atleast_1d(np.asarray(x, float)) for x in np.atleast_1d(p)])
            a = a.reshape(n, -1)
            return np.concatenate([a, np.zeros((n, 3 - a.shape[1]))], axis=1)
        pos_t = pts(s.pos_t, int(s.ntx))
        pos_r = pts(s.pos_r, int(s.nrx))
        it = int(r.ind_t0) - 1
        dist, _, _ = direction_to(pos_t[it], pos_r)
        az_deg, el_deg, r_m = pass_spherical_deg(pos_r - pos_t[it])
        np.testing.assert_allclose(r_m, dist, rtol=1e-15)
        ref = np.asarray(r.dir_t0r, float).reshape(int(s.nrx), 3)
        blocked = np.asarray(s.no_ls).reshape(int(s.ntx), int(s.nrx))[it].astype(bool)
        assert ref.shape == (int(s.nrx), 3)
        assert np.all(np.isnan(ref[blocked])) and not np.any(np.isnan(ref[~blocked]))
        ok = ~blocked
        np.testing.assert_allclose(dist[ok], ref[ok, 2], rtol=1e-9)
        daz = (az_deg[ok] - ref[ok, 0] + 180.0) % 360.0 - 180.0
        assert np.all(np.abs(daz) < 1e-6)
        np.testing.assert_allclose(el_deg[ok], ref[ok, 1], atol=1e-6)
        n_cases += 1
        n_rows += int(ok.sum())
        n_nan += int(blocked.sum())
    assert n_cases == 200
    assert n_rows > 2000 and n_nan > 0


# --------------------------------------------------------------------------- golden directivity

def test_directivity_golden_pass(reference_data):
    """results_channel_directivity.mat: 2000 cases, ±1 % (or ±0.001 below 0.01).

    PASS conventions converted explicitly: angles in degrees with el from +z, rotation by
    subtraction (pass_rotate_angles_deg), amplitude tables (Tabulated.from_pass_mat squares
    them), link amplitude = √(G_tx·G_rx). An empty antenna name is isotropic.
    """
    m = _load(reference_data / "pass-selftest" / "results_channel_directivity.mat")
    chars = reference_data / "pass-characteristics"
    patterns = {"": Isotropic()}
    for name in ("channelchar_directivity_l2-dipole", "channelchar_directivity_l4-dipole"):
        patterns[name] = Tabulated.from_pass_mat(chars / f"{name}.mat")

    def name_of(x):
        return x if isinstance(x, str) else ""

    n_cases = n_dirs = 0
    worst = 0.0
    for s, r in zip(m["settings"], m["results"]):
        dir_tx = np.atleast_2d(s.dir_tx)
        dir_rx = np.atleast_2d(s.dir_rx) if "dir_rx" in s._fieldnames else dir_tx
        ang_tx = pass_rotate_angles_deg(dir_tx, s.txrot)
        ang_rx = pass_rotate_angles_deg(dir_rx, s.rxrot, receiver=True)
        for got, ref in ((ang_tx, r.angle_tx), (ang_rx, r.angle_rx)):
            ref = np.atleast_2d(ref)
            daz = (got[:, 0] - ref[:, 0] + 180.0) % 360.0 - 180.0
            assert np.all(np.abs(daz) < 1e-9)
            np.testing.assert_allclose(got[:, 1], ref[:, 1], atol=1e-9)
        g_tx = patterns[name_of(s.txant)].gain(np.radians(ang_tx[:, 0]),
                                                np.radians(90.0 - ang_tx[:, 1]))
        g_rx = patterns[name_of(s.rxant)].gain(np.radians(ang_rx[:, 0]),
                                                np.radians(90.0 - ang_rx[:, 1]))
        amp = np.sqrt(g_tx * g_rx)
        ref_g = np.atleast_1d(r.gain)
        err = np.where(ref_g > 0.01, np.abs(amp / ref_g - 1.0) / 0.01, np.abs(amp - ref_g) / 0.001)
        worst = max(worst, float(err.max()))
        n_cases += 1
        n_dirs += ref_g.size
    assert n_cases == 2000
    assert n_dirs > 2000
    assert worst <= 1.0, f"worst case uses {worst:.2f} of the tolerance"


def test_pass_l4_table_is_the_half_wave_dipole(reference_data):
    """The PASS "l4-dipole" table squared × D₀ equals the analytic half-wave dipole."""
    tab = Tabulated.from_pass_mat(reference_data / "pass-characteristics"
                                  / "channelchar_directivity_l4-dipole.mat")
    l2 = Tabulated.from_pass_mat(reference_data / "pass-characteristics"
                                 / "channelchar_directivity_l2-dipole.mat")
    el = np.radians(np.linspace(-80, 80, 161))
    az = np.radians(np.linspace(0, 350, 161))
    ref = HalfWaveDipole().gain(az, el) / 1.6409223769845853
    np.testing.assert_allclose(tab.gain(az, el), ref, rtol=2e-3, atol=1e-6)
    # full-wave pattern with amplitude peak 2 → power peak 4 (+6.02 dB), as PASS applies it
    assert l2.gain(0.3, 0.0) == pytest.approx(4.0, rel=1e-9)


# --------------------------------------------------------------------------- analytic patterns

def test_half_wave_dipole_peak_and_sphere_integral():
    d = HalfWaveDipole()
    assert 10 * np.log10(d.gain(0.0, 0.0)) == pytest.approx(2.15, abs=0.005)
    assert d.gain(0.0, np.pi / 2) == 0.0 and d.gain(1.0, -np.pi / 2) == 0.0
    assert _sphere_integral(d.gain) == pytest.approx(4 * np.pi, rel=1e-6)
    assert _sphere_integral(HalfWaveDipole(efficiency=0.5).gain) == pytest.approx(2 * np.pi,
                                                                                   rel=1e-6)


def test_isotropic_integral():
    assert _sphere_integral(Isotropic().gain) == pytest.approx(4 * np.pi, rel=1e-12)


@pytest.mark.parametrize("gain_dbi, bw_deg, fb_db", [(8.0, 65.0, 20.0), (6.0, 90.0, 15.0),
                                                     (12.0, 35.0, 25.0), (3.0, 120.0, 10.0)])
def test_patch_peak_beamwidth_and_integral(gain_dbi, bw_deg, fb_db):
    p = Patch(gain_dbi, bw_deg, fb_db)
    g0 = 10 ** (gain_dbi / 10)
    assert p.gain(0.0, 0.0) == pytest.approx(g0, rel=1e-12)
    half = np.radians(bw_deg) / 2
    assert p.gain(half, 0.0) == pytest.approx(g0 / 2, rel=1e-9)        # −3 dB in azimuth
    assert p.gain(0.0, half) == pytest.approx(g0 / 2, rel=1e-9)        # and in elevation
    assert p.gain(np.pi, 0.0) == pytest.approx(g0 / 10 ** (fb_db / 10), rel=1e-12)
    assert p.gain(np.pi / 2, 0.3) == pytest.approx(g0 / 10 ** (fb_db / 10), rel=1e-9)
    total = _sphere_integral(p.gain, n_el=800, n_az=1440)
    assert total <= 4 * np.pi
    # kink of max(cosψ, 0)^q at ψ = 90°: the quadrature resolves it to ~1e-3
    assert total == pytest.approx(4 * np.pi * p.radiated_fraction, rel=2e-3)


def test_patch_rejects_gain_beyond_its_beamwidth():
    with pytest.raises(ConfigError):
        Patch(15.0, 90.0)             # a 90° beam allows at most 7.6 dBi
    with pytest.raises(ConfigError):
        Patch(6.0, 0.0)


# --------------------------------------------------------------------------- tabulated

def _grid_pattern():
    az = np.radians(np.arange(0, 360, 10.0))
    el = np.radians(np.arange(-90, 91, 10.0))
    table = 1.0 + 0.5 * np.cos(az)[:, None] * np.cos(el)[None, :]
    return az, el, table


def test_tabulated_3d_bilinear_exact_on_grid_and_linear_between():
    az, el, table = _grid_pattern()
    t = Tabulated(az, el, table=table)
    A, E = np.meshgrid(az, el, indexing="ij")
    np.testing.assert_allclose(t.gain(A, E), table, rtol=1e-12)
    # midpoint of a cell = mean of its 4 corners; wrap across 350° → 0°
    i, j = 35, 4
    mid = t.gain((az[i] + np.radians(5)), (el[j] + el[j + 1]) / 2)
    corners = [table[i, j], table[0, j], table[i, j + 1], table[0, j + 1]]
    assert mid == pytest.approx(np.mean(corners), rel=1e-12)
    assert t.gain(-np.radians(10), el[3]) == pytest.approx(table[35, 3], rel=1e-12)


def test_tabulated_amplitude_is_squared_and_cuts_are_separable():
    az = np.radians([0.0, 90.0, 180.0, 270.0])
    el = np.radians([-90.0, 0.0, 90.0])
    t = Tabulated(az, el, az_cut=[1.0, 0.5, 0.2, 0.5], el_cut=[0.0, 1.0, 0.0], quantity="amplitude")
    assert t.gain(np.radians(90.0), 0.0) == pytest.approx(0.25)
    assert t.gain(np.radians(45.0), np.radians(45.0)) == pytest.approx((0.75 * 0.5) ** 2)
    with pytest.raises(ConfigError):
        Tabulated(az, el, az_cut=[1, 1, 1, 1], el_cut=[1, 1, 1], quantity="dB")


def test_tabulated_npz_and_csv_loaders(tmp_path):
    az, el, table = _grid_pattern()
    np.savez(tmp_path / "p.npz", az_rad=az, el_rad=el, table=table)
    t_npz = Tabulated.from_npz(tmp_path / "p.npz")
    with open(tmp_path / "p.csv", "w") as fh:
        fh.write("az,el,gain\n")
        for i, a in enumerate(np.degrees(az)):
            for j, e in enumerate(np.degrees(el)):
                fh.write(f"{float(a)!r},{float(e)!r},{float(table[i, j])!r}\n")
    t_csv = Tabulated.from_csv(tmp_path / "p.csv")
    q_az = np.random.default_rng(3).uniform(-7, 7, 100)
    q_el = np.random.default_rng(4).uniform(-1.5, 1.5, 100)
    ref = Tabulated(az, el, table=table).gain(q_az, q_el)
    np.testing.assert_allclose(t_npz.gain(q_az, q_el), ref, rtol=1e-12)
    np.testing.assert_allclose(t_csv.gain(q_az, q_el), ref, rtol=1e-12)


# --------------------------------------------------------------------------- antenna object

def test_antenna_gain_towards_follows_orientation():
    patch = Patch(8.0, 65.0)
    ant = Antenna((1.0, 1.0, 0.0), orientation=(np.pi / 2, 0.0, 0.0), pattern=patch)
    pts = np.array([[1.0, 5.0, 0.0], [1.0, -3.0, 0.0], [5.0, 1.0, 0.0]])
    g = ant.gain_towards(pts)
    assert g.shape == (3,)
    assert g[0] == pytest.approx(10 ** 0.8)
    assert g[1] == pytest.approx(10 ** 0.8 / 100)
    assert g[2] == pytest.approx(10 ** 0.8 / 100)            # 90° off boresight: back level
    tilted = Antenna((0, 0, 0), (0.0, np.pi / 2, 0.0), HalfWaveDipole())  # axis now along −x
    assert tilted.gain_towards([[0.0, 0.0, 3.0]])[0] == pytest.approx(1.6409223769845853)
    assert tilted.gain_towards([[-2.0, 0.0, 0.0]])[0] == pytest.approx(0.0, abs=1e-12)


def test_antenna_is_hashable_and_compares_by_value():
    a = Antenna((0, 0, 1), (0.1, 0.2, 0.3), HalfWaveDipole())
    b = Antenna(np.array([0.0, 0.0, 1.0]), [0.1, 0.2, 0.3], HalfWaveDipole())
    assert a == b and hash(a) == hash(b) and len({a, b}) == 1
    assert a != Antenna((0, 0, 1), (0.1, 0.2, 0.3), Isotropic())
    with pytest.raises(ValueError):
        a.position_m[0] = 5.0
    with pytest.raises(ConfigError):
        Antenna((0, 0, 0), polarization="elliptic")


def test_polarization_mismatch_cases():
    facing = (np.pi, 0.0, 0.0)
    tx = Antenna((0, 0, 0))
    for delta in np.radians([0.0, 30.0, 45.0, 60.0, 90.0, 135.0]):
        rx = Antenna((5, 0, 0), facing, pol_tilt_rad=delta)
        assert tx.polarization_mismatch(rx) == pytest.approx(np.cos(delta) ** 2, abs=1e-12)
        rolled = Antenna((5, 0, 0), (np.pi, 0.0, delta))          # same via roll
        assert tx.polarization_mismatch(rolled) == pytest.approx(np.cos(delta) ** 2, abs=1e-12)
    rhcp = Antenna((0, 0, 0), polarization="circular")
    rhcp_rx = Antenna((3, 4, 0), polarization="circular", handedness="rhcp")
    lhcp_rx = Antenna((3, 4, 0), polarization="circular", handedness="lhcp")
    assert rhcp.polarization_mismatch(rhcp_rx) == pytest.approx(1.0)
    assert rhcp.polarization_mismatch(lhcp_rx) == pytest.approx(0.0, abs=1e-15)
    assert rhcp.polarization_mismatch(Antenna((3, 4, 0))) == pytest.approx(0.5)
    assert Antenna((0, 0, -2)).polarization_mismatch(tx) == 0.0   # along the axis: no field
    # vectorised over directions
    k = np.random.default_rng(5).normal(size=(7, 3))
    pm = rhcp.polarization_mismatch(Antenna((0, 0, 0), pol_tilt_rad=0.4), direction=k)
    assert pm.shape == (7,)
    e = rhcp.polarization_vector(k)
    np.testing.assert_allclose(polarization_mismatch_factor(e, e), 1.0)


def test_elliptical_panel_axial_ratio_against_rolled_dipoles():
    # Ellipse of axial ratio AR (field ratio r = 1/AR) against a linear antenna at the angle τ from
    # the major axis (the panel's vertical): PLF = (cos²τ + r²·sin²τ)/(1 + r²) (derived by hand:
    # |(û − j r v̂)·(cos τ û + sin τ v̂)|²/(1 + r²)). AR(ψ) = 1 dB on boresight, 3 dB at ψ = 35°.
    panel = EllipticalPanel(position_m=(0.0, 0.0, 0.0), pattern=Patch(9.0, 70.0, 20.0), polarization="circular",
                            axial_ratio_db=(1.0, 3.0), half_beamwidth_rad=np.radians(35.0))
    for ar_db, pos in ((1.0, np.array([5.0, 0.0, 0.0])),
                       (3.0, 5.0 * np.array([np.cos(np.radians(35.0)), np.sin(np.radians(35.0)), 0.0]))):
        r = 10 ** (-ar_db / 20)
        az = np.arctan2(-pos[1], -pos[0])
        for roll_deg in (0.0, 30.0, 90.0):
            tau = np.radians(roll_deg)
            dipole = Antenna(pos, (az, 0.0, tau), HalfWaveDipole())
            expected = (np.cos(tau) ** 2 + r * r * np.sin(tau) ** 2) / (1 + r * r)
            assert float(panel.polarization_mismatch(dipole)) == pytest.approx(expected, rel=1e-9), (ar_db, roll_deg)
    # AR = 0 dB is the ideal circular panel of Antenna: the same vector up to a phase (the same
    # hand: matched to it, |e·e'*|² = 1), 1/2 against any linear antenna
    ideal = EllipticalPanel(position_m=(0.0, 0.0, 0.0), polarization="circular", axial_ratio_db=(0.0, 0.0))
    k = np.random.default_rng(2).normal(size=(5, 3))
    k[:, 0] = np.abs(k[:, 0]) + 0.5
    circular = Antenna((0, 0, 0), polarization="circular").polarization_vector(k)
    np.testing.assert_allclose(polarization_mismatch_factor(ideal.polarization_vector(k), circular), 1.0, rtol=1e-12)
    assert float(ideal.polarization_mismatch(Antenna((3.0, 1.0, 0.5), (0.3, 0.0, 0.7)))) == pytest.approx(0.5)
    # the axial-ratio law is part of the antenna's identity
    assert ideal != EllipticalPanel(position_m=(0.0, 0.0, 0.0), polarization="circular")
    assert panel == EllipticalPanel(position_m=(0.0, 0.0, 0.0), pattern=Patch(9.0, 70.0, 20.0),
                                    polarization="circular", axial_ratio_db=(1.0, 3.0),
                                    half_beamwidth_rad=np.radians(35.0))

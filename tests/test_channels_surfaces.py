"""Fresnel coefficients (PASS golden file), image-method geometry and the two-ray floor."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import optimize
from scipy.io import loadmat

from rfsim.channels.antennas import Antenna
from rfsim.channels.paths import apply_paths
from rfsim.channels.scene import Channel, Scene
from rfsim.channels.surfaces import (
    Surface,
    fresnel_reflection,
    fresnel_transmission,
    image_paths,
    surface_coefficient,
)
from rfsim.core.units import C_M_S

_PASS_MODES = {0: "off", 1: "transmission", 2: "reflection"}


def test_pass_fresnel_golden(reference_data):
    """results_channel_surface.mat: 4200 cases; PASS ``dim == pol_dim`` (E along the normal)
    is TM; transmission is the amplitude factor 1 − r² (pass-paris-simulator.md §2.4)."""
    m = loadmat(reference_data / "pass-selftest" / "results_channel_surface.mat", squeeze_me=True,
                struct_as_record=False)
    settings, results = m["settings"], m["results"]
    assert len(settings) == len(results) == 4200
    part = m["partitioning"]
    assert list(part.runs) == [100, 100, 1000, 1000, 1000, 1000]
    counts = {}
    worst = 0.0
    for s, r in zip(settings, results):
        mode = _PASS_MODES[int(s.mode)]
        assert r.mode == mode
        pol = "TM" if s.dim == s.pol_dim else "TE"
        g = surface_coefficient(np.deg2rad(s.aoi), s.n2, pol, mode)
        mse = float(np.mean(np.abs(g - np.asarray(r.gain, dtype=float)) ** 2))
        worst = max(worst, mse)
        counts[mode] = counts.get(mode, 0) + 1
    assert counts == {"off": 200, "reflection": 2000, "transmission": 2000}
    assert worst <= 1e-12


def test_fresnel_physics():
    n = 1.7
    # normal incidence: both (1 − n)/(1 + n); Brewster angle: r_TM = 0; grazing: −1 (TE)
    for pol in ("TE", "TM"):
        assert fresnel_reflection(0.0, n, pol) == pytest.approx((1 - n) / (1 + n), abs=1e-15)
    assert abs(fresnel_reflection(np.arctan(n), n, "TM")) < 1e-15
    assert fresnel_reflection(np.pi / 2, n, "TE") == pytest.approx(-1.0, abs=1e-12)
    # lossless energy conservation via Snell: T = 1 − |r|² = (n cos θt / cos θi)|t|²
    th = np.linspace(0.01, 1.5, 50)
    ct = np.sqrt(1 - (np.sin(th) / n) ** 2)
    t_te = 2 * np.cos(th) / (np.cos(th) + n * ct)
    np.testing.assert_allclose(fresnel_transmission(th, n, "TE"), n * ct / np.cos(th) * t_te**2, rtol=1e-12)
    # lossy medium: |r| < 1 everywhere
    assert np.all(np.abs(fresnel_reflection(th, np.sqrt(5 - 2j), "TM")) < 1)


def test_image_paths_geometry():
    floor = Surface([0, 0, 0], [0, 0, 1])
    ceiling = Surface([0, 0, 3], [0, 0, -1])
    tx, rx = np.array([0.0, 0, 1]), np.array([4.0, 0, 2])
    paths = image_paths(tx, rx, [floor, ceiling], order=2)
    by = {p.surfaces: p for p in paths}
    assert set(by) == {(0,), (1,), (0, 1), (1, 0)}
    # unfolded lengths: floor √(16 + 3²), ceiling √(16 + 3²) (images at z = −1 and z = 5)
    assert by[(0,)].length_m == pytest.approx(5.0, rel=1e-15)
    assert by[(1,)].length_m == pytest.approx(np.hypot(4, 3), rel=1e-15)
    # floor then ceiling: image of tx in floor (z=−1) then in ceiling (z=7): Δz = 5
    assert by[(0, 1)].length_m == pytest.approx(np.hypot(4, 5), rel=1e-15)
    np.testing.assert_allclose(by[(0,)].points_m[0], [4 / 3, 0, 0], atol=1e-15)
    assert by[(0,)].aoi_rad[0] == pytest.approx(np.arctan2(4, 3), rel=1e-14)
    # finite extent: a 1 m × 1 m floor tile around x = 3 misses the specular point at x = 4/3
    tile = Surface([3, 0, 0], [0, 0, 1], half_size_m=(0.5, 0.5), u_axis=[1, 0, 0])
    assert image_paths(tx, rx, [tile], order=1) == []
    tile2 = Surface([1.3, 0, 0], [0, 0, 1], half_size_m=(0.5, 0.5), u_axis=[1, 0, 0])
    assert len(image_paths(tx, rx, [tile2], order=1)) == 1
    # end points on opposite sides of a plane: no reflection
    assert image_paths(tx, [4, 0, -1], [floor], order=1) == []


def _two_ray_nulls(ht, hr, lam, d_lo, d_hi):
    """Ground distances where d2 − d1 = m·λ (destructive with a real negative r)."""
    out = []
    m = 1
    while True:
        delta = m * lam
        s = 4 * ht * hr / delta  # d1 + d2
        if s <= delta:
            break
        d1 = (s - delta) / 2
        if d1 ** 2 > (ht - hr) ** 2:
            dist = np.sqrt(d1 ** 2 - (ht - hr) ** 2)
            if d_lo < dist < d_hi:
                out.append(dist)
        m += 1
    return np.sort(np.array(out))


def _two_ray_setup(eps_r):
    fc = 915e6
    floor = Surface([0, 0, 0], [0, 0, 1], eps_r=eps_r)
    ch = Channel(Scene(surfaces=(floor,), image_order=1))
    tx = Antenna([0, 0, 1.5], pol_tilt_rad=np.pi / 2)  # E along y ⟂ the plane of incidence (x-z)

    def paths_at(x):
        return ch.link(tx, Antenna([x, 0, 1.0], pol_tilt_rad=np.pi / 2), fc_hz=fc)

    return fc, paths_at


def test_two_ray_floor_antiphase_at_analytic_nulls():
    """Horizontal (TE) dipoles over a lossless dielectric floor: r_TE is real and negative, so
    LoS and floor path are in exact antiphase where d2 − d1 = m·λ."""
    fc, paths_at = _two_ray_setup(4.0)
    expected = _two_ray_nulls(1.5, 1.0, C_M_S / fc, 1.0, 12.0)
    assert expected.size == 4
    for x in expected:
        p = paths_at(x)
        c = p.coefficients(fc)
        assert p.n_paths == 2
        ratio = c[1] / c[0]
        assert abs(np.angle(-ratio)) < 1e-9
        assert abs(p.narrowband_gain(fc)) == pytest.approx(abs(c[0]) - abs(c[1]), rel=1e-9)


def test_two_ray_floor_nulls_positions():
    """Near-PEC floor (r ≈ −1): the minima of |h(x)| from the scene match the minima of the
    textbook two-ray field e^{−jkd1}/d1 − e^{−jkd2}/d2, which lie next to d2 − d1 = m·λ."""
    fc, paths_at = _two_ray_setup(1e8)
    k = 2 * np.pi * fc / C_M_S
    nulls = _two_ray_nulls(1.5, 1.0, C_M_S / fc, 1.0, 12.0)

    def two_ray(x):
        d1, d2 = np.hypot(x, 0.5), np.hypot(x, 2.5)
        return abs(np.exp(-1j * k * d1) / d1 - np.exp(-1j * k * d2) / d2)

    coarse = np.arange(1.0, 12.0, 0.01)
    h = np.array([abs(paths_at(x).narrowband_gain(fc)) for x in coarse])
    i_min = np.flatnonzero((h[1:-1] < h[:-2]) & (h[1:-1] < h[2:])) + 1
    assert i_min.size == nulls.size == 4

    def argmin(f, i):
        return optimize.minimize_scalar(f, bounds=(coarse[i - 1], coarse[i + 1]), method="bounded",
                                        options={"xatol": 1e-7}).x

    found = np.array([argmin(lambda x: abs(paths_at(x).narrowband_gain(fc)), i) for i in i_min])
    expected = np.array([argmin(two_ray, i) for i in i_min])
    np.testing.assert_allclose(found, expected, atol=1e-5)
    np.testing.assert_allclose(found, nulls, atol=1e-2)  # amplitude tilt: a few mm at most


def test_image_path_phase_applied_exactly():
    # the reflected path's carrier phase enters apply_paths like any path: check on a CW
    fc, fs = 915e6, 2e6
    floor = Surface([0, 0, 0], [0, 0, 1], eps_r=4.0)
    ch = Channel(Scene(surfaces=(floor,)))
    p = ch.link(Antenna([0, 0, 1.0]), Antenna([3, 0, 2.0]), fc_hz=fc)
    y = apply_paths(np.ones(200, complex), fs_hz=fs, fc_hz=fc, paths=p)
    assert y[100] == pytest.approx(p.narrowband_gain(fc), rel=1e-12)

"""rfsim.channels.bulk: vectorised link draws against Channel.link and the APDP model.

Deterministic paths (LoS, image paths) are compared with :meth:`Channel.link`, the
one-link-at-a-time assembly, link by link. The diffuse taps are compared in law: the exact
per-link profile against the model curves K(d), τrms(d), and ensemble statistics over 2000
draws per link against ``average_profile`` (the profile ``Channel.link`` draws from).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from rfsim.channels.antennas import Antenna, HalfWaveDipole, Patch
from rfsim.channels.bulk import diffuse_profile, draw_links, static_placements
from rfsim.channels.large_scale import LogDistance, ShadowingField, Wall
from rfsim.channels.scene import Channel, Scene
from rfsim.channels.small_scale import ApdpModel, average_profile, profile_statistics
from rfsim.channels.surfaces import Surface
from rfsim.core.units import C_M_S

FC = 915e6
LO, HI = np.array([0.3, 0.3, 0.2]), np.array([7.7, 5.7, 2.8])


def _room(finite=True):
    """8 m × 6 m × 3 m room; one lossy wall, and optionally a finite panel instead of a wall."""
    last = (Surface([4, 6, 1.5], [0, 1, 0], eps_r=4.0, half_size_m=(2.5, 1.0), u_axis=[1, 0, 0])
            if finite else Surface([0, 6, 0], [0, 1, 0], eps_r=5.3))
    return (
        Surface([0, 0, 0], [0, 0, 1], eps_r=5.3), Surface([0, 0, 3], [0, 0, 1], eps_r=3.0),
        Surface([0, 0, 0], [1, 0, 0], eps_r=5.3), Surface([8, 0, 0], [1, 0, 0], eps_r=5.3 - 0.4j),
        Surface([0, 0, 0], [0, 1, 0], eps_r=5.3), last,
    )


def _placed(template: Antenna, position):
    return Antenna(position, orientation=template.orientation, pattern=template.pattern,
                   polarization=template.polarization, pol_tilt_rad=template.pol_tilt_rad,
                   handedness=template.handedness)


CASES = {
    # order 1, linear–linear with tilts, walls, log-distance, shadowing, both ends moving
    "order1_linear_walls_shadowing": dict(
        order=1, n=200, moving=True,
        tx=Antenna([0, 0, 0], orientation=(0.4, -0.2, 0.3), pattern=Patch(6.0, 70.0), pol_tilt_rad=0.5),
        rx=Antenna([0, 0, 0], orientation=(1.1, 0.3, -0.6), pattern=HalfWaveDipole(), pol_tilt_rad=0.2),
        walls=(Wall.segment_2d([4, 0], [4, 4], 6.0), Wall.plane([0, 0, 1.2], [0, 0.3, 1], 2.5)),
        large_scale=LogDistance(exponent=2.4), shadowing=True),
    # order 2 (30 second-order sequences), circular receiver
    "order2_circular": dict(
        order=2, n=40, moving=True,
        tx=Antenna([0, 0, 0], pattern=HalfWaveDipole()),
        rx=Antenna([0, 0, 0], orientation=(0.2, 0.5, 0), polarization="circular", handedness="lhcp"),
        walls=(), large_scale=None, shadowing=False),
    # circular patch transmitter (generic TE weight and polarization factors), linear receiver
    "order1_circular_tx": dict(
        order=1, n=60, moving=False,
        tx=Antenna([0, 0, 0], orientation=(0.7, 0.1, 0), pattern=Patch(7.0, 65.0), polarization="circular"),
        rx=Antenna([0, 0, 0], pol_tilt_rad=0.9),
        walls=(), large_scale=None, shadowing=False),
    # default antennas (None ⇔ Antenna(p)), static
    "order1_default_static": dict(order=1, n=200, moving=False, tx=None, rx=None, walls=(),
                                  large_scale=None, shadowing=False),
}


def _scene_and_links(case, apdp=None, seed=1):
    rng = np.random.default_rng(seed)
    shadow = ShadowingField(4.0, 2.0, rng=rng, n_features=64) if case["shadowing"] else None
    scene = Scene(surfaces=_room(), walls=case["walls"], large_scale=case["large_scale"], apdp=apdp,
                  shadowing=shadow, image_order=case["order"])
    n = case["n"]
    tx = rng.uniform(LO, HI, (n, 3))
    rx = rng.uniform(LO, HI, (n, 3))
    vt = rng.normal(0, 1.5, (n, 3)) if case["moving"] else None
    vr = rng.normal(0, 1.5, (n, 3)) if case["moving"] else None
    return scene, tx, rx, vt, vr


@pytest.mark.parametrize("name", list(CASES))
def test_deterministic_paths_equal_channel_link(name):
    case = CASES[name]
    scene, tx, rx, vt, vr = _scene_and_links(case)
    out = draw_links(scene, tx, rx, fc_hz=FC, rng=np.random.default_rng(0), tx_antenna=case["tx"],
                     rx_antenna=case["rx"], tx_velocity_m_s=vt, rx_velocity_m_s=vr)
    ch = Channel(scene)
    t_tpl = case["tx"] or Antenna([0, 0, 0])
    r_tpl = case["rx"] or Antenna([0, 0, 0])
    n_paths = 0
    for i in range(case["n"]):
        ref = ch.link(_placed(t_tpl, tx[i]), _placed(r_tpl, rx[i]), fc_hz=FC,
                      tx_motion=None if vt is None else vt[i], rx_motion=None if vr is None else vr[i])
        got = out.pathset(i)
        assert got.n_paths == ref.n_paths
        np.testing.assert_allclose(got.gain, ref.gain, rtol=1e-9, atol=0)
        np.testing.assert_allclose(got.delay_s, ref.delay_s, rtol=1e-9, atol=0)
        np.testing.assert_allclose(got.doppler_hz, ref.doppler_hz, rtol=1e-9,
                                   atol=1e-9 * max(1.0, np.max(np.abs(ref.doppler_hz))))
        n_paths += ref.n_paths
    assert out.n_links == case["n"]
    # the finite panel and the side tests must have removed some paths, and most remain
    n_slots = case["n"] * out.n_image_slots
    assert case["n"] < n_paths - case["n"] < n_slots
    pad = ~out.valid
    assert pad.any() and np.all(out.gain[pad] == 0) and np.all(out.delay_s[pad] == 0)
    if not case["moving"]:
        assert out.doppler_hz is None


def test_deterministic_columns_with_apdp_equal_channel_link():
    case = CASES["order1_linear_walls_shadowing"]
    scene, tx, rx, vt, vr = _scene_and_links(case, apdp=ApdpModel())
    out = draw_links(scene, tx[:50], rx[:50], fc_hz=FC, rng=np.random.default_rng(3),
                     tx_antenna=case["tx"], rx_antenna=case["rx"], tx_velocity_m_s=vt[:50],
                     rx_velocity_m_s=vr[:50])
    ch = Channel(scene)
    rng = np.random.default_rng(4)
    n_det = 1 + out.n_image_slots
    for i in range(50):
        ref = ch.link(_placed(case["tx"], tx[i]), _placed(case["rx"], rx[i]), fc_hz=FC, rng=rng,
                      tx_motion=vt[i], rx_motion=vr[i])
        got = out.pathset(i)
        m = int(out.valid[i, :n_det].sum())  # LoS + existing image paths come first in both
        np.testing.assert_allclose(got.gain[:m], ref.gain[:m], rtol=1e-9, atol=0)
        np.testing.assert_allclose(got.delay_s[:m], ref.delay_s[:m], rtol=1e-9, atol=0)
        np.testing.assert_allclose(got.doppler_hz[:m], ref.doppler_hz[:m], rtol=1e-9, atol=1e-9)
        # diffuse taps: after the LoS delay, with the LoS Doppler
        assert np.all(got.delay_s[m:] >= ref.delay_s[0])
        np.testing.assert_array_equal(got.doppler_hz[m:], got.doppler_hz[0])
    assert out.n_diffuse == 21  # ⌈2·50 MHz/5 MHz⌉ + 1 bins


def test_profile_meets_k_and_tau_rms_exactly():
    apdp = ApdpModel()
    d = np.array([0.05, 0.3, 1.0, 3.0, 7.0, 15.0, 40.0, 120.0])
    p_los, pw, rel = diffuse_profile(apdp, d)
    k_model = apdp.k_lin_at(d)
    tau_model = apdp.tau_rms_s_at(d)
    for i in range(d.size):
        k, tau = profile_statistics(np.r_[p_los[i], pw[i]], np.r_[0.0, rel[i]])
        assert k == pytest.approx(k_model[i], rel=1e-12)
        assert tau == pytest.approx(tau_model[i], rel=1e-9)
        assert p_los[i] + pw[i].sum() == pytest.approx(1.0, rel=1e-14)
    assert np.all(np.diff(rel, axis=1) > 0) and np.all(rel[:, 0] > 0)


def test_diffuse_ensemble_statistics_match_scene():
    """Mean power, K and τrms over M = 2000 draws per link vs ``average_profile``.

    Free space, isotropic antennas, no surfaces: per draw, the link is the LoS tap (fixed,
    power g²·P₀) plus taps g·h_i, h_i ~ CN(0, P_i). Each tap's mean power over M draws is an
    average of M exponentials: relative std 1/√M, independent across taps. Hence (delta method,
    P_i, τ_i of ``average_profile``, powers relative to g²):
    σ(total) = √(Σ_{i≥1} P_i²/M);  σ(K̂)/K = √(Σ_{i≥1} P_i²/M)/P_nlos;
    σ(τ̂²) = √(Σ_{i≥1} P_i²·((τ_i − τ̄)² − τ²)²/M), σ(τ̂) = σ(τ̂²)/(2τ).
    Tolerances are 5σ (a false alarm ≈ 6e-7 per check); τrms adds the model difference
    |τ_scene − τ_target| ≤ eps_trms·τ_target (the bulk profile meets τ_target exactly, see
    test_profile_meets_k_and_tau_rms_exactly).
    """
    apdp = ApdpModel()
    scene = Scene(apdp=apdp)
    m_draws = 2000
    tx = np.zeros(3)
    dists = np.array([0.5, 2.0, 5.0, 10.0, 20.0])
    rx = np.repeat(np.c_[dists, np.zeros((dists.size, 2))], m_draws, axis=0)
    out = draw_links(scene, tx, rx, fc_hz=FC, rng=np.random.default_rng(11))
    n_checked = 0
    for j, d in enumerate(dists):
        rows = slice(j * m_draws, (j + 1) * m_draws)
        g = out.gain[rows]
        tau = out.delay_s[rows]
        np.testing.assert_array_equal(tau, np.broadcast_to(tau[0], tau.shape))  # fixed delays
        g2 = (C_M_S / (4 * np.pi * FC * d)) ** 2
        pdp = np.mean(np.abs(g) ** 2, axis=0) / g2
        p_ref, t_ref = average_profile(float(apdp.k_lin_at(d)), float(apdp.tau_rms_s_at(d)),
                                       **apdp.profile_options)
        k_ref, tau_ref = profile_statistics(p_ref, t_ref)
        tau_target = float(apdp.tau_rms_s_at(d))
        pn = p_ref[1:]
        s_pow = np.sqrt(np.sum(pn ** 2) / m_draws)
        mean_ref = np.sum(p_ref * t_ref)
        s_tau2 = np.sqrt(np.sum(pn ** 2 * ((t_ref[1:] - mean_ref) ** 2 - tau_ref ** 2) ** 2) / m_draws)
        s_tau = s_tau2 / (2 * tau_ref)

        assert pdp.sum() == pytest.approx(p_ref.sum(), abs=5 * s_pow)
        k_hat, tau_hat = profile_statistics(pdp, tau[0] - tau[0, 0])
        assert k_hat == pytest.approx(k_ref, rel=5 * s_pow / pn.sum())
        assert tau_hat == pytest.approx(tau_ref, abs=5 * s_tau + apdp.eps_trms * tau_target)
        assert tau_hat == pytest.approx(tau_target, abs=5 * s_tau)
        n_checked += 1
    assert n_checked == dists.size


def test_diffuse_taps_are_circular_gaussian():
    """|h_i|²/P_i pooled over taps is Exp(1) and the phases are uniform (KS, 21 × 4000 samples)."""
    apdp = ApdpModel()
    scene = Scene(apdp=apdp)
    n = 4000
    out = draw_links(scene, np.zeros(3), np.tile([3.0, 0.0, 0.0], (n, 1)), fc_hz=FC,
                     rng=np.random.default_rng(5))
    _, pw, _ = diffuse_profile(apdp, np.array([3.0]))
    g = C_M_S / (4 * np.pi * FC * 3.0)
    h = out.gain[:, 1 + out.n_image_slots:] / g
    z = (np.abs(h) ** 2 / pw).ravel()
    assert z.size == n * 21
    assert stats.kstest(z, "expon").pvalue > 1e-3
    assert stats.kstest(np.angle(h).ravel(), "uniform", args=(-np.pi, 2 * np.pi)).pvalue > 1e-3


def test_reproducible_and_independent_of_block_size():
    scene = Scene(surfaces=_room(), apdp=ApdpModel())
    rng = np.random.default_rng(2)
    tx = rng.uniform(LO, HI, (20000, 3))
    rx = rng.uniform(LO, HI, (20000, 3))
    a = draw_links(scene, tx, rx, fc_hz=FC, rng=np.random.default_rng(42))
    b = draw_links(scene, tx, rx, fc_hz=FC, rng=np.random.default_rng(42))
    c = draw_links(scene, tx[:100], rx[:100], fc_hz=FC, rng=np.random.default_rng(42))
    d = draw_links(scene, tx, rx, fc_hz=FC, rng=np.random.default_rng(43))
    np.testing.assert_array_equal(a.gain, b.gain)
    np.testing.assert_array_equal(a.delay_s, b.delay_s)
    np.testing.assert_array_equal(a.gain[:100], c.gain)  # rows are drawn in order
    det = slice(0, 1 + a.n_image_slots)
    np.testing.assert_array_equal(a.gain[:, det], d.gain[:, det])
    assert not np.any(a.gain[:, det.stop:] == d.gain[:, det.stop:])


def test_narrowband_gain_and_broadcasting():
    scene = Scene(surfaces=_room(finite=False), apdp=ApdpModel())
    rng = np.random.default_rng(8)
    rx = rng.uniform(LO, HI, (30, 3))
    out = draw_links(scene, [0.5, 3.0, 2.0], rx, fc_hz=FC, rng=rng)
    nb = out.narrowband_gain(FC)
    assert nb.shape == (30,)
    for i in range(30):
        assert nb[i] == pytest.approx(out.pathset(i).narrowband_gain(FC), rel=1e-12)


def test_invalid_inputs():
    scene = Scene()
    with pytest.raises(ValueError):
        draw_links(scene, np.ones((4, 3)), np.ones((4, 3)), fc_hz=FC, rng=np.random.default_rng(0))
    with pytest.raises(ValueError):
        draw_links(scene, np.ones((4, 2, 3)), np.zeros(3), fc_hz=FC, rng=np.random.default_rng(0))
    with pytest.raises(ValueError):
        draw_links(scene, np.ones((4, 3)), np.zeros((5, 3)), fc_hz=FC, rng=np.random.default_rng(0))


def test_bench_bulk_links_runs():
    from rfsim.bench.channels import bench_bulk_links

    out = bench_bulk_links(n_links=2000, repeats=1)
    assert out["bulk_links_per_s"] > 0
    assert out["paths_per_link"] == 1 + 6 + 21
    assert 0 < out["image_slot_fill"] <= 1


def test_narrowband_rms_error_per_link_two_path_closed_form_and_pathset():
    """Two paths g1 at τ0 and g2 at τ0 + Δ: error = 2π·B·Δ·|g2| / √(|g1|² + |g2|²) (independent
    derivation); with surfaces and APDP every link equals the PathSet rule of rfsim.channels.paths."""
    from rfsim.channels.bulk import BulkPaths
    from rfsim.channels.paths import narrowband_rms_error

    g = np.array([[1.0, 0.5j], [0.3, 0.0]], dtype=np.complex128)
    tau = np.array([[10e-9, 60e-9], [20e-9, 0.0]])
    valid = np.array([[True, True], [True, False]])  # link 1: one path + a padded slot
    bp = BulkPaths(g, tau, None, valid, 1, 0)
    b = 96e3
    want0 = 2 * np.pi * b * 50e-9 * 0.5 / np.sqrt(1.0 + 0.25)
    np.testing.assert_allclose(bp.narrowband_rms_error(b), [want0, 0.0], rtol=1e-12, atol=0)
    rng = np.random.default_rng(3)
    scene = Scene(surfaces=_room(), apdp=ApdpModel())
    rx = rng.uniform(LO, HI, size=(40, 3))
    bulk = draw_links(scene, [1.0, 1.0, 1.5], rx, fc_hz=FC, rng=rng)
    got = bulk.narrowband_rms_error(2e6)
    ref = [narrowband_rms_error(bulk.pathset(i), 2e6) for i in range(40)]
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)
    assert got.max() > 0.1 > got.min()  # both sides of the tolerance occur at this bandwidth


def test_batch_link_gains_shape_and_narrowband_decision():
    rng = np.random.default_rng(5)
    scene = Scene(apdp=ApdpModel())
    rx = rng.uniform(LO, HI, size=(6, 3))
    bulk = draw_links(scene, [0.5, 0.5, 1.0], rx, fc_hz=FC, rng=rng)
    link = bulk.batch_link((3, 2))
    gain = link.constant_gain(FC)
    assert gain.shape == (3, 2, 1)
    # row-major: batch element (i, j) is link 2·i + j, Σ_p g·e^{-j2π fc τ} of its paths
    for i in range(6):
        ps = bulk.pathset(i)
        want = np.sum(ps.gain * np.exp(-2j * np.pi * FC * ps.delay_s))
        assert abs(gain[i // 2, i % 2, 0] - want) <= 1e-12 * abs(want)
    assert link.static
    err = link.narrowband_error(96e3)
    assert link.method(96e3) == ("narrowband" if err <= 0.1 else "exact")
    assert link.method(1e9) == "exact"  # far above the tolerance: fractional delays needed
    assert link.method(1e9, "narrowband") == "narrowband"
    with pytest.raises(ValueError, match="narrowband only"):
        link.apply(np.ones(4, complex), fs_hz=1e6, fc_hz=FC, method="exact")
    with pytest.raises(ValueError, match="does not hold"):
        bulk.batch_link((4, 2))


@pytest.mark.parametrize("polarization", ["circular", "linear"])
def test_static_placements_equal_the_channels_own_bit_for_bit(polarization):
    """static_placements against Channel._placement, element by element with ==, over 300
    random receivers (position, orientation, polarization tilt) around a patch panel; then a
    link whose placement is held equals the link the channel evaluates itself."""
    rng = np.random.default_rng(12)
    tx = Antenna(position_m=(0.2, -0.1, 0.3), orientation=(0.3, -0.1, 0.2), pattern=Patch(9.0, 70.0, 20.0),
                 polarization=polarization)
    rxs = [Antenna(position_m=rng.uniform(-5, 5, 3), orientation=tuple(rng.uniform(-np.pi, np.pi, 3)),
                   pattern=HalfWaveDipole(), polarization="linear", pol_tilt_rad=float(rng.uniform(0, 1)))
           for _ in range(300)]
    sc = Scene(apdp=ApdpModel())
    bulk = static_placements(sc, tx, rxs)
    for rx, got in zip(rxs, bulk):
        want = Channel(sc)._placement(tx, rx, 0.0, None, None)
        assert len(got) == len(want)
        for a, b in zip(got, want):
            if isinstance(b, np.ndarray):
                assert np.array_equal(a, b) and a.dtype == b.dtype and not a.flags.writeable
            else:
                assert a == b and type(a) is type(b)
    # one transmitter per link (rolled dipoles) to the same receivers
    txs = [Antenna(position_m=rng.uniform(-5, 5, 3), orientation=tuple(rng.uniform(-np.pi, np.pi, 3)),
                   pattern=HalfWaveDipole(), polarization="linear", pol_tilt_rad=float(rng.uniform(0, 1)))
           for _ in rxs]
    for t, rx, got in zip(txs, rxs, static_placements(sc, txs, rxs)):
        want = Channel(sc)._placement(t, rx, 0.0, None, None)
        for a, b in zip(got, want):
            assert np.array_equal(a, b) if isinstance(b, np.ndarray) else (a == b and type(a) is type(b))
    held = Channel(sc)
    held.hold_placement(tx, rxs[0], bulk[0])
    p_held = held.link(tx, rxs[0], fc_hz=915e6, rng=np.random.default_rng(3))
    p_own = Channel(sc).link(tx, rxs[0], fc_hz=915e6, rng=np.random.default_rng(3))
    assert np.array_equal(p_held.gain, p_own.gain) and np.array_equal(p_held.delay_s, p_own.delay_s)
    with pytest.raises(ValueError, match="surfaces and walls"):
        static_placements(Scene(walls=(Wall.segment_2d([4, 0], [4, 4], 6.0),)), tx, rxs)


def test_static_constants_equal_each_links_narrowband_constant_bit_for_bit():
    # Channel.static_constants: the one-LoS-path links of a static scene at one carrier as arrays;
    # each constant must be the link's own narrowband_constant to the bit (a hop of an inventory
    # reads them), at many carriers and distances; None where the links are not of that form.
    from rfsim.channels.antennas import Isotropic
    from rfsim.scenes.room_inventory import tag_antenna

    rng = np.random.default_rng(3)
    ra = Antenna(position_m=(0.0, 0.0, 1.0), orientation=(0.0, 0.0, 0.0), pattern=Isotropic(),
                 polarization="circular")
    ants = [tag_antenna(tuple(float(v) for v in rng.uniform(-6.0, 6.0, 3)), float(rng.uniform(0, 2 * np.pi)))
            for _ in range(200)]
    for fc in [902.75e6 + 0.5e6 * k for k in range(0, 50, 4)] + rng.uniform(860e6, 960e6, 6).tolist():
        got = Channel(Scene()).static_constants(ra, ants, fc_hz=fc, bandwidth_hz=640e3)
        ref = Channel(Scene())
        want = [ref.link(ra, a, fc_hz=fc).narrowband_constant(fc, 640e3, "auto") for a in ants]
        assert [(c.real.hex(), c.imag.hex()) for c in got] == [(c.real.hex(), c.imag.hex()) for c in want]
        assert Channel(Scene()).static_constants(ra, ants, fc_hz=fc, bandwidth_hz=640e3, inbound=True) == got
    assert Channel(Scene()).static_constants(ra, ants, fc_hz=fc, bandwidth_hz=640e3, propagation="exact") is None
    assert Channel(Scene(large_scale=LogDistance())).static_constants(ra, ants, fc_hz=fc, bandwidth_hz=640e3) is None
    assert Channel(Scene(reciprocal=False)).static_constants(ra, ants, fc_hz=fc, bandwidth_hz=640e3,
                                                             inbound=True) is None
    assert Channel(Scene()).static_constants(ra, [], fc_hz=fc, bandwidth_hz=640e3) == []

"""Link assembly: backscatter phase and power laws, Doppler, quasi-static draws, bulk links."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.channels.antennas import Antenna, HalfWaveDipole
from rfsim.channels.large_scale import LogDistance, Wall, friis_amplitude_gain
from rfsim.channels.paths import apply_backscatter, apply_paths, compose_backscatter
from rfsim.channels.scene import Channel, Scene, los_links
from rfsim.channels.small_scale import ApdpModel
from rfsim.channels.surfaces import Surface
from rfsim.core.units import C_M_S

FC = 915e6


def _monostatic(distance_m, **scene_kw):
    ch = Channel(Scene(**scene_kw))
    reader = Antenna([0.0, 0.0, 1.0])
    tag = Antenna([distance_m, 0.0, 1.0])
    return ch, reader, tag


def test_monostatic_backscatter_phase():
    """Round-trip phase lag = 4πd/λ mod 2π within 1e-9 rad for d in [0.1, 20] m, both from the
    composed paths and from a sample-level CW through apply_backscatter."""
    lam = C_M_S / FC
    fs = 2e6
    for d in np.geomspace(0.1, 20.0, 25):
        ch, reader, tag = _monostatic(d)
        fwd, bwd = ch.backscatter_links(reader, tag, fc_hz=FC)
        expected = np.mod(4 * np.pi * d / lam, 2 * np.pi)
        lag = np.mod(-np.angle(compose_backscatter(fwd, bwd).narrowband_gain(FC)), 2 * np.pi)
        assert abs(np.angle(np.exp(1j * (lag - expected)))) < 1e-9
        y = apply_backscatter(np.ones(300, complex), 1.0, fwd, bwd, fs_hz=fs, fc_hz=FC)
        lag_wave = np.mod(-np.angle(y[150]), 2 * np.pi)
        assert abs(np.angle(np.exp(1j * (lag_wave - expected)))) < 1e-9


def test_free_space_power_slopes():
    """One-way received power falls 20 dB/decade, the monostatic round trip 40 dB/decade."""
    d = np.geomspace(1.0, 100.0, 9)
    one_way, round_trip = [], []
    for dist in d:
        ch, reader, tag = _monostatic(dist)
        fwd, bwd = ch.backscatter_links(reader, tag, fc_hz=FC)
        one_way.append(abs(fwd.narrowband_gain(FC)) ** 2)
        round_trip.append(abs(compose_backscatter(fwd, bwd).narrowband_gain(FC)) ** 2)
    slope1 = np.polyfit(np.log10(d), 10 * np.log10(one_way), 1)[0]
    slope2 = np.polyfit(np.log10(d), 10 * np.log10(round_trip), 1)[0]
    assert slope1 == pytest.approx(-20.0, abs=1e-9)
    assert slope2 == pytest.approx(-40.0, abs=1e-9)
    # and the level is Friis: (λ/4πd)²
    assert one_way[0] == pytest.approx((C_M_S / (4 * np.pi * FC * d[0])) ** 2, rel=1e-12)


@pytest.mark.parametrize("v", [0.5, -2.0, 10.0])
def test_moving_tag_doppler(v):
    """A tag moving radially at v: the CW through the sample-level backscatter link turns at
    f_D = 2v/λ (receding: negative) within 0.1 % (gen2-and-validation-anchors.md §4.7)."""
    lam = C_M_S / FC
    ch, reader, tag = _monostatic(3.0)
    fwd, bwd = ch.backscatter_links(reader, tag, fc_hz=FC, tag_motion=[v, 0.0, 0.0])
    fs = 20e3
    y = apply_backscatter(np.ones(4000, complex), 0.4, fwd, bwd, fs_hz=fs, fc_hz=FC)
    seg = y[100:-100]
    phase = np.unwrap(np.angle(seg))
    slope_hz = np.polyfit(np.arange(seg.size) / fs, phase, 1)[0] / (2 * np.pi)
    assert slope_hz == pytest.approx(-2 * v / lam, rel=1e-3)


def test_trajectory_motion_matches_velocity():
    ch, reader, tag = _monostatic(3.0)
    v = np.array([1.0, 2.0, 0.0])
    p_v = ch.link(reader, tag, fc_hz=FC, t_s=0.5, rx_motion=v)
    p_t = ch.link(reader, tag, fc_hz=FC, t_s=0.5, rx_motion=lambda t: tag.position_m + v * t)
    assert p_v.delay_s[0] == pytest.approx(p_t.delay_s[0], rel=1e-14)
    assert p_v.doppler_hz[0] == pytest.approx(p_t.doppler_hz[0], rel=1e-6)
    # radial component only: tag at (3, 0, 1) moving (1, 2, 0) recedes at 1 m/s
    assert ch.link(reader, tag, fc_hz=FC, rx_motion=v).doppler_hz[0] == pytest.approx(-FC / C_M_S, rel=1e-12)


def test_image_path_doppler_uses_mirrored_velocity():
    """Tag moving towards a wall behind it: its image path lengthens faster than the LoS."""
    wall = Surface([10.0, 0, 0], [1, 0, 0])
    ch = Channel(Scene(surfaces=(wall,)))
    reader, tag = Antenna([0.0, 0, 1]), Antenna([4.0, 0, 1])
    # the reader's image in the wall is at x = 20, so the wall path is 20 − x_tag long
    p = ch.link(reader, tag, fc_hz=FC, rx_motion=[1.0, 0, 0])
    assert p.n_paths == 2
    assert p.doppler_hz[0] == pytest.approx(-FC / C_M_S, rel=1e-12)  # LoS lengthens at 1 m/s
    assert p.doppler_hz[1] == pytest.approx(+FC / C_M_S, rel=1e-12)  # image path (20 − x) shortens


def test_quasi_static_diffuse_draws_and_reciprocity():
    ch = Channel(Scene(apdp=ApdpModel()))
    a, b = Antenna([0.0, 0, 1]), Antenna([3.0, 1, 1], pattern=HalfWaveDipole())
    with pytest.raises(ValueError, match="pass rng"):
        ch.link(a, b, fc_hz=FC)
    p1 = ch.link(a, b, fc_hz=FC, rng=np.random.default_rng(1))
    p2 = ch.link(a, b, fc_hz=FC)  # held
    np.testing.assert_array_equal(p1.gain, p2.gain)
    back = ch.link(b, a, fc_hz=FC)  # reciprocal: same held draw
    np.testing.assert_allclose(back.gain, p1.gain, rtol=1e-14)
    np.testing.assert_allclose(back.delay_s, p1.delay_s, rtol=1e-15)
    p3 = ch.link(a, b, fc_hz=FC, rng=np.random.default_rng(2))
    assert not np.allclose(p3.gain[1:], p1.gain[1:])
    assert p3.gain[0] == p1.gain[0]  # the LoS is deterministic
    # diffuse taps come after the LoS delay
    assert np.all(p1.delay_s[1:] >= p1.delay_s[0])


def test_apdp_power_split_in_link():
    """LoS carries K/(K+1) of the large-scale power; the diffuse taps 1/(K+1) on average."""
    model = ApdpModel()
    ch = Channel(Scene(apdp=model))
    a, b = Antenna([0.0, 0, 1]), Antenna([5.0, 0, 1])
    d = 5.0
    k = float(model.k_lin_at(d))
    g2 = friis_amplitude_gain(d, FC) ** 2
    rng = np.random.default_rng(7)
    n = 2000
    nlos = np.empty(n)
    for i in range(n):
        p = ch.link(a, b, fc_hz=FC, rng=rng)
        nlos[i] = np.sum(np.abs(p.gain[1:]) ** 2)
    assert abs(p.gain[0]) ** 2 == pytest.approx(g2 * k / (k + 1), rel=1e-12)
    # the mean of n sums of exponentials has relative std ≤ 1/√n = 2.2 %; tolerance 4σ
    assert nlos.mean() == pytest.approx(g2 / (k + 1), rel=0.09)


def test_los_links_bulk_matches_scene():
    rng = np.random.default_rng(4)
    n = 200_000
    tx = np.zeros((n, 3))
    rx = rng.uniform(-10, 10, (n, 3)) + np.array([0, 0, 12.0])
    g, tau, dop = los_links(tx, rx, FC)
    assert g.shape == tau.shape == dop.shape == (n,)
    ch = Channel(Scene())
    for i in (0, 17, n - 1):
        p = ch.link(Antenna(tx[i]), Antenna(rx[i]), fc_hz=FC)
        assert g[i] == pytest.approx(p.gain[0], rel=1e-13)
        assert tau[i] == pytest.approx(p.delay_s[0], rel=1e-15)
    # log-distance, a wall, antenna templates and velocities
    ls = LogDistance(exponent=3.0)
    wall = Wall.plane([0, 0, 5.0], [0, 0, 1], 6.0)
    ant = Antenna([0, 0, 0], pattern=HalfWaveDipole())
    g2, _, dop2 = los_links(tx[:5], rx[:5], FC, large_scale=ls, walls=[wall], tx_antenna=ant, rx_antenna=ant,
                            rx_velocity_m_s=np.array([0, 0, 1.0]))
    ch2 = Channel(Scene(walls=(wall,), large_scale=ls))
    for i in range(5):
        p = ch2.link(Antenna(tx[i], pattern=HalfWaveDipole()), Antenna(rx[i], pattern=HalfWaveDipole()),
                     fc_hz=FC, rx_motion=[0, 0, 1.0])
        assert g2[i] == pytest.approx(p.gain[0], rel=1e-12)
        assert dop2[i] == pytest.approx(p.doppler_hz[0], rel=1e-12)


def test_held_draw_follows_moving_link():
    # motion does not discard the held draw (the link is named by the antennas as given)
    ch = Channel(Scene(apdp=ApdpModel()))
    a, b = Antenna([0.0, 0, 1]), Antenna([3.0, 0, 1])
    p0 = ch.link(a, b, fc_hz=FC, rng=np.random.default_rng(3), rx_motion=[1.0, 0, 0])
    p1 = ch.link(a, b, fc_hz=FC, t_s=0.01, rx_motion=[1.0, 0, 0])
    np.testing.assert_allclose(np.abs(p1.gain[1:]) / np.abs(p0.gain[1:]), abs(p1.gain[0] / p0.gain[0]), rtol=1e-12)
    y = apply_paths(np.ones(100, complex), fs_hz=1e6, fc_hz=FC, paths=p1, method="narrowband")
    assert np.all(np.isfinite(y))


def test_held_links_return_the_held_draw_per_pair_only():
    """HeldLinks: the PathSet given for (tx, rx), by antenna identity; None for any other pair
    (including the reverse pair and an equal antenna at the same place)."""
    from rfsim.channels.scene import HeldLinks
    from rfsim.channels.paths import PathSet

    a, b = Antenna([0.0, 0.0, 1.0]), Antenna([2.0, 0.0, 1.0])
    twin = Antenna([2.0, 0.0, 1.0])
    fwd = PathSet([0.1 + 0.2j], [6.7e-9])
    links = HeldLinks([(a, b, fwd)])
    assert links.paths(a, b, fc_hz=915e6, t_s=0.0) is fwd
    assert links.paths(a, b, fc_hz=866e6, t_s=3.0) is fwd  # held: whatever the carrier and time
    assert links.paths(b, a, fc_hz=915e6, t_s=0.0) is None
    assert links.paths(a, twin, fc_hz=915e6, t_s=0.0) is None


def test_hold_placements_gives_the_links_the_channel_evaluates_itself():
    # 40 dipoles around an isotropic reader: links after hold_placements equal, bit for bit,
    # those of a channel that evaluates each placement on its own; a scene with a reflecting
    # floor, or circularly polarized receivers, is left to link()
    from rfsim.channels.antennas import Isotropic

    tx = Antenna(position_m=(0.0, 0.0, 1.0), orientation=(0.0, 0.0, 0.0), pattern=Isotropic(), polarization="circular")
    a = 2 * np.pi * np.arange(40) / 40
    tags = [Antenna(position_m=(2 * np.cos(x), 2 * np.sin(x), 1.0), orientation=(x + np.pi, 0.0, 0.0),
                    pattern=HalfWaveDipole(), polarization="linear") for x in a]
    held, own = Channel(Scene()), Channel(Scene())
    assert held.hold_placements(tx, tags) == 40
    assert held.hold_placements(tx, tags) == 0  # already held
    for t in tags:
        p, q = held.link(tx, t, fc_hz=915e6), own.link(tx, t, fc_hz=915e6)
        assert np.array_equal(p.gain, q.gain) and np.array_equal(p.delay_s, q.delay_s)
        assert np.array_equal(p.doppler_hz, q.doppler_hz)
    floor = Scene(surfaces=(Surface(point_m=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), eps_r=5.3),), image_order=1)
    assert Channel(floor).hold_placements(tx, tags) == 0
    assert Channel(Scene()).hold_placements(tags[0], [tx]) == 0  # a circular receiver


def test_static_link_draws_share_their_delay_terms_and_keep_draw_taps_numbers():
    # successive draws of a static link: new diffuse gains on the same delays, the numbers of
    # draw_taps (the same generator state after), and coefficients and narrowband error equal to
    # those of a link assembled without the shared terms
    from rfsim.channels.paths import PathSet, narrowband_rms_error
    from rfsim.channels.small_scale import draw_taps

    model = ApdpModel()
    ch = Channel(Scene(apdp=model))
    a, b = Antenna([0.0, 0, 1]), Antenna([4.0, 1, 1], pattern=HalfWaveDipole())
    rng, ref_rng = np.random.default_rng(3), np.random.default_rng(3)
    p1 = ch.link(a, b, fc_hz=FC, rng=rng)
    p2 = ch.link(a, b, fc_hz=FC, rng=rng)
    assert p2.delay_s is p1.delay_s and p2.doppler_hz is p1.doppler_hz
    assert not np.array_equal(p1.gain[1:], p2.gain[1:])
    d = float(np.linalg.norm(b.position_m - a.position_m))
    scales = []
    for p in (p1, p2):
        taps, rel = draw_taps(float(model.k_lin_at(d)), float(model.tau_rms_s_at(d)), rng=ref_rng, n_draws=1,
                              **model.profile_options)
        scale = p.gain[1:] / taps[0, 1:]  # the large-scale amplitude g_ls·env, the same for every tap
        np.testing.assert_allclose(scale, scale[0].real, rtol=1e-12)
        scales.append(scale[0].real)
        np.testing.assert_array_equal(p.delay_s[1:], p.delay_s[0] + rel[1:])
    assert scales[0] == pytest.approx(scales[1], rel=1e-12)
    assert rng.bit_generator.state == ref_rng.bit_generator.state
    plain = PathSet(p2.gain, p2.delay_s, p2.doppler_hz)
    for fc in (FC, FC + 0.5e6):
        assert p2.coefficients(fc).tobytes() == plain.coefficients(fc).tobytes()
    assert narrowband_rms_error(p2, 640e3) == narrowband_rms_error(plain, 640e3)
    assert p2.static and p2.constant_gain(FC) == plain.constant_gain(FC)


def test_a_link_found_again_in_the_tables_is_the_link_a_new_channel_assembles():
    # the channel finds a static link's entries again in its tables (keyed by the antennas' values
    # and the carrier): links asked in turn (the same pair again, an equal antenna of its own,
    # another carrier, the reverse direction) are bit for bit those of a channel that assembles
    # each one anew
    a, b = Antenna([0.0, 0, 1]), Antenna([4.0, 1, 1], pattern=HalfWaveDipole())
    b_equal, c = Antenna([4.0, 1, 1], pattern=HalfWaveDipole()), Antenna([2.0, -1, 1.5])
    scene = Scene(apdp=ApdpModel(), surfaces=(Surface(point_m=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)),), image_order=1)
    ch = Channel(scene)
    asked = [(a, b, FC), (a, b, FC), (a, b_equal, FC), (a, b, FC + 0.5e6), (a, b, FC), (a, c, FC), (b, a, FC),
             (a, b, FC)]
    rng = np.random.default_rng(5)
    for k, (tx, rx, fc) in enumerate(asked):
        p = ch.link(tx, rx, fc_hz=fc, rng=rng)
        ref_rng = np.random.default_rng(5)
        for tx_r, rx_r, fc_r in asked[:k]:  # the same generator state: the same draws before
            Channel(scene).link(tx_r, rx_r, fc_hz=fc_r, rng=ref_rng)
        ref = Channel(scene).link(tx, rx, fc_hz=fc, rng=ref_rng)
        assert p.gain.tobytes() == ref.gain.tobytes(), k
        assert p.delay_s.tobytes() == ref.delay_s.tobytes() and p.doppler_hz.tobytes() == ref.doppler_hz.tobytes(), k
        assert p.constant_gain(fc) == ref.constant_gain(fc), k
        held = ch.link(tx, rx, fc_hz=fc)  # the held draw of this pair
        assert held.gain.tobytes() == p.gain.tobytes(), k
    # the pair found again keeps the delays the channel shares between draws
    p1, p2 = ch.link(a, b, fc_hz=FC, rng=rng), ch.link(a, b, fc_hz=FC, rng=rng)
    assert p2.delay_s is p1.delay_s

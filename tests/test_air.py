"""The air interface (rfsim.air.step): superposition, carrier offsets, noise, batches, exciter,
own-schedule reflectors and bad input.

Expected values are written out from the free-space link model (Friis amplitude λ/(4πd),
delay d/c, carrier phase e^{−j2π·fc·d/c}; rfsim.channels.scene docstring) — not taken from the
step itself.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.channels import Antenna, Channel, Isotropic, Scene, vertical_dipole
from rfsim.channels.paths import PathSet
from rfsim.devices.exciter import Exciter, ExciterConfig
from rfsim.devices.sense_a_tag import SenseATag, SenseATagConfig, make_receiver
from rfsim.devices.tag import PassiveTag, TagConfig
from rfsim.air.step import AntennaPort, FixedEmitter, LinkTable, Segment, propagate
from rfsim.air.links import AntennaMotion
from rfsim.core.errors import ConfigError, UserError
from rfsim.core.rng import trial_rng
from reference.channels_paths import apply_paths_reference

C = 299792458.0
FC, FS, N = 915e6, 4e6, 400


def iso(p):
    return Antenna(position_m=p, pattern=Isotropic(), polarization="circular")


def friis(a, b, fc=FC):
    """Free-space amplitude gain with carrier phase between two isotropic circular antennas."""
    d = float(np.linalg.norm(np.subtract(b.position_m, a.position_m)))
    return C / fc / (4 * math.pi * d) * np.exp(-2j * math.pi * ((fc * d / C) % 1.0))


class Const:
    """A reflector re-radiating a fixed factor r (scalar, or (n,) samples: modulating)."""

    def __init__(self, antenna, r):
        self.antenna, self.r = antenna, r
        self.seen = None

    def reflect(self, incident):
        self.seen = incident
        return self

    scatters = True

    @property
    def constant_reradiation(self):
        return None if np.ndim(self.r) else complex(self.r)

    def reradiation(self, n):
        return np.broadcast_to(np.asarray(self.r, complex), (n,)).copy()


def _cw(antenna, p_w=1.0, fc=FC, t0=0.0, n=N):
    return FixedEmitter(antenna, Segment(t0, FS, fc, np.full(n, math.sqrt(p_w), complex)))


def test_superposition_matches_free_space_closed_form():
    e, t, rx = iso([0, 0, 1]), iso([1.5, 0.3, 1]), iso([0.4, 2.0, 1.2])
    r_mod = np.where((np.arange(N) // 25) % 2 == 0, 0.3 + 0.1j, -0.2)
    x = np.full(N, math.sqrt(2.0), complex)
    for r in (0.7 - 0.2j, r_mod):
        refl = Const(t, r)
        out = propagate([_cw(e, 2.0)], [refl], [AntennaPort(rx)], LinkTable(Channel(Scene())), t0_s=0.0,
                        fs_hz=FS, n_samples=N, propagation="narrowband")
        inc = friis(e, t) * x
        np.testing.assert_allclose(refl.seen.samples, inc, rtol=1e-12)
        want = friis(e, rx) * x + friis(t, rx) * (r * inc)
        np.testing.assert_allclose(out.inputs[0].samples, want, rtol=1e-12)
        assert out.dropped == []


def test_carrier_offset_shifted_inside_band_and_dropped_outside():
    e1, e2, e3, rx = iso([0, 0, 1]), iso([0, 1, 1]), iso([0, -1, 1]), iso([2, 0, 1])
    d_in, d_out = 250e3, 2.5e6  # |Δ| < fs/2 = 2 MHz, and outside it
    t0 = 1.234e-3
    ems = [_cw(e1, 1.0, FC, t0), _cw(e2, 0.5, FC + d_in, t0), _cw(e3, 0.5, FC + d_out, t0)]
    out = propagate(ems, [], [AntennaPort(rx)], LinkTable(Channel(Scene())), t0_s=t0, fs_hz=FS, n_samples=N,
                    propagation="narrowband")
    t = t0 + np.arange(N) / FS
    want = friis(e1, rx) * 1.0 + friis(e2, rx, FC + d_in) * math.sqrt(0.5) * np.exp(2j * math.pi * d_in * t)
    np.testing.assert_allclose(out.inputs[0].samples, want, rtol=1e-9)
    assert out.dropped == [(2, "receiver", 0, pytest.approx(d_out))]


def test_exact_propagation_is_the_fractional_delay_of_each_path():
    e, rx = iso([0, 0, 1]), iso([9.0, 0, 1])
    x = np.exp(2j * np.pi * 0.01 * np.arange(N) ** 1.5)
    out = propagate([FixedEmitter(e, Segment(0.0, FS, FC, x))], [], [AntennaPort(rx)],
                    LinkTable(Channel(Scene())), t0_s=0.0, fs_hz=FS, n_samples=N, propagation="exact")
    d = 9.0
    ref = apply_paths_reference(x, fs_hz=FS, fc_hz=FC, paths=PathSet([C / FC / (4 * math.pi * d)], [d / C]))
    np.testing.assert_allclose(out.inputs[0].samples, ref, rtol=1e-9, atol=1e-12)


def test_receiver_noise_power():
    n = 40000
    e, rx = iso([0, 0, 1]), iso([1, 0, 1])
    p_n = 1e-9
    out = propagate([_cw(e, 1.0, n=n)], [], [AntennaPort(rx, p_n)], LinkTable(Channel(Scene())), t0_s=0.0,
                    fs_hz=FS, n_samples=n, rng=np.random.default_rng(5), propagation="narrowband")
    noise = out.inputs[0].samples - friis(e, rx)
    # |n|² is exponential with mean P: the sample mean has relative std 1/√n = 0.5 %; 5σ
    assert abs(np.mean(np.abs(noise) ** 2) / p_n - 1.0) < 5 / math.sqrt(n)
    assert abs(np.mean(noise.real ** 2) / (p_n / 2) - 1.0) < 5 * math.sqrt(2 / n)


def test_batch_rows_equal_single_steps():
    e, t, rx = iso([0, 0, 1]), iso([1, 1, 1]), iso([2, 0, 1])
    xb = np.stack([np.full(N, 1.0 + 0j), np.linspace(0.5, 1.5, N) + 0j, np.exp(1j * np.arange(N) / 7)])
    r = np.where(np.arange(N) % 40 < 20, 0.4, -0.4)
    batch = propagate([FixedEmitter(e, Segment(0.0, FS, FC, xb))], [Const(t, r)], [AntennaPort(rx)],
                      LinkTable(Channel(Scene())), t0_s=0.0, fs_hz=FS, n_samples=N)
    for b in range(3):
        one = propagate([FixedEmitter(e, Segment(0.0, FS, FC, xb[b]))], [Const(t, r)], [AntennaPort(rx)],
                        LinkTable(Channel(Scene())), t0_s=0.0, fs_hz=FS, n_samples=N)
        np.testing.assert_allclose(batch.inputs[0].samples[b], one.inputs[0].samples, rtol=1e-13)


def test_exciter_eirp_schedule_and_phase_noise():
    ant = Antenna(position_m=[0, 0, 1], pattern=Isotropic())
    ex = Exciter(ExciterConfig(eirp_dbm=30.0, schedule_s=(1e-4, 2e-4)), ant)
    assert ex.power_w == pytest.approx(1.0)  # isotropic: conducted = EIRP
    assert ex.emit(t0_s=0.0, fs_hz=FS, n_samples=100) is None  # off before 100 µs
    seg = ex.emit(t0_s=0.9e-4, fs_hz=FS, n_samples=400)
    on = 0.9e-4 + np.arange(400) / FS
    np.testing.assert_array_equal(np.abs(seg.samples) > 0, (on >= 1e-4) & (on < 2e-4))
    # Wiener phase noise: Var[φ(t+T) − φ(t)] = 2π·Δν·T
    lw, n = 1e3, 200000
    pn = Exciter(ExciterConfig(eirp_dbm=30.0, linewidth_hz=lw), ant, rng=np.random.default_rng(3))
    ph = np.unwrap(np.angle(pn.emit(t0_s=0.0, fs_hz=FS, n_samples=n).samples))
    lag = 400
    dphi = ph[lag:] - ph[:-lag]
    want = 2 * math.pi * lw * lag / FS
    # independent blocks: n/lag = 500 of them; the variance estimate has rel. std √(2/500) = 6 %
    blocks = dphi[::lag]
    assert abs(np.var(blocks) / want - 1.0) < 4 * math.sqrt(2 / blocks.size)


def test_tag_powered_only_by_an_exciter_answers_nothing():
    e = vertical_dipole([0, 0, 1])
    tag = PassiveTag(TagConfig(), vertical_dipole([0.5, 0, 1]), rng=trial_rng(1, 2))
    ex = Exciter(ExciterConfig(), e)
    out = propagate([ex], [tag], [], LinkTable(Channel(Scene())), t0_s=0.0, fs_hz=FS, n_samples=2000)
    resp = out.reflections[0]
    assert resp.powered and resp.gamma is None and resp.reply is None
    assert resp.reason == "decode error"  # CW only: no PIE frame to decode
    assert resp.incident_power_dbm > TagConfig().threshold_incident_dbm


def test_st_frame_on_its_own_schedule_is_heard_by_a_second_st():
    fs, blf, n = 4e6, 160e3, 4000
    bits = np.array([1, 0, 1, 1, 0, 0, 1, 0, 1, 1, 1, 0, 0, 0, 1, 0], np.uint8)
    cfg1 = SenseATagConfig(n_antennas=1, technique="single")
    tx_st = SenseATag(cfg1, [vertical_dipole([1.0, 0, 1])], rng=trial_rng(4, 1), fs_hz=fs)
    end = tx_st.send_frame(bits, start_s=100e-6, blf_hz=blf, m=1)
    assert end < n / fs
    rx_st = SenseATag(cfg1, [vertical_dipole([1.25, 0.1, 1])], rng=trial_rng(4, 2), fs_hz=fs)
    passive = PassiveTag(TagConfig(), vertical_dipole([0.7, 0.5, 1]), rng=trial_rng(4, 3))
    exciter = Exciter(ExciterConfig(), vertical_dipole([0, 0, 1]))
    out = propagate([exciter], [tx_st, passive], [AntennaPort(a) for a in rx_st.antennas],
                    LinkTable(Channel(Scene())), t0_s=0.0, fs_hz=fs, n_samples=n, bandwidth_hz=2 * blf)
    assert out.reflections[0].gamma is not None  # the transmitting ST modulates
    assert out.reflections[1].gamma is None  # the passive tag heard no command
    rec = make_receiver(cfg1, fs_hz=fs, blf_hz=blf, m=1, trext=False).receive(
        out.inputs[0].samples, n_bits=16, crc=False)
    assert rec.detected
    np.testing.assert_array_equal(rec.bits, bits)


# ----------------------------------------------------------------------------- bad input


class NoLinks:
    def paths(self, tx, rx, *, fc_hz, t_s):
        return None


@pytest.mark.parametrize("case, key", [
    ("empty", "air.emitters"),
    ("same position", "reflector[0].position_m"),
    ("no link", "air.links"),
])
def test_bad_input_is_a_one_line_user_error(case, key):
    e = iso([0, 0, 1])
    kw = dict(t0_s=0.0, fs_hz=FS, n_samples=N)
    with pytest.raises(ConfigError) as err:
        if case == "empty":
            propagate([], [], [AntennaPort(iso([1, 0, 1]))], LinkTable(Channel(Scene())), **kw)
        elif case == "same position":
            propagate([_cw(e)], [Const(iso([0, 0, 1]), 0.5)], [], LinkTable(Channel(Scene())), **kw)
        else:
            propagate([_cw(e)], [Const(iso([1, 0, 1]), 0.5)], [], NoLinks(), **kw)
    assert err.value.key == key
    assert isinstance(err.value, UserError) and err.value.exit_code == 2
    assert "\n" not in str(err.value)


class HeldTable(LinkTable):
    """A LinkTable that also offers the held narrowband constants of its links (as the
    engine's round links do), so that a reflector group can take its shortcut."""

    def held_constants(self, antenna, others, *, fc_hz, bandwidth_hz, propagation, inbound):
        out = []
        for a in others:
            p = self.paths(a, antenna, fc_hz=fc_hz, t_s=0.0) if inbound else self.paths(antenna, a, fc_hz=fc_hz,
                                                                                         t_s=0.0)
            c = p.narrowband_constant(fc_hz, bandwidth_hz, propagation)
            if c is None:
                return None
            out.append(c)
        return out


class OwnPort(AntennaPort):
    """A receiver on the emitter's antenna with a fixed TX→RX leakage (a reader's port)."""

    def coupling(self, emitter):
        return (0.01 - 0.002j) if emitter.antenna is self.antenna else None


@pytest.mark.parametrize("links_kind", ["table", "held"])
def test_tag_population_equals_its_tags_one_by_one(links_kind):
    # A Query, then QueryReps and an ACK for nobody, from a reader to 9 passive tags (ASK and
    # PSK, some too far to power up), received with noise: the tags as one population
    # (rfsim.devices.tag_population) and the same tags one by one give the same receiver input, bit
    # for bit, the same reflections and tag states. With held constants the population
    # answers its quiet tags at once (AirResult.groups); without, every tag reflects.
    from rfsim.devices.reader import Reader, ReaderConfig
    from rfsim.gen2.commands import ACK, Query, QueryRep

    radii = [1.0, 1.3, 1.7, 2.2, 2.8, 3.5, 9.0, 12.0, 1.5]
    runs = []
    for grouped in (False, True):
        ra = iso([0.0, 0.0, 1.0])
        reader = Reader(ReaderConfig(), [ra], rng=trial_rng(91, 0))
        tags = [PassiveTag(TagConfig(epc_hex=f"{k + 1:024X}", modulation="PSK" if k % 4 == 3 else "ASK"),
                           iso([r * math.cos(k), r * math.sin(k), 1.0]), rng=trial_rng(91, 1, k))
                for k, r in enumerate(radii)]
        refl = [PassiveTag.population(tags)] if grouped else tags
        table = (HeldTable if links_kind == "held" else LinkTable)(Channel(Scene()), rng=trial_rng(91, 2))
        port = OwnPort(ra, noise_power_w=1e-13)
        noise = trial_rng(91, 3)
        lk = reader.link
        out, t = [], 0.0
        for cmd in [Query(dr=lk.dr, m=lk.m, q=2)] + [QueryRep()] * 3 + [ACK(0x1234), QueryRep()]:
            tx = reader.transmit(cmd, t0_s=t, cw_after_s=4e-4)
            air = propagate([FixedEmitter(ra, tx)], refl, [port], table, t0_s=t, fs_hz=tx.fs_hz,
                            n_samples=tx.samples.size, rng=noise, bandwidth_hz=2 * lk.blf_hz)
            out.append((air.inputs[0].samples.copy(), [(r.powered, r.reason, r.incident_power_dbm, r.gamma_rest,
                                                        None if r.gamma is None else r.gamma.tobytes())
                                                       for r in air.reflections],
                        [inc.samples.tobytes() for inc in air.incident], len(air.groups)))
            t += tx.samples.size / tx.fs_hz + 1e-4
        runs.append((out, [(tg.state.state, tg.state.slot, tg.state.t_s, dict(tg.state.inventoried)) for tg in tags]))
    (plain, plain_states), (grouped, grouped_states) = runs
    for a, b in zip(plain, grouped):
        np.testing.assert_array_equal(a[0], b[0])
        assert a[1:3] == b[1:3]
    assert plain_states == grouped_states
    shortcuts = sum(b[3] for b in grouped)
    assert shortcuts == (6 if links_kind == "held" else 0), shortcuts  # the Query too
    assert sum(a[1][j][0] for a in plain for j in range(len(radii))) >= 6 * 5  # powered tags present


def test_moving_reflector_phase_refers_to_the_step_start():
    """A reflector moving at constant velocity, seen in a step that starts at t0 = 0.37 s,
    gives the receiver what a reflector starting at the t0 position gives in a step at t0 = 0:
    the free-space physics does not depend on the clock's origin. Expected values: the
    written-out Friis links of the t0 geometry, the reflected part advanced by the Doppler
    e^{j2π·f_D·n/fs} with f_D = −(2/λ)·v (emitter and receiver both behind the tag on its line
    of motion)."""
    e, rx = iso([0.0, 0.0, 1.0]), iso([-0.5, 0.0, 1.0])
    v = np.array([3.0, 0.0, 0.0])  # m/s, radially away from the emitter and the receiver
    t0 = 0.37
    p0 = np.array([1.2, 0.0, 1.0])
    moving, shifted = iso(list(p0)), iso(list(p0 + v * t0))
    outs = []
    for ant, start in ((moving, t0), (shifted, 0.0)):
        refl = Const(ant, 0.5 + 0.0j)
        links = LinkTable(Channel(Scene()), motions=[AntennaMotion(ant, v)])
        out = propagate([_cw(e, 1.0, t0=start)], [refl], [AntennaPort(rx)], links, t0_s=start, fs_hz=FS,
                        n_samples=N, propagation="narrowband")
        outs.append(out.inputs[0].samples)
    np.testing.assert_allclose(outs[0], outs[1], rtol=1e-9, atol=0.0)
    at_t0 = iso(list(p0 + v * t0))
    f_d = -2.0 * FC / C * 3.0
    want = friis(e, rx) + 0.5 * friis(e, at_t0) * friis(at_t0, rx) * np.exp(2j * math.pi * f_d * np.arange(N) / FS)
    np.testing.assert_allclose(outs[0], want, rtol=2e-3)


def test_position_check_remembers_a_reflector_tuple_only_with_its_emitters():
    # a tuple of reflector antennas checked with one emitter is not checked again with it;
    # with another emitter at one of its positions it is checked, and refused
    from rfsim.air.cache import AirCache
    from rfsim.air.links import check_positions

    ants = (iso([1, 0, 1]), iso([2, 0, 1]))
    far, on_top = _cw(iso([0, 0, 1])), _cw(iso([2, 0, 1]))
    cache = AirCache()
    check_positions([far], ants, [], cache)
    assert cache.checked_tuples[id(ants)].reflectors is ants
    check_positions([far], ants, [], cache)
    with pytest.raises(ConfigError) as err:
        check_positions([on_top], ants, [], cache)
    assert err.value.key == "reflector[1].position_m"


@pytest.mark.parametrize("modulating", [False, True])
def test_skip_unmodulated_draws_the_noise_but_forms_no_input(modulating):
    # two noisy receivers; a constant reflector: no inputs, each generator left exactly as the
    # full step leaves it (2·N normals per noisy receiver); a modulating one: the full step
    e, t = iso([0, 0, 1]), iso([1.5, 0.3, 1])
    r = np.where((np.arange(N) // 25) % 2 == 0, 0.3 + 0.1j, -0.2) if modulating else 0.7 - 0.2j
    outs = []
    for skip in (False, True):
        g = np.random.default_rng(42)
        ports = [AntennaPort(iso([0.4, 2.0, 1.2]), 1e-12), AntennaPort(iso([-1.0, 1.0, 1.0]), 2e-12)]
        out = propagate([_cw(e)], [Const(t, r)], ports, LinkTable(Channel(Scene())), t0_s=0.0, fs_hz=FS,
                        n_samples=N, rng=g, skip_unmodulated=skip)
        outs.append((out, g.standard_normal(3).tolist()))
    (full, after_full), (skipped, after_skip) = outs
    assert after_skip == after_full
    if modulating:
        for a, b in zip(full.inputs, skipped.inputs):
            assert np.array_equal(a.samples, b.samples)
    else:
        assert skipped.inputs == [None, None] and skipped.outputs == [None, None]
        assert all(seg is not None for seg in full.inputs)

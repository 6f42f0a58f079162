"""Antenna structural-mode scattering of the passive tag: r(t) = A_s − Γ(t).

Physics (rfsim.devices.tag module docstring step 6; Nikitin, Rao & Lam, IEEE AP Magazine 48(6),
2006): the tag scatters (A_s − Γ(t))·incident. Expectations derived from that equation:

* the re-radiation factor takes exactly the two values A_s − Γ_A, A_s − Γ_B (and A_s − Γ_A
  throughout without a reply);
* the modulated part r_B − r_A = Γ_A − Γ_B does not depend on A_s, so the reader's decoded
  bits, RSSI and phase are the same for A_s = 0 and A_s = 1 (same seeds: the only change is
  a constant backscatter offset, which the receiver's least-squares offset removes exactly);
* at a listener the two backscatter components differ by exactly ΔA_s·g_TS·incident over the
  whole segment (narrowband free-space link g_TS).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rfsim.channels import Antenna, Channel, HalfWaveDipole, Isotropic, Patch, Scene
from rfsim.channels.paths import apply_paths
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.devices.tag import PassiveTag, TagConfig, TagResponse
from rfsim.protocols.bistatic import listen_exchange
from rfsim.protocols.engine import run_exchange
from rfsim.core.errors import ConfigError
from rfsim.gen2.commands import Query
from rfsim.gen2.link import t1
from rfsim.core.rng import trial_rng

READER_CFG = ReaderConfig(link_profile="pass-miller2-48k", fs_hz=1e6, hopping=False, fixed_channel=26,
                          noise_figure_db=0.0)


def _devices(a_s: float, modulation: str = "ASK"):
    ra = Antenna(position_m=(0.0, 0.0, 1.0), pattern=Patch(6.0, 70.0))
    reader = Reader(READER_CFG, [ra], rng=trial_rng(4, 0))
    ta = Antenna(position_m=(2.0, 0.0, 1.0), orientation=(math.pi, 0, 0), pattern=HalfWaveDipole())
    tag = PassiveTag(TagConfig(modulation=modulation, structural_mode=a_s), ta, rng=trial_rng(4, 1))
    return reader, tag


def _query(reader):
    lk = reader.link
    return Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0)


def test_config_default_and_range():
    assert TagConfig().structural_mode == 1.0  # minimum-scattering antenna
    for bad in (-0.1, 1.5):
        with pytest.raises(ConfigError):
            TagConfig(structural_mode=bad)


@pytest.mark.parametrize("modulation", ["ASK", "PSK"])
@pytest.mark.parametrize("a_s", [0.0, 0.6, 1.0])
def test_reradiation_takes_the_two_states(a_s, modulation):
    reader, tag = _devices(a_s, modulation)
    ex = listen_exchange(reader, [tag], Channel(Scene()), _query(reader), [], t_s=0.0, rng=None,
                         cw_after_s=t1(reader.link).max_s + reader.link.reply_duration_s(16))
    r = ex.responses[0]
    assert r.reply is not None and r.structural_mode == a_s
    n = ex.tx.samples.size
    rr = r.reradiation(n)
    assert rr.shape == (n,) and rr.dtype == np.complex128
    rs = tag.reflection_states
    np.testing.assert_array_equal(rr, a_s - r.reflection(n))
    assert set(np.unique(rr)) == {a_s - rs.gamma_a, a_s - rs.gamma_b}
    # the modulated part does not depend on A_s
    assert (a_s - rs.gamma_b) - (a_s - rs.gamma_a) == pytest.approx(rs.gamma_a - rs.gamma_b, abs=1e-15)


def test_silent_response_scatters_its_rest_state():
    r = TagResponse(powered=True, command=None, reply=None, gamma=None, reply_start_s=None, blf_hz=None,
                    reason="no reply", incident_power_dbm=0.0, gamma_rest=0.25 + 0j, structural_mode=1.0 + 0j)
    np.testing.assert_array_equal(r.reradiation(5), np.full(5, 0.75 + 0j))
    assert r.scatters
    # A_s = Γ_A: the re-radiated field is identically zero (the engine skips it)
    assert not dataclasses.replace(r, structural_mode=0.25 + 0j).scatters
    # a bare response (structural_mode left at 0) re-radiates −Γ_A
    assert TagResponse(powered=False, command=None, reply=None, gamma=None, reply_start_s=None, blf_hz=None,
                       reason="not powered", incident_power_dbm=0.0, gamma_rest=0.5j).reradiation(1)[0] == -0.5j


def test_reader_measurements_do_not_depend_on_structural_mode():
    """Same seeds, A_s = 0 vs 1: the backscatter changes by the constant A_s·incident (a CW
    term), which the receiver's offset estimate removes; bits, RSSI and phase agree to
    rounding (1e-9 rad, 1e-9 dB)."""
    reads = []
    for a_s in (0.0, 1.0):
        reader, tag = _devices(a_s)
        ex = run_exchange(reader, [tag], Channel(Scene()), _query(reader), t_s=0.0, rng=trial_rng(4, 2),
                          reply_bits=16, expect_crc=False)
        assert ex.failure_reason == "" and ex.read.success
        reads.append(ex.read)
    a, b = reads
    np.testing.assert_array_equal(a.bits, b.bits)
    assert abs(a.rssi_dbm - b.rssi_dbm) < 1e-9
    assert abs(np.angle(np.exp(1j * (a.phase_rad - b.phase_rad)))) < 1e-9


def test_listener_sees_the_structural_term():
    """backscatter(A_s = 1) − backscatter(A_s = 0) = g_TS·incident at every sample."""
    lis = [Antenna(position_m=(2.3, 0.25, 1.0), pattern=Isotropic())]
    out = []
    for a_s in (0.0, 1.0):
        reader, tag = _devices(a_s)
        ch = Channel(Scene())
        ex = listen_exchange(reader, [tag], ch, _query(reader), lis, t_s=0.0, rng=None,
                             cw_after_s=t1(reader.link).max_s + reader.link.reply_duration_s(16))
        out.append(ex)
    x, fs, fc = out[0].tx.samples, out[0].tx.fs_hz, out[0].tx.fc_hz
    inc = apply_paths(x, fs_hz=fs, fc_hz=fc, paths=ch.link(reader.antennas[0], tag.antenna, fc_hz=fc),
                      method="narrowband")
    g_ts = ch.link(tag.antenna, lis[0], fc_hz=fc).narrowband_gain(fc)
    np.testing.assert_array_equal(out[0].responses[0].gamma, out[1].responses[0].gamma)
    diff = out[1].backscatter[0, 0] - out[0].backscatter[0, 0]
    np.testing.assert_allclose(diff, g_ts * inc, rtol=1e-12, atol=1e-18)
    assert np.max(np.abs(diff)) > 0

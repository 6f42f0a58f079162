"""Reader + tag end to end through the engine (issue 4, items 5 and 7).

* every named link profile × M ∈ {1, 2, 4, 8} reads the EPC at 3 m over the link scenario's
  default channel (APDP + concrete floor);
* the read range in free space equals the Friis forward-link prediction within 2 %;
* in free space the reported phase is 4πd/λ − arg(Γ_A − Γ_B) (mod 2π) within 0.01 rad (the
  tag re-radiates A_s − Γ),
  the RSSI follows the radar equation (slope −40 dB/decade within 0.2 dB/decade), and a tag
  moving radially at 1 m/s gives the Doppler 2v/λ within 1 %.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rfsim.channels import Antenna, Channel, HalfWaveDipole, Patch, Scene
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.devices.tag import PassiveTag, TagConfig
from rfsim.protocols.engine import singulate
from rfsim.gen2.commands import Query
from rfsim.gen2.link import PROFILES, LinkProfile
from rfsim.core.rng import trial_rng
from rfsim.core.units import C_M_S
from rfsim.scenarios import link as link_scenario

PTX_DBM = 30.0
PATCH_GAIN_DBI = 6.0
#: Half-wave dipole broadside directivity 1.6409 (2.15 dBi), Balanis "Antenna Theory" §4.6.
DIPOLE_GAIN = 1.6409
#: Circular reader antenna vs linear tag: half the power (polarization loss factor).
PLF_CIRCULAR_LINEAR = 0.5
HEIGHT_M = 1.0
READER_ANTENNA = Antenna(position_m=(0.0, 0.0, HEIGHT_M), orientation=(0.0, 0.0, 0.0),
                         pattern=Patch(PATCH_GAIN_DBI, 70.0), polarization="circular")


def tag_at(x_m: float) -> Antenna:
    return Antenna(position_m=(x_m, 0.0, HEIGHT_M), orientation=(math.pi, 0.0, 0.0),
                   pattern=HalfWaveDipole(), polarization="linear")


def query_for(link: LinkProfile, **kw) -> Query:
    return Query(dr=link.dr, m=link.m, trext=link.trext, **{"q": 0, **kw})


def read_once(reader, tag, channel, *, seed, t_s=0.0, motions=None, **qkw):
    return singulate(reader, [tag], channel, t_s=t_s, rng=trial_rng(11, seed),
                     query=query_for(reader.link, **qkw), motions=motions)


def epc_read(exchanges):
    last = exchanges[-1]
    return last if last.command == "ACK" and last.success else None


# ----------------------------------------------------------------------------- item 5


CASES = [(name, m) for name in PROFILES for m in (1, 2, 4, 8)]


@pytest.mark.parametrize("name, m", CASES)
def test_every_profile_and_m_reads_the_epc_at_3_m(name, m):
    link = dataclasses.replace(PROFILES[name], m=m)
    fs_hz = max(4e6, 8.0 * link.blf_hz)
    assert fs_hz >= 8.0 * link.blf_hz
    cfg = link_scenario.Config()
    reader = Reader(ReaderConfig(fs_hz=fs_hz), [link_scenario.reader_antenna(cfg.geometry)],
                    rng=trial_rng(11, 0), link=link)
    tag = PassiveTag(TagConfig(), link_scenario.tag_antenna(cfg.geometry, 3.0), rng=trial_rng(11, 1))
    channel = Channel(link_scenario.scene(cfg.channel))
    assert channel.scene.apdp is not None and channel.scene.surfaces  # the default channel
    ex = read_once(reader, tag, channel, seed=2)
    assert [e.command for e in ex] == ["Query", "ACK"]
    assert [e.failure_reason for e in ex] == ["", ""]
    assert ex[1].read.success and ex[1].read.bits.size == 128
    np.testing.assert_array_equal(ex[1].read.bits[16:112], tag.state.epc)


def friis_read_range_m(fc_hz: float, tag_cfg: TagConfig) -> float:
    """d_max = λ/(4π)·√(P_tx·G_r·G_t·PLF·τ / P_sens) (forward link, free space)."""
    lam = C_M_S / fc_hz
    p_tx = 10 ** ((PTX_DBM - 30) / 10)
    p_sens = 10 ** ((tag_cfg.sensitivity_dbm - 30) / 10)
    g_r = 10 ** (PATCH_GAIN_DBI / 10)
    return lam / (4 * math.pi) * math.sqrt(p_tx * g_r * DIPOLE_GAIN * PLF_CIRCULAR_LINEAR * tag_cfg.tau / p_sens)


def test_read_range_equals_friis_prediction():
    # Free space, NF 0 dB: at the range limit (≈ 6.6 m) the reply arrives ≈ 45 dB above the
    # noise per sample, so reception never limits; the tag's power-up does.
    tag_cfg = TagConfig()
    reader = Reader(ReaderConfig(hopping=False, noise_figure_db=0.0, ptx_dbm=PTX_DBM), [READER_ANTENNA],
                    rng=trial_rng(11, 0))
    fc = reader.fc_hz(0.0)
    predicted = friis_read_range_m(fc, tag_cfg)

    def reads(d_m, k):
        tag = PassiveTag(tag_cfg, tag_at(d_m), rng=trial_rng(11, 100 + k))
        return epc_read(read_once(reader, tag, Channel(Scene()), seed=200 + k))

    lo, hi = 1.0, 20.0
    assert reads(lo, 0) is not None and reads(hi, 1) is None
    for k in range(14):  # bracket to 19 m / 2^14 ≈ 1.2 mm
        mid = 0.5 * (lo + hi)
        if reads(mid, k + 2) is not None:
            lo = mid
        else:
            hi = mid
    assert abs(lo / predicted - 1.0) < 0.02
    # forward-link limited: the last successful read still had a strong reply
    assert reads(lo, 99).read.snr_db > 20.0


# ----------------------------------------------------------------------------- item 7


def free_space_epc(d_m: float, *, seed: int, link: LinkProfile | None = None, motion=None,
                   sensitivity_dbm: float = -25.0):
    reader = Reader(ReaderConfig(hopping=False, noise_figure_db=0.0, ptx_dbm=PTX_DBM), [READER_ANTENNA],
                    rng=trial_rng(11, 0), link=link)
    tag = PassiveTag(TagConfig(sensitivity_dbm=sensitivity_dbm), tag_at(d_m), rng=trial_rng(11, seed))
    ex = read_once(reader, tag, Channel(Scene()), seed=seed + 1000,
                   motions=None if motion is None else [motion])
    assert [e.failure_reason for e in ex] == ["", ""]
    return ex[1], tag


DISTANCES_M = (0.5, 0.7, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 7.0, 10.0)


def test_phase_rssi_against_free_space_physics():
    """Reported phase and RSSI vs the monostatic radar equation.

    The tag re-radiates r = A_s − Γ (structural mode A_s, rfsim.devices.tag; Nikitin, Rao & Lam
    2006): r_B for s = +1, r_A for s = −1, so r = (r_A + r_B)/2 + s·(r_B − r_A)/2 with
    r_B − r_A = (A_s − Γ_B) − (A_s − Γ_A) = Γ_A − Γ_B (A_s cancels; the static part is
    removed with the leakage). h = √P_tx·a²·e^{−j4πd/λ}·(Γ_A − Γ_B)/2 with
    a = (λ/4πd)·√(G_r·G_t·PLF) real and positive (Friis LoS); the reader refers the phase
    to its own carrier and reports (−arg h) mod 2π, so the fixed device offset is
    −arg(Γ_A − Γ_B) (π away from the −arg(Γ_B − Γ_A) of a tag re-radiating Γ alone).
    RSSI = |h|² = P_tx·a⁴·|Γ_A − Γ_B|²/4 (independent of A_s). Tolerance: 0.01 rad; at NF
    0 dB the worst case (10 m) has SNR ≈ 37 dB per sample over ≈ 5000 samples, phase std
    ≈ 2e−4 rad.
    """
    phases, rssi, pred_phase, pred_rssi = [], [], [], []
    for k, d in enumerate(DISTANCES_M):
        ex, tag = free_space_epc(d, seed=k)
        fc = ex.fc_hz
        lam = C_M_S / fc
        # modulated re-radiation r_B − r_A = (A_s − Γ_B) − (A_s − Γ_A) = Γ_A − Γ_B
        dg = tag.reflection_states.gamma_a - tag.reflection_states.gamma_b
        a2 = (lam / (4 * math.pi * d)) ** 2 * 10 ** (PATCH_GAIN_DBI / 10) * DIPOLE_GAIN * PLF_CIRCULAR_LINEAR
        phases.append(ex.read.phase_rad)
        pred_phase.append((4 * math.pi * d / lam - np.angle(dg)) % (2 * math.pi))
        rssi.append(ex.read.rssi_dbm)
        pred_rssi.append(10 * math.log10(10 ** ((PTX_DBM - 30) / 10) * a2**2 * abs(dg) ** 2 / 4) + 30)
    err = np.angle(np.exp(1j * (np.array(phases) - np.array(pred_phase))))
    assert np.max(np.abs(err)) < 0.01, err
    # the residual device offset −arg(Γ_A − Γ_B) is ≈ 2.8 rad for the default chip (far from 0)
    assert np.max(np.abs(np.array(rssi) - np.array(pred_rssi))) < 0.05
    slope = np.polyfit(np.log10(DISTANCES_M), rssi, 1)[0]
    assert abs(slope - (-40.0)) < 0.2, slope


@pytest.mark.parametrize("v_m_s", [1.0, -1.0])
def test_doppler_of_a_radially_moving_tag(v_m_s):
    """A tag at 3 m moving radially (+x away from the reader) at |v| = 1 m/s: f_D = −2v/λ
    (positive when approaching, the reader's convention). FM0 at 40 kHz with Miller-4:
    a 13.6 ms EPC reply (phase drift 0.08 cycle, inside the decoder's 1/8 cycle); the
    resolution at its ≈ 100 dB energy-to-noise ratio is far below the 1 % = 0.06 Hz tolerance.
    """
    link = dataclasses.replace(PROFILES["fm0-40k"], m=4)
    ex, _ = free_space_epc(3.0, seed=50, link=link, motion=np.array([v_m_s, 0.0, 0.0]))
    expected = -2.0 * v_m_s * ex.fc_hz / C_M_S
    assert abs(ex.read.doppler_hz / expected - 1.0) < 0.01, (ex.read.doppler_hz, expected)

"""rfsim.devices.st_pair, st_detector and pass_tag: the dual-antenna ST's pair coupling, its
techniques over many positions, the per-cell probabilities, the detector built from its config
and the tag of each states model — against values derived by hand."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from rfsim.channels.antennas import vertical_dipole
from rfsim.devices import pass_tag, st_pair
from rfsim.devices.sense_a_tag import make_receiver
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.st_analytic import coupling_matrix
from rfsim.devices.st_detector import DetectorConfig, make_detector, make_st_receiver
from rfsim.devices.tag_config import TagConfig


def test_couple_ports_mixes_by_the_coupling_coefficient():
    # Z11 = 73.1 + j42.5 Ω, Z12 = 40.8 − j28.3 Ω, conjugate load: c = Z12/(2·Re Z11) = 0.279070 − j0.193570;
    # one port driven (x = (1, 0)): y = (1, −c)/(1 − c²), so y2/y1 = −c, on gains and on waveforms
    c = complex(40.8, -28.3) / 146.2
    assert c == pytest.approx(complex(0.279070, -0.193570), abs=1e-6)
    mix = coupling_matrix()
    y = st_pair.couple_ports(mix, np.array([[1.0, 0.0]], complex))
    assert y[0, 1] / y[0, 0] == pytest.approx(-c, rel=1e-12)
    assert y[0, 0] == pytest.approx(1.0 / (1.0 - c * c), rel=1e-12)
    w = st_pair.couple_ports(mix, np.array([[[1.0, 2.0], [0.0, 0.0]]], complex))  # (N, 2, n)
    np.testing.assert_allclose(w[0, :, 1], 2.0 * y[0], rtol=1e-15)
    with pytest.raises(ValueError):
        st_pair.couple_ports(mix, np.zeros((3, 3)))


def test_technique_rows_closed_forms_for_a_hand_solved_pair():
    """Linear detector (gain 1), threshold 5 mV, CW 0.5 V at both antennas; backscatter states
    0.010 V and 0.004 V in phase with the CW at SA1, at 90° to it at SA2. SA1: |A1 − A2| =
    0.006 V (detected); SA2: sqrt(0.25 + 1e-4) − sqrt(0.25 + 1.6e-5) = 8.4e-5 V (cancelled, yet
    detectable: synchronised |b1 − b2| = 0.006 V); the RF sum: |1.01 + 0.01j| − |1.004 + 0.004j|
    = 0.0060415 V. So single is cancelled, combination and selection are not. The tag did not
    reply (rn16 None): nothing decoded, every sample-level difference 0."""
    st = SenseATagConfig()
    rx = make_st_receiver(DetectorConfig(law="linear"), st, fs_hz=1e6, blf_hz=48e3, m=2, trext=True)
    cw = np.array([[0.5, 0.5]], complex)
    bs1 = np.array([[0.010, 0.010j]])
    bs2 = np.array([[0.004, 0.004j]])
    out = st_pair.technique_rows(rx, cw, bs1, bs2, SimpleNamespace(rn16=None), detector_gain=1.0,
                                 threshold_v=5e-3)
    assert out["closed_diff_sa1_v"][0] == pytest.approx(0.006, rel=1e-9)
    assert out["closed_diff_sa2_v"][0] == pytest.approx(math.sqrt(0.2501) - math.sqrt(0.250016), rel=1e-6)
    assert out["closed_diff_combined_v"][0] == pytest.approx(abs(1.01 + 0.01j) - abs(1.004 + 0.004j), rel=1e-9)
    assert out["sync_sa2_v"][0] == pytest.approx(0.006, rel=1e-9)
    assert out["theta_sa2_rad"][0] == pytest.approx(math.pi / 2)
    assert out["detectable"][0]
    assert out["closed_cancelled_single"][0]
    assert not out["closed_cancelled_combination"][0] and not out["closed_cancelled_selection"][0]
    for t in ("single", "combination", "selection", "stamp"):
        assert not out[f"detected_{t}"][0] and out[f"cancelled_{t}"][0]
    assert out["diff_sa1_v"][0] == out["diff_sa2_v"][0] == out["diff_combined_v"][0] == 0.0


def test_cell_probabilities_are_clopper_pearson_per_cell():
    # cell 0: 1 of 2 cancelled → [1 − sqrt(0.975), sqrt(0.975)] = [0.012579, 0.987421];
    # cell 1: 2 of 2 → [sqrt(0.025), 1] = [0.158114, 1]; the masked sample is left out
    flags = {"single": np.array([True, False, True, True, False])}
    cell = np.array([0, 0, 1, 1, 1])
    out = st_pair.cell_probabilities(flags, cell, 2, keep=np.array([True, True, True, True, False]))
    np.testing.assert_allclose(out["p_single"], [0.5, 1.0])
    np.testing.assert_allclose(out["ci_lo_single"], [1 - math.sqrt(0.975), math.sqrt(0.025)], rtol=1e-9)
    np.testing.assert_allclose(out["ci_hi_single"], [math.sqrt(0.975), 1.0], rtol=1e-9)
    np.testing.assert_array_equal(out["n_samples"], [2, 2])
    assert list(out) == ["p_single", "ci_lo_single", "ci_hi_single", "n_samples"]


def test_column_descriptions_name_antenna_and_technique():
    assert "SA1 (receive-only path P1)" in st_pair.describe_column("diff_sa1_v")
    assert "ASK-PSK stamp" in st_pair.describe_column("p_stamp")
    assert "p_selection" in st_pair.describe_column("ci_hi_selection")
    assert st_pair.describe_column("cell") is None
    assert [st_pair.column_unit(k) for k in ("a_r_sa2_v", "sa1_x_m", "theta_sa1_rad", "p_w", "p_single")] == \
        ["V", "m", "rad", "W", "1"]


def test_detector_from_its_config():
    # RC τ = 1/(2π·4·BLF) = 8.28931e-7 s at 48 kHz; the diode law's parameters pass through
    st = SenseATagConfig()
    det = make_detector(DetectorConfig(matching_gain=0.9, ideality=1.2, temperature_k=300.0), st, 48e3)
    assert det.law == "diode" and det.tau_s == pytest.approx(8.28931e-7, rel=1e-5)
    assert (det.matching_gain, det.ideality, det.temperature_k) == (0.9, 1.2, 300.0)
    lin = make_st_receiver(DetectorConfig(law="linear"), st, fs_hz=1e6, blf_hz=48e3, m=2, trext=True)
    assert lin == make_receiver(st, fs_hz=1e6, blf_hz=48e3, m=2, trext=True)
    assert lin.envelope_detector.gain == st.detector_gain


def test_tag_of_each_states_model():
    ant = vertical_dipole(np.zeros(3))
    rng = np.random.default_rng(1)
    pr = pass_tag.PassReplicationConfig()
    # 'source': re-radiated states r = −Γ_source with no structural term
    src = pass_tag.make_tag(TagConfig(), pass_tag.TagStatesConfig(model="source"), pr, ant, 915e6, rng)
    assert complex(src.reflection_states.gamma_a) == pytest.approx(0.70)
    assert complex(src.reflection_states.gamma_b) == pytest.approx(0.721)
    assert src.config.structural_mode == 0.0
    chip = pass_tag.make_tag(TagConfig(), pass_tag.TagStatesConfig(model="chip"), pr, ant, 915e6, rng)
    assert chip.config.structural_mode == TagConfig().structural_mode
    attrs = pass_tag.tag_attributes(pass_tag.TagStatesConfig(), pr, 915e6)
    assert list(attrs) == ["tag_states", "tag_antenna", "st_antenna"] and "UCODE" in attrs["tag_states"]

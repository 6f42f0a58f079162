"""The pieces of the exciter scenes: a frame sent on the device's own schedule
(rfsim.devices.own_schedule), the receive chain on many rows (rfsim.devices.st_rows), drawn
links (rfsim.scenes.links), the exciter scene (rfsim.scenes.exciter) and column tables
(rfsim.core.columns)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.core.columns import concat, unit_of
from rfsim.devices.own_schedule import FrameConfig, build_frame
from rfsim.devices.sense_a_tag import make_receiver
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.st_receiver import STAMP_S1, STAMP_S2
from rfsim.devices.st_rows import RowsChain
from rfsim.gen2.bits import int_to_bits
from rfsim.gen2.crc import append_crc16
from rfsim.scenes.exciter import NoiseConfig, exciter_antenna, room, uniform_disc
from rfsim.scenes.links import BatchAntenna, BatchLink, DrawnLinks, add_drawn_link
from rfsim.channels.antennas import vertical_dipole

FRAME = FrameConfig()  # 1 MS/s, BLF 48 kHz, Miller-2 with pilot


def _frame(word: int):
    return build_frame(append_crc16(int_to_bits(word, 16)), FRAME, stamp_cycles=0)


def test_frame_without_stamp_maps_levels_to_states_and_rests_absorbing():
    f = _frame(0x0A5C)
    lv, st = f.stamp.levels, f.stamp.states
    assert f.bits.size == 32 and f.n_samples == lv.size == st.size
    assert f.stamp.start == f.stamp.reply_start == math.ceil(FRAME.lead_cycles / FRAME.blf_hz * FRAME.fs_hz)
    assert np.all(st[lv > 0] == STAMP_S1) and np.all(st[lv < 0] == STAMP_S2)
    g = f.gamma(0.5 + 0.1j, -0.2j, math.pi)
    assert np.all(g[:f.stamp.start] == -0.2j) and np.all(g[f.end:] == -0.2j)  # rest state S2 = Γ_A
    inside = slice(f.stamp.start, f.end)
    assert np.array_equal(g[inside], np.where(lv[inside] > 0, 0.5 + 0.1j, -0.2j))


def test_stamp_frame_has_the_psk_state_at_psi():
    f = build_frame(np.zeros(10, np.uint8), FRAME, stamp_cycles=4)
    g = f.gamma(0.5, 0.0, math.pi / 2)
    psk = g[f.stamp.ask_stop:f.stamp.psk_stop]
    assert np.any(np.isclose(psk, 0.5j, rtol=0, atol=1e-15))  # S3 = Γ_B·e^{jψ}
    assert f.stamp.reply_start > f.stamp.psk_stop - 1


def test_rows_chain_decodes_which_frame_was_sent_and_measures_the_level_difference():
    """Clean inputs a·(1 ± 0.3) √W: the chain recovers each word; the settled detector levels
    differ by g·√(2·50 Ω)·0.6·a = 0.06 V (a = 0.01, g = 1)."""
    fa, fb = _frame(0x0A5C), _frame(0x1234)
    rx = make_receiver(SenseATagConfig(n_antennas=1, technique="single"), fs_hz=FRAME.fs_hz, blf_hz=FRAME.blf_hz,
                       m=FRAME.m, trext=FRAME.trext)
    x = np.stack([1e-2 * (1 + 0.3 * fa.stamp.levels), 1e-2 * (1 + 0.3 * fb.stamp.levels),
                  np.full(fa.n_samples, 1e-2)]).astype(np.complex128)
    ch = RowsChain.run(rx, x)
    assert ch.matched(rx, [fa, fb]).tolist() == [0, 1, -1]
    assert ch.matched(rx, [fb]).tolist() == [-1, 0, -1]
    assert ch.decoded(rx, fa).tolist() == [True, False, False]
    assert ch.decoded(rx, fa, rows=[False, True, True]).tolist() == [False, False, False]
    diff = ch.level_difference_v(rx, fa)
    assert abs(diff[0] - 0.06) < 0.06 * 0.01 and diff[2] < 1e-12


def test_drawn_links_are_reciprocal_and_batched_receivers_get_a_batch_link():
    sc, rng = room(False), np.random.default_rng(1)
    tx = exciter_antenna("dipole", 6.0, 1.0)
    one = vertical_dipole((2.0, 0.0, 1.0))
    many = BatchAntenna(vertical_dipole(np.zeros(3)), [[1.0, 0.0, 1.0], [3.0, 0.0, 1.0]])
    links = DrawnLinks()
    add_drawn_link(links, sc, tx, one, fc_hz=915e6, rng=rng)
    add_drawn_link(links, sc, tx, many, fc_hz=915e6, rng=rng)
    assert links.paths(tx, one, fc_hz=915e6, t_s=0.0) is links.paths(one, tx, fc_hz=915e6, t_s=0.0)
    assert links.paths(one, many, fc_hz=915e6, t_s=0.0) is None
    batch = links.paths(tx, many, fc_hz=915e6, t_s=0.0)
    assert isinstance(batch, BatchLink) and batch.method(96e3) == "narrowband"
    g = batch.constant_gain(915e6)[:, 0]
    # Friis, free space: |g| = λ/(4πd)·(dipole gain 1.64 at broadside)
    lam = 299792458.0 / 915e6
    assert np.allclose(np.abs(g), 1.64 * lam / (4 * np.pi * np.array([1.0, 3.0])), rtol=0.01)
    with pytest.raises(ValueError, match="narrowband"):
        batch.method(96e3, "exact")


def test_noise_power_is_kTBF_and_the_disc_is_area_uniform():
    assert math.isclose(NoiseConfig(nf_db=10.0).power_w(1e6), 1.380649e-23 * 290.0 * 1e6 * 10.0, rel_tol=1e-12)
    assert NoiseConfig(enabled=False).power_w(1e6) == 0.0
    dx, dy = uniform_disc(np.random.default_rng(2), 40000, 2.0)
    r2 = dx * dx + dy * dy
    assert r2.max() <= 4.0
    # E[r²] = R²/2 = 2, Var[r²] = R⁴/12: 4 σ of the mean of 40000
    assert abs(r2.mean() - 2.0) < 4 * math.sqrt(16.0 / 12.0 / 40000)


def test_columns_concat_in_order_and_units_from_suffixes():
    out = concat([{"a_m": np.array([1, 2]), "b": np.array([True, False])}, {"a_m": np.array([3]), "b": np.array([True])}])
    assert list(out) == ["a_m", "b"] and out["a_m"].tolist() == [1, 2, 3] and out["b"].tolist() == [True, False, True]
    assert [unit_of(k) for k in ("diff_v", "d_m", "theta_rad", "p_w", "f_hz", "draw")] == ["V", "m", "rad", "W", "Hz", "1"]
    assert unit_of("rate_per_s", {"_per_s": "1/s", "_s": "s"}) == "1/s"

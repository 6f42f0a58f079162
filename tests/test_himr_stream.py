"""The 2-D HIMR measurement stream and the per-case observer run outside the scenario: the
stream from a hand-made set of pylon measurements, the wrap periods λ/(2Δt), the gated
dealiasing hook, the Table 9 initial states and the scene checks."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from rfsim.core.errors import ConfigError
from rfsim.core.trajectories import RotatingBoom
from rfsim.devices.himr_tag import HimrTag, HimrTagConfig
from rfsim.estimators.himr_cases import measurement_stream, observe_case, wrap_periods
from rfsim.estimators.himr_model import PYLONS_M, h_2d, initial_state
from rfsim.estimators.observer import W_D2, range_gate
from rfsim.scenes.himr_air import RadioConfig, check_scene

C = 299_792_458.0


def test_initial_states_of_table_9():
    np.testing.assert_array_equal(initial_state(2), [1.0, 0, 0, 1.0, 0, 0, math.pi / 2, 0, 0])
    np.testing.assert_array_equal(initial_state(1)[[0, 3, 6]], [2.0, 1.8048, math.pi])


def test_wrap_periods_are_lambda_over_two_dt():
    t = np.array([0.0, 0.01, 0.03])
    per = wrap_periods(t, 2, [C / 0.06, C / 0.05])
    # λ = 0.06 m, 0.05 m; Δt = 0.01 (the first epoch takes the first interval), 0.01, 0.02 s
    np.testing.assert_allclose(per, [[3.0, 2.5], [3.0, 2.5], [1.5, 1.25]], rtol=1e-12)


def test_range_gate_wraps_only_below_the_gate():
    period = np.array([[0.0, 1.0, 0.0, 1.0]])
    hook = range_gate(2, 0.05, period)
    inside = np.array([0.01, 0.9, -0.02, -0.7])          # ranges within 5 cm → ṙ wrapped into ±0.5
    np.testing.assert_allclose(hook(0, inside), [0.01, -0.1, -0.02, 0.3])
    outside = np.array([0.2, 0.9, np.nan, -0.7])         # one range 20 cm off → as measured
    np.testing.assert_array_equal(hook(0, outside), outside)


def _fake_run(t, r, fc, every_ok=True):
    """Three pylons that decoded every packet: ranges r (n, 3), phases from 4π r/λ."""
    pylons, meas, index, true_r = [], [], [], []
    for u in range(3):
        lam = C / fc[u]
        phase = np.angle(np.exp(1j * 4 * np.pi * r[:, u] / lam))
        meas.append(SimpleNamespace(crc_ok=np.ones(t.size, bool), range_m=r[:, u], phase_rad=phase))
        pylons.append(SimpleNamespace(fc_hz=fc[u]))
        index.append(np.arange(t.size))
        true_r.append(r[:, u])
    return SimpleNamespace(pylons=pylons, measurements=meas, packet_index=index, true_range_m=true_r)


def test_measurement_stream_from_pylon_tables():
    t = np.arange(0.0, 0.2, 1 / 141)
    X = RotatingBoom()(t).state_2d()
    h = np.array([h_2d(x, PYLONS_M) for x in X])               # (n, 10) true outputs
    fc = (5.79e9, 5.80e9, 5.81e9)
    run = _fake_run(t, h[:, [0, 2, 4]], fc)
    imu = {"accel_y": h[:, 6], "accel_x": -h[:, 7], "heading_rad": h[:, 8], "gyro_z": h[:, 9]}
    s = measurement_stream(run, SimpleNamespace(start_s=t), imu)
    np.testing.assert_array_equal(s["y"][:, [0, 2, 4, 6, 7, 8, 9]], h[:, [0, 2, 4, 6, 7, 8, 9]])
    assert np.isnan(s["y"][0, 1])                                # no velocity before the second packet
    mean_v = np.diff(h[:, 0]) / np.diff(t)                       # slow start: no alias, ṙ = Δr/Δt
    np.testing.assert_allclose(s["y"][1:, 1], mean_v, atol=1e-9)
    np.testing.assert_allclose(s["rdot_oracle"][1:, 0], mean_v, atol=1e-9)
    every = measurement_stream(run, SimpleNamespace(start_s=t), imu, every=2)
    np.testing.assert_array_equal(every["t_s"], t[::2])
    cs, est = observe_case("prerotated", 6, "gated", {1: s, 6: every}, x0=initial_state(1), W=W_D2,
                           pylons_m=PYLONS_M, fc_hz=fc)
    assert cs.case == 6 and est.shape == (t[::2].size, 9)
    assert np.abs(est[-1, [0, 3]] - X[::2][-1, [0, 3]]).max() < 0.05


def test_check_scene_names_the_key():
    tag = HimrTag(HimrTagConfig(packet_format="9axis-2d"), RotatingBoom(), None)
    p0 = tag.trajectory(0.0).position_m[0]
    with pytest.raises(ConfigError, match=r"scene.pylons_m\[0\]"):
        check_scene(RadioConfig(), tag, [tuple(p0)], [5.8e9], t_end_s=1.6, room_min_m=(-0.5, -0.5),
                    room_max_m=(4.5, 3.5), key="scene.pylons_m")

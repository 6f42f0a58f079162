"""Frequency plans beyond FCC/ETSI: explicit carrier lists, validated (rfsim.air.carriers, Reader)."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.channels import Antenna
from rfsim.devices.exciter import ExciterConfig
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.cli import main
from rfsim.core.errors import ConfigError
from rfsim.core.rng import trial_rng


def _reader(**kw):
    return Reader(ReaderConfig(**kw), [Antenna(position_m=(0.0, 0.0, 1.0))], rng=trial_rng(1, 2))


def test_single_890_mhz_carrier():
    r = _reader(region="custom", channels_hz=(890e6,))
    assert r.fc_hz(0.0) == 890e6 and r.fc_hz(3.7) == 890e6
    assert r.channel_of(890e6) == 1


def test_three_himr_carriers_hop_in_order():
    plan = (5.79e9, 5.80e9, 5.81e9)
    r = _reader(region="custom", channels_hz=plan, dwell_s=0.1, fs_hz=4e6)
    got = [r.fc_hz(t) for t in (0.05, 0.15, 0.25, 0.35)]
    assert got == [5.79e9, 5.80e9, 5.81e9, 5.79e9]
    assert [r.channel_index(t) for t in (0.05, 0.15, 0.25)] == [1, 2, 3]


@pytest.mark.parametrize("kw, key", [
    (dict(region="custom", channels_hz=(20e9,)), "reader.channels_hz"),  # outside the models' range
    (dict(region="custom", channels_hz=(50e6, 915e6)), "reader.channels_hz"),
    (dict(region="custom", channels_hz=()), "reader.channels_hz"),
    (dict(region="custom", channels_hz=(915e6, 915e6)), "reader.channels_hz"),
    (dict(region="FCC", channels_hz=(915e6,)), "reader.channels_hz"),  # a list needs region 'custom'
    (dict(region="custom", channels_hz=(915e6,), hopping=False, fixed_channel=2), "reader.fixed_channel"),
])
def test_bad_plans_name_the_key(kw, key):
    with pytest.raises(ConfigError) as err:
        _reader(**kw)
    assert err.value.key == key and "\n" not in str(err.value)


def test_a_carrier_no_plan_contains():
    with pytest.raises(ConfigError) as err:
        _reader(region="ETSI").channel_of(915e6)
    assert err.value.key == "reader.channels_hz" and "865700000" in str(err.value)
    with pytest.raises(ConfigError) as err:
        ExciterConfig(fc_hz=24e9)
    assert err.value.key == "exciter.fc_hz"


@pytest.mark.parametrize("sets, fragment", [
    (["reader.region=custom", "reader.channels_hz=[20e9]"], "'reader.channels_hz'"),
    (["reader.channels_hz=[890e6]"], "region = 'custom'"),
])
def test_cli_bad_carrier_exits_2_with_one_line(sets, fragment, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = ["run", "link"]
    for s in sets:
        argv += ["--set", s]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rfsim: error: ") and fragment in err
    assert not list(tmp_path.glob("**/*.h5"))


def test_custom_plan_runs_an_exchange_on_its_carrier():
    from rfsim.channels import Channel, Isotropic, Scene
    from rfsim.devices.tag import PassiveTag, TagConfig
    from rfsim.protocols.engine import run_exchange
    from rfsim.gen2.commands import Query

    r = Reader(ReaderConfig(region="custom", channels_hz=(890e6,)),
               [Antenna(position_m=(0.0, 0.0, 1.0), pattern=Isotropic(), polarization="circular")], rng=trial_rng(3, 1))
    tag = PassiveTag(TagConfig(), Antenna(position_m=(1.5, 0.0, 1.0), pattern=Isotropic(), polarization="circular"),
                     rng=trial_rng(3, 2))
    lk = r.link
    ex = run_exchange(r, [tag], Channel(Scene()), Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0), t_s=0.0,
                      rng=trial_rng(3, 3), reply_bits=16, expect_crc=False)
    assert ex.fc_hz == 890e6 and ex.channel_index == 1 and ex.success
    # free space at 890 MHz: incident power = P_tx·(λ/4πd)² (isotropic, circular: no mismatch)
    lam = 299792458.0 / 890e6
    want_dbm = 30.0 + 20 * np.log10(lam / (4 * np.pi * 1.5))
    assert abs(ex.incident_power_dbm[0] - want_dbm) < 1e-6

"""Typed configs: TOML + --set overrides, and one-line errors for bad input."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import pytest

from rfsim.core.config import describe, from_dict, load_config, parse_override, to_toml
from rfsim.core.errors import ConfigError, UserError
from rfsim.core.config import param


@dataclass(frozen=True)
class ReaderToy:
    ptx_dbm: float = param(30.0, lo=-10.0, hi=36.0, unit="dBm", doc="conducted power")
    n_antennas: int = param(1, lo=1, hi=4, doc="antennas used in turn")
    modulation: Literal["DSB-ASK", "SSB-ASK", "PR-ASK"] = param("PR-ASK", doc="modulation")
    hop: bool = param(True, doc="frequency hopping")


@dataclass(frozen=True)
class ToyConfig:
    name: str = param("demo", doc="label")
    distances_m: tuple[float, ...] = param((1.0, 2.0), lo=0.0, lo_open=True, unit="m", doc="d")
    reader: ReaderToy = param(ReaderToy(ptx_dbm=20.0), doc="reader")


def test_defaults_and_overrides(tmp_path):
    cfg = load_config(ToyConfig)
    assert cfg.reader.ptx_dbm == 20.0  # the parent's default instance is kept
    toml = tmp_path / "c.toml"
    toml.write_text('name = "x"\n[reader]\nn_antennas = 2\n')
    cfg = load_config(ToyConfig, toml, ["reader.ptx_dbm=33", "distances_m=[0.5, 3]",
                                        "reader.modulation=DSB-ASK", "reader.hop=false"])
    assert cfg.name == "x"
    assert cfg.reader == ReaderToy(ptx_dbm=33.0, n_antennas=2, modulation="DSB-ASK", hop=False)
    assert cfg.distances_m == (0.5, 3.0)
    assert isinstance(cfg.reader.ptx_dbm, float)


def test_toml_round_trip(tmp_path):
    cfg = load_config(ToyConfig, None, ["reader.ptx_dbm=31.5", "name=a \"q\" b"])
    text = to_toml(cfg)
    path = tmp_path / "resolved.toml"
    path.write_text(text)
    assert load_config(ToyConfig, path) == cfg


def test_parse_override_values():
    assert parse_override("a.b=1e-6") == (["a", "b"], 1e-6)
    assert parse_override("a=true") == (["a"], True)
    assert parse_override("a=[1, 2]") == (["a"], [1, 2])
    assert parse_override("a=PR-ASK") == (["a"], "PR-ASK")
    assert parse_override("a = 'x y'") == (["a"], "x y")


# Each case: overrides, the key the message must name, a fragment of what is allowed.
BAD_INPUTS = [
    (["reader.ptx_dbm=50"], "reader.ptx_dbm", "[-10, 36] dBm"),
    (["reader.ptx_dbm=loud"], "reader.ptx_dbm", "a number"),
    (["reader.ptx_dbm=nan"], "reader.ptx_dbm", "finite"),
    (["reader.ptx_dbbm=3"], "reader.ptx_dbbm", "did you mean 'ptx_dbm'"),
    (["reader.n_antennas=2.5"], "reader.n_antennas", "an integer"),
    (["reader.n_antennas=0"], "reader.n_antennas", "[1, 4]"),
    (["reader.modulation=PRASK"], "reader.modulation", "did you mean 'PR-ASK'"),
    (["reader.hop=1"], "reader.hop", "true or false"),
    (["distances_m=[1, -2]"], "distances_m[1]", "(0, inf] m"),
    (["distances_m=3"], "distances_m", "a list of"),
    (["reader=5"], "reader", "a table"),
    (["nme=x"], "nme", "did you mean 'name'"),
    (["name=3"], "name", "a string"),
    (["reader.ptx_dbm.x=1"], "reader.ptx_dbm", "a number"),
]


@pytest.mark.parametrize("overrides,key,allowed", BAD_INPUTS)
def test_bad_inputs_name_key_value_and_allowed(overrides, key, allowed):
    with pytest.raises(ConfigError) as info:
        load_config(ToyConfig, None, overrides)
    message = str(info.value)
    assert "\n" not in message
    assert f"'{key}'" in message
    assert allowed in message
    assert info.value.key == key


def test_bad_toml_file_is_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("reader = [\n")
    with pytest.raises(UserError) as info:
        load_config(ToyConfig, bad)
    assert "not valid TOML" in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(UserError, match="cannot be read"):
        load_config(ToyConfig, tmp_path / "missing.toml")
    with pytest.raises(UserError, match="KEY=VALUE"):
        load_config(ToyConfig, None, ["reader.ptx_dbm"])


def test_from_dict_rejects_unknown_nested_key_with_choices():
    with pytest.raises(ConfigError, match="one of hop, modulation, n_antennas, ptx_dbm"):
        from_dict(ToyConfig, {"reader": {"zzz": 1}})


def test_describe_lists_every_leaf_key():
    keys = [row[0] for row in describe(ToyConfig)]
    assert keys == ["name", "distances_m", "reader.ptx_dbm", "reader.n_antennas",
                    "reader.modulation", "reader.hop"]


def test_empty_list_for_a_variable_length_tuple_is_refused():
    with pytest.raises(ConfigError, match=r"config key 'distances_m': got \[\]; allowed: a non-empty list of float"):
        load_config(ToyConfig, None, ["distances_m=[]"])


def test_config_error_survives_pickling_into_another_process():
    import pickle

    err = pickle.loads(pickle.dumps(ConfigError("reader.link_profile", "x", "one of a, b")))
    assert isinstance(err, ConfigError) and str(err) == "config key 'reader.link_profile': got 'x'; allowed: one of a, b"


def test_binary_toml_file_is_a_one_line_user_error(tmp_path):
    path = tmp_path / "c.toml"
    path.write_bytes(b"\xff\xfe\x00name = 1")
    with pytest.raises(UserError, match="not UTF-8 text") as info:
        load_config(ToyConfig, path)
    assert "\n" not in str(info.value)


def test_check_value_checks_one_dotted_key():
    from rfsim.core.config import check_value

    assert check_value(ToyConfig, "reader.ptx_dbm", 12) == 12.0
    with pytest.raises(ConfigError, match="config key 'reader.ptx_dbm': got 99"):
        check_value(ToyConfig, "reader.ptx_dbm", 99)
    with pytest.raises(ConfigError, match="'reader.nope'"):
        check_value(ToyConfig, "reader.nope", 1)


def test_a_list_that_is_empty_by_default_may_stay_empty():
    @dataclass(frozen=True)
    class Optional:
        extra_m: tuple[float, ...] = param((), unit="m", doc="optional positions")

    assert load_config(Optional, None, ["extra_m=[]"]).extra_m == ()


@dataclass(frozen=True)
class CheckedToy:
    """A config that checks its fields in code (``check_fields``, as the device configs do)."""

    gain_db: float = param(0.0, lo=-10.0, hi=10.0, unit="dB", doc="gain")
    spacing_m: tuple[float, ...] = param((1.0,), lo=0.0, lo_open=True, unit="m", doc="spacing")
    mode: Literal["a", "b"] = param("a", doc="mode")

    def __post_init__(self):
        from rfsim.core.config import check_fields
        check_fields(self, "toy")


def test_fields_checked_once_per_distinct_values_convert_and_reject_as_every_time():
    from rfsim.core.config import CHECKED_FIELDS

    CHECKED_FIELDS.clear()
    first = CheckedToy(gain_db=1.5, spacing_m=(2.0, 3))
    again = CheckedToy(gain_db=1.5, spacing_m=(2.0, 3))  # the verdict of these values is kept
    assert len(CHECKED_FIELDS.entries) == 1
    for cfg in (first, again):  # stored in canonical form on the kept verdict too
        assert cfg == CheckedToy(gain_db=1.5, spacing_m=(2.0, 3.0))
        assert [type(v) for v in cfg.spacing_m] == [float, float]
    CheckedToy(gain_db=2.0)
    as_int = CheckedToy(gain_db=2)  # an equal int: another key (its type), converted to a float
    assert type(as_int.gain_db) is float and as_int.gain_db == 2.0
    twice = CheckedToy(gain_db=2)
    assert type(twice.gain_db) is float
    CheckedToy(gain_db=0.0)
    negative_zero = CheckedToy(gain_db=-0.0)  # equal to a checked value: its own value is kept
    assert str(negative_zero.gain_db) == "-0.0"
    for _ in range(2):  # a value out of range is rejected every time, after the good ones were kept
        with pytest.raises(ConfigError, match="toy.gain_db"):
            CheckedToy(gain_db=11.0)
        with pytest.raises(ConfigError, match="toy.mode"):
            CheckedToy(mode="c")
    with pytest.raises(ConfigError, match=r"toy.spacing_m\[1\]"):
        CheckedToy(spacing_m=(1.0, 0.0))

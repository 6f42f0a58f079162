"""No config gives a traceback: every scenario, on a tiny problem size, with one or two keys
drawn from their declared ranges, choices and types (and just outside them), either runs to a
result or stops with a one-line :class:`~rfsim.core.errors.UserError` (the command line's exit
status 2) — never another exception.

The degenerate configs found this way (and by hand) are pinned below as examples: each names
the key the user set.
"""

from __future__ import annotations

import math
import types
import typing
from typing import Any, Literal

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rfsim
from rfsim.cli import main
from rfsim.core.config import describe, field_at, field_meta
from rfsim.core.errors import ConfigError, UserError
from rfsim.runs.registry import builtin_modules, get_scenario

#: A tiny problem per scenario (well under a second a run once its kernels are compiled):
#: the drawn keys come on top of it.
TINY: dict[str, dict[str, Any]] = {
    "access": {"geometry.distances_m": [1.0], "rounds_per_point": 1},
    "detection-probability": {"samples.count": 4, "samples.n_train": 2, "samples.workers": 1},
    "exciter-link": {"sweep.exciter_distance_m": [0.5, 1.0], "sweep.tag_distance_m": [0.1, 0.2],
                     "sweep.draws_per_point": 1, "sweep.workers": 1},
    "gen2-waveforms": {"profiles": ["fm0-640k"]},
    "himr-1d": {"scene.duration_s": 0.1},
    "himr-2d": {"scene.duration_s": 0.3, "observer.outage_s": [0.1, 0.2], "observer.cases": [1],
                "observer.variants": ["prerotated"]},
    "inventory": {"populations": [2], "runs": 1, "capture.trials": 1, "capture.ratios_db": [0.0],
                  "capture_sweep.enabled": False, "capture_inventory.enabled": False},
    "link": {"geometry.distances_m": [1.0], "rounds_per_point": 1},
    "phase-cancellation": {"mc.positions_per_cell": 2, "mc.workers": 1, "geometry.tag_x_m": [1.0, 2.0],
                           "tracks.cell": 0, "tracks.angles_deg": [0.0], "tracks.step_m": 0.5},
    "phase-tracking": {"trajectory.duration_s": 0.2, "schedule.workers": 1},
    "reader-detection": {"campaign.distances_m": [1.0], "campaign.angles_deg": [0.0], "campaign.repetitions": 2,
                         "campaign.queries": 2, "campaign.workers": 1},
    "rss-localization": {"trials": 1, "particles": 5, "motions": ["fixed"], "sigma0_db": [3.0]},
    "st-localization": {"realizations": 1, "experiments": ["trajectory-2"], "trajectory_2_speeds_mps": [2.5],
                        "path_duration_s": 0.5, "filters.particles": 5, "workers": 1,
                        "sample_level.duration_s": 0.1, "sample_level.realizations": 1},
    "st-to-st": {"mc.positions_per_cell": 2, "mc.workers": 1, "geometry.st_x_m": [1.0]},
    "tag-to-tag-tracking": {"trajectories": 1, "filter_runs": 1, "workers": 1, "motion.duration_s": 0.5,
                            "ranges_m": [1.5], "trackers.particles": [5], "trackers.rbpf_particles": [5]},
}

#: Keys not drawn (besides the pinned ones): they set the problem's size (the guard against
#: sizes that do not fit is a check of its own) or switch to the full-size run.
SIZE_KEYS = ("full", "mc.full", "sweep.full", "campaign.full", "workers", "threads", "duration_s", "trials",
             "repetitions", "realizations", "particles", "max_rounds", "max_slots", "populations", "runs",
             "queries", "count", "first", "n_train", "home_steps", "rounds", "draws_per_point", "step_m",
             "filter_runs", "trajectories", "positions_per_cell", "characteristics_dir", "agc_dir",
             "samples_per_element", "dt_s", "period_s", "st_step_m", "walk_duration_s", "nn_k")

#: Scenarios whose full set of choices includes a much larger problem than the tiny one
#: (a drawn value of these keys keeps to the listed choices).
CHOICES: dict[str, dict[str, tuple]] = {
    "st-localization": {"preset": ("pfaa", "sqlam"), "mode": ("surrogate",)},
    "rss-localization": {"preset": ("sim-5x8",), "rss_model": ("log-distance",)},
    "inventory": {"capture_sweep.enabled": (False,), "capture_inventory.enabled": (False,),
                  "capture.enabled": (True, False)},
}


def _is_size_key(key: str) -> bool:
    leaf = key.rsplit(".", 1)[-1]
    return key in SIZE_KEYS or leaf in SIZE_KEYS or leaf.endswith("duration_s")


def _number(meta: dict, kind: type, default: Any) -> st.SearchStrategy:
    """Values of a numeric key: inside its declared range (bounds included), just outside it,
    and non-finite ones."""
    lo, hi = meta["lo"], meta["hi"]
    scale = abs(default) if isinstance(default, (int, float)) and default else 1.0
    lo_ = lo if lo is not None else -10.0 * scale
    hi_ = hi if hi is not None else 10.0 * scale
    if kind is int:
        inside = st.integers(int(math.ceil(lo_)), int(math.floor(min(hi_, max(lo_, 0) + 1000))))
        edges = [v for v in (lo, hi) if v is not None]
        outside = st.sampled_from([int(v) + d for v in edges for d in (-1, 1)] or [-1])
        return st.one_of(inside, outside)
    hi_in = min(hi_, lo_ + 1e6)
    inside = st.floats(lo_, hi_in, allow_nan=False, allow_infinity=False)
    edges = [float(v) for v in (lo, hi) if v is not None]
    special = st.sampled_from(edges + [v * (1 + 1e-9) + d for v in edges for d in (-1e-9, 1e-9)]
                              + [math.nan, math.inf, -math.inf, 0.0])
    return st.one_of(inside, special)


def value_strategy(cls: type, key: str, default: Any) -> st.SearchStrategy | None:
    """Values of the config key ``key`` drawn from its declared type, range and choices; None
    for a key of a kind not drawn (free text)."""
    f, tp = field_at(cls, key)
    meta = field_meta(f)
    origin = typing.get_origin(tp)
    if origin is Literal:
        return st.sampled_from(typing.get_args(tp))
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in typing.get_args(tp) if a is not type(None)][0]
        base = _element(inner, meta, default)
        return None if base is None else st.one_of(st.just("none"), base)
    return _element(tp, meta, default)


def _element(tp: Any, meta: dict, default: Any) -> st.SearchStrategy | None:
    if tp is bool:
        return st.booleans()
    if tp in (int, float):
        return _number(meta, tp, default)
    if typing.get_origin(tp) is tuple:
        args = typing.get_args(tp)
        sample = default[0] if isinstance(default, tuple) and default else None
        if len(args) == 2 and args[1] is Ellipsis:
            item = _element(args[0], meta, sample)
            return None if item is None else st.lists(item, min_size=0, max_size=3)
        items = [_element(a, meta, sample) for a in args]
        return None if any(i is None for i in items) else st.tuples(*items).map(list)
    return None  # strings: free text (paths, hex words, names) is checked by their own tests


def key_strategies(name: str) -> dict[str, st.SearchStrategy]:
    module = get_scenario(name)
    defaults = {row[0] for row in describe(module.Config)}
    default_config = module.Config()
    out = {}
    for key in sorted(defaults):
        if key in TINY[name] or _is_size_key(key):
            continue
        default: Any = default_config
        for part in key.split("."):
            default = getattr(default, part)
        if key in CHOICES.get(name, {}):
            out[key] = st.sampled_from(CHOICES[name][key])
            continue
        strategy = value_strategy(module.Config, key, default)
        if strategy is not None:
            out[key] = strategy
    return out


def result_or_one_line(name: str, overrides: dict[str, Any]) -> None:
    """Run ``name`` with the tiny size and ``overrides``: a result, or a one-line UserError."""
    try:
        rfsim.run(name, seed=1, progress=False, config={**TINY[name], **overrides})
    except UserError as err:
        assert "\n" not in str(err), str(err)


def check_scenario(name: str, examples: int) -> None:
    strategies = key_strategies(name)
    keys = sorted(strategies)

    @settings(max_examples=examples, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(st.data())
    def one(data):
        chosen = data.draw(st.lists(st.sampled_from(keys), min_size=1, max_size=2, unique=True), label="keys")
        result_or_one_line(name, {k: data.draw(strategies[k], label=k) for k in chosen})

    one()


@pytest.mark.parametrize("name", sorted(TINY))
def test_drawn_configs_give_a_result_or_one_line(name):
    check_scenario(name, examples=12)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(TINY))
def test_drawn_configs_give_a_result_or_one_line_many(name):
    check_scenario(name, examples=30)  # 30 x 14 scenarios: a few minutes of the slow tier


def test_every_scenario_has_a_tiny_size():
    assert set(TINY) == set(builtin_modules())
    for name in TINY:
        assert key_strategies(name), name


# ----------------------------------------------------------------------------- found cases

FOUND = [
    ("st-localization", ["experiments=[]"], "experiments"),
    ("himr-2d", ["scene.pylons_m=[[0,0],[0,0],[2.7,-0.03]]"], "scene.pylons_m[1]"),
    ("himr-2d", ["scene.pylons_m=[[-0.1,1.5],[2.0,3.05],[-0.1,1.52]]"], "scene.pylons_m[2]"),
    ("st-to-st", ["exciter.schedule_s=[10.0]"], "exciter.schedule_s"),
    ("st-to-st", ["exciter.schedule_s=[0.5, 1.0]"], "exciter.schedule_s"),
    ("exciter-link", ["exciter.schedule_s=[10.0]"], "exciter.schedule_s"),
    ("himr-1d", ["tag.chip_rate_hz=1e9"], "tag.chip_rate_hz"),
    ("himr-1d", ["radio.margin_s=0"], "radio.margin_s"),
    ("himr-1d", ["tag.packet_rate_hz=2.3", "scene.duration_s=0.1"], "tag.packet_rate_hz"),
    # every ST distance drawn below the radius is redrawn below min_st_distance_m: no draw kept (the run hung)
    ("detection-probability", ["geometry.st_radius_m=0.05"], "geometry.min_st_distance_m"),
    ("detection-probability", ["geometry.st_radius_m=0.5", "geometry.min_st_distance_m=0.6"],
     "geometry.min_st_distance_m"),
]


@pytest.mark.parametrize("name, sets, key", FOUND)
def test_degenerate_config_is_one_line_naming_the_key(name, sets, key, tmp_path, capsys):
    argv = ["run", name, "-q", "--no-plot", "-o", str(tmp_path / "x.h5")]
    for s in sets:
        argv += ["--set", s]
    try:
        code = main(argv)
    except SystemExit as info:
        code = info.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and f"config key '{key}'" in err, err
    assert not (tmp_path / "x.h5").exists()


def test_schedule_on_during_the_frame_is_accepted():
    """A schedule that switches the exciter on inside the frame is a run, not an error."""
    rfsim.run("st-to-st", seed=1, progress=False, config={**TINY["st-to-st"], "exciter.schedule_s": [0.0, 1e-4]})
    with pytest.raises(ConfigError):
        rfsim.run("st-to-st", seed=1, progress=False, config={**TINY["st-to-st"], "exciter.schedule_s": [1.0]})

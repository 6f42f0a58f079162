"""Sweep specs: TOML parsing, validation and deterministic expansion into points.

A spec names a scenario, a root seed, a number of repetitions, an output file, base
config overrides and a list of axes::

    scenario = "gen2-waveforms"
    seed = 7
    repetitions = 2
    output = "results/sweep.h5"

    [base]
    profiles = ["fm0-40k"]

    [[axes]]                       # grid: one group of len(values) settings
    kind = "grid"
    key = "fs_hz"
    values = [1e6, 2e6]

    [[axes]]                       # zip: the keys move together (one list per key)
    kind = "zip"
    keys = ["q", "session"]
    values = [[1, 2, 3], [0, 1, 2]]

    [[axes]]                       # random: n draws from a named distribution
    kind = "random"
    key = "pie_rise_fall_tari"
    distribution = "uniform"
    low = 0.05
    high = 0.3
    n = 4

Expansion: every grid axis and every zip axis is one *group*; all random axes with the
same ``n`` form one group (they move together, draw j of each axis in the same point).
The points are the Cartesian product of the groups, in the order the groups first appear
in the spec, the last group varying fastest (``itertools.product`` order). Random axis
number ``a`` (its position in ``[[axes]]``) draws its ``n`` values from
``rfsim.core.rng.trial_rng(seed, a)`` — a one-element spawn key, so it never shares a stream
with a point's run seed (two-element keys ``(point, repetition)``).

Paths: a relative ``output`` in a spec file resolves against the spec file's folder (so a
spec and its results move together, whatever the working directory); a spec given as a
mapping (``parse_spec(dict)``, ``rfsim.sweep(dict)``) has no folder, and its relative
``output`` resolves against the working directory. An ``output=`` override (the command
line's ``--output``) replaces the spec's and resolves against the working directory.

Point ``i``, repetition ``k`` runs the scenario with the seed :func:`point_seed`
``(seed, i, k)``, so the result of a point does not depend on the executor, the number of
workers or the order in which points finish.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rfsim.core.config import check_value, from_dict, read_toml
from rfsim.core.errors import SEED_LIMIT, SEED_RANGE_TEXT, ConfigError, UserError, did_you_mean
from rfsim.core.rng import trial_rng, trial_seed_sequence

_TOP_KEYS = ("scenario", "seed", "repetitions", "output", "base", "axes")
_AXIS_KEYS = {
    "grid": ("kind", "key", "values"),
    "zip": ("kind", "keys", "values"),
    "random": ("kind", "key", "distribution", "n", "low", "high", "mean", "std", "values"),
}
#: distribution → the parameters it needs.
DISTRIBUTIONS = {
    "uniform": ("low", "high"),
    "normal": ("mean", "std"),
    "loguniform": ("low", "high"),
    "choice": ("values",),
}
#: Upper bound on the number of runs (points × repetitions) of one sweep (points are
#: expanded lazily, so this bounds the point store, not the memory of a dry-run).
MAX_RUNS = 10**9


@dataclasses.dataclass(frozen=True)
class Axis:
    """One ``[[axes]]`` entry after parsing: the keys it sets and one value tuple per step.

    Attributes
    ----------
    kind : {"grid", "zip", "random"}
        The axis kind.
    keys : tuple of str
        Dotted config keys the axis sets (one for grid and random axes).
    values : sequence of tuple
        One tuple of values (one per key) per step; random axes hold their draws lazily.
    group : str
        Expansion group: random axes of the same ``n`` share one (``"random-n<n>"``); a
        grid or zip axis has its own (``"axis<i>"``).
    """

    kind: str
    keys: tuple[str, ...]
    #: one tuple of values (one per key) per step; random axes hold their draws lazily
    values: Sequence[tuple[Any, ...]]
    #: random axes of the same ``n`` share a group; grid/zip axes have their own
    group: str

    def __len__(self) -> int:
        """Steps of the axis."""
        return len(self.values)


@dataclasses.dataclass(frozen=True)
class SweepSpec:
    """A parsed, checked sweep spec (the axes' random values are already drawn).

    Build it with :func:`load_spec` or :func:`parse_spec`.

    Attributes
    ----------
    scenario : str
        Scenario name (as ``rfsim list`` shows it).
    seed : int
        Root seed of the sweep; run seeds come from :func:`point_seed`.
    repetitions : int
        Runs per point (>= 1).
    output : pathlib.Path
        The merged output file (``.h5`` or ``.hdf5``), resolved as the module docstring says.
    base : mapping
        Config values shared by every point (``[base]``).
    axes : tuple of Axis
        The parsed axes, in spec order.
    text : str
        The spec's TOML text (stored in the merged file's provenance); empty for a mapping.
    path : pathlib.Path or None
        Where the spec was read from; None when built from a mapping.
    data : mapping
        The checked spec mapping without ``output`` (a merged file of a spec built from a
        mapping stores it as JSON, so that its points can be rebuilt).
    swept_keys : tuple of str
        Dotted config keys set by the axes, in spec order.
    group_sizes : tuple of int
        Length of each group of axes, in expansion order.
    n_points : int
        Points: the product of ``group_sizes``.
    n_runs : int
        Scenario runs: points × repetitions.
    """

    scenario: str
    seed: int
    repetitions: int
    output: Path
    base: Mapping[str, Any]
    axes: tuple[Axis, ...]
    #: the spec's TOML text (stored in the merged file's provenance)
    text: str = ""
    #: where the spec was read from (None when built from a dict)
    path: Path | None = None
    #: the checked spec mapping without ``output`` (a merged file of a spec built from a
    #: mapping stores it as JSON, so that its points can be rebuilt)
    data: Mapping[str, Any] = dataclasses.field(default_factory=dict, repr=False, compare=False)

    @property
    def swept_keys(self) -> tuple[str, ...]:
        """Dotted config keys set by the axes, in spec order."""
        return tuple(k for a in self.axes for k in a.keys)

    @property
    def group_sizes(self) -> tuple[int, ...]:
        """Length of each group of axes, in expansion order."""
        sizes: dict[str, int] = {}
        for a in self.axes:
            sizes.setdefault(a.group, len(a))
        return tuple(sizes.values())

    @property
    def n_points(self) -> int:
        """Points of the sweep: the product of the group sizes."""
        return math.prod(self.group_sizes)

    @property
    def n_runs(self) -> int:
        """Scenario runs of the sweep: points × repetitions."""
        return self.n_points * self.repetitions


# ----------------------------------------------------------------------------- parsing


def load_spec(path: str | Path, *, output: str | Path | None = None) -> SweepSpec:
    """Read and check a sweep spec TOML file.

    Parameters
    ----------
    path : str or pathlib.Path
        The spec file. A relative ``output`` in it resolves against its folder.
    output : str or pathlib.Path, optional
        Output file replacing the spec's (e.g. ``rfsim sweep run --output``); resolves
        against the working directory. Default None: the spec's.

    Returns
    -------
    SweepSpec
        The parsed spec, its random axes drawn, its TOML text and path kept.

    Raises
    ------
    UserError
        The file cannot be read or parsed, or the spec is invalid (one line;
        :class:`~rfsim.core.errors.ConfigError` names the key).
    """
    p = Path(path)
    data = read_toml(p)
    return parse_spec(data, text=p.read_text(encoding="utf-8"), path=p, output=output)


def _output_path(value: Any, where: str) -> Path:
    if isinstance(value, Path):
        value = str(value)
    if not isinstance(value, str) or not value.endswith((".h5", ".hdf5")):
        if where.startswith("--"):
            raise UserError(f"{where} {value!r}: expected a file name ending in .h5 or .hdf5")
        raise ConfigError(where, value, "a file name ending in .h5 or .hdf5")
    return Path(value)


def parse_spec(data: Mapping[str, Any], *, text: str = "", path: Path | None = None,
               output: str | Path | None = None) -> SweepSpec:
    """Check the spec mapping ``data`` and draw its random axes.

    Parameters
    ----------
    data : mapping
        The spec: ``scenario``, ``seed``, ``output`` (required), ``repetitions``, ``base``,
        ``axes`` (see the module docstring).
    text : str, optional
        The spec's TOML text, kept for the provenance (default empty).
    path : pathlib.Path, optional
        The spec file; a relative ``output`` of the spec resolves against its folder, or —
        without ``path`` (default None) — against the working directory.
    output : str or pathlib.Path, optional
        Output file overriding the spec's (then the spec's ``output`` key may be left out).

    Returns
    -------
    SweepSpec
        The checked spec with its random axes drawn (axis ``a`` from
        ``rfsim.core.rng.trial_rng(seed, a)``).

    Raises
    ------
    UserError
        A key is missing, unknown or invalid (a :class:`~rfsim.core.errors.ConfigError`
        naming it), a key is swept twice, or the sweep has more than :data:`MAX_RUNS` runs.
    """
    for k, v in data.items():
        if k not in _TOP_KEYS:
            raise ConfigError(k, v, "a sweep spec key" + _hint(k, _TOP_KEYS))
    for k in ("scenario", "seed", "output"):
        if k not in data and not (k == "output" and output is not None):
            raise UserError(f"sweep spec: the key {k!r} is missing (required: scenario, seed, output)")
    scenario = data["scenario"]
    if not isinstance(scenario, str) or not scenario:
        raise ConfigError("scenario", scenario, "a scenario name (see 'rfsim list')")
    seed = data["seed"]
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < SEED_LIMIT:
        raise ConfigError("seed", seed, SEED_RANGE_TEXT)
    repetitions = _int(data, "repetitions", lo=1, default=1)
    if output is not None:
        out_path = _output_path(output, "--output")
    else:
        out_path = _output_path(data["output"], "output")
        if path is not None and not out_path.is_absolute():
            out_path = Path(path).parent / out_path
    base = data.get("base", {})
    if not isinstance(base, Mapping):
        raise ConfigError("base", base, "a table of config values ([base])")
    raw_axes = data.get("axes", [])
    if not isinstance(raw_axes, list) or not all(isinstance(a, Mapping) for a in raw_axes):
        raise ConfigError("axes", raw_axes, "an array of tables ([[axes]])")
    axes = tuple(_parse_axis(i, a, seed) for i, a in enumerate(raw_axes))
    seen: dict[str, int] = {}
    for i, a in enumerate(axes):
        for k in a.keys:
            if k in seen:
                raise ConfigError(f"axes[{i}].key", k, f"a key not already swept by axes[{seen[k]}]")
            seen[k] = i
    spec = SweepSpec(scenario, seed, repetitions, out_path, dict(base), axes, text, path,
                     {k: copy.deepcopy(v) for k, v in data.items() if k != "output"})
    if spec.n_runs > MAX_RUNS:
        raise ConfigError("axes", f"{spec.n_points} points x {repetitions} repetitions",
                          f"at most {MAX_RUNS} runs in one sweep")
    return spec


def _hint(name: str, choices: Sequence[str]) -> str:
    return did_you_mean(name, choices) or f" (one of {', '.join(choices)})"


def _int(data: Mapping[str, Any], key: str, *, lo: int, default: int | None = None,
         prefix: str = "") -> int:
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        raise ConfigError(prefix + key, value, f"an integer >= {lo}")
    return value


def _number(axis: Mapping[str, Any], key: str, prefix: str) -> float:
    if key not in axis:
        raise ConfigError(prefix + key, None, f"a number (required by distribution "
                          f"{axis['distribution']!r})")
    value = axis[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(prefix + key, value, "a finite number")
    return float(value)


def _dotted(key: Any, where: str) -> str:
    if not isinstance(key, str) or not key or any(not p for p in key.split(".")):
        raise ConfigError(where, key, "a dotted config key, e.g. \"reader.ptx_dbm\"")
    return key


def _nonempty_list(value: Any, where: str) -> list:
    if not isinstance(value, list) or not value:
        raise ConfigError(where, value, "a non-empty list of values")
    return value


def _parse_axis(i: int, axis: Mapping[str, Any], seed: int) -> Axis:
    prefix = f"axes[{i}]."
    kind = axis.get("kind")
    if kind not in _AXIS_KEYS:
        raise ConfigError(prefix + "kind", kind, "one of 'grid', 'zip', 'random'"
                          + (did_you_mean(kind, _AXIS_KEYS) if isinstance(kind, str) else ""))
    for k, v in axis.items():
        if k not in _AXIS_KEYS[kind]:
            raise ConfigError(prefix + k, v, f"a key of a {kind} axis" + _hint(k, _AXIS_KEYS[kind]))
    if kind == "grid":
        key = _dotted(axis.get("key"), prefix + "key")
        values = _nonempty_list(axis.get("values"), prefix + "values")
        return Axis("grid", (key,), tuple((v,) for v in values), group=f"axis{i}")
    if kind == "zip":
        keys = axis.get("keys")
        if not isinstance(keys, list) or len(keys) < 1:
            raise ConfigError(prefix + "keys", keys, "a non-empty list of dotted config keys")
        keys = [_dotted(k, prefix + "keys") for k in keys]
        values = _nonempty_list(axis.get("values"), prefix + "values")
        if len(values) != len(keys) or not all(isinstance(v, list) and v for v in values):
            raise ConfigError(prefix + "values", values,
                              f"one non-empty list of values per key ({len(keys)} lists)")
        lengths = {len(v) for v in values}
        if len(lengths) != 1:
            raise ConfigError(prefix + "values", [len(v) for v in values],
                              "lists of equal length (zip keys move together)")
        return Axis("zip", tuple(keys), tuple(zip(*values)), group=f"axis{i}")
    key = _dotted(axis.get("key"), prefix + "key")
    dist = axis.get("distribution")
    if dist not in DISTRIBUTIONS:
        raise ConfigError(prefix + "distribution", dist, "one of " + ", ".join(map(repr, DISTRIBUTIONS))
                          + (did_you_mean(dist, DISTRIBUTIONS) if isinstance(dist, str) else ""))
    for k in axis:
        if k not in ("kind", "key", "distribution", "n") and k not in DISTRIBUTIONS[dist]:
            raise ConfigError(prefix + k, axis[k], f"a parameter of {dist!r}: "
                              + ", ".join(DISTRIBUTIONS[dist]))
    n = _int(axis, "n", lo=1, prefix=prefix) if "n" in axis else None
    if n is None:
        raise ConfigError(prefix + "n", None, "an integer >= 1 (number of draws)")
    if n > MAX_RUNS:
        raise ConfigError(prefix + "n", n, f"an integer in [1, {MAX_RUNS}]")
    rng = trial_rng(seed, i)
    if dist == "choice":
        choices = _nonempty_list(axis.get("values"), prefix + "values")
        drawn = _Draws(rng.integers(0, len(choices), n), tuple(choices))
    else:
        p = {k: _number(axis, k, prefix) for k in DISTRIBUTIONS[dist]}
        if dist == "uniform":
            if not p["low"] < p["high"]:
                raise ConfigError(prefix + "high", p["high"], f"a number > low = {p['low']:g}")
            arr = rng.uniform(p["low"], p["high"], n)
        elif dist == "normal":
            if not p["std"] > 0:
                raise ConfigError(prefix + "std", p["std"], "a number > 0")
            arr = rng.normal(p["mean"], p["std"], n)
        else:
            if not 0 < p["low"] < p["high"]:
                raise ConfigError(prefix + "low", p["low"], f"0 < low < high = {p['high']:g}")
            arr = np.exp(rng.uniform(np.log(p["low"]), np.log(p["high"]), n))
        drawn = _Draws(arr)
    return Axis("random", (key,), drawn, group=f"random-n{n}")


class _Draws(Sequence):
    """The ``n`` draws of a random axis as one-value steps, kept as one NumPy array."""

    def __init__(self, drawn: np.ndarray, choices: tuple[Any, ...] | None = None):
        self._drawn, self._choices = drawn, choices

    def __len__(self) -> int:
        return len(self._drawn)

    def __getitem__(self, j):
        if isinstance(j, slice):
            return [self[k] for k in range(*j.indices(len(self)))]
        v = self._drawn[j]
        return (copy.deepcopy(self._choices[int(v)]),) if self._choices is not None else (float(v),)

    def __eq__(self, other) -> bool:
        return list(self) == list(other)

    def support(self) -> list[Any]:
        """Values to check: the choices, or the smallest and largest draw (ranges are intervals)."""
        if self._choices is not None:
            return list(self._choices)
        return [float(self._drawn.min()), float(self._drawn.max())]


def axis_support(axis: Axis, j: int = 0) -> list[Any]:
    """Values of key ``j`` of ``axis`` to check against the config.

    Parameters
    ----------
    axis : Axis
        A parsed axis.
    j : int, default 0
        Index of the key in ``axis.keys``.

    Returns
    -------
    list
        Every grid or zip value of the key; for a random axis its choices, or its smallest
        and largest draw (floats; config ranges are intervals).
    """
    if isinstance(axis.values, _Draws):
        return axis.values.support()
    return [step[j] for step in axis.values]


# ----------------------------------------------------------------------------- expansion


def _groups(spec: SweepSpec) -> list[list[Axis]]:
    groups: dict[str, list[Axis]] = {}
    for a in spec.axes:
        groups.setdefault(a.group, []).append(a)
    return list(groups.values())


def point_value(spec: SweepSpec, index: int) -> dict[str, Any]:
    """Swept values of point ``index`` alone (no expansion of the other points).

    The index is read as a mixed-radix number over the group sizes, the last group
    varying fastest — the ``itertools.product`` order of :func:`point_values`.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    index : int
        Point index, in ``[0, spec.n_points)``.

    Returns
    -------
    dict of str to object
        Dotted key → value, in the order of ``spec.swept_keys``.

    Raises
    ------
    IndexError
        ``index`` is out of range.
    """
    if not 0 <= index < spec.n_points:
        raise IndexError(f"point {index} of a sweep of {spec.n_points} points")
    values: dict[str, Any] = {}
    rest = index
    steps = []
    for members in reversed(_groups(spec)):
        rest, j = divmod(rest, len(members[0]))
        steps.append((members, j))
    for members, j in reversed(steps):
        for a in members:
            values.update(zip(a.keys, a.values[j]))
    return {k: values[k] for k in spec.swept_keys}


def iter_point_values(spec: SweepSpec, start: int = 0, stop: int | None = None) -> Iterator[dict[str, Any]]:
    """Swept values of points ``start`` … ``stop - 1``, one at a time (lazy).

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    start : int, default 0
        First point.
    stop : int, optional
        End of the range (exclusive), clipped to ``spec.n_points``; None (default): all.

    Yields
    ------
    dict of str to object
        Dotted key → value of each point (:func:`point_value`).
    """
    stop = spec.n_points if stop is None else min(stop, spec.n_points)
    for i in range(start, stop):
        yield point_value(spec, i)


def point_values(spec: SweepSpec) -> list[dict[str, Any]]:
    """Swept key → value of every point, in point order (see the module docstring).

    Holds every point in memory; large sweeps use :func:`point_value` /
    :func:`iter_point_values`.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.

    Returns
    -------
    list of dict
        Per point, dotted key → value.
    """
    return list(iter_point_values(spec))


def check_axis_values(spec: SweepSpec, config_cls: type) -> None:
    """Check every value of every axis against its key's type, range or choices.

    Costs one field check per axis value (not per point), so a 10⁷-point spec is checked
    in milliseconds; the cross-field checks of whole configs are left to the points that
    are validated in full.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    config_cls : type
        The scenario's config dataclass.

    Raises
    ------
    UserError
        A value is not allowed (one line naming the axis, the value's step and the key).
    """
    for a_index, axis in enumerate(spec.axes):
        for j, key in enumerate(axis.keys):
            for step, value in enumerate(axis_support(axis, j)):
                try:
                    check_value(config_cls, key, value)
                except ConfigError as err:
                    raise UserError(f"sweep axes[{a_index}] value {step}: {err}") from None


def _set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    parts = key.split(".")
    node = data
    for part in parts[:-1]:
        child = node.get(part)
        if child is None:
            child = node[part] = {}
        elif not isinstance(child, dict):
            raise ConfigError(".".join(parts[:-1]), child, "a table (it is a plain value)")
        node = child
    node[parts[-1]] = copy.deepcopy(value)


def point_config_dict(spec: SweepSpec, values: Mapping[str, Any]) -> dict[str, Any]:
    """The nested config mapping of one point: ``[base]`` with the swept values set.

    Parameters
    ----------
    spec : SweepSpec
        The sweep (its ``base``).
    values : mapping of str to object
        Dotted key → value of the point (:func:`point_value`).

    Returns
    -------
    dict
        A deep copy of ``spec.base`` with each dotted key set (sub-tables created).

    Raises
    ------
    rfsim.core.errors.ConfigError
        A dotted key runs through a plain value of ``base``.
    """
    data = copy.deepcopy(dict(spec.base))
    for key, value in values.items():
        _set_dotted(data, key, value)
    return data


def _short(values: Mapping[str, Any]) -> str:
    text = ", ".join(f"{k}={v!r}" for k, v in values.items())
    return text if len(text) <= 120 else text[:117] + "..."


def point_config(spec: SweepSpec, config_cls: type, index: int, values: Mapping[str, Any] | None = None) -> Any:
    """Validated config of point ``index``; a bad point raises a one-line error.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    config_cls : type
        The scenario's config dataclass.
    index : int
        Point index.
    values : mapping of str to object, optional
        The point's swept values when already computed; None (default):
        :func:`point_value`.

    Returns
    -------
    Config
        An instance of ``config_cls`` (:func:`rfsim.core.config.from_dict`).

    Raises
    ------
    UserError
        The point's config is invalid; the message names the point index and its swept
        values, then the key, the value and what is allowed (the
        :class:`~rfsim.core.errors.ConfigError` of :func:`rfsim.core.config.from_dict`).
    IndexError
        ``index`` is out of range (when ``values`` is None).
    """
    values = point_value(spec, index) if values is None else values
    try:
        return from_dict(config_cls, point_config_dict(spec, values))
    except ConfigError as err:
        where = f"sweep point {index}" + (f" ({_short(values)})" if values else "")
        raise UserError(f"{where}: {err}") from None


def point_configs(spec: SweepSpec, config_cls: type) -> list[Any]:
    """Validated config of every point (in memory); the first bad point raises.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    config_cls : type
        The scenario's config dataclass.

    Returns
    -------
    list of Config
        One config per point, in point order (:func:`point_config`).

    Raises
    ------
    UserError
        A point's config is invalid.
    """
    return [point_config(spec, config_cls, i) for i in range(spec.n_points)]


def point_seed(seed: int, point: int, repetition: int) -> int:
    """Run seed of point ``point``, repetition ``repetition`` of a sweep with root ``seed``.

    The first 64-bit word of ``SeedSequence(seed, spawn_key=(point, repetition))``'s state,
    shifted to 63 bits (so it fits a signed int64 column): independent of the executor.

    Parameters
    ----------
    seed : int
        Root seed of the sweep.
    point : int
        Point index.
    repetition : int
        Repetition of the point.

    Returns
    -------
    int
        The run seed, in ``[0, 2**63)``.
    """
    word = trial_seed_sequence(seed, point, repetition).generate_state(1, np.uint64)[0]
    return int(word >> np.uint64(1))


def shard_runs(n_runs: int, shard: int, n_shards: int) -> range:
    """Flat run indices (``point * repetitions + repetition``) of shard ``shard`` of ``n_shards``.

    Strided (``shard, shard + n_shards, ...``) so that shards get similar mixes of points.

    Parameters
    ----------
    n_runs : int
        Runs of the sweep.
    shard : int
        Shard index ``I``, in ``[0, n_shards)``.
    n_shards : int
        Number of shards ``N``.

    Returns
    -------
    range
        ``range(shard, n_runs, n_shards)``.

    Raises
    ------
    UserError
        ``shard`` is not in ``[0, n_shards)``.
    """
    if not 0 <= shard < n_shards:
        raise UserError(f"--shard {shard}/{n_shards}: expected I/N with 0 <= I < N")
    return range(shard, n_runs, n_shards)


__all__ = [
    "Axis",
    "SweepSpec",
    "DISTRIBUTIONS",
    "load_spec",
    "parse_spec",
    "point_value",
    "axis_support",
    "iter_point_values",
    "point_values",
    "check_axis_values",
    "point_config",
    "point_config_dict",
    "point_configs",
    "point_seed",
    "shard_runs",
]

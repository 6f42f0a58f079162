"""Per-point persistence, resume checks and the merge of a sweep's point files.

Every finished run (point ``i``, repetition ``k``) is written, as soon as it finishes,
to the *point store* beside the output::

    <output>.points/point-000123-rep-00.h5

with :func:`rfsim.dataset.write_dataset` (temporary name, fsync, rename), so a killed
sweep never loses a finished point and never leaves a truncated point file. A point file
is *valid* for resuming when it opens and its provenance holds the same scenario, seed
and resolved config (TOML text) as the point it stands for — a changed spec recomputes
the points it changed.

Merge (:func:`merge_points`): tables of the same name are concatenated over the runs in
(point, repetition) order with added columns ``sweep_point``, ``sweep_repetition`` and one
column ``sweep.<key>`` per swept key (units from the config field metadata; list values
are stored as their TOML text). The prefix keeps them apart from the scenario's own
columns (the ``link`` scenario has a ``point`` column of its own). A table ``sweep_runs``
has one row per run: ``point``, ``repetition``, ``seed``, the swept values under their
dotted keys and the scalar root attributes of the run's dataset. A grid present in every
run with identical coordinates and variable shapes is stacked along two new leading
dimensions ``sweep_point`` and ``sweep_repetition`` (with the variables
``sweep.<key>`` over ``sweep_point``); otherwise each run's copy is stored as its own
grid ``<grid>__point-000123-rep-00``.
"""

from __future__ import annotations

import dataclasses
import importlib
import os
import resource
import sys
import time
import typing
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from rfsim.config import field_meta, to_toml
from rfsim.dataset import Column, Dataset, column, make_provenance, read_dataset, utc_now, write_dataset

_RUNS_TABLE = "sweep_runs"
#: names of the columns/dimensions the merge adds to the scenario's own tables and grids
POINT, REPETITION, KEY_PREFIX = "sweep_point", "sweep_repetition", "sweep."


@dataclasses.dataclass(frozen=True)
class PointTask:
    """Everything a worker needs to run one (point, repetition) and persist it."""

    scenario_module: str
    config: Any
    point: int
    repetition: int
    seed: int
    path: Path


@dataclasses.dataclass(frozen=True)
class PointResult:
    """What a worker reports back: where the file is, how long it took, who ran it."""

    point: int
    repetition: int
    path: Path
    wall_time_s: float
    pid: int
    host: str
    peak_rss_mb: float


def points_dir(output: Path) -> Path:
    """The point store of the sweep writing ``output``."""
    return output.with_name(output.name + ".points")


def point_path(output: Path, point: int, repetition: int) -> Path:
    return points_dir(output) / f"point-{point:06d}-rep-{repetition:02d}.h5"


def _peak_rss_mb() -> float:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 1024.0 if sys.platform != "darwin" else rss / 2**20


def run_point(task: PointTask) -> PointResult:
    """Run one point in this process and write its file atomically (the worker function)."""
    module = importlib.import_module(task.scenario_module)
    start_utc, t0 = utc_now(), time.perf_counter()
    dataset = module.run(task.config, seed=task.seed)
    dataset.scenario = module.NAME
    prov = make_provenance(config_toml=to_toml(task.config), seed=task.seed, scenario=module.NAME,
                           start_time_utc=start_utc,
                           extra={"sweep_point": task.point, "sweep_repetition": task.repetition})
    write_dataset(task.path, dataset, prov)
    return PointResult(task.point, task.repetition, task.path, time.perf_counter() - t0,
                       os.getpid(), os.uname().nodename, _peak_rss_mb())


def is_valid_point(task: PointTask, scenario: str) -> bool:
    """True if ``task.path`` is a complete point file of exactly this point's run."""
    try:
        with h5py.File(task.path, "r") as f:
            prov = f["provenance"].attrs
            return (int(prov["seed"]) == task.seed and str(prov["scenario"]) == scenario
                    and int(prov["sweep_point"]) == task.point
                    and int(prov["sweep_repetition"]) == task.repetition
                    and str(prov["config_toml"]) == to_toml(task.config))
    except (OSError, KeyError, ValueError):
        return False


def remove_partials(output: Path) -> int:
    """Delete temporary files left in the point store by killed writers; returns how many."""
    n = 0
    for p in points_dir(output).glob(".point-*.partial"):
        p.unlink(missing_ok=True)
        n += 1
    return n


# ----------------------------------------------------------------------------- merge


def _key_field(config_cls: type, key: str) -> dataclasses.Field | None:
    cls = config_cls
    parts = key.split(".")
    for j, part in enumerate(parts):
        fields = {f.name: f for f in dataclasses.fields(cls)}
        if part not in fields:
            return None
        if j == len(parts) - 1:
            return fields[part]
        cls = typing.get_type_hints(cls)[part]
        if not dataclasses.is_dataclass(cls):
            return None
    return None


def _value_column(key: str, values: Sequence[Any], config_cls: type) -> Column:
    """One column of the swept values of ``key`` (lists/tuples as their TOML text)."""
    from rfsim.config import toml_value

    f = _key_field(config_cls, key)
    meta = field_meta(f) if f is not None else {"unit": "", "doc": ""}
    if any(isinstance(v, dict) for v in values):  # a whole sub-table swept at once
        data = [repr(v) for v in values]
    elif any(isinstance(v, (list, tuple)) or v is None for v in values):
        data = [toml_value(tuple(v) if isinstance(v, list) else v) for v in values]
    else:
        data = list(values)
    desc = f"swept config value {key}" + (f": {meta['doc']}" if meta["doc"] else "")
    return column(data, meta["unit"], desc)


def merge_points(results: Sequence[tuple[int, int, int, Path]], point_values: Sequence[Mapping[str, Any]],
                 config_cls: type, n_repetitions: int) -> Dataset:
    """Merge the point files ``results`` = [(point, repetition, run seed, path)] in that order."""
    keys = list(point_values[0]) if point_values else []
    datasets = [read_dataset(p) for (_, _, _, p) in results]
    merged = Dataset(title=(datasets[0].title + " (sweep)") if datasets else "sweep",
                     scenario=datasets[0].scenario if datasets else "")
    pts = np.array([r[0] for r in results], dtype=np.int64)
    reps = np.array([r[1] for r in results], dtype=np.int64)

    runs: dict[str, Column] = {
        "point": column(pts, "1", "sweep point index"),
        "repetition": column(reps, "1", "repetition of the point"),
        "seed": column(np.array([r[2] for r in results], dtype=np.int64), "1",
                       "seed the scenario ran with (SeedSequence(seed, spawn_key=(point, repetition)))"),
    }
    for key in keys:
        runs[key] = _value_column(key, [point_values[p][key] for p in pts], config_cls)
    attr_names = [k for k, v in (datasets[0].attrs.items() if datasets else ())
                  if np.ndim(v) == 0 and all(k in d.attrs for d in datasets)]
    for name in attr_names:
        if name not in runs:
            runs[name] = column([d.attrs[name] for d in datasets], "", f"root attribute {name!r} of the run")
    merged.add_table(_RUNS_TABLE, runs)

    table_names: list[str] = []
    for d in datasets:
        table_names += [t for t in d.tables if t not in table_names]
    for name in table_names:
        merged.add_table(name, _concat_table(name, datasets, pts, reps, keys, point_values, config_cls))

    grid_names: list[str] = []
    for d in datasets:
        grid_names += [g for g in d.grids if g not in grid_names]
    for name in grid_names:
        _merge_grid(merged, name, datasets, results, keys, point_values, config_cls, n_repetitions)
    return merged


def _concat_table(name, datasets, pts, reps, keys, point_values, config_cls) -> dict[str, Column]:
    members = [(j, d.tables[name]) for j, d in enumerate(datasets) if name in d.tables]
    cols = list(members[0][1])
    for j, t in members:
        if list(t) != cols:
            raise ValueError(f"table {name!r}: run {j} has columns {list(t)}, the first has {cols}")
    for reserved in [POINT, REPETITION, *(KEY_PREFIX + k for k in keys)]:
        if reserved in cols:
            raise ValueError(f"table {name!r} already has a column {reserved!r}; cannot merge")
    lengths = [len(next(iter(t.values())).data) for _, t in members]
    idx = np.array([j for j, _ in members], dtype=np.int64)
    out: dict[str, Column] = {
        POINT: column(np.repeat(pts[idx], lengths), "1", "sweep point index"),
        REPETITION: column(np.repeat(reps[idx], lengths), "1", "repetition of the point"),
    }
    for key in keys:
        vals = _value_column(key, [point_values[pts[j]][key] for j in idx], config_cls)
        out[KEY_PREFIX + key] = dataclasses.replace(vals, data=np.repeat(vals.data, lengths))
    for c in cols:
        first = members[0][1][c]
        out[c] = Column(np.concatenate([t[c].data for _, t in members]), first.units, first.description)
    return out


def _merge_grid(merged, name, datasets, results, keys, point_values, config_cls, n_reps) -> None:
    members = [d.grids.get(name) for d in datasets]
    n_points = len(datasets) // n_reps if n_reps else 0
    stackable = all(m is not None for m in members) and len(datasets) == n_points * n_reps
    if stackable:
        c0, v0 = members[0]
        for c, v in members[1:]:
            if (list(c) != list(c0) or list(v) != list(v0)
                    or any(not np.array_equal(c[k].data, c0[k].data) for k in c0)
                    or any(v[k].data.shape != v0[k].data.shape or v[k].dims != v0[k].dims for k in v0)):
                stackable = False
                break
    if not stackable:
        for (p, k, _, _), m in zip(results, members):
            if m is not None:
                merged.add_grid(f"{name}__point-{p:06d}-rep-{k:02d}", *m)
        return
    c0, v0 = members[0]
    for reserved in (POINT, REPETITION, *(KEY_PREFIX + k for k in keys)):
        if reserved in c0 or reserved in v0:
            raise ValueError(f"grid {name!r} already has {reserved!r}; cannot merge")
    coords = {POINT: column(np.arange(n_points, dtype=np.int64), "1", "sweep point index"),
              REPETITION: column(np.arange(n_reps, dtype=np.int64), "1", "repetition of the point"),
              **c0}
    variables: dict[str, Column] = {}
    for key in keys:
        vals = _value_column(key, [point_values[p][key] for p in range(n_points)], config_cls)
        variables[KEY_PREFIX + key] = dataclasses.replace(vals, dims=(POINT,))
    for vname, v in v0.items():
        stacked = np.stack([m[1][vname].data for m in members]).reshape(
            (n_points, n_reps) + v.data.shape)
        variables[vname] = Column(stacked, v.units, v.description, (POINT, REPETITION, *v.dims))
    merged.add_grid(name, coords, variables)


def write_merged(output: Path, merged: Dataset, provenance: Mapping[str, Any]) -> Path:
    """Write the merged dataset atomically under its final name."""
    return write_dataset(output, merged, provenance)


__all__ = [
    "PointTask",
    "PointResult",
    "points_dir",
    "point_path",
    "run_point",
    "is_valid_point",
    "remove_partials",
    "merge_points",
    "write_merged",
]

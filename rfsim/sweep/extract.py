"""Extract one point of a merged sweep into a standalone dataset file.

:func:`extract_point` writes the rows, grids and scalars of point ``N`` (one repetition,
or all of them) of a merged sweep file (:mod:`rfsim.sweep.merge`) as a dataset of its own,
which ``rfsim info`` and ``rfsim plot`` read like the file of a single ``rfsim run``:

* every table, cut to the rows of the point (their ``sweep_point``, ``sweep_repetition``
  and ``sweep.<key>`` columns are kept, so the rows equal the merged file's rows);
* a stacked grid, sliced at the point (and at the repetition, which gives back the run's
  own grid; without one, the grid keeps its ``sweep_repetition`` dimension); a grid kept
  per run (``<grid>__point-000123-rep-00``) under its own name ``<grid>`` for one run,
  under its per-run names for several; the ``sweep.<key>`` grid variables are left out
  (the values are in the config and in the tables);
* for one run, the root attributes of that run (its scalar results, from ``sweep_runs``;
  attributes that were arrays are not kept by the merge and so are not restored);
* the provenance: the resolved config of the point (``config_toml``, rebuilt from the
  spec stored in the merged file: its TOML text, or the JSON of a spec given as a mapping),
  the run's seed (the sweep's root seed when several
  repetitions are extracted), the scenario name, the software versions of the sweep, and
  ``sweep_point``, ``sweep_repetition`` (-1: all), ``sweep_seed``, ``sweep_spec_toml`` and
  ``extracted_from``.

One run is chosen by ``repetition``; a sweep of one repetition gives its only run without it.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from rfsim.core.config import to_toml
from rfsim.core.dataset import Column, Dataset, write_dataset
from rfsim.core.errors import UserError
from rfsim.runs.registry import get_scenario
from rfsim.sweep.merge import KEY_PREFIX, POINT, REPETITION, RUNS_TABLE
from rfsim.sweep.spec import parse_spec, point_config, point_seed

#: provenance attributes copied from the merged file (how and with what it was computed)
_SOFTWARE = ("rfsim_version", "git_revision", "start_time_utc", "platform", "python", "numpy", "numba", "h5py")
_BOOL_ATTR = "rfsim_dtype"
_ROW = "row"


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _read(ds: h5py.Dataset, index: Any = ()) -> np.ndarray:
    """``ds[index]`` as written by :mod:`rfsim.core.dataset` (text as ``str``, flags as bool)."""
    if h5py.check_string_dtype(ds.dtype) is not None:
        return np.asarray(ds.asstr()[index]).astype(str)
    data = np.asarray(ds[index])
    return data.astype(bool) if ds.attrs.get(_BOOL_ATTR) == "bool" else data


def _column(ds: h5py.Dataset, data: np.ndarray, dims: tuple[str, ...] = ()) -> Column:
    return Column(data, _text(ds.attrs.get("units", "")), _text(ds.attrs.get("description", "")), dims)


def _dims(ds: h5py.Dataset) -> tuple[str, ...]:
    return tuple(ds.dims[i][0].name.rsplit("/", 1)[-1] if len(ds.dims[i]) else "" for i in range(ds.ndim))


def _rows(g: h5py.Group, point: int, repetition: int | None) -> slice:
    """The rows of ``point`` (and ``repetition``) of a merged table: one contiguous range,
    since the runs are concatenated in (point, repetition) order."""
    mask = _read(g[POINT]) == point
    if repetition is not None:
        mask &= _read(g[REPETITION]) == repetition
    where = np.flatnonzero(mask)
    if where.size == 0:
        return slice(0, 0)
    return slice(int(where[0]), int(where[-1]) + 1)


def _is_sweep(f: h5py.File) -> bool:
    return "provenance" in f and "spec_toml" in f["provenance"].attrs and RUNS_TABLE in f


def extract_point(merged: str | Path, point: int, output: str | Path, *, repetition: int | None = None) -> Path:
    """Write one point of a merged sweep file as a standalone dataset.

    Point ``point`` (repetition ``repetition``, or all of them) of ``merged`` is written to
    ``output`` as a dataset that ``rfsim info`` and ``rfsim plot`` read like the file of a
    single run (what is kept: see the module docstring).

    Parameters
    ----------
    merged : str or pathlib.Path
        The merged sweep file (:mod:`rfsim.sweep.merge`).
    point : int
        Index of the point, in ``[0, n_points)``.
    output : str or pathlib.Path
        The dataset file to write.
    repetition : int, optional
        Repetition to extract, in ``[0, n_repetitions)``; None (default) extracts all
        repetitions (a sweep of one repetition gives its only run).

    Returns
    -------
    pathlib.Path
        The written path.

    Raises
    ------
    UserError
        ``merged`` is missing, not an HDF5 file or not a merged sweep; ``point`` or
        ``repetition`` is out of range; the merged file does not hold its spec.
    """
    merged, output = Path(merged), Path(output)
    if not merged.is_file():
        raise UserError(f"sweep extract: {str(merged)!r}: no such file")
    try:
        f = h5py.File(merged, "r")
    except OSError:
        raise UserError(f"sweep extract: {str(merged)!r} is not an HDF5 file") from None
    with f:
        if not _is_sweep(f):
            raise UserError(f"sweep extract: {str(merged)!r} is not a merged sweep (no provenance "
                            f"spec_toml or no {RUNS_TABLE} table)")
        prov = {k: f["provenance"].attrs[k] for k in f["provenance"].attrs}
        n_points, n_reps = int(prov["sweep_points"]), int(prov["sweep_repetitions"])
        if not 0 <= point < n_points:
            raise UserError(f"--point {point}: expected an integer in [0, {n_points - 1}] "
                            f"(the sweep has {n_points} points)")
        if repetition is not None and not 0 <= repetition < n_reps:
            raise UserError(f"--repetition {repetition}: expected an integer in [0, {n_reps - 1}] "
                            f"(the sweep has {n_reps} repetitions)")
        if repetition is None and n_reps == 1:
            repetition = 0
        scenario = _text(f.attrs.get("scenario", ""))
        keys = [k for k in _text(prov.get("sweep_keys", "")).split(", ") if k]
        title = _text(f.attrs.get("title", "")).removesuffix(" (sweep)")
        where = f"sweep point {point}" + (f", repetition {repetition}" if repetition is not None else "")
        out = Dataset(title=f"{title} ({where})", scenario=scenario)
        runs_rows = _rows(f[RUNS_TABLE], point, repetition)
        for gname, g in f.items():
            if gname == "provenance" or not isinstance(g, h5py.Group):
                continue
            desc = _text(g.attrs.get("description", ""))
            if _ROW in g and g[_ROW].is_scale:
                rows = _rows(g, point, repetition) if POINT in g else slice(0, 0)
                out.add_table(gname, {k: _column(ds, _read(ds, rows)) for k, ds in g.items() if k != _ROW}, desc)
            elif POINT in g and g[POINT].is_scale:
                _add_stacked(out, gname, g, point, repetition, desc)
            elif "__point-" in gname:
                base, _, tag = gname.rpartition("__point-")
                p, _, k = tag.partition("-rep-")
                if int(p) != point or (repetition is not None and int(k) != repetition):
                    continue
                name = base if repetition is not None else gname
                coords = {k2: _column(ds, _read(ds)) for k2, ds in g.items() if ds.is_scale}
                variables = {k2: _column(ds, _read(ds), _dims(ds)) for k2, ds in g.items() if not ds.is_scale}
                out.add_grid(name, coords, variables, desc)
            else:  # a grid not written by the merge: copied as it is
                coords = {k2: _column(ds, _read(ds)) for k2, ds in g.items() if ds.is_scale}
                variables = {k2: _column(ds, _read(ds), _dims(ds)) for k2, ds in g.items() if not ds.is_scale}
                out.add_grid(gname, coords, variables, desc)
        if repetition is not None:
            skip = {POINT, REPETITION, "seed", *keys}
            runs = f[RUNS_TABLE]
            for name, ds in runs.items():
                if name not in skip and name != _ROW:
                    value = _read(ds, runs_rows)[0]
                    out.attrs[name] = str(value) if isinstance(value, str) else value
        spec_text = _text(prov.get("spec_toml", ""))
        spec_json = _text(prov.get("spec_json", ""))
    config_toml = _point_config_toml(spec_text, spec_json, scenario, point)
    root_seed = int(prov["seed"])
    provenance = {k: prov[k] for k in _SOFTWARE if k in prov}
    provenance.update(
        config_toml=config_toml, scenario=scenario,
        seed=point_seed(root_seed, point, repetition) if repetition is not None else root_seed,
        sweep_point=point, sweep_repetition=-1 if repetition is None else repetition, sweep_seed=root_seed,
        sweep_spec_toml=spec_text, extracted_from=merged.name)
    return write_dataset(output, out, provenance)


def _add_stacked(out: Dataset, name: str, g: h5py.Group, point: int, repetition: int | None, desc: str) -> None:
    """A grid stacked along (sweep_point, sweep_repetition, ...), sliced at the point."""
    coords = {k: _column(ds, _read(ds)) for k, ds in g.items()
              if ds.is_scale and k != POINT and (k != REPETITION or repetition is None)}
    variables = {}
    for k, ds in g.items():
        if ds.is_scale or k.startswith(KEY_PREFIX):
            continue
        dims = _dims(ds)
        if dims[:2] != (POINT, REPETITION):  # not one of the stacked variables
            continue
        if repetition is None:
            variables[k] = _column(ds, _read(ds, point), dims[1:])
        else:
            variables[k] = _column(ds, _read(ds, (point, repetition)), dims[2:])
    out.add_grid(name, coords, variables, desc)


def _point_config_toml(spec_text: str, spec_json: str, scenario: str, point: int) -> str:
    """The resolved config of ``point``, rebuilt from the spec stored in the merged file (its
    TOML text, or — for a spec given as a mapping — its JSON; the output is irrelevant here)."""
    if spec_text:
        data = tomllib.loads(spec_text)
    elif spec_json:
        data = json.loads(spec_json)
    else:
        raise UserError(f"sweep extract: the merged file does not hold its spec, so the config of point "
                        f"{point} cannot be rebuilt")
    spec = parse_spec(data, output="unused.h5")
    return to_toml(point_config(spec, get_scenario(scenario).Config, point))


__all__ = ["extract_point"]

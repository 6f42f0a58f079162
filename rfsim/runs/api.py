"""The Python API: run a scenario or a sweep from a script or a notebook.

::

    import rfsim

    result = rfsim.run("link", seed=1, **{"geometry.distances_m": [1.0, 2.0], "rounds_per_point": 5})
    result.tables                      # ('reads',): the dataset's tables
    frame = result.table("reads")      # a pandas DataFrame; units in frame.attrs["units"]
    tree = result.to_xarray()          # every group as one xarray DataTree
    result.figures()                   # the scenario's figures, shown inline in a notebook
    result.save("link.h5")             # the same file as 'rfsim run link --seed 1 --set ...'

:func:`run` takes a built-in or plug-in scenario's name or the path of a scenario file
(``"my_scenario.py"``, :mod:`rfsim.runs.registry`), a ``config`` (the scenario's ``Config``,
a nested mapping or a TOML file) and overrides with the dotted keys of ``rfsim run --set``
(``**{"reader.ptx_dbm": 30}``) or as nested mappings (``reader={"ptx_dbm": 30}``), checked
like the command line's: a wrong key or value is a one-line
:class:`~rfsim.core.errors.ConfigError` naming the key. The default seed is 1, the
command line's, so ``rfsim.run(name)`` gives the dataset of ``rfsim run name``, bit for bit.

The run happens in this process and writes nothing: the :class:`Result` holds the dataset
in memory until :meth:`Result.save` writes it. Progress (stages, the numba compile notice,
the scenario's bars) goes to stderr; in a Jupyter notebook the bars are ``tqdm.auto``
widgets. :func:`run_sweep` runs a sweep spec (:mod:`rfsim.sweep.spec`) and returns the merged
file as a :class:`Result`.

:meth:`Result.table` needs pandas and :meth:`Result.to_xarray` xarray: both are in the
optional extra ``analysis`` (``pip install 'rfsim[analysis]'``); without them these two
methods raise a one-line :class:`~rfsim.core.errors.UserError` that names the extra.
"""

from __future__ import annotations

import base64
import copy
import dataclasses
import html
import io
import shutil
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from rfsim.channels import Scene
from rfsim.core.config import from_dict, read_toml, to_dict, to_toml
from rfsim.core.dataset import (Column, Dataset, long_name, make_provenance, read_dataset, read_provenance, utc_now,
                                write_dataset, write_root_attrs)
from rfsim.core.errors import ConfigError, UserError, check_seed, did_you_mean
from rfsim.core.lazy import lazy_import
from rfsim.core.outputs import check_output_file
from rfsim.core.progress import Reporter, reporting
from rfsim.runs.kernel_plan import precompile_scenario
from rfsim.runs.registry import get_scenario
from rfsim.sweep.executors import PoolExecutor, SerialExecutor
from rfsim.sweep.runner import run_sweep as run_spec
from rfsim.sweep.spec import SweepSpec, load_spec, parse_spec

h5py = lazy_import("h5py")

#: The command line's default seed (``rfsim run --seed``), used when ``seed`` is None.
DEFAULT_SEED = 1
#: The optional extra that brings pandas and xarray.
ANALYSIS_EXTRA = "analysis"


# ----------------------------------------------------------------------------- config


def _set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    """Set ``value`` at the dotted ``key`` of the nested mapping ``data``; a mapping value is
    merged into the table already there (so ``reader={"ptx_dbm": 30}`` keeps the other
    reader keys)."""
    parts = key.split(".")
    if not key or any(not p for p in parts):
        raise UserError(f"override {key!r}: the key must be dotted names, e.g. reader.ptx_dbm")
    node = data
    for i, part in enumerate(parts[:-1]):
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            raise ConfigError(".".join(parts[:i + 1]), child, "a table (it is a plain value)")
        node = child
    old = node.get(parts[-1])
    if isinstance(value, Mapping) and isinstance(old, dict):
        for k, v in value.items():
            _set_dotted(old, str(k), v)
    else:
        node[parts[-1]] = copy.deepcopy(dict(value) if isinstance(value, Mapping) else value)


def resolve_config(module: ModuleType, config: Any = None, overrides: Mapping[str, Any] | None = None) -> Any:
    """Return the validated ``module.Config`` of ``config`` with ``overrides`` applied.

    Parameters
    ----------
    module : module
        The scenario module (or a scene file's module, whose config is the file itself:
        then ``config`` must be None or its ``Config`` and ``overrides`` act as ``--set``).
    config : object, optional
        None (the defaults), an instance of ``module.Config``, a mapping (nested tables
        and/or dotted keys) or the path of a TOML file (as ``rfsim run --config``).
    overrides : mapping of str to object, optional
        Dotted key → value (as ``rfsim run --set key=value``; a mapping value sets the keys
        of that table).

    Returns
    -------
    object
        The scenario's ``Config`` instance.

    Raises
    ------
    rfsim.core.errors.ConfigError
        A wrong key, type or value: one line naming the dotted key, the same checks as the
        command line's.
    rfsim.core.errors.UserError
        ``config`` of an unsupported type, or a malformed dotted key.
    """
    if hasattr(module, "scene_config"):  # a scene file is its own config; overrides as --set
        if config is not None and not isinstance(config, module.Config):
            raise UserError(f"config: scene file {module.NAME!r} is its own config; change values with "
                            f"overrides (e.g. **{{'reader.0.ptx_dbm': 20}})")
        if isinstance(config, module.Config):
            return config
        return module.scene_config(None, [f"{k}={_toml_literal(v)}" for k, v in (overrides or {}).items()])
    data: dict[str, Any] = {}
    if isinstance(config, (str, Path)):
        data = read_toml(config)
    elif isinstance(config, module.Config):
        data = to_dict(config)
    elif isinstance(config, Mapping):
        for key, value in config.items():
            _set_dotted(data, str(key), value)
    elif config is not None:
        raise UserError(f"config: expected None, a {module.NAME} Config, a mapping or a TOML file path, "
                        f"got {type(config).__name__}")
    for key, value in (overrides or {}).items():
        _set_dotted(data, str(key), value)
    return from_dict(module.Config, data)


def _toml_literal(value: Any) -> str:
    """``value`` as the TOML text a ``--set KEY=VALUE`` takes (numbers, booleans, strings, arrays)."""
    import json

    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_literal(v) for v in value) + "]"
    if isinstance(value, str):
        return json.dumps(value)
    return repr(value)


# ----------------------------------------------------------------------------- progress


def _notebook_tqdm():
    """``tqdm.auto.tqdm`` when it is the notebook widget (in Jupyter), else None."""
    from tqdm.auto import tqdm as auto_tqdm
    from tqdm.std import tqdm as std_tqdm

    return None if auto_tqdm is std_tqdm else auto_tqdm


class NotebookReporter(Reporter):
    """A :class:`~rfsim.core.progress.Reporter` whose bars are ``tqdm.auto`` widgets in a
    Jupyter notebook (and the reporter's own terminal or log bars elsewhere)."""

    def bar(self, total: int | None, *, desc: str, unit: str, initial: int = 0):  # noqa: D102
        """Return a progress bar: a ``tqdm.auto`` widget in Jupyter, else the reporter's own.

        Parameters
        ----------
        total : int or None
            Number of steps (None: unknown).
        desc : str
            Label shown before the bar.
        unit : str
            Name of one step (e.g. ``"round"``).
        initial : int, optional
            Steps already done, default 0.

        Returns
        -------
        object
            A tqdm-like bar (``update``, ``close``); a quiet reporter's is silent.
        """
        widget = None if self.quiet else _notebook_tqdm()
        if widget is None:
            return super().bar(total, desc=desc, unit=unit, initial=initial)
        return widget(total=total, initial=initial, desc=desc, unit=unit, leave=True)


# ----------------------------------------------------------------------------- optional libraries


def _pandas():
    try:
        import pandas
    except ImportError:
        raise UserError(f"Result.table needs pandas: pip install 'rfsim[{ANALYSIS_EXTRA}]'") from None
    return pandas


def _xarray():
    try:
        import xarray
    except ImportError:
        raise UserError(f"Result.to_xarray needs xarray: pip install 'rfsim[{ANALYSIS_EXTRA}]'") from None
    if not hasattr(xarray, "DataTree"):
        raise UserError(f"Result.to_xarray needs xarray >= 2024.10 (DataTree), found {xarray.__version__}: "
                        f"pip install -U 'rfsim[{ANALYSIS_EXTRA}]'")
    return xarray


def _decoded(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """HDF5 attributes as a dict, byte strings decoded (as :func:`~rfsim.core.dataset.read_provenance`)."""
    return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in attrs.items()}


def _var_attrs(col: Column, name: str) -> dict[str, str]:
    """CF attributes of a column (as in the file: units, long_name, description)."""
    return {"units": col.units, "long_name": long_name(col.description) or name, "description": col.description}


# ----------------------------------------------------------------------------- figures


@dataclasses.dataclass(frozen=True)
class FigureImage:
    """One figure of a scenario as a PNG image (shown inline by Jupyter).

    Attributes
    ----------
    name : str
        The figure's file stem.
    png : bytes
        The PNG file's bytes.
    path : pathlib.Path or None
        The file it was written to (None when drawn into a temporary folder).
    """

    name: str
    png: bytes
    path: Path | None = None

    def _repr_png_(self) -> bytes:
        return self.png

    def save(self, path: str | Path) -> Path:
        """Write the PNG to ``path``.

        Parameters
        ----------
        path : str or pathlib.Path
            The file to write (overwritten if it exists).

        Returns
        -------
        pathlib.Path
            ``path``.
        """
        path = Path(path)
        path.write_bytes(self.png)
        return path


class Figures(tuple):
    """The figures of a run (a tuple of :class:`FigureImage`); a notebook shows them all
    inline, each under its name."""

    def _repr_html_(self) -> str:
        parts = []
        for fig in self:
            data = base64.b64encode(fig.png).decode("ascii")
            parts.append(f"<figure><img src='data:image/png;base64,{data}'/>"
                         f"<figcaption>{html.escape(fig.name)}</figcaption></figure>")
        return "".join(parts)

    @property
    def paths(self) -> tuple[Path | None, ...]:
        """The files the figures were written to (None for a temporary folder)."""
        return tuple(f.path for f in self)


# ----------------------------------------------------------------------------- result


class Result:
    """A scenario's dataset (in memory, or a file for a sweep) with its run's metadata.

    Parameters
    ----------
    module : module
        The scenario module.
    dataset : rfsim.core.dataset.Dataset, optional
        The dataset in memory (a run's).
    path : pathlib.Path, optional
        The dataset file (a sweep's merged file), read on first use. One of ``dataset``
        and ``path`` is needed.
    config : object, optional
        The resolved config.
    seed : int, optional
        The root seed.
    provenance : mapping, optional
        The provenance attributes; None reads them from ``path``.
    wall_time_s : float, optional
        Wall time of the run [s], default NaN.
    figures_drawable : bool, optional
        Whether the scenario's figures can be drawn from this dataset (False for a sweep),
        default True.

    Attributes
    ----------
    scenario : str
        The scenario's name.
    module : module
        The scenario module.
    config : object
        The resolved config (None for a sweep: its points have their own).
    seed : int
        The root seed.
    provenance : dict
        How the dataset was made (as the file's ``/provenance`` attributes;
        ``end_time_utc`` is stamped when the dataset is saved).
    path : pathlib.Path or None
        The sweep's merged file; None for a run (its dataset is in memory; :meth:`save`
        writes a copy and leaves the result as it is).
    wall_time_s : float
        Wall time of the run [s].

    Raises
    ------
    ValueError
        Neither ``dataset`` nor ``path`` is given.
    """

    def __init__(self, *, module: ModuleType, dataset: Dataset | None = None, path: Path | None = None,
                 config: Any = None, seed: int | None = None, provenance: Mapping[str, Any] | None = None,
                 wall_time_s: float = float("nan"), figures_drawable: bool = True):
        if dataset is None and path is None:
            raise ValueError("a Result needs a dataset or a file")
        self.module, self.scenario = module, module.NAME
        self._dataset, self.path = dataset, (Path(path) if path is not None else None)
        self.config, self.seed, self.wall_time_s = config, seed, wall_time_s
        self.provenance = dict(provenance) if provenance is not None else read_provenance(self.path)
        self._figures_drawable = figures_drawable

    def __repr__(self) -> str:
        where = f", path={str(self.path)!r}" if self.path is not None else ""
        return (f"<rfsim Result {self.scenario!r} seed={self.seed} tables={list(self.tables)} "
                f"grids={list(self.grids)}{where}>")

    @property
    def dataset(self) -> Dataset:
        """The :class:`~rfsim.core.dataset.Dataset` (read from the file on first use for a sweep)."""
        if self._dataset is None:
            self._dataset = read_dataset(self.path)
        return self._dataset

    @property
    def tables(self) -> tuple[str, ...]:
        """Names of the dataset's tables."""
        return tuple(self.dataset.tables)

    @property
    def grids(self) -> tuple[str, ...]:
        """Names of the dataset's grids."""
        return tuple(self.dataset.grids)

    @property
    def attrs(self) -> dict[str, Any]:
        """The dataset's scalar results (the file's root attributes beside title and scenario)."""
        return dict(self.dataset.attrs)

    def _group_error(self, name: str, kind: str) -> UserError:
        names = self.tables if kind == "table" else self.grids
        return UserError(f"{self.scenario} has no {kind} {name!r}{did_you_mean(name, names)}; "
                         f"its {kind}s: {', '.join(names) or 'none'}")

    def table(self, name: str):
        """Return table ``name`` as a pandas DataFrame, one column per field.

        Parameters
        ----------
        name : str
            The table's name (one of :attr:`tables`).

        Returns
        -------
        pandas.DataFrame
            One row per table row. ``frame.attrs`` holds ``units`` (column → unit, e.g.
            ``"dBm"``; ``"1"`` for counts), ``descriptions`` (column → what it is),
            ``description`` (what one row is) and ``name``. Booleans stay bool, text
            columns are ``str``.

        Raises
        ------
        rfsim.core.errors.UserError
            No such table, or pandas is not installed (extra ``analysis``).
        """
        if name not in self.dataset.tables:
            raise self._group_error(name, "table")
        pd = _pandas()
        cols = self.dataset.tables[name]
        frame = pd.DataFrame({k: c.data for k, c in cols.items()})
        frame.attrs = {"name": name, "description": self.dataset.descriptions.get(name, ""),
                       "units": {k: c.units for k, c in cols.items()},
                       "descriptions": {k: c.description for k, c in cols.items()}}
        return frame

    def grid(self, name: str):
        """Return grid ``name`` as an :class:`xarray.Dataset`.

        Parameters
        ----------
        name : str
            The grid's name (one of :attr:`grids`).

        Returns
        -------
        xarray.Dataset
            Coordinates and variables with their ``units``, ``long_name`` and
            ``description`` attributes; the grid's description in ``attrs``.

        Raises
        ------
        rfsim.core.errors.UserError
            No such grid, or xarray (>= 2024.10) is not installed (extra ``analysis``).
        """
        if name not in self.dataset.grids:
            raise self._group_error(name, "grid")
        return self._grid_xr(_xarray(), name)

    def _table_xr(self, xr, name: str):
        cols = self.dataset.tables[name]
        n = len(next(iter(cols.values())).data)
        ds = xr.Dataset({k: ("row", c.data, _var_attrs(c, k)) for k, c in cols.items()},
                        coords={"row": ("row", np.arange(n, dtype=np.int64),
                                        {"units": "1", "long_name": "row index"})})
        ds.attrs["description"] = self.dataset.descriptions.get(name, "")
        return ds

    def _grid_xr(self, xr, name: str):
        coords, variables = self.dataset.grids[name]
        ds = xr.Dataset({k: (v.dims, v.data, _var_attrs(v, k)) for k, v in variables.items()},
                        coords={k: (k, c.data, _var_attrs(c, k)) for k, c in coords.items()})
        ds.attrs["description"] = self.dataset.descriptions.get(name, "")
        return ds

    def _root_attrs(self) -> dict[str, Any]:
        """Return the root attributes of the dataset's HDF5 file.

        For a sweep these are the merged file's own root attributes. For a run they are
        those :meth:`save` would write now: ``title``, ``scenario``, ``rfsim_version``,
        ``Conventions``, ``source``, ``history`` and the scalar results, written by
        :func:`~rfsim.core.dataset.write_root_attrs` into an in-memory HDF5 file and read
        back, so that names, values and types are those of the saved file.

        Returns
        -------
        dict of str to object
            Attribute name to value, as h5py reads them (text as ``str``). The time
            stamp that begins the last ``history`` line is the time of this call (the
            saved file's is the time of :meth:`save`).
        """
        if self.path is not None:
            with h5py.File(self.path, "r") as f:
                return _decoded(f.attrs)
        with h5py.File(io.BytesIO(), "w") as f:
            write_root_attrs(f, self.dataset, self.provenance)
            return _decoded(f.attrs)

    def to_xarray(self):
        """Return every group of the dataset as one :class:`xarray.DataTree`.

        The root node carries the file's root attributes (``title``,
        ``scenario``, ``rfsim_version``, ``Conventions``, ``source``, ``history`` and the
        scalar results); one child per table (dimension ``row``) and per grid (its named
        coordinates), each variable with ``units``, ``long_name`` and ``description``; a
        ``provenance`` child with the provenance attributes. Needs xarray >= 2024.10 (extra
        ``analysis``).

        Returns
        -------
        xarray.DataTree
            The tree named after the scenario.

        Raises
        ------
        rfsim.core.errors.UserError
            xarray is not installed or older than 2024.10 (one line naming the extra).
        """
        xr = _xarray()
        d = self.dataset
        root = xr.Dataset(attrs=self._root_attrs())
        nodes = {"/": root}
        nodes.update({f"/{name}": self._table_xr(xr, name) for name in d.tables})
        nodes.update({f"/{name}": self._grid_xr(xr, name) for name in d.grids})
        nodes["/provenance"] = xr.Dataset(attrs=dict(self.provenance))
        return xr.DataTree.from_dict(nodes, name=self.scenario)

    def save(self, path: str | Path) -> Path:
        """Write the dataset to the HDF5 file ``path``.

        The file is written atomically in the format of ``rfsim run``, with the run's
        provenance. For a sweep result the merged file is copied.

        Parameters
        ----------
        path : str or pathlib.Path
            The output file (suffix ``.h5`` or ``.hdf5``).

        Returns
        -------
        pathlib.Path
            ``path``.

        Raises
        ------
        rfsim.core.errors.UserError
            ``path`` is not a usable output file (suffix, folder).
        """
        path = Path(path)
        check_output_file(path, "dataset", suffixes=(".h5", ".hdf5"))
        if self._dataset is None:  # a sweep's merged file: copy it whole
            if path.resolve() != self.path.resolve():
                shutil.copyfile(self.path, path)
            return path
        return write_dataset(path, self._dataset, self.provenance)

    def figures(self, folder: str | Path | None = None) -> Figures:
        """Draw the scenario's figures (those of ``rfsim run``) and return them as PNG images.

        The scenarios draw their figures from a dataset file, so the dataset is written to a
        temporary file first (or the result's own file is used).

        Parameters
        ----------
        folder : str or pathlib.Path, optional
            Where to write and keep the PNG files (``<scenario>-<figure>.png``, or after the
            saved file's stem). None draws them into a temporary folder that is removed, and
            only the images are kept.

        Returns
        -------
        Figures
            One :class:`FigureImage` per figure; a notebook shows every image inline.

        Raises
        ------
        rfsim.core.errors.UserError
            The result is a sweep's merged file (it has no scenario figures).
        """
        if not self._figures_drawable:
            raise UserError(f"a sweep's merged dataset has no {self.scenario} figures; "
                            "draw from result.table(...) or result.to_xarray()")
        with tempfile.TemporaryDirectory(prefix="rfsim-figures-") as tmp:
            data_path = self.path if self.path is not None else self.save(Path(tmp) / f"{self.scenario}.h5")
            out = Path(folder) if folder is not None else Path(tmp) / "figures"
            out.mkdir(parents=True, exist_ok=True)
            paths = [Path(p) for p in self.module.plot(data_path, out)]
            return Figures(FigureImage(p.stem, p.read_bytes(), p if folder is not None else None)
                           for p in paths)


# ----------------------------------------------------------------------------- entry points


def run(scenario: str | Path, *, seed: int | None = None, config: Any = None, progress: bool = True,
        **overrides: Any) -> Result:
    """Run a scenario in this process and return its :class:`Result` (nothing is written).

    Parameters
    ----------
    scenario : str or pathlib.Path
        A scenario name (``rfsim list``: built-in or plug-in) or the path of a scenario
        file (``"my_scenario.py"``) or scene file (``.toml``).
    seed : int, optional
        Root seed in [0, 2**64); None gives the command line's default, 1.
    config : object, optional
        None (defaults), the scenario's ``Config``, a mapping or a TOML file path.
    progress : bool, optional
        Show stages and progress bars on stderr (``tqdm.auto`` widgets in Jupyter),
        default True.
    **overrides
        Config values by dotted key, as ``rfsim run --set``:
        ``rfsim.run("link", **{"reader.ptx_dbm": 30})``, or by table:
        ``rfsim.run("link", reader={"ptx_dbm": 30})``.

    Returns
    -------
    Result
        The dataset with its config, seed and provenance: ``.table(name)``,
        ``.to_xarray()``, ``.figures()``, ``.save(path)``.

    Raises
    ------
    rfsim.core.errors.UserError
        An unknown scenario, an invalid scenario file, a bad seed, or (as its subclass
        :class:`~rfsim.core.errors.ConfigError`) a wrong config key or value; ``str(err)``
        is one line.

    Notes
    -----
    With the same scenario, seed and config the dataset equals that of ``rfsim run``
    (the same ``run(config, seed=seed)`` call), bit for bit.
    """
    module = get_scenario(scenario)
    seed = check_seed(DEFAULT_SEED if seed is None else seed)
    resolved = resolve_config(module, config, overrides)
    start_utc, t0 = utc_now(), time.perf_counter()
    with reporting(NotebookReporter(quiet=not progress)) as rep:
        precompile_scenario(module.NAME)  # a cold cache: the scenario's kernels compiled side by side
        rep.stage(f"running {module.NAME} (seed {seed})")
        from rfsim.core.procs import few_collections

        with few_collections():
            dataset = module.run(resolved, seed=seed)
    dataset.scenario = module.NAME
    provenance = make_provenance(config_toml=to_toml(resolved), seed=seed, scenario=module.NAME,
                                 start_time_utc=start_utc)
    return Result(module=module, dataset=dataset, config=resolved, seed=seed, provenance=provenance,
                  wall_time_s=time.perf_counter() - t0)


def _executor(executor: Any):
    if executor is None or executor == "pool":
        return PoolExecutor()
    if executor == "serial":
        return SerialExecutor()
    if isinstance(executor, int) and not isinstance(executor, bool):
        return PoolExecutor(executor)
    if isinstance(executor, str):
        raise UserError(f"executor {executor!r}: expected 'serial', 'pool', a number of worker processes "
                        "or an executor object (rfsim.sweep.DaskExecutor(...), ...)")
    return executor


def run_sweep(spec: Any, *, executor: Any = None, resume: bool = False, progress: bool = True) -> Result:
    """Run the sweep ``spec`` and return its merged dataset as a :class:`Result`.

    Parameters
    ----------
    spec : str, pathlib.Path, mapping or rfsim.sweep.spec.SweepSpec
        The path of a sweep spec TOML file, its content as a mapping or a
        :class:`~rfsim.sweep.spec.SweepSpec` (:mod:`rfsim.sweep.spec`; the scenario may be a
        scenario file's path).
    executor : None, str, int or executor, optional
        None or ``"pool"`` (a process pool over the available cores, as ``rfsim sweep``),
        ``"serial"`` (this process), a number of worker processes, or an executor object
        (:class:`rfsim.sweep.DaskExecutor`, ...).
    resume : bool, optional
        Reuse the runs already in the sweep's point store (``rfsim sweep --resume``),
        default False.
    progress : bool, optional
        Show a progress bar (a ``tqdm.auto`` widget in Jupyter), default True.

    Returns
    -------
    Result
        The merged dataset: the spec's ``output`` file (written, as by ``rfsim sweep``),
        read on first use; no config (each point has its own) and no figures.

    Raises
    ------
    rfsim.core.errors.UserError
        A bad spec, scenario or executor (one line).
    """
    if isinstance(spec, (str, Path)):
        spec = load_spec(spec)
    elif isinstance(spec, Mapping):
        spec = parse_spec(spec)
    elif not isinstance(spec, SweepSpec):
        raise UserError(f"sweep spec: expected a TOML file path, a mapping or a SweepSpec, got {type(spec).__name__}")
    module = get_scenario(spec.scenario)
    ex = _executor(executor)

    def make_progress(total: int, *, done: int) -> _SweepProgress:
        from rfsim.sweep.progress import Progress

        return Progress(total, done=done, reporter=NotebookReporter(quiet=not progress))

    try:
        report = run_spec(spec, ex, resume=resume, progress=make_progress, module=module)
    finally:
        close = getattr(ex, "close", None)
        if close is not None and ex is not executor:
            close()
    return Result(module=module, path=report.output, seed=spec.seed, wall_time_s=report.wall_time_s,
                  figures_drawable=False)


__all__ = ["run", "run_sweep", "Result", "Figures", "FigureImage", "NotebookReporter", "resolve_config",
           "Scene", "DEFAULT_SEED", "ANALYSIS_EXTRA"]

"""Scenario discovery: built-in scenarios, user scenario files and installed plug-ins.

A scenario is any module with the scenario contract: ``NAME``, ``DESCRIPTION``, a config
dataclass ``Config``, ``run(config, *, seed) -> Dataset`` and ``plot(dataset_path, out_dir)
-> list[Path]``. Three places provide them:

* built-in: every module of the ``rfsim.scenarios`` package that defines the contract;
* a user's file: ``get_scenario("path/to/my_scenario.py")`` (``rfsim run my_scenario.py``)
  imports the file under the module name :func:`file_module_name` — a name that encodes the
  file's absolute path, so that any process that imported this registry (a sweep worker, a
  Dask worker) imports the same file by that name (:class:`_ScenarioFileFinder`) and can
  unpickle its ``Config``;
* a scene file: ``get_scenario("path/to/my-scene.toml")`` (``rfsim run my-scene.toml``), a
  TOML file whose top level has ``[[reader]]`` (:mod:`rfsim.scenes.scene_file`): its scenario
  is named after the file's stem and its config is the file itself;
* a plug-in: an installed distribution that declares an entry point in the group
  ``rfsim.scenarios`` (``[project.entry-points."rfsim.scenarios"] my-scenario =
  "my_package.my_scenario"``); the entry point names the module. A plug-in whose ``NAME``
  is already a built-in scenario's is ignored (the built-in wins).

The ``rfsim`` core never imports ``rfsim.scenarios`` at module level; the CLI asks this
registry at run time, so the dependency direction stays scenarios → devices, channels
→ rfsim.
"""

from __future__ import annotations

import ast
import importlib
import importlib.abc
import importlib.util
import pkgutil
import sys
from pathlib import Path
from types import ModuleType

from rfsim.core.errors import UserError, did_you_mean

_REQUIRED = ("NAME", "DESCRIPTION", "Config", "run", "plot")
#: Entry point group of scenario plug-ins.
ENTRY_POINT_GROUP = "rfsim.scenarios"
#: Prefix of the module names of scenario files (followed by the hex of the UTF-8 absolute path).
FILE_MODULE_PREFIX = "rfsim_scenario_file_"
#: Suffixes of scenario files.
FILE_SUFFIXES = (".py",)
#: Suffix of scene files (a deployment described in TOML).
SCENE_SUFFIX = ".toml"


def file_module_name(path: str | Path) -> str:
    """Return the module name a scenario file is imported under.

    The name is :data:`FILE_MODULE_PREFIX` + the hex of the file's absolute path (UTF-8),
    the same in every process and for every spelling of the path.

    Parameters
    ----------
    path : str or pathlib.Path
        The scenario file (relative paths are resolved against the working folder).

    Returns
    -------
    str
        The module name.
    """
    return FILE_MODULE_PREFIX + str(Path(path).resolve()).encode("utf-8").hex()


def _file_of_module_name(name: str) -> Path | None:
    """The scenario file a :func:`file_module_name` encodes, or None for any other name."""
    if not name.startswith(FILE_MODULE_PREFIX) or "." in name:
        return None
    try:
        return Path(bytes.fromhex(name[len(FILE_MODULE_PREFIX):]).decode("utf-8"))
    except (ValueError, UnicodeDecodeError):
        return None


class _ScenarioFileFinder(importlib.abc.MetaPathFinder):
    """Imports the module names of :func:`file_module_name` from the files they encode.

    Installed on ``sys.meta_path`` when this registry is imported, so a worker process
    that unpickles a task (and with it the scenario file's ``Config``) imports the file.
    """

    def find_spec(self, fullname, path=None, target=None):  # noqa: D102 - importlib hook
        file = _file_of_module_name(fullname)
        if file is None or not file.is_file():
            return None
        return importlib.util.spec_from_file_location(fullname, file)


if not any(isinstance(f, _ScenarioFileFinder) for f in sys.meta_path):
    sys.meta_path.append(_ScenarioFileFinder())


def _missing(module: ModuleType) -> list[str]:
    return [a for a in _REQUIRED if not hasattr(module, a)]


def is_scenario_file(name: str) -> bool:
    """Tell whether ``name`` names a scenario file (ends in ``.py``) rather than a scenario.

    Parameters
    ----------
    name : str
        A scenario name or a file name.

    Returns
    -------
    bool
        True when ``name`` ends in one of :data:`FILE_SUFFIXES`.
    """
    return name.endswith(FILE_SUFFIXES)


def scenario_from_file(path: str | Path) -> ModuleType:
    """Import the scenario file ``path`` (see the module docstring).

    Importing the same file again returns the module already imported.

    Parameters
    ----------
    path : str or pathlib.Path
        The scenario file (``.py``).

    Returns
    -------
    module
        The imported scenario module, named :func:`file_module_name` of ``path``.

    Raises
    ------
    rfsim.core.errors.UserError
        A missing file, a file that is not Python, does not import (syntax or import
        error) or lacks the scenario contract (one line).
    """
    p = Path(path)
    if not p.is_file():
        raise UserError(f"scenario file {str(p)!r}: no such file")
    if not is_scenario_file(p.name):
        raise UserError(f"scenario file {str(p)!r}: expected a Python file (*.py)")
    name = file_module_name(p)
    try:
        module = importlib.import_module(name)
    except SyntaxError as err:
        sys.modules.pop(name, None)
        raise UserError(f"scenario file {str(p)!r}: syntax error at line {err.lineno}: {err.msg}") from None
    except ImportError as err:
        sys.modules.pop(name, None)
        raise UserError(f"scenario file {str(p)!r}: cannot be imported ({err})") from None
    missing = _missing(module)
    if missing:
        sys.modules.pop(name, None)
        raise UserError(f"scenario file {str(p)!r} is not a scenario: it lacks {', '.join(missing)} "
                        f"(a scenario defines {', '.join(_REQUIRED)})")
    return module


def scene_from_file(path: str | Path) -> ModuleType:
    """Return the scenario of the scene file ``path``.

    Parameters
    ----------
    path : str or pathlib.Path
        The scene file (TOML with ``[[reader]]`` tables at its top level).

    Returns
    -------
    module
        The scene's scenario module (:func:`rfsim.scenes.scene_file.scenario_module`).

    Raises
    ------
    rfsim.core.errors.UserError
        A missing file or a TOML file without ``[[reader]]`` (e.g. a scenario's ``-c``
        config), one line.
    """
    p = Path(path)
    if not p.is_file():
        raise UserError(f"scene file {str(p)!r}: no such file")
    scene_file = importlib.import_module("rfsim.scenes.scene_file")
    if not scene_file.is_scene_file(p):
        kinds = ", ".join(f"[[{k}]]" for k in scene_file.DEVICE_KINDS)
        raise UserError(f"{str(p)!r} is not a scene file: a scene file is TOML with one of {kinds} at its "
                        f"top level (a scenario's config file goes after -c)")
    return scene_file.scenario_module(p)


def _entry_points() -> list:
    """The installed entry points of :data:`ENTRY_POINT_GROUP`, sorted by name."""
    # importlib.metadata costs ≈ 0.1 s: imported when plug-ins are looked for, not at start-up
    import importlib.metadata

    return sorted(importlib.metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name)


def _plugin_module(ep) -> ModuleType:
    """The scenario module of entry point ``ep``; one that does not load or lacks the
    contract is a one-line user error naming the entry point and its distribution."""
    dist = getattr(getattr(ep, "dist", None), "name", None) or "?"
    where = f"scenario plug-in {ep.name!r} ({ep.value}, distribution {dist})"
    try:
        module = ep.load()
    except ImportError as err:
        raise UserError(f"{where} cannot be imported: {err}") from None
    if not isinstance(module, ModuleType):
        raise UserError(f"{where}: the entry point must name a module, got {type(module).__name__}")
    missing = _missing(module)
    if missing:
        raise UserError(f"{where} is not a scenario: it lacks {', '.join(missing)}")
    return module


def plugin_modules(*, skip: tuple[str, ...] = ()) -> dict[str, ModuleType]:
    """Return the installed plug-in scenarios (entry point group :data:`ENTRY_POINT_GROUP`).

    Parameters
    ----------
    skip : tuple of str, optional
        Scenario names to leave out (the built-ins), default none.

    Returns
    -------
    dict of str to module
        Scenario name → module, in the entry points' name order; the first entry point of
        a name wins.

    Raises
    ------
    rfsim.core.errors.UserError
        A plug-in that does not import, does not name a module or lacks the scenario
        contract (one line naming the entry point and its distribution).
    """
    found: dict[str, ModuleType] = {}
    for ep in _entry_points():
        module = _plugin_module(ep)
        if module.NAME not in skip:
            found.setdefault(module.NAME, module)
    return found


def builtin_modules() -> dict[str, ModuleType]:
    """Return the built-in scenarios (modules of ``rfsim.scenarios`` with the contract).

    Returns
    -------
    dict of str to module
        Scenario name → module, in alphabetical order of names.
    """
    package = importlib.import_module("rfsim.scenarios")
    found: dict[str, ModuleType] = {}
    for info in pkgutil.iter_modules(package.__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"rfsim.scenarios.{info.name}")
        if all(hasattr(module, attr) for attr in _REQUIRED):
            found[module.NAME] = module
    return dict(sorted(found.items()))


def scenario_modules() -> dict[str, ModuleType]:
    """Return every scenario: the built-ins and the installed plug-ins.

    A plug-in whose name is a built-in's is left out (the built-in wins).

    Returns
    -------
    dict of str to module
        Scenario name → module, in alphabetical order of names.
    """
    found = builtin_modules()
    found.update(plugin_modules(skip=tuple(found)))
    return dict(sorted(found.items()))


def _literal_metadata(path: Path) -> tuple[str, str] | None:
    """``(NAME, DESCRIPTION)`` of a scenario source file when both are top-level string
    literals and the module defines ``Config``, ``run`` and ``plot`` at top level; None
    otherwise. Nothing is executed: the two assignments are parsed alone
    (:func:`ast.literal_eval`), the definitions are recognised by their first line."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    values, defined = {}, set()
    for k, line in enumerate(lines):
        if not line or line[0] in " \t#)":
            continue
        head = line.split("(", 1)[0].split(":", 1)[0].split()
        if len(head) >= 2 and head[0] in ("class", "def"):
            defined.add(head[1])
        name = line.split("=", 1)[0].strip()
        if name in ("NAME", "DESCRIPTION") and "=" in line:
            stmt = line
            for nxt in lines[k + 1:]:  # continuation lines of a parenthesised value
                if nxt and nxt[0] not in " \t)":
                    break
                stmt += "\n" + nxt
            try:
                value = ast.literal_eval(stmt.split("=", 1)[1].strip())
            except (ValueError, SyntaxError):
                return None
            if not isinstance(value, str):
                return None
            values[name] = value
            defined.add(name)
    if "NAME" in values and "DESCRIPTION" in values and set(_REQUIRED) <= defined:
        return values["NAME"], values["DESCRIPTION"]
    return None


def scenario_descriptions() -> dict[str, str]:
    """Return every scenario's one-line description, without importing the scenarios' physics.

    ``NAME`` and ``DESCRIPTION`` are read from each built-in or plug-in module's source
    (:func:`_literal_metadata`); a module whose metadata is not written as string literals
    is imported instead.

    Returns
    -------
    dict of str to str
        Scenario name → description, in alphabetical order of names.
    """
    spec = importlib.util.find_spec("rfsim.scenarios")
    found: dict[str, str] = {}
    for info in pkgutil.iter_modules(spec.submodule_search_locations):
        if info.name.startswith("_"):
            continue
        meta = None
        origin = Path(info.module_finder.path) / f"{info.name}.py"
        if origin.is_file():
            meta = _literal_metadata(origin)
        if meta is None:
            module = importlib.import_module(f"rfsim.scenarios.{info.name}")
            if not all(hasattr(module, attr) for attr in _REQUIRED):
                continue
            meta = (module.NAME, module.DESCRIPTION)
        found[meta[0]] = meta[1]
    for ep in _entry_points():
        meta = None
        try:
            spec = importlib.util.find_spec(ep.module) if ep.attr is None else None
        except (ImportError, ValueError):  # its package is missing: _plugin_module says so
            spec = None
        if spec is not None and spec.origin and spec.origin.endswith(".py"):
            meta = _literal_metadata(Path(spec.origin))
        if meta is None:
            module = _plugin_module(ep)
            meta = (module.NAME, module.DESCRIPTION)
        found.setdefault(meta[0], meta[1])
    return dict(sorted(found.items()))


def get_scenario(name: str | Path) -> ModuleType:
    """Return the scenario module called ``name``, or of the scenario or scene file ``name``.

    Tries the built-in module named after the scenario first (``gen2-waveforms`` →
    ``rfsim.scenarios.gen2_waveforms``), so one scenario's imports are paid, not all of them;
    then every built-in and plug-in scenario.

    Parameters
    ----------
    name : str or pathlib.Path
        A scenario name, the path of a scenario file (ending in ``.py``,
        :func:`scenario_from_file`; any :class:`~pathlib.Path` that is not a scene file) or
        of a scene file (ending in ``.toml``, :func:`scene_from_file`).

    Returns
    -------
    module
        The scenario module.

    Raises
    ------
    rfsim.core.errors.UserError
        An unknown name (one line with the closest names and the available ones), or a
        bad scenario or scene file.
    """
    if str(name).endswith(SCENE_SUFFIX):
        return scene_from_file(name)
    if isinstance(name, Path) or is_scenario_file(name):
        return scenario_from_file(name)
    if name and name.replace("-", "_").isidentifier():
        try:
            module = importlib.import_module(f"rfsim.scenarios.{name.replace('-', '_')}")
        except ModuleNotFoundError as err:
            if err.name != f"rfsim.scenarios.{name.replace('-', '_')}":
                raise
        else:
            if getattr(module, "NAME", None) == name and all(hasattr(module, a) for a in _REQUIRED):
                return module
    modules = scenario_modules()
    if name not in modules:
        raise UserError(f"unknown scenario {name!r}{did_you_mean(name, modules)}; "
                        f"available: {', '.join(modules)} (see 'rfsim list')")
    return modules[name]


def load_scenario(module_name: str) -> ModuleType:
    """Return the scenario module of the importable name ``module_name``.

    Used e.g. in a sweep worker that received the name of its scenario's module.

    Parameters
    ----------
    module_name : str
        A built-in scenario's ``rfsim.scenarios.<name>``, a plug-in's module, a scenario
        file's :func:`file_module_name`, or any module with the scenario contract (``NAME``,
        ``DESCRIPTION``, ``Config``, ``run``, ``plot``).

    Returns
    -------
    module
        The scenario module.

    Raises
    ------
    rfsim.core.errors.UserError
        The module lacks the scenario contract (one line).
    """
    file = _file_of_module_name(module_name)
    if file is not None:
        return scenario_from_file(file)
    module = importlib.import_module(module_name)
    missing = _missing(module)
    if missing:
        raise UserError(f"module {module_name!r} is not a scenario: it lacks {', '.join(missing)}")
    return module


__all__ = ["scenario_modules", "builtin_modules", "plugin_modules", "scenario_descriptions", "get_scenario",
           "load_scenario", "scenario_from_file", "scene_from_file", "file_module_name", "is_scenario_file", "ENTRY_POINT_GROUP"]

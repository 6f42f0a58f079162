"""A ratchet on the API reference: in the modules listed in :data:`COMPLETE`, every public function
and method (the definition of ``docs/numpydoc_coverage.py``: public names defined in the module,
public functions of its public classes) has a numpydoc ``Parameters`` section naming each of its
parameters (but ``self``/``cls``) and, when it returns a value, a ``Returns`` section (``Yields``
for a generator). The docstrings are parsed here with plain text rules, so the test runs without
numpydoc installed. Add a module to :data:`COMPLETE` once its docstrings are done: the set only
grows.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import re
import textwrap

import pytest

#: Modules whose public functions and methods all have complete numpydoc sections.
COMPLETE = (
    "rfsim.gen2.bits",
    "rfsim.gen2.capture",
    "rfsim.gen2.capture_records",
    "rfsim.gen2.commands",
    "rfsim.gen2.crc",
    "rfsim.gen2.linecode",
    "rfsim.gen2.link",
    "rfsim.gen2.pie",
    "rfsim.gen2.replies",
    "rfsim.gen2.reply_decoding",
    "rfsim.gen2.reply_search",
    "rfsim.gen2.reply_tracking",
    "rfsim.estimators.bounds",
    "rfsim.estimators.calibration",
    "rfsim.estimators.grid_bayes",
    "rfsim.estimators.himr_cases",
    "rfsim.estimators.himr_model",
    "rfsim.estimators.himr_surrogate",
    "rfsim.estimators.kalman",
    "rfsim.estimators.landmark_pf",
    "rfsim.estimators.nearest",
    "rfsim.estimators.observer",
    "rfsim.estimators.particle",
    "rfsim.estimators.phase_tracking",
    "rfsim.estimators.proximity",
    "rfsim.estimators.proximity_trackers",
    "rfsim.estimators.rss_localization",
    "rfsim.estimators.track_errors",
    "rfsim.detection.fit",
    "rfsim.detection.landmark_rts",
    "rfsim.detection.models",
    "rfsim.detection.tables",
    "rfsim.detection.tag_to_tag",
    "rfsim.himr.boc",
    "rfsim.himr.dsp",
    "rfsim.himr.link",
    "rfsim.himr.packet",
    "rfsim.channels.antennas",
    "rfsim.channels.bulk",
    "rfsim.channels.geometry",
    "rfsim.channels.large_scale",
    "rfsim.channels.noise",
    "rfsim.channels.paths",
    "rfsim.channels.rss",
    "rfsim.channels.scene",
    "rfsim.channels.small_scale",
    "rfsim.channels.surfaces",
    "rfsim.core.config",
    "rfsim.core.errors",
    "rfsim.core.figure_style",
    "rfsim.core.lazy",
    "rfsim.core.monte_carlo",
    "rfsim.core.procs",
    "rfsim.core.references",
    "rfsim.core.trajectories",
    "rfsim.core.units",
)

_HEADER = re.compile(r"^(\w[\w ]*)\n-{3,}[ \t]*$", re.M)


def _public_functions(module):
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            yield name, obj
        elif inspect.isclass(obj):
            for attr, f in vars(obj).items():
                if inspect.isfunction(f) and not attr.startswith("_"):
                    yield f"{name}.{attr}", f


def _sections(doc: str) -> dict[str, str]:
    """Section title → body of a numpydoc docstring (``inspect.getdoc`` text, dedented)."""
    heads = list(_HEADER.finditer(doc))
    return {m.group(1).strip(): doc[m.end(): heads[i + 1].start() if i + 1 < len(heads) else len(doc)]
            for i, m in enumerate(heads)}


def _documented_names(body: str) -> set[str]:
    """Parameter names of a ``Parameters`` section: the unindented lines ``a, b : type`` or ``a``."""
    names = set()
    for line in body.splitlines():
        if line and not line[0].isspace():
            for name in line.split(" : ")[0].split(","):
                names.add(name.strip().lstrip("*"))
    return names


def _returns_value(function) -> tuple[bool, bool]:
    """(returns a value, is a generator) from the function's own body (nested defs skipped)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(function)))
    node = tree.body[0]
    value = generator = False
    stack = list(node.body)
    while stack:
        n = stack.pop()
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)):
            continue
        if isinstance(n, (ast.Yield, ast.YieldFrom)):
            generator = True
        if isinstance(n, ast.Return) and n.value is not None and not (
                isinstance(n.value, ast.Constant) and n.value.value is None):
            value = True
        stack.extend(ast.iter_child_nodes(n))
    return value, generator


def _problems(module_name: str) -> list[str]:
    module = importlib.import_module(module_name)
    out = []
    for name, function in _public_functions(module):
        doc = inspect.getdoc(function) or ""
        sections = _sections(doc)
        params = [p.name for p in inspect.signature(function).parameters.values() if p.name not in ("self", "cls")]
        if params:
            missing = set(params) - _documented_names(sections.get("Parameters", ""))
            if "Parameters" not in sections:
                out.append(f"{name}: no Parameters section")
            elif missing:
                out.append(f"{name}: Parameters does not name {sorted(missing)}")
        value, generator = _returns_value(function)
        if generator and "Yields" not in sections:
            out.append(f"{name}: a generator without a Yields section")
        elif value and not generator and "Returns" not in sections:
            out.append(f"{name}: returns a value but has no Returns section")
    return out


@pytest.mark.parametrize("module_name", COMPLETE)
def test_numpydoc_sections(module_name):
    assert _problems(module_name) == []


def test_section_parser_can_fail():
    """The checks flag a docstring without sections and one that leaves a parameter out."""

    def bare(x, y):
        """Sum."""
        return x + y

    def partial(x, y):
        """Sum.

        Parameters
        ----------
        x : float
            First.

        Returns
        -------
        float
            The sum.
        """
        return x + y

    assert "Parameters" not in _sections(inspect.getdoc(bare))
    assert _returns_value(bare) == (True, False)
    assert _documented_names(_sections(inspect.getdoc(partial))["Parameters"]) == {"x"}


@pytest.mark.parametrize("module_name", COMPLETE)
def test_numpydoc_parser_agrees(module_name):
    """Where numpydoc is installed (the ``docs`` extra), its own parser reads every docstring of
    the module without a warning and finds the same parameter names as the plain rules above."""
    docscrape = pytest.importorskip("numpydoc.docscrape")
    import warnings

    module = importlib.import_module(module_name)
    for name, function in _public_functions(module):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            doc = docscrape.FunctionDoc(function)
        names = {n.strip().lstrip("*") for p in doc["Parameters"] for n in p.name.split(",")}
        expected = _documented_names(_sections(inspect.getdoc(function) or "").get("Parameters", ""))
        assert names == expected, name

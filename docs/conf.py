"""Sphinx configuration of the rfsim documentation.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (``docs/build.sh``).
"""

from __future__ import annotations

import os
import re
import sys
import types
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _installed_version

os.environ.setdefault("MPLBACKEND", "Agg")
# ``rfsim/__main__.py`` runs the command line when imported (``python -m rfsim``); the
# API reference walks every module of the package, so it meets an empty stand-in instead.
sys.modules.setdefault("rfsim.__main__", types.ModuleType("rfsim.__main__"))

project = "rfsim"
author = "rfsim authors"
copyright = "rfsim authors, MIT licence"
try:
    release = _installed_version("rfsim")
except PackageNotFoundError:  # a source tree that is not installed
    release = "0+unknown"
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
templates_path = ["_templates"]
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "_templates"]

myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# API reference: one page per module, generated from the docstrings.
autosummary_generate = True
autosummary_imported_members = False
autodoc_member_order = "bysource"
# The signatures carry the type hints; the numpydoc "Parameters" sections carry types
# and units in words. Repeating the hints in the description would double them.
autodoc_typehints = "signature"

# numpydoc, with the conventions of numpy/scipy. Class pages list members through
# autodoc, not through numpydoc's member tables (which would list each member twice).
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

html_theme = "furo"
html_title = f"rfsim {release}"
html_static_path = ["_static"]


# The docstrings are plain text with reStructuredText roles: |x| is a magnitude, h* a complex
# conjugate, (*shape, 1) a shape, ``name_`` an identifier. reStructuredText would read these as
# substitutions, emphasis and link targets; they are escaped here, outside inline literals,
# roles and literal blocks (and kept at their width inside simple tables), so the text renders
# as written. Everything else reaches Sphinx unchanged and -W stops the build on it.
_LITERAL = re.compile(r"``.+?``|:[\w:+.-]+:`[^`]+`|`[^`]+`_{0,2}", re.S)
_EMPHASIS = re.compile(r"(?<![\w*\\])(\*\*?)(?=[^\s*])[^*\n]*?(?<=[^\s*\\])\1(?![\w*])")
_TABLE_BORDER = re.compile(r"^\s*=+(\s+=+)+\s*$")


def _escape_plain(text: str, in_table: bool) -> str:
    parts, last = [], 0
    for m in _EMPHASIS.finditer(text):
        parts.append(_escape_chars(text[last:m.start()], in_table))
        parts.append(m.group(0))
        last = m.end()
    parts.append(_escape_chars(text[last:], in_table))
    return "".join(parts)


def _escape_chars(text: str, in_table: bool) -> str:
    text = text.replace("|", "\u2223" if in_table else "\\|")
    text = re.sub(r"(?<!\\)\*(?=\S)", r"\\*", text)  # not a bullet: "* item"
    return re.sub(r"(?<=\w)_(?![\w\[])", r"\\_", text)


def _escape_chunk(lines: list[str]) -> list[str]:
    text = "\n".join(lines)
    out, last = [], 0
    borders = [i for i, line in enumerate(lines) if _TABLE_BORDER.match(line)]
    table_from = sum(len(line) + 1 for line in lines[: borders[0]]) if len(borders) >= 2 else -1
    table_to = sum(len(line) + 1 for line in lines[: borders[-1]]) if len(borders) >= 2 else -1

    def plain(a: int, b: int) -> str:
        return _escape_plain(text[a:b], table_from <= a < table_to)

    for m in _LITERAL.finditer(text):
        out.append(plain(last, m.start()))
        out.append(m.group(0))
        last = m.end()
    out.append(plain(last, len(text)))
    new = "".join(out).split("\n")
    assert len(new) == len(lines)
    return new


def _plain_text_docstring(app, what, name, obj, options, lines):
    result, chunk, block_indent = [], [], None
    for line in lines:
        indent = len(line) - len(line.lstrip())
        if block_indent is not None:
            if not line.strip() or indent > block_indent:
                result.append(line)
                continue
            block_indent = None
        if line.lstrip().startswith((">>>", "... ")):
            result.extend(_escape_chunk(chunk)) if chunk else None
            chunk = []
            result.append(line)
            continue
        chunk.append(line)
        if line.rstrip().endswith("::"):
            result.extend(_escape_chunk(chunk))
            chunk, block_indent = [], indent
    if chunk:
        result.extend(_escape_chunk(chunk))
    lines[:] = result


def setup(app):
    app.connect("autodoc-process-docstring", _plain_text_docstring, priority=600)

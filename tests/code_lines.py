"""Lines of code for the size rules of the tests (``test_house``, ``test_exchange_core``):
docstrings — the numpydoc text of the API reference — are documentation, not code, and do not
count."""

from __future__ import annotations

import ast


def docstring_lines(tree: ast.AST) -> set[int]:
    """Line numbers of every module, class and function docstring in ``tree``."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                out.update(range(first.lineno, first.end_lineno + 1))
    return out


def code_lines(node: ast.AST, docs: set[int]) -> int:
    """Lines spanned by ``node`` that are not docstring lines (``docs``: :func:`docstring_lines`)."""
    return sum(1 for line in range(node.lineno, node.end_lineno + 1) if line not in docs)

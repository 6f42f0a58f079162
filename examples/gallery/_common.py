"""Shared command line of the gallery examples: ``--out DIR`` (default ``results/gallery``)
and ``--small`` (a smaller run for the tests)."""

from __future__ import annotations

import argparse
from pathlib import Path


def arguments(description: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--out", type=Path, default=Path("results/gallery"), help="folder for the figure")
    parser.add_argument("--small", action="store_true", help="a smaller, faster run")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    return args

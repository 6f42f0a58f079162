#!/usr/bin/env bash
# Build the documentation site into docs/_build/html with Sphinx warnings as errors.
# Needs the docs extra: pip install -e ".[docs]". Extra arguments go to sphinx-build.
set -euo pipefail
cd "$(dirname "$0")/.."
exec python -m sphinx -W --keep-going -b html docs docs/_build/html "$@"

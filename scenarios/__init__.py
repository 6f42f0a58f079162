"""Runnable scenarios, one module each, discovered by name by the CLI.

A scenario module defines ``NAME`` (the CLI name), ``DESCRIPTION`` (one line),
``Config`` (a frozen dataclass with defaults), ``run(config, *, seed) ->
rfsim.core.dataset.Dataset`` and ``plot(dataset_path, out_dir) -> list[Path]``.
"""

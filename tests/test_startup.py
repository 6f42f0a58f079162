"""Start-up of the ``rfsim`` command: ``--help`` and ``list`` import no scenario physics, no
numba and no scipy.signal (issue 16 item 4); the scenario metadata read from the sources
equals the modules' own."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rfsim.cli.decode import SUFFIXES as CLI_SUFFIXES
from rfsim.gen2.capture import SUFFIXES
from rfsim.registry import scenario_descriptions, scenario_modules

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "scipy.signal", "scipy.stats", "h5py", "devices", "channels", "matplotlib")


def _imported_after(argv: list[str]) -> list[str]:
    code = ("import sys, io, contextlib\nfrom rfsim.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try:\n        main(%r)\n    except SystemExit:\n        pass\n"
            "import json; print(json.dumps(sorted(sys.modules)))" % (argv,))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("argv", [["--help"], ["list"]])
def test_help_and_list_import_no_physics(argv):
    mods = _imported_after(argv)
    heavy = [m for m in mods if m.split(".")[0] in ("numba", "h5py", "devices", "channels", "matplotlib")
             or m.startswith(("scipy.signal", "scipy.stats", "scenarios."))]
    assert heavy == []


def test_scenario_metadata_from_sources_equals_modules():
    descriptions = scenario_descriptions()
    assert len(descriptions) >= 9
    assert descriptions == {name: module.DESCRIPTION for name, module in scenario_modules().items()}


def test_decode_cli_lists_the_capture_endings_of_the_loader():
    assert CLI_SUFFIXES == SUFFIXES

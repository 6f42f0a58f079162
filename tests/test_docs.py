"""The documentation stays true: the README is short and lists every scenario with its page;
every scenario has a page saying what it simulates, writes and costs; every source document
is cited in full; the tutorials' code satisfies the scenario contract and runs. (The README's
two scripting blocks are run by tests/test_simulation.py.)"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys

from rfsim.core.references import REFERENCES
from rfsim.runs.registry import _literal_metadata, scenario_modules
from rfsim.runs.runner import run_scenario
from rfsim.core.dataset import read_table


def _read(project_root, relative: str) -> str:
    return (project_root / relative).read_text(encoding="utf-8")


def test_readme_is_short_and_keeps_the_two_quick_start_commands(project_root):
    text = _read(project_root, "README.md")
    assert len(text.encode("utf-8")) <= 10_000
    block = text[text.index("<!-- quickstart:begin -->"): text.index("<!-- quickstart:end -->")]
    commands = [line for line in block.splitlines() if re.match(r"^(python|\.|pip|rfsim)", line)]
    assert len(commands) == 2 and "rfsim run" in commands[0] and "pytest" in commands[1]
    figure = re.search(r"!\[[^\]]*\]\(([^)]+\.png)\)", text)
    assert figure and (project_root / figure.group(1)).is_file()


def test_readme_lists_every_scenario_in_one_line_with_its_page(project_root):
    text = _read(project_root, "README.md")
    lines = {m.group(1): m.group(0) for m in
             re.finditer(r"^- \[`([a-z0-9-]+)`\]\(docs/scenarios/\1\.md\) — \S.*$", text, re.M)}
    assert set(lines) == set(scenario_modules())
    for link in re.findall(r"\]\((docs/[^)#]+)\)", text):
        assert (project_root / link).is_file(), link


def test_the_scenario_table_lists_every_scenario_with_what_it_writes(project_root):
    text = _read(project_root, "docs/scenarios/index.md")
    rows = {m.group(1): m.group(0) for m in re.finditer(r"^\| `([a-z0-9-]+)` \|.*\|$", text, re.M)}
    assert set(rows) == set(scenario_modules())
    for name, row in rows.items():
        cells = [c.strip() for c in row.strip("|").split(" | ")]
        assert len(cells) == 5 and all(cells), row  # name, what it simulates, tables, figures, time
        assert re.search(r"\d+(\.\d+)? s", cells[4]), f"{name}: no measured time in {cells[4]!r}"


def test_every_scenario_has_a_page_with_its_dataset_figures_and_runtime(project_root):
    toctree = _read(project_root, "docs/scenarios/index.md")
    for name, module in scenario_modules().items():
        page = _read(project_root, f"docs/scenarios/{name}.md")
        assert f"\n{name}\n" in toctree, f"{name} is not in the scenarios toctree"
        for heading in ("## Run it", "## The dataset", "## Figures", "## Runtime"):
            assert heading in page, f"{name}: no {heading!r}"
        assert f"rfsim run {name}" in page
        assert re.search(r"\d+(\.\d+)? s", page[page.index("## Runtime"):]), name
        assert f"{{py:mod}}`{module.__name__}`" in page


def test_the_references_give_every_source_in_full(project_root):
    text = _read(project_root, "docs/cite.md")
    section = text[text.index("## References"):]
    for ref in REFERENCES.values():
        assert f"**{ref.short}** — {ref.full}" in section
    for needle in ("Akbar", "Särkkä", "Özkaya", "Geng", "Wang", "EPCglobal", "PARIS", "PASS", "CITATION.cff"):
        assert needle in text


def test_the_own_scenario_tutorial_module_has_the_contract_and_runs(project_root, tmp_path):
    path = project_root / "docs" / "tutorials" / "my_scenario.py"
    assert len(path.read_text(encoding="utf-8").splitlines()) < 60
    assert _literal_metadata(path) == ("read-range", "reader + one tag in free space: read rate and RSSI vs distance")
    spec = importlib.util.spec_from_file_location("my_scenario", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["my_scenario"] = module
    try:
        spec.loader.exec_module(module)
        out = run_scenario(module, module.Config(distances_m=(1.0, 3.0), rounds=2), seed=1, out_dir=tmp_path)
    finally:
        del sys.modules["my_scenario"]
    reads = read_table(out.dataset_path, "reads")
    assert list(reads["distance_m"]) == [1.0, 1.0, 3.0, 3.0]
    # free space, 6 dBi patch, 30 dBm: every read succeeds and the RSSI falls with distance
    assert reads["success"].all() and reads["rssi_dbm"][0] > reads["rssi_dbm"][2]
    assert [p.name for p in out.figure_paths] == ["read-range-rssi.png"]


def test_the_own_scene_tutorial_runs_and_prints_what_the_page_shows(project_root, tmp_path):
    script = project_root / "docs" / "tutorials" / "my_scene.py"
    done = subprocess.run([sys.executable, str(script), str(tmp_path / "scene.h5")], capture_output=True,
                          text=True, timeout=600, env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-2000:]
    page = _read(project_root, "docs/tutorials/own-scene.md")
    printed = [line for line in done.stdout.splitlines() if "EPCs read" in line]
    assert len(printed) == 4 and all(line in page for line in printed), done.stdout
    assert (tmp_path / "scene.h5").is_file()

"""The README stays true: every scenario listed with what it writes, every source document
with its full reference, the scripting example present (tests/test_simulation.py runs it)."""

from __future__ import annotations

import re

from rfsim.core.references import REFERENCES
from rfsim.runs.registry import scenario_modules


def _readme(project_root) -> str:
    return (project_root / "README.md").read_text(encoding="utf-8")


def test_readme_lists_every_scenario_with_what_it_writes(project_root):
    text = _readme(project_root)
    rows = {m.group(1): m.group(0) for m in re.finditer(r"^\| `([a-z0-9-]+)` \|.*\|$", text, re.M)}
    assert set(rows) == set(scenario_modules())
    for name, row in rows.items():
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert len(cells) == 5 and all(cells), row  # what it simulates, tables, figures, time
        assert re.search(r"\d+(\.\d+)? s", cells[4]), f"{name}: no measured time in {cells[4]!r}"


def test_readme_references_give_every_source_in_full(project_root):
    text = _readme(project_root)
    section = text[text.index("## References"):]
    section = section[: section.index("\n## ", 1)]
    for ref in REFERENCES.values():
        assert f"**{ref.short}** — {ref.full}" in section
    for needle in ("Akbar", "Särkkä", "Özkaya", "Geng", "Wang", "EPCglobal", "PARIS", "PASS"):
        assert needle in section

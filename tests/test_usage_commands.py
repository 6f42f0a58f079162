"""The commands the README and the usage page show work in the order written, in an empty
folder beside a fresh checkout: every command exits 0, writes nothing on stderr but progress
and notices, and what a later command reads was made by an earlier one (a newcomer pastes
them one by one)."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest


def _block(text: str, after: str) -> list[str]:
    """Command lines of the first ```bash block after the heading/marker ``after``."""
    start = text.index("```bash", text.index(after)) + len("```bash")
    body = text[start: text.index("```", start)]
    return [line.split("  #")[0].strip() for line in body.splitlines() if line.strip()]


def _run_in_order(commands: list[str], cwd: Path) -> None:
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    for command in commands:
        argv = shlex.split(command)
        assert argv[0] in ("rfsim", "python"), command
        argv[0] = sys.executable if argv[0] == "python" else argv[0]
        out_file = None
        if ">" in argv:  # `rfsim config X > my.toml`
            i = argv.index(">")
            argv, out_file = argv[:i], cwd / argv[i + 1]
        done = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=900)
        assert done.returncode == 0, f"{command!r} exited {done.returncode}: {done.stderr[-800:]}"
        assert "Traceback" not in done.stderr, command
        if out_file is not None:
            out_file.write_text(done.stdout, encoding="utf-8")


@pytest.fixture()
def fresh_folder(tmp_path, project_root):
    """An empty working folder holding a copy of the checkout's examples/ (sweep specs write
    their output relative to the spec, so the checkout itself stays clean)."""
    shutil.copytree(project_root / "examples", tmp_path / "examples")
    return tmp_path


def test_the_usage_page_block_runs_top_to_bottom(project_root, fresh_folder):
    commands = _block((project_root / "docs" / "usage.md").read_text(encoding="utf-8"), "# Using rfsim")
    assert len(commands) >= 12 and any(c.startswith("rfsim decode") for c in commands)
    _run_in_order(commands, fresh_folder)
    # what each step promises is there: the -o dataset with its figures beside it, the re-drawn
    # figures, the decoded capture as HDF5, the benchmark JSON
    assert (fresh_folder / "results" / "far.h5").is_file()
    assert list((fresh_folder / "results").glob("far-*.png"))
    assert list((fresh_folder / "figures").glob("far-*.png"))
    assert list((fresh_folder / "results" / "today").glob("gen2-waveforms*.h5"))
    assert (fresh_folder / "capture.h5").is_file() and (fresh_folder / "bench.json").is_file()


def test_the_decode_example_finds_both_commands_and_both_replies(project_root, fresh_folder):
    _run_in_order(["python examples/captures/make_capture.py cap.cf32 --fs 2e6"], fresh_folder)
    done = subprocess.run([str(Path(sys.executable).parent / "rfsim"), "decode", "cap.cf32", "--fs", "2e6"],
                          cwd=fresh_folder, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    # the generator's construction: RN16 0xB5C3, then PC 0x3000 + the EPC with a valid CRC-16
    assert "RN16=0xB5C3" in done.stdout and "EPC=300833B2DDD9014000000027  CRC ok" in done.stdout
    assert re.search(r"2 commands .*2 tag replies", done.stdout)


@pytest.mark.slow
def test_the_readme_common_commands_run_in_order(project_root, fresh_folder):
    text = (project_root / "README.md").read_text(encoding="utf-8")
    commands = _block(text, "## The three most common commands")
    assert len(commands) == 3
    _run_in_order(commands, fresh_folder)
    assert (fresh_folder / "results" / "link.h5").is_file()
    assert (fresh_folder / "examples" / "sweeps" / "results" / "sweep-link.h5").is_file()

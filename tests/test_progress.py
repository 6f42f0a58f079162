"""Progress reporting (rfsim.core.progress): terminal bars, batch-log lines, quiet, the compile notice."""

from __future__ import annotations

import io
import types

import numba
import pytest

from rfsim.core import _jit
from rfsim.core.progress import COMPILE_NOTICE, Reporter, reporting, stage, track


def test_track_without_a_reporter_is_the_plain_iteration():
    assert list(track(iter(range(5)), total=5, desc="x")) == [0, 1, 2, 3, 4]
    stage("nobody listens")  # no reporter: nothing happens, nothing fails


def test_batch_log_lines_start_end_and_no_carriage_returns():
    log = io.StringIO()
    with reporting(Reporter(log, tty=False, log_interval_s=3600.0)):
        stage("simulating")
        assert list(track(range(7), desc="monte carlo", unit="cells")) == list(range(7))
    lines = log.getvalue().splitlines()
    assert "\r" not in log.getvalue()
    assert lines[0] == "rfsim: simulating"
    assert lines[1].startswith("monte carlo: 0/7 cells (0.0 %), ")
    # a 1 h interval: only the first line and the final one (with the rate, elapsed and ETA)
    assert len(lines) == 3 and lines[2].startswith("monte carlo: 7/7 cells (100.0 %), ")
    assert "cells/s, elapsed 00:00, ETA 00:00" in lines[2]


def test_terminal_bar_redraws_in_place_with_eta():
    tty = io.StringIO()
    with reporting(Reporter(tty, tty=True)):
        for _ in track(range(4), desc="monte carlo", unit="cells"):
            pass
    text = tty.getvalue()
    assert "\r" in text and "monte carlo: 100%|" in text and "4/4 cells [" in text
    assert "<00:00" in text  # elapsed<remaining, tqdm's ETA


def test_eta_leaves_out_the_first_step_that_carries_the_compilation():
    clock = [100.0]
    bar = Reporter(io.StringIO(), tty=False, log_interval_s=3600.0).bar(10, desc="cells", unit="cells")
    bar._time, bar.start_t = (lambda: clock[0]), 100.0
    clock[0] = 160.0  # the first cell: 60 s, of which most is numba compiling
    bar.update(1)
    assert bar.format_dict["rate"] == 0.0  # no second step yet: ETA "?"
    for _ in range(2):  # then one cell per second
        clock[0] += 1.0
        bar.update(1)
    fd = bar.format_dict
    assert fd["rate"] == pytest.approx(1.0) and fd["elapsed"] == pytest.approx(62.0)
    line = bar.format_meter(**fd)
    assert "ETA 00:07" in line  # 7 cells left at 1 cell/s, not 7 x 20.7 s
    bar.close()


def test_quiet_prints_nothing_and_details_need_verbose():
    out = io.StringIO()
    with reporting(Reporter(out, quiet=True)) as rep:
        stage("x")
        list(track(range(3), desc="y"))
        rep.compile_started()
    assert out.getvalue() == ""
    loud, normal = io.StringIO(), io.StringIO()
    Reporter(loud, verbose=True).detail("config")
    Reporter(normal).detail("config")
    assert loud.getvalue() == "rfsim: config\n" and normal.getvalue() == ""


def test_a_real_numba_compilation_is_announced_once():
    """An uncached njit function compiles inside the block: the notice appears exactly once."""
    out = io.StringIO()
    f = numba.njit(lambda x: x + 1)
    g = numba.njit(lambda x: x * 2)
    with reporting(Reporter(out, tty=False)):
        assert f(1) == 2 and g(2) == 4
    assert out.getvalue() == f"rfsim: {COMPILE_NOTICE}\n"


def test_first_compilation_means_no_kernel_has_a_cache_index(tmp_path, monkeypatch):
    def fake(name, index):
        cache = types.SimpleNamespace(_cache_file=types.SimpleNamespace(_index_path=str(index)))
        return types.SimpleNamespace(_cache=cache, py_func=types.SimpleNamespace(__qualname__=name))

    present = tmp_path / "a.nbi"
    present.write_bytes(b"")
    monkeypatch.setattr(_jit, "KERNELS", [fake("a", present), fake("b", tmp_path / "b.nbi")])
    assert _jit.uncached_kernels() == ["b"] and not _jit.first_compilation()
    monkeypatch.setattr(_jit, "KERNELS", [fake("b", tmp_path / "b.nbi"), fake("c", tmp_path / "c.nbi")])
    assert _jit.first_compilation()


@pytest.mark.parametrize("tty", [True, False])
def test_stage_lines_do_not_break_a_running_bar(tty):
    out = io.StringIO()
    with reporting(Reporter(out, tty=tty, log_interval_s=0.0)):
        for i in track(range(3), desc="loop", unit="steps"):
            if i == 1:
                stage("halfway")
    lines = [line for line in out.getvalue().replace("\r", "\n").splitlines() if line.strip()]
    assert "rfsim: halfway" in lines and any(line.startswith("loop: ") for line in lines)

"""Scenario ``access``: read range and write range from the command line, and the gap between them
against the Friis prediction from the chip's write threshold."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.core.dataset import read_dataset, read_table
from rfsim.gen2.memory import CHIP_MODELS
from rfsim.scenarios import access


def test_range_is_where_the_rate_crosses_one_half():
    d = [1.0, 2.0, 3.0, 4.0]
    assert access.range_m(d, [1.0, 1.0, 0.0, 0.0]) == pytest.approx(2.5)
    assert access.range_m(d, [1.0, 0.75, 0.25, 0.0]) == pytest.approx(2.5)
    assert access.range_m(d, [1.0, 1.0, 0.6, 0.1]) == pytest.approx(3.2)
    assert math.isnan(access.range_m(d, [1.0, 1.0, 1.0, 1.0]))  # beyond the grid
    assert math.isnan(access.range_m(d, [0.0, 1.0, 0.0, 0.0]))  # not read at the first distance


def test_runs_from_the_command_line_and_plot_draws_its_figure(tmp_path, capsys):
    out = tmp_path / "a.h5"
    assert main(["run", "access", "--seed", "1", "--no-plot", "-q", "-o", str(out),
                 "--set", "geometry.distances_m=[1.0, 30.0]", "--set", "rounds_per_point=2"]) == 0
    acc, reads, rates = (read_table(out, n) for n in ("accesses", "reads", "rates"))
    assert reads["success"].tolist() == [True, True, False, False]  # sorted by time: 1 m first
    # one row per command of the default program (a Write is Req_RN + Write) per trial
    assert acc["step"].size == 4 * 5
    near = acc["distance_m"] == 1.0
    assert set(acc["result"][near & (acc["command"] == "Read")]) == {"ok"}
    assert set(acc["result"][~near]) == {"not sent"}
    # the keys of the reads table find every access row's trial
    keys = set(zip(reads["point"].tolist(), reads["round"].tolist()))
    assert set(zip(acc["point"].tolist(), acc["round"].tolist())) == keys
    assert rates["read_rate"].tolist() == [1.0, 0.0] and rates["trials"].tolist() == [2, 2]
    assert main(["plot", str(out), "--out-dir", str(tmp_path)]) == 0
    assert (tmp_path / "a-ranges.png").stat().st_size > 10_000


def test_write_range_is_short_of_the_read_range_by_the_friis_ratio_of_the_write_threshold(tmp_path):
    """Free space: P_inc ∝ d⁻², so the distance where the chip has Δ dB more power than at the
    read range is d_read·10^(−Δ/20). The grid step h bounds each interpolated range's error (the
    rates step from 1 to 0 between two grid points), the hop channels (902–928 MHz) add ±1.4 % of
    a distance (Friis λ²). Free space and a static tag: a rate is 0 or 1 but within a hop's
    ±1.4 %, so one trial per distance suffices."""
    out = tmp_path / "a.h5"
    step_m = 0.1
    grid = np.round(np.arange(4.0, 7.3, step_m), 2).tolist()
    assert main(["run", "access", "--seed", "3", "--no-plot", "-q", "-o", str(out),
                 "--set", f"geometry.distances_m={grid}", "--set", "rounds_per_point=1"]) == 0
    a = read_dataset(out).attrs
    delta_db = CHIP_MODELS["generic"].write_threshold_db
    assert a["write_threshold_db"] == delta_db == 3.0
    d_read, d_write = a["read_range_m"], a["write_range_m"]
    assert 4.0 < d_write < d_read < 7.2
    tol = lambda d: step_m + 0.015 * d  # noqa: E731
    expected = d_read * 10 ** (-delta_db / 20)
    assert abs(d_write - expected) <= tol(d_write) + tol(d_read) * 10 ** (-delta_db / 20)
    assert a["range_gap_m"] == pytest.approx(d_read - d_write)
    # between the two ranges the Writes fail for lack of power (0Bh), not for lack of a reply
    acc = read_table(out, "accesses")
    between = (acc["distance_m"] > d_write + tol(d_write)) & (acc["distance_m"] < d_read - tol(d_read))
    writes = between & (acc["command"] == "Write")
    assert writes.sum() >= 8 and set(acc["error_code"][writes]) == {0x0B}

"""The project's figure style: paper widths, series told apart without colour, published values
distinct from every series, no-data cells masked, probabilities drawn with their intervals."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.colors import to_rgba

from rfsim.core import figure_style as fs
from rfsim.core.plots import pyplot


@pytest.fixture
def close_all():
    yield
    pyplot().close("all")


@pytest.mark.parametrize("columns, width_in", [(1, 3.5), (2, 7.16)])
def test_figure_has_the_paper_widths_and_constrained_layout(close_all, columns, width_in):
    with fs.paper_style():
        fig, axes = fs.figure(columns=columns, nrows=2, ncols=2)
    assert fig.get_figwidth() == pytest.approx(width_in)
    assert axes.shape == (2, 2)
    assert type(fig.get_layout_engine()).__name__ == "ConstrainedLayoutEngine"
    with pytest.raises(ValueError):
        fs.figure(columns=3)


def test_series_differ_in_line_style_and_marker_not_only_colour():
    styles = [fs.series_style(i) for i in range(49)]
    assert len({(s["linestyle"], s["marker"]) for s in styles[:7]}) == 7  # greyscale: still 7 series
    assert len({str((s["color"], s["linestyle"], s["marker"])) for s in styles}) == 49
    # no series is black (reserved for published values) and published markers are hollow
    assert all(to_rgba(s["color"])[:3] != (0.0, 0.0, 0.0) for s in styles)
    assert fs.PUBLISHED["color"] == "black" and fs.PUBLISHED["markerfacecolor"] == "none"
    assert fs.published_label("AURIS Fig. 3.8") == "published (AURIS Fig. 3.8)"


def test_mask_no_data_covers_exactly_the_masked_cells(close_all):
    with fs.paper_style():
        fig, ax = fs.figure()
    x, y = np.array([0.0, 1.0, 3.0]), np.array([10.0, 20.0])
    mask = np.array([[False, True, False], [False, False, True]])
    handle = fs.mask_no_data(ax, x, y, mask, label="tag not powered")
    boxes = sorted((p.get_x(), p.get_y(), p.get_width(), p.get_height()) for p in ax.patches)
    # cell edges half-way between centres, the outer ones mirrored: x 0|0.5|2|4, y 5|15|25
    assert boxes == [(0.5, 5.0, 1.5, 10.0), (2.0, 15.0, 2.0, 10.0)]
    assert handle.get_label() == "tag not powered" and handle.get_hatch()
    assert fs.mask_no_data(ax, x, y, np.zeros_like(mask)) is None
    with pytest.raises(ValueError):
        fs.mask_no_data(ax, x, y, mask.T)


def test_ci_errorbar_skips_points_without_trials_and_scales(close_all):
    with fs.paper_style():
        fig, ax = fs.figure()
    p = np.array([0.5, np.nan, 0.2])
    container = fs.ci_errorbar(ax, [1, 2, 3], p, [0.3, np.nan, 0.1], [0.6, np.nan, 0.4], scale=100.0)
    line = container[0]
    assert list(line.get_xdata()) == [1.0, 3.0] and list(line.get_ydata()) == [50.0, 20.0]
    segments = container[2][0].get_segments()
    assert [tuple(s[:, 1]) for s in segments] == [(30.0, 60.0), (10.0, 40.0)]


def test_dodge_spreads_series_around_x():
    x = np.array([1.0, 2.0])
    shifted = [fs.dodge(x, i, 4, width=0.4) for i in range(4)]
    assert np.allclose(np.mean(shifted, axis=0), x)
    assert np.allclose(shifted[0], x - 0.15) and np.allclose(shifted[3], x + 0.15)
    assert np.allclose(fs.dodge(x, 0, 2, width=0.2, log=True), x * np.exp(-0.05))


def test_legend_outside_keeps_the_legend_off_the_axes(close_all):
    with fs.paper_style():
        fig, (a, b) = fs.figure(columns=2, ncols=2)
        for ax in (a, b):
            ax.plot([0, 1], [0, 1], label="series", **fs.series_style(0))
            ax.set(xlabel="x [m]", ylabel="y [m]")
        right = fs.legend_outside(a)
        below = fs.legend_outside(b, where="below")
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        assert right.get_window_extent(renderer).x0 >= a.get_window_extent(renderer).x1
        label_bottom = b.xaxis.get_tightbbox(renderer).y0
        assert below.get_window_extent(renderer).y1 <= label_bottom + 1
        with pytest.raises(ValueError):
            fs.legend_outside(a, where="inside")

"""Caption lines of the scenarios' figures stay on the canvas and legends list each series once."""

from __future__ import annotations

import pytest

from rfsim.core.figure_style import figure, paper_style
from rfsim.core.plots import pyplot
from rfsim.scenarios._captions import caption, unique_handles

LONG = ("After HIMR dissertation (Akbar, Georgia Tech 2016) Figs. 68-96 (cases: L1050-L1072); one run: 226 packets "
        "at 141 packets/s; published values: black hollow markers in the estimator's marker shape.")


@pytest.mark.parametrize("columns", [1, 2])
def test_a_long_caption_is_wrapped_inside_the_canvas(columns):
    plt = pyplot()
    with paper_style():
        fig, ax = figure(columns=columns)
        ax.plot([0, 1], [0, 1])
        ax.set(xlabel="x [m]", ylabel="y [m]")
        text = caption(fig, LONG, "", "Second part.")
        fig.canvas.draw()
        box, canvas = text.get_window_extent(), fig.bbox
    plt.close(fig)
    assert box.x0 >= canvas.x0 - 1 and box.x1 <= canvas.x1 + 1, (box, canvas)
    lines = text.get_text().split("\n")
    assert len(lines) >= 2 and lines[-1] == "Second part."  # wrapped, the empty part skipped
    assert " ".join(lines[:-1]) == LONG


def test_unique_handles_keeps_the_first_artist_of_each_label_in_order():
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2)
    first = a.plot([0, 1], [0, 1], label="wall")[0]
    a.plot([0, 1], [1, 0], label="wall")
    other = a.plot([0, 1], [1, 1], label="reader")[0]
    b.plot([0, 1], [0, 1], label="wall")
    last = b.plot([0, 1], [0, 0], label="track")[0]
    assert unique_handles(a, b) == [first, other, last]
    plt.close(fig)

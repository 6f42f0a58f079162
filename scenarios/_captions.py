"""Caption lines of the scenarios' figures, wrapped to the figure's width, and the legend
entries of several axes without repeats.

:func:`rfsim.core.figure_style.source_note` writes one line under a figure; a line naming a
document, its figure number and the run's size is often wider than a one-column figure
(3.5 in), and a text beyond the canvas is cut off. :func:`caption` wraps each part to the
figure's width first.
"""

from __future__ import annotations

import textwrap

from rfsim.core.figure_style import source_note

#: Font size [pt] of caption lines (as :func:`~rfsim.core.figure_style.source_note`).
CAPTION_PT = 6.5
#: Mean advance of an italic DejaVu Sans character, in units of the font size (generous: the
#: wrapped line must fit, a short line costs nothing).
CHAR_EM = 0.56


def caption(fig, *parts: str):
    """Write ``parts`` (sentences, e.g. the source and the run's size) under ``fig``, each
    wrapped to the figure's width; empty parts are skipped. Returns the text artist."""
    width_pt = fig.get_figwidth() * 72.0 * 0.95
    chars = max(20, int(width_pt / (CAPTION_PT * CHAR_EM)))
    lines = [line for part in parts if part for line in textwrap.wrap(part, chars)]
    return source_note(fig, "\n".join(lines), fontsize=CAPTION_PT)


def unique_handles(*axes) -> list:
    """The legend handles of ``axes``, one per label, in order of appearance (e.g. one legend for
    panels that draw the same series, or a floor plan that labels every wall)."""
    seen = {}
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(label, h)
    return list(seen.values())


__all__ = ["caption", "unique_handles"]

"""Caption lines of the scenarios' figures, one paragraph per part, and the legend entries of
several axes without repeats.

:func:`rfsim.core.figure_style.source_note` wraps a caption to the figure's width;
:func:`caption` keeps the parts of a caption (the source, the run's size, a remark) on lines of
their own.
"""

from __future__ import annotations

from rfsim.core.figure_style import source_note


def caption(fig, *parts: str):
    """Write ``parts`` (sentences, e.g. the source and the run's size) under ``fig``, each
    starting on a new line and wrapped to the figure's width; empty parts are skipped.
    Returns the text artist (None when every part is empty)."""
    text = None
    for part in parts:
        if part:
            text = source_note(fig, part)
    return text


def unique_handles(*axes) -> list:
    """The legend handles of ``axes``, one per label, in order of appearance (e.g. one legend for
    panels that draw the same series, or a floor plan that labels every wall)."""
    seen = {}
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(label, h)
    return list(seen.values())


__all__ = ["caption", "unique_handles"]

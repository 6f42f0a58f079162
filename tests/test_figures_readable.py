"""Every scenario's figures as a reader sees them: after ``fig.canvas.draw()``

* no drawn text (title, axis labels, tick labels, legend, annotations) leaves the canvas,
  and no title or axis label overlaps another one (e.g. the titles of neighbouring panels),
* no legend lies on the data: its box stays off every axes' plotting area,
* no axes is empty (each draws data),
* every axes has an x and a y label (colorbars excepted; a label may be that of an axes
  sharing the axis, as in a stack of panels over one time axis or a row over one y scale),
* every legend entry has a visible handle, and the artist it names draws something inside
  its axes (a series in the legend that is all NaN or out of view is a lie).

Each scenario runs a tiny config (``--set``) with ``--no-plot``; its ``plot`` then draws from
the file with ``pyplot.close`` held back, so the test sees the figures ``save_figure`` wrote.
Scenarios whose smallest run is long are in the ``slow`` tier.
"""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.cli import main
from rfsim.runs.registry import get_scenario

#: Tolerance [pixels] for a text's extent beyond the canvas (anti-aliasing of the last pixel).
EDGE_PX = 1.0

#: A small run of each scenario (``--set`` overrides: smallest sizes that still draw every
#: panel) and whether it is slow (minutes on one core).
SMALL = {
    "access": (["geometry.distances_m=[1.0, 3.0, 5.0, 9.0]", "rounds_per_point=2"], False),
    "gen2-waveforms": (["profiles=['fm0-40k', 'miller4-320k']", "fs_hz=3e6"], False),
    "link": (["geometry.distances_m=[1.0, 3.0, 9.0]", "rounds_per_point=3"], False),
    "inventory": (["populations=[3]", "runs=1", "capture.trials=2", "capture.ratios_db=[0.0, 4.0]",
                   "capture_sweep.trials=20", "capture_sweep.ratios_db=[0.0, 6.0]"], False),
    "reader-detection": (["campaign.distances_m=[1.0, 9.0]", "campaign.angles_deg=[0.0, 90.0]",
                          "campaign.repetitions=2", "campaign.queries=5", "campaign.workers=1"], False),
    "detection-probability": (["samples.count=40", "samples.n_train=30", "samples.workers=1"], False),
    "phase-cancellation": (["geometry.tag_x_m=[1.0, 6.0]", "mc.positions_per_cell=6", "mc.workers=1",
                            "tracks.cell=0"], False),
    "rss-localization": (["sigma0_db=[5.2]", "trials=20", "particles=50"], False),
    "st-to-st": (["geometry.st_x_m=[1.0, 4.0]", "mc.positions_per_cell=6", "mc.workers=1"], False),
    "exciter-link": (["sweep.exciter_distance_m=[1.0, 3.0]", "sweep.tag_distance_m=[0.2, 1.0]",
                      "sweep.draws_per_point=3", "sweep.workers=1"], False),
    "himr-2d": (["scene.duration_s=0.4", "observer.outage_s=[0.1, 0.2]"], False),
    "himr-1d": (["scene.duration_s=0.2"], False),
    "phase-tracking": (["trajectory.duration_s=0.5", "schedule.workers=1"], False),
    "tag-to-tag-tracking": (["trajectories=3", "filter_runs=2", "workers=1", "ranges_m=[2.0]"], False),
    "st-localization": (["realizations=2", "speeds_mps=[0.5, 2.0]", "trajectory_2_speeds_mps=[0.5]",
                         "path_duration_s=6", "walk_duration_s=6", "workers=1"], False),
}


def _params():
    for name, (_, slow) in SMALL.items():
        yield pytest.param(name, id=name, marks=[pytest.mark.slow] if slow else [])


# ----------------------------------------------------------------------------- the checks


def _drawn_texts(fig, monkeypatch):
    """Draw ``fig``; every text actually drawn (visible, not empty) with its window extent."""
    from matplotlib.text import Text

    drawn = []
    original = Text.draw

    def draw(self, renderer):
        original(self, renderer)
        if self.get_visible() and self.get_text().strip() and self.figure is not None:
            drawn.append((self, self.get_window_extent(renderer)))

    with monkeypatch.context() as m:
        m.setattr(Text, "draw", draw)
        fig.canvas.draw()
    return drawn


def _is_colorbar(ax) -> bool:
    return getattr(ax, "_colorbar", None) is not None or ax.get_label() == "<colorbar>"


def _handle_visible(h) -> bool:
    """Whether a legend handle draws anything (a line, a marker, a face, an edge or a hatch)."""
    from matplotlib.collections import Collection
    from matplotlib.colors import to_rgba
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if not h.get_visible() or (h.get_alpha() is not None and h.get_alpha() == 0):
        return False
    if isinstance(h, Line2D):
        line = h.get_linestyle() not in ("None", "none", "", " ") and h.get_linewidth() > 0
        marker = h.get_marker() not in (None, "None", "none", "", " ") and h.get_markersize() > 0
        return (line or marker) and to_rgba(h.get_color())[3] > 0 or (marker and h.get_markeredgewidth() > 0)
    if isinstance(h, Patch):
        return (h.get_facecolor()[3] > 0 or (h.get_edgecolor()[3] > 0 and h.get_linewidth() > 0)
                or bool(h.get_hatch()))
    if isinstance(h, Collection):
        fc, ec = h.get_facecolors(), h.get_edgecolors()
        return (len(fc) and np.max(fc[:, 3]) > 0) or (len(ec) and np.max(ec[:, 3]) > 0)
    return True


def _draws_inside(artist, ax) -> bool:
    """Whether ``artist`` (a line, collection, patch, image or container) puts anything
    inside ``ax``'s box on the canvas."""
    from matplotlib.collections import Collection
    from matplotlib.container import Container
    from matplotlib.image import AxesImage
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    box = ax.bbox.expanded(1.0, 1.0)
    if isinstance(artist, Container):
        return any(_draws_inside(a, ax) for a in artist.get_children() if a is not None)
    if not artist.get_visible():
        return False
    if isinstance(artist, Line2D):
        xy = np.asarray(artist.get_xydata(), dtype=float)
        pts = artist.get_transform().transform(xy) if xy.size else np.empty((0, 2))
    elif isinstance(artist, Collection):
        off = np.asarray(artist.get_offsets(), dtype=float)
        if off.size and not np.all(off == 0):
            pts = artist.get_offset_transform().transform(off)
        else:
            verts = [p.vertices for p in artist.get_paths() if len(p.vertices)]
            pts = artist.get_transform().transform(np.vstack(verts)) if verts else np.empty((0, 2))
    elif isinstance(artist, (Patch, AxesImage)):
        return artist.get_window_extent().overlaps(box)
    else:
        return True
    ok = np.all(np.isfinite(pts), axis=1)
    pts = pts[ok]
    return bool(np.any((pts[:, 0] >= box.x0) & (pts[:, 0] <= box.x1)
                       & (pts[:, 1] >= box.y0) & (pts[:, 1] <= box.y1)))


def _overlapping_labels(fig, extents: dict) -> list[str]:
    """Pairs of drawn titles and axis labels (of the axes and of the figure) whose extents
    overlap by more than 2 pixels each way."""
    labels = [t for t in (getattr(fig, "_suptitle", None), getattr(fig, "_supxlabel", None),
                          getattr(fig, "_supylabel", None)) if t is not None]
    for ax in fig.get_axes():
        labels += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label]
    seen = [(t, extents[id(t)]) for t in labels if id(t) in extents]
    out = []
    for i, (a, ea) in enumerate(seen):
        for b, eb in seen[i + 1:]:
            w = min(ea.x1, eb.x1) - max(ea.x0, eb.x0)
            h = min(ea.y1, eb.y1) - max(ea.y0, eb.y0)
            if w > 2 and h > 2:
                out.append(f"{a.get_text()[:40]!r} overlaps {b.get_text()[:40]!r}")
    return out


def _legends_on_data(fig) -> list[str]:
    """Legends whose box overlaps an axes' plotting area by more than 2 pixels each way."""
    renderer = fig.canvas.get_renderer()
    legends = [ax.get_legend() for ax in fig.get_axes() if ax.get_legend() is not None] + list(fig.legends)
    out = []
    for leg in legends:
        if not leg.get_visible():
            continue
        box = leg.get_window_extent(renderer)
        for ax in fig.get_axes():
            if not ax.get_visible() or _is_colorbar(ax):
                continue
            w = min(box.x1, ax.bbox.x1) - max(box.x0, ax.bbox.x0)
            h = min(box.y1, ax.bbox.y1) - max(box.y0, ax.bbox.y0)
            if w > 2 and h > 2:
                first = leg.get_texts()[0].get_text()[:30] if leg.get_texts() else ""
                out.append(f"the legend ({first!r}, ...) lies on the data of axes "
                           f"{ax.get_title()[:40] or 'untitled'!r}")
                break
    return out


def readability_problems(fig, monkeypatch, name: str = "figure") -> list[str]:
    """What a reader of ``fig`` would stumble on (an empty list when nothing)."""
    problems = []
    canvas = fig.bbox
    drawn = _drawn_texts(fig, monkeypatch)
    for text, ext in drawn:
        if (ext.x0 < canvas.x0 - EDGE_PX or ext.y0 < canvas.y0 - EDGE_PX
                or ext.x1 > canvas.x1 + EDGE_PX or ext.y1 > canvas.y1 + EDGE_PX):
            if text.get_clip_on() and text.get_clip_box() is not None and not ext.overlaps(text.get_clip_box()):
                continue  # clipped away: not seen
            problems.append(f"{name}: text {text.get_text()[:50]!r} leaves the canvas "
                            f"(extent {ext.x0:.0f}..{ext.x1:.0f} x {ext.y0:.0f}..{ext.y1:.0f} px, "
                            f"canvas {canvas.width:.0f} x {canvas.height:.0f} px)")
    problems += [f"{name}: {o}" for o in _overlapping_labels(fig, {id(t): e for t, e in drawn})]
    problems += [f"{name}: {o}" for o in _legends_on_data(fig)]
    axes = [ax for ax in fig.get_axes() if ax.get_visible()]
    for k, ax in enumerate(axes):
        if _is_colorbar(ax):
            continue
        where = f"{name} axes {k} ({ax.get_title() or ax.get_title('left') or 'untitled'}"[:70] + ")"
        if not ax.has_data():
            problems.append(f"{where}: empty (no data drawn)")
            continue
        siblings = [s for s in ax.get_shared_x_axes().get_siblings(ax) if s.get_visible()]
        if not any(s.get_xlabel().strip() for s in siblings):
            problems.append(f"{where}: no x label")
        siblings = [s for s in ax.get_shared_y_axes().get_siblings(ax) if s.get_visible()]
        if not any(s.get_ylabel().strip() for s in siblings):
            problems.append(f"{where}: no y label")
        legends = [ax.get_legend()] if ax.get_legend() is not None else []
        legends += [leg for leg in fig.legends if leg.axes is None or leg.axes is ax]
        shown = {t.get_text() for leg in legends for t in leg.get_texts()}
        for leg in legends:
            for handle, text in zip(leg.legend_handles, leg.get_texts()):
                if handle is None or not _handle_visible(handle):
                    problems.append(f"{where}: legend entry {text.get_text()!r} has no visible handle")
        for artist, label in zip(*ax.get_legend_handles_labels()):
            if label in shown and not _draws_inside(artist, ax):
                problems.append(f"{where}: legend entry {label!r} names a series not drawn in the axes")
    return sorted(set(problems))


# ----------------------------------------------------------------------------- the test


@pytest.fixture
def held_figures(monkeypatch):
    """Figures ``save_figure`` closes are kept open (and closed after the test)."""
    from rfsim.core.plots import pyplot

    plt = pyplot()
    held = []
    real_close = plt.close

    def close(fig=None):
        if fig is not None and hasattr(fig, "canvas"):
            held.append(fig)
        else:
            real_close(fig)

    monkeypatch.setattr(plt, "close", close)
    yield held
    for fig in held:
        real_close(fig)


@pytest.mark.parametrize("scenario", list(_params()))
def test_every_figure_is_readable(scenario, tmp_path, held_figures, monkeypatch):
    overrides, _ = SMALL[scenario]
    data = tmp_path / f"{scenario}.h5"
    args = ["run", scenario, "--seed", "1", "--no-plot", "-q", "-o", str(data)]
    for o in overrides:
        args += ["--set", o]
    assert main(args) == 0
    paths = get_scenario(scenario).plot(data, tmp_path)
    assert len(paths) >= 1 and len(held_figures) == len(paths)
    problems = []
    for path, fig in zip(paths, held_figures):
        problems += readability_problems(fig, monkeypatch, path.stem)
    assert not problems, "\n".join(problems)


def test_the_checks_see_a_clipped_title_an_empty_axes_and_a_legend_lie(held_figures, monkeypatch):
    """The checker itself: a figure with each defect is caught, its repair passes."""
    from rfsim.core.plots import pyplot

    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(3, 2))
    a.plot([0, 1], [0, 1], label="drawn")
    a.plot([np.nan, np.nan], [0, 1], label="all NaN")
    a.plot([5, 6], [0, 1], label="out of view")
    a.set_xlim(0, 1)
    a.legend(loc="upper left")
    a.set_title("a very long title that cannot fit on so small a canvas at all, not at all")
    a.set_ylabel("y [m]")
    b.set_title("the second panel's title, long too")
    problems = readability_problems(fig, monkeypatch)
    text = "\n".join(problems)
    assert "leaves the canvas" in text and "a very long title" in text
    assert "'all NaN' names a series not drawn" in text and "'out of view' names a series" in text
    assert "'drawn'" not in text.replace("the legend ('drawn'", "")
    assert "the legend ('drawn', ...) lies on the data" in text
    assert "axes 0 (a very long title" in text and "no x label" in text
    assert "axes 1 (the second panel's title, long too): empty" in text
    assert any("'a very long title that cannot fit on so ' overlaps" in p and "second panel" in p
               for p in problems)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(3, 2), layout="constrained")
    ax.plot([0, 1], [0, 1], label="drawn")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="short")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0))  # off the data
    assert readability_problems(fig, monkeypatch) == []


@pytest.mark.parametrize("scene", ["one-reader-one-tag.toml", "exciter-sense-a-tags.toml"])
def test_scene_file_figures_are_readable(scene, project_root, tmp_path, held_figures, monkeypatch):
    """A scene file's figures (geometry, reads, RSSI/phase, detections) pass the same checks."""
    from rfsim.scenes.scene_file import plot

    data = tmp_path / "scene.h5"
    assert main(["run", str(project_root / "examples" / "scenes" / scene), "--seed", "1", "--no-plot", "-q",
                 "-o", str(data)]) == 0
    paths = plot(data, tmp_path)
    problems = []
    for path, fig in zip(paths, held_figures):
        if fig.axes and any(ax.has_data() for ax in fig.axes):  # a scene without readers draws empty reads
            problems += readability_problems(fig, monkeypatch, path.stem)
    assert paths and not problems, "\n".join(problems)

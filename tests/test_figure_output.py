"""``--format`` and ``--dpi`` of ``rfsim run`` and ``rfsim plot``: one file per format, PNG by
default, the resolution of raster files as asked, one-line errors for what cannot be written."""

from __future__ import annotations

import pytest

from rfsim.cli import main
from rfsim.core.errors import UserError
from rfsim.core.plots import FigureOutput, figure_output, pyplot, save_figure

GEN2 = ["--set", "profiles=['fm0-40k']", "--set", "fs_hz=1e6"]

#: The first bytes of each file format (its signature), written by the format's own writer.
MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "pdf": b"%PDF-", "svg": b"<?xml", "eps": b"%!PS-Adobe"}


def _png_size(path):
    """(width, height) [pixels] from a PNG's IHDR chunk."""
    data = path.read_bytes()
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    assert main(["run", "gen2-waveforms", *GEN2, "-q", "--no-plot", "--out-dir", str(out)]) == 0
    return out / "gen2-waveforms.h5"


def test_run_writes_each_format_and_prints_every_file(tmp_path, capsys):
    assert main(["run", "gen2-waveforms", *GEN2, "--out-dir", str(tmp_path),
                 "--format", "png,pdf,svg"]) == 0
    printed = [line.split(None, 1)[1] for line in capsys.readouterr().out.splitlines()
               if line.startswith("figure:")]
    names = [f"gen2-waveforms-exchange.{fmt}" for fmt in ("png", "pdf", "svg")]
    assert printed == [str(tmp_path / n) for n in names]
    for name in names:
        assert (tmp_path / name).read_bytes().startswith(MAGIC[name.rsplit(".", 1)[1]])


def test_plot_default_is_png_only(dataset, tmp_path):
    assert main(["plot", str(dataset), "--out-dir", str(tmp_path), "-q"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gen2-waveforms-exchange.png"]


def test_plot_dpi_scales_the_raster_and_format_is_case_insensitive(dataset, tmp_path):
    sizes = {}
    for dpi in (60, 180):
        out = tmp_path / str(dpi)
        assert main(["plot", str(dataset), "--out-dir", str(out), "-q", "--format", "PNG,eps",
                     "--dpi", str(dpi)]) == 0
        assert (out / "gen2-waveforms-exchange.eps").read_bytes().startswith(MAGIC["eps"])
        sizes[dpi] = _png_size(out / "gen2-waveforms-exchange.png")
    # three times the resolution: three times the pixels on each side (a tight bounding box
    # rounds each side to a whole pixel at each resolution)
    for k in (0, 1):
        assert abs(sizes[180][k] - 3 * sizes[60][k]) <= 3


@pytest.mark.parametrize("args, message", [
    (["--format", "jpg"], "--format 'jpg'"),
    (["--format", ","], "--format: give at least one"),
    (["--dpi", "5"], "--dpi 5"),
])
def test_bad_format_or_dpi_is_one_line_before_anything_is_drawn(dataset, tmp_path, capsys, args, message):
    assert main(["plot", str(dataset), "--out-dir", str(tmp_path), *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rfsim: error: ") and message in err and err.count("\n") == 1
    assert not any(tmp_path.iterdir())


def test_save_figure_in_a_figure_output_block(tmp_path):
    """The block's formats replace the path's suffix; the user's dpi wins over the figure's."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(2, 1))
    ax.plot([0, 1], [0, 1])
    with figure_output(FigureOutput(("svg", "png"), dpi=50)):
        first = save_figure(fig, tmp_path / "a.png", dpi=200)
    assert first == tmp_path / "a.svg"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.svg"]
    w, h = _png_size(tmp_path / "a.png")
    assert 90 <= w <= 100 and 40 <= h <= 50  # 2 x 1 in at 50 dpi (tight box: a little less)
    fig, ax = plt.subplots(figsize=(2, 1))
    ax.plot([0, 1], [0, 1])
    save_figure(fig, tmp_path / "b.png", dpi=200)  # outside the block: PNG at the figure's dpi
    w, h = _png_size(tmp_path / "b.png")
    assert 360 <= w <= 400 and 160 <= h <= 200
    with pytest.raises(UserError):
        FigureOutput.parse("png,tiff")


def test_contact_sheet_puts_every_figure_of_every_dataset_on_one_page(dataset, tmp_path, capsys):
    runs = tmp_path / "results"
    runs.mkdir()
    (runs / "gen2-waveforms.h5").write_bytes(dataset.read_bytes())
    assert main(["run", "link", "-q", "--no-plot", "-o", str(runs / "link.h5"), "--set",
                 "geometry.distances_m=[1.0, 9.0]", "--set", "rounds_per_point=2"]) == 0
    (runs / "notes.h5").write_text("not a dataset")  # skipped, as is anything not written by 'rfsim run'
    sheet_dir = tmp_path / "sheet"
    assert main(["plot", "--all-scenarios", str(runs), "--out-dir", str(sheet_dir), "--format", "png,pdf"]) == 0
    out = capsys.readouterr()
    assert out.out.split() == ["figure:", str(sheet_dir / "contact-sheet.png"),
                               "figure:", str(sheet_dir / "contact-sheet.pdf")]
    # scenarios in 'rfsim list' order: gen2-waveforms before link
    assert out.err.index("gen2-waveforms figures") < out.err.index("link figures")
    assert (sheet_dir / "contact-sheet.pdf").read_bytes().startswith(MAGIC["pdf"])
    # two figures side by side: two cells of 4.2 in at 150 dpi (the tight box trims the margins)
    w, h = _png_size(sheet_dir / "contact-sheet.png")
    assert 2 * 4.2 * 150 * 0.85 < w <= 2 * 4.2 * 150 and h > 300
    assert not list(runs.glob("*.png"))  # the datasets' folder is left as it was


@pytest.mark.parametrize("args, message", [
    ([], "give a dataset file or --all-scenarios DIR"),
    (["x.h5", "--all-scenarios", "."], "give a dataset file or --all-scenarios DIR"),
    (["--all-scenarios", "missing"], "not a folder"),
    (["--all-scenarios", "."], "no dataset written by 'rfsim run'"),
])
def test_contact_sheet_errors_are_one_line(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    assert main(["plot", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rfsim: error: ") and message in err and err.count("\n") == 1

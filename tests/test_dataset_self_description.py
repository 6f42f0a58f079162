"""Every scenario's dataset explains itself (issue: datasets a researcher can read alone).

Each scenario runs once, tiny, through the command line; its file is then checked with
h5py and xarray, not with rfsim's own reader: every group and column has a description
that is more than its name respelled, units and a CF ``long_name`` that xarray shows,
booleans carry CF ``flag_values``/``flag_meanings``, root attributes are finite or say what
their NaN/inf means, and every table goes into pandas in one line.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import io
import re

import h5py
import matplotlib
import numpy as np
import pandas as pd
import pytest
import scipy
import xarray as xr

import rfsim

from rfsim.cli import main
from rfsim.core.dataset import CONVENTIONS, LONG_NAME_MAX, read_table

#: Tiny configs (``--set`` overrides) that still produce every table of each scenario.
TINY = {
    "access": ["geometry.distances_m=[1.0, 5.0, 9.0]", "rounds_per_point=2"],
    "gen2-waveforms": ["profiles=['fm0-40k', 'miller4-320k']", "fs_hz=3e6"],
    "link": ["geometry.distances_m=[1.0, 9.0]", "rounds_per_point=2"],
    "inventory": ["populations=[3]", "runs=1", "capture.trials=2", "capture.ratios_db=[0.0, 4.0]",
                  "capture_sweep.trials=20", "capture_sweep.ratios_db=[0.0, 6.0]", "spread.enabled=true",
                  "reader.blf_search=preamble", "reader.rn16_false_accept=0.01"],
    "reader-detection": ["campaign.distances_m=[1.0, 9.0]", "campaign.angles_deg=[0.0, 90.0]",
                         "campaign.repetitions=2", "campaign.queries=5", "campaign.workers=1"],
    "detection-probability": ["samples.count=40", "samples.n_train=30"],
    "phase-cancellation": ["geometry.tag_x_m=[1.0, 6.0]", "mc.positions_per_cell=6", "mc.workers=1",
                           "tracks.cell=0"],
    "rss-localization": ["sigma0_db=[5.2]", "trials=20", "particles=50", "rss_model=waveform"],
    "st-to-st": ["geometry.st_x_m=[1.0, 4.0]", "mc.positions_per_cell=6", "mc.workers=1"],
    "exciter-link": ["sweep.exciter_distance_m=[1.0, 3.0]", "sweep.tag_distance_m=[0.2, 1.0]",
                     "sweep.draws_per_point=3", "sweep.workers=1"],
    "himr-2d": ["scene.duration_s=0.4", "observer.outage_s=[0.1, 0.2]"],
    "himr-1d": ["scene.duration_s=0.2"],
    "phase-tracking": ["trajectory.duration_s=0.5", "schedule.workers=1"],
    "tag-to-tag-tracking": ["trajectories=3", "filter_runs=2", "workers=1", "ranges_m=[2.0]"],
    "st-localization": ["realizations=2", "speeds_mps=[0.5, 2.0]", "trajectory_2_speeds_mps=[0.5]",
                        "path_duration_s=6", "walk_duration_s=6", "workers=1"],
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Each scenario run once, tiny, by the CLI: (dataset path, what it printed on stderr)."""
    out = tmp_path_factory.mktemp("self-description")
    done = {}
    for name, sets in TINY.items():
        path = out / f"tiny-{name}.h5"
        argv = ["run", name, "--no-plot", "-o", str(path)]
        for s in sets:
            argv += ["--set", s]
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            assert main(argv) == 0, name
        done[name] = (path, err.getvalue())
    return done


@pytest.fixture(scope="module")
def datasets(runs):
    return {name: path for name, (path, _) in runs.items()}


@pytest.mark.parametrize("scenario", sorted(TINY))
def test_every_run_reports_its_stages_and_monte_carlo_progress(runs, scenario):
    """Progress in a batch log (stderr is not a TTY here): stage lines and, for every loop of
    trials, tqdm lines ``desc: n/N unit (p %)`` from the first to the last — no ``\r``."""
    _, err = runs[scenario]
    assert "\r" not in err
    assert f"rfsim: running {scenario} (seed 1)" in err and "rfsim: writing " in err
    if scenario != "gen2-waveforms":  # the only scenario without a loop of trials
        first = re.search(r"^[\w ]+: 0/(\d+) \w+ \(0\.0 %\)", err, re.M)
        assert first, err
        assert re.search(rf"^[\w ]+: {first.group(1)}/{first.group(1)} \w+ \(100\.0 %\), .* ETA", err, re.M), err


def _words(text: str) -> set[str]:
    return {w for w in re.split(r"[^a-z0-9]+", text.lower()) if w}


def _problems(path) -> list[str]:
    """Everything in the file that does not explain itself, as readable lines."""
    bad = []
    with h5py.File(path, "r") as f:
        for k, v in f.attrs.items():
            arr = np.asarray(v)
            if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)) and not f.attrs.get(f"{k}_meaning"):
                bad.append(f"root attribute {k} = {v!r} without {k}_meaning")
        for gname, g in f.items():
            if len(str(g.attrs.get("description", "")).split()) < 4:
                bad.append(f"group {gname}: no description")
            for name, ds in g.items():
                where = f"{gname}/{name}"
                desc = str(ds.attrs.get("description", ""))
                respelled = set(name.lower().split("_")) | {"m", "s", "v", "hz", "rad", "w", "db", "dbm"}
                if len(desc.split()) < 3 or _words(desc) <= respelled:
                    bad.append(f"{where}: description {desc!r} says no more than the name")
                if "units" not in ds.attrs or not str(ds.attrs.get("long_name", "")):
                    bad.append(f"{where}: units or long_name missing")
                if len(str(ds.attrs.get("long_name", ""))) > LONG_NAME_MAX:
                    bad.append(f"{where}: long_name longer than {LONG_NAME_MAX} characters (the sentence "
                               "belongs in description)")
                if h5py.check_string_dtype(ds.dtype) is not None and ds.attrs.get("units") != "":
                    bad.append(f"{where}: text column with units {ds.attrs.get('units')!r} (text has units '')")
                if ds.attrs.get("rfsim_dtype") == "bool":
                    if list(ds.attrs.get("flag_values", [])) != [0, 1] or \
                            len(str(ds.attrs.get("flag_meanings", "")).split()) != 2:
                        bad.append(f"{where}: boolean without CF flag_values/flag_meanings")
    return bad


@pytest.mark.parametrize("scenario", sorted(TINY))
def test_every_group_and_column_explains_itself(datasets, scenario):
    assert _problems(datasets[scenario]) == []


@pytest.mark.parametrize("scenario", sorted(TINY))
def test_every_file_says_where_it_comes_from(datasets, scenario):
    """Root ``Conventions``, ``source`` (version + scenario) and ``history`` (ISO time and the
    command line); provenance with the command line and the scipy and matplotlib versions.
    xarray shows them on every group it opens."""
    path = datasets[scenario]
    with h5py.File(path, "r") as f:
        assert f.attrs["Conventions"] == CONVENTIONS
        assert f.attrs["source"] == f"rfsim {rfsim.__version__}, scenario {scenario}"
        history = str(f.attrs["history"])
        prov = {k: str(v) for k, v in f["provenance"].attrs.items()}
    assert prov["command_line"].startswith(f"rfsim run {scenario} --no-plot -o ")
    assert prov["scipy"] == scipy.__version__ and prov["matplotlib"] == matplotlib.__version__
    stamp, command = history.split(" ", 1)
    assert _dt.datetime.fromisoformat(stamp).tzinfo is not None and command == prov["command_line"]
    with xr.open_dataset(path, engine="h5netcdf") as root:
        assert root.attrs["Conventions"] == CONVENTIONS and root.attrs["history"] == history


def test_the_check_finds_what_it_should(tmp_path):
    """The checker above is not vacuous: a file with each defect is reported for each."""
    path = tmp_path / "bad.h5"
    with h5py.File(path, "w") as f:
        f.attrs["spacing_m"] = float("inf")
        g = f.create_group("t")
        g.create_dataset("n_test", data=np.arange(3)).attrs["description"] = "n test"
        b = g.create_dataset("ok", data=np.ones(3, np.uint8))
        b.attrs.update(description="the ST decoded the reply", units="1", long_name="decoded", rfsim_dtype="bool")
        w = g.create_dataset("why", data=np.array(["a", "b", "c"], dtype=h5py.string_dtype()))
        w.attrs.update(description="why the read failed, in words", units="1", long_name="x" * 61)
    text = "\n".join(_problems(path))
    for expected in ("root attribute spacing_m", "group t: no description", "t/n_test: description",
                     "t/n_test: units or long_name", "t/ok: boolean without CF", "t/why: long_name longer",
                     "t/why: text column with units '1'"):
        assert expected in text


def test_xarray_shows_units_long_name_and_group_description(datasets):
    with xr.open_dataset(datasets["link"], engine="h5netcdf", group="reads") as reads:
        assert reads["peak_rssi_dbm"].attrs["units"] == "dBm"
        assert reads["peak_rssi_dbm"].attrs["long_name"] == "peak RSSI"
        assert "round" in reads.attrs["description"]
        # CF flags: xarray keeps them as attributes of the uint8 variable
        assert list(reads["success"].attrs["flag_values"]) == [0, 1]
        assert reads["success"].attrs["flag_meanings"] == "false true"
    with xr.open_dataset(datasets["phase-cancellation"], engine="h5netcdf", group="tracks") as tracks:
        assert tracks["diff_v"].attrs["units"] == "V" and tracks["diff_v"].dims == ("angle_deg", "distance_m")


def test_any_table_into_pandas_in_one_line(datasets):
    """The README's one-liners: ``pandas.DataFrame(read_table(...))`` and xarray's ``to_dataframe``."""
    path = datasets["inventory"]
    frame = pd.DataFrame(read_table(path, "slots"))
    with h5py.File(path, "r") as f:
        names = sorted(k for k in f["slots"] if k != "row")
        n = f["slots"]["row"].shape[0]
        epc = f["slots"]["epc_hex"].asstr()[()]
    assert sorted(frame.columns) == names and len(frame) == n > 0
    assert list(frame["epc_hex"]) == list(epc)
    via_xr = xr.open_dataset(path, engine="h5netcdf", group="slots").to_dataframe()
    assert len(via_xr) == n and set(names) <= set(via_xr.columns)
    grid = xr.open_dataset(datasets["phase-cancellation"], engine="h5netcdf", group="tracks").to_dataframe()
    assert {"diff_v", "closed_diff_v", "theta_rad"} <= set(grid.columns)
    assert grid.index.names == ["angle_deg", "distance_m"]


#: Figures each scenario draws (suffixes after the dataset's stem).
FIGURES = {
    "access": ["ranges"],
    "gen2-waveforms": ["exchange"], "link": ["rssi-read-rate"], "inventory": ["capture", "summary"],
    "reader-detection": ["heatmap", "mean"], "detection-probability": ["fig4_7"],
    "phase-cancellation": ["fig3_15", "fig3_16", "fig3_3_3_5", "fig3_8"],
    "rss-localization": ["cdf", "floorplan", "rmse"],
    "st-to-st": ["pcancel"], "exciter-link": ["heatmap"],
    "himr-2d": ["eigenvalues", "errors", "rss-phase", "trajectory"],
    "himr-1d": ["eigenvalues", "errors", "rss-phase", "trajectory"],
    "phase-tracking": ["cdf", "phase", "track"],
    "tag-to-tag-tracking": ["cdf", "error-time", "table6_2", "tracks"],
    "st-localization": ["cdf", "error-time", "rmse", "room", "speed"],
}


@pytest.mark.parametrize("scenario", sorted(TINY))
def test_rfsim_plot_draws_every_figure_from_the_file_alone(datasets, scenario, tmp_path):
    assert main(["plot", str(datasets[scenario]), "--out-dir", str(tmp_path), "-q"]) == 0
    drawn = sorted(p.name for p in tmp_path.glob("*.png"))
    assert drawn == sorted(f"tiny-{scenario}-{what}.png" for what in FIGURES[scenario])
    assert all((tmp_path / name).stat().st_size > 5000 for name in drawn)

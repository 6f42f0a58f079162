"""Scenario ``read-range``: a reader and a tag at swept distance, a few Query rounds each;
the read rate and the RSSI vs distance (a smaller cousin of the built-in ``link``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfsim import Simulation
from rfsim.channels import Antenna, Channel, HalfWaveDipole, Patch, Scene
from rfsim.core.config import param
from rfsim.core.dataset import Dataset, column, read_table
from rfsim.core.plots import figure_path, pyplot, save_figure
from rfsim.core.rng import trial_rng
from rfsim.devices import PassiveTag, Reader, ReaderConfig, TagConfig

NAME = "read-range"
DESCRIPTION = "reader + one tag in free space: read rate and RSSI vs distance"


@dataclass(frozen=True)
class Config:
    distances_m: tuple[float, ...] = param((1.0, 2.0, 4.0), lo=0.1, hi=50.0, unit="m", doc="reader-tag distances")
    rounds: int = param(3, lo=1, hi=1000, doc="Query rounds per distance")


def run(config: Config, *, seed: int) -> Dataset:
    rows = {"distance_m": [], "success": [], "rssi_dbm": []}
    for i, d in enumerate(config.distances_m):
        reader = Reader(ReaderConfig(), [Antenna(position_m=(0.0, 0.0, 1.0), pattern=Patch(6.0, 70.0))],
                        rng=trial_rng(seed, i, 0))
        tag = PassiveTag(TagConfig(), Antenna(position_m=(d, 0.0, 1.0), orientation=(np.pi, 0.0, 0.0),
                                              pattern=HalfWaveDipole()), rng=trial_rng(seed, i, 1))
        sim = Simulation(reader, [tag], Channel(Scene()), seed=seed + i)
        for r in range(config.rounds):  # a read flips the tag's S0 flag: alternate the target
            last = sim.query_round(target="AB"[r % 2])[-1]
            ok = last.command == "ACK" and last.success
            rows["distance_m"].append(d)
            rows["success"].append(ok)
            rows["rssi_dbm"].append(last.read.rssi_dbm if ok else np.nan)
    ds = Dataset(title="read rate and RSSI vs distance")
    ds.add_table("reads", {"distance_m": column(rows["distance_m"], "m", "reader-tag distance"),
                           "success": column(rows["success"], "1", "EPC decoded with CRC ok"),
                           "rssi_dbm": column(rows["rssi_dbm"], "dBm", "RSSI of the EPC reply (NaN: no read)")},
                 description="one row per Query round")
    return ds


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    t = read_table(dataset_path, "reads")
    d = np.unique(t["distance_m"])
    rssi = [np.nanmean(t["rssi_dbm"][t["distance_m"] == x]) if t["success"][t["distance_m"] == x].any() else np.nan
            for x in d]
    fig, ax = pyplot().subplots(figsize=(6, 3.5))
    ax.semilogx(d, rssi, "o-")
    ax.set(xlabel="distance [m]", ylabel="mean RSSI [dBm]", title="read range")
    return [save_figure(fig, figure_path(dataset_path, out_dir, "rssi"))]

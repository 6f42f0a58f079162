"""A user scenario: read rate of one tag vs distance in free space (rfsim run examples/my_scenario.py)."""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfsim import Scene, Simulation
from rfsim.channels import Antenna, Channel, HalfWaveDipole, Patch
from rfsim.core.config import param
from rfsim.core.dataset import Dataset, column, read_table
from rfsim.core.plots import figure_path, pyplot, save_figure
from rfsim.core.rng import trial_rng
from rfsim.devices import PassiveTag, Reader, ReaderConfig, TagConfig

NAME = "my-read-rate"
DESCRIPTION = "example user scenario: read rate of one tag vs distance, free space"


@dataclass(frozen=True)
class Config:
    distances_m: tuple[float, ...] = param((1.0, 4.0, 8.0), lo=0.1, hi=30.0, unit="m", doc="tag distances")
    rounds: int = param(4, lo=1, hi=10000, doc="inventory rounds per distance")
    reader: ReaderConfig = param(ReaderConfig(), doc="reader")


def run(config: Config, *, seed: int) -> Dataset:
    distance, success = [], []
    for i, d in enumerate(config.distances_m):
        reader = Reader(config.reader, [Antenna(position_m=(0.0, 0.0, 1.0), pattern=Patch(6.0, 70.0))],
                        rng=trial_rng(seed, i, 0))
        tag = PassiveTag(TagConfig(), Antenna(position_m=(d, 0.0, 1.0), orientation=(np.pi, 0.0, 0.0),
                                              pattern=HalfWaveDipole()), rng=trial_rng(seed, i, 1))
        sim = Simulation(reader, [tag], Channel(Scene()), seed=int(trial_rng(seed, i, 2).integers(2**63)))
        for r in range(config.rounds):
            # a read flips the tag's session-0 flag A -> B: alternate the target to read it again
            last = sim.query_round(target="AB"[r % 2])[-1]
            distance.append(d)
            success.append(last.command == "ACK" and not last.failure_reason)
    ds = Dataset(title="read rate vs distance (example user scenario)")
    ds.add_table("rounds", {"distance_m": column(distance, "m", "tag distance from the reader antenna"),
                            "success": column(success, "1", "the EPC was read in this round")},
                 description="one row per inventory round")
    ds.attrs["read_rate"] = float(np.mean(success))
    return ds


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    t = read_table(dataset_path, "rounds")
    d = np.unique(t["distance_m"])
    rate = [t["success"][t["distance_m"] == x].mean() for x in d]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(d, rate, "o-")
    ax.set(xlabel="distance [m]", ylabel="read rate", ylim=(-0.05, 1.05))
    return [save_figure(fig, figure_path(dataset_path, out_dir, "read-rate"))]

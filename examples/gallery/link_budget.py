"""Link budget vs distance: one reader, one tag, a Query round at each distance.

Each point runs :class:`rfsim.Simulation` (sample-level Query → RN16 → ACK → EPC in free
space) and records the reader's RSSI; the line is the monostatic free-space slope
(−40 dB per decade of distance, Friis twice) through the first point.
Writes ``link_budget.png``.
"""

from __future__ import annotations

import numpy as np

from rfsim import Simulation
from rfsim.channels import Antenna, Channel, HalfWaveDipole, Patch, Scene
from rfsim.core.plots import pyplot
from rfsim.core.rng import trial_rng
from rfsim.devices import PassiveTag, Reader, ReaderConfig, TagConfig

from _common import arguments


def rssi_at(distance_m: float, seed: int) -> float:
    """RSSI [dBm] of the ACK's reply for a tag at ``distance_m`` (NaN when the read fails)."""
    reader = Reader(ReaderConfig(), [Antenna(position_m=(0.0, 0.0, 1.0), pattern=Patch(6.0, 70.0))],
                    rng=trial_rng(seed, 0))
    tag = PassiveTag(TagConfig(), Antenna(position_m=(distance_m, 0.0, 1.0), orientation=(np.pi, 0.0, 0.0),
                                          pattern=HalfWaveDipole()), rng=trial_rng(seed, 1))
    last = Simulation(reader, [tag], Channel(Scene()), seed=seed).query_round()[-1]
    return last.read.rssi_dbm if last.command == "ACK" and last.success else float("nan")


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    distances_m = np.array([1.0, 2.0, 4.0] if args.small else [0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0])
    rssi_dbm = np.array([rssi_at(d, seed=7) for d in distances_m])
    for d, r in zip(distances_m, rssi_dbm):
        print(f"{d:4.1f} m: RSSI {r:6.1f} dBm")
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.semilogx(distances_m, rssi_dbm, "o", label="simulated read")
    ax.semilogx(distances_m, rssi_dbm[0] - 40 * np.log10(distances_m / distances_m[0]), "--",
                label="−40 dB/decade (free space, monostatic)")
    ax.set(xlabel="reader–tag distance [m]", ylabel="RSSI [dBm]", title="Backscatter link budget")
    ax.legend()
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    path = args.out / "link_budget.png"
    fig.savefig(path, dpi=90)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()

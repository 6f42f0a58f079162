"""A small inventory: the Q algorithm reads a tag population at sample level.

Tags on a circle around the reader; :func:`rfsim.protocols.inventory.run_inventory` runs
Gen2 rounds (Query, QueryRep, QueryAdjust, ACK) through the sample-level air interface
(:class:`rfsim.protocols.inventory.EngineAir`) until a round brings no reply.
Writes ``small_inventory.png``: the slots in time, coloured by what the reader saw.
"""

from __future__ import annotations

import numpy as np

from rfsim.channels import Antenna, Channel, HalfWaveDipole, Patch, Scene
from rfsim.core.plots import pyplot
from rfsim.core.rng import trial_rng
from rfsim.devices import PassiveTag, Reader, ReaderConfig, TagConfig
from rfsim.protocols.inventory import EngineAir, InventoryConfig, run_inventory

from _common import arguments


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    n_tags, seed = (4 if args.small else 12), 3
    reader = Reader(ReaderConfig(), [Antenna(position_m=(0.0, 0.0, 1.0), pattern=Patch(6.0, 70.0))],
                    rng=trial_rng(seed, 0))
    tags = []
    for k, a in enumerate(np.linspace(-0.5, 0.5, n_tags)):  # a 1 rad arc, 2 m from the reader
        position = (2.0 * np.cos(a), 2.0 * np.sin(a), 1.0)
        tags.append(PassiveTag(TagConfig(), Antenna(position_m=position, orientation=(a + np.pi, 0.0, 0.0),
                                                    pattern=HalfWaveDipole()), rng=trial_rng(seed, 1, k)))
    air = EngineAir(reader, tags, Channel(Scene()), rng=trial_rng(seed, 2))
    log = run_inventory(air, InventoryConfig(q_initial=2.0))
    kinds = np.asarray(log.slots["slot_type"])
    n_read = len({t for t in log.reads["tag"] if t >= 0})
    counts = {str(kind): int(np.sum(kinds == kind)) for kind in dict.fromkeys(kinds)}
    print(f"{n_read} of {n_tags} tags read in {kinds.size} slots: {counts}")
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 2.8))
    colours = {"success": "tab:green", "capture": "tab:olive", "collision": "tab:red", "empty": "0.7"}
    for kind in counts:
        at = np.flatnonzero(kinds == kind)
        ax.bar(at, np.ones(at.size), width=0.9, color=colours.get(kind, "tab:purple"), label=f"{kind} ({at.size})")
    ax.set(xlabel="slot", yticks=[], title=f"Inventory of {n_tags} tags: {n_read} read")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    path = args.out / "small_inventory.png"
    fig.savefig(path, dpi=90)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()

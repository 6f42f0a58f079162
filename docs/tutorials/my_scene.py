"""Your own scene: a reader and a tag, in free space and in a room with a concrete floor and
diffuse paths.

Prints the read rate and the RSSI spread over a few Query rounds at two distances in each
scene, and saves the exchanges of the last run as an HDF5 file.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from rfsim import Simulation
from rfsim.channels import Antenna, ApdpModel, Channel, HalfWaveDipole, Patch, Scene, Surface
from rfsim.core.rng import trial_rng
from rfsim.devices import PassiveTag, Reader, ReaderConfig, TagConfig

SEED, ROUNDS = 11, 6


def devices(distance_m: float, seed: int):
    """A 6 dBi patch at 1 m height looking along +x; a dipole tag on its boresight."""
    reader = Reader(ReaderConfig(), [Antenna(position_m=(0.0, 0.0, 1.0), pattern=Patch(6.0, 70.0))],
                    rng=trial_rng(seed, 0))
    tag = PassiveTag(TagConfig(), Antenna(position_m=(distance_m, 0.0, 1.0), orientation=(np.pi, 0.0, 0.0),
                                          pattern=HalfWaveDipole()), rng=trial_rng(seed, 1))
    return reader, tag


scenes = {
    "free space": Scene(),
    "room": Scene(surfaces=(Surface(point_m=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), eps_r=5.3),),
                  apdp=ApdpModel(), image_order=1),
}
for label, scene in scenes.items():
    for distance_m in (2.0, 4.0):
        reader, tag = devices(distance_m, SEED)
        sim = Simulation(reader, [tag], Channel(scene), seed=SEED)
        for r in range(ROUNDS):
            sim.query_round(target="AB"[r % 2])  # a read flips the tag's S0 flag: alternate
        table = sim.table()
        rssi = table["rssi_dbm"][(table["command"] == "ACK") & table["success"]]
        print(f"{label:10s} {distance_m:.0f} m: {rssi.size} of {ROUNDS} EPCs read, "
              f"RSSI {np.min(rssi, initial=np.inf):6.1f} to {np.max(rssi, initial=-np.inf):6.1f} dBm")
out = Path(sys.argv[1] if len(sys.argv) > 1 else "results/my-scene.h5")
print("dataset:", sim.save(out))

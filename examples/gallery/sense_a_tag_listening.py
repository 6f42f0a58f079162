"""A sense-a-tag hears another sense-a-tag: an exciter-powered tag-to-tag link.

An RF exciter (915 MHz CW) powers a sense-a-tag that backscatters a 16-bit FM0 frame on its
own schedule; a second sense-a-tag 0.27 m away receives it through the air interface
(:func:`rfsim.air.step.propagate`) and decodes it with its envelope detector. A passive tag
nearby hears no reader command and stays silent. Writes ``sense_a_tag_listening.png``:
the envelope at the listener's antenna port.
"""

from __future__ import annotations

import numpy as np

from rfsim.air.step import AntennaPort, LinkTable, propagate
from rfsim.channels import Channel, Scene, vertical_dipole
from rfsim.core.plots import pyplot
from rfsim.core.rng import trial_rng
from rfsim.devices import PassiveTag, TagConfig
from rfsim.devices.exciter import Exciter, ExciterConfig
from rfsim.devices.sense_a_tag import SenseATag, SenseATagConfig, make_receiver

from _common import arguments


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    seed, fs_hz, blf_hz = 4, 4e6, 160e3
    bits = np.array([1, 0, 1, 1, 0, 0, 1, 0, 1, 1, 1, 0, 0, 0, 1, 0], np.uint8)
    st_config = SenseATagConfig(n_antennas=1, technique="single")
    sender = SenseATag(st_config, [vertical_dipole([1.0, 0.0, 1.0])], rng=trial_rng(seed, 1), fs_hz=fs_hz)
    sender.send_frame(bits, start_s=100e-6, blf_hz=blf_hz, m=1)
    listener = SenseATag(st_config, [vertical_dipole([1.25, 0.1, 1.0])], rng=trial_rng(seed, 2), fs_hz=fs_hz)
    tag = PassiveTag(TagConfig(), vertical_dipole([0.7, 0.5, 1.0]), rng=trial_rng(seed, 3))
    exciter = Exciter(ExciterConfig(), vertical_dipole([0.0, 0.0, 1.0]))
    air = propagate([exciter], [sender, tag], [AntennaPort(a) for a in listener.antennas],
                    LinkTable(Channel(Scene())), t0_s=0.0, fs_hz=fs_hz, n_samples=4000, bandwidth_hz=2 * blf_hz)
    samples = air.inputs[0].samples
    heard = make_receiver(st_config, fs_hz=fs_hz, blf_hz=blf_hz, m=1, trext=False).receive(
        samples, n_bits=16, crc=False)
    decoded = "".join(map(str, heard.bits))
    print("passive tag replied:", air.reflections[1].gamma is not None)
    print("listener decoded:", decoded, "sent:", "".join(map(str, bits)))
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 3.2))
    t_us = np.arange(samples.size) / fs_hz * 1e6
    envelope_uv = np.abs(samples) * 1e6
    ax.plot(t_us, envelope_uv - np.median(envelope_uv))
    ax.set(xlabel="time [µs]", ylabel="|r| − median [µ√W]",
           title=f"listener's antenna port: decoded {decoded}")
    fig.tight_layout()
    path = args.out / "sense_a_tag_listening.png"
    fig.savefig(path, dpi=90)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()

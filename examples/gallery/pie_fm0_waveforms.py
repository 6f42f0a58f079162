"""PIE and FM0 waveforms of a Query → RN16 exchange (EPC Gen2 "Physical layer").

The reader's Query is PIE-encoded (data-0 = Tari, data-1 = 2 Tari, preamble with TRcal) on
the envelope of the carrier; the tag answers with an FM0 RN16 at BLF = DR/TRcal = 40 kHz.
Writes ``pie_fm0_waveforms.png``.
"""

from __future__ import annotations

import numpy as np

from rfsim.core.plots import pyplot
from rfsim.gen2.commands import Query, encode
from rfsim.gen2.link import profile
from rfsim.gen2.linecode import reply_waveform
from rfsim.gen2.pie import pie_envelope_for_profile

from _common import arguments


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    link = profile("fm0-40k")                      # Tari 25 µs, TRcal 200 µs, DR 8, FM0
    fs_hz = 2e6
    query = encode(Query(dr=link.dr, m=link.m, trext=link.trext, q=0))   # 22 bits with CRC-5
    envelope = np.asarray(pie_envelope_for_profile(query, link, fs_hz=fs_hz, cw_before_s=50e-6))
    rn16 = np.random.default_rng(1).integers(0, 2, 16, dtype=np.uint8)
    reply = reply_waveform(rn16, m=link.m, trext=link.trext, blf_hz=link.blf_hz, fs_hz=fs_hz)

    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5))
    a1.plot(np.arange(envelope.size) / fs_hz * 1e6, envelope)
    a1.set(title=f"reader: PIE Query ({query.size} bits)", xlabel="time [µs]", ylabel="envelope")
    a2.plot(np.arange(reply.size) / fs_hz * 1e6, reply, drawstyle="steps-post")
    a2.set(title=f"tag: FM0 RN16 {''.join(map(str, rn16))} at BLF {link.blf_hz / 1e3:.0f} kHz",
           xlabel="time [µs]", ylabel="modulation state")
    fig.tight_layout()
    path = args.out / "pie_fm0_waveforms.png"
    fig.savefig(path, dpi=90)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()

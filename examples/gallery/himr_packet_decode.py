"""An HIMR packet decoded from a noisy BOC waveform (HIMR dissertation Ch. IV).

A 9-axis HIMR packet (3 B header, 2 B tag id, accelerometer, gyroscope and compass words,
CRC-8; 192 bits) is BOC-coded (8 chips per bit at 4 Mchip/s), received with a complex gain
and white noise, decoded with the header as phase reference (:func:`rfsim.himr.boc.boc_decode`)
and parsed with its CRC (:func:`rfsim.himr.packet.parse_packets`) at several SNRs.
Writes ``himr_packet_decode.png``: bit errors and CRC per SNR, and the waveform at the lowest.
"""

from __future__ import annotations

import numpy as np

from rfsim.core.plots import pyplot
from rfsim.core.rng import trial_rng
from rfsim.himr.boc import boc_decode, boc_train
from rfsim.himr.packet import Framing, build_packets, packet_format, parse_packets

from _common import arguments


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    fmt, framing = packet_format("9axis-2d"), Framing()
    code = fmt.code()
    fs_hz = 4 * code.chip_rate_hz                        # 4 samples per chip
    rng = trial_rng(5, 0)
    words = rng.integers(-2000, 2000, (1, fmt.n_words))
    bits = build_packets(fmt, framing, tag_id=42, words=words)
    start_s = 20e-6
    n_samples = int((start_s + fmt.air_time_s + 20e-6) * fs_hz)
    clean = boc_train(np.array([start_s]), bits, code, t0_s=0.0, fs_hz=fs_hz, n_samples=n_samples)
    gain = 0.8 * np.exp(1j * 0.6)
    snrs_db = [-22.0, -14.0, -6.0] if args.small else [-24.0, -22.0, -20.0, -18.0, -16.0, -14.0, -10.0, -6.0]
    n_errors, crc_ok = [], []
    for k, snr_db in enumerate(snrs_db):
        sigma = abs(gain) * 10 ** (-snr_db / 20) / np.sqrt(2)
        noise = sigma * (trial_rng(5, 1, k).standard_normal(n_samples) + 1j * trial_rng(5, 2, k).standard_normal(n_samples))
        r = gain * clean + noise
        det = boc_decode(r, code=code, fs_hz=fs_hz, n_bits=fmt.n_bits, start_sample=start_s * fs_hz,
                         preamble_bits=bits[0, :24])
        parsed = parse_packets(fmt, framing, det.bits[None, :])
        n_errors.append(int(np.sum(det.bits != bits[0])))
        crc_ok.append(bool(parsed.crc_ok[0]))
        print(f"SNR {snr_db:5.1f} dB per sample: {n_errors[-1]:3d} bit errors, CRC ok {crc_ok[-1]}, "
              f"tag id {int(parsed.tag_id[0])}")
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5))
    a1.plot(np.arange(n_samples)[:800] / fs_hz * 1e6, (gain * clean + noise)[:800].real, lw=0.7)
    a1.set(xlabel="time [µs]", ylabel="Re r", title=f"received BOC waveform at {snrs_db[-1]:g} dB (start)")
    a2.plot(snrs_db, n_errors, "o-")
    for s, e, ok in zip(snrs_db, n_errors, crc_ok):
        a2.annotate("CRC ok" if ok else "CRC fail", (s, e), textcoords="offset points", xytext=(0, 6),
                    ha="center", fontsize=8)
    a2.set(xlabel="SNR per sample [dB]", ylabel=f"bit errors of {fmt.n_bits}")
    fig.tight_layout()
    path = args.out / "himr_packet_decode.png"
    fig.savefig(path, dpi=90)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()

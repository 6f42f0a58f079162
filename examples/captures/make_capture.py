"""Write a small synthetic reader capture to try ``rfsim decode`` on: Query → RN16, ACK → PC+EPC.

The capture is what a monostatic reader's receiver sees at baseband,
``x(t) = L·e(t) + h·e(t)·s(t) + n(t)``: ``e`` the reader's PIE envelope (Tari 12.5 µs,
modulation depth 0.9, rfsim.gen2.pie), ``L`` the carrier leakage, ``h`` the tag's backscatter
channel, ``s`` the tag's Miller-4 element sequence (rfsim.gen2.linecode, ±1 while it replies,
−1 otherwise) starting T1 = max(RTcal, 10/BLF) after the command, and ``n`` complex white noise.
Written as interleaved complex64 (``.cf32``, the GNU Radio file sink's format).

Usage: ``python examples/captures/make_capture.py [OUT.cf32] [--fs HZ]``, then
``rfsim decode OUT.cf32 --fs HZ`` prints two commands and two replies.
"""

import argparse

import numpy as np

from rfsim.gen2.commands import ACK, Query, command_preamble, encode
from rfsim.gen2.crc import append_crc16
from rfsim.gen2.linecode import halfsymbols
from rfsim.gen2.pie import pie_envelope, pie_timeline

TARI_S, BLF_HZ, M = 12.5e-6, 256e3, 4          # DR 64/3: TRcal = 64/3 / BLF
TRCAL_S, RTCAL_S = 64 / 3 / BLF_HZ, 3 * TARI_S
RN16 = 0xB5C3
PC_EPC = np.array([int(c) for c in f"{0x3000:016b}{0x300833B2DDD9014000000027:096b}"], np.uint8)


def command(cmd, fs_hz, cw_after_s):
    """PIE envelope of ``cmd`` and the time of its last rising edge [s]."""
    kw = dict(tari_s=TARI_S, data1_tari=2.0, pw_s=TARI_S / 2, delimiter_s=12.5e-6, preamble=command_preamble(cmd))
    trcal = TRCAL_S if kw["preamble"] == "query" else None
    env = pie_envelope(encode(cmd), trcal_s=trcal, depth=0.9, fs_hz=fs_hz, cw_after_s=cw_after_s, **kw)
    return env, float(pie_timeline(encode(cmd), trcal_s=trcal, **kw).rise_s[-1])


def capture(fs_hz: float, seed: int = 0) -> np.ndarray:
    rn16 = np.array([int(c) for c in f"{RN16:016b}"], np.uint8)
    lead = np.ones(int(300e-6 * fs_hz))
    parts, replies, n0 = [lead], [], lead.size
    for cmd, bits, cw_s in ((Query(dr="64/3", m=M, trext=False, q=0), rn16, 0.6e-3),
                            (ACK(rn16=RN16), append_crc16(PC_EPC), 2.5e-3)):
        env, end_s = command(cmd, fs_hz, cw_s)
        replies.append((n0 / fs_hz + end_s + max(RTCAL_S, 10 / BLF_HZ), halfsymbols(bits, m=M, trext=False)))
        parts.append(env)
        n0 += env.size
    e = np.concatenate(parts + [lead])
    t, s = np.arange(e.size) / fs_hz, -np.ones(e.size)
    for start_s, elements in replies:
        k = np.floor(2 * BLF_HZ * (t - start_s)).astype(np.int64)
        on = (k >= 0) & (k < elements.size)
        s[on] = elements[k[on]]
    rng = np.random.default_rng(seed)
    noise = 1e-3 * (rng.standard_normal(e.size) + 1j * rng.standard_normal(e.size)) / np.sqrt(2)
    return ((0.8 + 0.3j) * e + (0.02 - 0.03j) * e * s + noise).astype(np.complex64)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default="capture.cf32")
    ap.add_argument("--fs", type=float, default=2e6, help="sample rate [Hz] (default 2e6)")
    args = ap.parse_args()
    capture(args.fs).tofile(args.out)
    print(f"wrote {args.out}: Query/RN16 and ACK/EPC at {args.fs:g} S/s")

"""Trials of the reader's receiver on synthetic replies, for comparing the sample-level and
the statistic-level receiver models (tests/test_reader_statistic.py).

A trial: the noise-free input x = c + Σ_k h_k·level_k(t) at the RX port — the leakage c (a
constant 30 dB above the reply) and each tag's backscatter, its ±1 reply levels from
:func:`rfsim.gen2.linecode.reply_waveform` and −1 (its rest state) outside the reply — with the
first reply starting inside the T1 window at a random fractional sample. The sample-level
reader gets x plus complex white Gaussian noise of its ``noise_power_w()`` drawn here; the
statistic-level reader gets x and draws its own noise. The gain sets Eb/N0 = |h|²·(fs·M/BLF)/σ²
(samples per bit fs·M/BLF; tests/test_link_ber.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np

from rfsim.channels.antennas import vertical_dipole
from rfsim.devices.reader import Reader, ReaderConfig
from rfsim.gen2.crc import append_crc16
from rfsim.gen2.link import LinkProfile, profile, t1
from rfsim.gen2.linecode import reply_duration_s, reply_waveform

#: Payload bits of an EPC reply (PC + 96-bit EPC) before its CRC-16.
PAYLOAD_BITS = 112
#: Leakage amplitude relative to the first tag's |h|.
LEAKAGE_REL = 30.0
#: Phase of the first tag's gain [rad].
PHASE_RAD = 0.7


def miller8_link() -> LinkProfile:
    """A Miller-8 link: the miller4-320k profile with M = 8 (no named profile uses M = 8)."""
    return replace(profile("miller4-320k"), m=8)


LINKS = {1: lambda: profile("fm0-640k"), 2: lambda: profile("pass-miller2-48k"),
         4: lambda: profile("miller4-320k"), 8: miller8_link}
FS_HZ = {1: 4e6, 2: 1e6, 4: 4e6, 8: 4e6}


@dataclass(frozen=True)
class Outcome:
    """Per trial: detected, success (CRC ok), bit errors against the first tag, captured (the
    first tag's bits decoded with a correct CRC), RSSI [dBm] and phase [rad] (NaN if none)."""

    detected: np.ndarray
    success: np.ndarray
    bit_errors: np.ndarray
    captured: np.ndarray
    rssi_dbm: np.ndarray
    phase_rad: np.ndarray


def make_reader(m: int, rx_model: str, seed: int) -> Reader:
    cfg = ReaderConfig(link_profile="miller4-320k", fs_hz=FS_HZ[m], rx_model=rx_model, hopping=False)
    return Reader(cfg, [vertical_dipole((0.0, 0.0, 0.0))], rng=np.random.default_rng(seed), link=LINKS[m]())


def _setup(m: int, rx_model: str, seed: int, ebn0_db: float, n_bits: int):
    """(reader, generator, σ² [W], first tag's |h|, command end [s], samples per input) of a point."""
    reader = make_reader(m, rx_model, seed)
    rng = np.random.default_rng([seed, 7])
    lk, fs = reader.link, reader.fs_hz
    sigma2 = float(Reader(replace(reader.config, rx_model="sample"), reader.antennas, rng=np.random.default_rng(0),
                          link=lk).noise_power_w())
    amp = math.sqrt(10 ** (ebn0_db / 10) * sigma2 / (fs * lk.m / lk.blf_hz))
    win = t1(lk)
    cmd_end_s = (40 - win.min_s * fs) / fs  # the search starts ≈ 40 samples into the input
    n_reply = reply_duration_s(n_bits, m=lk.m, trext=lk.trext, blf_hz=lk.blf_hz) * fs
    n = int(math.ceil((cmd_end_s + win.max_s) * fs + n_reply)) + 60
    return reader, rng, sigma2, amp, cmd_end_s, n


def _input(reader, rng, amp: float, cmd_end_s: float, n: int, n_bits: int, second_db: float | None):
    """One trial's noise-free input x and the first tag's bits (module docstring)."""
    lk, fs = reader.link, reader.fs_hz
    win = t1(lk)
    bits = [append_crc16(rng.integers(0, 2, n_bits - 16, dtype=np.uint8)) for _ in range(2)]
    start_s = cmd_end_s + win.min_s + rng.uniform(0.25, 0.75) * (win.max_s - win.min_s)
    x = np.full(n, LEAKAGE_REL * amp * np.exp(1j * 2.1), dtype=np.complex128)
    tags = [(amp * np.exp(1j * PHASE_RAD), start_s)]
    if second_db is not None:
        tags.append((amp * 10 ** (-second_db / 20) * np.exp(1j * rng.uniform(0, 2 * math.pi)),
                     start_s + rng.uniform(-2.0, 2.0) / fs))
    for (h, t0), b in zip(tags, bits):
        s = reply_waveform(b, m=lk.m, trext=lk.trext, blf_hz=lk.blf_hz, fs_hz=fs, t0_s=t0, n_samples=n)
        x += h * np.where(s == 0.0, -1.0, s)
    return x, bits[0]


def inputs(m: int, n_trials: int, *, ebn0_db: float, seed: int, second_db: float | None = None,
           n_bits: int = PAYLOAD_BITS + 16) -> tuple[list, Reader, float]:
    """The noise-free inputs of ``n_trials`` trials as :func:`run` makes them, a statistic-level
    reader and the command end [s]."""
    reader, rng, _, amp, cmd_end_s, n = _setup(m, "statistic", seed, ebn0_db, n_bits)
    return [_input(reader, rng, amp, cmd_end_s, n, n_bits, second_db)[0] for _ in range(n_trials)], reader, cmd_end_s


def run(m: int, rx_model: str, n_trials: int, *, ebn0_db: float, seed: int, second_db: float | None = None,
        n_bits: int = PAYLOAD_BITS + 16) -> Outcome:
    """``n_trials`` trials (module docstring) at ``ebn0_db`` of the first tag; ``second_db``: a
    second tag second_db dB weaker replying within ±2 samples of the first (a collision)."""
    reader, rng, sigma2, amp, cmd_end_s, n = _setup(m, rx_model, seed, ebn0_db, n_bits)
    out = {k: np.zeros(n_trials, dtype=float) for k in Outcome.__dataclass_fields__}
    for t in range(n_trials):
        x, first = _input(reader, rng, amp, cmd_end_s, n, n_bits, second_db)
        if rx_model == "sample":
            x += math.sqrt(sigma2 / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
        res = reader.receive(x, t0_s=0.0, n_bits=n_bits, expect_crc=True, cmd_end_s=cmd_end_s)
        out["detected"][t] = res.bits is not None
        out["success"][t] = res.success
        out["bit_errors"][t] = np.count_nonzero(res.bits != first) if res.bits is not None else np.nan
        out["captured"][t] = res.success and np.array_equal(res.bits, first)
        out["rssi_dbm"][t] = res.rssi_dbm
        out["phase_rad"][t] = res.phase_rad
    return Outcome(**out)

"""The time-domain engine: event-driven between exchanges, sample-level inside them.

One *exchange* is a reader command followed by the CW during which tags may reply
(DESIGN.md "Simulation flow"):

1. the reader emits a segment: the PIE command and CW up to the end of the reply window
   (``reader.transmit``), in √W at its antenna port;
2. for every tag the channel gives the forward and backward links (PathSets); the incident
   field is the segment through the forward link (``apply_paths``, exact carrier phase);
3. each tag listens (``tag.listen``): power-up, envelope/PIE decoding with its own clock,
   Gen2 state machine, and — if it replies — a reflection coefficient Γ(t) on the same
   time base;
4. each tag re-radiates Γ(t)·incident(t) through its backward link; at the reader the
   backscatter of all tags superposes with the TX→RX leakage and thermal noise;
5. the reader decodes the reply window (``reader.receive``) and measures RSSI, phase,
   Doppler and SNR.

Propagation (``propagation="auto"``, the default): a link is applied narrowband — the
exact carrier phase exp(−j2π·fc·τ) and Doppler of every path, the envelope delays dropped —
when the relative RMS envelope error of doing so (:func:`narrowband_rms_error`: the
per-path Bernstein bound 2π·B·(τ − τ0), B = 2·BLF the main lobe of the FM0/Miller reply, τ0
the earliest delay, power-weighted over the paths) is at most :data:`NARROWBAND_TOLERANCE`;
otherwise every path gets its exact fractional delay. The common delay τ0 (time of flight, 3.3 ns/m) is then dropped from the
envelope only — it shifts the reply by tens of ns, far below the T1 tolerance, and has no
effect on RSSI, phase and Doppler, which keep the exact carrier phase of every path. (The fractional-delay interpolator also rings on the hard-switched FM0/Miller
edges — an artefact of sampling a non-band-limited reply, seen as a false SNR ceiling —
which the narrowband path avoids.)

Between exchanges nothing is sampled: time advances by the link timing (T2 before the next
command, T4 between commands without a reply), so silent air time costs nothing.

The engine only sees devices and the channel through these methods; it imports the channel
toolbox (``channels.paths``) lazily, so the core never depends on it at import time.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

#: Failure reasons of a read, in the order the engine checks them.
FAILURE_REASONS = ("", "not powered", "no reply", "collision", "preamble not found", "crc error",
                   "timing violation", "decode error")


@dataclasses.dataclass(frozen=True)
class Exchange:
    """Record of one reader command and what came back.

    Attributes
    ----------
    time_s : start of the reader's segment [s] (CW lead-in, then the command)
    command : command name (``"Query"``, ``"ACK"``, …)
    antenna : reader antenna index (0-based)
    channel_index : 1-based index into the reader's frequency plan (as LLRP reports it)
    fc_hz : carrier frequency [Hz]
    replied : indices of the tags that replied
    powered : indices of the tags that were powered
    incident_power_dbm : (n_tags,) incident power at each tag's antenna port [dBm]
    read : the reader's :class:`ReadResult`-like measurement, or None when nobody replied
    failure_reason : one of :data:`FAILURE_REASONS` (``""`` = decoded)
    end_s : end of the reply window [s]
    """

    time_s: float
    command: str
    antenna: int
    channel_index: int
    fc_hz: float
    replied: tuple[int, ...]
    powered: tuple[int, ...]
    incident_power_dbm: tuple[float, ...]
    read: Any
    failure_reason: str
    end_s: float

    @property
    def success(self) -> bool:
        return self.failure_reason == ""


PROPAGATION_METHODS = ("auto", "exact", "narrowband")
#: Relative envelope-error bound below which "auto" propagation is narrowband.
NARROWBAND_TOLERANCE = 0.1


def narrowband_rms_error(paths, bandwidth_hz: float) -> float:
    """Relative RMS envelope error of dropping the envelope delays of ``paths``.

    √(Σ|g|²·(2π·B·(τ − τ0))²) / √(Σ|g|²), τ0 the earliest delay: the Bernstein bound
    2π·B·τ on each path's envelope change, added in power (the paths' carrier phases are
    independent — diffuse taps, reflections at different lengths).
    """
    p = np.abs(paths.gain) ** 2
    total = float(np.sum(p))
    if total == 0.0:
        return 0.0
    rel = 2.0 * np.pi * bandwidth_hz * (paths.delay_s - np.min(paths.delay_s))
    return float(np.sqrt(np.sum(p * rel**2) / total))


def _method(paths, bandwidth_hz: float, propagation: str) -> str:
    if propagation != "auto":
        return propagation
    ok = paths.n_paths == 0 or narrowband_rms_error(paths, bandwidth_hz) <= NARROWBAND_TOLERANCE
    return "narrowband" if ok else "exact"


def _failure(read, replied: Sequence[int], powered: Sequence[int]) -> str:
    if not powered:
        return "not powered"
    if not replied:
        return "no reply"
    if read is not None and read.success:
        return ""
    reason = read.failure_reason if read is not None else "preamble not found"
    if len(replied) > 1 and reason in ("preamble not found", "crc error"):
        return "collision"
    return reason


def run_exchange(reader, tags: Sequence, channel, cmd, *, t_s: float, rng: np.random.Generator,
                 reply_bits: int, expect_crc: bool, motions: Sequence | None = None,
                 round_index: int = 0, draw_channel: bool = True,
                 propagation: str = "auto") -> Exchange:
    """Simulate one command + reply window at sample level; return its :class:`Exchange`.

    Parameters
    ----------
    reader : reader device (``transmit``, ``receive``, ``leakage_gain``, ``noise_power_w``,
        ``antennas``, ``antenna_index``, ``link``)
    tags : tag devices (``listen``, ``antenna``)
    channel : link model with ``backscatter_links(emitter, tag, *, fc_hz, rng, t_s,
        tag_motion)`` → (forward, backward) PathSets
    cmd : the Gen2 command object to send
    t_s : start time of the command [s]
    rng : generator for the channel draw and the receiver noise
    reply_bits : number of bits of the expected reply (16 for RN16, PC+EPC+CRC otherwise)
    expect_crc : whether the reply carries a CRC-16 (EPC replies)
    motions : optional per-tag motion (velocity (3,) m/s or callable t → position)
    round_index : which inventory round (selects the antenna when several are used in turn)
    draw_channel : draw the channel's random part anew from ``rng`` (otherwise reuse the
        draw the channel holds: a quasi-static channel within a round)
    propagation : "auto", "exact" or "narrowband" (see the module docstring)
    """
    if propagation not in PROPAGATION_METHODS:
        raise ValueError(f"propagation must be one of {PROPAGATION_METHODS}, got {propagation!r}")
    from channels.paths import apply_paths

    antenna_index = reader.antenna_index(round_index)
    antenna = reader.antennas[antenna_index]
    link = reader.link
    window_s = (link.reply_duration_s(reply_bits) + _t1_max_s(link) + 3.0 * link.tpri_s)
    tx = reader.transmit(cmd, t0_s=t_s, cw_after_s=window_s, round_index=round_index)
    fs, fc = tx.fs_hz, tx.fc_hz
    rx = reader.leakage_gain() * tx.samples
    replied, powered, incident_dbm = [], [], []
    for i, tag in enumerate(tags):
        motion = motions[i] if motions is not None else None
        fwd, bwd = channel.backscatter_links(antenna, tag.antenna, fc_hz=fc,
                                             rng=rng if draw_channel else None, t_s=t_s,
                                             tag_motion=motion)
        incident = apply_paths(tx.samples, fs_hz=fs, fc_hz=fc, paths=fwd, t0_s=t_s,
                               method=_method(fwd, 2.0 * link.blf_hz, propagation))
        response = tag.listen(incident, t0_s=t_s, fs_hz=fs)
        incident_dbm.append(float(response.incident_power_dbm))
        if response.powered:
            powered.append(i)
        if response.gamma is not None:
            replied.append(i)
        if response.gamma is not None or response.gamma_rest != 0:
            # Every tag scatters: its rest state Γ_A throughout, Γ(t) while it replies.
            scattered = response.reflection(incident.size) * incident
            rx = rx + apply_paths(scattered, fs_hz=fs, fc_hz=fc, paths=bwd, t0_s=t_s,
                                  method=_method(bwd, 2.0 * link.blf_hz, propagation))
    noise_w = reader.noise_power_w()
    if noise_w > 0:
        scale = math.sqrt(noise_w / 2.0)
        rx = rx + scale * (rng.standard_normal(rx.size) + 1j * rng.standard_normal(rx.size))
    read = None
    if replied:
        # The receiver listens from half a Tari after its own command's last edge (the edge
        # and the channel's delay spread have settled) and searches the reply in the T1
        # window; it is given no knowledge of the tags (BLF: the profile's nominal value).
        i0 = int(math.ceil((tx.cmd_end_s + 0.5 * link.tari_s - t_s) * fs))
        read = reader.receive(rx[i0:], t0_s=t_s + i0 / fs, n_bits=reply_bits,
                              expect_crc=expect_crc, cmd_end_s=tx.cmd_end_s)
    return Exchange(time_s=t_s, command=type(cmd).__name__, antenna=antenna_index,
                    channel_index=tx.channel_index, fc_hz=fc, replied=tuple(replied),
                    powered=tuple(powered), incident_power_dbm=tuple(incident_dbm), read=read,
                    failure_reason=_failure(read, replied, powered),
                    end_s=t_s + tx.samples.size / fs)


def _t1_max_s(link) -> float:
    from rfsim.gen2.link import t1

    return t1(link).max_s


def singulate(reader, tags: Sequence, channel, *, t_s: float, rng: np.random.Generator,
              query, round_index: int = 0, motions: Sequence | None = None,
              epc_bits: int = 128, draw_channel: bool = True) -> list[Exchange]:
    """Query → RN16 → ACK → PC+EPC+CRC: one inventory round of a Q = 0 Query.

    Returns the exchanges (one or two). The ACK is sent only when the RN16 was decoded; it
    starts T2 (10 Tpri, inside the 3–20 Tpri window) after the RN16 reply ends. The channel
    is drawn (when ``draw_channel``) for the Query and held for the ACK.
    """
    from rfsim.gen2.bits import bits_to_int
    from rfsim.gen2.commands import ACK

    first = run_exchange(reader, tags, channel, query, t_s=t_s, rng=rng, reply_bits=16,
                         expect_crc=False, motions=motions, round_index=round_index,
                         draw_channel=draw_channel)
    if not first.success:
        return [first]
    rn16 = bits_to_int(first.read.bits)
    t_ack = first.read.start_s + reader.link.reply_duration_s(16) + 10.0 * reader.link.tpri_s
    second = run_exchange(reader, tags, channel, ACK(rn16), t_s=t_ack, rng=rng,
                          reply_bits=epc_bits, expect_crc=True, motions=motions,
                          round_index=round_index, draw_channel=False)
    return [first, second]


__all__ = ["Exchange", "FAILURE_REASONS", "PROPAGATION_METHODS", "NARROWBAND_TOLERANCE",
           "narrowband_rms_error", "run_exchange", "singulate"]

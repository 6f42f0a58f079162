"""Per-packet receiver DSP of a HIMR pylon on its complex baseband input: find each packet,
decode the BOC chips, check the CRC, estimate the complex gain, and turn it into RSS, phase,
radial velocity and RSS range (wave2-specs.md §H "Per-packet DSP"; himr-tag.md §2.4, §7 P0.6).

For each expected packet start (the tag's nominal schedule; the tag is free-running, so the
start is searched in ±``search_s`` around it by preamble correlation,
:func:`rfsim.himr.boc.boc_find`):

1. BOC decode at the found start (:func:`rfsim.himr.boc.boc_decode`): bits, least-squares complex
   gain h of the modulated part against the decided chips, offset c (leakage and the static
   echo), σ², SNR;
2. CRC and fields (:func:`rfsim.himr.packet.parse_packets`): a packet that fails its CRC
   keeps its RF reading in the table but is flagged (``crc_ok``); its IMU words are unusable;
3. RSS = |h|² (the modulated backscatter power, W, as the input is in √W), ``rss_dbm``;
4. φ = −arg h, Δφ = wrap(φ_k − φ_{k−1}) between consecutive packets, radial velocity
   ṙ = λ·Δφ/(4π·Δt) with Δt the difference of the found starts (eq. 23,
   :func:`rfsim.himr.link.radial_velocity_mps`), the per-packet aliasing limit λ/(4·Δt)
   and, given the true radial velocity, the ``aliased`` flag where |ṙ_true| reaches it;
5. range r = (K_u/|h|²)^¼ (eq. 22, :func:`rfsim.himr.link.rss_range_m`) when K_u is given.

The measured phase is that of the modulated part only: with re-radiation r = A_s − Γ(t)
the chips enter with a minus sign, a constant π that cancels in Δφ.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.himr.boc import BocCode, boc_decode, boc_find
from rfsim.himr.link import aliasing_limit_mps, radial_velocity_mps, rss_range_m, wrap_pi
from rfsim.himr.packet import Framing, PacketFormat, parse_packets


@dataclass(frozen=True, eq=False)
class PacketMeasurements:
    """Columns of one pylon's packet table (P rows; NaN where undefined)."""

    start_s: np.ndarray             #: found packet start [s]
    crc_ok: np.ndarray              #: bool
    words: np.ndarray               #: (P, n_words) int16, valid where crc_ok
    gain: np.ndarray                #: complex h [√W]
    snr_db: np.ndarray              #: per-sample SNR of the modulated part [dB]
    rss_dbm: np.ndarray             #: 10·log10(|h|²) + 30 [dBm]
    phase_rad: np.ndarray           #: −arg h [rad]
    dphase_rad: np.ndarray          #: wrap(φ_k − φ_{k−1}) [rad] (NaN for the first)
    radial_velocity_mps: np.ndarray  #: eq. 23 [m/s] (NaN for the first)
    aliasing_limit_mps: np.ndarray  #: λ/(4·Δt) [m/s] (NaN for the first)
    aliased: np.ndarray             #: bool, |true ṙ| ≥ the limit (False without ground truth)
    range_m: np.ndarray             #: eq. 22 [m] (NaN without K_u)


@dataclass(frozen=True, eq=False)
class PacketDecode:
    """One packet decoded at one pylon (:func:`decode_packet`)."""

    start_s: float       #: found start [s]
    bits: np.ndarray     #: (n_bits,) uint8 decided bits
    gain: complex        #: least-squares complex gain h of the modulated part [√W]
    snr_db: float        #: per-sample SNR |h|²/σ² [dB]
    rho: float           #: normalised preamble correlation at the found start


def decode_packet(r, *, t0_s: float, fs_hz: float, fmt: PacketFormat, framing: Framing, code: BocCode,
                  expected_start_s: float, search_s: float = 2e-6) -> PacketDecode | None:
    """Step 1 of the module docstring for one packet.

    Search the start in ±``search_s`` around ``expected_start_s`` by preamble correlation,
    then BOC-decode there.

    Parameters
    ----------
    r : array_like
        ``(n,)`` complex baseband [√W] on the time base t = t0_s + n/fs_hz.
    t0_s : float
        Time of sample 0 [s].
    fs_hz : float
        Sample rate [Hz].
    fmt : PacketFormat
        The packet format.
    framing : Framing
        The framing (its preamble is the correlation reference).
    code : BocCode
        The line code.
    expected_start_s : float
        Nominal packet start [s].
    search_s : float
        Half-width of the start search [s].

    Returns
    -------
    PacketDecode or None
        The decoded packet; None when the packet (with its search window) is not wholly
        inside ``r``.
    """
    fs = code.check_fs(fs_hz)
    n_air = int(np.ceil(code.duration_s(fmt.n_bits) * fs))
    half = int(np.ceil(search_s * fs))
    s0 = (float(expected_start_s) - t0_s) * fs
    lo, hi = int(np.floor(s0)) - half, int(np.floor(s0)) + half + 1
    if lo < 0 or hi + n_air > np.size(r):
        return None
    pre = framing.preamble_bits
    found, rho = boc_find(r, code=code, fs_hz=fs, preamble_bits=pre, search=(lo, hi))
    det = boc_decode(r, code=code, fs_hz=fs, n_bits=fmt.n_bits, start_sample=float(found), preamble_bits=pre)
    return PacketDecode(start_s=t0_s + found / fs, bits=det.bits, gain=det.gain, snr_db=det.snr_db, rho=rho)


def packet_table(decoded, *, fc_hz: float, fmt: PacketFormat, framing: Framing, k_u: float | None = None,
                 true_radial_velocity_mps=None) -> PacketMeasurements:
    """Steps 2–5 of the module docstring over a pylon's consecutive decoded packets.

    Parameters
    ----------
    decoded : sequence of PacketDecode
        In time order.
    fc_hz : float
        The pylon's carrier (for λ) [Hz].
    fmt : PacketFormat
        The packet format.
    framing : Framing
        The framing (CRC, word order).
    k_u : float or None
        RSS-range constant K_u [W·m⁴] (None: no range).
    true_radial_velocity_mps : array_like or None
        ``(P,)`` ground-truth mean radial velocity over each packet interval,
        (r_k − r_{k−1})/Δt [m/s] (None: ``aliased`` all False); a packet is ``aliased`` where
        its magnitude reaches the limit λ/(4·Δt) — the wrapped Δφ then no longer tells the
        true velocity.

    Returns
    -------
    PacketMeasurements
        The pylon's packet table.
    """
    start = np.array([d.start_s for d in decoded], dtype=float)
    gain = np.array([d.gain for d in decoded], dtype=np.complex128)
    bits = np.array([d.bits for d in decoded], dtype=np.uint8).reshape(len(decoded), fmt.n_bits)
    parsed = parse_packets(fmt, framing, bits)
    phase = -np.angle(gain)
    dt = np.full(start.size, np.nan)
    dt[1:] = np.diff(start)
    dphi = np.full(start.size, np.nan)
    dphi[1:] = wrap_pi(np.diff(phase))
    power = np.abs(gain) ** 2
    limit = aliasing_limit_mps(fc_hz=fc_hz, packet_rate_hz=1.0 / dt)
    if true_radial_velocity_mps is None:
        aliased = np.zeros(start.size, bool)
    else:
        v = np.asarray(true_radial_velocity_mps, float)
        aliased = np.abs(np.nan_to_num(v)) >= np.nan_to_num(limit, nan=np.inf)
    return PacketMeasurements(
        start_s=start, crc_ok=parsed.crc_ok, words=parsed.words, gain=gain,
        snr_db=np.array([d.snr_db for d in decoded], dtype=float),
        rss_dbm=10 * np.log10(power) + 30, phase_rad=phase, dphase_rad=dphi,
        radial_velocity_mps=radial_velocity_mps(dphi, fc_hz=fc_hz, dt_s=dt),
        aliasing_limit_mps=limit, aliased=aliased,
        range_m=rss_range_m(power, k_u) if k_u is not None else np.full(start.size, np.nan))


def measure_packets(r, *, t0_s: float, fs_hz: float, fc_hz: float, fmt: PacketFormat, framing: Framing,
                    code: BocCode, expected_starts_s, search_s: float = 2e-6,
                    k_u: float | None = None) -> PacketMeasurements:
    """Per-packet measurements of a pylon's baseband input (module docstring).

    Parameters
    ----------
    r : array_like
        ``(n,)`` complex baseband [√W] on the time base t = t0_s + n/fs_hz.
    t0_s : float
        Time of sample 0 [s].
    fs_hz : float
        Sample rate [Hz].
    fc_hz : float
        The pylon's carrier (for λ) [Hz].
    fmt, framing, code : PacketFormat, Framing, BocCode
        The tag's packet format, framing and line code.
    expected_starts_s : array_like
        ``(P,)`` nominal packet starts [s]; packets not wholly inside ``r`` are skipped.
    search_s : float
        Half-width of the start search [s].
    k_u : float or None
        RSS-range constant K_u [W·m⁴] (None: no range).

    Returns
    -------
    PacketMeasurements
        The pylon's packet table.
    """
    r = np.asarray(r, dtype=np.complex128)
    found = [decode_packet(r, t0_s=t0_s, fs_hz=fs_hz, fmt=fmt, framing=framing, code=code, expected_start_s=t,
                           search_s=search_s) for t in np.asarray(expected_starts_s, dtype=float)]
    return packet_table([d for d in found if d is not None], fc_hz=fc_hz, fmt=fmt, framing=framing, k_u=k_u)


__all__ = ["PacketMeasurements", "PacketDecode", "decode_packet", "packet_table", "measure_packets"]

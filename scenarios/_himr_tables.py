"""Tables and figures shared by the HIMR scenarios (``himr-1d``, ``himr-2d``): the per-packet
table of every pylon, the decoded IMU words, the errors of an estimate, and the RSS/phase
figure. The measurements follow wave2-specs.md §H "Datasets"."""

from __future__ import annotations

import numpy as np

from rfsim.devices.imu import WORD_NAMES, heading_from_compass, words_to_si
from rfsim.core.dataset import column
from rfsim.core.units import wavelength_m

PACKET_BITS_NOTE = (
    "packet size from the source's byte counts: the 9axis-2d packet is 3 B header + 2 B ID + 6 B accel + 6 B gyro + "
    "6 B compass + 1 B CRC = 24 B = 192 bit (seed 000 Table 5, L715-L720; 'three-bytes header, two-bytes ID, "
    "18-bytes inertial data, single-byte CRC'), air time 192 x 8 / 4 Mcps = 0.384 ms; the reference pages' "
    "'30 bytes = 240 bit, 0.48 ms' does not follow from those byte counts")


def packets_table(run, plan) -> dict:
    """One row per (packet, pylon) decoded (:class:`rfsim.scenarios._himr_air.AirRun`)."""
    cols: dict[str, list] = {}
    for u, (p, m) in enumerate(zip(run.pylons, run.measurements)):
        idx = run.packet_index[u]
        r_true = run.true_range_m[u]
        v_true = np.full(idx.size, np.nan)
        v_true[1:] = np.diff(r_true) / np.diff(plan.start_s[idx])
        part = {
            "t_s": m.start_s, "packet": idx, "pylon": np.full(idx.size, u + 1),
            "carrier_hz": np.full(idx.size, p.fc_hz),
            "crc_ok": m.crc_ok, "h_re": m.gain.real, "h_im": m.gain.imag, "rss_dbm": m.rss_dbm, "snr_db": m.snr_db,
            "phase_rad": m.phase_rad, "dphase_rad": m.dphase_rad, "range_rss_m": m.range_m,
            "radial_velocity_mps": m.radial_velocity_mps, "aliasing_limit_mps": m.aliasing_limit_mps,
            "aliased": m.aliased, "true_range_m": r_true, "true_radial_velocity_mps": v_true,
            "true_start_s": plan.start_s[idx]}
        for k, v in part.items():
            cols.setdefault(k, []).append(np.asarray(v))
    return {k: np.concatenate(v) for k, v in cols.items()}


PACKET_COLUMNS = {
    "t_s": ("s", "packet start found by the pylon's preamble correlation (shared clock)"),
    "packet": ("1", "index of the packet in the tag's schedule (its sequence number, from 0)"),
    "pylon": ("1", "pylon (receiver) number 1..N, Table 7 order"),
    "carrier_hz": ("Hz", "carrier of the pylon that measured the packet"),
    "crc_ok": ("1", "the decoded packet passed its CRC-8 (else its IMU words and RF reading are not used)"),
    "h_re": ("sqrt(W)", "real part of the least-squares complex gain h of the modulated backscatter"),
    "h_im": ("sqrt(W)", "imaginary part of the least-squares complex gain h of the modulated backscatter"),
    "rss_dbm": ("dBm", "received signal strength of the modulated part, 10 log10(|h|^2) + 30"),
    "snr_db": ("dB", "per-sample SNR |h|^2 / residual noise power of the packet fit"),
    "phase_rad": ("rad", "phase phi = -arg h of the packet (eq. 1 convention: grows as the tag recedes)"),
    "dphase_rad": ("rad", "wrapped phase difference to the pylon's previous packet (NaN for its first)"),
    "range_rss_m": ("m", "RSS range (K_u/|h|^2)^(1/4), eq. 22 (NaN without K_u)"),
    "radial_velocity_mps": ("m/s", "lambda wrap(dphi) / (4 pi dt), eq. 23, positive receding (NaN for the first)"),
    "aliasing_limit_mps": ("m/s", "largest unambiguous radial speed lambda / (4 dt) for this packet interval"),
    "aliased": ("1", "the true mean radial speed over the interval reaches the aliasing limit (wrapped value wrong)"),
    "true_range_m": ("m", "ground truth: distance pylon - tag at the middle of the packet"),
    "true_radial_velocity_mps": ("m/s", "ground truth: mean radial velocity over the packet interval"),
    "true_start_s": ("s", "ground truth: start of the packet in the tag's schedule"),
}


def imu_table(run, plan, imu_cfg, *, heading_start_rad: float) -> dict:
    """One row per packet: the IMU words from the first pylon whose copy passed its CRC."""
    n = plan.start_s.size
    n_words = plan.words.shape[1]
    words = np.zeros((n, n_words), dtype=np.int16)
    by = np.zeros(n, dtype=np.int64)
    for u in range(len(run.pylons) - 1, -1, -1):  # the first pylon wins
        m, idx = run.measurements[u], run.packet_index[u]
        ok = m.crc_ok
        words[idx[ok]] = m.words[ok]
        by[idx[ok]] = u + 1
    valid = by > 0
    si = words_to_si(words, imu_cfg).astype(float)
    si[~valid] = np.nan
    out = {"t_s": plan.start_s, "packet": np.arange(n), "decoded_by": by, "valid": valid}
    names = WORD_NAMES[:n_words]
    for j, name in enumerate(names):
        out[f"{name}_raw"] = words[:, j]
    for j, name in enumerate(names):
        out[name] = si[:, j]
    if n_words == 9:
        head = np.full(n, np.nan)
        if valid.any():
            h = np.unwrap(heading_from_compass(si[valid, 6], si[valid, 7], imu_cfg.declination_rad))
            head[valid] = h + 2 * np.pi * np.round((heading_start_rad - h[0]) / (2 * np.pi))
        out["heading_rad"] = head
    return out


_IMU_UNITS = {"accel": ("m/s^2", "accelerometer specific force along body axis"),
              "gyro": ("rad/s", "gyroscope rate about body axis"),
              "compass": ("uT", "magnetometer field along body axis")}


def imu_columns(table: dict) -> dict:
    cols = {"t_s": column(table["t_s"], "s", "scheduled start of the packet that carried the IMU sample"),
            "packet": column(table["packet"], "1", "index of the packet in the tag's schedule"),
            "decoded_by": column(table["decoded_by"], "1",
                                 "pylon whose copy passed the CRC first (0: none, sample lost)"),
            "valid": column(table["valid"], "1", "some pylon decoded the packet with a good CRC (else NaN readings)")}
    for k, v in table.items():
        if k in cols:
            continue
        if k == "heading_rad":
            cols[k] = column(v, "rad",
                             "heading of the body y axis from the compass x, y words, unwrapped, start pose pi")
            continue
        sensor, axis = k.split("_")[0], k.split("_")[1]
        unit, text = _IMU_UNITS[sensor]
        if k.endswith("_raw"):
            cols[k] = column(v, "1", f"raw int16 word of the {sensor} {axis} axis as decoded from the packet")
        else:
            cols[k] = column(v, unit, f"{text} {axis} from the int16 word (NaN when the packet was lost)")
    return cols


def errors(est_xy, true_xy) -> np.ndarray:
    """Euclidean position error per epoch [m] (n,)."""
    d = np.atleast_2d(np.asarray(est_xy, float) - np.asarray(true_xy, float))
    return np.hypot(d[:, 0], d[:, 1]) if d.shape[1] == 2 else np.abs(d[:, 0])


def wrap_periods(t_s, n_pylons: int, fc_hz) -> np.ndarray:
    """(n, N) period λ_u/(2·Δt_k) of the phase-derived radial velocities at the epochs."""
    t = np.asarray(t_s, float)
    dt = np.append(np.diff(t[:2]), np.diff(t))
    lam = wavelength_m(np.asarray(fc_hz, float))
    return lam[None, :] / (2.0 * dt[:, None]) * np.ones((t.size, n_pylons))


def plot_rss_phase(plt, packets: dict, title: str):
    """RSS and phase per pylon vs time."""
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for u in np.unique(packets["pylon"]):
        s = packets["pylon"] == u
        f = packets["carrier_hz"][s][0] / 1e9
        a1.plot(packets["t_s"][s], packets["rss_dbm"][s], ".-", ms=2, lw=0.6, label=f"pylon {u} ({f:.2f} GHz)")
        a2.plot(packets["t_s"][s], packets["phase_rad"][s], ".", ms=2, label=f"pylon {u}")
        al = s & (packets["aliased"] > 0)
        a2.plot(packets["t_s"][al], packets["phase_rad"][al], "kx", ms=3)
    a1.set(ylabel="RSS of the modulated part [dBm]", title=title)
    a2.set(xlabel="time [s]", ylabel="phase -arg h [rad] (x: aliased interval)")
    a1.legend(fontsize=7)
    return fig


__all__ = ["PACKET_BITS_NOTE", "packets_table", "PACKET_COLUMNS", "imu_table", "imu_columns", "errors",
           "wrap_periods", "plot_rss_phase"]

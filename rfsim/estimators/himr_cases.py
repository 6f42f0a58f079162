"""The seven analysis cases of the 2-D HIMR study as post-processing of a recorded
measurement stream (himr-tag.md §3.5, §4.3, §5; seed 000 L1050–L1072, L1243–L1404).

As in the source, link breakage ("submarining") is emulated on recorded data: every sensed
quantity is corrupted over the outage window, 0.39–0.75 s (360 ms ≈ 50 packets at
141 packets/s, L1243). The cases:

1. all measurements;
2. the last value before the outage is repeated through it (L1243–L1261);
3. the gain is switched off during the outage, dx̂/dt = A·x̂ (eq. 52, L1056–L1060);
4. the measurements are linearly interpolated between the last value before and the first
   after the outage (offline reconstruction, L1064–L1066);
5. inertial replay: the IMU outputs are kept (stored on the tag and replayed), the RF
   outputs repeat their last value (L1068);
6. every other packet (70.5 packets/s, L1069, L1354);
7. pylons 1 and 2 only (rows of pylon 3 removed; the gain is re-solved with V = I₈,
   L1070, L1392, L2019).

A measurement is inside the outage when t ∈ [t_start, t_end); the held/interpolation
anchors are the last epoch before t_start and the first at or after t_end.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rfsim.core.units import wavelength_m
from rfsim.estimators.observer import observe_2d, range_gate

CASES = {
    1: "all measurements",
    2: "repeat the last value during the outage",
    3: "gain off (open loop) during the outage",
    4: "offline linear interpolation over the outage",
    5: "inertial replay, RF held during the outage",
    6: "every other packet",
    7: "pylons 1 and 2 only",
}
OUTAGE_S = (0.39, 0.75)
#: Max errors the source prints per case (x, y) [m], L1176-L1404 (NaN: not printed).
SOURCE_MAX_ERROR_M = {1: (0.10, np.nan), 2: (np.nan, 0.5), 3: (0.16, 0.30), 4: (0.10, 0.05),
                      5: (np.nan, np.nan), 6: (0.13, 0.08), 7: (0.135, 0.10)}
#: Convergence times the source states (L1176-L1404) [s].
SOURCE_CONVERGENCE_S = {1: 0.8, 2: np.nan, 3: np.nan, 4: np.nan, 5: np.nan, 6: 1.2, 7: 1.1}


@dataclass(frozen=True, eq=False)
class CaseStream:
    """A measurement stream prepared for one case.

    Attributes
    ----------
    case : 1…7
    t_s : (n,) epochs;  y : (n, p) outputs in observer order
    gain_on : (n,) bool (False inside the Case-3 outage)
    pylons : indices of the pylons whose outputs ``y`` holds
    """

    case: int
    t_s: np.ndarray
    y: np.ndarray
    gain_on: np.ndarray
    pylons: tuple[int, ...]


def case_stream(case: int, t_s, y, *, n_pylons: int = 3, outage_s=OUTAGE_S) -> CaseStream:
    """Apply case ``case`` (module docstring) to a recorded stream.

    Parameters
    ----------
    case : int
        Case 1…7.
    t_s : array_like
        ``(n,)`` epochs [s].
    y : array_like
        ``(n, 2·n_pylons + 4)`` outputs in observer order (units of
        :func:`rfsim.estimators.himr_model.h_2d`).
    n_pylons : int
        Number of pylons P.
    outage_s : tuple of float
        Outage window ``(t_start, t_end)`` [s].

    Returns
    -------
    CaseStream
        The stream prepared for the case (Case 6: every other epoch; Case 7: pylons 1, 2).

    Raises
    ------
    ValueError
        For an unknown case, a ``y`` of the wrong shape, an outage that starts before the first
        measurement, or Case 4 without a measurement after the outage.
    """
    if case not in CASES:
        raise ValueError(f"case must be one of {sorted(CASES)}, got {case!r}")
    t = np.asarray(t_s, float)
    y = np.array(y, dtype=float, copy=True)
    if y.shape != (t.size, 2 * n_pylons + 4):
        raise ValueError(f"y must be ({t.size}, {2 * n_pylons + 4}), got {y.shape}")
    on = np.ones(t.size, bool)
    pylons = tuple(range(n_pylons))
    inside = (t >= outage_s[0]) & (t < outage_s[1])
    if case in (2, 3, 4, 5) and inside.any():
        before = np.nonzero(t < outage_s[0])[0]
        after = np.nonzero(t >= outage_s[1])[0]
        if before.size == 0:
            raise ValueError("the outage starts before the first measurement")
        i0 = before[-1]
        rf = slice(0, 2 * n_pylons)
        if case == 2:
            y[inside] = y[i0]
        elif case == 3:
            on[inside] = False
        elif case == 5:
            y[inside, rf] = y[i0, rf]
        else:
            if after.size == 0:
                raise ValueError("case 4 needs a measurement after the outage")
            i1 = after[0]
            w = ((t[inside] - t[i0]) / (t[i1] - t[i0]))[:, None]
            y[inside] = (1 - w) * y[i0] + w * y[i1]
    if case == 6:
        t, y, on = t[::2], y[::2], on[::2]
    if case == 7:
        pylons = (0, 1)
        keep = [0, 1, 2, 3] + list(range(2 * n_pylons, 2 * n_pylons + 4))
        y = y[:, keep]
    return CaseStream(case=case, t_s=t, y=y, gain_on=on, pylons=pylons)


# ----------------------------------------------------------------------------- the recorded stream


def measurement_stream(run, plan, imu: dict, *, every: int = 1) -> dict:
    """The recorded stream of the 2-D observer from what the pylons measured.

    Per epoch (every ``every``-th scheduled packet) the outputs in observer order
    [r₁ ṙ₁ … r_P ṙ_P, a₁, a₂, θ_z, ω_z] with NaN where not measured: each pylon's RSS range where
    its copy passed the CRC, the radial velocity λ·wrap(Δφ)/(4π·Δt) from the phases of the kept
    packets (eq. 23), a₁ = the accelerometer's y^B reading, a₂ = minus its x^B reading, the
    compass heading and the gyroscope z rate.

    Parameters
    ----------
    run : the pylons' measurements (``rfsim.scenes.himr_air.AirRun``: ``pylons[u].fc_hz``,
        ``measurements[u]``, ``packet_index[u]``, ``true_range_m[u]``)
    plan : the tag's schedule (``start_s`` (n,) [s])
    imu : the decoded IMU words per scheduled packet (``accel_x``, ``accel_y``, ``heading_rad``,
        ``gyro_z``, SI units)
    every : keep every ``every``-th packet (Case 6: 2)

    Returns
    -------
    dict with ``t_s`` (m,) [s], ``packet`` (m,), ``y`` (m, 2P + 4) and ``rdot_oracle`` (m, P): the
    alias of each radial velocity nearest the true mean radial velocity (ground truth) [m/s]
    """
    keep = np.arange(0, plan.start_s.size, every)
    t = plan.start_s[keep]
    n_p = len(run.pylons)
    y = np.full((t.size, 2 * n_p + 4), np.nan)
    oracle = np.full((t.size, n_p), np.nan)
    for u, (p, m) in enumerate(zip(run.pylons, run.measurements)):
        idx = run.packet_index[u]
        pos = np.full(plan.start_s.size, -1)
        pos[idx] = np.arange(idx.size)
        rows = pos[keep]
        ok = rows >= 0
        ok[ok] &= m.crc_ok[rows[ok]]
        y[ok, 2 * u] = m.range_m[rows[ok]]
        phase = np.full(t.size, np.nan)
        phase[ok] = m.phase_rad[rows[ok]]
        dphi = np.angle(np.exp(1j * np.diff(phase)))
        y[1:, 2 * u + 1] = wavelength_m(p.fc_hz) / (4 * np.pi) * dphi / np.diff(t)
        # the alias nearest the true mean radial velocity (ground truth: dealias = "oracle")
        r_true = np.full(plan.start_s.size, np.nan)
        r_true[idx] = run.true_range_m[u]
        v_true = np.diff(r_true[keep]) / np.diff(t)
        period = wavelength_m(p.fc_hz) / (2 * np.diff(t))
        oracle[1:, u] = y[1:, 2 * u + 1] + period * np.round((v_true - y[1:, 2 * u + 1]) / period)
    k = 2 * n_p
    y[:, k] = imu["accel_y"][keep]
    y[:, k + 1] = -imu["accel_x"][keep]
    y[:, k + 2] = imu["heading_rad"][keep]
    y[:, k + 3] = imu["gyro_z"][keep]
    return {"t_s": t, "packet": keep, "y": y, "rdot_oracle": oracle}


def wrap_periods(t_s, n_pylons: int, fc_hz) -> np.ndarray:
    """Period λ_u/(2·Δt_k) of the phase-derived radial velocities at the epochs (eq. 23).

    Parameters
    ----------
    t_s : array_like
        ``(n,)`` epochs [s] (the first Δt repeats the second).
    n_pylons : int
        Number of pylons N.
    fc_hz : array_like
        ``(N,)`` carrier frequencies [Hz].

    Returns
    -------
    numpy.ndarray
        ``(n, N)`` periods [m/s].
    """
    t = np.asarray(t_s, float)
    dt = np.append(np.diff(t[:2]), np.diff(t))
    lam = wavelength_m(np.asarray(fc_hz, float))
    return lam[None, :] / (2.0 * dt[:, None]) * np.ones((t.size, n_pylons))


def observe_case(variant: str, case: int, dealias: str, streams: dict, *, x0, W, pylons_m, fc_hz,
                 outage_s=OUTAGE_S, gate_m: float = 0.05) -> tuple[CaseStream, np.ndarray]:
    """Run one observer variant on one case of a recorded stream.

    Parameters
    ----------
    variant : {"literal", "prerotated", "ekf"}
        Observer variant (:func:`rfsim.estimators.observer.observe_2d`).
    case : int
        Case 1…7 (module docstring).
    dealias : {"innovation", "gated", "none", "oracle"}
        The radial-velocity aliasing treatment: "innovation" wraps the innovations into
        ±λ/(4Δt), "gated" does so while every range innovation is below ``gate_m``
        (:func:`rfsim.estimators.observer.range_gate`; the EKF wraps always), "none" feeds the
        wrapped values, "oracle" takes ``rdot_oracle``.
    streams : dict
        ``{1: the full stream, 6: every other packet}`` of :func:`measurement_stream`.
    x0 : array_like
        ``(9,)`` initial estimate (units of :func:`rfsim.estimators.himr_model.h_2d`).
    W : array_like
        CARE tuning weight (:func:`rfsim.estimators.observer.care_gain`).
    pylons_m : array_like
        ``(3, 2)`` pylon positions [m].
    fc_hz : array_like
        ``(3,)`` carriers [Hz].
    outage_s : tuple of float
        Outage window of Cases 2–5 [s].
    gate_m : float
        Range-innovation gate of ``dealias="gated"`` [m].

    Returns
    -------
    stream : CaseStream
        The case's stream.
    estimates : numpy.ndarray
        ``(n, 9)`` state estimates at its epochs.
    """
    base = streams[6 if case == 6 else 1]
    yb = base["y"]
    if dealias == "oracle":
        yb = yb.copy()
        yb[:, 1:6:2] = base["rdot_oracle"]
    cs = case_stream(1 if case == 6 else case, base["t_s"], yb, n_pylons=3, outage_s=outage_s)
    if case == 6:
        cs = replace(cs, case=6)
    sel = list(cs.pylons)
    wrap = hook = None
    if dealias in ("gated", "innovation"):
        per = wrap_periods(cs.t_s, 3, fc_hz)
        wrap = np.zeros_like(cs.y)
        for j, u in enumerate(sel):
            wrap[:, 2 * j + 1] = per[:, u]
    if dealias == "gated" and variant != "ekf":
        wrap, hook = None, range_gate(len(sel), gate_m, wrap)
    est = observe_2d(cs.t_s, cs.y, x0=x0, variant=variant, pylons_m=np.asarray(pylons_m, float)[sel], W=W,
                     gain_on=cs.gain_on, wrap_period=wrap, innovation=hook)
    return cs, est


__all__ = ["CASES", "OUTAGE_S", "SOURCE_MAX_ERROR_M", "SOURCE_CONVERGENCE_S", "CaseStream", "case_stream", "measurement_stream", "wrap_periods", "observe_case"]

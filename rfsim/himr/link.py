"""Per-packet link formulas of HIMR ranging: backscatter power, RSS range, phase-derived
radial velocity and its aliasing limit (himr-tag.md §1.1–1.3, §2.4; seed 000 L432–L465,
L744–L779; wave2-specs.md §H "Per-packet DSP").

* Received backscatter power (eq. 3, L449, after Griffin & Durgin):
  P = P_T·G_T·G_R·G_t²·λ⁴·X²·M / (4π·d)⁴ [W], with M = |Γ_A − Γ_B|²/4 (1 for ideal
  open/short loads) and X the polarisation mismatch (kept explicit; eq. 22 omits it,
  erratum 5).
* RSS range (eq. 22, L746): r = (K_u / P)^(1/4) with K_u = P·d⁴ — from the link budget,
  K_u = P_T·G_T·G_R·G_t²·λ⁴·X²·M/(4π)⁴, or calibrated at a known pose, K_u = P₀·d₀⁴.
  Any estimate of the received power works (e.g. |h|² of the per-packet complex gain) as
  long as K_u is in the same unit.
* Phase φ = −arg h with h ∝ exp(−j·4π·d/λ) (eq. 1, L434), so φ grows as the tag recedes;
  radial velocity (eq. 23, L776) ṙ = λ·wrap(Δφ)/(4π·Δt), positive when the tag moves away
  (L1088; the sign conflict of erratum 8 is fixed by this convention).
* The wrapped difference is unambiguous only while |Δφ| < π, i.e. |ṙ| < λ/(4·Δt)
  (himr-tag.md §1.3 [derived]): 1.822 m/s at 141 packets/s and 5.8 GHz.
"""

from __future__ import annotations

import numpy as np

from rfsim.core.units import wavelength_m


def lambda_over_4pi_m(fc_hz):
    """λ/(4π), the range per radian of round-trip phase (0.004113 m/rad at 5.80 GHz).

    Parameters
    ----------
    fc_hz : array_like
        Carrier frequency [Hz].

    Returns
    -------
    numpy.ndarray or float
        λ/(4π) [m/rad].
    """
    return wavelength_m(fc_hz) / (4.0 * np.pi)


def backscatter_power_w(distance_m, *, fc_hz, ptx_w, g_tx=1.0, g_rx=1.0, g_tag=1.0,
                        polarization=1.0, modulation=1.0):
    """Received backscatter power, eq. 3: P = P_T·G_T·G_R·G_t²·λ⁴·X²·M/(4π·d)⁴ (Griffin & Durgin).

    Parameters
    ----------
    distance_m : array_like
        Reader–tag distance d [m].
    fc_hz : float
        Carrier frequency [Hz].
    ptx_w : float
        Transmit power P_T [W].
    g_tx, g_rx, g_tag : float
        Linear gains G_T, G_R, G_t [1].
    polarization : float
        Polarisation mismatch X [1].
    modulation : float
        Modulation factor M = |Γ_A − Γ_B|²/4 [1].

    Returns
    -------
    numpy.ndarray
        P [W], shape of ``distance_m``.
    """
    lam = wavelength_m(fc_hz)
    d = np.asarray(distance_m, float)
    return ptx_w * g_tx * g_rx * g_tag ** 2 * lam ** 4 * polarization ** 2 * modulation / (4 * np.pi * d) ** 4


def rss_constant(*, fc_hz, ptx_w, g_tx=1.0, g_rx=1.0, g_tag=1.0, polarization=1.0, modulation=1.0) -> float:
    """K_u of eq. 22 from the link budget: P·d⁴.

    Parameters
    ----------
    fc_hz : float
        Carrier frequency [Hz].
    ptx_w : float
        Transmit power [W].
    g_tx, g_rx, g_tag, polarization, modulation : float
        Linear factors of :func:`backscatter_power_w` [1].

    Returns
    -------
    float
        K_u [W·m⁴].
    """
    return float(backscatter_power_w(1.0, fc_hz=fc_hz, ptx_w=ptx_w, g_tx=g_tx, g_rx=g_rx, g_tag=g_tag,
                                     polarization=polarization, modulation=modulation))


def ptx_for_snr_w(snr_db: float, distance_m: float, *, noise_power_w: float, fc_hz, g_tx=1.0, g_rx=1.0,
                  g_tag=1.0, polarization=1.0, modulation=1.0) -> float:
    """Transmit power P_T that gives the backscatter power P(d) = SNR·N at ``distance_m``.

    Eq. 3 solved for P_T (wave2-specs.md §H: calibrate P_T to SNR 31.6 dB at 1 m, L646).

    Parameters
    ----------
    snr_db : float
        Target SNR [dB].
    distance_m : float
        Distance [m].
    noise_power_w : float
        Noise power N [W].
    fc_hz : float
        Carrier frequency [Hz].
    g_tx, g_rx, g_tag, polarization, modulation : float
        Linear factors of :func:`backscatter_power_w` [1].

    Returns
    -------
    float
        P_T [W].
    """
    p1 = float(backscatter_power_w(distance_m, fc_hz=fc_hz, ptx_w=1.0, g_tx=g_tx, g_rx=g_rx, g_tag=g_tag,
                                   polarization=polarization, modulation=modulation))
    return 10.0 ** (float(snr_db) / 10.0) * float(noise_power_w) / p1


def calibrate_rss_constant(power, distance_m) -> float:
    """K_u = P₀·d₀⁴ from a reading at a known range (the start pose).

    Parameters
    ----------
    power : float
        Received power P₀ (any unit; K_u takes it).
    distance_m : float
        Known range d₀ [m].

    Returns
    -------
    float
        K_u [power unit·m⁴].
    """
    return float(np.asarray(power, float) * np.asarray(distance_m, float) ** 4)


def rss_range_m(power, k_u: float):
    """RSS range, eq. 22: r = (K_u/P)^(1/4).

    Parameters
    ----------
    power : array_like
        Received power P, unit of ``k_u`` / m⁴.
    k_u : float
        K_u [power unit·m⁴].

    Returns
    -------
    numpy.ndarray
        r [m].
    """
    return (k_u / np.asarray(power, float)) ** 0.25


def wrap_pi(phi_rad):
    """Wrap an angle to (−π, π].

    Parameters
    ----------
    phi_rad : array_like
        Angle [rad].

    Returns
    -------
    numpy.ndarray
        Wrapped angle [rad].
    """
    x = np.asarray(phi_rad, float)
    return np.pi - np.mod(np.pi - x, 2.0 * np.pi)


def radial_velocity_mps(dphi_rad, *, fc_hz, dt_s):
    """Eq. 23: ṙ = λ·wrap(Δφ)/(4π·Δt), Δφ of φ = −arg h (positive: receding).

    Parameters
    ----------
    dphi_rad : array_like
        Phase difference Δφ [rad].
    fc_hz : float
        Carrier frequency [Hz].
    dt_s : array_like
        Time between the packets Δt [s].

    Returns
    -------
    numpy.ndarray
        ṙ [m/s].
    """
    return lambda_over_4pi_m(fc_hz) * wrap_pi(dphi_rad) / np.asarray(dt_s, float)


def aliasing_limit_mps(*, fc_hz, packet_rate_hz):
    """Largest unambiguous |ṙ| = λ/(4·Δt) = λ·rate/4 (himr-tag.md §1.3).

    Parameters
    ----------
    fc_hz : float
        Carrier frequency [Hz].
    packet_rate_hz : array_like
        Packet rate 1/Δt [Hz].

    Returns
    -------
    numpy.ndarray
        Limit [m/s].
    """
    return wavelength_m(fc_hz) * np.asarray(packet_rate_hz, float) / 4.0


__all__ = ["lambda_over_4pi_m", "backscatter_power_w", "rss_constant", "ptx_for_snr_w", "calibrate_rss_constant",
           "rss_range_m", "wrap_pi", "radial_velocity_mps", "aliasing_limit_mps"]

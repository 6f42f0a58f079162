"""Reference twins of :mod:`rfsim.devices.sense_a_tag`."""

from __future__ import annotations

import numpy as np
import scipy.signal as _signal
import scipy.special as _special

from rfsim.devices import st_receiver as sr
from rfsim.devices.sense_a_tag import _chain_inputs


def chain_rows_reference(rx: sr.STReceiver, x) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """SciPy twin of :func:`rfsim.devices.sense_a_tag.chain_rows` (``lfilter`` for the RC,
    ``sosfilt_zi`` and ``sosfilt`` for the band-pass, :func:`rfsim.devices.st_receiver.comparator`
    row by row)."""
    u, a, sos, _ = _chain_inputs(rx, x)
    sos_zi = _signal.sosfilt_zi(sos)
    env = _signal.lfilter([a], [1.0, -(1.0 - a)], u, axis=1, zi=(1.0 - a) * u[:, :1])[0]
    bp = _signal.sosfilt(sos, env, axis=1, zi=sos_zi[:, None, :] * env[None, :, :1])[0]
    cmp = np.empty_like(bp)
    tog = np.empty(u.shape[0], dtype=np.int64)
    for i in range(u.shape[0]):
        cmp[i], _, tog[i] = sr.comparator(bp[i], threshold_v=rx.threshold_v)
    return env, bp, cmp, tog


def diode_chain_bounds(rx: sr.STReceiver, x) -> tuple[int, float]:
    """Numerical contract between :func:`rfsim.devices.sense_a_tag.chain_rows` (diode law, one numba
    kernel) and :func:`chain_rows_reference` for the inputs ``x``: ``(max_ulp, atol)``, the
    largest ULP distance of the envelopes and the largest absolute difference of the band-passed
    signals [V].

    Derivation. Both sides form the diode argument X = (G_v·(k·|x|))/(n·V_T) and i0e(X) with the
    same exactly rounded operations (i0e bit for bit: ``test_i0e_kernel_blocks_equal_scipy_bit_for_bit``),
    then ``u = (ln i0e(X) + X)·n·V_T``. ``ln`` is the only step that may differ: numba calls the
    C library's ``log``, NumPy may take a SIMD path; both are faithfully rounded, so the two
    values of L = ln i0e(X) < 0 differ by ≤ 1 ulp(L). The sum s = L + X = ln I0(X) > 0 cancels:
    ulp(L)/ulp(s) ≤ 2·|L|/s, largest at the smallest X (|L|/s ≈ 4/X for small X); with the
    rounding of s and of the product with n·V_T the two values of u differ by at most
    (A + 2)·2⁻⁵² relative, A = 2·|L|/s at min X. The RC (lfilter order, y = a·u + (1 − a)·y,
    coefficients > 0) averages u with positive weights summing to 1, so its relative error is
    u's, ≤ 2·(A + 2) ulp of the output (ulp(v) ≥ |v|·2⁻⁵³), plus its own re-rounding: ≤ 3
    roundings per sample, accumulated through 1/(1 − (1 − a)z⁻¹) whose l1 gain is 1/a, ≤ 2·3/a
    ulp.

    The band-pass output is formed by cancellation (it removes the DC of the envelope), so it is
    bounded in absolute terms: the envelope's difference through the cascade's l1 gain ‖h‖₁,
    plus the re-rounding inside each section k (transposed direct form II, ≤ 10 roundings per
    sample, each ≤ ulp(Z_k) with Z_k the largest intermediate value, bounded by
    Σ|b_k|·max|input| + Σ|a_k|·max|output|), fed back through the section's own poles
    (‖1/A_k‖₁) and on through the later sections (‖h_{>k}‖₁). Sections with poles near z = 1
    make ‖1/A_k‖₁ large (hundreds): this term dominates.
    """
    det = rx.envelope_detector
    x_arg = (det.matching_gain * (det.volts_per_sqrt_w * np.abs(np.atleast_2d(x)))) / det.thermal_voltage_v
    x_min = float(x_arg.min())
    ln_i0e = float(np.log(_special.i0e(x_min)))
    amp = 2.0 * abs(ln_i0e) / (ln_i0e + x_min)
    a = -np.expm1(-1.0 / (rx.fs_hz * det.tau_s))
    max_ulp = int(np.ceil(2.0 * (amp + 2.0) + 6.0 / a))

    env = chain_rows_reference(rx, x)[0]
    eps = np.finfo(np.float64).eps
    impulse = np.zeros(200_000)
    impulse[0] = 1.0
    sos = np.asarray(rx.sos, dtype=np.float64)
    atol = float(np.abs(_signal.sosfilt(sos, impulse)).sum()) * max_ulp * eps * float(np.abs(env).max())
    section_in = env
    for k in range(sos.shape[0]):
        zi_k = _signal.sosfilt_zi(sos[k:k + 1])
        section_out = _signal.sosfilt(sos[k:k + 1], section_in, axis=1, zi=zi_k[:, None, :] * section_in[None, :, :1])[0]
        z_k = (np.abs(sos[k, :3]).sum() * np.abs(section_in).max() + np.abs(sos[k, 3:]).sum() * np.abs(section_out).max())
        own = np.abs(_signal.lfilter([1.0], sos[k, 3:], impulse)).sum()
        later = np.abs(_signal.sosfilt(sos[k + 1:], impulse)).sum() if k + 1 < sos.shape[0] else 1.0
        atol += 10.0 * eps * float(z_k) * float(own) * float(later)
        section_in = section_out
    return max_ulp, atol

"""2-D HIMR tracking on a GEOMETRIC SURROGATE of the measurement stream (ideal RSS ranges and
radial velocities from the true trajectory plus the noise of himr-tag.md §6.3 — not the
sample-level receivers): the `prerotated` observer against the reference's time-domain
numbers, what the `literal` observer gives instead of the seed's 10 cm transient, the EKF
variant, the outage-case orderings, and IMU words that reach the observer through packets."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.devices.himr_tag import HimrTag, HimrTagConfig
from rfsim.devices.imu import ImuConfig, heading_from_compass, true_readings, words_to_si
from rfsim.estimators.himr_cases import case_stream
from rfsim.estimators.himr_model import PYLONS_M, h_2d
from rfsim.estimators.himr_surrogate import SurrogateNoise, geometric_measurements
from rfsim.estimators.observer import W_D1, observe_2d
from rfsim.himr.packet import parse_packets
from rfsim.core.rng import trial_rng
from rfsim.core.trajectories import LinearTrapezoid, RotatingBoom

N_TRIALS = 16


def _run(rate_hz, variant, *, noise=None, seed=0, lag_s=0.0, case=1, x0=None, t_end=1.6, W=None):
    """Errors |x̂ − x|, |ŷ − y| (n, 2) of one run and the epochs; motion ends at 1.2 s + lag."""
    tr = RotatingBoom(lag_s=lag_s)
    t = np.arange(0.0, t_end, 1.0 / rate_hz)
    X = tr(t).state_2d()
    y = geometric_measurements(X, noise=noise, rng=trial_rng(seed, 0))
    cs = case_stream(case, t, y)
    kw = {} if W is None else {"W": W}
    est = observe_2d(cs.t_s, cs.y, variant=variant, pylons_m=PYLONS_M[list(cs.pylons)],
                     gain_on=cs.gain_on, x0=x0, **kw)
    Xc = tr(cs.t_s).state_2d()
    return cs.t_s, np.abs(est[:, [0, 3]] - Xc[:, [0, 3]])


def _max_in_motion(t, e, lag_s=0.0):
    return e[t <= 1.2 + lag_s].max(axis=0)


def test_prerotated_noise_free():
    """H§6.3: noise-free max error 1.2 cm (x) / 2.2 cm (y) → target ≤ 2.5 cm; final < 2 mm
    (at the last epoch, 0.4 s after the stroke)."""
    t, e = _run(141.0, "prerotated")
    assert _max_in_motion(t, e).max() <= 0.025
    assert e[-1].max() < 0.002


@pytest.mark.parametrize("rate_hz, lo, hi", [(141.0, 0.035, 0.065), (70.5, 0.042, 0.091)])
def test_prerotated_with_noise(rate_hz, lo, hi):
    """H§6.3 noise (σ 5 cm, 5 cm/s, 0.5 m/s², 0.05 rad, 0.3 rad/s): max error ≈ 5 cm at
    141 packets/s and 6–7 cm at 70.5 packets/s, tolerance ±30 % (wave2-specs §H): the median
    over 16 seeded trials of max(|e_x|, |e_y|) during the stroke must fall in
    [3.5, 6.5] cm / [4.2, 9.1] cm."""
    peaks = [_max_in_motion(*_run(rate_hz, "prerotated", noise=SurrogateNoise(), seed=s)).max()
             for s in range(N_TRIALS)]
    assert lo <= np.median(peaks) <= hi


def test_halving_the_packet_rate_raises_the_error():
    """Case 6 vs Case 1 on the same 8 noise draws: the median peak error grows (medians of
    16 trials: 4.5 cm → 6.3 cm)."""
    p141 = [_max_in_motion(*_run(141.0, "prerotated", noise=SurrogateNoise(), seed=s)).max() for s in range(8)]
    p70 = [_max_in_motion(*_run(141.0, "prerotated", noise=SurrogateNoise(), seed=s, case=6)).max()
           for s in range(8)]
    assert np.median(p70) > 1.1 * np.median(p141)


def test_literal_observer_transient():
    """The seed's estimator (fixed D.2 gain, trigonometric acceleration rows) cannot give the
    source's ≈ 10 cm Case-1 transient: noise-free it reaches ≈ 1.5 m in x and ≈ 1.0 m in y
    (himr-tag.md §6.3 [derived]: ≈ 1.5–1.6 m, ≈ 1.1 m) because cos ψ in rows a₁, a₂ flips
    sign once the heading has turned 90° from the linearisation value π, making the frozen
    A − L·C(x) unstable over 0.42–0.78 s; it converges once the heading is back near π (final
    < 2 mm). With the D.1 gain it diverges."""
    t, e = _run(141.0, "literal")
    peak = _max_in_motion(t, e)
    assert 1.2 <= peak[0] <= 1.8 and 0.8 <= peak[1] <= 1.3
    assert e[-1].max() < 0.002
    t1, e1 = _run(141.0, "literal", W=W_D1)
    assert e1[-1].max() > 100.0


def test_ekf_variant():
    """EKF on the literal model with R = the §6.3 variances: noise-free it follows the true
    trajectory (< 1 mm); with the §6.3 noise its median peak error over 16 trials is
    ≈ 12 cm (bounds 6–20 cm) — the fixed tuning W is not re-tuned for it."""
    t, e = _run(141.0, "ekf")
    assert _max_in_motion(t, e).max() < 1e-3
    peaks = [_max_in_motion(*_run(141.0, "ekf", noise=SurrogateNoise(), seed=s)).max() for s in range(N_TRIALS)]
    assert 0.06 <= np.median(peaks) <= 0.20


def test_outage_case_orderings():
    """Seed L1243–L1350 (max y error): Case 4 (5 cm) < Case 3 (30 cm) < Case 2 (50 cm),
    Case 5 ≈ Case 2. The surrogate follows the seed in comparing with the actual
    trajectory, which ran 150 ms behind the programmed one (L1014–L1020); the outage
    0.39–0.75 s then covers programmed 0.24–0.60 s. Noise-free, prerotated observer.
    (Against the un-delayed trajectory the outage falls into the fastest part of the turn
    and Case 3's open-loop extrapolation is the worst, not the middle, case.)"""
    ey = {c: _max_in_motion(*_run(141.0, "prerotated", lag_s=0.15, case=c), lag_s=0.15)[1] for c in (2, 3, 4, 5)}
    assert ey[4] < ey[3] < ey[2]
    assert abs(ey[5] / ey[2] - 1) < 0.3
    e1 = _max_in_motion(*_run(141.0, "prerotated", lag_s=0.15), lag_s=0.15)[1]
    assert e1 < ey[4]


def test_convergence_ordering():
    """Seed L1354–L1404: Case 6 (≈ 1.2 s) and Case 7 (≈ 1.1 s) converge later than Case 1
    (≈ 0.8 s). Convergence time = last epoch with a position error above 5 mm, noise-free,
    from IC #2 of Table 9 ((1, 1) m, ψ = π/2, L1196–L1206), actual (150 ms delayed)
    trajectory. Measured: 1.15 s (C1), 1.32 s (C6), 1.30 s (C7). (The 1 m initial error
    itself is gone within 0.15 s in Cases 1 and 7 and 0.8 s in Case 6 at a 2 cm threshold;
    what remains until ≈ 1.1 s is the in-motion tracking error.)"""
    x0 = np.array([1.0, 0, 0, 1.0, 0, 0, np.pi / 2, 0, 0])

    def conv(case, threshold_m):
        t, e = _run(141.0, "prerotated", lag_s=0.15, case=case, x0=x0)
        big = np.nonzero(np.hypot(e[:, 0], e[:, 1]) > threshold_m)[0]
        return t[big[-1]]

    c = {k: conv(k, 0.005) for k in (1, 6, 7)}
    assert c[6] > c[1] + 0.05 and c[7] > c[1] + 0.05
    assert conv(6, 0.02) > conv(1, 0.02) + 0.3


def test_case_stream_by_hand():
    """Hold, gain off, interpolation, replay, decimation and pylon selection on a ramp."""
    t = np.arange(10) * 0.1
    y = np.column_stack([t * 10 + k for k in range(10)])
    win = (0.25, 0.55)  # epochs 3, 4, 5 inside; anchors 2 and 6
    c2 = case_stream(2, t, y, outage_s=win)
    np.testing.assert_array_equal(c2.y[3:6], np.tile(y[2], (3, 1)))
    c3 = case_stream(3, t, y, outage_s=win)
    np.testing.assert_array_equal(c3.gain_on, [1, 1, 1, 0, 0, 0, 1, 1, 1, 1])
    np.testing.assert_array_equal(c3.y, y)
    c4 = case_stream(4, t, y, outage_s=win)
    np.testing.assert_allclose(c4.y, y, atol=1e-12)  # a ramp interpolates to itself
    c5 = case_stream(5, t, y, outage_s=win)
    np.testing.assert_array_equal(c5.y[3:6, :6], np.tile(y[2, :6], (3, 1)))
    np.testing.assert_array_equal(c5.y[:, 6:], y[:, 6:])
    c6 = case_stream(6, t, y)
    np.testing.assert_array_equal(c6.t_s, t[::2])
    c7 = case_stream(7, t, y)
    assert c7.pylons == (0, 1)
    np.testing.assert_array_equal(c7.y, y[:, [0, 1, 2, 3, 6, 7, 8, 9]])


# ----------------------------------------------------------------------------- packets → observer


def test_imu_device_matches_model_outputs():
    """rfsim.devices.imu readings (f_y, −f_x, heading, ψ̇) are the model's outputs a₁, a₂, θ_z, ω_z."""
    k = RotatingBoom()(np.linspace(0, 1.2, 60))
    f = true_readings(k, ImuConfig())
    h = h_2d(k.state_2d())
    np.testing.assert_allclose(f[:, 1], h[:, 6], atol=1e-12)
    np.testing.assert_allclose(-f[:, 0], h[:, 7], atol=1e-12)
    np.testing.assert_allclose(f[:, 5], h[:, 9], atol=1e-12)


def test_imu_words_from_packets_drive_the_observer():
    """The tag's packets (datasheet IMU noise, int16 words, compass heading) supply the
    inertial outputs; the RF outputs come from the noise-free surrogate at the packet times;
    10 % of the packets fail their CRC and lose RF and IMU together (a NaN row). The
    prerotated observer stays within 5 cm, the H§6.3 noise level (the compass quantisation,
    0.6 µT of 22 µT ≈ 0.03 rad, rotates the 25 m/s² centripetal reading by ≈ 0.7 m/s²;
    measured 3.0 cm)."""
    tag = HimrTag(HimrTagConfig(jitter_rms_s=20e-6), RotatingBoom(), ImuConfig())
    plan = tag.plan(1.6, rng=trial_rng(30, 0))
    bits = plan.bits.copy()
    lost = trial_rng(30, 1).random(bits.shape[0]) < 0.1
    bits[lost, 100] ^= 1
    p = parse_packets(tag.config.format, tag.config.framing, bits)
    np.testing.assert_array_equal(p.crc_ok, ~lost)
    si = words_to_si(p.words, tag.imu)
    X = plan.truth.state_2d()
    y = geometric_measurements(X)
    heading = np.unwrap(heading_from_compass(si[:, 6], si[:, 7], tag.imu.declination_rad))
    y[:, 6], y[:, 7], y[:, 8], y[:, 9] = si[:, 1], -si[:, 0], heading + 2 * np.pi * np.round(
        (np.pi - heading[0]) / (2 * np.pi)), si[:, 5]
    y[~p.crc_ok] = np.nan
    est = observe_2d(plan.start_s, y, variant="prerotated")
    e = np.abs(est[:, [0, 3]] - X[:, [0, 3]])
    assert e[plan.start_s <= 1.2].max() <= 0.05


# ----------------------------------------------------------------------------- 1-D


def test_1d_euler_stability_limit():
    """Forward Euler (eq. 20) with the gain (18) is stable iff |1 − 387.3·T| < 1, i.e. above
    2·387.3/2 = 193.6 packets/s [derived from (19)]: fine at the tag's ≈ 300 packets/s
    (L411), unstable at 141 packets/s."""
    from rfsim.estimators.himr_model import A3
    from rfsim.estimators.observer import gain_1d
    L = gain_1d().L
    rho = {r: np.abs(np.linalg.eigvals(np.eye(3) + (A3 - L) / r)).max() for r in (300.0, 194.0, 193.0, 141.0)}
    assert rho[300.0] < 1 and rho[194.0] < 1 and rho[193.0] > 1 and rho[141.0] > 1


@pytest.mark.parametrize("rate_hz, printed", [(1000.0, 0.05), (300.0, 0.12)])
def test_1d_seed_noise_read_as_state_noise(rate_hz, printed):
    """The 1-D simulation (L610–L628) with the seed's noise scales 0.03/0.08/0.05 read as
    standard deviations in m, m/s, m/s² on z, ż, z̈: median peak position error over 20
    trials ≈ 5 cm at T = 1 ms and ≈ 12 cm at T = 1/300 s (himr-tag.md §6.4 [derived], ±25 %),
    not the seed's 1 mm — with that reading the gain (18) (bandwidth 387 rad/s) hardly
    filters at these rates; the seed's noise must be on another scale (§6.4)."""
    from rfsim.estimators.observer import observe_1d
    tr = LinearTrapezoid()
    t = np.arange(0.0, 1.0, 1.0 / rate_hz)
    X = tr(t).state_1d()
    peaks = []
    for s in range(20):
        y = X + np.array([0.03, 0.08, 0.05]) * trial_rng(s, 7).standard_normal(X.shape)
        peaks.append(np.abs(observe_1d(t, y, x0=X[0])[:, 0] - X[:, 0]).max())
    assert abs(np.median(peaks) / printed - 1) < 0.25
    # noise-free: the observer follows the trapezoid to well under the seed's 1 mm
    assert np.abs(observe_1d(t, X, x0=X[0])[:, 0] - X[:, 0]).max() < 1e-4


def test_wrapped_radial_velocities_are_resolved_by_the_innovation_wrap():
    """The phase-derived ṙ is known only modulo λ/(2Δt) (eq. 23, H§1.3). The surrogate's
    radial velocities wrapped into ±λ/(4Δt) (1.822 m/s at 141 packets/s, 5.8 GHz; the boom
    reaches 2.78 m/s) and fed as they are mislead the prerotated observer (11.5 cm, > 5 cm asserted); with the
    innovation wrapped by the same period (``wrap_period``) it tracks as with the true
    velocities (1.79 cm both; within 1 mm of that run)."""
    from rfsim.estimators.observer import wrap_innovation

    np.testing.assert_allclose(wrap_innovation(np.array([3.0, -2.0, 0.5, np.nan]), np.array([4.0, 4.0, 0.0, 4.0])),
                               [-1.0, -2.0, 0.5, np.nan])
    tr = RotatingBoom()
    t = np.arange(0.0, 1.6, 1 / 141)
    X = tr(t).state_2d()
    y = geometric_measurements(X)
    period = 299792458.0 / 5.8e9 / (2 * (1 / 141))
    yw = y.copy()
    yw[:, 1:6:2] = y[:, 1:6:2] - period * np.round(y[:, 1:6:2] / period)
    assert np.abs(y[:, 1:6:2]).max() > period / 2  # some samples alias
    wp = np.zeros(y.shape[1])
    wp[1:6:2] = period
    ref = observe_2d(t, y, variant="prerotated")
    raw = observe_2d(t, yw, variant="prerotated")
    fixed = observe_2d(t, yw, variant="prerotated", wrap_period=wp)
    err = lambda e: np.hypot(e[:, 0] - X[:, 0], e[:, 3] - X[:, 3]).max()
    assert err(raw) > 0.05
    assert abs(err(fixed) - err(ref)) < 1e-3

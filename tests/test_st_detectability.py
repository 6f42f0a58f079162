"""Detectability of a sample under the default diode detector, against hand-derived values.

Detectability (R3-5, auris-sense-a-tag.md §4.1, seed L3472-3502): "the envelope detector output
of the superimposed signal of tag's backscattering signal and synchronized Reader's CW ... should
be larger than the phase cancellation threshold 0.005 V". For the CW phasor c and the two
backscatter states b1, b2 the envelopes are A_i = |c + b_i| (Eq. 3.3); synchronising the CW
(its phase free, its amplitude not) the envelope swing is D = |b1 − b2| whenever the CW
dominates (|c| ≥ |b_i|), centred on |c|. The detector output swing is then

    Δv = f(|c| + D/2) − f(|c| − D/2),   f(V) = n·V_T·ln I0(G_v·V/(n·V_T))

with the ST's diode law f (rfsim.devices.st_receiver, module docstring "law='diode'") and its
default parameters G_v = 0.96, n = 1.05, T = 290 K: n·V_T = 1.05·(1.380649e-23/1.602176634e-19)·290
= 0.0262398 V. This is ``sync_sa2_v`` of :func:`rfsim.devices.st_analytic.technique_outcomes`
with ``transfer = EnvelopeDetector(law="diode").transfer_v``, the value the phase-cancellation
scenario compares with 5 mV. A factor 2 on the swing (D instead of D/2 on either side, or 2·Δv)
doubles the result and fails these tests.
"""

from __future__ import annotations

import math

import pytest

from rfsim.devices.st_analytic import technique_outcomes
from rfsim.devices.st_receiver import EnvelopeDetector

#: 50 Ω peak volts per source volt (peak sqrt(2P) across 1 Ω): sqrt(50)
SQRT_50 = math.sqrt(50.0)


def _sync_sa2_v(cw, bs1, bs2) -> float:
    det = EnvelopeDetector(tau_s=1e-6, law="diode")
    out = technique_outcomes(cw, bs1, bs2, cw, bs1, bs2, transfer=det.transfer_v, threshold_v=5e-3)
    return float(out.sync_sa2_v)


def test_collinear_states_of_table_3_1_give_the_hand_derived_swing():
    """Table 3.1 row "No phase cancellation" (R3-2, L3372-3380), source volts × sqrt(50):
    A_R = 0.1087 → |c| = 0.768625 V, A_T1 = 0.0585, A_T2 = 0.0568 → D = 0.0017·sqrt(50)
    = 0.0120208 V (collinear states: D = A_T1 − A_T2).

    Hand derivation. For a small swing the secant is the slope at the centre,
    Δv = G_v·D·I1(x)/I0(x) + O(D³·f'''), x = G_v·|c|/(n·V_T) = 0.96·0.768625/0.0262398 = 28.121;
    the large-argument series I1/I0 = 1 − 1/(2x) − 1/(8x²) − … = 1 − 0.017780 − 0.000158 = 0.982061;
    Δv = 0.96 · 0.0120208 · 0.982061 = 0.011333 V (the neglected terms: 1/(8x³) ≈ 6e-6
    relative, the cubic term ≈ 1e-7 relative). Above the 5 mV threshold: detectable. (The
    source quotes ≈ 0.01 V for its 0.0017 V, R3-1, L3340-3366.)"""
    c, b1, b2 = 0.1087 * SQRT_50, 0.0585 * SQRT_50, 0.0568 * SQRT_50
    got = _sync_sa2_v(c, b1, b2)
    assert got == pytest.approx(0.011333, rel=1e-4)
    assert got > 5e-3


def test_states_in_quadrature_swing_by_their_distance_not_their_magnitudes():
    """Same amplitudes with b2 turned by 90°: |c| = 0.768625 V still dominates, so
    D = |b1 − b2| = sqrt(0.0585² + 0.0568²)·sqrt(50) = 0.576563 V, not ||b1| − |b2||.

    Hand derivation with ln I0(x) = x − ½·ln(2πx) + ln(1 + 1/(8x) + 9/(128x²)) (large x):
    V± = |c| ± D/2 = 1.056906 V, 0.480344 V → x± = 38.6676, 17.5737;
    f(V+) = n·V_T·(38.6676 − 2.7464 + 0.003274) = 0.942650 V,
    f(V−) = n·V_T·(17.5737 − 2.3521 + 0.007314) = 0.399602 V; Δv = 0.543048 V
    (the series' next term, 75/(1024x³) ≈ 1.35e-5 at x−, moves f(V−) by 3.5e-7 V)."""
    c, b1, b2 = 0.1087 * SQRT_50, 0.0585 * SQRT_50, 0.0568j * SQRT_50
    assert _sync_sa2_v(c, b1, b2) == pytest.approx(0.543048, rel=2e-5)

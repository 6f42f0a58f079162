"""PF-AA's motion model (rfsim.estimators.landmark_pf.pf_aa, Eqs. 4.13, 4.14, 4.22) against a
track derived by hand: with a flat likelihood and no process or initial noise every particle
sits at the same point, so the MMSE is that point and the filter follows the motion model
alone."""

from __future__ import annotations

import numpy as np

from rfsim.estimators.landmark_pf import pf_aa

#: Landmarks L0 = (0, 0), L1 = (4, 0), L2 = (0, 4) [m].
LANDMARKS_XY = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]])
#: Detections per period: L0 only, then L1 and L2 once each, then none, then L2 only, so the
#: weighted centroids x̂*_t are (0, 0), (2, 2), none, (0, 4).
COUNTS = np.array([[[1, 0, 0], [0, 1, 1], [0, 0, 0], [0, 0, 1]]])


def _flat(positions, t):
    """Every landmark detected with probability 1/2 wherever the ST is: no particle is preferred."""
    return np.full(positions.shape[:-1] + (LANDMARKS_XY.shape[0],), 0.5)


def test_pf_aa_moves_along_the_blended_velocity_by_hand():
    """Δt = 0.5 s, b0 = 0.8, b1 = 0.2, x̂_t = x̂_{t−1} + v_t·Δt with v_t = b0·v̂*_t + b1·v̂_{t−1},
    v̂*_t = (x̂*_t − x̂_{t−1})/Δt (0 without detections), v̂_t = (x̂_t − x̂_{t−1})/Δt:

    * t = 0: x̂_0 = x̂*_0 = (0, 0), v̂_0 = 0;
    * t = 1: v̂* = (2, 2)/0.5 = (4, 4), v = 0.8·(4, 4) = (3.2, 3.2), x̂_1 = (1.6, 1.6), v̂_1 = (3.2, 3.2);
    * t = 2: no detection, v = 0.2·(3.2, 3.2) = (0.64, 0.64), x̂_2 = (1.92, 1.92), v̂_2 = (0.64, 0.64);
    * t = 3: v̂* = ((0, 4) − (1.92, 1.92))/0.5 = (−3.84, 4.16), v = 0.8·v̂* + 0.2·(0.64, 0.64)
      = (−2.944, 3.456), x̂_3 = (1.92 − 1.472, 1.92 + 1.728) = (0.448, 3.648).

    Four particles (weights 1/4, exact) at one point; a few dozen roundings of values below
    8 m leave errors below 1e-14 m, so 1e-12 m is a safe bound, far below the 3.2 m by which a
    velocity of the wrong sign moves x̂_1."""
    x_hat, v_hat = pf_aa(COUNTS, LANDMARKS_XY, n_particles=4, period_s=0.5, q_std_m=0.0, init_std_m=0.0,
                         b0=0.8, b1=0.2, n_rounds=1, probability=_flat, rng=np.random.default_rng(1))
    want_x = [[0.0, 0.0], [1.6, 1.6], [1.92, 1.92], [0.448, 3.648]]
    want_v = [[0.0, 0.0], [3.2, 3.2], [0.64, 0.64], [-2.944, 3.456]]
    np.testing.assert_allclose(x_hat[0], want_x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v_hat[0], want_v, rtol=0, atol=1e-12)

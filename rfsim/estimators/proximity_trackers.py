"""The trackers of Geng's Table 6.2 (binary-detection.md §1.11, seeds/004 L1099-L1249) run on
one sequence of proximity observations: NN, KF, Bernoulli PF and RBPF of
:mod:`rfsim.estimators.proximity`, each from "the prior knowledge of the states" (Table 6.1,
L1208): N(x0, diag(σ_p², σ_v², σ_p², σ_v²)) around the true initial state x0 (the source gives
no σ; the filters draw their initial particles from it, the KF starts from it).

On the KF against Table 6.2. The KF is the one the text fixes
(:func:`rfsim.estimators.proximity.proximity_kalman`): the measurement is the single decoded
tag's location y = l_i (L1089, L1109), one at a time (L1061), G = diag(r²/2, r²/2) (L1119), an
update only when a decode arrives (L1095), the motion model (6.1) over the real gap
Δt = t2 − t1 (L1080) with Q = diag(0.01, 0.01) (L1203), and the same prior knowledge as the
PF/RBPF (Table 6.1, L1208; the text gives the KF none). In the scenario ``tag-to-tag-tracking``
its error stays flat in r because the decoded-tag offsets are nearly zero-mean along the
two-sided aisle and independent between decodes, and the decode rate grows with r
(3.4/5.4/7.0 per s), which offsets the larger spread of the offsets. Readings the text leaves
open, each tried alone (40 trajectories, seed 1; KF at r = 1.5/2/2.5 m): a KF prior at the first
decode with zero velocity (σ_v 0.3-3 m/s) 0.47-0.52/0.45-0.50/0.54-0.61; its Q × 0 … × 10⁴
0.30-0.81 m, flat or falling in r; R = r/2 … r²/2000 0.33-0.72 m, flat; the truth stepped at
T_s = 0.5 s as in ch. 4 (L836) 0.40/0.40/0.48; v0 read as the vector (0.1, 1) m/s, 1 m/s along
the aisle, 0.31/0.33/0.42; 10 or 20 Aloha slots instead of 50 0.48/0.42/0.43 and
0.38/0.35/0.37 m. None grows like Table 6.2's KF (× 1.9 from r = 1.5 to 2.5 m). Only changes
against the text do: a fixed Δt per decode (1 s: 0.56/0.66/0.76 m; L1080 says t2 − t1), or a
truth 10 × rougher than the filters' Q (q = 0.1 m²/s⁴ on 0.5 s steps: KF 0.55/0.67/0.81 m, NN
1.07/1.40/1.66 m) — which lifts PF30 to 0.78/0.92/1.04 m, so PF30 < KF fails. Table 6.2's KF
(≈ NN − 0.5 m, worse than PF20 at r ≥ 2 m) thus looks like a KF handicapped relative to the PF
in a way the text does not state, e.g. a motion model or prior it does not share with the PF
[inference]; with the stated model and prior the linear KF is the better tracker.

The readings of L1203 as a grid (seed 1, 100 trajectories; the scenario's config keys
``layout.tag_layout``, ``motion.initial_velocity``, ``trackers.prior``; KF at r = 1.5/2/2.5 m,
the full table on the scenario's docs page): with the initial velocity read as a speed along
the aisle the KF stays at 0.20-0.78 m in every layout and prior, never within 25 % of Table 6.2
at all three r. Read as the vector (0.1, 1) m/s — 1 m/s across the aisle, the tag bouncing
off the shelves, which the constant-velocity model cannot follow — the KF with the true prior
is 0.64-0.91 / 0.78-0.97 / 0.91-1.05 m over the layouts (within 25 % in three of five; the
``short-1m`` layout 0.64/0.78/0.96 m, seeds 1-3 within ± 0.015 m) and NN 1.02-1.07 / 1.32-1.42
/ 1.43-1.60 m (published 1.07/1.34/1.56 m). But the particle filters, on the same
constant-velocity model with 10-30 particles, lose that motion: PF10/20/30 3.79-4.22 /
2.97-3.39 / 2.54-3.02 m (``short-1m``, 50 runs; published 0.52-0.80 m). Read as 1 m/s along the
aisle with a prior at the portal or the first decode (velocity unknown, N(0, σ_v²)), the KF is
within 25 % in ``short-1m`` (0.61-0.66 / 0.71-0.79 / 0.86-1.03 m) but PF30 is 1.27-1.49 m
(10 runs); with the vector and the portal prior PF30 is 0.62/0.80/0.95 m against a KF of
0.50/0.65/0.81 m. No reading tried gives the KF row and PF30 < KF together.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from rfsim.core.config import param
from rfsim.core.lazy import lazy_import

_proximity = lazy_import("rfsim.estimators.proximity")  # the filters load on first use


#: Table 6.2 (seeds/004 L1242-L1249): average RMSE [m] per sensing range r: NN, KF, PF M = 10, 20, 30.
PUBLISHED_TABLE_6_2 = {
    1.5: {"nn": 1.0720, "kf": 0.5611, "pf10": 0.6466, "pf20": 0.5484, "pf30": 0.5183},
    2.0: {"nn": 1.3391, "kf": 0.8203, "pf10": 0.7351, "pf20": 0.5886, "pf30": 0.5340},
    2.5: {"nn": 1.5643, "kf": 1.0782, "pf10": 0.8046, "pf20": 0.6513, "pf30": 0.5812},
}


@dataclass(frozen=True)
class TrackerConfig:
    """The trackers run (NN, KF, PF and RBPF per particle count) and their prior."""

    particles: tuple[int, ...] = param((10, 20, 30), lo=1, hi=100000, doc="Bernoulli PF particle counts M (L1246)")
    rbpf_particles: tuple[int, ...] = param((30,), lo=1, hi=100000, doc="RBPF particle counts M (L1221)")
    likelihood: Literal["exciter-link", "slope"] = param(
        "exciter-link", doc="the filters' Eq. (6.5): the range section's (exciter-link) curve, or p(r) = 0.5 "
                            "with the slope slope_per_m")
    slope_per_m: float = param(4.0, lo=0.01, hi=1000.0, unit="1/m",
                               doc="likelihood 'slope': a2 of the filters' Eq. (6.5) with p(r) = 0.5")
    prior_position_std_m: float = param(0.3, lo=1e-6, hi=100.0, unit="m", doc="prior std of the initial position")
    prior_velocity_std_mps: float = param(0.3, lo=1e-6, hi=100.0, unit="m/s", doc="prior std of the initial velocity")
    prior: Literal["truth", "portal", "first-decode"] = param(
        "truth", doc="prior mean: 'truth' = the true initial state; 'portal' = the entry point at t = 0 with zero "
                     "velocity; 'first-decode' = the first decoded tag's location at the first decode, zero "
                     "velocity, position std r/sqrt(2) (G); see prior_for")

    @property
    def labels(self) -> list[tuple[str, str, int]]:
        """(label, kind, M) of every tracker run: nn, kf, pf<M>…, rbpf<M>…"""
        return ([("nn", "nn", 0), ("kf", "kf", 0)] + [(f"pf{m}", "pf", m) for m in self.particles]
                + [(f"rbpf{m}", "rbpf", m) for m in self.rbpf_particles])


def prior_for(prior: str, x0_true, start_xy_m, times_s, observed_xy, *, range_m: float, position_std_m: float,
              velocity_std_mps: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(t0 [s], mean (4,), std (4,)) of the trackers' prior ``[x, ẋ, y, ẏ]`` (:class:`TrackerConfig`
    ``prior``; Table 6.1's "prior knowledge of the states", the source gives none).

    "truth": N(x0_true, diag(σ_p, σ_v, σ_p, σ_v)²) at t0 = 0 (the default). "portal": the mobile tag
    is known to enter at ``start_xy_m`` at t0 = 0, its velocity is not: mean (start, 0), same σ.
    "first-decode": nothing is known before the first decode; at t0 = t_1 the posterior of a flat
    prior after y_1 = l_i under (6.3) is N(l_i, G), G = diag(r²/2, r²/2), velocity N(0, σ_v²); the
    filters then process observations 2…T (the estimate at t_1 is the prior's mean).
    """
    sd_v = velocity_std_mps
    if prior == "truth":
        return 0.0, np.asarray(x0_true, float), np.array([position_std_m, sd_v] * 2)
    if prior == "portal":
        return 0.0, np.array([start_xy_m[0], 0.0, start_xy_m[1], 0.0]), np.array([position_std_m, sd_v] * 2)
    y1 = np.asarray(observed_xy, float)[0]
    sd_p = range_m / np.sqrt(2.0)
    return float(np.asarray(times_s)[0]), np.array([y1[0], 0.0, y1[1], 0.0]), np.array([sd_p, sd_v] * 2)


def prior_particles(x0, rng: np.random.Generator, n_runs: int, m: int, *, position_std_m: float,
                    velocity_std_mps: float, rao_blackwellised: bool) -> np.ndarray:
    """(n_runs, m, 4) initial particles ``[x, ẋ, y, ẏ]`` drawn from the prior (module docstring).

    For the RBPF (``rao_blackwellised``) the velocity slots hold the Kalman mean x^l_0 = the
    prior mean (Table 6.1); the normals are drawn all the same.
    """
    sd = np.array([position_std_m, velocity_std_mps] * 2)
    p = x0 + rng.standard_normal((n_runs, m, 4)) * sd
    if rao_blackwellised:
        p[..., 1::2] = x0[1::2]
    return p


def run_tracker(kind: str, times_s, observed_xy, x0, *, m: int, n_runs: int, range_m: float, accel_var: float,
                a1: float, a2: float, position_std_m: float, velocity_std_mps: float,
                rng: np.random.Generator, t0_s: float = 0.0, from_first: bool = False) -> np.ndarray:
    """Position estimates of one tracker at the observation instants: (runs, T, 2) [m].

    Parameters
    ----------
    kind : "nn" (association), "kf" (:func:`~rfsim.estimators.proximity.proximity_kalman`, G from
        ``range_m``), "pf" (:func:`~rfsim.estimators.proximity.bernoulli_pf`) or "rbpf"
        (:func:`~rfsim.estimators.proximity.rbpf`); NN and KF are deterministic (one run)
    times_s : (T,) observation instants [s] (the motion starts at t = 0)
    observed_xy : (T, 2) locations of the decoded reference tags [m]
    x0 : (4,) prior mean ``[x, ẋ, y, ẏ]``
    m, n_runs : particles per filter and independent filter runs (PF, RBPF)
    accel_var : q of the motion model (6.1) [m²/s⁴]
    a1, a2 : Eq. (6.5) coefficients of the filters' likelihood (a2 in 1/m)
    position_std_m, velocity_std_mps : prior standard deviations σ_p [m], σ_v [m/s]
    rng : the filter's stream (prior draws, propagation, resampling)
    t0_s : time of the prior [s]
    from_first : the prior is the posterior after the first observation (:func:`prior_for`
        "first-decode"): the filters process observations 2…T, the estimate at the first is
        the prior mean (KF) or the particles' mean (PF, RBPF)
    """
    if kind == "nn":
        return _proximity.association(observed_xy)[None]
    k0 = 1 if from_first else 0
    t, z = np.asarray(times_s, float)[k0:], np.asarray(observed_xy, float)[k0:]
    if kind == "kf":
        P0 = np.diag([position_std_m, velocity_std_mps] * 2) ** 2
        if t.size == 0:
            return np.asarray(x0, float)[None, None, 0::2]
        est = _proximity.proximity_kalman(t, z, x0, P0, t0_s=t0_s, accel_var=accel_var,
                                          range_m=range_m).x[None][..., 0::2]
        return np.concatenate([np.asarray(x0, float)[None, None, 0::2], est], axis=1) if from_first else est
    init = prior_particles(x0, rng, n_runs, m, position_std_m=position_std_m, velocity_std_mps=velocity_std_mps,
                           rao_blackwellised=kind == "rbpf")
    if t.size == 0:
        est = np.zeros((n_runs, 0, 2))
    elif kind == "pf":
        est = _proximity.bernoulli_pf(t, z, init, t0_s=t0_s, accel_var=accel_var, a1=a1, a2=a2,
                                      rng=rng).mmse[..., 0::2]
    else:
        est = _proximity.rbpf(t, z, init, velocity_std_mps ** 2, t0_s=t0_s, accel_var=accel_var, a1=a1, a2=a2,
                              rng=rng).mmse[..., 0::2]
    return np.concatenate([init.mean(axis=1)[:, None, 0::2], est], axis=1) if from_first else est


__all__ = ["PUBLISHED_TABLE_6_2", "TrackerConfig", "prior_for", "prior_particles", "run_tracker"]

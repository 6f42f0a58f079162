"""Trackers for binary proximity observations: association (NN), Kalman filter, Bernoulli
particle filter and Rao-Blackwellised particle filter, batched over filter runs.

Geng ch. 6 (binary-detection.md §1.11, seeds/004 L1074-L1199). The mobile tag's state (6.1)
is ``x = [x1, ẋ1, …, xJ, ẋJ]ᵀ`` and moves between observation instants t1 < t2 as::

    x_{t2} = A x_{t1} + B u_{t2},   A = I_J ⊗ [[1, Δt], [0, 1]],   B = I_J ⊗ [Δt²/2; Δt],
    u ~ N(0, Q)  (per-axis acceleration variance q_j [m²/s⁴], Q = diag(0.01, 0.01), L1203)

Each observation is the location ``y_k = l_i`` of the reference tag whose broadcast was decoded
(L1089).

* **Association / NN** (L1099): x̂_{t_k} = l_{i_k}.
* **KF** (6.3)-(6.4), L1105-L1119: y = H x + v, H = I_J ⊗ [1 0], v ~ N(0, G),
  G = diag(r²/2, r²/2) with r the sensing range; the Kalman recursion of
  :func:`rfsim.estimators.kalman.kalman_filter` with the time-varying F = A(Δt_k),
  Q_k = B(Δt_k) Q B(Δt_k)ᵀ. What the text fixes and this filter does: the measurement is the
  location of the one reference tag just decoded, y_{t2} = l_i ("the location of a reference
  tag whose backscattering is picked up", L1089, L1109) — no average over several tags, one
  observation at a time (L1061); the filter runs only when a decode arrives ("estimates x_t as
  soon as it receives a backscattered signal", L1095), predicting over the real gap
  Δt = t2 − t1 (L1080) with the motion model's Q (L1203). The text gives no KF prior: the
  caller passes the same "prior knowledge of the states" as the RBPF's (Table 6.1, L1208).
* **Bernoulli PF** (6.5), L1123-L1127: the SIR filter of :func:`rfsim.estimators.particle.sir_filter`
  with the prior (6.1) as proposal and the likelihood of one decode,
  p(d) = 1/(1 + exp(a1 + a2·d)), d = ‖particle position − l_i‖.
* **RBPF** (6.6)-(6.20), Table 6.1: position particles x^n, and per particle a Kalman mean of
  the velocity x^l with a covariance P^l shared by all particles (it does not depend on the
  particle). With A^n = Δt·I, A^l = I, B^n = Δt²/2·I, B^l = Δt·I::

      x^n_{t2} ~ N(x^n_{t1} + Δt x^l, Δt² P^l + Δt⁴/4 Q)                 (6.12), (6.14)
      z = x^n_{t2} − x^n_{t1},  K = Δt P^l / S                          (6.13), (6.17)
      x^l_{t1|t1} = x^l + K (z − Δt x^l),  P^l_{t1|t1} = P^l − K Δt P^l  (6.15), (6.16)
      x^l_{t2|t1} = Ā x^l_{t1|t1} + (2/Δt) z,  Ā = I − Δt·(2/Δt²)·Δt = −I  (6.18), (6.20)
      P^l_{t2|t1} = Ā P^l_{t1|t1} Āᵀ = P^l_{t1|t1}                      (6.19)

  then the weight update with (6.5) at x^n and resampling as in the PF (Table 6.1; the seed's
  "apply a KF" at L1163 means the PF, and l_{i,x} at L1210 means l_{i,y}, binary-detection.md §0.3).
  The velocity is driven by the same u as the position, so P^l only shrinks.

State order in every array is that of (6.1): ``[x1, ẋ1, x2, ẋ2]`` for J = 2.
"""

from __future__ import annotations

import numpy as np

from rfsim.estimators.kalman import FilterResult, kalman_filter
from rfsim.estimators.particle import ParticleFilterResult, sir_filter


def cv_transition(dt_s, n_dims: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A and B of the constant-velocity model (6.1) for each Δt.

    A = I_J ⊗ [[1, Δt], [0, 1]], B = I_J ⊗ [Δt²/2; Δt].

    Parameters
    ----------
    dt_s : array_like
        ``(T,)`` or scalar time steps Δt [s].
    n_dims : int
        Number of axes J.

    Returns
    -------
    A : numpy.ndarray
        ``(T, 2J, 2J)`` transitions.
    B : numpy.ndarray
        ``(T, 2J, J)`` input matrices [s², s].
    """
    dt = np.atleast_1d(np.asarray(dt_s, float))
    eye = np.eye(n_dims)
    a1 = np.zeros((dt.size, 2, 2))
    a1[:, 0, 0] = a1[:, 1, 1] = 1.0
    a1[:, 0, 1] = dt
    b1 = np.stack([dt * dt / 2.0, dt], axis=1)[:, :, None]
    A = np.einsum("ij,tkl->tikjl", eye, a1).reshape(dt.size, 2 * n_dims, 2 * n_dims)
    B = np.einsum("ij,tkl->tikjl", eye, b1).reshape(dt.size, 2 * n_dims, n_dims)
    return A, B


def cv_process_noise(dt_s, accel_var) -> np.ndarray:
    """Process noise Q_k = B(Δt_k) diag(q) B(Δt_k)ᵀ of (6.1).

    Parameters
    ----------
    dt_s : array_like
        ``(T,)`` or scalar time steps [s].
    accel_var : array_like
        ``(J,)`` acceleration variances q [m²/s⁴].

    Returns
    -------
    numpy.ndarray
        ``(T, 2J, 2J)`` covariances [m², m²/s, m²/s²].
    """
    q = np.atleast_1d(np.asarray(accel_var, float))
    _, B = cv_transition(dt_s, q.size)
    return B @ (q[:, None] * np.swapaxes(B, -1, -2))


def association(observed_xy) -> np.ndarray:
    """NN / association (L1099): the estimate is the observed reference-tag location.

    Parameters
    ----------
    observed_xy : array_like
        ``(..., T, J)`` observed locations [m].

    Returns
    -------
    numpy.ndarray
        ``(..., T, J)`` estimates [m] (a copy).
    """
    return np.array(observed_xy, float)


def proximity_kalman(times_s, observed_xy, x0, P0, *, t0_s: float, accel_var, range_m: float) -> FilterResult:
    """KF of (6.3)-(6.4) over the observed reference-tag locations.

    Predicts from the prior at ``t0_s`` into the first observation, then from each observation
    to the next; R = G = diag(r²/2, …).

    Parameters
    ----------
    times_s : array_like
        ``(T,)`` observation instants [s].
    observed_xy : array_like
        ``(T, J)`` observed locations [m].
    x0 : array_like
        ``(2J,)`` prior mean, state order of (6.1) [m, m/s, …].
    P0 : array_like
        ``(2J, 2J)`` prior covariance.
    t0_s : float
        Time of the prior [s].
    accel_var : array_like or float
        ``(J,)`` or scalar acceleration variance q [m²/s⁴].
    range_m : float
        Sensing range r [m].

    Returns
    -------
    rfsim.estimators.kalman.FilterResult
        Filtered and predicted moments.
    """
    t = np.asarray(times_s, float)
    z = np.asarray(observed_xy, float)
    n_dims = z.shape[-1]
    dt = np.diff(t, prepend=t0_s)
    F, _ = cv_transition(dt, n_dims)
    Q = cv_process_noise(dt, np.broadcast_to(accel_var, (n_dims,)))
    H = np.kron(np.eye(n_dims), [[1.0, 0.0]])
    R = np.eye(n_dims) * (range_m * range_m / 2.0)
    return kalman_filter(z, x0, P0, F, Q, H, R, predict_first=True)


def logistic_log_likelihood(positions_xy, observed_xy, a1: float, a2: float) -> np.ndarray:
    """log p(d) of (6.5), p(d) = 1/(1 + exp(a1 + a2·d)), d = ‖particle position − l_i‖.

    Parameters
    ----------
    positions_xy : numpy.ndarray
        ``(B, M, J)`` particle positions [m].
    observed_xy : array_like
        ``(B, J)`` observed reference-tag locations [m].
    a1 : float
        Offset of (6.5) [1].
    a2 : float
        Slope of (6.5) [1/m].

    Returns
    -------
    numpy.ndarray
        ``(B, M)`` log-likelihood [nats].
    """
    d = np.linalg.norm(positions_xy - np.asarray(observed_xy, float)[:, None, :], axis=-1)
    return -np.logaddexp(0.0, a1 + a2 * d)


def _positions(particles: np.ndarray) -> np.ndarray:
    return particles[..., 0::2]


def _filter_inputs(times_s, t0_s: float, initial_particles) -> tuple[np.ndarray, np.ndarray, int]:
    """``(dt (T,) [s] from t0_s to each observation, particles as float, J)`` of a filter's inputs."""
    t = np.asarray(times_s, float)
    particles = np.asarray(initial_particles, float)
    return np.diff(t, prepend=t0_s), particles, particles.shape[-1] // 2


def bernoulli_pf(times_s, observed_xy, initial_particles, *, t0_s: float, accel_var, a1: float, a2: float,
                 rng: np.random.Generator) -> ParticleFilterResult:
    """Bernoulli PF (6.5) for B runs at once on one observation sequence.

    Parameters
    ----------
    times_s : array_like
        ``(T,)`` observation instants [s].
    observed_xy : array_like
        ``(T, J)`` observed locations [m].
    initial_particles : array_like
        ``(B, M, 2J)`` draws from the prior at ``t0_s`` (state order of (6.1)).
    t0_s : float
        Time of the prior [s].
    accel_var : array_like or float
        ``(J,)`` or scalar acceleration variance q [m²/s⁴].
    a1, a2 : float
        (6.5) coefficients [1], [1/m].
    rng : numpy.random.Generator
        Propagation noise and resampling.

    Returns
    -------
    rfsim.estimators.particle.ParticleFilterResult
        MMSE over the full state.
    """
    dt, particles, n_dims = _filter_inputs(times_s, t0_s, initial_particles)
    sd = np.sqrt(np.broadcast_to(np.asarray(accel_var, float), (n_dims,)))

    def propagate(p, k, rng):
        u = rng.standard_normal(p.shape[:-1] + (n_dims,)) * sd
        out = p.copy()
        h = dt[k]
        out[..., 0::2] += h * p[..., 1::2] + 0.5 * h * h * u
        out[..., 1::2] += h * u
        return out

    obs = np.broadcast_to(np.asarray(observed_xy, float), (particles.shape[0],) + np.shape(observed_xy))
    return sir_filter(obs, particles, propagate=propagate, rng=rng,
                      log_likelihood=lambda p, y: logistic_log_likelihood(_positions(p), y, a1, a2))


def rbpf(times_s, observed_xy, initial_particles, velocity_var0, *, t0_s: float, accel_var, a1: float, a2: float,
         rng: np.random.Generator) -> ParticleFilterResult:
    """Rao-Blackwellised PF of Table 6.1 (module docstring, (6.6)–(6.20)) for B runs at once.

    Parameters
    ----------
    times_s : array_like
        ``(T,)`` observation instants [s].
    observed_xy : array_like
        ``(T, J)`` observed locations [m].
    initial_particles : array_like
        ``(B, M, 2J)``: position particles x^n drawn from the prior and, in the velocity slots,
        the prior velocity mean x^l_0 [m, m/s].
    velocity_var0 : array_like or float
        ``(J,)`` or scalar P^l_0 [m²/s²].
    t0_s : float
        Time of the prior [s].
    accel_var : array_like or float
        ``(J,)`` or scalar acceleration variance q [m²/s⁴].
    a1, a2 : float
        (6.5) coefficients [1], [1/m].
    rng : numpy.random.Generator
        Propagation noise and resampling.

    Returns
    -------
    rfsim.estimators.particle.ParticleFilterResult
        The MMSE holds x̂^n and x̂^l (the weighted Kalman means) in the order of (6.1).
    """
    dt, particles, n_dims = _filter_inputs(times_s, t0_s, initial_particles)
    q = np.broadcast_to(np.asarray(accel_var, float), (n_dims,))
    p_l = np.array(np.broadcast_to(np.asarray(velocity_var0, float), (n_dims,)))

    def propagate(p, k, rng):
        h = dt[k]
        x, v = p[..., 0::2], p[..., 1::2]
        s = h * h * p_l + h ** 4 / 4.0 * q                            # (6.14)
        x_new = x + h * v + np.sqrt(s) * rng.standard_normal(x.shape)  # (6.12)
        z = x_new - x                                                  # (6.17)
        gain = h * p_l / s                                             # (6.13)
        v_filt = v + gain * (z - h * v)                                # (6.15)
        p_l[:] = p_l - gain * h * p_l                                  # (6.16), then (6.19): Ā = −I
        out = np.empty_like(p)
        out[..., 0::2] = x_new
        out[..., 1::2] = -v_filt + (2.0 / h) * z if h > 0 else v_filt  # (6.18)
        return out

    obs = np.broadcast_to(np.asarray(observed_xy, float), (particles.shape[0],) + np.shape(observed_xy))
    return sir_filter(obs, particles, propagate=propagate, rng=rng,
                      log_likelihood=lambda p, y: logistic_log_likelihood(_positions(p), y, a1, a2))


__all__ = [
    "cv_transition",
    "cv_process_noise",
    "association",
    "proximity_kalman",
    "logistic_log_likelihood",
    "bernoulli_pf",
    "rbpf",
]

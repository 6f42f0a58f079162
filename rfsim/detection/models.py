"""Reference detection-probability models: ST-to-tag logistic (TS, RTS) and the reader
Beta-binomial (DA) model.

**ST-to-tag models** (auris-sense-a-tag.md §2.2; seed 003 L3729-3801, coefficients L3854-3873,
test cost L3900-3906). Features (seed 003 L3760-3768): ``D`` reader-antenna→tag distance [m],
``d`` tag→ST distance [m], azimuth ``θ`` = angle between the antenna (X, Z) plane and the
antenna→tag direction, elevation ``φ`` = angle between the antenna (X, Y) plane and that
direction, both in [−π/2, π/2] [rad]::

    RTS (Eq. 4.6):  p(D, d, θ, φ) = 1 / (1 + exp(a0 + a1·D + a2·d + a3·|θ| + a4·|φ|))
    TS  (Eq. 4.7):  p(d)          = 1 / (1 + exp(a0 + a1·d))

A design matrix row is ``[1, D, d, |θ|, |φ|]`` (RTS) or ``[1, d]`` (TS); a probability is
``1 / (1 + exp(x·a))`` — note the *plus* sign in the exponent: positive coefficients make the
probability fall.

**Reader DA model** (binary-detection.md §1.6; seed 004 L612-L666, dead zone L638/L838)::

    E[p](d, θ) = μ = 1 / (1 + exp(a1 + a2·d + a3·|θ|))                          (4.4)
    Var[p](d, θ) = σ² = c1 + c2·d + c3·d² + c4·|θ| + c5·θ²                       (4.6)
    p ~ Beta(α, β),  α = μ·s,  β = (1 − μ)·s,  s = μ(1 − μ)/σ² − 1               (4.5, 4.7)
    P(n | d, θ) = (1 − λ̄)·BetaBin(n; N, α, β) + λ̄·δ(n),  λ̄ = αλ/(αλ + βλ)          (4.11)

with θ in degrees (binary-detection.md §0.3, "Angle units") and d in m.

Infeasible variance (binary-detection.md §1.6.4): the Beta needs 0 < σ² < μ(1 − μ).
The seed clips σ² to 0 beyond 10 m (seed 004 L666); the polynomial is also ≤ 0 for
d ≥ 9.48 m at θ = 0. Here σ² ≤ 0 (or d > ``variance_cutoff_m``) means p is deterministic
(α, β → ∞, a plain binomial), and σ² ≥ κ·μ(1 − μ) is clipped to κ·μ(1 − μ) with κ < 1
(default 0.99), the rule suggested by the reference page.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import

stats = lazy_import("scipy.stats")
_special = lazy_import("scipy.special")

# --- ST-to-tag logistic models (seed 003 L3854-3873) -----------------------------------------
RTS_COEFFICIENTS = np.array([-1.462, 0.4941, 2.506, 0.0126, 0.0523])
"""Published RTS coefficients (a0, a1, a2, a3, a4), features (1, D [m], d [m], |θ|, |φ| [rad])
(seed 003 L3856; angle unit not printed, radians presumed)."""
TS_COEFFICIENTS = np.array([0.8970, 2.4443])
"""Published TS coefficients (a0, a1), features (1, d [m]) (seed 003 L3870-3871)."""
RTS_TEST_CROSS_ENTROPY = 0.1278
"""Published RTS cross-entropy (Eq. 4.8) on 1000 test samples (seed 003 L3904)."""
TS_TEST_CROSS_ENTROPY = 0.1502
"""Published TS cross-entropy (Eq. 4.8) on 1000 test samples (seed 003 L3904)."""

# --- reader DA model (seed 004 L666, L838) -----------------------------------------------------
DA_MEAN_COEFFICIENTS = (-3.2699, 0.4931, 0.0438)
"""(a1, a2 [1/m], a3 [1/deg]) of the mean model (4.4), least-squares fit (seed 004 L666)."""
DA_VARIANCE_COEFFICIENTS = (0.0448, 0.0057, -0.0011, 0.0004, 0.0)
"""(c1, c2 [1/m], c3 [1/m²], c4 [1/deg], c5 [1/deg²]) of the variance model (4.6) (L666)."""
DA_DEAD_ZONE = (0.1875, 3.5625)
"""(αλ, βλ) of the dead-zone probability λ ~ Beta(αλ, βλ): mean 0.05, variance 0.01 (L838)."""
DA_QUERIES_PER_ROUND = 50
"""N, queries per reader round (seed 004 L664, L699)."""


def predict_proba(features: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
    """Logistic probability ``p = 1 / (1 + exp(x·a))`` (Eqs. 4.6, 4.7 of seed 003).

    Parameters
    ----------
    features : (n, k) float64, design matrix (first column ones), see :func:`rts_design`
    coefficients : (k,) float64, (a0, ..., a_{k-1})

    Returns
    -------
    p : (n,) float64, detection probability
    """
    x = np.asarray(features, dtype=np.float64)
    a = np.asarray(coefficients, dtype=np.float64)
    if x.ndim != 2 or a.ndim != 1 or x.shape[1] != a.size:
        raise ValueError(f"features {x.shape} and coefficients {a.shape} do not match")
    return _special.expit(-(x @ a))


def rts_design(distance_reader_tag_m, distance_tag_st_m, theta_rad, phi_rad) -> np.ndarray:
    """RTS design matrix ``[1, D, d, |θ|, |φ|]`` (Eq. 4.6).

    Parameters
    ----------
    distance_reader_tag_m : array_like
        D, reader antenna → tag [m].
    distance_tag_st_m : array_like
        d, tag → ST [m].
    theta_rad, phi_rad : array_like
        Azimuth θ and elevation φ [rad] (broadcast together).

    Returns
    -------
    numpy.ndarray
        ``(n, 5) float64``.
    """
    cols = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in
                                 (distance_reader_tag_m, distance_tag_st_m, theta_rad, phi_rad)))
    big_d, small_d, theta, phi = (c.ravel() for c in cols)
    return np.column_stack([np.ones_like(big_d), big_d, small_d, np.abs(theta), np.abs(phi)])


def ts_design(distance_tag_st_m) -> np.ndarray:
    """TS design matrix ``[1, d]`` (Eq. 4.7).

    Parameters
    ----------
    distance_tag_st_m : array_like
        d, tag → ST [m].

    Returns
    -------
    numpy.ndarray
        ``(n, 2) float64``.
    """
    small_d = np.atleast_1d(np.asarray(distance_tag_st_m, dtype=np.float64)).ravel()
    return np.column_stack([np.ones_like(small_d), small_d])


def rts_probability(distance_reader_tag_m, distance_tag_st_m, theta_rad, phi_rad,
                    coefficients=RTS_COEFFICIENTS) -> np.ndarray:
    """RTS detection probability p(D, d, θ, φ) (Eq. 4.6, seed 003 L3772-3778).

    Parameters
    ----------
    distance_reader_tag_m, distance_tag_st_m : array_like
        D and d [m].
    theta_rad, phi_rad : array_like
        θ and φ [rad].
    coefficients : array_like
        ``(5,)`` (a0 … a4); default the published ones.

    Returns
    -------
    numpy.ndarray
        ``(n,) float64`` probabilities [1].
    """
    return predict_proba(rts_design(distance_reader_tag_m, distance_tag_st_m, theta_rad,
                                    phi_rad), coefficients)


def ts_probability(distance_tag_st_m, coefficients=TS_COEFFICIENTS) -> np.ndarray:
    """TS detection probability p(d) (Eq. 4.7, seed 003 L3793-3799).

    Parameters
    ----------
    distance_tag_st_m : array_like
        d [m].
    coefficients : array_like
        ``(2,)`` (a0, a1); default the published ones.

    Returns
    -------
    numpy.ndarray
        ``(n,) float64`` probabilities [1].
    """
    return predict_proba(ts_design(distance_tag_st_m), coefficients)


def st_features(tag_xyz_m, st_xyz_m, antenna_xyz_m=(0.0, 0.0, 0.0)):
    """Features (D, d, θ, φ) of the ST-to-tag models (seed 003 L3760-3768, Fig. 4.2).

    Positions are given in the reader-antenna frame: boresight +x, antenna (X, Y) plane
    horizontal, z up. The angle between a direction v and a plane with unit normal n is
    ``arcsin(n·v/|v|)``, so ``θ = arcsin(v_y/D)`` (plane X-Z) and ``φ = arcsin(v_z/D)``
    (plane X-Y), both in [−π/2, π/2], with v = tag − antenna.

    Parameters
    ----------
    tag_xyz_m, st_xyz_m : (n, 3) or (3,) float64, positions [m]
    antenna_xyz_m : (3,) float64, antenna phase centre [m]

    Returns
    -------
    distance_reader_tag_m, distance_tag_st_m, theta_rad, phi_rad : (n,) float64
    """
    tag = np.atleast_2d(np.asarray(tag_xyz_m, dtype=np.float64))
    st = np.atleast_2d(np.asarray(st_xyz_m, dtype=np.float64))
    v = tag - np.asarray(antenna_xyz_m, dtype=np.float64)
    big_d = np.linalg.norm(v, axis=1)
    if np.any(big_d <= 0.0):
        raise ValueError("tag at the antenna phase centre: angles undefined")
    small_d = np.linalg.norm(st - tag, axis=1)
    theta = np.arcsin(np.clip(v[:, 1] / big_d, -1.0, 1.0))
    phi = np.arcsin(np.clip(v[:, 2] / big_d, -1.0, 1.0))
    return big_d, small_d, theta, phi


def beta_from_moments(mean, variance, kappa: float = 0.99):
    """Beta parameters (α, β) from mean μ and variance σ² with feasibility clipping.

    ``s = μ(1−μ)/σ² − 1``, ``α = μ s``, ``β = (1−μ) s`` (binary-detection.md §1.6.4).
    σ² ≥ κ·μ(1−μ) is clipped to κ·μ(1−μ); σ² ≤ 0 gives α = β = +inf (p = μ deterministic).

    Parameters
    ----------
    mean : (...) float64 in (0, 1)
    variance : (...) float64
    kappa : float in (0, 1), upper clipping fraction of the Bernoulli variance μ(1−μ)

    Returns
    -------
    alpha, beta : (...) float64, +inf where the variance is ≤ 0
    """
    if not 0.0 < kappa < 1.0:
        raise ValueError(f"kappa must be in (0, 1), got {kappa}")
    mu, var = np.broadcast_arrays(np.asarray(mean, dtype=np.float64),
                                  np.asarray(variance, dtype=np.float64))
    bern = mu * (1.0 - mu)
    degenerate = var <= 0.0
    var_c = np.where(degenerate, 1.0, np.minimum(var, kappa * bern))
    with np.errstate(divide="ignore", invalid="ignore"):
        s = bern / var_c - 1.0
    s = np.where(degenerate, np.inf, s)
    with np.errstate(invalid="ignore"):
        alpha = np.where(degenerate, np.inf, mu * s)
        beta = np.where(degenerate, np.inf, (1.0 - mu) * s)
    return alpha, beta


@dataclass(frozen=True)
class ReaderDetectionModel:
    """DA reader detection model: Beta-distributed p with logistic mean, polynomial
    variance and a dead zone (binary-detection.md §1.6.2-1.6.3; seed 004 L612-L666, L838).

    Defaults are the published values. Angles θ are in degrees, distances d in m.

    Attributes
    ----------
    mean_coefficients : (a1, a2 [1/m], a3 [1/deg])
    variance_coefficients : (c1, c2 [1/m], c3 [1/m²], c4 [1/deg], c5 [1/deg²])
    dead_zone_alpha, dead_zone_beta : αλ, βλ of λ ~ Beta(αλ, βλ)
    variance_cutoff_m : σ² = 0 for d > this [m] (seed 004 L666: 10 m); None disables
    kappa : σ² is clipped to at most κ·μ(1−μ), κ in (0, 1)
    """

    mean_coefficients: tuple = DA_MEAN_COEFFICIENTS
    variance_coefficients: tuple = DA_VARIANCE_COEFFICIENTS
    dead_zone_alpha: float = DA_DEAD_ZONE[0]
    dead_zone_beta: float = DA_DEAD_ZONE[1]
    variance_cutoff_m: float | None = 10.0
    kappa: float = 0.99

    def __post_init__(self):
        if len(self.mean_coefficients) != 3:
            raise ConfigError("mean_coefficients", self.mean_coefficients, "3 numbers (a1, a2, a3)")
        if len(self.variance_coefficients) != 5:
            raise ConfigError("variance_coefficients", self.variance_coefficients,
                              "5 numbers (c1..c5)")
        for key in ("dead_zone_alpha", "dead_zone_beta"):
            if not getattr(self, key) > 0.0:
                raise ConfigError(key, getattr(self, key), "a number > 0")
        if not 0.0 < self.kappa < 1.0:
            raise ConfigError("kappa", self.kappa, "a number in (0, 1)")
        if self.variance_cutoff_m is not None and not self.variance_cutoff_m > 0.0:
            raise ConfigError("variance_cutoff_m", self.variance_cutoff_m, "a number > 0 or None")

    @property
    def dead_zone_mean(self) -> float:
        """λ̄ = αλ / (αλ + βλ), the probability of the dead-zone event (n = 0)."""
        return self.dead_zone_alpha / (self.dead_zone_alpha + self.dead_zone_beta)

    def mean(self, distance_m, theta_deg) -> np.ndarray:
        """E[p](d, θ) = 1 / (1 + exp(a1 + a2·d + a3·|θ|)) (4.4), without the dead zone.

        Parameters
        ----------
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast.

        Returns
        -------
        numpy.ndarray
            μ [1].
        """
        a1, a2, a3 = self.mean_coefficients
        d, th = np.broadcast_arrays(np.asarray(distance_m, float), np.asarray(theta_deg, float))
        return _special.expit(-(a1 + a2 * d + a3 * np.abs(th)))

    def raw_variance(self, distance_m, theta_deg) -> np.ndarray:
        """σ²(d, θ) = c1 + c2·d + c3·d² + c4·|θ| + c5·θ² (4.6), unclipped.

        Parameters
        ----------
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast.

        Returns
        -------
        numpy.ndarray
            σ² [1].
        """
        c1, c2, c3, c4, c5 = self.variance_coefficients
        d, th = np.broadcast_arrays(np.asarray(distance_m, float), np.asarray(theta_deg, float))
        return c1 + c2 * d + c3 * d * d + c4 * np.abs(th) + c5 * th * th

    def variance(self, distance_m, theta_deg) -> np.ndarray:
        """Var[p] after clipping: 0 where σ² ≤ 0 or d > cutoff; at most κ·μ(1−μ).

        Parameters
        ----------
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast.

        Returns
        -------
        numpy.ndarray
            Clipped σ² [1].
        """
        d, th = np.broadcast_arrays(np.asarray(distance_m, float), np.asarray(theta_deg, float))
        var = self.raw_variance(d, th)
        if self.variance_cutoff_m is not None:
            var = np.where(d > self.variance_cutoff_m, 0.0, var)
        mu = self.mean(d, th)
        return np.clip(var, 0.0, self.kappa * mu * (1.0 - mu))

    def feasible(self, distance_m, theta_deg) -> np.ndarray:
        """True where the unclipped σ² satisfies 0 < σ² < μ(1−μ) (no clipping needed).

        Parameters
        ----------
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast.

        Returns
        -------
        numpy.ndarray
            bool.
        """
        var = self.raw_variance(distance_m, theta_deg)
        mu = self.mean(distance_m, theta_deg)
        return (var > 0.0) & (var < mu * (1.0 - mu))

    def beta_params(self, distance_m, theta_deg):
        """(α, β) of the Beta law of p (4.5, 4.7) after clipping.

        Parameters
        ----------
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast.

        Returns
        -------
        alpha, beta : numpy.ndarray
            Beta parameters [1], +inf where σ² = 0.
        """
        mu = self.mean(distance_m, theta_deg)
        var = self.variance(distance_m, theta_deg)
        return beta_from_moments(mu, var, kappa=1.0 - 1e-12)

    def pmf(self, n_reads, n_queries: int, distance_m, theta_deg) -> np.ndarray:
        """P(n | d, θ) of Eq. (4.11): (1 − λ̄)·BetaBin(n; N, α, β) + λ̄·δ(n).

        Where σ² = 0 the Beta-binomial is replaced by Binomial(N, μ).

        Parameters
        ----------
        n_reads : (...) int, number of reads n in [0, N]
        n_queries : int, N
        distance_m, theta_deg : (...) float64, broadcast with ``n_reads``

        Returns
        -------
        (...) float64
        """
        n, d, th = np.broadcast_arrays(np.asarray(n_reads), np.asarray(distance_m, float),
                                       np.asarray(theta_deg, float))
        return np.exp(self.logpmf(n, n_queries, d, th))

    def logpmf(self, n_reads, n_queries: int, distance_m, theta_deg) -> np.ndarray:
        """log P(n | d, θ) of Eq. (4.11), see :meth:`pmf`.

        Parameters
        ----------
        n_reads : array_like of int
            n in [0, N].
        n_queries : int
            N.
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast with ``n_reads``.

        Returns
        -------
        numpy.ndarray
            Log-probabilities [nat].
        """
        n, d, th = np.broadcast_arrays(np.asarray(n_reads), np.asarray(distance_m, float),
                                       np.asarray(theta_deg, float))
        mu = self.mean(d, th)
        alpha, beta = self.beta_params(d, th)
        return mixture_logpmf(n, n_queries, mu, alpha, beta, self.dead_zone_mean)

    def cdf(self, n_reads, n_queries: int, distance_m, theta_deg) -> np.ndarray:
        """P(n' ≤ n | d, θ) under Eq. (4.11), for scalar d and θ.

        Parameters
        ----------
        n_reads : array_like of int
            n in [0, N].
        n_queries : int
            N.
        distance_m : float
            d [m].
        theta_deg : float
            θ [deg].

        Returns
        -------
        numpy.ndarray
            Probabilities [1], shape of ``n_reads``.
        """
        k = np.arange(n_queries + 1)
        pmf = self.pmf(k, n_queries, distance_m, theta_deg)
        return np.cumsum(pmf)[np.asarray(n_reads)]

    def prob_no_read(self, n_queries: int, distance_m, theta_deg) -> np.ndarray:
        """P(n = 0 | d, θ), Eq. (4.11) at n = 0.

        Parameters
        ----------
        n_queries : int
            N.
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast.

        Returns
        -------
        numpy.ndarray
            Probabilities [1].
        """
        return self.pmf(0, n_queries, distance_m, theta_deg)

    def expected_reads(self, n_queries: int, distance_m, theta_deg) -> np.ndarray:
        """E[n | d, θ] = N·(1 − λ̄)·μ(d, θ).

        Parameters
        ----------
        n_queries : int
            N.
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast.

        Returns
        -------
        numpy.ndarray
            Expected reads.
        """
        return n_queries * (1.0 - self.dead_zone_mean) * self.mean(distance_m, theta_deg)

    def d50(self, theta_deg) -> np.ndarray:
        """Distance where E[p] = 1/2: d50 = (−a1 − a3·|θ|)/a2.

        Parameters
        ----------
        theta_deg : array_like
            θ [deg].

        Returns
        -------
        numpy.ndarray
            d50 [m] (negative: never reached).
        """
        a1, a2, a3 = self.mean_coefficients
        return (-a1 - a3 * np.abs(np.asarray(theta_deg, float))) / a2

    def sample_reads(self, n_queries: int, distance_m, theta_deg, *,
                     rng: np.random.Generator) -> np.ndarray:
        """Draw read counts from the hierarchy of Eq. (4.11).

        λ ~ Beta(αλ, βλ), dead ~ Bernoulli(λ), p ~ Beta(α, β) (p = μ where σ² = 0),
        n ~ Binomial(N, p), n = 0 if dead.

        Parameters
        ----------
        n_queries : int
            N.
        distance_m, theta_deg : array_like
            d [m] and θ [deg], broadcast.
        rng : numpy.random.Generator
            The draws.

        Returns
        -------
        numpy.ndarray
            int64 reads, shape of the broadcast (d, θ).
        """
        d, th = np.broadcast_arrays(np.asarray(distance_m, float), np.asarray(theta_deg, float))
        mu = self.mean(d, th)
        alpha, beta = self.beta_params(d, th)
        finite = np.isfinite(alpha)
        p = mu.copy()
        p[finite] = rng.beta(alpha[finite], beta[finite])
        lam = rng.beta(self.dead_zone_alpha, self.dead_zone_beta, size=d.shape)
        dead = rng.random(d.shape) < lam
        n = rng.binomial(n_queries, p)
        return np.where(dead, 0, n).astype(np.int64)


def mixture_logpmf(n_reads, n_queries, mean, alpha, beta, dead_zone_mean) -> np.ndarray:
    """log[(1 − λ̄)·BetaBin(n; N, α, β) + λ̄·δ(n)] (Eq. 4.11), elementwise.

    ``log BetaBin = log C(N, n) + log B(n + α, N − n + β) − log B(α, β)`` with log-Γ based
    Beta functions (binary-detection.md §0.3, erratum to Eq. 4.10). Where α + β > 1e10 or α is
    infinite (σ² ≈ 0) Binomial(N, ``mean``) is used instead.

    Parameters
    ----------
    n_reads, n_queries : array_like of int
        n and N (broadcast).
    mean, alpha, beta : array_like
        μ and the Beta parameters [1].
    dead_zone_mean : float
        λ̄ in [0, 1).

    Returns
    -------
    numpy.ndarray
        Log-probabilities [nat], shape of the broadcast.
    """
    n, nq, mu, a, b = np.broadcast_arrays(np.asarray(n_reads), np.asarray(n_queries),
                                          np.asarray(mean, float), np.asarray(alpha, float),
                                          np.asarray(beta, float))
    shape = n.shape
    n, nq, mu, a, b = (np.ravel(v) for v in (n.astype(np.float64), nq.astype(np.float64),
                                             mu, a, b))
    log_comb = _special.gammaln(nq + 1.0) - _special.gammaln(n + 1.0) - _special.gammaln(nq - n + 1.0)
    near_binomial = ~np.isfinite(a) | ~(a + b <= 1e10)
    bb = ~near_binomial
    log_core = np.empty(n.shape, dtype=np.float64)
    log_core[bb] = (log_comb[bb] + _special.betaln(n[bb] + a[bb], nq[bb] - n[bb] + b[bb])
                    - _special.betaln(a[bb], b[bb]))
    nb = near_binomial
    log_core[nb] = stats.binom.logpmf(n[nb], nq[nb], mu[nb]) if np.any(nb) else 0.0
    lam = float(dead_zone_mean)
    if lam <= 0.0:
        return log_core.reshape(shape)
    out = np.log1p(-lam) + log_core
    zero = n == 0
    out[zero] = np.logaddexp(out[zero], np.log(lam))
    return out.reshape(shape)


PUBLISHED_READER_MODEL = ReaderDetectionModel()
"""The DA model with the published coefficients (seed 004 L666, L838)."""

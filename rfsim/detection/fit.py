"""Maximum-likelihood fitting of the detection-probability models, cross-entropy, and binned
empirical probabilities with Wilson intervals.

* Logistic regression (TS/RTS, auris-sense-a-tag.md §2.2; seed 003 Eq. 4.8, L3846-3852) in the
  sign convention ``p = 1/(1 + exp(x·a))``, by Newton-Raphson (IRLS) with step halving.
  Log-likelihood of k successes out of m trials per row:
  ``ℓ(a) = Σ k log p + (m − k) log(1 − p)``, gradient ``∂ℓ/∂a = Xᵀ(m p − k)``, Fisher
  information ``I = Xᵀ diag(m p (1 − p)) X``; standard errors ``sqrt(diag(I⁻¹))``.
  :func:`fit_logistic_gradient_descent`: the same cost by a fixed number of gradient-descent
  steps from zero (the source's method, L3854; not converged when stopped early).
* Beta-binomial DA model (binary-detection.md §1.6; seed 004 Eqs. 4.4-4.11): per-cell
  least-squares moment fit (the method of seed 004 L666) and the maximum-likelihood fit of
  (a1, a2, a3, c1..c5, λ̄) on the read counts, with standard errors from the inverse of the
  observed information (numerical Hessian of the negative log-likelihood).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.detection.models import (DA_DEAD_ZONE, ReaderDetectionModel, mixture_logpmf)
from rfsim.core.errors import UserError
from rfsim.core.lazy import lazy_import

optimize = lazy_import("scipy.optimize")
_special = lazy_import("scipy.special")


# --- logistic regression ---------------------------------------------------------------------
@dataclass(frozen=True)
class LogisticFit:
    """Result of :func:`fit_logistic`.

    Attributes
    ----------
    coefficients : (k,) float64, a in ``p = 1/(1 + exp(x·a))``
    stderr : (k,) float64, sqrt(diag(I⁻¹))
    covariance : (k, k) float64, inverse Fisher information at the estimate
    log_likelihood : float, ℓ at the estimate [nat]
    n_iter : int, Newton iterations
    n_samples : int, number of rows
    """

    coefficients: np.ndarray
    stderr: np.ndarray
    covariance: np.ndarray
    log_likelihood: float
    n_iter: int
    n_samples: int

    def predict_proba(self, features) -> np.ndarray:
        """p = 1/(1 + exp(x·a)) of the fitted model for a design matrix.

        Parameters
        ----------
        features : array_like
            ``(n, k)`` design matrix x.

        Returns
        -------
        numpy.ndarray
            ``(n,) float64`` probabilities [1].
        """
        return _special.expit(-(np.asarray(features, float) @ self.coefficients))

    def cross_entropy(self, features, y) -> float:
        """Eq. (4.8) of the fitted model on (features, y).

        Parameters
        ----------
        features : array_like
            ``(n, k)`` design matrix x.
        y : array_like
            ``(n,)`` outcomes {0, 1}.

        Returns
        -------
        float
            Mean cross-entropy [nat per sample].
        """
        return cross_entropy_logits(np.asarray(features, float) @ self.coefficients, y)


def cross_entropy_logits(z, y) -> float:
    """Mean cross-entropy (Eq. 4.8) for p = 1/(1 + exp(z)), computed stably.

    ``−log p = softplus(z)`` and ``−log(1 − p) = softplus(z) − z``, so the per-sample loss is
    ``softplus(z) − (1 − y)·z``.

    Parameters
    ----------
    z : array_like
        ``(m,)`` logits z = x·a.
    y : array_like
        ``(m,)`` outcomes {0, 1}.

    Returns
    -------
    float
        Mean cross-entropy [nat].
    """
    z = np.asarray(z, float)
    y = np.asarray(y, float)
    return float(np.mean(np.logaddexp(0.0, z) - (1.0 - y) * z))


def cross_entropy(y, p) -> float:
    """Mean cross-entropy J = (1/m) Σ −y log p − (1 − y) log(1 − p) (Eq. 4.8).

    Parameters
    ----------
    y : array_like
        ``(m,)`` outcomes {0, 1}.
    p : array_like
        ``(m,) float64`` predicted probabilities in (0, 1) (a 0 or 1 prediction contradicted
        by the outcome gives +inf).

    Returns
    -------
    float
        J [nat].
    """
    y = np.asarray(y, float)
    p = np.asarray(p, float)
    with np.errstate(divide="ignore"):
        terms = -np.where(y > 0, np.log(p), 0.0) - np.where(y < 1, np.log1p(-p), 0.0)
    return float(np.mean(terms))


def expected_cross_entropy(p):
    """Mean and standard deviation of the cross-entropy of the *true* model.

    On m independent outcomes y_i ~ Bernoulli(p_i), given the p_i:
    ``E[J] = (1/m) Σ H(p_i)`` with H the binary entropy [nat];
    ``Var[J] = (1/m²) Σ p_i (1 − p_i) (log(p_i/(1 − p_i)))²``.

    Parameters
    ----------
    p : array_like
        ``(m,)`` true probabilities [1].

    Returns
    -------
    mean, std : float
        [nat].
    """
    p = np.asarray(p, float)
    m = p.size
    # log p as scipy.stats.bernoulli.logpmf(1, p) forms it (xlogy(1, p); -inf at p = 0, no warning)
    h = -(_special.xlogy(1.0, p) * p + np.log1p(-p) * (1.0 - p))
    var = np.sum(p * (1.0 - p) * _special.logit(p) ** 2) / m ** 2
    return float(np.mean(h)), float(np.sqrt(var))


def fit_logistic(features, successes, trials=1, *, max_iter: int = 100,
                 tol: float = 1e-10) -> LogisticFit:
    """Maximum-likelihood logistic regression ``p = 1/(1 + exp(x·a))`` by Newton-Raphson.

    Parameters
    ----------
    features : (n, k) float64, design matrix (first column ones)
    successes : (n,) int or {0, 1}, k_i detections
    trials : (n,) int or scalar, m_i trials per row (1 for binary outcomes)
    max_iter : int, Newton iterations before giving up
    tol : float, stop when the largest |Δa| < tol

    Returns
    -------
    LogisticFit

    Raises
    ------
    UserError
        If the likelihood has no finite maximum (perfectly separated data) or the Fisher
        information is singular (collinear features).
    """
    x = np.asarray(features, float)
    k = np.asarray(successes, float)
    m = np.broadcast_to(np.asarray(trials, float), k.shape)
    if x.ndim != 2 or x.shape[0] != k.size:
        raise ValueError(f"features {x.shape} and successes {k.shape} do not match")
    if np.any((k < 0) | (k > m)):
        raise UserError("successes must lie in [0, trials]")

    def loglik(a):
        z = x @ a
        return float(np.sum(-k * np.logaddexp(0.0, z) - (m - k) * np.logaddexp(0.0, -z)))

    a = np.zeros(x.shape[1])
    ll = loglik(a)
    for it in range(1, max_iter + 1):
        p = _special.expit(-(x @ a))
        grad = x.T @ (m * p - k)          # ∂ℓ/∂a, since ∂ℓ/∂z = m p − k
        info = (x * (m * p * (1.0 - p))[:, None]).T @ x      # −∂²ℓ/∂a²
        try:
            step = np.linalg.solve(info, grad)
        except np.linalg.LinAlgError:
            raise UserError("logistic fit: singular Fisher information (collinear features "
                            "or separated data)") from None
        new, t = a + step, 1.0
        ll_new = loglik(new)
        while ll_new < ll - 1e-12 * abs(ll) and t > 1e-8:
            t *= 0.5
            new = a + t * step
            ll_new = loglik(new)
        if np.max(np.abs(new)) > 1e6:
            raise UserError("logistic fit diverges (perfectly separated data)")
        done = np.max(np.abs(new - a)) < tol
        a, ll = new, ll_new
        if done:
            break
    else:
        raise UserError(f"logistic fit did not converge in {max_iter} iterations "
                        "(separated data?)")
    p = _special.expit(-(x @ a))
    info = (x * (m * p * (1.0 - p))[:, None]).T @ x
    try:
        cov = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        raise UserError("logistic fit: singular Fisher information at the estimate") from None
    return LogisticFit(coefficients=a, stderr=np.sqrt(np.diag(cov)), covariance=cov,
                       log_likelihood=ll, n_iter=it, n_samples=x.shape[0])


def fit_logistic_gradient_descent(features, outcomes, *, learning_rate: float,
                                  iterations: int) -> np.ndarray:
    """Logistic regression ``p = 1/(1 + exp(x·a))`` by batch gradient descent on Eq. (4.8).

    The method the source names for its fits (seed 003 L3854, "We apply gradient descent
    method"; its learning rate, iterations and start are not given): a ← a − α ∇J(a) with
    J the mean cross-entropy of Eq. (4.8), ``∇J = (1/m) xᵀ(y − p)``, from a = 0, a fixed
    number of steps and no feature scaling. Stopped before convergence it is the ML fit
    shrunk towards zero along the directions of small curvature (for small α it depends on
    α·iterations only).

    Parameters
    ----------
    features : array_like
        ``(m, k)`` design matrix x (first column ones).
    outcomes : array_like
        ``(m,)`` outcomes y ∈ {0, 1}.
    learning_rate : float
        Step size α [1].
    iterations : int
        Number of steps.

    Returns
    -------
    numpy.ndarray
        ``(k,) float64`` coefficients a after ``iterations`` steps.
    """
    x = np.asarray(features, float)
    y = np.asarray(outcomes, float)
    a = np.zeros(x.shape[1])
    for _ in range(int(iterations)):
        a -= learning_rate * (x.T @ (y - _special.expit(-(x @ a)))) / y.size
    return a


# --- reader DA model (Beta-binomial) ---------------------------------------------------------
DA_PARAMETER_NAMES = ("a1", "a2", "a3", "c1", "c2", "c3", "c4", "c5", "dead_zone_mean")
"""Parameter order of :class:`ReaderModelFit` (θ in degrees, d in m)."""
_DA_SCALE = np.array([1.0, 0.1, 0.01, 0.01, 0.01, 1e-3, 1e-3, 1e-5, 1.0])
"""Typical magnitudes used to condition the optimiser (the last entry is logit λ̄)."""
_DEAD_ZONE_CONCENTRATION = DA_DEAD_ZONE[0] + DA_DEAD_ZONE[1]


@dataclass(frozen=True)
class ReaderModelFit:
    """Result of :func:`fit_reader_moments` or :func:`fit_reader_mle`.

    Attributes
    ----------
    model : ReaderDetectionModel with the fitted coefficients
    estimates : (9,) float64, in the order of ``DA_PARAMETER_NAMES``
    stderr : (9,) float64, NaN for parameters held fixed
    covariance : (9, 9) float64, NaN rows/columns for fixed parameters
    log_likelihood : float, Σ log P(n_i | d_i, θ_i) of Eq. (4.11) at the estimate [nat]
    method : "moments" or "mle"
    n_trials : int, number of (d, θ, n, N) repetitions used
    stderr_basis : "full" (inverse of the whole information matrix), "mean block" (the
        maximum lies on the edge of the feasible region — σ² pushed to 0+ in a cell, where the
        Beta-binomial turns binomial and the likelihood falls by tens of nats within a step
        of the finite differences, or λ̄ → 0 — so the whole matrix is not positive definite: the standard errors of a1, a2, a3 are those of the mean block of the
        observed information, conditional on the variance and dead-zone estimates; the others
        are NaN) or "least squares" (moments)
    """

    model: ReaderDetectionModel
    estimates: np.ndarray
    stderr: np.ndarray
    covariance: np.ndarray
    log_likelihood: float
    method: str
    n_trials: int
    parameter_names: tuple = DA_PARAMETER_NAMES
    stderr_basis: str = "full"

    def as_dict(self) -> dict:
        """The estimates and standard errors by parameter name.

        Returns
        -------
        dict of str to tuple of float
            ``{name: (estimate, stderr)}`` in the units of :data:`DA_PARAMETER_NAMES`.
        """
        return {k: (float(e), float(s)) for k, e, s in
                zip(self.parameter_names, self.estimates, self.stderr)}


def _as_trials(distance_m, theta_deg, n_reads, n_queries):
    d, th, n, nq = np.broadcast_arrays(np.asarray(distance_m, float),
                                       np.asarray(theta_deg, float),
                                       np.asarray(n_reads), np.asarray(n_queries))
    d, th, n, nq = (v.ravel() for v in (d, th, n, nq))
    if d.size == 0:
        raise UserError("no trials to fit")
    if np.any((n < 0) | (n > nq)) or np.any(nq < 1):
        raise UserError("read counts must lie in [0, N] with N ≥ 1")
    return d, th, n.astype(np.int64), nq.astype(np.int64)


def _model_from(params, dead_zone_concentration, variance_cutoff_m, kappa):
    lam = float(np.clip(params[8], 1e-12, 1.0 - 1e-12))
    return ReaderDetectionModel(mean_coefficients=tuple(float(v) for v in params[:3]),
                                variance_coefficients=tuple(float(v) for v in params[3:8]),
                                dead_zone_alpha=lam * dead_zone_concentration,
                                dead_zone_beta=(1.0 - lam) * dead_zone_concentration,
                                variance_cutoff_m=variance_cutoff_m, kappa=kappa)


def log_likelihood_reader(model: ReaderDetectionModel, d, th, n, nq, lam) -> float:
    """Eq. 4.11 log-likelihood of read counts under a DA model with a dead-zone mean.

    Parameters
    ----------
    model : ReaderDetectionModel
        The DA model.
    d : array_like
        Distances [m].
    th : array_like
        Angles θ [deg].
    n : array_like
        Reads per trial.
    nq : array_like
        Queries per trial.
    lam : float
        Dead-zone mean λ̄ [1].

    Returns
    -------
    float
        Log-likelihood [nat].
    """
    mu = model.mean(d, th)
    alpha, beta = model.beta_params(d, th)
    return float(np.sum(mixture_logpmf(n, nq, mu, alpha, beta, lam)))


def fit_reader_moments(distance_m, theta_deg, n_reads, n_queries, *,
                       binomial_correction: bool = True,
                       dead_zone=DA_DEAD_ZONE) -> ReaderModelFit:
    """Least-squares fit of the DA mean (4.4) and variance (4.6) models to the per-cell
    mean and variance of p̂ = n/N over repetitions (the method of seed 004 L666).

    Cells are the distinct (d, θ) pairs. The mean coefficients minimise
    Σ_cells (p̄ − μ(d, θ))² (``scipy.optimize.least_squares``, started from a binomial
    logistic fit); the variance coefficients are the linear least-squares fit of the cell
    variances (ddof = 1) on [1, d, d², |θ|, θ²]. With ``binomial_correction`` the sampling
    part is removed first: Var(p̂) = σ²(1 − 1/N) + μ(1 − μ)/N, so
    σ̂² = (Var(p̂) − p̄(1 − p̄)/N)/(1 − 1/N). Standard errors are the usual least-squares ones
    (residual variance × (JᵀJ)⁻¹). The dead zone is not estimated (``dead_zone`` = (αλ, βλ) is
    put into the returned model); λ̄ has NaN standard error.

    Parameters
    ----------
    distance_m, theta_deg : (n,) float64, d [m] and θ [deg] of each repetition
    n_reads : (n,) int, reads n out of ``n_queries``
    n_queries : (n,) int or int, N (the same within a cell)
    binomial_correction : bool, subtract the binomial sampling variance
    dead_zone : (αλ, βλ) for the returned model

    Returns
    -------
    ReaderModelFit with ``method == "moments"``
    """
    d, th, n, nq = _as_trials(distance_m, theta_deg, n_reads, n_queries)
    cells, inverse, counts = np.unique(np.column_stack([d, th]), axis=0, return_inverse=True,
                                       return_counts=True)
    inverse = inverse.ravel()
    if np.any(counts < 2):
        raise UserError("every (d, θ) cell needs at least 2 repetitions for a variance")
    p_hat = n / nq
    mean_c = np.bincount(inverse, p_hat) / counts
    var_c = np.bincount(inverse, (p_hat - mean_c[inverse]) ** 2) / (counts - 1)
    nq_c = np.bincount(inverse, nq) / counts
    cd, cth = cells[:, 0], np.abs(cells[:, 1])
    if binomial_correction:
        var_c = (var_c - mean_c * (1.0 - mean_c) / nq_c) / (1.0 - 1.0 / nq_c)

    x_mean = np.column_stack([np.ones_like(cd), cd, cth])
    start = fit_logistic(x_mean, np.bincount(inverse, n), np.bincount(inverse, nq)).coefficients
    res = optimize.least_squares(lambda a: _special.expit(-(x_mean @ a)) - mean_c, start,
                                 jac=lambda a: -(_special.expit(-(x_mean @ a)) *
                                                 _special.expit(x_mean @ a))[:, None] * x_mean)
    dof_mean = max(cells.shape[0] - 3, 1)
    cov_a = 2.0 * res.cost / dof_mean * np.linalg.inv(res.jac.T @ res.jac)

    x_var = np.column_stack([np.ones_like(cd), cd, cd * cd, cth, cth * cth])
    c, *_ = np.linalg.lstsq(x_var, var_c, rcond=None)
    resid = var_c - x_var @ c
    dof_var = max(cells.shape[0] - 5, 1)
    cov_c = resid @ resid / dof_var * np.linalg.pinv(x_var.T @ x_var)

    lam = dead_zone[0] / (dead_zone[0] + dead_zone[1])
    est = np.concatenate([res.x, c, [lam]])
    cov = np.full((9, 9), np.nan)
    cov[:3, :3], cov[3:8, 3:8] = cov_a, cov_c
    model = ReaderDetectionModel(mean_coefficients=tuple(float(v) for v in res.x),
                                 variance_coefficients=tuple(float(v) for v in c),
                                 dead_zone_alpha=float(dead_zone[0]),
                                 dead_zone_beta=float(dead_zone[1]), variance_cutoff_m=None)
    return ReaderModelFit(model=model, estimates=est, stderr=np.sqrt(np.diag(cov)),
                          covariance=cov,
                          log_likelihood=log_likelihood_reader(model, d, th, n, nq, lam),
                          method="moments", n_trials=d.size, stderr_basis="least squares")


def _numerical_hessian(f, x, h):
    """Central-difference Hessian of f at x with per-coordinate steps h."""
    k = x.size
    hess = np.empty((k, k))
    f0 = f(x)
    e = np.diag(h)
    for i in range(k):
        hess[i, i] = (f(x + e[i]) - 2.0 * f0 + f(x - e[i])) / h[i] ** 2
        for j in range(i):
            hess[i, j] = hess[j, i] = (f(x + e[i] + e[j]) - f(x + e[i] - e[j])
                                       - f(x - e[i] + e[j]) + f(x - e[i] - e[j])) / (
                4.0 * h[i] * h[j])
    return hess


def fit_reader_mle(distance_m, theta_deg, n_reads, n_queries, *, fit_dead_zone: bool = True,
                   start: ReaderDetectionModel | None = None,
                   variance_cutoff_m: float | None = None,
                   kappa: float = 0.99) -> ReaderModelFit:
    """Maximum-likelihood fit of the DA Beta-binomial model (Eq. 4.11) to read counts.

    Maximises ℓ = Σ_i log[(1 − λ̄)·BetaBin(n_i; N_i, α_i, β_i) + λ̄·δ(n_i)] over
    (a1, a2, a3, c1..c5) and, with ``fit_dead_zone``, λ̄ (only the mean of the dead-zone
    Beta is identifiable from counts; the returned model keeps αλ + βλ = 3.75 of the published
    values). The variance is clipped as in :class:`ReaderDetectionModel` (0 below, κ·μ(1−μ)
    above), so parameters are only informed by cells in the feasible region. BFGS on
    rescaled parameters, started from ``start`` or from :func:`fit_reader_moments`. Standard
    errors: sqrt(diag(H⁻¹)), H the central-difference Hessian of −ℓ (observed information);
    of the mean block of H only when the maximum lies on the feasible region's edge
    (:attr:`ReaderModelFit.stderr_basis`).

    Parameters
    ----------
    distance_m, theta_deg : (n,) float64, d [m] and θ [deg] of each repetition
    n_reads : (n,) int, reads
    n_queries : (n,) int or int, N
    fit_dead_zone : bool, estimate λ̄ (else keep the start model's λ̄)
    start : ReaderDetectionModel or None, starting point
    variance_cutoff_m : float or None, σ² = 0 beyond this distance in the fitted model
    kappa : float in (0, 1), upper variance clip fraction

    Returns
    -------
    ReaderModelFit with ``method == "mle"``

    Raises
    ------
    UserError
        If the optimiser fails or the information matrix is not positive definite.
    """
    d, th, n, nq = _as_trials(distance_m, theta_deg, n_reads, n_queries)
    if start is None:
        try:
            start = fit_reader_moments(d, th, n, nq).model
        except UserError:
            start = ReaderDetectionModel(variance_cutoff_m=None)
    x0 = np.array([*start.mean_coefficients, *start.variance_coefficients,
                   start.dead_zone_mean])
    free = np.ones(9, dtype=bool)
    free[8] = fit_dead_zone
    # optimise u = (a, c)/scale and logit(λ̄)
    u0 = x0 / _DA_SCALE
    u0[8] = _special.logit(np.clip(x0[8], 1e-6, 1.0 - 1e-6))

    def params_of(u_free):
        u = u0.copy()
        u[free] = u_free
        p = u * _DA_SCALE
        p[8] = _special.expit(u[8])
        return p

    def nll(u_free):
        p = params_of(u_free)
        model = _model_from(p, _DEAD_ZONE_CONCENTRATION, variance_cutoff_m, kappa)
        value = -log_likelihood_reader(model, d, th, n, nq, p[8])
        return value if np.isfinite(value) else 1e300

    res = optimize.minimize(nll, u0[free], method="BFGS", jac="3-point",
                            options={"gtol": 1e-5, "maxiter": 2000})
    if not np.isfinite(res.fun) or res.fun >= 1e300:
        raise UserError(f"Beta-binomial fit failed: {res.message}")
    u_hat = res.x
    hess = _numerical_hessian(nll, u_hat, np.full(u_hat.size, 1e-3))
    basis = "full"
    try:
        cov_u = np.linalg.inv(hess)
        regular = bool(np.all(np.linalg.eigvalsh(hess) > 0))
    except np.linalg.LinAlgError:
        regular = False
    if not regular:
        # maximum on the edge of the feasible region (docstring of ReaderModelFit): the
        # mean coefficients' standard errors from their block of the observed information
        block = hess[:3, :3]
        if not np.all(np.linalg.eigvalsh(block) > 0):
            raise UserError("Beta-binomial fit: information matrix not positive definite "
                            "(also its mean block)")
        cov_u = np.full_like(hess, np.nan)
        cov_u[:3, :3] = np.linalg.inv(block)
        basis = "mean block"
    p_hat = params_of(u_hat)
    # Jacobian of p with respect to the free u: scale, or λ̄(1 − λ̄) for logit λ̄
    jac = (_DA_SCALE.copy())
    jac[8] = p_hat[8] * (1.0 - p_hat[8])
    jac = jac[free]
    cov = np.full((9, 9), np.nan)
    cov[np.ix_(free, free)] = cov_u * np.outer(jac, jac)
    model = _model_from(p_hat, _DEAD_ZONE_CONCENTRATION, variance_cutoff_m, kappa)
    return ReaderModelFit(model=model, estimates=p_hat, stderr=np.sqrt(np.diag(cov)),
                          covariance=cov, log_likelihood=-float(res.fun), method="mle",
                          n_trials=d.size, stderr_basis=basis)


# --- binned empirical probabilities ----------------------------------------------------------
def wilson_interval(successes, trials, confidence: float = 0.95):
    """Wilson score interval for a binomial proportion (no continuity correction).

    ``(p̂ + z²/2n ± z·sqrt(p̂(1 − p̂)/n + z²/4n²)) / (1 + z²/n)``, z = Φ⁻¹((1 + confidence)/2).

    Parameters
    ----------
    successes, trials : (...) int, k and n (n = 0 gives NaN)
    confidence : float in (0, 1)

    Returns
    -------
    lower, upper : (...) float64
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    k = np.asarray(successes, float)
    n = np.asarray(trials, float)
    z = _special.ndtri(0.5 + confidence / 2.0)  # Φ⁻¹ (what scipy.stats.norm.ppf evaluates)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = k / n
        denom = 1.0 + z * z / n
        centre = (p + z * z / (2.0 * n)) / denom
        half = z * np.sqrt(p * (1.0 - p) / n + z * z / (4.0 * n * n)) / denom
    return np.clip(centre - half, 0.0, 1.0), np.clip(centre + half, 0.0, 1.0)


@dataclass(frozen=True)
class BinnedProbability:
    """Binned empirical detection probability (see :func:`binned_probability`).

    Attributes: ``edges`` (b+1,), and per bin (b,): ``centers``, ``trials``, ``successes``,
    ``p_hat`` (NaN in empty bins), ``lower``/``upper`` (Wilson interval, NaN in empty bins).
    """

    edges: np.ndarray
    centers: np.ndarray
    trials: np.ndarray
    successes: np.ndarray
    p_hat: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


def binned_probability(x, y, edges, *, confidence: float = 0.95) -> BinnedProbability:
    """Empirical P(y = 1) in bins of x with Wilson intervals.

    For plots like seed 003 Fig. 4.7: D in 0.3 m bins, d in 0.2 m bins, L3877-3897.

    Parameters
    ----------
    x : array_like
        ``(m,) float64`` binning variable (samples outside ``edges`` are dropped).
    y : array_like
        ``(m,)`` outcomes {0, 1}.
    edges : array_like
        ``(b+1,) float64`` increasing bin edges; bins are [e_i, e_{i+1}), the last closed.
    confidence : float
        Wilson interval level.

    Returns
    -------
    BinnedProbability
        Per bin: centres, trials, successes, p̂ and Wilson interval (NaN in empty bins).

    Raises
    ------
    ValueError
        If x and y differ in length or ``edges`` are not increasing with at least 2 entries.
    """
    x = np.asarray(x, float).ravel()
    y = np.asarray(y, float).ravel()
    edges = np.asarray(edges, float)
    if x.shape != y.shape:
        raise ValueError("x and y differ in length")
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
        raise ValueError("edges must be increasing with at least 2 entries")
    trials, _ = np.histogram(x, bins=edges)
    successes, _ = np.histogram(x, bins=edges, weights=y)
    successes = np.rint(successes).astype(np.int64)
    with np.errstate(divide="ignore", invalid="ignore"):
        p_hat = successes / trials
    lower, upper = wilson_interval(successes, trials, confidence)
    empty = trials == 0
    p_hat[empty] = lower[empty] = upper[empty] = np.nan
    return BinnedProbability(edges=edges, centers=0.5 * (edges[:-1] + edges[1:]),
                             trials=trials, successes=successes, p_hat=p_hat, lower=lower,
                             upper=upper)

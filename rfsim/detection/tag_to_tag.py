"""The tag-to-tag detection model of the reader-free network (Geng ch. 6): Eq. (6.5),
p(d) = 1/(1 + exp(a1 + a2·d)), the probability that a listening tag decodes a reference tag's
broadcast at distance d (binary-detection.md §1.11, seeds/004 L1123-L1127; wave2-specs.md §X).

* :func:`logistic_p`, :func:`logistic_coefficients` (the fitted curve, or stretched so that
  p(r) = 0.5 at a sensing range r: a2 → −a1/r) and :func:`in_range` (whether a broadcast would
  be decoded on its own: d ≤ r for the disc model, a Bernoulli draw of p(d) for the logistic);
* :func:`fit_eq65`: the maximum-likelihood fit of Eq. (6.5) on decode counts
  (:func:`rfsim.detection.fit.fit_logistic`), with the 50 % range d50 = −a1/a2 and its
  delta-method standard error, or why the fit has no finite maximum (:class:`Eq65Fit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import UserError
from rfsim.core.lazy import lazy_import

_fit = lazy_import("rfsim.detection.fit")


def logistic_coefficients(a1: float, a2_per_m: float, range_m: float, scale_to_range: bool) -> tuple[float, float]:
    """Coefficients of Eq. (6.5) used at a sensing range.

    As fitted, or (when ``scale_to_range``) stretched so that p(r) = 0.5, i.e. a2 = −a1/r.

    Parameters
    ----------
    a1 : float
        Fitted a1 [1].
    a2_per_m : float
        Fitted a2 [1/m].
    range_m : float
        Sensing range r [m].
    scale_to_range : bool
        Stretch the curve to p(r) = 0.5.

    Returns
    -------
    a1, a2 : float
        [1], [1/m].
    """
    return (float(a1), -float(a1) / range_m) if scale_to_range else (float(a1), float(a2_per_m))


@dataclass(frozen=True)
class Eq65Config:
    """Eq. (6.5) coefficients of a logistic range model (default: the ``exciter-link`` pooled fit
    of its default run, seed 1), optionally stretched to a sensing range."""

    logistic_a1: float = param(-2.523, lo=-100.0, hi=100.0,
                               doc="Eq. (6.5) a1: exciter-link pooled fit (default run, seed 1)")
    logistic_a2_per_m: float = param(5.028, lo=-1000.0, hi=1000.0, unit="1/m",
                                     doc="Eq. (6.5) a2: exciter-link pooled fit (d50 = 0.50 m)")
    scale_to_range: bool = param(True, doc="stretch the fitted curve so that p(r) = 0.5 (a2 = -a1/r)")

    def coefficients(self, range_m: float) -> tuple[float, float]:
        """Coefficients at a sensing range (:func:`logistic_coefficients`).

        Parameters
        ----------
        range_m : float
            Sensing range r [m].

        Returns
        -------
        a1, a2 : float
            [1], [1/m].
        """
        return logistic_coefficients(self.logistic_a1, self.logistic_a2_per_m, range_m, self.scale_to_range)


def logistic_p(d_m, a1: float, a2: float) -> np.ndarray:
    """Eq. (6.5): p(d) = 1/(1 + exp(a1 + a2·d)).

    Parameters
    ----------
    d_m : array_like
        Distances d [m].
    a1 : float
        Offset [1].
    a2 : float
        Slope [1/m].

    Returns
    -------
    numpy.ndarray
        Decode probabilities [1], shape of ``d_m``.
    """
    return 1.0 / (1.0 + np.exp(a1 + a2 * np.asarray(d_m, float)))


def in_range(distance_m, *, model: str, range_m: float, a1: float, a2: float,
             rng: np.random.Generator) -> np.ndarray:
    """Whether the broadcast at ``distance_m`` would be decoded on its own (no collision).

    ``model`` "disc": d ≤ r (seeds/004 L1068, "within its sensing range r"); "logistic": with
    probability :func:`logistic_p` (one uniform draw of ``rng`` per broadcast).

    Parameters
    ----------
    distance_m : array_like
        ``(n,)`` distances [m].
    model : {"disc", "logistic"}
        Range model.
    range_m : float
        Sensing range r of the disc model [m].
    a1, a2 : float
        Eq. (6.5) coefficients of the logistic model [1], [1/m].
    rng : numpy.random.Generator
        The uniforms of the logistic model.

    Returns
    -------
    numpy.ndarray
        ``(n,) bool``.
    """
    d = np.asarray(distance_m, float)
    if model == "disc":
        return d <= range_m
    return rng.random(d.shape) < logistic_p(d, a1, a2)


@dataclass(frozen=True)
class Eq65Fit:
    """Eq. (6.5) fitted on one set of points: p = 1/(1 + exp(x·a)).

    Attributes
    ----------
    coefficients, stderr : (k,) a and its standard errors (NaN when the fit has no finite maximum)
    status : "ok" or why not
    d50_m, d50_stderr_m : −a1/a2 [m] and its delta-method standard error (2-coefficient model only)
    """

    coefficients: np.ndarray
    stderr: np.ndarray
    status: str
    d50_m: float = float("nan")
    d50_stderr_m: float = float("nan")


def fit_eq65(design, decoded_count, draws) -> Eq65Fit:
    """Maximum-likelihood fit of p = 1/(1 + exp(x·a)) (Eq. 6.5, binary-detection.md §1.11).

    On k decodes out of m draws per row of ``design`` (:func:`rfsim.detection.fit.fit_logistic`).
    With the design [1, d]: d50 = −a1/a2 (p = 0.5) and
    Var(d50) = (Var a1 + d50²·Var a2 + 2·d50·Cov(a1, a2)) / a2² (delta method). Data with
    nothing or everything decoded, or perfectly separated, have no finite maximum: NaN
    coefficients and the reason in ``status``.

    Parameters
    ----------
    design : array_like
        ``(n, k)`` design matrix x (e.g. [1, d [m]]).
    decoded_count : array_like
        ``(n,)`` decodes per row.
    draws : array_like
        ``(n,)`` broadcasts per row.

    Returns
    -------
    Eq65Fit
        Coefficients, standard errors, status and d50 [m].
    """
    x = np.asarray(design, float)
    k, m = np.asarray(decoded_count, float), np.asarray(draws, float)
    nan = np.full(x.shape[1], np.nan)
    if k.sum() == 0 or k.sum() == m.sum():
        return Eq65Fit(nan, nan, "nothing decoded" if k.sum() == 0 else "everything decoded")
    try:
        f = _fit.fit_logistic(x, k, m)
    except UserError as err:
        return Eq65Fit(nan, nan, str(err))
    if x.shape[1] != 2:
        return Eq65Fit(f.coefficients, f.stderr, "ok")
    a1, a2 = f.coefficients
    d50 = -a1 / a2
    c = f.covariance
    var = (c[0, 0] + d50 * d50 * c[1, 1] + 2.0 * d50 * c[0, 1]) / (a2 * a2)
    return Eq65Fit(f.coefficients, f.stderr, "ok", float(d50), float(math.sqrt(max(var, 0.0))))


__all__ = ["Eq65Config", "logistic_coefficients", "logistic_p", "in_range", "Eq65Fit", "fit_eq65"]

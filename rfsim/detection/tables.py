"""Fit tables of the detection-probability models: every model fitted to a set of samples or
trials beside the published one, one row per (model, source) or per method, with standard
errors, cross-entropies or log-likelihoods, and the units and descriptions of the columns.

* ST-to-tag models TS and RTS (auris-sense-a-tag.md §2.2 Eqs. 4.6-4.8, R4-1; seed 003
  L3846-3906): :func:`fit_st_models` (ML fits, or the source's gradient descent, on the training
  rows, cross-entropies on both sets), :func:`st_fit_columns`, :func:`st_fits_comparison`.
* Reader Beta-binomial DA model (binary-detection.md §1.6; seed 004 Eqs. 4.4-4.11, L666, L838):
  :func:`fit_reader_models` (published, moments, maximum likelihood), :func:`reader_fit_columns`,
  :func:`cell_moments` (per-cell mean and variance of p̂ over repetitions).
"""

from __future__ import annotations

import numpy as np

from rfsim.core.errors import UserError
from rfsim.detection.fit import (DA_PARAMETER_NAMES, cross_entropy, expected_cross_entropy,
                                 fit_logistic, fit_logistic_gradient_descent, fit_reader_mle, fit_reader_moments,
                                 log_likelihood_reader)
from rfsim.detection.models import (PUBLISHED_READER_MODEL, RTS_COEFFICIENTS,
                                    RTS_TEST_CROSS_ENTROPY, TS_COEFFICIENTS,
                                    TS_TEST_CROSS_ENTROPY, predict_proba, rts_design, ts_design)

#: The ST models in the order of the table's rows.
ST_MODELS = ("RTS", "TS")
#: Names of the RTS coefficients a0 … a4 (features 1, D, d, |θ|, |φ|).
RTS_NAMES = ("a0", "a1_D", "a2_d", "a3_abs_theta", "a4_abs_phi")
#: Names of the TS coefficients a0, a1 (features 1, d).
TS_NAMES = ("a0", "a1_d")
#: Units of the ST coefficients (the others are dimensionless).
ST_FIT_UNITS = {"a1": "1/m", "a2": "1/m", "a3": "1/rad", "a4": "1/rad"}
#: Angles [deg] at which the reader fits report d50 by default (the source's, seed 004 L838).
D50_ANGLES_DEG = (0.0, 30.0, 60.0)

_ST_COUNTS = ("n_train", "n_test", "n_train_detected", "n_test_detected")
_ST_DESCRIPTIONS = {
    "model": "RTS (Eq. 4.6) or TS (Eq. 4.7)", "source": "'fit' (ML, or the run's gradient descent, on the training set) or 'published' (R4-1)",
    "train_cross_entropy": "Eq. 4.8 on the training set", "test_cross_entropy": "Eq. 4.8 on the test set",
    "published_test_cross_entropy": "the source's test cross-entropy (RTS 0.1278, TS 0.1502)",
    "expected_test_cross_entropy": "mean binary entropy of the model's test predictions",
    "n_train": "training samples (index < samples.n_train) the fit used",
    "n_test": "test samples (index >= samples.n_train) the cross-entropy is taken over",
    "n_train_detected": "training samples in which the ST detected the tag (y = 1)",
    "n_test_detected": "test samples in which the ST detected the tag (y = 1)"}


def fit_st_models(samples: dict[str, np.ndarray], *,
                  gradient_descent: tuple[float, int] | None = None) -> dict[str, np.ndarray]:
    """ML fits of RTS and TS on the training rows, cross-entropies on both sets.

    Parameters
    ----------
    samples : dict with ``D_m``, ``d_m`` [m], ``theta_rad``, ``phi_rad`` [rad] (features of
        :func:`rfsim.detection.st_features`), ``st_detected``, ``is_test`` (bool)
    gradient_descent : (learning rate, iterations) or None, default None
        None: maximum likelihood (:func:`rfsim.detection.fit.fit_logistic`); else both models
        by that many gradient-descent steps from zero
        (:func:`rfsim.detection.fit.fit_logistic_gradient_descent`, the source's method), with
        NaN standard errors

    Returns
    -------
    dict of (4,) columns, rows (RTS fit, RTS published, TS fit, TS published): ``model``,
    ``source``, ``a0`` … ``a4`` (NaN where the model has no such term; RTS order
    1, D, d, |θ|, |φ|; TS 1, d), ``se_a0`` … ``se_a4`` (NaN for published rows),
    ``train_cross_entropy``, ``test_cross_entropy`` (Eq. 4.8 [nat]; the published rows give the
    published coefficients evaluated on this data, and ``published_test_cross_entropy`` the
    source's value), ``expected_test_cross_entropy`` (entropy of the fitted model's own
    predictions on the test features), ``n_train``, ``n_test``, ``n_train_detected``,
    ``n_test_detected``.

    Raises
    ------
    UserError
        when a set is empty or the training outcomes are all equal (no finite ML estimate).
    """
    y = np.asarray(samples["st_detected"], bool)
    test = np.asarray(samples["is_test"], bool)
    train = ~test
    if train.sum() < 3 or test.sum() < 1:
        raise UserError(f"fits need training and test samples (have {train.sum()} / {test.sum()})")
    if y[train].all() or not y[train].any():
        raise UserError("fits need both outcomes in the training set")
    x_rts = rts_design(samples["D_m"], samples["d_m"], samples["theta_rad"], samples["phi_rad"])
    x_ts = ts_design(samples["d_m"])
    cols: dict[str, list] = {k: [] for k in ("model", "source", *[f"a{i}" for i in range(5)],
                                             *[f"se_a{i}" for i in range(5)], "train_cross_entropy",
                                             "test_cross_entropy", "published_test_cross_entropy",
                                             "expected_test_cross_entropy", *_ST_COUNTS)}
    counts = (int(train.sum()), int(test.sum()), int(y[train].sum()), int(y[test].sum()))
    for name, x, pub, pub_ce in (("RTS", x_rts, RTS_COEFFICIENTS, RTS_TEST_CROSS_ENTROPY),
                                 ("TS", x_ts, TS_COEFFICIENTS, TS_TEST_CROSS_ENTROPY)):
        if gradient_descent is None:
            fit = fit_logistic(x[train], y[train].astype(float))
            fitted, fitted_se = fit.coefficients, fit.stderr
        else:
            fitted = fit_logistic_gradient_descent(x[train], y[train], learning_rate=gradient_descent[0],
                                                   iterations=gradient_descent[1])
            fitted_se = np.full(fitted.size, np.nan)
        for source, coef, se in (("fit", fitted, fitted_se), ("published", pub, np.full(pub.size, np.nan))):
            cols["model"].append(name)
            cols["source"].append(source)
            for i in range(5):
                cols[f"a{i}"].append(float(coef[i]) if i < coef.size else np.nan)
                cols[f"se_a{i}"].append(float(se[i]) if i < coef.size else np.nan)
            cols["train_cross_entropy"].append(cross_entropy(y[train], predict_proba(x[train], coef)))
            cols["test_cross_entropy"].append(cross_entropy(y[test], predict_proba(x[test], coef)))
            cols["published_test_cross_entropy"].append(pub_ce)
            cols["expected_test_cross_entropy"].append(expected_cross_entropy(predict_proba(x[test], coef))[0])
            for key, n in zip(_ST_COUNTS, counts):
                cols[key].append(n)
    return {k: np.array(v) for k, v in cols.items()}


def st_fit_columns(fits: dict[str, np.ndarray]) -> dict[str, tuple[str, str]]:
    """Units and descriptions of the columns of a :func:`fit_st_models` table.

    Parameters
    ----------
    fits : dict of str to numpy.ndarray
        The table of :func:`fit_st_models`.

    Returns
    -------
    dict of str to tuple of str
        ``{column: (unit, description)}``.
    """
    out = {}
    for k in fits:
        base = k[3:] if k.startswith("se_") else k
        unit = "nat" if "cross_entropy" in k else ST_FIT_UNITS.get(base, "1")
        if k.startswith("a") and k[1:].isdigit():
            text = f"coefficient {k} of p = 1/(1+exp(x.a)); RTS x = (1, D, d, |theta|, |phi|), TS x = (1, d)"
        elif k.startswith("se_"):
            text = f"standard error of {base} (inverse Fisher information)"
        else:
            text = _ST_DESCRIPTIONS.get(k, k.replace("_", " "))
        out[k] = (unit, text)
    return out


def st_fits_comparison(fits: dict[str, np.ndarray]) -> str:
    """One line per model of a :func:`fit_st_models` table.

    Fitted vs published coefficients (± standard error), test cross-entropies (fit, published
    coefficients on this test set, published value) and the order of the non-constant
    coefficients by size.

    Parameters
    ----------
    fits : dict of str to numpy.ndarray
        The table of :func:`fit_st_models`.

    Returns
    -------
    str
        The lines, newline-separated.
    """
    lines = []
    for model in ST_MODELS:
        rows = {fits["source"][i]: i for i in range(fits["model"].size) if fits["model"][i] == model}
        f, p = rows["fit"], rows["published"]
        n = 5 if model == "RTS" else 2
        names = RTS_NAMES if model == "RTS" else TS_NAMES
        coef = ", ".join(f"{names[j]} {fits[f'a{j}'][f]:.4g} +- {fits[f'se_a{j}'][f]:.2g} (published "
                         f"{fits[f'a{j}'][p]:.4g})" for j in range(n))

        def order(i):
            return " > ".join(names[j] for j in sorted(range(1, n), key=lambda j: -abs(fits[f"a{j}"][i])))

        lines.append(f"{model}: {coef}; test cross-entropy {fits['test_cross_entropy'][f]:.4f} (published "
                     f"coefficients on this test set {fits['test_cross_entropy'][p]:.4f}, published value "
                     f"{fits['published_test_cross_entropy'][f]:.4f}); order by size: fit {order(f)}, published "
                     f"{order(p)}")
    return "; ".join(lines)


# --------------------------------------------------------------------------- reader DA model


def fit_reader_models(trials: dict[str, np.ndarray], *,
                      d50_angles_deg: tuple[float, ...] = D50_ANGLES_DEG) -> dict[str, np.ndarray]:
    """DA fits of reader trials: rows ``published``, ``moments`` and ``mle``.

    Parameters
    ----------
    trials : dict with ``distance_m`` [m], ``theta_deg`` [deg], ``n_reads``, ``n_queries``
        (one entry per trial)
    d50_angles_deg : angles [deg] of the ``d50_<θ>deg_m`` columns

    Returns
    -------
    dict: ``method``, ``stderr_basis``, the 9 parameters (:data:`DA_PARAMETER_NAMES`), their
    standard errors ``se_<name>``, ``d50_<θ>deg_m`` at ``d50_angles_deg`` and the
    log-likelihood of Eq. 4.11 (NaN row where a fit fails); key ``errors``: why a fit failed
    ("" if none). The maximum-likelihood fit fails (information matrix not positive definite)
    when p̂ is almost always 0 or 1: the variance is then clipped at κ·μ(1 − μ) in most cells
    and the likelihood is flat along the c's.
    """
    d, th, n, nq = trials["distance_m"], trials["theta_deg"], trials["n_reads"], trials["n_queries"]
    rows = [("published", PUBLISHED_READER_MODEL, None)]
    errors = []
    try:
        mom = fit_reader_moments(d, th, n, nq)
        rows.append(("moments", mom.model, mom))
    except (UserError, np.linalg.LinAlgError, ValueError) as exc:
        mom = None
        rows.append(("moments", None, None))
        errors.append(f"moments: {exc}")
    try:
        mle = fit_reader_mle(d, th, n, nq, start=mom.model if mom is not None else None)
        rows.append(("mle", mle.model, mle))
    except (UserError, np.linalg.LinAlgError, ValueError) as exc:
        rows.append(("mle", None, None))
        errors.append(f"mle: {exc}")
    out: dict[str, list] = {"method": [], "stderr_basis": []}
    for name in DA_PARAMETER_NAMES:
        out[name], out["se_" + name] = [], []
    for a in d50_angles_deg:
        out[f"d50_{int(a)}deg_m"] = []
    out["log_likelihood"] = []
    for method, model, fit in rows:
        out["method"].append(method)
        out["stderr_basis"].append(fit.stderr_basis if fit is not None else "none" if model is not None else "failed")
        if model is None:
            for k in out:
                if k not in ("method", "stderr_basis"):
                    out[k].append(np.nan)
            continue
        est = (fit.estimates if fit is not None else
               np.array([*model.mean_coefficients, *model.variance_coefficients, model.dead_zone_mean]))
        se = fit.stderr if fit is not None else np.full(9, np.nan)
        for i, name in enumerate(DA_PARAMETER_NAMES):
            out[name].append(float(est[i]))
            out["se_" + name].append(float(se[i]))
        for a in d50_angles_deg:
            out[f"d50_{int(a)}deg_m"].append(float(model.d50(a)))
        out["log_likelihood"].append(log_likelihood_reader(model, np.asarray(d, float), np.asarray(th, float),
                                                           np.asarray(n), np.asarray(nq), model.dead_zone_mean))
    out = {k: np.array(v) for k, v in out.items()}
    out["errors"] = "; ".join(errors)
    return out


_DA_UNITS = {"a2": "1/m", "a3": "1/deg", "c2": "1/m", "c3": "1/m^2", "c4": "1/deg", "c5": "1/deg^2"}


def reader_fit_columns(fits: dict[str, np.ndarray]) -> dict[str, tuple[str, str]]:
    """Units and descriptions of the columns of a :func:`fit_reader_models` table (without ``errors``).

    Parameters
    ----------
    fits : dict of str to numpy.ndarray
        The table of :func:`fit_reader_models`.

    Returns
    -------
    dict of str to tuple of str
        ``{column: (unit, description)}``.
    """
    out = {"method": ("", "published (seed 004 L666, L838), moments (LSQ on cell moments, the source's method) "
                          "or mle (Eq. 4.11)"),
           "stderr_basis": ("", "how the standard errors were obtained: 'full' inverse information, 'mean block' "
                                "(ML maximum on the edge of the feasible region: a1-a3 only, conditional on the "
                                "variance and dead-zone estimates), 'least squares' (moments), 'none' (published)")}
    for k in fits:
        if k in ("method", "stderr_basis", "errors"):
            continue
        base = k[3:] if k.startswith("se_") else k
        unit = "m" if k.startswith("d50") else "nat" if k == "log_likelihood" else _DA_UNITS.get(base, "1")
        text = (f"standard error of {base}" if k.startswith("se_") else
                "distance where E[p] = 1/2" if k.startswith("d50") else
                "log-likelihood of Eq. 4.11 on the trials" if k == "log_likelihood" else
                f"DA model parameter {k} (mean 1/(1+exp(a1+a2 d+a3|theta|)), variance c1+c2 d+c3 d^2+c4|theta|+c5 "
                "theta^2, dead-zone mean lambda)")
        out[k] = (unit, text)
    return out


def cell_moments(trials: dict[str, np.ndarray], dists, angles, n_rooms: int = 2) -> dict[str, np.ndarray]:
    """(room, distance, angle) grids of the mean and variance (ddof 1) of p̂ over repetitions.

    Parameters
    ----------
    trials : dict with ``room``, ``distance_m`` [m], ``theta_deg`` [deg], ``p_hat`` per trial
    dists, angles : the grid's distances [m] and angles [deg] (matched exactly)
    n_rooms : rooms 0 … n_rooms − 1

    Returns
    -------
    ``p_mean``, ``p_var`` : (n_rooms, len(dists), len(angles)) float64, NaN where a cell has no
    trial (variance: fewer than two)
    """
    shape = (n_rooms, len(dists), len(angles))
    mean, var = np.full(shape, np.nan), np.full(shape, np.nan)
    for k in range(n_rooms):
        for i, d in enumerate(dists):
            for j, a in enumerate(angles):
                sel = (trials["room"] == k) & (trials["distance_m"] == d) & (trials["theta_deg"] == a)
                if sel.any():
                    mean[k, i, j] = trials["p_hat"][sel].mean()
                    var[k, i, j] = trials["p_hat"][sel].var(ddof=1) if sel.sum() > 1 else np.nan
    return {"p_mean": mean, "p_var": var}

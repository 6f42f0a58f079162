"""Detection-probability models and their fitting.

:mod:`~rfsim.detection.models`: the ST-to-tag logistic models TS and RTS with the published
coefficients (auris-sense-a-tag.md §2.2) and the reader Beta-binomial DA model with dead zone
(binary-detection.md §1.6). :mod:`~rfsim.detection.fit`: maximum-likelihood logistic
regression, cross-entropy, moment and maximum-likelihood fits of the DA model, binned
empirical probabilities with Wilson intervals. :mod:`~rfsim.detection.tables`: fit tables (every
model fitted beside the published one, with standard errors and cross-entropies or
log-likelihoods) and their column units and descriptions.

:mod:`~rfsim.detection.tag_to_tag`: the tag-to-tag decode-probability model of Eq. (6.5) and its fit.
:mod:`~rfsim.detection.landmark_rts`: the RTS surrogate of a sense-a-tag detecting landmark tags
round by round (Bernoulli draws, antenna selection, the trackers' likelihood model).
"""

from rfsim.core.lazy import lazy_exports

#: Module of the package → the public names it provides, each imported on first use (so that a
#: scenario's config, which names one model, does not import the fits and scipy.optimize).
_SOURCES = {
    "fit": ("DA_PARAMETER_NAMES", "BinnedProbability", "LogisticFit", "ReaderModelFit", "binned_probability", "cross_entropy", "cross_entropy_logits", "expected_cross_entropy", "fit_logistic", "fit_logistic_gradient_descent", "fit_reader_mle", "fit_reader_moments", "wilson_interval",),
    "models": ("DA_DEAD_ZONE", "DA_MEAN_COEFFICIENTS", "DA_QUERIES_PER_ROUND", "DA_VARIANCE_COEFFICIENTS", "PUBLISHED_READER_MODEL", "RTS_COEFFICIENTS", "RTS_TEST_CROSS_ENTROPY", "TS_COEFFICIENTS", "TS_TEST_CROSS_ENTROPY", "ReaderDetectionModel", "beta_from_moments", "mixture_logpmf", "predict_proba", "rts_design", "rts_probability", "st_features", "ts_design", "ts_probability",),
    "tables": ("cell_moments", "fit_reader_models", "fit_st_models", "reader_fit_columns", "st_fit_columns", "st_fits_comparison",),
}
__getattr__, __dir__ = lazy_exports(globals(), _SOURCES)

__all__ = [
    "RTS_COEFFICIENTS", "TS_COEFFICIENTS", "RTS_TEST_CROSS_ENTROPY", "TS_TEST_CROSS_ENTROPY",
    "DA_MEAN_COEFFICIENTS", "DA_VARIANCE_COEFFICIENTS", "DA_DEAD_ZONE", "DA_QUERIES_PER_ROUND",
    "PUBLISHED_READER_MODEL", "ReaderDetectionModel", "beta_from_moments", "mixture_logpmf",
    "predict_proba", "rts_design", "ts_design", "rts_probability", "ts_probability",
    "st_features",
    "LogisticFit", "fit_logistic", "fit_logistic_gradient_descent", "cross_entropy", "cross_entropy_logits",
    "expected_cross_entropy", "ReaderModelFit", "DA_PARAMETER_NAMES", "fit_reader_moments",
    "fit_reader_mle", "BinnedProbability", "binned_probability", "wilson_interval",
    "fit_st_models", "st_fit_columns", "st_fits_comparison", "fit_reader_models", "reader_fit_columns",
    "cell_moments",
]

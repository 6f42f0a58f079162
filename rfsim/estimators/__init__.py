"""Reference estimators: the filters, locators and observers the source documents used.

Small, vectorised (over particles and trials) implementations, each with its
equation and source in the docstring, cross-checked in the tests against
well-kept libraries (filterpy for the Kalman family, scipy.linalg for the Riccati equation) or
brute-force references. They are references for validating datasets, not a tracking library.

HIMR: state-space models and observability (:mod:`~rfsim.estimators.himr_model`), CARE-gain
observers and diagnostics (:mod:`~rfsim.estimators.observer`), the outage cases
(:mod:`~rfsim.estimators.himr_cases`) and a geometric measurement surrogate for tests
(:mod:`~rfsim.estimators.himr_surrogate`).

The public names are listed one per line (so that independent additions merge), each
imported from its module on first use; ``__all__`` is every listed name.
"""

from rfsim.core.lazy import lazy_exports

#: Module of the package → the public names it provides, each imported on first use (so
#: that importing one estimator does not import the others).
_SOURCES = {
    "kalman": (
        "kf_predict",
        "kf_update",
        "ekf_update",
        "FilterResult",
        "kalman_filter",
        "extended_kalman_filter",
        "rts_smoother",
    ),
    "particle": (
        "effective_sample_size",
        "systematic_indices",
        "systematic_resample",
        "multinomial_resample",
        "ParticleFilterResult",
        "sir_filter",
    ),
    "grid_bayes": (
        "gaussian_log_likelihood",
        "gaussian_transition",
        "grid_bayes_filter",
        "grid_estimates",
    ),
    "nearest": (
        "landmarc",
        "weighted_centroid",
    ),
    "calibration": (
        "ALPHA_GRID_DBM",
        "EXPONENT_GRID",
        "Calibration",
        "calibrate_log_distance",
        "fit_log_distance",
    ),
    "bounds": (
        "log_distance_crlb",
    ),
    "rss_localization": (
        "reflect_into",
        "rss_sir",
        "estimate_simulation",
        "smooth_rssi",
        "estimate_home",
        "error_statistics",
    ),
    "observer": (
        "care_gain",
        "observe_1d",
        "observe_2d",
    ),
    "phase_tracking": (
        "unwrap_pseudoranges",
        "unwrap_limit_mps",
        "rssi_fix",
        "continuous_model",
        "discrete_model",
        "initial_state",
        "PassResult",
        "ekf_reads",
        "rts_reads",
        "track_phase",
    ),
    "proximity": (
        "cv_transition",
        "cv_process_noise",
        "association",
        "proximity_kalman",
        "logistic_log_likelihood",
        "bernoulli_pf",
        "rbpf",
    ),
    "landmark_pf": (
        "binomial_log_likelihood",
        "wcl_track",
        "pf_bin",
        "pf_aa",
        "bias_compensate",
    ),
}
__getattr__, __dir__ = lazy_exports(globals(), _SOURCES)

__all__ = sorted(name for names in _SOURCES.values() for name in names)

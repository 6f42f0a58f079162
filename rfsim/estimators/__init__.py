"""Reference estimators: the filters, locators and observers the source documents used.

Small, vectorised (over particles and trials) implementations, each with its
equation and source in the docstring, cross-checked in the tests against
well-kept libraries (filterpy for the Kalman family, scipy.linalg for the Riccati equation) or
brute-force references. They are references for validating datasets, not a tracking library.

HIMR: state-space models and observability (:mod:`~rfsim.estimators.himr_model`), CARE-gain
observers and diagnostics (:mod:`~rfsim.estimators.observer`), the outage cases
(:mod:`~rfsim.estimators.himr_cases`) and a geometric measurement surrogate for tests
(:mod:`~rfsim.estimators.himr_surrogate`).

The public names are imported one per line (so that independent additions merge); ``__all__``
is every imported public name.
"""

from rfsim.estimators.kalman import kf_predict
from rfsim.estimators.kalman import kf_update
from rfsim.estimators.kalman import ekf_update
from rfsim.estimators.kalman import FilterResult
from rfsim.estimators.kalman import kalman_filter
from rfsim.estimators.kalman import extended_kalman_filter
from rfsim.estimators.kalman import rts_smoother
from rfsim.estimators.particle import effective_sample_size
from rfsim.estimators.particle import systematic_indices
from rfsim.estimators.particle import systematic_resample
from rfsim.estimators.particle import multinomial_resample
from rfsim.estimators.particle import ParticleFilterResult
from rfsim.estimators.particle import sir_filter
from rfsim.estimators.grid_bayes import gaussian_log_likelihood
from rfsim.estimators.grid_bayes import gaussian_transition
from rfsim.estimators.grid_bayes import grid_bayes_filter
from rfsim.estimators.grid_bayes import grid_estimates
from rfsim.estimators.nearest import landmarc
from rfsim.estimators.nearest import weighted_centroid
from rfsim.estimators.calibration import ALPHA_GRID_DBM
from rfsim.estimators.calibration import EXPONENT_GRID
from rfsim.estimators.calibration import Calibration
from rfsim.estimators.calibration import calibrate_log_distance
from rfsim.estimators.calibration import fit_log_distance
from rfsim.estimators.bounds import log_distance_crlb
from rfsim.estimators.observer import care_gain
from rfsim.estimators.observer import observe_1d
from rfsim.estimators.observer import observe_2d
from rfsim.estimators.phase_tracking import unwrap_pseudoranges
from rfsim.estimators.phase_tracking import unwrap_limit_mps
from rfsim.estimators.phase_tracking import rssi_fix
from rfsim.estimators.phase_tracking import continuous_model
from rfsim.estimators.phase_tracking import discrete_model
from rfsim.estimators.phase_tracking import initial_state
from rfsim.estimators.phase_tracking import PassResult
from rfsim.estimators.phase_tracking import ekf_reads
from rfsim.estimators.phase_tracking import rts_reads
from rfsim.estimators.phase_tracking import track_phase
from rfsim.estimators.proximity import cv_transition
from rfsim.estimators.proximity import cv_process_noise
from rfsim.estimators.proximity import association
from rfsim.estimators.proximity import proximity_kalman
from rfsim.estimators.proximity import logistic_log_likelihood
from rfsim.estimators.proximity import bernoulli_pf
from rfsim.estimators.proximity import rbpf
from rfsim.estimators.landmark_pf import binomial_log_likelihood
from rfsim.estimators.landmark_pf import wcl_track
from rfsim.estimators.landmark_pf import pf_bin
from rfsim.estimators.landmark_pf import pf_aa
from rfsim.estimators.landmark_pf import bias_compensate

import types as _types

__all__ = sorted(name for name, value in dict(globals()).items()
                 if not name.startswith("_") and not isinstance(value, _types.ModuleType))

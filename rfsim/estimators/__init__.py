"""Reference estimators that turn datasets into positions.

HIMR: state-space models and observability (:mod:`~rfsim.estimators.himr_model`), CARE-gain
observers and diagnostics (:mod:`~rfsim.estimators.observer`), the outage cases
(:mod:`~rfsim.estimators.himr_cases`) and a geometric measurement surrogate for tests
(:mod:`~rfsim.estimators.himr_surrogate`).
"""

from rfsim.estimators.observer import care_gain
from rfsim.estimators.observer import observe_1d
from rfsim.estimators.observer import observe_2d

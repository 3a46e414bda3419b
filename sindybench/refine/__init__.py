"""Fit by simulation error: forward sensitivities, output-error refinement, initial states, covariance."""

from ._core import Physical, estimate_initial_state, refine_simulation_error
from ._covariance import ParameterCovariance, parameter_covariance
from ._report import UncertaintyMixin, confidence_intervals, standard_errors
from ._result import RefinementResult
from ._sensitivity import simulate_sensitivity
from ._settings import OutputErrorRefinement

__all__ = [
    "OutputErrorRefinement",
    "ParameterCovariance",
    "Physical",
    "RefinementResult",
    "UncertaintyMixin",
    "confidence_intervals",
    "estimate_initial_state",
    "parameter_covariance",
    "refine_simulation_error",
    "simulate_sensitivity",
    "standard_errors",
]

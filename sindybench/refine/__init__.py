"""Fit by simulation or prediction error: sensitivities, output- and prediction-error refinement, covariance."""

from ._core import Physical, estimate_initial_state, refine_simulation_error
from ._covariance import ParameterCovariance, parameter_covariance
from ._prediction import refine_prediction_error
from ._predictor import predict_sensitivity
from ._report import UncertaintyMixin, confidence_intervals, standard_errors
from ._result import RefinementResult
from ._sensitivity import simulate_sensitivity
from ._settings import OutputErrorRefinement, PredictionErrorRefinement

__all__ = [
    "OutputErrorRefinement",
    "ParameterCovariance",
    "Physical",
    "PredictionErrorRefinement",
    "RefinementResult",
    "UncertaintyMixin",
    "confidence_intervals",
    "estimate_initial_state",
    "parameter_covariance",
    "predict_sensitivity",
    "refine_prediction_error",
    "refine_simulation_error",
    "simulate_sensitivity",
    "standard_errors",
]

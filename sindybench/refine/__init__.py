"""Fit by simulation or prediction error: forward sensitivities, output- and prediction-error refinement,
initial states.

Every criterion takes a fitted :class:`~sindybench.dynamics.Dynamics` and a
:class:`FreeParameters` description of what is free (coefficient entries, a
:class:`Physical` map of physical parameters, initial states), with its
knobs grouped in :class:`LeastSquares` and :class:`Shooting`.

The covariance of the refined parameters and its reporting (standard errors,
confidence intervals) moved to :mod:`sindybench.uncertainty`; the old names
here still work, with a ``FutureWarning``.
"""

import warnings

from ._core import estimate_initial_state, refine_simulation_error
from ._parametrized import CoefficientMap, FreeParameters, LeastSquares, ParametrizedDynamics, Physical, Shooting
from ._prediction import refine_prediction_error
from ._predictor import predict_sensitivity
from ._result import RefinementResult
from ._sensitivity import simulate_sensitivity
from ._settings import OutputErrorRefinement, PredictionErrorRefinement

__all__ = [
    "CoefficientMap",
    "FreeParameters",
    "LeastSquares",
    "OutputErrorRefinement",
    "ParametrizedDynamics",
    "Physical",
    "PredictionErrorRefinement",
    "RefinementResult",
    "Shooting",
    "estimate_initial_state",
    "predict_sensitivity",
    "refine_prediction_error",
    "refine_simulation_error",
    "simulate_sensitivity",
]

_MOVED = {"ParameterCovariance", "UncertaintyMixin", "confidence_intervals", "parameter_covariance",
          "standard_errors"}


def __getattr__(name):
    """The names that moved to :mod:`sindybench.uncertainty` (``UncertaintyMixin``: the estimators' base)."""
    if name not in _MOVED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(f"sindybench.refine.{name} moved to sindybench.uncertainty; import it from there "
                  "(the old name will be removed).", FutureWarning, stacklevel=2)
    if name == "UncertaintyMixin":
        from .._uncertainty_methods import UncertaintyMixin

        return UncertaintyMixin
    from .. import uncertainty  # a deprecated alias only: nothing in refine uses the upper layer

    return getattr(uncertainty, name)

"""Uncertainty of identified models: residual analysis, calibrated bands, parameter covariance, ensembles.

* residual analysis (:func:`residual_analysis`, :func:`residual_test`): are a
  model's residuals white and independent of past inputs?
* calibrated bands (:func:`conformal_calibration`): split conformal bands of
  the free run and of the k-step prediction, from held-out errors;
* the covariance of a refined model's parameters (:func:`parameter_covariance`,
  :func:`standard_errors`, :func:`confidence_intervals`; the estimators'
  ``standard_errors()`` and ``confidence_intervals()``), which warns
  (:class:`ModelErrorWarning`) when the residual test contradicts it;
* :class:`BootstrapEnsemble` (clone + refit on circular-block bootstraps of the
  simulation residuals, any estimator and strategy) and :func:`prediction_band`.

What each assumes: :doc:`/uncertainty`.
"""

from .._covariance import ParameterCovariance, parameter_covariance
from .._residual_tests import ModelErrorWarning, ResidualTest, residual_test
from ._bands import PredictionBand, prediction_band
from ._bootstrap import BootstrapEnsemble, circular_block_indices
from ._conformal import (ConformalBand, ConformalCalibration, ExtrapolationWarning, conformal_calibration,
                         conformal_quantile)
from ._covariance import confidence_intervals, standard_errors
from ._residuals import ResidualAnalysis, k_step_prediction, residual_analysis

__all__ = [
    "BootstrapEnsemble",
    "ConformalBand",
    "ConformalCalibration",
    "ExtrapolationWarning",
    "ModelErrorWarning",
    "ParameterCovariance",
    "PredictionBand",
    "ResidualAnalysis",
    "ResidualTest",
    "circular_block_indices",
    "confidence_intervals",
    "conformal_calibration",
    "conformal_quantile",
    "k_step_prediction",
    "parameter_covariance",
    "prediction_band",
    "residual_analysis",
    "residual_test",
    "standard_errors",
]

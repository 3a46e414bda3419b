"""Uncertainty of identified models: block-bootstrap ensembles and prediction bands.

The covariance of a refined model's parameters lives where its Jacobian is,
in :mod:`sindybench.refine` (``model.standard_errors()``,
``model.confidence_intervals()``); this package adds what needs refits:
:class:`BootstrapEnsemble` (clone + refit on circular-block bootstraps of the
simulation residuals, any estimator and strategy) and :func:`prediction_band`.
"""

from .._residual_tests import ModelErrorWarning, ResidualTest, residual_test
from ._bands import PredictionBand, prediction_band
from ._bootstrap import BootstrapEnsemble, circular_block_indices
from ._conformal import ConformalBand, ConformalCalibration, conformal_calibration, conformal_quantile
from ._residuals import ResidualAnalysis, k_step_prediction, residual_analysis

__all__ = [
    "BootstrapEnsemble",
    "ConformalBand",
    "ConformalCalibration",
    "ModelErrorWarning",
    "PredictionBand",
    "ResidualAnalysis",
    "ResidualTest",
    "circular_block_indices",
    "conformal_calibration",
    "conformal_quantile",
    "k_step_prediction",
    "prediction_band",
    "residual_analysis",
    "residual_test",
]

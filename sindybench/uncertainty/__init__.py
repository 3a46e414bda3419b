"""Uncertainty of identified models: block-bootstrap ensembles and prediction bands.

The covariance of a refined model's parameters lives where its Jacobian is,
in :mod:`sindybench.refine` (``model.standard_errors()``,
``model.confidence_intervals()``); this package adds what needs refits:
:class:`BootstrapEnsemble` (clone + refit on circular-block bootstraps of the
simulation residuals, any estimator and strategy) and :func:`prediction_band`.
"""

from ._bands import PredictionBand, prediction_band
from ._bootstrap import BootstrapEnsemble, circular_block_indices

__all__ = ["BootstrapEnsemble", "PredictionBand", "circular_block_indices", "prediction_band"]

"""State estimation for fitted models: extended Kalman filter, RTS smoother, k-step prediction, linearization."""

from ._kalman import FilterDivergenceError, KalmanResult, extended_kalman_filter, rts_smoother
from ._model_step import ModelStep, model_step

__all__ = [
    "FilterDivergenceError",
    "KalmanResult",
    "ModelStep",
    "extended_kalman_filter",
    "model_step",
    "rts_smoother",
]

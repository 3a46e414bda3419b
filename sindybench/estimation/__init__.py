"""State estimation for fitted models: extended Kalman filter, RTS smoother, k-step prediction, linearization.

:func:`latent_invariants` (the gauge-free poles and gain of a latent-state model) is built on :func:`linearize`.
"""

from ._invariants import latent_invariants
from ._kalman import FilterDivergenceError, KalmanResult, extended_kalman_filter, rts_smoother
from ._linearize import Linearization, linearize
from ._model_step import ModelStep, model_step
from ._noise import estimate_noise
from ._predict import k_step_rmse, predict_k_step, smooth_initial_state

__all__ = [
    "FilterDivergenceError",
    "KalmanResult",
    "Linearization",
    "ModelStep",
    "estimate_noise",
    "extended_kalman_filter",
    "k_step_rmse",
    "latent_invariants",
    "linearize",
    "model_step",
    "predict_k_step",
    "rts_smoother",
    "smooth_initial_state",
]

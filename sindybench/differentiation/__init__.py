"""Derivative estimation: ``method.derivative(y, dt=..., order=1 or 2)``."""

from ._auto import bandwidth, data_differentiation, savgol_window
from ._base import BaseDifferentiation
from ._local import FiniteDifference, SavitzkyGolay, finite_difference
from ._smoothing import Kalman, SmoothingSpline, kalman_smooth
from ._spectral import Spectral, spectral_derivative
from ._total_variation import TotalVariation, tv_smooth
from ._wrap import PySINDyDifferentiation, as_differentiation

__all__ = [
    "BaseDifferentiation",
    "FiniteDifference",
    "Kalman",
    "PySINDyDifferentiation",
    "SavitzkyGolay",
    "SmoothingSpline",
    "Spectral",
    "TotalVariation",
    "as_differentiation",
    "bandwidth",
    "data_differentiation",
    "finite_difference",
    "kalman_smooth",
    "savgol_window",
    "spectral_derivative",
    "tv_smooth",
]

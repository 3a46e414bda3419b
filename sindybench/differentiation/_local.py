"""Local methods: finite differences and Savitzky-Golay filters."""

import numpy as np
from pysindy.differentiation import FiniteDifference as _PySINDyFiniteDifference
from scipy.signal import savgol_filter

from .._validation import check_integer
from ..io import register_model
from ._base import BaseDifferentiation

__all__ = ["FiniteDifference", "SavitzkyGolay", "finite_difference"]


def finite_difference(y, t, *, order=1, accuracy=2, step=None):
    """Finite-difference derivative of the columns of ``y`` (no NaN at the ends).

    Centred stencils inside, one-sided stencils of the same accuracy at the ends;
    non-uniform ``t`` uses stencils fitted to the actual sample times. The
    stencils come from :class:`pysindy.differentiation.FiniteDifference`.

    Parameters
    ----------
    y : ndarray of shape (n_samples, n_channels)
    t : ndarray of shape (n_samples,)
        Sample times.
    order : {1, 2}, default=1
    accuracy : {2, 4}, default=2
        Order of the truncation error.
    step : float, optional
        The uniform sampling interval, when known (faster stencils).

    Returns
    -------
    ndarray of shape (n_samples, n_channels)

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> finite_difference((t**2)[:, None], t).ravel()
    array([0. , 0.5, 1. , 1.5, 2. ])
    """
    fd = _PySINDyFiniteDifference(order=accuracy, d=order, axis=0)
    return np.asarray(fd._differentiate(y, t if step is None else step), dtype=float)


class FiniteDifference(BaseDifferentiation):
    """Plain finite differences (no smoothing).

    Parameters
    ----------
    accuracy : {2, 4}, default=2
        Order of the truncation error: accuracy 2 is exact on quadratics,
        accuracy 4 on quartics (up to rounding), uniform or not.

    See Also
    --------
    finite_difference : the function doing the work.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 9)
    >>> FiniteDifference().derivative(3.0 * t**2, t=t, order=2)
    array([6., 6., 6., 6., 6., 6., 6., 6., 6.])
    """

    def __init__(self, accuracy=2):
        self.accuracy = accuracy

    def _validate_params(self):
        if self.accuracy not in (2, 4) or isinstance(self.accuracy, bool):
            raise ValueError(f"accuracy must be 2 or 4; got {self.accuracy!r}.")

    def _min_samples(self, order):
        return order + self.accuracy

    def _derivative(self, y, t, step, order):
        return finite_difference(y, t, order=order, accuracy=self.accuracy, step=step)


class SavitzkyGolay(BaseDifferentiation):
    """Savitzky-Golay derivative: local least-squares polynomials (uniform sampling only).

    Each sample gets the derivative of the polynomial of degree ``polyorder``
    fitted to the ``window_length`` samples around it; near the ends the
    polynomial fitted to the first or last window is used
    (:func:`scipy.signal.savgol_filter` with ``mode="interp"``), so polynomials
    of degree up to ``polyorder`` are differentiated exactly everywhere. The
    second derivative comes from the same local fits.

    Parameters
    ----------
    window_length : int, default=11
        Odd number of samples in each window (at most the number of samples).
    polyorder : int, default=3
        Degree of the local polynomials, less than ``window_length`` and at
        least the derivative order.

    Examples
    --------
    >>> t = np.arange(20) * 0.1
    >>> d = SavitzkyGolay(window_length=7, polyorder=3).derivative(t**3, dt=0.1)
    >>> bool(np.allclose(d, 3 * t**2))
    True
    """

    def __init__(self, window_length=11, *, polyorder=3):
        self.window_length = window_length
        self.polyorder = polyorder

    def _validate_params(self):
        check_integer(self.window_length, "window_length", low=3)
        if self.window_length % 2 == 0:
            raise ValueError(f"window_length must be odd; got {self.window_length}.")
        check_integer(self.polyorder, "polyorder", low=0, high=self.window_length - 1)

    def _min_samples(self, order):
        return self.window_length

    def _derivative(self, y, t, step, order):
        if step is None:
            raise ValueError(
                "SavitzkyGolay needs uniformly sampled data but t is not uniform "
                f"(steps from {np.min(np.diff(t)):g} to {np.max(np.diff(t)):g}); pass dt, resample, "
                "or use a method that accepts non-uniform t (FiniteDifference, SmoothingSpline, "
                "TotalVariation, Kalman)."
            )
        if order > self.polyorder:
            raise ValueError(
                f"polyorder={self.polyorder} cannot give a derivative of order {order}; "
                f"expected polyorder >= {order}."
            )
        return savgol_filter(
            y, self.window_length, self.polyorder, deriv=order, delta=step, axis=0, mode="interp"
        )


register_model(FiniteDifference)
register_model(SavitzkyGolay)

"""The shared interface of the differentiation methods and its argument checks."""

import numbers

import numpy as np
from sklearn.base import BaseEstimator

from .._validation import check_dt, check_signal, check_time, uniform_step

__all__ = ["BaseDifferentiation"]


class BaseDifferentiation(BaseEstimator):
    """Base class: ``derivative(y, *, dt=None, t=None, order=1)`` for every method.

    Subclasses implement ``_derivative(y, t, step, order)`` with ``y`` of shape
    ``(n_samples, n_channels)``, ``t`` the sample times and ``step`` the sampling
    interval when it is uniform (``None`` otherwise), and ``_min_samples(order)``.
    Columns are differentiated independently.

    Examples
    --------
    A method built on ``numpy.gradient`` (second-order accurate, uniform or not):

    >>> class Gradient(BaseDifferentiation):
    ...     def _derivative(self, y, t, step, order):
    ...         d = np.gradient(y, t, axis=0, edge_order=2)
    ...         return d if order == 1 else np.gradient(d, t, axis=0, edge_order=2)
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> Gradient().derivative(t**2, dt=0.1)[:3]
    array([0. , 0.2, 0.4])
    >>> Gradient().derivative(t**2, t=t, order=2)[:3]
    array([2., 2., 2.])
    """

    def derivative(self, y, *, dt=None, t=None, order=1):
        """Estimate the first or second time derivative of ``y``.

        Parameters
        ----------
        y : array-like of shape (n_samples,) or (n_samples, n_channels)
            Samples of the signal; each column is differentiated on its own.
        dt : float, optional
            Uniform sampling interval. Give ``dt`` or ``t``, not both.
        t : array-like of shape (n_samples,), optional
            Strictly increasing sample times.
        order : {1, 2}, default=1
            Order of the derivative.

        Returns
        -------
        ndarray of the shape of ``y``
            The derivative at the sample times (finite at the ends too).
        """
        shape = np.shape(y)
        y = check_signal(y, "y")
        order = check_order(order)
        t, step = resolve_time(y.shape[0], dt, t)
        self._validate_params()
        need = self._min_samples(order)
        if y.shape[0] < need:
            raise ValueError(
                f"y has {y.shape[0]} samples; {type(self).__name__} needs at least {need} "
                f"for order={order} with these parameters."
            )
        try:
            out = self._derivative(y, t, step, order)
        except (np.linalg.LinAlgError, ZeroDivisionError, OverflowError) as exc:  # powers of dt = 1e-300 underflow
            spacing = f"dt = {step:g}" if step is not None else f"the smallest step {np.min(np.diff(t)):g}"
            raise ValueError(
                f"{type(self).__name__} could not differentiate y with {spacing} ({exc}); expected sample "
                "times on a scale the method can resolve (rescale the time unit)."
            ) from exc
        if not np.all(np.isfinite(out)):  # y is finite: the method's weights over- or underflowed
            spacing = f"dt = {step:g}" if step is not None else f"the smallest step {np.min(np.diff(t)):g}"
            raise ValueError(
                f"{type(self).__name__} gave NaN or inf derivatives of the finite y with {spacing}; expected "
                "sample times on a scale the method can resolve (rescale the time unit)."
            )
        return out.reshape(shape)

    def _validate_params(self):
        """Check the constructor parameters (called at the start of ``derivative``)."""

    def _min_samples(self, order):
        return 3


def check_order(order):
    """Return the derivative order, 1 or 2."""
    if isinstance(order, bool) or not isinstance(order, numbers.Integral) or order not in (1, 2):
        raise ValueError(f"order must be 1 or 2; got {order!r}.")
    return int(order)


def resolve_time(n_samples, dt, t):
    """Return ``(t, step)``: sample times and the uniform step (``None`` if not uniform).

    Examples
    --------
    >>> resolve_time(3, 0.5, None)
    (array([0. , 0.5, 1. ]), 0.5)
    >>> resolve_time(3, None, [0.0, 1.0, 3.0])[1] is None
    True
    """
    if dt is not None and t is not None:
        raise ValueError("got both dt and t; give the sampling interval dt or the sample times t, not both.")
    if dt is None and t is None:
        raise ValueError("got neither dt nor t; give the sampling interval dt or the sample times t.")
    if t is None:
        dt = check_dt(dt)
        return np.arange(n_samples) * dt, dt
    t = check_time(t, n_samples)
    return t, uniform_step(t)

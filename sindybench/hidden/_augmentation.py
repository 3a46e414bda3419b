"""Derivative-coordinate augmentation: states ``(y, y', ..., y^(n-1))``."""

import math

import numpy as np

from .._validation import check_integer
from ..io import register_model
from ._base import Design, HiddenStrategy, Structure, linear_term

__all__ = ["DerivativeHiddenState", "start_derivatives"]


class DerivativeHiddenState(HiddenStrategy):
    """Lift each output to ``(y, y', ..., y^(order-1))`` and learn ``y^(order)``.

    The chain rows ``d/dt y^(k) = y^(k+1)`` are fixed rows of the model (they
    hold by construction; nothing is overwritten after the fit); the library
    learns the highest derivative from ``Z = [y, y', ..., u]``. On new data the
    initial derivatives come from the first ``init_size`` output samples with
    the estimator's differentiation method (more when the method needs more:
    a ``SavitzkyGolay(window_length=21)`` uses 21). Given fewer samples than
    the method needs (a window chosen from a long training record is often
    longer than the 20 start samples ``predict`` gets), the start comes from
    one local polynomial of the method's degree (cubic when it has none)
    fitted to all of them (:func:`start_derivatives`); the training
    derivatives are the method's own.

    States are ordered derivative by derivative: for outputs ``y0, y1`` and
    ``order=2`` they are ``(y0, y1, y0', y1')``.

    Parameters
    ----------
    order : int, default=2
        Order of the learned derivative (1 = plain SINDy on the outputs).
    init_size : int, default=20
        Output samples used to estimate the initial derivatives on new data,
        or as many as the differentiation method needs if that is more (and
        ``y_init`` holds them).

    Examples
    --------
    >>> s = DerivativeHiddenState(order=2).structure({}, n_outputs=1, n_inputs=1)
    >>> s.state_names, s.learned, s.output_index
    (['y0', "y0'"], (1,), (0,))
    """

    def __init__(self, *, order=2, init_size=20):
        self.order = order
        self.init_size = init_size

    def _validate(self):
        check_integer(self.order, "order")
        check_integer(self.init_size, "init_size")

    def structure(self, params, *, n_outputs, n_inputs):
        p, n = n_outputs, self.order
        n_states = p * n
        terms = [linear_term(p * (k + 1) + j) for k in range(n - 1) for j in range(p)]
        coef = np.zeros((len(terms), n_states))
        for row, (k, j) in enumerate((k, j) for k in range(n - 1) for j in range(p)):
            coef[row, p * k + j] = 1.0
        names = [f"y{j}" + "'" * k for k in range(n) for j in range(p)]
        return Structure(
            n_states=n_states,
            learned=tuple(p * (n - 1) + j for j in range(p)),
            output_index=tuple(range(p)),
            fixed_terms=terms,
            fixed_coef=coef,
            state_names=names,
        )

    def design(self, u, y, dt, *, derivative, params):
        states = np.hstack([derivative(y, k) for k in range(self.order)])
        return Design(states=states, targets=derivative(y, self.order))

    def initial_state(self, u, y_init, dt, *, derivative, params, model):
        need = samples_needed(derivative, self.order - 1)
        if y_init.shape[0] < need:  # fewer start samples than the method's window: the same local fit, shorter
            return start_derivatives(y_init, dt, self.order - 1,
                                     degree=getattr(getattr(derivative, "differentiation", None), "polyorder", 3))
        y_init = y_init[: max(self.init_size, need)]
        return np.concatenate([derivative(y_init, k)[0] for k in range(self.order)])


def start_derivatives(y_init, dt, order, *, degree=3):
    """Derivatives 0 to ``order`` of ``y_init`` at its first sample, from one polynomial fitted to all of it.

    The start of a simulation from fewer samples than the differentiation
    method needs (a Savitzky-Golay window chosen from a long training record
    is often longer than the 20 samples ``predict`` is given): the least-squares
    polynomial of degree ``degree`` (at most ``n - 1`` for ``n`` samples, at
    least ``order``) over every sample of ``y_init``, differentiated at the
    first sample -- what a Savitzky-Golay filter with ``mode="interp"`` does
    at the start of a record, over a shorter window.

    Parameters
    ----------
    y_init : ndarray of shape (n_samples, n_outputs)
    dt : float
    order : int
        The highest derivative.
    degree : int, default=3

    Returns
    -------
    ndarray of shape ((order + 1) * n_outputs,)
        Derivative by derivative: ``y(0), y'(0), ...``, each for every output.

    Examples
    --------
    >>> t = np.arange(6) * 0.1
    >>> start_derivatives((1.0 + 2.0 * t + t**3)[:, None], 0.1, 1).round(6).tolist()
    [1.0, 2.0]
    """
    y_init = np.asarray(y_init, dtype=float)
    n = y_init.shape[0]
    if n < order + 1:
        raise ValueError(f"y_init has {n} samples; too short to estimate the initial derivatives up to order "
                         f"{order}: expected at least {order + 1} samples.")
    degree = int(min(max(degree, order), n - 1))
    t = np.arange(n) / (n - 1) if n > 1 else np.zeros(1)  # on [0, 1]: a well-conditioned fit, rescaled below
    coef = np.polynomial.polynomial.polyfit(t, y_init, degree) if n > 1 else y_init[:1]
    span = (n - 1) * dt if n > 1 else 1.0
    # the k-th derivative at t = 0 is k! times the coefficient of t^k, divided by span^k for the time unit of dt
    return np.concatenate([np.atleast_1d(coef[k]) * math.factorial(k) / span**k if k <= degree
                           else np.zeros(y_init.shape[1]) for k in range(order + 1)])


def samples_needed(derivative, order):
    """Samples the differentiation behind ``derivative`` needs for derivatives up to ``order`` (1 if unknown).

    Orders above 2 chain second and first derivatives, so they need what orders 1 and 2 need.

    Examples
    --------
    >>> from sindybench.differentiation import SavitzkyGolay
    >>> class Bound:  # a derivative callable bound to a method, as HiddenStateSINDy passes it
    ...     differentiation = SavitzkyGolay(window_length=21)
    >>> samples_needed(Bound(), 1), samples_needed(Bound(), 0)
    (21, 1)
    """
    need = getattr(getattr(derivative, "differentiation", None), "_min_samples", None)
    if need is None or order < 1:
        return 1
    return max(int(need(k)) for k in range(1, min(order, 2) + 1))


register_model(DerivativeHiddenState)

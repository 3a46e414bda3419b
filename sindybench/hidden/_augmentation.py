"""Derivative-coordinate augmentation: states ``(y, y', ..., y^(n-1))``."""

import numpy as np

from .._validation import check_integer
from ..io import register_model
from ._base import Design, HiddenStrategy, Structure, linear_term

__all__ = ["DerivativeHiddenState"]


class DerivativeHiddenState(HiddenStrategy):
    """Lift each output to ``(y, y', ..., y^(order-1))`` and learn ``y^(order)``.

    The chain rows ``d/dt y^(k) = y^(k+1)`` are fixed rows of the model (they
    hold by construction; nothing is overwritten after the fit); the library
    learns the highest derivative from ``Z = [y, y', ..., u]``. On new data the
    initial derivatives come from the first ``init_size`` output samples with
    the estimator's differentiation method (more when the method needs more:
    a ``SavitzkyGolay(window_length=21)`` uses 21).

    States are ordered derivative by derivative: for outputs ``y0, y1`` and
    ``order=2`` they are ``(y0, y1, y0', y1')``.

    Parameters
    ----------
    order : int, default=2
        Order of the learned derivative (1 = plain SINDy on the outputs).
    init_size : int, default=20
        Output samples used to estimate the initial derivatives on new data,
        or as many as the differentiation method needs if that is more.

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
        if y_init.shape[0] < need:
            method = type(getattr(derivative, "differentiation", derivative)).__name__
            raise ValueError(
                f"y_init has {y_init.shape[0]} samples; too short to estimate the initial derivatives up to order "
                f"{self.order - 1} with {method}: expected at least {need} samples."
            )
        y_init = y_init[: max(self.init_size, need)]
        return np.concatenate([derivative(y_init, k)[0] for k in range(self.order)])


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

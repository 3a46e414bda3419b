"""``OutputErrorRefinement``: the refinement settings an estimator's ``refine`` parameter takes."""

import numbers

from sklearn.base import BaseEstimator

from .._validation import check_bool, check_integer, check_positive, is_records
from ..io import register_model
from ._core import refine_simulation_error

__all__ = ["OutputErrorRefinement"]


class OutputErrorRefinement(BaseEstimator):
    """Refine a fitted sparse model by its open-loop simulation error.

    Pass it as ``refine=`` to :class:`~sindybench.SINDy` or
    :class:`~sindybench.HiddenStateSINDy`: after the equation-error fit (and
    the inner search), the nonzero coefficients, the strategy's physical
    parameters and the initial state (hidden states included) are refined
    by :func:`~sindybench.refine.refine_simulation_error` on the training
    record (on every training record, with one initial state each, when
    ``fit`` got several records). Its parameters are nested (``refine__max_nfev``,
    ``refine__prune``), so they can be searched like any other.

    Parameters
    ----------
    max_nfev : int, default=30
        Budget of simulations per refinement round.
    n_segments : int, default=1
        Multiple-shooting segments (1 = single shooting).
    continuity_weight : float, default=1.0
        Weight of the continuity residuals of multiple shooting.
    prune : float, default=0.0
        Drop terms contributing less than this fraction of their state's
        derivative (RMS along the simulation) and refine again; 0 keeps the
        support.
    physical : bool, default=True
        Refine the strategy's physical parameters (e.g. ``m, c, k``,
        ``k1, k2``) as they enter the fixed rows.
    initial_state : bool, default=True
        Refine the initial state of the training record.
    max_samples : int or None, default=None
        Refine on the first ``max_samples`` samples only (of each record;
        faster on long records); None = all.

    Examples
    --------
    >>> OutputErrorRefinement(prune=0.01).get_params()["prune"]
    0.01
    """

    def __init__(self, *, max_nfev=30, n_segments=1, continuity_weight=1.0, prune=0.0, physical=True,
                 initial_state=True, max_samples=None):
        self.max_nfev = max_nfev
        self.n_segments = n_segments
        self.continuity_weight = continuity_weight
        self.prune = prune
        self.physical = physical
        self.initial_state = initial_state
        self.max_samples = max_samples

    def _validate(self):
        check_integer(self.max_nfev, "max_nfev")
        check_integer(self.n_segments, "n_segments")
        check_positive(self.continuity_weight, "continuity_weight")
        check_positive(self.prune, "prune", strict=False)
        check_bool(self.physical, "physical")
        check_bool(self.initial_state, "initial_state")
        if self.max_samples is not None and (isinstance(self.max_samples, bool)
                                             or not isinstance(self.max_samples, numbers.Integral)
                                             or self.max_samples < 10):
            raise ValueError(f"max_samples must be an integer >= 10 or None (all samples); got {self.max_samples!r}.")

    def run(self, terms, coef, u, y, dt, *, x0, output_index, free=None, physical=None, make_rhs=None, **settings):
        """Refine with these settings (see :func:`~sindybench.refine.refine_simulation_error`)."""
        self._validate()
        if physical is not None and not self.physical:  # held at their values
            coef = coef + physical.coef(physical.values)
            if physical.make_rhs is not None:
                make_rhs = _Held(physical.make_rhs, physical.values)
            physical = None
        if is_records(y):  # several records: the first max_samples of each
            u, y = [self._head(u_r) for u_r in u], [self._head(y_r) for y_r in y]
        else:
            u, y = self._head(u), self._head(y)
        return refine_simulation_error(
            terms, coef, u, y, dt, x0=x0, output_index=output_index, free=free,
            physical=physical, free_x0=None if self.initial_state else [],
            make_rhs=make_rhs, n_segments=self.n_segments, continuity_weight=self.continuity_weight,
            prune=self.prune, max_nfev=self.max_nfev, **settings,
        )

    def _head(self, a):
        return a if self.max_samples is None else a[: self.max_samples]


class _Held:
    """``make_rhs(C)`` with the physical parameters held at ``values``."""

    def __init__(self, make_rhs, values):
        self.make_rhs, self.values = make_rhs, values

    def __call__(self, C):
        return self.make_rhs(C, self.values)


register_model(OutputErrorRefinement)

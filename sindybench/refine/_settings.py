"""``OutputErrorRefinement``, ``PredictionErrorRefinement``: the refinement settings an estimator's ``refine`` takes."""

import numbers

from sklearn.base import BaseEstimator

from .._validation import check_bool, check_integer, check_positive, is_records
from ..io import register_model
from ._core import refine_simulation_error
from ._parametrized import FreeParameters, LeastSquares, Shooting
from ._prediction import refine_prediction_error

__all__ = ["OutputErrorRefinement", "PredictionErrorRefinement"]


class _Refinement(BaseEstimator):
    """What both criteria's settings share: held physical parameters, the first ``max_samples``."""

    def _validate_common(self):
        check_integer(self.max_nfev, "max_nfev")
        check_positive(self.prune, "prune", strict=False)
        check_bool(self.physical, "physical")
        check_bool(self.initial_state, "initial_state")
        if self.max_samples is not None and (isinstance(self.max_samples, bool)
                                             or not isinstance(self.max_samples, numbers.Integral)
                                             or self.max_samples < 10):
            raise ValueError(f"max_samples must be an integer >= 10 or None (all samples); got {self.max_samples!r}.")

    def _prepare(self, u, y, free):
        """``(u, y, free)``: the records cut to ``max_samples``; the physical parameters held if not refined."""
        free = FreeParameters() if free is None else free
        free = free._replace(physical=free.physical if self.physical else None,  # held at the model's values
                             x0=free.x0 if self.initial_state else [])
        if is_records(y):  # several records: the first max_samples of each
            u, y = [self._head(u_r) for u_r in u], [self._head(y_r) for y_r in y]
        else:
            u, y = self._head(u), self._head(y)
        return u, y, free

    def _head(self, a):
        return a if self.max_samples is None else a[: self.max_samples]


class OutputErrorRefinement(_Refinement):
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
        self._validate_common()
        check_integer(self.n_segments, "n_segments")
        check_positive(self.continuity_weight, "continuity_weight")

    def run(self, dynamics, u, y, *, x0, free=None):
        """Refine ``dynamics`` with these settings (see :func:`~sindybench.refine.refine_simulation_error`).

        ``free``: a :class:`~sindybench.refine.FreeParameters` (the physical
        parameters are dropped, i.e. held, with ``physical=False``; the initial
        states with ``initial_state=False``).
        """
        self._validate()
        u, y, free = self._prepare(u, y, free)
        return refine_simulation_error(dynamics, u, y, x0=x0, free=free, prune=self.prune,
                                       shooting=Shooting(self.n_segments, self.continuity_weight),
                                       solver=LeastSquares(max_nfev=self.max_nfev))


class PredictionErrorRefinement(_Refinement):
    """Refine a fitted sparse model by the errors of its one-step (or ``horizon``-step) predictions.

    Pass it as ``refine=`` to :class:`~sindybench.SINDy` or
    :class:`~sindybench.HiddenStateSINDy`, like
    :class:`OutputErrorRefinement`: the same free parameters (nonzero
    coefficients, the strategy's physical parameters, the initial state) and
    the gain of the predictor are refined by
    :func:`~sindybench.refine.refine_prediction_error`, which corrects the
    predicted state from the measured outputs at every sample. Use it when
    the starting model's open-loop simulation diverges or drifts on the
    training record (an unstable plant recorded under feedback, an
    integrator, a self-excited oscillator), then judge the model by free run
    as before. It needs a compiled model (a built-in or custom library).

    Parameters
    ----------
    horizon : int, default=1
        Steps ahead of the fitted predictions (1 = one-step prediction error;
        larger values bridge to output error).
    max_nfev : int, default=30
        Budget of predictor runs per refinement round.
    prune : float, default=0.0
        As in :class:`OutputErrorRefinement`, along the predictions.
    physical : bool, default=True
        Refine the strategy's physical parameters.
    initial_state : bool, default=True
        Refine the first predicted state.
    fit_gain : bool, default=True
        Refine the observer gain with the model (else keep its start).
    noise : (Q, R) or None, default=None
        Process and measurement noise covariances (or diagonals) of the
        starting gain (the steady-state Kalman gain of the starting model);
        None: 1 % of each state's spread and 10 % of each output's.
    max_samples : int or None, default=None
        Refine on the first ``max_samples`` samples only (of each record).

    See Also
    --------
    OutputErrorRefinement : the open-loop simulation error.

    Examples
    --------
    >>> PredictionErrorRefinement(horizon=5).get_params()["horizon"]
    5
    """

    def __init__(self, *, horizon=1, max_nfev=30, prune=0.0, physical=True, initial_state=True, fit_gain=True,
                 noise=None, max_samples=None):
        self.horizon = horizon
        self.max_nfev = max_nfev
        self.prune = prune
        self.physical = physical
        self.initial_state = initial_state
        self.fit_gain = fit_gain
        self.noise = noise
        self.max_samples = max_samples

    def run(self, dynamics, u, y, *, x0, free=None):
        """Refine ``dynamics`` with these settings (see :func:`~sindybench.refine.refine_prediction_error`)."""
        self._validate_common()
        check_integer(self.horizon, "horizon")
        check_bool(self.fit_gain, "fit_gain")
        u, y, free = self._prepare(u, y, free)
        return refine_prediction_error(dynamics, u, y, x0=x0, free=free, horizon=self.horizon,
                                       free_gain=self.fit_gain, noise=self.noise, prune=self.prune,
                                       solver=LeastSquares(max_nfev=self.max_nfev))


register_model(OutputErrorRefinement)
register_model(PredictionErrorRefinement)

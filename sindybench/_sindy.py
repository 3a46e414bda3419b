"""Continuous-time SINDy with control inputs, as a scikit-learn estimator."""

import logging
import warnings

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils.validation import check_is_fitted

from ._equations import EquationRow, EquationsDisplayMixin, format_equations
from ._params import SharedDefaultsMixin
from ._sindy_persist import sindy_from_dict, sindy_to_dict
from ._stls import STLS
from ._validation import (
    check_array_like,
    check_bounds,
    check_dt,
    check_inputs_outputs,
    check_integer,
    check_model_inputs,
    check_n_samples,
    check_option,
    check_positive,
    check_signal,
    check_time,
    uniform_step,
)
from .differentiation import FiniteDifference, as_differentiation
from .io import SaveLoadMixin, register_model
from .libraries import PolynomialLibrary, as_library
from .metrics import make_simulation_scorer
from .refine._report import UncertaintyMixin
from .simulate import _HOLDS, _METHODS, SimulationError, make_rhs, simulate

__all__ = ["SINDy"]

logger = logging.getLogger(__name__)


def _check_names(names, n, prefix, name):
    if names is None:
        return [f"{prefix}{i}" for i in range(n)]
    if isinstance(names, str) or len(names) != n or not all(isinstance(s, str) for s in names):
        raise ValueError(f"{name} must be a list of {n} strings; got {names!r}.")
    return list(names)


class SINDy(UncertaintyMixin, EquationsDisplayMixin, SaveLoadMixin, SharedDefaultsMixin, RegressorMixin, BaseEstimator):
    """Continuous-time SINDy with control: ``y' = Theta([y, u]) coef``.

    ``fit`` differentiates the measured states ``y``, evaluates the library on
    ``Z = [y, u]`` and finds sparse coefficients with the optimizer (STLS by
    default); ``simulate`` integrates the model open loop from an initial
    state, driven by the inputs.

    Parameters
    ----------
    library : library, pysindy feature library or None, default=PolynomialLibrary(degree=2)
        Candidate terms over ``Z = [y, u]`` (states first); None means the
        default. Its parameters are searchable (``library__degree``).
    optimizer : regressor or None, default=STLS()
        Sparse regression ``fit(Theta, y_dot)`` exposing ``coef_`` of shape
        (n_states, n_terms); None means the default :class:`~sindybench.STLS`
        (threshold 0.1), whose ``optimizer__threshold`` is searchable.
    differentiation : differentiation method or None, default=FiniteDifference()
        Estimates ``y'`` from ``y``; None means the default; pysindy
        differentiation objects are accepted.
    dt : float or None, default=None
        Sampling interval, used unless ``fit``/``simulate`` receive ``dt`` or ``t``.
    n_substeps : int, default=1
        Integration steps per sampling interval in simulations.
    integrator : {"rk4", "euler"}, default="rk4"
    input_hold : {"zoh", "linear"}, default="zoh"
        Input between samples: held, or linearly interpolated.
    bounds : (lower, upper) or None, default=None
        State bounds for simulations (saturation), scalars or one per state.
    max_abs : float, default=inf
        A simulated state with ``|x| > max_abs`` counts as diverged.
    output_names, input_names : list of str or None, default=None
        Names of the columns of ``y`` and ``X`` (default ``y0, y1, ...`` and
        ``u0, u1, ...``), used by :meth:`equations` and the feature names.
    refine : OutputErrorRefinement or None, default=None
        After the equation-error fit, refine the nonzero coefficients and the
        first state by the open-loop simulation error of the training record
        (:class:`~sindybench.refine.OutputErrorRefinement`; needs uniform
        sampling). A model whose simulation of the training record diverges
        is kept as fitted, with a warning.

    Attributes
    ----------
    coef_ : ndarray of shape (n_states, n_terms)
        Row ``i`` holds the coefficients of ``y_i'``.
    library_, optimizer_, differentiation_ : fitted clones of the parameters
    terms_ : list of term tuples or None
        The library's symbolic terms (None for custom/external libraries,
        which simulate on the slower Python path and cannot be saved).
    feature_names_ : list of str
        Names of the library terms.
    dt_ : float or None
        Sampling interval of the training data (None for non-uniform ``t``).
    x0_ : ndarray of shape (n_states,)
        First training sample (the default initial state of :meth:`predict`;
        refined with ``refine``).
    refinement_ : dict or None
        Record of the refinement (see :meth:`RefinementResult.summary
        <sindybench.refine.RefinementResult.summary>`); None without ``refine``.
    n_states_, n_inputs_, n_features_in_ : int
        ``n_features_in_`` is the number of inputs (columns of ``X``).

    See Also
    --------
    sindybench.STLS, sindybench.simulate.simulate, sindybench.load_model

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary
    >>> from sindybench.simulate import simulate, TermsRHS
    >>> t = np.arange(0, 10, 0.01)
    >>> u = np.sin(t)[:, None]
    >>> truth = lambda x, u: np.array([-2.0 * x[0] + u[0]])
    >>> y = simulate(truth, [0.5], u, dt=0.01, input_hold="linear")
    >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.01).fit(u, y)
    >>> model.equations(precision=2)
    ["y0' = -2.00 y0 + 1.00 u0"]
    >>> round(model.score(u, y), 4)
    1.0
    """

    def __init__(
        self,
        *,
        library=PolynomialLibrary(degree=2),
        optimizer=STLS(),
        differentiation=FiniteDifference(),
        dt=None,
        n_substeps=1,
        integrator="rk4",
        input_hold="zoh",
        bounds=None,
        max_abs=np.inf,
        output_names=None,
        input_names=None,
        refine=None,
    ):
        self.library = library
        self.optimizer = optimizer
        self.differentiation = differentiation
        self.dt = dt
        self.n_substeps = n_substeps
        self.integrator = integrator
        self.input_hold = input_hold
        self.bounds = bounds
        self.max_abs = max_abs
        self.output_names = output_names
        self.input_names = input_names
        self.refine = refine

    # ------------------------------------------------------------------ checks
    def _check_params(self, n_states):
        check_dt(self.dt, allow_none=True)
        check_integer(self.n_substeps, "n_substeps")
        check_option(self.integrator, "integrator", _METHODS)
        check_option(self.input_hold, "input_hold", _HOLDS)
        check_positive(self.max_abs, "max_abs", allow_inf=True)
        check_bounds(self.bounds, n_states)
        if self.refine is not None and not hasattr(self.refine, "run"):
            raise ValueError(f"refine must be an OutputErrorRefinement or None; got {type(self.refine).__name__}.")

    @staticmethod
    def _resolve_time(dt, t, n_samples, fallback):
        """Return ``(dt, t)`` with exactly one of them set."""
        if dt is not None and t is not None:
            raise ValueError("give dt or t, not both.")
        if t is not None:
            return None, check_time(t, n_samples)
        dt = check_dt(dt if dt is not None else fallback, allow_none=True)
        if dt is None:
            raise ValueError("dt is None; pass dt (to the constructor, fit or simulate) or the sample times t.")
        return dt, None

    # --------------------------------------------------------------------- fit
    def fit(self, X, y, *, dt=None, t=None, x_dot=None):
        """Fit the sparse model ``y' = Theta([y, u]) coef``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
            Inputs ``u``; None or zero columns for an autonomous system.
        y : array-like of shape (n_samples, n_states) or (n_samples,)
            Measured states.
        dt : float, optional
            Sampling interval (overrides the constructor's ``dt``).
        t : array-like of shape (n_samples,), optional
            Strictly increasing sample times, instead of ``dt``.
        x_dot : array-like of shape (n_samples, n_states), optional
            Known derivatives of ``y``; skips ``differentiation``.

        Returns
        -------
        self
        """
        if y is None:
            raise ValueError(
                "SINDy requires y to be passed, but the target y is None; expected the measured states."
            )
        check_array_like(X, "X")
        check_array_like(y, "y")
        y_1d = np.asarray(y).ndim == 1
        X, y = check_inputs_outputs(X, y)
        n_samples, n_states = y.shape
        self._check_params(n_states)
        dt, t = self._resolve_time(dt, t, n_samples, self.dt)
        if n_samples < 3 and x_dot is None:
            raise ValueError(f"y has {n_samples} sample(s); expected at least 3 to estimate derivatives.")
        out_names = _check_names(self.output_names, n_states, "y", "output_names")
        in_names = _check_names(self.input_names, X.shape[1], "u", "input_names")

        self.differentiation_ = clone(as_differentiation(self.differentiation))
        if x_dot is None:
            x_dot = self.differentiation_.derivative(y, dt=dt, t=t)
            x_dot = check_signal(x_dot, "derivative of y", n_samples=n_samples)
        else:
            x_dot = check_signal(x_dot, "x_dot", n_samples=n_samples)
            if x_dot.shape[1] != n_states:
                raise ValueError(f"x_dot has {x_dot.shape[1]} columns; expected {n_states} (one per state in y).")

        self.library_ = clone(as_library(self.library))
        theta = self.library_.fit_transform(np.hstack([y, X]))
        check_n_samples(n_samples, theta.shape[1])
        theta = check_signal(theta, "library output Theta([y, u])")
        self.optimizer_ = clone(STLS() if self.optimizer is None else self.optimizer)
        self.optimizer_.fit(theta, x_dot)
        coef = np.asarray(self.optimizer_.coef_, dtype=float).reshape(n_states, theta.shape[1])
        if not np.all(np.isfinite(coef)):
            raise ValueError("the optimizer returned NaN or inf coefficients; check the data and its settings.")

        self.coef_ = coef
        self.terms_ = getattr(self.library_, "terms_", None)
        self.output_names_ = out_names
        self.input_names_ = in_names
        self.feature_names_ = [str(s) for s in self.library_.get_feature_names_out(out_names + in_names)]
        self.n_states_ = n_states
        self.n_inputs_ = X.shape[1]
        self.n_features_in_ = X.shape[1]
        self.dt_ = dt if dt is not None else uniform_step(t)
        self.x0_ = y[0].copy()
        self._y_1d = y_1d
        self.refinement_ = None
        if self.refine is not None:
            if t is not None:
                raise ValueError("refine needs uniformly sampled data (dt); got sample times t.")
            self._refine(X, y)
        return self

    def _refine(self, X, y):
        """Refine ``coef_`` and ``x0_`` by simulation error (see ``refine``)."""
        library, n = self.library_, self.n_states_
        settings = dict(n_substeps=self.n_substeps, method=self.integrator, input_hold=self.input_hold,
                        bounds=self.bounds, max_abs=self.max_abs)
        try:
            result = self.refine.run(self.terms_, self.coef_.T, X, y, self.dt_, x0=np.clip(y[0], *check_bounds(
                self.bounds, n)), output_index=tuple(range(n)), make_rhs=lambda C: make_rhs(library, C, n), **settings)
        except SimulationError as exc:
            warnings.warn(f"refinement skipped, the equation-error model is kept: {exc}", UserWarning, stacklevel=3)
            self.refinement_ = {"status": -1, "message": f"skipped: {exc}"}
            return
        self.coef_ = result.coef.T.copy()
        self.x0_ = result.x0
        self.refinement_ = result.summary()

    # -------------------------------------------------------------- simulation
    def _rhs(self):
        return make_rhs(self.library_, self.coef_.T, self.n_states_)

    def simulate(self, X, x0, *, dt=None, t=None, on_divergence="raise"):
        """Open-loop simulation driven by the inputs ``X`` from ``x0``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
            Inputs (None for an autonomous model, with ``t`` given).
        x0 : array-like of shape (n_states,)
            Initial state (returned as the first row).
        dt : float, optional
            Step (default: the training ``dt``).
        t : array-like of shape (n_samples,), optional
            Sample times instead of ``dt`` (may be non-uniform).
        on_divergence : {"raise", "nan"}, default="raise"
            Raise :class:`sindybench.SimulationError`, or fill NaN from the
            diverged sample on.

        Returns
        -------
        ndarray of shape (n_samples, n_states)
        """
        check_is_fitted(self)
        X = check_model_inputs(X, self.n_inputs_, type(self).__name__, n_samples=None if t is None else len(t))
        dt, t = self._resolve_time(dt, t, X.shape[0], self.dt_)
        return simulate(
            self._rhs(),
            x0,
            X,
            dt,
            t=t,
            n_substeps=self.n_substeps,
            method=self.integrator,
            input_hold=self.input_hold,
            bounds=self.bounds,
            max_abs=self.max_abs,
            on_divergence=on_divergence,
        )

    def predict(self, X, *, x0=None, y_init=None):
        """Simulated output for the inputs ``X``, NaN after a divergence.

        The simulation starts from ``x0``, or from ``y_init[0]`` (``y_init``:
        the first samples of the measured output, as the scorers of
        :mod:`sindybench.metrics` pass it). Without either it starts from the
        first training sample ``x0_`` and warns: that is only right when ``X``
        starts where the training data started. ``y_init[0]`` is clipped into
        ``bounds`` (a noisy measurement may lie just outside them).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
        x0 : array-like of shape (n_states,), optional
        y_init : array-like of shape (n_init, n_states), optional

        Returns
        -------
        ndarray of shape (n_samples, n_states), or (n_samples,) when ``fit`` got a 1-D ``y``
        """
        check_is_fitted(self)
        if x0 is not None and y_init is not None:
            raise ValueError("give x0 or y_init, not both.")
        if x0 is None and y_init is None:
            warnings.warn(
                "predict without x0 or y_init starts from the first training sample x0_; "
                "pass y_init (the first samples of the measured y) for new data.",
                UserWarning,
                stacklevel=2,
            )
            x0 = self.x0_
        if y_init is not None:
            y_init = check_signal(y_init, "y_init")
            if y_init.shape[1] != self.n_states_:
                raise ValueError(f"y_init has {y_init.shape[1]} columns; expected {self.n_states_} (one per state).")
            # a measured sample may lie slightly outside the model's bounds (noise)
            x0 = np.clip(y_init[0], *check_bounds(self.bounds, self.n_states_))
        y_pred = self.simulate(X, x0, on_divergence="nan")
        return y_pred[:, 0] if getattr(self, "_y_1d", False) else y_pred

    def score(self, X, y, sample_weight=None):
        """R^2 of the open-loop simulation started from ``y[0]``.

        A diverged simulation scores ``-inf`` (ranked last by scikit-learn
        searches, as by :func:`sindybench.metrics.make_simulation_scorer`).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
        y : array-like of shape (n_samples, n_states)
        sample_weight : None
            Not supported; must be None.

        Returns
        -------
        float
        """
        if sample_weight is not None:
            raise ValueError("sample_weight is not supported by SINDy.score; expected None.")
        X, y = check_inputs_outputs(X, y)
        return make_simulation_scorer("r2")(self, X, y)

    # ----------------------------------------------------------------- display
    def equations(self, precision=3, *, latex=False, errors=False):
        r"""Readable model equations, one line per state.

        Lines look like ``y0' = -4.822 y0 + 0.740 y0 u0 + 1.742 u0^2``; a
        constant term shows as its number, an all-zero row as ``0``. In a
        notebook a fitted model displays them typeset (``_repr_latex_``).

        Parameters
        ----------
        precision : int, default=3
            Decimals of the coefficients; coefficients that would show fewer
            than two significant digits, or ``|c| >= 1e6``, use ``precision``
            significant digits (``%.3g``) instead.
        latex : bool, default=False
            LaTeX lines instead (``\dot{y}_0 = -2.00 \, y_0``), the terms
            written from the library's symbolic terms (``\sqrt{x_1}``, ``|v| z``).
        errors : bool, default=False
            Write each refined coefficient with its standard error,
            ``(4.822 ± 0.012)`` (needs ``refine``; see :meth:`standard_errors`).

        Returns
        -------
        list of str

        Examples
        --------
        >>> from sindybench.libraries import PolynomialLibrary
        >>> t = np.arange(0, 3, 0.01)
        >>> y = np.column_stack([np.exp(-2 * t), 1 + np.exp(-t)])
        >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.01)
        >>> model.fit(None, y).equations(precision=2)
        ["y0' = -2.00 y0", "y1' = 1.00 - 1.00 y1"]
        >>> model.equations(precision=2, latex=True)[0]
        '\\dot{y}_0 = -2.00 \\, y_0'
        """
        return format_equations(self._equation_rows(), precision=precision, latex=latex,
                                errors=self._coef_errors() if errors else None)

    def _equation_rows(self):
        check_is_fitted(self)
        names = self.output_names_ + self.input_names_
        return [EquationRow(name, row, self.feature_names_, self.terms_, names)
                for name, row in zip(self.output_names_, self.coef_)]

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        tags.regressor_tags.poor_score = True
        tags.input_tags.allow_nan = False
        return tags


register_model(SINDy, to_dict=sindy_to_dict, from_dict=sindy_from_dict)

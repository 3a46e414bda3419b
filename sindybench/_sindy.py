"""Continuous-time SINDy with control inputs, as a scikit-learn estimator."""

import logging
import warnings

import numpy as np
from sklearn.base import clone
from sklearn.utils.validation import check_is_fitted

from ._base import DynamicsEstimator
from ._params import Constraint
from ._preprocessing import scaling_record
from ._equations import EquationRow
from ._sindy_persist import sindy_from_dict, sindy_to_dict
from .optimizers import STLS
from ._validation import (check_bounds, check_column_names, check_distinct_names, check_dt, check_positive, check_signal,
                          check_time, uniform_step)
from ._records import in_record, record_name
from .differentiation import FiniteDifference, as_differentiation
from .dynamics import assemble
from .io import register_model
from .libraries import PolynomialLibrary, as_library
from ._regression import fit_sparse

__all__ = ["SINDy"]

logger = logging.getLogger(__name__)


class SINDy(DynamicsEstimator):
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
    differentiation : differentiation method, "auto" or None, default=FiniteDifference()
        Estimates ``y'`` from ``y``; None means the default; ``"auto"``: the
        method the (first) record's bandwidth chooses
        (:func:`~sindybench.differentiation.data_differentiation`); pysindy
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
    max_abs : float, default=1e6
        A simulated state with ``|x| > max_abs`` counts as diverged (the
        default was ``inf`` before version 0.2; model files keep the value
        they were saved with).
    input_delay : int, default=0
        Input delay in samples: the model is driven by ``u(t - input_delay dt)``
        in ``fit``, ``simulate`` and ``predict`` (the first input is held
        before the record starts); see :func:`sindybench.identify.estimate_delay`.
    normalize : bool, default=False
        Centre and scale inside ``fit``: the library's features are taken of
        ``(z - mean) / std`` of ``Z = [y, u]`` and each derivative is divided
        by its root mean square, so the optimizer's threshold is relative
        (a fraction of the derivative's size per standard deviation of a
        feature) and no longer depends on the data's units. ``coef_``,
        :meth:`equations`, ``simulate`` and ``predict`` stay in the user's
        units: polynomial terms are expanded back exactly (a library with
        every lower-degree monomial, such as ``PolynomialLibrary``), other
        terms are scaled only. ``scaling_`` reports the operating point.
    output_names, input_names : list of str or None, default=None
        Names of the columns of ``y`` and ``X`` (default ``y0, y1, ...`` and
        ``u0, u1, ...``), used by :meth:`equations` and the feature names.
    refine : OutputErrorRefinement, PredictionErrorRefinement or None, default=None
        After the equation-error fit, refine the nonzero coefficients and the
        first state by the open-loop simulation error of the training record
        (:class:`~sindybench.refine.OutputErrorRefinement`; needs uniform
        sampling), or by its prediction error
        (:class:`~sindybench.refine.PredictionErrorRefinement`). A model whose
        simulation (predictor) of the training record diverges is kept as
        fitted, with a warning.

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
        refined with ``refine``); with several records, the first record's.
    refinement_ : dict or None
        Record of the refinement (see :meth:`RefinementResult.summary
        <sindybench.refine.RefinementResult.summary>`); None without ``refine``.
    dynamics_ : Dynamics
        The fitted model (right-hand side, states, outputs, bounds,
        simulation settings; see :class:`sindybench.dynamics.Dynamics`),
        driven by the delayed inputs (see ``input_delay``).
    scaling_ : dict or None
        With ``normalize``: ``{"mean": ..., "scale": ...}``, the operating
        point of the training ``Z = [y, u]`` (lists, states first); None without.
    output_names_, input_names_, state_names_ : list of str
        ``state_names_`` equals ``output_names_`` (every state is measured).
    output_index_ : tuple of int
        ``(0, 1, ..., n_states - 1)``.
    n_states_, n_outputs_, n_inputs_, n_features_in_ : int
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

    Several records (lists of arrays), each differentiated on its own:

    >>> y2 = simulate(truth, [-1.0], -u, dt=0.01, input_hold="linear")
    >>> model.fit([u, -u], [y, y2]).equations(precision=2)
    ["y0' = -2.00 y0 + 1.00 u0"]
    >>> round(model.score([u, -u], [y, y2]), 4)
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
        max_abs=1e6,
        input_delay=0,
        normalize=False,
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
        self.input_delay = input_delay
        self.normalize = normalize
        self.output_names = output_names
        self.input_names = input_names
        self.refine = refine

    _parameter_constraints = {**DynamicsEstimator._parameter_constraints,
                              "dt": Constraint(check_positive, allow_none=True)}

    # ------------------------------------------------------------------ checks
    def _check_params(self, n_states):
        self._validate_params()
        check_bounds(self.bounds, n_states)

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

        Fitted attributes are set only when the fit succeeds.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs), None, or list
            Inputs ``u``; None or zero columns for an autonomous system. With
            several records: a list of input arrays (or of None), one per
            record of ``y``, or None.
        y : array-like of shape (n_samples, n_states) or (n_samples,), or list of ndarray
            Measured states. A Python list of NumPy arrays is several records
            of one system (pysindy's convention; a list of numbers or of lists
            is one record): each record is differentiated separately (never
            across the seam between records) and the library rows of all
            records are stacked into one regression. Lists rather than a
            record-id column because scikit-learn's checks and splitters cut
            one array by rows; cross-validate over records by passing lists
            per fold (see the user guide). Several records need a uniform
            ``dt``; ``refine`` then refines the shared coefficients on all
            records with one initial state each (multiple shooting takes one
            record); ``x0_`` is the first record's first state.
        dt : float, optional
            Sampling interval (overrides the constructor's ``dt``).
        t : array-like of shape (n_samples,), optional
            Strictly increasing sample times, instead of ``dt`` (one record only).
        x_dot : array-like of shape (n_samples, n_states), or list, optional
            Known derivatives of ``y`` (a list of arrays for several records);
            skips ``differentiation``.

        Returns
        -------
        self
        """
        Xs, ys, y_1d, several = self._check_fit_records(X, y, y_kind="states")
        n_records, n_states = len(ys), ys[0].shape[1]
        self._check_refine_records(n_records)
        if several and x_dot is not None and (not isinstance(x_dot, list) or len(x_dot) != n_records):
            raise ValueError(f"with {n_records} records, x_dot must be a list of {n_records} arrays or None.")
        if several and t is not None:
            raise ValueError("several records need a uniform step dt; sample times t are not supported with lists.")
        x_dots = x_dot if several and x_dot is not None else [x_dot] * n_records
        self._check_params(n_states)
        Xs = [self.delayed_inputs(X_r) for X_r in Xs]
        dt, t = self._resolve_time(dt, t, ys[0].shape[0], self.dt)
        if self.refine is not None and t is not None:
            raise ValueError("refine needs uniformly sampled data (dt); got sample times t.")
        fitted_dt = dt if dt is not None else uniform_step(t)
        # "auto": the first record's bandwidth chooses the derivative
        differentiation = clone(as_differentiation(self.differentiation, ys[0], fitted_dt))
        derivatives = [self._derivative(differentiation, y_r, x_dot_r, dt, t, r, several)
                       for r, (y_r, x_dot_r) in enumerate(zip(ys, x_dots))]
        return self._fit_stacked(differentiation, Xs, ys, derivatives, fitted_dt, y_1d)

    @staticmethod
    def _derivative(differentiation, y, x_dot, dt, t, r, several):
        """The derivative of the record ``y`` (number ``r``): ``x_dot`` checked, or estimated by ``differentiation``."""
        n_samples, n_states = y.shape
        if x_dot is not None:
            name = record_name("x_dot", r, several)
            x_dot = check_signal(x_dot, name, n_samples=n_samples)
            if x_dot.shape[1] != n_states:
                raise ValueError(f"{name} has {x_dot.shape[1]} columns; expected {n_states} (one per state in "
                                 f"{record_name('y', r, several)}).")
            return x_dot
        if n_samples < 3:
            where = f"record {r}" if several else "y"
            raise ValueError(f"{where} has {n_samples} sample(s); expected at least 3 to estimate derivatives.")
        with in_record(r, several):
            x_dot = differentiation.derivative(y, dt=dt, t=t)
        return check_signal(x_dot, f"derivative of {record_name('y', r, several)}", n_samples=n_samples)

    def _fit_stacked(self, differentiation, Xs, ys, derivatives, fitted_dt, y_1d):
        """Regress the records' derivatives on the library of their stacked rows ``[y, X]``; ``x0_`` is ``ys[0][0]``."""
        X, y, x_dot = np.vstack(Xs), np.vstack(ys), np.vstack(derivatives)
        n_states = y.shape[1]
        out_names = check_column_names(self.output_names, n_states, "y", "output_names")
        in_names = check_column_names(self.input_names, X.shape[1], "u", "input_names")
        check_distinct_names(out_names, in_names)
        library = clone(as_library(self.library))
        optimizer = clone(STLS() if self.optimizer is None else self.optimizer)
        Z = np.hstack([y, X])
        coef = fit_sparse(library, optimizer, Z, x_dot, what="library output Theta([y, u])", normalize=self.normalize)
        dynamics = self._assemble(library, coef, out_names, fitted_dt)
        x0, refinement = y[0].copy(), None
        if self.refine is not None:
            coef, x0, refinement = self._refine(dynamics, Xs, ys, coef, x0)
        coef_ = coef.T.copy()
        dynamics = self._assemble(library, coef_.T, out_names, fitted_dt)  # as _rebuild_model does

        self.differentiation_, self.library_, self.optimizer_ = differentiation, library, optimizer
        self.coef_ = coef_
        self.terms_ = getattr(library, "terms_", None)
        self.output_names_ = out_names
        self.input_names_ = in_names
        self.feature_names_ = [str(s) for s in library.get_feature_names_out(out_names + in_names)]
        self.n_inputs_ = X.shape[1]
        self.n_features_in_ = X.shape[1]
        self.dt_ = fitted_dt
        self.x0_ = x0
        self._y_1d = y_1d
        self.refinement_ = refinement
        self.scaling_ = scaling_record(Z) if self.normalize else None
        self.dynamics_ = dynamics
        return self

    def _assemble(self, library, coef, names, dt):
        """The :class:`~sindybench.dynamics.Dynamics` of ``coef`` (n_terms, n_states) over ``library``."""
        return assemble(library, coef, state_names=names, bounds=self.bounds, dt=dt, n_substeps=self.n_substeps,
                        method=self.integrator, input_hold=self.input_hold, max_abs=self.max_abs)

    def _rebuild_model(self):
        """Assemble ``dynamics_`` from the plain fitted attributes (after loading a model file)."""
        self.dynamics_ = self._assemble(self.library_, self.coef_.T, self.output_names_, self.dt_)

    def _refine(self, dynamics, X, y, coef, x0):
        """``(coef, x0, record)`` refined by simulation error (see ``refine``); kept as given if it diverges.

        ``X`` and ``y`` are lists of records, one initial state each; ``x0`` is the first record's.
        """
        lo, hi = check_bounds(self.bounds, dynamics.n_states)
        starts = [np.clip(y_i[0], lo, hi) for y_i in y]
        result, record = self._run_refinement(dynamics, X, y, x0=starts)
        if result is None:
            return coef, x0, record
        return result.coef.copy(), result.x0, result.summary()

    # -------------------------------------------------------------- simulation
    def _initial_state(self, X, y_init):
        # a measured sample may lie slightly outside the model's bounds (noise)
        return np.clip(y_init[0], *check_bounds(self.bounds, self.n_states_))

    def simulate(self, X, *args, y_init=None, x0=None, dt=None, t=None, on_divergence="raise"):
        """Open-loop simulation driven by the inputs ``X``, from ``x0`` or from ``y_init``.

        The shared ``simulate`` (``y_init``: the simulation starts from
        ``y_init[0]`` clipped into ``bounds``), with another step ``dt`` or
        sample times ``t`` (may be non-uniform; ``X`` may then be None for an
        autonomous model) if wanted. ``simulate(X, x0)`` with ``x0`` by
        position is the old spelling: it still works, with a
        ``FutureWarning``; write ``simulate(X, x0=x0)``.

        Returns
        -------
        ndarray of shape (n_samples, n_states)
        """
        if args:
            if len(args) > 1 or x0 is not None:
                raise TypeError("SINDy.simulate takes X and the keywords y_init, x0, dt, t and on_divergence.")
            warnings.warn("SINDy.simulate(X, x0) is deprecated; pass the initial state by keyword: "
                          "simulate(X, x0=x0) (or y_init=...).", FutureWarning, stacklevel=2)
            x0 = args[0]
        return self._simulate(X, y_init, x0, on_divergence, dt=dt, t=t)

    def _time(self, n_samples, dt, t):
        return self._resolve_time(dt, t, n_samples, self.dt_)

    def _equation_rows(self):
        check_is_fitted(self)
        names = self.output_names_ + self.input_names_
        return [EquationRow(name, row, self.feature_names_, self.terms_, names)
                for name, row in zip(self.output_names_, self.coef_)]


register_model(SINDy, to_dict=sindy_to_dict, from_dict=sindy_from_dict)

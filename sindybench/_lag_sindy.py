"""Discrete-time SINDy on delay coordinates (a sparse polynomial NARX), as a scikit-learn estimator."""

import numbers

import numpy as np
from sklearn.base import clone
from sklearn.utils.validation import check_is_fitted

from ._base import SHARED_CONSTRAINTS, DynamicsEstimator
from ._equations import EquationRow, format_equation
from ._lag_sindy_persist import lag_sindy_from_dict, lag_sindy_to_dict
from ._lags import feature_names, lag_dynamics, lag_names, lag_states, output_states
from ._params import Constraint
from ._preprocessing import scaling_record
from ._regression import fit_sparse
from ._validation import check_column_names, check_distinct_names
from ._validation import check_integer, check_positive
from .dynamics import POW
from .io import register_model
from .libraries import PolynomialLibrary, as_library
from .metrics import rmse
from .optimizers import STLS

__all__ = ["LagSINDy"]

#: orders whose validation error is within this fraction of the least are equal: the fewest lags win
_TIE = 0.01
#: the one-step regression's targets: the increments ``y[k+1] - y[k]`` or the next outputs ``y[k+1]``
_TARGETS = ("increment", "next")


def check_lags(value, name):
    """A lag order: an integer >= 1, or ``"auto"`` (chosen in ``fit``)."""
    if isinstance(value, str) and value == "auto":
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1 or 'auto'; got {value!r}.")
    return int(value)


def check_target(value, name):
    """The regression target of the one-step fit: ``"increment"`` or ``"next"``."""
    if not isinstance(value, str) or value not in _TARGETS:
        raise ValueError(f"{name} must be one of {list(_TARGETS)}; got {value!r}.")
    return value


def check_param_grid(value, name):
    """A dict of non-empty lists of values, keyed by parameter names, or None."""
    if value is not None and (not isinstance(value, dict) or not all(
            isinstance(k, str) and isinstance(v, (list, tuple)) and len(v) > 0 for k, v in value.items())):
        raise ValueError(f"{name} must be a dict of non-empty lists keyed by the optimizer's parameter names "
                         f"(e.g. {{'n_terms': [8, 16]}}) or None; got {value!r}.")
    return value


def check_fraction(value, name):
    """A fraction in (0, 0.5]."""
    check_positive(value, name)
    if value > 0.5:
        raise ValueError(f"{name} must be a number in (0, 0.5]; got {value!r}.")
    return float(value)


class LagSINDy(DynamicsEstimator):
    """Discrete-time SINDy on lagged outputs and inputs: ``y[k+1] = y[k] + Theta(x[k], u[k]) coef``.

    The state ``x[k]`` holds each output's ``output_lags`` latest samples and
    each input's ``input_lags - 1`` past samples; the current input ``u[k]``
    drives the model. ``fit`` regresses the one-step increments
    ``y[k+1] - y[k]`` on the library of ``[x[k], u[k]]`` with the optimizer
    (STLS: a sparse polynomial NARX), then, with ``refine``, refines the
    nonzero coefficients and the first outputs by the free-run simulation
    error. Lags set to ``"auto"`` are chosen from the data: every order up
    to ``max_lags`` is fitted on the first part of each record and scored
    by its free run on the last ``validation_fraction``; the fewest lags
    within 1 % of the least error win.

    The fitted model is a :class:`~sindybench.dynamics.Dynamics` that
    explicit Euler integrates with one step per sample and a held input
    (see :func:`sindybench._lags.lag_dynamics`), so ``predict``, the
    refinements, the Kalman filter, k-step prediction, bands and model files
    work as for the continuous-time estimators. :meth:`equations` prints the
    difference equations.

    Parameters
    ----------
    library : library or None, default=PolynomialLibrary(degree=2)
        Candidate terms over ``[x[k], u[k]]`` (delay coordinates first).
    optimizer : regressor or None, default=STLS(threshold=0.01)
        Sparse regression; with ``normalize`` its threshold is relative.
    output_lags : int or "auto", default=2
        Samples of each output in the state (``na`` >= 1).
    input_lags : int or "auto", default=2
        Samples of each input the model sees, ``u[k], ..., u[k-nb+1]``
        (``nb`` >= 1; ignored without inputs).
    max_lags : int, default=4
        Largest order tried for an ``"auto"`` lag.
    validation_fraction : float, default=0.2
        The last part of each record that scores the orders of ``"auto"`` lags.
    dt : float or None, default=None
        Sampling interval (the Euler step; 1.0 when neither ``fit`` nor the
        constructor gives one).
    input_delay : int >= -1, default=0
        The model is driven by ``u[k - input_delay]`` (the names of the
        equations say so). -1 is a lead: ``y[k+1]`` depends on ``u[k+1]``,
        the input at the sample it predicts (a sampled record of a plant
        driven by a smooth input, whose input between the samples the next
        sample tells; the last input is held after a record's end).
    normalize : bool, default=True
        Centre and scale the features and the increments inside the
        regression (see :class:`~sindybench.SINDy`); coefficients stay in the
        user's units.
    max_abs : float, default=1e6
        A simulated state with ``|x| > max_abs`` counts as diverged.
    output_names, input_names : list of str or None, default=None
        Default ``y0, y1, ...`` and ``u0, u1, ...``.
    refine : OutputErrorRefinement, PredictionErrorRefinement or None, default=None
        Refine the nonzero coefficients of the outputs' rows and the first
        outputs (never the delay line) by simulation (or prediction) error.
    param_grid : dict of list or None, default=None
        Values of the optimizer's parameters searched with the orders (e.g.
        ``{"n_terms": [8, 16, 24]}`` for
        :class:`~sindybench.optimizers.ForwardOLS`): every combination is
        fitted and scored as the ``"auto"`` lags are, and the fewest lags
        within 1 % of the least error win, then the earliest values of the
        grid (list them sparsest first).
    target : {"increment", "next"}, default="increment"
        What the one-step regression fits: the increments ``y[k+1] - y[k]``,
        or the next outputs ``y[k+1]`` (then one is subtracted from the
        coefficient of ``y[k]``, which the library must hold). The model is
        the same difference equation; a selecting optimizer
        (:class:`~sindybench.optimizers.ForwardOLS`) chooses other terms for
        each: with ``"next"`` the output's own last sample is its first,
        as in the term selection of polynomial NARX models.

    Attributes
    ----------
    coef_ : ndarray of shape (n_outputs, n_terms)
        Row ``j``: the coefficients of the increment ``y_j[k+1] - y_j[k]``.
    output_lags_, input_lags_ : int
        The orders used (chosen by the data for ``"auto"``).
    lag_search_ : list of dict or None
        With ``"auto"`` lags or a ``param_grid``, every order (and
        parameters) tried and its validation error (RMSE over the output's
        standard deviation; inf for a divergence).
    library_, optimizer_ : fitted clones of the parameters
    terms_ : list of term tuples or None
    feature_names_ : list of str
        Names of the terms, in the delay coordinates (``y0[k-1] u0[k]``).
    dt_ : float
    x0_ : ndarray of shape (n_states,)
        The first training state (refined with ``refine``).
    refinement_ : dict or None
    scaling_ : dict or None
    dynamics_ : Dynamics
    output_names_, input_names_ : list of str
    n_inputs_, n_features_in_ : int

    See Also
    --------
    sindybench.SINDy : the continuous-time equation.
    sindybench.baselines.ARX : the linear lag model.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.libraries import PolynomialLibrary
    >>> u = np.random.default_rng(0).uniform(-1, 1, (400, 1))
    >>> y = np.zeros((400, 1))
    >>> for k in range(1, 399):
    ...     y[k + 1] = 1.2 * y[k] - 0.5 * y[k - 1] - 0.1 * y[k] ** 2 + 0.3 * u[k - 1]
    >>> model = LagSINDy(library=PolynomialLibrary(degree=2), output_lags=2, input_lags=2, normalize=False)
    >>> model.fit(u, y).equations(precision=2)
    ['y0[k+1] = 1.20 y0[k] - 0.50 y0[k-1] + 0.30 u0[k-1] - 0.1 y0[k]^2']
    >>> round(model.score(u, y), 6)
    1.0
    """

    def __init__(self, *, library=PolynomialLibrary(degree=2), optimizer=STLS(threshold=0.01), output_lags=2,
                 input_lags=2, max_lags=4, validation_fraction=0.2, dt=None, input_delay=0, normalize=True,
                 max_abs=1e6, output_names=None, input_names=None, refine=None, param_grid=None,
                 target="increment"):
        self.library = library
        self.optimizer = optimizer
        self.output_lags = output_lags
        self.input_lags = input_lags
        self.max_lags = max_lags
        self.validation_fraction = validation_fraction
        self.dt = dt
        self.input_delay = input_delay
        self.normalize = normalize
        self.max_abs = max_abs
        self.output_names = output_names
        self.input_names = input_names
        self.refine = refine
        self.param_grid = param_grid
        self.target = target

    _parameter_constraints = {
        **{k: SHARED_CONSTRAINTS[k] for k in ("max_abs", "normalize", "optimizer", "refine")},
        "input_delay": Constraint(check_integer, low=-1),
        "output_lags": Constraint(check_lags),
        "input_lags": Constraint(check_lags),
        "max_lags": Constraint(check_integer),
        "validation_fraction": Constraint(check_fraction),
        "dt": Constraint(check_positive, allow_none=True),
        "target": Constraint(check_target),
        "param_grid": Constraint(check_param_grid),
    }

    # --------------------------------------------------------------------- fit
    def fit(self, X, y, *, dt=None):
        """Fit the lag model by one-step regression (and ``refine``).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs), None, or list
            Inputs; a list of arrays with several records.
        y : array-like of shape (n_samples, n_outputs) or (n_samples,), or list of ndarray
            Measured outputs; a list of arrays is several records of one system
            (their regression rows are stacked; no row spans two records).
        dt : float, optional
            Sampling interval (overrides the constructor's ``dt``).

        Returns
        -------
        self
        """
        Xs, ys, y_1d, several = self._check_fit_records(X, y, y_kind="outputs")
        self._check_refine_records(len(ys))
        self._validate_params()
        dt = check_positive(dt if dt is not None else self.dt if self.dt is not None else 1.0, "dt")
        Xs = [self.delayed_inputs(X_r) for X_r in Xs]
        n_outputs, n_inputs = ys[0].shape[1], Xs[0].shape[1]
        out_names = check_column_names(self.output_names, n_outputs, "y", "output_names")
        in_names = check_column_names(self.input_names, n_inputs, "u", "input_names")
        check_distinct_names(out_names, in_names)
        search, params = None, {}
        if "auto" in (self.output_lags, self.input_lags) or self.param_grid:
            na, nb, params, search = self._search_lags(Xs, ys, dt, out_names, in_names)
        else:
            na, nb = self.output_lags, self.input_lags if n_inputs else 1
        _check_length(ys, max(na, nb) + 1, several)
        library, optimizer, coef, dynamics = self._fit_lags(Xs, ys, na, nb, dt, out_names, in_names, params)
        x0s = [lag_states(X_r, y_r, na, nb)[0] for X_r, y_r in zip(Xs, ys)]
        refinement = None
        if self.refine is not None:
            coef, x0s, refinement = self._refine(dynamics, Xs, ys, x0s, coef, na, nb, dt, library)
            dynamics = self._dynamics(library, coef, n_outputs, n_inputs, na, nb, dt, out_names, in_names)

        self.library_, self.optimizer_ = library, optimizer
        self.coef_ = coef.T.copy()
        self.terms_ = getattr(library, "terms_", None)
        self.output_lags_, self.input_lags_ = na, nb
        self.lag_search_ = search
        self.output_names_, self.input_names_ = out_names, in_names
        self.feature_names_ = feature_names(library, out_names, in_names, na, nb, self.input_delay)
        self.n_inputs_ = self.n_features_in_ = n_inputs
        self.dt_ = dt
        self.x0_ = np.asarray(x0s[0], dtype=float).copy()
        self._y_1d = y_1d
        self.refinement_ = refinement
        self.scaling_ = (scaling_record(np.vstack([np.hstack([lag_states(X_r, y_r, na, nb), X_r])
                                                   for X_r, y_r in zip(Xs, ys)])) if self.normalize else None)
        self.dynamics_ = dynamics
        return self

    def _dynamics(self, library, coef, n_outputs, n_inputs, na, nb, dt, out_names, in_names):
        names, _ = lag_names(out_names, in_names, na, nb, self.input_delay)
        return lag_dynamics(library, coef, n_outputs=n_outputs, n_inputs=n_inputs, na=na, nb=nb, dt=dt,
                            state_names=names, max_abs=self.max_abs)

    def _fit_lags(self, Xs, ys, na, nb, dt, out_names, in_names, params=None):
        """The one-step regression of orders ``(na, nb)``: ``(library, optimizer, coef, dynamics)``."""
        library = clone(as_library(self.library))
        optimizer = clone(STLS(threshold=0.01) if self.optimizer is None else self.optimizer)
        optimizer.set_params(**(params or {}))
        n_outputs, n_inputs = ys[0].shape[1], Xs[0].shape[1]
        Z, target = _design(Xs, ys, na, nb)
        if self.target == "next":
            target = target + Z[:, list(output_states(n_outputs, na))]
        coef = fit_sparse(library, optimizer, Z, target, what="library output Theta([x[k], u[k]])",
                          normalize=self.normalize)
        if self.target == "next":
            coef = _next_to_increment(library, coef, output_states(n_outputs, na))
        return library, optimizer, coef, self._dynamics(library, coef, n_outputs, n_inputs, na, nb, dt, out_names,
                                                        in_names)

    def _search_lags(self, Xs, ys, dt, out_names, in_names):
        """The orders of the ``"auto"`` lags (and the ``param_grid``'s values) with the least free-run error on each
        record's last part: ``(na, nb, params, table)``."""
        from sklearn.model_selection import ParameterGrid

        n_inputs = Xs[0].shape[1]
        known = (STLS(threshold=0.01) if self.optimizer is None else self.optimizer).get_params()
        unknown = sorted(set(self.param_grid or {}) - set(known))
        if unknown:
            raise ValueError(f"param_grid names {unknown}, not parameters of the optimizer; expected some of "
                             f"{sorted(known)}.")
        grid_p = list(ParameterGrid(self.param_grid)) if self.param_grid else [{}]
        grid_a = range(1, self.max_lags + 1) if self.output_lags == "auto" else [self.output_lags]
        grid_b = ([1] if not n_inputs else range(1, self.max_lags + 1) if self.input_lags == "auto"
                  else [self.input_lags])
        n_init = max(max(grid_a), max(grid_b))
        cuts = [int(round(y_r.shape[0] * (1.0 - self.validation_fraction))) for y_r in ys]
        for r, (y_r, cut) in enumerate(zip(ys, cuts)):
            if cut < n_init + 2 or y_r.shape[0] - cut < n_init + 2:
                where = f"record {r}" if len(ys) > 1 else "y"
                raise ValueError(f"{where} has {y_r.shape[0]} samples; expected at least {2 * (n_init + 2)} to choose "
                                 f"the lags (up to {n_init}) on its last {self.validation_fraction:g}.")
        train_X = [X_r[:c] for X_r, c in zip(Xs, cuts)]
        train_y = [y_r[:c] for y_r, c in zip(ys, cuts)]
        table, order = [], []
        for na, nb, (p, params) in ((a, b, pp) for a in grid_a for b in grid_b for pp in enumerate(grid_p)):
            try:
                dyn = self._fit_lags(train_X, train_y, na, nb, dt, out_names, in_names, params)[3]
                errors = []
                for X_r, y_r, c in zip(Xs, ys, cuts):
                    y_hat = free_run(dyn, X_r[c:], y_r[c:c + n_init], na, nb)[:, list(dyn.output_index)]
                    scale = np.where(np.std(y_r, axis=0) > 0, np.std(y_r, axis=0), 1.0)
                    e = rmse(y_r[c + n_init:], y_hat[n_init:], multioutput="raw_values") / scale
                    errors.append(float(np.mean(e)) if np.all(np.isfinite(y_hat)) else np.inf)
                error, status = float(np.mean(errors)), "ok"
            except ValueError as exc:
                error, status = np.inf, f"failed: {exc}"
            table.append({"output_lags": na, "input_lags": nb, "error": error, "status": status,
                          **({"params": params} if self.param_grid else {})})
            order.append(p)
        least = min(row["error"] for row in table)
        # the fewest lags within 1 % of the least error (ties are common on clean data), then the grid's first values
        k = min((k for k, row in enumerate(table) if row["error"] <= least * (1.0 + _TIE) + 1e-12),
                key=lambda k: (table[k]["output_lags"] + table[k]["input_lags"], table[k]["output_lags"], order[k]))
        best = table[k]
        if not np.isfinite(best["error"]):
            raise ValueError(f"every order up to max_lags={self.max_lags} diverged or failed on the validation part; "
                             "expected at least one that simulates (try a smaller library or threshold).")
        return best["output_lags"], best["input_lags"], grid_p[order[k]], table

    def _refine(self, dynamics, Xs, ys, x0s, coef, na, nb, dt, library):
        """``(coef, x0s, record)``: the outputs' nonzero increments and first outputs refined (see ``refine``).

        The refinement starts from the one-step fit, or from its linear terms
        refitted alone (the others at zero, still free) when those simulate
        the training records better: a one-step fit that diverges in free run
        cannot be refined by simulation error, and one that drifts often
        leads it to a poor local minimum. The record says which
        (``"start": "linear"`` or ``"one-step"``).
        """
        from .refine import FreeParameters

        n_lib, outputs = coef.shape[0], list(dynamics.output_index)
        mask = np.zeros(dynamics.coef.shape, dtype=bool)
        mask[:n_lib, outputs] = coef != 0
        start = "one-step"
        linear = _linear_start(library, coef, *_design(Xs, ys, na, nb))
        if linear is not None and np.any(linear != coef):
            linear_dynamics = lag_dynamics(library, linear, n_outputs=len(outputs), n_inputs=Xs[0].shape[1], na=na,
                                           nb=nb, dt=dt, max_abs=self.max_abs)
            if _free_run_error(linear_dynamics, Xs, ys, x0s) < _free_run_error(dynamics, Xs, ys, x0s):
                coef, dynamics, start = linear, linear_dynamics, "linear"
        y_states = [j * na + i for j in range(len(outputs)) for i in range(na)]
        result, record = self._run_refinement(dynamics, Xs, ys, x0=np.array(x0s),
                                              free=FreeParameters(coef=mask, x0=y_states))
        if result is None:
            return coef, x0s, dict(record, start=start)
        starts = getattr(result, "initial_states", None)
        starts = list(np.asarray(starts)) if starts is not None else [np.asarray(result.x0, dtype=float)]
        return np.asarray(result.coef)[:n_lib, outputs] * dt, starts, dict(result.summary(), start=start)

    def library_input(self, X, y):
        """The library's input ``Z = [x[k], u[k]]`` of a record (delay coordinates held before its start).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
        y : array-like of shape (n_samples, n_outputs)

        Returns
        -------
        ndarray of shape (n_samples, n_states + n_inputs)
            ``library_.transform`` of it gives the features of the regression
            (whose rows start at ``max(output_lags_, input_lags_) - 1``).
        """
        check_is_fitted(self)
        self._check_one_record("library_input", X, y)
        y = self._check_y_init(y)
        X = self.delayed_inputs(self._check_X(X, y.shape[0]))
        return np.hstack([lag_states(X, y, self.output_lags_, self.input_lags_), X])

    # -------------------------------------------------------------- simulation
    def _initial_state(self, X, y_init):
        """The delay coordinates at the first sample: ``y_init[0]`` and ``X[0]`` held before it."""
        return lag_states(X[:1], y_init[:1], self.output_lags_, self.input_lags_)[0]

    def _simulate(self, X, y_init, x0, on_divergence, *, dt=None, t=None):
        """From ``x0``, or from the first samples of ``y_init``: the first ``max(na, nb) - 1`` outputs measured."""
        if y_init is None:
            return super()._simulate(X, y_init, x0, on_divergence)
        check_is_fitted(self)
        self._check_one_record("simulate", X, y_init)
        if x0 is not None:
            raise ValueError("give exactly one of x0 and y_init.")
        y_init = self._check_y_init(y_init)
        X = self.delayed_inputs(self._check_X(X, y_init.shape[0] if X is None else None))
        return free_run(self.dynamics_, X, y_init, self.output_lags_, self.input_lags_, on_divergence)

    # ----------------------------------------------------------------- display
    def equations(self, precision=3, *, latex=False, errors=False):
        """The difference equations, one per output: ``y0[k+1] = 1.2 y0[k] - 0.5 y0[k-1] + 0.3 u0[k-1]``.

        Parameters
        ----------
        precision : int, default=3
        latex : bool, default=False
            LaTeX lines (the names as upright text).
        errors : bool, default=False
            Each refined coefficient with its standard error (needs ``refine``).

        Returns
        -------
        list of str
        """
        rows = [self._equation_rows()[i] for i in self.output_index_]
        errs = None
        if errors:
            all_errors = self._coef_errors()
            errs = [np.asarray(all_errors[i]) * self.dt_ for i in self.output_index_]
        lines = []
        for k, row in enumerate(rows):
            coef, features, err = _difference_row(self.coef_[k], row.features, row.terms, row.variables,
                                                  self.output_index_[k], None if errs is None else errs[k])
            if latex:
                features = [f if f == "1" else r"\mathrm{" + f.replace(" ", r"\ ") + "}" for f in features]
            text = format_equation(row.name, coef, features, precision=precision, latex=latex, errors=err)
            lhs = rf"\mathrm{{{row.name}[k+1]}}" if latex else f"{row.name}[k+1]"
            lines.append(f"{lhs} = {text.split(' = ', 1)[1]}")
        return lines

    def _equation_rows(self):
        """One row per state: the outputs' increments over ``dt`` (as ``dynamics_``), the delay line fixed."""
        check_is_fitted(self)
        states, inputs = lag_names(self.output_names_, self.input_names_, self.output_lags_, self.input_lags_,
                                   self.input_delay)
        variables = states + inputs
        rows = []
        outputs = list(self.output_index_)
        for i, name in enumerate(states):
            if i in outputs:
                j = outputs.index(i)
                rows.append(EquationRow(self.output_names_[j], self.coef_[j] / self.dt_, self.feature_names_,
                                        self.terms_, variables))
            else:
                rows.append(EquationRow(name, None, self.feature_names_, self.terms_, variables, learned=False,
                                        fixed="delay line"))
        return rows

    def _rebuild_model(self):
        """Assemble ``dynamics_`` from the plain fitted attributes (after loading a model file)."""
        self.dynamics_ = self._dynamics(self.library_, self.coef_.T, len(self.output_names_), self.n_inputs_,
                                        self.output_lags_, self.input_lags_, self.dt_, self.output_names_,
                                        self.input_names_)


def _design(Xs, ys, na, nb):
    """The one-step regression of orders ``(na, nb)``: ``Z = [x[k], u[k]]`` and the increments ``y[k+1] - y[k]``."""
    start = max(na, nb) - 1
    rows_Z, rows_target = [], []
    for X_r, y_r in zip(Xs, ys):
        rows_Z.append(np.hstack([lag_states(X_r, y_r, na, nb), X_r])[start:-1])
        rows_target.append(y_r[start + 1:] - y_r[start:-1])
    return np.vstack(rows_Z), np.vstack(rows_target)


def _free_run_error(dynamics, Xs, ys, x0s):
    """Mean squared free-run output error over the records (inf when a run diverges)."""
    total, count = 0.0, 0
    outputs = list(dynamics.output_index)
    for X_r, y_r, x0 in zip(Xs, ys, x0s):
        y_hat = dynamics.simulate(X_r, x0, on_divergence="nan")[:, outputs]
        if not np.all(np.isfinite(y_hat)):
            return np.inf
        total, count = total + float(np.sum((y_hat - y_r) ** 2)), count + y_r.size
    return total / count


def _is_linear(term):
    """A constant or one variable to the first power."""
    return len(term) == 0 or (len(term) == 1 and term[0][1] == POW and term[0][2] == 1)


def _linear_start(library, coef, Z, target):
    """The support's constant and linear terms refitted alone by least squares (the others zero); None without terms."""
    terms = getattr(library, "terms_", None)
    if terms is None:
        return None
    theta = library.transform(Z)
    start = np.zeros_like(coef)
    for j in range(coef.shape[1]):
        cols = [i for i, term in enumerate(terms) if coef[i, j] != 0 and _is_linear(term)]
        if cols:
            start[cols, j] = np.linalg.lstsq(theta[:, cols], target[:, j], rcond=None)[0]
    return start


def _next_to_increment(library, coef, states):
    """The coefficients of the next outputs made those of the increments: one less on each output's ``y[k]``."""
    terms = [tuple(tuple(f) for f in term) for term in getattr(library, "terms_", None) or []]
    coef = np.array(coef, dtype=float)
    for j, state in enumerate(states):
        own = ((state, POW, 1, 0),)
        if own not in terms:
            raise ValueError("target='next' needs a library with the linear term of each output's last sample "
                             f"(y[k], variable {state}); expected a library such as PolynomialLibrary.")
        coef[terms.index(own), j] -= 1.0
    return coef


def _check_length(ys, need, several):
    for r, y_r in enumerate(ys):
        if y_r.shape[0] < need:
            where = f"record {r}" if several else "y"
            raise ValueError(f"{where} has {y_r.shape[0]} samples; expected at least {need} (the lags and one more "
                             "sample for one regression row).")


def _difference_row(coef, features, terms, variables, state, errors):
    """The coefficients of ``y[k+1]`` (the increment's plus one on ``y[k]``) and the features they multiply."""
    coef, features = np.array(coef, dtype=float), list(features)
    errors = None if errors is None else list(errors)
    own = ((state, POW, 1, 0),)
    index = None
    if terms is not None:
        index = next((i for i, term in enumerate(terms) if tuple(tuple(f) for f in term) == own), None)
    if index is None:  # a library without the linear term of y[k]: the identity as a feature of its own
        coef, features = np.append(coef, 0.0), features + [variables[state]]
        errors = None if errors is None else errors + [float("nan")]
        index = len(coef) - 1
    coef[index] += 1.0
    return coef, features, errors


def free_run(dynamics, X, y_init, na, nb, on_divergence="nan"):
    """The states of a lag model's free run over ``X``, the first ``min(len(y_init), max(na, nb)) - 1`` measured.

    The state at sample ``s`` is built from the measured ``y_init[:s + 1]``
    and ``X[:s + 1]`` (exact from ``s = max(na, nb) - 1``), the rows before
    it too, and the model runs from there.
    """
    s = min(y_init.shape[0], max(na, nb), X.shape[0]) - 1
    head = lag_states(X[:s + 1], y_init[:s + 1], na, nb)
    tail = dynamics.simulate(X[s:], head[s], on_divergence=on_divergence)
    return np.vstack([head[:s], tail])


register_model(LagSINDy, to_dict=lag_sindy_to_dict, from_dict=lag_sindy_from_dict)

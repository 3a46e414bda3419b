"""``HiddenStateSINDy``: SINDy with control for systems whose state is partly unmeasured."""

import logging
import numbers
import warnings
from typing import NamedTuple

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils.validation import check_is_fitted

from .._equations import EquationRow, EquationsDisplayMixin, format_equations
from .._params import SharedDefaultsMixin
from .._stls import STLS
from .._validation import (
    check_array_like,
    check_bool,
    check_dt,
    check_inputs_outputs,
    check_integer,
    check_model_inputs,
    check_n_samples,
    check_option,
    check_positive,
    check_signal,
)
from ..differentiation import FiniteDifference, as_differentiation
from ..io import SaveLoadMixin, register_model
from ..libraries import as_library, evaluate_terms, term_name
from ..metrics import make_simulation_scorer
from ..refine._report import UncertaintyMixin
from ..simulate import _HOLDS, SimulationError, TermsRHS, simulate
from ._augmentation import DerivativeHiddenState
from ._base import Design, HiddenStrategy, ModelView, Structure
from ._persist import hidden_sindy_from_dict, hidden_sindy_to_dict
from ._refinement import initial_state, refine_candidate
from ._search import check_space, minimize

__all__ = ["HiddenStateSINDy"]

logger = logging.getLogger(__name__)

_PENALTY = 1e3  # validation score of a diverged or failed candidate (scores are normalized RMSEs)
_HIDDEN_PREFIX = "hidden__"
_VALIDATIONS = ("block", "continued", "full")
_INITIAL_STATES = ("strategy", "fit", "periodic")


class _Derivative:
    """``derivative(a, order=1)`` bound to a differentiation method and ``dt`` (picklable).

    Orders above 2 chain second and first derivatives. While an array is
    ``pinned`` (the measured outputs, during the inner search), derivatives of
    arrays equal to it are computed once and then copied from a memo.
    """

    def __init__(self, differentiation, dt):
        self.differentiation = differentiation
        self.dt = dt
        self.pinned, self._memo = None, {}

    def pin(self, a):
        """Memoize derivatives of ``a`` (None stops and clears the memo)."""
        self.pinned = None if a is None else np.asarray(a, dtype=float)
        self._memo = {}

    def __call__(self, a, order=1):
        a = np.asarray(a, dtype=float)
        if order == 0:
            return a.copy()
        p = self.pinned
        if p is not None and a.size == p.size and np.array_equal(a.reshape(p.shape), p):
            key = (order, a.shape)
            if key not in self._memo:
                self._memo[key] = self._compute(a, order)
            return self._memo[key].copy()
        return self._compute(a, order)

    def _compute(self, a, order):
        if order <= 2:
            d = self.differentiation.derivative(a, dt=self.dt, order=order)
            return np.asarray(d, dtype=float).reshape(a.shape)
        return self(self(a, 2), order - 2)


class _Candidate(NamedTuple):
    """One fitted model for given physical parameters (internal)."""

    params: dict
    structure: Structure
    library: object
    optimizer: object
    differentiation: object
    coef: np.ndarray
    derivative: _Derivative
    design: Design
    rhs: object


def _build_rhs(structure, library, coef):
    """Full right-hand side: learned rows from ``library``/``coef``, fixed rows from ``structure``."""
    n_states, learned = structure.n_states, list(structure.learned)
    fixed_coef = structure.fixed_coef.copy()
    fixed_coef[:, learned] = 0.0
    lib_terms = getattr(library, "terms_", None)
    if lib_terms is not None and structure.fixed_rhs is None:
        full = np.zeros((len(lib_terms) + len(structure.fixed_terms), n_states))
        full[: len(lib_terms), learned] = coef
        full[len(lib_terms) :] = fixed_coef
        return TermsRHS(full, list(lib_terms) + list(structure.fixed_terms), n_states)
    return _PythonRHS(structure, library, coef, fixed_coef)


class _PythonRHS:
    """Right-hand side on the Python path (non-compilable library or Python fixed rows); picklable."""

    def __init__(self, structure, library, coef, fixed_coef):
        self.n_states, self.learned = structure.n_states, list(structure.learned)
        self.fixed_terms, self.fixed_rhs, self.fixed_coef = structure.fixed_terms, structure.fixed_rhs, fixed_coef
        self.library, self.coef = library, coef
        lib_terms = getattr(library, "terms_", None)
        if lib_terms is not None:  # evaluate only the active terms, without the transformer's checks
            active = np.flatnonzero(np.any(coef != 0, axis=1))
            self.active_terms, self.active_coef = [lib_terms[j] for j in active], coef[active]
        else:
            self.active_terms = None

    def __call__(self, x, u):
        z = np.concatenate([x, u])[None, :]
        if self.fixed_rhs is not None:
            dx = np.array(self.fixed_rhs(x, u), dtype=float).reshape(self.n_states)
        elif self.fixed_terms:
            dx = evaluate_terms(self.fixed_terms, z)[0] @ self.fixed_coef
        else:
            dx = np.zeros(self.n_states)
        if self.active_terms is not None:
            dx[self.learned] = evaluate_terms(self.active_terms, z)[0] @ self.active_coef
        else:
            dx[self.learned] = self.library.transform(z)[0] @ self.coef
        return dx


class HiddenStateSINDy(UncertaintyMixin, EquationsDisplayMixin, SaveLoadMixin, SharedDefaultsMixin, RegressorMixin, BaseEstimator):
    """SINDy with control for partly hidden states, with a physics-guided hidden-state strategy.

    The ``hidden`` strategy turns measured outputs into a full state (observed +
    reconstructed hidden states) and fixes the rows of the model that physics
    dictates; the ``library`` and the sparse ``optimizer`` learn the remaining
    rows. Physical guesses left ``None`` in the strategy (and the estimator
    parameters listed in ``search_params``) are searched inside ``fit`` with
    Optuna's TPE sampler: each candidate is fitted on the training data without
    its last ``validation_size`` samples and scored by the error of an
    open-loop simulation (see ``validation``). A diverging candidate is a bad
    trial, never a crash.

    Parameters
    ----------
    hidden : HiddenStrategy, default=DerivativeHiddenState(order=2)
        The strategy (None means the default); its parameters are
        searchable (``hidden__order``).
    library : transformer, default=None
        Candidate functions of ``Z = [states, inputs]``; None means the
        strategy's ``default_library()`` (it depends on the strategy, so it
        is chosen in ``fit``). pysindy libraries are wrapped.
    optimizer : regressor, default=STLS(threshold=0.0)
        Sparse regressor with ``coef_`` (n_targets, n_features); the default
        is plain least squares (None means the same), and
        ``optimizer__threshold`` sets sparsity in the units of your problem.
    differentiation : object, default=FiniteDifference()
        Derivative method with ``derivative(y, *, dt, order)`` (see
        :mod:`sindybench.differentiation`); None means finite differences.
    dt : float, default=None
        Sampling interval (required, here or in ``fit``).
    validation_size : float or int, default=0.2
        Validation block at the end of the training data: a fraction in
        (0, 1) or a number of samples. Used only when something is searched.
    validation : {"block", "continued", "full"}, default="block"
        How a candidate is scored in the inner search (normalized RMSE of an
        open-loop simulation of the outputs):

        * ``"block"``: the validation block alone, started the way new data is
          started (``strategy.initial_state`` from its first samples);
        * ``"continued"``: the validation block, simulated without a restart
          from the first training state (the reconstructed state at sample 0),
          so the model must stay valid over the whole record;
        * ``"full"``: as ``"continued"``, scored over the whole record
          (training and validation block).

        The simulated candidate is always the one fitted without the
        validation block. ``"continued"`` and ``"full"`` reject candidates
        that fit a short block but drift away over long horizons (slow
        hidden states such as the cascaded tanks' upper tank).
    n_trials : int, default=50
        Candidates evaluated by the inner search.
    local_trials : int, default=0
        How many of the ``n_trials`` refine the best TPE candidates locally
        (bounded Nelder-Mead on the float parameters from the 3 best distinct
        candidates); the other ``n_trials - local_trials`` are TPE trials.
        Useful when good candidates lie in narrow valleys.
    random_state : int, RandomState or None, default=None
        Seed of the TPE sampler.
    search_params : dict, optional
        Further parameters of this estimator to search jointly, by nested name
        (``"differentiation__window_length": (5, 41)``,
        ``"optimizer__threshold": (1e-3, 1.0, True)``, a list = choices).
    refit : bool, default=True
        Refit the best candidate on all the training data (else keep the fit
        without the validation block).
    show_progress_bar : bool, default=True
        Show a progress bar of the inner search (``tqdm.auto``) when there is
        somewhere to draw it, a notebook or a terminal, never in a log file;
        the environment variable ``SINDYBENCH_PROGRESS=0`` turns bars off.
    n_substeps : int, default=1
        Integration steps per sample in simulations.
    input_hold : {"zoh", "linear"}, default="zoh"
        Input interpolation between samples in simulations.
    max_abs : float, default=1e6
        A simulated state beyond this magnitude counts as divergence.
    refine : OutputErrorRefinement or None, default=None
        Refine the final model by its open-loop simulation error on the
        training record (:class:`~sindybench.refine.OutputErrorRefinement`):
        the nonzero learned coefficients, the strategy's physical parameters
        (:meth:`HiddenStrategy.refinable`, e.g. ``m, c, k`` or ``k1, k2``) and
        the initial state. Only the model chosen by the inner search is
        refined: a refinement costs tens of simulations with sensitivities,
        about as much as the whole inner search of a short record, and it
        polishes a basin rather than moving to another one.
    initial_state : {"strategy", "fit", "periodic"}, default="strategy"
        How ``predict`` / ``simulate`` start on new data from ``y_init``:
        the strategy's estimate; that estimate refined by least squares of
        the simulation of the ``y_init`` samples (all states, hidden ones
        included, free); or, for one period of a periodic input, the state
        reached after simulating two periods from the strategy's estimate
        (uses the input alone).

    Attributes
    ----------
    hidden_ : HiddenStrategy
        The fitted clone of the strategy.
    params_ : dict
        All physical parameters of the final model (given and searched).
    best_params_ : dict
        Values of the best trial (``hidden__<name>`` for physical parameters);
        empty when nothing was searched.
    search_results_ : list of (dict, float)
        Every trial's values and validation score (normalized RMSE).
    library_, optimizer_, differentiation_ : fitted components
    coef_ : ndarray of shape (n_learned, n_library_terms)
        Learned coefficients, one row per learned state.
    structure_ : Structure
    rhs_ : TermsRHS or callable
        Right-hand side of the full state.
    states_ : ndarray of shape (n_samples, n_states)
        State trajectory reconstructed on the training data (with ``refine``,
        the refined model's simulation of it from ``x0_``).
    hidden_states_ : ndarray of shape (n_samples, n_hidden)
        The reconstructed hidden (not measured) states on the training data.
    x0_ : ndarray of shape (n_states,)
        First training state (refined with ``refine``).
    refinement_ : dict or None
        Record of the refinement (costs before and after, simulations,
        status, refined physical parameters, pruned terms); None without
        ``refine``.
    state_names_ : list of str
    dt_ : float
    n_features_in_ : int
        Number of inputs.
    n_outputs_ : int

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.hidden import DerivativeHiddenState
    >>> from sindybench.libraries import PolynomialLibrary
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> t = np.arange(2000) * 0.01
    >>> u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    >>> truth = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0},
    ...     {((0, 0, 1, 0),): -4.0, ((1, 0, 1, 0),): -0.5, ((2, 0, 1, 0),): 2.0}])
    >>> y = simulate(truth, [0.0, 0.0], u, dt=0.01, n_substeps=4)[:, :1]
    >>> model = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2),
    ...                          library=PolynomialLibrary(degree=1), dt=0.01).fit(u, y)
    >>> model.score(u, y) > 0.99
    True
    """

    def __init__(
        self,
        *,
        hidden=DerivativeHiddenState(order=2),
        library=None,
        optimizer=STLS(threshold=0.0),
        differentiation=FiniteDifference(),
        dt=None,
        validation_size=0.2,
        validation="block",
        n_trials=50,
        local_trials=0,
        random_state=None,
        search_params=None,
        refit=True,
        show_progress_bar=True,
        n_substeps=1,
        input_hold="zoh",
        max_abs=1e6,
        refine=None,
        initial_state="strategy",
    ):
        self.hidden = hidden
        self.library = library
        self.optimizer = optimizer
        self.differentiation = differentiation
        self.dt = dt
        self.validation_size = validation_size
        self.validation = validation
        self.n_trials = n_trials
        self.local_trials = local_trials
        self.random_state = random_state
        self.search_params = search_params
        self.refit = refit
        self.show_progress_bar = show_progress_bar
        self.n_substeps = n_substeps
        self.input_hold = input_hold
        self.max_abs = max_abs
        self.refine = refine
        self.initial_state = initial_state

    # ------------------------------------------------------------------ checks
    def _check_params(self, dt):
        dt = check_dt(dt if dt is not None else self.dt, allow_none=True)
        if dt is None:
            raise ValueError("dt is None; pass dt to the constructor or to fit.")
        if self.hidden is not None and not isinstance(self.hidden, HiddenStrategy):
            raise ValueError(
                f"hidden must be a HiddenStrategy (e.g. DerivativeHiddenState()); got {type(self.hidden).__name__}."
            )
        n_trials = check_integer(self.n_trials, "n_trials")
        check_integer(self.n_substeps, "n_substeps")
        check_integer(self.local_trials, "local_trials", low=0, high=n_trials - 1)
        check_option(self.validation, "validation", _VALIDATIONS)
        check_option(self.input_hold, "input_hold", _HOLDS)
        check_bool(self.refit, "refit")
        check_bool(self.show_progress_bar, "show_progress_bar")
        check_positive(self.max_abs, "max_abs", allow_inf=True)
        check_option(self.initial_state, "initial_state", _INITIAL_STATES)
        if self.refine is not None and not hasattr(self.refine, "run"):
            raise ValueError(
                f"refine must be an OutputErrorRefinement or None; got {type(self.refine).__name__}."
            )
        space = check_space(self.search_params)
        bad = [k for k in space if k.startswith(_HIDDEN_PREFIX)]
        if bad:
            raise ValueError(
                f"search_params {bad} name strategy parameters; leave them None in the strategy "
                "(with their bounds) to search them."
            )
        valid = self.get_params(deep=True)
        unknown = [k for k in space if k not in valid]
        if unknown:
            raise ValueError(f"search_params names unknown parameters {unknown}; expected names from get_params().")
        return dt, space

    def _n_validation(self, n_samples):
        v = self.validation_size
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            raise ValueError(f"validation_size must be a fraction in (0, 1) or a number of samples; got {v!r}.")
        n_val = int(round(v * n_samples)) if 0 < v < 1 else int(v)
        if v != n_val and not 0 < v < 1:
            raise ValueError(f"validation_size must be a fraction in (0, 1) or an integer; got {v!r}.")
        if not 2 <= n_val <= n_samples - 2:
            raise ValueError(
                f"validation_size={v!r} gives {n_val} validation samples out of {n_samples}; "
                "expected at least 2 on each side of the split."
            )
        return n_val

    # --------------------------------------------------------------------- fit
    def fit(self, X, y, *, dt=None):
        """Fit the model, searching the strategy's open physical parameters.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs) or None
            Inputs ``u``.
        y : array-like of shape (n_samples, n_outputs)
            Measured outputs.
        dt : float, optional
            Sampling interval (overrides the constructor's ``dt``).

        Returns
        -------
        self
        """
        X, y1 = _check_fit_data(X, y)
        dt, est_space = self._check_params(dt)
        hidden = clone(self.hidden) if self.hidden is not None else _default_strategy()
        hidden._validate()
        space = {_HIDDEN_PREFIX + k: ("float", lo, hi, log) for k, (lo, hi, log) in hidden.search_space().items()}
        space.update(est_space)
        n = y1.shape[0]
        self.best_params_, self.search_results_ = {}, []
        n_rows = n
        # the outputs' derivatives do not depend on a trial unless the differentiation is searched
        derivative = None
        if not any(k.split("__")[0] == "differentiation" for k in space):
            derivative = _Derivative(clone(as_differentiation(self.differentiation)), dt)
            derivative.pin(y1)
        if space:
            n_val = self._n_validation(n)
            n_fit = n - n_val

            def objective(values):
                try:
                    cand = self._candidate(hidden, values, X, y1, dt, n_fit, derivative)
                    return self._validation_error(hidden, cand, X, y1, dt, n_fit)
                except (SimulationError, ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
                    logger.debug("bad trial %s: %s", values, exc)
                    return _PENALTY

            with np.errstate(all="ignore"):
                self.best_params_, self.search_results_ = minimize(
                    objective, space, n_trials=self.n_trials, random_state=self.random_state, penalty=_PENALTY,
                    n_local=self.local_trials, show_progress_bar=self.show_progress_bar,
                )
            if min(s for _, s in self.search_results_) >= _PENALTY:
                raise ValueError(
                    f"all {self.n_trials} candidates of the inner search diverged or failed on the validation "
                    "block; expected bounds of the searched parameters that contain a stable model."
                )
            n_rows = n if self.refit else n_fit
        cand = self._candidate(hidden, self.best_params_, X, y1, dt, n_rows, derivative)
        cand.derivative.pin(None)
        x0, self.refinement_ = None, None
        if self.refine is not None:
            cand, x0, self.refinement_ = self._refine(hidden, cand, X[:n_rows], y1[:n_rows], dt)
        self._set_fitted(hidden, cand, self.best_params_, dt, X, y1)
        if x0 is not None:  # the refined model's own trajectory replaces the reconstruction
            self.x0_ = x0
            self.states_ = self._simulate(cand, x0, X, dt, "nan")
            self._rebuild_model()
        self._y_1d = np.asarray(y).ndim == 1
        return self

    def _components(self, est_values):
        est = clone(self).set_params(**est_values) if est_values else self
        library = est.library if est.library is not None else None
        optimizer = clone(est.optimizer) if est.optimizer is not None else STLS(threshold=0.0)
        differentiation = clone(as_differentiation(est.differentiation))
        return library, optimizer, differentiation

    def _candidate(self, hidden, values, X, y, dt, n_rows, derivative=None):
        hvals = {k[len(_HIDDEN_PREFIX) :]: v for k, v in values.items() if k.startswith(_HIDDEN_PREFIX)}
        est_values = {k: v for k, v in values.items() if not k.startswith(_HIDDEN_PREFIX)}
        library, optimizer, differentiation = self._components(est_values)
        library = clone(as_library(library if library is not None else hidden.default_library()))
        if derivative is None:
            derivative = _Derivative(differentiation, dt)
        differentiation = derivative.differentiation
        params = hidden.resolve_params(hvals)
        structure = hidden.structure(params, n_outputs=y.shape[1], n_inputs=X.shape[1])
        design = hidden.design(X, y, dt, derivative=derivative, params=params)
        states = check_signal(design.states, "strategy states", n_samples=y.shape[0])
        targets = check_signal(design.targets, "strategy targets", n_samples=y.shape[0])
        if states.shape[1] != structure.n_states or targets.shape[1] != len(structure.learned):
            raise ValueError(
                f"the strategy returned states {states.shape} and targets {targets.shape}; expected "
                f"{structure.n_states} state columns and {len(structure.learned)} target columns."
            )
        rows = np.zeros(y.shape[0], dtype=bool)
        rows[:n_rows] = True
        if design.rows is not None:
            keep = np.zeros(y.shape[0], dtype=bool)
            keep[design.rows] = True
            rows &= keep
        Z = np.hstack([states, X])
        library.fit(Z[rows])
        if design.feature_filter is None:
            theta = library.transform(Z[rows])
        else:
            theta = check_signal(design.feature_filter(library.transform(Z)), "filtered features")[rows]
        check_n_samples(int(rows.sum()), theta.shape[1])
        optimizer.fit(theta, targets[rows])
        coef = np.asarray(optimizer.coef_, dtype=float).reshape(len(structure.learned), theta.shape[1]).T
        rhs = _build_rhs(structure, library, coef)
        return _Candidate(params=params, structure=structure, library=library, optimizer=optimizer,
                          differentiation=differentiation, coef=coef, derivative=derivative, design=design, rhs=rhs)

    def _settings(self, structure):
        return dict(n_substeps=self.n_substeps, input_hold=self.input_hold, bounds=structure.bounds,
                    max_abs=self.max_abs)

    def _simulate(self, cand, x0, X, dt, on_divergence):
        return simulate(cand.rhs, x0, X, dt, on_divergence=on_divergence, **self._settings(cand.structure))

    def _refine(self, hidden, cand, X, y, dt):
        """The candidate refined by simulation error, its refined first state and the refinement record.

        A model whose simulation of the training record diverges cannot be
        refined: it is kept as fitted by equation error (first state None),
        with a warning.
        """
        try:
            params, coef, x0, result = refine_candidate(cand, hidden, X, y, dt, self.refine, python_rhs=_PythonRHS,
                                                        settings=self._settings(cand.structure))
        except SimulationError as exc:
            warnings.warn(f"refinement skipped, the equation-error model is kept: {exc}", UserWarning, stacklevel=3)
            return cand, None, {"status": -1, "message": f"skipped: {exc}"}
        structure = hidden.structure(params, n_outputs=y.shape[1], n_inputs=X.shape[1])
        cand = cand._replace(params=params, structure=structure, coef=coef,
                             rhs=_build_rhs(structure, cand.library, coef))
        logger.info("refinement: cost %.3g -> %.3g in %d simulations (%s)", result.initial_cost, result.cost,
                    result.nfev, result.message)
        return cand, x0, result.summary()

    def _model_view(self, cand, dt):
        return ModelView(rhs=cand.rhs, simulate=lambda x0, u: self._simulate(cand, x0, u, dt, "nan"))

    def _initial_state(self, hidden, cand, X, y_init, dt, mode="strategy"):
        n = min(X.shape[0], y_init.shape[0])
        x0 = hidden.initial_state(X[:n], y_init[:n], dt, derivative=cand.derivative, params=cand.params,
                                  model=self._model_view(cand, dt))
        x0 = np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape[0] != cand.structure.n_states or not np.all(np.isfinite(x0)):
            raise ValueError(f"the strategy's initial state {x0!r} is not {cand.structure.n_states} finite numbers.")
        return initial_state(mode, cand.rhs, x0, X, y_init[:n], dt, output_index=cand.structure.output_index,
                             settings=self._settings(cand.structure))

    def _validation_error(self, hidden, cand, X, y, dt, n_fit):
        """Normalized RMSE of the candidate's simulation (see ``validation``)."""
        if self.validation == "block":
            X, y = X[n_fit:], y[n_fit:]
            x0 = self._initial_state(hidden, cand, X, y, dt)
        else:
            x0 = np.asarray(cand.design.states[0], dtype=float)
        y_sim = self._simulate(cand, x0, X, dt, "nan")[:, list(cand.structure.output_index)]
        if not np.all(np.isfinite(y_sim)):
            return _PENALTY
        if self.validation == "continued":
            y_sim, y = y_sim[n_fit:], y[n_fit:]
        scale = np.std(y, axis=0)
        scale[scale == 0] = 1.0
        return float(np.mean(np.sqrt(np.mean((y_sim - y) ** 2, axis=0)) / scale))

    def _set_fitted(self, hidden, cand, values, dt, X, y):
        s = cand.structure
        self.hidden_ = hidden
        self.params_ = dict(cand.params)
        self.library_, self.optimizer_, self.differentiation_ = cand.library, cand.optimizer, cand.differentiation
        self.coef_ = cand.coef.T.copy()
        self.structure_ = s
        self.states_ = np.asarray(cand.design.states, dtype=float)
        self.x0_ = self.states_[0].copy()
        self.dt_ = dt
        self.n_features_in_ = X.shape[1]
        self.n_outputs_ = y.shape[1]
        self._rebuild_model()

    def _rebuild_model(self):
        """Assemble ``rhs_``, ``_candidate_`` and the derived attributes from the plain fitted attributes.

        The one way the fitted model is put together: after ``fit``, after a
        change of ``coef_`` or ``structure_.fixed_coef``, and when a model file
        is loaded (:mod:`sindybench.hidden._persist`). Reads ``structure_``,
        ``library_``, ``coef_``, ``params_``, ``optimizer_``,
        ``differentiation_``, ``dt_`` and ``states_``.
        """
        s = self.structure_
        coef = self.coef_.T
        self.rhs_ = _build_rhs(s, self.library_, coef)
        design = Design(states=self.states_, targets=np.empty((self.states_.shape[0], 0)))
        self._candidate_ = _Candidate(
            params=self.params_, structure=s, library=self.library_, optimizer=self.optimizer_,
            differentiation=self.differentiation_, coef=coef, derivative=_Derivative(self.differentiation_, self.dt_),
            design=design, rhs=self.rhs_,
        )
        hidden_idx = [i for i in range(s.n_states) if i not in s.output_index]
        self.hidden_states_ = self.states_[:, hidden_idx]
        self.state_names_ = list(s.state_names)

    # ------------------------------------------------------------- simulation
    def _check_X(self, X, n_samples=None):
        return check_model_inputs(X, self.n_features_in_, type(self).__name__, n_samples=n_samples)

    def estimate_initial_state(self, X, y_init):
        """Initial state for simulating ``X``, from the first samples ``y_init`` of its output.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs)
            Inputs of the run to simulate (the strategy may use the first ones).
        y_init : array-like of shape (n_init, n_outputs)
            First measured output samples of that run.

        Returns
        -------
        ndarray of shape (n_states,)
        """
        check_is_fitted(self)
        y_init = check_signal(y_init, "y_init")
        if y_init.shape[1] != self.n_outputs_:
            raise ValueError(f"y_init has {y_init.shape[1]} columns; expected {self.n_outputs_} (one per output).")
        X = self._check_X(X, y_init.shape[0])
        check_option(self.initial_state, "initial_state", _INITIAL_STATES)
        return self._initial_state(self.hidden_, self._candidate_, X, y_init, self.dt_, self.initial_state)

    def simulate(self, X, *, y_init=None, x0=None, on_divergence="raise"):
        """Open-loop simulation of the full state (measured and hidden).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs)
        y_init : array-like of shape (n_init, n_outputs), optional
            First measured output samples; the initial state is estimated from them.
        x0 : array-like of shape (n_states,), optional
            The initial state, instead of ``y_init``.
        on_divergence : {"raise", "nan"}, default="raise"

        Returns
        -------
        ndarray of shape (n_samples, n_states)
        """
        check_is_fitted(self)
        if (x0 is None) == (y_init is None):
            raise ValueError("give exactly one of x0 and y_init.")
        X = self._check_X(X)
        if y_init is not None:
            x0 = self.estimate_initial_state(X, y_init)
        x0 = np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape[0] != self.structure_.n_states:
            raise ValueError(f"x0 has {x0.shape[0]} entries; expected {self.structure_.n_states} (one per state).")
        return self._simulate(self._candidate_, x0, X, self.dt_, on_divergence)

    def predict(self, X, *, y_init=None):
        """Simulated outputs for the inputs ``X`` (NaN after a divergence).

        Started from the state estimated from ``y_init`` (the first samples of
        the measured output); without it from the first training state
        ``x0_``, with a warning.
        """
        check_is_fitted(self)
        if y_init is None:
            warnings.warn(
                "predict without y_init starts from the first training state x0_; "
                "pass y_init (the first samples of the measured y) for new data.",
                UserWarning,
                stacklevel=2,
            )
            states = self.simulate(X, x0=self.x0_, on_divergence="nan")
        else:
            states = self.simulate(X, y_init=y_init, on_divergence="nan")
        y_pred = states[:, list(self.structure_.output_index)]
        return y_pred[:, 0] if self._y_1d else y_pred

    def score(self, X, y, sample_weight=None):
        """R^2 of the open-loop simulation initialised from the start of ``y`` (-inf if it diverges)."""
        if sample_weight is not None:
            raise ValueError("sample_weight is not supported by HiddenStateSINDy.score; expected None.")
        X, y = check_inputs_outputs(X, y)
        return make_simulation_scorer("r2")(self, X, y)

    def equations(self, precision=3, *, latex=False, errors=False):
        """Readable model equations, one line per state (fixed rows included).

        Formatted as :meth:`sindybench.SINDy.equations`; a row fixed by a
        Python function shows as ``(fixed: <strategy>)``. In a notebook a
        fitted model displays them typeset (``_repr_latex_``).

        Parameters
        ----------
        precision : int, default=3
            Decimals of the coefficients.
        latex : bool, default=False
            LaTeX lines instead (``\\dot{z} = ... \\, |v| z``).
        errors : bool, default=False
            Write each refined coefficient with its standard error,
            ``(4.822 ± 0.012)`` (needs ``refine``; see :meth:`standard_errors`).

        Returns
        -------
        list of str
        """
        return format_equations(self._equation_rows(), precision=precision, latex=latex,
                                errors=self._coef_errors() if errors else None)

    def _equation_rows(self):
        check_is_fitted(self)
        names = self.state_names_ + [f"u{i}" for i in range(self.n_features_in_)]
        s = self.structure_
        lib_names = list(self.library_.get_feature_names_out(names))
        lib_terms = getattr(self.library_, "terms_", None)
        fixed_names = [term_name(t, names) for t in s.fixed_terms]
        rows = []
        for i in range(s.n_states):
            if i in s.learned:
                rows.append(EquationRow(names[i], self.coef_[s.learned.index(i)], lib_names, lib_terms, names))
            elif s.fixed_rhs is not None:
                rows.append(EquationRow(names[i], None, [], None, names, learned=False,
                                        fixed=type(self.hidden_).__name__))
            else:
                rows.append(EquationRow(names[i], s.fixed_coef[:, i], fixed_names, list(s.fixed_terms), names,
                                        learned=False))
        return rows

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        tags.regressor_tags.poor_score = True
        return tags


def _default_strategy():
    return DerivativeHiddenState(order=2)


def _check_fit_data(X, y):
    if y is None:
        raise ValueError("HiddenStateSINDy requires y to be passed, but the target y is None; expected the outputs.")
    check_array_like(X, "X")
    check_array_like(y, "y")
    return check_inputs_outputs(X, y)


register_model(HiddenStateSINDy, to_dict=hidden_sindy_to_dict, from_dict=hidden_sindy_from_dict)

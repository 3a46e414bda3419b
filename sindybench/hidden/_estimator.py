"""``HiddenStateSINDy``: SINDy with control for systems whose state is partly unmeasured."""

import logging
import numbers
import warnings

import numpy as np
from sklearn.base import clone
from sklearn.utils.validation import check_is_fitted

from .._base import DynamicsEstimator
from .._params import Constraint
from .._preprocessing import scaling_record
from .._equations import EquationRow
from ..optimizers import STLS
from .._validation import check_bool, check_dt, check_integer, check_option
from .._records import in_record
from ..differentiation import as_differentiation
from ..io import register_model
from ..libraries import as_library, term_name
from ..search import SEARCH_PENALTY, Categorical, check_search_space, minimize
from ._augmentation import DerivativeHiddenState
from ._auto import AUTO, HOLDS, auto_grid, auto_refinement, candidate_settings, check_refine_param, decide, is_auto
from ._base import Design, HiddenStrategy
from ._candidate import Candidate, candidate_initial_state, fit_candidate, structure_dynamics
from ._derivative import Derivative
from ._objective import VALIDATIONS, SearchObjective
from ._persist import hidden_sindy_from_dict, hidden_sindy_to_dict
from ._latent_hard import fit_range_levels
from ._multistart import heads, refine_best, refit_failed, search_starts
from ._refinement import refined_values, refinement_problem

__all__ = ["HiddenStateSINDy"]

logger = logging.getLogger(__name__)

_HIDDEN_PREFIX = "hidden__"
_INITIAL_STATES = ("strategy", "fit", "prior", "periodic")


def _check_strategy_param(value, name):
    if value is not None and not isinstance(value, HiddenStrategy):
        raise ValueError(f"{name} must be a HiddenStrategy (e.g. DerivativeHiddenState()); got {type(value).__name__}.")
    return value


class HiddenStateSINDy(DynamicsEstimator):
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
    library : transformer, "auto" or None, default="auto"
        Candidate functions of ``Z = [states, inputs]``; None means the
        strategy's ``default_library()`` (it depends on the strategy, so it
        is chosen in ``fit``). ``"auto"`` (the default since 0.2): that
        library, or when it is a ``PolynomialLibrary`` each of its degrees
        from 1 up, the one whose model simulates the validation block best
        (when the inner search runs, the strategy's library itself). pysindy
        libraries are wrapped.
    optimizer : regressor, default=STLS(threshold=0.0)
        Sparse regressor with ``coef_`` (n_targets, n_features); the default
        is plain least squares (None means the same), and
        ``optimizer__threshold`` sets sparsity in the units of your problem.
    differentiation : object or "auto", default="auto"
        Derivative method with ``derivative(y, *, dt, order)`` (see
        :mod:`sindybench.differentiation`); None means finite differences.
        ``"auto"``: chosen from the (first) record as
        :func:`~sindybench.identify.identify` chooses it: a cubic
        Savitzky-Golay filter whose window follows the outputs' bandwidth
        (:func:`~sindybench.differentiation.data_differentiation`). New data
        shorter than that window (``predict`` with 20 start samples) starts
        from one cubic fitted to the samples it has
        (:class:`~sindybench.hidden.DerivativeHiddenState`). The default was
        ``FiniteDifference()`` (accuracy 2) before 0.2 and
        ``FiniteDifference(accuracy=4)`` in 0.2; model files keep theirs.
    dt : float, default=None
        Sampling interval (required, here or in ``fit``).
    validation_size : float or int, default=0.2
        Validation block at the end of the training data: a fraction in
        (0, 1) or a number of samples (at the end of each record, with
        several records). Used only when something is searched or decided
        (``"auto"``).
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
        (bounded Nelder-Mead on the real parameters from the 3 best distinct
        candidates, Normal and LogNormal priors on their quantile; integers and
        choices keep their values); the other ``n_trials - local_trials`` are TPE trials.
        Useful when good candidates lie in narrow valleys.
    random_state : int, RandomState or None, default=None
        Seed of the TPE sampler.
    sampler : {"tpe", "grid"}, default="tpe"
        How the inner search draws its ``n_trials - local_trials`` candidates:
        Optuna's TPE, or ``"grid"``: an even grid over the searched ranges
        (:func:`~sindybench.search.grid_points`; log-spaced on a log scale),
        the same at every seed.
    n_refined : int, default=1
        How many of the inner search's best distinct candidates are refined
        by simulation error (``refine``) on the training part and scored again
        on the validation block; the best of them after the refinement is
        kept (``refined_results_`` records each). 1: the search's best is kept
        as it is, then refined. With ``LatentHiddenState(start="auto")`` the
        pool also holds the best candidate of each other kind of start.
    search_params : dict, optional
        Further parameters of this estimator to search jointly, by nested
        name: ``{"optimizer__threshold": LogUniform(1e-3, 1.0),
        "differentiation__window_length": IntRange(5, 41)}``, with the
        dimensions of :mod:`sindybench.search` (``Normal`` and ``LogNormal``
        priors too). The older spellings still work (:func:`~sindybench.search.as_dimension`):
        ``(5, 41)`` integers, ``(1e-3, 1.0, True)`` a log-scaled float, a list of choices.
    refit : bool, default=True
        Refit the best candidate on all the training data (else keep the fit
        without the validation block).
    show_progress_bar : bool, default=True
        Show a progress bar of the inner search (``tqdm.auto``) when there is
        somewhere to draw it, a notebook or a terminal, never in a log file;
        the environment variable ``SINDYBENCH_PROGRESS=0`` turns bars off.
    n_substeps : int, default=1
        Integration steps per sample in simulations.
    integrator : {"rk4", "euler"}, default="rk4"
    input_hold : {"zoh", "linear", "auto"}, default="auto"
        Input interpolation between samples in simulations. ``"auto"`` (the
        default since 0.2; ``"zoh"`` before): the hold whose model simulates
        the validation block best, decided with the library (or as one more
        dimension of the inner search when it runs); ``input_hold_`` says
        which. Too short a record for a validation block takes ``"linear"``
        and the default library's own degree.
    bounds : (lower, upper) or None, default=None
        State bounds for simulations (scalars or one per state), instead of
        the strategy's own (``structure_.bounds``); None keeps the strategy's.
    max_abs : float, default=1e6
        A simulated state beyond this magnitude counts as divergence.
    input_delay : int, default=0
        Input delay in samples: the model is driven by ``u(t - input_delay dt)``
        (as :class:`~sindybench.SINDy`'s ``input_delay``).
    normalize : bool, default=False
        Centre and scale the regression (as :class:`~sindybench.SINDy`'s
        ``normalize``): the library's features of the centred, scaled states
        and inputs, each target divided by its root mean square, the
        coefficients mapped back exactly to the user's units.
    refine : OutputErrorRefinement, PredictionErrorRefinement, "auto" or None, default="auto"
        ``"auto"`` (the default since 0.2; None before): an
        ``OutputErrorRefinement()`` when the chosen model is compiled (built
        from terms: exact sensitivities), none otherwise (a Python right-hand
        side refines by finite differences, far slower).
        Refine the final model by its open-loop simulation error on the
        training record (:class:`~sindybench.refine.OutputErrorRefinement`;
        or by its prediction error,
        :class:`~sindybench.refine.PredictionErrorRefinement`, for a model
        whose simulation diverges or drifts: compiled models only):
        the nonzero learned coefficients, the strategy's physical parameters
        (:meth:`HiddenStrategy.refinable`, e.g. ``m, c, k`` or ``k1, k2``) and
        the initial state. Only the model chosen by the inner search is
        refined: a refinement costs tens of simulations with sensitivities,
        about as much as the whole inner search of a short record, and it
        polishes a basin rather than moving to another one.
    initial_state : {"strategy", "fit", "prior", "periodic"}, default="strategy"
        How ``predict`` / ``simulate`` start on new data from ``y_init``:
        the strategy's estimate; that estimate refined by least squares of
        the simulation of the ``y_init`` samples (all states, hidden ones
        included, free); the same least squares with a Gaussian prior of
        the state (``"prior"``: the most probable state, well posed when
        ``y_init`` is too short to tell every state, e.g. 10 samples of a
        model with six states; the prior's mean and covariance are those of
        the states along the model's simulation of the whole ``X`` from the
        strategy's estimate, its first fifth left out, the outputs' noise
        level the refinement's RMS output error, ``sqrt(2 cost)`` of
        ``refinement_``, over the outputs' spread, or 5 % without a
        refinement; see
        :func:`~sindybench.refine.estimate_initial_state`'s ``prior``); or,
        for one period of a periodic input, the state reached after
        simulating two periods from the strategy's estimate (uses the input
        alone).

    Attributes
    ----------
    hidden_ : HiddenStrategy
        The fitted clone of the strategy.
    params_ : dict
        All physical parameters of the final model (given and searched).
    best_params_ : dict
        Values of the best trial (``hidden__<name>`` for physical parameters),
        and what the ``"auto"`` parameters decided (``input_hold``,
        ``library__degree``); empty when nothing was searched or decided.
    search_results_ : list of (dict, float)
        Every trial's values and validation score (normalized RMSE); without
        a search, every candidate of the ``"auto"`` parameters.
    refined_results_ : list of dict
        With ``n_refined > 1`` or ``start="auto"``: each candidate refined
        after the search, its ``start`` (the kind of start with
        ``start="auto"``, else None), values, ``score`` (before) and ``refined_score`` (after the
        refinement), CPU ``seconds`` and ``error``; empty otherwise (and in a
        loaded model file).
    input_hold_ : str
        The input hold the model simulates with (what ``input_hold="auto"``
        decided, else ``input_hold``).
    library_, optimizer_, differentiation_ : fitted components
    coef_ : ndarray of shape (n_learned, n_library_terms)
        Learned coefficients, one row per learned state.
    structure_ : Structure
    dynamics_ : Dynamics
        The fitted model of the full state (right-hand side, states, outputs,
        bounds, simulation settings; see :class:`sindybench.dynamics.Dynamics`).
    rhs_ : TermsRHS or callable
        Right-hand side of the full state (``dynamics_.rhs``).
    states_ : ndarray of shape (n_samples, n_states)
        State trajectory reconstructed on the training data (with ``refine``,
        the refined model's simulation of it from ``x0_``); with several
        records, the records' trajectories stacked in order.
    hidden_states_ : ndarray of shape (n_samples, n_hidden)
        The reconstructed hidden (not measured) states on the training data.
    x0_ : ndarray of shape (n_states,)
        First training state (refined with ``refine``); with several
        records, the first record's (``refinement_["initial_states"]``
        holds every record's refined one).
    refinement_ : dict or None
        Record of the refinement (costs before and after, simulations,
        status, refined physical parameters, pruned terms); None without
        ``refine``.
    starts_ : list of dict
        With ``LatentHiddenState(start="auto")`` only: each kind of start's
        name, its best validation score (normalized RMSE of the validation
        block) after refinement on the training part, CPU seconds (search and refinement) and error (the best one is
        kept; ``refined_results_`` lists every refined candidate).
    scaling_ : dict or None
        With ``normalize``: ``{"mean": ..., "scale": ...}`` of the training
        states and inputs ``[x, u]``; None without.
    state_names_ : list of str
    output_index_ : tuple of int
        The states that are the outputs (``structure_.output_index``).
    n_states_ : int
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
        library="auto",
        optimizer=STLS(threshold=0.0),
        differentiation="auto",
        dt=None,
        validation_size=0.2,
        validation="block",
        n_trials=50,
        local_trials=0,
        random_state=None,
        sampler="tpe",
        n_refined=1,
        search_params=None,
        refit=True,
        show_progress_bar=True,
        n_substeps=1,
        integrator="rk4",
        input_hold="auto",
        bounds=None,
        max_abs=1e6,
        input_delay=0,
        normalize=False,
        refine="auto",
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
        self.sampler = sampler
        self.n_refined = n_refined
        self.search_params = search_params
        self.refit = refit
        self.show_progress_bar = show_progress_bar
        self.n_substeps = n_substeps
        self.integrator = integrator
        self.input_hold = input_hold
        self.bounds = bounds
        self.max_abs = max_abs
        self.input_delay = input_delay
        self.normalize = normalize
        self.refine = refine
        self.initial_state = initial_state

    _parameter_constraints = {
        **DynamicsEstimator._parameter_constraints,
        "hidden": Constraint(_check_strategy_param),
        "n_trials": Constraint(check_integer),
        "sampler": Constraint(check_option, options=("tpe", "grid")),
        "n_refined": Constraint(check_integer, low=1),
        "validation": Constraint(check_option, options=VALIDATIONS),
        "refit": Constraint(check_bool),
        "show_progress_bar": Constraint(check_bool),
        "initial_state": Constraint(check_option, options=_INITIAL_STATES),
        "input_hold": Constraint(check_option, options=(*HOLDS, AUTO)),
        "refine": Constraint(check_refine_param),
    }

    # ------------------------------------------------------------------ checks
    def _check_params(self, dt):
        dt = check_dt(dt if dt is not None else self.dt, allow_none=True)
        if dt is None:
            raise ValueError("dt is None; pass dt to the constructor or to fit.")
        self._validate_params()
        check_integer(self.local_trials, "local_trials", low=0, high=self.n_trials - 1)
        space = _check_search_params(self.search_params)
        bad = [k for k in space if k.startswith(_HIDDEN_PREFIX)]
        if bad:
            raise ValueError(
                f"search_params {bad} name strategy parameters; leave them None in the strategy "
                "(with their bounds) to search them."
            )
        if "input_delay" in space:
            raise ValueError("search_params names input_delay, which shifts the data before the inner search; search "
                             "it from outside (sindybench.model_selection.tune, GridSearchCV) or estimate it with "
                             "sindybench.identify.estimate_delay.")
        valid = self.get_params(deep=True)
        unknown = [k for k in space if k not in valid]
        if unknown:
            hint = (" (differentiation='auto' has no parameters: pass a method, e.g. SavitzkyGolay(), to search "
                    "its own)" if is_auto(self.differentiation) and any(k.startswith("differentiation__")
                                                                       for k in unknown) else "")
            raise ValueError(f"search_params names unknown parameters {unknown}; expected names from get_params()"
                             f"{hint}.")
        return dt, space

    def _n_validation(self, n_samples, record=None):
        v = self.validation_size
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            raise ValueError(f"validation_size must be a fraction in (0, 1) or a number of samples; got {v!r}.")
        n_val = int(round(v * n_samples)) if 0 < v < 1 else int(v)
        if v != n_val and not 0 < v < 1:
            raise ValueError(f"validation_size must be a fraction in (0, 1) or an integer; got {v!r}.")
        if not 2 <= n_val <= n_samples - 2:
            where = "" if record is None else f"record {record}: "
            raise ValueError(
                f"{where}validation_size={v!r} gives {n_val} validation samples out of {n_samples}; "
                "expected at least 2 on each side of the split."
            )
        return n_val

    # --------------------------------------------------------------------- fit
    def fit(self, X, y, *, dt=None):
        """Fit the model, searching the strategy's open physical parameters.

        Fitted attributes are set only when the fit succeeds.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs), None, or list
            Inputs ``u``; with several records a list of input arrays (or
            of None), one per record of ``y``, or None.
        y : array-like of shape (n_samples, n_outputs), or list of ndarray
            Measured outputs. A Python list of NumPy arrays is several
            records of one system (as in :meth:`SINDy.fit
            <sindybench.SINDy.fit>`): the strategy's design (derivatives,
            hidden-state reconstruction, ``Design.rows``, feature filter)
            runs on each record alone and the regression rows of all
            records are stacked into one model; with a search, each record
            keeps its own validation block (``validation_size`` of that
            record) and a candidate's score pools the blocks of all records,
            each simulated from its own start; ``refine`` refines the shared
            model on all records with one initial state each.
        dt : float, optional
            Sampling interval (overrides the constructor's ``dt``).

        Returns
        -------
        self
        """
        X, y, y_1d, several = self._check_fit_records(X, y, y_kind="outputs")
        auto_start = getattr(self.hidden, "start", None) == "auto"  # several kinds of start in one refined pool
        if auto_start and several:
            raise ValueError("start='auto' fits one record; got several. Fit each start (start='lag', "
                             "'subspace') and compare them, or pass one record.")
        if getattr(self.hidden, "levels", None) == "range":  # the plain model first, then its hinges from 0
            if several:
                raise ValueError("levels='range' fits one record; got several. Pass one record, or levels='library'.")
            return fit_range_levels(self, X[0], y[0][:, 0] if y_1d else y[0], dt)
        dt, est_space = self._check_params(dt)
        X = [self.delayed_inputs(X_r) for X_r in X]
        self._check_refine_records(len(y))
        # "auto": the first record's bandwidth chooses the derivative once, for every candidate
        self._auto_differentiation = as_differentiation("auto", y[0], dt)
        hidden = clone(self.hidden) if self.hidden is not None else _default_strategy()
        hidden._validate()
        for i, (X_r, y_r) in enumerate(zip(X, y)):
            with in_record(i, several):
                hidden._validate_data(X_r, y_r)
        starts = hidden.starts() if auto_start else None
        if starts:
            hidden = starts[0][1]
        space = self._search_space(hidden, est_space, X[0].shape[1])
        grid = auto_grid(self, hidden, X[0].shape[1], searched=bool(space))
        n = [y_r.shape[0] for y_r in y]
        best_params, search_results, refined_results = {}, [], []
        n_rows, kept = n, None  # kept: the winner of several refined candidates (refined on the training part)
        # the outputs' derivatives do not depend on a trial unless the differentiation is searched
        derivative = None
        if not any(k.split("__")[0] == "differentiation" for k in space):
            derivative = Derivative(self._differentiation_of(self.differentiation), dt)
            derivative.pin(y)
        starts_record = None
        if starts:  # every kind of start searched, its best refined side by side on the training part, one kept
            n_fit = [n_r - self._n_validation(n_r, record=i if several else None) for i, n_r in enumerate(n)]
            hidden, best_params, search_results, refined_results, starts_record, kept = search_starts(
                self, starts, est_space, X, y, dt, n_fit, derivative)
            n_rows = n if self.refit else n_fit
        elif space:
            n_fit = [n_r - self._n_validation(n_r, record=i if several else None) for i, n_r in enumerate(n)]
            best_params, search_results, objective = self._inner_search(hidden, space, X, y, dt, n_fit, derivative)
            if min(s for _, s in search_results) >= SEARCH_PENALTY:
                first = "" if objective.first_error is None else f" The first failure: {objective.first_error}"
                raise ValueError(
                    f"all {self.n_trials} candidates of the inner search diverged or failed on the validation "
                    f"block; expected bounds of the searched parameters that contain a stable model.{first}"
                )
            if self.n_refined > 1:  # the best few refined on the training part, the best after refinement kept
                _, best_params, refined_results, kept = refine_best(self, hidden, search_results, X, y, dt, n_fit,
                                                                    derivative, self.n_refined)
            n_rows = n if self.refit else n_fit
        elif grid:
            best_params, search_results, n_rows = decide(self, grid, hidden, X, y, dt, derivative)
        cand = self._candidate(hidden, best_params, X, y, dt, n_rows, derivative)
        cand.derivative.pin(None)
        # the records' states stacked; x0_ is the first record's
        states = np.vstack([np.asarray(d.states, dtype=float) for d in cand.designs])
        x0 = np.asarray(cand.designs[0].states[0], dtype=float).copy()
        scaling = scaling_record(np.hstack([states, np.vstack(X)])) if self.normalize else None  # [x, u], all records
        refinement = None
        refine = auto_refinement(self.refine, cand.dynamics)
        if refine is not None:
            head = heads(X, y, n_rows)
            try:
                cand, x0_refined, refinement = self._refine(hidden, cand, *head, refine=refine)
            except ValueError as exc:  # "auto" refines what can be refined; a refinement asked for must run
                if not is_auto(self.refine):
                    raise
                x0_refined, refinement = None, {"status": -1, "message": f"skipped (refine='auto'): {exc}"}
            if x0_refined is not None and kept is not None and self.refit:
                failed, new, old = refit_failed(hidden, cand, x0_refined, kept, X, y, n_fit)
                if failed:  # the refit's start led elsewhere: the winner refined on the training part is kept
                    cand, x0_refined, refinement = kept[0], kept[1], dict(kept[2])
                    refinement["refit"] = (f"failed: the refit on the whole record simulates the training part "
                                           f"with normalized RMSE {new:.4g} against {old:.4g}; the candidate "
                                           "refined on the training part is kept")
            if x0_refined is not None:  # the refined model's own trajectories replace the reconstruction
                x0 = x0_refined[0]
                states = np.vstack([cand.dynamics.simulate(X_r, x0_r, on_divergence="nan")
                                    for X_r, x0_r in zip(X, x0_refined)])

        self.best_params_, self.search_results_ = best_params, search_results
        self.refined_results_ = refined_results
        if starts_record is not None:
            self.starts_ = starts_record
        else:
            self.__dict__.pop("starts_", None)
        self.input_hold_ = cand.dynamics.input_hold
        self.hidden_ = hidden
        self.params_ = dict(cand.params)
        self.library_, self.optimizer_, self.differentiation_ = cand.library, cand.optimizer, cand.differentiation
        self.coef_ = cand.coef.T.copy()
        self.structure_ = cand.structure
        self.states_ = states
        self.x0_ = x0
        self.dt_ = dt
        self.n_features_in_ = X[0].shape[1]
        self.refinement_ = refinement
        self.scaling_ = scaling
        self._y_1d = y_1d
        self._rebuild_model()
        if hasattr(hidden, "check_fit") and not several:
            hidden.check_fit(self, X[0], y[0], dt)
        return self

    def _search_space(self, hidden, est_space, n_inputs):
        """The inner search's space: the strategy's parameters (prefixed), the estimator's, the hold if "auto"."""
        space = {_HIDDEN_PREFIX + k: dim for k, dim in hidden.search_space().items()}
        space.update(est_space)
        if space and is_auto(self.input_hold) and n_inputs:
            space["input_hold"] = Categorical(list(HOLDS))  # "auto": the inner search decides the hold too
        return space

    def _inner_search(self, hidden, space, X, y, dt, n_fit, derivative):
        """``(best values, [(values, score), ...], objective)`` of the inner search of ``hidden`` over ``space``."""
        objective = SearchObjective(lambda values: self._candidate(hidden, values, X, y, dt, n_fit, derivative),
                                    hidden, X, y, n_fit, self.validation)
        with np.errstate(all="ignore"):
            best_params, search_results = minimize(
                objective, space, n_trials=self.n_trials, random_state=self.random_state, penalty=SEARCH_PENALTY,
                n_local=self.local_trials, show_progress_bar=self.show_progress_bar, sampler=self.sampler,
            )
        return best_params, search_results, objective

    def _components(self, est_values):
        est = clone(self).set_params(**est_values) if est_values else self
        optimizer = clone(est.optimizer) if est.optimizer is not None else STLS(threshold=0.0)
        return est, optimizer, self._differentiation_of(est.differentiation)

    def _differentiation_of(self, value):
        """A fresh differentiation method for the parameter ``value`` (``"auto"``: the one ``fit`` chose)."""
        if isinstance(value, str) and value == "auto":
            return clone(self._auto_differentiation)
        return clone(as_differentiation(value))

    def _simulation(self, dt, input_hold=None):
        """Simulation settings of the dynamics; the hold: ``input_hold``, else ``input_hold_``, else the parameter."""
        hold = input_hold or getattr(self, "input_hold_", None) or self.input_hold
        return dict(dt=dt, n_substeps=self.n_substeps, input_hold=hold, max_abs=self.max_abs,
                    method=self.integrator, bounds=self.bounds)

    def _candidate(self, hidden, values, X, y, dt, n_rows, derivative=None):
        """The candidate of ``values``; ``X``, ``y`` and ``n_rows`` are lists, one entry per record."""
        hvals = {k[len(_HIDDEN_PREFIX) :]: v for k, v in values.items() if k.startswith(_HIDDEN_PREFIX)}
        est_values = {k: v for k, v in values.items() if not k.startswith(_HIDDEN_PREFIX)}
        auto_keys = ("input_hold", "library__degree") if is_auto(self.library) else ("input_hold",)
        est, optimizer, differentiation = self._components(
            {k: v for k, v in est_values.items() if k not in auto_keys})
        library, hold, _ = candidate_settings(est, hidden, est_values)
        library = clone(as_library(library))
        if derivative is None:
            derivative = Derivative(differentiation, dt)
        return fit_candidate(hidden, hidden.resolve_params(hvals), library, optimizer, derivative, X, y, n_rows,
                             self._simulation(dt, hold), normalize=est_values.get("normalize", self.normalize))

    def _refine(self, hidden, cand, X, y, held=(), refine=None):
        """The candidate refined by simulation error, its refined first state and the refinement record.

        A model whose simulation of the training record diverges cannot be
        refined: it is kept as fitted by equation error (first state None),
        with a warning. ``X`` and ``y`` are lists of records; the refined
        first states are an array (n_records, n_states).
        """
        simulation = self._simulation(cand.dynamics.dt, cand.dynamics.input_hold)
        n_outputs, n_inputs = y[0].shape[1], X[0].shape[1]
        problem = refinement_problem(cand, hidden, n_outputs, n_inputs)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result, record = self._run_refinement(cand.dynamics, X, y, refine=refine, **problem)
        fallback = getattr(hidden, "diverging_refinement", lambda refine: None)(refine)
        if result is None and fallback is not None and cand.dynamics.compiled:  # the start diverges: prediction error
            result, record = self._run_refinement(cand.dynamics, X, y, refine=fallback, **problem)
            caught = [w for w in caught if "refinement skipped" not in str(w.message)]
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        if result is None:
            return cand, None, record
        params, coef, x0 = refined_values(cand, result)
        structure = hidden.structure(params, n_outputs=n_outputs, n_inputs=n_inputs)
        cand = cand._replace(params=params, structure=structure, coef=coef,
                             dynamics=structure_dynamics(structure, cand.library, coef, simulation))
        logger.info("refinement: cost %.3g -> %.3g in %d simulations (%s)", result.initial_cost, result.cost,
                    result.nfev, result.message)
        summary = result.summary()
        mixing = getattr(hidden, "canonical_mixing", None)
        gauged = None if mixing is None or len(cand.designs) > 1 else mixing(cand, x0[0], n_inputs)
        if gauged is not None and not held:  # a free mixing z -> z + k y: refined again in its canonical gauge
            coef, states, x0_new, mixing_held = gauged
            states[0] = x0_new
            moved = cand._replace(coef=coef, designs=(cand.design._replace(states=states),),
                                  dynamics=structure_dynamics(cand.structure, cand.library, coef, simulation))
            moved, x0_again, again = self._refine(hidden, moved, X, y, held=mixing_held, refine=refine)
            if again.get("status", -1) >= 0 and again["cost"] <= summary["cost"] * (1 + 1e-3) + 1e-15:
                return moved, x0_again, again
        if held:
            summary["mixing_held"] = [list(map(int, h)) for h in held]
        return cand, x0, summary

    def _rebuild_model(self):
        """Assemble ``dynamics_``, ``_candidate_`` and the derived attributes from the plain fitted attributes.

        The one way the fitted model is put together: after ``fit``, after a
        change of ``coef_`` or ``structure_.fixed_coef``, and when a model file
        is loaded (:mod:`sindybench.hidden._persist`). Reads ``structure_``,
        ``library_``, ``coef_``, ``params_``, ``optimizer_``,
        ``differentiation_``, ``dt_`` and ``states_``.
        """
        s = self.structure_
        coef = self.coef_.T
        self.dynamics_ = structure_dynamics(s, self.library_, coef, self._simulation(self.dt_))
        design = Design(states=self.states_, targets=np.empty((self.states_.shape[0], 0)))
        self._candidate_ = Candidate(
            params=self.params_, structure=s, library=self.library_, optimizer=self.optimizer_,
            differentiation=self.differentiation_, coef=coef, derivative=Derivative(self.differentiation_, self.dt_),
            designs=(design,), dynamics=self.dynamics_,
        )
        hidden_idx = [i for i in range(s.n_states) if i not in s.output_index]
        self.hidden_states_ = self.states_[:, hidden_idx]

    @property
    def rhs_(self):
        """Right-hand side of the full state (``dynamics_.rhs``)."""
        return self.dynamics_.rhs

    # ------------------------------------------------------------- simulation
    def _initial_state(self, X, y_init):
        check_option(self.initial_state, "initial_state", _INITIAL_STATES)
        return candidate_initial_state(self.hidden_, self._candidate_, X, y_init, self.initial_state,
                                       self._start_noise())

    def _start_noise(self):
        """The outputs' noise level of ``initial_state="prior"``: the refinement's RMS output error over the
        outputs' spread (``sqrt(2 cost)``), None (the default level) without a refinement."""
        cost = (self.refinement_ or {}).get("cost")
        if self.initial_state != "prior" or cost is None or (self.refinement_ or {}).get("status", -1) < 0 \
                or not np.isfinite(cost):
            return None
        return float(np.sqrt(2.0 * cost))

    def _equation_notes(self):
        gauge = getattr(self.hidden_, "gauge", None)  # strategies with latent states say how their scale is fixed
        return gauge(model=self).splitlines() if callable(gauge) else []

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


def _default_strategy():
    return DerivativeHiddenState(order=2)


def _check_search_params(search_params):
    """``search_params`` as a dict ``name -> dimension`` (empty for None)."""
    if search_params is None or (isinstance(search_params, dict) and not search_params):
        return {}
    if not isinstance(search_params, dict):
        raise ValueError(f"search_params must be a dict name -> dimension (Uniform, LogUniform, IntRange, Categorical, "
                         f"Normal, LogNormal, or (low, high[, log]) or a list of choices); got {search_params!r}.")
    return check_search_space(search_params, name="search_params", convert=True)


register_model(HiddenStateSINDy, to_dict=hidden_sindy_to_dict, from_dict=hidden_sindy_from_dict)

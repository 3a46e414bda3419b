"""``IdentifyCV``: the structure search scored by simulation, as an estimator; ``identify``, its one-call form."""

import warnings
from functools import partial

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from .._validation import is_records
from ._checks import MIN_TRAIN as _MIN_TRAIN
from ._checks import check_data, check_params
from ._choice import choose_candidate, scored_table
from ._criterion import choose_criterion
from ._resume import CandidateStore, fingerprint
from ._linear import linear_base_index
from ._run_stages import run_stages
from ._search import describe_blocks, pareto_front, record_folds, segments, stls_threshold
from ._space import n_terms
from ._space import FAMILIES, LIBRARIES, data_settings, make_estimator, structures
from ._stages import STRUCTURE, Budget, parallel_map, refit_choice, refit_failed, validated_library
from . import _persist  # noqa: F401  (model files keep identification_: registers its codec)

__all__ = ["IdentifyCV", "identify"]

# first samples that start a simulation of new data, unless n_init says
_N_INIT = 20


class IdentifyCV(RegressorMixin, BaseEstimator):
    """Identify a model from inputs, outputs and the sample time: a structure search scored by simulation.

    Selection inside ``fit``, as in scikit-learn's ``LassoCV`` or
    ``GridSearchCV``: the data advice (:func:`~sindybench.identify.advice`,
    logged) gives the input delay and the input hold (both confirmed on
    validation) and the hard terms worth proposing (a velocity that changes
    sign, a positive output, an output that sits at a level); the output's
    spectrum gives the derivative methods' bandwidth; and the search chooses
    the family, the library, the derivative method and the sparsity. Every
    candidate is an ordinary :class:`~sindybench.SINDy` or
    :class:`~sindybench.HiddenStateSINDy`, fitted on the samples before a
    validation block and scored by the RMSE of its open-loop simulation of
    the block (started from its first ``n_init`` samples) over the output's standard deviation.

    The search is a successive halving over the number of validation blocks:

    1. *screen*: every structure's pruning path (thresholds between the
       sorted coefficients of its dense fit) on the last block only, trained
       on at most ``screen_window`` samples before it;
    2. *blocks*: the best ``screen_keep`` fraction (at most 16) and the best
       candidate of every family and library, on all ``n_blocks``
       forward-chaining blocks (plus the best two without the input delay,
       when the advice found one);
    3. *refine*: the parsimonious pick of stage 2, then its Pareto front
       (sparsest first), then the best ones (``n_refine`` in all), refined
       by their simulation error
       (``refinement``) and scored on all blocks again; the pick is refined
       with the other input hold too (when the hold is searched), since
       equation-error fits seldom tell the holds apart, and that one is
       chosen only when it validates better by more than the pick's
       standard error (its status says so otherwise).

    Halving by blocks rather than by training length because a candidate's
    cost is one equation-error fit and one simulation per block: the cheap
    first pass separates the structures that simulate at all from the rest,
    and only the promising pay for every block and for a refinement (tens of
    simulations each). A **parsimony rule** then picks the model: the
    sparsest candidate whose mean error over the blocks is within one
    standard error of the best one. The chosen settings are refitted on the
    whole record.

    Parameters
    ----------
    dt : float or None, default=None
        Sampling interval (required, here or in ``fit``).
    families : sequence of str, default=FAMILIES
        ``("first_order", "order2", "order3", "order1+latent", "order2+latent", "linear_ss", "lag")``.
        Model families: first-order SINDy ``y' = f(y, u)``; derivative
        coordinates of order 2 and 3 (``HiddenStateSINDy(DerivativeHiddenState(n))``);
        one latent state ``z`` (:class:`~sindybench.hidden.LatentHiddenState`,
        one output only): at order 1 driven by the input, with the libraries
        ``linear`` and ``linear+hard`` (square roots of ``y`` and ``z``, the
        output's saturation indicator, hinges of ``z`` at levels the fit
        decides), and at order 2 driven by the velocity,
        with the library ``linear+abs`` (linear terms, ``v|z|``, ``|v|z``,
        ``|v||z|``); ``"linear_ss"``, the linear base (a linear state-space
        model whose order the data decide, which every nonlinear pick must beat
        by more than its standard error); ``"lag"``
        (:class:`~sindybench.LagSINDy`, discrete time on delay coordinates, its
        orders and terms chosen inside its ``fit``; returned only when it
        validates better than the equations' pick by more than its standard
        error). The latent, linear and lag families skip the screening: their
        own search runs inside their ``fit``. Off the default list:
        ``"order1+latent2"`` (two latent states) and ``"linear_ss+nl"`` (the
        linear base's states plus the outputs' polynomial and proposed terms).
    libraries : sequence of str, default=("linear", "poly2", "poly3", "linear+hard", "poly2+hard")
        Libraries of graded richness; ``"+hard"`` adds the terms the data
        proposes (skipped when it proposes none).
    derivatives : sequence of str or None, default=None
        Derivative methods among ``"finite_difference"``, ``"savgol"``,
        ``"spectral"`` (bandwidths from the data); None = all three.
    input_hold : {"zoh", "linear"} or None, default=None
        None = both holds are candidates (the advice's, from the input's
        shape, first): validation decides.
    input_delay : int or None, default=None
        Input delay in samples (the estimators' ``input_delay``); None = the
        data advice's estimate (:func:`~sindybench.identify.estimate_delay`),
        confirmed on validation against no delay.
    n_blocks : int, default=3
        Validation blocks at the end of the record (several records: of
        each record, or the most records left out).
    block_size : float, default=0.15
        Length of each block, as a fraction of the record.
    validation : {"blocks", "records"} or None, default=None
        What a candidate is validated on. ``"blocks"``: ``n_blocks``
        forward-chaining blocks at the end of the record; with several
        records, fold ``k`` validates the ``k``-th block of every record,
        trained on every record before its block. ``"records"`` (several
        records only): the last ``min(n_blocks, n_records)`` records are
        left out in turn, each validated whole and trained on the others.
        None = ``"blocks"`` for one record, ``"records"`` for several. The
        chosen model is refitted on every record.
    max_path : int, default=12
        Most thresholds on each structure's pruning path.
    screen_keep : float, default=1/3
        Fraction of the screened candidates that go on to every block.
    screen_window : int, default=8000
        Most training samples of a screening fit.
    n_refine : int, default=4
        Candidates refined by their simulation error (0: none): the
        parsimonious pick of stage 2, then its Pareto front (sparsest
        first), then the best ones.
    max_terms : int, default=15
        Most terms in one learned row of the chosen model (readability);
        richer candidates are evaluated and recorded, never chosen.
    refinement : refinement or None, default=None
        The refinement of stage 3; None = ``OutputErrorRefinement(max_nfev=20,
        max_samples=5000)``. Any object the estimators' ``refine`` takes (the
        hook for a prediction-error refinement of candidates whose free run
        diverges).
    criterion : {"auto", "free_run", "k_step"}, default="auto"
        How a candidate is scored on a validation block: its free run (RMSE
        of the simulation over the output's standard deviation), or its
        ``horizon``-step prediction (the block cut into windows restarted from
        the measured output every ``horizon`` samples, see
        :func:`~sindybench.identify.k_step_error`). ``"auto"``:
        the k-step prediction when the data advice finds an open-loop
        unstable output (a free run of such a plant drifts whatever the
        model), else the free run; when the record looks integrating or
        closed-loop and the chosen free run does not beat the output's mean, a
        warning says so. Under the k-step criterion the refined candidates
        are refined by their ``horizon``-step prediction error
        (:class:`~sindybench.refine.PredictionErrorRefinement`) unless
        ``refinement`` is given. ``criterion_`` and ``identification_["criterion"]``
        record the choice and why.
    horizon : int or None, default=None
        The k-step horizon in samples; None = a quarter of a period of the
        outputs' 95 % bandwidth (at least 5, at most a quarter of a block).
    n_init : int or None, default=None
        First samples of new data that start a simulation (the validation
        blocks start from as many); None = 20. Give the number a test
        protocol allows, so that the search scores candidates as they will
        be used (a derivative method needing more start samples then fails).
    time_budget : float or None, default=None
        Seconds of search; candidates not started by then are left out (the
        best one found so far is kept). None = no limit.
    max_candidates : int or None, default=None
        Most candidates evaluated. None = no limit.
    random_state : int or None, default=None
        Passed to the families' estimators (None = 0). The default families
        do not draw: the latent families search their start on an even grid
        of time constants, so the identified model is the same at every seed.
    storage : None, str, path-like or optuna storage, default=None
        Where the evaluated candidates are kept, so that a search that
        stops (a budget, an interrupt, a crash) resumes: the forms
        :func:`~sindybench.model_selection.tune` takes (``"sqlite:///search.db"``,
        a database URL, a journal file ``"search.log"``, an Optuna storage).
        Each candidate is one finished trial (its settings, stage, block
        errors, terms, time and status as user attributes). A second ``fit``
        with the same storage, study name, data and settings reads the
        evaluated candidates back instead of fitting them again, and ends
        with the result of an uninterrupted search; a study made on other
        data or with other settings is refused (never changed). None =
        nothing kept.
    study_name : str or None, default=None
        The study's name in ``storage``; None = ``"identify"``.
    n_jobs : int or None, default=None
        Parallel candidates (joblib); None = 1.
    show_progress_bar : bool, default=True
        A progress bar in a terminal or a notebook (``SINDYBENCH_PROGRESS=0`` turns it off).

    Attributes
    ----------
    best_estimator_ : SINDy or HiddenStateSINDy
        The chosen model refitted on the whole record; it carries
        ``identification_`` (the settings, the table and the front).
    best_index_ : int
        Row of ``cv_results_`` that was chosen.
    best_params_ : dict
        The chosen settings (family, library, derivative, input hold, input
        delay, threshold, refine) and the refitted model's ``n_terms`` and
        ``max_row_terms``. The threshold is a level of RMS contribution
        (coefficient times the RMS of its term, in the target's units).
    cv_results_ : dict of lists
        One entry per candidate: ``family``, ``library``, ``derivative``,
        ``input_hold``, ``input_delay``, ``threshold``, ``refine``, ``stage``, ``n_terms``,
        ``max_row_terms``, ``split<k>_validation_error``,
        ``mean_validation_error``, ``std_validation_error`` (inf for a
        candidate not scored on every block), ``fit_time``, ``status``
        (``"ok"`` or why it failed) and ``equations`` (those of the fit on
        the last fold's training part; None for a screened candidate).
    pareto_front_ : list of dict
        ``{"n_terms", "validation_error", "index"}`` of the candidates no
        other one beats with as few terms, sparsest first.
    settings_ : dict
        What the data decided before any fit: the data advice (``advice``),
        input delay and hold, bandwidth, derivative methods, proposed terms.
    blocks_ : list
        The validation blocks: ``(start, stop)`` of each for one record;
        for several records, the ``(record, start, stop)`` blocks of each fold.
    validation_ : str
        ``"blocks"`` or ``"records"`` (see ``validation``).
    splits_ : list of dict
        Each fold's ``"train"`` and ``"validation"`` samples as text
        (``"record 1 [0, 700)"``); ``split<k>_validation_error`` of
        ``cv_results_`` is fold ``k``'s.
    criterion_ : dict
        ``name`` (``"free_run"`` or ``"k_step"``), ``horizon`` and ``reason``:
        the score that ranked the candidates.
    n_resumed_ : int
        Candidates read back from ``storage`` instead of evaluated.
    n_features_in_ : int

    See Also
    --------
    identify : the function form, returning the chosen model.

    Examples
    --------
    >>> from sindybench.simulate import simulate
    >>> t = np.arange(1500) * 0.01
    >>> u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    >>> y = simulate(lambda x, u: np.array([-2.0 * x[0] + u[0]]), [0.0], u, dt=0.01, input_hold="linear")
    >>> search = IdentifyCV(dt=0.01, families=["first_order"], libraries=["linear", "poly2"],
    ...                     derivatives=["finite_difference"], n_refine=0, show_progress_bar=False).fit(u, y)
    >>> search.best_estimator_.equations(precision=2)
    ["y0' = -2.00 y0 + 1.00 u0"]
    >>> search.best_params_["family"], search.best_params_["input_hold"]
    ('first_order', 'linear')
    """

    def __init__(self, *, dt=None, families=FAMILIES, libraries=LIBRARIES, derivatives=None, input_hold=None,
                 input_delay=None, n_blocks=3, block_size=0.15, validation=None, max_path=12, screen_keep=1 / 3,
                 screen_window=8000, n_refine=4, max_terms=15, refinement=None, n_init=None, time_budget=None,
                 max_candidates=None, random_state=None, storage=None, study_name=None, n_jobs=None,
                 show_progress_bar=True, criterion="auto", horizon=None):
        self.dt = dt
        self.criterion = criterion
        self.horizon = horizon
        self.families = families
        self.libraries = libraries
        self.derivatives = derivatives
        self.input_hold = input_hold
        self.input_delay = input_delay
        self.n_blocks = n_blocks
        self.block_size = block_size
        self.validation = validation
        self.max_path = max_path
        self.screen_keep = screen_keep
        self.screen_window = screen_window
        self.n_refine = n_refine
        self.max_terms = max_terms
        self.refinement = refinement
        self.n_init = n_init
        self.time_budget = time_budget
        self.max_candidates = max_candidates
        self.random_state = random_state
        self.storage = storage
        self.study_name = study_name
        self.n_jobs = n_jobs
        self.show_progress_bar = show_progress_bar

    # ------------------------------------------------------------------ checks
    def _check_params(self, dt):
        return check_params(self, dt)

    _check_data = staticmethod(check_data)

    # --------------------------------------------------------------------- fit
    def fit(self, X, y, *, dt=None):
        """Search the structures, choose one by the parsimony rule and refit it on the whole record.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_inputs), or list of them
            Inputs ``u``; several records of one system as a list of arrays.
        y : array-like of shape (n_samples, n_outputs) or (n_samples,), or list of them
            Measured outputs (a list of arrays, one per record, with ``X`` a list as long).
        dt : float, optional
            Sampling interval (overrides the constructor's ``dt``).

        Returns
        -------
        self
        """
        dt = self._check_params(dt)
        several = is_records(y)
        y_1d = not several and y is not None and np.asarray(y).ndim == 1
        X, y = self._check_data(X, y)
        n = sum(y_r.shape[0] for y_r in y)
        n_init = self.n_init if self.n_init is not None else _N_INIT
        shortest = min(y_r.shape[0] for y_r in y)
        if self.input_delay is not None and X[0].shape[1] and self.input_delay >= shortest:
            raise ValueError(f"input_delay={self.input_delay} samples is not shorter than the record ({shortest} "
                             "samples): the delayed inputs would hold their first sample throughout. Expected a delay "
                             "of fewer samples than the record (None: the data advice estimates it).")
        validation = self.validation or ("records" if several else "blocks")
        folds = record_folds([y_r.shape[0] for y_r in y], self.n_blocks, self.block_size, _MIN_TRAIN,
                             min_block=n_init + 2, validation=validation)
        # what the data decides, from the longest training part of the last fold (one record: all before its block)
        r, lo, hi = max(folds[-1][0], key=lambda part: part[2] - part[1])
        settings = data_settings(X[r][lo:hi], y[r][lo:hi], dt, families=self.families)
        _, y_train = segments(X, y, folds[-1][0])
        X_all, y_all = np.vstack(X), np.vstack(y)
        structs = structures(X_all, y_all, dt, settings, families=self.families, libraries=self.libraries,
                             derivatives=self.derivatives, input_hold=self.input_hold, input_delay=self.input_delay)
        if self.input_hold is None and X_all.shape[1] > 0:  # the advice's hold first, the other too: validation decides
            other = {"zoh": "linear", "linear": "zoh"}
            structs += [(dict(s, input_hold=other[s["input_hold"]]), lib) for s, lib in structs]
        budget = Budget(self.time_budget, self.max_candidates)
        scale = np.std(np.vstack(y_train) if several else y_train, axis=0)
        random_state = 0 if self.random_state is None else self.random_state
        block_length = min(hi - lo for _, val in folds for _, lo, hi in val)
        criterion, horizon, why = choose_criterion(self.criterion, settings["advice"], horizon=self.horizon,
                                                   block_length=block_length)
        if criterion == "k_step" and block_length < n_init + horizon:
            raise ValueError(f"horizon={horizon} with n_init={n_init} needs validation blocks of at least "
                             f"{n_init + horizon} samples; the shortest has {block_length}. Expected a shorter "
                             "horizon or n_init, or larger blocks (block_size).")
        signature = {"data": fingerprint(X, y, dt), "validation": validation, "n_blocks": self.n_blocks,
                     "block_size": self.block_size, "n_init": n_init, "screen_window": self.screen_window,
                     "random_state": random_state, "refinement": repr(self.refinement)}
        if horizon is not None:  # free-run stores keep their former signature
            signature["horizon"] = horizon
        ctx = {"X": X, "y": y, "dt": dt, "settings": settings, "random_state": random_state, "folds": folds,
               "n_init": n_init, "horizon": horizon,
               "scale": np.where(scale > 0, scale, 1.0), "window": self.screen_window, "deadline": budget.deadline,
               # with a candidate budget, the screening's paths take at most half of it
               "levels": self.max_path if self.max_candidates is None else max(
                   1, min(self.max_path, self.max_candidates // (2 * max(len(structs), 1))))}
        parallel = parallel_map(self.n_jobs)
        refinement = self._refinement(n, horizon)
        # the store stays in this process (never sent to the workers): it reads back and records every candidate
        store = CandidateStore(self.storage, self.study_name, signature)
        rows, libraries = run_stages(self, structs, settings, ctx, budget, store, parallel, refinement, X_all.shape[1],
                                     len(folds))
        table, mean = scored_table(rows, len(folds), self.max_terms)
        terms = [t if t is not None else 10**9 for t in table["n_terms"]]
        choose = partial(choose_candidate, rows, table, len(folds))

        def refit(i):
            chosen = {k: rows[i][k] for k in STRUCTURE + ("threshold", "refine")}
            library = validated_library(rows[i], libraries[i])  # no term that no validation block scored
            final = make_estimator(chosen, library, stls_threshold(chosen["threshold"], n), dt, settings,
                                   refine=refinement if chosen["refine"] else None, random_state=ctx["random_state"])
            if several:
                final.fit(X, y)
            else:
                final.fit(X[0], y[0][:, 0] if y_1d else y[0])
            chosen["n_terms"], chosen["max_row_terms"], _ = n_terms(final)
            return chosen, final

        best, rule, chosen, final = refit_choice(choose, refit, table, mean)  # a failed refit: the next choice
        front = [{"n_terms": int(terms[i]), "validation_error": float(mean[i]), "index": int(i)}
                 for i in pareto_front(list(mean), terms)]
        base = linear_base_index(rows, mean)
        if chosen["n_terms"] == 0 and base is not None and base != best and mean[base] < mean[best]:
            # a model with no term is never returned when the linear base validates better
            try:
                chosen, final = refit(base)
                best, rule = base, "the refit choice had no term left; the linear base validates better"
            except Exception as exc:  # the linear base cannot be refitted: the refit choice stands
                refit_failed(table, mean, base, exc)
        # one record: (start, stop) of each block; several: (record, start, stop) of each fold's blocks
        blocks = [val[0][1:] for _, val in folds] if not several else [val for _, val in folds]
        splits = [{"train": describe_blocks(train, several), "validation": describe_blocks(val, several)}
                  for train, val in folds]
        self.settings_ = settings
        self.blocks_ = blocks
        self.validation_ = validation
        self.splits_ = splits
        self.n_resumed_ = store.n_read
        self.cv_results_ = table
        self.best_index_ = int(best)
        self.best_params_ = chosen
        self.pareto_front_ = front
        self.criterion_ = {"name": criterion, "horizon": horizon, "reason": why}
        final.identification_ = {"settings": chosen, "data": settings, "blocks": blocks, "cv_results": table,
                                 "pareto_front": front, "best_index": int(best), "rule": rule,
                                 "validation": validation, "splits": splits, "criterion": dict(self.criterion_),
                                 "n_init": n_init}  # the start samples the blocks were simulated from (the report's)
        self._warn_criterion(settings["advice"], float(mean[best]))
        self.best_estimator_ = final
        self.n_features_in_ = X[0].shape[1]
        return self

    def _warn_criterion(self, advice, error):
        """Say which score chose the model when a free run is not a meaningful score of this record."""
        name, horizon = self.criterion_["name"], self.criterion_["horizon"]
        if name == "k_step":
            warnings.warn(f"identify: candidates were ranked by their {horizon}-step prediction "
                          f"(criterion='k_step': {self.criterion_['reason']}); the chosen model's free run is not a "
                          "meaningful score of this record", UserWarning, stacklevel=3)
        elif error >= 1.0 and advice is not None and (advice.integrating or advice.closed_loop):
            what = "integrating" if advice.integrating else "closed-loop"
            warnings.warn(f"identify: the chosen model's free run does not beat the output's mean on validation "
                          f"(error {error:.3g} of the output's standard deviation) and the record looks {what} "
                          "(data advice): its free run drifts; rank the candidates by k-step prediction "
                          "(criterion='k_step')", UserWarning, stacklevel=3)

    def _refinement(self, n_samples, horizon=None):
        """The stage-3 refinement: the user's, else by simulation error, or by ``horizon``-step prediction error
        when the candidates are ranked by their k-step prediction."""
        if self.refinement is not None:
            from sklearn.base import clone

            return clone(self.refinement)
        from ..refine import OutputErrorRefinement, PredictionErrorRefinement

        if horizon is not None:
            return PredictionErrorRefinement(horizon=horizon, max_nfev=20, max_samples=min(n_samples, 5000))
        return OutputErrorRefinement(max_nfev=20, max_samples=min(n_samples, 5000))

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        tags.regressor_tags.poor_score = True  # an open-loop simulation of the checks' random data
        tags.input_tags.allow_nan = False
        return tags

    # -------------------------------------------------------------- delegation
    def predict(self, X, *, y_init=None, x0=None):
        """The chosen model's open-loop simulated outputs (see its ``predict``)."""
        check_is_fitted(self)
        return self.best_estimator_.predict(X, y_init=y_init, x0=x0)

    def simulate(self, X, *, y_init=None, x0=None):
        """The chosen model's free run of the full state (see its ``simulate``)."""
        check_is_fitted(self)
        return self.best_estimator_.simulate(X, y_init=y_init, x0=x0)

    def score(self, X, y, sample_weight=None):
        """R^2 of the chosen model's simulation (see its ``score``)."""
        check_is_fitted(self)
        return self.best_estimator_.score(X, y, sample_weight=sample_weight)

    def to_json(self, path):
        """Save the chosen model as a model file (see its ``to_json``; :func:`sindybench.load_model` reads it)."""
        check_is_fitted(self)
        return self.best_estimator_.to_json(path)

    def equations(self, **kwargs):
        """The chosen model's equations (see its ``equations``)."""
        check_is_fitted(self)
        return self.best_estimator_.equations(**kwargs)


def identify(X, y, *, dt, **kwargs):
    """Identify a model from inputs, outputs and the sample time alone; return the chosen, fitted model.

    Runs :class:`IdentifyCV` (its parameters by keyword) and returns its
    ``best_estimator_``: an ordinary :class:`~sindybench.SINDy` or
    :class:`~sindybench.HiddenStateSINDy`, so ``predict``, ``simulate``,
    ``equations``, ``to_json``, the Kalman filter and the uncertainty tools work
    on it unchanged. Its ``identification_`` holds the record of the
    selection: the chosen settings, what the data decided, the validation
    blocks, every candidate (``cv_results``) and the Pareto front.

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs), or list of them
        Inputs; several records of one system as a list of arrays.
    y : array-like of shape (n_samples, n_outputs) or (n_samples,), or list of them
        Measured outputs (a list as long as ``X`` for several records).
    dt : float
        Sampling interval.
    **kwargs
        Parameters of :class:`IdentifyCV` (``families``, ``validation``, ``time_budget``, ``storage``,
        ``study_name``, ``n_jobs``, ...).

    Returns
    -------
    SINDy or HiddenStateSINDy
        The fitted model, with ``identification_``.

    Examples
    --------
    >>> from sindybench.simulate import simulate
    >>> t = np.arange(1500) * 0.01
    >>> u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    >>> y = simulate(lambda x, u: np.array([-2.0 * x[0] + u[0]]), [0.0], u, dt=0.01, input_hold="linear")
    >>> model = identify(u, y, dt=0.01, families=["first_order"], n_refine=0, show_progress_bar=False)
    >>> model.equations(precision=2)
    ["y0' = -2.00 y0 + 1.00 u0"]
    >>> model.identification_["settings"]["family"]
    'first_order'
    """
    return IdentifyCV(dt=dt, **kwargs).fit(X, y).best_estimator_

"""``IdentifyCV``: the structure search scored by simulation, as an estimator; ``identify``, its one-call form."""

import math
import warnings
from functools import partial

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from .._progress import progress_bar
from .._records import check_record_lists, check_records
from .._validation import (check_array_like, check_bool, check_dt, check_inputs_outputs, check_integer, check_option,
                           check_positive, is_records)
from ._advice import check_magnitude
from ._criterion import CRITERIA, choose_criterion
from ._resume import CandidateStore, fingerprint
from ._lag import LAG_FAMILY, equation_or_lag
from ._linear import linear_base_index, linear_base_rule
from ._search import describe_blocks, pareto_front, parsimonious_index, record_folds, segments, stls_threshold
from ._space import n_terms
from ._space import ALL_FAMILIES, FAMILIES, LATENT_FAMILIES, LIBRARIES, data_settings, make_estimator, structures
from ._stages import (STRUCTURE, Budget, confirm_hold, hold_twin, parallel_map, refit_choice, refit_failed, run_stage,
                      score_candidate, screen_structure, store_full, store_screen, stored_full, stored_screen)
from . import _persist  # noqa: F401  (model files keep identification_: registers its codec)

__all__ = ["IdentifyCV", "identify"]

_HOLDS = ("zoh", "linear")
# fewest samples a fold may train on
_MIN_TRAIN = 5
# first samples that start a simulation of new data, unless n_init says
_N_INIT = 20
# the most a screening stage keeps, whatever the fraction
_MAX_SURVIVORS = 16


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
        dt = check_dt(dt if dt is not None else self.dt, allow_none=True)
        if dt is None:
            raise ValueError("dt is None; pass the sampling interval dt to IdentifyCV or to fit.")
        for name, value, options in (("families", self.families, ALL_FAMILIES),
                                     ("libraries", self.libraries, LIBRARIES),
                                     ("derivatives", self.derivatives, ("finite_difference", "savgol", "spectral"))):
            if value is None and name == "derivatives":
                continue
            if isinstance(value, str) or not hasattr(value, "__iter__") or not list(value):
                raise ValueError(f"{name} must be a non-empty list of names from {list(options)}; got {value!r}.")
            for v in value:
                check_option(v, name, options)
        if self.input_hold is not None:
            check_option(self.input_hold, "input_hold", _HOLDS)
        if self.input_delay is not None:
            check_integer(self.input_delay, "input_delay", low=0)
        check_option(self.criterion, "criterion", CRITERIA)
        if self.horizon is not None:
            check_integer(self.horizon, "horizon", low=1)
        check_integer(self.n_blocks, "n_blocks", low=2)
        check_positive(self.block_size, "block_size")
        if self.block_size * self.n_blocks >= 0.9:
            raise ValueError(f"n_blocks * block_size = {self.n_blocks * self.block_size:.3g} leaves too little "
                             "training data; expected < 0.9.")
        check_integer(self.max_path, "max_path")
        check_positive(self.screen_keep, "screen_keep")
        if self.screen_keep > 1:
            raise ValueError(f"screen_keep must be a fraction in (0, 1]; got {self.screen_keep!r}.")
        check_integer(self.screen_window, "screen_window", low=_MIN_TRAIN)
        check_integer(self.n_refine, "n_refine", low=0)
        check_integer(self.max_terms, "max_terms")
        if self.refinement is not None and not hasattr(self.refinement, "run"):
            raise ValueError(f"refinement must be an OutputErrorRefinement or None; got "
                             f"{type(self.refinement).__name__}.")
        if self.time_budget is not None:
            check_positive(self.time_budget, "time_budget")
        if self.max_candidates is not None:
            check_integer(self.max_candidates, "max_candidates")
        if self.n_init is not None:
            check_integer(self.n_init, "n_init")
        if self.n_jobs is not None and (check_integer(self.n_jobs, "n_jobs", low=None) == 0 or self.n_jobs < -1):
            raise ValueError(f"n_jobs must be None (one process), an integer >= 1, or -1 for one process per CPU; got "
                             f"{self.n_jobs!r}.")
        check_bool(self.show_progress_bar, "show_progress_bar")
        if self.validation is not None:
            check_option(self.validation, "validation", ("blocks", "records"))
        if self.study_name is not None and not isinstance(self.study_name, str):
            raise ValueError(f"study_name must be None or a str; got {self.study_name!r}.")
        if self.storage is not None:
            from ..model_selection import check_storage

            check_storage(self.storage)
        return dt

    @staticmethod
    def _check_data(X, y):
        """Lists ``(X, y)`` of 2-D arrays, one per record (one array: a list of one), checked."""
        if y is None:
            raise ValueError("IdentifyCV requires y to be passed, but the target y is None; expected the outputs.")
        if is_records(y) or (isinstance(X, list) and X and hasattr(X[0], "shape") and np.ndim(X[0]) == 2):
            check_record_lists(X, y)
            X, y = check_records(X, y, y_kind="outputs")
        else:
            check_array_like(X, "X")
            check_array_like(y, "y")
            X, y = check_inputs_outputs(X, y)
            X, y = [X], [y]
        check_magnitude(np.vstack(X), np.vstack(y))
        n = sum(y_r.shape[0] for y_r in y)
        if n < 2 * _MIN_TRAIN:
            raise ValueError(f"y has {n} sample(s) (n_samples = {n}); identify needs at least "
                             f"{2 * _MIN_TRAIN} to train and validate a candidate.")
        for j, col in enumerate(np.vstack(X).T):
            if np.ptp(col) == 0:
                raise ValueError(f"input column {j} is constant ({col[0]!r}); a constant input cannot be told apart "
                                 "from an offset. Expected inputs that vary (drop the constant column).")
        for j, col in enumerate(np.vstack(y).T):
            if np.ptp(col) == 0:
                raise ValueError(f"output column {j} is constant ({col[0]!r}); expected outputs that vary.")
        return X, y

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
        # the store stays in this process (never sent to the workers): it reads back and records every candidate
        store = CandidateStore(self.storage, self.study_name, signature)
        stored_screens, store_screens = partial(stored_screen, store), partial(store_screen, store)
        stored_scores, store_scores = partial(stored_full, store), partial(store_full, store)
        rows, libraries = [], []
        with progress_bar(len(structs), desc="identify", show=self.show_progress_bar) as bar:
            # stage 1: every structure's pruning path on the last block (the latent family has its own search)
            latent = [(s, lib) for s, lib in structs if s["family"] in LATENT_FAMILIES]
            structs = [(s, lib) for s, lib in structs if s["family"] not in LATENT_FAMILIES]
            todo = structs[: budget.take(len(structs))]
            screens = run_stage(screen_structure, [(s, lib, ctx) for s, lib in todo], stored_screens, store_screens,
                                parallel)
            for (struct, library), screened in zip(todo, screens):
                rows.extend(screened)
                libraries.extend([library] * len(screened))
                bar.update()
            if budget.left is not None:  # the path's levels count as candidates
                budget.left = max(0, budget.left - (len(rows) - len(todo)))
            # stage 2: the best screened candidates on every block (and the best ones with the other hold)
            ok = [i for i, r in enumerate(rows) if np.isfinite(r["errors"][0])]
            ok.sort(key=lambda i: rows[i]["errors"][0])
            keep = ok[: min(_MAX_SURVIVORS, max(4, math.ceil(self.screen_keep * len(ok))))]
            # ... and the best of every family and library, so that a sparse structure is refined and compared too
            seen = {(rows[i]["family"], rows[i]["library"]) for i in keep}
            for i in ok:
                if (rows[i]["family"], rows[i]["library"]) not in seen:
                    seen.add((rows[i]["family"], rows[i]["library"]))
                    keep.append(i)
            second = [(rows[i], libraries[i]) for i in keep]
            if self.input_delay is None and settings["input_delay"] > 0:  # the advice's delay, confirmed against none
                second += [(dict(rows[i], input_delay=0), libraries[i]) for i in keep[:2]]
            second += [(dict(s, threshold=0.0), lib) for s, lib in latent]
            if self.input_delay is None and settings["input_delay"] > 0:  # in the latent and linear families too
                second += [(dict(s, threshold=0.0, input_delay=0), lib) for s, lib in latent]
            second = second[: budget.take(len(second))]
            bar.total += len(second)
            results = run_stage(score_candidate, [(r, lib, ctx, None) for r, lib in second], stored_scores,
                                store_scores, parallel)
            for (row, library), result in zip(second, results):
                rows.append(result)
                libraries.append(library)
                bar.update()
            # stage 3: the parsimonious pick of stage 2 and the best ones, refined by simulation error
            scored = [i for i, r in enumerate(rows) if r["stage"] == "blocks" and np.all(np.isfinite(r["errors"]))
                      and r["max_row_terms"] <= self.max_terms and r["family"] not in LATENT_FAMILIES]
            scored.sort(key=lambda i: np.mean(rows[i]["errors"]))
            if scored:
                pick = scored[parsimonious_index([np.mean(rows[i]["errors"]) for i in scored],
                                                 [np.std(rows[i]["errors"]) for i in scored],
                                                 [rows[i]["n_terms"] for i in scored], len(folds))]
                front = [scored[k] for k in pareto_front([np.mean(rows[i]["errors"]) for i in scored],
                                                         [rows[i]["n_terms"] for i in scored])]
                order = [pick] + front + scored  # the pick, then the front sparsest first, then the best
                scored = [i for k, i in enumerate(order) if i not in order[:k]]
            third = [(rows[i], libraries[i]) for i in scored[: budget.take(min(self.n_refine, len(scored)))]]
            twin = hold_twin(third) if self.input_hold is None and X_all.shape[1] > 0 else None
            if twin is not None and budget.take(1):
                third.insert(1, twin)
            else:
                twin = None
            refinement = self._refinement(n, horizon)
            bar.total += len(third)
            calls = [(r, lib, ctx, refinement) for r, lib in third]
            results = run_stage(score_candidate, calls, stored_scores, store_scores, parallel)
            for (_, library), result in zip(third, results):
                rows.append(result)
                libraries.append(library)
                bar.update()
            if twin is not None:
                rows[-len(third) + 1] = confirm_hold(rows[-len(third)], rows[-len(third) + 1])
        table = _table(rows, len(folds))
        full = np.array([r["stage"] != "screen" and (r["max_row_terms"] or 0) <= self.max_terms
                         and not r.get("excluded") for r in rows])
        mean = np.where(full, table["mean_validation_error"], np.inf)
        if not np.any(np.isfinite(mean)):
            reasons = sorted({r["status"] for r in rows if r["status"] != "ok"})[:3] or [
                "the budget ended before any candidate was scored on every block"]
            raise ValueError(f"identify: none of the {len(rows)} candidates with at most max_terms={self.max_terms} "
                             f"terms per row simulated every validation block without failing (first reasons: "
                             f"{reasons}); expected a record long and rich enough for at least one candidate, or a "
                             "larger time_budget / max_candidates / max_terms.")
        terms = [t if t is not None else 10**9 for t in table["n_terms"]]

        lags = np.array([r["family"] == LAG_FAMILY for r in rows])

        def choose(mean):
            # the equations' pick (the lag models aside), then the lag model only when better by more than its SE
            equation_mean = np.where(lags, np.inf, mean)
            best = rule = None
            if np.any(np.isfinite(equation_mean)):
                best = parsimonious_index(equation_mean, table["std_validation_error"], terms, len(folds))
                best, rule = linear_base_rule(best, rows, equation_mean, table["std_validation_error"], len(folds))
            lag = int(np.argmin(np.where(lags, mean, np.inf))) if np.any(np.isfinite(mean[lags])) else None
            best, lag_reason = equation_or_lag(best, lag, mean, table["std_validation_error"], len(folds))
            return best, lag_reason or rule

        def refit(i):
            chosen = {k: rows[i][k] for k in STRUCTURE + ("threshold", "refine")}
            final = make_estimator(chosen, libraries[i], stls_threshold(chosen["threshold"], n), dt, settings,
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


def _table(rows, n_blocks):
    """``cv_results_``: one list per column; block errors of screened rows only in their last split."""
    table = {k: [r[k] for r in rows] for k in STRUCTURE + ("threshold", "refine", "stage", "n_terms",
                                                            "max_row_terms", "fit_time", "status")}
    table["equations"] = [r.get("equations") for r in rows]  # of the last fold's fit; None for screened rows
    errors = np.full((len(rows), n_blocks), np.nan)
    for i, r in enumerate(rows):
        errors[i, n_blocks - len(r["errors"]):] = r["errors"]
    for k in range(n_blocks):
        table[f"split{k}_validation_error"] = errors[:, k]
    complete = ~np.isnan(errors).any(axis=1) & np.isfinite(errors).all(axis=1)
    with np.errstate(invalid="ignore"):
        table["mean_validation_error"] = np.where(complete, errors.mean(axis=1), np.inf)
        table["std_validation_error"] = np.where(complete, errors.std(axis=1), np.inf)
    return table


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

"""``tune``: Bayesian optimisation (Optuna TPE) of any estimator, scored by simulation."""

import collections
import logging
import numbers
import re

import numpy as np
import optuna
from sklearn.base import clone
from sklearn.model_selection import KFold, TimeSeriesSplit

from .._json import jsonable
from .._progress import show_progress
from .._validation import check_bool, check_integer, is_records, records_hint
from .._records import check_record_lists, check_records, count_records
from ..metrics import make_simulation_scorer
from ..search import check_search_space, create_study, sample_params
from ._split import HoldoutSplit, LeaveOneRecordOut
from ._storage import (
    count_claimed,
    describe_storage,
    fail_dead_workers,
    make_storage,
    tag_trial,
    this_call_trials,
)

__all__ = ["AllTrialsFailedError", "tune"]

logger = logging.getLogger(__name__)

#: Seeds are numpy ``RandomState`` seeds: integers below 2**32.
MAX_SEED = 2**32

_DIRECTIONS = {"rmse": "minimize", "nrmse": "minimize", "r2": "maximize", "fit_index": "maximize"}


class AllTrialsFailedError(RuntimeError):
    """No trial of the study completed; ``study`` holds the trials and their ``fail_reason``."""

    def __init__(self, message, study):
        super().__init__(message)
        self.study = study


def _check_args(n_trials, timeout, n_jobs, random_state, scoring):
    check_integer(n_trials, "n_trials")
    if timeout is not None and (
        isinstance(timeout, bool) or not isinstance(timeout, numbers.Real) or not timeout > 0
    ):
        raise ValueError(f"timeout must be None or a number of seconds > 0; got {timeout!r}.")
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, numbers.Integral) or n_jobs == 0 or n_jobs < -1:
        raise ValueError(f"n_jobs must be an integer >= 1, or -1 for one thread per CPU; got {n_jobs!r}.")
    if random_state is not None and (
        isinstance(random_state, bool)
        or not isinstance(random_state, numbers.Integral)
        or not 0 <= random_state < MAX_SEED
    ):
        raise ValueError(f"random_state must be None or an integer seed in [0, 2**32 - 1]; got {random_state!r}.")
    if isinstance(scoring, str):
        if scoring not in _DIRECTIONS:
            raise ValueError(f"scoring must be one of {sorted(_DIRECTIONS)} or a scorer callable; got {scoring!r}.")
        return make_simulation_scorer(scoring), _DIRECTIONS[scoring], -1.0 if _DIRECTIONS[scoring] == "minimize" else 1.0
    if callable(scoring):
        return scoring, "maximize", 1.0
    raise ValueError(f"scoring must be one of {sorted(_DIRECTIONS)} or a scorer callable; got {scoring!r}.")


def _splits(cv, X, y):
    records = is_records(y)
    if cv is None:
        cv = LeaveOneRecordOut() if records else HoldoutSplit()
    elif isinstance(cv, numbers.Integral) and not isinstance(cv, bool):
        if records and cv > len(y):
            raise ValueError(f"cv={cv} asks for {cv} folds of {len(y)} records; expected at most {len(y)} (each fold "
                             "validates on whole records).")
        cv = KFold(n_splits=int(cv)) if records else TimeSeriesSplit(n_splits=int(cv))
    ref = y if X is None else X
    splits = list(cv.split(ref, y)) if hasattr(cv, "split") else list(cv)
    if not splits:
        raise ValueError(f"cv={cv!r} gave no split; expected at least one (train, validation) pair.")
    if records:
        for k, split in enumerate(splits):
            _check_record_split(k, split, len(y))
    return splits


def _check_record_split(k, split, n_records):
    """A split of several records: two non-empty arrays of record indices in ``[0, n_records)``."""
    try:
        train, test = split
    except (TypeError, ValueError) as exc:
        raise ValueError(f"cv split {k} is not a (train, validation) pair; got {split!r}.") from exc
    for name, idx in (("training", train), ("validation", test)):
        idx = np.asarray(idx)
        ok = idx.ndim == 1 and idx.size > 0 and np.issubdtype(idx.dtype, np.integer)
        if not ok or idx.min() < 0 or idx.max() >= n_records:
            raise ValueError(f"cv split {k}: the {name} indices {_preview(idx)} are not record indices; with several "
                             f"records (lists) a split picks records 0..{n_records - 1} (at least one on each side, "
                             "e.g. LeaveOneRecordOut), not samples.")


def _preview(idx):
    text = np.array2string(np.asarray(idx).ravel()[:6], separator=", ")
    return text[:-1] + ", ...]" if np.size(idx) > 6 else text


def _take(a, idx):
    """Rows ``idx`` of an array, or records ``idx`` of a list of records."""
    if isinstance(a, list):
        return [a[i] for i in idx]
    return None if a is None else a[idx]


def _fail(trial, reason):
    trial.set_user_attr("fail_reason", reason)
    raise optuna.TrialPruned(reason)


class _BudgetFilled(Exception):
    """Raised by a trial that started when other workers already held every place of the budget."""


def _objective(estimator, search_space, X, y, splits, scorer, sign, n_trials, running):
    def objective(trial):
        tag_trial(trial, running)
        if count_claimed(trial.study, before=trial.number) >= n_trials:
            # two workers started their last trials at once: the later one stands down (it ends FAIL,
            # which never counts), so the study ends with exactly n_trials finished trials
            trial.study.stop()
            trial.set_user_attr("fail_reason", "not run: the budget was filled by other workers")
            raise _BudgetFilled(f"the {n_trials} places of the budget are taken")
        params = sample_params(search_space, trial)
        trial.set_user_attr("params", {k: jsonable(v) for k, v in params.items()})
        scores = []
        for k, (train, test) in enumerate(splits):
            stage = "set_params"
            try:
                model = clone(estimator).set_params(**params)
                stage = "fit"
                model.fit(_take(X, train), _take(y, train))
                stage = "simulation"
                score = float(scorer(model, _take(X, test), _take(y, test)))
            except Exception as exc:  # a failed fit or simulation ends the trial, never the study
                _fail(trial, f"{stage} failed on split {k}: {type(exc).__name__}: {exc}")
            if not np.isfinite(score):
                _fail(trial, f"simulation diverged on split {k} (non-finite prediction, score {score})")
            scores.append(score)
        trial.set_user_attr("split_scores", scores)
        return sign * float(np.mean(scores))

    return objective


def _as_array(a, name):
    """``a`` as an array of at most 2 dimensions (None stays None); several records in another form are refused."""
    if a is None:
        return None
    try:
        arr = np.asarray(a)
    except ValueError as exc:  # ragged
        raise ValueError(f"{name} could not be converted to an array: {exc}{records_hint(a)}") from exc
    if arr.ndim > 2:
        raise ValueError(f"{name} has {arr.ndim} dimensions (shape {arr.shape}); expected shape (n_samples,) or "
                         f"(n_samples, n_columns).{records_hint(a)}")
    return arr


def _check_record_lists(X, y):
    """Several records: the lists and each record checked before the study (lengths, shapes, finite values, the
    columns of record 0), so that bad data fails here, naming the record, rather than in every trial."""
    check_record_lists(X, y)
    check_records(X, y, y_kind="outputs")


def _open_study(storage, study_name, estimator, search_space, direction, scoring, random_state):
    space_text = repr(search_space) if isinstance(search_space, dict) else getattr(search_space, "__qualname__", "")
    if study_name is None and not isinstance(storage, optuna.storages.InMemoryStorage):
        study_name = f"tune-{type(estimator).__name__}"
    study = create_study(random_state, storage=storage, study_name=study_name, direction=direction,
                         load_if_exists=True)
    # one attribute, written at once: a second worker never sees half of it
    signature = {"estimator": type(estimator).__name__, "search_space": space_text, "scoring": _scoring_name(scoring)}
    stored = study.user_attrs.get("tune_call")
    if stored is not None and stored != signature:
        raise ValueError(
            f"study {study.study_name!r} in this storage was made by another call ({stored}); got {signature}. "
            "Expected the same estimator class, search space and scoring to resume it: pass another study_name."
        )
    if study.direction.name.lower() != direction:
        raise ValueError(f"study {study.study_name!r} has direction {study.direction.name}; expected {direction}.")
    if stored is None:
        study.set_user_attr("tune_call", signature)
    return study


def _scoring_name(scoring):
    """``scoring`` as the study records it: the same text in every process that passes the same scorer.

    A metric name stays its ``repr``; a function, class or method is named by
    its module and qualified name; any other scorer object by its ``repr`` with
    memory addresses (``at 0x7f...``) removed, which differ from run to run.

    Examples
    --------
    >>> _scoring_name("rmse"), _scoring_name(len)
    ("'rmse'", 'builtins.len')
    >>> import functools
    >>> _scoring_name(functools.partial(_scoring_name))
    'functools.partial(<function _scoring_name>)'
    """
    if isinstance(scoring, str):
        return repr(scoring)
    name = getattr(scoring, "__qualname__", None)
    if isinstance(name, str):
        return f"{getattr(scoring, '__module__', None) or ''}.{name}".lstrip(".")
    return re.sub(r" at 0x[0-9a-fA-F]+", "", repr(scoring))


def _storage_failure(exc):
    """The database error behind ``exc`` (Optuna's ``StorageInternalError`` or a SQLAlchemy ``OperationalError``)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, optuna.exceptions.StorageInternalError) or type(exc).__name__ == "OperationalError":
            return exc
        exc = exc.__cause__ or exc.__context__
    return None


def _failure_summary(study):
    reasons = collections.Counter(
        t.user_attrs.get("fail_reason", f"{t.state.name} (no reason recorded)")
        for t in study.get_trials(deepcopy=False)
    )
    return "; ".join(f"{n} x {reason}" for reason, n in reasons.most_common(3))


def tune(
    estimator,
    search_space,
    X,
    y,
    *,
    cv=None,
    scoring="rmse",
    n_trials=100,
    timeout=None,
    storage=None,
    study_name=None,
    n_jobs=1,
    random_state=None,
    show_progress_bar=True,
    refit=True,
):
    """Choose hyperparameters by Bayesian optimisation of the simulation error.

    Every trial draws parameters from ``search_space`` (Optuna TPE), fits a
    clone of ``estimator`` on each training block of ``cv`` and scores the
    open-loop simulation of the matching validation block
    (:func:`~sindybench.metrics.make_simulation_scorer`). The best parameters
    are then refitted on all of ``X, y``.

    Parameters
    ----------
    estimator : estimator
        Any sindybench estimator (``fit(X, y)``, ``predict(X, y_init=...)``),
        cloned for every fit.
    search_space : dict or callable
        ``{parameter name: dimension}`` with the dimensions of
        :mod:`sindybench.model_selection` (``LogUniform``, ``LogNormal``,
        ``IntRange``, ``Categorical``, ...) or Optuna's ``FloatDistribution``,
        ``IntDistribution`` and ``CategoricalDistribution`` (the same dict then
        serves ``optuna_integration.OptunaSearchCV``), names as in
        ``set_params`` (``"optimizer__threshold"``). Or a callable ``f(trial) -> dict`` of
        parameter values for conditional spaces.
    X : array-like of shape (n_samples, n_inputs), None, or list
        Inputs.
    y : array-like of shape (n_samples, n_outputs), or list of ndarray
        Measured outputs. Lists of arrays (``X`` a list too, or None) are
        several records of one system: the splits then pick whole records
        (fit on the training records, score on the held-out ones, each
        simulated from its own start and the samples pooled), for an
        estimator whose ``fit`` takes lists (``SINDy``,
        ``HiddenStateSINDy``).
    cv : splitter, int or iterable, default=None
        ``None``: :class:`HoldoutSplit` (the last 20 % validates), or with
        several records :class:`LeaveOneRecordOut`; an int:
        ``TimeSeriesSplit(n_splits=cv)`` (records: ``KFold(n_splits=cv)``
        over the records, in order); any scikit-learn splitter or list of
        ``(train, validation)`` index pairs (record indices with lists). The
        trial value is the mean over splits.
    scoring : {"rmse", "nrmse", "r2", "fit_index"} or callable, default="rmse"
        A simulation metric (minimised for rmse and nrmse, maximised
        otherwise, the study's values are the metric itself), or a scorer
        ``scorer(estimator, X, y) -> float`` to maximise. A persistent study
        records a scorer function by its module and qualified name, so that
        another process passing the same function resumes the study.
    n_trials : int, default=100
        Budget of the *study*, not of this call: trials that finished
        (COMPLETE, or PRUNED for a failed evaluation) count, and a call on a
        study that already holds some runs only the missing ones. Workers
        sharing a study share the budget exactly: a trial that another
        worker is running holds its place, and the study ends with
        ``n_trials`` finished trials (a trial left RUNNING by a killed worker
        gives its place back once it is marked FAIL, see Notes).
    timeout : float, optional
        Stop starting new trials after this many seconds.
    storage : None, str, path-like or optuna storage, default=None
        ``None`` keeps the study in memory. ``"sqlite:///study.db"`` (or a
        ``.db`` path), ``"journal:///path/study.log"`` (or a ``.log`` path),
        or a PostgreSQL/MySQL URL make it persistent, resumable and shared
        between worker processes and machines: see ``docs/scaling.rst``.
    study_name : str, optional
        Name in the storage; default ``"tune-<EstimatorClass>"`` with a
        persistent storage. The same call with the same name resumes.
    n_jobs : int, default=1
        Threads in this process (``-1``: one per CPU). For CPU-bound fits, run
        several processes on one storage instead.
    random_state : int or None, default=None
        Seeds TPE (an integer from 0 to 2**32 - 1). Trial ``n`` draws from a generator seeded by
        ``(random_state, n)``, so concurrent or restarted workers do not
        repeat each other's points.
    show_progress_bar : bool, default=True
        Optuna's ``tqdm.auto`` bar, drawn only where there is somewhere to
        draw it, a notebook or a terminal, never into a log file or a pipe;
        the environment variable ``SINDYBENCH_PROGRESS=0`` turns bars off.
    refit : bool, default=True
        Fit the best estimator on all of ``X, y`` (every record). ``False`` returns it
        unfitted, for a caller that fits it on other data (the study fits the
        chosen model on the training block only), saving one fit.

    Returns
    -------
    best_estimator : estimator
        A clone with the best trial's parameters, fitted on all of ``X, y``
        (unfitted with ``refit=False``).
    study : optuna.study.Study
        All trials. ``user_attrs`` of a trial: ``params`` (the values set on
        the estimator), ``split_scores``, ``worker`` (``host:pid``) and, for a
        failed one, ``fail_reason``.

    Raises
    ------
    AllTrialsFailedError
        When no trial of the study completed (its ``study`` attribute holds them).
    ValueError
        For a bad argument, and for a storage that cannot serve: an unknown database
        kind, a file that is not an SQLite database or an Optuna journal.
    ConnectionError
        When the database cannot be reached, or stops answering during the study
        (the finished trials are kept in it: the same call resumes the study).

    Notes
    -----
    A fit that raises, a simulation that raises (``sindybench.SimulationError``)
    or a non-finite simulation ends the trial as **PRUNED** with user attribute
    ``fail_reason``; it never stops the study. PRUNED rather than FAIL because
    TPE ranks pruned trials below all completed ones, so it learns to stay away
    from regions where models diverge, while it ignores FAIL trials. FAIL is
    left to trials that were interrupted (worker killed, Ctrl-C, stale
    heartbeat); they do not count toward ``n_trials``. On start and after
    each trial, RUNNING trials of dead workers on this machine are marked
    FAIL; a database storage's heartbeat does it for other machines.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.baselines import ARX
    >>> from sindybench.model_selection import IntRange, tune
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((400, 1))
    >>> y = np.zeros((400, 1))
    >>> for t in range(2, 400):
    ...     y[t] = 1.5 * y[t - 1] - 0.7 * y[t - 2] + u[t - 1]
    >>> space = {"na": IntRange(1, 4), "nb": IntRange(1, 3)}
    >>> best, study = tune(ARX(), space, u, y, n_trials=15, random_state=0)
    >>> best.na >= 2, study.best_value < 1e-6
    (True, True)
    """
    scorer, direction, sign = _check_args(n_trials, timeout, n_jobs, random_state, scoring)
    check_bool(refit, "refit")
    show_progress_bar = show_progress(show_progress_bar)
    check_search_space(search_space, estimator)
    if is_records(y) or count_records(X):
        _check_record_lists(X, y)
    else:
        X, y = _as_array(X, "X"), _as_array(y, "y")
        if X is not None and X.shape[0] != y.shape[0]:
            raise ValueError(f"X has {X.shape[0]} samples and y has {y.shape[0]}; expected the same number of "
                             "samples.")
    splits = _splits(cv, X, y)
    opened = make_storage(storage)
    try:
        study = _open_study(opened, study_name, estimator, search_space, direction, scoring, random_state)
        with this_call_trials() as running:  # once the call ends, a trial of it still RUNNING is an orphan
            objective = _objective(estimator, search_space, X, y, splits, scorer, sign, n_trials, running)
            best = _run_study(study, objective, search_space, n_trials=n_trials, timeout=timeout, n_jobs=n_jobs,
                              show_progress_bar=show_progress_bar)
    except AssertionError as exc:  # Optuna's loop hides a storage write that failed (a full disk) behind an assert
        if isinstance(exc.__context__, OSError):
            raise exc.__context__ from None
        raise
    except Exception as exc:
        failure = _storage_failure(exc)
        if failure is None:
            raise
        cause = failure.__cause__ or failure
        text = str(getattr(cause, "orig", None) or cause).strip().splitlines()
        raise ConnectionError(
            f"storage {describe_storage(storage)!r}: the database stopped answering during the study "
            f"({type(cause).__name__}: {text[0] if text else ''}). The finished trials are kept in it; run the "
            "same call again once it answers to resume (a trial left RUNNING is then marked FAIL and run again)."
        ) from failure
    best_estimator = clone(estimator).set_params(**best)
    if refit:
        best_estimator.fit(X, y)
    return best_estimator, study


def _run_study(study, objective, search_space, *, n_trials, timeout, n_jobs, show_progress_bar):
    """Run the missing trials of ``study``; return the best trial's parameters."""
    fail_dead_workers(study)

    def stop_at_budget(study, trial):
        # trials that other workers are running hold their places: start no trial that could exceed the budget
        fail_dead_workers(study)
        if count_claimed(study) >= n_trials:
            study.stop()

    remaining = n_trials - count_claimed(study)
    while remaining > 0:
        logger.info("study %r: running up to %d of %d trials", study.study_name, remaining, n_trials)
        study.optimize(
            objective,
            n_trials=remaining,
            timeout=timeout,
            n_jobs=n_jobs,
            catch=(_BudgetFilled,),
            callbacks=[stop_at_budget],
            show_progress_bar=show_progress_bar,
        )
        if timeout is not None:
            break
        # a place held by a dead worker's RUNNING trial is given back only once that trial is marked FAIL,
        # possibly after this worker stood down for it: run what is still missing (every trial run here
        # either finishes, which claims a place, or stands down because all places are claimed)
        fail_dead_workers(study)
        remaining = n_trials - count_claimed(study)
    complete = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
    if not complete:
        raise AllTrialsFailedError(
            f"no trial of study {study.study_name!r} completed ({len(study.trials)} trials); "
            f"most frequent reasons: {_failure_summary(study)}",
            study,
        )
    best = study.best_trial
    return sample_params(search_space, optuna.trial.FixedTrial(best.params, best.number))

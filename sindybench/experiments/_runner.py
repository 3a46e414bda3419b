"""Train the study's models on one benchmark, evaluate them, collect results.

The runner is a plain function over a :class:`~sindybench.experiments.Benchmark`
description: load the data, tune and fit every model on the training +
validation record (the validation block is the last part, as in the study),
simulate each fitted model open loop on every test set from the test's first
samples, and score the simulation with RMSE, R^2 and the fit index. Writing
files is left to :mod:`sindybench.experiments._report`.
"""

import logging
import os
import time
import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning

from .._version import __version__
from .._json import jsonable
from ..identify._resume import shared_candidates
from ._best import free_run_scores, k_step_scores, report_best_model, test_record
from ._published import published

__all__ = ["DataNotFoundError", "evaluate", "fit_model", "load_data", "run_benchmark", "test_sets"]

logger = logging.getLogger(__name__)


class DataNotFoundError(FileNotFoundError):
    """A benchmark record could not be found (or downloaded).

    The message names the benchmark, repeats what the loader said (which file,
    where it looked) and says how to provide the data.
    """


def load_data(benchmark, *, data_home=None, download_if_missing=True):
    """Load a benchmark's record, turning a missing file into :class:`DataNotFoundError`.

    Parameters
    ----------
    benchmark : Benchmark
    data_home : str or path-like, optional
        Data folder; ``None`` uses ``SINDYBENCH_DATA`` or the default data home.
    download_if_missing : bool, default=True
        Try the public source when a file is absent.

    Returns
    -------
    Bunch
    """
    try:
        return benchmark.load(data_home=data_home, download_if_missing=download_if_missing)
    except OSError as exc:  # FileNotFoundError, a failed download (URLError is an OSError)
        if data_home is not None:
            where = f"{data_home} (--data-home / data_home=)"
        elif os.environ.get("SINDYBENCH_DATA"):
            where = f"{os.environ['SINDYBENCH_DATA']} (SINDYBENCH_DATA)"
        else:
            where = "~/sindybench_data (the default data home; SINDYBENCH_DATA is not set)"
        how = ("put the benchmark records in a folder DIR and pass --data-home DIR "
               "(data_home= in Python) or set SINDYBENCH_DATA=DIR")
        if not download_if_missing:
            how += ", or allow the download from the public source (drop --no-download; needs a network)"
        raise DataNotFoundError(
            f"{benchmark.title}: benchmark data not found.\n  {exc}\n  Looked in: {where}.\n  To provide them: {how}."
        ) from exc


def test_sets(data):
    """Return the test sets of a dataset Bunch as an ordered ``{name: Bunch}``."""
    test = data["test"]
    if isinstance(test, dict) and "u" not in test:
        return dict(test)
    return {"test": test}


def _n_init(benchmark, data, test):
    for source in (test, data):
        value = source.get("n_init") if hasattr(source, "get") else None
        if value is not None:
            return int(value)
    return benchmark.n_init


def _training_record(benchmark, data, quick):
    train, val = data["train"], data["validation"]
    u_tr, y_tr = np.asarray(train["u"], float), np.asarray(train["y"], float)
    if quick and benchmark.n_train_quick is not None:
        u_tr, y_tr = u_tr[: benchmark.n_train_quick], y_tr[: benchmark.n_train_quick]
    u_va, y_va = np.asarray(val["u"], float), np.asarray(val["y"], float)
    X = np.vstack([u_tr.reshape(len(u_tr), -1), u_va.reshape(len(u_va), -1)])
    y = np.vstack([y_tr.reshape(len(y_tr), -1), y_va.reshape(len(y_va), -1)])
    return X, y, len(y_tr), len(y_va)


def _chosen(estimator):
    """The estimator's inner-search choices as fixed parameters (``hidden__<name>``)."""
    hidden = getattr(estimator, "hidden_", None)
    params = getattr(estimator, "params_", None) or {}
    if hidden is None:
        return {}
    names = hidden.get_params(deep=False)
    return {f"hidden__{k}": v for k, v in params.items() if k in names}


def refine_model(spec, base, X, y, *, dt, seed=0, quick=False):
    """Fit the refinement row ``spec`` from the fitted model ``base`` it refines.

    ``base`` is cloned with the hyperparameters its searches chose held
    (inner physical guesses become fixed values), the parameters returned by
    ``spec.make`` are set, and it is fitted on the whole estimation record
    ``X, y`` (training + validation block): every choice was already made on
    the validation block, and the refinement is the final fit.

    Returns
    -------
    estimator, info : as :func:`fit_model`
    """
    from sklearn.base import clone

    start = time.perf_counter()
    settings = spec.make(random_state=seed, quick=quick, dt=dt, n_val=0, n_samples=len(y))
    if "initial_state" not in base.get_params(deep=False):
        settings.pop("initial_state", None)  # SINDy measures its whole state: it starts from y_init[0]
    chosen = _chosen(base)
    estimator = clone(base).set_params(**chosen, **settings).fit(X, y)
    info = {"n_trials": 0, "best_params": {k: jsonable(v) for k, v in chosen.items()}, "best_value": None,
            "inner_trials": 0, "refinement": getattr(estimator, "refinement_", None),
            "fit_time_s": time.perf_counter() - start}
    return estimator, info


def fit_model(spec, X, y, *, n_val, dt, n_trials, n_init, seed=0, quick=False, storage=None,
              n_jobs=1, study_name=None, show_progress_bar=False):
    """Tune (when the spec has a search space and a budget) and fit one model.

    The search validates on the last ``n_val`` samples of ``X, y``; ``n_init``
    (the initial samples a test gives a model) caps model orders in the space.

    Returns
    -------
    estimator : object
        The fitted estimator: with an outer search, the best candidate fitted
        on the training block (without the validation block), as the study
        did; otherwise the estimator fitted on all of ``X, y`` (estimators
        that search inside ``fit`` hold the validation block out themselves).
    info : dict
        ``n_trials``, ``best_params`` (outer search, or the estimator's own
        ``best_params_``), ``best_value`` (validation RMSE) and ``fit_time_s``.
    """
    start = time.perf_counter()
    estimator = spec.make(random_state=seed, quick=quick, dt=dt, n_val=n_val, n_samples=len(y))
    if "show_progress_bar" in estimator.get_params(deep=False):  # an inner search (HiddenStateSINDy)
        estimator.set_params(show_progress_bar=show_progress_bar)
    info = {"n_trials": 0, "best_params": {}, "best_value": None}
    with warnings.catch_warnings():
        # small budgets stop iterative fits early on purpose (NN-ARX): say it once in the report, not per fit
        warnings.simplefilter("ignore", ConvergenceWarning)
        estimator = _search_and_fit(
            spec, estimator, X, y, info, n_val=n_val, n_trials=n_trials, n_init=n_init, seed=seed, quick=quick,
            storage=storage, n_jobs=n_jobs, study_name=study_name, show_progress_bar=show_progress_bar,
        )
    inner = getattr(estimator, "best_params_", None)
    if not info["best_params"] and inner:
        info["best_params"] = {k: jsonable(v) for k, v in inner.items()}
    info["inner_trials"] = len(getattr(estimator, "search_results_", None) or getattr(estimator, "cv_results_", {})
                               .get("family", ()))
    if getattr(estimator, "pareto_front_", None) is not None:  # identify's candidates: terms vs validation error
        info["pareto_front"] = [{k: jsonable(v) for k, v in p.items()} for p in estimator.pareto_front_]
    info["fit_time_s"] = time.perf_counter() - start
    return estimator, info


def _search_and_fit(spec, estimator, X, y, info, *, n_val, n_trials, n_init, seed, quick, storage, n_jobs, study_name,
                    show_progress_bar):
    if n_trials > 0:
        from ..model_selection import HoldoutSplit, tune

        # the study's protocol: fit on the training block, choose on the last n_val samples ...
        best, study = tune(
            estimator, spec.search_space(quick, n_init), X, y, cv=HoldoutSplit(validation_size=n_val), scoring="rmse",
            n_trials=n_trials, storage=storage, study_name=study_name, n_jobs=n_jobs,
            random_state=seed, show_progress_bar=show_progress_bar, refit=False,
        )
        trial = study.best_trial
        info["n_trials"] = len(study.trials)
        info["best_params"] = {k: jsonable(v) for k, v in trial.user_attrs.get("params", trial.params).items()}
        value = abs(float(trial.value))
        info["best_value"] = value if np.isfinite(value) else None
        # ... and keep the model fitted on the training block, the one the validation chose
        # (a thresholded fit on more data can select other terms than the validated one)
        return best.fit(X[:-n_val], y[:-n_val])
    # estimators with an inner search validate on the last n_val samples themselves
    return estimator.fit(X, y)


def _test_info(benchmark, data, test):
    info = {"n_samples": int(len(test["y"])), "n_init": _n_init(benchmark, data, test), "score_from": _score_from(test)}
    if test.get("protocol"):
        info["protocol"] = str(test["protocol"])
    return info


def _score_from(test):
    value = test.get("score_from") if hasattr(test, "get") else None
    return 0 if value is None else int(value)


def evaluate(estimator, test, n_init):
    """Simulate a fitted model on one test set and score it.

    The scores cover the samples from ``test["score_from"]`` on (all of
    them when the test set does not say).

    Returns
    -------
    y_pred : ndarray or None
        The open-loop simulation (``None`` when it failed).
    scores : dict
        ``rmse``, ``r2``, ``fit_index`` (``None`` when the simulation
        diverged) and ``status`` (``"ok"`` or the reason it failed).
    """
    u, y = test_record(test)
    try:
        y_pred = np.asarray(estimator.predict(u, y_init=y[:n_init]), float).reshape(y.shape)
    except Exception as exc:  # a diverging candidate is a result, not a crash
        logger.warning("simulation failed: %s", exc)
        return None, {"rmse": None, "r2": None, "fit_index": None, "status": f"failed: {exc}"}
    # a protocol may score only the samples after those that set the state
    scores = free_run_scores(y, y_pred, _score_from(test))
    return (y_pred if scores["status"] == "ok" else None), scores


def _equations(estimator):
    method = getattr(estimator, "equations", None)
    if method is None:
        return []
    try:
        eqs = method()
    except Exception as exc:  # equations are informative; never fail the run on them
        return [f"<equations unavailable: {exc}>"]
    return [str(e) for e in (eqs if isinstance(eqs, (list, tuple)) else [eqs])]


# the identify rows of one benchmark share their candidates: the equations-only row computes only those the
# identified row did not (the same results, bit for bit)
@shared_candidates()
def run_benchmark(benchmark, *, data=None, trials=None, seed=0, quick=False, storage=None, n_jobs=1,
                  data_home=None, download_if_missing=True, show_progress_bar=False, models=None):
    """Train every model of a benchmark and evaluate it on every test set.

    Parameters
    ----------
    benchmark : Benchmark
    data : Bunch, optional
        Already loaded data (else loaded with ``data_home``).
    trials : int, optional
        Outer search budget per model (default: each model's own budget).
    seed : int, default=0
        Seed of every search and estimator.
    quick : bool, default=False
        Small budgets (a smoke run).
    storage : str, optional
        Optuna storage URL (e.g. ``sqlite:///study.db``) to resume or share searches.
    n_jobs : int, default=1
        Parallel trials per search.
    models : list of str, optional
        Keys of the models to run (default: all).

    Returns
    -------
    results : dict
        JSON-serialisable results (see :func:`sindybench.experiments.write_results`).
    fitted : dict
        ``{model key: fitted estimator or None}``.
    simulations : dict
        ``{test name: {model key: y_pred or None}}``.
    """
    from ..model_selection._storage import describe_storage

    start = time.perf_counter()
    if data is None:
        data = load_data(benchmark, data_home=data_home, download_if_missing=download_if_missing)
    X, y, n_train, n_val = _training_record(benchmark, data, quick)
    dt = float(data["train"]["dt"])
    tests = test_sets(data)
    if quick and benchmark.test_sets_quick is not None:
        tests = {k: v for k, v in tests.items() if k in benchmark.test_sets_quick}
    specs = [m for m in benchmark.models if models is None or m.key in models]
    wanted = {m.key for m in specs}
    # a refinement row needs the model it refines
    specs = [m for m in benchmark.models if m.key in wanted or any(s.refines == m.key for s in specs)]
    results = {
        "benchmark": benchmark.name,
        "title": benchmark.title,
        "sindybench_version": __version__,
        "seed": seed,
        "quick": bool(quick),
        "n_jobs": n_jobs,
        "storage": describe_storage(storage),  # never a database password in results.json
        "n_train": n_train,
        "n_validation": n_val,
        "dt": dt,
        "test_sets": {name: _test_info(benchmark, data, t) for name, t in tests.items()},
        "output_label": benchmark.output_label,
        "input_label": benchmark.input_label,
        "models": [],
    }
    n_init = min(info["n_init"] for info in results["test_sets"].values())
    fitted, simulations = {}, {name: {} for name in tests}
    for spec in specs:
        budget = spec.budget(quick=quick, trials=trials)
        logger.info("%s: %s (%s)", benchmark.name, spec.label,
                    f"{budget} search trials" if budget else "no outer search")
        entry = {"key": spec.key, "label": spec.label, "description": spec.description}
        cap = spec.train_cap(quick=quick)
        keep = spec.train_rows(quick=quick, n_train=n_train, n_samples=len(y))
        entry["n_train"] = n_train if cap is None else min(cap, n_train)
        try:
            if spec.refines is not None:
                base = fitted.get(spec.refines)
                if base is None:
                    raise ValueError(f"the model it refines, {spec.refines!r}, was not fitted in this run.")
                estimator, info = refine_model(spec, base, X[keep], y[keep], dt=dt, seed=seed, quick=quick)
                searched = next(m["fit_time_s"] for m in results["models"] if m["key"] == spec.refines)
                info.update(refines=spec.refines, fit_time_with_search_s=info["fit_time_s"] + searched)
            else:
                estimator, info = fit_model(
                    spec, X[keep], y[keep], n_val=n_val, dt=dt, n_trials=budget, n_init=n_init, seed=seed,
                    quick=quick, storage=storage, n_jobs=n_jobs, study_name=f"{benchmark.name}.{spec.key}.seed{seed}",
                    show_progress_bar=show_progress_bar,
                )
            entry.update(info, status="ok", equations=_equations(estimator))
        except ConnectionError:  # the storage stopped answering: every later search would fail the same way
            raise
        except Exception as exc:  # one model failing must not lose the others' results
            logger.warning("%s: %s failed to fit: %s", benchmark.name, spec.label, exc)
            estimator = None
            entry.update(n_trials=budget, best_params={}, best_value=None, fit_time_s=None, inner_trials=0,
                         status=f"fit failed: {type(exc).__name__}: {exc}", equations=[])
        fitted[spec.key] = estimator
        entry["scores"], entry["published"] = {}, {}
        for name, test in tests.items():
            if estimator is None:
                y_pred, scores = None, {"rmse": None, "r2": None, "fit_index": None, "status": "not fitted"}
            else:
                y_pred, scores = evaluate(estimator, test, results["test_sets"][name]["n_init"])
            simulations[name][spec.key] = y_pred
            entry["scores"][name] = scores
            entry["published"][name] = published(benchmark.name, spec.key, name)
        if spec.k_step and estimator is not None:
            entry["k_step"] = k_step_scores(estimator, X[:n_train], y[:n_train], tests)
        results["models"].append(entry)
    results["best_model"] = report_best_model(benchmark, results, fitted, X, y, n_train, tests, quick=quick, seed=seed,
                                              simulations=simulations)
    results["wall_time_s"] = time.perf_counter() - start
    return results, fitted, simulations

"""Search histories (an estimator's inner search or an Optuna study)."""

import numpy as np

from ..search import SEARCH_PENALTY as _SEARCH_PENALTY  # the inner search's score of a failed candidate
from ._common import _check_axes, _new_axes


# ------------------------------------------------------------------ searches
def _search_values(search):
    """``(values, failed trial numbers, minimize, y label)`` of a study, a fitted model or a history."""
    if hasattr(search, "trials") and hasattr(search, "direction"):  # an optuna Study
        values, failed = [], []
        for trial in search.trials:
            if trial.state.name == "COMPLETE" and trial.value is not None and np.isfinite(trial.value):
                values.append((trial.number, float(trial.value)))
            elif trial.state.name in ("PRUNED", "FAIL"):
                failed.append(trial.number)
        return values, failed, search.direction.name == "MINIMIZE", "objective"
    history = getattr(search, "search_results_", search)
    if not isinstance(history, (list, tuple)) or not all(isinstance(h, (list, tuple)) and len(h) == 2
                                                         for h in history):
        raise ValueError(
            f"cannot read a search history from {type(search).__name__}; expected an optuna Study (from tune), "
            "a fitted HiddenStateSINDy (search_results_) or a list of (params, score) pairs."
        )
    values, failed = [], []
    for i, (_, score) in enumerate(history):
        score = float(score)
        if np.isfinite(score) and score < _SEARCH_PENALTY:
            values.append((i, score))
        else:
            failed.append(i)
    return values, failed, True, "validation score (normalized RMSE)"


def plot_search_history(search, *, label=None, log=None, ax=None):
    """Score of every trial of a search and the best score so far.

    Parameters
    ----------
    search : optuna Study, HiddenStateSINDy or list of (params, score)
        The study returned by :func:`sindybench.model_selection.tune`, a
        fitted :class:`~sindybench.HiddenStateSINDy` (its inner search,
        ``search_results_``; lower is better) or such a list.
    label : str, optional
        Label of the best-so-far line (to compare several searches on one ``ax``).
    log : bool, optional
        Logarithmic score axis; default: when all scores are positive and span
        more than two decades.
    ax : Axes, optional

    Returns
    -------
    Axes

    Examples
    --------
    >>> history = [({"k": 1.0}, 0.5), ({"k": 2.0}, 0.7), ({"k": 3.0}, 0.2), ({"k": 4.0}, 1e3)]
    >>> ax = plot_search_history(history)
    >>> ax.get_lines()[0].get_ydata().tolist()
    [0.5, 0.5, 0.2]
    """
    values, failed, minimize, y_label = _search_values(search)
    if not values:
        raise ValueError(f"the search has no successful trial ({len(failed)} failed); nothing to draw.")
    (ax,) = _check_axes(ax, 1) or _new_axes(1, figsize=(7, 4))
    number = np.array([n for n, _ in values])
    score = np.array([s for _, s in values])
    best = np.minimum.accumulate(score) if minimize else np.maximum.accumulate(score)
    line = ax.step(number, best, where="post", lw=1.8, label=label or "best so far")[0]
    ax.plot(number, score, "o", ms=3.5, alpha=0.5, color=line.get_color(), label="trial")
    if failed:
        ax.plot(failed, np.full(len(failed), 0.98), "x", color="red", transform=ax.get_xaxis_transform(),
                label=f"failed ({len(failed)})")
    if log is None:
        log = bool(np.all(score > 0) and score.max() > 100 * score.min())
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("trial")
    ax.set_ylabel(y_label + (" (lower is better)" if minimize else " (higher is better)"))
    ax.legend(fontsize=7)
    return ax


# -------------------------------------------------------------- Pareto front
def _front_record(search):
    """``(complexity, error, front indices, chosen index)`` of an IdentifyCV, an identified model or its record."""
    record = getattr(search, "identification_", None)
    if record is None and hasattr(search, "cv_results_") and hasattr(search, "pareto_front_"):
        record = {"cv_results": search.cv_results_, "pareto_front": search.pareto_front_,
                  "best_index": search.best_index_}
    if record is None and isinstance(search, dict):
        record = search
    if not isinstance(record, dict) or not {"cv_results", "pareto_front"} <= set(record):
        raise ValueError(
            f"cannot read a Pareto front from {type(search).__name__}; expected a fitted IdentifyCV, a model "
            "returned by sindybench.identify (identification_) or its identification_ dict."
        )
    table = record["cv_results"]
    terms = np.array([np.nan if t is None else t for t in table["n_terms"]], dtype=float)
    error = np.asarray(table["mean_validation_error"], dtype=float)
    return terms, error, [p["index"] for p in record["pareto_front"]], record.get("best_index")


def plot_pareto_front(search, *, ax=None):
    """Number of terms against validation error of every candidate of ``identify``, with the front and the choice.

    Parameters
    ----------
    search : IdentifyCV, identified model or dict
        A fitted :class:`~sindybench.identify.IdentifyCV`, the model
        :func:`sindybench.identify` returns (its ``identification_``) or that dict.
    ax : Axes, optional

    Returns
    -------
    Axes

    Examples
    --------
    >>> record = {"cv_results": {"n_terms": [2, 5, 5, 9], "mean_validation_error": [0.5, 0.2, 0.3, 0.1]},
    ...           "pareto_front": [{"index": 0}, {"index": 1}, {"index": 3}], "best_index": 1}
    >>> ax = plot_pareto_front(record)
    >>> ax.get_lines()[1].get_xdata().tolist(), ax.get_lines()[1].get_ydata().tolist()
    ([2.0, 5.0, 9.0], [0.5, 0.2, 0.1])
    """
    terms, error, front, best = _front_record(search)
    ok = np.isfinite(terms) & np.isfinite(error)
    if not ok.any():
        raise ValueError("no candidate was scored on every validation block; nothing to draw.")
    (ax,) = _check_axes(ax, 1) or _new_axes(1, figsize=(6, 4))
    ax.plot(terms[ok], error[ok], "o", ms=4, alpha=0.35, color="0.5", label=f"candidates ({int(ok.sum())})")
    ax.plot(terms[front], error[front], "o-", lw=1.6, ms=5, label="Pareto front")
    if best is not None and ok[best]:
        ax.plot([terms[best]], [error[best]], "*", ms=14, color="C3", label="chosen (parsimony rule)")
    if np.all(error[ok] > 0) and error[ok].max() > 20 * error[ok].min():
        ax.set_yscale("log")
    ax.set_xlabel("number of terms")
    ax.set_ylabel("validation error (RMSE / output std)")
    ax.legend(fontsize=7)
    return ax

"""Several candidates of the inner search refined side by side, the best by validation kept (``n_refined``).

The inner search of :class:`~sindybench.HiddenStateSINDy` scores candidates
fitted by equation error; the refinement by simulation error then moves the
chosen one, and a start that scores second before the refinement can score
first after it. :func:`refine_best` refines the ``n`` best distinct
candidates on the training part of the record, scores each refined model
on the validation block exactly as the search scores a trial, and returns
the values of the best. :func:`search_starts` (``LatentHiddenState(start="auto")``)
puts the best candidates of several kinds of start (each with its own strategy
and inner search) in one such pool.
"""

import time
import warnings

import numpy as np

from ..search import SEARCH_PENALTY
from ..simulate import SimulationError
from ._auto import auto_grid, auto_refinement
from ._objective import SearchObjective, validation_error

__all__ = ["distinct_best", "refine_best", "refit_failed", "search_starts"]

# a model refined on the training part is scored on the validation block only: "full" would score the samples it
# was refined on too
_VALIDATION = {"full": "continued"}
# a refit on the whole record that simulates the training part this many times worse than the kept winner has failed
_REFIT_RATIO = 2.0
_FAILURES = (ValueError, FloatingPointError, np.linalg.LinAlgError, SimulationError)


def distinct_best(search_results, n, penalty=SEARCH_PENALTY):
    """The ``n`` best distinct ``(values, score)`` of an inner search, failed ones left out, best first.

    Examples
    --------
    >>> results = [({"tau": 1.0}, 0.3), ({"tau": 2.0}, 0.1), ({"tau": 1.0}, 0.3), ({"tau": 5.0}, 1e3)]
    >>> distinct_best(results, 3)
    [({'tau': 2.0}, 0.1), ({'tau': 1.0}, 0.3)]
    """
    out, seen = [], set()
    for values, score in sorted(search_results, key=lambda item: item[1]):
        key = repr(sorted(values.items()))
        if score >= penalty or not np.isfinite(score) or key in seen:
            continue
        seen.add(key)
        out.append((values, score))
        if len(out) == n:
            break
    return out


def heads(X, y, n):
    """``(X, y)`` cut to the first ``n[i]`` samples of each record (lists, one entry per record)."""
    return [X_r[:k] for X_r, k in zip(X, n)], [y_r[:k] for y_r, k in zip(y, n)]


def _with_first_states(cand, x0):
    """``cand`` whose records start from the refined first states ``x0`` (n_records, n_states)."""
    designs = []
    for design, x in zip(cand.designs, x0):
        states = np.array(design.states, dtype=float)
        states[0] = x
        designs.append(design._replace(states=states))
    return cand._replace(designs=tuple(designs))


def refine_best(estimator, hidden, search_results, X, y, dt, n_fit, derivative, n, extra=()):
    """``(strategy, values, record, kept)``: the search's ``n`` best distinct candidates refined on the training part.

    Each candidate is fitted with its values on the first ``n_fit`` samples
    of each record, refined there by simulation error (the estimator's
    ``refine``; a candidate it does not refine is scored as fitted), and
    scored by :func:`~sindybench.hidden._objective.validation_error` with the
    estimator's ``validation``. ``extra``: more candidates of other
    strategies, ``(name, strategy, values, score)`` each, fitted with their
    own strategy in the same pool. ``record`` lists, for each, its start's
    name (None for ``hidden``'s), values, score before and after the
    refinement, CPU seconds and error (a candidate whose fit or refinement
    fails is left out); the best's strategy and values are returned, and
    ``kept``: its refined candidate, refined first states and refinement
    record (for :func:`refit_failed`). When every one fails, the search's
    best values are returned (with ``hidden``; ``kept`` None).
    """
    pool = [(None, hidden, values, score) for values, score in distinct_best(search_results, n)] + list(extra)
    record, best = [], None
    head = heads(X, y, n_fit)
    for name, strategy, values, score in pool:
        t0 = time.process_time()
        entry = {"start": name, "values": dict(values), "score": float(score), "refined_score": SEARCH_PENALTY,
                 "error": None}
        try:
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")
                cand = estimator._candidate(strategy, values, X, y, dt, n_fit, derivative)
                refine = auto_refinement(estimator.refine, cand.dynamics)
                refined, x0, summary = cand, None, None
                if refine is not None:
                    refined, x0, summary = estimator._refine(strategy, cand, *head, refine=refine)
                if x0 is not None:
                    refined = _with_first_states(refined, x0)
                entry["refined_score"] = float(validation_error(strategy, refined, X, y, n_fit, _VALIDATION.get(
                    estimator.validation, estimator.validation)))
        except _FAILURES as exc:
            entry["error"] = f"{type(exc).__name__}: {exc}"
        entry["seconds"] = time.process_time() - t0
        record.append(entry)
        if entry["error"] is None and entry["refined_score"] < SEARCH_PENALTY and (
                best is None or entry["refined_score"] < best[0]["refined_score"]):
            best = (entry, strategy, (refined, x0, summary) if x0 is not None else None)
    if best is None:
        if not search_results and pool:  # nothing of hidden's own: the best unrefined of the pool
            _, strategy, values, _ = min(pool, key=lambda item: item[3])
            return strategy, dict(values), record, None
        return hidden, dict(min(search_results, key=lambda item: item[1])[0]), record, None
    return best[1], dict(best[0]["values"]), record, best[2]


def refit_failed(hidden, refit, x0, kept, X, y, n_fit, ratio=_REFIT_RATIO):
    """Whether the refit on the whole record (``refit``, first states ``x0``) failed against ``kept``.

    ``kept`` is :func:`refine_best`'s winner, refined on the first ``n_fit``
    samples of each record. Both models have seen those samples; the refit
    has failed when its simulation of them is more than ``ratio`` times
    worse (normalized RMSE, or a divergence) than the winner's: its start
    (an equation-error fit on the whole record) led the refinement to
    another minimum. Returns ``(failed, refit error, kept error)``.
    """
    head = heads(X, y, n_fit)
    with np.errstate(all="ignore"):  # "full": the whole head scored (its n_fit unused)
        new = float(validation_error(hidden, _with_first_states(refit, x0), *head, n_fit, "full"))
        old = float(validation_error(hidden, kept[0], *head, n_fit, "full"))
    return bool(new >= SEARCH_PENALTY or new > ratio * old), new, old


def search_starts(estimator, starts, est_space, X, y, dt, n_fit, derivative):
    """``(strategy, values, search_results, refined record, starts record, kept)`` of ``start="auto"``.

    Each start ``(name, strategy)`` of ``starts`` is searched by the
    estimator's inner search (its own space; a start with nothing to search,
    such as the subspace model, is scored at its one setting, or at each
    entry of its ``"auto"`` grid); the first start's ``n_refined`` best
    distinct candidates and every other start's best one (a start whose
    every candidate diverges: its best still, as the refinement may rescue
    it; one whose every fit fails: none) are refined side by
    side on the training part (:func:`refine_best`) and scored on the
    validation block only, and the best is kept: the caller refits only it.
    The starts record lists each start's name, best refined validation score
    (``inf`` when every candidate failed), CPU seconds (search and
    refinement) and error. Raises ValueError when every start fails.
    """
    pool, summary, results_of = [], [], {}
    for i, (name, strategy) in enumerate(starts):
        t0 = time.process_time()
        space = estimator._search_space(strategy, est_space, X[0].shape[1])
        if space:
            _, results, objective = estimator._inner_search(strategy, space, X, y, dt, n_fit, derivative)
        else:
            objective = SearchObjective(lambda values, s=strategy: estimator._candidate(
                s, values, X, y, dt, n_fit, derivative), strategy, X, y, n_fit, estimator.validation)
            with np.errstate(all="ignore"):
                results = [(values, objective(values)) for values in
                           auto_grid(estimator, strategy, X[0].shape[1], searched=False) or [{}]]
        # a start whose every candidate diverges before the refinement still has its best refined (the refinement
        # falls back to prediction error when the start cannot be simulated)
        best = distinct_best(results, estimator.n_refined if i == 0 else 1) or [min(results, key=lambda r: r[1])]
        results_of[name] = results
        if objective.first_error is not None and best[0][1] >= SEARCH_PENALTY:  # none simulates, a fit raised: its error
            best = []
        pool += [(name, strategy, values, score) for values, score in best]
        summary.append({"start": name, "score": np.inf, "seconds": time.process_time() - t0,
                        "error": None if best else objective.first_error})
    if not pool:
        raise ValueError("every start of the latent states failed: " +
                         "; ".join(f"{e['start']}: {e['error']}" for e in summary))
    strategy, values, record, kept = refine_best(estimator, starts[0][1], [], X, y, dt, n_fit, derivative, 0,
                                                 extra=pool)
    for entry in summary:
        mine = [e for e in record if e["start"] == entry["start"]]
        entry["seconds"] += sum(e["seconds"] for e in mine)
        scores = [e["refined_score"] for e in mine if e["error"] is None and e["refined_score"] < SEARCH_PENALTY]
        if scores:
            entry["score"] = min(scores)
        elif mine and entry["error"] is None:
            entry["error"] = next((e["error"] for e in mine if e["error"]), "the refined candidates failed")
    name = next(name for name, s in starts if s is strategy)
    return strategy, values, results_of[name], record, summary, kept

"""Several candidates of the inner search refined side by side, the best by validation kept (``n_refined``).

The inner search of :class:`~sindybench.HiddenStateSINDy` scores candidates
fitted by equation error; the refinement by simulation error then moves the
chosen one, and a start that scores second before the refinement can score
first after it. :func:`refine_best` refines the ``n`` best distinct
candidates on the training part of the record, scores each refined model
on the validation block exactly as the search scores a trial, and returns
the values of the best.
"""

import time
import warnings

import numpy as np

from ..search import SEARCH_PENALTY
from ..simulate import SimulationError
from ._auto import auto_refinement
from ._objective import validation_error

__all__ = ["distinct_best", "refine_best"]

# a model refined on the training part is scored on the validation block only: "full" would score the samples it
# was refined on too
_VALIDATION = {"full": "continued"}
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


def _with_first_states(cand, x0):
    """``cand`` whose records start from the refined first states ``x0`` (n_records, n_states)."""
    designs = []
    for design, x in zip(cand.designs, x0):
        states = np.array(design.states, dtype=float)
        states[0] = x
        designs.append(design._replace(states=states))
    return cand._replace(designs=tuple(designs))


def refine_best(estimator, hidden, search_results, X, y, dt, n_fit, derivative, n):
    """``(values, record)``: the search's ``n`` best distinct candidates refined on the training part, the best kept.

    Each candidate is fitted with its values on the first ``n_fit`` samples
    of each record, refined there by simulation error (the estimator's
    ``refine``; a candidate it does not refine is scored as fitted), and
    scored by :func:`~sindybench.hidden._objective.validation_error` with the
    estimator's ``validation``. ``record`` lists, for each, its values, its
    score before and after the refinement, CPU seconds and error (a
    candidate whose fit or refinement fails is left out). When every one
    fails, the search's best values are returned.
    """
    record, best = [], None
    for values, score in distinct_best(search_results, n):
        t0 = time.process_time()
        entry = {"values": dict(values), "score": float(score), "refined_score": SEARCH_PENALTY, "error": None}
        try:
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")
                cand = estimator._candidate(hidden, values, X, y, dt, n_fit, derivative)
                head = ([X_r[:k] for X_r, k in zip(X, n_fit)], [y_r[:k] for y_r, k in zip(y, n_fit)])
                refine = auto_refinement(estimator.refine, cand.dynamics)
                refined, x0 = cand, None
                if refine is not None:
                    refined, x0, _ = estimator._refine(hidden, cand, *head, refine=refine)
                if x0 is not None:
                    refined = _with_first_states(refined, x0)
                entry["refined_score"] = float(validation_error(hidden, refined, X, y, n_fit, _VALIDATION.get(
                    estimator.validation, estimator.validation)))
        except _FAILURES as exc:
            entry["error"] = f"{type(exc).__name__}: {exc}"
        entry["seconds"] = time.process_time() - t0
        record.append(entry)
        if entry["error"] is None and entry["refined_score"] < SEARCH_PENALTY and (
                best is None or entry["refined_score"] < best["refined_score"]):
            best = entry
    if best is None:
        return dict(min(search_results, key=lambda item: item[1])[0]), record
    return dict(best["values"]), record

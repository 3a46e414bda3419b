"""The stages of ``identify``'s search, one candidate or one structure at a time, and their budget.

``screen_structure`` scores a structure's pruning path on the last fold; ``score_candidate`` one
candidate on every fold (refined or not); ``run_stage`` runs a stage's calls in
order, reading back those a :class:`~sindybench.identify._resume.CandidateStore`
holds and recording the others as they finish; ``Budget`` counts the
candidates and seconds left; ``refit_choice`` refits the choice on the whole record, the next one where that fails.
"""

import copy
import time

import numpy as np

from ._lag import LAG_FAMILY
from ._resume import CandidateStore
from ._search import evaluate, path_thresholds, segments, stls_threshold
from ._space import LATENT_FAMILIES, make_estimator

__all__ = ["HOLD_FREE", "STRUCTURE", "Budget", "confirm_hold", "hold_twin", "parallel_map", "refit_choice",
           "refit_failed", "run_stage", "score_candidate", "screen_structure", "store_full", "store_screen", "stored_full",
           "stored_screen", "validated_library", "validated_terms"]

# the settings that make a structure (the threshold and the refinement make a candidate of it)
STRUCTURE = ("family", "library", "derivative", "input_hold", "input_delay")
#: the families whose estimator does not use the input hold (a lag model holds its inputs by construction): their
#: candidates with either hold are one computation (see :func:`score_candidate`)
HOLD_FREE = (LAG_FAMILY,)


def parallel_map(n_jobs):
    """``run(func, args_list)``: the results in order as they finish, from a plain loop for ``n_jobs`` None or 1,
    else from joblib's ``Parallel`` (imported here)."""
    if n_jobs in (None, 1):
        return lambda func, calls: (func(*args) for args in calls)
    from joblib import Parallel, delayed  # a base dependency

    return lambda func, calls: Parallel(n_jobs=n_jobs, return_as="generator")(delayed(func)(*args) for args in calls)


def run_stage(func, calls, get, put, parallel):
    """``func(*call)`` of each call, in order: read back by ``get(*call)`` where stored, else computed (in
    parallel) and recorded by ``put(call, result)`` as it finishes."""
    stored = [get(*call) for call in calls]
    computed = parallel(func, [call for call, result in zip(calls, stored) if result is None])
    for call, result in zip(calls, stored):
        if result is None:
            result = next(computed)
            put(call, result)
        yield result


class Budget:
    """Candidates and seconds left (a deadline on the wall clock, so that worker processes read it too)."""

    def __init__(self, time_budget, max_candidates):
        self.deadline = None if time_budget is None else time.time() + time_budget
        self.left = max_candidates

    def take(self, n):
        """How many of ``n`` candidates may still run (0 once the time or the count is spent)."""
        if self.deadline is not None and time.time() >= self.deadline:
            return 0
        k = n if self.left is None else min(n, self.left)
        if self.left is not None:
            self.left -= k
        return k


def screen_structure(struct, library, ctx):
    """Stage 1 of one structure: the pruning path of its dense fit, each level scored on the last fold."""
    X, y, folds = ctx["X"], ctx["y"], ctx["folds"]
    train = [(r, max(lo, hi - ctx["window"]), hi) for r, lo, hi in folds[-1][0]]
    make = lambda t, n: make_estimator(struct, library, stls_threshold(t, n), ctx["dt"], ctx["settings"],  # noqa: E731
                                       random_state=ctx["random_state"])
    rows = []
    try:
        dense = make(0.0, sum(hi - lo for _, lo, hi in train)).fit(*segments(X, y, train))
        thresholds = path_thresholds(dense, *segments(X, y, train), ctx["levels"])
    except Exception as exc:  # the structure cannot be fitted at all: one failed row
        return [dict(struct, threshold=0.0, refine=False, stage="screen", errors=[np.inf], n_terms=None,
                     max_row_terms=None, fit_time=0.0, status=f"failed: {type(exc).__name__}: {exc}", path_length=1)]
    for t in thresholds:
        if ctx["deadline"] is not None and time.time() >= ctx["deadline"]:
            break
        result = evaluate(lambda n, t=t: make(t, n), X, y, folds[-1:], n_init=ctx["n_init"], scale=ctx["scale"],
                          train_window=ctx["window"], horizon=ctx.get("horizon"))
        result.pop("model")
        rows.append(dict(struct, threshold=t, refine=False, stage="screen", path_length=len(thresholds), **result))
    return rows


def _screen_key(struct, ctx, k):
    return CandidateStore.key(dict(struct, threshold=None, stage="screen"), levels=ctx["levels"], k=k)


def stored_screen(store, struct, library, ctx):
    """The stored screen of ``struct`` (its whole path) in ``store``, or None."""
    first = store.get(_screen_key(struct, ctx, 0))
    if first is None:
        return None
    rows = [first] + [store.get(_screen_key(struct, ctx, k)) for k in range(1, first["path_length"])]
    if any(r is None for r in rows):
        return None
    store.n_read += len(rows)
    return rows


def store_screen(store, call, rows):
    """Record the screened path ``rows`` of ``call``'s structure."""
    struct, _, ctx = call
    for k, row in enumerate(rows):
        store.put(_screen_key(struct, ctx, k), row, path_length=row["path_length"])


def _full_key(row, refinement):
    return CandidateStore.key(dict(row, stage="refine" if refinement is not None else "blocks"))


def stored_full(store, row, library, ctx, refinement):
    """The stored result of the candidate ``row`` on every fold (refined when ``refinement`` is given), or None."""
    stored = store.get(_full_key(row, refinement))
    store.n_read += stored is not None
    return stored


def store_full(store, call, result):
    """Record ``result``, the candidate of ``call`` on every fold."""
    row, _, _, refinement = call
    store.put(_full_key(row, refinement), result)


def score_candidate(row, library, ctx, refinement):
    """Stages 2 and 3: one candidate on every block (refined when ``refinement`` is given).

    A candidate of a family that does not use the input hold (:data:`HOLD_FREE`) takes the result of its twin
    with the other hold when this process has scored it in the same search (``ctx``): the same computation.
    """
    struct = {k: row[k] for k in STRUCTURE}
    twin = _hold_free_key(row, refinement)
    scored = ctx.setdefault("hold_free", {}) if twin is not None else {}
    if twin in scored:
        start = time.perf_counter()
        result = copy.deepcopy(scored[twin])
        result.update(input_hold=row["input_hold"], fit_time=time.perf_counter() - start)
        return result
    make = lambda n: make_estimator(struct, library, stls_threshold(row["threshold"], n), ctx["dt"],  # noqa: E731
                                    ctx["settings"], refine=refinement, random_state=ctx["random_state"])
    result = evaluate(make, ctx["X"], ctx["y"], ctx["folds"], n_init=ctx["n_init"], scale=ctx["scale"],
                      horizon=ctx.get("horizon"))
    model = result.pop("model")
    result["equations"] = _equations(model)
    result["support"] = validated_terms(model, struct["family"])
    refined = refinement is not None or struct["family"] in LATENT_FAMILIES  # the latent families refine in fit
    result = dict(struct, threshold=row["threshold"], refine=refined,
                  stage="refine" if refinement is not None else "blocks", **result)
    if twin is not None:
        scored[twin] = copy.deepcopy(result)
    return result


def _hold_free_key(row, refinement):
    """What makes a candidate of a :data:`HOLD_FREE` family (its settings but the hold), or None for another family."""
    if row["family"] not in HOLD_FREE:
        return None
    return repr([(k, row[k]) for k in STRUCTURE + ("threshold",) if k != "input_hold"] + [repr(refinement)])


def _equations(model):
    """The equations of a candidate's last fold fit (for the report's Pareto front), or None."""
    try:
        return list(model.equations()) if model is not None else None
    except Exception:  # a candidate that cannot write its equations is still a candidate
        return None


def validated_terms(model, family):
    """The terms a candidate's validated fit kept, for its refit on the whole record (see :func:`validated_library`).

    The library terms with a nonzero coefficient in some learned row of
    ``model`` (the fit of the last fold), in the library's order and their JSON
    form; None for a family that selects its terms inside its own fit (the
    latent, lag and linear families), a library without terms, or no model.

    Examples
    --------
    >>> from sindybench import SINDy
    >>> from sindybench.libraries import PolynomialLibrary
    >>> t = np.arange(200) * 0.05
    >>> model = SINDy(library=PolynomialLibrary(degree=2), dt=0.05).fit(np.sin(t)[:, None], np.cos(t)[:, None])
    >>> len(validated_terms(model, "first_order")) == int(np.count_nonzero(np.any(model.coef_ != 0, axis=0)))
    True
    """
    if model is None or family in LATENT_FAMILIES:
        return None
    terms = getattr(getattr(model, "library_", None), "terms_", None)
    coef = getattr(model, "coef_", None)
    if terms is None or coef is None or len(terms) != np.shape(coef)[1]:
        return None
    kept = np.flatnonzero(np.any(np.asarray(coef) != 0, axis=0))
    return [[[float(v) if k >= 2 else int(v) for k, v in enumerate(f)] for f in terms[j]] for j in kept]


def validated_library(row, library):
    """The library of a chosen candidate's refit on the whole record: the terms its validated fit kept.

    The refit thresholds at the candidate's level as before, but over the
    terms that the fit of the last fold kept (``row["support"]``,
    :func:`validated_terms`, as a :class:`~sindybench.libraries.TermsLibrary`):
    it may drop a term whose contribution falls below the level on more
    samples, never add one that no validation block scored (on EMPS the
    validated pick ``1, y', u, y'^2, sign(y')`` gained ``y`` and ``y^2`` when
    refitted over the whole library: test 6.88 mm instead of 5.41). A row
    without a support (a family with its own term selection, a candidate read
    back from an older store) keeps ``library``.

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary
    >>> row = {"support": [[], [[1, 0, 1.0, 0.0]]]}
    >>> validated_library(row, PolynomialLibrary(degree=2)).fit(np.zeros((1, 2))).get_feature_names_out(["y", "u"])
    array(['1', 'u'], dtype=object)
    >>> validated_library({}, PolynomialLibrary(degree=2))
    PolynomialLibrary()
    """
    from ..libraries import TermsLibrary

    support = row.get("support")
    return TermsLibrary(terms=support) if support else library


def hold_twin(third):
    """The first candidate to refine with the other input hold (equation-error fits seldom tell the holds apart)."""
    if not third:
        return None
    row, library = third[0]
    twin = dict(row, input_hold={"zoh": "linear", "linear": "zoh"}[row["input_hold"]])
    key = lambda r: tuple(r[k] for k in STRUCTURE + ("threshold",))  # noqa: E731
    return None if any(key(r) == key(twin) for r, _ in third) else (twin, library)


def confirm_hold(pick, twin):
    """The twin's row as the choice sees it: the other hold replaces the pick's only when better by a standard error."""
    errors = np.asarray(pick["errors"], dtype=float)
    if np.all(np.isfinite(errors)) and np.mean(twin["errors"]) >= np.mean(errors) - np.std(errors) / np.sqrt(
            errors.size):
        return dict(twin, excluded=True,
                    status="not chosen: the other input hold, not better than the pick's by a standard error")
    return twin


def refit_choice(choose, refit, table, mean):
    """``(index, rule, chosen, final)``: the candidate ``choose(mean)`` picks, refitted on the whole record by ``refit``.

    A candidate whose refit fails (a refinement whose starting model's
    simulation diverges on the whole record though it simulated every
    validation block, a fit that raises) is recorded as failed in ``table``
    (``cv_results_``: its status says why, its mean and spread of validation
    errors become inf; the block errors stay as measured), leaves ``mean``,
    and the next choice is refitted. When none is left, a ``ValueError``
    names the reasons.

    Parameters
    ----------
    choose : callable
        ``choose(mean) -> (index, rule)``: the choice among the finite ``mean`` errors.
    refit : callable
        ``refit(index) -> (chosen, final)``: the settings and the model fitted on the whole record.
    table : dict of lists
        The search's table (changed in place).
    mean : ndarray
        The candidates' mean validation errors, inf where not eligible (changed in place).
    """
    while True:
        best, rule = choose(mean)
        try:
            return (best, rule, *refit(best))
        except Exception as exc:  # a candidate that cannot be refitted is a failed candidate, not the end of fit
            refit_failed(table, mean, best, exc)
            if not np.any(np.isfinite(mean)):
                failed = [s for s in table["status"] if s.startswith("failed at the refit")]
                reasons = list(dict.fromkeys(failed))[:3]
                raise ValueError(f"identify: each of the {len(failed)} candidate(s) that simulated every validation "
                                 f"block failed when refitted on the whole record (reasons: {reasons}); expected a "
                                 "record on which a chosen model can be fitted whole (a better-scaled or longer "
                                 "record, other families, or n_refine=0).") from exc


def refit_failed(table, mean, i, exc):
    """Record candidate ``i`` of ``table`` as failed at its refit by ``exc``, and out of ``mean`` (see :func:`refit_choice`)."""
    table["status"][i] = f"failed at the refit on the whole record: {type(exc).__name__}: {exc}"
    table["mean_validation_error"][i] = table["std_validation_error"][i] = np.inf
    mean[i] = np.inf

"""The inner search of :class:`~sindybench.HiddenStateSINDy`: Optuna TPE, then a bounded local search.

The search space is a dict ``name -> dimension`` (:mod:`sindybench.search`);
the study comes from :func:`~sindybench.search.create_study` and the trial's
values from :func:`~sindybench.search.sample_params`, as in
:func:`~sindybench.model_selection.tune`.
"""

import logging
import warnings

import numpy as np
import optuna
from optuna.distributions import FloatDistribution
from scipy.optimize import minimize as scipy_minimize
from sklearn.utils import check_random_state

from .._progress import progress_bar
from .._validation import check_integer, check_positive
from ._grid import grid_points
from ._space import LogUniform, Uniform, check_search_space, sample_params
from ._study import create_study

__all__ = ["SEARCH_PENALTY", "minimize"]

logger = logging.getLogger(__name__)

SEARCH_PENALTY = 1e3
"""Score of a failed or diverged evaluation in the inner search, and the cap of every score (scores are
normalized RMSEs, so 1e3 is far worse than any model that simulates)."""


class _Budget(Exception):
    """The local refinement used up its evaluations (internal)."""


def _unit_dimension(dim):
    """The dimension that maps ``dim``'s values to ``[0, 1]``, or None for a dimension the local search leaves alone.

    Uniform, LogUniform (and Optuna's FloatDistribution without a step) move on
    their linear or log scale; Normal and LogNormal priors on their quantile
    (the coordinate TPE models); integers and choices keep the start's values.
    """
    if isinstance(dim, FloatDistribution) and dim.step is None:
        return LogUniform(dim.low, dim.high) if dim.log else Uniform(dim.low, dim.high)
    return dim if hasattr(dim, "to_unit") else None


def _local_dimensions(space):
    dims = {key: _unit_dimension(dim) for key, dim in space.items()}
    return {key: dim for key, dim in dims.items() if dim is not None}


def _to_unit(values, dims):
    """Values of the refined dimensions -> coordinates in the unit cube."""
    return np.array([dim.to_unit(values[key]) for key, dim in dims.items()])


def _from_unit(z, dims):
    return {key: dim.from_unit(zi) for (key, dim), zi in zip(dims.items(), np.clip(z, 0.0, 1.0))}


def _starts(history, dims, n_starts, min_distance=0.1):
    """The best trials, at least ``min_distance`` apart in the unit cube (refined dimensions)."""
    chosen = []
    for values, _ in sorted(history, key=lambda item: item[1]):
        z = _to_unit(values, dims)
        if all(np.max(np.abs(z - zc)) >= min_distance for _, zc in chosen):
            chosen.append((values, z))
        if len(chosen) == n_starts:
            break
    return chosen


def _refine(evaluate, space, history, *, n_evals, n_starts, step):
    """Bounded Nelder-Mead on the real dimensions from the best distinct trials of ``history``.

    ``evaluate(values)`` scores and records one point; the other dimensions
    (integers, choices) keep the start's values. The ``n_evals`` evaluations
    are shared between the starts (fewer than ``n_starts`` when the budget is
    small).
    """
    dims = _local_dimensions(space)
    if not dims:
        return
    d = len(dims)
    # each start gets at least two simplices' worth of evaluations
    starts = _starts(history, dims, max(1, min(n_starts, n_evals // (2 * (d + 1)))))
    for i, (values, z0) in enumerate(starts):
        n_left = n_evals * (i + 1) // len(starts) - n_evals * i // len(starts)
        used = [0]

        def f(z, values=values, n_left=n_left, used=used):
            if used[0] >= n_left:
                raise _Budget
            used[0] += 1
            return evaluate({**values, **_from_unit(z, dims)})

        # initial simplex: the start and one step along each axis (inwards at an upper edge)
        simplex = np.vstack([z0] + [z0 + np.eye(d)[j] * (step if z0[j] + step <= 1 else -step) for j in range(d)])
        try:
            scipy_minimize(f, z0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * d,
                           options={"initial_simplex": simplex, "maxfev": n_left, "xatol": 1e-4, "fatol": 1e-6})
        except _Budget:
            pass


def minimize(objective, space, *, n_trials, random_state=None, penalty=SEARCH_PENALTY, n_local=0, n_starts=3, step=0.05,
             show_progress_bar=False, sampler="tpe"):
    """Minimize ``objective(values)`` over ``space`` with Optuna's TPE sampler (or a grid), then refine locally.

    The first ``n_trials - n_local`` evaluations are TPE trials (with
    ``sampler="grid"``: the points of :func:`~sindybench.search.grid_points`,
    the same at every seed); the last
    ``n_local`` refine the ``n_starts`` best distinct trials by bounded
    Nelder-Mead on the real dimensions (in the unit cube: Uniform on its
    linear scale, LogUniform on a log scale, Normal and LogNormal on their
    quantile; integers and choices stay at the start's values), which finds
    the bottom of narrow valleys that TPE samples only coarsely.

    Parameters
    ----------
    objective : callable
        ``objective(values) -> float`` for ``values = {name: value}``. NaN,
        inf or an exception listed by the objective itself count as
        ``penalty`` (a bad trial, never a crash): the trial completes with
        that value, so TPE and the local search see it as a bad point.
    space : dict
        ``{name: dimension}`` (the older spellings are read by
        :func:`~sindybench.search.as_dimension`).
    n_trials : int
        Evaluations in all.
    random_state : int, RandomState or None, default=None
        Seeds the TPE sampler.
    penalty : float, default=SEARCH_PENALTY
        Score of a failed evaluation (and the cap of every score).
    n_local : int, default=0
        Evaluations of the local refinement, ``0 <= n_local < n_trials``.
    n_starts : int, default=3
        Distinct best trials the local refinement starts from.
    step : float, default=0.05
        Edge of the initial simplex in the unit cube.
    show_progress_bar : bool, default=False
        A transient ``tqdm.auto`` bar with the best score so far, in a
        notebook or a terminal only (see :mod:`sindybench._progress`).
    sampler : {"tpe", "grid"}, default="tpe"
        ``"grid"``: a deterministic grid instead of TPE trials; ``random_state`` is then unused.

    Returns
    -------
    best : dict
        Values of the best evaluation.
    history : list of (dict, float)
        Every evaluation's values and score, in order (``n_trials`` at most).

    Examples
    --------
    >>> from sindybench.search import Uniform
    >>> best, history = minimize(lambda v: (v["a"] - 0.3) ** 2, {"a": Uniform(0.0, 1.0)},
    ...                          n_trials=30, random_state=0)
    >>> abs(best["a"] - 0.3) < 0.1, len(history)
    (True, 30)
    >>> best, history = minimize(lambda v: (v["a"] - 0.3) ** 2, {"a": (0.0, 1.0)},
    ...                          n_trials=30, n_local=15, n_starts=1, random_state=0)
    >>> abs(best["a"] - 0.3) < 1e-3, len(history) <= 30
    (True, True)
    >>> best, history = minimize(lambda v: (v["a"] - 0.32) ** 2, {"a": (0.0, 1.0)}, n_trials=10, sampler="grid")
    >>> round(best["a"], 2), len(history)
    (0.35, 10)
    """
    n_trials = check_integer(n_trials, "n_trials", low=1)
    n_local = check_integer(n_local, "n_local", low=0, high=n_trials - 1)
    n_starts = check_integer(n_starts, "n_starts", low=1)
    step = check_positive(step, "step")
    if sampler not in ("tpe", "grid"):
        raise ValueError(f"sampler must be 'tpe' or 'grid'; got {sampler!r}.")
    space = check_search_space(space, name="space", convert=True)
    if callable(space):
        raise ValueError("space must be a dict name -> dimension; a callable(trial) space cannot be refined locally.")
    n_tpe = n_trials - n_local
    seed = int(check_random_state(random_state).randint(np.iinfo(np.int32).max))
    history, best = [], [penalty]
    bar = progress_bar(n_trials, desc="inner search", show=show_progress_bar, leave=False)

    def evaluate(values):
        score = float(objective(values))
        if not np.isfinite(score) or score > penalty:
            score = penalty
        history.append((values, score))
        best[0] = min(best[0], score)  # the running best, not a scan of the history at every trial
        bar.set_postfix_str(f"best {best[0]:.4g}", refresh=False)
        bar.update()
        return score

    verbosity = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", category=optuna.exceptions.ExperimentalWarning)
            if sampler == "grid":
                for values in grid_points(space, n_tpe):
                    evaluate(values)
            else:
                study = create_study(seed, per_trial=False, n_startup_trials=max(10, n_tpe // 3))
                study.optimize(lambda trial: evaluate(sample_params(space, trial)), n_trials=n_tpe)
        if n_local:
            _refine(evaluate, space, list(history), n_evals=n_local, n_starts=n_starts, step=step)
    finally:
        optuna.logging.set_verbosity(verbosity)
        bar.close()
    best_values, best_score = min(history, key=lambda item: item[1])
    logger.info("inner search: best score %.4g after %d evaluations: %s", best_score, len(history), best_values)
    return dict(best_values), history

"""The inner search of :class:`~sindybench.HiddenStateSINDy`: Optuna TPE over a box.

A search space is a dict ``name -> spec``; a spec is ``(low, high)``,
``(low, high, log)`` (floats; integers when both ends are ``int`` and ``log`` is
not set) or a list of choices.
"""

import logging
import numbers
import warnings

import numpy as np
from scipy.optimize import minimize as scipy_minimize
from sklearn.utils import check_random_state

from .._progress import progress_bar

__all__ = ["check_space", "minimize"]

logger = logging.getLogger(__name__)


def _import_optuna():
    try:
        import optuna
    except ImportError as exc:  # pragma: no cover - optuna is a dependency
        raise ImportError(
            "HiddenStateSINDy's search needs optuna: pip install optuna (or fix every searched parameter)."
        ) from exc
    return optuna


def check_space(space, *, name="search_params"):
    """Return ``space`` in the normalized form ``name -> ("float"|"int", low, high, log) | ("choice", list)``.

    Examples
    --------
    >>> check_space({"a": (1e-3, 1.0, True), "b": (3, 9), "c": ["x", "y"]})
    {'a': ('float', 0.001, 1.0, True), 'b': ('int', 3, 9, False), 'c': ('choice', ['x', 'y'])}
    >>> check_space({"a": (2.0, 1.0)})
    Traceback (most recent call last):
    ...
    ValueError: search_params['a'] = (2.0, 1.0); expected low < high.
    """
    if space is None:
        return {}
    if not isinstance(space, dict):
        raise ValueError(f"{name} must be a dict name -> (low, high[, log]) or list of choices; got {space!r}.")
    out = {}
    for key, spec in space.items():
        if isinstance(spec, list):
            if not spec:
                raise ValueError(f"{name}[{key!r}] is an empty list; expected at least one choice.")
            out[key] = ("choice", list(spec))
            continue
        if not isinstance(spec, tuple) or len(spec) not in (2, 3):
            raise ValueError(
                f"{name}[{key!r}] = {spec!r}; expected (low, high), (low, high, log) or a list of choices."
            )
        low, high = spec[0], spec[1]
        log = bool(spec[2]) if len(spec) == 3 else False
        if not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in (low, high)):
            raise ValueError(f"{name}[{key!r}] = {spec!r}; expected numeric low and high.")
        if not (np.isfinite(low) and np.isfinite(high)) or not low < high:
            raise ValueError(f"{name}[{key!r}] = {spec!r}; expected low < high.")
        if log and low <= 0:
            raise ValueError(f"{name}[{key!r}] = {spec!r} is log-scaled; expected low > 0.")
        is_int = isinstance(low, numbers.Integral) and isinstance(high, numbers.Integral)
        out[key] = ("int", int(low), int(high), log) if is_int else ("float", float(low), float(high), log)
    return out


def _suggest(trial, key, spec):
    if spec[0] == "choice":
        return trial.suggest_categorical(key, spec[1])
    kind, low, high, log = spec
    if kind == "int":
        return trial.suggest_int(key, low, high, log=log)
    return trial.suggest_float(key, low, high, log=log)


class _Budget(Exception):
    """The local refinement used up its evaluations (internal)."""


def _float_keys(space):
    return [key for key, spec in space.items() if spec[0] == "float"]


def _to_unit(values, space, keys):
    """Float values -> coordinates in the unit cube (log scale for log dimensions)."""
    out = []
    for key in keys:
        _, low, high, log = space[key]
        f = np.log if log else (lambda v: v)
        out.append((f(values[key]) - f(low)) / (f(high) - f(low)))
    return np.array(out)


def _from_unit(z, space, keys):
    out = {}
    for key, zi in zip(keys, np.clip(z, 0.0, 1.0)):
        _, low, high, log = space[key]
        v = np.exp(np.log(low) + zi * (np.log(high) - np.log(low))) if log else low + zi * (high - low)
        out[key] = float(min(max(v, low), high))
    return out


def _starts(history, space, keys, n_starts, min_distance=0.1):
    """The best trials, at least ``min_distance`` apart in the unit cube (float dimensions)."""
    chosen = []
    for values, _ in sorted(history, key=lambda item: item[1]):
        z = _to_unit(values, space, keys)
        if all(np.max(np.abs(z - zc)) >= min_distance for _, zc in chosen):
            chosen.append((values, z))
        if len(chosen) == n_starts:
            break
    return chosen


def _refine(evaluate, space, history, *, n_evals, n_starts, step):
    """Bounded Nelder-Mead on the float dimensions from the best distinct trials of ``history``.

    ``evaluate(values)`` scores and records one point; the other dimensions
    keep the start's values. The ``n_evals`` evaluations are shared between
    the starts (fewer than ``n_starts`` when the budget is small).
    """
    keys = _float_keys(space)
    if not keys:
        return
    d = len(keys)
    # each start gets at least two simplices' worth of evaluations
    starts = _starts(history, space, keys, max(1, min(n_starts, n_evals // (2 * (d + 1)))))
    for i, (values, z0) in enumerate(starts):
        n_left = n_evals * (i + 1) // len(starts) - n_evals * i // len(starts)
        used = [0]

        def f(z, values=values, n_left=n_left, used=used):
            if used[0] >= n_left:
                raise _Budget
            used[0] += 1
            return evaluate({**values, **_from_unit(z, space, keys)})

        # initial simplex: the start and one step along each axis (inwards at an upper edge)
        simplex = np.vstack([z0] + [z0 + np.eye(d)[j] * (step if z0[j] + step <= 1 else -step) for j in range(d)])
        try:
            scipy_minimize(f, z0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * d,
                           options={"initial_simplex": simplex, "maxfev": n_left, "xatol": 1e-4, "fatol": 1e-6})
        except _Budget:
            pass


def minimize(objective, space, *, n_trials, random_state=None, penalty=1e3, n_local=0, n_starts=3, step=0.05,
             show_progress_bar=False):
    """Minimize ``objective(values)`` over ``space`` with Optuna's TPE sampler, then refine locally.

    ``objective`` returns a float; NaN, inf or an exception listed by the
    objective itself count as ``penalty`` (a bad trial, never a crash).
    The first ``n_trials - n_local`` evaluations are TPE trials (the caller
    checks ``0 <= n_local < n_trials``); the last
    ``n_local`` refine the ``n_starts`` best distinct trials by bounded
    Nelder-Mead on the float dimensions (in the unit cube, log dimensions on
    a log scale; initial simplex of edge ``step``), which finds the bottom
    of narrow valleys that TPE samples only coarsely. ``show_progress_bar``
    draws a transient ``tqdm.auto`` bar with the best score so far, in a
    notebook or a terminal only (see :mod:`sindybench._progress`).

    Returns
    -------
    best : dict
        Values of the best evaluation.
    history : list of (dict, float)
        Every evaluation's values and score, in order (``n_trials`` at most).

    Examples
    --------
    >>> best, history = minimize(lambda v: (v["a"] - 0.3) ** 2, {"a": ("float", 0.0, 1.0, False)},
    ...                          n_trials=30, random_state=0)
    >>> abs(best["a"] - 0.3) < 0.1, len(history)
    (True, 30)
    >>> best, history = minimize(lambda v: (v["a"] - 0.3) ** 2, {"a": ("float", 0.0, 1.0, False)},
    ...                          n_trials=30, n_local=15, n_starts=1, random_state=0)
    >>> abs(best["a"] - 0.3) < 1e-3, len(history) <= 30
    (True, True)
    """
    optuna = _import_optuna()
    n_tpe = n_trials - n_local
    seed = int(check_random_state(random_state).randint(np.iinfo(np.int32).max))
    sampler = optuna.samplers.TPESampler(seed=seed, n_startup_trials=max(10, n_tpe // 3))
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
            study = optuna.create_study(direction="minimize", sampler=sampler)
            study.optimize(lambda trial: evaluate({k: _suggest(trial, k, v) for k, v in space.items()}),
                           n_trials=n_tpe)
        if n_local:
            _refine(evaluate, space, list(history), n_evals=n_local, n_starts=n_starts, step=step)
    finally:
        optuna.logging.set_verbosity(verbosity)
        bar.close()
    best_values, best_score = min(history, key=lambda item: item[1])
    logger.info("inner search: best score %.4g after %d evaluations: %s", best_score, len(history), best_values)
    return dict(best_values), history

"""The inner search of :class:`~sindybench.HiddenStateSINDy`: Optuna TPE over a box.

A search space is a dict ``name -> spec``; a spec is ``(low, high)``,
``(low, high, log)`` (floats; integers when both ends are ``int`` and ``log`` is
not set) or a list of choices.
"""

import logging
import numbers
import warnings

import numpy as np
from sklearn.utils import check_random_state

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


def minimize(objective, space, *, n_trials, random_state=None, penalty=1e3):
    """Minimize ``objective(values)`` over ``space`` with Optuna's TPE sampler.

    ``objective`` returns a float; NaN, inf or an exception listed by the
    objective itself count as ``penalty`` (a bad trial, never a crash).

    Returns
    -------
    best : dict
        Values of the best trial.
    history : list of (dict, float)
        Every trial's values and score, in order.

    Examples
    --------
    >>> best, history = minimize(lambda v: (v["a"] - 0.3) ** 2, {"a": ("float", 0.0, 1.0, False)},
    ...                          n_trials=30, random_state=0)
    >>> abs(best["a"] - 0.3) < 0.1, len(history)
    (True, 30)
    """
    optuna = _import_optuna()
    seed = int(check_random_state(random_state).randint(np.iinfo(np.int32).max))
    sampler = optuna.samplers.TPESampler(seed=seed, n_startup_trials=max(10, n_trials // 3))
    history = []

    def wrapped(trial):
        values = {key: _suggest(trial, key, spec) for key, spec in space.items()}
        score = float(objective(values))
        if not np.isfinite(score) or score > penalty:
            score = penalty
        history.append((values, score))
        return score

    verbosity = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", category=optuna.exceptions.ExperimentalWarning)
            study = optuna.create_study(direction="minimize", sampler=sampler)
            study.optimize(wrapped, n_trials=n_trials)
    finally:
        optuna.logging.set_verbosity(verbosity)
    best_values, best_score = min(history, key=lambda item: item[1])
    logger.info("inner search: best score %.4g after %d trials: %s", best_score, len(history), best_values)
    return dict(best_values), history

"""Helpers shared by the plotting functions: axes, time axes, models' simulations, labels."""

import numbers

import numpy as np

from .._validation import check_integer, check_signal, real_scalar
from ..metrics import fit_index, r2

MAX_POINTS = 6000  # samples drawn per curve at most (longer records are strided)


def _new_axes(n, *, figsize, height_ratios=None, sharex=True):
    import matplotlib.pyplot as plt

    kw = {"height_ratios": height_ratios} if height_ratios else {}
    _, axes = plt.subplots(n, 1, figsize=figsize, squeeze=False, sharex=sharex, layout="constrained",
                           gridspec_kw=kw)
    return list(axes[:, 0])


def _stacked_axes(ax, n):
    """``n`` Axes, one per panel: those given as ``ax`` (checked) or a new figure of ``n`` stacked panels."""
    return _check_axes(ax, n) or _new_axes(n, figsize=(10, 1.2 + 1.8 * n))


def _check_axes(ax, *counts):
    """``ax`` (one Axes or a sequence of them) as a list of Axes, of one of the allowed ``counts``; None stays None."""
    if ax is None:
        return None
    from matplotlib.axes import Axes

    axes = [ax] if isinstance(ax, Axes) else list(np.ravel(np.asarray(ax, dtype=object)))
    if len(axes) not in counts or not all(isinstance(a, Axes) for a in axes):
        got = f"{len(axes)} objects" if isinstance(ax, (list, tuple, np.ndarray)) else type(ax).__name__
        expected = " or ".join("one matplotlib Axes" if n == 1 else f"a sequence of {n} Axes" for n in counts)
        raise ValueError(f"ax must be {expected}; got {got}.")
    return axes


def _stride(n, max_points):
    return max(1, int(np.ceil(n / max_points)))


def _column(a, index, name):
    index = check_integer(index, name, low=0)
    if index >= a.shape[1]:
        raise ValueError(f"{name}={index} but there are {a.shape[1]} column(s); expected {name} < {a.shape[1]}.")
    return a[:, index]


def _time(n, dt):
    if dt is None:
        return np.arange(n), "sample"
    dt = real_scalar(dt)
    if isinstance(dt, bool) or not isinstance(dt, numbers.Real) or not dt > 0:
        raise ValueError(f"dt must be a number > 0 or None (samples on the x axis); got {dt!r}.")
    return np.arange(n) * float(dt), "time [s]"


def _as_models(models):
    """``models`` as a list of ``(label, model)``: a dict, a list, or one model / array."""
    if models is None:
        return []
    if isinstance(models, dict):
        return [(str(k), v) for k, v in models.items()]
    if isinstance(models, (list, tuple)) and not (models and isinstance(models[0], numbers.Number)):
        return [(_default_label(m, i), m) for i, m in enumerate(models)]
    return [(_default_label(models, 0), models)]


def _default_label(model, i):
    return type(model).__name__ if hasattr(model, "predict") else f"model {i}"


def _prediction(label, model, X, y, n_init):
    """The simulated output of ``model`` (fitted estimator or array) as a 2-D array like ``y``."""
    if hasattr(model, "predict"):
        if X is None:
            raise ValueError(f"model {label!r} is an estimator; pass its inputs X to simulate it.")
        model = model.predict(X, y_init=y[:n_init])
    try:
        pred = np.asarray(model, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"model {label!r} is neither a fitted estimator nor an array of simulated outputs ({exc})."
        ) from None
    pred = pred[:, None] if pred.ndim == 1 else pred
    if pred.ndim != 2 or pred.shape != y.shape:
        raise ValueError(f"the simulation of model {label!r} has shape {pred.shape}; expected {y.shape} (as y).")
    return pred


def _predictions(models, X, y, n_init):
    n_init = check_integer(n_init, "n_init")
    return [(label, _prediction(label, m, X, y, n_init)) for label, m in _as_models(models)]


def _score_label(label, y_true, y_pred):
    if not np.all(np.isfinite(y_pred)):
        return f"{label} (diverged)"
    return f"{label} (R^2 {r2(y_true, y_pred):.2f}, fit {fit_index(y_true, y_pred):.1f} %)"


def _signals(X, y):
    y = check_signal(y, "y")
    if X is not None:
        X = check_signal(X, "X", n_samples=y.shape[0])
    return X, y

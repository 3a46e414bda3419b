"""Simulations against measurements, hysteresis loops and hidden states."""

import numpy as np

from .._validation import check_integer
from ._common import (
    MAX_POINTS,
    _as_models,
    _check_axes,
    _column,
    _new_axes,
    _predictions,
    _score_label,
    _signals,
    _stacked_axes,
    _stride,
    _time,
)


# ------------------------------------------------------------- simulation
def plot_simulation(X, y, models=None, *, n_init=1, dt=None, output=0, input=0, output_label="output",
                    input_label="input", frame=0.5, max_points=MAX_POINTS, ax=None):
    """Measured output against open-loop simulations, with the input below.

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs) or None
        Inputs (drawn below the output; None: no input panel).
    y : array-like of shape (n_samples, n_outputs)
        Measured outputs, drawn in black.
    models : estimator, array-like, list or dict, optional
        Simulations to compare: fitted estimators (simulated here with
        ``predict(X, y_init=y[:n_init])``) or arrays of simulated outputs
        shaped like ``y``; a dict gives the legend labels. Each label carries
        the simulation's R^2 and fit index (or "diverged"): R^2 = 0.9999 and
        0.999 both read "1.00", their fit indices 99.0 % and 96.8 % do not.
    n_init : int, default=1
        Samples of ``y`` handed to the estimators as ``y_init``.
    dt : float, optional
        Sampling interval: time in seconds on the x axis (default: samples).
    output, input : int, default=0
        Column of ``y`` and of ``X`` to draw.
    output_label, input_label : str
        Axis labels.
    frame : float, default=0.5
        A simulation that leaves the measured range widened by ``frame``
        times its span on either side is cut at that frame (and said so in
        its label), so one diverging model does not flatten the others.
    max_points : int, default=6000
        Longer records are drawn with a stride.
    ax : Axes or sequence of two Axes, optional
        Where to draw: one Axes for the output alone, or ``(output_ax,
        input_ax)``. Default: a new figure with both.

    Returns
    -------
    list of Axes
        ``[output_ax]`` or ``[output_ax, input_ax]``.

    Examples
    --------
    >>> t = np.linspace(0, 10, 200)
    >>> u, y = np.sin(t)[:, None], np.cos(t)[:, None]
    >>> out_ax, in_ax = plot_simulation(u, y, {"close": y + 0.1}, dt=t[1])
    >>> [line.get_label() for line in out_ax.get_lines()]
    ['measured', 'close (R^2 0.98, fit 86.2 %)']
    """
    X, y = _signals(X, y)
    y_col = _column(y, output, "output")
    u_col = None if X is None or X.shape[1] == 0 else _column(X, input, "input")
    sims = _predictions(models, X, y, n_init)
    max_points = check_integer(max_points, "max_points")
    t, t_label = _time(len(y), dt)
    n_axes = 1 if u_col is None else 2
    if ax is None:
        axes = _new_axes(n_axes, figsize=(10, 5 if n_axes == 2 else 4),
                         height_ratios=[3, 1] if n_axes == 2 else None)
    else:
        axes = _check_axes(ax, 1, 2)
        if len(axes) == 1:
            u_col = None
        elif u_col is None:
            raise ValueError("ax holds two Axes (output, input) but X has no input to draw; expected one Axes.")
    k = _stride(len(y), max_points)
    out_ax = axes[0]
    out_ax.plot(t[::k], y_col[::k], color="black", lw=1.6, label="measured")
    span = float(np.ptp(y_col)) or 1.0
    low, high = float(y_col.min()) - frame * span, float(y_col.max()) + frame * span
    off_scale = False
    for label, pred in sims:
        p = pred[:, output]
        text = _score_label(label, y, pred)
        finite = p[np.isfinite(p)]
        if finite.size and (finite.min() < low or finite.max() > high):
            off_scale = True
            text += ", leaves the frame"
        out_ax.plot(t[::k], p[::k], lw=1.0, label=text)
    if off_scale:
        out_ax.set_ylim(low, high)
    out_ax.set_ylabel(output_label)
    if sims:
        out_ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    if u_col is not None:
        axes[1].plot(t[::k], u_col[::k], color="gray", lw=0.8)
        axes[1].set_ylabel(input_label)
    axes[-1].set_xlabel(t_label)
    return axes


# --------------------------------------------------------------- hysteresis
def _hidden_indices(model):
    """Indices in the full state of the model's hidden (not measured) states."""
    names = getattr(model, "state_names_", None)
    outputs = getattr(model, "output_index_", None)
    hidden = [] if names is None or outputs is None else [i for i in range(len(names)) if i not in outputs]
    if not hidden or not hasattr(model, "simulate"):
        raise ValueError(
            f"{type(model).__name__} has no hidden states; expected a fitted HiddenStateSINDy "
            "(or a model with state_names_, output_index_ and simulate)."
        )
    return hidden


def _hidden_index(model, state):
    """Index in the full state of hidden ``state`` (a name or an index among the hidden states)."""
    hidden = _hidden_indices(model)
    names = [model.state_names_[i] for i in hidden]
    if isinstance(state, str):
        if state not in names:
            raise ValueError(f"{state!r} is not a hidden state of the model; expected one of {names}.")
        return hidden[names.index(state)]
    state = check_integer(state, "hidden", low=0)
    if state >= len(hidden):
        raise ValueError(f"hidden={state} but the model has {len(hidden)} hidden state(s); expected a smaller index.")
    return hidden[state]


def plot_hysteresis(X, y, models=None, *, n_init=1, output=0, input=0, hidden=None, output_label="output",
                    input_label="input", max_points=MAX_POINTS, ax=None):
    """Hysteresis loops: the output on the x axis against the input or a hidden state.

    With ``hidden=None`` the loops are (output, input), the force-displacement
    loops of a hysteretic system: the measured one in black and one per
    model's simulation. With ``hidden`` set, each model (a fitted
    :class:`~sindybench.HiddenStateSINDy`) is simulated and its hidden state
    is drawn against its simulated output (the measured loop does not exist).

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
    models : estimator, array-like, list or dict, optional
        As in :func:`plot_simulation`; fitted estimators only when ``hidden`` is set.
    n_init : int, default=1
        Samples of ``y`` handed to the estimators as ``y_init``.
    output, input : int, default=0
        Column of ``y`` and ``X``.
    hidden : str or int, optional
        Name of a hidden state (``"z"``) or index among the model's hidden states.
    output_label, input_label : str
        Axis labels (the y axis is labelled with the state's name when ``hidden`` is set).
    max_points : int, default=6000
    ax : Axes, optional

    Returns
    -------
    Axes

    Examples
    --------
    >>> t = np.linspace(0, 4 * np.pi, 400)
    >>> u, y = np.sin(t)[:, None], np.sin(t - 0.5)[:, None]
    >>> ax = plot_hysteresis(u, y, {"model": 0.9 * y})
    >>> [line.get_label() for line in ax.get_lines()]
    ['measured', 'model']
    """
    X, y = _signals(X, y)
    if X is None or X.shape[1] == 0:
        raise ValueError("plot_hysteresis needs the inputs X; got none.")
    (ax,) = _check_axes(ax, 1) or _new_axes(1, figsize=(7, 5))
    max_points = check_integer(max_points, "max_points")
    k = _stride(len(y), max_points)
    if hidden is None:
        u_col = _column(X, input, "input")
        ax.plot(_column(y, output, "output")[::k], u_col[::k], color="black", lw=1.8, label="measured")
        for label, pred in _predictions(models, X, y, n_init):
            ax.plot(pred[::k, output], u_col[::k], lw=1.0, label=label)
        ax.set_ylabel(input_label)
    else:
        n_init = check_integer(n_init, "n_init")
        for label, model in _as_models(models):
            idx = _hidden_index(model, hidden)
            states = model.simulate(X, y_init=y[:n_init], on_divergence="nan")
            out = list(model.output_index_)[output]
            ax.plot(states[::k, out], states[::k, idx], lw=1.0, label=label)
            ax.set_ylabel(model.state_names_[idx])
    ax.set_xlabel(output_label)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return ax


# ------------------------------------------------------------ hidden states
def _per_state(values, names, what):
    """One entry per drawn state from None, a sequence (in order) or a dict ``name -> value``."""
    if values is None:
        return [None] * len(names)
    if isinstance(values, str):
        values = [values]
    if isinstance(values, dict):
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise ValueError(f"{what} names {unknown}, not drawn states; expected keys among {names}.")
        return [values.get(n) for n in names]
    values = list(values)
    if len(values) != len(names):
        raise ValueError(f"{what} has {len(values)} entries; expected {len(names)}, one per drawn state {names}.")
    return values


def plot_hidden_states(model, X=None, y=None, *, n_init=1, states=None, labels=None, units=None,
                       max_points=MAX_POINTS, ax=None):
    """The hidden states of a fitted :class:`~sindybench.HiddenStateSINDy` over time.

    Without data, the states the strategy reconstructed on the training data
    (``hidden_states_``); with ``X`` and ``y``, the hidden states of the
    open-loop simulation of that record (started from ``y[:n_init]``). One
    Axes per hidden state (their units differ).

    Parameters
    ----------
    model : HiddenStateSINDy
        Fitted.
    X, y : array-like, optional
        Inputs and measured outputs of a record to simulate (both or neither).
    n_init : int, default=1
    states : list of str, optional
        Names of the hidden states to draw (default: all).
    labels : list of str or dict, optional
        Axis labels of the drawn states, in order or as ``state name ->
        label`` (default: the state names), e.g. ``{"h0": "friction force"}``.
    units : list of str or dict, optional
        Units, likewise, appended to the labels in brackets: ``"z [N]"``.
    max_points : int, default=6000
    ax : Axes or sequence of Axes, optional
        One Axes per drawn state.

    Returns
    -------
    list of Axes

    Examples
    --------
    >>> from sindybench import HiddenStateSINDy
    >>> from sindybench.hidden import DerivativeHiddenState
    >>> t = np.arange(0, 10, 0.01)
    >>> model = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), dt=0.01)
    >>> model = model.fit(np.sin(t)[:, None], np.cos(t)[:, None])
    >>> (ax,) = plot_hidden_states(model)
    >>> ax.get_ylabel(), np.array_equal(ax.get_lines()[0].get_ydata(), model.hidden_states_[:, 0])
    ("y0'", True)
    >>> plot_hidden_states(model, labels={"y0'": "velocity"}, units=["m/s"])[0].get_ylabel()
    'velocity [m/s]'
    """
    if isinstance(states, str):
        states = [states]
    index = _hidden_indices(model) if states is None else [_hidden_index(model, s) for s in states]
    if not index:
        raise ValueError("no hidden state to draw; expected a model with hidden states or names in states.")
    if (X is None) != (y is None):
        raise ValueError("give both X and y (a record to simulate) or neither (the training reconstruction).")
    names = [model.state_names_[i] for i in index]
    labels = [lab if lab is not None else n for lab, n in zip(_per_state(labels, names, "labels"), names)]
    units = _per_state(units, names, "units")
    for what, values in (("labels", labels), ("units", units)):
        if any(v is not None and not isinstance(v, str) for v in values):
            raise ValueError(f"{what} = {values!r}; expected strings (or None).")
    if X is None:
        trajectory = np.asarray(model.states_, dtype=float)
        what = "reconstructed on the training data"
    else:
        X, y = _signals(X, y)
        trajectory = model.simulate(X, y_init=y[: check_integer(n_init, "n_init")], on_divergence="nan")
        what = "simulated"
    axes = _stacked_axes(ax, len(index))
    t, t_label = _time(len(trajectory), getattr(model, "dt_", None))
    k = _stride(len(trajectory), check_integer(max_points, "max_points"))
    for a, i, label, unit in zip(axes, index, labels, units):
        a.plot(t[::k], trajectory[::k, i], lw=1.0, label=f"{model.state_names_[i]}, {what}")
        a.set_ylabel(label if not unit else f"{label} [{unit}]")
        a.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel(t_label)
    return axes

"""Figures for notebooks and reports: simulations, hysteresis loops, hidden states, coefficients, searches.

Every function draws on the matplotlib ``Axes`` given as ``ax=`` (so figures
can be composed), or on a new pyplot figure, and returns the axes it drew on.
matplotlib is imported inside the functions, so ``import sindybench`` stays
light. Models are given either fitted (anything with ``predict(X, y_init=...)``:
the open-loop simulation is computed here) or as arrays of simulated outputs.
``sindybench run`` draws its report figures with these functions.

The figures below come from one example: a forced oscillator whose velocity is
not measured, ``y'' = -4 y - 0.5 y' - 2 y^3 + 2 u``, fitted by plain SINDy on
``y`` alone and by :class:`~sindybench.HiddenStateSINDy` with the velocity as
a hidden state.

.. plot::
   :context: reset

   import numpy as np
   from sindybench import STLS, HiddenStateSINDy, SINDy
   from sindybench.hidden import DerivativeHiddenState
   from sindybench.libraries import PolynomialLibrary
   from sindybench.plotting import plot_simulation
   from sindybench.simulate import simulate

   def oscillator(x, u):
       return np.array([x[1], -4 * x[0] - 0.5 * x[1] - 2 * x[0] ** 3 + 2 * u[0]])

   dt = 0.01
   t = np.arange(3000) * dt
   u = (np.sin(t) + np.sin(2.3 * t))[:, None]
   y = simulate(oscillator, [0.0, 0.0], u, dt=dt, n_substeps=4)[:, :1]  # the position only
   library = PolynomialLibrary(degree=3)
   plain = SINDy(library=library, optimizer=STLS(threshold=0.05), dt=dt).fit(u, y)
   hidden = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=library,
                             optimizer=STLS(threshold=0.05), dt=dt).fit(u, y)
   models = {"SINDy on y": plain, "hidden velocity": hidden}
   plot_simulation(u, y, models, n_init=20, dt=dt)

Loops of the output against the input (:func:`plot_hysteresis`), and against
the hidden velocity as the model simulates it:

.. plot::
   :context: close-figs

   import matplotlib.pyplot as plt
   from sindybench.plotting import plot_hysteresis

   last = slice(-400, None)  # the last four seconds
   fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
   plot_hysteresis(u[last], y[last], models, n_init=20, ax=left)
   plot_hysteresis(u[last], y[last], {"hidden velocity": hidden}, n_init=20, hidden="y0'", ax=right)

The hidden state as reconstructed from the training data (:func:`plot_hidden_states`):

.. plot::
   :context: close-figs

   from sindybench.plotting import plot_hidden_states

   plot_hidden_states(hidden)

The coefficients of both models (:func:`plot_coefficients`):

.. plot::
   :context: close-figs

   from sindybench.plotting import plot_coefficients

   plot_coefficients(models)

An inner search of the threshold (:func:`plot_search_history`; the study
returned by :func:`sindybench.model_selection.tune` is drawn the same way):

.. plot::
   :context: close-figs

   from sindybench.plotting import plot_search_history

   searched = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=library, optimizer=STLS(),
                               search_params={"optimizer__threshold": (1e-3, 10.0, True)},
                               n_trials=20, random_state=0, dt=dt).fit(u, y)
   plot_search_history(searched)
"""

import numbers

import numpy as np

from ._validation import check_integer, check_signal
from .hidden import SEARCH_PENALTY as _SEARCH_PENALTY  # the inner search's score of a failed candidate
from .metrics import fit_index, r2

__all__ = [
    "coefficient_table",
    "plot_coefficients",
    "plot_hidden_states",
    "plot_hysteresis",
    "plot_search_history",
    "plot_simulation",
]

MAX_POINTS = 6000  # samples drawn per curve at most (longer records are strided)


# ----------------------------------------------------------------- helpers
def _new_axes(n, *, figsize, height_ratios=None, sharex=True):
    import matplotlib.pyplot as plt

    kw = {"height_ratios": height_ratios} if height_ratios else {}
    _, axes = plt.subplots(n, 1, figsize=figsize, squeeze=False, sharex=sharex, layout="constrained",
                           gridspec_kw=kw)
    return list(axes[:, 0])


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
    axes = _check_axes(ax, len(index)) or _new_axes(len(index), figsize=(10, 1.2 + 1.8 * len(index)))
    t, t_label = _time(len(trajectory), getattr(model, "dt_", None))
    k = _stride(len(trajectory), check_integer(max_points, "max_points"))
    for a, i, label, unit in zip(axes, index, labels, units):
        a.plot(t[::k], trajectory[::k, i], lw=1.0, label=f"{model.state_names_[i]}, {what}")
        a.set_ylabel(label if not unit else f"{label} [{unit}]")
        a.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel(t_label)
    return axes


# ------------------------------------------------------------- coefficients
def coefficient_table(models, *, learned_only=True):
    """The coefficients of several fitted models in one table.

    Parameters
    ----------
    models : estimator, list or dict
        Fitted :class:`~sindybench.SINDy` or :class:`~sindybench.HiddenStateSINDy`
        models; a dict gives the row labels.
    learned_only : bool, default=True
        Leave out the rows a hidden-state strategy fixes by physics (``y' = v``).

    Returns
    -------
    rows : list of str
        ``"<model>: <state>'"``, one per equation.
    terms : list of str
        The union of the models' terms, in order of first appearance.
    values : ndarray of shape (len(rows), len(terms))
        Zero where a model lacks the term or dropped it.

    Examples
    --------
    >>> from sindybench import SINDy
    >>> from sindybench.libraries import PolynomialLibrary
    >>> t = np.arange(0, 3, 0.01)
    >>> y = np.exp(-2 * t)[:, None]
    >>> model = SINDy(library=PolynomialLibrary(degree=1), dt=0.01).fit(None, y)
    >>> rows, terms, values = coefficient_table({"A": model})
    >>> rows, terms, np.round(values, 1)
    (["A: y0'"], ['1', 'y0'], array([[ 0., -2.]]))
    """
    entries = []
    for label, model in _as_models(models):
        rows = getattr(model, "_equation_rows", None)
        if rows is None:
            raise ValueError(f"model {label!r} ({type(model).__name__}) has no equations; expected a fitted "
                             "SINDy or HiddenStateSINDy.")
        for row in rows():
            if row.fixed is None and (row.learned or not learned_only):
                entries.append((f"{label}: {row.name}'", dict(zip(row.features, row.coef))))
    terms = list(dict.fromkeys(term for _, coefs in entries for term in coefs))
    values = np.array([[coefs.get(term, 0.0) for term in terms] for _, coefs in entries]).reshape(len(entries),
                                                                                                  len(terms))
    return [label for label, _ in entries], terms, values


def plot_coefficients(models, *, learned_only=True, annotate=True, precision=2, drop_zero_terms=True, ax=None):
    """Heatmap of the coefficients of several models (rows: equations, columns: terms).

    Colours follow the sign and, on a symmetric log scale, the magnitude;
    zero coefficients stay blank.

    Parameters
    ----------
    models : estimator, list or dict
        As in :func:`coefficient_table`.
    learned_only : bool, default=True
    annotate : bool, default=True
        Write each non-zero coefficient in its cell.
    precision : int, default=2
        Significant digits of the annotations.
    drop_zero_terms : bool, default=True
        Leave out the terms no model uses.
    ax : Axes, optional

    Returns
    -------
    Axes

    Examples
    --------
    >>> from sindybench import SINDy
    >>> from sindybench.libraries import PolynomialLibrary
    >>> t = np.arange(0, 3, 0.01)
    >>> y = np.column_stack([np.exp(-2 * t), 1 + np.exp(-t)])
    >>> model = SINDy(library=PolynomialLibrary(degree=1), dt=0.01).fit(None, y)
    >>> ax = plot_coefficients({"A": model})
    >>> [label.get_text() for label in ax.get_yticklabels()]
    ["A: y0'", "A: y1'"]
    """
    from matplotlib.colors import SymLogNorm

    rows, terms, values = coefficient_table(models, learned_only=learned_only)
    if not rows:
        raise ValueError("no equations to draw; expected at least one fitted model with learned rows.")
    precision = check_integer(precision, "precision")
    if drop_zero_terms:
        keep = np.any(values != 0, axis=0)
        terms, values = [t for t, k in zip(terms, keep) if k], values[:, keep]
    if ax is None:
        (ax,) = _new_axes(1, figsize=(max(4.0, 0.75 * len(terms) + 2.5), 1.0 + 0.45 * len(rows)))
    else:
        (ax,) = _check_axes(ax, 1)
    nonzero = np.abs(values[values != 0])
    top = float(nonzero.max()) if nonzero.size else 1.0
    # a linear band around zero of at most four decades below the largest magnitude
    linthresh = min(max(float(nonzero.min()) if nonzero.size else 1.0, 1e-4 * top), top)
    norm = SymLogNorm(linthresh=linthresh, vmin=-top, vmax=top)
    image = ax.imshow(np.ma.masked_equal(values, 0.0), cmap="RdBu_r", norm=norm, aspect="auto")
    ax.set_xticks(range(len(terms)), terms, rotation=45, ha="right")
    ax.set_yticks(range(len(rows)), rows)
    if annotate:
        for (i, j), c in np.ndenumerate(values):
            if c != 0:  # white on the dark ends of the colour map
                ax.text(j, i, f"{c:.{precision}g}", ha="center", va="center", fontsize=7,
                        color="white" if abs(float(norm(c)) - 0.5) > 0.3 else "black")
    mid = float(np.sqrt(top * linthresh))  # halfway on the log part of the scale
    ticks = [-top, 0.0, top] if linthresh >= top else [-top, -mid, 0.0, mid, top]
    bar = ax.figure.colorbar(image, ax=ax, label="coefficient", ticks=ticks)
    bar.ax.set_yticklabels([f"{t:.2g}" for t in ticks])
    return ax


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


def plot_prediction_band(band, y=None, *, dt=None, columns=None, max_points=MAX_POINTS, ax=None):
    """A :class:`~sindybench.uncertainty.PredictionBand` over time: median and shaded band, one Axes per column.

    Parameters
    ----------
    band : PredictionBand
        From :func:`sindybench.uncertainty.prediction_band` (outputs, or
        every state with ``states=True``).
    y : array-like of shape (n_samples, n_outputs), optional
        Measured outputs, drawn on the output columns with the fraction of
        samples inside the band.
    dt : float, optional
        Sampling interval (time on the x axis); default samples.
    columns : list of str, optional
        Names of the columns to draw (default: all).
    max_points : int, default=6000
    ax : Axes or sequence of Axes, optional
        One Axes per drawn column.

    Returns
    -------
    list of Axes

    Examples
    --------
    >>> from sindybench.uncertainty import PredictionBand
    >>> s = np.random.default_rng(0).normal(size=(20, 50, 1)).cumsum(axis=1)
    >>> lo, med, hi = np.quantile(s, [0.025, 0.5, 0.975], axis=0)
    >>> band = PredictionBand(med, lo, hi, s, ["y0"], [0], 0.05, 0)
    >>> (ax,) = plot_prediction_band(band, y=s[0])
    >>> ax.get_ylabel(), len(ax.collections)
    ('y0', 1)
    """
    names = list(band.names)
    index = list(range(len(names))) if columns is None else [names.index(c) for c in columns if c in names]
    if columns is not None and len(index) != len(columns):
        raise ValueError(f"columns {list(columns)} are not all in the band's columns {names}.")
    axes = _check_axes(ax, len(index)) or _new_axes(len(index), figsize=(10, 1.2 + 1.8 * len(index)))
    n = band.median.shape[0]
    t, t_label = _time(n, dt)
    k = _stride(n, check_integer(max_points, "max_points"))
    level = round(100 * (1 - band.alpha))
    measured = None if y is None else np.asarray(y, dtype=float).reshape(n, -1)
    for a, i in zip(axes, index):
        line = a.plot(t[::k], band.median[::k, i], lw=1.2, label="ensemble median")[0]
        a.fill_between(t[::k], band.lower[::k, i], band.upper[::k, i], color=line.get_color(), alpha=0.25,
                       label=f"{level} % band")
        if measured is not None and i in band.outputs:
            m = measured[:, band.outputs.index(i)]
            inside = np.mean((m >= band.lower[:, i]) & (m <= band.upper[:, i]))
            a.plot(t[::k], m[::k], "k", lw=0.6, alpha=0.7, label=f"measured ({100 * inside:.0f} % inside)")
        a.set_ylabel(names[i])
        a.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel(t_label)
    return axes

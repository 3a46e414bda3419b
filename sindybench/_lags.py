"""Delay coordinates of a discrete-time (NARX) model, and the model as a :class:`~sindybench.dynamics.Dynamics`.

A lag model of orders ``(na, nb)`` predicts one step ahead,
``y[k+1] = y[k] + Theta(x[k], u[k]) c``, from the state of delay coordinates

``x[k] = [y_0[k], ..., y_0[k-na+1], y_1[k], ..., u_0[k-1], ..., u_0[k-nb+1], u_1[k-1], ...]``

(each output's ``na`` latest samples, then each input's ``nb - 1`` past samples;
the current input ``u[k]`` is the model's input). Written as the right-hand side
``f(x, u) = (x[k+1] - x[k]) / dt`` and integrated by explicit Euler with one step
per sample and the input held (``zoh``), it is the difference equation itself:
the outputs' rows are the fitted increments over ``dt`` and the other rows shift
the delay line. So every tool that takes a ``Dynamics`` (simulation, refinement
with exact sensitivities, the Kalman filter, k-step prediction, bands, model
files) runs a lag model unchanged.
"""

import numpy as np

from .dynamics import POW, assemble

__all__ = ["lag_dynamics", "lag_names", "lag_states", "n_lag_states", "output_states"]


def n_lag_states(n_outputs, n_inputs, na, nb):
    """Number of delay coordinates: ``na`` per output, ``nb - 1`` per input.

    Examples
    --------
    >>> n_lag_states(1, 1, 3, 2)
    4
    """
    return n_outputs * na + n_inputs * (nb - 1)


def output_states(n_outputs, na):
    """The states that are the outputs' current values, ``y_j[k]`` (the model's ``output_index``).

    Examples
    --------
    >>> output_states(2, 3)
    (0, 3)
    """
    return tuple(j * na for j in range(n_outputs))


def lag_states(u, y, na, nb):
    """The delay coordinates ``x[k]`` of a record, the samples before its start held at its first.

    Parameters
    ----------
    u : ndarray of shape (n_samples, n_inputs)
    y : ndarray of shape (n_samples, n_outputs)
    na, nb : int
        Output and input orders (>= 1).

    Returns
    -------
    ndarray of shape (n_samples, n_lag_states(n_outputs, n_inputs, na, nb))
        Row ``k`` is ``x[k]``; from row ``max(na, nb) - 1`` on, no entry is held.

    Examples
    --------
    >>> u = np.arange(4.0)[:, None]
    >>> y = 10 * u
    >>> lag_states(u, y, 2, 3).tolist()
    [[0.0, 0.0, 0.0, 0.0], [10.0, 0.0, 0.0, 0.0], [20.0, 10.0, 1.0, 0.0], [30.0, 20.0, 2.0, 1.0]]
    """
    n = y.shape[0]
    cols = []
    y_pad = np.vstack([np.repeat(y[:1], na - 1, axis=0), y])
    for j in range(y.shape[1]):
        cols += [y_pad[na - 1 - i: na - 1 - i + n, j] for i in range(na)]
    if u.shape[1] and nb > 1:
        u_pad = np.vstack([np.repeat(u[:1], nb - 1, axis=0), u])
        for i in range(u.shape[1]):
            cols += [u_pad[nb - 1 - lag: nb - 1 - lag + n, i] for lag in range(1, nb)]
    return np.column_stack(cols) if cols else np.empty((n, 0))


def _shift(k, delay):
    k = k + delay
    return "[k]" if k == 0 else f"[k-{k}]" if k > 0 else f"[k+{-k}]"


def feature_names(library, output_names, input_names, na, nb, input_delay):
    """The fitted ``library``'s feature names over the lag states' and inputs' names (:func:`lag_names`)."""
    states, inputs = lag_names(output_names, input_names, na, nb, input_delay)
    return [str(s) for s in library.get_feature_names_out(states + inputs)]


def lag_names(output_names, input_names, na, nb, input_delay=0):
    """Names of the delay coordinates and of the current inputs: ``(state_names, input_names)``.

    An input delay ``d`` names the model's input ``u[k-d]``: the model is
    driven by the inputs delayed by ``d`` samples.

    Examples
    --------
    >>> lag_names(["y0"], ["u0"], 2, 3, input_delay=1)
    (['y0[k]', 'y0[k-1]', 'u0[k-2]', 'u0[k-3]'], ['u0[k-1]'])
    >>> lag_names(["y0"], ["u0"], 1, 2, input_delay=-1)
    (['y0[k]', 'u0[k]'], ['u0[k+1]'])
    """
    states = [f"{name}{_shift(i, 0)}" for name in output_names for i in range(na)]
    states += [f"{name}{_shift(lag, input_delay)}" for name in input_names for lag in range(1, nb)]
    return states, [f"{name}{_shift(0, input_delay)}" for name in input_names]


def _shift_rows(n_outputs, n_inputs, na, nb, dt):
    """Linear terms over ``Z = [x, u]`` and their coefficients: the rows that move the delay line by one sample."""
    n_states = n_lag_states(n_outputs, n_inputs, na, nb)
    n_z = n_states + n_inputs
    terms = [((col, POW, 1, 0),) for col in range(n_z)]
    coef = np.zeros((n_z, n_states))
    for j in range(n_outputs):
        for i in range(1, na):
            state = j * na + i
            coef[state - 1, state] += 1.0 / dt
            coef[state, state] -= 1.0 / dt
    base = n_outputs * na
    for i in range(n_inputs):
        for lag in range(1, nb):
            state = base + i * (nb - 1) + lag - 1
            source = n_states + i if lag == 1 else state - 1  # u[k] is the input column, u[k-1] the previous state
            coef[source, state] += 1.0 / dt
            coef[state, state] -= 1.0 / dt
    return terms, coef


def lag_dynamics(library, coef, *, n_outputs, n_inputs, na, nb, dt, state_names=None, max_abs=np.inf):
    """The lag model ``y[k+1] = y[k] + Theta([x[k], u[k]]) coef`` as a :class:`~sindybench.dynamics.Dynamics`.

    Parameters
    ----------
    library : fitted library
        Over ``Z = [x, u]`` (the delay coordinates, then the current inputs).
    coef : array-like of shape (n_terms, n_outputs)
        Column ``j``: the coefficients of the increment ``y_j[k+1] - y_j[k]``.
    n_outputs, n_inputs, na, nb : int
    dt : float
        The sampling interval (the Euler step).
    state_names : sequence of str, optional
    max_abs : float, default=inf

    Returns
    -------
    Dynamics
        Explicit Euler, one step per sample, input held: its simulation is
        the difference equation.

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary
    >>> library = PolynomialLibrary(degree=1).fit(np.zeros((1, 3)))  # Z = [y[k], y[k-1], u[k]]
    >>> # y[k+1] = 0.5 y[k] + 0.2 y[k-1] + u[k]: the increment is -0.5 y[k] + 0.2 y[k-1] + u[k]
    >>> dyn = lag_dynamics(library, [[0.0], [-0.5], [0.2], [1.0]], n_outputs=1, n_inputs=1, na=2, nb=1, dt=0.1)
    >>> dyn.simulate(np.ones((4, 1)), [0.0, 0.0])[:, 0].round(12).tolist()
    [0.0, 1.0, 1.5, 1.95]
    """
    coef = np.asarray(coef, dtype=float).reshape(-1, n_outputs)
    fixed_terms, fixed_coef = _shift_rows(n_outputs, n_inputs, na, nb, dt)
    n_states = fixed_coef.shape[1]
    outputs = output_states(n_outputs, na)
    return assemble(library, coef / dt, n_states=n_states, learned=outputs, fixed_terms=fixed_terms,
                    fixed_coef=fixed_coef, output_index=outputs, state_names=state_names, dt=dt, n_substeps=1,
                    method="euler", input_hold="zoh", max_abs=max_abs)

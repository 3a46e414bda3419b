"""Gauge-free quantities of a latent-state model: its equilibrium, poles and static gain, from :func:`linearize`."""

import numpy as np
from scipy.optimize import least_squares

from ..dynamics import SimulationError, simulate
from ._linearize import linearize
from ._model_step import model_step

__all__ = ["latent_invariants"]


def _equilibrium(m, u_op, start, free=None):
    """Where ``rhs(x, u_op) = 0`` near ``start``: least squares over the ``free`` states within the bounds.

    The other states keep their values in ``start`` (states held at a bound)
    and their rows are left out.
    """
    x = np.clip(start, m.lower, m.upper)
    free = np.ones(m.n_states, dtype=bool) if free is None else free
    if not free.any():
        return x

    def full(v):
        out = x.copy()
        out[free] = v
        return out

    def residual(v):
        return m.rhs(full(v), u_op)[free]

    def jacobian(v):
        return m.rhs.jacobian(full(v), u_op)[1][np.ix_(free, free)]

    with np.errstate(all="ignore"):
        sol = least_squares(residual, x[free], jac=jacobian, bounds=(m.lower[free], m.upper[free]), xtol=1e-14,
                            ftol=1e-14, gtol=1e-14)
    return full(sol.x)


def _settled(m, u_op, start, n_samples):
    """The state after ``n_samples`` samples of a free run under the constant input ``u_op`` (None if it diverges)."""
    try:
        x = simulate(m.rhs, np.clip(start, m.lower, m.upper), np.tile(u_op, (n_samples, 1)), m.dt,
                     n_substeps=m.n_substeps, method=m.method, bounds=(m.lower, m.upper), max_abs=m.max_abs)
    except SimulationError:
        return None
    return x[-1]


def latent_invariants(model, u_op, *, y_guess=None, rtol=1e-6):
    """Gauge-free quantities of a fitted latent-state model at a steady operating point.

    The poles (eigenvalues of the state Jacobian at the equilibrium for the
    constant input ``u_op``) and the static gain of the outputs from the inputs
    do not depend on the latent states' scale (:meth:`LatentHiddenState.gauge
    <sindybench.hidden.LatentHiddenState.gauge>`). The Jacobians are
    :func:`linearize`'s exact ones.

    The equilibrium is searched by least squares on the right-hand side from
    ``y_guess`` (default: the mean of the training states); when that ends
    where the right-hand side is not zero, from the end of a free run of the
    model under ``u_op`` as long as its training record. A point that is still
    not an equilibrium is an error: poles and gains there would describe no
    steady state.

    Parameters
    ----------
    model : HiddenStateSINDy
        Fitted with a :class:`~sindybench.hidden.LatentHiddenState` and a
        library of built-in terms (the compiled right-hand side).
    u_op : array-like of shape (n_inputs,)
        Constant input of the operating point.
    y_guess : array-like of shape (n_states,), optional
        Start of the equilibrium search (default: the training states' mean).
    rtol : float, default=1e-6
        Relative tolerances: a state is an equilibrium when each state moves
        less than ``rtol`` times its training spread over one sample; the
        static gain is None when the smallest pole's magnitude is below
        ``rtol`` times the largest one's (an integrator, or a continuum of
        equilibria) or the state Jacobian is numerically singular.

    Returns
    -------
    dict
        ``"state"``: the equilibrium, ``"jacobian"``: the state Jacobian there
        (:func:`linearize`'s ``A``), ``"poles"``: its eigenvalues (1/time),
        ``"gain"``: d y / d u at steady state (n_outputs, n_inputs) or None,
        ``"residual"``: the right-hand side at the equilibrium, ``"held"``:
        the states that rest against a bound there (the derivative pushes
        them outward and the simulator holds them, as a full tank's level);
        the poles and the gain are then those of the other states, with
        the held ones constant.

    Raises
    ------
    ValueError
        When ``model`` is not a fitted latent-state model, ``u_op`` or
        ``y_guess`` has the wrong length, or no equilibrium is found.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench import STLS, HiddenStateSINDy
    >>> from sindybench.hidden import LatentHiddenState
    >>> from sindybench.libraries import PolynomialLibrary
    >>> from sindybench.simulate import simulate
    >>> u = np.repeat(np.random.default_rng(0).uniform(0.5, 2.0, 20), 30)[:, None]
    >>> def truth(x, u):  # y' = -y + z, z' = -0.5 z + u: poles -1 and -0.5, static gain 2
    ...     return np.array([-x[0] + x[1], -0.5 * x[1] + u[0]])
    >>> x = simulate(truth, 2 * u[0, 0] * np.ones(2), u, 0.1, n_substeps=4)  # from rest
    >>> model = HiddenStateSINDy(hidden=LatentHiddenState(tau=2.0), library=PolynomialLibrary(degree=1),
    ...                          optimizer=STLS(threshold=0.05), dt=0.1, n_trials=1,
    ...                          input_hold="zoh").fit(u, x[:, :1])  # the hold the data were simulated with
    >>> inv = latent_invariants(model, [1.0])
    >>> np.sort(inv["poles"].real).round(2).tolist(), inv["gain"].round(2).tolist()
    ([-1.0, -0.5], [[2.0]])
    """
    name = type(model).__name__
    hidden = getattr(model, "hidden_", getattr(model, "hidden", None))
    if getattr(hidden, "n_latent", None) is None:  # asks the strategy for its latent states (no import of hidden/)
        raise ValueError(f"latent_invariants takes a HiddenStateSINDy fitted with a LatentHiddenState; got {name}"
                         f"{' with ' + type(model.hidden).__name__ if hasattr(model, 'hidden') else ''}. For another "
                         "model, linearize it at a state of your choice (sindybench.estimation.linearize).")
    m = model_step(model)  # a clear error when unfitted or not compiled
    n = m.n_states
    u_op = np.asarray(u_op, dtype=float).reshape(-1)
    if u_op.shape != (m.n_inputs,) or not np.all(np.isfinite(u_op)):
        raise ValueError(f"u_op = {u_op}; expected {m.n_inputs} finite values (one per input of the model).")
    states = model.states_ if not isinstance(model.states_, list) else np.vstack(model.states_)
    states = np.asarray(states, dtype=float)
    if y_guess is None:
        start = np.nanmean(states, axis=0)
    else:
        start = np.asarray(y_guess, dtype=float).reshape(-1)
        if start.shape != (n,) or not np.all(np.isfinite(start)):
            raise ValueError(f"y_guess = {start}; expected {n} finite values (one per state, latent ones included).")
    tol = rtol * m.state_scale / m.dt  # a state that moves less than rtol of its spread over one sample

    def is_equilibrium(x):
        return bool(np.all(np.abs(_at_rest(m, x, u_op)[0]) <= tol))

    x = _equilibrium(m, u_op, start)
    if not is_equilibrium(x):
        settled = _settled(m, u_op, start, max(len(states), 10))
        if settled is not None:
            x = _equilibrium(m, u_op, settled)
    f, held = _at_rest(m, x, u_op)
    if held.any():  # held at its bound (where the library may switch, [z >= 10]): the others at rest there
        x = _equilibrium(m, u_op, np.where(held, np.where(m.rhs(x, u_op) > 0, m.upper, m.lower), x), ~held)
        f, held = _at_rest(m, x, u_op)
    if not is_equilibrium(x):
        raise ValueError(f"no equilibrium found for u_op = {u_op.tolist()}: the best point, {x}, has the right-hand "
                         f"side {f} (expected |f| <= {tol}); the model may have no steady state there. Expected "
                         "another y_guess or operating point.")
    lin = linearize(m, x, u_op)
    free = ~held  # a state held at its bound does not move under small changes: the rest is the linear system
    A, B, C = lin.A[np.ix_(free, free)], lin.B[free], lin.C[:, free]
    poles = np.linalg.eigvals(A) if free.any() else np.zeros(0)
    magnitude = np.abs(poles)
    gain = None  # an integrator or a continuum of equilibria (a hysteresis state at rest): no static gain
    if not free.any():
        gain = np.zeros((len(m.output_index), m.n_inputs))
    elif magnitude.min() > rtol * magnitude.max() and np.linalg.cond(A) < 1e10:
        gain = -(C @ np.linalg.solve(A, B))
    return {"state": x, "jacobian": lin.A, "poles": poles, "gain": gain, "residual": f,
            "held": tuple(int(i) for i in np.flatnonzero(held))}


def _at_rest(m, x, u_op):
    """The right-hand side as the simulator applies it (zero where it pushes a state past its bound), and where."""
    f = m.rhs(x, u_op)
    near = 1e-9 * np.maximum(1.0, np.abs(x))  # least squares within bounds stops a rounding short of them
    held = ((x <= m.lower + near) & (f < 0)) | ((x >= m.upper - near) & (f > 0))
    return np.where(held, 0.0, f), held

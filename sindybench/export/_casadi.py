"""A fitted model's dynamics as CasADi functions, for model predictive control and optimal control.

CasADi is an optional dependency (``pip install "sindybench[casadi]"``), imported when
:func:`to_casadi` is called.
"""

from typing import NamedTuple

import numpy as np

from .._validation import check_signal
from ..dynamics._user import operation
from ..estimation import model_step

__all__ = ["CasadiModel", "simulate_casadi", "to_casadi"]


class CasadiModel(NamedTuple):
    """The CasADi functions of a fitted model.

    Attributes
    ----------
    rhs : casadi.Function
        ``rhs(x, u) -> x'``, the right-hand side (bounds not applied).
    step : casadi.Function
        ``step(x, u0, u1) -> x_next``: one sample of the model's integrator
        (stages, sub-steps, bounds as the simulator applies them); ``u0`` is
        the input at the sample, ``u1`` at the next one (read only with
        ``input_hold="linear"``).
    output : casadi.Function
        ``output(x) -> y``, the measured states.
    dt : float
    n_states, n_inputs : int
    output_index : tuple of int
    """

    rhs: object
    step: object
    output: object
    dt: float
    n_states: int
    n_inputs: int
    output_index: tuple


def _factor(ca, v, op, a, b):
    """One factor as the simulator values it: its operation's CasADi form (:mod:`sindybench.dynamics._optable`)."""
    return operation(op).casadi(ca, v, a, b)


def _rhs_expr(ca, terms, coef, z, n):
    """``f(z)`` from the active terms of a :class:`~sindybench.dynamics.StepModel`, summed in the simulator's order."""
    ptr, col, op, a, b = terms
    theta = []
    for j in range(ptr.shape[0] - 1):
        value = 1.0
        for f in range(ptr[j], ptr[j + 1]):
            value = value * _factor(ca, z[int(col[f])], int(op[f]), float(a[f]), float(b[f]))
        theta.append(value)
    out = []
    for i in range(n):
        acc = 0.0
        for j in range(coef.shape[0]):
            if coef[j, i] != 0.0:
                acc = acc + theta[j] * float(coef[j, i])
        out.append(acc)
    return out


def _clip(ca, v, lo, hi):
    if np.isfinite(lo):
        v = ca.fmax(v, lo)
    if np.isfinite(hi):
        v = ca.fmin(v, hi)
    return v


def to_casadi(model):
    """Export a fitted model's dynamics to CasADi.

    The step reproduces :func:`sindybench.simulate.simulate` operation by
    operation (explicit Runge-Kutta stages, sub-steps, input hold, bounds:
    stage states clipped, outward derivatives at a bound zeroed, the state
    clipped after each sub-step), so a run of ``step`` matches the
    simulator to rounding. Divergence (``max_abs``) is not checked. Each factor
    is its operation's CasADi form from the one table of operations: the
    simulator's value and derivative (a square root clipped at ``a`` is the
    constant ``sqrt(a)`` at and below it, so its derivatives stay finite for the
    solvers). A user operation is exported when it is one of NumPy's ``sign``,
    ``tanh``, ``sin``, ``cos``, ``exp``, ``arctan``, ``abs``; another raises a
    ``ValueError`` naming it.

    Parameters
    ----------
    model : SINDy, HiddenStateSINDy or ModelStep
        A fitted model with the compiled right-hand side.

    Returns
    -------
    CasadiModel

    Raises
    ------
    ImportError
        When CasADi is not installed (``pip install "sindybench[casadi]"``).
    ValueError
        When a term uses a user operation without a CasADi form.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((0, 0, 1, 0),): -1.0, ((1, 0, 1, 0),): 1.0}])   # x' = -x + u
    >>> cm = to_casadi(ModelStep.from_rhs(rhs, 0.1, n_inputs=1))
    >>> float(cm.step([1.0], [0.5], [0.5]))   # doctest: +ELLIPSIS
    0.95241...
    >>> float(simulate(rhs, [1.0], [[0.5], [0.5]], 0.1)[1, 0])   # doctest: +ELLIPSIS
    0.95241...
    """
    try:
        import casadi as ca
    except ImportError as exc:
        raise ImportError('to_casadi needs CasADi: pip install "sindybench[casadi]" (or pip install casadi).') from exc
    m = model_step(model)
    n, n_u = m.n_states, m.n_inputs
    sm = m.step_model()  # stage table, bounds and the active terms of the public one-step map
    offsets, weights, lo, hi, arrays = sm.offsets, sm.weights, sm.lo, sm.hi, (sm.terms, sm.coef)
    x, u = ca.SX.sym("x", n), ca.SX.sym("u", n_u)
    z = [x[i] for i in range(n)] + [u[i] for i in range(n_u)]
    rhs = ca.Function("rhs", [x, u], [ca.vertcat(*_rhs_expr(ca, *arrays, z, n))], ["x", "u"], ["xdot"])

    u0, u1 = ca.SX.sym("u0", n_u), ca.SX.sym("u1", n_u)
    hs = m.dt / m.n_substeps
    linear = m.input_hold == "linear"
    state = [x[i] for i in range(n)]
    for j in range(m.n_substeps):
        stages = []
        for s, c in enumerate(offsets):
            zs = [state[i] + c * hs * stages[s - 1][i] if c != 0.0 else state[i] for i in range(n)]
            zs = [_clip(ca, zs[i], lo[i], hi[i]) for i in range(n)]
            frac = (j + c) / m.n_substeps
            us = [u0[i] + frac * (u1[i] - u0[i]) if linear else u0[i] for i in range(n_u)]
            k = _rhs_expr(ca, *arrays, zs + us, n)
            for i in range(n):
                held = []
                if np.isfinite(lo[i]):
                    held.append(ca.logic_and(zs[i] <= lo[i], k[i] < 0.0))
                if np.isfinite(hi[i]):
                    held.append(ca.logic_and(zs[i] >= hi[i], k[i] > 0.0))
                for cond in held:
                    k[i] = ca.if_else(cond, 0.0, k[i])
            stages.append(k)
        for i in range(n):
            incr = 0.0
            for s, w in enumerate(weights.tolist()):
                incr = incr + w * stages[s][i]
            state[i] = _clip(ca, state[i] + hs * incr, lo[i], hi[i])
    step = ca.Function("step", [x, u0, u1], [ca.vertcat(*state)], ["x", "u0", "u1"], ["x_next"])
    output = ca.Function("output", [x], [ca.vertcat(*[x[i] for i in m.output_index])], ["x"], ["y"])
    return CasadiModel(rhs=rhs, step=step, output=output, dt=m.dt, n_states=n, n_inputs=n_u,
                       output_index=m.output_index)


def simulate_casadi(cm, x0, u):
    """Simulate a :class:`CasadiModel` over the rows of ``u`` (``step.mapaccum``): ``(n_samples, n_states)``.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((0, 0, 1, 0),): -1.0}])
    >>> cm = to_casadi(ModelStep.from_rhs(rhs, 0.1))
    >>> np.round(simulate_casadi(cm, [1.0], np.zeros((3, 0)))[:, 0], 4).tolist()
    [1.0, 0.9048, 0.8187]
    """
    u = check_signal(np.asarray(u, dtype=float).reshape(len(u), -1), "u")  # NaN or inf: an error, not NaN rows
    x0 = np.asarray(x0, dtype=float).reshape(-1)
    if x0.shape != (cm.n_states,) or u.shape[1] != cm.n_inputs:
        raise ValueError(f"x0 has shape {x0.shape} and u {u.shape}; expected ({cm.n_states},) and "
                         f"(n_samples, {cm.n_inputs}).")
    if not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 = {x0} contains NaN or inf; expected finite values.")
    if len(u) < 2:
        return x0[None, :].copy()
    run = cm.step.mapaccum("run", len(u) - 1)
    x = np.asarray(run(x0, u[:-1].T, u[1:].T)).reshape(cm.n_states, -1).T
    return np.vstack([x0, x])

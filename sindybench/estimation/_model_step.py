"""The one place where :mod:`sindybench.estimation` touches a fitted model.

Two jobs, kept together so that one module changes when the models' contract
does:

* :func:`model_step` reads a fitted estimator (today's attributes of
  :class:`~sindybench.SINDy` and :class:`~sindybench.HiddenStateSINDy`) into a
  :class:`ModelStep`: the compiled right-hand side of the full state, which
  states are measured, the bounds and the simulation settings;
* the compiled one-step map: :func:`step_jacobian` advances the state by one
  sample with the model's own integrator (explicit Runge-Kutta stages,
  sub-steps, input hold, bounds) and returns the exact Jacobian of that step
  with respect to the state; :func:`step_states` advances several samples
  without a Jacobian. Both are numba functions that other compiled loops call.

They reuse the compiled pieces of the simulator: the flattened active terms
of :class:`~sindybench.simulate.TermsRHS` (``_arrays``), its kernel
``simulate._run_terms`` and the factor derivatives of
``refine._sensitivity._factor``. The step is the simulator's step (same
stages, same order of sums: the same state to the last bit), and its
Jacobian is the forward sensitivity of that discrete map with respect to the
state, as ``refine._sensitivity._run_sensitivity`` computes it for
parameters.
"""

from typing import NamedTuple

import numpy as np
from numba import njit

from .._validation import check_bounds
from ..refine._sensitivity import _factor
from ..simulate import _STAGES, TermsRHS, _run_terms

__all__ = ["ModelStep", "model_step"]


class ModelStep(NamedTuple):
    """A fitted model's dynamics as the estimators need them.

    Attributes
    ----------
    rhs : TermsRHS
        Right-hand side of the full state (learned and fixed rows).
    n_inputs : int
    output_index : tuple of int
        The measured states, in the order of the columns of ``y``.
    lower, upper : ndarray of shape (n_states,)
        State bounds (``-inf`` / ``inf`` when unbounded).
    dt : float
        Sampling interval.
    n_substeps : int
    method : {"rk4", "euler"}
    input_hold : {"zoh", "linear"}
    max_abs : float
        A state beyond this magnitude counts as divergence.
    x0 : ndarray of shape (n_states,)
        The model's first training state (a default prior mean).
    state_scale : ndarray of shape (n_states,)
        Standard deviation of each state on the training record (a default
        prior spread and the unit of estimated process noise).
    """

    rhs: TermsRHS
    n_inputs: int
    output_index: tuple
    lower: np.ndarray
    upper: np.ndarray
    dt: float
    n_substeps: int
    method: str
    input_hold: str
    max_abs: float
    x0: np.ndarray
    state_scale: np.ndarray

    @property
    def n_states(self):
        return self.rhs.n_states

    @classmethod
    def from_rhs(cls, rhs, dt, *, n_inputs=0, output_index=(0,), bounds=None, n_substeps=1, method="rk4",
                 input_hold="zoh", max_abs=np.inf, x0=None, state_scale=None):
        """A model given by its right-hand side and simulation settings (defaults as ``simulate``'s).

        Examples
        --------
        >>> from sindybench.libraries import POW
        >>> m = ModelStep.from_rhs(TermsRHS([[-1.0]], [((0, POW, 1, 0),)], 1), 0.1)
        >>> m.n_states, m.output_index, m.upper.tolist()
        (1, (0,), [inf])
        """
        if not isinstance(rhs, TermsRHS):
            raise ValueError(f"rhs must be a TermsRHS; got {type(rhs).__name__}.")
        n = rhs.n_states
        lo, hi = check_bounds(bounds, n)
        x0 = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float)
        scale = np.ones(n) if state_scale is None else np.asarray(state_scale, dtype=float)
        return cls(rhs=rhs, n_inputs=int(n_inputs), output_index=tuple(int(i) for i in output_index), lower=lo,
                   upper=hi, dt=float(dt), n_substeps=int(n_substeps), method=method, input_hold=input_hold,
                   max_abs=float(max_abs), x0=x0, state_scale=scale)


def _scale(states):
    scale = np.std(np.asarray(states, dtype=float), axis=0)
    scale[~np.isfinite(scale) | (scale <= 0)] = 1.0
    return scale


def model_step(model):
    """Read a fitted estimator into a :class:`ModelStep`.

    Parameters
    ----------
    model : SINDy, HiddenStateSINDy or ModelStep
        A fitted estimator with the compiled right-hand side (library
        ``terms_`` and no Python fixed rows); a ``ModelStep`` is returned as is.

    Returns
    -------
    ModelStep

    Raises
    ------
    ValueError
        When ``model`` is not fitted, has no compiled right-hand side, or
        was fitted on non-uniform sample times.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench import SINDy
    >>> from sindybench.libraries import PolynomialLibrary
    >>> u = np.sin(np.arange(200) * 0.05)[:, None]
    >>> y = np.cumsum(u, axis=0) * 0.05
    >>> m = model_step(SINDy(library=PolynomialLibrary(degree=1), dt=0.05).fit(u, y))
    >>> m.n_states, m.output_index, m.method
    (1, (0,), 'rk4')
    """
    if isinstance(model, ModelStep):
        return model
    name = type(model).__name__
    if not hasattr(model, "coef_"):
        raise ValueError(f"{name} is not fitted (or not a sindybench model); expected a fitted SINDy or "
                         "HiddenStateSINDy.")
    if hasattr(model, "structure_"):  # HiddenStateSINDy
        s = model.structure_
        rhs, n_inputs, output_index = model.rhs_, model.n_features_in_, s.output_index
        lo, hi = check_bounds(s.bounds, s.n_states)
        method, states = "rk4", model.states_
    else:  # SINDy
        n = model.n_states_
        rhs = TermsRHS(model.coef_.T, model.terms_, n) if model.terms_ is not None else None
        n_inputs, output_index = model.n_inputs_, tuple(range(n))
        lo, hi = check_bounds(model.bounds, n)
        method, states = model.integrator, None
    if not isinstance(rhs, TermsRHS):
        raise ValueError(f"{name} has a Python right-hand side (a custom library or Python fixed rows); the "
                         "estimators need the compiled one (libraries with terms_).")
    if model.dt_ is None:
        raise ValueError(f"{name} was fitted on non-uniform sample times; the estimators need a uniform dt.")
    x0 = np.clip(np.asarray(model.x0_, dtype=float), lo, hi)
    scale = _scale(states) if states is not None else np.ones(rhs.n_states)
    return ModelStep(rhs=rhs, n_inputs=int(n_inputs), output_index=tuple(int(i) for i in output_index), lower=lo,
                     upper=hi, dt=float(model.dt_), n_substeps=int(model.n_substeps), method=method,
                     input_hold=model.input_hold, max_abs=float(model.max_abs), x0=x0, state_scale=scale)


def kernel(m):
    """The compiled model as one tuple for :func:`step_jacobian` and :func:`step_states`.

    ``(n_substeps, stage offsets, stage weights, linear hold, lower, upper,
    max_abs, flattened active terms)``; the terms are the simulator's
    (``TermsRHS._arrays``: ``ptr, col, op, a, b`` of the active terms, then
    ``rptr, rows, vals``, their coefficients per state).
    """
    offsets, weights = (np.array(v, dtype=float) for v in _STAGES[m.method])
    return (np.int64(m.n_substeps), offsets, weights, m.input_hold == "linear", np.asarray(m.lower, dtype=float),
            np.asarray(m.upper, dtype=float), float(m.max_abs), m.rhs._arrays)


@njit(cache=True, inline="always")
def _rhs_jacobian(z, n, arrays, theta, dtheta, fv, fd, K, s, jac):
    """``K[s] = f(z)`` and ``jac = df/dx`` (the first ``n`` columns of ``z``), from the simulator's flattened terms.

    Values are accumulated in the simulator's order, so the state is the simulator's to the last bit.
    """
    ptr, col, op, a, b, rptr, rows, vals = arrays
    for f in range(col.shape[0]):
        fv[f], fd[f] = _factor(z[col[f]], op[f], a[f], b[f])
    for j in range(ptr.shape[0] - 1):
        value = 1.0
        for f in range(ptr[j], ptr[j + 1]):
            value *= fv[f]
        theta[j] = value
        for c in range(n):
            dtheta[j, c] = 0.0
        for f in range(ptr[j], ptr[j + 1]):
            if col[f] < n and fd[f] != 0.0:
                d = fd[f]
                for g in range(ptr[j], ptr[j + 1]):
                    if g != f:
                        d *= fv[g]
                dtheta[j, col[f]] += d
    for i in range(n):
        acc = 0.0
        for c in range(n):
            jac[i, c] = 0.0
        for k in range(rptr[i], rptr[i + 1]):
            acc += theta[rows[k]] * vals[k]
            for c in range(n):
                jac[i, c] += vals[k] * dtheta[rows[k], c]
        K[s, i] = acc


@njit(cache=True)
def rhs_jacobian(z, n, arrays):
    """``f(z)`` and ``df/dz[:, :n]`` of the right-hand side with flattened ``arrays`` at ``z = [x, u]``."""
    n_terms, n_factors = arrays[0].shape[0] - 1, arrays[1].shape[0]
    K = np.empty((1, n))
    jac = np.empty((n, n))
    _rhs_jacobian(z, n, arrays, np.empty(n_terms), np.empty((n_terms, n)), np.empty(n_factors),
                  np.empty(n_factors), K, 0, jac)
    return K[0], jac


def with_inputs_as_states(m):
    """The model over ``[x, u]`` with ``u' = 0``: its state Jacobians hold the input Jacobians too."""
    rhs, n_u = m.rhs, m.n_inputs
    coef = np.hstack([rhs.coef, np.zeros((rhs.coef.shape[0], n_u))])
    lower = np.concatenate([m.lower, np.full(n_u, -np.inf)])
    upper = np.concatenate([m.upper, np.full(n_u, np.inf)])
    return m._replace(rhs=TermsRHS(coef, rhs.terms, rhs.n_states + n_u), n_inputs=0, lower=lower, upper=upper,
                      input_hold="zoh", x0=np.zeros(rhs.n_states + n_u), state_scale=np.ones(rhs.n_states + n_u))


@njit(cache=True, inline="always")
def _weighted(weights, stages):
    """``sum_s weights[s] stages[s]``: the Runge-Kutta increment of one component."""
    acc = 0.0
    for s in range(weights.shape[0]):
        acc += weights[s] * stages[s]
    return acc


@njit(cache=True)
def workspace(kern, n, n_u):
    """Scratch arrays of :func:`step_jacobian`, allocated once per loop."""
    arrays, n_st = kern[7], kern[1].shape[0]
    n_terms, n_factors = arrays[0].shape[0] - 1, arrays[1].shape[0]
    return (np.empty(n + n_u), np.empty(n_terms), np.empty((n_terms, n)), np.empty(n_factors), np.empty(n_factors),
            np.empty((n, n)), np.zeros((n_st, n)), np.zeros((n_st, n, n)), np.empty((n, n)))


@njit(cache=True)
def step_jacobian(x, u2, h1, kern, work, x_next, jac):
    """One sample step from ``x`` with inputs ``u2`` (2 rows) over ``h1`` (1 step).

    Writes the next state into ``x_next`` and ``d x_next / d x`` into ``jac``
    (the tangent of the simulator's discrete step: a component clipped at a
    bound, or held there, has a zero row); returns -1, or 1 when the step
    diverged (non-finite or beyond ``max_abs``). Same stages as
    ``refine._sensitivity._run_sensitivity`` with the initial state as the
    parameters, specialised to one sample and a square sensitivity.
    """
    n_sub, offsets, weights, linear, lo, hi, max_abs, arrays = kern
    n, n_st, n_u = x.shape[0], offsets.shape[0], u2.shape[1]
    z, theta, dtheta, fv, fd, fjac, K, dK, dz = work
    for i in range(n):
        x_next[i] = x[i]
        for c in range(n):
            jac[i, c] = 1.0 if i == c else 0.0
    hs = h1[0] / n_sub
    for j in range(n_sub):
        for s in range(n_st):
            cs = offsets[s]
            for i in range(n):
                zi = x_next[i] + cs * hs * K[s - 1, i] if cs != 0.0 else x_next[i]
                clipped = zi <= lo[i] or zi >= hi[i]
                z[i] = min(max(zi, lo[i]), hi[i])
                for c in range(n):
                    if clipped:
                        dz[i, c] = 0.0
                    elif cs != 0.0:
                        dz[i, c] = jac[i, c] + cs * hs * dK[s - 1, i, c]
                    else:
                        dz[i, c] = jac[i, c]
            frac = (j + cs) / n_sub
            for i in range(n_u):
                z[n + i] = u2[0, i] + frac * (u2[1, i] - u2[0, i]) if linear else u2[0, i]
            _rhs_jacobian(z, n, arrays, theta, dtheta, fv, fd, K, s, fjac)
            for i in range(n):
                if (z[i] <= lo[i] and K[s, i] < 0.0) or (z[i] >= hi[i] and K[s, i] > 0.0):
                    K[s, i] = 0.0
                    for c in range(n):
                        dK[s, i, c] = 0.0
                    continue
                for c in range(n):
                    acc = 0.0
                    for e in range(n):
                        acc += fjac[i, e] * dz[e, c]
                    dK[s, i, c] = acc
        bad = False
        for i in range(n):
            x_next[i] += hs * _weighted(weights, K[:, i])
            held = x_next[i] <= lo[i] or x_next[i] >= hi[i]  # clipped: no sensitivity through this step
            if held:
                x_next[i] = min(max(x_next[i], lo[i]), hi[i])
            for c in range(n):
                jac[i, c] = 0.0 if held else jac[i, c] + hs * _weighted(weights, dK[:, i, c])
            bad |= not (abs(x_next[i]) <= max_abs and abs(x_next[i]) < np.inf)
        if bad:
            return 1
    return -1


@njit(cache=True)
def step_states(x, u, h, kern, out):
    """Simulate from ``x`` over the rows of ``u`` into ``out``; -1 or the first diverged row."""
    n_sub, offsets, weights, linear, lo, hi, max_abs, arrays = kern
    return _run_terms(x, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, arrays, out)


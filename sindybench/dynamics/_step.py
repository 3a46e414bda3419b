"""The one-step map ``x_{k+1} = F(x_k, u_k, u_{k+1})`` of a compiled model, and its Jacobians.

``F`` is one output sample of the model's own integrator (RK4 or Euler,
sub-steps, zero-order or linear input hold, bounds clipping), computed by the
very kernel :func:`~sindybench.simulate.simulate` runs, so stepping a state
sample by sample reproduces the simulated trajectory bit for bit. Its
Jacobians ``dF/dx`` and ``dF/dp`` (``p``: coefficient directions, by default
every nonzero coefficient) come from the sensitivity kernel of
:func:`~sindybench.refine.simulate_sensitivity`: exact derivatives of the
discrete map, not of the continuous flow.

From Python: :func:`step` and :func:`step_jacobian`.

From numba (e.g. a Kalman filter looping over samples inside a compiled
function): build the flattened model once with :func:`step_model` and call

* ``step_kernel(m, x, u0, u1, dt) -> (x_next, diverged)``
* ``step_jacobian_kernel(m, x, u0, u1, dt) -> (x_next, jac_x, jac_p, diverged)``

with ``m`` the :class:`StepModel` (a NamedTuple numba takes as one argument),
``x`` (n_states,), ``u0``, ``u1`` (n_inputs,) float64 arrays (``u1`` is used
only with ``input_hold="linear"``), ``dt`` a float; ``jac_x`` is
(n_states, n_states), ``jac_p`` (n_states, n_params). Both allocate their
small work arrays per call and never raise: ``diverged`` is True when a state
left ``max_abs`` or became non-finite (``x_next`` is then that state).

A loop over many samples (a filter) allocates the work once and steps in place,
the same arithmetic without an allocation per sample:

* ``work = step_workspace(m, n_inputs)``, then ``step_into(m, x, u0, u1, dt, work) -> diverged``;
* ``work = jacobian_workspace(m, n_inputs)``, then
  ``step_jacobian_into(m, x, u0, u1, dt, work, jac_x, jac_p) -> diverged``.
"""

from typing import NamedTuple

import numpy as np
from numba import njit

from ._kernels import run_state_into, sensitivity_work, step_sensitivity
from ._simulate import SimulationError, TermsRHS, simulation_settings
from ._terms import terms_to_arrays

__all__ = ["StepModel", "coefficient_directions", "jacobian_workspace", "sensitivity_arrays", "step", "step_into",
           "step_jacobian", "step_jacobian_into", "step_jacobian_kernel", "step_kernel", "step_model", "step_workspace"]


def _directions_to_arrays(directions, n_terms, n_states):
    """Sparse (term, state, weight) triples of each coefficient direction."""
    directions = np.asarray(directions, dtype=float)
    if directions.ndim != 3 or directions.shape[1:] != (n_terms, n_states):
        raise ValueError(
            f"directions has shape {directions.shape}; expected (n_params, n_terms={n_terms}, n_states={n_states})."
        )
    if not np.all(np.isfinite(directions)):
        raise ValueError("directions contains NaN or inf; expected finite coefficient derivatives.")
    ptr = np.zeros(directions.shape[0] + 1, dtype=np.int64)
    terms, states, weights = [], [], []
    for p, d in enumerate(directions):
        j, i = np.nonzero(d)
        terms.append(j)
        states.append(i)
        weights.append(d[j, i])
        ptr[p + 1] = ptr[p] + j.size
    cat = (lambda parts, dtype: np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype))
    return ptr, cat(terms, np.int64), cat(states, np.int64), cat(weights, float)


def coefficient_directions(rhs):
    """One unit direction per nonzero coefficient of ``rhs`` (``np.nonzero(rhs.coef)`` order).

    Examples
    --------
    >>> from sindybench.libraries import POW
    >>> rhs = TermsRHS([[0.0, 1.0], [-4.0, 0.0]], [((1, POW, 1, 0),), ((0, POW, 1, 0),)], 2)
    >>> coefficient_directions(rhs).shape
    (2, 2, 2)
    """
    rows, cols = np.nonzero(rhs.coef)
    out = np.zeros((rows.size, *rhs.coef.shape))
    out[np.arange(rows.size), rows, cols] = 1.0
    return out


def sensitivity_arrays(rhs, directions=None):
    """Flattened ``(terms, coef, par)`` of ``rhs`` for the sensitivity kernel.

    Only the terms with a nonzero coefficient or a direction are kept;
    ``par = (ppar, pterm, pstate, pw)`` lists, for each parameter ``p``, the
    entries ``(term, state, weight)`` it moves (``pterm`` into the kept terms).
    """
    n_terms, n = rhs.coef.shape
    if directions is None:
        directions = np.zeros((0, n_terms, n))
    ppar, pterm, pstate, pw = _directions_to_arrays(directions, n_terms, n)
    used = np.any(rhs.coef != 0, axis=1)
    used[pterm] = True
    keep = np.flatnonzero(used)
    remap = np.full(n_terms, -1, dtype=np.int64)
    remap[keep] = np.arange(keep.size)
    terms = terms_to_arrays([rhs.terms[j] for j in keep])
    return terms, np.ascontiguousarray(rhs.coef[keep]), (ppar, remap[pterm], pstate, pw)


class StepModel(NamedTuple):
    """A compiled model and its integrator settings, flattened for :func:`step_kernel`."""

    n_sub: int
    offsets: np.ndarray
    weights: np.ndarray
    linear: bool
    lo: np.ndarray
    hi: np.ndarray
    max_abs: float
    model: tuple  # TermsRHS._arrays: active terms and sparse coefficients (state path)
    terms: tuple  # (ptr, col, op, a, b) of the terms the sensitivities need
    coef: np.ndarray  # their dense coefficients (n_kept, n_states)
    par: tuple  # the coefficient directions (ppar, pterm, pstate, pw)
    user: object  # the address (int) of the compiled table of user operations, None without


def _check_rhs(rhs):
    if not isinstance(rhs, TermsRHS):
        raise ValueError(f"rhs must be a TermsRHS (a compiled model); got {type(rhs).__name__}.")


def step_model(rhs, *, directions=None, n_substeps=1, method="rk4", input_hold="zoh", bounds=None, max_abs=np.inf):
    """Flatten ``rhs`` and its settings into a :class:`StepModel` for the numba-callable kernels.

    Parameters
    ----------
    rhs : TermsRHS
    directions : array-like of shape (n_params, n_terms, n_states), optional
        The coefficient parameters of ``jac_p``; default one per nonzero
        coefficient (:func:`coefficient_directions`).
    n_substeps, method, input_hold, bounds, max_abs
        As in :func:`~sindybench.simulate.simulate`.
    """
    _check_rhs(rhs)
    st, _, _ = simulation_settings(rhs.n_states, np.zeros((2, 0)), None, 1.0, n_substeps=n_substeps, method=method,
                                   input_hold=input_hold, bounds=bounds, max_abs=max_abs)
    terms, coef, par = sensitivity_arrays(rhs, coefficient_directions(rhs) if directions is None else directions)
    return StepModel(st.n_sub, st.offsets, st.weights, st.linear, st.lo, st.hi, st.max_abs, rhs._arrays, terms, coef,
                     par, rhs.user)


@njit(cache=True, inline="always")
def _set_inputs(u, u0, u1):
    for i in range(u0.shape[0]):
        u[0, i] = u0[i]
        u[1, i] = u1[i]


@njit(cache=True)
def step_workspace(m, n_inputs):
    """Work arrays of :func:`step_into` for a loop over samples (allocated once, numba-callable)."""
    n = m.lo.shape[0]
    return (np.empty((2, n_inputs)), np.empty(n + n_inputs), np.empty(m.model[0].shape[0] - 1),
            np.zeros((m.offsets.shape[0], n)), np.empty(1), np.empty((2, n)))


@njit(cache=True)
def step_into(m, x, u0, u1, dt, work):
    """Advance ``x`` in place by one output sample; return ``diverged`` (numba-callable, no allocation).

    ``work`` from :func:`step_workspace`; :func:`step_kernel` is this on a copy of ``x``.
    """
    u, z, theta, K, h, out = work
    _set_inputs(u, u0, u1)
    h[0] = dt
    # the free run's own loop over two samples: one compiled integrator for simulate, step and k-step
    return run_state_into(x, u, h, m.n_sub, m.offsets, m.weights, m.linear, m.lo, m.hi, m.max_abs, m.model, m.user,
                          z, theta, K, out) >= 0


@njit(cache=True)
def step_kernel(m, x, u0, u1, dt):
    """``(F(x, u0, u1), diverged)``: one output sample of the model (numba-callable)."""
    x_next = x.copy()
    bad = step_into(m, x_next, u0, u1, dt, step_workspace(m, u0.shape[0]))
    return x_next, bad


@njit(cache=True)
def jacobian_workspace(m, n_inputs):
    """Work arrays of :func:`step_jacobian_into` for a loop over samples (allocated once, numba-callable)."""
    n = m.lo.shape[0]
    n_par = m.par[0].shape[0] - 1
    q = n + n_par
    z, work = sensitivity_work(n, n_inputs, m.terms[0].shape[0] - 1, m.terms[1].shape[0], m.offsets.shape[0], q)
    # parameter p of the kernel is column n + p of S: shift the directions' parameter index
    ppar = np.zeros(q + 1, dtype=np.int64)
    for p in range(n_par + 1):
        ppar[n + p] = m.par[0][p]
    return np.empty((2, n_inputs)), np.empty((n, q)), z, work, (ppar, m.par[1], m.par[2], m.par[3])


@njit(cache=True)
def step_jacobian_into(m, x, u0, u1, dt, work, jac_x, jac_p):
    """Advance ``x`` in place by one output sample, ``dF/dx`` into ``jac_x``, ``dF/dp`` into ``jac_p``.

    Returns ``diverged``; numba-callable, no allocation (``work`` from
    :func:`jacobian_workspace`). :func:`step_jacobian_kernel` is this on
    fresh arrays.
    """
    u, S, z, sens, par = work
    n = x.shape[0]
    _set_inputs(u, u0, u1)
    for i in range(n):
        for c in range(S.shape[1]):
            S[i, c] = 1.0 if i == c else 0.0
    # step_sensitivity inlined here, not reached through run_sensitivity_into (which would share its compilation
    # with the refinement): the Kalman filter calls this once per sample, and that call cost 18 % of its time
    bad = step_sensitivity(x, S, u, 0, 1 if m.linear else 0, dt, m.n_sub, m.offsets, m.weights, m.lo, m.hi,
                           m.max_abs, m.terms, m.coef, par, m.user, z, sens)
    for i in range(n):
        for c in range(n):
            jac_x[i, c] = S[i, c]
        for p in range(jac_p.shape[1]):
            jac_p[i, p] = S[i, n + p]
    return bad


@njit(cache=True)
def step_jacobian_kernel(m, x, u0, u1, dt):
    """``(F, dF/dx, dF/dp, diverged)`` at ``(x, u0, u1)`` (numba-callable)."""
    n = x.shape[0]
    x_next = x.copy()
    jac_x = np.empty((n, n))
    jac_p = np.empty((n, m.par[0].shape[0] - 1))
    bad = step_jacobian_into(m, x_next, u0, u1, dt, jacobian_workspace(m, u0.shape[0]), jac_x, jac_p)
    return x_next, jac_x, jac_p, bad


def _check_point(m, x, u0, u1, dt, n_inputs):
    x = np.asarray(x, dtype=float).reshape(-1)
    if x.shape[0] != m.lo.shape[0] or not np.all(np.isfinite(x)):
        raise ValueError(f"x = {x}; expected {m.lo.shape[0]} finite values (one per state).")
    us = []
    for name, v in (("u0", u0), ("u1", u0 if u1 is None else u1)):
        v = np.ascontiguousarray(np.zeros(0) if v is None else v, dtype=float).reshape(-1)
        if v.shape[0] != n_inputs or not np.all(np.isfinite(v)):
            raise ValueError(f"{name} = {v}; expected {n_inputs} finite input values.")
        us.append(v)
    dt = float(dt)
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt = {dt!r}; expected a positive finite number.")
    return np.ascontiguousarray(x), us[0], us[1], dt


def _n_inputs(rhs, u0):
    n_inputs = np.asarray(np.zeros(0) if u0 is None else u0, dtype=float).reshape(-1).shape[0]
    if rhs.n_variables > rhs.n_states + n_inputs:
        raise ValueError(f"rhs terms use column {rhs.n_variables - 1} of Z = [x, u], but u0 has {n_inputs} values; "
                         f"expected at least {rhs.n_variables - rhs.n_states}.")
    return n_inputs


def _diverged(x_next, on_divergence):
    if on_divergence == "raise":
        raise SimulationError(f"the step diverged: state {x_next} is not finite or exceeds max_abs.", step=1,
                              state=x_next)
    x_next[:] = np.nan


def step(rhs, x, u0, u1=None, dt=None, *, n_substeps=1, method="rk4", input_hold="zoh", bounds=None,
         max_abs=np.inf, on_divergence="raise"):
    """The state one output sample after ``x``: ``F(x, u0, u1)``.

    Parameters
    ----------
    rhs : TermsRHS
    x : array-like of shape (n_states,)
    u0, u1 : array-like of shape (n_inputs,)
        Inputs at the start and end of the sample (``u1`` only matters for
        ``input_hold="linear"``; default ``u0``).
    dt : float
        The sample length.
    n_substeps, method, input_hold, bounds, max_abs, on_divergence
        As in :func:`~sindybench.simulate.simulate`.

    Returns
    -------
    ndarray of shape (n_states,)
        Bit for bit row ``k + 1`` of :func:`~sindybench.simulate.simulate`
        started from row ``k``.

    Examples
    --------
    >>> from sindybench.libraries import POW
    >>> from sindybench.simulate import simulate
    >>> rhs = TermsRHS([[-1.0], [2.0]], [((0, POW, 1, 0),), ((1, POW, 1, 0),)], 1)  # x' = -x + 2 u
    >>> u = np.array([[1.0], [0.5], [0.0]])
    >>> x = simulate(rhs, [0.3], u, 0.1, input_hold="linear")
    >>> bool(np.all(step(rhs, x[1], u[1], u[2], 0.1, input_hold="linear") == x[2]))
    True
    """
    _check_rhs(rhs)
    m = step_model(rhs, directions=np.zeros((0, *rhs.coef.shape)), n_substeps=n_substeps, method=method,
                   input_hold=input_hold, bounds=bounds, max_abs=max_abs)
    x, u0, u1, dt = _check_point(m, x, u0, u1, dt, _n_inputs(rhs, u0))
    x_next, bad = step_kernel(m, x, u0, u1, dt)
    if bad:
        _diverged(x_next, on_divergence)
    return x_next


def step_jacobian(rhs, x, u0, u1=None, dt=None, *, directions=None, n_substeps=1, method="rk4", input_hold="zoh",
                  bounds=None, max_abs=np.inf, on_divergence="raise"):
    """``F(x, u0, u1)`` with ``dF/dx`` and ``dF/dp`` (exact derivatives of the discrete step).

    Parameters
    ----------
    rhs, x, u0, u1, dt, n_substeps, method, input_hold, bounds, max_abs, on_divergence
        As in :func:`step`.
    directions : array-like of shape (n_params, n_terms, n_states), optional
        ``dC/dp`` of each parameter; default one per nonzero coefficient of
        ``rhs``, in ``np.nonzero(rhs.coef)`` order.

    Returns
    -------
    x_next : ndarray of shape (n_states,)
        Identical to :func:`step`.
    jac_x : ndarray of shape (n_states, n_states)
    jac_p : ndarray of shape (n_states, n_params)

    Examples
    --------
    Euler on ``x' = a x``: ``F = x + dt a x``, ``dF/dx = 1 + dt a``, ``dF/da = dt x``.

    >>> from sindybench.libraries import POW
    >>> rhs = TermsRHS([[-2.0]], [((0, POW, 1, 0),)], 1)
    >>> x1, jx, jp = step_jacobian(rhs, [1.5], [], dt=0.1, method="euler")
    >>> x1.tolist(), jx.tolist(), jp.round(12).tolist()
    ([1.2], [[0.8]], [[0.15]])
    """
    m = step_model(rhs, directions=directions, n_substeps=n_substeps, method=method, input_hold=input_hold,
                   bounds=bounds, max_abs=max_abs)
    x, u0, u1, dt = _check_point(m, x, u0, u1, dt, _n_inputs(rhs, u0))
    x_next, jac_x, jac_p, bad = step_jacobian_kernel(m, x, u0, u1, dt)
    if bad:
        _diverged(x_next, on_divergence)
        jac_x[:], jac_p[:] = np.nan, np.nan
    return x_next, jac_x, jac_p

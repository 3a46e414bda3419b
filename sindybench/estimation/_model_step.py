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

They reuse the compiled kernels of :mod:`sindybench.simulate` (``_run_terms``)
and :mod:`sindybench.refine._sensitivity` (``_run_sensitivity``): the step is
the simulator's step, and its Jacobian is the forward sensitivity of that
discrete map with respect to the initial state.
"""

from typing import NamedTuple

import numpy as np
from numba import njit

from .._validation import check_bounds
from ..libraries._terms import terms_to_arrays
from ..refine._sensitivity import _run_sensitivity
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
    """The compiled model as one tuple for :func:`step_jacobian` and :func:`step_states`."""
    rhs = m.rhs
    active = np.flatnonzero(np.any(rhs.coef != 0, axis=1))
    terms = terms_to_arrays([rhs.terms[j] for j in active])
    coef = np.ascontiguousarray(rhs.coef[active])
    par = (np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0))
    offsets, weights = (np.array(v, dtype=float) for v in _STAGES[m.method])
    return (np.int64(m.n_substeps), offsets, weights, m.input_hold == "linear", np.asarray(m.lower, dtype=float),
            np.asarray(m.upper, dtype=float), float(m.max_abs), terms, coef, par, rhs._arrays)


@njit(cache=True)
def step_jacobian(x, u2, h1, kern, x_next, jac):
    """One sample step from ``x`` with inputs ``u2`` (2 rows) over ``h1`` (1 step).

    Writes the next state into ``x_next`` and ``d x_next / d x`` into ``jac``;
    returns -1, or 1 when the step diverged (non-finite or beyond ``max_abs``).
    """
    n_sub, offsets, weights, linear, lo, hi, max_abs, terms, coef, par, _ = kern
    n = x.shape[0]
    eye = np.eye(n)
    out_x = np.empty((2, n))
    out_s = np.empty((2, 0, n))
    step = _run_sensitivity(x, eye, u2, h1, n_sub, offsets, weights, linear, lo, hi, max_abs, terms, coef, par,
                            np.zeros(0, dtype=np.int64), out_x, out_s, jac)
    for i in range(n):
        x_next[i] = out_x[1, i]
    return step


@njit(cache=True)
def step_states(x, u, h, kern, out):
    """Simulate from ``x`` over the rows of ``u`` into ``out``; -1 or the first diverged row."""
    n_sub, offsets, weights, linear, lo, hi, max_abs, _, _, _, arrays = kern
    return _run_terms(x, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, arrays, out)


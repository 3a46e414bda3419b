"""Linearization of a fitted model at a state and an input, continuous and discrete (for control design)."""

from typing import NamedTuple

import numpy as np

from ..dynamics import SimulationError, step_jacobian_kernel
from ._model_step import model_step

__all__ = ["Linearization", "linearize"]


class Linearization(NamedTuple):
    """State-space matrices of a model linearized at ``(x, u)``.

    Continuous: ``dx' = A dx + B du``, ``dy = C dx + D du``; discrete (one
    sample, the input held over it): ``dx[k+1] = Ad dx[k] + Bd du[k]``,
    ``dy[k] = Cd dx[k] + Dd du[k]``, with ``dx = x - x_op``, ``du = u - u_op``.

    Attributes
    ----------
    A, B, C, D : ndarray
        Continuous-time matrices, ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``.
    Ad, Bd, Cd, Dd : ndarray
        Discrete-time matrices of the model's sample step (its integrator,
        sub-steps and bounds).
    f : ndarray of shape (n,)
        ``x'`` at the operating point (zero at an equilibrium).
    x_next : ndarray of shape (n,)
        The state one sample later (``x`` at an equilibrium).
    dt : float
        The sample interval of the discrete matrices.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    Ad: np.ndarray
    Bd: np.ndarray
    Cd: np.ndarray
    Dd: np.ndarray
    f: np.ndarray
    x_next: np.ndarray
    dt: float


def linearize(model, x, u=None):
    """Linearize a fitted model at the state ``x`` and input ``u``.

    The continuous matrices are the exact derivatives of the right-hand side
    (from the terms' derivatives, no finite differences); the discrete ones
    are the exact derivatives of the model's own sample step (Runge-Kutta
    stages and sub-steps, the input held constant over the sample, bounds
    as the simulator applies them), so ``Ad`` is not ``expm(A dt)`` but what
    the simulator does. ``C`` selects the measured states and ``D = 0``.

    Parameters
    ----------
    model : SINDy, HiddenStateSINDy or ModelStep
    x : array-like of shape (n_states,)
    u : array-like of shape (n_inputs,), optional
        Omit (or give an empty array) for a model without inputs.

    Returns
    -------
    Linearization

    Raises
    ------
    ValueError
        When ``x`` or ``u`` has the wrong length, is not finite, or ``x`` is
        outside the model's bounds.
    SimulationError
        When the model's step from ``(x, u)`` diverges.

    Examples
    --------
    The pendulum ``x0' = x1``, ``x1' = -sin``-like ``-x0 + x0^3 / 6 + u`` at rest:

    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0},
    ...                                {((0, 0, 1, 0),): -1.0, ((0, 0, 3, 0),): 1 / 6, ((2, 0, 1, 0),): 1.0}])
    >>> lin = linearize(ModelStep.from_rhs(rhs, 0.1, n_inputs=1), [0.0, 0.0], [0.0])
    >>> lin.A.tolist(), lin.B.ravel().tolist(), lin.C.tolist()
    ([[0.0, 1.0], [-1.0, 0.0]], [0.0, 1.0], [[1.0, 0.0]])
    >>> bool(np.allclose(lin.Ad, [[np.cos(0.1), np.sin(0.1)], [-np.sin(0.1), np.cos(0.1)]], atol=1e-6))
    True
    """
    m = model_step(model)
    n, n_u = m.n_states, m.n_inputs
    x = np.asarray(x, dtype=float).reshape(-1)
    u = np.zeros(0) if u is None else np.asarray(u, dtype=float).reshape(-1)
    if x.shape != (n,) or not np.all(np.isfinite(x)):
        raise ValueError(f"x = {x!r}; expected {n} finite numbers (one per state).")
    if u.shape != (n_u,) or not np.all(np.isfinite(u)):
        raise ValueError(f"u = {u!r}; expected {n_u} finite numbers (one per input).")
    outside = (x < m.lower) | (x > m.upper)
    if outside.any():
        i = int(np.argmax(outside))
        raise ValueError(f"x[{i}] = {x[i]:g} is outside the model's bounds [{m.lower[i]:g}, {m.upper[i]:g}].")
    z = np.concatenate([x, u])
    f, jac = m.rhs.jacobian(x, u)  # df/dz
    # the step of the model over [x, u] with u' = 0: its state Jacobian holds d x_next / d u
    z_next, jac_d, _, bad = step_jacobian_kernel(m.step_model(with_inputs=True), z, np.zeros(0), np.zeros(0), m.dt)
    if bad:
        raise SimulationError(f"the model's step from x = {x} with u = {u} diverged (state {z_next[:n]}).", step=1,
                              state=z_next[:n])
    C = np.zeros((len(m.output_index), n))
    C[np.arange(len(m.output_index)), list(m.output_index)] = 1.0
    D = np.zeros((len(m.output_index), n_u))
    return Linearization(A=jac[:n, :n].copy(), B=jac[:n, n:].copy(), C=C, D=D, Ad=jac_d[:n, :n].copy(),
                         Bd=jac_d[:n, n:].copy(), Cd=C.copy(), Dd=D.copy(), f=f[:n].copy(), x_next=z_next[:n].copy(),
                         dt=m.dt)

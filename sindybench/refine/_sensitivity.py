"""Forward sensitivities of the compiled simulator.

:func:`simulate_sensitivity` integrates a :class:`~sindybench.simulate.TermsRHS`
together with the derivatives of its state with respect to chosen parameters:
coefficient directions (``dC/dp`` for each parameter ``p``) and entries of the
initial state. It runs exactly the steps of :func:`sindybench.simulate.simulate`
(explicit Runge-Kutta stages, sub-steps, input hold, bounds): the sensitivity
equations are the derivative of that discrete map, so the Jacobian they give
is the exact Jacobian of the simulated output (not of the continuous flow).
A state component that is clipped at a bound, or held at it because its
derivative points outward, has zero sensitivity through that step.
"""

import numpy as np

from ..dynamics import SimulationError, TermsRHS, sensitivity_arrays, simulation_settings
from ..dynamics._kernels import run_sensitivity

__all__ = ["simulate_sensitivity"]


def simulate_sensitivity(rhs, x0, u, dt, *, directions=None, free_x0=None, output_index=None, n_substeps=1,
                         method="rk4", input_hold="zoh", bounds=None, max_abs=np.inf, on_divergence="raise"):
    """Simulate a :class:`~sindybench.simulate.TermsRHS` with its forward sensitivities.

    The parameters are ``p = (p_coef, x0[free_x0])``: the coefficient matrix
    of ``rhs`` moves along ``directions[i]`` (``dC/dp_i``) for the first
    ones, and the free entries of the initial state are the others.

    Parameters
    ----------
    rhs : TermsRHS
        The model (compiled path only; Python right-hand sides have no
        sensitivities: use finite differences).
    x0 : array-like of shape (n_states,)
    u : array-like of shape (n_samples, n_inputs)
    dt : float
    directions : array-like of shape (n_coef_params, n_terms, n_states), optional
        Derivative of ``rhs.coef`` with respect to each coefficient parameter.
    free_x0 : sequence of int, optional
        States whose initial value is a parameter (in this order).
    output_index : sequence of int, optional
        States whose sensitivities are returned at every sample (default: all).
    n_substeps, method, input_hold, bounds, max_abs, on_divergence
        As in :func:`sindybench.simulate.simulate`.

    Returns
    -------
    x : ndarray of shape (n_samples, n_states)
        The simulated states, identical to :func:`~sindybench.simulate.simulate`.
    sens : ndarray of shape (n_samples, len(output_index), n_params)
        ``d x[k, output_index[r]] / d p``.
    sens_end : ndarray of shape (n_states, n_params)
        Sensitivity of the whole final state (for multiple shooting).

    Raises
    ------
    SimulationError
        On divergence with ``on_divergence="raise"``; with ``"nan"`` the
        state and sensitivities from the diverged sample on are NaN.

    Examples
    --------
    ``x' = -a x`` from ``x0``: ``dx/da = -t x`` and ``dx/dx0 = exp(-a t)``.

    >>> from sindybench.libraries import POW
    >>> rhs = TermsRHS([[-2.0]], [((0, POW, 1, 0),)], 1)
    >>> x, s, _ = simulate_sensitivity(rhs, [1.0], np.zeros((11, 0)), 0.1, directions=[[[-1.0]]], free_x0=[0])
    >>> t, xe = 1.0, np.exp(-2.0)
    >>> np.allclose(s[-1, 0], [-t * xe, xe], rtol=1e-4)  # RK4 at h = 0.1
    True
    """
    if not isinstance(rhs, TermsRHS):
        raise ValueError(f"rhs must be a TermsRHS for exact sensitivities; got {type(rhs).__name__}.")
    if u is not None and np.ndim(u) == 2 and rhs.n_variables > rhs.n_states + np.shape(u)[1]:
        raise ValueError(f"rhs terms use column {rhs.n_variables - 1} of Z = [x, u], but u has {np.shape(u)[1]} "
                         f"columns; expected at least {rhs.n_variables - rhs.n_states}.")
    settings, u, x0 = simulation_settings(rhs.n_states, u, x0, dt, n_substeps=n_substeps, method=method,
                                          input_hold=input_hold, bounds=bounds, max_abs=max_abs,
                                          on_divergence=on_divergence)
    n = rhs.n_states
    terms, coef, par = sensitivity_arrays(rhs, directions)
    free_x0 = np.array([] if free_x0 is None else free_x0, dtype=np.int64).reshape(-1)
    oidx = np.arange(n, dtype=np.int64) if output_index is None else np.asarray(output_index, dtype=np.int64)
    for name, idx in (("free_x0", free_x0), ("output_index", oidx)):
        if idx.size and (idx.min() < 0 or idx.max() >= n):
            raise ValueError(f"{name} = {idx.tolist()} has a state index outside [0, {n - 1}].")
    n_coef = par[0].shape[0] - 1
    q = n_coef + free_x0.size
    S0 = np.zeros((n, q))
    S0[free_x0, n_coef + np.arange(free_x0.size)] = 1.0
    out_x = np.empty((u.shape[0], n))
    out_s = np.zeros((u.shape[0], oidx.size, q))
    s_end = np.zeros((n, q))
    h, n_sub, offsets, weights, linear, lo, hi, max_abs = settings[:8]
    step = run_sensitivity(x0, S0, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, terms, coef, par,
                           rhs.user, oidx, out_x, out_s, s_end)
    if step >= 0:
        if on_divergence == "raise":
            raise SimulationError(
                f"simulation diverged at step {step} of {u.shape[0]}: state {out_x[step]} "
                f"{'is not finite' if not np.all(np.isfinite(out_x[step])) else f'exceeds max_abs = {max_abs:g}'}.",
                step=int(step), state=out_x[step].copy())
        out_x[step:] = np.nan
        out_s[step:] = np.nan
        s_end[:] = np.nan
    return out_x, out_s, s_end

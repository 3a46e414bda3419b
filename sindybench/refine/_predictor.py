"""The prediction-error predictor: a constant-gain observer run by the model's own integrator, with sensitivities.

The predictor of :func:`~sindybench.refine.refine_prediction_error` is the
model in innovation form: from ``x[0|-1] = x0``, each measured sample corrects
the predicted state by a constant gain and the model's step (the simulator's
Runge-Kutta map: stages, sub-steps, input hold, bounds) carries it on::

    e[t]      = y[t] - x[t|t-1][output_index]
    x[t|t]    = clip(x[t|t-1] + K e[t])
    x[t+1|t]  = step(x[t|t], u[t])

The ``k``-step-ahead prediction of sample ``t`` is the model run open loop
for ``k - 1`` steps from ``x[t-k+1|t-k]`` (from ``x0`` for ``t < k - 1``):
``k = 1`` is the one-step predictor above, and ``k`` at least the record's
length is the open-loop simulation of the output-error criterion.

:func:`predict_sensitivity` also returns ``d x_pred / d p`` for the
parameters ``p`` of the sensitivity kernel (coefficient directions and free
initial states) and, optionally, the entries of ``K``: the derivative of the
correction, ``dx[t|t] = (I - K H) dx[t|t-1] + dK e[t]``, followed by the
step's own sensitivity recursion (:func:`sindybench.dynamics._kernels.step_sensitivity`),
so the Jacobian is the exact derivative of the discrete predictor.
"""

import numpy as np
from numba import njit

from ..dynamics import TermsRHS, sensitivity_arrays, simulation_settings
from ..dynamics._kernels import sensitivity_work, step_sensitivity, step_state

__all__ = ["predict_sensitivity"]


@njit(cache=True, inline="always")
def _record(x, S, oidx, t, out_x, out_s):
    for i in range(x.shape[0]):
        out_x[t, i] = x[i]
    for r in range(oidx.shape[0]):
        for p in range(S.shape[1]):
            out_s[t, r, p] = S[oidx[r], p]


@njit(cache=True, inline="always")
def _correct(x, S, y, t, gain, gcol, oidx, lo, hi, e, tmp):
    """``x += K (y[t] - x[oidx])`` (clipped into the bounds) and its sensitivity."""
    n, n_out, q = x.shape[0], oidx.shape[0], S.shape[1]
    for r in range(n_out):
        e[r] = y[t, r] - x[oidx[r]]
        for p in range(q):
            tmp[r, p] = S[oidx[r], p]
    for i in range(n):
        acc = 0.0
        for r in range(n_out):
            acc += gain[i, r] * e[r]
        x[i] += acc
        for p in range(q):
            d = 0.0
            for r in range(n_out):
                d += gain[i, r] * tmp[r, p]
            S[i, p] -= d
        if gcol >= 0 and q > 0:
            for r in range(n_out):
                S[i, gcol + i * n_out + r] += e[r]
        if x[i] <= lo[i] or x[i] >= hi[i]:
            x[i] = min(max(x[i], lo[i]), hi[i])
            for p in range(q):
                S[i, p] = 0.0


@njit(cache=True)
def run_predictor(x0, S0, y, gain, gcol, horizon, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, terms,
                  coef, par, user, oidx, out_x, out_s):
    """Predictions ``x[t|t-horizon]`` and their sensitivities; the first sample where the filter diverged, or -1.

    A ``horizon``-step branch that diverges leaves its prediction NaN (the
    caller penalizes it) and the filter goes on.
    """
    n, q, n_samples = x0.shape[0], S0.shape[1], out_x.shape[0]
    n_out = oidx.shape[0]
    z, work = sensitivity_work(n, u.shape[1], coef.shape[0], terms[1].shape[0], offsets.shape[0], q)
    e, tmp = np.empty(n_out), np.empty((n_out, q))
    xb, Sb = x0.copy(), S0.copy()
    for t in range(min(horizon - 1, n_samples)):  # the first samples: open loop from x0
        _record(xb, Sb, oidx, t, out_x, out_s)
        if step_sensitivity(xb, Sb, u, t, t + 1 if linear else t, h[t], n_sub, offsets, weights, lo, hi, max_abs,
                            terms, coef, par, user, z, work):
            for tt in range(t + 1, min(horizon - 1, n_samples)):
                out_x[tt, 0] = np.nan
            break
    x, S = x0.copy(), S0.copy()
    for s in range(n_samples - horizon + 1):
        t = s + horizon - 1
        if horizon == 1:
            _record(x, S, oidx, t, out_x, out_s)
        else:
            xb[:] = x
            Sb[:, :] = S
            bad = False
            for j in range(s, t):
                bad = step_sensitivity(xb, Sb, u, j, j + 1 if linear else j, h[j], n_sub, offsets, weights, lo, hi,
                                       max_abs, terms, coef, par, user, z, work)
                if bad:
                    break
            _record(xb, Sb, oidx, t, out_x, out_s)
            if bad:
                out_x[t, 0] = np.nan
        if s + 1 > n_samples - horizon:
            break
        _correct(x, S, y, s, gain, gcol, oidx, lo, hi, e, tmp)
        if step_sensitivity(x, S, u, s, s + 1 if linear else s, h[s], n_sub, offsets, weights, lo, hi, max_abs,
                            terms, coef, par, user, z, work):
            return s + 1
    return -1


@njit(cache=True)
def run_predictor_state(x0, y, gain, horizon, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, model, user,
                        oidx, out_x):
    """:func:`run_predictor` without sensitivities, on the simulator's state-only step (the same states)."""
    n, n_samples, n_out = x0.shape[0], out_x.shape[0], oidx.shape[0]
    z = np.empty(n + u.shape[1])
    theta = np.empty(model[0].shape[0] - 1)
    K = np.zeros((offsets.shape[0], n))
    e = np.empty(n_out)
    xb = x0.copy()
    for t in range(min(horizon - 1, n_samples)):
        out_x[t, :] = xb
        if step_state(xb, u, t, t + 1 if linear else t, h[t], n_sub, offsets, weights, lo, hi, max_abs, model, user,
                      z, theta, K):
            for tt in range(t + 1, min(horizon - 1, n_samples)):
                out_x[tt, 0] = np.nan
            break
    x = x0.copy()
    for s in range(n_samples - horizon + 1):
        t = s + horizon - 1
        xb[:] = x
        bad = False
        for j in range(s, t):
            bad = step_state(xb, u, j, j + 1 if linear else j, h[j], n_sub, offsets, weights, lo, hi, max_abs, model,
                             user, z, theta, K)
            if bad:
                break
        out_x[t, :] = xb
        if bad:
            out_x[t, 0] = np.nan
        if s + 1 > n_samples - horizon:
            break
        for r in range(n_out):
            e[r] = y[s, r] - x[oidx[r]]
        for i in range(n):
            acc = 0.0
            for r in range(n_out):
                acc += gain[i, r] * e[r]
            x[i] = min(max(x[i] + acc, lo[i]), hi[i])
        if step_state(x, u, s, s + 1 if linear else s, h[s], n_sub, offsets, weights, lo, hi, max_abs, model, user, z,
                      theta, K):
            return s + 1
    return -1


def predict_sensitivity(rhs, x0, u, y, dt, *, gain, horizon=1, directions=None, free_x0=None, free_gain=False,
                        output_index=(0,), sensitivities=True, n_substeps=1, method="rk4", input_hold="zoh",
                        bounds=None, max_abs=np.inf):
    """The ``horizon``-step predictions of a constant-gain predictor and their sensitivities.

    Parameters
    ----------
    rhs : TermsRHS
    x0 : array-like of shape (n_states,)
        The first predicted state ``x[0|-1]``.
    u : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
        The measured outputs that correct the state.
    dt : float
    gain : array-like of shape (n_states, n_outputs)
        The constant observer gain ``K``.
    horizon : int, default=1
        Steps ahead of each prediction (1 = one-step predictor).
    directions : array-like of shape (n_coef_params, n_terms, n_states), optional
        ``dC/dp`` of each coefficient parameter.
    free_x0 : sequence of int, optional
        States whose initial value is a parameter.
    free_gain : bool, default=False
        The entries of ``gain`` (row by row) are parameters too, after those.
    output_index : sequence of int, default=(0,)
    sensitivities : bool, default=True
        False: the predictions only (``sens`` has no columns).
    n_substeps, method, input_hold, bounds, max_abs
        As in :func:`sindybench.simulate.simulate`.

    Returns
    -------
    x : ndarray of shape (n_samples, n_states)
        Predicted states (NaN after the filter diverged; NaN in the first
        column for a ``horizon``-step branch that diverged).
    sens : ndarray of shape (n_samples, n_outputs, n_params)
    diverged : int
        The sample where the filter diverged, or -1.

    Examples
    --------
    ``x' = -x`` measured exactly: the corrected prediction with ``K = 1`` is
    the model's step from the measurement, and the one-step errors vanish.

    >>> from sindybench.libraries import POW
    >>> from sindybench.simulate import simulate
    >>> rhs = TermsRHS([[-1.0]], [((0, POW, 1, 0),)], 1)
    >>> y = simulate(rhs, [1.0], np.zeros((5, 0)), 0.1)
    >>> x, s, bad = predict_sensitivity(rhs, [0.5], np.zeros((5, 0)), y, 0.1, gain=[[1.0]], free_x0=[0])
    >>> bool(np.allclose(x[1:], y[1:])), s[1:, 0, 0].tolist(), bad
    (True, [0.0, 0.0, 0.0, 0.0], -1)
    """
    if not isinstance(rhs, TermsRHS):
        raise ValueError(f"rhs must be a TermsRHS for the compiled predictor; got {type(rhs).__name__}.")
    st, u, x0 = simulation_settings(rhs.n_states, u, x0, dt, n_substeps=n_substeps, method=method,
                                    input_hold=input_hold, bounds=bounds, max_abs=max_abs)
    n = rhs.n_states
    oidx = np.asarray(output_index, dtype=np.int64)
    # own writable copies: a read-only array (a memory map) would compile the kernels a second time
    y = np.array(y, dtype=float, order="C").reshape(u.shape[0], oidx.size)
    gain = np.array(gain, dtype=float, order="C").reshape(n, oidx.size)
    if not sensitivities:
        out_x = np.zeros((u.shape[0], n))
        with np.errstate(all="ignore"):
            bad = run_predictor_state(x0, y, gain, int(horizon), u, st.h, st.n_sub, st.offsets, st.weights,
                                      st.linear, st.lo, st.hi, st.max_abs, rhs._arrays, rhs.user, oidx, out_x)
        out_s = np.zeros((u.shape[0], oidx.size, 0))
        return _diverged(out_x, out_s, bad)
    terms, coef, par = sensitivity_arrays(rhs, directions)
    free_x0 = np.array([] if free_x0 is None else free_x0, dtype=np.int64).reshape(-1)
    n_coef = par[0].shape[0] - 1
    gcol = n_coef + free_x0.size if free_gain else -1
    q = n_coef + free_x0.size + (gain.size if free_gain else 0)
    S0 = np.zeros((n, q))
    S0[free_x0, n_coef + np.arange(free_x0.size)] = 1.0
    out_x = np.zeros((u.shape[0], n))
    out_s = np.zeros((u.shape[0], oidx.size, q))
    with np.errstate(all="ignore"):
        bad = run_predictor(x0, S0, y, gain, gcol, int(horizon), u, st.h, st.n_sub, st.offsets, st.weights,
                            st.linear, st.lo, st.hi, st.max_abs, terms, coef, par, rhs.user, oidx, out_x, out_s)
    return _diverged(out_x, out_s, bad)


def _diverged(out_x, out_s, bad):
    """NaN from the sample where the filter diverged on, and in the rows of diverged branches."""
    if bad >= 0:
        out_x[bad:] = np.nan
        out_s[bad:] = np.nan
    branch = ~np.isfinite(out_x[:, 0])
    out_x[branch] = np.nan
    out_s[branch] = np.nan
    return out_x, out_s, int(bad)

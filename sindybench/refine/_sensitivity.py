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
from numba import njit

from .._validation import check_bounds, check_integer, check_option, check_positive, check_signal
from ..libraries._terms import terms_to_arrays
from ..simulate import _HOLDS, _METHODS, _STAGES, SimulationError, TermsRHS, _check_steps, _check_x0, _power

__all__ = ["simulate_sensitivity"]


@njit(cache=True, inline="always")
def _factor(v, o, a, b):
    """Value and derivative of one factor ``op(v)``."""
    if o == 0:  # POW, valued exactly as the simulator does
        if a == 0.0:
            return _power(v, a), 0.0
        return _power(v, a), a * _power(v, a - 1.0)
    if o == 1:  # ABS_POW; at 0 the derivative is taken as 0 (sign(0) = 0, also for a < 1)
        w = abs(v)
        if a == 0.0 or v == 0.0:
            return _power(w, a), 0.0
        return _power(w, a), a * _power(w, a - 1.0) * (1.0 if v > 0.0 else -1.0)
    if o == 2:  # SQRT of clip(v, a, b)
        if v <= a:
            return np.sqrt(a), 0.0
        if v >= b:
            return np.sqrt(b), 0.0
        r = np.sqrt(v)
        return r, 0.5 / r
    if o == 4:  # STEP
        return (1.0 if a <= v <= b else 0.0), 0.0
    # SIGN
    if v > 0.0:
        return 1.0, 0.0
    if v < 0.0:
        return -1.0, 0.0
    return 0.0 * v, 0.0  # sign(0) = 0, sign(nan) = nan


@njit(cache=True, inline="always")
def _eval(z, n, ptr, col, op, a, b, coef, theta, fv, fd, jac, K, dK, dz, ppar, pterm, pstate, pw, s, lo, hi):
    """K[s] = f(z), dK[s] = df/dz dz + df/dp at stage ``s`` (dK rows zeroed where K is)."""
    n_terms = ptr.shape[0] - 1
    n_par = dK.shape[2]
    for i in range(n):
        for c in range(n):
            jac[i, c] = 0.0
    for f in range(col.shape[0]):  # every factor once: value and derivative
        fv[f], fd[f] = _factor(z[col[f]], op[f], a[f], b[f])
    for j in range(n_terms):
        value = 1.0
        for f in range(ptr[j], ptr[j + 1]):
            value *= fv[f]
        theta[j] = value
        for f in range(ptr[j], ptr[j + 1]):
            c = col[f]
            if c >= n or fd[f] == 0.0:
                continue
            d = fd[f]
            for g in range(ptr[j], ptr[j + 1]):
                if g != f:
                    d *= fv[g]
            for i in range(n):
                if coef[j, i] != 0.0:
                    jac[i, c] += coef[j, i] * d
    for i in range(n):
        acc = 0.0
        for j in range(n_terms):
            if coef[j, i] != 0.0:  # as the simulator, which skips zero coefficients (0 * nan)
                acc += coef[j, i] * theta[j]
        K[s, i] = acc
    for i in range(n):
        for p in range(n_par):
            acc = 0.0
            for c in range(n):
                if jac[i, c] != 0.0:
                    acc += jac[i, c] * dz[c, p]
            dK[s, i, p] = acc
    for p in range(ppar.shape[0] - 1):
        for e in range(ppar[p], ppar[p + 1]):
            dK[s, pstate[e], p] += pw[e] * theta[pterm[e]]
    for i in range(n):
        if (z[i] <= lo[i] and K[s, i] < 0.0) or (z[i] >= hi[i] and K[s, i] > 0.0):
            K[s, i] = 0.0
            for p in range(n_par):
                dK[s, i, p] = 0.0


@njit(cache=True)
def _run_sensitivity(x0, S0, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, terms, coef, par, oidx,
                     out_x, out_s, s_end):
    """Integrate state and sensitivities; return the first invalid step or -1."""
    ptr, col, op, a, b = terms
    ppar, pterm, pstate, pw = par
    n = x0.shape[0]
    q = S0.shape[1]
    n_st = offsets.shape[0]
    x = x0.copy()
    S = S0.copy()
    z = np.empty(n + u.shape[1])
    dz = np.zeros((n, q))
    theta = np.empty(ptr.shape[0] - 1)
    fv = np.empty(col.shape[0])
    fd = np.empty(col.shape[0])
    jac = np.zeros((n, n))
    K = np.zeros((n_st, n))
    dK = np.zeros((n_st, n, q))
    for i in range(n):
        out_x[0, i] = x[i]
    for r in range(oidx.shape[0]):
        for p in range(q):
            out_s[0, r, p] = S[oidx[r], p]
    for k in range(out_x.shape[0] - 1):
        hs = h[k] / n_sub
        k1 = k + 1 if linear else k
        for j in range(n_sub):
            for s in range(n_st):
                c = offsets[s]
                for i in range(n):
                    zi = x[i] + c * hs * K[s - 1, i] if c != 0.0 else x[i]
                    clipped = False
                    if zi <= lo[i]:
                        clipped = True
                        zi = lo[i]
                    elif zi >= hi[i]:
                        clipped = True
                        zi = hi[i]
                    z[i] = zi
                    if clipped:
                        for p in range(q):
                            dz[i, p] = 0.0
                    elif c != 0.0:
                        for p in range(q):
                            dz[i, p] = S[i, p] + c * hs * dK[s - 1, i, p]
                    else:
                        for p in range(q):
                            dz[i, p] = S[i, p]
                frac = (j + c) / n_sub
                for i in range(u.shape[1]):
                    z[n + i] = u[k, i] + frac * (u[k1, i] - u[k, i])
                _eval(z, n, ptr, col, op, a, b, coef, theta, fv, fd, jac, K, dK, dz, ppar, pterm, pstate, pw, s, lo,
                      hi)
            bad = False
            for i in range(n):
                incr = 0.0
                for s in range(n_st):
                    incr += weights[s] * K[s, i]
                x[i] += hs * incr
                at_bound = False
                if x[i] <= lo[i]:
                    x[i] = lo[i]
                    at_bound = True
                elif x[i] >= hi[i]:
                    x[i] = hi[i]
                    at_bound = True
                if at_bound:
                    for p in range(q):
                        S[i, p] = 0.0
                else:
                    for p in range(q):
                        incr = 0.0
                        for s in range(n_st):
                            incr += weights[s] * dK[s, i, p]
                        S[i, p] += hs * incr
                if not (abs(x[i]) <= max_abs and abs(x[i]) < np.inf):
                    bad = True
            if bad:
                for i in range(n):
                    out_x[k + 1, i] = x[i]
                return k + 1
        for i in range(n):
            out_x[k + 1, i] = x[i]
        for r in range(oidx.shape[0]):
            for p in range(q):
                out_s[k + 1, r, p] = S[oidx[r], p]
    for i in range(n):
        for p in range(q):
            s_end[i, p] = S[i, p]
    return -1


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
    u = np.ascontiguousarray(check_signal(u, "u"))
    n = rhs.n_states
    n_terms = len(rhs.terms)
    h, t = _check_steps(dt, None, u.shape[0])
    lo, hi = check_bounds(bounds, n)
    x0 = _check_x0(x0, n, lo, hi)
    check_option(method, "method", _METHODS)
    check_option(input_hold, "input_hold", _HOLDS)
    check_option(on_divergence, "on_divergence", ("raise", "nan"))
    n_substeps = check_integer(n_substeps, "n_substeps")
    max_abs = check_positive(max_abs, "max_abs", allow_inf=True)
    if directions is None:
        directions = np.zeros((0, n_terms, n))
    ppar, pterm, pstate, pw = _directions_to_arrays(directions, n_terms, n)
    free_x0 = np.array([] if free_x0 is None else free_x0, dtype=np.int64).reshape(-1)
    oidx = np.arange(n, dtype=np.int64) if output_index is None else np.asarray(output_index, dtype=np.int64)
    for name, idx in (("free_x0", free_x0), ("output_index", oidx)):
        if idx.size and (idx.min() < 0 or idx.max() >= n):
            raise ValueError(f"{name} = {idx.tolist()} has a state index outside [0, {n - 1}].")
    n_coef = ppar.shape[0] - 1
    q = n_coef + free_x0.size
    S0 = np.zeros((n, q))
    S0[free_x0, n_coef + np.arange(free_x0.size)] = 1.0
    # evaluate only terms with a nonzero coefficient or a direction
    used = np.any(rhs.coef != 0, axis=1)
    used[pterm] = True
    keep = np.flatnonzero(used)
    remap = np.full(n_terms, -1, dtype=np.int64)
    remap[keep] = np.arange(keep.size)
    terms = terms_to_arrays([rhs.terms[j] for j in keep])
    coef = np.ascontiguousarray(rhs.coef[keep])
    offsets, weights = (np.array(v) for v in _STAGES[method])
    out_x = np.empty((u.shape[0], n))
    out_s = np.zeros((u.shape[0], oidx.size, q))
    s_end = np.zeros((n, q))
    step = _run_sensitivity(x0, S0, u, h, n_substeps, offsets, weights, input_hold == "linear", lo, hi, max_abs,
                            terms, coef, (ppar, remap[pterm], pstate, pw), oidx, out_x, out_s, s_end)
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

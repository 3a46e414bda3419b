"""The compiled integrator: one output sample of the model's own Runge-Kutta map, with or without sensitivities.

Everything here is a numba function over flattened arrays; :mod:`._simulate`
(open-loop runs), :mod:`._step` (the public one-step map) and
:func:`sindybench.refine.simulate_sensitivity` call these very functions, so
a state computed one way is bit for bit the state computed the other ways.

Explicit Runge-Kutta: stage ``s`` of a sub-step of length ``hs`` evaluates
``f`` at ``clip(x + offsets[s] hs K[s-1])`` and the input
``u[k] + frac (u[k1] - u[k])`` (``k1 = k`` for a zero-order hold); the step
adds ``hs sum_s weights[s] K[s]`` and clips. At a bound a derivative pointing
outward is zeroed. The sensitivity version propagates ``S = dx/dp`` through
the same arithmetic (the exact derivative of the discrete map).
"""

import numpy as np
from numba import njit, types
from numba.extending import overload

from ._ops import apply_factor, apply_op, call_rows, op_derivative, op_value

__all__ = ["run_sensitivity", "run_sensitivity_into", "run_state", "run_state_into", "sensitivity_work",
           "step_sensitivity", "step_state"]


# ------------------------------------------------------------------ state only
def _add_rows(fn, z, par, out, K, s, first):
    """``K[s, first + r] += fn(z, par)[r]``; compiled away for a model without rows (``fn`` None)."""


@overload(_add_rows, inline="always")
def _add_rows_impl(fn, z, par, out, K, s, first):
    if isinstance(fn, types.NoneType):
        return lambda fn, z, par, out, K, s, first: None

    def add(fn, z, par, out, K, s, first):
        call_rows(fn, z, par, out)
        for r in range(out.shape[0]):
            K[s, first + r] += out[r]

    return add


@njit(cache=True, inline="always")
def _terms_rhs(z, model, user, theta, K, s):
    """K[s, i] = sum_k theta[rows[k]] vals[k] over k in rptr[i]:rptr[i+1], theta = terms(z).

    With a compiled rows function (``fn`` an address, else None), ``K[s, first + r] += out[r]``
    for ``out = fn(z, par)`` (:mod:`._rows`).
    """
    ptr, col, op, a, b, rptr, rows, vals, fn, par, out, first = model
    for j in range(ptr.shape[0] - 1):
        value = 1.0
        for f in range(ptr[j], ptr[j + 1]):
            value = apply_op(value, op[f], z[col[f]], a[f], b[f], user)
        theta[j] = value
    for i in range(rptr.shape[0] - 1):
        acc = 0.0
        for k in range(rptr[i], rptr[i + 1]):
            acc += theta[rows[k]] * vals[k]
        K[s, i] = acc
    _add_rows(fn, z, par, out, K, s, first)


@njit(cache=True, inline="always")
def _clip(x, lo, hi):
    for i in range(lo.shape[0]):
        if x[i] < lo[i]:
            x[i] = lo[i]
        elif x[i] > hi[i]:
            x[i] = hi[i]


@njit(cache=True, inline="always")
def _invalid(v, max_abs):
    return not (abs(v) <= max_abs and abs(v) < np.inf)


@njit(cache=True, inline="always")
def _inputs(z, n, u, k, k1, frac):
    for i in range(u.shape[1]):
        z[n + i] = u[k, i] + frac * (u[k1, i] - u[k, i])


@njit(cache=True, inline="always")
def _stage(x, K, s, c, hs, u, k, k1, frac, z, lo, hi, model, user, theta):
    """K[s] = f at state clip(x + c hs K[s-1]) and input u[k] + frac (u[k1] - u[k])."""
    n = x.shape[0]
    for i in range(n):
        z[i] = x[i] + c * hs * K[s - 1, i] if c != 0.0 else x[i]
    _clip(z, lo, hi)
    _inputs(z, n, u, k, k1, frac)
    _terms_rhs(z, model, user, theta, K, s)
    for i in range(n):
        if (z[i] <= lo[i] and K[s, i] < 0.0) or (z[i] >= hi[i] and K[s, i] > 0.0):
            K[s, i] = 0.0


@njit(cache=True, inline="always")
def step_state(x, u, k, k1, h, n_sub, offsets, weights, lo, hi, max_abs, model, user, z, theta, K):
    """Advance ``x`` in place over one output sample of length ``h`` (``n_sub`` sub-steps).

    ``u[k]`` and ``u[k1]`` are the inputs at the start and end of the sample
    (``k1 = k`` for a zero-order hold). ``z`` (n + n_inputs), ``theta``
    (n_terms) and ``K`` (n_stages, n) are work arrays. Returns True if the
    state diverged (``x`` is then the state of the sub-step where it did).
    """
    n = x.shape[0]
    hs = h / n_sub
    for j in range(n_sub):
        for s in range(offsets.shape[0]):
            frac = (j + offsets[s]) / n_sub
            _stage(x, K, s, offsets[s], hs, u, k, k1, frac, z, lo, hi, model, user, theta)
        for i in range(n):
            incr = 0.0
            for s in range(offsets.shape[0]):
                incr += weights[s] * K[s, i]
            x[i] += hs * incr
        _clip(x, lo, hi)
        bad = False
        for i in range(n):
            bad = bad or _invalid(x[i], max_abs)
        if bad:
            return True
    return False


def run_state(x0, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, model, user, out):
    """Integrate into ``out``; return the first invalid step or -1.

    Python: the work arrays come from NumPy, so that the one compiled loop is
    :func:`run_state_into` (a compiled wrapper cost about 1 s more of compilation).
    """
    n = x0.shape[0]
    z = np.empty(n + u.shape[1])
    theta = np.empty(model[0].shape[0] - 1)
    K = np.zeros((offsets.shape[0], n))
    x = np.array(x0, dtype=np.float64, order="C")  # a copy
    return run_state_into(x, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, model, user, z, theta, K, out)


@njit(cache=True)
def run_state_into(x, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, model, user, z, theta, K, out):
    """:func:`run_state` from ``x`` (advanced in place) with the work arrays given: no allocation.

    The one compiled loop around :func:`step_state` (inlined here only): the free run, the
    one-step map (:func:`~sindybench.dynamics.step_into`, two samples) and the k-step prediction
    call it, so its compilation is paid once per process and model type.
    """
    n = x.shape[0]
    for i in range(n):
        out[0, i] = x[i]
    for k in range(out.shape[0] - 1):
        bad = step_state(x, u, k, k + 1 if linear else k, h[k], n_sub, offsets, weights, lo, hi, max_abs, model,
                         user, z, theta, K)
        for i in range(n):
            out[k + 1, i] = x[i]
        if bad:
            return k + 1
    return -1


# ------------------------------------------------------------ with sensitivity
@njit(cache=True, inline="always")
def _eval(z, n, terms, coef, user, par, work, s, lo, hi):
    """K[s] = f(z), dK[s] = df/dz dz + df/dp at stage ``s`` (dK rows zeroed where K is)."""
    ptr, col, op, a, b = terms
    ppar, pterm, pstate, pw = par
    dz, theta, fv, fd, jac, K, dK = work
    n_terms = ptr.shape[0] - 1
    n_par = dK.shape[2]
    for i in range(n):
        for c in range(n):
            jac[i, c] = 0.0
    for f in range(col.shape[0]):  # every factor once: value and derivative
        v = z[col[f]]
        fv[f] = op_value(op[f], v, a[f], b[f], user)
        fd[f] = op_derivative(op[f], v, fv[f], a[f], b[f], user) if n_par > 0 and col[f] < n else 0.0  # dz: states
    for j in range(n_terms):
        value = 1.0
        for f in range(ptr[j], ptr[j + 1]):
            value = apply_factor(value, op[f], fv[f])
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
        K[s, i] = 0.0
    for j in range(n_terms):  # each K[s, i] summed over j ascending, as before: the same bits, coef read by rows
        for i in range(n):
            if coef[j, i] != 0.0:  # as the state-only path, which skips zero coefficients (0 * nan)
                K[s, i] += coef[j, i] * theta[j]
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


@njit(cache=True, inline="always")
def sensitivity_work(n, n_inputs, n_terms, n_factors, n_stages, q):
    """Work arrays of :func:`step_sensitivity`: ``(z, (dz, theta, fv, fd, jac, K, dK))``."""
    return np.empty(n + n_inputs), (np.zeros((n, q)), np.empty(n_terms), np.empty(n_factors), np.empty(n_factors),
                                    np.zeros((n, n)), np.zeros((n_stages, n)), np.zeros((n_stages, n, q)))


@njit(cache=True, inline="always")
def step_sensitivity(x, S, u, k, k1, h, n_sub, offsets, weights, lo, hi, max_abs, terms, coef, par, user, z, work):
    """Advance ``x`` and ``S = dx/dp`` in place over one output sample; True if the state diverged.

    ``terms`` is ``(ptr, col, op, a, b)``, ``coef`` the dense coefficients
    (n_terms, n), ``par`` the coefficient directions ``(ppar, pterm, pstate,
    pw)``: parameter ``p`` moves ``coef[pterm[e], pstate[e]]`` by ``pw[e]`` for
    ``e`` in ``ppar[p]:ppar[p+1]``. ``z`` and ``work`` from :func:`sensitivity_work`.
    """
    n = x.shape[0]
    q = S.shape[1]
    n_st = offsets.shape[0]
    dz, K, dK = work[0], work[5], work[6]
    hs = h / n_sub
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
            _inputs(z, n, u, k, k1, (j + c) / n_sub)
            _eval(z, n, terms, coef, user, par, work, s, lo, hi)
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
            if _invalid(x[i], max_abs):
                bad = True
        if bad:
            return True
    return False


def run_sensitivity(x0, S0, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, terms, coef, par, user, oidx,
                    out_x, out_s, s_end):
    """Integrate state and sensitivities; return the first invalid step or -1.

    Python, as :func:`run_state`: the one compiled loop is :func:`run_sensitivity_into`.
    """
    z, work = sensitivity_work.py_func(x0.shape[0], u.shape[1], coef.shape[0], terms[1].shape[0], offsets.shape[0],
                                       S0.shape[1])
    x, S = np.array(x0, dtype=np.float64, order="C"), np.array(S0, dtype=np.float64, order="C")  # copies
    return run_sensitivity_into(x, S, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, terms, coef, par, user,
                                oidx, z, work, out_x, out_s, s_end)


@njit(cache=True)
def run_sensitivity_into(x, S, u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, terms, coef, par, user, oidx,
                         z, work, out_x, out_s, s_end):
    """:func:`run_sensitivity` from ``x`` and ``S`` (advanced in place), work arrays given: no allocation.

    The refinement's compiled loop around :func:`step_sensitivity` (the one-step Jacobian,
    :func:`~sindybench.dynamics.step_jacobian_into`, inlines the step itself: the Kalman filter
    calls it once per sample, where a call to this loop cost 18 % of the filter's time).
    """
    n = x.shape[0]
    q = S.shape[1]
    for i in range(n):
        out_x[0, i] = x[i]
    for r in range(oidx.shape[0]):
        for p in range(q):
            out_s[0, r, p] = S[oidx[r], p]
    for k in range(out_x.shape[0] - 1):
        bad = step_sensitivity(x, S, u, k, k + 1 if linear else k, h[k], n_sub, offsets, weights, lo, hi, max_abs,
                               terms, coef, par, user, z, work)
        for i in range(n):
            out_x[k + 1, i] = x[i]
        if bad:
            return k + 1
        for r in range(oidx.shape[0]):
            for p in range(q):
                out_s[k + 1, r, p] = S[oidx[r], p]
    for i in range(n):
        for p in range(q):
            s_end[i, p] = S[i, p]
    return -1

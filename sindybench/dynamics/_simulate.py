"""Fixed-step open-loop simulation of continuous-time models with inputs.

The right-hand side is either a :class:`TermsRHS` (``dx/dt = theta([x, u]) @ coef``
with ``theta`` made of library terms, built-in or compiled user operations),
integrated by the numba-compiled kernel of :mod:`._kernels` that interprets the
flattened terms (no Python per step), or any Python callable ``f(x, u) -> dxdt``,
integrated by a plain Python loop with the same semantics (sub-steps, input
hold, bounds, divergence).
"""

import logging
from typing import NamedTuple

import numpy as np

from .._validation import check_bounds, check_dt, check_integer, check_option, check_positive, check_signal, check_time
from ._kernels import run_state
from ._terms import check_terms, evaluate_terms, evaluate_terms_jacobian, terms_to_arrays, user_ops_of

__all__ = ["Settings", "SimulationError", "TermsRHS", "simulate", "simulation_settings"]

logger = logging.getLogger(__name__)

_METHODS = ("rk4", "euler")
_HOLDS = ("zoh", "linear")
_ON_DIVERGENCE = ("raise", "nan")
# stage offsets (fraction of a sub-step) and weights
_STAGES = {"rk4": ((0.0, 0.5, 0.5, 1.0), (1 / 6, 1 / 3, 1 / 3, 1 / 6)), "euler": ((0.0,), (1.0,))}


class SimulationError(RuntimeError):
    """A simulation diverged (non-finite state or ``|x| > max_abs``).

    Attributes
    ----------
    step : int
        Index of the first output sample whose state is invalid.
    state : ndarray or None
        That state.

    Examples
    --------
    ``dx/dt = x^2`` from ``x(0) = 1`` blows up at ``t = 1``:

    >>> try:
    ...     simulate(lambda x, u: x**2, [1.0], np.zeros((30, 0)), 0.1)
    ... except SimulationError as exc:
    ...     print(exc.step, exc.state)
    13 [inf]

    With ``on_divergence="nan"`` the samples from that step on are NaN instead:

    >>> x = simulate(lambda x, u: x**2, [1.0], np.zeros((30, 0)), 0.1, on_divergence="nan")
    >>> int(np.argmax(np.isnan(x[:, 0])))
    13
    """

    def __init__(self, message, *, step, state=None):
        super().__init__(message)
        self.step = step
        self.state = state


class TermsRHS:
    """Right-hand side ``dx/dt = evaluate_terms(terms, [x, u]) @ coef``.

    Parameters
    ----------
    coef : array-like of shape (n_terms, n_states)
        Column ``i`` holds the coefficients of ``x_i'``.
    terms : sequence of tuple
        Terms over ``Z = [x, u]`` (see :mod:`sindybench.libraries._terms`),
        e.g. a fitted library's ``terms_``; JSON form accepted.
    n_states : int
        Number of states (the first columns of ``Z``).

    Notes
    -----
    Terms whose coefficients are all zero are skipped by the compiled
    simulator, so a sparse model over a large library costs what its active
    terms cost. Instances are callable, ``rhs(x, u)``, in plain numpy.

    Examples
    --------
    >>> from sindybench.libraries import POW
    >>> rhs = TermsRHS([[-1.0], [2.0]], [((0, POW, 1, 0),), ((1, POW, 1, 0),)], 1)
    >>> rhs(np.array([3.0]), np.array([1.0]))
    array([-1.])
    """

    def __init__(self, coef, terms, n_states):
        n_states = check_integer(n_states, "n_states")
        coef = np.asarray(coef, dtype=float)
        if coef.ndim == 1 and n_states == 1:
            coef = coef.reshape(-1, 1)
        if coef.ndim != 2 or coef.shape[1] != n_states:
            raise ValueError(f"coef has shape {coef.shape}; expected (n_terms, n_states={n_states}).")
        if not np.all(np.isfinite(coef)):
            raise ValueError("coef contains NaN or inf; expected finite coefficients.")
        terms = check_terms(terms)
        if len(terms) != coef.shape[0]:
            raise ValueError(
                f"coef has {coef.shape[0]} rows but there are {len(terms)} terms; expected one row per term."
            )
        self.coef = coef
        self.terms = terms
        self.n_states = n_states
        self.n_variables = 1 + max((f[0] for t in terms for f in t), default=-1)
        active = np.flatnonzero(np.any(coef != 0, axis=1))
        sub = coef[active]
        rptr = np.zeros(n_states + 1, dtype=np.int64)
        rptr[1:] = np.cumsum(np.count_nonzero(sub, axis=0))
        rows, cols = np.nonzero(sub.T)  # grouped by state
        # compiled evaluation: flattened active terms + per-state sparse coefficients
        self._arrays = (*terms_to_arrays([terms[j] for j in active]), rptr, cols.astype(np.int64), sub[cols, rows],
                        *NO_ROWS)
        self.n_active = len(active)

    @classmethod
    def from_equations(cls, equations):
        """Build from one ``{term: coefficient}`` dict per state.

        Useful for models with fixed structural rows, e.g. ``y' = v``,
        ``v' = (u - c v - k y - z) / m`` and learned ``z'``.

        Examples
        --------
        >>> from sindybench.libraries import POW
        >>> y, v = ((0, POW, 1, 0),), ((1, POW, 1, 0),)
        >>> rhs = TermsRHS.from_equations([{v: 1.0}, {y: -4.0, v: -0.1}])
        >>> rhs.coef.shape, rhs(np.array([1.0, 0.0]), np.zeros(0)).tolist()
        ((2, 2), [0.0, -4.0])
        """
        if isinstance(equations, dict) or len(equations) == 0:
            raise ValueError("equations must be a non-empty sequence of {term: coefficient} dicts, one per state.")
        terms = list(dict.fromkeys(t for eq in equations for t in check_terms(list(eq))))
        index = {t: j for j, t in enumerate(terms)}
        coef = np.zeros((len(terms), len(equations)))
        for i, eq in enumerate(equations):
            for term, c in zip(check_terms(list(eq)), eq.values()):
                coef[index[term], i] += c
        return cls(coef, terms, len(equations))

    _compiled = True  # simulated by the compiled kernel

    def __reduce__(self):  # the flattened arrays hold process-local user op codes: rebuild them
        return (type(self), (self.coef, self.terms, self.n_states))

    @property
    def user(self):
        """The compiled table of the user operations in the terms (see :mod:`sindybench.dynamics`)."""
        return user_ops_of(self.terms)

    def __call__(self, x, u):
        z = np.concatenate([np.asarray(x, dtype=float), np.asarray(u, dtype=float)])[None, :]
        return evaluate_terms(self.terms, z)[0] @ self.coef

    def jacobian(self, x, u):
        """``f(x, u)`` and its exact Jacobian ``df / d[x, u]``, from the terms' derivatives (no finite differences).

        Only nonzero coefficients count (``0 * inf`` is not 0: a term whose
        derivative is infinite there, a square root at zero, adds nothing when
        it is not in the model).

        Parameters
        ----------
        x : array-like of shape (n_states,)
        u : array-like of shape (n_inputs,)

        Returns
        -------
        f : ndarray of shape (n_states,)
        jacobian : ndarray of shape (n_states, n_states + n_inputs)

        Examples
        --------
        >>> from sindybench.libraries import POW
        >>> rhs = TermsRHS([[-1.0], [2.0]], [((0, POW, 2, 0),), ((1, POW, 1, 0),)], 1)  # x' = -x^2 + 2 u
        >>> f, jac = rhs.jacobian(np.array([3.0]), np.array([1.0]))
        >>> f.tolist(), jac.tolist()
        ([-7.0], [[-6.0, 2.0]])
        """
        z = np.concatenate([np.asarray(x, dtype=float).reshape(-1), np.asarray(u, dtype=float).reshape(-1)])[None, :]
        coef = self.coef.T[:, :, None]  # (n_states, n_terms, 1)
        f = np.where(coef[:, :, 0] != 0, coef[:, :, 0] * evaluate_terms(self.terms, z), 0.0).sum(axis=1)
        jac = np.where(coef != 0, coef * evaluate_terms_jacobian(self.terms, z)[0], 0.0).sum(axis=1)
        return f, jac

    def __repr__(self):
        return f"TermsRHS(n_terms={len(self.terms)}, n_active={self.n_active}, n_states={self.n_states})"


NO_ROWS = (None, np.zeros(0), np.zeros(0), 0)
"""The rows part of a model without a compiled rows function (see :mod:`._rows`)."""


# ------------------------------------------------------------------- Python path
def _run_python(f, x0, u, h, n_sub, method, linear, lo, hi, max_abs, out):
    """Same semantics as :func:`._kernels.run_state` for a Python callable ``f(x, u)``."""
    offsets, weights = _STAGES[method]
    x = x0.copy()
    n = x.shape[0]
    out[0] = x
    for k in range(out.shape[0] - 1):
        hs = h[k] / n_sub
        du = (u[k + 1] - u[k]) if linear else 0.0 * u[k]
        for j in range(n_sub):
            incr = np.zeros(n)
            kprev = np.zeros(n)
            for c, w in zip(offsets, weights):
                xs = np.clip(x + c * hs * kprev, lo, hi)
                dx = np.asarray(f(xs, u[k] + (j + c) / n_sub * du), dtype=float)
                if dx.shape != (n,):
                    raise ValueError(f"rhs returned shape {dx.shape}; expected ({n},) (one derivative per state).")
                dx = np.where(((xs <= lo) & (dx < 0)) | ((xs >= hi) & (dx > 0)), 0.0, dx)
                incr += w * dx
                kprev = dx
            x = np.clip(x + hs * incr, lo, hi)
            if not np.all((np.abs(x) <= max_abs) & np.isfinite(x)):
                out[k + 1] = x
                return k + 1
        out[k + 1] = x
    return -1


# ------------------------------------------------------------------ public entry
def _check_steps(dt, t, n_samples):
    if (dt is None) == (t is None):
        raise ValueError(f"give exactly one of dt and t; got dt={dt!r} and t={'None' if t is None else 'an array'}.")
    if t is not None:
        t = check_time(t, n_samples)
        return np.diff(t), t
    dt = check_dt(dt)
    return np.full(n_samples - 1, dt), None


def _check_x0(x0, n_states, lo, hi):
    x0 = np.asarray(x0, dtype=float)
    if x0.ndim != 1 or x0.shape[0] != n_states:
        raise ValueError(f"x0 has shape {x0.shape}; expected ({n_states},) (one value per state).")
    if not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 = {x0} contains NaN or inf; expected finite values.")
    outside = (x0 < lo) | (x0 > hi)
    if outside.any():
        i = int(np.argmax(outside))
        raise ValueError(
            f"x0[{i}] = {x0[i]:g} is outside bounds [{lo[i]:g}, {hi[i]:g}]; expected a state within bounds."
        )
    return x0


class Settings(NamedTuple):
    """Checked simulation settings as the compiled kernels take them."""

    h: np.ndarray  # step length of each output sample, (n_samples - 1,)
    n_sub: int
    offsets: np.ndarray  # Runge-Kutta stage offsets (fractions of a sub-step)
    weights: np.ndarray
    linear: bool  # linear input hold (else zero-order)
    lo: np.ndarray
    hi: np.ndarray
    max_abs: float
    t: np.ndarray  # the sample times if given, else None


def simulation_settings(n_states, u, x0, dt, *, t=None, n_substeps=1, method="rk4", input_hold="zoh", bounds=None,
                        max_abs=np.inf, on_divergence="raise"):
    """Check the arguments of :func:`simulate`; return ``(Settings, u, x0)`` (``u`` C-contiguous float).

    ``x0=None`` skips the initial-state check (and returns None for it).
    """
    if u is None:
        raise ValueError("u is None; expected inputs of shape (n_samples, n_inputs), with 0 columns if there are none.")
    u = np.ascontiguousarray(check_signal(u, "u"))  # (n_samples, 0) passes: no inputs
    h, t = _check_steps(dt, t, u.shape[0])
    lo, hi = check_bounds(bounds, n_states)
    if x0 is not None:
        x0 = _check_x0(x0, n_states, lo, hi)
    n_substeps = check_integer(n_substeps, "n_substeps")
    check_option(method, "method", _METHODS)
    check_option(input_hold, "input_hold", _HOLDS)
    check_option(on_divergence, "on_divergence", _ON_DIVERGENCE)
    max_abs = check_positive(max_abs, "max_abs", allow_inf=True)
    offsets, weights = (np.array(v) for v in _STAGES[method])
    return Settings(h, n_substeps, offsets, weights, input_hold == "linear", lo, hi, max_abs, t), u, x0


def _check_columns(rhs, u):
    n_states = rhs.n_states
    if rhs.n_variables > n_states + u.shape[1]:
        raise ValueError(
            f"rhs terms use column {rhs.n_variables - 1} of Z = [x, u], but there are {n_states} states and "
            f"{u.shape[1]} inputs; expected u with at least {rhs.n_variables - n_states} columns."
        )


def simulate(rhs, x0, u, dt=None, *, t=None, n_substeps=1, method="rk4", input_hold="zoh", bounds=None,
             max_abs=np.inf, on_divergence="raise"):
    """Simulate ``x' = rhs(x, u)`` open loop at the sample times of ``u``.

    Parameters
    ----------
    rhs : TermsRHS or callable
        A :class:`TermsRHS` is integrated by a compiled kernel; a callable
        ``f(x, u) -> dxdt`` (1-D arrays) by a Python loop with the same semantics.
    x0 : array-like of shape (n_states,)
        Initial state, returned as the first row.
    u : array-like of shape (n_samples, n_inputs)
        Inputs at the sample times (``n_inputs`` may be 0); 1-D means one input.
    dt : float, optional
        Sampling interval. Give either ``dt`` or ``t``.
    t : array-like of shape (n_samples,), optional
        Strictly increasing (possibly non-uniform) sample times.
    n_substeps : int, default=1
        Integration steps per sampling interval.
    method : {"rk4", "euler"}, default="rk4"
        Classical fourth-order Runge-Kutta or explicit Euler.
    input_hold : {"zoh", "linear"}, default="zoh"
        Hold ``u[k]`` over ``[t_k, t_k+1)``, or interpolate linearly between
        ``u[k]`` and ``u[k+1]`` at every stage time.
    bounds : (lower, upper), optional
        State bounds (scalars or one per state; None or inf = unbounded): the
        state is clipped after every (sub-)step, every stage is evaluated at a
        clipped state, and a derivative pushing outward at a bound is zeroed.
    max_abs : float, default=inf
        A state with ``|x_i| > max_abs`` (or not finite) means divergence.
    on_divergence : {"raise", "nan"}, default="raise"
        Raise :class:`SimulationError`, or return with NaN from the diverged
        sample on.

    Returns
    -------
    x : ndarray of shape (n_samples, n_states)

    Raises
    ------
    SimulationError
        On divergence with ``on_divergence="raise"``; ``step`` is the row index.

    Examples
    --------
    >>> from sindybench.libraries import POW
    >>> rhs = TermsRHS([[-1.0]], [((0, POW, 1, 0),)], 1)   # x' = -x
    >>> x = simulate(rhs, [1.0], np.zeros((11, 0)), dt=0.1)
    >>> round(float(x[-1, 0]), 6), round(float(np.exp(-1.0)), 6)
    (0.367879, 0.367879)
    """
    compiled = getattr(type(rhs), "_compiled", False)  # a TermsRHS or a RowsRHS
    if compiled:
        n_states = rhs.n_states
    elif callable(rhs):
        n_states = np.asarray(x0).reshape(-1).shape[0]
    else:
        raise ValueError(f"rhs must be a TermsRHS or a callable f(x, u); got {rhs!r}.")
    st, u, x0 = simulation_settings(n_states, u, x0, dt, t=t, n_substeps=n_substeps, method=method,
                                    input_hold=input_hold, bounds=bounds, max_abs=max_abs, on_divergence=on_divergence)
    if compiled:
        _check_columns(rhs, u)
    h, t, n_samples = st.h, st.t, u.shape[0]
    out = np.empty((n_samples, n_states))
    if compiled:
        step = run_state(x0, u, h, st.n_sub, st.offsets, st.weights, st.linear, st.lo, st.hi, st.max_abs,
                         rhs._arrays, rhs.user, out)
    else:
        with np.errstate(over="ignore", invalid="ignore"):  # divergence is reported below
            step = _run_python(rhs, x0, u, h, st.n_sub, method, st.linear, st.lo, st.hi, st.max_abs, out)
    if step < 0:
        return out
    when = t[step] if t is not None else step * h[0]
    state = out[step].copy()
    msg = (f"simulation diverged at step {step} of {n_samples} (t = {when:g}): state {state} "
           f"{'is not finite' if not np.all(np.isfinite(state)) else f'exceeds max_abs = {max_abs:g}'}.")
    if on_divergence == "raise":
        raise SimulationError(msg, step=int(step), state=state)
    logger.debug("%s Filling NaN from there.", msg)
    out[step:] = np.nan
    return out

"""Continuous-discrete extended Kalman filter and Rauch-Tung-Striebel smoother.

The state is propagated from sample to sample by the fitted model's own
integrator (the public one-step map of :mod:`sindybench.dynamics`, the
simulator's step: Runge-Kutta stages, sub-steps, input hold, bounds) and the
covariance by the exact Jacobian ``F`` of that step,
``P <- F P F' + Q``; each measured sample then updates the measured states
(the model's output states, ``H`` a selection) in Joseph form. The loop over
samples, the smoother's backward pass included, is compiled with numba.
"""

from typing import NamedTuple

import numpy as np
from numba import njit

from .._limits import shown
from .._validation import check_signal
from .._records import check_one_record
from ..dynamics import jacobian_workspace, step_jacobian_into
from ._model_step import model_step

#: What a filter or smoother given several records says to do instead.
ONE_RECORD_ADVICE = "call it once per record; a model fitted on several records filters any one of them"

__all__ = ["FilterDivergenceError", "KalmanResult", "extended_kalman_filter", "rts_smoother"]

_LOG_2PI = float(np.log(2 * np.pi))


class FilterDivergenceError(RuntimeError):
    """The filter diverged: the model's step blew up or a covariance lost positive definiteness.

    Attributes
    ----------
    step : int
        Index of the sample where it happened.
    """

    def __init__(self, message, *, step):
        super().__init__(message)
        self.step = step


class KalmanResult(NamedTuple):
    """What :func:`extended_kalman_filter` and :func:`rts_smoother` return.

    Attributes
    ----------
    states : ndarray of shape (n_samples, n_states)
        Filtered states ``x[k|k]`` (smoothed ``x[k|N]`` for the smoother).
    covariances : ndarray of shape (n_samples, n_states, n_states)
        Their covariances.
    filtered_states, filtered_covariances : ndarray
        The filter's ``x[k|k]`` and ``P[k|k]`` (the same arrays as ``states``
        and ``covariances`` for the filter).
    innovations : ndarray of shape (n_samples, n_outputs)
        ``y[k] - x[k|k-1][output_index]``.
    innovation_covariances : ndarray of shape (n_samples, n_outputs, n_outputs)
    log_likelihood : float
        Gaussian log-likelihood of the innovations.
    """

    states: np.ndarray
    covariances: np.ndarray
    filtered_states: np.ndarray
    filtered_covariances: np.ndarray
    innovations: np.ndarray
    innovation_covariances: np.ndarray
    log_likelihood: float


# ------------------------------------------------------------ small dense algebra
@njit(cache=True, inline="always")
def _cholesky(A, L):
    """Lower Cholesky factor of ``A`` into ``L``; False when ``A`` is not positive definite."""
    n = A.shape[0]
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
        for i in range(j):
            L[i, j] = 0.0
    return True


@njit(cache=True, inline="always")
def _cho_solve(L, B):
    """Solve ``L L' X = B`` in place (``B`` of shape (n, r))."""
    n = L.shape[0]
    for c in range(B.shape[1]):
        for i in range(n):
            s = B[i, c]
            for k in range(i):
                s -= L[i, k] * B[k, c]
            B[i, c] = s / L[i, i]
        for i in range(n - 1, -1, -1):
            s = B[i, c]
            for k in range(i + 1, n):
                s -= L[k, i] * B[k, c]
            B[i, c] = s / L[i, i]


@njit(cache=True, inline="always")
def _sandwich(A, P, tmp, out):
    """``out = A P A'`` (symmetrised), with ``tmp`` of shape (n, n)."""
    n = P.shape[0]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += A[i, k] * P[k, j]
            tmp[i, j] = acc
    for i in range(n):
        for j in range(i + 1):
            acc = 0.0
            for k in range(n):
                acc += tmp[i, k] * A[j, k]
            out[i, j] = acc
            out[j, i] = acc


@njit(cache=True, inline="always")
def _put1(out, k, value):
    """``out[k] = value`` as a loop: numba's array assignment compiles a shape-error message (string
    formatting) that took seconds of the filter's first compilation."""
    for i in range(value.shape[0]):
        out[k, i] = value[i]


@njit(cache=True, inline="always")
def _put2(out, k, value):
    """``out[k] = value`` for a matrix ``value``, as loops (see :func:`_put1`)."""
    for i in range(value.shape[0]):
        for j in range(value.shape[1]):
            out[k, i, j] = value[i, j]


@njit(cache=True)
def _filter(x0, P0, u, y, dt, Q, R, oidx, sm, xf, Pf, xp, Pp, F, innov, S_out):
    """Run the filter; return (first failing sample or -1, failure code, log-likelihood).

    Codes: 1 the model's step diverged, 2 the innovation covariance is not
    positive definite, 3 the updated state is not finite.
    """
    n, m, N = x0.shape[0], oidx.shape[0], y.shape[0]
    lo, hi = sm.lo, sm.hi
    x = x0.copy()
    P = P0.copy()
    J = np.empty((n, n))
    no_par = np.empty((n, 0))
    work = jacobian_workspace(sm, u.shape[1])
    S = np.empty((m, m))
    L = np.zeros((m, m))
    PHt = np.empty((n, m))
    Kt = np.empty((m, n))
    A = np.empty((n, n))
    tmp = np.empty((n, n))
    e = np.empty(m)
    w = np.empty((m, 1))
    loglik = 0.0
    for k in range(N):
        if k > 0:
            if step_jacobian_into(sm, x, u[k - 1], u[k], dt, work, J, no_par):
                return k, 1, loglik
            _sandwich(J, P, tmp, P)
            for i in range(n):
                for j in range(n):
                    P[i, j] += Q[i, j]
            if F.shape[0]:  # the predictions are kept for the smoother only
                _put2(F, k, J)
        if xp.shape[0]:
            _put1(xp, k, x)
            _put2(Pp, k, P)
        # update with y[k]: H picks the measured states
        for a in range(m):
            e[a] = y[k, a] - x[oidx[a]]
            for b in range(m):
                S[a, b] = P[oidx[a], oidx[b]] + R[a, b]
            for i in range(n):
                PHt[i, a] = P[i, oidx[a]]
        if not _cholesky(S, L):
            return k, 2, loglik
        for i in range(n):
            for a in range(m):
                Kt[a, i] = PHt[i, a]
        _cho_solve(L, Kt)  # Kt = S^-1 H P, the transposed gain
        for a in range(m):
            w[a, 0] = e[a]
        _cho_solve(L, w)
        logdet = 0.0
        quad = 0.0
        for a in range(m):
            logdet += 2.0 * np.log(L[a, a])
            quad += e[a] * w[a, 0]
        loglik -= 0.5 * (logdet + quad + m * _LOG_2PI)
        for i in range(n):
            for a in range(m):
                x[i] += Kt[a, i] * e[a]
            if not np.isfinite(x[i]):
                return k, 3, loglik
            x[i] = min(max(x[i], lo[i]), hi[i])
        # Joseph form: (I - K H) P (I - K H)' + K R K'
        for i in range(n):
            for j in range(n):
                A[i, j] = 1.0 if i == j else 0.0
            for a in range(m):
                A[i, oidx[a]] -= Kt[a, i]
        _sandwich(A, P, tmp, P)
        for i in range(n):
            for j in range(i + 1):
                acc = 0.0
                for a in range(m):
                    for b in range(m):
                        acc += Kt[a, i] * R[a, b] * Kt[b, j]
                P[i, j] += acc
                if j != i:
                    P[j, i] += acc
        _put1(xf, k, x)
        _put2(Pf, k, P)
        _put1(innov, k, e)
        _put2(S_out, k, S)
    return -1, 0, loglik


@njit(cache=True)
def _smooth(xf, Pf, xp, Pp, F, xs, Ps):
    """Backward RTS pass; return -1 or the sample whose predicted covariance is singular."""
    N, n = xf.shape
    xs[N - 1] = xf[N - 1]
    Ps[N - 1] = Pf[N - 1]
    L = np.zeros((n, n))
    for k in range(N - 2, -1, -1):
        # gain G = Pf[k] F' Pp[k+1]^-1, from Pp[k+1] G' = F Pf[k]
        Gt = F[k + 1] @ Pf[k]
        if _cholesky(Pp[k + 1], L):
            _cho_solve(L, Gt)
        else:
            Gt = np.linalg.pinv(Pp[k + 1]) @ Gt
        G = Gt.T.copy()
        xs[k] = xf[k] + G @ (xs[k + 1] - xp[k + 1])
        P = Pf[k] + G @ (Ps[k + 1] - Pp[k + 1]) @ Gt
        Ps[k] = 0.5 * (P + P.T)
        for i in range(n):
            if not np.isfinite(xs[k, i]):
                return k
    return -1


# ----------------------------------------------------------------- input checks
def check_covariance(C, n, name, *, definite=False):
    """A symmetric positive (semi-)definite ``(n, n)`` matrix from a matrix, a diagonal or a scalar."""
    if C is None or isinstance(C, (str, bytes, dict)):  # np.asarray(None, float) is NaN
        raise ValueError(f"{name} is {shown(C)}; expected a covariance: an ({n}, {n}) matrix, a diagonal of length "
                         f"{n} or a number (0 for none).")
    try:
        C = np.asarray(C, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} could not be read as a covariance ({exc}); expected an ({n}, {n}) matrix, a "
                         f"diagonal of length {n} or a number.") from None
    if C.ndim == 0:
        C = np.full(n, float(C))
    if C.ndim == 1:
        if C.shape[0] != n:
            raise ValueError(f"{name} has {C.shape[0]} entries; expected {n} (a diagonal) or an ({n}, {n}) matrix.")
        C = np.diag(C)
    if C.shape != (n, n):
        raise ValueError(f"{name} has shape {C.shape}; expected ({n}, {n}) (or a diagonal of length {n}).")
    if not np.all(np.isfinite(C)):
        raise ValueError(f"{name} contains NaN or inf; expected a finite covariance.")
    if not np.allclose(C, C.T, rtol=1e-10, atol=1e-14 * max(1.0, np.abs(C).max())):
        raise ValueError(f"{name} is not symmetric; expected a covariance matrix.")
    C = 0.5 * (C + C.T)
    low = np.linalg.eigvalsh(C).min() if n else 0.0
    tol = 1e-12 * max(1.0, np.abs(C).max())
    if low < -tol or (definite and low <= 0.0):
        kind = "positive definite" if definite else "positive semi-definite"
        raise ValueError(f"{name} is not {kind} (smallest eigenvalue {low:.3g}); expected a {kind} covariance.")
    return np.ascontiguousarray(C)


def check_record(m, X, y):
    """``X`` (zero columns when the model has no inputs) and ``y`` of one record, checked against ``m``.

    ``X`` comes back delayed by the model's ``input_delay`` (:meth:`ModelStep.delayed`): the user gives the
    inputs as measured, the model applies its own delay.
    """
    check_one_record("the Kalman filter", X, y, advice=ONE_RECORD_ADVICE)
    y = check_signal(y, "y")  # refuses NaN: the filter does not skip samples
    n_out = len(m.output_index)
    if y.shape[1] != n_out:
        raise ValueError(f"y has {y.shape[1]} columns; expected {n_out} (one per measured state).")
    if m.n_inputs == 0 and X is None:
        X = np.zeros((y.shape[0], 0))
    X = np.ascontiguousarray(check_signal(X, "X"))  # refuses NaN and inf
    if X.shape != (y.shape[0], m.n_inputs):
        raise ValueError(f"X has shape {X.shape}; expected ({y.shape[0]}, {m.n_inputs}) (one row per sample of y, "
                         "one column per input).")
    return np.ascontiguousarray(m.delayed(X)), np.ascontiguousarray(y)


def check_prior(m, x0, P0):
    """The prior mean (clipped to the bounds) and covariance, defaults from ``m``."""
    n = m.n_states
    x0 = m.x0 if x0 is None else np.asarray(x0, dtype=float)
    if x0.shape != (n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 = {x0!r}; expected {n} finite numbers (the prior mean of the first state).")
    P0 = np.diag(m.state_scale**2) if P0 is None else P0
    return np.clip(x0, m.lower, m.upper), check_covariance(P0, n, "P0")


_CAUSES = {
    1: "the model's step diverged (state not finite or beyond max_abs)",
    2: "the innovation covariance lost positive definiteness",
    3: "the updated state is not finite",
}


def check_filter_args(model, X, y, Q, R, x0, P0):
    """``(m, X, y, Q, R, x0, P0)`` checked, ``X`` delayed by the model's ``input_delay`` (once)."""
    m = model_step(model)
    X, y = check_record(m, X, y)
    Q = check_covariance(Q, m.n_states, "Q")
    R = check_covariance(R, len(m.output_index), "R", definite=True)
    x0, P0 = check_prior(m, x0, P0)
    return m, X, y, Q, R, x0, P0


def run_filter(model, X, y, *, Q, R, x0=None, P0=None, keep_predictions=False):
    """The filter, with its predictions and step Jacobians (the smoother's input) if ``keep_predictions``.

    Checks every argument.
    """
    return filter_checked(*check_filter_args(model, X, y, Q, R, x0, P0), keep_predictions=keep_predictions)


def filter_checked(m, X, y, Q, R, x0, P0, *, keep_predictions=False, sm=None):
    """:func:`run_filter` on arguments it has checked (``sm``: ``m.step_model()``, to build it once for many runs)."""
    n, n_out, N = m.n_states, len(m.output_index), y.shape[0]
    sm = m.step_model() if sm is None else sm
    keep = int(bool(keep_predictions))
    arrays = {name: np.zeros(shape) for name, shape in (
        ("xf", (N, n)), ("Pf", (N, n, n)), ("xp", (N * keep, n)), ("Pp", (N * keep, n, n)), ("F", (N * keep, n, n)),
        ("innov", (N, n_out)), ("S", (N, n_out, n_out)))}
    oidx = np.asarray(m.output_index, dtype=np.int64)
    k, code, loglik = _filter(x0, P0, X, y, m.dt, Q, R, oidx, sm, *arrays.values())
    if k >= 0:
        raise FilterDivergenceError(f"the Kalman filter diverged at sample {k} of {N}: {_CAUSES[code]}. Check the "
                                    "model (does its simulation of this record stay finite?), Q, R and the prior.",
                                    step=int(k))
    return arrays, float(loglik)


def extended_kalman_filter(model, X, y, *, Q, R, x0=None, P0=None):
    """Filtered states of a fitted model given its inputs and measured outputs.

    Parameters
    ----------
    model : SINDy, HiddenStateSINDy or ModelStep
        A fitted model with the compiled right-hand side.
    X : array-like of shape (n_samples, n_inputs)
        Inputs as measured (None for a model without inputs). A model fitted
        with ``input_delay`` delays them itself, as its ``simulate`` does: do
        not pass ``model.delayed_inputs(X)``.
    y : array-like of shape (n_samples, n_outputs)
        Measured outputs (the model's output states), no NaN.
    Q : array-like of shape (n_states, n_states), (n_states,) or float
        Process noise covariance added per sample step (a diagonal or a
        scalar times the identity are accepted); positive semi-definite.
    R : array-like of shape (n_outputs, n_outputs), (n_outputs,) or float
        Measurement noise covariance; positive definite.
    x0 : array-like of shape (n_states,), optional
        Prior mean of the state at the first sample (default: the model's
        first training state).
    P0 : array-like, optional
        Prior covariance (default: the variance of each state on the
        training record, on the diagonal).

    Returns
    -------
    KalmanResult

    Raises
    ------
    ValueError
        On a wrong shape, NaN, or a covariance that is not positive
        (semi-)definite.
    FilterDivergenceError
        When the filter diverges.

    See Also
    --------
    rts_smoother, estimate_noise

    Examples
    --------
    A damped oscillator whose velocity is not measured:

    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0}, {((0, 0, 1, 0),): -4.0, ((1, 0, 1, 0),): -0.4}])
    >>> m = ModelStep.from_rhs(rhs, 0.05)
    >>> x = simulate(rhs, [1.0, 0.0], np.zeros((200, 0)), 0.05)
    >>> y = x[:, :1] + 0.01 * np.random.default_rng(0).standard_normal((200, 1))
    >>> res = extended_kalman_filter(m, None, y, Q=1e-8, R=1e-4, x0=[0.0, 0.0], P0=1.0)
    >>> bool(np.abs(res.states[-50:, 1] - x[-50:, 1]).max() < 0.02)
    True
    """
    a, loglik = run_filter(model, X, y, Q=Q, R=R, x0=x0, P0=P0)
    return KalmanResult(a["xf"], a["Pf"], a["xf"], a["Pf"], a["innov"], a["S"], loglik)


def rts_smoother(model, X, y, *, Q, R, x0=None, P0=None):
    """Smoothed states (Rauch-Tung-Striebel) of a fitted model over a whole record.

    The extended Kalman filter runs forward, then the backward pass combines
    each filtered state with the smoothed next one through the stored step
    Jacobians. Parameters, errors and defaults are those of
    :func:`extended_kalman_filter`.

    Returns
    -------
    KalmanResult
        ``states`` and ``covariances`` are the smoothed ones.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> from sindybench.estimation import ModelStep
    >>> rhs = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0}, {((0, 0, 1, 0),): -4.0}])
    >>> m = ModelStep.from_rhs(rhs, 0.05)
    >>> y = simulate(rhs, [1.0, 0.5], np.zeros((100, 0)), 0.05)[:, :1]
    >>> res = rts_smoother(m, None, y, Q=0.0, R=1e-6, x0=[0.0, 0.0], P0=10.0)
    >>> np.round(res.states[0], 3).tolist()
    [1.0, 0.5]
    """
    a, loglik = run_filter(model, X, y, Q=Q, R=R, x0=x0, P0=P0, keep_predictions=True)
    xs, Ps = np.empty_like(a["xf"]), np.empty_like(a["Pf"])
    if a["xf"].shape[0]:
        k = _smooth(a["xf"], a["Pf"], a["xp"], a["Pp"], a["F"], xs, Ps)
        if k >= 0:
            raise FilterDivergenceError(f"the RTS smoother produced a non-finite state at sample {k}.", step=int(k))
    return KalmanResult(xs, Ps, a["xf"], a["Pf"], a["innov"], a["S"], loglik)

"""Global smoothers solved in O(n): smoothing spline and Kalman (RTS) smoother.

Both are the posterior mean of a chain-of-integrators model observed with white
noise: the ``(n_states - 1)``-th derivative of the signal is a Brownian motion
(white noise on the ``n_states``-th derivative). With ``n_states=2`` this is the
natural cubic smoothing spline; with ``n_states=3`` the constant-acceleration
Kalman model. The fixed-interval (Rauch-Tung-Striebel) smoother with a diffuse
initial state computes the same mean; here it is obtained by one banded
Cholesky solve of the block-tridiagonal normal equations, O(n) in time and
memory, for all channels at once.
"""

from math import factorial

import numpy as np
from scipy.linalg import LinAlgError, solveh_banded

from .._validation import check_positive
from ..io import register_model
from ._base import BaseDifferentiation

__all__ = ["Kalman", "SmoothingSpline", "kalman_smooth"]


def kalman_smooth(y, t, *, alpha, n_states=3):
    """Smoothed signal and derivatives under a chain-of-integrators model.

    Minimizes ``sum_i (y_i - x(t_i))**2 + alpha * sum_k w_k' Q_k^{-1} w_k`` where
    ``w_k`` is the process noise of step ``k`` and ``Q_k`` its covariance for
    unit white-noise intensity; ``alpha`` is the ratio of the measurement-noise
    variance to the process-noise intensity. For ``n_states=2`` this equals
    ``sum_i (y_i - g(t_i))**2 + alpha * integral g''(t)**2 dt`` over natural cubic
    splines ``g`` (the smoothing spline of
    :func:`scipy.interpolate.make_smoothing_spline` with ``lam=alpha``).

    Parameters
    ----------
    y : ndarray of shape (n_samples, n_channels)
    t : ndarray of shape (n_samples,)
        Strictly increasing sample times (uniform or not).
    alpha : float
        Regularization (> 0): larger is smoother.
    n_states : int, default=3
        2 (integrated white noise: position, velocity) or 3 (constant
        acceleration: position, velocity, acceleration).

    Returns
    -------
    ndarray of shape (n_samples, n_states, n_channels)
        ``[:, j]`` is the smoothed ``j``-th derivative.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> s = kalman_smooth((1 + 2 * t + 3 * t**2)[:, None], t, alpha=1.0)
    >>> bool(np.allclose(s[:, 1, 0], 2 + 6 * t) and np.allclose(s[:, 2, 0], 6.0))
    True
    """
    n, m = len(t), n_states
    h = (t[-1] - t[0]) / (n - 1)
    r = np.diff(t) / h
    i, j = np.indices((m, m))
    # Unit-step process covariance of the scaled state (x, h x', h^2 x'', ...)
    # and its inverse; a step of r units scales entry (i, j) by r**(2m-1-i-j).
    q1 = 1.0 / ((2 * m - 1 - i - j) * np.vectorize(factorial)(m - 1 - i) * np.vectorize(factorial)(m - 1 - j))
    p = (alpha / h ** (2 * m - 1)) * np.linalg.inv(q1)[None] * r[:, None, None] ** (i + j - (2 * m - 1))[None]
    jump = np.clip(j - i, 0, None)
    f = np.where(j >= i, r[:, None, None] ** jump / np.vectorize(factorial)(jump), 0.0)
    diag = np.zeros((n, m, m))
    diag[:-1] += np.einsum("kai,kab,kbj->kij", f, p, f)
    diag[1:] += p
    diag[:, 0, 0] += 1.0
    sub = -np.einsum("kab,kbj->kaj", p, f)
    ab = np.zeros((2 * m, n * m))
    for a in range(m):
        for b in range(m):
            if a >= b:
                ab[a - b, b::m] = diag[:, a, b]
            ab[m + a - b, b : (n - 1) * m : m] = sub[:, a, b]
    rhs = np.zeros((n * m, y.shape[1]))
    rhs[::m] = y
    try:
        sol = solveh_banded(ab, rhs, lower=True, check_finite=False)
    except LinAlgError as exc:
        raise ValueError(
            f"the smoother's normal equations are numerically singular for alpha={alpha:g}; "
            "expected a smaller alpha (or rescale y)."
        ) from exc
    return sol.reshape(n, m, -1) / (h ** np.arange(m))[None, :, None]


class SmoothingSpline(BaseDifferentiation):
    """Derivatives of the natural cubic smoothing spline (non-uniform ``t`` allowed).

    The spline minimizes ``sum_i (y_i - g(t_i))**2 + smoothing * integral g''(t)**2 dt``,
    the same fit as :func:`scipy.interpolate.make_smoothing_spline` with
    ``lam=smoothing`` and as the ``derivative`` package's ``Kalman(alpha=smoothing)``,
    computed in O(n) (scipy's constructor loops over the samples in Python; the
    ``derivative`` package solves a dense system). The second derivative is that
    of the same spline (zero at the ends, as for any natural spline).

    Parameters
    ----------
    smoothing : float, default=1e-3
        Regularization (> 0), in units of ``y**2 * time**3``: larger is smoother.
        The data term sums over samples, so the same smoothness needs a
        ``smoothing`` proportional to the sampling rate.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> d = SmoothingSpline(smoothing=10.0).derivative(2.0 - 3.0 * t, t=t)
    >>> bool(np.allclose(d, -3.0))
    True
    """

    def __init__(self, smoothing=1e-3):
        self.smoothing = smoothing

    def _validate_params(self):
        check_positive(self.smoothing, "smoothing")

    def _derivative(self, y, t, step, order):
        states = kalman_smooth(y, t, alpha=self.smoothing, n_states=2)
        g, dg = states[:, 0], states[:, 1]
        if order == 1:
            return dg
        # second derivative of the cubic pieces from their end values and slopes
        h = np.diff(t)[:, None]
        slope = np.diff(g, axis=0) / h
        out = np.empty_like(g)
        out[:-1] = (6.0 * slope - 4.0 * dg[:-1] - 2.0 * dg[1:]) / h
        out[-1] = (-6.0 * slope[-1] + 2.0 * dg[-2] + 4.0 * dg[-1]) / h[-1]
        return out


class Kalman(BaseDifferentiation):
    """Kalman (RTS) smoother derivative on a constant-acceleration model.

    The signal's second derivative is modelled as a Brownian motion (white
    jerk) observed with white noise; the smoothed velocity and acceleration are
    the first and second derivatives, from the same smoother. Equivalently the
    natural quintic smoothing spline of ``sum (y_i - x(t_i))**2 + alpha * integral
    x'''(t)**2 dt``; quadratics are differentiated exactly. Non-uniform ``t`` is
    allowed. Solved in O(n) (see :func:`kalman_smooth`); the ``derivative``
    package's ``Kalman`` uses the velocity model (that is :class:`SmoothingSpline`)
    and a dense solve.

    Parameters
    ----------
    alpha : float, default=1e-6
        Ratio of measurement-noise variance to jerk-noise intensity (> 0), in
        units of ``time**5``: larger is smoother.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> d2 = Kalman(alpha=1.0).derivative(4.0 * t**2, t=t, order=2)
    >>> bool(np.allclose(d2, 8.0))
    True
    """

    def __init__(self, alpha=1e-6):
        self.alpha = alpha

    def _validate_params(self):
        check_positive(self.alpha, "alpha")

    def _derivative(self, y, t, step, order):
        return kalman_smooth(y, t, alpha=self.alpha, n_states=3)[:, order]


register_model(SmoothingSpline)
register_model(Kalman)

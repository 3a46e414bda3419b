"""Total-variation regularized differentiation, solved by a banded primal-dual Newton method."""

import warnings

import numpy as np
from scipy.linalg import LinAlgError, solveh_banded
from sklearn.exceptions import ConvergenceWarning

from .._validation import check_positive
from ._base import BaseDifferentiation, check_int
from ._local import finite_difference

__all__ = ["TotalVariation", "tv_smooth"]


def _jump_stencil(t, tv_order):
    """Rows ``c`` of the jump operator: ``(L x)_i = sum_a c[i, a] * x[i + a]``.

    ``L x`` holds the jumps between neighbouring estimates of the ``tv_order``-th
    derivative (divided differences on the actual sample times), scaled by
    ``h**tv_order`` with ``h`` the mean step so that its entries are O(1).
    """
    h = (t[-1] - t[0]) / (len(t) - 1)
    c = np.stack([-h / np.diff(t), h / np.diff(t)], axis=1)
    for q in range(2, tv_order + 1):
        nxt = np.zeros((c.shape[0] - 1, q + 1))
        nxt[:, :-1] -= c[:-1]
        nxt[:, 1:] += c[1:]
        c = nxt * (q * h / (t[q:] - t[:-q]))[:, None]
    jump = np.zeros((c.shape[0] - 1, c.shape[1] + 1))
    jump[:, :-1] -= c[:-1]
    jump[:, 1:] += c[1:]
    return jump, h


def _apply(c, x):
    m = c.shape[0]
    return sum(c[:, a] * x[a : a + m] for a in range(c.shape[1]))


def _apply_t(c, w, n):
    out = np.zeros(n)
    for a in range(c.shape[1]):
        out[a : a + c.shape[0]] += c[:, a] * w
    return out


def _gram_banded(c, d, n):
    """Lower banded storage of ``I + L' diag(d) L``."""
    m, k = c.shape
    ab = np.zeros((k, n))
    ab[0] = 1.0
    for a in range(k):
        for b in range(a + 1):
            ab[a - b, b : b + m] += d * c[:, a] * c[:, b]
    return ab


def _tv_smooth_1d(y, c, g, eps, tol, max_iter):
    """Minimize ``0.5 |x - y|^2 + g sum sqrt((L x)^2 + eps^2)`` (Chan-Golub-Mulet Newton)."""
    n = y.shape[0]
    scale = np.ptp(y) or 1.0
    x = y.copy()
    lx = _apply(c, x)
    s = np.sqrt(lx**2 + eps**2)
    w = lx / s

    def objective(x, s):
        return 0.5 * np.sum((x - y) ** 2) + g * np.sum(s)

    for it in range(1, max_iter + 1):
        f1 = x - y + g * _apply_t(c, w, n)
        f2 = s * w - lx
        d = (1.0 - w * lx / s) / s
        try:
            dx = solveh_banded(_gram_banded(c, g * d, n), -f1 + g * _apply_t(c, f2 / s, n), lower=True, check_finite=False)
        except LinAlgError as exc:
            raise ValueError(
                f"the Newton system is numerically singular (gamma too large for epsilon); "
                "expected a larger epsilon or a smaller gamma."
            ) from exc
        ldx = _apply(c, dx)
        dw = d * ldx - f2 / s
        # backtracking on the (convex, smooth) objective for x
        f0, slope, tau = objective(x, s), f1 @ dx, 1.0
        while True:
            lx_new = lx + tau * ldx
            s_new = np.sqrt(lx_new**2 + eps**2)
            if objective(x + tau * dx, s_new) <= f0 + 1e-4 * tau * slope or tau < 1e-10:
                break
            tau *= 0.5
        # the dual variable stays in [-1, 1]
        w_new = w + dw
        out = np.abs(w_new) > 1.0
        if out.any():
            limit = np.where(dw[out] > 0, (1.0 - w[out]) / dw[out], (-1.0 - w[out]) / dw[out])
            w_new = w + min(1.0, 0.99 * limit.min()) * dw
        x, lx, s, w = x + tau * dx, lx_new, s_new, w_new
        if tau * np.max(np.abs(dx)) <= tol * scale:
            return x, it
    warnings.warn(
        f"TotalVariation did not converge in {max_iter} iterations (last step "
        f"{tau * np.max(np.abs(dx)) / scale:.2g} of the signal range, tol={tol:g}); "
        "increase max_iter or epsilon.",
        ConvergenceWarning,
        stacklevel=3,
    )
    return x, max_iter


def tv_smooth(y, t, *, gamma, tv_order=1, epsilon=1e-3, tol=1e-7, max_iter=100):
    """Signal fit whose ``tv_order``-th derivative has small total variation.

    Minimizes, for each column of ``y``,
    ``0.5 * sum_i (x_i - y_i)**2 + gamma * sum_i sqrt(J_i**2 + e**2)``, where
    ``J_i`` are the jumps between neighbouring estimates of the ``tv_order``-th
    derivative of ``x`` (so ``sum |J_i|`` is its total variation) and
    ``e = epsilon * ptp(y) / (t[-1] - t[0])**tv_order`` rounds the absolute value
    at zero (as in Chartrand's TV-regularized differentiation). With
    ``tv_order=1`` the fit is close to piecewise linear (a piecewise-constant
    derivative), with ``tv_order=2`` close to piecewise quadratic. Solved by the
    primal-dual Newton method of Chan, Golub and Mulet, each step one banded
    Cholesky solve: O(n) per iteration, usually 20-60 iterations.

    Parameters
    ----------
    y : ndarray of shape (n_samples, n_channels)
    t : ndarray of shape (n_samples,)
        Strictly increasing sample times (uniform or not).
    gamma : float
        Regularization (> 0).
    tv_order : {1, 2}, default=1
    epsilon : float, default=1e-3
        Relative rounding of the absolute value (> 0).
    tol : float, default=1e-7
        Stop when a Newton step changes the fit by less than ``tol * ptp(y)``.
    max_iter : int, default=100

    Returns
    -------
    x : ndarray of shape (n_samples, n_channels)
    n_iter : int
        The largest number of Newton steps over the columns.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 21)
    >>> x, _ = tv_smooth((1.0 + 2.0 * t)[:, None], t, gamma=1.0)
    >>> bool(np.allclose(x[:, 0], 1.0 + 2.0 * t))
    True
    """
    c, h = _jump_stencil(t, tv_order)
    g = gamma / h**tv_order
    span = t[-1] - t[0]
    # the Newton matrix has norm up to about g * |c|^2 / e: keep it below 1e12
    e_min = 1e-12 * g * np.max(np.sum(c**2, axis=1))
    x = np.empty_like(y)
    n_iter = 0
    for col in range(y.shape[1]):
        e = max(epsilon * (np.ptp(y[:, col]) or 1.0) * (h / span) ** tv_order, e_min)
        x[:, col], it = _tv_smooth_1d(y[:, col], c, g, e, tol, max_iter)
        n_iter = max(n_iter, it)
    return x, n_iter


class TotalVariation(BaseDifferentiation):
    """Total-variation regularized differentiation (non-uniform ``t`` allowed).

    The derivative of the fit of :func:`tv_smooth`, which penalizes the total
    variation of the ``tv_order``-th derivative. ``tv_order=1`` (TV of the first
    derivative, Chartrand's method) is the study's choice for ``order=1``; its fit
    is piecewise linear, whose second derivative is a train of spikes, so a
    second derivative comes from the fit with TV on the second derivative
    (``tv_order=2``, piecewise-quadratic fit). By default (``tv_order=None``)
    each order uses the matching fit; set ``tv_order=2`` to get the first and
    second derivatives from one and the same fit. Derivatives of the fit are
    taken with second-order finite differences (exact on the fit's pieces).
    Signals that are polynomials of degree ``tv_order`` are fitted exactly.

    Parameters
    ----------
    gamma : float, default=1e-2
        Regularization (> 0), in units of ``y * time**tv_order``: larger is smoother.
        The data term sums over samples, so the same smoothness needs a
        ``gamma`` proportional to the sampling rate.
    tv_order : {None, 1, 2}, default=None
        Which derivative carries the TV penalty; ``None`` means the order asked for.
    epsilon : float, default=1e-3
        Relative rounding of the absolute value at zero (see :func:`tv_smooth`).
    tol : float, default=1e-7
        Newton stopping tolerance, relative to the range of ``y``.
    max_iter : int, default=100
        Maximum number of Newton steps per column.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 41)
    >>> d = TotalVariation(gamma=0.1).derivative(3.0 * t - 1.0, t=t)
    >>> bool(np.allclose(d, 3.0))
    True
    """

    def __init__(self, gamma=1e-2, *, tv_order=None, epsilon=1e-3, tol=1e-7, max_iter=100):
        self.gamma = gamma
        self.tv_order = tv_order
        self.epsilon = epsilon
        self.tol = tol
        self.max_iter = max_iter

    def _validate_params(self):
        check_positive(self.gamma, "gamma")
        if self.tv_order is not None:
            check_int(self.tv_order, "tv_order", low=1, high=2)
        check_positive(self.epsilon, "epsilon")
        check_positive(self.tol, "tol")
        check_int(self.max_iter, "max_iter", low=1)

    def _min_samples(self, order):
        return (self.tv_order or order) + 2

    def _derivative(self, y, t, step, order):
        tv_order = self.tv_order or order
        if order > tv_order:
            raise ValueError(
                "TotalVariation(tv_order=1) fits a piecewise-linear signal whose second derivative "
                "is a train of spikes; expected tv_order=2 or None for order=2."
            )
        x, _ = tv_smooth(
            y, t, gamma=self.gamma, tv_order=tv_order, epsilon=self.epsilon, tol=self.tol, max_iter=self.max_iter
        )
        return finite_difference(x, t, order=order, accuracy=2, step=step)

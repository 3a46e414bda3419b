"""Correlation of residuals and the tests of whiteness and of independence from the input (arrays only).

This is the numeric core of :func:`sindybench.uncertainty.residual_analysis`;
it sits at the bottom of the package (numpy and scipy only) so that a fit can
record the test of its refinement's residuals (``refinement_["residual_test"]``)
without an import pointing up.

Correlations are computed with the FFT (``O(n log n)``; 100,000 samples and
25 lags in a few milliseconds), normalized as in Ljung's *System
Identification* (1999, section 16.6) and MATLAB's ``resid``:

``r_ee(k) = sum_t e[t] e[t+k] / sum_t e[t]^2`` (residuals centred), and
``r_eu(k) = sum_t e[t+k] u[t] / sqrt(sum e^2 sum u^2)`` (``k >= 0``: the
residual after the input; ``k < 0``: before it, feedback).

Two portmanteau tests, both with :data:`scipy.stats.chi2` (statsmodels'
``acorr_ljungbox`` does the first; it is not a dependency, and the test is
five lines):

* whiteness, Ljung-Box: ``Q = n (n + 2) sum_{k=1..M} r_ee(k)^2 / (n - k)``,
  chi-square with ``M`` degrees of freedom under white residuals;
* independence from past inputs (Ljung, eq. 16.61): ``S = n r^T P^{-1} r``
  with ``r = (r_eu(0), ..., r_eu(M))`` and ``P`` the Toeplitz matrix of the
  input's autocorrelation, chi-square with ``M + 1`` degrees of freedom when
  the residuals are white and independent of the input (``P`` corrects for a
  coloured input, whose cross-correlations at neighbouring lags are not
  independent).

Each output and each (output, input) pair is tested at level ``alpha``
divided by the number of tests (Bonferroni), so ``white`` and ``independent``
keep the level ``alpha`` overall.
"""

from typing import NamedTuple

import numpy as np
from scipy import stats
from scipy.linalg import toeplitz

__all__ = ["ModelErrorWarning", "ResidualTest", "correlation", "refinement_residual_test", "residual_test"]


class ModelErrorWarning(UserWarning):
    """Residuals that are not white or depend on the input: intervals that assume otherwise are too narrow."""


def _next_fast(n):
    return 1 << int(np.ceil(np.log2(max(n, 1))))


def correlation(a, b=None, *, max_lag):
    """Normalized correlation of the columns of ``a`` (with those of ``b``) at lags ``-max_lag .. max_lag``.

    Parameters
    ----------
    a : ndarray of shape (n_samples, n_a)
    b : ndarray of shape (n_samples, n_b), optional
        Default ``a`` (autocorrelation).
    max_lag : int

    Returns
    -------
    ndarray of shape (2 * max_lag + 1, n_a, n_b)
        Entry ``[max_lag + k, i, j]`` is ``sum_t a[t+k, i] b[t, j]``
        divided by ``sqrt(sum a_i^2 sum b_j^2)``, the columns centred first
        (zero where a column is constant).

    Examples
    --------
    >>> e = np.random.default_rng(0).normal(size=(1000, 1))
    >>> r = correlation(e, max_lag=2)
    >>> r.shape, float(r[2, 0, 0])
    ((5, 1, 1), 1.0)
    >>> bool(np.allclose(r[3], np.sum((e[1:] - e.mean()) * (e[:-1] - e.mean())) / np.sum((e - e.mean()) ** 2)))
    True
    """
    a = np.asarray(a, dtype=float)
    b = a if b is None else np.asarray(b, dtype=float)
    a, b = a - a.mean(axis=0), b - b.mean(axis=0)
    n = a.shape[0]
    size = _next_fast(2 * n)
    fa, fb = np.fft.rfft(a, size, axis=0), np.fft.rfft(b, size, axis=0)
    full = np.fft.irfft(fa[:, :, None] * np.conj(fb[:, None, :]), size, axis=0)  # [k] = sum_t a[t+k] b[t]
    lags = np.arange(-max_lag, max_lag + 1)
    out = full[lags % size]
    norm = np.sqrt(np.sum(a**2, axis=0)[:, None] * np.sum(b**2, axis=0)[None, :])
    return np.divide(out, norm, out=np.zeros_like(out), where=norm > 0)


class ResidualTest(NamedTuple):
    """Whiteness and input-independence tests of residuals (see the module docstring).

    Attributes
    ----------
    max_lag : int
    alpha : float
        Overall level of each of the two tests.
    n_samples : int
    whiteness_pvalues : ndarray of shape (n_outputs,)
        Ljung-Box p-value of each output's residuals.
    independence_pvalues : ndarray of shape (n_outputs, n_inputs)
        p-value of the cross-correlation test of each output's residuals with each input.
    """

    max_lag: int
    alpha: float
    n_samples: int
    whiteness_pvalues: np.ndarray
    independence_pvalues: np.ndarray

    @property
    def white(self):
        """True when no output's residuals fail the whiteness test (Bonferroni over the outputs)."""
        p = self.whiteness_pvalues
        return bool(np.all(p >= self.alpha / max(p.size, 1)))

    @property
    def independent(self):
        """True when no (output, input) pair fails the independence test (Bonferroni over the pairs)."""
        p = self.independence_pvalues
        return bool(p.size == 0 or np.all(p >= self.alpha / p.size))

    def message(self):
        """One sentence: what failed, or that both tests passed."""
        failed = []
        if not self.white:
            failed.append(f"not white (smallest Ljung-Box p-value {np.min(self.whiteness_pvalues):.2g})")
        if not self.independent:
            failed.append("correlated with past inputs (smallest p-value "
                          f"{np.min(self.independence_pvalues):.2g})")
        if not failed:
            return f"white and independent of the inputs at level {self.alpha:g} ({self.max_lag} lags)"
        return " and ".join(failed) + f" at level {self.alpha:g} ({self.max_lag} lags, {self.n_samples} samples)"

    def to_dict(self):
        """JSON-able dict; :meth:`from_dict` inverts it."""
        return {"max_lag": int(self.max_lag), "alpha": float(self.alpha), "n_samples": int(self.n_samples),
                "whiteness_pvalues": self.whiteness_pvalues.tolist(),
                "independence_pvalues": self.independence_pvalues.tolist(), "white": self.white,
                "independent": self.independent}

    @classmethod
    def from_dict(cls, data):
        """Rebuild from :meth:`to_dict`'s output."""
        white = np.asarray(data["whiteness_pvalues"], dtype=float).reshape(-1)
        indep = np.asarray(data["independence_pvalues"], dtype=float).reshape(white.size, -1)
        return cls(int(data["max_lag"]), float(data["alpha"]), int(data["n_samples"]), white, indep)


def _check_residuals(e, name):
    e = np.asarray(e, dtype=float)
    e = e.reshape(-1, 1) if e.ndim == 1 else e
    if e.ndim != 2:
        raise ValueError(f"{name} has shape {e.shape}; expected (n_samples, n_columns).")
    if not np.all(np.isfinite(e)):
        bad = int(np.argmax(~np.all(np.isfinite(e), axis=1)))
        raise ValueError(f"{name} contains NaN or inf (first at sample {bad}); expected finite residuals "
                         "(a diverged simulation has no residual test).")
    return e


def residual_test(residuals, inputs=None, *, max_lag=25, alpha=0.05):
    """Ljung-Box whiteness test and the cross-correlation test with past inputs.

    Parameters
    ----------
    residuals : array-like of shape (n_samples, n_outputs) or (n_samples,)
    inputs : array-like of shape (n_samples, n_inputs), optional
    max_lag : int, default=25
        Lags ``M`` of both tests (MATLAB ``resid``'s default).
    alpha : float, default=0.05

    Returns
    -------
    ResidualTest

    Raises
    ------
    ValueError
        On NaN or inf residuals, ``max_lag`` not below a quarter of the samples, or ``alpha`` outside (0, 1).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(2000, 1))
    >>> residual_test(rng.normal(size=2000), u).message()
    'white and independent of the inputs at level 0.05 (25 lags)'
    >>> e = np.convolve(rng.normal(size=2000), np.ones(5) / 5, "same") + 0.3 * np.roll(u[:, 0], 3)
    >>> test = residual_test(e, u)
    >>> test.white, test.independent
    (False, False)
    """
    e = _check_residuals(residuals, "residuals")
    n = e.shape[0]
    if isinstance(max_lag, bool) or not isinstance(max_lag, (int, np.integer)) or not 1 <= max_lag < n // 4:
        raise ValueError(f"max_lag must be an integer in [1, n_samples / 4) = [1, {n // 4}); got {max_lag!r}.")
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.floating)) or not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1) (0.05 tests at the 5 % level); got {alpha!r}.")
    M = int(max_lag)
    r = correlation(e, max_lag=M)
    k = np.arange(1, M + 1)
    acf = np.stack([r[M + 1:, i, i] for i in range(e.shape[1])], axis=1)  # (M, n_outputs)
    q = n * (n + 2) * np.sum(acf**2 / (n - k)[:, None], axis=0)
    white = stats.chi2.sf(q, M)
    if inputs is None:
        indep = np.empty((e.shape[1], 0))
    else:
        u = _check_residuals(inputs, "inputs")
        if u.shape[0] != n:
            raise ValueError(f"inputs have {u.shape[0]} samples and residuals {n}; expected the same number.")
        ru = correlation(e, u, max_lag=M)[M:]  # k = 0..M: residual after the input
        ruu = correlation(u, max_lag=M)[M:]
        indep = np.ones((e.shape[1], u.shape[1]))
        for j in range(u.shape[1]):
            if np.ptp(u[:, j]) == 0:
                continue  # a constant input cannot explain anything
            P = toeplitz(ruu[:, j, j])
            for i in range(e.shape[1]):
                s = n * ru[:, i, j] @ np.linalg.lstsq(P, ru[:, i, j], rcond=1e-10)[0]
                indep[i, j] = stats.chi2.sf(s, M + 1)
    return ResidualTest(M, float(alpha), n, white, indep)


def refinement_residual_test(residuals, n_outputs, inputs, *, max_lag=25, alpha=0.05):
    """:func:`residual_test` of a refinement's output residuals (rows sample by sample), or None if too short.

    ``inputs`` is the list of the records' input arrays (a list of one for
    one record), their samples stacked in order as the residuals are.
    """
    e = np.asarray(residuals, dtype=float).reshape(-1, n_outputs)
    inputs = np.vstack(inputs) if inputs and all(a is not None for a in inputs) else None
    u = None if inputs is None else np.asarray(inputs, dtype=float).reshape(e.shape[0], -1)
    if u is not None and u.shape[1] == 0:
        u = None
    lag = min(int(max_lag), e.shape[0] // 4 - 1)
    if lag < 1 or not np.all(np.isfinite(e)):
        return None
    return residual_test(e, u, max_lag=lag, alpha=alpha)

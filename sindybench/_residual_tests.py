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

Which residuals are white under the null hypothesis. A model refined by
simulation error is an *output-error* model: its noise is on the measured
output only, so with the right structure its free-run residuals are that
noise, white and independent of the input, while its one-step residuals are
not white (an equation-error one-step prediction from measured outputs carries
the noise of two samples, ``v[t+1] - A v[t]``, and a filter's innovations
those of a gain the model does not have). A model refined by prediction error
with ``horizon=1`` (or an ARX model) is an *equation-error* model: its
one-step residuals are white under the null, its free-run residuals integrate
the noise. So each model is tested on the residuals of its own criterion (a
refinement records the test of the residuals it minimized), and testing the
other kind as well would raise false alarms at a rate nothing controls. A
``horizon`` above 1 leaves residuals correlated over ``horizon - 1`` lags even
with the right structure.

The statistics, at several lag windows ``w`` (:func:`lag_windows`: ``max_lag
// 5``, ``max_lag`` and ``4 max_lag``, since a model error shows as correlation
at a few lags or as a slow drift over many):

* Ljung-Box: ``Q_w = n (n + 2) sum_{k=1..w} r_ee(k)^2 / (n - k)``,
  chi-square with ``w`` degrees of freedom under white residuals (statsmodels'
  ``acorr_ljungbox``, which is not a dependency);
* the low-frequency (variance-ratio) statistic: ``Z_w = sqrt(n) sum_{k=1..w}
  c_k r_ee(k) / sqrt(sum c_k^2)`` with the Bartlett weights ``c_k = 1 - k /
  (w + 1)``, normal under white residuals and tested one-sided: it is the
  excess of the residuals' spectrum near frequency zero, where the error of a
  wrong structure filtered by the model's dynamics lands (a friction law
  ``sign(v)`` where the truth is smooth leaves a slow drift that Ljung-Box,
  squaring each correlation, sees less well);
* independence from past inputs (Ljung, eq. 16.61): ``S_w = n r^T P^{-1} r``
  with ``r = (r_eu(0), ..., r_eu(w))`` and ``P`` the Toeplitz matrix of the
  input's autocorrelation, chi-square with ``w + 1`` degrees of freedom when
  the residuals are white and independent of the input (``P`` corrects for a
  coloured input, whose cross-correlations at neighbouring lags are not
  independent).

The level is held twice. Within each output's whiteness test (each
(output, input) pair's independence test) the smallest p-value over its
statistics and windows is calibrated on its exact asymptotic null
distribution: ``sqrt(n) r_ee(k)`` (the whitened cross-correlations) are
independent standard normals under the null, so the windows' statistics are
nested sums of the same draws, simulated once (fixed seed, 20,000 draws) and
cached; this costs less than Bonferroni over the windows, which are strongly
correlated. Then Holm's step-down procedure at ``alpha`` runs over all outputs'
and pairs' p-values: ``white and independent`` fails with probability close to
``alpha`` for white residuals independent of the inputs (measured over 1000
records at level 0.05: 5.4 % with 2000 samples and a white input, 6.1 % with
1000 samples, 3 outputs and 2 held inputs; the calibration is asymptotic).
On a model's residuals the fitted parameters make them slightly more
orthogonal to the input than the noise is, which lowers the rate a little
(the servo of ``benchmarks/bench_residual_power.py``: see docs/uncertainty.rst).

A test recorded before the windows (a model file of version 0.2) has no
``windows`` and keeps its rule: Ljung-Box and the input test at ``max_lag``,
each at level ``alpha`` with Bonferroni over the outputs (pairs).
"""

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from scipy import stats
from scipy.linalg import cholesky, solve_triangular, toeplitz

__all__ = ["ModelErrorWarning", "ResidualTest", "correlation", "lag_windows", "refinement_residual_test",
           "residual_test"]


class ModelErrorWarning(UserWarning):
    """Residuals that are not white or depend on the input: intervals that assume otherwise are too narrow."""


def _next_fast(n):
    return 1 << int(np.ceil(np.log2(max(n, 1))))


def _unit_peak(a):
    """Each column of ``a`` divided by its largest absolute value (a zero column as it is)."""
    peak = np.max(np.abs(a), axis=0) if a.shape[0] else np.ones(a.shape[1:])
    return a / np.where(peak > 0, peak, 1.0)


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
    a = _unit_peak(np.asarray(a, dtype=float))  # correlations do not depend on scale: none overflows or underflows
    b = a if b is None else _unit_peak(np.asarray(b, dtype=float))
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
        Level of the whole test (:attr:`white` and :attr:`independent` together).
    n_samples : int
    whiteness_pvalues : ndarray of shape (n_outputs,)
        p-value of the whiteness test of each output's residuals (Ljung-Box and
        the low-frequency statistic at every lag window, combined).
    independence_pvalues : ndarray of shape (n_outputs, n_inputs)
        p-value of the cross-correlation test (every lag window, combined) of
        each output's residuals with each input.
    windows : tuple of int
        The lag windows (empty: a test recorded before 0.3, Ljung-Box and the
        cross-correlation test at ``max_lag`` only, each at level ``alpha``).
    """

    max_lag: int
    alpha: float
    n_samples: int
    whiteness_pvalues: np.ndarray
    independence_pvalues: np.ndarray
    windows: tuple = ()

    def _rejected(self):
        """(whiteness, independence) rejections: Holm over every output and pair at ``alpha`` (old records: as then)."""
        pw, pi = np.asarray(self.whiteness_pvalues).ravel(), np.asarray(self.independence_pvalues).ravel()
        if not self.windows:  # the rule of tests recorded before the windows: Bonferroni within each test
            return pw < self.alpha / max(pw.size, 1), pi < self.alpha / max(pi.size, 1)
        p = np.concatenate([pw, pi])
        rejected = np.zeros(p.size, dtype=bool)
        for rank, i in enumerate(np.argsort(p, kind="stable")):
            if p[i] >= self.alpha / (p.size - rank):
                break
            rejected[i] = True
        return rejected[:pw.size], rejected[pw.size:]

    @property
    def white(self):
        """True when no output's residuals fail the whiteness test (Holm over all the tests)."""
        return not bool(np.any(self._rejected()[0]))

    @property
    def independent(self):
        """True when no (output, input) pair fails the independence test (Holm over all the tests)."""
        return not bool(np.any(self._rejected()[1]))

    @property
    def pvalue(self):
        """The p-value of the whole test: the smallest Holm-adjusted p-value (flagged when below ``alpha``)."""
        p = np.concatenate([np.ravel(self.whiteness_pvalues), np.ravel(self.independence_pvalues)])
        return float(min(1.0, p.size * np.min(p))) if p.size else 1.0

    def message(self):
        """One sentence: what failed, or that both tests passed."""
        lags = f"lag windows {', '.join(map(str, self.windows))}" if self.windows else f"{self.max_lag} lags"
        failed = []
        if not self.white:
            failed.append(f"not white (smallest {'whiteness' if self.windows else 'Ljung-Box'} p-value "
                          f"{np.min(self.whiteness_pvalues):.2g})")
        if not self.independent:
            failed.append("correlated with past inputs (smallest p-value "
                          f"{np.min(self.independence_pvalues):.2g})")
        if not failed:
            return f"white and independent of the inputs at level {self.alpha:g} ({lags})"
        return " and ".join(failed) + f" at level {self.alpha:g} ({lags}, {self.n_samples} samples)"

    def to_dict(self):
        """JSON-able dict; :meth:`from_dict` inverts it."""
        return {"max_lag": int(self.max_lag), "alpha": float(self.alpha), "n_samples": int(self.n_samples),
                "whiteness_pvalues": np.asarray(self.whiteness_pvalues).tolist(),
                "independence_pvalues": np.asarray(self.independence_pvalues).tolist(), "white": self.white,
                "independent": self.independent, "windows": [int(w) for w in self.windows]}

    @classmethod
    def from_dict(cls, data):
        """Rebuild from :meth:`to_dict`'s output (a record without ``"windows"`` keeps its old rule)."""
        white = np.asarray(data["whiteness_pvalues"], dtype=float).reshape(-1)
        indep = np.asarray(data["independence_pvalues"], dtype=float).reshape(white.size, -1)
        return cls(int(data["max_lag"]), float(data["alpha"]), int(data["n_samples"]), white, indep,
                   tuple(int(w) for w in data.get("windows", ())))


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


NULL_DRAWS = 20000
"""Draws of the asymptotic null distribution that calibrate the combination of the lag windows."""


def lag_windows(max_lag, n_samples):
    """The lag windows of the tests: ``max_lag // 5``, ``max_lag`` and ``4 max_lag`` (below a quarter of the samples).

    Examples
    --------
    >>> lag_windows(25, 2000), lag_windows(25, 120), lag_windows(3, 1000)
    ((5, 25, 100), (5, 25, 29), (1, 3, 12))
    """
    top = max(min(4 * max_lag, n_samples // 4 - 1), max_lag)
    return tuple(sorted({max(max_lag // 5, 1), max_lag, top}))


def _bartlett(w):
    """Weights ``1 - k / (w + 1)`` of lags ``k = 1 .. w`` (the variance-ratio statistic of window ``w``)."""
    return 1.0 - np.arange(1, w + 1) / (w + 1)


def _whiteness_pvalues(z, windows):
    """Ljung-Box and low-frequency p-values at each window from ``z[..., k-1] = sqrt(n) r(k)`` (last axis: lags)."""
    q = np.cumsum(z**2, axis=-1)
    out = []
    for w in windows:
        weights = _bartlett(w)
        out.append(stats.chi2.sf(q[..., w - 1], w))
        out.append(stats.norm.sf(z[..., :w] @ weights / np.sqrt(weights @ weights)))
    return np.stack(out, axis=-1)


@lru_cache(maxsize=32)
def _null_min_p(kind, windows):
    """Sorted smallest p-values over the windows' statistics under the asymptotic null (fixed seed)."""
    rng = np.random.default_rng(0)
    top = max(windows)
    if kind == "whiteness":  # sqrt(n) r(k), k = 1..top: independent N(0, 1) for white residuals
        p = _whiteness_pvalues(rng.standard_normal((NULL_DRAWS, top)), windows)
    else:  # the whitened cross-correlations at k = 0..top: independent N(0, 1); nested sums for the windows
        q = np.cumsum(rng.standard_normal((NULL_DRAWS, top + 1)) ** 2, axis=1)
        p = np.stack([stats.chi2.sf(q[:, w], w + 1) for w in windows], axis=1)
    return np.sort(p.min(axis=1))


def _combined_pvalue(p, kind, windows):
    """The p-value of the smallest of ``p`` (one per statistic), calibrated on the null of its family.

    The calibration counts the null draws with a smaller minimum; in the far tail, where the draws are too
    few, it is the Bonferroni bound (``p.size * min p``), an upper bound that is tight there.
    """
    table = _null_min_p(kind, tuple(windows))
    smallest = float(np.min(p))
    count = np.searchsorted(table, smallest, side="right")
    bonferroni = min(1.0, p.size * smallest)
    return bonferroni if count < 20 else min(bonferroni, count / table.size)


def residual_test(residuals, inputs=None, *, max_lag=25, alpha=0.05, windows=None):
    """The whiteness test and the cross-correlation test with past inputs, at several lag windows, at level ``alpha``.

    Under the null hypothesis the residuals are white and independent of the inputs: the
    free-run residuals of an output-error model (noise on the measured output only), or the
    one-step residuals of an equation-error or prediction-error model. See the module docstring.

    Parameters
    ----------
    residuals : array-like of shape (n_samples, n_outputs) or (n_samples,)
    inputs : array-like of shape (n_samples, n_inputs), optional
    max_lag : int, default=25
        The middle lag window (MATLAB ``resid``'s default lags); the others
        are ``max_lag // 5`` and ``4 max_lag`` (at most a quarter of the
        samples): :func:`lag_windows`.
    alpha : float, default=0.05
        Level of the whole test: ``white and independent`` fails with
        probability about ``alpha`` for white residuals independent of the inputs.
    windows : sequence of int, optional
        The lag windows instead (each in ``[1, n_samples / 4)``).

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
    'white and independent of the inputs at level 0.05 (lag windows 5, 25, 100)'
    >>> e = np.convolve(rng.normal(size=2000), np.ones(5) / 5, "same") + 0.3 * np.roll(u[:, 0], 3)
    >>> test = residual_test(e, u)
    >>> test.white, test.independent
    (False, False)
    """
    e = _check_residuals(residuals, "residuals")
    n = e.shape[0]
    if n < 8:  # max_lag >= 1 and max_lag < n / 4
        raise ValueError(f"residuals have {n} sample(s); the residual test needs at least 8 (max_lag < n_samples / 4).")
    if isinstance(max_lag, bool) or not isinstance(max_lag, (int, np.integer)) or not 1 <= max_lag < n // 4:
        raise ValueError(f"max_lag must be an integer in [1, n_samples / 4) = [1, {n // 4}); got {max_lag!r}.")
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.floating)) or not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1) (0.05 tests at the 5 % level); got {alpha!r}.")
    M = int(max_lag)
    if windows is None:
        windows = lag_windows(M, n)
    else:
        given = np.atleast_1d(np.asarray(windows))
        if (given.ndim != 1 or given.size == 0 or not np.issubdtype(given.dtype, np.integer)
                or given.min() < 1 or given.max() >= n // 4):
            raise ValueError(f"windows must be integers in [1, n_samples / 4) = [1, {n // 4}); got {windows!r}.")
        windows = tuple(sorted({int(w) for w in given}))
    top = max(windows)
    r = correlation(e, max_lag=top)
    k = np.arange(1, top + 1)
    acf = np.stack([r[top + 1:, i, i] for i in range(e.shape[1])], axis=0)  # (n_outputs, top)
    z = acf * np.sqrt(n * (n + 2) / (n - k))  # Ljung-Box's small-sample weights
    white = np.array([_combined_pvalue(p, "whiteness", windows) for p in _whiteness_pvalues(z, windows)])
    if inputs is None:
        indep = np.empty((e.shape[1], 0))
    else:
        u = _check_residuals(inputs, "inputs")
        if u.shape[0] != n:
            raise ValueError(f"inputs have {u.shape[0]} samples and residuals {n}; expected the same number.")
        ru = correlation(e, u, max_lag=top)[top:]  # k = 0..top: residual after the input
        ruu = correlation(u, max_lag=top)[top:]
        indep = np.ones((e.shape[1], u.shape[1]))
        for j in range(u.shape[1]):
            if np.ptp(u[:, j]) == 0:
                continue  # a constant input cannot explain anything
            # the leading block of P's Cholesky factor is that of P's leading block: one solve gives every window
            L = cholesky(toeplitz(ruu[:, j, j]) + 1e-9 * np.eye(top + 1), lower=True)
            for i in range(e.shape[1]):
                s = np.cumsum(n * solve_triangular(L, ru[:, i, j], lower=True) ** 2)[list(windows)]
                p = stats.chi2.sf(s, np.asarray(windows) + 1)
                indep[i, j] = _combined_pvalue(p, "independence", windows)
    return ResidualTest(M, float(alpha), n, white, indep, windows)


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

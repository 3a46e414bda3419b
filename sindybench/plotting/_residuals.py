"""Residual analysis: autocorrelation of the residuals and cross-correlation with the inputs, with bounds."""

import numpy as np

from ._common import _stacked_axes


def plot_residual_analysis(analysis, *, ax=None):
    """A :class:`~sindybench.uncertainty.ResidualAnalysis` as MATLAB's ``resid`` draws it.

    One Axes for the autocorrelation of each output's residuals (lags
    ``1 .. max_lag``) and one for their cross-correlation with each input
    (lags ``-max_lag .. max_lag``; positive lags: the residual after the
    input), each with the ``1 - alpha`` bounds of a white, independent
    residual; the titles give the tests' p-values.

    Parameters
    ----------
    analysis : ResidualAnalysis
        From :func:`sindybench.uncertainty.residual_analysis` or a fitted
        model's ``residual_analysis``.
    ax : sequence of Axes, optional
        ``n_outputs * (1 + n_inputs)`` Axes.

    Returns
    -------
    list of Axes

    Examples
    --------
    >>> from sindybench.baselines import ARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(500, 1))
    >>> y = np.convolve(u[:, 0], [0.0, 1.0, 0.5])[:500, None] + 0.1 * rng.normal(size=(500, 1))
    >>> analysis = ARX(na=0, nb=2).fit(u, y).residual_analysis(u, y, max_lag=10)
    >>> axes = plot_residual_analysis(analysis)
    >>> len(axes), analysis.white
    (2, True)
    """
    n_out, n_in = analysis.cross_correlation.shape[1], analysis.cross_correlation.shape[2]
    axes = _stacked_axes(ax, n_out * (1 + n_in))
    lags, M = analysis.lags, int(analysis.lags[-1])
    level = round(100 * (1 - analysis.test.alpha))
    panels = iter(axes)
    for i in range(n_out):
        a = next(panels)
        a.stem(lags[M + 1:], analysis.autocorrelation[M + 1:, i], basefmt=" ")
        a.set_title(f"autocorrelation of the {analysis.kind} residuals of output {i} (whiteness p = "
                    f"{analysis.test.whiteness_pvalues[i]:.2g})", fontsize=9)
        panel_bounds = [a]
        for j in range(n_in):
            b = next(panels)
            b.stem(lags, analysis.cross_correlation[:, i, j], basefmt=" ")
            b.set_title(f"cross-correlation of output {i}'s residuals with input {j} (p = "
                        f"{analysis.test.independence_pvalues[i, j]:.2g})", fontsize=9)
            panel_bounds.append(b)
        for p in panel_bounds:
            p.axhspan(-analysis.bound, analysis.bound, color="tab:blue", alpha=0.15, label=f"{level} % bound")
            p.axhline(0.0, color="k", lw=0.5)
            p.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("lag (samples)")
    return axes

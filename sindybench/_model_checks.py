"""``residual_analysis`` and ``conformal_calibration`` as methods of every fitted estimator.

The work is done in :mod:`sindybench.uncertainty`, which sits above the
estimators (it simulates, filters and predicts them); these methods import it
when called, the way pandas' ``DataFrame.plot`` reaches its plotting layer, so
no module-level import points up.
"""

__all__ = ["ModelChecksMixin"]


class ModelChecksMixin:
    """Adds :meth:`residual_analysis` and :meth:`conformal_calibration` to a fitted estimator."""

    def residual_analysis(self, X, y, *, kind="free_run", n_init=None, max_lag=25, alpha=0.05, Q=None, R=None):
        """Autocorrelation of the residuals on ``(X, y)``, cross-correlation with the inputs, and their tests.

        See :func:`sindybench.uncertainty.residual_analysis` (``kind``:
        ``"free_run"`` or ``"one_step"``).

        Returns
        -------
        ResidualAnalysis
        """
        from .uncertainty import residual_analysis

        return residual_analysis(self, X, y, kind=kind, n_init=n_init, max_lag=max_lag, alpha=alpha, Q=Q, R=R)

    def conformal_calibration(self, X, y, *, alpha=0.05, horizon=None, block_length=None, n_init=None, score_from=0,
                              Q=None, R=None):
        """Calibrate a conformal band of the free run (or of the ``horizon``-step prediction) on held-out data.

        See :func:`sindybench.uncertainty.conformal_calibration`; the result's
        ``band(model, X, y_init=...)`` gives the band of a new record.

        Returns
        -------
        ConformalCalibration
        """
        from .uncertainty import conformal_calibration

        return conformal_calibration(self, X, y, alpha=alpha, horizon=horizon, block_length=block_length,
                                     n_init=n_init, score_from=score_from, Q=Q, R=R)

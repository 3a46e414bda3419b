"""The uncertainty methods of the estimators, whose work is done in :mod:`sindybench.uncertainty`.

``residual_analysis`` and ``conformal_calibration`` (every estimator:
:class:`ModelChecksMixin`), ``standard_errors`` and ``confidence_intervals``
(the refined ones: :class:`UncertaintyMixin`). The modules that do the work
import nothing that imports the estimators: the residual analysis and the
conformal calibration reach the model through its methods and through
:mod:`sindybench.estimation` (which reads the fitted ``dynamics_`` and knows no
estimator class), the standard errors through ``_covariance``. So these thin
methods import those modules (not the :mod:`sindybench.uncertainty` package,
whose ensembles refit estimators) and the imports of the package point one way
(``tests/test_imports.py``).
"""

__all__ = ["ModelChecksMixin", "UncertaintyMixin"]


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
        from .uncertainty._residuals import residual_analysis

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
        from .uncertainty._conformal import conformal_calibration

        return conformal_calibration(self, X, y, alpha=alpha, horizon=horizon, block_length=block_length,
                                     n_init=n_init, score_from=score_from, Q=Q, R=R)


class UncertaintyMixin:
    """``standard_errors()`` and ``confidence_intervals()`` for estimators with ``refinement_`` and equation rows."""

    def standard_errors(self, kind="white"):
        """Standard errors of the refined parameters (needs ``refine``).

        From the Jacobian of the simulation at the refined optimum and the
        residual variance (see :doc:`/uncertainty`). Warns
        (:class:`~sindybench.uncertainty.ModelErrorWarning`) when the
        refinement's residual test contradicts what ``kind`` assumes.

        Parameters
        ----------
        kind : {"white", "hac"}, default="white"
            ``"white"`` assumes independent residuals; ``"hac"`` (Newey-West)
            allows residuals correlated in time.

        Returns
        -------
        dict
            ``{name: standard error}``: physical parameters by name,
            coefficients as ``"<state>': <feature>"``, initial states as
            ``"<state>(0)"``.
        """
        from .uncertainty._covariance import standard_errors

        return standard_errors(self, kind)

    def confidence_intervals(self, alpha=0.05, kind="white"):
        """Two-sided ``1 - alpha`` confidence intervals of the refined parameters (needs ``refine``).

        Parameters
        ----------
        alpha : float, default=0.05
        kind : {"white", "hac"}, default="white"
            As in :meth:`standard_errors` (and it warns alike).

        Returns
        -------
        dict
            ``{name: (lower, upper)}``, named as in :meth:`standard_errors`.
        """
        from .uncertainty._covariance import confidence_intervals

        return confidence_intervals(self, alpha, kind)

    def _coef_errors(self):
        from .uncertainty._covariance import coef_errors

        return coef_errors(self)

"""The prediction the sparse regressors share: ``X @ coef_.T``, several targets at once."""

from sklearn.utils.validation import check_is_fitted

from .._validation import validate_named

__all__ = ["LinearPredictMixin"]


class LinearPredictMixin:
    """``predict`` and the multi-output tag of a regressor whose fit sets ``coef_`` (``(n_targets, n_features)``
    or ``(n_features,)``) and no intercept; put it before scikit-learn's mixins."""

    def predict(self, X):
        """Return ``X @ coef_.T``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)

        Returns
        -------
        ndarray of shape (n_samples,) or (n_samples, n_targets)
        """
        check_is_fitted(self)
        X = validate_named(self, X, reset=False, dtype=float)
        return X @ self.coef_.T

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        return tags

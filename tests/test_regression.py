"""The regression step shared by the estimators (sindybench._regression)."""

import numpy as np
import pytest
from sklearn.base import BaseEstimator
from sklearn.exceptions import NotFittedError

from sindybench import STLS, HiddenStateSINDy, SINDy
from sindybench._regression import fit_sparse
from sindybench.libraries import CustomLibrary, PolynomialLibrary


class _NaNOptimizer(BaseEstimator):
    def fit(self, theta, target):
        self.coef_ = np.full((target.shape[1], theta.shape[1]), np.nan)
        return self


def test_rows_and_feature_filter_select_the_regression(rng):
    Z = rng.normal(size=(50, 2))
    target = (3.0 * Z[:, :1] - Z[:, 1:]) + 0.0
    target[40:] = 100.0  # rows left out of the regression
    rows = np.arange(50) < 40
    coef = fit_sparse(PolynomialLibrary(degree=1), STLS(threshold=0.0), Z, target, rows=rows)
    np.testing.assert_allclose(coef[:, 0], [0.0, 3.0, -1.0], atol=1e-12)
    doubled = fit_sparse(PolynomialLibrary(degree=1), STLS(threshold=0.0), Z, target, rows=rows,
                         feature_filter=lambda theta: 2.0 * theta)
    np.testing.assert_allclose(doubled, coef / 2.0, atol=1e-12)


@pytest.mark.parametrize("library", [PolynomialLibrary(degree=1), CustomLibrary(functions=[np.positive])],
                         ids=["compiled", "python"])
def test_non_finite_coefficients_are_a_clear_error_and_leave_the_model_unfitted(library, rng):
    u = rng.normal(size=(200, 1))
    y = np.cumsum(rng.normal(size=(200, 1)), axis=0) * 0.01
    for model in (SINDy(library=library, optimizer=_NaNOptimizer(), dt=0.01),
                  HiddenStateSINDy(library=library, optimizer=_NaNOptimizer(), dt=0.01)):
        with pytest.raises(ValueError, match="the optimizer returned NaN or inf coefficients"):
            model.fit(u, y)
        with pytest.raises(NotFittedError):
            model.predict(u, y_init=y)

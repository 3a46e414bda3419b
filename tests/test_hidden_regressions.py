"""hidden._regressions: a regression repeated inside a search is fitted once, its copies the same numbers."""

import warnings

import numpy as np
import pytest

from sindybench import STLS
from sindybench.hidden import _regressions
from sindybench.hidden._regressions import fit_regression, reused_regressions
from sindybench.libraries import PolynomialLibrary


@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    Z = rng.normal(size=(200, 2))
    return Z, np.c_[2.0 * Z[:, 0] - Z[:, 0] * Z[:, 1], 0.5 * Z[:, 1] ** 2] + 0.01 * rng.normal(size=(200, 2))


def _fit(Z, target, threshold=0.1, **kwargs):
    return fit_regression(PolynomialLibrary(degree=2), STLS(threshold=threshold), Z, target, **kwargs)


def test_a_repeated_regression_is_a_copy_of_the_first(data):
    Z, target = data
    with reused_regressions():
        library, optimizer, coef = _fit(Z, target)
        again = _fit(Z.copy(), target.copy())  # the same numbers in other arrays
        assert len(_regressions._KEPT) == 1
        np.testing.assert_array_equal(again[2], coef)
        assert again[0] is not library and again[1] is not optimizer and again[2] is not coef
        assert again[0].terms_ == library.terms_
        np.testing.assert_array_equal(again[1].coef_, optimizer.coef_)
        _fit(Z, target, threshold=0.2)  # another optimizer: another regression
        _fit(Z, target, rows=np.arange(200) < 150)  # other rows: another regression
        assert len(_regressions._KEPT) == 3
    assert _regressions._KEPT is None  # outside the block, nothing is kept
    np.testing.assert_array_equal(_fit(Z, target)[2], coef)


def test_a_fit_that_warns_is_not_kept_and_warns_each_time(data, monkeypatch):
    Z, target = data
    fit_sparse = _regressions.fit_sparse

    def warning_fit(*args, **kwargs):
        warnings.warn("a warning of the fit", UserWarning)
        return fit_sparse(*args, **kwargs)

    monkeypatch.setattr(_regressions, "fit_sparse", warning_fit)
    with reused_regressions():
        for _ in range(2):
            with pytest.warns(UserWarning, match="a warning of the fit"):
                _fit(Z, target)
        assert len(_regressions._KEPT) == 0


def test_the_oldest_regressions_go_first(data, monkeypatch):
    Z, target = data
    monkeypatch.setattr(_regressions, "MAX_KEPT", 2)
    with reused_regressions():
        for threshold in (0.1, 0.2, 0.3):
            _fit(Z, target, threshold=threshold)
        assert len(_regressions._KEPT) == 2

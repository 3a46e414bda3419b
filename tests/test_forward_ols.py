"""ForwardOLS: greedy forward selection of terms by orthogonal least squares."""

import numpy as np
import pytest

from sindybench.io import model_from_dict, model_to_dict
from sindybench.optimizers import ForwardOLS, forward_ols


@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    theta = rng.normal(size=(300, 8))
    return theta, theta @ [0.0, 2.0, 0.0, -1.0, 0.0, 0.0, 0.5, 0.0]


def test_selects_the_true_terms_in_order_of_explained_variance(data):
    theta, y = data
    model = ForwardOLS(n_terms=3).fit(theta, y)
    assert model.order_ == [[1, 3, 6]]
    np.testing.assert_allclose(model.coef_, [0.0, 2.0, 0.0, -1.0, 0.0, 0.0, 0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(model.predict(theta), y, atol=1e-12)


def test_at_most_n_terms_and_tol_stops_early(data):
    theta, y = data
    assert np.count_nonzero(ForwardOLS(n_terms=2).fit(theta, y).coef_) == 2
    assert len(ForwardOLS(n_terms=8, tol=1e-9).fit(theta, y).order_[0]) == 3  # all explained after three


def test_several_targets_and_a_dependent_column():
    theta = np.random.default_rng(1).normal(size=(100, 3))
    theta = np.hstack([theta, theta[:, :1] + theta[:, 1:2]])  # column 3 = column 0 + column 1
    target = np.column_stack([theta[:, 3], theta[:, 2]])
    coef, order = forward_ols(theta, target, n_terms=4)
    assert coef.shape == (4, 2) and len(order[0]) == 3  # the dependent fourth column is never chosen
    np.testing.assert_allclose(theta @ coef, target, atol=1e-10)


def test_center_keeps_the_constant_as_an_intercept(data):
    theta, y = data
    theta = np.hstack([np.ones((theta.shape[0], 1)), theta])
    model = ForwardOLS(n_terms=3, center=True).fit(theta, y + 4.0)
    assert model.order_ == [[2, 4, 7]]
    np.testing.assert_allclose(model.coef_[[0, 2, 4, 7]], [4.0, 2.0, -1.0, 0.5], atol=1e-10)
    assert np.count_nonzero(model.coef_) == 4
    # without centring the constant is a candidate like any other: chosen first, it takes one of the three places
    assert ForwardOLS(n_terms=3).fit(theta, y + 4.0).order_[0][0] == 0


def test_model_dict_round_trip(data):
    theta, y = data
    model = ForwardOLS(n_terms=3, center=True).fit(theta, y)
    loaded = model_from_dict(model_to_dict(model))
    np.testing.assert_array_equal(loaded.coef_, model.coef_)
    assert loaded.order_ == model.order_ and loaded.get_params() == model.get_params()


@pytest.mark.parametrize("params, match", [
    ({"n_terms": 0}, "n_terms must be an integer >= 1"),
    ({"tol": 1.0}, r"tol must be a number in \[0, 1\); got 1.0"),
    ({"center": "yes"}, "center"),
])
def test_bad_parameters(data, params, match):
    with pytest.raises(ValueError, match=match):
        ForwardOLS(**params).fit(*data)


@pytest.mark.parametrize("center", [False, True])
def test_a_selection_of_more_terms_resumes_the_last_one(data, center):
    """A search over n_terms: the second call resumes the first's selection, with the numbers of a fresh one."""
    from sindybench.optimizers import _forward

    theta, y = data
    _forward._LAST.value = None
    fresh = forward_ols(theta, y, n_terms=3, center=center)
    _forward._LAST.value = None
    first = forward_ols(theta, y, n_terms=2, center=center)
    resumed = forward_ols(theta, y, n_terms=3, center=center)
    assert len(_forward._LAST.value["selections"][0].chosen) == 3  # one selection, taken one step further
    np.testing.assert_array_equal(resumed[0], fresh[0])
    assert resumed[1] == fresh[1] and first[1] == [fresh[1][0][:2]]
    theta2 = theta.copy()
    theta2[:, 1] = 0.0  # other columns: a selection of their own, not the last one resumed
    assert 1 not in forward_ols(theta2, y, n_terms=3, center=center)[1][0]


def test_subtract_outer_in_blocks_is_the_outer_product_subtracted():
    from sindybench.optimizers._forward import _subtract_outer

    rng = np.random.default_rng(3)
    W, q, v = rng.normal(size=(1000, 7)), rng.normal(size=1000), rng.normal(size=7)
    expected = W - np.outer(q, v)
    _subtract_outer(W, q, v, rows=64)  # 16 blocks, the last one short
    np.testing.assert_array_equal(W, expected)

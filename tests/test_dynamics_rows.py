"""dynamics: NumPy right-hand sides compiled into the simulator (RowsRHS) and their Python fallback."""

import pickle

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sindybench.dynamics import POW, OpCompileError, simulate
from sindybench.dynamics._rows import RowsRHS
from sindybench.dynamics._rows import ParametricRows as _HiddenRows

LAYOUT = ((1, 2), (0, 1), (2, 3))  # x_h = z[1], y = z[0], u = z[2]


def lag(xh, y, u, *, a, b):
    """h' = -a h + b tanh(u) y."""
    return -a * xh + b * np.tanh(u[:1]) * y


_GAINS = {"k": 1.0}  # a global dict: numba cannot type it


def not_numba(xh, y, u, *, a):
    return -a * xh + _GAINS["k"] * u[:1]


def _terms_and_coef():
    terms = [((0, POW, 1, 0),), ((1, POW, 1, 0),), ((2, POW, 1, 0),)]
    coef = np.array([[-1.0, 0.0], [1.5, 0.0], [0.3, 0.0]])  # y' = -y + 1.5 h + 0.3 u; h' from the rows
    return terms, coef


def test_rows_rhs_simulates_as_the_python_path(rng):
    terms, coef = _terms_and_coef()
    params = {"a": 2.0, "b": 0.7}
    rhs = RowsRHS(coef, terms, 2, lag, params, LAYOUT, 1)
    rows = _HiddenRows(lag, params, 1, 1)
    assert isinstance(rows.compiled(coef, terms, 2), RowsRHS)

    def python(x, u):
        return rhs.base(x, u) + rows(x, u)

    u = np.sin(np.linspace(0, 20, 400))[:, None] + 0.2 * rng.normal(size=(400, 1))
    kw = dict(n_substeps=2, input_hold="linear", bounds=([-5.0, -0.5], [5.0, 0.5]))
    fast = simulate(rhs, [0.1, 0.2], u, 0.02, **kw)
    assert np.ptp(fast[:, 1]) > 0.1
    assert_allclose(fast, simulate(python, [0.1, 0.2], u, 0.02, **kw), rtol=1e-12, atol=1e-14)
    assert_allclose(rhs(fast[7], u[7]), python(fast[7], u[7]), rtol=1e-14)
    again = pickle.loads(pickle.dumps(rhs))
    assert np.array_equal(simulate(again, [0.1, 0.2], u, 0.02, **kw), fast)


def test_rows_that_do_not_compile_fall_back_with_a_warning():
    terms, coef = _terms_and_coef()
    with pytest.raises(OpCompileError, match="cannot be compiled by numba"):
        RowsRHS(coef, terms, 2, not_numba, {"a": 1.0}, LAYOUT, 1)
    with pytest.warns(UserWarning, match="runs on the Python path"):
        assert _HiddenRows(not_numba, {"a": 1.0}, 1, 1).compiled(coef, terms, 2) is None
    with pytest.raises(OpCompileError, match="does not take"):
        RowsRHS(coef, terms, 2, lag, {"a": 1.0}, LAYOUT, 1)  # b is missing

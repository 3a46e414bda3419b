"""The fitted-dynamics value and its assembler (sindybench.dynamics._model)."""

import pickle

import numpy as np
import pytest

from sindybench.dynamics import Dynamics, assemble
from sindybench.libraries import CustomLibrary, PolynomialLibrary
from sindybench.simulate import TermsRHS, simulate

DT = 0.05


@pytest.fixture
def library():
    return PolynomialLibrary(degree=1).fit(np.zeros((1, 3)))  # terms 1, x0, x1, u0


def _inputs(rng, n=200):
    return np.sin(np.arange(n) * DT)[:, None] + 0.1 * rng.normal(size=(n, 1))


def test_compiled_model_equals_the_terms_rhs_it_stands_for(library, rng):
    coef = np.array([[0.0, 0.0], [0.0, -2.0], [1.0, -0.3], [0.0, 1.5]])  # x0' = x1, x1' = -2 x0 - 0.3 x1 + 1.5 u
    dyn = assemble(library, coef, state_names=["y", "v"], output_index=[0], dt=DT, n_substeps=2,
                   input_hold="linear", bounds=(-5.0, 5.0))
    assert isinstance(dyn, Dynamics) and dyn.compiled
    assert (dyn.n_states, dyn.state_names, dyn.output_index, dyn.learned) == (2, ("y", "v"), (0,), (0, 1))
    u = _inputs(rng)
    direct = simulate(TermsRHS(coef, library.terms_, 2), [0.2, 0.0], u, DT, n_substeps=2, input_hold="linear",
                      bounds=(-5.0, 5.0))
    np.testing.assert_array_equal(dyn.simulate(u, [0.2, 0.0]), direct)
    assert dyn.settings == dict(n_substeps=2, method="rk4", input_hold="linear", bounds=(-5.0, 5.0), max_abs=np.inf)


def test_python_path_gives_the_compiled_numbers(rng):
    lin = PolynomialLibrary(degree=1, include_bias=False).fit(np.zeros((1, 2)))  # terms x0, u0
    compiled = assemble(lin, np.array([[-1.0], [2.0]]), dt=DT)  # x0' = -x0 + 2 u
    custom = CustomLibrary(functions=[np.positive], compile=False).fit(np.zeros((1, 2)))  # the same, in Python
    python = assemble(custom, np.array([[-1.0], [2.0]]), dt=DT)
    assert compiled.compiled and not python.compiled and python.terms is None
    u = _inputs(rng)
    np.testing.assert_allclose(python.simulate(u, [1.0]), compiled.simulate(u, [1.0]), rtol=1e-12, atol=1e-14)
    restored = pickle.loads(pickle.dumps(python))  # estimators holding it must pickle
    np.testing.assert_array_equal(restored.simulate(u, [1.0]), python.simulate(u, [1.0]))


def test_fixed_rows_join_the_learned_rows_and_rhs_for_swaps_coefficients(library, rng):
    # x0' = x1 fixed (the chain row), x1' learned; the fixed block's learned column is ignored
    fixed_terms = [((1, 0, 1, 0),)]
    learned = np.array([[0.0], [-4.0], [-0.5], [1.0]])
    dyn = assemble(library, learned, n_states=2, learned=[1], fixed_terms=fixed_terms,
                   fixed_coef=[[1.0, 99.0]], dt=DT)
    assert dyn.compiled and len(dyn.terms) == 5
    np.testing.assert_array_equal(dyn.coef[:, 0], [0, 0, 0, 0, 1.0])
    np.testing.assert_array_equal(dyn.coef[:, 1], [0, -4.0, -0.5, 1.0, 0])
    x, u = np.array([0.3, -0.2]), np.array([0.7])
    np.testing.assert_allclose(dyn.rhs(x, u), [-0.2, -4.0 * 0.3 + 0.5 * 0.2 + 0.7])
    doubled = dyn.rhs_for(2.0 * dyn.coef)
    np.testing.assert_allclose(doubled(x, u), 2.0 * dyn.rhs(x, u))
    python = assemble(library, learned, n_states=2, learned=[1], fixed_rhs=lambda x, u: np.array([x[1], 123.0]),
                      dt=DT)
    assert not python.compiled
    np.testing.assert_allclose(python.rhs(x, u), dyn.rhs(x, u))  # the learned entry overwrites 123
    np.testing.assert_allclose(python.rhs_for(2.0 * python.coef)(x, u), [-0.2, 2.0 * dyn.rhs(x, u)[1]])


def test_bad_coefficient_shape_is_a_clear_error(library):
    with pytest.raises(ValueError, match="coef has 2 columns; expected 1"):
        assemble(library, np.zeros((4, 2)), n_states=2, learned=[1])

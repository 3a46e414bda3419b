"""sindybench.export: the CasADi export agrees with the simulator."""

import sys

import numpy as np
import pytest

from sindybench import SINDy
from sindybench.estimation import ModelStep, linearize
from sindybench.export import simulate_casadi, to_casadi
from sindybench.libraries import PolynomialLibrary
from sindybench.libraries._terms import ABS_POW, POW, SIGN, SQRT, STEP
from sindybench.simulate import TermsRHS, simulate

casadi = pytest.importorskip("casadi")

DT = 0.05


def lin(col):
    return ((col, POW, 1.0, 0.0),)


# every factor operation; x2 bounded in [0, 0.25] and reaching the upper bound; input in column 3
MIXED = TermsRHS.from_equations([
    {lin(1): 1.0},
    {lin(0): -1.5, ((1, ABS_POW, 1.0, 0.0), (0, POW, 1.0, 0.0)): -0.2, ((1, SIGN, 0.0, 0.0), (1, POW, 2.0, 0.0)): -0.1,
     lin(3): 1.0, lin(2): -0.5, ((3, STEP, 0.5, np.inf), (1, POW, 1.0, 0.0)): -0.3},
    {((0, SQRT, 0.0, 0.3),): 0.8, ((2, POW, 1.5, 0.0),): -0.6, ((0, ABS_POW, 2.5, 0.0),): 0.1},
])
BOUNDS = ([-np.inf, -np.inf, 0.0], [np.inf, np.inf, 0.25])


@pytest.mark.parametrize("method, hold, n_sub", [("rk4", "zoh", 1), ("rk4", "linear", 3), ("euler", "linear", 2)])
def test_casadi_run_matches_the_simulator(method, hold, n_sub, rng):
    m = ModelStep.from_rhs(MIXED, DT, n_inputs=1, bounds=BOUNDS, n_substeps=n_sub, method=method, input_hold=hold)
    u = np.repeat(rng.uniform(-1.0, 2.0, (30, 1)), 10, axis=0)
    x0 = np.array([0.2, -0.3, 0.1])
    x_sim = simulate(MIXED, x0, u, DT, n_substeps=n_sub, method=method, input_hold=hold, bounds=BOUNDS)
    x_ca = simulate_casadi(to_casadi(m), x0, u)
    assert np.any(x_sim[:, 2] == 0.25) and np.any(x_sim[:, 0] > 0.3) and np.any(x_sim[:, 0] < 0.0)
    np.testing.assert_allclose(x_ca, x_sim, rtol=1e-9, atol=1e-12)


def test_casadi_rhs_and_jacobian_match_the_model(rng):
    m = ModelStep.from_rhs(MIXED, DT, n_inputs=1, bounds=BOUNDS, n_substeps=2)
    cm = to_casadi(m)
    x, u = np.array([0.15, -0.4, 0.1]), np.array([0.7])
    np.testing.assert_allclose(np.asarray(cm.rhs(x, u)).ravel(), MIXED(x, u), rtol=1e-13)
    # CasADi's automatic derivative of the step is the discrete linearization
    xs, us = casadi.SX.sym("x", 3), casadi.SX.sym("u", 1)
    jac = casadi.Function("j", [xs, us], [casadi.jacobian(cm.step(xs, us, us), casadi.vertcat(xs, us))])
    lin = linearize(m, x, u)
    np.testing.assert_allclose(np.asarray(jac(x, u)), np.hstack([lin.Ad, lin.Bd]), rtol=1e-10, atol=1e-12)
    assert np.asarray(cm.output(x)).ravel().tolist() == [0.15]


def test_casadi_export_of_a_fitted_sindy(rng):
    t = np.arange(600) * DT
    u = np.sin(0.8 * t)[:, None]
    truth = TermsRHS.from_equations([{lin(1): 1.0}, {lin(0): -2.0, lin(1): -0.3, ((0, POW, 3.0, 0.0),): -0.5,
                                                     lin(2): 1.0}])
    y = simulate(truth, [0.5, 0.0], u, DT, n_substeps=2)
    model = SINDy(library=PolynomialLibrary(degree=3), dt=DT, n_substeps=2, input_hold="linear").fit(u, y)
    x_ca = simulate_casadi(to_casadi(model), y[0], u)
    np.testing.assert_allclose(x_ca, model.simulate(u, y[0]), rtol=1e-9, atol=1e-12)


def test_missing_casadi_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "casadi", None)
    with pytest.raises(ImportError, match=r'pip install "sindybench\[casadi\]"'):
        to_casadi(ModelStep.from_rhs(MIXED, DT, n_inputs=1))


def test_simulate_casadi_checks_shapes():
    cm = to_casadi(ModelStep.from_rhs(MIXED, DT, n_inputs=1))
    with pytest.raises(ValueError, match=r"expected \(3,\) and \(n_samples, 1\)"):
        simulate_casadi(cm, [0.0, 0.0], np.zeros((5, 1)))
    # before: NaN rows from a NaN input, silently
    u = np.zeros((5, 1))
    u[2] = np.nan
    with pytest.raises(ValueError, match=r"u contains NaN or inf \(first at sample 2\)"):
        simulate_casadi(cm, [0.0, 0.0, 0.1], u)
    with pytest.raises(ValueError, match="x0 = .* contains NaN or inf"):
        simulate_casadi(cm, [np.nan, 0.0, 0.1], np.zeros((5, 1)))



def test_user_operations_export_when_numpy_names_them_and_say_so_otherwise():
    from sindybench.dynamics import register_op

    tanh = register_op(np.tanh)
    rhs = TermsRHS.from_equations([{((0, tanh, 0.0, 0.0),): -1.0, lin(1): 1.0}])
    u = np.sin(np.linspace(0.0, 3.0, 40))[:, None]
    x_ca = simulate_casadi(to_casadi(ModelStep.from_rhs(rhs, DT, n_inputs=1)), [0.3], u)
    np.testing.assert_allclose(x_ca, simulate(rhs, [0.3], u, DT), rtol=1e-12, atol=1e-14)
    smooth = register_op(lambda v: np.tanh(v / 0.02), name="tanh({}/0.02)")
    rhs = TermsRHS.from_equations([{((0, smooth, 0.0, 0.0),): -1.0}])
    with pytest.raises(ValueError, match=r"user operation 'tanh\(z/0.02\)' .* has no CasADi form"):
        to_casadi(ModelStep.from_rhs(rhs, DT))


def test_a_clipped_square_root_has_the_simulators_value_and_derivative():
    """One clip for simulator and export: sqrt(clip(x, 0, 0.3)) is flat (derivative 0) at and outside its ends."""
    rhs = TermsRHS.from_equations([{((0, SQRT, 0.0, 0.3),): 1.0}])
    cm = to_casadi(ModelStep.from_rhs(rhs, DT))
    xs = casadi.SX.sym("x", 1)
    slope = casadi.Function("d", [xs], [casadi.jacobian(cm.rhs(xs, casadi.SX.sym("u", 0)), xs)])
    for x, value, derivative in [(-0.1, 0.0, 0.0), (0.0, 0.0, 0.0), (0.04, 0.2, 2.5), (0.3, np.sqrt(0.3), 0.0),
                                 (0.5, np.sqrt(0.3), 0.0)]:
        assert float(cm.rhs([x], [])) == rhs([x], np.zeros(0))[0] == pytest.approx(value, rel=1e-15)
        assert float(slope([x])) == pytest.approx(derivative, rel=1e-12)

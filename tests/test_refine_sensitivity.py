"""sindybench.refine.simulate_sensitivity: forward sensitivities of every factor operation, against finite differences."""

import numpy as np
import pytest

from sindybench.libraries._terms import ABS_POW, POW, SIGN, SQRT, STEP, evaluate_terms, evaluate_terms_jacobian
from sindybench.dynamics import Dynamics
from sindybench.refine import FreeParameters, refine_simulation_error, simulate_sensitivity
from sindybench.simulate import SimulationError, TermsRHS, simulate

X0, X1, X2, U = 0, 1, 2, 3
DT = 0.05


def lin(col):
    return ((col, POW, 1.0, 0.0),)


# A 3-state model that uses every factor operation: an oscillator (x0, x1) with cubic, |x1| x0,
# |x0|^2.5, sign(x1) x1^2 and [u>=0.2] x1 terms, driven by u and by a positive lag state x2 with a
# non-integer power x2^1.5 and a clipped square root of x0 (clip active on both sides).
# (SIGN and STEP jump: they act on the state through products that are continuous, or on the
# input, so that finite differences of the trajectory exist.)
TERMS = [lin(X1), lin(X0), ((X0, POW, 3.0, 0.0),), ((X1, ABS_POW, 1.0, 0.0), (X0, POW, 1.0, 0.0)), lin(U),
         ((X0, ABS_POW, 2.5, 0.0),), ((X1, SIGN, 0.0, 0.0), (X1, POW, 2.0, 0.0)), lin(X2),
         ((X2, POW, 1.5, 0.0),), ((X0, SQRT, 0.05, 0.3),), (), ((U, STEP, 0.2, np.inf), (X1, POW, 1.0, 0.0))]
X2_BOUNDS = ([-np.inf, -np.inf, 0.0], [np.inf, np.inf, 0.7])


def every_op_coef(cubic=-1.0):
    coef = np.zeros((len(TERMS), 3))
    coef[0, 0] = 1.0
    coef[[1, 2, 3, 4, 5, 6, 7, 11], 1] = [-4.0, cubic, -0.3, 1.0, -0.2, -0.05, 0.3, -0.3]
    coef[[8, 9, 10, 4], 2] = [-0.8, 0.4, 0.45, 0.3]
    return coef


@pytest.fixture
def u_sines():
    k = np.arange(400)
    return (np.sin(0.05 * k) + 0.5 * np.sin(0.13 * k))[:, None]


def unit_directions(coef):
    free = np.argwhere(coef != 0)
    D = np.zeros((len(free),) + coef.shape)
    D[np.arange(len(free)), free[:, 0], free[:, 1]] = 1.0
    return free, D


def fd_sensitivities(coef, x0, u, free, settings, eps=1e-6, terms=TERMS):
    """Central differences of simulate() for every free coefficient, then every x0 entry."""
    cols = []
    for j, i in free:
        step = eps * max(1.0, abs(coef[j, i]))
        hi, lo = coef.copy(), coef.copy()
        hi[j, i] += step
        lo[j, i] -= step
        cols.append((simulate(TermsRHS(hi, terms, 3), x0, u, DT, **settings)
                     - simulate(TermsRHS(lo, terms, 3), x0, u, DT, **settings)) / (2 * step))
    rhs = TermsRHS(coef, terms, 3)
    for k in range(x0.size):
        hi, lo = x0.copy(), x0.copy()
        hi[k] += eps
        lo[k] -= eps
        cols.append((simulate(rhs, hi, u, DT, **settings) - simulate(rhs, lo, u, DT, **settings)) / (2 * eps))
    return np.stack(cols, axis=2)


SETTINGS = [
    pytest.param({}, id="rk4-zoh"),
    pytest.param({"method": "euler", "n_substeps": 4}, id="euler-substeps"),
    pytest.param({"input_hold": "linear", "n_substeps": 3}, id="rk4-linear-substeps"),
    pytest.param({"bounds": X2_BOUNDS}, id="rk4-bounded"),
]


# ------------------------------------------------------------- sensitivities
@pytest.mark.parametrize("settings", SETTINGS)
def test_sensitivity_states_equal_simulate_and_match_finite_differences(settings, u_sines):
    coef = every_op_coef(cubic=0.0)  # x0^3 (POW 3) has its own test below
    x0 = np.array([0.5, 0.1, 0.6])
    free, D = unit_directions(coef)
    rhs = TermsRHS(coef, TERMS, 3)
    x, S, S_end = simulate_sensitivity(rhs, x0, u_sines, DT, directions=D, free_x0=[0, 1, 2], **settings)
    assert np.array_equal(x, simulate(rhs, x0, u_sines, DT, **settings))
    assert S.shape == (400, 3, len(free) + 3)
    assert np.array_equal(S_end, S[-1])
    J = fd_sensitivities(coef, x0, u_sines, free, settings)
    rel = np.abs(J - S).max(axis=(0, 1)) / np.abs(S).max(axis=(0, 1))
    assert rel.max() < 1e-6
    assert np.all(np.abs(S).max(axis=(0, 1)) > 1e-3)  # every parameter moves the trajectory


def test_sensitivity_along_a_dense_direction(u_sines, rng):
    """A physical parameter moves several coefficients at once: d x / d p along dC/dp = D."""
    coef = every_op_coef(cubic=0.0)
    D = rng.uniform(-1.0, 1.0, coef.shape) * (coef != 0)
    D[10, 1] = 0.5  # and an entry whose coefficient is zero (the constant of x1')
    x0 = np.array([0.5, 0.1, 0.6])
    _, S, _ = simulate_sensitivity(TermsRHS(coef, TERMS, 3), x0, u_sines, DT, directions=D[None], bounds=X2_BOUNDS)
    eps = 1e-6
    fd = (simulate(TermsRHS(coef + eps * D, TERMS, 3), x0, u_sines, DT, bounds=X2_BOUNDS)
          - simulate(TermsRHS(coef - eps * D, TERMS, 3), x0, u_sines, DT, bounds=X2_BOUNDS)) / (2 * eps)
    assert np.abs(S[:, :, 0]).max() > 1e-2
    assert np.abs(fd - S[:, :, 0]).max() < 1e-6 * np.abs(S[:, :, 0]).max()


def test_sensitivity_is_zero_while_clipped_at_a_bound(u_sines):
    coef = every_op_coef(cubic=0.0)
    x0 = np.array([0.5, 0.1, 0.6])
    free, D = unit_directions(coef)
    x, S, _ = simulate_sensitivity(TermsRHS(coef, TERMS, 3), x0, u_sines, DT, directions=D, free_x0=[0, 1, 2],
                                   bounds=X2_BOUNDS)
    held = x[:, 2] == 0.7
    assert 50 < held.sum() < 350  # the bound is hit, left and hit again
    assert np.all(S[held, 2] == 0.0)
    assert np.abs(S[~held, 2]).max() > 1e-2


def test_overflow_indicator_of_a_bounded_state(u_sines):
    """[x2>=0.7] on a state held at its bound 0.7 (an overflowing tank): exact states and sensitivities."""
    terms = TERMS + [((X2, STEP, 0.7, np.inf),)]
    coef = np.vstack([every_op_coef(cubic=0.0), [[0.0, -0.5, 0.0]]])  # x1' gets -0.5 while x2 overflows
    x0 = np.array([0.5, 0.1, 0.6])
    free, D = unit_directions(coef)
    rhs = TermsRHS(coef, terms, 3)
    x, S, _ = simulate_sensitivity(rhs, x0, u_sines, DT, directions=D, free_x0=[0, 1, 2], bounds=X2_BOUNDS)
    assert np.array_equal(x, simulate(rhs, x0, u_sines, DT, bounds=X2_BOUNDS))
    without = simulate(TermsRHS(coef[:-1], TERMS, 3), x0, u_sines, DT, bounds=X2_BOUNDS)
    assert np.abs(x[:, 1] - without[:, 1]).max() > 0.1  # the indicator acts
    J = fd_sensitivities(coef, x0, u_sines, free, {"bounds": X2_BOUNDS}, terms=terms)
    assert (np.abs(J - S).max(axis=(0, 1)) / np.abs(S).max(axis=(0, 1))).max() < 1e-6
    assert np.abs(S[:, :, -4]).max() > 1e-2  # the indicator's coefficient is a live parameter


@pytest.mark.parametrize("op", [POW, ABS_POW])
def test_cube_bit_for_bit(op, u_sines):
    terms = [lin(X1), lin(X0), ((X0, op, 3.0, 0.0),), lin(2)]  # two states: the input is column 2
    coef = np.array([[1.0, 0.0], [0.0, -4.0], [0.0, -1.0], [0.0, 1.0]])
    rhs = TermsRHS(coef, terms, 2)
    x, _, _ = simulate_sensitivity(rhs, [0.5, 0.1], u_sines, DT)
    assert np.array_equal(x, simulate(rhs, [0.5, 0.1], u_sines, DT))


def test_zero_coefficient_direction_leaves_the_state_unchanged(u_sines):
    terms = [lin(X1), lin(X0), lin(2), ((X0, POW, 0.5, 0.0),)]  # two states: the input is column 2
    coef = np.array([[1.0, 0.0], [0.0, -4.0], [0.0, 1.0], [0.0, 0.0]])
    rhs = TermsRHS(coef, terms, 2)
    D = np.zeros((1, 4, 2))
    D[0, 3, 1] = 1.0  # free the zero coefficient of x0^0.5 (x0 goes negative)
    x_ref = simulate(rhs, [0.5, 0.1], u_sines, DT)
    assert x_ref[:, 0].min() < 0
    x, _, _ = simulate_sensitivity(rhs, [0.5, 0.1], u_sines, DT, directions=D, on_divergence="nan")
    assert np.array_equal(x, x_ref)


# x |x|^0.5 (a Bouc-Wen-type law with nu = 1.5) is C^1 with derivative 1.5 |x|^0.5, 0 at x = 0
C1_TERMS = [((0, ABS_POW, 0.5, 0.0), (0, POW, 1.0, 0.0)), lin(1)]
C1_COEF = np.array([[-1.0], [1.0]])  # x' = -x |x|^0.5 + u, from rest


def test_terms_jacobian_of_a_c1_product_at_zero():
    J = evaluate_terms_jacobian(C1_TERMS[:1], np.array([[0.0], [0.04]]))
    np.testing.assert_allclose(J[:, 0, 0], [0.0, 1.5 * 0.2])


def test_sensitivity_of_a_c1_product_through_zero(u_sines):
    rhs = TermsRHS(C1_COEF, C1_TERMS, 1)
    x, S, _ = simulate_sensitivity(rhs, [0.0], u_sines, DT, directions=np.eye(2).reshape(2, 2, 1), free_x0=[0],
                                   on_divergence="nan")
    assert np.all(np.isfinite(x))
    assert np.all(np.isfinite(S))


def test_refine_a_c1_product_from_rest(u_sines):
    y = simulate(TermsRHS(C1_COEF, C1_TERMS, 1), [0.0], u_sines, DT)
    res = refine_simulation_error(Dynamics.from_terms(C1_TERMS, C1_COEF * 0.9, dt=DT), u_sines, y, x0=[0.0],
                                  free=FreeParameters(x0=[]))
    np.testing.assert_allclose(res.coef, C1_COEF, rtol=1e-6)


def test_sensitivity_output_index_and_divergence(u_sines):
    coef = every_op_coef()
    rhs = TermsRHS(coef, TERMS, 3)
    _, D = unit_directions(coef)
    x, S, S_end = simulate_sensitivity(rhs, [0.5, 0.1, 0.6], u_sines, DT, directions=D, output_index=[2, 0])
    _, S_all, _ = simulate_sensitivity(rhs, [0.5, 0.1, 0.6], u_sines, DT, directions=D)
    assert np.array_equal(S, S_all[:, [2, 0]])
    assert S_end.shape == (3, D.shape[0])
    blow = TermsRHS([[1.0]], [((0, POW, 2.0, 0.0),)], 1)  # x' = x^2 from 1 blows up at t = 1
    with pytest.raises(SimulationError, match="diverged at step"):
        simulate_sensitivity(blow, [1.0], np.zeros((30, 0)), 0.1, free_x0=[0])
    x, S, S_end = simulate_sensitivity(blow, [1.0], np.zeros((30, 0)), 0.1, free_x0=[0], on_divergence="nan")
    k = int(np.argmax(np.isnan(x[:, 0])))
    assert 5 < k < 15 and np.all(np.isnan(x[k:])) and np.all(np.isnan(S[k:])) and np.all(np.isnan(S_end))
    assert np.all(np.isfinite(S[:k]))


def test_evaluate_terms_jacobian_matches_finite_differences(rng):
    Z = np.column_stack([rng.uniform(-1, 1, 200), rng.uniform(-2, 2, 200), rng.uniform(0.2, 1.0, 200),
                         rng.uniform(-1, 1, 200)])
    Z = Z[np.abs(Z[:, 0] - 0.05) > 1e-3]
    Z = Z[np.abs(Z[:, 0] - 0.3) > 1e-3]  # away from the clip kinks of sqrt
    Z = Z[np.abs(Z[:, 3] - 0.2) > 1e-3]  # and from the jump of [u>=0.2]
    J = evaluate_terms_jacobian(TERMS, Z)
    assert J.shape == (Z.shape[0], len(TERMS), 4)
    eps = 1e-6
    for c in range(4):
        hi, lo = Z.copy(), Z.copy()
        hi[:, c] += eps
        lo[:, c] -= eps
        fd = (evaluate_terms(TERMS, hi) - evaluate_terms(TERMS, lo)) / (2 * eps)
        np.testing.assert_allclose(J[:, :, c], fd, rtol=1e-6, atol=1e-6)
    clipped = (Z[:, 0] < 0.05) | (Z[:, 0] > 0.3)
    assert clipped.any() and np.all(J[clipped, 9, 0] == 0.0)
    assert np.all(J[:, 6, 1] == 2 * np.abs(Z[:, 1]))  # d(sign(v) v^2)/dv = 2 |v|
    assert np.all(J[:, 11, 1] == (Z[:, 3] >= 0.2)) and np.all(J[:, 11, 3] == 0.0)  # [u>=0.2] v

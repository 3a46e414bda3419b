"""dynamics: the one-step map (bit for bit the simulator), its Jacobians (against differences), numba use."""

import numpy as np
import pytest
from numba import njit
from numpy.testing import assert_allclose

from sindybench.dynamics import (
    ABS_POW,
    POW,
    SIGN,
    SQRT,
    STEP,
    SimulationError,
    TermsRHS,
    coefficient_directions,
    jacobian_workspace,
    simulate,
    step,
    step_into,
    step_jacobian,
    step_jacobian_into,
    step_jacobian_kernel,
    step_kernel,
    step_model,
    step_workspace,
)
from sindybench.refine import simulate_sensitivity

TERMS = [(), ((0, POW, 1, 0),), ((1, POW, 1, 0),), ((2, POW, 1, 0),), ((0, POW, 2, 0), (2, POW, 1, 0)),
         ((0, ABS_POW, 1, 0), (1, POW, 1, 0)), ((0, SQRT, 0.0, np.inf),), ((1, SIGN, 0, 0),),
         ((0, STEP, 0.9, np.inf), (2, POW, 1, 0))]
SETTINGS = [dict(), dict(method="euler", n_substeps=3), dict(input_hold="linear", n_substeps=2),
            dict(bounds=([0.0, -1.0], [1.2, 1.0]), input_hold="linear")]


@pytest.fixture
def model(rng):
    coef = np.zeros((len(TERMS), 2))
    coef[2, 0], coef[1, 1], coef[2, 1], coef[3, 1] = 1.0, -3.0, -0.4, 1.0
    coef[4:, :] = rng.normal(scale=0.2, size=(len(TERMS) - 4, 2))
    return TermsRHS(coef, TERMS, 2)


@pytest.fixture
def inputs(rng):
    return np.cumsum(rng.normal(scale=0.3, size=(120, 1)), axis=0) * 0.2


@pytest.mark.parametrize("settings", SETTINGS)
def test_step_reproduces_simulate_bit_for_bit(model, inputs, settings):
    x = simulate(model, [0.5, 0.1], inputs, 0.05, **settings)
    stepped = [x[0]]
    for k in range(len(inputs) - 1):
        stepped.append(step(model, stepped[-1], inputs[k], inputs[k + 1], 0.05, **settings))
    assert np.array_equal(np.array(stepped), x)
    # and the Jacobian's state is the same one
    for k in (0, 37, 118):
        x1, _, _ = step_jacobian(model, x[k], inputs[k], inputs[k + 1], 0.05, **settings)
        assert np.array_equal(x1, x[k + 1])


@pytest.mark.parametrize("settings", SETTINGS)
def test_step_jacobians_match_central_differences(model, inputs, settings):
    x, u0, u1, dt = np.array([0.6, -0.3]), inputs[5], inputs[6], 0.05
    x1, jx, jp = step_jacobian(model, x, u0, u1, dt, **settings)
    eps = 1e-6
    fd_x = np.column_stack([(step(model, x + eps * e, u0, u1, dt, **settings)
                             - step(model, x - eps * e, u0, u1, dt, **settings)) / (2 * eps) for e in np.eye(2)])
    assert_allclose(jx, fd_x, rtol=1e-6, atol=1e-8)
    D = coefficient_directions(model)
    assert jp.shape == (2, D.shape[0])

    def moved(d):
        return step(TermsRHS(model.coef + d, model.terms, 2), x, u0, u1, dt, **settings)

    fd_p = np.column_stack([(moved(eps * d) - moved(-eps * d)) / (2 * eps) for d in D])
    assert_allclose(jp, fd_p, rtol=1e-6, atol=1e-8)


def test_step_jacobian_chains_to_the_trajectory_sensitivity(model, inputs):
    """The product of the one-step state Jacobians is d x_k / d x_0 of simulate_sensitivity."""
    x, S, _ = simulate_sensitivity(model, [0.5, 0.1], inputs[:30], 0.05, free_x0=[0, 1])
    J = np.eye(2)
    for k in range(29):
        _, jx, _ = step_jacobian(model, x[k], inputs[k], inputs[k + 1], 0.05)
        J = jx @ J
    assert_allclose(J, S[-1], rtol=1e-12, atol=1e-14)


@njit
def _loop(m, x0, u, dt):
    """A numba loop over the step, as a Kalman filter would run it."""
    x = x0.copy()
    P = np.eye(x.shape[0])
    for k in range(u.shape[0] - 1):
        x, jx, _, bad = step_jacobian_kernel(m, x, u[k], u[k + 1], dt)
        P = jx @ P @ jx.T
        x2, bad2 = step_kernel(m, x0, u[k], u[k + 1], dt)
    return x, P, x2


def test_step_kernels_are_callable_from_numba(model, inputs):
    m = step_model(model, input_hold="linear")
    x, P, _ = _loop(m, np.array([0.5, 0.1]), inputs, 0.05)
    assert np.array_equal(x, simulate(model, [0.5, 0.1], inputs, 0.05, input_hold="linear")[-1])
    assert P.shape == (2, 2) and np.all(np.isfinite(P))


@njit
def _loop_in_place(m, x0, u, dt):
    """The in-place forms over a whole record, the work arrays allocated once."""
    n, n_par = x0.shape[0], m.par[0].shape[0] - 1
    xs, Js, Ps = np.empty((u.shape[0], n)), np.empty((u.shape[0], n, n)), np.empty((u.shape[0], n, n_par))
    x, x2 = x0.copy(), x0.copy()
    work, work2 = jacobian_workspace(m, u.shape[1]), step_workspace(m, u.shape[1])
    for k in range(u.shape[0] - 1):
        bad = step_jacobian_into(m, x, u[k], u[k + 1], dt, work, Js[k], Ps[k])
        bad2 = step_into(m, x2, u[k], u[k + 1], dt, work2)
        if bad or bad2 or not np.array_equal(x, x2):
            return xs[:k], Js[:k], Ps[:k]
        xs[k + 1] = x
    xs[0] = x0
    return xs, Js[:-1], Ps[:-1]


def test_in_place_steps_are_the_kernels_bit_for_bit(model, inputs):
    """step_into / step_jacobian_into with work reused over samples give the fresh kernels' every bit."""
    m = step_model(model, input_hold="linear", bounds=([0.0, -1.0], [1.2, 1.0]))
    xs, Js, Ps = _loop_in_place(m, np.array([0.5, 0.1]), inputs, 0.05)
    assert np.array_equal(xs, simulate(model, [0.5, 0.1], inputs, 0.05, input_hold="linear",
                                       bounds=([0.0, -1.0], [1.2, 1.0])))
    for k in (0, 7, len(Js) - 1):
        _, jx, jp, _ = step_jacobian_kernel(m, xs[k], inputs[k], inputs[k + 1], 0.05)
        assert np.array_equal(Js[k], jx) and np.array_equal(Ps[k], jp) and jp.shape[1] > 0


def test_step_divergence_and_bad_input(model):
    blowup = TermsRHS([[1.0]], [((0, POW, 3, 0),)], 1)
    with pytest.raises(SimulationError, match="diverged"):
        step(blowup, [1e100], [], dt=1.0)
    assert np.isnan(step(blowup, [1e100], [], dt=1.0, on_divergence="nan")).all()
    with pytest.raises(ValueError, match="expected 2 finite values"):
        step(model, [0.1], [0.0], dt=0.1)
    with pytest.raises(ValueError, match="expected 1 finite input values"):
        step(model, [0.1, 0.2], [0.0], [np.nan], dt=0.1)
    with pytest.raises(ValueError, match="u0 has 0 values"):
        step(model, [0.1, 0.2], [], dt=0.1)
    with pytest.raises(ValueError, match="positive finite"):
        step(model, [0.1, 0.2], [0.0], dt=-1.0)
    with pytest.raises(ValueError, match="must be a TermsRHS"):
        step(lambda x, u: -x, [0.1], [], dt=0.1)

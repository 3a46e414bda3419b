"""simulate(): accuracy on linear systems, compiled vs Python path, bounds, divergence, bad input."""

import numpy as np
import pytest
import scipy.linalg
from numpy.testing import assert_allclose

import sindybench
from sindybench.libraries import CustomLibrary, PolynomialLibrary
from sindybench.libraries._terms import ABS_POW, POW, SIGN, SQRT
from sindybench.simulate import SimulationError, TermsRHS, make_rhs, simulate

X0, X1, X2, U0 = (((i, POW, 1, 0),) for i in range(4))


def linear_rhs(A, B):
    """TermsRHS of x' = A x + B u over Z = [x, u]."""
    n, m = B.shape
    terms = [((i, POW, 1.0, 0.0),) for i in range(n + m)]
    return TermsRHS(np.vstack([A.T, B.T]), terms, n)


@pytest.fixture
def system():
    A = np.array([[0.0, 1.0, 0.0], [-4.0, -0.4, 1.0], [0.0, -1.0, -2.0]])
    B = np.array([[0.0], [1.0], [0.5]])
    return A, B


def exact_linear(A, B, x0, times, u_of_t_poly):
    """Exact x(t) of x' = A x + B u with u(t) = c0 + c1 t (augmented matrix exponential)."""
    n = A.shape[0]
    c0, c1 = u_of_t_poly
    M = np.zeros((n + 2, n + 2))
    M[:n, :n], M[:n, n] = A, B[:, 0]
    M[n, n + 1] = 1.0  # state n holds u, state n+1 holds du/dt
    z0 = np.concatenate([x0, [c0, c1]])
    return np.array([(scipy.linalg.expm(M * t) @ z0)[:n] for t in times])


def rel_error(x, ref):
    return np.max(np.abs(x - ref)) / np.max(np.abs(ref))


# -------------------------------------------------------------------- accuracy
def test_linear_autonomous_matches_expm(system):
    A, B = system
    x0 = np.array([1.0, -0.5, 0.3])
    n, dt = 1001, 0.01
    x = simulate(linear_rhs(A, B), x0, np.zeros((n, 1)), dt)
    ref = exact_linear(A, B, x0, np.arange(n) * dt, (0.0, 0.0))
    assert rel_error(x, ref) <= 1e-6


def test_linear_constant_input_matches_expm(system):
    A, B = system
    n, dt = 801, 0.02
    x = simulate(linear_rhs(A, B), np.zeros(3), np.full((n, 1), 0.7), dt, n_substeps=2)
    ref = exact_linear(A, B, np.zeros(3), np.arange(n) * dt, (0.7, 0.0))
    assert rel_error(x, ref) <= 1e-6


def test_linear_hold_follows_ramp_input(system):
    A, B = system
    n, dt = 501, 0.02
    t = np.arange(n) * dt
    u = (0.2 + 1.5 * t)[:, None]
    x = simulate(linear_rhs(A, B), np.zeros(3), u, dt, input_hold="linear")
    ref = exact_linear(A, B, np.zeros(3), t, (0.2, 1.5))
    assert rel_error(x, ref) <= 1e-6
    # zero-order hold lags the ramp: an error far above the integration error
    assert rel_error(simulate(linear_rhs(A, B), np.zeros(3), u, dt), ref) > 1e-3


def test_zoh_matches_discretised_system(system, rng):
    A, B = system
    n, dt = 300, 0.05
    u = rng.normal(size=(n, 1))
    M = scipy.linalg.expm(np.block([[A, B], [np.zeros((1, 4))]]) * dt)
    Ad, Bd = M[:3, :3], M[:3, 3:]
    ref = np.zeros((n, 3))
    ref[0] = [0.1, 0.0, 0.0]
    for k in range(n - 1):
        ref[k + 1] = Ad @ ref[k] + Bd @ u[k]
    x = simulate(linear_rhs(A, B), ref[0], u, dt, n_substeps=5)
    assert rel_error(x, ref) <= 1e-6


def test_nonuniform_times(system, rng):
    A, B = system
    t = np.cumsum(np.r_[0.0, rng.uniform(0.005, 0.02, size=400)])
    x = simulate(linear_rhs(A, B), np.array([1.0, 0.0, 0.0]), np.zeros((t.size, 1)), t=t)
    ref = exact_linear(A, B, np.array([1.0, 0.0, 0.0]), t, (0.0, 0.0))
    assert rel_error(x, ref) <= 1e-6


def test_euler_is_first_order():
    rhs = TermsRHS([[-1.0]], [X0], 1)
    errors = [abs(simulate(rhs, [1.0], np.zeros((11, 0)), 0.1, n_substeps=s, method="euler")[-1, 0] - np.exp(-1))
              for s in (10, 20)]
    assert 1.9 < errors[0] / errors[1] < 2.1


def test_output_layout(system):
    A, B = system
    x = simulate(linear_rhs(A, B), [1.0, 2.0, 3.0], np.zeros((7, 1)), 0.1)
    assert x.shape == (7, 3)
    assert x[0].tolist() == [1.0, 2.0, 3.0]
    assert simulate(linear_rhs(A, B), [1.0, 2.0, 3.0], np.zeros((1, 1)), 0.1).tolist() == [[1.0, 2.0, 3.0]]


# ------------------------------------------------------ compiled == Python path
@pytest.fixture
def nonlinear_rhs():
    """Every factor operation; states (x0, x1, x2), input u0."""
    terms = [
        (),
        X0,
        X1,
        U0,
        ((0, POW, 3.0, 0.0),),
        ((1, ABS_POW, 1.0, 0.0), (2, POW, 1.0, 0.0)),
        ((2, ABS_POW, 1.5, 0.0),),
        ((0, SQRT, 0.0, 2.0),),
        ((1, SIGN, 0.0, 0.0),),
        ((2, POW, 2.0, 0.0), (0, POW, 1.0, 0.0)),
    ]
    coef = np.array([
        [0.1, 0.0, 0.0],
        [0.0, -2.0, 0.5],
        [1.0, -0.3, 0.0],
        [0.0, 1.0, 0.2],
        [0.0, -0.5, 0.0],
        [0.0, 0.0, -0.4],
        [0.0, 0.0, -0.1],
        [-0.2, 0.0, 0.0],
        [0.0, -0.05, 0.0],
        [0.0, 0.0, 0.0],  # inactive term: skipped by the compiled kernel
    ])
    return TermsRHS(coef, terms, 3)


@pytest.mark.parametrize("method", ["rk4", "euler"])
@pytest.mark.parametrize("input_hold", ["zoh", "linear"])
@pytest.mark.parametrize("n_substeps", [1, 3])
def test_compiled_equals_python_path(nonlinear_rhs, rng, method, input_hold, n_substeps):
    u = np.sin(np.linspace(0, 20, 400))[:, None] + 0.1 * rng.normal(size=(400, 1))
    kw = dict(method=method, input_hold=input_hold, n_substeps=n_substeps, bounds=([0.0, None, -1.0], [3.0, None, 1.0]))
    fast = simulate(nonlinear_rhs, [0.5, 0.0, 0.0], u, 0.05, **kw)
    slow = simulate(nonlinear_rhs.__call__, [0.5, 0.0, 0.0], u, 0.05, **kw)
    assert np.ptp(fast[:, 1]) > 0.1  # the model moves
    assert_allclose(fast, slow, rtol=1e-10, atol=1e-12)


def test_make_rhs_custom_library_equals_compiled(rng):
    Z = rng.normal(size=(5, 2))
    coef = np.array([[-1.0], [0.5]])
    compiled = make_rhs(PolynomialLibrary(degree=1, include_bias=False).fit(Z), coef, 1)
    custom = make_rhs(CustomLibrary(functions=[lambda z: z], compile=False).fit(Z), coef, 1)
    user = make_rhs(CustomLibrary(functions=[lambda z: z]).fit(Z), coef, 1)
    assert isinstance(compiled, TermsRHS) and not isinstance(custom, TermsRHS) and isinstance(user, TermsRHS)
    u = rng.normal(size=(200, 1))
    assert_allclose(simulate(compiled, [1.0], u, 0.01), simulate(custom, [1.0], u, 0.01), rtol=1e-12)
    assert np.array_equal(simulate(compiled, [1.0], u, 0.01), simulate(user, [1.0], u, 0.01))


def test_from_equations_equals_matrix():
    coupled = ((2, POW, 1.0, 0.0), (1, ABS_POW, 1.0, 0.0))
    rhs = TermsRHS.from_equations([{X1: 1.0}, {U0: 2.0, X0: -4.0, X1: -0.1, X2: -1.0}, {X1: 3.0, coupled: -0.5}])
    x, u = np.array([0.3, -0.2, 0.1]), np.array([0.5])
    expected = [-0.2, 1.0 - 1.2 + 0.02 - 0.1, -0.6 - 0.5 * 0.1 * 0.2]
    assert_allclose(rhs(x, u), expected)
    assert rhs.n_active == 5


# ---------------------------------------------------------------------- bounds
def test_bounds_saturate_and_stop_outward_derivative():
    # tank: x0' = u - 0.5 sqrt(x0), overflow at 2; x1' = sqrt(x0) - sqrt(x1)
    terms = [((2, POW, 1.0, 0.0),), ((0, SQRT, 0.0, np.inf),), ((1, SQRT, 0.0, np.inf),)]
    rhs = TermsRHS([[1.0, 0.0], [-0.5, 1.0], [0.0, -1.0]], terms, 2)
    u = np.r_[np.full(300, 3.0), np.zeros(300)][:, None]
    x = simulate(rhs, [0.0, 0.0], u, 0.05, bounds=(0.0, [2.0, None]))
    assert x[:, 0].max() == 2.0  # clipped exactly at the bound
    full = np.flatnonzero(x[:300, 0] == 2.0)
    assert full.size > 100 and np.all(np.diff(full) == 1)  # stays full while filling
    assert x[-1, 0] < 2.0 and np.all(x >= 0.0)  # drains once the input stops
    # the coupled tank only sees the saturated level: it settles at the same level as x0
    assert abs(x[299, 1] - 2.0) < 0.1


def test_lower_bound_holds_state_exactly():
    rhs = TermsRHS([[-1.0]], [()], 1)  # x' = -1
    x = simulate(rhs, [0.5], np.zeros((200, 0)), 0.01, bounds=(0.0, None))
    assert_allclose(x[:50, 0], 0.5 - 0.01 * np.arange(50), atol=1e-12)
    assert np.all(x[51:, 0] == 0.0)


def test_bounds_python_path_same():
    rhs = TermsRHS([[-1.0]], [()], 1)
    args = ([0.5], np.zeros((100, 0)), 0.01)
    assert_allclose(simulate(rhs, *args, bounds=(0.0, 1.0)), simulate(rhs.__call__, *args, bounds=(0.0, 1.0)))


# ------------------------------------------------------------------ divergence
def blowup():
    return TermsRHS([[1.0]], [((0, POW, 2.0, 0.0),)], 1)  # x' = x^2, x(t) = 1/(1 - t)


@pytest.mark.parametrize("path", ["compiled", "python"])
def test_divergence_raises_with_step(path):
    rhs = blowup() if path == "compiled" else blowup().__call__
    with pytest.raises(SimulationError, match=r"diverged at step \d+ of 300") as info:
        simulate(rhs, [1.0], np.zeros((300, 0)), 0.01, max_abs=1e6)
    # blow-up at t = 1, i.e. step 100; RK4 follows until |x| > 1e6
    assert 95 <= info.value.step <= 101
    assert abs(info.value.state[0]) > 1e6
    assert isinstance(info.value, RuntimeError) and sindybench.SimulationError is SimulationError


def test_divergence_nonfinite_without_max_abs():
    with pytest.raises(SimulationError, match="is not finite") as info:
        simulate(blowup(), [1.0], np.zeros((300, 0)), 0.01)
    assert 95 <= info.value.step <= 105


def test_max_abs_step_is_first_exceeding_sample():
    rhs = TermsRHS([[1.0]], [X0], 1)  # x = e^t
    free = simulate(rhs, [1.0], np.zeros((400, 0)), 0.01)
    first = int(np.argmax(np.abs(free[:, 0]) > 10.0))
    with pytest.raises(SimulationError) as info:
        simulate(rhs, [1.0], np.zeros((400, 0)), 0.01, max_abs=10.0)
    assert info.value.step == first == 231  # e^2.31 > 10 > e^2.30


@pytest.mark.parametrize("path", ["compiled", "python"])
def test_divergence_nan_fill(path):
    rhs = blowup() if path == "compiled" else blowup().__call__
    x = simulate(rhs, [1.0], np.zeros((300, 0)), 0.01, max_abs=1e6, on_divergence="nan")
    bad = np.flatnonzero(np.isnan(x[:, 0]))
    assert 95 <= bad[0] <= 101 and bad[-1] == 299 and bad.size == 300 - bad[0]
    assert_allclose(x[:50, 0], 1.0 / (1.0 - 0.01 * np.arange(50)), rtol=1e-6)


# ------------------------------------------------------------------- bad input
@pytest.fixture
def rhs2():
    return TermsRHS([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0]], [X0, X1, ((2, POW, 1.0, 0.0),)], 2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(dt=0.0), "dt must be a finite number > 0"),
        (dict(dt=-0.1), "dt must be a finite number > 0"),
        (dict(dt=None), "give exactly one of dt and t"),
        (dict(dt=0.1, t=np.arange(10.0)), "give exactly one of dt and t"),
        (dict(dt=None, t=np.r_[0.0, 0.1, 0.1, np.arange(3, 10.0)]), "t must be strictly increasing"),
        (dict(dt=None, t=np.arange(9.0)), "t has 9 samples; expected 10"),
        (dict(x0=[0.0]), r"x0 has shape \(1,\); expected \(2,\)"),
        (dict(x0=[0.0, np.nan]), "x0 = .* contains NaN"),
        (dict(x0=[2.0, 0.0], bounds=(None, 1.0)), r"x0\[0\] = 2 is outside bounds"),
        (dict(u=np.r_[np.zeros(9), np.nan]), "u contains NaN or inf"),
        (dict(u=None), "u is None"),
        (dict(u=np.zeros((10, 0))), "terms use column 2 of Z"),
        (dict(n_substeps=0), "n_substeps must be an integer >= 1"),
        (dict(n_substeps=1.5), "n_substeps must be an integer >= 1"),
        (dict(method="rk45"), "method must be one of"),
        (dict(input_hold="foh"), "input_hold must be one of"),
        (dict(on_divergence="ignore"), "on_divergence must be one of"),
        (dict(max_abs=0.0), "max_abs must be a number > 0"),
        (dict(bounds=(1.0, 0.0)), "lower bound 1 >= upper bound 0"),
        (dict(rhs="x'=-x"), "rhs must be a TermsRHS or a callable"),
        (dict(rhs=lambda x, u: np.zeros(3)), r"rhs returned shape \(3,\); expected \(2,\)"),
    ],
)
def test_bad_input(rhs2, kwargs, match):
    args = dict(rhs=rhs2, x0=[0.0, 1.0], u=np.zeros((10, 1)), dt=0.1)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        simulate(args.pop("rhs"), args.pop("x0"), args.pop("u"), **args)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (([[1.0, 2.0]], [X0], 1), r"coef has shape \(1, 2\); expected \(n_terms, n_states=1\)"),
        (([[1.0], [2.0]], [X0], 1), "coef has 2 rows but there are 1 terms"),
        (([[np.inf]], [X0], 1), "coef contains NaN or inf"),
        (([[1.0]], [X0], 0), "n_states must be an integer >= 1"),
        (([[1.0]], [((0, 9, 1.0, 0.0),)], 1), "unknown operation 9"),
    ],
)
def test_bad_terms_rhs(args, match):
    with pytest.raises(ValueError, match=match):
        TermsRHS(*args)


def test_bad_from_equations():
    with pytest.raises(ValueError, match="one per state"):
        TermsRHS.from_equations({X0: 1.0})


def test_bad_make_rhs_shape(rng):
    lib = CustomLibrary(functions=[np.sin], compile=False).fit(rng.normal(size=(4, 2)))
    with pytest.raises(ValueError, match=r"coef has shape \(3, 1\); expected \(2, 1\)"):
        make_rhs(lib, np.ones((3, 1)), 1)

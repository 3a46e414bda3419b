"""sindybench.refine: exact sensitivities, output-error refinement, estimator integration, bad input."""

import warnings

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.model_selection import GridSearchCV, KFold

import sindybench.refine._core as core
import sindybench.refine._problem as problem_mod
from sindybench import STLS, HiddenStateSINDy
from sindybench.differentiation import FiniteDifference
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.libraries._terms import POW
from sindybench.dynamics import Dynamics
from sindybench.refine import (
    CoefficientMap,
    FreeParameters,
    LeastSquares,
    OutputErrorRefinement,
    ParametrizedDynamics,
    Physical,
    Shooting,
    estimate_initial_state,
    refine_simulation_error,
    simulate_sensitivity,
)
from sindybench.simulate import SimulationError, TermsRHS, simulate

DT = 0.05


def lin(col):
    return ((col, POW, 1.0, 0.0),)


# ---------------------------------------------------------------- refinement
DUFFING = [lin(1), lin(0), lin(2), ((0, POW, 3.0, 0.0),)]  # v, y, u, y^3 over Z = [y, v, u]
TRUE_COEF = np.array([[1.0, -0.5], [0.0, -4.0], [0.0, 2.0], [0.0, -1.0]])
TRUE_X0 = np.array([0.3, -0.2])
FREE = TRUE_COEF != 0
FREE[0, 0] = False  # y' = v held: the scale of the unmeasured v would be free otherwise


def duffing_model(coef=TRUE_COEF, **settings):
    """The Duffing oscillator's ``Dynamics`` with these coefficients; the output is ``y``."""
    return Dynamics.from_terms(DUFFING, coef, dt=DT, output_index=(0,), **settings)


def python_path(make_rhs):
    """A physical map without parameters whose Python ``make_rhs(C)`` puts the refinement on the Python path."""
    return Physical(names=(), values=np.zeros(0), lower=np.zeros(0), upper=np.zeros(0), coef=lambda values: 0.0,
                    make_rhs=lambda C, values: make_rhs(C))


@pytest.fixture
def duffing(rng):
    """Noise-free outputs of y'' = -4 y - 0.5 y' - y^3 + 2 u (multisine-like input)."""
    t = np.arange(600) * DT
    u = (np.sin(0.9 * t + 0.3) + 0.6 * np.sin(2.3 * t) + 0.3 * rng.standard_normal(t.size).cumsum() / 30)[:, None]
    y = simulate(TermsRHS(TRUE_COEF, DUFFING, 2), TRUE_X0, u, DT)[:, :1]
    return u, y


@pytest.mark.parametrize("n_segments", [1, 3])
def test_refine_recovers_coefficients_and_initial_state(duffing, n_segments):
    u, y = duffing
    start = TRUE_COEF * np.array([[1.0, 0.8], [1.0, 1.15], [1.0, 0.9], [1.0, 0.7]])
    res = refine_simulation_error(duffing_model(start), u, y, x0=[0.25, 0.0],
                                  free=FreeParameters(coef=FREE), shooting=Shooting(n_segments=n_segments),
                                  solver=LeastSquares(max_nfev=50))
    assert res.jacobian == "sensitivity" and res.status > 0
    np.testing.assert_allclose(res.coef, TRUE_COEF, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(res.x0, TRUE_X0, rtol=1e-6, atol=1e-8)
    assert res.cost < 1e-14 < res.initial_cost
    assert res.pruned == [] and res.coef[0, 0] == 1.0


def test_multiple_shooting_cost_is_the_open_loop_cost(duffing):
    u, y = duffing
    start = TRUE_COEF * np.array([[1.0, 0.8], [1.0, 1.15], [1.0, 0.9], [1.0, 0.7]])
    res = refine_simulation_error(duffing_model(start), u, y, x0=[0.25, 0.0],
                                  free=FreeParameters(coef=FREE), shooting=Shooting(n_segments=6),
                                  solver=LeastSquares(max_nfev=3))
    x = simulate(TermsRHS(res.coef, DUFFING, 2), res.x0, u, DT)[:, :1]
    open_loop = 0.5 * np.mean(((x - y) / np.std(y)) ** 2)  # the definition initial_cost follows
    assert res.cost == pytest.approx(open_loop, rel=1e-6)  # measured: 5.6e-6 reported, 4.3e-5 open loop


def test_refine_physical_parameters_through_a_nonlinear_map(duffing):
    u, y = duffing
    m, c, k = 0.5, 0.25, 2.0  # TRUE_COEF's velocity row = [-c/m, -k/m, 1/m]

    def to_coef(values):
        mm, cc, kk = values
        out = np.zeros((4, 2))
        out[:3, 1] = [-cc / mm, -kk / mm, 1.0 / mm]
        return out

    start = np.zeros((4, 2))
    start[0, 0], start[3, 1] = 1.0, -1.0  # y' = v held (not free), cubic free
    free = np.zeros((4, 2), dtype=bool)
    free[3, 1] = True
    physical = Physical(names=("m", "c", "k"), values=np.array([0.6, 0.2, 2.5]), lower=np.full(3, 1e-3),
                        upper=np.full(3, np.inf), coef=to_coef)
    model = duffing_model(start + to_coef(physical.values))  # the whole model: the physical part included
    res = refine_simulation_error(model, u, y, x0=TRUE_X0 * 0.9, free=FreeParameters(coef=free, physical=physical),
                                  solver=LeastSquares(max_nfev=60))
    assert set(res.physical) == {"m", "c", "k"}
    np.testing.assert_allclose([res.physical[n] for n in "mck"], [m, c, k], rtol=1e-4)
    np.testing.assert_allclose(res.coef, TRUE_COEF, rtol=1e-4, atol=1e-8)
    assert res.cost < 1e-10


def test_refine_prunes_a_spurious_term_and_keeps_the_true_ones(duffing):
    u, y = duffing
    terms = DUFFING + [((1, POW, 2.0, 0.0),)]  # a spurious v^2 in the velocity row
    start = np.vstack([TRUE_COEF * 1.05, [[0.0, 0.03]]])
    start[0, 0] = 1.0
    free = np.vstack([FREE, [[False, True]]])
    res = refine_simulation_error(Dynamics.from_terms(terms, start, dt=DT, output_index=(0,)), u, y, x0=TRUE_X0,
                                  free=FreeParameters(coef=free), prune=0.01,
                                  solver=LeastSquares(max_nfev=50))
    assert res.pruned == [(4, 1)]
    assert res.coef[4, 1] == 0.0
    np.testing.assert_allclose(res.coef[:4], TRUE_COEF, rtol=1e-6, atol=1e-9)
    no_prune = refine_simulation_error(Dynamics.from_terms(terms, start, dt=DT, output_index=(0,)), u, y, x0=TRUE_X0,
                                       free=FreeParameters(coef=free),
                                       solver=LeastSquares(max_nfev=50))
    assert no_prune.pruned == [] and no_prune.coef[4, 1] != 0.0


def test_refine_python_rhs_uses_finite_differences(duffing):
    u, y = duffing

    def make_rhs(C):
        def f(x, uu):
            return np.array([C[0, 0] * x[1], C[0, 1] * x[1] + C[1, 1] * x[0] + C[2, 1] * uu[0]
                             + C[3, 1] * x[0] ** 3])
        return f

    u, y = u[:200], y[:200]
    start = TRUE_COEF * np.array([[1.0, 0.9], [1.0, 1.1], [1.0, 0.95], [1.0, 0.8]])
    res = refine_simulation_error(duffing_model(start), u, y, x0=TRUE_X0,
                                  free=FreeParameters(coef=FREE, physical=python_path(make_rhs), x0=[]),
                                  solver=LeastSquares(max_nfev=40))
    assert res.jacobian == "2-point"
    assert res.status > 0
    np.testing.assert_allclose(res.coef, TRUE_COEF, rtol=1e-5, atol=1e-8)
    assert res.cost < 1e-12 < res.initial_cost


def test_refine_refuses_a_diverging_start(duffing):
    u, y = duffing
    bad = TRUE_COEF.copy()
    bad[3, 1] = 2.0  # +2 y^3: finite-time blow-up
    with pytest.raises(SimulationError, match="cannot refine: the starting model's simulation diverges.*n_segments"):
        refine_simulation_error(duffing_model(bad, max_abs=1e3), u, y,
                                x0=[1.0, 1.0])


@pytest.mark.parametrize("n_segments", [2, 3])
def test_multiple_shooting_starts_from_a_diverging_model(duffing, n_segments):
    """Segments cut where the start leaves the record; the refined model simulates the whole record exactly."""
    u, y = duffing
    bad = TRUE_COEF.copy()
    bad[3, 1] = 2.0  # +2 y^3: finite-time blow-up from x0 = (1, 1)
    free = FREE.copy()
    free[0, 0] = False  # y' = v held (else the scale of v is free)
    res = refine_simulation_error(duffing_model(bad, max_abs=1e3), u, y,
                                  x0=[1.0, 1.0], free=FreeParameters(coef=free),
                                  shooting=Shooting(n_segments=n_segments),
                                  solver=LeastSquares(max_nfev=200))
    assert res.initial_cost > 1e3  # the start's open loop diverges: penalized
    np.testing.assert_allclose(res.coef, TRUE_COEF, rtol=1e-5, atol=1e-8)
    np.testing.assert_allclose(res.x0, TRUE_X0, rtol=1e-5, atol=1e-8)
    assert res.cost < 1e-10


def test_multiple_shooting_refuses_a_start_that_cannot_take_one_step(duffing):
    u, y = duffing
    bad = TRUE_COEF.copy()
    bad[3, 1] = 1e4
    with pytest.raises(SimulationError, match="diverges within one sample of sample 0"):
        refine_simulation_error(duffing_model(bad, max_abs=1e3), u, y,
                                x0=[1.0, 1.0], shooting=Shooting(n_segments=3))


def test_diverging_trial_steps_never_reach_the_optimizer(duffing, monkeypatch):
    """A start near instability: the optimizer's trial steps diverge, yet it only sees finite residuals."""
    u, y = duffing
    seen = {"bad": 0, "diverged": 0, "calls": 0}
    original = core.least_squares

    def spy(fun, x0, **kwargs):
        def wrapped(p):
            r = fun(p)
            seen["calls"] += 1
            seen["bad"] += int(not np.all(np.isfinite(r)))
            seen["diverged"] += int(np.any(r == problem_mod._DIVERGED / np.sqrt(y.size)))
            return r
        return original(wrapped, x0, **kwargs)

    monkeypatch.setattr(core, "least_squares", spy)
    start = TRUE_COEF.copy()
    start[0, 1], start[3, 1] = -0.01, -0.01  # hardly damped, hardly any stiffening cubic
    res = refine_simulation_error(duffing_model(start, max_abs=50.0), u, y,
                                  x0=TRUE_X0, free=FreeParameters(coef=FREE),
                                  solver=LeastSquares(max_nfev=80))
    assert seen["diverged"] >= 1  # the start is close enough to instability that a trial step blows up
    assert seen["calls"] > 3 and seen["bad"] == 0
    assert np.isfinite(res.cost) and np.all(np.isfinite(res.coef))
    assert res.cost < 1e-12 < res.initial_cost


def test_estimate_initial_state_recovers_x0(duffing):
    u, y = duffing
    x0 = estimate_initial_state(duffing_model(), u[:40], y[:40], x0=[0.0, 0.0])
    np.testing.assert_allclose(x0, TRUE_X0, rtol=1e-6, atol=1e-9)
    only_v = estimate_initial_state(duffing_model(), u[:40], y[:40], x0=[0.3, 0.5], free_x0=[1])
    assert only_v[0] == 0.3 and only_v[1] == pytest.approx(-0.2, rel=1e-6)


def test_estimate_initial_state_box_bounds(duffing):
    u, y = duffing
    rhs = TermsRHS(TRUE_COEF, DUFFING, 2)
    inside = estimate_initial_state(duffing_model(), u[:40], y[:40], x0=[0.1, 0.0],
                                    solver=LeastSquares(max_nfev=50, x0_bounds=([0.0, -1.0], [1.0, 1.0])))
    np.testing.assert_allclose(inside, TRUE_X0, rtol=1e-6, atol=1e-9)
    # the velocity kept >= 0: it stops on its bound, the position moves to make up for it
    clipped = estimate_initial_state(duffing_model(), u[:40], y[:40], x0=[0.3, 0.5],
                                     solver=LeastSquares(max_nfev=50, x0_bounds=([-1.0, 0.0], [1.0, 1.0])))
    assert clipped[1] == pytest.approx(0.0, abs=1e-9) and clipped[0] != pytest.approx(TRUE_X0[0], abs=1e-3)
    cost = {name: np.mean((simulate(rhs, x, u[:40], DT)[:, 0] - y[:40, 0]) ** 2)
            for name, x in (("clipped", clipped), ("on the bound, position held", [0.3, 0.0]))}
    assert cost["clipped"] < cost["on the bound, position held"]


def test_estimate_initial_state_from_a_start_on_a_zero_bound(duffing):
    # a free state that starts on its bound at zero: the trust region starts at the size of x0,
    # so the default tolerances stop at once, tight ones let the steps grow (see the Notes)
    u, y = duffing
    rhs = TermsRHS(TRUE_COEF, DUFFING, 2)
    y_shift = simulate(rhs, [0.3, 0.4], u[:40], DT)[:, :1]
    kwargs = dict(x0=[0.3, 0.0], free_x0=[1])
    loose = estimate_initial_state(duffing_model(), u[:40], y_shift, solver=LeastSquares(50, x0_bounds=(0.0, None)),
                                   **kwargs)
    tight = estimate_initial_state(duffing_model(), u[:40], y_shift, **kwargs,
                                   solver=LeastSquares(50, 1e-12, 1e-12, 1e-12, x0_bounds=(0.0, None)))
    assert loose[1] < 1e-6
    assert tight[1] == pytest.approx(0.4, rel=1e-6)


def test_estimate_initial_state_output_scale_moves_only_the_weights(duffing):
    u, y = duffing
    noisy = y[:40] + 0.01 * np.sin(np.arange(40))[:, None]
    # gtol is absolute on the scaled gradient, so it is off here: with it a small residual scale stops early
    runs = [estimate_initial_state(duffing_model(), u[:40], noisy, x0=[0.0, 0.0],
                                   solver=LeastSquares(50, 1e-12, 1e-12, None, output_scale=scale))
            for scale in (None, 1e-3, 1e3)]
    for x in runs[1:]:
        np.testing.assert_allclose(x, runs[0], rtol=1e-7)  # one output: the scale does not move the optimum
    assert np.abs(runs[0] - TRUE_X0).max() > 1e-4  # the noise did move it


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"coef": np.zeros((3, 2))}, r"coef has 3 rows; expected 4 \(one per term\)"),
        ({"x0": [0.0, 0.0, 0.0]}, "x0 has 3 entries; expected 2"),
        ({"free": np.ones((4, 3), dtype=bool)}, r"free has shape \(4, 3\); expected \(4, 2\)"),
        ({"output_index": (0, 1)}, "output_index=.0, 1. does not match y"),
        ({"output_index": (2,)}, r"output_index\[0\] must be an integer in \[0, 1\]; got 2"),
        ({"n_segments": 0}, "n_segments must be an integer"),
        ({"n_segments": 1000}, "n_segments must be an integer in"),
        ({"prune": -0.1}, "prune must be a finite number >= 0; got -0.1"),
        ({"max_nfev": 0}, "max_nfev must be an integer"),
        ({"y": np.zeros((10, 1))}, "y has 10 samples; expected 600"),
        ({"x0_bounds": (0.0, 1.0, 2.0)}, "x0_bounds must be a pair"),
        ({"x0_bounds": (2.0, 3.0), "bounds": (-1.0, 1.0)}, "x0_bounds = .* leave no initial state within"),
        ({"output_scale": [0.0]}, r"output_scale = \[0.0\]; expected one finite number > 0 per output \(1\)"),
        ({"output_scale": [1.0, 2.0]}, r"output_scale = \[1.0, 2.0\]; expected one finite number > 0 per output"),
    ],
)
def test_refine_bad_input(duffing, kwargs, match):
    u, y = duffing
    args = {"coef": TRUE_COEF, "output_index": (0,), "bounds": None, "u": u, "y": y, "x0": TRUE_X0, "free": None,
            "n_segments": 1, "prune": 0.0, "max_nfev": 100, "x0_bounds": None, "output_scale": None}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        model = Dynamics.from_terms(DUFFING, args["coef"], dt=DT, output_index=args["output_index"],
                                    bounds=args["bounds"])
        refine_simulation_error(model, args["u"], args["y"], x0=args["x0"], free=FreeParameters(coef=args["free"]),
                                shooting=Shooting(args["n_segments"]), prune=args["prune"],
                                solver=LeastSquares(args["max_nfev"], x0_bounds=args["x0_bounds"],
                                                    output_scale=args["output_scale"]))


def test_refine_takes_a_dynamics(duffing):
    u, y = duffing
    with pytest.raises(TypeError, match="dynamics must be a sindybench.dynamics.Dynamics .*; got TermsRHS"):
        refine_simulation_error(TermsRHS(TRUE_COEF, DUFFING, 2), u, y, x0=TRUE_X0)
    # the old flat keywords' values where a grouped setting is expected: a TypeError that says how to write it
    with pytest.raises(TypeError, match=r"free must be a sindybench.refine.FreeParameters \(e.g. FreeParameters\("
                                        r"coef=mask\)\) or None; got ndarray"):
        refine_simulation_error(duffing_model(), u, y, x0=TRUE_X0, free=FREE)
    with pytest.raises(TypeError, match="shooting must be a sindybench.refine.Shooting .*; got int"):
        refine_simulation_error(duffing_model(), u, y, x0=TRUE_X0, shooting=3)
    with pytest.raises(TypeError, match="solver must be a sindybench.refine.LeastSquares .*; got dict"):
        estimate_initial_state(duffing_model(), u[:40], y[:40], x0=TRUE_X0, solver={"max_nfev": 5})


def test_coefficient_map_names_a_missing_parameter():
    rows = CoefficientMap((1, 1), [(0, 0, -1.0, ("c",), ("m",))])
    with pytest.raises(ValueError, match=r"the coefficient map needs the parameters \['c', 'm'\]; got \['k'\]"):
        rows.matrix({"k": 1.0})


def test_refine_free_x0_out_of_range(duffing):
    u, y = duffing
    with pytest.raises(ValueError, match="free_x0"):
        refine_simulation_error(duffing_model(TRUE_COEF), u, y, x0=TRUE_X0,
                                free=FreeParameters(x0=[2]))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"directions": np.zeros((1, 3, 2))}, r"directions has shape \(1, 3, 2\)"),
        ({"directions": np.full((1, 4, 2), np.nan)}, "directions contains NaN"),
        ({"free_x0": [2]}, r"free_x0 = \[2\] has a state index outside \[0, 1\]"),
        ({"output_index": [-1]}, "output_index = .-1. has a state index outside"),
        ({"method": "rk45"}, "method must be one of .'rk4', 'euler'.; got 'rk45'"),
        ({"x0": [0.0]}, r"x0 has shape \(1,\)"),
    ],
)
def test_sensitivity_bad_input(duffing, kwargs, match):
    u, _ = duffing
    args = {"x0": TRUE_X0}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        simulate_sensitivity(TermsRHS(TRUE_COEF, DUFFING, 2), args.pop("x0"), u, DT, **args)


def test_sensitivity_refuses_a_python_rhs(duffing):
    u, _ = duffing
    with pytest.raises(ValueError, match="rhs must be a TermsRHS for exact sensitivities; got function"):
        simulate_sensitivity(lambda x, uu: -x, [1.0], u, DT)


@pytest.mark.parametrize(
    "params, match",
    [
        ({"max_samples": 3}, "max_samples must be an integer >= 10 or None"),
        ({"max_samples": True}, "max_samples must be an integer >= 10 or None"),
        ({"max_samples": 50.0}, "max_samples must be an integer >= 10 or None"),
        ({"max_nfev": 0}, "max_nfev must be an integer"),
        ({"n_segments": 0}, "n_segments must be an integer"),
        ({"continuity_weight": 0.0}, "continuity_weight must be a finite number > 0"),
        ({"prune": -1.0}, "prune must be a finite number >= 0"),
        ({"physical": "yes"}, "physical must be True or False; got 'yes'"),
        ({"initial_state": 1}, "initial_state must be True or False; got 1"),
    ],
)
def test_output_error_refinement_bad_params(duffing, params, match):
    u, y = duffing
    with pytest.raises(ValueError, match=match):
        OutputErrorRefinement(**params).run(duffing_model(), u, y, x0=TRUE_X0)


def test_hidden_state_sindy_bad_refine_and_initial_state(duffing):
    u, y = duffing
    with pytest.raises(ValueError, match="refine must be an OutputErrorRefinement, a PredictionErrorRefinement or "
                                         "None; got object"):
        HiddenStateSINDy(refine=object(), dt=DT).fit(u, y)
    with pytest.raises(ValueError, match="initial_state must be one of .'strategy', 'fit', 'prior', 'periodic'.; got 'bogus'"):
        HiddenStateSINDy(initial_state="bogus", dt=DT).fit(u, y)


# ------------------------------------------------------------ estimator use
def msd_model(**refine):
    return HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=1),
                            optimizer=STLS(threshold=0.05), dt=DT, refine=OutputErrorRefinement(**refine),
                            input_hold="zoh", differentiation=FiniteDifference())  # the data's hold


@pytest.fixture
def msd(rng):
    """y'' = -4 y - 0.5 y' + 2 u, slightly noisy outputs."""
    t = np.arange(400) * DT
    u = (np.sin(0.9 * t) + 0.6 * np.sin(2.3 * t + 1.0))[:, None]
    coef = TRUE_COEF[:3]
    y = simulate(TermsRHS(coef, DUFFING[:3], 2), [0.0, 0.0], u, DT)[:, :1]
    return u, y + 1e-4 * np.std(y) * rng.standard_normal(y.shape)


def test_refine_in_hidden_state_sindy_improves_the_fit(msd):
    u, y = msd
    plain = msd_model().set_params(refine=None).fit(u, y)
    model = msd_model(max_nfev=20).fit(u, y)
    assert model.refinement_["jacobian"] == "sensitivity"
    assert model.refinement_["cost"] < model.refinement_["initial_cost"]
    truth = np.array([-4.0, -0.5, 2.0])  # over [y, y', u] (bias pruned by STLS)
    names = list(model.library_.get_feature_names_out(["y0", "y0'", "u0"]))
    learned = model.coef_[0][[names.index(n) for n in ("y0", "y0'", "u0")]]
    plain_learned = plain.coef_[0][[names.index(n) for n in ("y0", "y0'", "u0")]]
    err, plain_err = np.abs(learned / truth - 1).max(), np.abs(plain_learned / truth - 1).max()
    assert err < 1e-3 < plain_err
    assert model.equations(precision=3)[1] == "y0'' = -4.000 y0 - 0.500 y0' + 2.000 u0"  # the refined model's
    assert plain.equations(precision=3)[1] != model.equations(precision=3)[1]


def test_refine_in_hidden_state_sindy_prunes_and_prints_the_short_model(msd):
    u, y = msd
    dense = msd_model().set_params(refine=None, optimizer__threshold=0.0).fit(u, y)
    assert dense.equations(precision=3)[1].startswith("y0'' = 0.00")  # least squares keeps a spurious constant
    model = msd_model(max_nfev=20, prune=0.05).set_params(optimizer__threshold=0.0).fit(u, y)
    assert model.refinement_["pruned"] == [[0, 1]]  # the constant of the y0'' row
    assert model.coef_[0, 0] == 0.0
    assert model.equations(precision=3)[1] == "y0'' = -4.000 y0 - 0.500 y0' + 2.000 u0"


def test_refine_params_are_nested_clonable_and_searchable(msd):
    u, y = msd
    model = msd_model(prune=0.0)
    assert model.get_params()["refine__prune"] == 0.0
    model.set_params(refine__prune=0.02, refine__max_nfev=5)
    assert model.refine.prune == 0.02 and model.refine.max_nfev == 5
    cloned = clone(model)
    assert cloned.refine is not model.refine and cloned.get_params()["refine__prune"] == 0.02
    search = GridSearchCV(msd_model(), {"refine__max_nfev": [1, 15], "refine__prune": [0.0, 0.01]},
                          cv=KFold(2), error_score="raise").fit(u, y)
    assert len(search.cv_results_["params"]) == 4
    assert search.best_params_["refine__max_nfev"] == 15
    assert search.best_estimator_.refinement_ is not None
    assert np.all(np.isfinite(search.cv_results_["mean_test_score"]))


# ----------------------------------------------------------------- Jacobian at the optimum, covariance, budget
@pytest.fixture
def noisy_duffing(duffing, rng):
    u, y = duffing
    return u, y + 0.02 * rng.standard_normal(y.shape)


def output_residuals(res, terms, u, y, values):
    """The record's output residuals at ``values``, recomputed by simulation (for finite differences)."""
    C, x0 = res.coef.copy(), res.x0.copy()
    for v, q in zip(values, res.parameters):
        if q[0] == "coef":
            C[q[1], q[2]] = v
        else:
            x0[q[1]] = v
    x = simulate(TermsRHS(C, terms, C.shape[1]), x0, u, DT)[:, :1]
    return ((x - y) / np.std(y)).ravel() / np.sqrt(y.size)


def test_refine_keeps_the_jacobian_at_the_optimum(noisy_duffing):
    u, y = noisy_duffing
    res = refine_simulation_error(duffing_model(TRUE_COEF * 1.05), u, y,
                                  x0=TRUE_X0, free=FreeParameters(coef=FREE),
                                  solver=LeastSquares(max_nfev=50))
    assert res.parameters == (("coef", 0, 1), ("coef", 1, 1), ("coef", 2, 1), ("coef", 3, 1), ("x0", 0), ("x0", 1))
    r0 = output_residuals(res, DUFFING, u, y, res.values)
    np.testing.assert_allclose(res.residuals, r0, rtol=1e-9, atol=1e-12)
    fd = np.empty_like(res.jac)
    for k in range(res.values.size):
        step = 1e-6 * max(1.0, abs(res.values[k]))
        hi, lo = res.values.copy(), res.values.copy()
        hi[k] += step
        lo[k] -= step
        fd[:, k] = (output_residuals(res, DUFFING, u, y, hi)
                    - output_residuals(res, DUFFING, u, y, lo)) / (2 * step)
    np.testing.assert_allclose(res.jac, fd, rtol=1e-4, atol=1e-7 * np.abs(fd).max())
    assert not res.budget_exhausted and res.status > 0


def test_multiple_shooting_covariance_is_that_of_the_open_loop_model(duffing):
    u, y = duffing
    start = TRUE_COEF * np.array([[1.0, 0.8], [1.0, 1.15], [1.0, 0.9], [1.0, 0.7]])
    single = refine_simulation_error(duffing_model(start), u, y,
                                     x0=[0.25, 0.0], free=FreeParameters(coef=FREE),
                                     solver=LeastSquares(max_nfev=50))
    multiple = refine_simulation_error(duffing_model(start), u, y,
                                       x0=[0.25, 0.0], free=FreeParameters(coef=FREE),
                                       shooting=Shooting(n_segments=3),
                                       solver=LeastSquares(max_nfev=50))
    assert multiple.parameters == single.parameters  # no segment starts
    assert multiple.jac.shape == single.jac.shape == (y.size, len(single.parameters))
    np.testing.assert_allclose(multiple.jac, single.jac, rtol=1e-5, atol=1e-9 * np.abs(single.jac).max())


def test_covariance_of_one_output_is_the_textbook_formula(noisy_duffing):
    u, y = noisy_duffing
    res = refine_simulation_error(duffing_model(TRUE_COEF), u, y, x0=TRUE_X0,
                                  free=FreeParameters(coef=FREE), solver=LeastSquares(max_nfev=50))
    cov = res.covariance()
    p = len(res.parameters)
    s2 = res.residuals @ res.residuals / (y.size - p)
    np.testing.assert_allclose(cov.matrix, s2 * np.linalg.inv(res.jac.T @ res.jac), rtol=1e-6)
    assert cov.dof == y.size - p and cov.rank == p and not cov.rank_deficient
    # the residual spread in output units is the noise's (0.02)
    assert cov.sigma[0] * np.std(y) * np.sqrt(y.size) == pytest.approx(0.02, rel=0.15)
    lower, upper = res.confidence_intervals(0.05)
    np.testing.assert_allclose((upper - lower) / 2, 1.964 * res.standard_errors(), rtol=1e-3)
    hac = res.covariance("hac")
    assert hac.kind == "hac" and np.all(np.diag(hac.matrix) > 0)
    summary = res.summary()
    assert summary["budget_exhausted"] is False
    np.testing.assert_allclose(summary["covariance"]["white"]["matrix"], cov.matrix)
    with pytest.raises(ValueError, match="alpha must be in"):
        cov.confidence_intervals(1.5)
    with pytest.raises(ValueError, match="kind must be 'white' or 'hac'"):
        res.covariance("sandwich")


def test_covariance_of_collinear_terms_is_rank_deficient(noisy_duffing):
    u, y = noisy_duffing
    terms = DUFFING + [lin(2)]  # u twice
    start = np.vstack([TRUE_COEF, [[0.0, 0.5]]])
    start[2, 1] = 1.5
    free = np.vstack([FREE, [[False, True]]])
    res = refine_simulation_error(Dynamics.from_terms(terms, start, dt=DT, output_index=(0,)), u, y, x0=TRUE_X0,
                                  free=FreeParameters(coef=free),
                                  solver=LeastSquares(max_nfev=30, warn_budget=False))
    cov = res.covariance()
    assert cov.rank == len(res.parameters) - 1 and cov.rank_deficient
    assert np.all(np.isfinite(cov.standard_errors()))


def test_refine_warns_and_records_when_it_stops_on_its_budget(duffing):
    u, y = duffing
    start = TRUE_COEF * np.array([[1.0, 0.8], [1.0, 1.15], [1.0, 0.9], [1.0, 0.7]])
    with pytest.warns(ConvergenceWarning, match=r"stopped on its evaluation budget \(max_nfev=2\)"):
        res = refine_simulation_error(duffing_model(start), u, y,
                                      x0=[0.25, 0.0], free=FreeParameters(coef=FREE),
                                      solver=LeastSquares(max_nfev=2))
    assert res.budget_exhausted and res.status == 0 and res.summary()["budget_exhausted"] is True
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        quiet = refine_simulation_error(duffing_model(start), u, y,
                                        x0=[0.25, 0.0], free=FreeParameters(coef=FREE),
                                        solver=LeastSquares(max_nfev=2, warn_budget=False))
        estimate_initial_state(duffing_model(), u[:50], y[:50], x0=[0.2, 0.0], solver=LeastSquares(max_nfev=1))
    assert quiet.budget_exhausted


def test_python_rhs_multiple_shooting_jacobian_matches_the_sensitivities(noisy_duffing):
    """The forward-difference output Jacobian of a Python model after multiple shooting (no sensitivities)."""
    u, y = noisy_duffing
    u, y = u[:200], y[:200]

    def make_rhs(C):
        def f(x, uu):
            return np.array([C[0, 0] * x[1], C[0, 1] * x[1] + C[1, 1] * x[0] + C[2, 1] * uu[0]
                             + C[3, 1] * x[0] ** 3])
        return f

    python = refine_simulation_error(duffing_model(), u, y, x0=TRUE_X0,
                                     free=FreeParameters(coef=FREE, physical=python_path(make_rhs)),
                                     shooting=Shooting(n_segments=2), solver=LeastSquares(max_nfev=40))
    view = ParametrizedDynamics(duffing_model(python.coef), FreeParameters(coef=FREE))
    exact = problem_mod._Problem(view, [python.x0], [u], [y], [(0, 200)])
    J = exact.jacobian(python.values)
    assert python.jacobian == "2-point" and python.parameters == exact.parameters()
    np.testing.assert_allclose(python.jac, J, rtol=1e-3, atol=1e-5 * np.abs(J).max())


def test_first_residuals_reuse_the_start_simulation(duffing, monkeypatch):
    """_build simulates the start; the optimizer's first residuals there are those, with no second simulation."""
    u, y = duffing
    lo, hi = np.full(2, -np.inf), np.full(2, np.inf)
    view = ParametrizedDynamics(duffing_model(TRUE_COEF * 0.9), FreeParameters(coef=FREE))
    problem, xs = problem_mod._build(view, [TRUE_X0], [u], [y], Shooting(), lo, hi)
    p0 = problem.pack()
    fresh = simulate(TermsRHS(problem.matrix(p0), DUFFING, 2), TRUE_X0, u, DT)
    np.testing.assert_array_equal(xs[0], fresh)
    calls = []
    monkeypatch.setattr(problem_mod, "simulate", lambda *a, **k: calls.append(1) or simulate(*a, **k))
    r = problem.residuals(p0.copy())
    assert calls == []
    np.testing.assert_array_equal(r, ((fresh[:, :1] - y) / np.std(y, axis=0)).ravel() / np.sqrt(y.size))
    problem.residuals(p0 + 1e-3)  # another point simulates
    assert calls == [1]


def test_a_refinement_on_the_first_samples_records_the_residual_test_of_those_samples():
    # the residual test paired the residuals of max_samples with the whole record's inputs (a reshape error
    # that ended every fit with max_samples shorter than the record)
    from sindybench import SINDy
    from sindybench.libraries import PolynomialLibrary
    from sindybench.refine import OutputErrorRefinement

    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-1, 1, 40), 10)[:, None]
    y = np.zeros((400, 1))
    for t in range(399):
        y[t + 1] = y[t] + 0.05 * (-y[t] + u[t])
    model = SINDy(library=PolynomialLibrary(degree=1), dt=0.05,
                  refine=OutputErrorRefinement(max_samples=120)).fit(u, y + 0.01 * rng.normal(size=y.shape))
    assert model.refinement_["residual_test"]["n_samples"] == 120


def _chain(n_states=6):
    """``x_i' = x_{i+1} - x_i``, the last driven by ``u``; the output is the first state (a six-fold lag)."""
    terms = [((i, POW, 1, 0),) for i in range(n_states + 1)]
    coef = np.zeros((n_states + 1, n_states))
    for i in range(n_states):
        coef[i, i], coef[i + 1, i] = -1.0, 1.0
    return Dynamics.from_terms(terms, coef, dt=0.05, output_index=(0,))


def test_estimate_initial_state_prior_makes_a_short_window_well_posed(rng):
    """Ten noisy samples of one output cannot tell six states: the free least squares chases the noise, the prior
    (the states' spread along the record, the noise level) keeps the free run close to the truth."""
    dyn = _chain()
    u = np.repeat(rng.uniform(-1.0, 1.0, 80), 50)[:, None]
    x = dyn.simulate(u, np.zeros(6))
    start, n = 2000, 10
    noise = 0.01 * np.std(x[:, 0])
    y = x[start : start + n, :1] + noise * rng.standard_normal((n, 1))
    ahead = u[start : start + 400]
    truth = x[start : start + 400, 0]

    def error(x0):
        return np.sqrt(np.mean((dyn.simulate(ahead, x0)[:, 0] - truth) ** 2)) / np.std(x[:, 0])

    guess = np.r_[y[0], np.zeros(5)]
    free = estimate_initial_state(dyn, ahead[:n], y, x0=guess)
    prior = (np.mean(x, axis=0), np.cov(x, rowvar=False))
    held = estimate_initial_state(dyn, ahead[:n], y, x0=guess, solver=LeastSquares(output_scale=noise), prior=prior)
    assert error(held) < 0.5 and error(free) > 10 * error(held)  # free: over 100 output spreads off
    assert error(held) < error(prior[0])  # the samples still tell what they can


def test_estimate_initial_state_prior_yields_to_informative_samples(duffing):
    """Forty exact samples of a two-state model: a wrong prior mean does not bias the state."""
    u, y = duffing
    x0 = estimate_initial_state(duffing_model(), u[:40], y[:40], x0=[0.0, 0.0],
                                solver=LeastSquares(output_scale=1e-6), prior=([0.5, 0.5], np.eye(2)))
    np.testing.assert_allclose(x0, TRUE_X0, atol=1e-6)


@pytest.mark.parametrize(("prior", "match"), [
    ((np.zeros(2),), "pair"),
    ((np.zeros(3), np.eye(2)), "mean of shape"),
    ((np.zeros(2), np.eye(3)), "covariance of shape"),
    ((np.zeros(2), [[1.0, 0.5], [0.0, 1.0]]), "symmetric"),
    ((np.zeros(2), np.full((2, 2), np.nan)), "finite"),
    ((np.zeros(2), np.zeros((2, 2))), "no positive eigenvalue"),
])
def test_estimate_initial_state_refuses_a_bad_prior(duffing, prior, match):
    u, y = duffing
    with pytest.raises(ValueError, match=match):
        estimate_initial_state(duffing_model(), u[:40], y[:40], x0=[0.0, 0.0], prior=prior)


def test_hidden_state_sindy_prior_start_takes_the_refinement_noise_level(msd):
    """initial_state="prior": the noise level is the refinement's RMS output error (a default without one), and on
    twenty well-telling samples it starts where "fit" does."""
    u, y = msd
    model = msd_model(max_nfev=20).set_params(initial_state="prior").fit(u, y)
    assert model._start_noise() == pytest.approx(np.sqrt(2.0 * model.refinement_["cost"]))
    a = 200
    starts = {mode: model.set_params(initial_state=mode).estimate_initial_state(u[a:], y[a : a + 20])
              for mode in ("prior", "fit")}
    np.testing.assert_allclose(starts["prior"], starts["fit"], rtol=1e-3, atol=1e-3 * np.std(y))
    plain = msd_model().set_params(refine=None, initial_state="prior").fit(u, y)
    assert plain._start_noise() is None
    assert np.all(np.isfinite(plain.predict(u[a:], y_init=y[a : a + 20])))


def test_start_prior_needs_a_moving_finite_simulation():
    from sindybench.hidden._refinement import start_prior

    dyn = Dynamics.from_terms([((0, POW, 1, 0),), ((1, POW, 1, 0),)], [[-1.0], [1.0]], dt=0.1)  # x' = -x + u
    assert start_prior(dyn, [0.0], np.zeros((50, 1)), 0.1) == (None, None)  # at rest: the states do not move
    grows = Dynamics.from_terms([((0, POW, 1, 0),)], [[50.0]], dt=0.1, max_abs=1e3)  # x' = 50 x diverges at once
    assert start_prior(grows, [1.0], np.zeros((50, 0)), 0.1) == (None, None)
    (mean, cov), solver = start_prior(dyn, [0.0], np.ones((50, 1)), None)
    assert solver.output_scale[0] == pytest.approx(0.05 * np.std(dyn.simulate(np.ones((50, 1)), [0.0])[10:, 0]))

"""LatentHiddenState: latent states whose equations are discovered from the outputs alone."""

import numpy as np
import pytest

from sindybench import STLS, HiddenStateSINDy
from sindybench.differentiation import SavitzkyGolay
from sindybench.estimation import latent_invariants, linearize
from sindybench.hidden import LatentHiddenState
from sindybench.libraries import ConcatLibrary, PolynomialLibrary, SqrtLibrary, term_name
from sindybench.refine import OutputErrorRefinement
from sindybench.search import LogNormal, LogUniform, Uniform
from sindybench.simulate import simulate


def _steps(rng, n, low, high, hold):
    return np.repeat(rng.uniform(low, high, n // hold + 1), hold)[:n, None]


def _support(model):
    """Nonzero terms of each row, by name."""
    names = model.structure_.state_names + ["u0"]
    terms = model.library_.terms_
    return [{term_name(terms[i], names) for i in np.flatnonzero(row)} for row in model.coef_]


def _jacobian(rhs, x, u=(0.0,)):
    h = 1e-6
    return np.array([(np.asarray(rhs(x + e, u)) - np.asarray(rhs(x - e, u))) / (2 * h) for e in np.eye(x.size) * h]).T


def _poles(rhs, x, u):
    return np.sort(np.linalg.eigvals(_jacobian(rhs, x, u)).real)


def _fit(u, y, dt, library, tau_bounds, prune, **hidden):
    return HiddenStateSINDy(
        hidden=LatentHiddenState(bounds={"tau": tau_bounds}, **hidden), library=library,
        optimizer=STLS(threshold=1e-4), differentiation=SavitzkyGolay(window_length=11), dt=dt, n_substeps=4,
        validation_size=len(u) // 4, validation="full", n_trials=12, random_state=0,
        refine=OutputErrorRefinement(prune=prune, max_nfev=200), initial_state="fit",
    ).fit(u, y)


def test_hidden_tank_with_square_root_outflow(rng):
    """A hidden upper tank: the learned latent law has exactly the true terms; poles within 5 %."""

    def truth(x, u):
        up, low = max(x[1], 0.0), max(x[0], 0.0)
        return np.array([0.05 * np.sqrt(up) - 0.04 * np.sqrt(low), -0.05 * np.sqrt(up) + 0.04 * u[0]])

    dt, n = 2.0, 1200
    u = _steps(rng, n, 1.0, 4.0, 40)
    x = simulate(truth, [4.0, 4.0], u, dt, n_substeps=4)
    y = x[:, :1] + 0.01 * rng.standard_normal((n, 1))
    library = ConcatLibrary([PolynomialLibrary(degree=2), SqrtLibrary(variables=[0, 1])])
    model = _fit(u, y, dt, library, (2.0, 400.0, True), 0.1, latent_bounds=(0, np.inf), output_bounds=(0, np.inf))
    assert _support(model) == [{"sqrt(y0)", "sqrt(z0)"}, {"u0", "sqrt(z0)"}]
    inv = latent_invariants(model, [2.5])
    x_eq = np.array([6.25, 4.0])  # at u = 2.5: upper level (0.8 u)^2, lower level u^2
    np.testing.assert_allclose(np.sort(inv["poles"].real), _poles(truth, x_eq, [2.5]), rtol=0.05)
    np.testing.assert_allclose(inv["gain"], [[5.0]], rtol=0.05)  # dy/du = 2 u
    # the gauge: the coefficient of u0 in z0' is pinned at 1, and equations() says so
    assert model.equations()[-1] == "gauge: z0: the coefficient of u0 in z0' is 1 (scale gauge, held in the refinement)"
    assert "mixing" not in model.equations()[-2]  # z -> z + k y leaves no square-root model a square-root model
    z_row = model.coef_[1]
    assert z_row[model.library_.terms_.index(((2, 0, 1.0, 0.0),))] == pytest.approx(1.0)


def test_hidden_first_order_actuator_feeding_a_nonlinear_plant(rng):
    """``z' = -2 z + 2 u``, ``y' = -y - y^3 + z``: exact terms, gauge-free poles and gain within 5 %."""

    def truth(x, u):
        return np.array([-x[0] - x[0] ** 3 + x[1], -2.0 * x[1] + 2.0 * u[0]])

    dt, n = 0.05, 1200
    u = _steps(rng, n, -1.5, 1.5, 30)
    x = simulate(truth, [0.0, 0.0], u, dt, n_substeps=2)
    y = x[:, :1] + 0.002 * rng.standard_normal((n, 1))
    model = _fit(u, y, dt, PolynomialLibrary(degree=3), (0.05, 20.0, True), 0.05)
    assert _support(model) == [{"y0", "y0^3", "z0"}, {"z0", "u0"}]
    # y0' has no u0: z0 -> z0 + k y0 keeps the gauge coefficient and stays cubic, but adds terms to z0' for
    # any k != 0: the sparse support fixes k, and gauge() says so
    assert model.equations()[-2:] == [
        "gauge: z0: the coefficient of u0 in z0' is 1 (scale gauge, held in the refinement)",
        "gauge: z0: z0 -> z0 + k y0 gives the same outputs within this library but adds terms for any k != 0: the "
        "model's support fixes this mixing (sparsity gauge)"]
    inv = latent_invariants(model, [0.5])
    y_eq = np.roots([1.0, 0.0, 1.0, -0.5]).real[np.isclose(np.roots([1.0, 0.0, 1.0, -0.5]).imag, 0)][0]
    np.testing.assert_allclose(np.sort(inv["poles"].real), _poles(truth, np.array([y_eq, 0.5]), [0.5]), rtol=0.05)
    np.testing.assert_allclose(inv["gain"], [[1.0 / (1.0 + 3.0 * y_eq**2)]], rtol=0.05)
    lin = linearize(model, inv["state"], [0.5])  # the same exact derivatives as the linearization
    np.testing.assert_array_equal(inv["jacobian"], lin.A)
    np.testing.assert_allclose(inv["gain"], -np.linalg.solve(lin.A, lin.B)[:1], rtol=1e-12)


def test_without_the_gauge_term_the_refinement_says_what_is_missing(rng):
    u = _steps(rng, 300, 1.0, 2.0, 30)
    y = simulate(lambda x, v: -x + v, [1.0], u, 0.1)
    model = HiddenStateSINDy(hidden=LatentHiddenState(tau=1.0), library=SqrtLibrary(variables=[0, 1]),
                             dt=0.1, refine=OutputErrorRefinement())
    with pytest.raises(ValueError, match="no linear term of column 2"):
        model.fit(u, y)


@pytest.mark.parametrize(
    "params, match",
    [({"n_latent": 0}, "n_latent must be an integer >= 1"), ({"tau": -1.0}, "tau must be a finite number > 0"),
     ({"latent_bounds": (1.0, 0.0)}, "latent_bounds"), ({"scale": "range"}, "expected finite latent_bounds"),
     ({"driver": "velocity"}, "needs order=2"), ({"order": 3}, "order must be 1 or 2")],
)
def test_bad_parameters_are_refused(params, match):
    with pytest.raises(ValueError, match=match):
        LatentHiddenState(**params)._validate()


def test_two_latent_states_form_a_chain_with_one_gauge_each():
    s = LatentHiddenState(n_latent=2, tau=3.0)
    st = s.structure({"tau": 3.0}, n_outputs=1, n_inputs=1)
    assert st.state_names == ["y0", "z0", "z1"] and st.learned == (0, 1, 2)
    assert s.gauge().splitlines() == ["z0: the coefficient of u0 in z0' is held at 1 by the refinement (scale gauge)",
                                      "z1: the coefficient of z0 in z1' is held at 1 by the refinement (scale gauge)"]
    u = np.ones((50, 1))
    design = s.design(u, np.zeros((50, 1)), 0.1, derivative=lambda a, order=1: np.zeros_like(a),
                      params=s.resolve_params())
    # from the lags' steady state (z0 = tau u, z1 = tau z0) they stay at rest under a constant input
    np.testing.assert_allclose(design.states[:, 1:], np.tile([3.0, 9.0], (50, 1)))
    np.testing.assert_allclose(design.targets[:, 1:], 0.0, atol=1e-12)


def test_hidden_hysteresis_state_driven_by_the_velocity(rng):
    """A Bouc-Wen-like oscillator: ``v' = -4 y - 0.5 v - 6 z + u``, ``z' = v - 2 |v| z + v |z|``.

    The latent z is found from the displacement alone (``order=2``, gauge: the
    coefficient of v in z' is 1, as in the truth): exact terms, gauge-free
    poles within 5 % (at rest every z is an equilibrium: one pole is 0, and
    there is no static gain).
    """
    from sindybench.libraries import AbsProductLibrary
    from sindybench.simulate import TermsRHS

    truth = TermsRHS.from_equations([
        {((1, 0, 1, 0),): 1.0},
        {((0, 0, 1, 0),): -4.0, ((1, 0, 1, 0),): -0.5, ((2, 0, 1, 0),): -6.0, ((3, 0, 1, 0),): 1.0},
        {((1, 0, 1, 0),): 1.0, ((1, 1, 1, 0), (2, 0, 1, 0)): -2.0, ((1, 0, 1, 0), (2, 1, 1, 0)): 1.0},
    ])
    dt, n = 0.02, 3000
    t = np.arange(n) * dt
    u = sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in (0.13, 0.31, 0.57, 0.9))[:, None]
    x = simulate(truth, [0.0, 0.0, 0.0], u, dt, n_substeps=2)
    y = x[:, :1] + 1e-4 * rng.standard_normal((n, 1))
    library = ConcatLibrary([PolynomialLibrary(degree=1), AbsProductLibrary(pairs=[(1, 2)], products=("x|y|", "|x|y"))])
    model = HiddenStateSINDy(
        hidden=LatentHiddenState(order=2, driver="velocity", bounds={"tau": (0.05, 50.0)}), library=library,
        optimizer=STLS(threshold=1e-4, normalize_columns=True), differentiation=SavitzkyGolay(window_length=11),
        dt=dt, n_substeps=2, validation_size=600, n_trials=10, random_state=0,
        refine=OutputErrorRefinement(prune=0.02, max_nfev=100), initial_state="fit",
    ).fit(u, y)
    assert _support(model) == [{"y0", "v0", "z0", "u0"}, {"v0", "v0 |z0|", "|v0| z0"}]
    inv = latent_invariants(model, [0.0], y_guess=np.zeros(3))
    found, true = (np.sort_complex(np.linalg.eigvals(a)) for a in (inv["jacobian"], _jacobian(truth, np.zeros(3))))
    np.testing.assert_allclose(found, true, rtol=0.05, atol=1e-3)  # 0 and the roots of s^2 + 0.5 s + 10
    assert inv["gain"] is None


def test_bounds_pairs_are_log_scaled_and_dimensions_kept():
    space = LatentHiddenState(bounds={"tau": (1e-2, 1.0)}).search_space()
    assert space == {"tau": LogUniform(1e-2, 1.0)}
    prior = LogNormal(0.0, 1.0)
    assert LatentHiddenState(bounds={"tau": prior}).search_space() == {"tau": prior}
    with pytest.raises(ValueError, match=r"bounds\['tau'\] = Uniform\(low=-1.0, high=1.0\) reaches -1.0; expected "
                                         r"positive values only \(tau > 0\)"):
        LatentHiddenState(bounds={"tau": Uniform(-1.0, 1.0)})._validate()


def test_gauge_never_states_a_coefficient_the_model_does_not_have(rng):
    # before: "z0: the coefficient of u0 in z0' is 1" under a z0' row without u0 (no refinement, no u0 term)
    u = _steps(rng, 300, 1.0, 2.0, 30)
    y = simulate(lambda x, v: -x + v, [1.0], u, 0.1)
    model = HiddenStateSINDy(hidden=LatentHiddenState(tau=1.0), library=SqrtLibrary(variables=[0, 1]), dt=0.1,
                             n_trials=1).fit(u, y)
    assert "u0" not in model.equations()[1]
    assert model.equations()[-1] == ("gauge: z0: not fixed: z0' has no u0 term (the library has no linear term u0); "
                                     "the scale of z0 is free")


@pytest.mark.parametrize("params, match", [
    (dict(n_latent=0), "n_latent must be an integer >= 1; got 0"),  # before: ''
    (dict(driver="foo"), "driver must be one of .*got 'foo'"),  # before: KeyError: 'foo'
])
def test_gauge_of_an_invalid_strategy_is_an_error(params, match):
    with pytest.raises(ValueError, match=match):
        LatentHiddenState(**params).gauge()
def test_gauge_is_a_hook_of_every_strategy():
    """The protocol's gauge hook: nothing to say by default, one line per latent state for the latent strategy."""
    from sindybench.hidden import DerivativeHiddenState, HiddenStrategy

    assert "gauge" in vars(HiddenStrategy) and DerivativeHiddenState().gauge() == ""
    assert LatentHiddenState(n_latent=2).gauge().splitlines() == [
        "z0: the coefficient of u0 in z0' is held at 1 by the refinement (scale gauge)",
        "z1: the coefficient of z0 in z1' is held at 1 by the refinement (scale gauge)"]


def test_a_lag_chain_asked_again_is_the_one_simulated_before(monkeypatch):
    """The starting lag of one drive and time constant is simulated once; later calls get a copy of it."""
    from sindybench.hidden import _latent

    monkeypatch.setattr(_latent, "_LAG_CHAINS", __import__("collections").OrderedDict())
    strategy = LatentHiddenState()
    drive = np.sin(np.arange(400) * 0.05)
    z, z_dot = strategy._lags(drive, {"tau": 0.5, "gain": 1.0}, 0.01)
    z[:] = np.nan  # the caller's copy: the kept chain is not changed
    again, again_dot = strategy._lags(drive.copy(), {"tau": 0.5, "gain": 1.0}, 0.01)
    assert len(_latent._LAG_CHAINS) == 1
    fresh = simulate(lambda x, u: np.array([u[0] - x[0] / 0.5]), again[:1, 0], drive[:, None], 0.01, n_substeps=4)
    np.testing.assert_allclose(again, fresh, rtol=1e-12)
    np.testing.assert_array_equal(again_dot, np.c_[again, drive] @ [[-2.0], [1.0]])
    strategy._lags(drive, {"tau": 0.7, "gain": 1.0}, 0.01)  # another time constant: another chain
    assert len(_latent._LAG_CHAINS) == 2
    monkeypatch.setattr(_latent, "_LAG_CHAINS_BYTES", again.nbytes)  # room for one chain: the oldest goes
    strategy._lags(drive + 1.0, {"tau": 0.5, "gain": 1.0}, 0.01)
    assert len(_latent._LAG_CHAINS) == 1

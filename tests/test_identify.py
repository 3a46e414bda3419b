"""``sindybench.identify`` and ``IdentifyCV`` on synthetic systems of known truth, and on bad input."""

import importlib
import json

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.pipeline import Pipeline

import sindybench
from sindybench import HiddenStateSINDy, SINDy
from sindybench.identify import IdentifyCV, identify
from sindybench.identify._search import pareto_front, parsimonious_index, validation_blocks
from sindybench.simulate import SimulationError, simulate

# sindybench.identify is also the function: the module by its full name
stages_module = importlib.import_module("sindybench.identify._stages")
estimator_module = importlib.import_module("sindybench.identify._estimator")
DT = 0.01
# a quick search: one derivative method, no refinement (the defaults are exercised by the slow tests)
QUICK = dict(derivatives=["finite_difference"], n_refine=0, show_progress_bar=False)


def _multisine(n, rng, freqs=(0.3, 0.7, 1.3, 2.1)):
    t = np.arange(n) * DT
    phases = rng.uniform(0, 2 * np.pi, len(freqs))
    return sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, phases))[:, None]


def _record(rhs, x0, n, rng, noise=0.0, n_out=1):
    u = _multisine(n, rng)
    x = simulate(rhs, x0, u, dt=DT, n_substeps=4, input_hold="linear")
    y = x[:, :n_out] + noise * rng.standard_normal((n, n_out)) * np.std(x[:, :n_out])
    return u, y


def _support(model):
    """Names of the terms with nonzero coefficients in the learned rows."""
    names = model.library_.get_feature_names_out(model.state_names_ + ["u0"])
    return {str(n) for n, c in zip(names, np.asarray(model.coef_)[-1]) if c != 0}


def _oscillator(x, u):  # a lightly damped oscillator whose velocity is not measured
    return np.array([x[1], -4.0 * x[0] - 0.4 * x[1] + 2.0 * u[0]])


def _actuator(x, u):  # a hidden actuator: a first-order lag (the current) drives an integrator (the speed)
    return np.array([-3.0 * x[0] + x[1], -5.0 * x[1] + 4.0 * u[0]])


def _friction(x, u):  # a cart with viscous and Coulomb friction, position measured
    return np.array([x[1], -1.0 * x[1] - 0.8 * np.sign(x[1]) + 3.0 * u[0]])


@pytest.fixture(scope="module")
def oscillator():
    return _record(_oscillator, [0.0, 0.0], 3000, np.random.default_rng(0), noise=1e-4)


@pytest.fixture(scope="module")
def search(oscillator):
    u, y = oscillator
    return IdentifyCV(dt=DT, families=["first_order", "order2"], libraries=["linear", "poly2"], **QUICK).fit(u, y)


def test_oscillator_true_support(search, oscillator):
    model = search.best_estimator_
    assert isinstance(model, HiddenStateSINDy)
    assert search.best_params_["family"] == "order2"
    assert _support(model) == {"y0", "y0'", "u0"}
    u, y = oscillator
    assert model.score(u, y) > 0.999


def test_results_table_has_every_candidate(search):
    table = search.cv_results_
    n = len(table["family"])
    assert n > 20
    for key in ("library", "derivative", "input_hold", "threshold", "stage", "n_terms", "fit_time", "status",
                "split0_validation_error", "split2_validation_error", "mean_validation_error"):
        assert len(table[key]) == n
    assert set(table["stage"]) == {"screen", "blocks"}
    full = np.array(table["stage"]) != "screen"
    assert np.all(np.isinf(np.asarray(table["mean_validation_error"])[~full]))  # screened rows: one block only
    assert np.all(np.isfinite(np.asarray(table["split2_validation_error"])[full]))


def test_parsimony_rule_and_front(search):
    table = search.cv_results_
    mean = np.where(np.array(table["stage"]) != "screen", table["mean_validation_error"], np.inf)
    best = int(np.argmin(mean))
    chosen = search.best_index_
    assert mean[chosen] <= mean[best] + table["std_validation_error"][best] / np.sqrt(3)
    assert table["n_terms"][chosen] <= table["n_terms"][best]
    front = search.pareto_front_
    terms = [p["n_terms"] for p in front]
    errors = [p["validation_error"] for p in front]
    assert terms == sorted(terms) and errors == sorted(errors, reverse=True)
    assert chosen in [p["index"] for p in front]
    record = search.best_estimator_.identification_
    assert record["best_index"] == chosen and record["settings"] == search.best_params_


def test_input_hold_decided_and_confirmed(search):
    assert search.settings_["input_hold"] == "linear"  # a smooth input
    holds = {h for h, s in zip(search.cv_results_["input_hold"], search.cv_results_["stage"]) if s == "blocks"}
    assert holds == {"zoh", "linear"}


def test_hidden_actuator_true_support():
    u, y = _record(_actuator, [0.0, 0.0], 3000, np.random.default_rng(1), noise=1e-4)
    model = identify(u, y, dt=DT, families=["order2"], libraries=["linear", "poly2"], **QUICK)
    # y'' = -3 y' + x1' = -3 y' - 5 (y' + 3 y) + 4 u: the support is y, y', u
    assert _support(model) == {"y0", "y0'", "u0"}
    np.testing.assert_allclose(model.coef_[-1][model.coef_[-1] != 0], [-15.0, -8.0, 4.0], rtol=0.02)


def test_friction_proposed_and_found():
    u, y = _record(_friction, [0.0, 0.0], 4000, np.random.default_rng(2), noise=1e-5)
    search = IdentifyCV(dt=DT, families=["order2"], libraries=["linear", "linear+hard"], **QUICK).fit(u, y)
    model = search.best_estimator_
    assert "linear+hard" in search.cv_results_["library"]
    assert _support(model) == {"y0'", "sign(y0')", "u0"}
    np.testing.assert_allclose(model.coef_[-1][model.coef_[-1] != 0], [-1.0, 3.0, -0.8], rtol=0.05)


def test_returns_an_ordinary_estimator_that_saves(tmp_path):
    u, y = _record(lambda x, u: np.array([-2.0 * x[0] + u[0]]), [0.0], 1500, np.random.default_rng(3))
    model = sindybench.identify(u, y, dt=DT, families=["first_order"], libraries=["linear"], **QUICK)
    assert type(model) is SINDy
    model.to_json(tmp_path / "m.json")
    loaded = sindybench.load_model(tmp_path / "m.json")
    np.testing.assert_allclose(loaded.predict(u, y_init=y), model.predict(u, y_init=y))


def test_clone_and_pipeline(oscillator):
    u, y = oscillator
    est = IdentifyCV(dt=DT, families=["order2"], libraries=["linear"], max_candidates=12, **QUICK)
    assert clone(est).get_params() == est.get_params()
    pipe = Pipeline([("identify", est)]).fit(u, y)
    np.testing.assert_allclose(pipe.predict(u, y_init=y), pipe[-1].best_estimator_.predict(u, y_init=y))
    assert len(pipe[-1].cv_results_["family"]) <= 12 + 2  # the budget, plus the first path's levels


def test_a_failing_candidate_is_recorded_not_raised(oscillator, monkeypatch):
    u, y = oscillator
    from sindybench.differentiation._local import SavitzkyGolay

    def broken(self, *args, **kwargs):
        raise ValueError("this derivative cannot be taken")

    # every Savitzky-Golay derivative raises: those candidates fail, the search goes on (since 0.3 a 5-sample start
    # feeds any window through a polynomial fit of the start, so a short start no longer makes them fail)
    monkeypatch.setattr(SavitzkyGolay, "_derivative", broken)
    search = IdentifyCV(dt=DT, families=["order2"], libraries=["linear"], derivatives=["finite_difference", "savgol"],
                        n_init=5, n_refine=0, show_progress_bar=False).fit(u, y)
    status = search.cv_results_["status"]
    assert any("failed" in s for s in status) and any(s == "ok" for s in status)
    assert search.best_params_["derivative"] == "finite_difference"


@pytest.mark.parametrize("kwargs, match", [
    ({"time_budget": 0}, "time_budget must be"),
    ({"max_candidates": 0}, "max_candidates must be an integer >= 1"),
    ({"families": ["latent7"]}, "families must be one of"),
    ({"families": "order2"}, "families must be a non-empty list"),
    ({"input_hold": "cubic"}, "input_hold must be one of"),
    ({"n_blocks": 5, "block_size": 0.2}, "leaves too little training data"),
    ({"refinement": "yes"}, "refinement must be an OutputErrorRefinement"),
])
def test_bad_parameters(oscillator, kwargs, match):
    u, y = oscillator
    with pytest.raises(ValueError, match=match):
        IdentifyCV(dt=DT, **kwargs).fit(u, y)


def test_bad_data(oscillator):
    u, y = oscillator
    with pytest.raises(ValueError, match="too few for 3 validation blocks"):
        IdentifyCV(dt=DT).fit(u[:60], y[:60])
    with pytest.raises(ValueError, match="input column 0 is constant"):
        IdentifyCV(dt=DT).fit(np.ones_like(u), y)
    with pytest.raises(ValueError, match="NaN"):
        y_nan = y.copy()
        y_nan[10] = np.nan
        IdentifyCV(dt=DT).fit(u, y_nan)
    with pytest.raises(ValueError, match="dt is None"):
        IdentifyCV().fit(u, y)
    with pytest.raises(ValueError, match="too few for 3 validation blocks of 1002 samples"):
        IdentifyCV(dt=DT, n_init=1000).fit(u, y)


def test_a_family_that_raises_is_recorded_and_the_search_goes_on(oscillator, monkeypatch):
    real = stages_module.make_estimator

    def make_estimator(structure, *args, **kwargs):
        if structure["family"] in ("order3", "order1+latent"):
            raise RuntimeError(f"no estimator for {structure['family']}")
        return real(structure, *args, **kwargs)

    monkeypatch.setattr(stages_module, "make_estimator", make_estimator)
    search = IdentifyCV(dt=DT, families=["order2", "order3", "order1+latent"], libraries=["linear"],
                        **QUICK).fit(*oscillator)
    table = search.cv_results_
    for family in ("order3", "order1+latent"):
        rows = [i for i, f in enumerate(table["family"]) if f == family]
        assert rows and all(table["status"][i] == f"failed: RuntimeError: no estimator for {family}" for i in rows)
        assert all(np.isinf(table["mean_validation_error"][i]) for i in rows)
    assert search.best_params_["family"] == "order2"


def test_no_candidate_that_simulates_is_a_clear_error(oscillator, monkeypatch):
    u, y = oscillator

    def make_estimator(structure, *args, **kwargs):
        raise RuntimeError("nothing fits")

    monkeypatch.setattr(stages_module, "make_estimator", make_estimator)
    with pytest.raises(ValueError, match=r"none of the \d+ candidates .*RuntimeError: nothing fits.*expected a record"):
        IdentifyCV(dt=DT, families=["first_order"], libraries=["linear"], **QUICK).fit(u, y)


def _refit_diverges(monkeypatch, families, n_samples):
    """The refit on the whole record (``n_samples``) of the ``families``' candidates raises, as a refinement whose
    starting model diverges on the whole record did (the fits on the folds' training parts do not)."""
    real = estimator_module.make_estimator

    def make_estimator(structure, *args, **kwargs):
        est = real(structure, *args, **kwargs)
        if structure["family"] in families:
            fit = est.fit

            def fit_whole(X, y, **kw):
                if len(X) == n_samples:
                    raise SimulationError("cannot refine: the starting model's simulation diverges on the record",
                                          step=7)
                return fit(X, y, **kw)
            est.fit = fit_whole
        return est

    monkeypatch.setattr(estimator_module, "make_estimator", make_estimator)


def test_a_candidate_whose_refit_fails_is_recorded_and_the_next_one_chosen(oscillator, monkeypatch):
    """(was: the SimulationError of the chosen candidate's refit ended identify)"""
    u, y = oscillator
    _refit_diverges(monkeypatch, ("order2",), len(u))
    search = IdentifyCV(dt=DT, families=["first_order", "order2"], libraries=["linear"], **QUICK).fit(u, y)
    table = search.cv_results_
    failed = [i for i, s in enumerate(table["status"]) if s.startswith("failed at the refit")]
    assert failed and all(table["family"][i] == "order2" for i in failed)
    assert table["status"][failed[0]] == ("failed at the refit on the whole record: SimulationError: cannot refine: "
                                          "the starting model's simulation diverges on the record")
    assert all(np.isinf(table["mean_validation_error"][i]) for i in failed)
    assert search.best_params_["family"] == "first_order" and table["status"][search.best_index_] == "ok"
    assert not {p["index"] for p in search.pareto_front_} & set(failed)
    assert np.isfinite(search.best_estimator_.predict(u, y_init=y[:20])).all()


def test_every_refit_failing_is_a_clear_error(oscillator, monkeypatch):
    u, y = oscillator
    _refit_diverges(monkeypatch, ("first_order",), len(u))
    with pytest.raises(ValueError, match=r"each of the \d+ candidate\(s\) that simulated every validation block failed "
                       r'when refitted on the whole record \(reasons: \["failed at the refit on the whole '
                       r"record: SimulationError: cannot refine"):
        IdentifyCV(dt=DT, families=["first_order"], libraries=["linear"], **QUICK).fit(u, y)


def test_a_constant_output_is_refused(oscillator):
    u, y = oscillator
    with pytest.raises(ValueError, match="output column 0 is constant"):
        IdentifyCV(dt=DT).fit(u, np.full_like(y, 2.0))


def test_helpers():
    assert validation_blocks(200, 2, 0.25, 50) == [(100, 150), (150, 200)]
    assert parsimonious_index([0.2, 0.21, 0.5], [0.05, 0.0, 0.0], [9, 3, 1], 4) == 1
    assert pareto_front([0.3, 0.3, 0.1], [4, 2, 8]) == [1, 2]


def test_pareto_front_plot(search):
    pytest.importorskip("matplotlib")
    from sindybench.plotting import plot_pareto_front

    ax = plot_pareto_front(search.best_estimator_)
    front = ax.get_lines()[1]
    assert front.get_xdata().tolist() == [p["n_terms"] for p in search.pareto_front_]
    with pytest.raises(ValueError, match="cannot read a Pareto front"):
        plot_pareto_front(SINDy())


def test_run_all_row_reports_the_choice_and_the_front(tmp_path):
    from sklearn.utils import Bunch

    from sindybench.experiments import Benchmark, run_benchmarks
    from sindybench.experiments._common import IDENTIFIED, identified

    def load(*, data_home=None, download_if_missing=True):  # y' = -0.5 y + u, the input held between samples
        u = np.repeat(np.random.default_rng(0).uniform(-1.0, 1.0, 60), 20)[:, None]
        y = simulate(lambda x, u: np.array([-0.5 * x[0] + u[0]]), [0.0], u, dt=0.1)
        parts = [slice(0, 600), slice(600, 800), slice(800, 1200)]
        return Bunch(**{k: Bunch(u=u[p], y=y[p], dt=0.1) for k, p in zip(("train", "validation", "test"), parts)})

    bench = Benchmark(name="toy", title="Toy", load=load, n_init=2, models=(identified(2),))
    report = run_benchmarks([bench], tmp_path / "out", quick=True)

    results = json.loads((tmp_path / "out" / "toy" / "results.json").read_text())
    (row,) = results["models"]
    assert row["key"] == IDENTIFIED and row["status"] == "ok"
    assert row["best_params"]["input_hold"] in ("zoh", "linear") and row["best_params"]["n_terms"] >= 2
    assert row["scores"]["test"]["r2"] > 0.99
    assert row["pareto_front"][0]["n_terms"] <= 2 and row["inner_trials"] > 10
    assert "Pareto front (terms: validation error)" in report.read_text()
    assert (tmp_path / "out" / "toy" / "models" / f"{IDENTIFIED}.json").is_file()


def _tank(x, u):  # a tank with a square-root outflow: its level stays positive
    return np.array([-0.8 * np.sqrt(max(x[0], 0.0)) + 0.5 + 0.3 * u[0]])


def test_square_root_outflow_proposed_and_found():
    u, y = _record(_tank, [0.4], 4000, np.random.default_rng(4), noise=1e-5)
    search = IdentifyCV(dt=DT, families=["first_order"], libraries=["linear", "linear+hard"], **QUICK).fit(u, y)
    assert search.settings_["positive"]
    model = search.best_estimator_
    assert _support(model) == {"1", "sqrt(y0)", "u0"}
    np.testing.assert_allclose(model.coef_[0][model.coef_[0] != 0], [0.5, 0.3, -0.8], rtol=0.05)


@pytest.mark.slow
def test_default_search_puts_the_oscillator_on_its_front(oscillator):
    """Every family, library, derivative and the refinement: the true 3-term model is on the front.

    The parsimony rule may prefer the order-1 latent model (two states as well, 8 terms: an
    equivalent linear realization) when its validation error is lower by more than a standard error.
    """
    u, y = oscillator
    search = IdentifyCV(dt=DT, show_progress_bar=False).fit(u, y)
    table = search.cv_results_
    on_front = [p["index"] for p in search.pareto_front_ if p["n_terms"] == 3]
    assert on_front and table["family"][on_front[0]] == "order2"
    assert search.best_estimator_.score(u, y) > 0.999 and search.best_estimator_.n_states_ == 2


def test_input_delay_from_the_advice_confirmed_on_validation():
    rng = np.random.default_rng(5)
    u = np.repeat(rng.standard_normal(400), 5)[:, None]  # held for 5 samples
    delayed = np.vstack([np.zeros((3, 1)), u[:-3]])  # the system sees the input 3 samples late
    y = simulate(lambda x, u: np.array([-2.0 * x[0] + u[0]]), [0.0], delayed, dt=DT)
    search = IdentifyCV(dt=DT, families=["first_order"], libraries=["linear"], **QUICK).fit(u, y)
    assert search.settings_["input_delay"] == 3
    assert 0 in search.cv_results_["input_delay"]  # the delay was also tried without
    assert search.best_params_["input_delay"] == 3
    assert _support(search.best_estimator_) == {"y0", "u0"}


@pytest.mark.slow
def test_n_jobs_gives_the_same_search(oscillator):
    """Worker processes (joblib) give the very same table (slow: each worker compiles the kernels)."""
    u, y = oscillator
    kwargs = dict(dt=DT, families=["order2"], libraries=["linear"], **QUICK)
    one = IdentifyCV(**kwargs).fit(u, y)
    two = IdentifyCV(n_jobs=2, **kwargs).fit(u, y)
    assert one.best_params_ == two.best_params_
    np.testing.assert_array_equal(one.cv_results_["mean_validation_error"], two.cv_results_["mean_validation_error"])


def test_refit_keeps_the_validated_terms(oscillator, monkeypatch):
    # the choice is refitted on the whole record over the terms its validated (last-fold) fit kept, and no
    # others: here every candidate's validated support loses its last term, so the refit must lose it too
    real = stages_module.validated_terms

    def fewer(model, family):
        support = real(model, family)
        return support[:-1] if support is not None and len(support) > 1 else support

    monkeypatch.setattr(stages_module, "validated_terms", fewer)
    u, y = oscillator
    search = IdentifyCV(dt=DT, families=["order2"], libraries=["linear"], **QUICK).fit(u, y)
    model = search.best_estimator_
    assert search.best_params_["family"] == "order2"
    assert _support(model) == {"y0", "y0'"}  # u0 (the library's last term) was dropped from the support
    assert search.best_params_["n_terms"] == 2


def test_validated_terms_of_rows_with_their_own_supports():
    from sindybench.libraries import PolynomialLibrary

    u = np.linspace(0.0, 1.0, 50)[:, None]
    model = SINDy(library=PolynomialLibrary(degree=1), optimizer=sindybench.STLS(threshold=0.0), dt=0.1)
    model.fit(u, np.hstack([np.exp(np.linspace(0, 1, 50))[:, None], np.ones((50, 1))]))
    model.coef_ = np.array([[0.0, 1.0, 0.0, 2.0], [3.0, 0.0, 0.0, 0.0]])  # rows keep {x0, u0} and {1}
    support = stages_module.validated_terms(model, "first_order")
    library = stages_module.validated_library({"support": support}, PolynomialLibrary())
    assert library.fit(np.zeros((1, 3))).get_feature_names_out(["x0", "x1", "u0"]).tolist() == ["1", "x0", "u0"]
    assert stages_module.validated_terms(model, "order1+latent") is None  # a family with its own term selection

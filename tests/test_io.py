"""JSON save/load: every public estimator round-trips bit for bit, bad files are refused by field."""

import json

import numpy as np
import pytest
from sklearn.base import BaseEstimator, clone
from sklearn.exceptions import NotFittedError

import sindybench.io as sio
from sindybench import STLS, HiddenStateSINDy, SINDy, load_model
from sindybench.baselines import ARX, NNARX
from sindybench.datasets import load_bouc_wen, load_cascaded_tanks, load_pick_and_place
from sindybench.differentiation import SavitzkyGolay, Spectral
from sindybench.hidden import BoucWenHiddenState, DerivativeHiddenState, ParametricHiddenState, TanksHiddenState
from sindybench.libraries import AbsProductLibrary, CustomLibrary, PolynomialLibrary, SqrtLibrary
from sindybench.refine import OutputErrorRefinement
from sindybench.simulate import simulate

DT = 0.02


def upper_tank(xh, y, u, *, k1, k2):
    """A module-level ``rhs`` for ParametricHiddenState: the upper tank of the cascaded tanks."""
    return k1 * u - k2 * np.sqrt(np.clip(xh, 0.0, None))


# ---------------------------------------------------------------- real-data models
def _record(load, data_home, n=None):
    data = load(data_home=data_home)
    u, y = data["estimation"]["u"], data["estimation"]["y"]
    test = data["test"] if "u" in data["test"] else next(iter(data["test"].values()))
    return u[:n], y[:n], test["u"][:n], test["y"][:n], float(data["dt"])


def _tanks_models(dt):
    return {
        "SINDy": SINDy(library=PolynomialLibrary(degree=2) + SqrtLibrary(), optimizer=STLS(threshold=1e-3), dt=dt,
                       bounds=(0.0, 10.0), n_substeps=2, output_names=["level"], input_names=["pump"]),
        "SINDy-refined": SINDy(library=PolynomialLibrary(degree=1) + SqrtLibrary(), optimizer=STLS(threshold=1e-3),
                               dt=dt, bounds=(0.0, 10.0), refine=OutputErrorRefinement(max_nfev=5)),
        "ARX": ARX(na=2, nb=2),
        "NNARX": NNARX(hidden_layer_sizes=(8, 4), max_iter=60, n_estimators=2, random_state=0),
        "TanksHiddenState": HiddenStateSINDy(
            hidden=TanksHiddenState(k1=0.05, k_bounds=(0.02, 0.08), ratio_bounds=(0.3, 3.0), output_bounds=(0, 10)),
            dt=dt, n_substeps=2, n_trials=4, random_state=0, validation="full"),
        "ParametricHiddenState": HiddenStateSINDy(
            hidden=ParametricHiddenState(upper_tank, params={"k1": 0.05, "k2": (0.02, 0.1)}, x0_bounds=(0.0, 10.0),
                                         bounds=(0.0, 10.0), grid_size=3, init_size=10, n_substeps=1),
            library=PolynomialLibrary(degree=1) + SqrtLibrary(), dt=dt, n_trials=3, random_state=0),
    }


@pytest.fixture(scope="module")
def fitted_models(data_home):
    """``{name: (fitted model, X, y, X_test, y_test)}``, each fitted on a real benchmark record."""
    out = {}
    u, y, u_te, y_te, dt = _record(load_cascaded_tanks, data_home)
    for name, model in _tanks_models(dt).items():
        n = 400 if name == "ParametricHiddenState" else None  # the Python-path model: a shorter record, faster
        out[name] = (model.fit(u[:n], y[:n]), u[:n], y[:n], u_te, y_te)
    theta = PolynomialLibrary(degree=2).fit_transform(np.hstack([y, u]))
    target = np.gradient(y[:, 0], dt)
    out["STLS"] = (STLS(threshold=0.05).fit(theta, target), theta, target, theta, None)
    u, y, u_te, y_te, dt = _record(load_bouc_wen, data_home, n=3000)
    model = HiddenStateSINDy(hidden=BoucWenHiddenState(m=2.0, c=10.0, k=5e4, trim=50),
                             optimizer=STLS(threshold=1e5, normalize_columns=True),
                             differentiation=Spectral(cutoff=150.0), dt=dt, n_substeps=2, input_hold="linear")
    out["BoucWenHiddenState"] = (model.fit(u, y), u, y, u_te, y_te)
    refined = clone(model).set_params(hidden__m=2.2, refine=OutputErrorRefinement(max_nfev=4, max_samples=1000))
    out["BoucWenHiddenState-refined"] = (refined.fit(u, y), u, y, u_te, y_te)
    u, y, u_te, y_te, dt = _record(load_pick_and_place, data_home, n=1200)
    model = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=2),
                             optimizer=STLS(threshold=1e-3, normalize_columns=True), dt=dt)
    out["DerivativeHiddenState"] = (model.fit(u, y), u, y, u_te, y_te)
    return out


@pytest.fixture(scope="module")
def saved(fitted_models, tmp_path_factory):
    """``{name: path}`` of the fitted models saved as files."""
    folder = tmp_path_factory.mktemp("models")
    paths = {}
    for name, (model, *_) in fitted_models.items():
        paths[name] = folder / f"{name}.json"
        model.to_json(paths[name])
    return paths


def _outputs(model, X, y):
    """Every result a user reads from a fitted model: prediction and simulation."""
    if isinstance(model, STLS):
        return [model.predict(X)]
    n = 50
    if isinstance(model, SINDy):
        return [model.predict(X, y_init=y[:n]), model.simulate(X, x0=y[0])]
    if isinstance(model, HiddenStateSINDy):
        return [model.predict(X, y_init=y[:n]), model.simulate(X, y_init=y[:n], on_divergence="nan"),
                model.simulate(X, x0=model.x0_, on_divergence="nan")]
    return [model.predict(X, y_init=y[:n]), model.simulate(X)]


ESTIMATORS = ["SINDy", "STLS", "ARX", "NNARX", "DerivativeHiddenState", "BoucWenHiddenState", "TanksHiddenState",
              "ParametricHiddenState", "SINDy-refined", "BoucWenHiddenState-refined"]


@pytest.mark.parametrize("name", ESTIMATORS)
def test_every_estimator_round_trips_bit_for_bit(fitted_models, saved, name):
    model, X, y, X_test, y_test = fitted_models[name]
    X_test, y_test = X_test[:400], None if y_test is None else y_test[:400]
    loaded = load_model(saved[name], allow_import=True)
    assert type(loaded) is type(model) and repr(loaded) == repr(model)
    # the same hyperparameters (compared as stored) and the same fitted state: saving again gives the same file
    assert sio.model_to_dict(loaded) == sio.model_to_dict(model)
    expected = _outputs(model, X_test, y_test)
    assert all(np.all(np.isfinite(e)) for e in expected)
    assert all(np.array_equal(got, e) for got, e in zip(_outputs(loaded, X_test, y_test), expected, strict=True))
    if hasattr(model, "equations"):
        assert loaded.equations() == model.equations()
    # it clones, and a refit on the same data gives the same model again
    again = clone(loaded).fit(X, y)
    assert all(np.array_equal(got, e) for got, e in zip(_outputs(again, X_test, y_test), expected, strict=True))


def test_hidden_state_model_keeps_its_trajectory_and_search(fitted_models, saved):
    model = fitted_models["TanksHiddenState"][0]
    loaded = load_model(saved["TanksHiddenState"])
    assert len(model.search_results_) == 4 and loaded.search_results_ == model.search_results_
    assert loaded.best_params_ == model.best_params_ and loaded.params_ == model.params_
    np.testing.assert_array_equal(loaded.states_, model.states_)
    np.testing.assert_array_equal(loaded.hidden_states_, model.hidden_states_)
    np.testing.assert_array_equal(loaded.structure_.fixed_coef, model.structure_.fixed_coef)
    assert loaded.structure_.bounds is not None and loaded.state_names_ == model.state_names_


@pytest.mark.parametrize("name", ["SINDy-refined", "BoucWenHiddenState-refined"])
def test_refined_models_keep_their_refinement(fitted_models, saved, name):
    model = fitted_models[name][0]
    loaded = load_model(saved[name])
    assert model.refinement_["nfev"] >= 1 and loaded.refinement_ == model.refinement_
    assert loaded.refine.max_nfev == model.refine.max_nfev
    if name.startswith("BoucWen"):  # the refined mass enters the fixed force balance
        assert loaded.params_["m"] == model.params_["m"] != 2.2
        np.testing.assert_array_equal(loaded.structure_.fixed_coef, model.structure_.fixed_coef)
    np.testing.assert_array_equal(loaded.x0_, model.x0_)


def test_refitted_values_survive_the_round_trip(fitted_models, tmp_path):
    """Fitted arrays changed after fit are stored, not recomputed; the fixed rows follow the physical parameters."""
    model = clone(fitted_models["BoucWenHiddenState"][0])
    _, X, y, X_test, y_test = fitted_models["BoucWenHiddenState"]
    model.fit(X, y)
    model.coef_ = model.coef_ * 0.99
    model.x0_ = model.x0_ + 1e-4
    model.hidden_ = clone(model.hidden_).set_params(k=model.params_["k"] * 1.01)  # another fixed k, and with it:
    model.params_ = {**model.params_, "k": model.hidden_.k}
    model.structure_ = model.hidden_.structure(model.params_, n_outputs=1, n_inputs=1)
    model._rebuild_model()
    model.to_json(tmp_path / "m.json")
    loaded = load_model(tmp_path / "m.json")
    np.testing.assert_array_equal(loaded.structure_.fixed_coef, model.structure_.fixed_coef)
    np.testing.assert_array_equal(loaded.coef_, model.coef_)
    assert np.array_equal(loaded.predict(X_test, y_init=y_test[:50]), model.predict(X_test, y_init=y_test[:50]))
    with pytest.warns(UserWarning, match="predict without y_init"):
        assert np.array_equal(loaded.predict(X_test), model.predict(X_test))


def test_parametric_function_is_imported_only_when_allowed(saved):
    with pytest.raises(ValueError, match=r"params.hidden.estimator.params.rhs is the Python function "
                                         r"'(tests\.)?test_io:upper_tank'.*pass allow_import=True"):
        load_model(saved["ParametricHiddenState"])
    assert load_model(saved["ParametricHiddenState"], allow_import=True).hidden.rhs is upper_tank


@pytest.mark.parametrize("rhs, match", [
    (lambda xh, y, u, *, a: -a * xh, "params.hidden.rhs = <function <lambda>.* cannot be stored: only a module-level"),
    ("local", r"params.hidden.rhs = <function .*<locals>.leak.* cannot be stored: only a module-level"),
])
def test_lambda_or_local_rhs_is_refused_at_save(tmp_path, rng, rhs, match):
    if rhs == "local":
        def leak(xh, y, u, *, a):
            return -a * xh

        rhs = leak
    t = np.arange(60) * DT
    u = np.sin(t)[:, None]
    y = np.cos(t)[:, None] + 1e-3 * rng.normal(size=(60, 1))
    hidden = ParametricHiddenState(rhs, params={"a": 0.5}, x0_bounds=(0.0, 1.0), grid_size=2, init_size=5)
    model = HiddenStateSINDy(hidden=hidden, library=PolynomialLibrary(degree=1), dt=DT, n_trials=2,
                             random_state=0).fit(u, y)
    with pytest.raises(ValueError, match=match):
        model.to_json(tmp_path / "m.json")
    assert list(tmp_path.iterdir()) == []


def test_floats_round_trip_exactly():
    a = np.array([0.1, 1 / 3, -0.0, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, np.pi * 1e-17,
                  np.inf, -np.inf, np.nan])
    back = sio.decode_array(json.loads(json.dumps(sio.encode_array(a), allow_nan=False)), "x")
    assert back.dtype == a.dtype and np.array_equal(back.view(np.int64), a.view(np.int64))
    a32 = np.array([0.1, 1 / 3, -0.0, 1e-45, 3.4028235e38, np.inf], dtype=np.float32)
    back = sio.decode_array(json.loads(json.dumps(sio.encode_array(a32), allow_nan=False)), "x")
    assert back.dtype == np.float32 and np.array_equal(back.view(np.int32), a32.view(np.int32))


# ---------------------------------------------------------------- refusal of bad files
def _set(path, value):
    """Edit that sets the entry at ``path`` (keys and list indices) to ``value``."""
    def edit(d):
        for key in path[:-1]:
            d = d[key]
        d[path[-1]] = value
    return edit


def _drop(path):
    def edit(d):
        for key in path[:-1]:
            d = d[key]
        del d[path[-1]]
    return edit


def _array(*shape):
    return sio.encode_array(np.ones(shape))


_FLOAT_DATA = {"dtype": "float64", "shape": [2], "data": [1.0, "one"]}
_EST = "estimator"
CORRUPTIONS = [
    # (file, edit of the JSON data or of the text, expected message)
    ("SINDy", "truncate", "is not valid JSON"),
    ("SINDy", "empty", "is not valid JSON"),
    ("SINDy", "list", "format: not a sindybench model"),
    ("SINDy", _set(["format_version"], "2"), "format_version: model file version '2' is not supported; expected 2"),
    ("SINDy", _drop(["class"]), r"class: unknown class None; expected one of \['ARX', "),
    ("SINDy", _set(["class"], "os.system"), "class: unknown class 'os.system'"),
    ("SINDy", _set(["class"], "PolynomialLibrary"), "class: unknown class 'PolynomialLibrary'"),
    ("SINDy", _set(["class"], "STLS"), r"params: unknown parameter\(s\) \['bounds', "),
    ("SINDy", _set(["params"], None), "params: missing or null; expected an object"),
    ("SINDy", _set(["params"], [1, 2]), "params: expected a JSON object; got a list of 2"),
    ("SINDy", _set(["params", "bogus"], 1), r"params: unknown parameter\(s\) \['bogus'\] of SINDy"),
    ("SINDy", _set(["params", "n_substeps"], "two"), "params: n_substeps must be an integer >= 1; got 'two'"),
    ("SINDy", _set(["params", "optimizer", _EST, "class"], "os.system"),
     "params.optimizer.estimator.class: unknown class 'os.system'"),
    ("SINDy", _set(["params", "optimizer"], {"pickle": "gASV"}),
     "params.optimizer: expected a plain value or a one-key object tagged"),
    ("SINDy", _set(["params", "optimizer", _EST, "params", "threshold"], {"float": "huge"}),
     r"params.optimizer.estimator.params.threshold.float: expected one of \['-inf', 'inf', 'nan'\]"),
    ("SINDy", _set(["params", "bounds"], {"tuple": 5}), "params.bounds.tuple: expected a list; got a number"),
    ("SINDy", _set(["params", "library", _EST, "params"], {"degree": 2, "shape": 1}),
     r"params.library.estimator.params: unknown parameter\(s\) \['degree', 'shape'\] of ConcatLibrary; expected "),
    ("SINDy", _set(["fitted"], None), "fitted: missing or null; expected an object"),
    ("SINDy", _drop(["fitted", "x0"]), "fitted.x0: missing or null; expected an array"),
    ("SINDy", _set(["fitted", "x0"], [0.5]), r"fitted.x0: expected an array \{'dtype', 'shape', 'data'\}; got a list"),
    ("SINDy", _set(["fitted", "coef"], _array(2, 8)),
     r"fitted.coef: expected an array of shape \(1, \d+\); got shape \(2, 8\)"),
    ("SINDy", _set(["fitted", "coef", "data"], [1.0]), r"fitted.coef.data: expected a list of \d+ values"),
    ("SINDy", _set(["fitted", "coef", "dtype"], "object"), r"fitted.coef.dtype: expected one of \['bool', "),
    ("SINDy", _set(["fitted", "x0"], _FLOAT_DATA), r"fitted.x0.data: expected float64 values"),
    ("SINDy", _set(["fitted", "n_states"], "1"), "fitted.n_states: expected an integer >= 1; got a string"),
    ("SINDy", _set(["fitted", "n_states"], True), "fitted.n_states: expected an integer >= 1; got a boolean"),
    ("SINDy", _set(["fitted", "n_states"], 0), "fitted.n_states: expected an integer >= 1; got a number"),
    ("SINDy", _set(["fitted", "output_names"], ["a", "b"]), "fitted.output_names: expected a list of 1 strings"),
    ("SINDy", _set(["fitted", "dt"], "fast"), "fitted.dt: expected a number; got a string"),
    ("SINDy", _set(["fitted", "output_1d"], "no"), "fitted.output_1d: expected true or false"),
    ("SINDy", _set(["fitted", "library", "terms"], [[]]), r"fitted.library.terms: expected the \d+ terms of"),
    ("SINDy", _set(["fitted", "library", "terms"], [[[9, 0, 1, 0]]]), r"fitted.library.terms\[0\] uses column 9"),
    ("SINDy", _set(["fitted", "library", "library", _EST, "class"], "subprocess.Popen"),
     "fitted.library.library.estimator.class: unknown class 'subprocess.Popen'"),
    ("SINDy", _set(["fitted", "optimizer", "fitted", "coef"], _array(3)),
     r"fitted.optimizer.fitted.coef: expected an array of shape \(n_features_in,\) or \(n_targets, n_features_in\)"),
    ("SINDy", _drop(["fitted", "optimizer", "class"]), "fitted.optimizer.class: unknown class None"),
    ("DerivativeHiddenState", _set(["fitted", "structure", "learned"], [7]),
     r"fitted.structure.learned: expected a list of integers >= 0 and < 2; got a list of 1"),
    ("DerivativeHiddenState", _set(["fitted", "structure", "fixed_coef"], _array(2, 2)),
     r"fitted.structure.fixed_coef: expected an array of shape \(1, 2\); got shape \(2, 2\)"),
    ("DerivativeHiddenState", _set(["fitted", "structure", "state_names"], None),
     "fitted.structure.state_names: missing or null; expected a list of 2 strings"),
    ("DerivativeHiddenState", _set(["fitted", "structure", "output_index"], [0, 1]),
     "fitted.structure.output_index: expected 1 indices"),
    ("DerivativeHiddenState", _set(["fitted", "states"], _array(5, 3)),
     r"fitted.states: expected an array of shape \(n, 2\); got shape \(5, 3\)"),
    ("DerivativeHiddenState", _set(["fitted", "hidden", _EST, "class"], "os.system"),
     "fitted.hidden.estimator.class: unknown class 'os.system'"),
    ("DerivativeHiddenState", _set(["fitted", "hidden"], {"estimator": {"class": "STLS", "params": {}}}),
     "fitted.hidden: expected a hidden-state strategy; got STLS"),
    ("DerivativeHiddenState", _set(["fitted", "params"], [1.0]), r"fitted.params: expected a dict \{name: value\}"),
    ("DerivativeHiddenState", _drop(["fitted", "structure"]), "fitted.structure: missing or null; expected an object"),
    ("DerivativeHiddenState", _set(["params", "validation"], "sometimes"), "params: validation must be one of"),
    ("NNARX", _set(["fitted", "networks"], []), r"fitted.networks: expected a list of 2 objects; got a list of 0"),
    ("NNARX", _set(["fitted", "networks", 0, "coefs", 0], _array(3, 8)),
     r"fitted.networks\[0\].coefs\[0\]: expected an array of shape \(4, 8\); got shape \(3, 8\)"),
    ("NNARX", _set(["fitted", "networks", 1, "seed"], 1.5), r"fitted.networks\[1\].seed: expected an integer"),
    ("NNARX", _set(["params", "activation"], "sine"), "params: activation must be one of"),
    ("ARX", _set(["fitted", "intercept"], _array(2)), r"fitted.intercept: expected an array of shape \(1,\)"),
    ("ParametricHiddenState", _set(["params", "hidden", _EST, "params", "rhs", "function"], "os:system"),
     r"params.hidden.estimator.params.rhs: 'os:system' is a builtin_function_or_method; expected a Python function"),
    ("ParametricHiddenState", _set(["params", "hidden", _EST, "params", "rhs", "function"], "no_such_module_x:f"),
     "params.hidden.estimator.params.rhs: cannot import the function 'no_such_module_x:f'"),
]


@pytest.mark.parametrize("name, edit, match", CORRUPTIONS, ids=[f"{c[0]}-{i}" for i, c in enumerate(CORRUPTIONS)])
def test_corrupted_files_are_refused_naming_the_field(saved, tmp_path, name, edit, match):
    text = saved[name].read_text()
    if edit == "truncate":
        text = text[: len(text) // 2]
    elif edit == "empty":
        text = ""
    elif edit == "list":
        text = json.dumps([json.loads(text)])
    else:
        data = json.loads(text)
        edit(data)
        text = json.dumps(data)
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        load_model(path, allow_import=True)


# ---------------------------------------------------------------- SINDy details, synthetic data
def _data(rng, n=1500):
    t = np.arange(n) * DT
    u = np.column_stack([np.sin(0.7 * t) + 0.5 * np.sin(2.3 * t + 1.0), np.cos(0.4 * t)])
    truth = lambda x, v: np.array([-1.5 * x[0] + x[0] * abs(v[0]) + v[1], -0.5 * x[1] + np.sqrt(max(x[0] + 2, 0)) - v[0]])  # noqa: E731
    y = simulate(truth, [0.3, 0.1], u, dt=DT, n_substeps=2, input_hold="linear")
    return u, y + 1e-4 * rng.normal(size=y.shape)


@pytest.fixture
def fitted(rng):
    u, y = _data(rng)
    library = PolynomialLibrary(degree=2) + SqrtLibrary(lower=0.0, variables=[0]) + AbsProductLibrary(pairs=[(0, 2)])
    model = SINDy(
        library=library,
        optimizer=STLS(threshold=0.02, alpha=1e-6),
        dt=DT,
        n_substeps=2,
        input_hold="linear",
        bounds=(None, [5.0, np.inf]),
        max_abs=1e3,
        output_names=["pos", "vel"],
        input_names=["force", "gate"],
    )
    return model.fit(u, y), u, y


def test_round_trip_simulates_identically(tmp_path, fitted):
    model, u, y = fitted
    path = tmp_path / "model.json"
    model.to_json(path)
    loaded = load_model(path)
    assert isinstance(loaded, SINDy)
    np.testing.assert_array_equal(loaded.coef_, model.coef_)
    assert loaded.terms_ == model.terms_
    assert loaded.equations() == model.equations()
    assert loaded.feature_names_ == model.feature_names_
    np.testing.assert_array_equal(loaded.simulate(u, x0=y[0]), model.simulate(u, x0=y[0]))
    np.testing.assert_array_equal(loaded.predict(u[:300], y_init=y[:300]), model.predict(u[:300], y_init=y[:300]))
    assert loaded.score(u, y) == model.score(u, y)
    assert repr(loaded) == repr(model) and loaded.bounds == model.bounds


def test_differentiation_settings_are_kept(tmp_path, rng):
    u, y = _data(rng, n=400)
    model = SINDy(library=PolynomialLibrary(degree=1), differentiation=SavitzkyGolay(window_length=9, polyorder=2), dt=DT)
    model.fit(u, y).to_json(tmp_path / "m.json")
    loaded = load_model(tmp_path / "m.json")
    assert isinstance(loaded.differentiation, SavitzkyGolay)
    assert loaded.differentiation.get_params() == {"window_length": 9, "polyorder": 2}
    np.testing.assert_array_equal(loaded.fit(u, y).coef_, model.coef_)


def test_file_is_plain_json(tmp_path, fitted):
    model, _, _ = fitted
    model.to_json(tmp_path / "m.json")
    data = json.loads((tmp_path / "m.json").read_text())
    assert data["format"] == "sindybench-model" and data["format_version"] == 2 and data["class"] == "SINDy"
    assert data["params"]["max_abs"] == 1000.0
    assert data["params"]["bounds"] == {"tuple": [None, [5.0, {"float": "inf"}]]}
    assert data["params"]["library"]["estimator"]["class"] == "ConcatLibrary"
    assert data["fitted"]["coef"]["shape"] == [2, len(data["fitted"]["library"]["terms"])]
    assert len(data["fitted"]["feature_names"]) == len(data["fitted"]["library"]["terms"])
    assert data["fitted"]["dt"] == DT


def test_custom_library_is_refused_and_nothing_written(tmp_path, rng):
    u, y = _data(rng, n=300)
    model = SINDy(library=CustomLibrary(functions=[np.tanh]), dt=DT).fit(u, y)
    with pytest.raises(ValueError, match="params.library = CustomLibrary.* is not a registered class"):
        model.to_json(tmp_path / "m.json")
    assert list(tmp_path.iterdir()) == []


def test_unfitted_model_is_refused(tmp_path):
    with pytest.raises(NotFittedError):
        SINDy().to_json(tmp_path / "m.json")
    assert list(tmp_path.iterdir()) == []


def test_saved_file_has_the_permissions_of_an_ordinary_file(tmp_path, fitted):
    model, _, _ = fitted
    model.to_json(tmp_path / "m.json")
    (tmp_path / "plain.txt").write_text("x")
    assert (tmp_path / "m.json").stat().st_mode == (tmp_path / "plain.txt").stat().st_mode


def test_failed_write_keeps_the_old_file(tmp_path, fitted, monkeypatch):
    model, u, y = fitted
    path = tmp_path / "m.json"
    model.to_json(path)
    before = path.read_bytes()

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(sio._files.os, "replace", broken_replace)
    other = SINDy(library=PolynomialLibrary(degree=1), dt=DT).fit(u, y)
    with pytest.raises(OSError, match="disk full"):
        other.to_json(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["m.json"]  # no temporary file left


class _Gain(BaseEstimator):
    def __init__(self, *, k=1.0):
        self.k = k

    def fit(self, X, y):
        self.gain_ = self.k * float(np.mean(y))
        return self


def _restore_gain(model, fitted):
    model.gain_ = fitted.float("gain")


def test_other_estimators_plug_in(tmp_path, monkeypatch):
    monkeypatch.setitem(sio._registry._REGISTRY, "_Gain", None)  # removed again after the test
    sio.register_model(_Gain, to_dict=lambda m: {"gain": m.gain_}, from_dict=_restore_gain)
    model = _Gain(k=2.0).fit(None, np.array([1.0, 2.0]))
    sio.save_model(model, tmp_path / "g.json")
    loaded = load_model(tmp_path / "g.json")
    assert isinstance(loaded, _Gain) and loaded.k == 2.0 and loaded.gain_ == 3.0
    with pytest.raises(ValueError, match=r"cannot save a list; expected one of \['ARX', .*'_Gain'\]"):
        sio.save_model([], tmp_path / "x.json")
    with pytest.raises(ValueError, match="another class named 'SINDy' is registered"):
        sio.register_model(type("SINDy", (BaseEstimator,), {}))


def test_one_dimensional_output_round_trip(tmp_path, rng):
    u, y = _data(rng, n=400)
    model = SINDy(library=PolynomialLibrary(degree=1), dt=DT).fit(u, y[:, 0])
    model.to_json(tmp_path / "m.json")
    loaded = load_model(tmp_path / "m.json")
    np.testing.assert_array_equal(loaded.x0_, model.x0_)
    assert loaded.predict(u, y_init=y[:, 0]).shape == (400,)
    np.testing.assert_array_equal(loaded.predict(u, y_init=y[:, 0]), model.predict(u, y_init=y[:, 0]))


@pytest.mark.parametrize("make", [
    lambda: SINDy(library=PolynomialLibrary(degree=2), dt=0.01, refine=OutputErrorRefinement(max_nfev=5)),
    lambda: HiddenStateSINDy(hidden=DerivativeHiddenState(order=1), library=PolynomialLibrary(degree=2), dt=0.01,
                             differentiation=SavitzkyGolay(15, polyorder=3), refine=OutputErrorRefinement(max_nfev=5),
                             show_progress_bar=False),
], ids=["SINDy", "HiddenStateSINDy"])
def test_model_fitted_on_records_round_trips(tmp_path, make):
    # the records' refined starts, the stacked states and the per-record predictions survive the file
    t = np.arange(300) * 0.01
    us = [(m + 0.2 * np.sin(2 * t) + 0.1 * np.sin(5.3 * t))[:, None] for m in (0.0, 0.375)]
    ys = [simulate(lambda x, u: np.array([-x[0] + 0.5 * x[0] ** 2 + u[0]]), [y0], u, dt=0.01, input_hold="linear")
          for y0, u in zip((0.0, 1.5), us)]
    model = make().fit(us, ys)
    model.to_json(tmp_path / "m.json")
    loaded = load_model(tmp_path / "m.json")
    assert loaded.refinement_ == model.refinement_ and len(loaded.refinement_["initial_states"]) == 2
    np.testing.assert_array_equal(loaded.x0_, model.x0_)
    np.testing.assert_array_equal(getattr(loaded, "states_", 0), getattr(model, "states_", 0))
    starts = loaded.refinement_["initial_states"]
    for a, b in zip(loaded.predict(us, x0=starts), model.predict(us, x0=starts)):
        np.testing.assert_array_equal(a, b)
    assert loaded.standard_errors() == model.standard_errors()
    assert "y0(0) [record 1]" in loaded.standard_errors()

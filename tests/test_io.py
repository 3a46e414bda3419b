"""JSON save/load: identical simulation after a round trip, atomic writes, clear refusals."""

import json

import numpy as np
import pytest
from sklearn.base import BaseEstimator
from sklearn.exceptions import NotFittedError

import sindybench.io as sio
from sindybench import STLS, SINDy, load_model
from sindybench.differentiation import SavitzkyGolay
from sindybench.libraries import AbsProductLibrary, CustomLibrary, PolynomialLibrary, SqrtLibrary
from sindybench.simulate import simulate

DT = 0.02


def _data(rng, n=1500):
    t = np.arange(n) * DT
    u = np.column_stack([np.sin(0.7 * t) + 0.5 * np.sin(2.3 * t + 1.0), np.cos(0.4 * t)])
    truth = lambda x, v: np.array([-1.5 * x[0] + x[0] * abs(v[0]) + v[1], -0.5 * x[1] + np.sqrt(max(x[0] + 2, 0)) - v[0]])
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
    np.testing.assert_array_equal(loaded.simulate(u, y[0]), model.simulate(u, y[0]))
    np.testing.assert_array_equal(loaded.predict(u[:300], y_init=y[:300]), model.predict(u[:300], y_init=y[:300]))
    assert loaded.score(u, y) == model.score(u, y)
    for name in ("dt", "n_substeps", "integrator", "input_hold", "max_abs", "output_names", "input_names"):
        assert getattr(loaded, name) == getattr(model, name)
    assert repr(loaded.optimizer) == repr(model.optimizer)


def test_loaded_model_can_be_refit(tmp_path, fitted):
    model, u, y = fitted
    model.to_json(tmp_path / "m.json")
    refit = load_model(tmp_path / "m.json").fit(u, y)
    np.testing.assert_allclose(refit.coef_, model.coef_, rtol=1e-12, atol=1e-14)


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
    assert data["format"] == "sindybench-model" and data["class"] == "SINDy"
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


def test_failed_write_keeps_the_old_file(tmp_path, fitted, monkeypatch):
    model, u, y = fitted
    path = tmp_path / "m.json"
    model.to_json(path)
    before = path.read_bytes()

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(sio.os, "replace", broken_replace)
    other = SINDy(library=PolynomialLibrary(degree=1), dt=DT).fit(u, y)
    with pytest.raises(OSError, match="disk full"):
        other.to_json(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["m.json"]  # no temporary file left


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda d: d.update(format="other"), "not a sindybench model"),
        (lambda d: d.update(format_version=99), "version 99 is not supported"),
        (lambda d: d.update({"class": "Nope"}), "class: unknown class 'Nope'"),
        (lambda d: d["fitted"]["library"].pop("terms"), "fitted.library.terms: missing or null"),
        (lambda d: d["fitted"].update(coef=sio.encode_array(np.ones((1, 1)))), r"fitted.coef: expected .*\(2, 9\)"),
    ],
)
def test_bad_files_are_refused(tmp_path, fitted, edit, match):
    model, _, _ = fitted
    data = sio.model_to_dict(model)
    edit(data)
    path = tmp_path / "m.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=match):
        load_model(path)


def test_invalid_json_is_refused(tmp_path):
    path = tmp_path / "m.json"
    path.write_text('{"format": "sindybench-model", ')
    with pytest.raises(ValueError, match="is not valid JSON"):
        load_model(path)


class _Gain(BaseEstimator):
    def __init__(self, *, k=1.0):
        self.k = k

    def fit(self, X, y):
        self.gain_ = self.k * float(np.mean(y))
        return self


def test_other_estimators_plug_in(tmp_path, monkeypatch):
    monkeypatch.setattr(sio, "_REGISTRY", dict(sio._REGISTRY))
    sio.register_model(_Gain, to_dict=lambda m: {"gain": m.gain_}, from_dict=_restore_gain)
    model = _Gain(k=2.0).fit(None, np.array([1.0, 2.0]))
    sio.save_model(model, tmp_path / "g.json")
    loaded = load_model(tmp_path / "g.json")
    assert isinstance(loaded, _Gain) and loaded.k == 2.0 and loaded.gain_ == 3.0
    with pytest.raises(ValueError, match=r"cannot save a list; expected one of \['ARX', .*'_Gain'\]"):
        sio.save_model([], tmp_path / "x.json")


def _restore_gain(model, fitted):
    model.gain_ = fitted.float("gain")


def test_one_dimensional_output_round_trip(tmp_path, rng):
    u, y = _data(rng, n=400)
    model = SINDy(library=PolynomialLibrary(degree=1), dt=DT).fit(u, y[:, 0])
    model.to_json(tmp_path / "m.json")
    loaded = load_model(tmp_path / "m.json")
    np.testing.assert_array_equal(loaded.x0_, model.x0_)
    assert loaded.predict(u, y_init=y[:, 0]).shape == (400,)
    np.testing.assert_array_equal(loaded.predict(u, y_init=y[:, 0]), model.predict(u, y_init=y[:, 0]))

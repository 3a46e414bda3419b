"""HiddenStateSINDy's "auto" defaults (``sindybench/hidden/_auto.py``) and the model files written before them.

``tests/data/hidden_sindy_0_1.json`` and ``hidden_sindy_0_1_predict.npy`` were written by sindybench 0.1
(main before these defaults) from :func:`_old_record`::

    model = HiddenStateSINDy(dt=0.02, show_progress_bar=False).fit(u, y)
    model.to_json("hidden_sindy_0_1.json")
    np.save("hidden_sindy_0_1_predict.npy", model.predict(u, y_init=y[:20]))
"""

import json
from pathlib import Path

import numpy as np
import pytest
from sklearn.base import clone

from sindybench import HiddenStateSINDy, load_model
from sindybench.differentiation import FiniteDifference, data_differentiation
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.search import LogUniform
from sindybench.simulate import TermsRHS, simulate

DATA = Path(__file__).resolve().parent / "data"
DT = 0.01
_Y, _V = ((0, 0, 1, 0),), ((1, 0, 1, 0),)


def _oscillator(rng, n=1200, hold="linear"):
    """y'' = -4 y - 0.5 y' + 2 u driven by a smooth input (a linear hold between samples)."""
    t = np.arange(n) * DT
    u = (np.sin(1.3 * t) + np.sin(2.9 * t + 1.0) + 0.05 * rng.standard_normal(n).cumsum() / 30)[:, None]
    truth = TermsRHS.from_equations([{_V: 1.0}, {_Y: -4.0, _V: -0.5, ((2, 0, 1, 0),): 2.0}])
    return u, simulate(truth, [0.3, 0.0], u, dt=DT, n_substeps=4, input_hold=hold)[:, :1]


def _old_record():
    t = np.arange(300) * 0.02
    u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    truth = TermsRHS.from_equations([{_V: 1.0}, {_Y: -4.0, _V: -0.5, ((2, 0, 1, 0),): 2.0}])
    return u, simulate(truth, [0.0, 0.0], u, dt=0.02)[:, :1]


def test_defaults_decide_on_the_validation_block_and_report(rng):
    u, y = _oscillator(rng)
    # the record is noise-free: the exact fourth-order differences let the hold decide the scores (the bandwidth's
    # Savitzky-Golay window, the default derivative since 0.3, biases y'' by a few % here before the refinement)
    model = HiddenStateSINDy(dt=DT, differentiation=FiniteDifference(accuracy=4), show_progress_bar=False).fit(u, y)
    assert [sorted(v) for v, _ in model.search_results_] == [["input_hold", "library__degree"]] * 4
    scores = {(v["input_hold"], v["library__degree"]): s for v, s in model.search_results_}
    best = min(scores, key=scores.get)
    assert model.best_params_ == {"input_hold": best[0], "library__degree": best[1]}
    assert model.input_hold_ == best[0] == model.dynamics_.input_hold
    assert model.library_.degree == best[1]
    assert scores[("linear", 1)] < scores[("zoh", 1)]  # the truth's input is linear between samples
    assert model.refinement_ is not None  # compiled: refined by simulation error
    assert model.score(u, y) > 0.999
    default = HiddenStateSINDy(dt=DT, show_progress_bar=False).fit(u, y)
    assert repr(default.differentiation_) == repr(data_differentiation(y, DT))  # the record's bandwidth chose it (since 0.3)
    assert default.refinement_["status"] >= 1 and default.score(u, y) > 0.999  # the refinement removes its bias


def test_set_values_are_not_decided(rng):
    u, y = _oscillator(rng, n=600)
    model = HiddenStateSINDy(dt=DT, input_hold="zoh", library=PolynomialLibrary(degree=2), refine=None,
                             show_progress_bar=False).fit(u, y)
    assert model.best_params_ == {} and model.search_results_ == []
    assert model.input_hold_ == "zoh" and model.refinement_ is None and model.library_.degree == 2
    one = HiddenStateSINDy(dt=DT, input_hold="zoh", refine=None, show_progress_bar=False).fit(u, y)
    assert [v for v, _ in one.search_results_] == [{"library__degree": 1}, {"library__degree": 2}]
    assert one.input_hold_ == "zoh"


def test_a_search_decides_the_hold_with_its_other_dimensions(rng):
    u, y = _oscillator(rng, n=600)
    model = HiddenStateSINDy(dt=DT, library=PolynomialLibrary(degree=1), refine=None, n_trials=6, random_state=0,
                             search_params={"optimizer__threshold": LogUniform(1e-4, 1e-1)},
                             show_progress_bar=False).fit(u, y)
    assert all(v["input_hold"] in ("zoh", "linear") for v, _ in model.search_results_)
    assert model.input_hold_ == model.best_params_["input_hold"]


def test_too_short_for_a_validation_block_takes_the_fallback(rng):
    u, y = _oscillator(rng, n=40)
    model = HiddenStateSINDy(dt=DT, refine=None, validation_size=1, show_progress_bar=False).fit(u, y)
    assert model.best_params_ == {"input_hold": "linear", "library__degree": 2} and model.search_results_ == []


def test_bad_auto_values_are_refused(rng):
    u, y = _oscillator(rng, n=100)
    with pytest.raises(ValueError, match="input_hold must be one of"):
        HiddenStateSINDy(dt=DT, input_hold="Auto").fit(u, y)
    with pytest.raises(ValueError, match="refine must be an OutputErrorRefinement"):
        HiddenStateSINDy(dt=DT, refine="yes").fit(u, y)


def test_a_new_model_file_keeps_what_auto_decided(rng, tmp_path):
    u, y = _oscillator(rng, n=600, hold="zoh")
    model = HiddenStateSINDy(dt=DT, refine=None, show_progress_bar=False).fit(u, y)
    model.to_json(tmp_path / "m.json")
    loaded = load_model(tmp_path / "m.json")
    assert loaded.input_hold == "auto" and loaded.input_hold_ == model.input_hold_
    np.testing.assert_array_equal(loaded.predict(u, y_init=y[:20]), model.predict(u, y_init=y[:20]))
    data = json.loads((tmp_path / "m.json").read_text())
    data["fitted"]["input_hold"] = "cubic"
    with pytest.raises(ValueError, match="fitted.input_hold: expected one of"):
        load_model_dict(data)


def load_model_dict(data):
    from sindybench.io import model_from_dict

    return model_from_dict(data)


def test_a_file_written_by_0_1_loads_with_its_settings_and_predicts_the_same():
    u, y = _old_record()
    model = load_model(DATA / "hidden_sindy_0_1.json")
    assert model.input_hold == model.input_hold_ == "zoh"
    assert model.library is None and model.refine is None and model.differentiation.accuracy == 2
    np.testing.assert_allclose(model.predict(u, y_init=y[:20]), np.load(DATA / "hidden_sindy_0_1_predict.npy"),
                               rtol=1e-10, atol=1e-12)


def test_a_file_without_the_later_parameters_takes_the_old_defaults():
    u, y = _old_record()
    data = json.loads((DATA / "hidden_sindy_0_1.json").read_text())
    for name in ("input_hold", "library", "refine", "differentiation"):  # a file written before they existed
        del data["params"][name]
    model = load_model_dict(data)
    assert (model.input_hold, model.input_hold_, model.library, model.refine) == ("zoh", "zoh", None, None)
    assert model.differentiation.accuracy == 2
    np.testing.assert_allclose(model.predict(u, y_init=y[:20]), np.load(DATA / "hidden_sindy_0_1_predict.npy"),
                               rtol=1e-10, atol=1e-12)
    refit = HiddenStateSINDy(**model.get_params(deep=False)).fit(u, y)  # a refit of such a file is the 0.1 fit
    np.testing.assert_allclose(refit.coef_, model.coef_, rtol=1e-9, atol=1e-12)


def test_a_file_of_0_2_without_the_differentiation_parameter_keeps_fourth_order_differences(rng, tmp_path):
    # 0.2's default was FiniteDifference(accuracy=4); a file that did not store it loads with it, not with "auto"
    u, y = _oscillator(rng, n=400)
    model = HiddenStateSINDy(dt=DT, differentiation=FiniteDifference(accuracy=4), refine=None,
                             show_progress_bar=False).fit(u, y)
    model.to_json(tmp_path / "m.json")
    data = json.loads((tmp_path / "m.json").read_text())
    assert load_model_dict(data).differentiation.accuracy == 4  # stored: kept
    del data["params"]["differentiation"]
    loaded = load_model_dict(data)
    assert type(loaded.differentiation) is FiniteDifference and loaded.differentiation.accuracy == 4
    np.testing.assert_array_equal(loaded.predict(u, y_init=y[:20]), model.predict(u, y_init=y[:20]))
    refit = clone(loaded).fit(u, y)
    np.testing.assert_array_equal(refit.coef_, model.coef_)
    auto = HiddenStateSINDy(dt=DT, refine=None, show_progress_bar=False).fit(u, y)  # a file of "auto" keeps it
    auto.to_json(tmp_path / "auto.json")
    assert load_model(tmp_path / "auto.json").differentiation == "auto"


def test_order_one_strategy_and_no_inputs(rng):
    u, y = _oscillator(rng, n=400)
    model = HiddenStateSINDy(dt=DT, hidden=DerivativeHiddenState(order=1), refine=None,
                             show_progress_bar=False).fit(None, y)
    assert {v["input_hold"] for v, _ in model.search_results_} == {"zoh"}


def test_auto_skips_a_refinement_the_strategy_cannot_set_up(rng):
    from sindybench.hidden import LatentHiddenState
    from sindybench.libraries import SqrtLibrary

    u = np.repeat(rng.uniform(1.0, 2.0, 10), 30)[:, None]
    y = simulate(lambda x, v: -x + v, [1.0], u, 0.1)
    kwargs = dict(hidden=LatentHiddenState(tau=1.0), library=SqrtLibrary(variables=[0, 1]), dt=0.1, n_trials=1,
                  show_progress_bar=False)
    model = HiddenStateSINDy(**kwargs).fit(u, y)  # no linear driver term: the latent gauge cannot be held
    assert model.refinement_["status"] == -1 and "no linear term of column 2" in model.refinement_["message"]
    from sindybench.refine import OutputErrorRefinement

    with pytest.raises(ValueError, match="no linear term of column 2"):  # asked for, it must run
        HiddenStateSINDy(refine=OutputErrorRefinement(), **kwargs).fit(u, y)

"""hidden._latent_hard: hinges of a latent state whose level the fit decides (the level gauge)."""

import warnings

import numpy as np
import pytest

from sindybench import HiddenStateSINDy
from sindybench.hidden import LatentHiddenState
from sindybench.hidden._latent_hard import hinge_terms, latent_levels
from sindybench.io import load_model
from sindybench.libraries import PolynomialLibrary, TermsLibrary
from sindybench.optimizers import STLS
from sindybench.refine import OutputErrorRefinement
from sindybench.search import Uniform
from sindybench.simulate import simulate

DT, LEVEL = 0.05, 0.8


def _record(n=700):
    """A fast hidden state ``x' = -x + 2 u`` feeding ``y' = -0.5 y + 0.5 min(x, 0.8)``: it saturates at u = 0.4."""
    t = np.arange(n) * DT
    u = (0.6 * np.sin(0.7 * t) + 0.4 * np.sin(1.9 * t + 1.0) + 0.3 * np.sin(0.23 * t))[:, None]
    x = simulate(lambda x, u: np.array([-x[0] + 2.0 * u[0], -0.5 * x[1] + 0.5 * min(x[0], LEVEL)]), np.zeros(2), u,
                 DT, n_substeps=4)
    return u, x[:, 1:2] + 0.002 * np.random.default_rng(0).standard_normal((n, 1))


@pytest.fixture(scope="module")
def fitted():
    u, y = _record()
    # the upper hinge placed off the truth (u0's 80 % quantile, in u0's units at the start): the fit moves it
    level = float(np.quantile(u, 0.8))
    library = PolynomialLibrary(degree=1) + TermsLibrary(terms=hinge_terms(1, level, times=[2]))
    half = 0.5 * (level - float(np.quantile(u, 0.2)))  # the start's offset searched: the level's search
    hidden = LatentHiddenState(scale="units", offset=None, bounds={"tau": (0.2, 10.0), "offset": Uniform(-half, half)})
    model = HiddenStateSINDy(hidden=hidden, library=library,
                             optimizer=STLS(threshold=0.0, alpha=1e-9, normalize_columns=True), dt=DT, n_trials=10,
                             refine=OutputErrorRefinement(max_nfev=30), initial_state="fit", show_progress_bar=False,
                             random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(u, y)
    return model, u, y, level


def test_the_fitted_level_recovers_the_saturation(fitted):
    model, u, y, held = fitted
    (entry,) = latent_levels(model)
    assert entry["state"] == "z0" and entry["side"] == "upper" and entry["held"] == held
    names = list(model.library_.get_feature_names_out(["y0", "z0", "u0"]))
    a, b = (model.coef_[1, names.index(name)] for name in ("z0", "u0"))
    # gauge-free: the input level at which the latent state reaches its kink at rest (true 0.8 / 2 = 0.4)
    assert -entry["level"] * a / b == pytest.approx(LEVEL / 2.0, rel=0.05)
    y_pred = model.predict(u, y_init=y[:5])
    assert np.sqrt(np.mean((y_pred - y) ** 2)) < 0.05 * np.std(y)


def test_equations_and_gauge_print_the_exact_level(fitted):
    model, _, _, held = fitted
    text = "\n".join(model.equations())
    assert f"max(z0-{held!r}, 0)" in text and f"max(z0-{held!r}, 0) u0" in text
    gauge = model.hidden.gauge(model)
    assert f"upper hinge level is held at {held!r}" in gauge
    assert f"the fitted level is {latent_levels(model)[0]['level']!r} where z0 rests at 0" in gauge


def test_a_model_with_a_latent_hinge_round_trips_through_json(fitted, tmp_path):
    model, u, y, _ = fitted
    model.to_json(tmp_path / "hinge.json")
    loaded = load_model(tmp_path / "hinge.json")
    assert loaded.equations() == model.equations()
    assert latent_levels(loaded) == latent_levels(model)
    np.testing.assert_allclose(loaded.predict(u[:200], y_init=y[:5]), model.predict(u[:200], y_init=y[:5]),
                               rtol=1e-9, atol=1e-12)


def test_the_filter_sees_the_hinge(fitted):
    """The Jacobian of the terms (the filters') steps at the held level, and the model's filter follows the record."""
    from sindybench.estimation import extended_kalman_filter
    from sindybench.libraries import evaluate_terms_jacobian

    model, u, y, held = fitted
    terms = hinge_terms(1, held)
    Z = np.array([[0.0, held - 0.1, 0.0], [0.0, held + 0.1, 0.0]])
    assert evaluate_terms_jacobian(terms, Z)[:, 0, 1].tolist() == [0.0, 1.0]
    result = extended_kalman_filter(model, u, y, Q=1e-8, R=0.002**2)
    assert np.sqrt(np.mean((result.states[:, 0] - y[:, 0]) ** 2)) < 0.004


def test_hinge_terms_check_their_arguments():
    assert hinge_terms(1, -0.5, side="lower") == [((1, 5, -0.5, -1.0),)]
    with pytest.raises(ValueError, match="side must be 'upper' or 'lower'"):
        hinge_terms(1, 0.5, side="top")
    with pytest.raises(ValueError, match="level must be a finite number"):
        hinge_terms(1, np.inf)


def test_the_units_gauge_starts_in_the_drivers_units():
    s = LatentHiddenState(scale="units")
    assert s.resolve_params({"tau": 4.0}) == {"tau": 4.0, "gain": 0.25}  # offset 0: the parameters of old files
    assert LatentHiddenState(offset=0.5).resolve_params({"tau": 4.0}) == {"tau": 4.0, "gain": 1.0, "offset": 0.5}
    searched = LatentHiddenState(scale="units", offset=None, bounds={"offset": (-1.0, 1.0)})
    assert sorted(searched.search_space()) == ["offset", "tau"]
    with pytest.raises(ValueError, match="offset must be a finite number or None"):
        LatentHiddenState(offset=np.nan)._validate()
    assert "held at its start value 1/tau" in s.gauge()
    with pytest.raises(ValueError, match="scale must be one of"):
        LatentHiddenState(scale="offset")._validate()


def test_a_model_file_from_before_the_offset_still_loads(tmp_path):
    """Files written before ``offset`` existed have no such key: they load as ``offset=0`` and predict alike."""
    import json

    u, y = _record(300)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = HiddenStateSINDy(hidden=LatentHiddenState(bounds={"tau": (0.2, 10.0)}), dt=DT, n_trials=4,
                                 random_state=0, show_progress_bar=False,
                                 refine=OutputErrorRefinement(max_nfev=3)).fit(u, y)
    model.to_json(tmp_path / "new.json")

    def strip(obj):
        if isinstance(obj, dict):
            return {k: strip(v) for k, v in obj.items() if k != "offset"}
        return [strip(v) for v in obj] if isinstance(obj, list) else obj

    old = strip(json.loads((tmp_path / "new.json").read_text()))
    (tmp_path / "old.json").write_text(json.dumps(old))
    loaded = load_model(tmp_path / "old.json")
    assert loaded.hidden.offset == 0.0
    np.testing.assert_allclose(loaded.predict(u, y_init=y[:5]), model.predict(u, y_init=y[:5]), rtol=1e-12)


# ---------------------------------------------------------------- warm start: levels="range"
def _warm(levels, library=None, **kwargs):
    lib = library if library is not None else PolynomialLibrary(degree=1) + TermsLibrary(
        terms=hinge_terms(1, 0.0, times=[2]) + hinge_terms(1, 0.0, side="lower", times=[2]))
    return HiddenStateSINDy(hidden=LatentHiddenState(bounds={"tau": (0.2, 10.0)}, levels=levels), library=lib,
                            optimizer=STLS(threshold=0.0, alpha=1e-9, normalize_columns=True), dt=DT, n_trials=6,
                            refine=OutputErrorRefinement(max_nfev=20), initial_state="fit", show_progress_bar=False,
                            random_state=0, **kwargs)


@pytest.fixture(scope="module")
def warm():
    u, y = _record()
    return _warm_and_plain(u, y)


def _warm_and_plain(u, y, library=None):
    """The warm-started model of ``library`` and the plain model it starts from, fitted on ``(u, y)``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = _warm("range", library=library).fit(u, y)
        plain = _warm("library", library=PolynomialLibrary(degree=1)).fit(u, y)
    return model, plain, u, y


def test_the_warm_start_refines_the_hinges_from_the_plain_model(warm):
    model, plain, u, y = warm
    record = model.refinement_["range_levels"]
    # it starts from the plain model: the same simulation error before its refinement as the plain one after its own
    assert record["plain_cost"] == pytest.approx(plain.refinement_["cost"], rel=1e-6)
    assert record["kept"] and record["cost"] <= record["plain_cost"]
    # the levels: the 80 % and 20 % quantiles of the plain model's simulated latent state
    z = plain.states_[:, 1]
    assert [lv[2] for lv in record["levels"]] == pytest.approx([np.quantile(z, 0.8), np.quantile(z, 0.2)])
    # the hinges move the fit: a saturation the plain linear model cannot follow
    rmse = [np.sqrt(np.mean((m.predict(u, y_init=y[:5]) - y) ** 2)) for m in (model, plain)]
    assert rmse[0] < 0.5 * rmse[1]
    # the upper hinge's fitted level, gauge-free: the input at which the latent state at rest reaches it (true 0.4)
    names = list(model.library_.get_feature_names_out(["y0", "z0", "u0"]))
    a, b = (model.coef_[1, names.index(name)] for name in ("z0", "u0"))
    upper = [e for e in latent_levels(model) if e["side"] == "upper"][0]
    assert -upper["level"] * a / b == pytest.approx(LEVEL / 2.0, rel=0.05)


def test_a_warm_started_model_round_trips_and_prints_its_levels(warm, tmp_path):
    model, _, u, y = warm
    assert model.hidden_.levels == "range"
    text = "\n".join(model.equations())
    for _, _, level, _ in model.refinement_["range_levels"]["levels"]:
        assert repr(level) in text
    model.to_json(tmp_path / "warm.json")
    loaded = load_model(tmp_path / "warm.json")
    assert loaded.equations() == model.equations() and loaded.hidden.levels == "range"
    np.testing.assert_allclose(loaded.predict(u[:200], y_init=y[:5]), model.predict(u[:200], y_init=y[:5]),
                               rtol=1e-9, atol=1e-12)


def test_the_warm_start_checks_its_inputs():
    u, y = _record(200)
    with pytest.raises(ValueError, match="levels must be one of"):
        LatentHiddenState(levels="data")._validate()
    with pytest.raises(ValueError, match="levels='range' needs a library whose last part is a TermsLibrary of hinge"):
        _warm("range", library=PolynomialLibrary(degree=1)).fit(u, y)
    with pytest.raises(ValueError, match="levels='range' fits one record; got several"):
        _warm("range").fit([u, u], [y, y])


# ---------------------------------------------------------------- indicators of a latent state, levels="range"
def _overflow(n=700):
    """``x' = -x + 2 u`` feeding ``y' = -0.5 y + 0.5 x - 0.4 [x >= 0.8]``: a drop while the hidden state is high."""
    t = np.arange(n) * DT
    u = (0.6 * np.sin(0.7 * t) + 0.4 * np.sin(1.9 * t + 1.0) + 0.3 * np.sin(0.23 * t))[:, None]
    x = simulate(lambda x, u: np.array([-x[0] + 2.0 * u[0], -0.5 * x[1] + 0.5 * x[0] - 0.4 * (x[0] >= LEVEL)]),
                 np.zeros(2), u, DT, n_substeps=4)
    return u, x[:, 1:2] + 0.002 * np.random.default_rng(0).standard_normal((n, 1))


@pytest.fixture(scope="module")
def indicator():
    from sindybench.hidden._latent_hard import indicator_terms

    u, y = _overflow()
    return _warm_and_plain(u, y, PolynomialLibrary(degree=1) + TermsLibrary(terms=indicator_terms(1, 0.0)))


def test_the_indicator_is_refined_smoothed_then_exact(indicator):
    from sindybench.dynamics import LOGISTIC, STEP
    from sindybench.hidden._latent_hard import WIDTHS

    model, plain, u, y = indicator
    record = model.refinement_["range_levels"]
    assert record["plain_cost"] == pytest.approx(plain.refinement_["cost"], rel=1e-6)
    # one refinement per width, the last one exact, each from the one before: the cost falls
    assert len(record["costs"]) == len(WIDTHS) and record["kept"]
    assert record["costs"][-1] <= record["costs"][0] < record["plain_cost"]
    (placed,) = record["levels"]
    assert placed[:2] == [1, "indicator"] and placed[2] == pytest.approx(np.quantile(plain.states_[:, 1], 0.8),
                                                                           rel=1e-5)
    # the final model holds the exact indicator, written with its exact level
    ops = {f[1] for t in model.library_.terms_ for f in t}
    assert STEP in ops and LOGISTIC not in ops
    assert f"[z0>={placed[2]!r}]" in "\n".join(model.equations())
    (entry,) = latent_levels(model)
    assert (entry["kind"], entry["held"]) == ("indicator", placed[2])
    assert "upper indicator level is held at" in model.hidden_.gauge(model)
    # the drop found: its coefficient in y0' near the true -0.4
    names = list(model.library_.get_feature_names_out(["y0", "z0", "u0"]))
    assert model.coef_[0, names.index(f"[z0>={placed[2]!r}]")] == pytest.approx(-0.4, abs=0.1)


def test_a_model_with_a_latent_indicator_round_trips_and_filters(indicator, tmp_path):
    from sindybench.estimation import extended_kalman_filter

    model, _, u, y = indicator
    model.to_json(tmp_path / "indicator.json")
    loaded = load_model(tmp_path / "indicator.json")
    assert loaded.equations() == model.equations()
    np.testing.assert_allclose(loaded.predict(u[:200], y_init=y[:5]), model.predict(u[:200], y_init=y[:5]),
                               rtol=1e-9, atol=1e-12)
    result = extended_kalman_filter(model, u, y, Q=1e-6, R=0.002**2)
    assert np.sqrt(np.mean((result.states[:, 0] - y[:, 0]) ** 2)) < 0.1 * np.std(y)


def test_indicator_terms_and_range_levels_check_their_arguments():
    from sindybench.hidden._latent_hard import indicator_terms, range_levels

    assert indicator_terms(1, 2.5, times=[2]) == [((1, 4, 2.5, np.inf),), ((1, 4, 2.5, np.inf), (2, 0, 1.0, 0.0))]
    with pytest.raises(ValueError, match="level must be a finite number"):
        indicator_terms(1, np.nan)
    with pytest.raises(ValueError, match="quantiles must be two numbers in"):
        range_levels(np.arange(5.0), (0.8, 1.2))
    with pytest.raises(ValueError, match="z has no finite sample"):
        range_levels([np.nan])

"""Nonlinear models on the linear base (family ``linear_ss+nl``): its structures, its fit, and identify choosing it."""

import warnings

import numpy as np
import pytest

from sindybench.differentiation import FiniteDifference
from sindybench.identify._linear import make_linear
from sindybench.identify._linear_nl import LINEAR_NL_FAMILY, make_linear_nl, propose_linear_nl
from sindybench.identify._space import ALL_FAMILIES, FAMILIES, FAMILY_TABLE, LATENT_FAMILIES, data_settings
from sindybench.io import load_model
from sindybench.metrics import fit_index
from sindybench.systems import get_system

# six states (three masses) from 50 start samples: fewer leave the least-squares start of the slow modes ill-posed
N_INIT = 50


def _settings(order=4, rows=40, **hard):
    return {"linear": {"order": order, "block_rows": rows, "n_outputs": 1}, "positive": hard.get("positive", []),
            "indicator": hard.get("indicator", [None]), "friction": hard.get("friction", [])}


def test_family_is_registered_opt_in():
    assert LINEAR_NL_FAMILY in FAMILY_TABLE and LINEAR_NL_FAMILY in LATENT_FAMILIES
    assert LINEAR_NL_FAMILY in ALL_FAMILIES and LINEAR_NL_FAMILY not in FAMILIES


def test_structures_follow_the_linear_base_and_the_advice():
    (struct, library), = propose_linear_nl(_settings(), 1, 1, "zoh", 3)
    assert struct == {"family": LINEAR_NL_FAMILY, "library": "poly3 n=4 rows=40", "derivative": "finite_difference",
                      "input_hold": "zoh", "input_delay": 3}
    names = library.fit(np.zeros((1, 5))).get_feature_names_out(["y0", "z0", "z1", "z2", "u0"]).tolist()
    assert names == ["1", "y0", "z0", "z1", "z2", "u0", "y0^2", "y0^3"]  # nonlinear in the output only
    hard = propose_linear_nl(_settings(indicator=[0.8], positive=[0]), 1, 1, "zoh", 0)
    assert [s["library"] for s, _ in hard] == ["poly3 n=4 rows=40", "poly3+hard n=4 rows=40"]
    names = hard[1][1].fit(np.zeros((1, 5))).get_feature_names_out(["y0", "z0", "z1", "z2", "u0"]).tolist()
    assert "sqrt(y0)" in names and any("u0" in n and "y0" in n and "[" in n for n in names)
    # no latent state (order 1, one output), no input, no linear base: nothing to add terms to
    assert propose_linear_nl(_settings(order=1), 1, 1, "zoh", 0) == []
    assert propose_linear_nl(_settings(), 1, 0, "zoh", 0) == []
    assert propose_linear_nl({"linear": None}, 1, 1, "zoh", 0) == []


def test_data_settings_find_the_linear_order_for_the_family_alone():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((500, 1))
    y = np.zeros((500, 1))
    for k in range(499):
        y[k + 1] = 0.9 * y[k] + 0.5 * u[k]
    assert data_settings(u, y, 0.1, families=[LINEAR_NL_FAMILY])["linear"]["order"] >= 1
    assert data_settings(u, y, 0.1, families=["first_order"])["linear"] is None


def _chain(n_samples, n_test):
    rec = get_system("chain_cubic_spring").record(0, n_samples=n_samples, n_test=n_test)
    return rec


def _test_fit(model, rec):
    y_hat = model.predict(rec.u_test, y_init=rec.y_test[:N_INIT])
    return fit_index(rec.y_test, y_hat, skip=N_INIT)


def test_family_finds_the_cubic_spring_of_a_six_state_chain_the_linear_base_misses(tmp_path):
    rec = _chain(1500, 2000)
    settings = _settings(order=6, rows=80)
    struct = {"family": LINEAR_NL_FAMILY, "library": "poly3 n=6 rows=80", "derivative": "finite_difference",
              "input_hold": "linear", "input_delay": 0}
    (_, library), = propose_linear_nl(settings, 1, 1, "linear", 0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        base = make_linear(dict(struct, family="linear_ss", library="linear n=6 rows=80"), library.libraries[0],
                           rec.dt, FiniteDifference(), settings).fit(rec.u, rec.y)
        model = make_linear_nl(struct, library, rec.dt, FiniteDifference(), settings).fit(rec.u, rec.y)
    assert model.hidden_.n_latent == 5 and model.refinement_["status"] >= 0
    base_fit, fit = _test_fit(base, rec), _test_fit(model, rec)
    assert fit > 96.0 and fit > base_fit + 3.0, (fit, base_fit)  # measured: 98.3 against 93.0
    # the cubic term is in the model, and the pruning left terms out
    assert any("y0^3" in row for row in model.equations())
    assert np.count_nonzero(model.coef_) < model.coef_.size
    # an ordinary model: its file loads and predicts the same
    model.to_json(tmp_path / "m.json")
    loaded = load_model(tmp_path / "m.json")
    np.testing.assert_allclose(loaded.predict(rec.u_test, y_init=rec.y_test[:N_INIT]),
                               model.predict(rec.u_test, y_init=rec.y_test[:N_INIT]), rtol=1e-9, atol=1e-12)


@pytest.mark.slow
def test_identify_chooses_the_family_on_the_chain_with_a_cubic_spring():
    from sindybench.identify import identify

    rec = _chain(4000, 2000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = identify(rec.u, rec.y, dt=rec.dt, families=["linear_ss", LINEAR_NL_FAMILY], n_init=N_INIT,
                         show_progress_bar=False, random_state=0)
    assert model.identification_["settings"]["family"] == LINEAR_NL_FAMILY
    assert _test_fit(model, rec) > 97.0

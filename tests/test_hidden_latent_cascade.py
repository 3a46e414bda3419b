"""LatentHiddenState(cascade=True): latent rows without output terms, z' = f(z, u) and y' = g(y, z, u)."""

import warnings

import numpy as np
import pytest

from sindybench import STLS, HiddenStateSINDy
from sindybench.hidden import LatentHiddenState
from sindybench.io import load_model
from sindybench.libraries import ConcatLibrary, PolynomialLibrary, SqrtLibrary
from sindybench.refine import OutputErrorRefinement
from sindybench.simulate import simulate

DT = 2.0


def _tanks(n=600, seed=0):
    """Two tanks in series, the upper one hidden: ``x' = -0.05 sqrt(x) + 0.04 u``, ``y' = 0.05 sqrt(x) - 0.04 sqrt(y)``."""
    rng = np.random.default_rng(seed)

    def truth(x, u):
        up, low = max(x[1], 0.0), max(x[0], 0.0)
        return np.array([0.05 * np.sqrt(up) - 0.04 * np.sqrt(low), -0.05 * np.sqrt(up) + 0.04 * u[0]])

    u = np.repeat(rng.uniform(1.0, 4.0, n // 40 + 1), 40)[:n, None]
    x = simulate(truth, [4.0, 4.0], u, DT, n_substeps=4)
    return u, x[:, :1] + 0.01 * rng.standard_normal((n, 1))


def _fit(u, y, cascade):
    library = ConcatLibrary([PolynomialLibrary(degree=1), SqrtLibrary(variables=[0, 1])])
    model = HiddenStateSINDy(
        hidden=LatentHiddenState(bounds={"tau": (2.0, 400.0)}, latent_bounds=(0.0, np.inf),
                                 output_bounds=(0.0, np.inf), cascade=cascade),
        library=library, optimizer=STLS(threshold=0.0, alpha=1e-9, normalize_columns=True), dt=DT, n_trials=8,
        validation_size=0.2, validation="full", random_state=0, refine=OutputErrorRefinement(max_nfev=30),
        initial_state="fit", show_progress_bar=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model.fit(u, y)


def _output_terms_of_latent_row(model):
    names = model.library_.get_feature_names_out(["y0", "z0", "u0"])
    return {name for name, c in zip(names, model.coef_[1]) if c != 0 and "y0" in name}


@pytest.fixture(scope="module")
def fits():
    u, y = _tanks()
    return u, y, _fit(u, y, cascade=False), _fit(u, y, cascade=True)


def test_the_latent_row_has_no_output_terms_after_fit_and_refinement(fits):
    u, y, free, cascade = fits
    assert cascade.refinement_ is not None and cascade.refinement_["nfev"] > 1
    assert _output_terms_of_latent_row(cascade) == set()
    assert _output_terms_of_latent_row(free)  # the same fit without the cascade puts y0 into z0's row
    rmse = np.sqrt(np.mean((cascade.predict(u, y_init=y[:5]) - y) ** 2))
    assert rmse < 0.05 * np.std(y)
    assert "z0' = " in "\n".join(cascade.equations()) and "y0" not in cascade.equations()[1]


def test_a_cascade_round_trips_through_json(fits, tmp_path):
    u, y, _, cascade = fits
    cascade.to_json(tmp_path / "cascade.json")
    loaded = load_model(tmp_path / "cascade.json")
    assert loaded.hidden_.cascade is True and loaded.equations() == cascade.equations()
    np.testing.assert_allclose(loaded.predict(u[:200], y_init=y[:5]), cascade.predict(u[:200], y_init=y[:5]),
                               rtol=1e-9, atol=1e-12)


def test_a_cascade_has_one_start_and_no_mixing():
    hidden = LatentHiddenState(cascade=True, start="auto")
    assert [name for name, _ in hidden.starts()] == ["input lag"]
    assert hidden.canonical_mixing(None, None, 1) is None
    assert LatentHiddenState().coef_support([((0, 0, 1.0, 0.0),)], n_outputs=1, n_inputs=1) is None


@pytest.mark.parametrize("params, error, match", [
    ({"cascade": "yes"}, TypeError, "cascade must be True or False; got 'yes'"),
    ({"cascade": True, "driver": "output"}, ValueError, "cascade=True needs driver='input'"),
    ({"cascade": True, "start": "subspace"}, ValueError, "a lag start"),
])
def test_bad_cascade_settings_are_refused(params, error, match):
    with pytest.raises(error, match=match):
        LatentHiddenState(**params)._validate()

"""``identify`` on failing candidates and bad input: a candidate that fails is a row with its reason."""

import importlib

import numpy as np
import pytest

from sindybench.identify import IdentifyCV
from sindybench.simulate import simulate

# sindybench.identify is also the function: the module by its full name
estimator_module = importlib.import_module("sindybench.identify._estimator")
DT = 0.01
SEARCH = dict(dt=DT, families=["first_order", "order2"], libraries=["linear"], derivatives=["finite_difference"],
              n_refine=1, max_path=4, show_progress_bar=False)


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(3)
    t = np.arange(1500) * DT
    u = (np.sin(2 * np.pi * 0.4 * t) + np.sin(2 * np.pi * 1.1 * t + 1.0))[:, None]
    x = simulate(lambda x, u: np.array([x[1], -4.0 * x[0] - 0.4 * x[1] + 2.0 * u[0]]), [0.0, 0.0], u, dt=DT,
                 n_substeps=4, input_hold="linear")
    return u, x[:, :1] + 1e-4 * rng.standard_normal((1500, 1))


def test_a_family_that_raises_is_recorded_and_the_search_goes_on(record, monkeypatch):
    real = estimator_module.make_estimator

    def make_estimator(structure, *args, **kwargs):
        if structure["family"] in ("order3", "order1+latent"):
            raise RuntimeError(f"no estimator for {structure['family']}")
        return real(structure, *args, **kwargs)

    monkeypatch.setattr(estimator_module, "make_estimator", make_estimator)
    search = IdentifyCV(**dict(SEARCH, families=["order2", "order3", "order1+latent"])).fit(*record)
    table = search.cv_results_
    for family in ("order3", "order1+latent"):
        rows = [i for i, f in enumerate(table["family"]) if f == family]
        assert rows and all(table["status"][i] == f"failed: RuntimeError: no estimator for {family}" for i in rows)
        assert all(np.isinf(table["mean_validation_error"][i]) for i in rows)
    assert search.best_params_["family"] == "order2"


def test_no_candidate_that_simulates_is_a_clear_error(record, monkeypatch):
    u, y = record

    def make_estimator(structure, *args, **kwargs):
        raise RuntimeError("nothing fits")

    monkeypatch.setattr(estimator_module, "make_estimator", make_estimator)
    with pytest.raises(ValueError, match=r"none of the \d+ candidates .*RuntimeError: nothing fits.*expected a record"):
        IdentifyCV(**SEARCH).fit(u, y)


def test_a_constant_output_is_refused(record):
    u, y = record
    with pytest.raises(ValueError, match="output column 0 is constant"):
        IdentifyCV(**SEARCH).fit(u, np.full_like(y, 2.0))

"""identify's lag family (``families=["lag"]``): LagSINDy candidates in the search."""

import numpy as np

from sindybench import LagSINDy
from sindybench.identify import IdentifyCV


def _narx_record():
    """``y[k+1] = 1.2 y[k] - 0.5 y[k-1] - 0.1 y[k]^2 + 0.3 u[k-1]``, 700 samples of a uniform random input."""
    u = np.random.default_rng(1).uniform(-1.0, 1.0, (700, 1))
    y = np.zeros((700, 1))
    for k in range(1, 699):
        y[k + 1] = 1.2 * y[k] - 0.5 * y[k - 1] - 0.1 * y[k] ** 2 + 0.3 * u[k - 1]
    return u, y


def test_identify_with_the_lag_family():
    u, y = _narx_record()
    search = IdentifyCV(dt=0.1, families=["lag"], libraries=["poly2"], input_delay=0, n_refine=0,
                        show_progress_bar=False).fit(u[:600], y[:600])
    model = search.best_estimator_
    assert search.best_params_["family"] == "lag" and isinstance(model, LagSINDy)
    assert set(search.cv_results_["derivative"]) == {"none"}
    assert model.score(u[600:], y[600:]) > 0.999  # the held-out end of the record, from its first samples
    # a lag model holds its inputs by construction: its twin with the other hold is scored once, not twice
    table = search.cv_results_
    zoh, linear = table["input_hold"].index("zoh"), table["input_hold"].index("linear")
    assert table["split0_validation_error"][linear] == table["split0_validation_error"][zoh]
    assert table["fit_time"][linear] < 0.05 * table["fit_time"][zoh]


def test_the_equation_wins_a_tie_with_a_lag_model():
    """A first-order linear plant with 2 % output noise: the refined equation and the lag model validate alike."""
    rng = np.random.default_rng(2)
    dt = 0.05
    u = np.repeat(rng.uniform(-1.0, 1.0, 40), 20)[:, None]
    y = np.zeros((800, 1))
    a = np.exp(-dt)
    for k in range(799):  # y' = -y + 2 u, the input held between the samples: exact
        y[k + 1] = a * y[k] + 2.0 * (1.0 - a) * u[k]
    y = y + 0.02 * np.std(y) * rng.standard_normal(y.shape)
    search = IdentifyCV(dt=dt, families=["first_order", "lag"], libraries=["linear"], input_delay=0,
                        show_progress_bar=False).fit(u, y)
    table = search.cv_results_
    lag = [i for i, f in enumerate(table["family"]) if f == "lag"]
    assert lag and np.isfinite(table["mean_validation_error"][lag[0]])  # the lag model was scored ...
    assert search.best_params_["family"] == "first_order"  # ... and the equation wins
    assert search.best_estimator_.equations(precision=2) == ["y0' = -1.00 y0 + 2.00 u0"]
    assert search.best_estimator_.identification_["rule"].startswith("the equation")


def test_the_lag_model_wins_when_better_by_more_than_its_standard_error():
    u, y = _narx_record()
    search = IdentifyCV(dt=0.1, families=["first_order", "lag"], libraries=["poly2"], input_delay=0, n_refine=0,
                        show_progress_bar=False).fit(u[:600], y[:600])
    assert search.best_params_["family"] == "lag"
    assert search.best_estimator_.identification_["rule"].startswith("the lag model")


def test_equation_or_lag_without_one_side():
    from sindybench.identify._lag import equation_or_lag

    assert equation_or_lag(3, None, [0.1] * 4, [0.0] * 4, 3) == (3, None)
    assert equation_or_lag(None, 1, [np.inf, 0.2], [0.0, 0.1], 3)[0] == 1
    assert equation_or_lag(0, 1, [0.1, np.inf], [0.0, 0.0], 3) == (0, None)

"""The Silverbox benchmark (sindybench.experiments.silverbox): its rows, in quick form."""

import math

import numpy as np
import pytest

from sindybench.experiments import evaluate, get_benchmark
from sindybench.experiments._runner import refine_model


@pytest.fixture(scope="module")
def silverbox(data_home):
    return get_benchmark("silverbox"), get_benchmark("silverbox").load(data_home=data_home)


def test_load_reports_the_output_in_millivolts(silverbox, data_home):
    from sindybench.datasets import load_silverbox

    bench, data = silverbox
    volts = load_silverbox(data_home=data_home)
    assert data.units.y == "mV" and volts.units.y == "V" and data.units.u == "V"
    np.testing.assert_array_equal(data.test.arrow_full.y, 1e3 * volts.test.arrow_full.y)
    np.testing.assert_array_equal(data.estimation.u, volts.estimation.u)
    assert bench.n_init == data.n_init == 50 and bench.reported_model == "sindy_duffing_refined"


def test_duffing_rows_find_the_oscillator_from_a_short_record(silverbox):
    """6000 training samples: least squares on the spectral derivative, then the refinement, as the runner does."""
    bench, data = silverbox
    X, y = data.train.u[:6000], data.train.y[:6000]
    base = bench.model("sindy_duffing").make(random_state=0, quick=True, dt=data.dt, n_val=0, n_samples=len(y))
    base.fit(X, y)
    refined, info = refine_model(bench.model("sindy_duffing_refined"), base, X, y, dt=data.dt, quick=True)
    assert info["refinement"]["cost"] < 0.2 * info["refinement"]["initial_cost"]
    _, k, c, _, _ = refined.coef_[0]  # y'' = c0 + k y + c y' + b u + k3 y^3
    frequency, damping = math.sqrt(-k) / (2 * math.pi), -c / (2 * math.sqrt(-k))
    assert frequency == pytest.approx(68.3, abs=0.5) and damping == pytest.approx(0.049, abs=0.005)
    before = evaluate(base, data.test.multisine, 50)[1]["rmse"]
    after = evaluate(refined, data.test.multisine, 50)[1]["rmse"]
    assert after < 1.0 < 2.0 < before  # mV: the refinement is what makes the model good


def test_rows_and_their_settings(silverbox):
    bench, data = silverbox
    keys = [m.key for m in bench.models]
    assert keys == ["sindy_poly", "sindy_second_order", "sindy_second_order_refined", "sindy_duffing",
                    "sindy_duffing_refined", "arx", "nnarx", "identified", "identified_equations"]
    for key in ("sindy_poly", "sindy_second_order", "sindy_duffing"):
        est = bench.model(key).make(random_state=0, quick=True, dt=data.dt, n_val=100, n_samples=1000)
        assert (est.input_hold, est.n_substeps, est.differentiation.cutoff) == ("linear", 2, 200.0)
    assert bench.model("nnarx").train_cap(quick=False) <= 10000  # NN-ARX's cost grows with the record

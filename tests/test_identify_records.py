"""``identify`` on several records: whole records (leave one out) or blocks inside each record as validation."""

import numpy as np
import pytest
from sklearn.base import clone

from sindybench.identify import IdentifyCV, identify
from sindybench.simulate import simulate

DT = 0.01
QUICK = dict(families=["first_order", "order2"], libraries=["linear", "poly2"], derivatives=["finite_difference"],
             n_refine=0, max_path=4, show_progress_bar=False)


def _lag(x, u):  # a first-order lag with a quadratic loss: y' = -2 y - 0.5 y^2 + u
    return np.array([-2.0 * x[0] - 0.5 * x[0] ** 2 + u[0]])


@pytest.fixture(scope="module")
def records():
    rng = np.random.default_rng(5)
    us, ys = [], []
    for n, freqs in ((900, (0.3, 1.1)), (700, (0.5, 1.7))):
        t = np.arange(n) * DT
        u = (1.0 + sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 6)) for f in freqs))[:, None]
        y = simulate(_lag, [0.2], u, dt=DT, n_substeps=4, input_hold="linear")
        us.append(u)
        ys.append(y + 1e-5 * rng.standard_normal(y.shape))
    return us, ys


def test_two_records_leave_one_record_out(records):
    us, ys = records
    search = IdentifyCV(dt=DT, **QUICK).fit(us, ys)
    assert search.validation_ == "records"
    assert search.splits_ == [{"train": "record 1 [0, 700)", "validation": "record 0 [0, 900)"},
                              {"train": "record 0 [0, 900)", "validation": "record 1 [0, 700)"}]
    assert "split1_validation_error" in search.cv_results_ and "split2_validation_error" not in search.cv_results_
    model = search.best_estimator_
    assert search.best_params_["family"] == "first_order"
    coef = dict(zip(model.library_.get_feature_names_out(["y0", "u0"]), np.asarray(model.coef_)[0]))
    assert {k for k, c in coef.items() if c != 0} == {"y0", "y0^2", "u0"}
    np.testing.assert_allclose([coef["y0"], coef["y0^2"], coef["u0"]], [-2.0, -0.5, 1.0], rtol=0.02)
    # the chosen model is refitted on both records, not on one
    np.testing.assert_array_equal(model.coef_, clone(model).fit(us, ys).coef_)
    assert not np.array_equal(model.coef_, clone(model).fit(us[0], ys[0]).coef_)


def test_two_records_blocks_inside_each_record(records):
    us, ys = records
    model = identify(us, ys, dt=DT, validation="blocks", n_blocks=2, **QUICK)
    record = model.identification_
    assert record["validation"] == "blocks"
    assert record["splits"][0] == {"train": "record 0 [0, 630), record 1 [0, 490)",
                                   "validation": "record 0 [630, 765), record 1 [490, 595)"}
    assert record["settings"]["family"] == "first_order"
    y_sim = model.predict(us[1], y_init=ys[1][:20])
    assert np.sqrt(np.mean((y_sim - ys[1]) ** 2)) < 0.01 * np.std(ys[1])


def test_bad_records(records):
    us, ys = records
    with pytest.raises(ValueError, match="record 1: 40 samples are too few"):
        IdentifyCV(dt=DT, validation="blocks", **QUICK).fit([us[0], us[1][:40]], [ys[0], ys[1][:40]])
    with pytest.raises(ValueError, match="validation='records' needs several records"):
        IdentifyCV(dt=DT, validation="records", **QUICK).fit(us[0], ys[0])
    with pytest.raises(ValueError, match="so X must be None or a list of 2"):
        IdentifyCV(dt=DT, **QUICK).fit(us[0], ys)
    with pytest.raises(ValueError, match="validation must be one of"):
        IdentifyCV(dt=DT, validation="kfold", **QUICK).fit(us, ys)
    nan = [ys[0], ys[1].copy()]
    nan[1][3] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        IdentifyCV(dt=DT, **QUICK).fit(us, nan)


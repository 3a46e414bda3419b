"""identify's scoring criterion: the free run, or the k-step prediction for open-loop unstable records."""

import re
import warnings

import numpy as np
import pytest

from sindybench import STLS, SINDy
from sindybench.libraries import PolynomialLibrary
from sindybench.identify import IdentifyCV, advice, identify, k_step_error
from sindybench.identify._criterion import choose_criterion


def _unstable_under_feedback(rng, n=1500, dt=0.02):
    """x' = 2 x + 3 u (an unstable pole at +2) recorded under the feedback u = -2 y + 1.5 r + noise."""
    r = np.repeat(rng.uniform(-1, 1, n // 100 + 1), 100)[:n]
    x, y, u = 0.0, np.zeros(n), np.zeros(n)
    for t in range(n):
        y[t] = x + 0.01 * rng.standard_normal()
        u[t] = -2.0 * y[t] + 1.5 * r[t] + 0.1 * rng.standard_normal()
        for _ in range(5):
            x += dt / 5 * (2.0 * x + 3.0 * u[t])
    return u[:, None], y[:, None], dt


def test_advice_finds_the_unstable_pole(rng):
    u, y, dt = _unstable_under_feedback(rng)
    report = advice(u, y, dt=dt)
    assert report.unstable == [0] and np.max(np.abs(report.poles[0])) > 1.0
    assert any("open-loop unstable" in w for w in report.warnings)


@pytest.mark.parametrize("part", [slice(None), slice(0, 2550)])  # the whole record; identify's training part
def test_advice_reads_the_zoos_inverted_pendulum_as_unstable(part):
    # theta'' = 4 sin(theta) - 0.2 theta' + u under PD feedback: open-loop pole +1.9 rad/s; the ARX poles give +1.36
    from sindybench.systems import get_system

    rec = get_system("inverted_pendulum_pd").record(0)
    report = advice(rec.u[part], rec.y[part], dt=rec.dt)
    assert report.closed_loop and report.unstable == [0]
    rate = np.log(np.max(np.abs(report.poles[0]))) / rec.dt
    assert 1.0 < rate < 2.5
    assert choose_criterion("auto", report, block_length=450)[0] == "k_step"


def test_k_step_error_scores_restarts_not_the_drift(rng):
    u, y, dt = _unstable_under_feedback(rng)
    truth = SINDy(optimizer=STLS(threshold=0.5), library=PolynomialLibrary(degree=1), input_hold="zoh").fit(u, y, dt=dt)  # the true structure, refit on the record
    wrong = SINDy(optimizer=STLS(threshold=0.5), library=PolynomialLibrary(degree=1), input_hold="zoh").fit(u, 1.3 * y, dt=dt)
    scale = np.std(y, axis=0)
    good, bad = k_step_error(truth, u, y, 5, scale, 10), k_step_error(wrong, u, y, 5, scale, 10)
    assert good < 0.05 and bad > 2 * good
    with pytest.raises(ValueError, match="shorter than n_init \\+ horizon"):
        k_step_error(truth, u[:12], y[:12], 5, scale, 10)


def test_identify_ranks_an_unstable_record_by_k_step_prediction(rng):
    u, y, dt = _unstable_under_feedback(rng)
    with pytest.warns(UserWarning, match="ranked by their .*-step prediction"):
        search = IdentifyCV(dt=dt, families=["first_order"], libraries=["linear"], n_refine=0,
                            show_progress_bar=False).fit(u, y)
    assert search.criterion_["name"] == "k_step" and search.criterion_["horizon"] >= 5
    assert search.best_estimator_.identification_["criterion"] == search.criterion_
    eq = search.best_estimator_.equations(precision=3)[0]
    a, b = (float(v) for v in re.fullmatch(r"y0' = ([\d.]+) y0 \+ ([\d.]+) u0", eq).groups())
    assert abs(a - 2.0) < 0.1 and abs(b - 3.0) < 0.15, eq  # the truth: y0' = 2 y0 + 3 u0


def test_k_step_candidates_are_refined_by_prediction_error(rng):
    u, y, dt = _unstable_under_feedback(rng)
    with pytest.warns(UserWarning, match="-step prediction"):
        search = IdentifyCV(dt=dt, families=["first_order"], libraries=["linear"], n_refine=1,
                            show_progress_bar=False).fit(u, y)
    table = search.cv_results_
    refined = [i for i, stage in enumerate(table["stage"]) if stage == "refine"]
    blocks = [table["mean_validation_error"][i] for i, stage in enumerate(table["stage"]) if stage == "blocks"]
    assert table["status"][refined[0]] == "ok" and search.best_index_ == refined[0]
    assert table["mean_validation_error"][refined[0]] < 0.9 * min(blocks)  # the prediction error refined it
    assert search._refinement(1000, search.criterion_["horizon"]).horizon == search.criterion_["horizon"]


def test_identify_keeps_the_free_run_on_a_stable_record():
    t = np.arange(1500) * 0.01
    u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    y = np.zeros_like(u)
    for k in range(1, len(t)):
        y[k] = y[k - 1] + 0.01 * (-2.0 * y[k - 1] + u[k - 1])
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        search = IdentifyCV(dt=0.01, families=["first_order"], libraries=["linear"], n_refine=0,
                            show_progress_bar=False).fit(u, y)
    assert search.criterion_["name"] == "free_run" and search.criterion_["horizon"] is None


@pytest.mark.parametrize("kwargs, message", [
    ({"criterion": "kstep"}, "criterion"),
    ({"horizon": 0}, "horizon"),
    ({"criterion": "k_step", "horizon": 10**6}, "horizon=1000000 with n_init"),
])
def test_criterion_bad_parameters(kwargs, message):
    t = np.arange(400) * 0.01
    with pytest.raises(ValueError, match=message):
        identify(np.sin(t)[:, None], np.cos(t)[:, None], dt=0.01, families=["first_order"], libraries=["linear"],
                 n_refine=0, show_progress_bar=False, **kwargs)


def test_choose_criterion_asked_for():
    assert choose_criterion("free_run", None, block_length=100) == ("free_run", None, "asked for")
    name, horizon, reason = choose_criterion("k_step", None, horizon=7, block_length=100)
    assert (name, horizon, reason) == ("k_step", 7, "asked for")

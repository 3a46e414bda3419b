"""identify and the estimators name the cause of a bad input (issue: messages that name the cause)."""

import time
import warnings

import numpy as np
import pytest

from sindybench import SINDy, HiddenStateSINDy, identify
from sindybench.identify import advice


@pytest.fixture
def record(rng):
    t = np.arange(600) * 0.01
    u = np.sin(t)[:, None] + 0.1 * rng.standard_normal((600, 1))
    y = np.cumsum(u, axis=0) * 0.01 + 0.01 * rng.standard_normal((600, 1))
    return u, y


@pytest.mark.parametrize("scale, name", [(1e200, "X reaches"), (1e101, "X reaches")])
def test_identify_refuses_magnitudes_whose_squares_overflow(record, scale, name):
    u, y = record
    start = time.process_time()
    with pytest.raises(ValueError, match=f"{name} .* beyond 1e\\+100, where squares and cubes of it overflow"):
        identify(u * scale, y * scale, dt=0.01, show_progress_bar=False)
    assert time.process_time() - start < 1.0
    with pytest.raises(ValueError, match="y reaches"):
        advice(u, y * scale, dt=0.01)


def test_identify_fits_a_record_in_large_units(record):
    """The candidates' divergence bound follows the record (the estimators' 1e6 would call every run diverged)."""
    u, y = record
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = identify(u * 1e20, y * 1e20, dt=0.01, families=["first_order"], libraries=["linear"], n_refine=0,
                         show_progress_bar=False)
    assert model.max_abs >= 1e22
    assert np.all(np.isfinite(model.predict(u * 1e20, y_init=1e20 * y[:20])))


def test_identify_refuses_a_delay_longer_than_the_record(record):
    u, y = record
    with pytest.raises(ValueError, match="input_delay=1000000 samples is not shorter than the record \\(600 samples"):
        identify(u, y, dt=0.01, input_delay=10**6, show_progress_bar=False)


@pytest.mark.parametrize("estimator", [SINDy(dt=0.01, input_delay=600), HiddenStateSINDy(dt=0.01, input_delay=900)])
def test_estimators_refuse_a_delay_longer_than_the_record(record, estimator):
    u, y = record
    with pytest.raises(ValueError, match="not shorter than the training record \\(600 samples\\)"):
        estimator.fit(u, y)


@pytest.mark.parametrize("n_jobs", [0, -2])
def test_identify_names_a_bad_n_jobs(record, n_jobs):
    u, y = record
    with pytest.raises(ValueError, match=f"n_jobs must be None .* got {n_jobs}"):
        identify(u, y, dt=0.01, n_jobs=n_jobs, show_progress_bar=False)

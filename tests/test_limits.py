"""What an argument or a model file may ask for: products of sizes bounded before any work (issue 30, 13-16)."""

import json
import time
import tracemalloc

import numpy as np
import pytest

from sindybench import HiddenStateSINDy, SINDy, load_model
from sindybench._limits import MAX_BYTES, check_memory, check_size
from sindybench.hidden import LatentHiddenState, ParametricHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.uncertainty import BootstrapEnsemble, circular_block_indices, prediction_band


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((400, 1))
    y = np.cumsum(u, axis=0) * 0.01 + 1e-3 * rng.standard_normal((400, 1))
    return u, y


def _quick(call, *args, **kwargs):
    """``call(...)``'s ValueError message, checking that it came within a second and allocated under 100 MB."""
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(ValueError) as info:
            call(*args, **kwargs)
        seconds, peak = time.perf_counter() - start, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert seconds < 1.0 and peak < 100e6, (seconds, peak)
    return str(info.value)


def test_check_size_bounds_the_product_and_names_each_factor():
    check_size("x", {"a": 10, "b": 10}, limit=100, unit="steps")
    with pytest.raises(ValueError, match=r"^x asks for 10 a x 11 b = 110 steps; expected at most 100\. Try less\.$"):
        check_size("x", {"a": 10, "b": 11}, limit=100, unit="steps", advice="Try less.")


def test_check_memory_refuses_past_one_gib():
    check_memory("y", (MAX_BYTES // 8,))
    with pytest.raises(ValueError, match=r"y would take 134,217,729 values of 8 bytes = 1.07 GB; expected at most"):
        check_memory("y", (MAX_BYTES // 8 + 1,))


def test_a_bootstrap_of_a_million_members_is_refused_before_any_fit(record):
    # issue 30, item 16: 22.9 s and 3.5 GiB before the first member fit, then MemoryError
    message = _quick(BootstrapEnsemble(SINDy(library=PolynomialLibrary(degree=1), dt=0.1), n_members=10**6).fit,
                     *record)
    assert "BootstrapEnsemble(n_members=1000000): the members' records would take 1,000,000 x 400 x 1 values" in message


@pytest.fixture(scope="module")
def ensemble(record):
    return BootstrapEnsemble(SINDy(library=PolynomialLibrary(degree=1), dt=0.1), n_members=3, block_length=20,
                             random_state=0).fit(*record)


def test_a_block_longer_than_the_record_is_cut_to_it():
    # issue 30, item 15: block_length 10**9 allocated 7.45 GiB for 400 indices
    for seed in range(3):
        long = circular_block_indices(400, 10**9, np.random.default_rng(seed))
        assert np.array_equal(long, circular_block_indices(400, 400, np.random.default_rng(seed)))


def test_an_ensemble_file_with_a_huge_block_is_refused(ensemble, record, tmp_path):
    path = tmp_path / "ensemble.json"
    ensemble.to_json(path)
    data = json.loads(path.read_text())
    data["fitted"]["block_length"] = 10**9
    path.write_text(json.dumps(data))
    message = _quick(load_model, path)
    assert "fitted.block_length: expected an integer in [1, 400]; got a number (1000000000)" in message
    band = prediction_band(ensemble, record[0], y_init=record[1][:1], noise=True, random_state=0)
    ensemble.block_length_ = 10**9  # the same band: a block is cut at the record's length
    tracemalloc.start()
    try:
        again = prediction_band(ensemble, record[0], y_init=record[1][:1], noise=True, random_state=0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
        ensemble.block_length_ = 20
    assert peak < 50e6 and np.all(np.isfinite(again.samples)) and band.samples.shape == again.samples.shape


def test_a_band_past_one_gib_is_refused_before_the_members_run(ensemble):
    message = _quick(prediction_band, ensemble, np.broadcast_to(0.0, (10**8, 1)), x0=[0.0])  # no memory
    assert "prediction_band: the members' simulations would take 3 x 100,000,000 x 1 values" in message


@pytest.mark.parametrize("n_latent, match", [
    (10**6, r"LatentHiddenState\(n_latent=1000000\): the lag chain's coefficients would take 1,000,001 x 1,000,000"),
    (2000, r"the features of PolynomialLibrary on 2002 columns of Z = \[states, inputs\] \(at least\) would take "
           r"400 x 2,007,006 values"),
])
def test_a_latent_model_of_a_million_states_is_refused(record, n_latent, match):
    # issue 30, item 15: LatentHiddenState(n_latent=10**6) asked for 7.28 TiB
    model = HiddenStateSINDy(hidden=LatentHiddenState(n_latent=n_latent, tau=1.0), dt=0.1, n_trials=1)
    start = time.perf_counter()
    with pytest.raises(ValueError, match=match):
        model.fit(*record)
    assert time.perf_counter() - start < 10.0  # the design's lag simulation of 2000 states comes first


def test_a_latent_file_asking_for_a_billion_states_is_refused_at_load(record, tmp_path):
    # issue 30, item 15: such a file loaded, then predict asked for 7.45 GiB
    model = HiddenStateSINDy(hidden=LatentHiddenState(tau=1.0), library=PolynomialLibrary(degree=1), dt=0.1,
                             n_trials=1, random_state=0).fit(*record)
    path = tmp_path / "latent.json"
    model.to_json(path)
    data = json.loads(path.read_text())
    for where in (data["params"]["hidden"], data["fitted"]["hidden"]):
        where["estimator"]["params"]["n_latent"] = 10**9
    path.write_text(json.dumps(data))
    message = _quick(load_model, path)
    assert "LatentHiddenState(n_latent=1000000000): the lag chain's coefficients would take" in message


def two_tanks(xh, y, u, *, k):
    return np.array([-k * xh[0] + u[0], k * (xh[0] - xh[1])])


def test_the_grid_limit_bounds_all_hidden_states_together(record):
    # issue 30, item 14: the limit applied per hidden state; two of 10,000 points built a 10**8-point grid
    hidden = ParametricHiddenState(two_tanks, params={"k": 0.5}, x0_bounds=[(0.0, 1.0), (0.0, 1.0)], grid_size=10_000)
    message = _quick(HiddenStateSINDy(hidden=hidden, dt=0.1, n_trials=1).fit, *record)
    assert ("ParametricHiddenState(grid_size=10000): the initial-state grid asks for 10,000 points of hidden state 0 "
            "x 10,000 points of hidden state 1 = 1e+08 grid points; expected at most 1e+04") in message
    hidden.set_params(grid_size=100)  # 10,000 points: within the limit
    hidden._validate()

"""benchmarks/bench_validation_rank.py: the rows it scores, and a candidate refitted as the search refits its choice."""

import numpy as np
import pytest

from _benchmarks import benchmark_script
from sindybench.identify import IdentifyCV
from sindybench.simulate import simulate


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("bench_validation_rank") as module:
        yield module


def test_scored_rows_skip_screened_failed_and_unscored_candidates(bench):
    table = {"stage": ["screen", "blocks", "refine", "blocks", "refine"],
             "status": ["ok", "ok", "ok", "failed: diverged", "ok"],
             "mean_validation_error": [0.1, 0.2, 0.3, 0.4, np.inf]}
    assert bench.scored_rows(table) == [1, 2]


@pytest.mark.parametrize("n_refine", [0, 1])
def test_refit_candidate_of_the_chosen_row_is_the_search_s_model(bench, n_refine):
    t = np.arange(1500) * 0.01
    u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    y = simulate(lambda x, u: np.array([-2.0 * x[0] + 0.5 * x[0] ** 2 + u[0]]), [0.0], u, dt=0.01,
                 input_hold="linear")
    search = IdentifyCV(dt=0.01, families=["first_order"], libraries=["linear", "poly2"],
                        derivatives=["finite_difference"], n_refine=n_refine, show_progress_bar=False).fit(u, y)
    best = search.best_index_
    assert best in bench.scored_rows(search.cv_results_)
    model = bench.refit_candidate(search, best, u, y, 0.01)
    assert model.equations(precision=6) == search.best_estimator_.equations(precision=6)
    assert (search.cv_results_["stage"][best] == "refine") == (model.refine is not None)

"""identify's lag family (``families=["lag"]``): LagSINDy candidates in the search."""

import numpy as np

from sindybench import LagSINDy
from sindybench.identify import IdentifyCV


def test_identify_with_the_lag_family():
    rng = np.random.default_rng(1)
    u = rng.uniform(-1.0, 1.0, (700, 1))
    y = np.zeros((700, 1))
    for k in range(1, 699):
        y[k + 1] = 1.2 * y[k] - 0.5 * y[k - 1] - 0.1 * y[k] ** 2 + 0.3 * u[k - 1]
    search = IdentifyCV(dt=0.1, families=["lag"], libraries=["poly2"], input_delay=0, n_refine=0,
                        show_progress_bar=False).fit(u[:600], y[:600])
    model = search.best_estimator_
    assert search.best_params_["family"] == "lag" and isinstance(model, LagSINDy)
    assert set(search.cv_results_["derivative"]) == {"none"}
    assert model.score(u[600:], y[600:]) > 0.999  # the held-out end of the record, from its first samples

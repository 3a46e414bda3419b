"""``identify``'s latent families: two latent states (``order1+latent2``) find a chain of two hidden lags."""

import numpy as np

from sindybench.identify import IdentifyCV
from sindybench.simulate import simulate


def _chain(x, u):  # two hidden lags in a chain: u -> z0 (pole -4) -> z1 (pole -2) -> y (pole -1)
    return np.array([-1.0 * x[0] + 2.0 * x[2], -4.0 * x[1] + u[0], -2.0 * x[2] + x[1]])


def test_two_latent_states_find_a_lag_chain():
    """The family ``order1+latent2`` (off the default list) finds a chain of two hidden lags: its gauge-free poles
    are the truth's, and it validates far better than one latent state (which cannot hold a third-order system)."""
    from sindybench.estimation import latent_invariants

    dt, rng = 0.05, np.random.default_rng(1)
    t = np.arange(2000) * dt
    u = sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 6)) for f in (0.05, 0.13, 0.31, 0.7, 1.1))[:, None]
    y = simulate(_chain, [0.0, 0.0, 0.0], u, dt=dt, n_substeps=4, input_hold="linear")[:, :1]
    y = y + 1e-4 * rng.standard_normal(y.shape)
    # input_delay=0: on this smooth input the advice read the lags as a 5-sample delay before its lag check
    # (the latent families take the advice's delay unconfirmed); it reads 0 now (tests/test_identify_advice.py)
    search = IdentifyCV(dt=dt, families=["order1+latent", "order1+latent2"], libraries=["linear"], input_delay=0,
                        n_refine=0, show_progress_bar=False).fit(u, y)
    assert search.best_params_["family"] == "order1+latent2"
    table = search.cv_results_
    mean = dict(zip(table["family"], table["mean_validation_error"]))
    assert mean["order1+latent2"] < 0.1 * mean["order1+latent"]
    poles = np.sort(latent_invariants(search.best_estimator_, [0.0])["poles"].real)
    np.testing.assert_allclose(poles, [-4.0, -2.0, -1.0], rtol=0.03)

"""Small records, an identified model and the reports the report tests (plain and in a browser) open."""

import numpy as np
from sklearn.utils import Bunch

from sindybench import STLS, SINDy, identify
from sindybench.libraries import PolynomialLibrary
from sindybench.report import benchmark_index, benchmark_report, identification_report
from sindybench.simulate import simulate

DT = 0.01
# a quick search (as in test_identify): one derivative method, one refinement, two libraries
QUICK = dict(families=["first_order"], libraries=["linear", "poly2"], derivatives=["finite_difference"], n_refine=1,
             n_init=30, show_progress_bar=False)


def record(n=2000, seed=0):
    """A first-order system with a cubic term, driven by a multisine, lightly noisy: estimation and test parts."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    u = (np.sin(0.9 * t) + 0.8 * np.sin(2.3 * t + 1.0) + 0.5 * np.sin(4.1 * t))[:, None]
    y = simulate(lambda x, u: np.array([-2.0 * x[0] - 0.5 * x[0] ** 3 + 2.0 * u[0]]), [0.0], u, dt=DT,
                 input_hold="linear")
    y = y + 0.002 * rng.standard_normal(y.shape)
    cut = int(0.7 * n)
    return (u[:cut], y[:cut]), (u[cut:], y[cut:])


def identified():
    (u, y), test = record()
    return identify(u, y, dt=DT, **QUICK), (u, y), test


def plain_model(u, y):
    return SINDy(library=PolynomialLibrary(degree=3), optimizer=STLS(threshold=0.1), dt=DT).fit(u, y)


def benchmark_run(test):
    """A benchmark's results, simulations and test sets as ``run all`` hands them to the pages."""
    u, y = test
    results = {"benchmark": "toy", "title": "Toy system", "dt": DT, "seed": 0, "quick": True, "n_train": 100,
               "n_validation": 20, "output_label": "y [m]", "input_label": "u [N]",
               "test_sets": {"t": {"n_init": 5, "n_samples": len(y), "protocol": "five samples set the state"}},
               "models": [{"key": "good", "label": "Good", "status": "ok", "fit_time_s": 0.1,
                           "equations": ["y0' = -2.000 y0 + 2.000 u0"], "scores": {"t": {"rmse": 0.01, "r2": 0.99,
                                                                                        "fit_index": 90.0}}},
                          {"key": "poor", "label": "Poor", "status": "ok", "fit_time_s": 0.2,
                           "equations": ["y0' = -1.000 y0"], "scores": {"t": {"rmse": 0.5, "r2": 0.2,
                                                                               "fit_index": 10.0}}}],
               "best_model": None}
    simulations = {"t": {"good": y + 0.01, "poor": 0.5 * y}}
    return results, simulations, {"t": Bunch(u=u, y=y, dt=DT)}


def write_reports(folder):
    """Every kind of page into ``folder``: an identified model's, a plain model's, a benchmark's and the index."""
    model, (u, y), test = identified()
    pages = {"identified": folder / "identified.html", "plain": folder / "plain.html",
             "benchmark": folder / "toy" / "report.html", "index": folder / "index.html"}
    identification_report(model, u, y, test=test, path=pages["identified"])
    identification_report(plain_model(u, y), u, y, path=pages["plain"])
    results, simulations, tests = benchmark_run(test)
    (folder / "toy").mkdir()
    benchmark_report(results, simulations, tests, path=pages["benchmark"])
    benchmark_index([results], path=pages["index"])
    return pages, model, (u, y), test

"""Where the EMPS identified row's error comes from: candidate structures on ``identify``'s validation, and on test.

Each candidate is an order-2 structure of the identified row (finite differences, linear hold, its threshold
level) with one thing changed: the friction law, its asymmetry, the library's degree, the input hold or delay,
the refinement's samples, or an input lag as a latent state. It is scored as ``identify`` scores a stage-3
candidate (:func:`~sindybench.identify._stages.score_candidate`: three forward-chaining blocks of 15 % of the
record, each trained on all samples before it, simulated from its first 20 samples, refined by simulation error on
the first 5000 samples), then refitted on the whole estimation record as ``identify`` refits its choice (over the
terms of its fit on the last fold) and simulated on the test's pulses. Prints per candidate the validation error
(mean, spread, per block) and the test RMSE in mm. The test scores are reported only: nothing here chooses
(docs/identify.rst, "Where the EMPS error comes from"). Needs the benchmark data (``SINDYBENCH_DATA``); about
a minute of one core. Run::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_emps_candidates.py
"""

import os

for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import warnings  # noqa: E402

import numpy as np  # noqa: E402

from bench_identify import _identified  # noqa: E402
from sindybench import STLS, HiddenStateSINDy  # noqa: E402
from sindybench.differentiation import FiniteDifference  # noqa: E402
from sindybench.experiments._runner import _n_init, evaluate, test_sets  # noqa: E402
from sindybench.hidden import LatentHiddenState  # noqa: E402
from sindybench.identify._checks import MIN_TRAIN  # noqa: E402
from sindybench.identify._search import evaluate as evaluate_blocks  # noqa: E402
from sindybench.identify._search import record_folds, segments, stls_threshold  # noqa: E402
from sindybench.identify._space import data_settings, make_estimator  # noqa: E402
from sindybench.identify._stages import score_candidate, validated_library  # noqa: E402
from sindybench.libraries import POW, FrictionLibrary, IndicatorLibrary, PolynomialLibrary, TermsLibrary  # noqa: E402
from sindybench.refine import OutputErrorRefinement  # noqa: E402
from sindybench.search import LogUniform  # noqa: E402

# the identified row's structure and threshold level (seed 0); Z = [y, y', u]
ROW = {"family": "order2", "library": "poly2+hard", "derivative": "finite_difference", "input_hold": "linear",
       "input_delay": 0}
LEVEL = 9.803400808760069


def _pick():
    return PolynomialLibrary(degree=2) + FrictionLibrary(variables=[1])


def candidates():
    """``(label, structure, library, refinement keywords)`` of every probe (structure None: the latent input lag)."""
    squares = TermsLibrary(terms=[[[0, POW, 2, 0]], [[1, POW, 2, 0]]])
    out = [("the pick", ROW, _pick(), {}),
           ("+ sign(y')|y'|^2 (drag)", ROW, PolynomialLibrary(degree=2) + FrictionLibrary(variables=[1], powers=[2.0]),
            {}),
           ("+ sign(y')|y'|^0.5 (Stribeck-like)",
            ROW, PolynomialLibrary(degree=2) + FrictionLibrary(variables=[1], powers=[0.5]), {}),
           ("[y'>=0], [y'<=0] for sign(y')", ROW, PolynomialLibrary(degree=2)
            + IndicatorLibrary(variables=[1], lower=0.0) + IndicatorLibrary(variables=[1], upper=0.0), {}),
           ("cubic library", ROW, PolynomialLibrary(degree=3) + FrictionLibrary(variables=[1]), {}),
           ("zero-order hold", dict(ROW, input_hold="zoh"), _pick(), {})]
    out += [(f"input delay {d}", dict(ROW, input_delay=d), _pick(), {}) for d in (1, 2, 3, 4, 5, 6, 8, 10, 15)]
    out += [(f"refinement on the first {m} samples", ROW, _pick(), {"max_samples": m}) for m in (4000, 6000)]
    out += [("input lag z (latent): linear + sign(y')", None,
             PolynomialLibrary(degree=1) + FrictionLibrary(variables=[1]), {}),
            ("input lag z (latent): + y^2, y'^2", None,
             PolynomialLibrary(degree=1) + FrictionLibrary(variables=[1]) + squares, {})]
    return out


def _input_lag(library, dt):
    """States (y, y', z), z' = (u - z) / tau driving the velocity: the lag searched and refined as identify's latent
    families are (a grid of 12 time constants, two refined)."""
    def make(n_samples):
        hidden = LatentHiddenState(order=2, driver="input", bounds={"tau": LogUniform(dt, 1000 * dt)}, start="lag")
        return HiddenStateSINDy(hidden=hidden, library=library, optimizer=STLS(threshold=0.0, alpha=1e-9,
                                                                                normalize_columns=True),
                                differentiation=FiniteDifference(), dt=dt, input_hold="linear", validation_size=0.15,
                                n_trials=12, sampler="grid", n_refined=2, random_state=0, initial_state="fit",
                                refine=OutputErrorRefinement(max_nfev=30, max_samples=5000), show_progress_bar=False)
    return make


def main():
    bench, data, X, y, dt, search = _identified("emps")
    n = len(y)
    folds = record_folds([n], 3, 0.15, MIN_TRAIN, min_block=search.n_init + 2)
    _, lo, hi = folds[-1][0][0]
    settings = data_settings(X[lo:hi], y[lo:hi], dt)
    scale = np.std(segments([X], [y], folds[-1][0])[1], axis=0)
    ctx = {"X": [X], "y": [y], "dt": dt, "settings": settings, "random_state": 0, "folds": folds,
           "n_init": search.n_init, "horizon": None, "scale": scale}
    test = test_sets(data)["test"]
    for label, struct, library, refine_kw in candidates():
        refine = OutputErrorRefinement(**{"max_nfev": 20, "max_samples": min(n, 5000), **refine_kw})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if struct is None:
                result = evaluate_blocks(_input_lag(library, dt), ctx["X"], ctx["y"], folds, n_init=search.n_init,
                                         scale=scale)
                model = _input_lag(library, dt)(n)
            else:
                result = score_candidate(dict(struct, threshold=LEVEL), library, ctx, refine)
                model = make_estimator(struct, validated_library(result, library), stls_threshold(LEVEL, n), dt,
                                       settings, refine=refine)
            try:
                rmse = evaluate(model.fit(X, y), test, _n_init(bench, data, test))[1]["rmse"]
            except Exception as exc:  # a refit that fails is a row without a test score
                rmse = f"({type(exc).__name__})"
        errors = np.asarray(result["errors"])
        test_text = rmse if isinstance(rmse, str) else f"{rmse:.2f}"
        print(f"{label:42s} terms {result['n_terms']}: validation {errors.mean():.4f} +- {errors.std():.4f} "
              f"[{', '.join(f'{e:.4f}' for e in errors)}], test RMSE {test_text} mm", flush=True)


if __name__ == "__main__":
    main()

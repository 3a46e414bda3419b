"""Cost and result of ``identify`` on every benchmark, against the issue's targets.

For each benchmark, in one process: the row "identified automatically" of ``sindybench run``
(:class:`~sindybench.identify.IdentifyCV` on the estimation record, its inputs, outputs and
sample time only, plus the protocol's number of start samples), timed in CPU seconds of this
process (``time.process_time``, one thread: numba, BLAS and OpenMP are pinned to one), after
one warm-up fit of a small search that compiles the kernels. As the reference, the same
process times a plain ``HiddenStateSINDy`` second-order fit of the same record; the ratio
says how many such fits the search costs. Prints each test set's RMSE (fit index for the
neural state-space protocol) next to the issue's target, the chosen settings, the number of
terms and the CPU time against the budget (30 s per benchmark, 60 s for Silverbox). Needs
the benchmark data (``SINDYBENCH_DATA``). Run::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_identify.py [benchmark ...] [--families a,b,...]
"""

import os

for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from sindybench import HiddenStateSINDy  # noqa: E402
from sindybench.experiments import get_benchmark  # noqa: E402
from sindybench.experiments._common import IDENTIFIED  # noqa: E402
from sindybench.experiments._runner import _n_init, _training_record, evaluate, load_data, test_sets  # noqa: E402

# the first goals (seed 0): test set -> (metric, target, "<=" or ">=")
TARGETS = {
    "cascaded-tanks": {"test": ("rmse", 0.33, "<=")},
    "bouc-wen": {"multisine": ("rmse", 1e-5, "<=")},
    "emps": {"test": ("rmse", 7.87, "<=")},
    "pick-and-place-nss": {"test": ("fit_index", 86.2, ">=")},
    "silverbox": {"multisine": ("rmse", 1.0, "<="), "arrow_full": ("rmse", 1.2, "<=")},
}
BUDGET_S = {"silverbox": 60.0}


def _cpu(fit):
    start = time.process_time()
    result = fit()
    return time.process_time() - start, result


def _warm_up():
    from sindybench.identify import IdentifyCV
    from sindybench.simulate import simulate

    u = np.sin(np.arange(600) * 0.05)[:, None]
    y = simulate(lambda x, u: np.array([x[1], -x[0] - 0.3 * x[1] + u[0]]), [0.0, 0.0], u, dt=0.05)[:, :1]
    IdentifyCV(dt=0.05, show_progress_bar=False).fit(u, y)


def run(name, families=None):
    bench = get_benchmark(name)
    data = load_data(bench)
    X, y, _, n_val = _training_record(bench, data, False)
    dt = float(data["train"]["dt"])
    spec = bench.model(IDENTIFIED)
    estimator = spec.make(random_state=0, quick=False, dt=dt, n_val=n_val, n_samples=len(y))
    if families is not None:  # e.g. the defaults plus two latent states: what that family costs
        estimator.set_params(families=families)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref_s, _ = _cpu(lambda: HiddenStateSINDy(dt=dt, show_progress_bar=False).fit(X, y))
        cpu_s, search = _cpu(lambda: estimator.fit(X, y))
    budget = BUDGET_S.get(name, 30.0)
    chosen = search.best_params_
    table = search.cv_results_
    print(f"== {name}: {len(y)} samples, {len(table['family'])} candidates")
    print(f"   CPU {cpu_s:.1f} s (budget {budget:.0f} s: {'met' if cpu_s <= budget else 'NOT met'}); "
          f"{cpu_s / ref_s:.0f}x one default HiddenStateSINDy fit ({ref_s:.2f} s)")
    print(f"   chosen: {chosen}; {chosen['n_terms']} terms, "
          f"at most {chosen['max_row_terms']} per row (target <= 15)")
    for eq in search.equations(precision=4):
        print(f"     {eq}")
    for test_name, test in test_sets(data).items():
        _, scores = evaluate(search, test, _n_init(bench, data, test))
        line = f"   {test_name}: rmse {scores['rmse']}, fit {scores['fit_index']}"
        target = TARGETS.get(name, {}).get(test_name)
        if target is not None and scores[target[0]] is not None:
            metric, goal, sense = target
            met = scores[metric] <= goal if sense == "<=" else scores[metric] >= goal
            line += f"  (target {metric} {sense} {goal}: {'met' if met else 'NOT met'})"
        print(line)
    print("   front (terms: validation error):",
          ", ".join(f"{p['n_terms']}: {p['validation_error']:.3g}" for p in search.pareto_front_))


def main(argv=None):
    from sindybench.experiments._registry import BENCHMARKS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("benchmarks", nargs="*", default=sorted(BENCHMARKS))
    parser.add_argument("--families", default=None, help="comma-separated families to search (default: the row's)")
    args = parser.parse_args(argv)
    _warm_up()
    for name in args.benchmarks:
        run(name, None if args.families is None else args.families.split(","))


if __name__ == "__main__":
    main()

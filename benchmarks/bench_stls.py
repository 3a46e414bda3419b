"""STLS speed: sindybench vs pysindy.STLSQ, side by side in one run.

1. One fit on N = 40,000 samples, p = 20 library terms, 3 targets.
2. 200 refits of the same data over a threshold grid (what a hyperparameter
   search does): pysindy refits from scratch each time; sindybench reuses the
   factorization of (theta, target), either through an explicit ``GramCache``
   or through the ``STLS`` estimator's shared content-keyed cache (a fresh
   clone per fit, as in ``GridSearchCV``).

BLAS runs on one thread (``--threads`` to change) so that the numbers measure
the algorithms, not the machine's load. Run: ``python benchmarks/bench_stls.py``.
"""

import argparse
import time
import warnings

import numpy as np
from pysindy.optimizers import STLSQ
from sklearn.base import clone
from threadpoolctl import threadpool_limits

from sindybench import STLS, stls
from sindybench._stls import GramCache, clear_stls_cache


def make_problem(n_samples, n_features, n_targets, seed):
    rng = np.random.default_rng(seed)
    mixing = np.eye(n_features) + 0.3 * rng.normal(size=(n_features, n_features))
    theta = rng.normal(size=(n_samples, n_features)) @ mixing  # correlated columns
    coef = rng.normal(size=(n_features, n_targets)) * (rng.random((n_features, n_targets)) < 0.3)
    target = theta @ coef + 0.05 * rng.normal(size=(n_samples, n_targets))
    return theta, target


def best_time(func, repeat):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - start)
    return best


def total_time(func):
    start = time.perf_counter()
    result = func()
    return time.perf_counter() - start, result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-samples", type=int, default=40_000)
    parser.add_argument("--n-features", type=int, default=20)
    parser.add_argument("--n-targets", type=int, default=3)
    parser.add_argument("--n-refits", type=int, default=200)
    parser.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    theta, target = make_problem(args.n_samples, args.n_features, args.n_targets, args.seed)
    thresholds = np.geomspace(1e-3, 1.0, args.n_refits)
    warnings.simplefilter("ignore")  # convergence / eliminated-everything warnings at grid ends

    with threadpool_limits(args.threads):
        t_ref = best_time(lambda: STLSQ(threshold=0.1, alpha=0.0).fit(theta, target), 5)
        t_one = best_time(lambda: stls(theta, target, threshold=0.1), 5)

        t_ref_grid, ref = total_time(
            lambda: [STLSQ(threshold=t, alpha=0.0).fit(theta, target).coef_.T for t in thresholds]
        )

        def with_cache():
            cache = GramCache(theta, target)
            return [stls(theta, target, threshold=t, cache=cache)[0] for t in thresholds]

        t_grid, ours = total_time(with_cache)

        def with_estimator():
            clear_stls_cache()
            base = STLS(alpha=0.0)
            return [clone(base).set_params(threshold=t).fit(theta, target).coef_.T for t in thresholds]

        t_est_grid, ours_est = total_time(with_estimator)

    same_support = sum(np.array_equal(a != 0, b != 0) for a, b in zip(ours, ref))
    max_rel = max(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300) for a, b in zip(ours, ref) if b.any())
    est_equal = all(np.array_equal(a, b) for a, b in zip(ours, ours_est))

    n, p, k = args.n_samples, args.n_features, args.n_targets
    print(f"STLS benchmark: N = {n}, p = {p}, targets = {k}, BLAS threads = {args.threads}, seed = {args.seed}")
    print(f"{'case':<44}{'pysindy':>12}{'sindybench':>13}{'speed-up':>10}")
    rows = [
        ("single fit (best of 5)", t_ref, t_one),
        (f"{args.n_refits} refits, threshold grid, GramCache", t_ref_grid, t_grid),
        (f"{args.n_refits} refits, STLS clones (shared cache)", t_ref_grid, t_est_grid),
    ]
    for name, ref_t, our_t in rows:
        print(f"{name:<44}{ref_t * 1e3:>10.1f}ms{our_t * 1e3:>11.1f}ms{ref_t / our_t:>9.1f}x")
    print(f"agreement: same support in {same_support}/{args.n_refits} fits, "
          f"max relative coefficient difference {max_rel:.1e}; estimator path identical: {est_equal}")


if __name__ == "__main__":
    main()

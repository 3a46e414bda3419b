"""Does ``identify``'s validation rank what a test rewards? Every candidate's validation error beside its test score.

For one benchmark, in one process: the search of the row "identified automatically" (as
``bench_identify.py`` fits it; ``--families``, ``--n-blocks``, ``--block-size``, ``--max-samples`` and
``--max-nfev`` change the search), then every candidate that was scored on every validation block
(stages ``blocks`` and ``refine``, status ok) refitted on the whole estimation record the way the search
refits its choice, and simulated on the benchmark's first test set as the row is. Prints one line per
candidate (settings, terms, mean and spread of the validation error, the test metric) and the Spearman
rank correlation between the validation error and the test metric (1: validation ranks the candidates
as the test does). The test scores are reported only: nothing here chooses. Needs the benchmark data
(``SINDYBENCH_DATA``); a few minutes of one core. Run::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_validation_rank.py emps --families order2,first_order
"""

import os

for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
from scipy.stats import spearmanr  # noqa: E402

from bench_identify import TARGETS, _identified, _warm_up  # noqa: E402
from sindybench.experiments._runner import _n_init, evaluate, test_sets  # noqa: E402
from sindybench.identify._search import stls_threshold  # noqa: E402
from sindybench.identify._space import LATENT_FAMILIES, make_estimator, structures  # noqa: E402
from sindybench.identify._stages import STRUCTURE, validated_library, validated_terms  # noqa: E402


def scored_rows(table):
    """Rows of ``cv_results_`` scored on every block without failing (stages ``blocks`` and ``refine``).

    Examples
    --------
    >>> table = {"stage": ["screen", "blocks", "refine", "blocks"], "status": ["ok", "ok", "ok", "failed: x"],
    ...          "mean_validation_error": [0.1, 0.2, 0.3, np.inf]}
    >>> scored_rows(table)
    [1, 2]
    """
    return [i for i, stage in enumerate(table["stage"]) if stage != "screen" and table["status"][i] == "ok"
            and np.isfinite(table["mean_validation_error"][i])]


def refit_candidate(search, i, X, y, dt):
    """Row ``i`` of a fitted ``IdentifyCV``'s table refitted on the whole record ``(X, y)`` as its choice is: on the
    terms that its fit on the last fold's training part keeps (``validated_library``)."""
    table, settings = search.cv_results_, search.settings_
    row = {k: table[k][i] for k in STRUCTURE}
    libraries = {tuple(s[k] for k in ("family", "library", "derivative")): lib
                 for s, lib in structures(X, y, dt, settings, families=search.families)}
    library = libraries[(row["family"], row["library"], row["derivative"])]
    refine = search._refinement(len(y), search.criterion_["horizon"]) if table["stage"][i] == "refine" else None

    def make(library, level, n):
        return make_estimator(row, library, stls_threshold(level, n), dt, settings, refine=refine,
                              random_state=search.random_state or 0)

    chosen = {"threshold": table["threshold"][i], "support": None}
    if row["family"] not in LATENT_FAMILIES:  # the others choose their terms in their own fit
        stop = search.blocks_[-1][0]  # the last fold trains on the samples before its block
        last = make(library, chosen["threshold"], stop).fit(X[:stop], y[:stop])
        chosen["support"] = validated_terms(last, row["family"])
    return make(validated_library(chosen, library), chosen["threshold"], len(y)).fit(X, y)


def rank(name, settings):
    """The search of ``name``'s identified row with ``settings``; every scored candidate's validation error and test
    metric; the Spearman correlation of the two (printed)."""
    from sindybench.refine import OutputErrorRefinement

    bench, data, X, y, dt, search = _identified(name)
    refinement = {k: settings.pop(k) for k in ("max_samples", "max_nfev") if k in settings}
    if refinement:
        search.set_params(refinement=OutputErrorRefinement(**{"max_nfev": 20, "max_samples": 5000, **refinement}))
    search.set_params(**settings)
    test_name, test = next(iter(test_sets(data).items()))
    metric = TARGETS.get(name, {}).get(test_name, ("rmse",))[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.process_time()
        search.fit(X, y)
        cpu = time.process_time() - start
        chosen = evaluate(search, test, _n_init(bench, data, test))[1][metric]
        table, vals, tests = search.cv_results_, [], []
        print(f"== {name}: {len(y)} samples, search CPU {cpu:.1f} s; chosen row {search.best_index_} "
              f"({search.best_params_['family']}/{search.best_params_['library']}, {search.best_params_['n_terms']} "
              f"terms): validation {table['mean_validation_error'][search.best_index_]:.4g}, {test_name} {metric} "
              f"{chosen:.4g}")
        for i in scored_rows(table):
            try:
                score = evaluate(refit_candidate(search, i, X, y, dt), test, _n_init(bench, data, test))[1][metric]
            except Exception as exc:  # a refit that fails is a row without a test score
                score, why = None, f" ({type(exc).__name__})"
            else:
                why = ""
            score = np.inf if score is None else float(score)
            vals.append(table["mean_validation_error"][i])
            tests.append(score)
            print(f"   {i:4d} {table['family'][i]}/{table['library'][i]} {table['derivative'][i]} "
                  f"{table['input_hold'][i]} {table['stage'][i]} terms {table['n_terms'][i]}: validation "
                  f"{table['mean_validation_error'][i]:.4f} +- {table['std_validation_error'][i]:.4f}, "
                  f"{test_name} {metric} {score:.4g}{why}", flush=True)
    ok = np.isfinite(tests)
    rho = spearmanr(np.asarray(vals)[ok], np.asarray(tests)[ok] * (-1 if metric == "fit_index" else 1))
    print(f"   Spearman rank correlation of validation error and {test_name} {metric} (error sense) over "
          f"{int(ok.sum())} candidates: {rho.statistic:.2f} (p = {rho.pvalue:.2g})")
    return rho.statistic


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("benchmark")
    parser.add_argument("--families", default=None, help="comma-separated families to search (default: the row's)")
    parser.add_argument("--n-blocks", type=int, default=None, help="validation blocks (default: the row's)")
    parser.add_argument("--block-size", type=float, default=None, help="each block's fraction of the record")
    parser.add_argument("--max-samples", default=None,
                        help="the stage-3 refinement's samples (first ones; 'all' for all; default 5000)")
    parser.add_argument("--max-nfev", type=int, default=None, help="the stage-3 refinement's simulations (default 20)")
    args = parser.parse_args(argv)
    settings = {"families": None if args.families is None else args.families.split(","), "n_blocks": args.n_blocks,
                "block_size": args.block_size, "max_nfev": args.max_nfev,
                "max_samples": None if args.max_samples == "all" else
                int(args.max_samples) if args.max_samples is not None else 5000}
    if args.max_samples is None:
        settings.pop("max_samples")
    _warm_up()
    rank(args.benchmark, {k: v for k, v in settings.items() if v is not None or k == "max_samples"})


if __name__ == "__main__":
    main()

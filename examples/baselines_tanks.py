"""ARX and NN-ARX on the cascaded tanks, orders and settings chosen by ``tune``.

The study's protocol: train on the first 768 samples of the estimation record,
choose hyperparameters on its last 256 (open-loop RMSE, Optuna TPE), test on the
official validation record (1024 samples), each simulation started from the first
``n_init`` = 5 measured samples. Prints the test RMSE next to the study's
(ARX 0.77 V, NN-ARX 0.47 V), for the model fitted on the training block (the one
the validation chose) and for the same settings refitted on all 1024 estimation
samples.

Run from the repository root (the data are read from ``SINDYBENCH_DATA`` or
downloaded)::

    python examples/baselines_tanks.py --arx-trials 50 --nnarx-trials 40 --seed 0

NN-ARX is by default a linear ARX part plus a network on its residual
(``NNARX(residual=True)``); ``--plain`` tunes the plain network instead (in the
first search space of this script) and ``--n-estimators 3`` averages three
networks in the free run.

With ``--storage tanks.db`` the two studies are kept in SQLite: run the script
again (or in several terminals at once) to resume or share them.
"""

import argparse
import logging
import time
import warnings

import optuna
from sklearn.base import clone
from sklearn.exceptions import ConvergenceWarning

from sindybench.baselines import ARX, NNARX
from sindybench.datasets import load_cascaded_tanks
from sindybench.metrics import rmse
from sindybench.model_selection import Categorical, HoldoutSplit, IntRange, LogUniform, tune

STUDY = {"ARX": 0.77, "NNARX": 0.47}


def spaces(n_init, seed, *, residual=True, n_estimators=1):
    """Orders capped so that a simulation needs at most ``n_init`` measured samples."""
    orders = {"na": IntRange(1, n_init), "nb": IntRange(1, n_init), "nk": IntRange(0, 1)}
    if residual:
        # alpha's lower bound 0.1: the best validation RMSE of seeds 0-2 among 1e-5, 1e-3, 1e-2 and 1e-1
        nn_space = {"hidden_layer_sizes": Categorical([(4,), (8,), (16,), (32,)]), "alpha": LogUniform(0.1, 10.0)}
    else:
        nn_space = {"hidden_layer_sizes": Categorical([(8,), (16,), (32,), (16, 16)]), "alpha": LogUniform(1e-6, 1e-1)}
    return {
        "ARX": (ARX(), orders),
        "NNARX": (
            NNARX(max_iter=500, residual=residual, n_estimators=n_estimators, random_state=seed),
            {**orders, "activation": Categorical(["tanh", "relu"]), **nn_space},
        ),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arx-trials", type=int, default=50)
    parser.add_argument("--nnarx-trials", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--plain", action="store_true", help="NN-ARX without the linear ARX part")
    parser.add_argument("--n-estimators", type=int, default=1, help="networks averaged by NN-ARX")
    parser.add_argument("--storage", default=None, help="e.g. tanks.db or journal:///tmp/tanks.log")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    warnings.simplefilter("ignore", ConvergenceWarning)

    data = load_cascaded_tanks()
    est, test, n_init = data.estimation, data.test, data.n_init
    cv = HoldoutSplit(validation_size=len(data.validation.y))
    n_trials = {"ARX": args.arx_trials, "NNARX": args.nnarx_trials}
    rows = []
    models = spaces(n_init, args.seed, residual=not args.plain, n_estimators=args.n_estimators)
    variant = {"ARX": "", "NNARX": ("-plain" if args.plain else "") + f"-x{args.n_estimators}"}
    for name, (model, space) in models.items():
        start = time.perf_counter()
        refitted, study = tune(model, space, est.u, est.y, cv=cv, n_trials=n_trials[name], storage=args.storage,
                               study_name=f"tanks-{name}{variant[name]}-seed{args.seed}", random_state=args.seed)
        trained = clone(refitted).fit(data.train.u, data.train.y)
        errors = [rmse(test.y, m.predict(test.u, y_init=test.y[:n_init])) for m in (trained, refitted)]
        rows.append((name, study, errors, time.perf_counter() - start))
        logging.info("%s: best %s", name, study.best_trial.user_attrs["params"])
    print(f"\ncascaded tanks, test RMSE [V] (seed {args.seed}, simulation from {n_init} samples)")
    print(f"{'model':6} {'trials':>6} {'valid.':>7} {'train 768':>10} {'all 1024':>9} {'study':>6} {'time s':>7}")
    for name, study, (trained, refitted), seconds in rows:
        print(f"{name:6} {len(study.trials):6d} {study.best_value:7.3f} {trained:10.3f} {refitted:9.3f} "
              f"{STUDY[name]:6.2f} {seconds:7.1f}")


if __name__ == "__main__":
    main()

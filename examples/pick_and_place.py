"""Pick-and-place machine: a first-order model cannot oscillate, a second-order one can.

The study's Table 1 in a few lines. Only the head position ``y`` is measured;
its velocity, the other half of a mechanical state, is hidden. Naive SINDy
fits ``y' = f(y, u)``; ``DerivativeHiddenState(order=2)`` takes ``(y, y')`` as
the state and fits ``y'' = f(y, y', u)`` with the same quadratic library, the
derivatives estimated by total-variation regularised differentiation. The
hyperparameters (threshold, ridge alpha, TV gamma) are tuned on the validation
block with :func:`sindybench.model_selection.tune`, as the study did.

Run ``python examples/pick_and_place.py [--quick]`` with the benchmark records
in ``SINDYBENCH_DATA`` (see ``sindybench.datasets``).
"""

import argparse

import optuna

from sindybench import STLS, HiddenStateSINDy, SINDy
from sindybench.datasets import load_pick_and_place
from sindybench.differentiation import TotalVariation
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.metrics import fit_index, r2, rmse
from sindybench.model_selection import HoldoutSplit, LogUniform, tune


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small search budget (a few seconds)")
    args = parser.parse_args(argv)
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # one line per trial is too much here

    data = load_pick_and_place()
    train, val, test = data.train, data.validation, data.test
    u, y = data.estimation.u, data.estimation.y  # training + validation, the validation block last
    space = {
        "optimizer__threshold": LogUniform(1e-4, 1e2),
        "optimizer__alpha": LogUniform(1e-8, 1e-1),
        "differentiation__gamma": LogUniform(1e-6, 1e1),
    }
    common = dict(library=PolynomialLibrary(degree=2), optimizer=STLS(), differentiation=TotalVariation(), dt=data.dt)
    models = {
        "SINDy, 1st order": SINDy(**common),
        "SINDy, 2nd order": HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), **common),
    }
    study_r2 = {"SINDy, 1st order": 0.76, "SINDy, 2nd order": 0.94}

    print(f"Pick-and-place, test record ({len(test.y)} samples, first {data.n_init} initialise the state)")
    print(f"{'model':<20}{'RMSE':>8}{'R^2':>8}{'fit %':>8}   study R^2")
    for label, model in models.items():
        best, search = tune(model, space, u, y, cv=HoldoutSplit(validation_size=len(val.y)),
                            n_trials=6 if args.quick else 60, random_state=0, refit=False)
        model = best.fit(train.u, train.y)  # the validated candidate, fitted on the training block
        y_sim = model.predict(test.u, y_init=test.y[: data.n_init])
        print(f"{label:<20}{rmse(test.y, y_sim):>8.3f}{r2(test.y, y_sim):>8.3f}{fit_index(test.y, y_sim):>8.1f}"
              f"   {study_r2[label]:.2f}")
        for line in model.equations():
            print("    " + line)


if __name__ == "__main__":
    main()

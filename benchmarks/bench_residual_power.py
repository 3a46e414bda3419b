"""Power and level of the residual test that a refinement records (issue 37, item 3).

A DC servo's speed ``w' = -2 w + 8 u - 1.5 f(w)`` under a held random staircase
(2000 samples, ``dt = 0.01``, white measurement noise), fitted by ``SINDy`` with
the terms ``w, u, sign(w)`` and refined by simulation error
(``OutputErrorRefinement()``, an output-error model):

* wrong structure: the true friction is smooth, ``f(w) = tanh(w / 0.05)``
  (``--friction stribeck``: ``tanh(w / 0.01) (1 + exp(-(w / 0.3)^2)) / 1.5``);
* right structure: ``f(w) = sign(w)``.

For each of ``--runs`` noise realizations it reads the test recorded in
``refinement_["residual_test"]`` (the one ``standard_errors`` and
``confidence_intervals`` warn on) and prints the share flagged (not white or not
independent of the input) for each structure, and the share of the wrong
structure's 95 % intervals (``kind="white"``) that cover the true coefficients.
The generator is the tests' (``tests/test_uncertainty_residuals.py``). Run::

    nice -n 10 python benchmarks/bench_residual_power.py [--runs 100] [--noise 0.05] [--friction tanh]

It only reads the recorded ``white`` and ``independent``, so it also measures a
checkout of an older version (put it first on ``PYTHONPATH``).
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

from _threads import pin_threads

pin_threads(sys.argv)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import numpy as np  # noqa: E402

from test_uncertainty_residuals import SERVO_TRUTH, servo_model, servo_record  # noqa: E402


def one(seed, friction, noise):
    """(flagged, covered) of one realization: the recorded test's verdict and the intervals' coverage."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the refinement's budget, and the ModelErrorWarning being measured
        model = servo_model().fit(*servo_record(seed, friction=friction, noise=noise))
        test = model.refinement_["residual_test"]
        intervals = list(model.confidence_intervals().values())[:3]
    covered = [lo <= v <= hi for (lo, hi), v in zip(intervals, SERVO_TRUTH)]
    return not (test["white"] and test["independent"]), covered


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--noise", type=float, default=0.05)
    parser.add_argument("--friction", choices=["tanh", "stribeck"], default="tanh")
    parser.add_argument("--threads", default="1")
    args = parser.parse_args()
    import sindybench

    print(f"sindybench {sindybench.__version__} from {Path(sindybench.__file__).parent}")
    print(f"DC servo, {args.runs} realizations, noise {args.noise}, true friction {args.friction} (wrong) / sign "
          "(right)")
    start = time.perf_counter()
    wrong = [one(seed, args.friction, args.noise) for seed in range(args.runs)]
    right = [one(seed, "sign", args.noise) for seed in range(args.runs)]
    print(f"  wrong structure flagged: {np.mean([f for f, _ in wrong]):.2f} "
          f"({sum(f for f, _ in wrong)} of {args.runs})")
    print(f"  right structure flagged: {np.mean([f for f, _ in right]):.2f} "
          f"({sum(f for f, _ in right)} of {args.runs}; the test's level is 0.05)")
    print(f"  95 % intervals covering the truth, wrong structure: {np.mean([c for _, c in wrong]):.2f}; "
          f"right structure: {np.mean([c for _, c in right]):.2f}")
    print(f"  {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()

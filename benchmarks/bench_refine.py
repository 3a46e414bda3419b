"""Speed of the simulation-error refinement: exact sensitivities vs finite differences, Bouc-Wen on 40,000 samples.

The model is the Bouc-Wen hidden-force model of the study, ``HiddenStateSINDy`` with
``BoucWenHiddenState`` and the true ``m, c, k`` (its "Ideal" row: ``z`` reconstructed,
``z'`` learned sparsely, spectral derivatives cut at 150 Hz, RK4 with 2 sub-steps and a
linearly interpolated force), fitted on the benchmark's 40,000 training samples. Its
refinement problem has the 3 physical parameters, the learned ``z'`` coefficients and the
3 initial states free. Printed side by side in one process:

1. the Jacobian of the refinement's residuals (one per training sample) from the forward
   sensitivities of the compiled simulator, against the 2-point finite-difference
   Jacobian that ``scipy.optimize.least_squares(jac="2-point")`` would compute on the same
   problem (one simulation per parameter), on the first ``--jac-samples`` samples: best
   wall time of each, their ratio, and the largest difference between the two Jacobians
   relative to the largest entry of its column;
2. the wall time of one whole refinement (``OutputErrorRefinement()``, default budget) on
   all 40,000 samples, with the cost before and after and the simulations it took.

Numba, BLAS and OpenMP run on one thread (``--threads`` to change), like the other
scripts here. Needs the benchmark data (``SINDYBENCH_DATA``). Run::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_refine.py [--repeat 3] [--jac-samples 40000]
"""

import argparse
import sys


from _threads import pin_threads  # benchmarks/_threads.py, which imports no sindybench

pin_threads(sys.argv)

import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize._numdiff import approx_derivative  # noqa: E402  (what least_squares(jac="2-point") calls)
from threadpoolctl import threadpool_limits  # noqa: E402

from sindybench import STLS, HiddenStateSINDy  # noqa: E402
from sindybench._validation import check_bounds  # noqa: E402
from sindybench.datasets import load_bouc_wen  # noqa: E402
from sindybench.differentiation import Spectral  # noqa: E402
from sindybench.hidden import BoucWenHiddenState  # noqa: E402
from sindybench.refine import OutputErrorRefinement, ParametrizedDynamics, Shooting  # noqa: E402
from sindybench.refine._problem import _build  # noqa: E402

TRUE_MCK = {"m": 2.0, "c": 10.0, "k": 5e4}


class _Capture(OutputErrorRefinement):
    """``OutputErrorRefinement`` that keeps the problem it is given and the wall time of its run."""

    def run(self, dynamics, u, y, **kwargs):
        self.problem_ = (dynamics, u, y, kwargs)
        start = time.perf_counter()
        result = super().run(dynamics, u, y, **kwargs)
        self.seconds_ = time.perf_counter() - start
        return result


def model(n_rows, refine):
    threshold = 0.1 * 1.3e4 * np.sqrt(n_rows)  # as the study's Bouc-Wen experiment
    return HiddenStateSINDy(hidden=BoucWenHiddenState(**TRUE_MCK),
                            optimizer=STLS(threshold=threshold, normalize_columns=True),
                            differentiation=Spectral(cutoff=150.0), dt=1.0 / 750.0, n_substeps=2,
                            input_hold="linear", refine=refine)


def residual_problem(captured, n_samples, free=None):
    """The refinement's problem (residuals, sensitivity Jacobian) on the first ``n_samples``, and its bounds.

    ``free`` replaces the captured mask of free coefficients (to vary the number of parameters).
    """
    dynamics, u, y, kw = captured
    u, y = (u[0], y[0]) if isinstance(y, list) else (u, y)  # the estimator passes a list of records
    lo, hi = check_bounds(dynamics.bounds, dynamics.n_states)
    view = ParametrizedDynamics(dynamics, kw["free"] if free is None else kw["free"]._replace(coef=free))
    problem, _ = _build(view, list(np.asarray(kw["x0"], dtype=float)), [u[:n_samples]], [y[:n_samples]], Shooting(),
                        lo, hi)
    return problem, problem.bounds(lo, hi)


def jacobians(problem, bounds, repeat):
    """Best wall times of one simulation (the residuals), the sensitivity and the 2-point Jacobians, and the
    largest column-relative difference between the two Jacobians."""
    p = problem.pack()
    problem.jacobian(p)  # compile / load the kernels outside the timings
    t_sens, J_sens = best_of(lambda: problem.jacobian(p), repeat)
    t_sim, r0 = best_of(lambda: problem.residuals(p), repeat)
    t_fd, J_fd = best_of(lambda: approx_derivative(problem.residuals, p, method="2-point", f0=r0, bounds=bounds),
                         repeat)
    scale = np.abs(J_sens).max(axis=0)
    diff = np.abs(J_fd - J_sens).max(axis=0) / np.where(scale > 0, scale, 1.0)
    return p.size, t_sim, t_sens, t_fd, diff


def best_of(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--jac-samples", type=int, default=40_000)
    parser.add_argument("--threads", type=int, default=1, help="numba / BLAS / OpenMP threads (default 1)")
    args = parser.parse_args(argv)

    data = load_bouc_wen()
    u, y = data.train.u, data.train.y
    with threadpool_limits(args.threads):
        start = time.perf_counter()
        plain = model(len(u), None).fit(u, y)
        t_fit = time.perf_counter() - start

        capture = _Capture()
        start = time.perf_counter()
        refined = model(len(u), capture).fit(u, y)
        t_fit_refined = time.perf_counter() - start

        n_jac = min(args.jac_samples, len(u))
        captured = capture.problem_
        free_all = np.array(captured[3]["free"].coef, dtype=bool)
        n_lib = free_all.shape[0] - 4  # the 4 fixed terms of BoucWenHiddenState follow the library
        free_all[:n_lib, 2] = True
        variants = [("m, c, k and x0 only", np.zeros_like(free_all)), ("as refined (z' support of STLS)", None),
                    ("every z' library coefficient", free_all)]
        rows = []
        for name, free in variants:
            problem, bounds = residual_problem(captured, n_jac, free)
            rows.append((name, problem) + jacobians(problem, bounds, args.repeat))

    res = refined.refinement_
    problem = rows[1][1]
    print(f"Bouc-Wen hidden model, true m, c, k: {len(u)} training samples; refined: {problem.n_phys} physical, "
          f"{len(problem.free)} z' coefficients, {problem.free_x0.size} initial states; "
          f"RK4 x {captured[0].n_substeps} sub-steps; {args.threads} thread(s)")
    print()
    print(f"(a) Jacobian of the residuals on {n_jac} samples, best of {args.repeat}")
    print(f"{'free parameters':<34}{'n':>4}{'1 simulation [s]':>18}{'sensitivity [s]':>17}{'2-point [s]':>13}"
          f"{'ratio':>7}{'max rel. diff':>15}")
    for name, _, q, t_sim, t_sens, t_fd, diff in rows:
        print(f"{name:<34}{q:>4}{t_sim:>18.3f}{t_sens:>17.3f}{t_fd:>13.3f}{t_fd / t_sens:>7.1f}{diff.max():>15.2e}")
    print("ratio = 2-point time / sensitivity time; max rel. diff = max over the columns of "
          "max |J_fd - J_sens| / max |J_sens| in that column")
    print()
    print("(b) one refinement on all the training samples (OutputErrorRefinement(), default budget)")
    print(f"{'step':<46}{'time [s]':>10}")
    print(f"{'fit without refinement':<46}{t_fit:>10.3f}")
    print(f"{'fit with refinement':<46}{t_fit_refined:>10.3f}")
    print(f"{'  of which the refinement':<46}{capture.seconds_:>10.3f}")
    print(f"cost {res['initial_cost']:.3e} -> {res['cost']:.3e} in {res['nfev']} simulations "
          f"({res['njev']} Jacobians); {res['message']}")
    print("refined m, c, k: " + ", ".join(f"{k} = {v:.6g}" for k, v in res["physical"].items())
          + f"; train R^2 {plain.score(u, y):.6f} -> {refined.score(u, y):.6f}")


if __name__ == "__main__":
    main()

"""Speed of the initial-state estimation: the one estimator against the strategies' former optimizers.

``HiddenStateSINDy`` starts a simulation of new data from a strategy's first guess,
refined by :func:`sindybench.refine.estimate_initial_state` (exact sensitivities of
the compiled simulator, trust-region least squares) as the strategy's
``initial_fit`` says. Before, each strategy refined its guess itself:
``BoucWenHiddenState`` by ``least_squares(method="lm")`` with a finite-difference
Jacobian (residuals over ``max|y|``) and ``ParametricHiddenState`` /
``TanksHiddenState`` by a bounded Brent search within one grid step of the grid's
best point (``xatol`` 1e-3 of a step). Those two are re-implemented here as the
reference. Printed side by side in one process, for each case: the time per call
of the refinement alone (the same first guess for both), best of ``--repeat`` over
``--windows`` windows of new data, the ratio, the window's mean squared output
error reached by each (and by the guess), and in how many windows each reached the
lower error of the two.

The cases are synthetic (no data files needed): the Bouc-Wen system under a
multisine (true ``m, c, k``, 10-sample windows, three free states) and the
simulated cascaded tanks (true ``k1, k2``, 50-sample windows, the upper tank free
within ``[0, 10]``; its window error jumps where the upper tank reaches the overflow
bound, so the two optimizers may end in different local minima of a window). Numba and
BLAS run on one thread (``--threads`` to change). Run::

    python benchmarks/bench_initial_state.py [--repeat 5] [--windows 20]
"""

import argparse
import sys


from _threads import pin_threads  # benchmarks/_threads.py, which imports no sindybench

pin_threads(sys.argv)

import timeit  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import least_squares, minimize_scalar  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from sindybench import STLS, HiddenStateSINDy  # noqa: E402
from sindybench.differentiation import SavitzkyGolay  # noqa: E402
from sindybench.hidden import BoucWenHiddenState, ModelView, TanksHiddenState  # noqa: E402
from sindybench.hidden._refinement import refine_guess  # noqa: E402
from sindybench.libraries import SqrtLibrary  # noqa: E402
from sindybench.systems import BoucWen, CascadedTanks, multisine  # noqa: E402


def reference_bouc_wen(x0, y, u, view):
    """The former ``BoucWenHiddenState`` refinement: Levenberg-Marquardt, finite differences."""
    spread = max(float(np.abs(y).max()), np.finfo(float).tiny)

    def residuals(x):
        with np.errstate(all="ignore"):
            r = (view.simulate(x, u)[:, 0] - y[:, 0]) / spread
        return np.where(np.isfinite(r), r, 1e3)

    return least_squares(residuals, x0, x_scale="jac", method="lm").x


def reference_tanks(x0, y, u, view, hidden):
    """The former ``ParametricHiddenState`` refinement: bounded Brent within one grid step of the guess."""
    (lo, hi), = hidden._init_ranges()
    step = (hi - lo) / (hidden.grid_size - 1)

    def cost(v):
        err = np.mean((view.simulate(np.r_[x0[0], v], u)[:, :1] - y) ** 2)
        return float(err) if np.isfinite(err) else np.inf

    res = minimize_scalar(cost, bounds=(max(lo, x0[1] - step), min(hi, x0[1] + step)), method="bounded",
                          options={"xatol": 1e-3 * step})
    return np.r_[x0[0], res.x] if res.fun <= cost(x0[1]) else x0


def bouc_wen_case():
    u = multisine(4096, random_state=np.random.default_rng(7))
    y = BoucWen().simulate(u, periodic=True)
    hidden = BoucWenHiddenState(m=2.0, c=10.0, k=5e4)
    model = HiddenStateSINDy(hidden=hidden, optimizer=STLS(threshold=0.1 * 1.3e4 * np.sqrt(len(u)),
                                                           normalize_columns=True),
                             differentiation=SavitzkyGolay(window_length=5, polyorder=4), dt=1.0 / 750.0,
                             n_substeps=2, input_hold="linear").fit(u, y)
    return "Bouc-Wen, 10 samples, 3 free", model, u, y, 10, reference_bouc_wen


def tanks_case():
    rng = np.random.default_rng(0)
    n = 1000
    u = np.repeat(rng.uniform(1.0, 5.5, n // 50), 50)[:, None]
    system = CascadedTanks()
    x = system.simulate_states(u, dt=4.0, x0=(3.0, 4.0))
    y = x[:, 1:2] + 0.005 * rng.standard_normal((n, 1))
    hidden = TanksHiddenState(k1=system.k1, k2=system.k2, x0=3.0)
    model = HiddenStateSINDy(hidden=hidden, library=SqrtLibrary(variables=[0, 1]), dt=4.0, n_substeps=4).fit(u, y)

    def reference(x0, y_w, u_w, view):
        return reference_tanks(x0, y_w, u_w, view, model.hidden_)

    return "cascaded tanks, 50 samples, 1 free (bounded)", model, u, y, 50, reference


def run_case(name, model, u, y, n_init, reference, *, repeat, windows):
    cand, hidden = model._candidate_, model.hidden_
    dyn = cand.dynamics
    view = ModelView(rhs=dyn.rhs, simulate=lambda x0, u_: dyn.simulate(u_, x0, on_divergence="nan"))
    fit = hidden.initial_fit(cand.params, n_outputs=y.shape[1], n_inputs=u.shape[1])
    starts = np.linspace(n_init, len(u) - 2 * n_init, windows).astype(int)
    rows = {"guess": [0.0, []], "reference": [0.0, []], "estimate_initial_state": [0.0, []]}
    for s in starts:
        u_w, y_w = u[s:s + n_init], y[s:s + n_init]
        guess = hidden.initial_state(u_w, y_w, dyn.dt, derivative=cand.derivative, params=cand.params, model=view)

        def new():
            return refine_guess(fit, dyn, guess, u_w, y_w)

        def old():
            return reference(guess, y_w, u_w, view)

        new(), old()  # compile and warm up
        for label, func in (("reference", old), ("estimate_initial_state", new)):
            rows[label][0] += min(timeit.repeat(func, number=1, repeat=repeat)) / windows
            rows[label][1].append(func())
        rows["guess"][1].append(guess)
    print(f"\n{name}: {windows} windows, best of {repeat}")
    print(f"{'':24s} {'ms per call':>12s} {'ratio':>7s} {'mean window MSE':>17s} {'lower MSE in':>13s}")
    mse = {label: np.array([np.mean((dyn.simulate(u[s:s + n_init], x0)[:, list(dyn.output_index)]
                                     - y[s:s + n_init]) ** 2) for s, x0 in zip(starts, x0s)])
           for label, (_, x0s) in rows.items()}
    for label, (seconds, _) in rows.items():
        timing = f"{1e3 * seconds:12.2f} {seconds / rows['reference'][0]:7.2f}" if seconds else f"{'':12s} {'':7s}"
        other = "estimate_initial_state" if label == "reference" else "reference"
        wins = f"{np.sum(mse[label] < mse[other]):3d} windows" if label != "guess" else ""
        print(f"{label:24s} {timing} {mse[label].mean():17.6e} {wins:>13s}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--windows", type=int, default=20)
    parser.add_argument("--threads", type=int, default=1, help="numba / BLAS threads (default 1)")
    args = parser.parse_args()
    with threadpool_limits(args.threads):
        for case in (bouc_wen_case, tanks_case):
            run_case(*case(), repeat=args.repeat, windows=args.windows)


if __name__ == "__main__":
    main()

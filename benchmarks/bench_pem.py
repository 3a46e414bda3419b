"""Cost of the prediction-error refinement against the output-error one, and the two predictors (gain vs EKF).

The model: a positioning axis with an actuator lag, 3 states ``(y, v, f)``::

    y' = v
    v' = -k y - c v - d y^3 - s sign(v) + f
    f' = -a f + b u

recorded for 25,000 samples (``dt = 0.01``, output ``y`` with 1 % noise), refined from
the truth with every free coefficient 10 % off. Free: the 7 coefficients ``k, c, d, s,
1 (of f), a, b`` and the 3 initial states, 10 parameters (``y' = v`` held). Printed side by
side in one process, CPU time of one thread (best of ``--repeat``):

1. ``refine_simulation_error`` (output error, single shooting, default budget);
2. ``refine_prediction_error`` (one-step prediction error, the gain held at its start: the
   same 10 free parameters), and with the gain free too (13);
3. option (a) of issue 28, for the choice of predictor: the same least squares on the
   innovations of the package's extended Kalman filter (``estimation.extended_kalman_filter``,
   ``Q``, ``R`` given), whose gain follows the parameters through the Riccati recursion, so its
   Jacobian is by finite differences (one filter run per parameter), on ``--ekf-samples``
   samples: the CPU time per filter run and per Jacobian, against the constant-gain
   predictor's run with exact sensitivities on the same samples, and the coefficients each
   reaches.

Also per evaluation on the whole record: the predictor against the simulation (residuals)
and the predictor's sensitivities against the simulator's (Jacobian).

Targets (issue 28): 2. within 5 s of CPU and within 3x of 1. Run::

    python benchmarks/bench_pem.py [--repeat 3] [--ekf-samples 5000]
"""

import argparse
import sys


from _threads import pin_threads  # benchmarks/_threads.py, which imports no sindybench

pin_threads(sys.argv)

import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from sindybench.dynamics import POW, SIGN  # noqa: E402
from sindybench.estimation import ModelStep, extended_kalman_filter  # noqa: E402
from sindybench.dynamics import Dynamics  # noqa: E402
from sindybench.refine import (  # noqa: E402
    FreeParameters,
    LeastSquares,
    refine_prediction_error,
    refine_simulation_error,
    simulate_sensitivity,
)
from sindybench.refine._predictor import predict_sensitivity  # noqa: E402
from sindybench.simulate import TermsRHS, simulate  # noqa: E402

DT = 0.01
# terms of Z = [y, v, f, u]
TERMS = [((0, POW, 1, 0),), ((1, POW, 1, 0),), ((0, POW, 3, 0),), ((1, SIGN, 0, 0),), ((2, POW, 1, 0),),
         ((3, POW, 1, 0),)]
TRUE = np.zeros((6, 3))
TRUE[1, 0] = 1.0  # y' = v
TRUE[[0, 1, 2, 3, 4], 1] = [-4.0, -0.6, -1.0, -0.3, 1.0]  # v'
TRUE[[4, 5], 2] = [-5.0, 5.0]  # f'
FREE = TRUE != 0
FREE[1, 0] = False
X0 = np.array([0.2, 0.0, 0.0])


def _record(n, seed=0):
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-2, 2, n // 200 + 1), 200)[:n, None]
    x = simulate(TermsRHS(TRUE, TERMS, 3), X0, u, DT)
    y = x[:, :1] + 0.01 * np.std(x[:, 0]) * rng.normal(size=(n, 1))
    return u, y


def _cpu(fn, repeat):
    best, out = np.inf, None
    for _ in range(repeat):
        start = time.process_time()
        out = fn()
        best = min(best, time.process_time() - start)
    return best, out


def _error(coef):
    return float(np.max(np.abs(coef[FREE] / TRUE[FREE] - 1)))


def _ekf_residuals(u, y, Q, R):
    """Innovations of the package's EKF for the free coefficients ``p`` (x0 held), scaled; NaN-safe."""
    scale = np.std(y)

    def residuals(p):
        C = TRUE.copy()
        C[FREE] = p
        m = ModelStep(rhs=TermsRHS(C, TERMS, 3), n_inputs=1, output_index=(0,), lower=np.full(3, -np.inf),
                      upper=np.full(3, np.inf), dt=DT, n_substeps=1, method="rk4", input_hold="zoh", max_abs=1e6,
                      x0=X0, state_scale=np.ones(3))
        try:
            e = extended_kalman_filter(m, u, y, Q=Q, R=R, x0=X0, P0=np.eye(3) * 1e-4).innovations[:, 0]
        except Exception:
            return np.full(y.shape[0], 1e3)
        return e / scale / np.sqrt(y.size)

    return residuals


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--samples", type=int, default=25000)
    parser.add_argument("--ekf-samples", type=int, default=5000)
    parser.add_argument("--threads", default="1")
    args = parser.parse_args(argv)
    u, y = _record(args.samples)
    start = TRUE * np.where(FREE, 1.1, 1.0)
    model, free = Dynamics.from_terms(TERMS, start, dt=DT, output_index=(0,)), FreeParameters(coef=FREE)
    # compile once, outside the timings
    quick = LeastSquares(max_nfev=2, warn_budget=False)
    refine_simulation_error(model, u[:200], y[:200], x0=X0, free=free, solver=quick)
    refine_prediction_error(model, u[:200], y[:200], x0=X0, free=free, solver=quick)
    with threadpool_limits(limits=int(args.threads)), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t_oe, oe = _cpu(lambda: refine_simulation_error(model, u, y, x0=X0, free=free), args.repeat)
        t_pem, pem = _cpu(lambda: refine_prediction_error(model, u, y, x0=X0, free=free, free_gain=False),
                          args.repeat)
        t_gain, gain = _cpu(lambda: refine_prediction_error(model, u, y, x0=X0, free=free), args.repeat)
    print(f"{args.samples} samples, 3 states, {int(FREE.sum()) + 3} free parameters (7 coefficients, 3 initial "
          f"states); CPU seconds, one thread, best of {args.repeat}")
    print(f"{'refinement':44s} {'CPU s':>7s} {'x OE':>6s} {'nfev':>5s} {'njev':>5s} {'max coef error':>15s}")
    for name, t, res in (("output error (single shooting)", t_oe, oe),
                         ("prediction error, k=1, gain held (10 free)", t_pem, pem),
                         ("prediction error, k=1, gain free (13 free)", t_gain, gain)):
        print(f"{name:44s} {t:7.2f} {t / t_oe:6.2f} {res.nfev:5d} {res.njev:5d} {_error(res.coef):14.2%}")
    # per evaluation, on the whole record: a residual (simulation vs predictor) and a Jacobian (sensitivities)
    rhs = TermsRHS(start, TERMS, 3)
    D = np.zeros((int(FREE.sum()),) + TRUE.shape)
    for k, (j, i) in enumerate(np.argwhere(FREE)):
        D[k, j, i] = 1.0
    t_sim, _ = _cpu(lambda: simulate(rhs, X0, u, DT), args.repeat)
    t_pred, _ = _cpu(lambda: predict_sensitivity(rhs, X0, u, y, DT, gain=gain.gain, sensitivities=False),
                     args.repeat)
    t_ssim, _ = _cpu(lambda: simulate_sensitivity(rhs, X0, u, DT, directions=D, free_x0=[0, 1, 2],
                                                  output_index=[0]), args.repeat)
    t_spred, _ = _cpu(lambda: predict_sensitivity(rhs, X0, u, y, DT, gain=gain.gain, directions=D,
                                                  free_x0=[0, 1, 2]), args.repeat)
    print(f"per evaluation: residuals {t_pred * 1e3:.1f} ms (predictor) vs {t_sim * 1e3:.1f} ms (simulation), "
          f"{t_pred / t_sim:.2f}x; Jacobian {t_spred * 1e3:.1f} ms vs {t_ssim * 1e3:.1f} ms, {t_spred / t_ssim:.2f}x")
    print(f"targets: prediction error (10 free) within 5 s: {'met' if t_pem <= 5 else 'NOT met'} ({t_pem:.2f} s); "
          f"within 3x output error: {'met' if t_pem <= 3 * t_oe else 'NOT met'} ({t_pem / t_oe:.2f}x)")

    # option (a): the EKF's innovations (gain through the Riccati recursion), finite-difference Jacobian
    n = args.ekf_samples
    ue, ye = u[:n], y[:n]
    Q, R = np.diag([1e-10, 1e-6, 1e-6]), np.array([[(0.01 * np.std(y[:, 0])) ** 2]])
    fun = _ekf_residuals(ue, ye, Q, R)
    p0 = start[FREE]
    fun(p0)  # compile
    t_run, _ = _cpu(lambda: fun(p0), args.repeat)
    K = gain.gain
    predict_sensitivity(rhs, X0, ue, ye, DT, gain=K, directions=D, free_x0=[0, 1, 2])
    t_sens, _ = _cpu(lambda: predict_sensitivity(rhs, X0, ue, ye, DT, gain=K, directions=D, free_x0=[0, 1, 2]),
                     args.repeat)
    t_fit, fit = _cpu(lambda: least_squares(fun, p0, jac="2-point", method="trf", x_scale="jac", max_nfev=30), 1)
    C = TRUE.copy()
    C[FREE] = fit.x
    t_gain_n, gain_n = _cpu(lambda: refine_prediction_error(model, ue, ye, x0=X0, free=free._replace(x0=[]),
                                                            solver=LeastSquares(warn_budget=False)), 1)
    print(f"\nthe predictor, on the first {n} samples (x0 held, 7 coefficients):")
    print(f"  EKF run (innovations)                      {t_run * 1e3:8.1f} ms; a finite-difference Jacobian "
          f"= {FREE.sum() + 1} runs = {(FREE.sum() + 1) * t_run * 1e3:.1f} ms")
    print(f"  constant-gain run with exact sensitivities {t_sens * 1e3:8.1f} ms (10 parameters + 3 gain entries)")
    print(f"  least squares through the EKF: {t_fit:.2f} s CPU, {fit.nfev} runs, max coef error "
          f"{_error(C):.2%}; through the constant-gain predictor: {t_gain_n:.2f} s, "
          f"max coef error {_error(gain_n.coef):.2%}")


if __name__ == "__main__":
    main()

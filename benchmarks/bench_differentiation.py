"""Differentiation speed: every sindybench method on 40,000 samples, next to numpy.gradient.

The signal is sin(t) plus 1% Gaussian noise at dt = 0.01 (one column). Each
method's best time over ``--repeat`` runs is printed with its ratio to
``numpy.gradient`` (the reference, measured in the same process) and its
RMSE against cos(t) or -sin(t); TotalVariation rows add the number of Newton
steps of its solver and the process CPU time (the machine may be shared).
Non-uniform timing uses jittered sample times. BLAS runs on one thread
(``--threads`` to change).
Run: ``python benchmarks/bench_differentiation.py``.
"""

import argparse
import time
import warnings

import numpy as np
from threadpoolctl import threadpool_limits

from sindybench.differentiation import (
    FiniteDifference,
    Kalman,
    SavitzkyGolay,
    SmoothingSpline,
    Spectral,
    TotalVariation,
    tv_smooth,
)

METHODS = [
    ("FiniteDifference(accuracy=2)", FiniteDifference()),
    ("FiniteDifference(accuracy=4)", FiniteDifference(accuracy=4)),
    ("SavitzkyGolay(51, 3)", SavitzkyGolay(window_length=51, polyorder=3)),
    ("SmoothingSpline(1e-2)", SmoothingSpline(smoothing=1e-2)),
    ("TotalVariation(1e-2)", TotalVariation(gamma=1e-2)),
    ("TotalVariation(1e-3, tv_order=2)", TotalVariation(gamma=1e-3, tv_order=2)),
    ("Kalman(1e-4)", Kalman(alpha=1e-4)),
    ("Spectral(cutoff=0.5)", Spectral(cutoff=0.5)),
]


def best_time(func, repeat, clock=time.perf_counter):
    best = np.inf
    for _ in range(repeat):
        start = clock()
        func()
        best = min(best, clock() - start)
    return best


def tv_note(method, y, t, order, repeat):
    """Newton steps of the TV solver and CPU time of one derivative."""
    _, n_iter = tv_smooth(
        y[:, None],
        t,
        gamma=method.gamma,
        tv_order=method.tv_order or order,
        epsilon=method.epsilon,
        tol=method.tol,
        max_iter=method.max_iter,
    )
    cpu = best_time(lambda: method.derivative(y, t=t, order=order), repeat, clock=time.process_time)
    return f"  {n_iter} Newton steps, CPU {cpu:.3f} s"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-samples", type=int, default=40_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    dt = 0.01
    t = np.arange(args.n_samples) * dt
    y = np.sin(t) + 0.01 * rng.standard_normal(t.size)
    t_jitter = t + rng.uniform(-0.2, 0.2, t.size) * dt

    with threadpool_limits(args.threads), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ref = best_time(lambda: np.gradient(y, dt), args.repeat)
        print(f"n_samples={args.n_samples}, dt={dt}, noise std 0.01, best of {args.repeat}, {args.threads} BLAS thread(s)")
        print(f"reference numpy.gradient: {ref * 1e3:.3f} ms")
        header = f"{'method':34s} {'order':>5s} {'uniform s':>10s} {'x ref':>8s} {'non-unif. s':>11s} {'RMSE':>8s}"
        print(header)
        print("-" * len(header))
        for name, method in METHODS:
            for order in (1, 2):
                if isinstance(method, TotalVariation) and method.tv_order is None and order == 2:
                    continue
                method.derivative(y[:200], dt=dt, order=order)  # numba compilation or cache load: untimed
                uni = best_time(lambda: method.derivative(y, dt=dt, order=order), args.repeat)
                if isinstance(method, (SavitzkyGolay, Spectral)):  # uniform sampling only
                    non = "n/a"
                else:
                    non = f"{best_time(lambda: method.derivative(y, t=t_jitter, order=order), args.repeat):.3f}"
                truth = np.cos(t) if order == 1 else -np.sin(t)
                err = np.sqrt(np.mean((method.derivative(y, dt=dt, order=order) - truth) ** 2))
                note = tv_note(method, y, t, order, args.repeat) if isinstance(method, TotalVariation) else ""
                print(f"{name:34s} {order:5d} {uni:10.3f} {uni / ref:8.0f} {non:>11s} {err:8.4f}{note}")
    for w in {str(w.message) for w in caught}:
        print("warning:", w)


if __name__ == "__main__":
    main()

"""Speed and accuracy of the Bouc-Wen simulator on the official tests.

Runs, in one process, ``sindybench.systems.BoucWen`` (Newmark average
acceleration + Newton, 20x band-limited upsampling, FIR decimation) and a
reference: a plain fixed-step RK4 at the same 15 kHz rate on the same
interpolated input, compiled with numba as well. Prints wall times (best of
``--repeat`` runs after a warm-up), their ratio, and the RMSE / std(y) of each
against the official outputs.

Usage::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_systems.py [--repeat 3]

The target of the issue: the 153,000-sample sine sweep (3.06 M integration
steps) in under 10 s.
"""

import argparse
import time

import numpy as np
from numba import njit

from sindybench.datasets import load_bouc_wen
from sindybench.systems import BoucWen, decimate_fir, upsample

P = dict(m=2.0, c=10.0, k=5e4, alpha=5e4, beta=1e3, gamma=0.8, delta=-1.1)


@njit(cache=True)
def _rk4_bouc_wen(u, h, m, c, k, alpha, beta, gamma, delta):
    """Reference: classic RK4 with the input held over each fine step."""
    n = u.shape[0]
    out = np.empty(n)
    y = v = z = 0.0
    for i in range(n):
        out[i] = y
        f = u[i]
        k1y, k1v, k1z = v, (f - c * v - k * y - z) / m, alpha * v - beta * (gamma * abs(v) * z + delta * v * abs(z))
        y2, v2, z2 = y + 0.5 * h * k1y, v + 0.5 * h * k1v, z + 0.5 * h * k1z
        k2y, k2v, k2z = v2, (f - c * v2 - k * y2 - z2) / m, alpha * v2 - beta * (gamma * abs(v2) * z2 + delta * v2 * abs(z2))
        y3, v3, z3 = y + 0.5 * h * k2y, v + 0.5 * h * k2v, z + 0.5 * h * k2z
        k3y, k3v, k3z = v3, (f - c * v3 - k * y3 - z3) / m, alpha * v3 - beta * (gamma * abs(v3) * z3 + delta * v3 * abs(z3))
        y4, v4, z4 = y + h * k3y, v + h * k3v, z + h * k3z
        k4y, k4v, k4z = v4, (f - c * v4 - k * y4 - z4) / m, alpha * v4 - beta * (gamma * abs(v4) * z4 + delta * v4 * abs(z4))
        y += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y)
        v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        z += h / 6 * (k1z + 2 * k2z + 2 * k3z + k4z)
    return out


def _reference(u, *, periodic, stages):
    fine = upsample(u, 20, periodic=periodic)
    if periodic:
        fine = np.tile(fine, 2)
    y = _rk4_bouc_wen(fine, 1 / 15000, *P.values())[-u.size * 20 :]
    for r in stages:
        y = decimate_fir(y, r, periodic=periodic)
    return y


def _best_time(fn, repeat):
    fn()  # warm-up (compilation, caches)
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _rel(y, ref):
    return float(np.sqrt(np.mean((np.ravel(y) - ref) ** 2)) / np.std(ref))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    try:
        tests = load_bouc_wen(download_if_missing=False).test
    except FileNotFoundError as exc:
        parser.exit(2, f"{parser.prog}: error: {exc}\n")
    cases = [(name, periodic, stages, tests[name].u.ravel(), tests[name].y.ravel())
             for name, periodic, stages in (("multisine", True, (2, 2, 5)), ("sinesweep", False, (20,)))]

    print(f"{'test':<10} {'samples':>8} {'steps':>9} {'newmark s':>10} {'rk4 ref s':>10} {'ratio':>6} "
          f"{'newmark rmse/std':>17} {'rk4 rmse/std':>13}")
    for name, periodic, stages, u, y in cases:
        system = BoucWen(decimation=stages)
        t_new, y_new = _best_time(lambda: system.simulate(u, periodic=periodic), args.repeat)
        t_ref, y_ref = _best_time(lambda: _reference(u, periodic=periodic, stages=stages), args.repeat)
        steps = u.size * 20 * (2 if periodic else 1)
        print(f"{name:<10} {u.size:>8} {steps:>9} {t_new:>10.3f} {t_ref:>10.3f} {t_new / t_ref:>6.2f} "
              f"{_rel(y_new, y):>17.2e} {_rel(y_ref, y):>13.2e}")
    sweep = cases[1]
    t_stages, y_stages = _best_time(lambda: BoucWen().simulate(sweep[3]), 1)
    print(f"sinesweep with the documented stages (2, 2, 5): {t_stages:.3f} s, rmse/std {_rel(y_stages, sweep[4]):.2e}")


if __name__ == "__main__":
    main()

"""Speed of ``sindybench.simulate`` against a plain numpy RK4 loop and pysindy.

The model: 3 states, one input, a degree-2 polynomial library over
``[x0, x1, x2, u0]`` (15 terms) of which 6 are active::

    x0' = x1
    x1' = u0 - x0 - 0.2 x1 - x2 - 0.1 x0^2
    x2' = 0.5 x1 - 0.3 x2 - 0.2 x1 x2

driven by a sine sweep sampled at 750 Hz over 153,000 samples (the length of
the Bouc-Wen sine-sweep test). Runs, side by side in one process:

* ``simulate`` with a ``TermsRHS`` (RK4, zero-order hold), compiled with numba:
  first call (compilation or cache load) and best steady-state time;
* a plain per-step numpy RK4 loop with the same library and coefficients
  (vectorised feature evaluation per stage), on the first ``--numpy-steps``
  samples, scaled linearly to the full horizon;
* ``pysindy.SINDy.simulate`` (its defaults: LSODA, rtol = atol = 1e-12, cubic
  input interpolation) with the same coefficients on the first
  ``--pysindy-steps`` samples, scaled linearly.

Usage::

    python benchmarks/bench_simulate.py [--repeat 5] [--numpy-steps 20000] [--pysindy-steps 2000]
"""

import argparse
import time
import warnings

import numpy as np

from sindybench.libraries import PolynomialLibrary
from sindybench.simulate import TermsRHS, simulate

N_SAMPLES = 153_000
DT = 1 / 750
NAMES = ["x0", "x1", "x2", "u0"]
COEF = {  # (feature name, state) -> coefficient
    ("x1", 0): 1.0,
    ("u0", 1): 1.0,
    ("x0", 1): -1.0,
    ("x1", 1): -0.2,
    ("x2", 1): -1.0,
    ("x0^2", 1): -0.1,
    ("x1", 2): 0.5,
    ("x2", 2): -0.3,
    ("x1 x2", 2): -0.2,
}


def model():
    lib = PolynomialLibrary(degree=2).fit(np.zeros((1, 4)))
    names = lib.get_feature_names_out(NAMES).tolist()
    coef = np.zeros((len(names), 3))
    for (name, state), value in COEF.items():
        coef[names.index(name), state] = value
    return lib, names, coef


def sine_sweep(n, dt, f0=0.05, f1=2.0):
    t = np.arange(n) * dt
    phase = 2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * t[-1]))
    return np.sin(phase)[:, None]


def numpy_rk4(coef, x0, u, dt):
    """Plain per-step RK4: degree-2 features as products of index pairs, then theta @ coef."""
    i, j = np.triu_indices(5)  # pairs over [1, x0, x1, x2, u0]
    x = np.empty((u.shape[0], 3))
    x[0] = x0

    def f(xs, us):
        z = np.concatenate(([1.0], xs, us))
        return (z[i] * z[j]) @ coef

    for k in range(u.shape[0] - 1):
        xk, uk = x[k], u[k]
        k1 = f(xk, uk)
        k2 = f(xk + 0.5 * DT * k1, uk)
        k3 = f(xk + 0.5 * DT * k2, uk)
        k4 = f(xk + DT * k3, uk)
        x[k + 1] = xk + DT / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def pysindy_model(names, coef, x, u):
    import pysindy as ps

    model = ps.SINDy(feature_library=ps.PolynomialLibrary(degree=2), optimizer=ps.STLSQ(threshold=0.01))
    model.fit(x, t=DT, u=u, feature_names=NAMES)
    order = [names.index(n) for n in model.get_feature_names()]
    model.optimizer.coef_ = coef[order].T.copy()
    return model


def numba_cache_counts():
    """``(cache hits, compilations)`` of every numba kernel sindybench has loaded so far."""
    import sys

    from numba.core.registry import CPUDispatcher

    hits = misses = 0
    for name, module in list(sys.modules.items()):
        if name.startswith("sindybench"):
            for obj in list(vars(module).values()):
                if isinstance(obj, CPUDispatcher):
                    hits += sum(obj.stats.cache_hits.values())
                    misses += sum(obj.stats.cache_misses.values())
    return hits, misses


def best_of(fn, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--numpy-steps", type=int, default=20_000)
    parser.add_argument("--pysindy-steps", type=int, default=2_000)
    args = parser.parse_args()

    lib, names, coef = model()
    rhs = TermsRHS(coef, lib.terms_, 3)
    u = sine_sweep(N_SAMPLES, DT)
    x0 = np.zeros(3)

    start = time.perf_counter()
    simulate(rhs, x0, u[:10], DT)
    first = time.perf_counter() - start
    fast, x = best_of(lambda: simulate(rhs, x0, u, DT), args.repeat)

    n_np = min(args.numpy_steps, N_SAMPLES)
    slow_np, x_np = best_of(lambda: numpy_rk4(coef, x0, u[:n_np], DT), 1)
    np_full = slow_np * (N_SAMPLES - 1) / (n_np - 1)

    n_ps = min(args.pysindy_steps, N_SAMPLES)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps_model = pysindy_model(names, coef, x[:5000], u[:5000])
        t_ps = np.arange(n_ps) * DT
        slow_ps, x_ps = best_of(lambda: ps_model.simulate(x0, t_ps, u=u[:n_ps]), 1)
    ps_full = slow_ps * (N_SAMPLES - 1) / (n_ps - 2)  # pysindy drops the last sample

    scale = np.max(np.abs(x[:n_np]))
    print(f"model: 3 states, {rhs.n_active} active terms of {len(names)}; {N_SAMPLES} samples, RK4, dt = {DT:.6g}")
    hits, misses = numba_cache_counts()
    how = "compilation" if misses else "cache load" if hits else "compilation or cache load"
    rows = [
        (f"sindybench.simulate, first call ({how})", first, None),
        (f"sindybench.simulate, compiled (best of {args.repeat})", fast, fast),
        (f"numpy RK4 loop, {n_np} steps", slow_np, np_full),
        (f"pysindy SINDy.simulate, {n_ps} steps", slow_ps, ps_full),
    ]
    print(f"{'method':<48}{'time [s]':>10}{'153k-sample equiv. [s]':>24}{'ratio':>8}")
    for name, seconds, full in rows:
        tail = "" if full is None else f"{full:>24.3f}{full / fast:>8.0f}"
        print(f"{name:<48}{seconds:>10.3f}{tail}")
    print(f"max |simulate - numpy RK4| / max|x| over {n_np} steps: {np.max(np.abs(x[:n_np] - x_np)) / scale:.2e}")
    err_ps = np.max(np.abs(x[: n_ps - 1] - x_ps)) / np.max(np.abs(x[: n_ps - 1]))
    print(f"max |simulate - pysindy| / max|x| over {n_ps - 1} steps (LSODA, cubic input): {err_ps:.2e}")


if __name__ == "__main__":
    main()

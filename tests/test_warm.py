"""sindybench.warm: the warm-up compiles the very kernel signatures that real calls use."""

import gc
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from sindybench import HiddenStateSINDy, SINDy, warm
from sindybench.estimation import estimate_noise, extended_kalman_filter, predict_k_step, rts_smoother
from sindybench.hidden import TanksHiddenState
from sindybench.libraries import ConcatLibrary, IndicatorLibrary, PolynomialLibrary, SqrtLibrary
from sindybench.refine import OutputErrorRefinement


def _signatures():
    """``{kernel: number of compiled signatures}`` of every sindybench numba kernel in this process."""
    kernels = [d for d in gc.get_objects() if type(d) is CPUDispatcher]  # isinstance fails on dead weak proxies
    return {f"{d.py_func.__module__}.{d.py_func.__qualname__}": len(d.signatures) for d in kernels
            if (d.py_func.__module__ or "").startswith("sindybench")}


def _tanks(n=300, dt=4.0):
    """Two tanks in cascade (both levels measured), a record unlike the warm-up's."""
    rng = np.random.default_rng(1)
    u = np.repeat(rng.uniform(2.0, 6.0, n // 20 + 1), 20)[:n, None]
    y = np.empty((n, 2))
    y[0] = [2.0, 1.0]
    for k in range(n - 1):
        up, low = y[k]
        y[k + 1] = [up + dt * (0.05 * u[k, 0] - 0.04 * np.sqrt(up)),
                    low + dt * (0.04 * np.sqrt(up) - 0.035 * np.sqrt(low))]
    return u, y, dt


def test_real_calls_after_the_warm_up_compile_nothing_new():
    """After the estimate_noise group and the fit/refine group, other models through the public API reuse their
    kernels: no kernel gains a second signature (a layout, a read-only array, a None for an int would)."""
    warm._run("filter, estimate_noise, smoother, k-step")
    warm._run("fit, predict, output-error refinement")
    before = _signatures()
    u, y, dt = _tanks()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lib = ConcatLibrary([PolynomialLibrary(degree=2), SqrtLibrary(), IndicatorLibrary(variables=[1], lower=3.0)])
        model = SINDy(library=lib, dt=dt, n_substeps=2, bounds=(0.0, 10.0),
                      refine=OutputErrorRefinement(max_nfev=2)).fit(u, y)
        model.predict(u[:50], y_init=y[:1])
        Q, R = estimate_noise(model, u, y, max_iter=3)
        extended_kalman_filter(model, u, y, Q=Q, R=R)
        rts_smoother(model, u, y, Q=Q, R=R)
        predict_k_step(model, u, y, 3, Q=Q, R=R)
        hidden = HiddenStateSINDy(hidden=TanksHiddenState(k_bounds=(0.02, 0.08), ratio_bounds=(0.3, 3.0)),
                                  library=PolynomialLibrary(degree=1), dt=dt, n_trials=2, local_trials=0,
                                  random_state=0).fit(u, y[:, 1:])
        hidden.predict(u[:50], y_init=y[:1, 1:])
    after = _signatures()
    grew = {name: (before.get(name, 0), n) for name, n in after.items() if n > max(before.get(name, 0), 1)}
    assert grew == {}
    used = ("estimation._kalman._filter", "estimation._kalman._smooth", "estimation._predict._k_step",
            "dynamics._kernels.run_state_into", "dynamics._kernels.run_sensitivity_into",
            "dynamics._ops.evaluate_kernel")
    assert all(before.get(f"sindybench.{name}", 0) >= 1 for name in used)  # the warm-up compiled them


def test_warm_runs_each_group_and_reports_its_seconds(monkeypatch, capsys):
    ran = []
    monkeypatch.setattr(warm, "GROUPS", {"a": lambda: ran.append("a"), "b": lambda: ran.append("b")})
    assert warm.main(["--jobs", "1"]) == 0
    assert ran == ["a", "b"]
    out = capsys.readouterr().out
    assert "s CPU  a" in out and "s CPU  b" in out and "numba's cache holds" in out


@pytest.mark.slow
def test_estimate_noise_after_the_warm_up_loads_every_kernel_from_the_cache(tmp_path):
    """In a new process on the cache that ``python -m sindybench.warm`` filled, estimate_noise compiles nothing."""
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(root)}
    subprocess.run([sys.executable, "-m", "sindybench.warm", "--jobs", "1"], env=env, check=True, capture_output=True)
    script = (
        "import gc, warnings, numpy as np\n"
        "from numba.core.registry import CPUDispatcher\n"
        "from sindybench import SINDy\nfrom sindybench.libraries import PolynomialLibrary\n"
        "from sindybench.estimation import estimate_noise\n"
        "warnings.simplefilter('ignore')\n"
        "u = np.sin(0.1 * np.arange(400))[:, None]; y = np.cumsum(u, axis=0) * 0.05 + 1.0\n"
        "m = SINDy(library=PolynomialLibrary(degree=2), dt=0.05).fit(u, y)\n"
        "estimate_noise(m, u, y, max_iter=3)\n"
        "print(sum(sum(d.stats.cache_misses.values()) for d in gc.get_objects() if type(d) is CPUDispatcher))\n")
    out = subprocess.run([sys.executable, "-c", script], env=env, check=True, capture_output=True, text=True)
    assert out.stdout.split()[-1] == "0"

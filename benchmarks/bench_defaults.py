"""The plain estimators with their defaults on every benchmark record: ``SINDy()``, ``HiddenStateSINDy()``, ``ARX()``.

Each configuration (only ``dt`` given, plus the settings named in its label) is

* fitted on the benchmark's training block and simulated on its validation block (the last
  block of the estimation record; these scores choose the defaults), and
* fitted on the whole estimation record and simulated on every test set (reported only).

Simulations start from the protocol's first ``n_init`` samples and are scored after them, RMSE in
the benchmark's units (Silverbox in mV). Silverbox is read from ``silverbox/SNLS80mV.csv`` with the
protocol of the data README (multisine block ``all[40650:127400]``, estimation its first 75 %,
tests ``multisine`` = the rest and ``arrow_full`` = ``all[100:40575]``, 50 initial samples); its
validation block is the last 20 % of the estimation record.

Usage (from the repository root)::

    SINDYBENCH_DATA=../shared/data PYTHONPATH=. python benchmarks/bench_defaults.py [--benchmarks tanks emps ...] \\
        [--configs "ARX()" "HiddenStateSINDy() (0.3: auto library, hold, derivative and refine)"]

(``PYTHONPATH=.``: the checkout's ``sindybench``, not another installed copy.) The last column
says what ``HiddenStateSINDy``'s ``"auto"`` parameters decided, on the validation fit and on the
full fit.
"""

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np

from sindybench import STLS, HiddenStateSINDy, SINDy
from sindybench.baselines import ARX
from sindybench.differentiation import FiniteDifference, Spectral
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.refine import OutputErrorRefinement
from sindybench.experiments import evaluate, get_benchmark, load_data, test_sets

OLD = dict(input_hold="zoh", differentiation=FiniteDifference(accuracy=2))  # the defaults before 0.2
NEW = dict(input_hold="linear", differentiation=FiniteDifference(accuracy=4))
QUIET = dict(show_progress_bar=False)
#: HiddenStateSINDy's defaults before 0.2: the strategy's library, zero-order hold, FiniteDifference(), no refinement
HIDDEN_01 = dict(library=None, refine=None, **OLD, **QUIET)
CONFIGS = {
    "ARX()": lambda dt: ARX(),
    "SINDy() (zoh, FD2, threshold 0.1)": lambda dt: SINDy(dt=dt),
    "SINDy linear, FD4": lambda dt: SINDy(dt=dt, **NEW),
    "SINDy normalize, threshold 0.05": lambda dt: SINDy(dt=dt, normalize=True, optimizer=STLS(threshold=0.05), **OLD),
    "SINDy linear, FD4, normalize, threshold 0.05":
        lambda dt: SINDy(dt=dt, normalize=True, optimizer=STLS(threshold=0.05), **NEW),
    "SINDy linear, FD4, refine": lambda dt: SINDy(dt=dt, refine=OutputErrorRefinement(), **NEW),
    "SINDy auto derivative (the record's bandwidth)": lambda dt: SINDy(dt=dt, differentiation="auto"),
    "HiddenStateSINDy, 0.1 defaults (zoh, FD2, poly2, least squares)": lambda dt: HiddenStateSINDy(dt=dt, **HIDDEN_01),
    "HiddenStateSINDy() (0.3: auto library, hold, derivative and refine)":
        lambda dt: HiddenStateSINDy(dt=dt, **QUIET),
    "HiddenStateSINDy, 0.2 defaults (auto library and hold, FD4, auto refine)":
        lambda dt: HiddenStateSINDy(dt=dt, differentiation=FiniteDifference(accuracy=4), **QUIET),
    "HiddenStateSINDy auto library, hold and derivative, no refinement":
        lambda dt: HiddenStateSINDy(dt=dt, refine=None, **QUIET),
    "HiddenStateSINDy auto library and hold, FD4, no refinement":
        lambda dt: HiddenStateSINDy(dt=dt, refine=None, differentiation=FiniteDifference(accuracy=4), **QUIET),
    "HiddenStateSINDy linear, FD4, poly2": lambda dt: HiddenStateSINDy(dt=dt, library=None, refine=None, **NEW, **QUIET),
    "HiddenStateSINDy linear, FD4, poly1": lambda dt: HiddenStateSINDy(
        dt=dt, library=PolynomialLibrary(degree=1), refine=None, **NEW, **QUIET),
    "HiddenStateSINDy linear, FD4, poly2, refine":
        lambda dt: HiddenStateSINDy(dt=dt, library=None, refine=OutputErrorRefinement(), **NEW, **QUIET),
    "HiddenStateSINDy linear, FD4, normalize, threshold 0.05": lambda dt: HiddenStateSINDy(
        dt=dt, library=None, refine=None, normalize=True, optimizer=STLS(threshold=0.05), **NEW, **QUIET),
    "HiddenStateSINDy linear, Spectral, n_substeps=4": lambda dt: HiddenStateSINDy(
        dt=dt, library=None, refine=None, input_hold="linear", differentiation=Spectral(), n_substeps=4, **QUIET),
    "HiddenStateSINDy order 1 (auto library, hold, refine)":
        lambda dt: HiddenStateSINDy(dt=dt, hidden=DerivativeHiddenState(order=1), **QUIET),
    "HiddenStateSINDy order 3 (auto library, hold, refine)":
        lambda dt: HiddenStateSINDy(dt=dt, hidden=DerivativeHiddenState(order=3), **QUIET),
    "HiddenStateSINDy() with refine max_samples=5000":
        lambda dt: HiddenStateSINDy(dt=dt, refine=OutputErrorRefinement(max_samples=5000), **QUIET),
}

NAMES = {"tanks": "cascaded-tanks", "bouc-wen": "bouc-wen", "emps": "emps", "pick-and-place": "pick-and-place",
         "pick-and-place-nss": "pick-and-place-nss"}


def _column(a):
    a = np.asarray(a, float)
    return a.reshape(len(a), -1)


def registry_record(name):
    """``(dt, (u_train, y_train), (u_val, y_val), n_init, {test: (u, y, n_init, score_from)})`` of a benchmark."""
    bench = get_benchmark(NAMES[name])
    data = load_data(bench)
    train, val = data["train"], data["validation"]
    tests = {}
    for key, test in test_sets(data).items():
        n_init = int(test.get("n_init") or data.get("n_init") or bench.n_init)
        tests[key] = (_column(test["u"]), _column(test["y"]), n_init, int(test.get("score_from") or 0))
    n_init = int(data.get("n_init") or bench.n_init)
    return (float(data["dt"]), (_column(train["u"]), _column(train["y"])), (_column(val["u"]), _column(val["y"])),
            n_init, tests)


def silverbox_record():
    """Silverbox by the data README's protocol, in millivolts."""
    path = Path(os.environ.get("SINDYBENCH_DATA", "../shared/data")) / "silverbox" / "SNLS80mV.csv"
    raw = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(0, 1))
    u, y = raw[:, :1], 1e3 * raw[:, 1:2]
    block_u, block_y = u[40650:127400], y[40650:127400]
    n_est = int(0.75 * len(block_y))
    n_train = int(0.8 * n_est)
    tests = {"multisine": (block_u[n_est:], block_y[n_est:], 50, 50),
             "arrow_full": (u[100:40575], y[100:40575], 50, 50)}
    return (1.6384e-3, (block_u[:n_train], block_y[:n_train]), (block_u[n_train:n_est], block_y[n_train:n_est]), 50,
            tests)


def _score(model, u, y, n_init, score_from):
    _, scores = evaluate(model, {"u": u, "y": y, "score_from": score_from}, n_init)
    return scores["rmse"]


def _fit(make, dt, u, y):
    start = time.process_time()  # CPU seconds of this process (run with one thread: NUMBA/OMP/OPENBLAS_NUM_THREADS=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return make(dt).fit(u, y), time.process_time() - start
        except Exception as exc:  # a configuration that fails is a result
            return exc, time.process_time() - start


def measure(name, record, configs=CONFIGS):
    dt, (u_tr, y_tr), (u_va, y_va), n_init, tests = record
    u_est, y_est = np.vstack([u_tr, u_va]), np.vstack([y_tr, y_va])
    rows = []
    for label, make in configs.items():
        model, _ = _fit(make, dt, u_tr, y_tr)
        val = None if isinstance(model, Exception) else _score(model, u_va, y_va, n_init, n_init)
        chosen = _chosen(model)
        model, cpu = _fit(make, dt, u_est, y_est)
        scores = {key: (None if isinstance(model, Exception) else _score(model, u, y, k, s))
                  for key, (u, y, k, s) in tests.items()}
        error = str(model) if isinstance(model, Exception) else None
        rows.append((name, label, val, scores, cpu, error, chosen, _chosen(model)))
    return rows


def _chosen(model):
    """What a HiddenStateSINDy's "auto" parameters decided (hold, library degree, refined); "" for the others."""
    if not hasattr(model, "input_hold_"):
        return ""
    degree = getattr(model.library_, "degree", "?")
    status = (model.refinement_ or {}).get("status", -1)
    refined = ", refined" if status >= 0 else (", refinement skipped" if model.refinement_ else "")
    return f"{model.input_hold_}, poly{degree}{refined}"


def _fmt(v):
    return "div." if v is None else f"{v:.4g}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--benchmarks", nargs="*", default=[*NAMES, "silverbox"])
    parser.add_argument("--configs", nargs="*", default=None, help="labels of CONFIGS to run (default: all)")
    args = parser.parse_args(argv)
    configs = CONFIGS if not args.configs else {k: CONFIGS[k] for k in args.configs}
    print("| benchmark | configuration | validation RMSE | test RMSE | fit CPU s | chosen (validation fit; full fit) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name in args.benchmarks:
        record = silverbox_record() if name == "silverbox" else registry_record(name)
        for bench, label, val, scores, cpu, error, chosen_val, chosen in measure(name, record, configs):
            tests = ", ".join(f"{k} {_fmt(v)}" for k, v in scores.items())
            note = f" (failed: {error[:60]})" if error else ""
            choice = f"{chosen_val}; {chosen}" if chosen else ""
            print(f"| {bench} | {label} | {_fmt(val)} | {tests}{note} | {cpu:.2f} | {choice} |", flush=True)


if __name__ == "__main__":
    main()

"""Compile time of each public entry point: a fresh numba cache against a warm one.

Each scenario runs in its own Python process, twice with the same ``NUMBA_CACHE_DIR``: first
with the folder empty (what a new machine, CI run or notebook kernel pays), then again with the
cache the first run wrote (warm). Inside the process only the entry point itself is timed (CPU,
``time.process_time``, and wall); what it needs first (loading the data, fitting the model) runs
before the timer, so an entry point is charged with the compilation that it adds. Printed: cold
and warm CPU seconds, their difference (the compilation) and their ratio.

Scenarios (cascaded-tanks data; a ``SINDy`` model with polynomial and square-root terms, 2
states, RK4, fitted on the estimation record):

- ``quickstart``: the README's quickstart, as the README writes it (the whole script is timed);
- ``fit``: ``SINDy(...).fit``; ``predict``: ``model.predict`` on the validation record;
- ``refine``: ``SINDy(..., refine=OutputErrorRefinement()).fit``;
- ``filter``: ``extended_kalman_filter``; ``estimate_noise``; ``k_step``: ``predict_k_step``.

``--reference REV`` also runs every scenario on the package of revision ``REV`` (exported with
``git archive`` into a temporary folder), scenario by scenario just before this tree's run (on a
shared machine the load drifts: compare neighbours). Also printed: the whole child process's CPU
(interpreter start and imports included), the measure of "a script's CPU time".
Numba, BLAS and OpenMP run on one thread.

``--warm`` also fills a cache with ``python -m sindybench.warm --jobs 1`` once (its CPU printed) and times each
scenario in a new process on a copy of it: the first call after the set-up's warm-up.

Measured (reference 9776474, the code before, with ``--warm --reference 9776474``; this tree in a second run
``--only ...`` minutes later; the shared 2-core machine at a load of 12-18; CPU seconds; compile = cold - warm CPU
of the entry point; "after the warm-up" measured on the commit before, which differed only in inlining, not
in what the cache holds)::

    scenario        compile before -> after   warm CPU   cold/warm after   after the warm-up / warm
    quickstart       8.45 ->  4.76 s           20.92 s    1.23x             1.02x
    fit              0.51 ->  0.39 s            0.23 s    2.72x             0.97x
    predict          2.67 ->  1.69 s            0.01 s                      0.88x
    refine           7.75 ->  5.20 s            0.05 s                      0.98x
    filter          10.60 ->  8.01 s            0.02 s                      0.97x
    estimate_noise  14.14 -> 10.10 s            0.13 s                      0.99x  (compile 0.00 s)
    k_step          17.10 -> 11.19 s            0.03 s                      1.00x
    python -m sindybench.warm --jobs 1 on an empty cache: 51.1 s CPU, once

Usage (from the repository root)::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_compile.py [--only quickstart] [--reference main] [--warm]
"""

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ("quickstart", "fit", "predict", "refine", "filter", "estimate_noise", "k_step")

_SETUP = """
import numpy as np
from sindybench import STLS, SINDy
from sindybench.datasets import load_cascaded_tanks
from sindybench.libraries import ConcatLibrary, PolynomialLibrary, SqrtLibrary
from sindybench.refine import OutputErrorRefinement
from sindybench.estimation import estimate_noise, extended_kalman_filter, predict_k_step
data = load_cascaded_tanks()
u, y = data.train.u, np.hstack([data.train.y, data.train.y])  # two measured states (a toy second tank)
uv, yv = data.validation.u, np.hstack([data.validation.y, data.validation.y])

def make(**kw):
    return SINDy(library=ConcatLibrary([PolynomialLibrary(degree=2), SqrtLibrary()]), optimizer=STLS(threshold=1e-4),
                 dt=data.dt, n_substeps=2, bounds=([0.0, 0.0], [10.0, 10.0]), **kw)
"""

_STEPS = {
    "fit": ("", "model = make().fit(u, y)"),
    "predict": ("model = make().fit(u, y)", "model.predict(uv, y_init=yv[:1])"),
    "refine": ("model = make().fit(u, y)", "make(refine=OutputErrorRefinement(max_nfev=3)).fit(u, y)"),
    "filter": ("model = make().fit(u, y)", "extended_kalman_filter(model, u, y, Q=[1e-4, 1e-4], R=[1e-3, 1e-3])"),
    "estimate_noise": ("model = make().fit(u, y)", "estimate_noise(model, u, y, max_iter=20)"),
    "k_step": ("model = make().fit(u, y)", "predict_k_step(model, uv, yv, 5, Q=[1e-4, 1e-4], R=[1e-3, 1e-3])"),
}

_TIMER = """
import time, json, warnings
warnings.simplefilter("ignore")
{setup}
c0, w0 = time.process_time(), time.perf_counter()
{body}
print("BENCH " + json.dumps({{"cpu": time.process_time() - c0, "wall": time.perf_counter() - w0}}))
"""


def _quickstart():
    text = (ROOT / "README.md").read_text()
    block = re.search(r"## Quickstart.*?```python\n(.*?)```", text, re.S).group(1)
    return "import time, json, warnings\nwarnings.simplefilter('ignore')\nc0, w0 = time.process_time(), " \
           "time.perf_counter()\n" + block + \
           "\nprint('BENCH ' + json.dumps({'cpu': time.process_time() - c0, 'wall': time.perf_counter() - w0}))\n"


def _script(name):
    if name == "quickstart":
        return _quickstart()
    before, body = _STEPS[name]
    return _TIMER.format(setup=_SETUP + "\n" + before, body=body)


def _run(tree, script, cache):
    """CPU and wall seconds of the timed part, and the whole child's CPU (interpreter start and imports included)."""
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(cache), "PYTHONDONTWRITEBYTECODE": "1",
           "MPLBACKEND": "Agg", "SINDYBENCH_PROGRESS": "0"}
    for name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[name] = "1"
    if env.get("SINDYBENCH_DATA"):
        env["SINDYBENCH_DATA"] = str(Path(env["SINDYBENCH_DATA"]).resolve())
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([sys.executable, "-c", script], env=env, cwd=tempfile.gettempdir(), capture_output=True,
                         text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode:
        raise RuntimeError(out.stderr[-2000:])
    line = [x for x in out.stdout.splitlines() if x.startswith("BENCH ")][-1]
    result = json.loads(line[6:])
    result["process"] = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return result


def measure(tree, name, label, warmed=None):
    """Cold and warm runs of a scenario; with ``warmed`` (a cache that ``sindybench.warm`` filled), a third run
    on a copy of it: the first call after the set-up's warm-up."""
    with tempfile.TemporaryDirectory() as cache:
        cold = _run(tree, _script(name), cache)
        warm = _run(tree, _script(name), cache)
    print(f"  {label:9s} {name:15s} cold {cold['cpu']:6.2f} s  warm {warm['cpu']:6.2f} s  compile "
          f"{cold['cpu'] - warm['cpu']:6.2f} s  ratio {cold['cpu'] / warm['cpu']:6.2f}x  (whole process "
          f"{cold['process']:6.2f} / {warm['process']:6.2f} s = {cold['process'] / warm['process']:5.2f}x; wall "
          f"{cold['wall']:6.2f} / {warm['wall']:6.2f} s)", flush=True)
    if warmed is not None:
        with tempfile.TemporaryDirectory() as folder:
            cache = Path(folder) / "cache"
            shutil.copytree(warmed, cache)
            after = _run(tree, _script(name), cache)
        print(f"  {label:9s} {name:15s} after python -m sindybench.warm {after['cpu']:6.2f} s  compile "
              f"{after['cpu'] - warm['cpu']:6.2f} s  ratio {after['cpu'] / warm['cpu']:6.2f}x", flush=True)
    return cold, warm


def _warm_cache(tree, cache):
    """Fill ``cache`` with ``python -m sindybench.warm --jobs 1``; print its CPU and wall seconds."""
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(cache), "PYTHONDONTWRITEBYTECODE": "1"}
    for name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[name] = "1"
    before, start = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run([sys.executable, "-m", "sindybench.warm", "--jobs", "1"], env=env, cwd=tempfile.gettempdir(),
                   check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    wall = time.perf_counter() - start
    print(f"  python -m sindybench.warm --jobs 1 on an empty cache: {cpu:.1f} s CPU, {wall:.0f} s wall", flush=True)


def _export(rev, folder):
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "sindybench", "README.md"], check=True,
                             capture_output=True)
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default=",".join(SCENARIOS), help="comma-separated scenarios")
    parser.add_argument("--reference", default=None, help="also time this git revision (e.g. main)")
    parser.add_argument("--warm", action="store_true", help="also time each scenario after python -m sindybench.warm")
    args = parser.parse_args()
    names = [n for n in args.only.split(",") if n]
    unknown = sorted(set(names) - set(SCENARIOS))
    if unknown:
        parser.error(f"unknown scenarios {unknown}; expected some of {list(SCENARIOS)}")
    print("CPU seconds of each entry point (fresh NUMBA_CACHE_DIR = cold, then the same cache = warm)")
    cur, ref = {}, {}
    with tempfile.TemporaryDirectory() as folder, tempfile.TemporaryDirectory() as warmed:
        if args.reference:
            _export(args.reference, folder)
        if args.warm:
            _warm_cache(ROOT, warmed)
        for name in names:  # reference and this tree back to back, scenario by scenario
            if args.reference:
                ref[name] = measure(Path(folder), name, "reference")
            cur[name] = measure(ROOT, name, "this tree", warmed if args.warm else None)
    if args.reference:
        print(f"compile seconds (cold - warm CPU), this tree / reference {args.reference}:")
        for name in names:
            a = cur[name][0]["cpu"] - cur[name][1]["cpu"]
            b = ref[name][0]["cpu"] - ref[name][1]["cpu"]
            print(f"  {name:15s} {a:6.2f} / {b:6.2f} s = {a / b:5.2f}")


if __name__ == "__main__":
    start = time.perf_counter()
    main()
    print(f"({time.perf_counter() - start:.0f} s)")

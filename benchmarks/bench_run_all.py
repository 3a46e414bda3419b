"""Wall time of the main job, ``sindybench run all``, against a reference revision, side by side.

The reference revision's package is exported (``git archive``) into a temporary folder and both
versions run the same command with the same interpreter, one after the other in this one
process's children, after a warm-up (``run all --quick --trials 1``) that fills each tree's numba
cache. Prints each wall time, their ratio, and each run's per-model fit times with the NN-ARX
share of the wall time.

Usage (from the repository root, with the benchmark records in SINDYBENCH_DATA)::

    SINDYBENCH_DATA=../shared/data .venv/bin/python benchmarks/bench_run_all.py [--reference REV] [--repeat N]

The default reference, b9f177e, is the main job before issue 12 (NN-ARX with the BLAS thread
count left to OpenBLAS and trained in double precision). The machine may be shared: compare
runs made back to back, and repeat (``--repeat``, alternating reference and current) to see the
spread.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _export(rev, folder):
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "sindybench"], check=True, capture_output=True)
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)


def _run(tree, out, *extra):
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    if env.get("SINDYBENCH_DATA"):  # the runs start in another folder
        env["SINDYBENCH_DATA"] = str(Path(env["SINDYBENCH_DATA"]).resolve())
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "sindybench.cli", "run", "all", "--no-progress", "-q", "--out", str(out),
                    *extra], check=True, env=env, cwd=tree, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def _fit_times(out):
    times = {}
    for results in sorted(Path(out).glob("*/results.json")):
        data = json.loads(results.read_text())
        for model in data["models"]:
            times[f"{data['benchmark']}/{model['key']}"] = model["fit_time_s"] or 0.0
    return times


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", default="b9f177e", help="git revision to compare with (default: b9f177e)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each version, alternating (default: 1)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bench-run-all-") as tmp:
        tmp = Path(tmp)
        reference = tmp / "reference"
        reference.mkdir()
        _export(args.reference, reference)
        trees = {"reference": reference, "current": ROOT}
        for name, tree in trees.items():  # fill the numba caches of both trees
            _run(tree, tmp / f"warm-{name}", "--quick", "--trials", "1")
        walls, fits = {name: [] for name in trees}, {}
        for i in range(args.repeat):
            for name, tree in trees.items():
                out = tmp / f"{name}-{i}"
                walls[name].append(_run(tree, out))
                fits[name] = _fit_times(out)
                print(f"run {i}: {name:9s} {walls[name][-1]:6.1f} s", flush=True)
        ref, cur = min(walls["reference"]), min(walls["current"])
        print(f"\nsindybench run all, best of {args.repeat}: reference ({args.reference}) {ref:.1f} s, "
              f"current {cur:.1f} s, ratio {ref / cur:.2f}x")
        print(f"\n{'model (last run)':40s} {'reference':>10s} {'current':>10s}")
        for key in sorted(set(fits["reference"]) | set(fits["current"])):
            ref_fit, cur_fit = fits["reference"].get(key), fits["current"].get(key)
            cells = [f"{v:9.1f}s" if v is not None else f"{'-':>10s}" for v in (ref_fit, cur_fit)]
            print(f"{key:40s} {cells[0]} {cells[1]}")
        for name in trees:
            nn = sum(v for k, v in fits[name].items() if k.endswith("/nnarx"))
            print(f"{name}: NN-ARX fits {nn:.1f} s = {100 * nn / walls[name][-1]:.0f} % of the wall time "
                  f"{walls[name][-1]:.1f} s")


if __name__ == "__main__":
    main()

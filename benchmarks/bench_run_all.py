"""Wall time of the main job, ``sindybench run all``, one benchmark after the other against all at once.

Runs ``sindybench run all --jobs 1`` (serial, in one process) and ``--jobs -1`` (one worker
process per core, the longest benchmark first) with the same interpreter, one after the other
in this process's children, each in its own copy of the package (``sindybench/`` without its
``__pycache__``), so each starts, as on a fresh checkout, with an empty numba cache (``--warm``
fills each copy's cache first with ``run all --quick --trials 1``). Prints each wall time and
CPU time, their ratio, each benchmark's own wall time in each run, and whether the two runs'
scores are the same (they must be: the order of the benchmarks changes no number). With
``--reference REV`` the package of a git revision runs serially too, as a third column.

Usage (from the repository root, with the benchmark records in SINDYBENCH_DATA)::

    SINDYBENCH_DATA=../shared/data python benchmarks/bench_run_all.py [--warm] [--quick] [--repeat N] [--reference REV]

The machine may be shared: compare runs made back to back, and repeat (``--repeat``, alternating
the runs) to see the spread; the load average before each run is printed.
"""

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _copy(folder):
    shutil.copytree(ROOT / "sindybench", folder / "sindybench", ignore=shutil.ignore_patterns("__pycache__"))


def _export(rev, folder):
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "sindybench"], check=True, capture_output=True)
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)


def _run(tree, out, *extra):
    """``(wall seconds, CPU seconds of the command and its workers)`` of one ``run all``."""
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    env.pop("NUMBA_CACHE_DIR", None)  # the cache in the copy's own __pycache__ folders
    if env.get("SINDYBENCH_DATA"):  # the runs start in another folder
        env["SINDYBENCH_DATA"] = str(Path(env["SINDYBENCH_DATA"]).resolve())
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "sindybench.cli", "run", "all", "--no-progress", "-q", "--out", str(out),
                    *extra], check=True, env=env, cwd=tree, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _results(out):
    return {p.parent.name: json.loads(p.read_text()) for p in sorted(Path(out).glob("*/results.json"))}


def _scores(results):
    return {(name, m["key"], test): s.get(metric) for name, r in results.items() for m in r["models"]
            for test, s in m["scores"].items() for metric in ("rmse", "r2", "fit_index")}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--warm", action="store_true", help="fill each copy's numba cache before the timed runs")
    parser.add_argument("--repeat", type=int, default=1, help="timed runs of each configuration, alternating")
    parser.add_argument("--reference", default=None, help="a git revision to time serially too")
    parser.add_argument("--quick", action="store_true", help="time 'run all --quick' (a smoke run) instead")
    args = parser.parse_args(argv)
    quick = ("--quick",) if args.quick else ()
    configs = {"serial": ("--jobs", "1", *quick), "parallel": ("--jobs", "-1", *quick)}
    if args.reference:
        configs["reference"] = quick
    with tempfile.TemporaryDirectory(prefix="bench-run-all-") as tmp:
        tmp = Path(tmp)
        walls, cpus, results = ({name: [] for name in configs} for _ in range(3))
        for i in range(args.repeat):
            for name, extra in configs.items():
                tree = tmp / f"{name}-{i}"
                tree.mkdir()
                _export(args.reference, tree) if name == "reference" else _copy(tree)
                if args.warm:
                    _run(tree, tmp / f"warm-{name}-{i}", "--quick", "--trials", "1", *extra)
                load = os.getloadavg()[0]
                wall, cpu = _run(tree, tmp / f"out-{name}-{i}", *extra)
                walls[name].append(wall)
                cpus[name].append(cpu)
                results[name] = _results(tmp / f"out-{name}-{i}")
                print(f"run {i}: {name:9s} {' '.join(extra) or '(serial)':8s} wall {wall:6.1f} s, CPU {cpu:6.1f} s "
                      f"(load average before: {load:.2f})", flush=True)
        cache = ("warm numba cache" if args.warm else "fresh numba cache") + (", --quick" if args.quick else "")
        serial, parallel = min(walls["serial"]), min(walls["parallel"])
        print(f"\nsindybench run all ({cache}), best of {args.repeat}: serial {serial:.1f} s, parallel "
              f"{parallel:.1f} s, ratio {serial / parallel:.2f}x; CPU {min(cpus['serial']):.1f} s vs "
              f"{min(cpus['parallel']):.1f} s")
        if args.reference:
            print(f"reference {args.reference} (serial): {min(walls['reference']):.1f} s")
        print(f"\n{'benchmark (last run), its own wall time':40s}" + "".join(f"{name:>11s}" for name in configs))
        for bench in sorted(results["serial"]):
            cells = "".join(f"{results[name][bench]['wall_time_s']:10.1f}s" if bench in results[name] else f"{'-':>11s}"
                            for name in configs)
            print(f"{bench:40s}{cells}")
        same = _scores(results["serial"]) == _scores(results["parallel"])
        print(f"\nscores of the serial and the parallel run {'identical' if same else 'DIFFER'} "
              f"({len(_scores(results['serial']))} scores)")


if __name__ == "__main__":
    main()

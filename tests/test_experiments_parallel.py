"""Benchmarks run at once in worker processes (``run_benchmarks(jobs=...)``, ``sindybench run --jobs``)."""

import dataclasses
import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from sindybench.experiments import run_benchmarks
from sindybench._numba_cache import lock_numba_cache
from sindybench.experiments._parallel import longest_first, worker_count
from test_cli import _synthetic

ROOT = Path(__file__).resolve().parents[1]
_TIMES = re.compile(r"(wall time|fit in|Total wall time) [0-9.]+ s|\([0-9.]+ min\)|[0-9.]+ s \([0-9]+ %"
                    r"|<span class=time>[^<]*</span>")


def _files(folder):
    """``{relative path: content}`` of a run's output, the times it reports masked."""
    out = {}
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        name = str(path.relative_to(folder))
        if path.suffix == ".json" and path.name == "results.json":
            data = json.loads(path.read_text())
            data.pop("wall_time_s")
            for m in data["models"]:
                m.pop("fit_time_s"), m.pop("fit_time_with_search_s", None)
            out[name] = data
        elif path.suffix in (".md", ".html"):
            out[name] = _TIMES.sub("<time>", path.read_text())
        else:
            out[name] = path.read_bytes()
    return out


def _toys():
    # a slower one (more trials) last in the list: the parallel run starts it first
    slow = dataclasses.replace(_synthetic(), name="toy-slow", title="Slow toy", cost=5.0,
                               models=tuple(dataclasses.replace(m, n_trials_quick=6) for m in _synthetic().models))
    return [dataclasses.replace(_synthetic(), name="toy", cost=1.0), slow]


def test_a_parallel_run_writes_the_files_of_a_serial_run(tmp_path, caplog):
    # the bars asked for (drawn only on a terminal) are a parameter of the saved models: the same in both runs
    serial = run_benchmarks(_toys(), tmp_path / "serial", quick=True, seed=2, jobs=1, show_progress_bar=True)
    with caplog.at_level("INFO", logger="sindybench"):
        parallel = run_benchmarks(_toys(), tmp_path / "parallel", quick=True, seed=2, jobs=2, show_progress_bar=True)
    assert serial.name == parallel.name == "report.md"
    a, b = _files(tmp_path / "serial"), _files(tmp_path / "parallel")
    assert sorted(a) == sorted(b) and "toy-slow/models/sindy_poly.json" in a
    for name in a:
        assert a[name] == b[name], name
    # the report lists the benchmarks in the given order, though the slow one started first
    report = (tmp_path / "parallel" / "report.md").read_text()
    assert report.index("Toy first-order system") < report.index("Slow toy")
    assert "the longest first: toy-slow, toy" in caplog.text and "done 2/2" in caplog.text
    # the common numba kernels first, once for both workers (here loaded: the cache is warm)
    assert caplog.text.index("common numba kernels compiled or loaded first") < caplog.text.index("the longest first")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["parallel", "serial"]  # no staging folder left


def test_a_benchmark_that_stops_in_a_worker_stops_the_run_and_leaves_no_files(tmp_path):
    from sindybench.experiments import ModelSpec

    def lost(**kwargs):  # a storage that stops answering stops the run (a failing model does not)
        raise ConnectionError("the storage stopped answering in the worker")

    toys = _toys()
    toys[1] = dataclasses.replace(toys[1], models=(ModelSpec("lost", "Lost", lost),))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("mine")
    with pytest.raises(ConnectionError, match="stopped answering in the worker"):
        run_benchmarks(toys, tmp_path / "out", quick=True, jobs=2)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["keep.txt"]


def test_the_longest_starts_first_and_jobs_are_checked():
    assert longest_first([12, 73, 39, 38, 30, 19]) == [1, 2, 3, 4, 5, 0]
    assert worker_count(-1, 1) == 1 and worker_count(2, 6) == 2
    for bad in (0, -2, 1.5, True, "2"):
        with pytest.raises(ValueError, match="jobs must be a positive integer or -1"):
            worker_count(bad, 6)
    with pytest.raises(ValueError, match="jobs must be a positive integer or -1"):
        run_benchmarks(_toys(), "never-written", jobs=0)
    assert not os.path.exists("never-written")


def test_numba_cache_saves_hold_the_runs_file_lock(tmp_path, monkeypatch):
    # two workers saving two specializations of one kernel at once could both take the index's next data file
    from filelock import FileLock, Timeout
    from numba.core import caching

    held = []

    def save(self, key, data):  # stands for numba's read-modify-write of the index
        try:
            FileLock(tmp_path / "numba.lock", timeout=0).acquire()
        except Timeout:
            held.append(key)

    monkeypatch.setattr(caching.IndexDataCacheFile, "save", save)  # restored after the test
    assert lock_numba_cache(tmp_path / "numba.lock")
    caching.IndexDataCacheFile.save(None, "key", b"")
    assert held == ["key"]
    assert lock_numba_cache(tmp_path / "other.lock")  # a second call wraps numba's method, not the first wrapper
    assert caching.IndexDataCacheFile.save.__wrapped__ is save


def test_ctrl_c_during_a_parallel_run_exits_130_and_writes_nothing(tmp_path):
    # the workers ignore SIGINT (a terminal sends it to the whole process group); the command stops them
    script = textwrap.dedent(f"""
        import dataclasses, sys, time
        sys.path.insert(0, {str(ROOT / "tests")!r})
        import sindybench.experiments as experiments
        from sindybench.cli import main
        from sindybench.experiments import ModelSpec
        from test_cli import _synthetic

        def slow(**kwargs):
            time.sleep(120)

        toy = _synthetic()
        benches = {{name: dataclasses.replace(toy, name=name, models=(ModelSpec("slow", "Slow", slow),))
                   for name in experiments.BENCHMARKS}}
        experiments.get_benchmark = benches.__getitem__
        print("started", flush=True)
        sys.exit(main(["run", "all", "--jobs", "2", "--out", sys.argv[1]]))
    """)
    proc = subprocess.Popen([sys.executable, "-c", script, str(tmp_path / "out")], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            env={**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"})
    assert proc.stdout.readline().strip() == "started"
    err = ""
    deadline = time.time() + 90
    while "the longest first" not in err and time.time() < deadline:  # the workers are running
        err += proc.stderr.readline()
    time.sleep(3.0)  # let the workers import the package and start fitting
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: to the command and its workers
    _, rest = proc.communicate(timeout=60)
    err += rest
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().endswith("sindybench: interrupted; no output written."), err
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no output, no staging folder
    for _ in range(50):  # the workers are killed (they would sleep for two minutes)
        left = subprocess.run(["pgrep", "-s", str(proc.pid)], capture_output=True, text=True).stdout.split()
        if not left:
            break
        time.sleep(0.1)
    assert left == [], f"worker processes left running: {left}"
    print(f"workers gone {_ * 0.1:.1f} s after the command ended")

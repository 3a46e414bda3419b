"""Run several benchmarks at once: one worker process per benchmark, the longest first.

``sindybench run all`` spends minutes of one core per benchmark, and the benchmarks share
nothing but the code: each is loaded, searched, fitted, scored and written on its own. So
they run in worker processes (joblib's loky backend), the longest first (a greedy
longest-processing-time schedule: the next benchmark goes to the first worker that is free),
and each worker writes its benchmark's files into the run's staging folder. The results
come back in the benchmarks' own order, so ``report.md`` and every file are the same as
those of a run of one benchmark after the other (the times they report aside).

The common numba kernels are compiled first, side by side in the workers (:func:`warm_up`), so
that two benchmarks starting together do not both compile them; each worker then compiles the
other kernels it needs, and saves them in numba's on-disk cache, which both workers share:
they save under one file lock of the run (:func:`sindybench._numba_cache.lock_numba_cache`,
which says why).
"""

import logging
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

from threadpoolctl import threadpool_limits

from .._numba_cache import lock_numba_cache
from .._progress import ENV_VAR as PROGRESS_ENV_VAR
from ._report import write_results
from ._runner import run_benchmark, test_sets
from ._warnings import collect_warnings

__all__ = ["longest_first", "run_and_write", "run_in_workers", "run_serially", "warm_up", "worker_count"]

logger = logging.getLogger(__name__)


def longest_first(costs):
    """The order in which to start jobs of the given ``costs``: the longest first, ties in their given order.

    Handing the next job to the first free worker in this order is the greedy
    longest-processing-time schedule, within 4/3 of the shortest possible wall
    time (Graham, 1969).

    Examples
    --------
    >>> longest_first([11.6, 73.3, 39.0, 38.0, 73.3])
    [1, 4, 2, 3, 0]
    """
    return sorted(range(len(costs)), key=lambda i: (-costs[i], i))


def worker_count(jobs, n_tasks):
    """The number of worker processes for ``n_tasks`` jobs: ``jobs`` (``-1``: every core), at most ``n_tasks``.

    Examples
    --------
    >>> worker_count(1, 6), worker_count(4, 2)
    (1, 2)
    >>> worker_count(0, 6)
    Traceback (most recent call last):
    ...
    ValueError: jobs must be a positive integer or -1 (every core); got 0.
    """
    from joblib import cpu_count

    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs == 0 or jobs < -1:
        raise ValueError(f"jobs must be a positive integer or -1 (every core); got {jobs!r}.")
    return max(1, min(cpu_count() if jobs == -1 else jobs, n_tasks))


def run_and_write(benchmark, data, folder, **settings):
    """Run one benchmark (:func:`run_benchmark` with ``settings``) and write its files into ``folder``.

    Returns
    -------
    dict
        The results with the written files (:func:`write_results`).
    """
    with collect_warnings() as said:
        results, fitted, simulations = run_benchmark(benchmark, data=data, **settings)
    for entry in said:  # the terminal hears each once, and not at all with -q (the report keeps them)
        logger.info("%s: %s%s", entry["category"], entry["message"],
                    f" ({entry['count']} times)" if entry["count"] > 1 else "")
    results = dict(results, warnings=said)
    folder = Path(folder)
    folder.mkdir()
    tests = {k: v for k, v in test_sets(data).items() if k in results["test_sets"]}
    return write_results(results, fitted, simulations, tests, folder, hysteresis_test=benchmark.hysteresis_test)


def _worker_setup(lock_file, log_level, log_to_stderr, optuna_verbosity, prefix):
    """In a worker: Ctrl-C is the parent's to handle, numba's cache saves under the run's lock, logs as the parent's."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent stops the workers and says "interrupted" once
    # no bars (two would garble one line); the estimators keep show_progress_bar, so the model files stay the same
    os.environ[PROGRESS_ENV_VAR] = "0"
    lock_numba_cache(lock_file)
    root = logging.getLogger("sindybench")
    if log_to_stderr:  # the command's log lines, each naming its benchmark
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter(f"[{prefix}] %(message)s"))
        root.handlers[:] = [handler]
        root.propagate = False
    root.setLevel(log_level)
    if optuna_verbosity is not None:
        import optuna

        optuna.logging.set_verbosity(optuna_verbosity)


def _timed(index, benchmark, data, folder, settings):
    """``(index, results, wall seconds, CPU seconds of this process)`` of :func:`run_and_write`."""
    start, cpu = time.perf_counter(), time.process_time()
    results = run_and_write(benchmark, data, folder, **settings)
    return index, results, time.perf_counter() - start, time.process_time() - cpu


def _log_done(count, total, benchmark, seconds, cpu, start):
    logger.info("done %d/%d: %s in %.0f s, %.0f s of CPU (%.0f s since the start)", count, total, benchmark.name,
                seconds, cpu, time.perf_counter() - start)


def _in_worker(index, benchmark, data, folder, settings, setup):
    _worker_setup(*setup, prefix=benchmark.name)
    # one BLAS thread, as in the serial run (a thread count would change the rounding of the results)
    with threadpool_limits(limits=1, user_api="blas"):
        return _timed(index, benchmark, data, folder, settings)


def run_serially(benchmarks, data, staging, *, settings):
    """Run ``benchmarks`` one after the other in this process; as :func:`run_in_workers` otherwise."""
    done, start = [], time.perf_counter()
    for i, benchmark in enumerate(benchmarks):
        logger.info("== %s ==", benchmark.title)
        _, results, seconds, cpu = _timed(i, benchmark, data[benchmark.name], Path(staging) / benchmark.name, settings)
        done.append(results)
        _log_done(i + 1, len(benchmarks), benchmark, seconds, cpu, start)
    return done


def _parent_setup(lock_file):
    root = logging.getLogger("sindybench")
    optuna = sys.modules.get("optuna")
    verbosity = optuna.logging.get_verbosity() if optuna is not None else None
    return lock_file, root.getEffectiveLevel(), bool(root.handlers), verbosity


def warm_up(n_workers):
    """Compile the common numba kernels (:func:`sindybench.warm.warm`) in ``n_workers`` processes side by side.

    On a fresh cache, benchmarks that start together would each compile the
    kernels they share (the simulation and its sensitivities, the
    prediction-error predictor, the Kalman filter: about 40 s of CPU, the same
    in every worker that reaches a kernel before another has saved it), so
    :func:`run_in_workers` compiles them once first; on a warm cache this loads
    them (a fraction of a second). The machine code is the same either way: no
    result changes.
    """
    from ..warm import warm

    start = time.perf_counter()
    seconds = warm(n_jobs=n_workers)
    logger.info("the common numba kernels compiled or loaded first: %.0f s, %.0f s of CPU",
                time.perf_counter() - start, sum(seconds.values()))


def run_in_workers(benchmarks, data, staging, n_workers, *, costs, settings):
    """Run ``benchmarks`` in ``n_workers`` processes, the longest (by ``costs``) first.

    Each writes into ``staging/<benchmark name>``; the workers show no
    progress bars (the log says when each benchmark starts and ends).

    Returns
    -------
    list of dict
        The written results (:func:`run_and_write`), in the order of ``benchmarks``.
    """
    from joblib import Parallel, delayed

    order = longest_first(costs)
    done = [None] * len(benchmarks)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="sindybench-run-") as tmp:
        setup = _parent_setup(Path(tmp) / "numba-cache.lock")
        warm_up(n_workers)
        logger.info("%d benchmarks in %d worker processes, the longest first: %s", len(benchmarks), n_workers,
                    ", ".join(benchmarks[i].name for i in order))
        tasks = (delayed(_in_worker)(i, benchmarks[i], data[benchmarks[i].name], Path(staging) / benchmarks[i].name,
                                     settings, setup) for i in order)
        parallel = Parallel(n_jobs=n_workers, backend="loky", batch_size=1, pre_dispatch="n_jobs",
                            return_as="generator_unordered")
        for count, (i, results, seconds, cpu) in enumerate(parallel(tasks), 1):
            done[i] = results
            _log_done(count, len(benchmarks), benchmarks[i], seconds, cpu, start)
    return done

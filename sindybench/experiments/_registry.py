"""The registry of benchmarks and the multi-benchmark runner used by the CLI."""

import importlib
import logging
import time
from pathlib import Path

from threadpoolctl import threadpool_limits

from .._numba_cache import numba_cache_lockable
from ._parallel import run_in_workers, run_serially, worker_count
from ._report import check_output_dir, staged_output_dir
from ._report import write_report as _write_report
from ._runner import load_data

__all__ = ["BENCHMARKS", "get_benchmark", "run_benchmarks"]

logger = logging.getLogger(__name__)

# CLI name -> module defining ``BENCHMARK`` (imported lazily: each pulls in its estimators)
BENCHMARKS = {
    "pick-and-place": "sindybench.experiments.pick_and_place",
    "pick-and-place-nss": "sindybench.experiments.pick_and_place_nss",
    "bouc-wen": "sindybench.experiments.bouc_wen",
    "cascaded-tanks": "sindybench.experiments.cascaded_tanks",
    "emps": "sindybench.experiments.emps",
    "silverbox": "sindybench.experiments.silverbox",
}


def get_benchmark(name):
    """Return the :class:`Benchmark` called ``name``.

    Examples
    --------
    >>> get_benchmark("cascaded-tanks").title
    'Cascaded tanks'
    >>> get_benchmark("tanks")
    Traceback (most recent call last):
    ...
    ValueError: unknown benchmark 'tanks'; expected one of ['bouc-wen', 'cascaded-tanks', 'emps', 'pick-and-place', 'pick-and-place-nss', 'silverbox'].
    """
    if name not in BENCHMARKS:
        raise ValueError(f"unknown benchmark {name!r}; expected one of {sorted(BENCHMARKS)}.")
    return importlib.import_module(BENCHMARKS[name]).BENCHMARK


def run_benchmarks(benchmarks, out, *, trials=None, seed=0, quick=False, storage=None, n_jobs=1, jobs=1,
                   data_home=None, download_if_missing=True, show_progress_bar=False, write_report=None):
    """Run several benchmarks and write their results under ``out``.

    The storage, the seed and the output folder are checked, all records
    are loaded and the storage is opened first, so a bad storage, a seed
    numpy cannot take (>= 2**32), an output path that is a file, or missing
    data fail before any training.
    Results go to ``out/<benchmark>/`` (``results.json``, ``results.md``,
    ``models/``, figures) and, with several benchmarks, ``out/report.md``.
    Files appear only when the whole run succeeded; files in ``out`` that the
    run does not write are kept (see :func:`staged_output_dir`).

    Parameters
    ----------
    benchmarks : list of Benchmark
    out : path-like
    trials, seed, quick, storage, n_jobs, show_progress_bar
        Passed to :func:`run_benchmark`.
    jobs : int, default=1
        Benchmarks run at once, each in a worker process, the longest (by
        ``Benchmark.cost``) first; ``-1``: one per core. The files are
        those of a run of one benchmark after the other (the times they
        report aside); ``1`` runs them one after the other in this process.
    data_home : path-like, optional
    download_if_missing : bool, default=True
    write_report : bool, optional
        Write ``report.md`` (default: with more than one benchmark).

    Returns
    -------
    Path
        ``out/report.md`` when written, else the single benchmark's ``results.md``.
    """
    from .._validation import check_integer
    from ..model_selection import check_storage
    from ..model_selection._storage import make_storage
    from ..model_selection._tune import MAX_SEED

    check_storage(storage)
    check_integer(seed, "seed", low=0, high=MAX_SEED - 1)
    n_workers = worker_count(jobs, len(benchmarks))
    out = Path(out)
    write_report_md = len(benchmarks) > 1 if write_report is None else write_report
    entries = {"report.md": "file", "index.html": "file"} if write_report_md else {}
    for b in benchmarks:
        entries.update({b.name: "dir", f"{b.name}/models": "dir", f"{b.name}/results.json": "file",
                        f"{b.name}/results.md": "file", f"{b.name}/report.html": "file"})
    check_output_dir(out, entries)
    data = {b.name: load_data(b, data_home=data_home, download_if_missing=download_if_missing) for b in benchmarks}
    if storage is not None:
        make_storage(storage)  # a database that cannot be opened fails here, before any training
    settings = dict(trials=trials, seed=seed, quick=quick, storage=storage, n_jobs=n_jobs,
                    show_progress_bar=show_progress_bar)
    if n_workers > 1 and not numba_cache_lockable():
        logger.warning("one benchmark after the other: this numba has no cache method to lock for two processes")
        n_workers = 1
    start = time.perf_counter()
    # one BLAS thread: the study's products are small, so threads only add overhead (many times over on a
    # busy machine), and a thread count would change the rounding of the results
    with staged_output_dir(out) as tmp, threadpool_limits(limits=1, user_api="blas"):
        if n_workers > 1:
            all_results = run_in_workers(benchmarks, data, tmp, n_workers, costs=[b.cost for b in benchmarks],
                                         settings=settings)
        else:
            all_results = run_serially(benchmarks, data, tmp, settings=settings)
        if write_report_md:
            _write_report(all_results, tmp / "report.md", wall_time_s=time.perf_counter() - start)
    if write_report_md:
        return out / "report.md"
    return out / benchmarks[0].name / "results.md"

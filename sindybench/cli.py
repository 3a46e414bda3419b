"""Command line interface: ``sindybench run <benchmark>``.

Reproduces the benchmarking study on one or all of its benchmarks and writes
results, fitted models, figures and reports into an output folder. This is a
leaf module: nothing in the library imports it.

Examples
--------
.. code-block:: console

    $ sindybench run all                       # default budgets (a few minutes on 2 cores)
    $ sindybench run cascaded-tanks --quick    # a smoke run, seconds
    $ sindybench run bouc-wen --trials 200 --storage sqlite:///bw.db --n-jobs 2
"""

import argparse
import logging
import sys
import time
from pathlib import Path

from . import __version__

__all__ = ["build_parser", "main"]

BENCHMARK_NAMES = ("pick-and-place", "bouc-wen", "cascaded-tanks")
logger = logging.getLogger("sindybench.cli")


def _non_negative_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0; got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0; got {value}")
    return value


def _n_jobs(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer or -1 (all cores); got {text!r}") from None
    if value == 0 or value < -1:
        raise argparse.ArgumentTypeError(f"expected a positive integer or -1 (all cores); got {value}")
    return value


def _storage(text):
    from .model_selection import check_storage

    try:
        return check_storage(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def build_parser():
    """Return the argument parser of the ``sindybench`` command."""
    parser = argparse.ArgumentParser(
        prog="sindybench",
        description="SINDy with control for hidden states and hard nonlinearities: "
        "reproduce the benchmarking study (Raffa Ugolini et al., 2024).",
    )
    parser.add_argument("--version", action="version", version=f"sindybench {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="command")
    run = sub.add_parser(
        "run",
        help="train, evaluate and report the study's models on a benchmark",
        description="Train every model of the study's table on a benchmark, evaluate it by open-loop "
        "simulation on every test set, and write results.json, results.md, models/*.json and PNG "
        "figures into OUT/<benchmark>/ ('all' also writes OUT/report.md).",
    )
    run.add_argument("benchmark", choices=(*BENCHMARK_NAMES, "all"), help="benchmark to run")
    run.add_argument("--trials", type=_non_negative_int, default=None, metavar="N",
                     help="search trials per model (default: each model's own budget)")
    run.add_argument("--seed", type=_non_negative_int, default=0, metavar="S", help="random seed (default: 0)")
    run.add_argument("--storage", type=_storage, default=None, metavar="URL",
                     help="Optuna storage URL, e.g. sqlite:///study.db, to resume or share searches")
    run.add_argument("--n-jobs", type=_n_jobs, default=1, metavar="J", help="parallel trials per search")
    run.add_argument("--out", type=Path, default=Path("sindybench_results"), metavar="DIR",
                     help="output folder (default: ./sindybench_results)")
    run.add_argument("--quick", action="store_true", help="small budgets: a smoke run of a few minutes")
    run.add_argument("--data-home", type=Path, default=None, metavar="DIR",
                     help="folder with the benchmark records (default: $SINDYBENCH_DATA or the data home)")
    run.add_argument("--no-download", action="store_true", help="never try to download a missing record")
    run.add_argument("--no-progress", action="store_true",
                     help="no progress bars (drawn only when stderr is a terminal; SINDYBENCH_PROGRESS=0 too)")
    run.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors on stderr")
    return parser


def _configure_logging(quiet):
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(message)s"))
    root = logging.getLogger("sindybench")
    root.handlers[:] = [handler]
    root.setLevel(logging.WARNING if quiet else logging.INFO)
    root.propagate = False
    import optuna  # a dependency of sindybench; imported here so that --help stays fast

    optuna.logging.set_verbosity(optuna.logging.WARNING)


def _run(args):
    from .experiments import get_benchmark, run_benchmarks

    names = BENCHMARK_NAMES if args.benchmark == "all" else (args.benchmark,)
    benchmarks = [get_benchmark(name) for name in names]
    start = time.perf_counter()
    report = run_benchmarks(
        benchmarks, args.out, trials=args.trials, seed=args.seed, quick=args.quick, storage=args.storage,
        n_jobs=args.n_jobs, data_home=args.data_home, download_if_missing=not args.no_download,
        show_progress_bar=not (args.no_progress or args.quiet), write_report=args.benchmark == "all",
    )
    elapsed = time.perf_counter() - start
    print(report.read_text() if report.suffix == ".md" else report)
    logger.info("wrote %s in %.0f s", args.out.resolve(), elapsed)
    return 0


def main(argv=None):
    """Entry point of the ``sindybench`` console script.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 on success, 2 when data are missing or an argument is bad.
    """
    args = build_parser().parse_args(argv)
    _configure_logging(args.quiet)
    from .experiments import DataNotFoundError

    try:
        return _run(args)
    except DataNotFoundError as exc:
        print(f"sindybench: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("sindybench: interrupted; no output written.", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

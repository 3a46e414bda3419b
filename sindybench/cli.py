"""Command line interface: ``sindybench run <benchmark>`` and ``sindybench simulate MODEL.json``.

``run`` reproduces the benchmarking study on one or all of its benchmarks and
writes results, fitted models, figures and reports into an output folder.
``simulate`` runs a saved model (a file of :func:`sindybench.load_model`, e.g.
one of ``run``'s ``models/*.json``) on an input record from a CSV file. This
is a leaf module: nothing in the library imports it.

Examples
--------
.. code-block:: console

    $ sindybench run all                       # default budgets (a few minutes on 2 cores)
    $ sindybench run cascaded-tanks --quick    # a smoke run, seconds
    $ sindybench run bouc-wen --trials 200 --storage sqlite:///bw.db --n-jobs 2
    $ sindybench simulate out/cascaded-tanks/models/arx.json --input u.csv --output y.csv --y-init y0.csv
"""

import argparse
import csv
import io
import logging
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

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
    sim = sub.add_parser(
        "simulate",
        help="simulate a saved model on an input record (CSV)",
        description="Load MODEL.json (written by model.to_json or by 'sindybench run'), simulate it open loop "
        "on the inputs of --input and write the simulated outputs to --output. CSV files have a header row and "
        "one row per sample. The input columns are taken by name when the model names its inputs, else in order.",
    )
    sim.add_argument("model", type=Path, metavar="MODEL.json", help="saved model")
    sim.add_argument("--input", type=Path, required=True, metavar="FILE.csv",
                     help="input record: one column per input of the model")
    sim.add_argument("--output", type=Path, required=True, metavar="FILE.csv",
                     help="where to write the simulated outputs (one column per output)")
    sim.add_argument("--y-init", type=Path, default=None, metavar="FILE.csv",
                     help="first measured output samples (one column per output) to start from; "
                     "default: the model's own initial state")
    sim.add_argument("--allow-import", action="store_true",
                     help="import the module-level Python function the model names (ParametricHiddenState)")
    sim.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors on stderr")
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


def _read_csv(path, what):
    """``(header, data)`` of a CSV file with a header row; ``ValueError`` naming line and column."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = [row for row in csv.reader(f) if row]
    if len(rows) < 2:
        raise ValueError(f"{what} {path} has no samples; expected a header row and one row per sample.")
    header = [name.strip() for name in rows[0]]
    data = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise ValueError(f"{what} {path}, line {i + 2}: {len(row)} values; expected {len(header)} "
                             f"(one per column of the header {header}).")
        for j, text in enumerate(row):
            try:
                value = float(text)
            except ValueError:
                value = None
            if value is None or not math.isfinite(value):
                raise ValueError(f"{what} {path}, line {i + 2}, column {header[j]!r}: {text.strip()!r}; "
                                 "expected a finite number (no NaN, no empty cell).")
            data[i, j] = value
    return header, data


def _model_inputs(model, header, data, path):
    """The columns of the input file that feed ``model``, in the model's order."""
    n_inputs = int(model.n_features_in_)
    names = getattr(model, "input_names", None)  # a SINDy model with named inputs
    if names is None and getattr(model, "feature_names_in_", None) is not None:
        names = [str(name) for name in model.feature_names_in_]
    if names is not None:
        missing = [name for name in names if name not in header]
        if missing:
            raise ValueError(f"input {path} has no column {missing[0]!r}; expected the model's inputs {list(names)} "
                             f"(found {header}).")
        return data[:, [header.index(name) for name in names]]
    if n_inputs == 0:  # an autonomous model: the file only gives the number of samples
        return data[:, :0]
    if len(header) != n_inputs:
        raise ValueError(f"input {path} has {len(header)} column(s) {header}; the model has {n_inputs} input(s): "
                         f"expected {n_inputs} column(s), in the order of the model's inputs.")
    return data


def _output_names(model, n_outputs):
    index = getattr(model, "output_index_", None)
    names = None if index is None else [model.state_names_[i] for i in index]
    return list(names) if names is not None and len(names) == n_outputs else [f"y{i}" for i in range(n_outputs)]


def _simulate(args):
    from . import load_model
    from .io import write_text_atomic

    model = load_model(args.model, allow_import=args.allow_import)
    header, data = _read_csv(args.input, "input")
    X = _model_inputs(model, header, data, args.input)
    y_init = None if args.y_init is None else _read_csv(args.y_init, "--y-init")[1]
    if y_init is not None:
        y_pred = model.predict(X, y_init=y_init)
    elif getattr(model, "x0_", None) is not None:  # the model's own initial state is what was asked for
        y_pred = model.predict(X, x0=model.x0_)
    else:
        with warnings.catch_warnings():  # the model's own initial state is what was asked for
            warnings.filterwarnings("ignore", message="predict without")
            y_pred = model.predict(X)
    y_pred = np.asarray(y_pred, dtype=float).reshape(X.shape[0], -1)
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(_output_names(model, y_pred.shape[1]))
    writer.writerows([repr(float(v)) for v in row] for row in y_pred)
    write_text_atomic(text.getvalue(), args.output)
    n_bad = int(np.sum(~np.all(np.isfinite(y_pred), axis=1)))
    if n_bad:
        logger.warning("the simulation diverged: %d of %d samples are NaN", n_bad, len(y_pred))
    logger.info("wrote %d samples of %d output(s) to %s", y_pred.shape[0], y_pred.shape[1], args.output)
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
        Exit status: 0 on success, 2 when data are missing, an argument is bad, or (``simulate``)
        a file cannot be read or does not fit the model.
    """
    args = build_parser().parse_args(argv)
    _configure_logging(args.quiet)
    if args.command == "simulate":
        try:
            return _simulate(args)
        except (OSError, ValueError) as exc:  # unreadable or bad files: say what, write nothing
            print(f"sindybench: error: {exc}", file=sys.stderr)
            return 2
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

"""Command line interface: ``sindybench run <benchmark>``, ``simulate MODEL.json``, ``identify DATA`` and ``report``.

``run`` reproduces the benchmarking study on one or all of its benchmarks and
writes results, fitted models, figures and reports into an output folder.
``simulate`` runs a saved model (a file of :func:`sindybench.load_model`, e.g.
one of ``run``'s ``models/*.json``) on an input record from a CSV file.
``identify`` identifies a model from a CSV record (or a dataset) and writes
its model file and HTML report; ``report`` writes the report of a saved model
later (both in :mod:`sindybench._cli_identify`). This is a leaf module:
nothing in the library imports it.

Examples
--------
.. code-block:: console

    $ sindybench run all                       # default budgets (a few minutes on 2 cores)
    $ sindybench run all --jobs 1              # the benchmarks one after the other, in this process
    $ sindybench run cascaded-tanks --quick    # a smoke run, seconds
    $ sindybench run bouc-wen --trials 200 --storage sqlite:///bw.db --n-jobs 2
    $ sindybench simulate out/cascaded-tanks/models/arx.json --input u.csv --output y.csv --y-init y0.csv
    $ sindybench identify data.csv --dt 0.01 --inputs u1,u2 --outputs y --test test.csv -o model.json --report report.html
    $ sindybench report model.json data.csv --test test.csv -o report.html
"""

import argparse
import csv
import io
import json
import logging
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from sindybench_launcher import _caused_by_interrupt as _interrupted  # one test of a Ctrl-C's chain, the launcher's
from ._cli_args import _load, _n_jobs, _non_negative_int, _read_csv, _same_file, _seed, _storage
from ._version import __version__
from .experiments import BENCHMARKS  # the one list of benchmark names

__all__ = ["build_parser", "main"]

logger = logging.getLogger("sindybench.cli")


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
    run.add_argument("benchmark", choices=(*BENCHMARKS, "all"), help="benchmark to run")
    run.add_argument("--trials", type=_non_negative_int, default=None, metavar="N",
                     help="search trials per model (default: each model's own budget)")
    run.add_argument("--seed", type=_seed, default=0, metavar="S", help="random seed, 0 to 2**32 - 1 (default: 0)")
    run.add_argument("--storage", type=_storage, default=None, metavar="URL",
                     help="Optuna storage URL, e.g. sqlite:///study.db, to resume or share searches")
    run.add_argument("--n-jobs", type=_n_jobs, default=1, metavar="J", help="parallel trials per search")
    run.add_argument("--jobs", type=_n_jobs, default=-1, metavar="J",
                     help="benchmarks run at once, each in a worker process, the longest first (default: -1, one "
                     "per core; 1: one after the other in this process); the files are the same either way")
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
        "on the inputs of --input and write the simulated outputs to --output. CSV files have one row per sample, "
        "after a header row naming the columns (a file whose first row is numbers has none). The input columns are "
        "taken by name when the model names its inputs and the file has a header, else in order.",
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
                     help="import the module-level Python function the model names (ParametricHiddenState); "
                     "modules in the current folder can be imported too")
    sim.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors on stderr")
    from ._cli_identify import add_parsers  # it reads this module's argument types and CSV reader

    add_parsers(sub)
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
    for optuna_handler in logging.getLogger("optuna").handlers:
        optuna_handler.addFilter(_not_an_interrupt)


def _not_an_interrupt(record):
    """Drop Optuna's "Trial n failed" record of a Ctrl-C (with its traceback): the command says it once."""
    return not (record.exc_info and isinstance(record.exc_info[1], KeyboardInterrupt))


def _run(args):
    from .experiments import get_benchmark, run_benchmarks

    names = tuple(BENCHMARKS) if args.benchmark == "all" else (args.benchmark,)
    benchmarks = [get_benchmark(name) for name in names]
    start = time.perf_counter()
    report = run_benchmarks(
        benchmarks, args.out, trials=args.trials, seed=args.seed, quick=args.quick, storage=args.storage,
        n_jobs=args.n_jobs, jobs=args.jobs, data_home=args.data_home, download_if_missing=not args.no_download,
        show_progress_bar=not (args.no_progress or args.quiet), write_report=args.benchmark == "all",
    )
    elapsed = time.perf_counter() - start
    print(report.read_text() if report.suffix == ".md" else report)
    logger.info("wrote %s in %.0f s", args.out.resolve(), elapsed)
    failed = _failed_models(args.out, names)
    if failed:
        print(f"sindybench: error: {len(failed)} model(s) could not be fitted, their rows read '(not fitted)':\n"
              + "\n".join(f"  {name}: {status}" for name, status in failed), file=sys.stderr)
        return 1
    return 0


def _failed_models(out, names):
    """``[(benchmark/model, status)]`` of the models that a run's ``results.json`` files record as not fitted."""
    failed = []
    for name in names:
        results = json.loads((out / name / "results.json").read_text())
        failed += [(f"{name}/{m['key']}", m["status"]) for m in results["models"] if m["status"] != "ok"]
    return failed


def _model_inputs(model, header, data, path):
    """The columns of the input file that feed ``model``, in the model's order."""
    n_inputs = int(model.n_features_in_)
    names = getattr(model, "input_names", None)  # a SINDy model with named inputs
    if names is None and getattr(model, "feature_names_in_", None) is not None:
        names = [str(name) for name in model.feature_names_in_]
    if names is None:  # a model of 'sindybench identify': the columns it was identified on
        names = _identified_columns(model, "inputs", n_inputs)
    if names is not None and header is not None:
        missing = [name for name in names if name not in header]
        if missing:
            raise ValueError(f"input {path} has no column {missing[0]!r}; expected the model's inputs {list(names)} "
                             f"(found {header}).")
        twice = [name for name in names if header.count(name) > 1]
        if twice:
            raise ValueError(f"input {path} has the column {twice[0]!r} more than once; expected each input once.")
        return data[:, [header.index(name) for name in names]]
    if n_inputs == 0:  # an autonomous model: the file only gives the number of samples
        return data[:, :0]
    if data.shape[1] != n_inputs:
        found = (f"{len(header)} column(s) {header}" if header is not None
                 else f"{data.shape[1]} column(s) and no header row")
        order = f"the model's inputs {list(names)}" if names is not None else "the model's inputs"
        raise ValueError(f"input {path} has {found}; the model has {n_inputs} input(s): expected {n_inputs} "
                         f"column(s), in the order of {order}" + (" (or a header row naming them)." if names else "."))
    return data


def _identified_columns(model, which, n):
    """The CSV columns (``"inputs"`` or ``"outputs"``) ``sindybench identify`` fitted ``model`` on, or None."""
    record = getattr(model, "identification_", None)
    cli = record.get("cli") if isinstance(record, dict) else None
    names = cli.get(which) if isinstance(cli, dict) and not cli.get("dataset") else None
    ok = isinstance(names, list) and len(names) == n and all(isinstance(name, str) for name in names)
    return list(names) if ok else None


def _output_names(model, n_outputs):
    identified = _identified_columns(model, "outputs", n_outputs)
    if identified is not None:
        return identified
    index = getattr(model, "output_index_", None)
    names = None if index is None else [model.state_names_[i] for i in index]
    return list(names) if names is not None and len(names) == n_outputs else [f"y{i}" for i in range(n_outputs)]


def _predict(model, X, y_init, args):
    try:
        if y_init is not None:
            return model.predict(X, y_init=y_init)
        if getattr(model, "x0_", None) is not None:  # the model's own initial state is what was asked for
            return model.predict(X, x0=model.x0_)
        with warnings.catch_warnings():  # the model's own initial state is what was asked for
            warnings.filterwarnings("ignore", message="predict without")
            return model.predict(X)
    except ValueError as exc:  # name the file the bad values came from
        if y_init is not None and "y_init" in str(exc):
            shape = f"{len(y_init)} row(s) of {y_init.shape[1]} value(s)"
            raise ValueError(f"--y-init {args.y_init} ({shape}): {exc}") from exc
        source = f"--input {args.input} ({len(X)} samples)"
        if y_init is not None:
            source += f" from --y-init {args.y_init}"
        raise ValueError(f"simulating {args.model} on {source}: {exc}") from exc


def _check_output(args):
    """Refuse an ``--output`` that is one of the files ``simulate`` reads (it would be replaced by the outputs)."""
    for option, path in (("MODEL.json", args.model), ("--input", args.input), ("--y-init", args.y_init)):
        if path is not None and _same_file(args.output, path):
            raise ValueError(f"--output {args.output} is the file of {option} ({path}); expected another file "
                             "(simulate never writes over what it reads).")


def _simulate(args):
    from .io import write_text_atomic

    _check_output(args)
    model = _load(args.model, args.allow_import)
    header, data = _read_csv(args.input, "input")
    X = _model_inputs(model, header, data, args.input)
    y_init = None if args.y_init is None else _read_csv(args.y_init, "--y-init")[1]
    y_pred = _predict(model, X, y_init, args)
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
        Exit status: 0 on success; 1 when ``run`` finished but some model could not be fitted
        (the run's files are written and the error names the models) or the storage stopped
        answering; 2 when data are missing, an argument, the output folder or the storage is
        bad, or (``simulate``, ``identify``, ``report``) a file cannot be read or does not fit the model,
        or an output file exists (``identify`` and ``report`` replace one only with ``--force``);
        130 on Ctrl-C (nothing written).
    """
    args = build_parser().parse_args(argv)
    try:  # from the first import on: a Ctrl-C at any time exits with 130, without a traceback
        return _command(args)
    except KeyboardInterrupt:
        print("sindybench: interrupted; no output written.", file=sys.stderr)
        return 130
    except Exception as exc:  # a cleanup that failed while a Ctrl-C unwound (Optuna's journal lock file)
        if not _interrupted(exc):
            raise
        print("sindybench: interrupted; no output written.", file=sys.stderr)
        return 130


def _command(args):
    _configure_logging(args.quiet)
    if args.command == "simulate":
        try:
            return _simulate(args)
        except (OSError, ValueError) as exc:  # unreadable or bad files: say what, write nothing
            if _interrupted(exc):
                raise
            print(f"sindybench: error: {exc}", file=sys.stderr)
            return 2
    from .experiments import DataNotFoundError

    if args.command in ("identify", "report"):
        from ._cli_identify import identify_command, report_command

        command = identify_command if args.command == "identify" else report_command
    else:
        command = _run
    try:
        return command(args)
    except ConnectionError as exc:  # the storage stopped answering: the finished trials are kept in it
        if _interrupted(exc):
            raise
        print(f"sindybench: error: {exc}\nNo output written.", file=sys.stderr)
        return 1
    except (DataNotFoundError, OSError, ValueError, ImportError) as exc:  # data, output folder, storage
        if _interrupted(exc):
            raise
        print(f"sindybench: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

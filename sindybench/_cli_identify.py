"""``sindybench identify`` and ``sindybench report``: from a CSV record (or a dataset) to a model file and a report.

``identify`` runs :class:`~sindybench.identify.IdentifyCV` on the columns of
a CSV file (or a benchmark's estimation record), prints the chosen equations
and, with a test record, the free run's scores; it writes the model file
(with its ``identification_`` record) and the HTML report only at the end,
each atomically, and never over an existing file unless ``--force``.
``report`` writes the report of a saved model later. Part of the command line
(:mod:`sindybench.cli`, which adds these commands to its parser): nothing in
the library imports it.
"""

import argparse
import json
import logging
import math
import sys
import time
from pathlib import Path

import numpy as np

from sindybench_launcher import _caused_by_interrupt as _interrupted  # one test of a Ctrl-C's chain

from ._cli_args import _n_jobs, _non_negative_int, _read_csv, _same_file, _seed, _storage
from .experiments import BENCHMARKS
from .identify._space import ALL_FAMILIES, FAMILIES, LIBRARIES

__all__ = ["add_parsers", "identify_command", "report_command"]

logger = logging.getLogger("sindybench.cli")

_DERIVATIVES = ("finite_difference", "savgol", "spectral")


def _positive_float(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0; got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0; got {text}")
    return value


def _fraction(text):
    value = _positive_float(text)
    if value > 1:
        raise argparse.ArgumentTypeError(f"expected a fraction in (0, 1]; got {text}")
    return value


def _positive_int(text):
    value = _non_negative_int(text)
    if value == 0:
        raise argparse.ArgumentTypeError("expected an integer >= 1; got 0")
    return value


def _names(options):
    """An argparse type: a comma-separated list of names from ``options``."""
    def parse(text):
        names = [name.strip() for name in text.split(",") if name.strip()]
        bad = [name for name in names if name not in options]
        if not names or bad:
            raise argparse.ArgumentTypeError(f"expected a comma-separated list of {', '.join(options)}; got {text!r}")
        return names
    return parse


def _columns_option(text):
    names = [name.strip() for name in text.split(",")]
    if not all(names):
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of column names or 0-based indices; "
                                         f"got {text!r}")
    return names


def _add_data_arguments(parser, what):
    parser.add_argument("--inputs", type=_columns_option, default=None, metavar="COLS",
                        help="input columns of a CSV file, by name (header row) or 0-based index, comma-separated: "
                        "u1,u2 or 0,1" + (" (default: those the model file records)" if what == "report" else ""))
    parser.add_argument("--outputs", type=_columns_option, default=None, metavar="COLS",
                        help="output columns, as --inputs" + (" (default: those the model file records)"
                                                               if what == "report" else ""))
    parser.add_argument("--test", default=None, metavar="TEST",
                        help="test record: a CSV file with the same columns (by name when both files have a header "
                        "row, else by index); for a dataset, the name of one of its test sets (default: its first)")
    parser.add_argument("-o", "--output", type=Path, required=what == "report", default=None,
                        metavar="REPORT.html" if what == "report" else "MODEL.json",
                        help="where to write the report" if what == "report" else
                        "where to write the model file (loads with sindybench.load_model; runs with "
                        "'sindybench simulate')")
    parser.add_argument("--force", action="store_true", help="replace existing output files (default: refuse)")
    parser.add_argument("--data-home", type=Path, default=None, metavar="DIR",
                        help="folder with the datasets' records (default: $SINDYBENCH_DATA or the data home)")
    parser.add_argument("--no-download", action="store_true", help="never try to download a missing dataset")
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors on stderr")


def add_parsers(sub):
    """Add the ``identify`` and ``report`` commands to the subparsers ``sub`` of :func:`sindybench.cli.build_parser`."""
    datasets = ", ".join(BENCHMARKS)
    ident = sub.add_parser(
        "identify",
        help="identify a model from a CSV record (or a dataset): model file, equations, report",
        description="Identify a model of the outputs from the inputs of DATA with sindybench.identify (IdentifyCV): "
        "a structure search scored by open-loop simulation of validation blocks at the end of the record, then the "
        "sparsest model within one standard error of the best, refitted on the whole record. Prints the equations "
        "(and the test scores with --test), writes the model file (-o) and the HTML report (--report) at the end. "
        "What is not given is decided by the data: the input delay and hold by the data advice (confirmed on "
        "validation), the derivative methods' bandwidth by the output's spectrum, the hard terms (square roots, "
        "saturation indicators, friction) by the features of the record. Ctrl-C exits with 130 and writes nothing "
        "(with --storage the evaluated candidates are kept: the same command resumes).",
        epilog="CSV files have one row per sample, an optional header row naming the columns, and finite numbers "
        f"only. DATA may also name a dataset ({datasets}): its official estimation record, dt and n_init, and its "
        "test set with --test NAME (default: the first).")
    ident.add_argument("data", metavar="DATA", help="a CSV file, or a dataset's name")
    ident.add_argument("--dt", type=_positive_float, default=None, metavar="DT",
                       help="sampling interval in seconds (required for a CSV file; a dataset gives its own)")
    _add_data_arguments(ident, "identify")
    ident.add_argument("--report", type=Path, default=None, metavar="REPORT.html",
                       help="also write the HTML report of the identification (one self-contained file)")
    ident.add_argument("--n-init", type=_positive_int, default=None, metavar="N",
                       help="first measured samples that start a simulation (validation blocks and test); default: "
                       "the dataset's protocol, else 20")
    search = ident.add_argument_group("search (IdentifyCV's parameters)")
    search.add_argument("--families", type=_names(ALL_FAMILIES), default=None, metavar="LIST",
                        help=f"model families among {', '.join(ALL_FAMILIES)} (default: {','.join(FAMILIES)})")
    search.add_argument("--libraries", type=_names(LIBRARIES), default=None, metavar="LIST",
                        help=f"libraries among {', '.join(LIBRARIES)} ('+hard': the terms the data proposes; "
                        "default: all)")
    search.add_argument("--derivatives", type=_names(_DERIVATIVES), default=None, metavar="LIST",
                        help=f"derivative methods among {', '.join(_DERIVATIVES)} (default: all three, their "
                        "bandwidth from the output's spectrum)")
    search.add_argument("--input-hold", choices=("zoh", "linear"), default=None,
                        help="input between samples (default: both searched, the data advice's first; validation "
                        "decides)")
    search.add_argument("--input-delay", type=_non_negative_int, default=None, metavar="K",
                        help="input delay in samples (default: the data advice's estimate, confirmed on validation "
                        "against none)")
    search.add_argument("--criterion", choices=("auto", "free_run", "k_step"), default=None,
                        help="how a candidate is scored on a validation block: its free run, or its k-step "
                        "prediction (default: auto: the k-step prediction when the data advice finds an open-loop "
                        "unstable output, else the free run; in versions whose IdentifyCV has it)")
    search.add_argument("--horizon", type=_positive_int, default=None, metavar="K",
                        help="the k-step criterion's horizon in samples (default: a quarter period of the outputs' "
                        "bandwidth)")
    search.add_argument("--n-blocks", type=_positive_int, default=3, metavar="N",
                        help="validation blocks at the end of the record (default: 3)")
    search.add_argument("--block-size", type=_fraction, default=0.15, metavar="F",
                        help="length of each block, a fraction of the record (default: 0.15)")
    search.add_argument("--max-path", type=_positive_int, default=12, metavar="N",
                        help="most sparsity levels on each structure's pruning path (default: 12)")
    search.add_argument("--screen-keep", type=_fraction, default=1 / 3, metavar="F",
                        help="fraction of the screened candidates scored on every block (default: 1/3)")
    search.add_argument("--screen-window", type=_positive_int, default=8000, metavar="N",
                        help="most training samples of a screening fit (default: 8000)")
    search.add_argument("--n-refine", type=_non_negative_int, default=4, metavar="N",
                        help="candidates refined by their simulation error (default: 4; 0: none)")
    search.add_argument("--max-terms", type=_positive_int, default=15, metavar="N",
                        help="most terms in one equation of the chosen model (default: 15)")
    search.add_argument("--time-budget", type=_positive_float, default=None, metavar="SECONDS",
                        help="seconds of search; the best candidate found by then is kept (default: no limit)")
    search.add_argument("--max-candidates", type=_positive_int, default=None, metavar="N",
                        help="most candidates evaluated (default: no limit)")
    search.add_argument("--random-state", type=_seed, default=None, metavar="S",
                        help="seed of the latent families' search of their start (default: 0; the other families "
                        "are deterministic)")
    search.add_argument("--storage", type=_storage, default=None, metavar="URL",
                        help="keep every evaluated candidate in an Optuna storage (sqlite:///search.db, a database "
                        "URL, or a journal file search.log): the same command resumes an interrupted search; several "
                        "processes (on one machine or, with a database, several) may run on one storage, each reading "
                        "back the candidates finished when its stages start")
    search.add_argument("--study-name", default=None, metavar="NAME",
                        help="the search's name in --storage (default: identify)")
    search.add_argument("--n-jobs", type=_n_jobs, default=None, metavar="J",
                        help="candidates evaluated in parallel (default: 1; -1: one per core)")
    search.add_argument("--no-progress", action="store_true",
                        help="no progress bar (drawn only when stderr is a terminal; SINDYBENCH_PROGRESS=0 too)")
    rep = sub.add_parser(
        "report",
        help="write the HTML report of a model file identified by 'sindybench identify'",
        description="Write the HTML report of MODEL.json (written by 'sindybench identify' or model.to_json after "
        "sindybench.identify: the file keeps its identification record) on the estimation record DATA, and on a "
        "test record with --test. The columns default to those the model file records.")
    rep.add_argument("model", type=Path, metavar="MODEL.json", help="saved model")
    rep.add_argument("data", metavar="DATA", help="the estimation record: a CSV file, or a dataset's name")
    _add_data_arguments(rep, "report")
    rep.add_argument("--title", default=None, help="the report's title (default: from the model and the data)")
    rep.add_argument("--allow-import", action="store_true",
                     help="import the module-level Python function the model names (ParametricHiddenState)")


# ------------------------------------------------------------------ records
class _Record:
    """The estimation record ``X, y``, ``dt``, ``n_init``, the optional test record and where the columns came from."""

    def __init__(self, X, y, dt, n_init, test, columns):
        self.X, self.y, self.dt, self.n_init, self.test, self.columns = X, y, dt, n_init, test, columns


def _is_dataset(data):
    return data in BENCHMARKS and not Path(data).exists()


def _column_indices(spec, header, n_columns, option, path):
    """0-based indices of the columns ``spec`` (names or indices) of a file with ``header`` (or None)."""
    indices = []
    for item in spec:
        if header is not None and item in header:
            if header.count(item) > 1:
                raise ValueError(f"{option}: the column {item!r} appears more than once in {path}; expected "
                                 "distinct column names (or give its 0-based index).")
            indices.append(header.index(item))
        elif item.isdigit() and item.isascii():
            if int(item) >= n_columns:
                raise ValueError(f"{option}: column index {item} is out of range: {path} has {n_columns} column(s) "
                                 f"(indices 0 to {n_columns - 1}).")
            indices.append(int(item))
        elif header is None:
            raise ValueError(f"{option}: {path} has no header row, so no column is named {item!r}; expected 0-based "
                             f"column indices (0 to {n_columns - 1}).")
        else:
            raise ValueError(f"{option}: {path} has no column {item!r}; expected names from its header {header} or "
                             "0-based indices.")
    if len(set(indices)) != len(indices):
        raise ValueError(f"{option}: a column is given twice ({spec}); expected each column once.")
    return indices


def _read_columns(path, what, inputs, outputs, reference=None):
    """``(X, y, header names of the inputs and outputs)`` of a CSV file."""
    header, data = _read_csv(path, what)
    if reference is not None and (header is None or reference[0] is None):  # a test file without names: by index
        i_in, i_out = reference[1], reference[2]
        if data.shape[1] <= max(i_in + i_out):
            raise ValueError(f"{what} {path} has {data.shape[1]} column(s); expected the columns {i_in + i_out} of "
                             "DATA (by index: one of the files has no header row).")
    else:
        i_in = _column_indices(inputs, header, data.shape[1], "--inputs", path)
        i_out = _column_indices(outputs, header, data.shape[1], "--outputs", path)
    both = sorted(set(i_in) & set(i_out))
    if both:
        raise ValueError(f"--inputs and --outputs both take column {both[0]} of {path}; expected distinct columns.")
    names = (lambda idx: [header[i] if header is not None else str(i) for i in idx])
    return data[:, i_in], data[:, i_out], (header, i_in, i_out, names(i_in), names(i_out))


def _dataset(args, n_init):
    from .experiments import get_benchmark, load_data, test_sets

    if args.inputs is not None or args.outputs is not None:
        raise ValueError(f"--inputs / --outputs: the dataset {args.data!r} gives its own columns; expected neither "
                         "(they select the columns of a CSV file).")
    benchmark = get_benchmark(args.data)
    data = load_data(benchmark, data_home=args.data_home, download_if_missing=not args.no_download)
    dt = float(data["dt"])
    if getattr(args, "dt", None) is not None and not math.isclose(args.dt, dt, rel_tol=1e-9):
        raise ValueError(f"--dt {args.dt}: the dataset {args.data!r} is sampled at dt = {dt:g}; expected no --dt "
                         "(or that value).")
    est = data["estimation"]
    X, y = (np.asarray(est[k], float).reshape(len(est["y"]), -1) for k in ("u", "y"))
    tests = test_sets(data)
    name = args.test if args.test is not None else next(iter(tests))
    if name not in tests:
        raise ValueError(f"--test {name!r}: the dataset {args.data!r} has the test sets {list(tests)}; expected one "
                         "of them.")
    test = tests[name]
    Xt, yt = (np.asarray(test[k], float).reshape(len(test["y"]), -1) for k in ("u", "y"))
    if n_init is None:
        n_init = next(int(v) for v in (test.get("n_init"), data.get("n_init"), benchmark.n_init, 20) if v is not None)
    score_from = test.get("score_from")
    columns = {"data": args.data, "dataset": True, "test": name,
               "inputs": [f"u{j}" for j in range(X.shape[1])], "outputs": [f"y{j}" for j in range(y.shape[1])]}
    return _Record(X, y, dt, n_init, (Xt, yt, 0 if score_from is None else int(score_from), name), columns)


def read_record(args, *, dt=None, n_init=None, recorded=None):
    """The estimation and test records the arguments name (a CSV file with columns, or a dataset)."""
    if _is_dataset(args.data):
        return _dataset(args, n_init)
    path = Path(args.data)
    if not path.is_file():
        raise ValueError(f"DATA {args.data}: no such file; expected a CSV file or a dataset's name "
                         f"({', '.join(BENCHMARKS)}).")
    inputs, outputs = args.inputs, args.outputs
    if recorded is not None and not recorded.get("dataset"):  # report: the columns the model file records
        inputs = inputs if inputs is not None else recorded.get("inputs")
        outputs = outputs if outputs is not None else recorded.get("outputs")
    missing = [opt for opt, v in (("--inputs", inputs), ("--outputs", outputs)) if v is None]
    if missing:
        raise ValueError(f"{' and '.join(missing)} missing: expected the columns of {path} to use (names or 0-based "
                         "indices, e.g. --inputs u1,u2 --outputs y).")
    if dt is None:
        raise ValueError(f"--dt missing: expected the sampling interval of {path} in seconds (e.g. --dt 0.01).")
    X, y, ref = _read_columns(path, "DATA", inputs, outputs)
    n_init = 20 if n_init is None else n_init
    test = None
    if args.test is not None:
        test_path = Path(args.test)
        Xt, yt, _ = _read_columns(test_path, "--test", inputs, outputs, reference=ref[:3])
        if len(yt) <= n_init:
            raise ValueError(f"--test {test_path} has {len(yt)} sample(s); expected more than the {n_init} that "
                             "start the simulation (--n-init).")
        test = (Xt, yt, 0, str(test_path))
    columns = {"data": str(path), "dataset": False, "test": args.test, "inputs": ref[3], "outputs": ref[4]}
    return _Record(X, y, dt, n_init, test, columns)


# ------------------------------------------------------------------ outputs
def check_outputs(args, reads):
    """Refuse, before any work, an output file that exists (without ``--force``), is an input, or has no folder."""
    outputs = [(opt, p) for opt, p in (("-o", args.output), ("--report", getattr(args, "report", None)))
               if p is not None]
    if len(outputs) == 2 and _same_file(outputs[0][1], outputs[1][1]):
        raise ValueError(f"-o and --report are the same file ({args.output}); expected two files.")
    for option, path in outputs:
        for read in reads:
            if read is not None and Path(read).exists() and _same_file(path, read):
                raise ValueError(f"{option} {path} is the file {read} that the command reads; expected another file.")
        if path.exists() and not args.force:
            raise ValueError(f"{option} {path} exists; pass --force to replace it (nothing was run).")
        if not path.parent.is_dir():
            raise ValueError(f"{option} {path}: the folder {path.parent} does not exist; expected an existing folder.")


def _report_function():
    """``sindybench.report.identification_report`` (imported when asked for: the report module is optional here)."""
    try:
        from .report import identification_report
    except ImportError as exc:
        raise ValueError(f"the HTML report (sindybench.report) is not available in this installation ({exc}); "
                         "expected sindybench with its report module.") from exc
    return identification_report


def _report_html(model, record, title):
    test = None if record.test is None else (record.test[0], record.test[1])
    return _report_function()(model, record.X, record.y, test=test, path=None, title=title)


# ------------------------------------------------------------------ identify
def _search(args, record):
    from .identify import IdentifyCV

    params = {"families": args.families, "libraries": args.libraries}
    params = {k: tuple(v) for k, v in params.items() if v is not None}
    for name in ("criterion", "horizon"):  # given only when asked for: not every IdentifyCV has them
        if getattr(args, name) is not None:
            if name not in IdentifyCV._get_param_names():
                raise ValueError(f"--{name}: this version's IdentifyCV has no {name} parameter; expected no "
                                 f"--{name}.")
            params[name] = getattr(args, name)
    return IdentifyCV(
        dt=record.dt, **params, derivatives=args.derivatives, input_hold=args.input_hold,
        input_delay=args.input_delay, n_blocks=args.n_blocks, block_size=args.block_size, max_path=args.max_path,
        screen_keep=args.screen_keep, screen_window=args.screen_window, n_refine=args.n_refine,
        max_terms=args.max_terms, n_init=record.n_init, time_budget=args.time_budget,
        max_candidates=args.max_candidates, random_state=args.random_state, storage=args.storage,
        study_name=args.study_name, n_jobs=args.n_jobs, show_progress_bar=not (args.no_progress or args.quiet))


def _legend(record):
    names = record.columns
    pairs = [f"u{j} is {n!r}" for j, n in enumerate(names["inputs"])] + [f"y{j} is {n!r}" for j, n in
                                                                           enumerate(names["outputs"])]
    return "" if names.get("dataset") else "  where " + ", ".join(pairs) + " (the columns of DATA)"


def scores_text(model, record):
    """The free run's scores on the test record (``experiments.evaluate``: the run's protocol) and its text."""
    from .experiments import evaluate

    Xt, yt, score_from, name = record.test
    _, scores = evaluate(model, {"u": Xt, "y": yt, "score_from": score_from}, record.n_init)
    n_scored = len(yt) - score_from
    protocol = (f"free run from the first n_init = {record.n_init} measured samples; scored samples: "
                + (f"all {n_scored}" if score_from == 0 else f"{n_scored} (from sample {score_from})"))
    if scores["status"] != "ok":
        return scores, f"test ({name}, {len(yt)} samples): {scores['status']} ({protocol})"
    return scores, (f"test ({name}, {len(yt)} samples): RMSE {scores['rmse']:.6g}, R^2 {scores['r2']:.4f}, "
                    f"fit index {scores['fit_index']:.2f} % ({protocol})")


def identify_command(args):
    """``sindybench identify``: search, print, then write the model file and the report (atomically, at the end)."""
    from .io import model_to_dict, write_text_atomic

    check_outputs(args, [args.data, args.test])
    if args.output is None and args.report is None:
        logger.warning("no -o MODEL.json nor --report REPORT.html: the model is printed, not saved")
    if args.report is not None:
        _report_function()  # before the search: a missing report module is said at once
    record = read_record(args, dt=args.dt, n_init=args.n_init)
    search = _search(args, record)
    start = time.perf_counter()
    try:
        search.fit(record.X, record.y)
    except BaseException as exc:
        if args.storage is not None and _interrupted(exc):
            print("sindybench: the evaluated candidates are kept in --storage: run the same command to resume.",
                  file=sys.stderr)
        raise
    elapsed = time.perf_counter() - start
    model = search.best_estimator_
    model.identification_["cli"] = dict(record.columns, n_init=record.n_init, dt=record.dt,
                                        search_time=elapsed)
    best = search.best_params_
    n_candidates = len(search.cv_results_["status"])
    print(f"identified ({n_candidates} candidates in {elapsed:.1f} s"
          + (f", {search.n_resumed_} read back from --storage" if search.n_resumed_ else "") + "): "
          f"{best['family']}, library {best['library']}, derivative {best['derivative']}, input hold "
          f"{best['input_hold']}, input delay {best['input_delay']}, {best['n_terms']} terms, validation error "
          f"{search.cv_results_['mean_validation_error'][search.best_index_]:.4g}")
    for equation in model.equations():
        print("  " + equation)
    legend = _legend(record)
    if legend:
        print(legend)
    scores = None
    if record.test is not None:
        scores, text = scores_text(model, record)
        print(text)
        model.identification_["cli"]["test_scores"] = scores
    # everything is built before anything is written: an error or a Ctrl-C until here leaves no file
    model_text = None if args.output is None else json.dumps(model_to_dict(model), allow_nan=False)
    html = None if args.report is None else _report_html(model, record, None)
    for path, text in ((args.output, model_text), (args.report, html)):
        if path is not None:
            write_text_atomic(text, path)
            logger.info("wrote %s", path)
    return 0


def report_command(args):
    """``sindybench report``: the HTML report of a saved model on its records."""
    from ._cli_args import _load
    from .io import write_text_atomic

    check_outputs(args, [args.model, args.data, args.test])
    report = _report_function()
    model = _load(args.model, args.allow_import)
    ident = getattr(model, "identification_", None)
    recorded = ident.get("cli") if isinstance(ident, dict) else None
    dt = getattr(model, "dt_", None)
    n_init = recorded.get("n_init") if isinstance(recorded, dict) else None
    record = read_record(args, dt=dt, n_init=n_init, recorded=recorded if isinstance(recorded, dict) else None)
    n_in = record.X.shape[1]
    if n_in != model.n_features_in_:
        raise ValueError(f"DATA {args.data}: {n_in} input column(s); the model {args.model} has "
                         f"{model.n_features_in_} input(s): expected as many --inputs.")
    test = None if record.test is None else (record.test[0], record.test[1])
    html = report(model, record.X, record.y, test=test, path=None, title=args.title)
    write_text_atomic(html, args.output)
    logger.info("wrote %s", args.output)
    return 0

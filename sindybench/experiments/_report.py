"""Write a run's results: JSON, Markdown tables, fitted models and figures.

Everything is written into a fresh directory that replaces the target only
when the whole run succeeded (:func:`staged_output_dir`), so an error leaves
no partial files behind, and entries the run did not write are never removed.
"""

import contextlib
import glob
import json
import logging
import math
import os
import shutil
import tempfile
import time
from pathlib import Path


from .._process import owner, owner_is_gone
from ..plotting import plot_hysteresis
from ..report import benchmark_index, benchmark_report
from ..report._benchmark import benchmark_figure
from ._best import best_model_markdown
from ._published import reference_figures
from ._warnings import warnings_markdown

__all__ = [
    "check_output_dir",
    "comparison_rows",
    "fit_from_r2",
    "format_number",
    "results_markdown",
    "staged_output_dir",
    "write_report",
    "write_results",
]

logger = logging.getLogger(__name__)
_COLUMNS = ("model", "RMSE", "RMSE (study)", "R^2", "R^2 (study)", "fit %", "fit % (study)")


_OWNER_FILE = ".sindybench-staging.json"
#: An empty staging folder older than this (seconds) lost its run before it could record its owner.
_EMPTY_STAGING_AGE = 3600


def check_output_dir(final, entries=()):
    """Refuse, before any work, an output folder the run could not write into.

    ``final`` must be a folder or a path that does not exist yet whose first
    existing parent is a folder; each of ``entries`` (``{name: "dir" or
    "file"}``, names relative to ``final``) that exists must be of that kind.

    Raises
    ------
    NotADirectoryError, IsADirectoryError
        Naming the path and what was expected.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (root / "notes.txt").write_text("mine")
    >>> check_output_dir(root / "notes.txt")
    Traceback (most recent call last):
    ...
    NotADirectoryError: output folder .../notes.txt is a file; expected a folder (or a path that does not exist yet).
    """
    final = Path(final)
    for parent in (final, *final.parents):
        if parent.exists():
            if not parent.is_dir():
                what = "output folder" if parent == final else f"the output folder {final} is inside"
                raise NotADirectoryError(f"{what} {parent} is a file; expected a folder (or a path that does not "
                                         "exist yet).")
            break
    for folder in dict.fromkeys((parent, final.parent)):  # the run writes its staging folder beside final
        if folder.is_dir() and not os.access(folder, os.W_OK | os.X_OK):  # a read-only file system too
            _not_writable(final, folder, "not writable")
    for name, kind in dict(entries).items():
        path = final / name
        if kind == "dir" and path.exists() and not path.is_dir():
            raise NotADirectoryError(f"{path} is a file; the run writes a folder of that name: expected a folder, or "
                                     "no such entry (move the file away or choose another --out).")
        if kind == "file" and path.is_dir():
            raise IsADirectoryError(f"{path} is a folder; the run writes a file of that name: expected a file, or "
                                    "no such entry (move the folder away or choose another --out).")


def _not_writable(final, folder, reason, error=PermissionError):
    raise error(f"output folder {final}: cannot write into {folder} ({reason}); expected a folder the run can write "
                "into (choose another --out).")


def _staging_folders(final):
    """Sibling staging folders of ``final``: ``(path, owner record or None)``."""
    for path in final.parent.glob(f".{glob.escape(final.name)}.tmp-*"):
        if path.is_symlink() or not path.is_dir():
            continue
        try:
            record = json.loads((path / _OWNER_FILE).read_text())
        except (OSError, ValueError):
            record = None
        yield path, record if isinstance(record, dict) else None


def _remove_stale_staging(final):
    """Remove the staging folders of runs that were killed: only those provably ours and stale.

    A staging folder names its owner (host, PID, token, start) in a record
    written when it is made; it is removed when that owner is on this host and
    provably no longer runs (:func:`sindybench._process.owner_is_gone`). An
    empty folder without a record (its run was killed before writing one) is
    removed once an hour old; anything else is left alone, with a warning.
    """
    for path, record in _staging_folders(final):
        if record is None:
            try:
                old = time.time() - path.stat().st_mtime > _EMPTY_STAGING_AGE
                if old and not any(path.iterdir()):
                    path.rmdir()  # never removes content
                    continue
            except OSError:
                pass
            logger.warning("left alone: %s (a staging folder without an owner record; remove it yourself if no run "
                           "is writing into it)", path)
            continue
        host, pid, token, since = (record.get(k) for k in ("host", "pid", "token", "created"))
        if not owner_is_gone(host, pid, token, since if isinstance(since, (int, float)) else None):
            continue
        shutil.rmtree(path, ignore_errors=True)
        logger.info("removed %s, the staging folder of a run that was killed (%s, process %s)", path, host, pid)


def _merge(source, target, skip=()):
    """Move every entry of ``source`` (but ``skip``) into ``target``, replacing same-named files; others stay."""
    target.mkdir(exist_ok=True)
    for entry in sorted(source.iterdir()):
        if entry.name in skip:
            continue
        destination = target / entry.name
        if entry.is_dir() and not entry.is_symlink():
            if destination.exists() and not destination.is_dir():
                raise NotADirectoryError(f"{destination} is a file; the run writes a folder of that name.")
            _merge(entry, destination)
        else:
            if destination.is_dir() and not destination.is_symlink():
                raise IsADirectoryError(f"{destination} is a folder; the run writes a file of that name.")
            os.replace(entry, destination)


@contextlib.contextmanager
def staged_output_dir(final):
    """Yield a temporary directory whose contents move into ``final`` on success.

    The temporary directory is a hidden sibling of ``final``
    (``.<name>.tmp-*``, on the same file system, so each move is a rename).
    On success each file in it replaces the file of the same name in
    ``final``, folder by folder: entries of ``final`` that the run did not
    write (the user's notes, files of an earlier run) are kept, never
    deleted. On an exception it is removed and ``final`` is left untouched,
    so a failed run leaves no partial files. The folder records its owner
    (host and process): staging folders left by runs that were killed
    (SIGKILL, a power cut) are removed by the next run into the same
    ``final``, and only those.

    Parameters
    ----------
    final : str or path-like

    Raises
    ------
    NotADirectoryError
        Before yielding, when ``final`` (or a parent) is a file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> (root / "out").mkdir()
    >>> _ = (root / "out" / "notes.txt").write_text("mine")
    >>> with staged_output_dir(root / "out") as tmp:
    ...     _ = (tmp / "a.txt").write_text("done")
    >>> sorted(p.name for p in root.iterdir()), sorted(p.name for p in (root / "out").iterdir())
    (['out'], ['a.txt', 'notes.txt'])
    """
    final = Path(final)
    check_output_dir(final)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale_staging(final)
        tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp-", dir=final.parent))
    except OSError as exc:  # name the folder the user chose, not the staging folder beside it
        _not_writable(final, final.parent, exc.strerror or exc, OSError)
    try:
        me = owner()
        (tmp / _OWNER_FILE).write_text(json.dumps({**me, "created": time.time()}))
        yield tmp
        _merge(tmp, final, skip={_OWNER_FILE})  # the record stays until the end: a kill now leaves a removable folder
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def fit_from_r2(value):
    """Fit index (percent) implied by an R^2: ``100 (1 - sqrt(1 - R^2))``.

    Examples
    --------
    >>> fit_from_r2(0.75)
    50.0
    >>> fit_from_r2(None) is None
    True
    """
    if value is None:
        return None
    return 100.0 * (1.0 - math.sqrt(max(0.0, 1.0 - value)))


def format_number(value, kind):
    """Format a table cell: ``kind`` is ``"rmse"``, ``"r2"`` or ``"fit"``.

    Examples
    --------
    >>> format_number(0.000183, "rmse"), format_number(0.9324, "r2"), format_number(None, "fit")
    ('1.83e-04', '0.932', '-')
    """
    if value is None:
        return "-"
    if kind == "rmse":
        return f"{value:.3g}" if 1e-2 <= abs(value) < 1e3 else f"{value:.2e}"
    if kind == "r2":
        return f"{value:.3f}"
    return f"{value:.1f}"


def comparison_rows(results, test_name):
    """Rows of the "ours beside the study" table for one test set.

    The study's fit index is not published: it is derived from its R^2 by
    :func:`fit_from_r2` (and marked with ``*``).

    Returns
    -------
    list of tuple of str
        The header first, then one row per model.
    """
    rows = [_COLUMNS]
    for m in results["models"]:
        ours = m["scores"].get(test_name, {})
        theirs = m["published"].get(test_name, {})
        fit_theirs = fit_from_r2(theirs.get("r2"))
        rows.append((
            m["label"] if ours.get("status", "ok") == "ok" else f"{m['label']} ({ours.get('status', '?')})",
            format_number(ours.get("rmse"), "rmse"),
            format_number(theirs.get("rmse"), "rmse"),
            format_number(ours.get("r2"), "r2"),
            format_number(theirs.get("r2"), "r2"),
            format_number(ours.get("fit_index"), "fit"),
            format_number(fit_theirs, "fit") + ("*" if fit_theirs is not None else ""),
        ))
    return rows


def _markdown_table(rows):
    lines = ["| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0])]
    lines += ["| " + " | ".join(r) + " |" for r in rows[1:]]
    return "\n".join(lines)


def results_markdown(results, *, heading_level=1):
    """The Markdown text of ``results.md`` for one benchmark."""
    h = "#" * heading_level
    out = [f"{h} {results['title']}: ours vs the study", ""]
    out.append(
        f"Seed {results['seed']}, {'quick' if results['quick'] else 'default'} budgets, "
        f"wall time {results['wall_time_s']:.0f} s; training {results['n_train']} + validation "
        f"{results['n_validation']} samples (dt = {results['dt']:g} s). Open-loop simulation "
        "of each test set from its first samples. The study's \"BFR\" is R^2; its fit index "
        "(marked *) is derived as 100 (1 - sqrt(1 - R^2))."
    )
    for name, info in results["test_sets"].items():
        out += ["", f"{h}# Test set `{name}` ({info['n_samples']} samples)", ""]
        first = info.get("score_from", 0)
        scored = (f"is scored on the {info['n_samples'] - first} samples after the first {first}" if first
                  else f"is scored on all {info['n_samples']} samples, the start included")
        named = f" ({info['protocol']})" if info.get("protocol") else ""
        out.append(
            f"Protocol{named}: every model starts from the first {info['n_init']} measured samples of the test record "
            f"(`y_init`) and {scored}; the "
            "\"+ simulation-error refinement\" rows fit their initial state (hidden states included) to those "
            f"{info['n_init']} samples by least squares."
        )
        out.append("")
        out.append(_markdown_table(comparison_rows(results, name)))
        others = reference_figures(results.get("benchmark", ""), name)
        if others:
            out += ["", f"Published on this test set (not trained here): {others}."]
    out += best_model_markdown(results.get("best_model"), f"{h}#")
    out += warnings_markdown(results.get("warnings"), f"{h}#")
    out += ["", f"{h}# Models", ""]
    for m in results["models"]:
        trials = f"{m['n_trials']} search trials" if m["n_trials"] else "no outer search"
        if m.get("inner_trials"):
            trials += f", {m['inner_trials']} trials of its own search in fit"
        if m.get("n_train", results["n_train"]) < results["n_train"]:
            trials += f", {m['n_train']} training samples"
        fit_time = f", fit in {m['fit_time_s']:.1f} s" if m.get("fit_time_s") is not None else ""
        if m.get("fit_time_with_search_s") is not None:
            fit_time += f" ({m['fit_time_with_search_s']:.1f} s with the search of `{m['refines']}`)"
        out.append(f"- **{m['label']}** (`{m['key']}`, {trials}{fit_time}): {m['description']}")
        if m["best_params"]:
            params = ", ".join(f"{k}={_short(v)}" for k, v in m["best_params"].items())
            out.append(f"  - best parameters: {params}")
        record = m.get("refinement")
        if record and record.get("status", -1) >= 0:
            physical = ", ".join(f"{k}={_short(v)}" for k, v in record["physical"].items())
            criterion = record.get("criterion")
            what = f"{criterion['horizon']}-step prediction cost" if criterion else "cost"
            out.append(f"  - refinement ({record['jacobian']} Jacobian): {what} {record['initial_cost']:.3g} -> "
                       f"{record['cost']:.3g} in {record['nfev']} {'predictor runs' if criterion else 'simulations'}"
                       + (f"; refined {physical}" if physical else ""))
        elif record:
            out.append(f"  - refinement: {record['message']}")
        for name, rows in (m.get("k_step") or {}).get("k_step", {}).items():
            ks = ", ".join(f"k={k}: {_short(v['rmse']) if v['rmse'] is not None else v['status']}"
                           for k, v in rows.items())
            out.append(f"  - k-step RMSE on `{name}` (the designated row's protocol): {ks}")
        if m.get("pareto_front"):
            front = ", ".join(f"{p['n_terms']}: {p['validation_error']:.3g}" for p in m["pareto_front"])
            out.append(f"  - Pareto front (terms: validation error): {front}")
        for eq in m["equations"]:
            out.append(f"  - `{eq}`")
    return "\n".join(out) + "\n"


def _short(v):
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def _save_model(estimator, path):
    """Save a fitted model as a model file (:func:`sindybench.load_model` reads it); False if it cannot be."""
    try:
        estimator.to_json(path)
    except (AttributeError, ValueError) as exc:
        logger.warning("model %s not saved: %s", path.name, exc)
        return False
    return True


def _figure(nrows, *, figsize, **subplot_kw):
    """A figure outside pyplot (no global state; the report saves and forgets it)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.subplots(nrows, 1, squeeze=False, **subplot_kw)[:, 0]


def _simulations(results, simulations):
    return {m["label"]: simulations[m["key"]] for m in results["models"] if simulations.get(m["key"]) is not None}


def _test_figure(results, test_name, test, simulations):
    """Figure: the measured output and each model's simulation error on one test set, a zoom, the spectra in dB."""
    return benchmark_figure(results, test_name, test, simulations)


def _hysteresis_figure(results, test_name, test, simulations):
    """Figure: force-displacement loops (input against output) on one test set."""
    fig, axes = _figure(1, figsize=(9, 5))
    plot_hysteresis(test["u"], test["y"], _simulations(results, simulations), output_label=results["output_label"],
                    input_label=results["input_label"], ax=axes[0])
    axes[0].set_title(f"{results['title']}: hysteresis loops, test set '{test_name}'")
    return fig


def write_results(results, fitted, simulations, tests, out_dir, *, hysteresis_test=None):
    """Write ``results.json``, ``results.md``, ``models/*.json``, PNG figures and ``report.html``.

    The model files are those of :func:`sindybench.load_model` (a model that
    cannot be saved as plain data is left out, with a warning); the
    equations stay in the results.

    Parameters
    ----------
    results, fitted, simulations
        As returned by :func:`sindybench.experiments.run_benchmark`.
    tests : dict
        ``{test name: Bunch}`` (for the measured signals of the figures).
    out_dir : path-like
        Existing directory to write into.
    hysteresis_test : str, optional
        Test set on which to draw force-displacement loops.

    Returns
    -------
    dict
        The results with the written file names added under ``"files"``.
    """
    out_dir = Path(out_dir)
    (out_dir / "models").mkdir(parents=True, exist_ok=True)
    files = {"models": {}, "figures": {}}
    for entry in results["models"]:
        estimator = fitted.get(entry["key"])
        if estimator is not None:
            name = f"models/{entry['key']}.json"
            if _save_model(estimator, out_dir / name):
                files["models"][entry["key"]] = name
    images = {}
    for test_name, test in tests.items():
        name = f"test_{test_name}.png"
        _test_figure(results, test_name, test, simulations[test_name]).savefig(out_dir / name, dpi=90)
        files["figures"][test_name] = name
        images[test_name] = (out_dir / name).read_bytes()  # the HTML page embeds the same figure
    if hysteresis_test is not None and hysteresis_test in tests:
        name = f"hysteresis_{hysteresis_test}.png"
        fig = _hysteresis_figure(results, hysteresis_test, tests[hysteresis_test], simulations[hysteresis_test])
        fig.savefig(out_dir / name, dpi=110)
        files["figures"]["hysteresis"] = name
        images["hysteresis"] = (out_dir / name).read_bytes()
    files["report"] = "report.html"
    results = dict(results, files=files)
    benchmark_report(results, simulations, tests, path=out_dir / "report.html", images=images)
    (out_dir / "results.json").write_text(json.dumps(results, indent=2, allow_nan=False) + "\n")
    (out_dir / "results.md").write_text(results_markdown(results))
    return results


def _fit_time_shares(all_results, wall_time_s):
    """One sentence: the fit time of each model family (by key, across benchmarks) and its share of the wall time.

    Examples
    --------
    >>> runs = [{"models": [{"key": "nnarx", "fit_time_s": 6.0}, {"key": "sindy_poly", "fit_time_s": 2.0}]},
    ...         {"models": [{"key": "nnarx", "fit_time_s": 4.0}, {"key": "arx", "fit_time_s": None}]}]
    >>> _fit_time_shares(runs, 40.0)
    'Fit times: nnarx 10.0 s (25 % of the wall time), sindy_poly 2.0 s (5 %).'
    """
    totals = {}
    for results in all_results:
        for m in results["models"]:
            totals[m["key"]] = totals.get(m["key"], 0.0) + (m.get("fit_time_s") or 0.0)
    ranked = sorted(totals.items(), key=lambda kv: -kv[1])
    cells = [f"{key} {t:.1f} s ({100 * t / wall_time_s:.0f} %{' of the wall time' if i == 0 else ''})"
             for i, (key, t) in enumerate(ranked) if t > 0]
    return "Fit times: " + ", ".join(cells) + "."


def write_report(all_results, path, *, wall_time_s):
    """Write ``report.md`` joining the results of several benchmarks, and ``index.html`` beside it (the HTML pages)."""
    out = ["# sindybench: the study's three benchmarks, ours vs published", ""]
    out.append(f"Total wall time {wall_time_s:.0f} s ({wall_time_s / 60:.1f} min). "
               + _fit_time_shares(all_results, wall_time_s))
    for results in all_results:
        out += ["", results_markdown(results, heading_level=2).rstrip()]
    Path(path).write_text("\n".join(out) + "\n")
    benchmark_index(all_results, path=Path(path).parent / "index.html", wall_time_s=wall_time_s)

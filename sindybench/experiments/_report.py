"""Write a run's results: JSON, Markdown tables, fitted models and figures.

Everything is written into a fresh directory that replaces the target only
when the whole run succeeded (:func:`atomic_output_dir`), so an error leaves
no partial files behind.
"""

import contextlib
import json
import math
import os
import shutil
import tempfile
import textwrap
from pathlib import Path

import numpy as np

__all__ = [
    "comparison_rows",
    "fit_from_r2",
    "format_number",
    "plot_hysteresis",
    "plot_test",
    "results_markdown",
    "staged_output_dir",
    "write_report",
    "write_results",
]

_MAX_POINTS = 6000
_COLUMNS = ("model", "RMSE", "RMSE (study)", "R^2", "R^2 (study)", "fit %", "fit % (study)")


@contextlib.contextmanager
def staged_output_dir(final):
    """Yield a temporary directory whose contents move into ``final`` on success.

    The temporary directory is a sibling of ``final`` (same file system, so
    each move is a rename). On success every entry of it replaces the entry of
    the same name in ``final`` (other entries of ``final`` are kept); on an
    exception it is removed and ``final`` is left untouched, so a failed run
    leaves no partial files.

    Parameters
    ----------
    final : str or path-like

    Examples
    --------
    >>> import tempfile, pathlib
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> with staged_output_dir(root / "out") as tmp:
    ...     _ = (tmp / "a.txt").write_text("done")
    >>> sorted(p.name for p in root.iterdir()), sorted(p.name for p in (root / "out").iterdir())
    (['out'], ['a.txt'])
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.tmp-", dir=final.parent))
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    final.mkdir(exist_ok=True)
    for entry in sorted(tmp.iterdir()):
        target = final / entry.name
        if target.is_dir() and not target.is_symlink():
            trash = tmp / f".old-{entry.name}"
            target.rename(trash)
            entry.rename(target)
            shutil.rmtree(trash, ignore_errors=True)
        else:
            os.replace(entry, target)
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
        out.append(_markdown_table(comparison_rows(results, name)))
    out += ["", f"{h}# Models", ""]
    for m in results["models"]:
        trials = f"{m['n_trials']} search trials" if m["n_trials"] else "no outer search"
        if m.get("inner_trials"):
            trials += f", {m['inner_trials']} trials of its own search in fit"
        if m.get("n_train", results["n_train"]) < results["n_train"]:
            trials += f", {m['n_train']} training samples"
        fit_time = f", fit in {m['fit_time_s']:.1f} s" if m.get("fit_time_s") is not None else ""
        out.append(f"- **{m['label']}** (`{m['key']}`, {trials}{fit_time}): {m['description']}")
        if m["best_params"]:
            params = ", ".join(f"{k}={_short(v)}" for k, v in m["best_params"].items())
            out.append(f"  - best parameters: {params}")
        for eq in m["equations"]:
            out.append(f"  - `{eq}`")
    return "\n".join(out) + "\n"


def _short(v):
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def _save_model(estimator, entry, path):
    """Save a fitted model as JSON: its own format when it has one, else a summary."""
    to_json = getattr(estimator, "to_json", None)
    if to_json is not None:
        try:
            to_json(path)
            return
        except (NotImplementedError, TypeError, ValueError):
            pass
    params = {k: repr(v) if not isinstance(v, (int, float, str, bool, type(None))) else v
              for k, v in estimator.get_params(deep=False).items()}
    doc = {"class": type(estimator).__name__, "params": params, "equations": entry["equations"]}
    for attr in ("coef_", "intercept_"):
        value = getattr(estimator, attr, None)
        if value is not None:
            doc[attr] = np.asarray(value, float).tolist()
    path.write_text(json.dumps(doc, indent=2) + "\n")


def _figure(nrows=1, ncols=1, *, figsize, **subplot_kw):
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplot_kw)
    return fig, axes


def _stride(n):
    return max(1, int(np.ceil(n / _MAX_POINTS)))


def plot_test(results, test_name, test, simulations):
    """Figure: the measured output and each model's simulation on one test set."""
    y = np.asarray(test["y"], float).reshape(len(test["y"]), -1)[:, 0]
    u = np.asarray(test["u"], float).reshape(len(y), -1)[:, 0]
    dt = float(test.get("dt", results["dt"]))
    t = np.arange(len(y)) * dt
    k = _stride(len(y))
    fig, axes = _figure(2, 1, figsize=(11, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    ax, ax_u = axes[0, 0], axes[1, 0]
    ax.plot(t[::k], y[::k], color="black", lw=1.6, label="measured")
    # a simulation far outside the measured range would flatten every other curve: keep the frame on the data
    span = float(np.ptp(y)) or 1.0
    low, high = float(y.min()) - 0.5 * span, float(y.max()) + 0.5 * span
    off_scale = False
    for m in results["models"]:
        y_pred = simulations.get(m["key"])
        if y_pred is None:
            continue
        y_pred = np.asarray(y_pred).reshape(len(y), -1)[:, 0]
        label = f"{m['label']} (R^2 {m['scores'][test_name]['r2']:.2f})"
        if y_pred.min() < low or y_pred.max() > high:
            off_scale = True
            label += ", leaves the frame"
        ax.plot(t[::k], y_pred[::k], lw=1.0, label=label)
    if off_scale:
        ax.set_ylim(low, high)
    ax.set_ylabel(results["output_label"])
    ax.set_title(f"{results['title']}: open-loop simulation, test set '{test_name}'")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax_u.plot(t[::k], u[::k], color="gray", lw=0.8)
    ax_u.set_ylabel(textwrap.fill(results["input_label"], 18))  # the input axes are short
    ax_u.set_xlabel("time [s]")
    return fig


def plot_hysteresis(results, test_name, test, simulations):
    """Figure: force-displacement loops (input vs output) on one test set."""
    y = np.asarray(test["y"], float).reshape(len(test["y"]), -1)[:, 0]
    u = np.asarray(test["u"], float).reshape(len(y), -1)[:, 0]
    fig, axes = _figure(figsize=(9, 5))
    ax = axes[0, 0]
    ax.plot(y, u, color="black", lw=1.8, label="true system")
    for m in results["models"]:
        y_pred = simulations.get(m["key"])
        if y_pred is not None:
            ax.plot(np.asarray(y_pred).reshape(len(y), -1)[:, 0], u, lw=1.0, label=m["label"])
    ax.set_xlabel(results["output_label"])
    ax.set_ylabel(results["input_label"])
    ax.set_title(f"{results['title']}: hysteresis loops, test set '{test_name}'")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def write_results(results, fitted, simulations, tests, out_dir, *, hysteresis_test=None):
    """Write ``results.json``, ``results.md``, ``models/*.json`` and PNG figures.

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
            _save_model(estimator, entry, out_dir / name)
            files["models"][entry["key"]] = name
    for test_name, test in tests.items():
        name = f"test_{test_name}.png"
        plot_test(results, test_name, test, simulations[test_name]).savefig(out_dir / name, dpi=110)
        files["figures"][test_name] = name
    if hysteresis_test is not None and hysteresis_test in tests:
        name = f"hysteresis_{hysteresis_test}.png"
        fig = plot_hysteresis(results, hysteresis_test, tests[hysteresis_test], simulations[hysteresis_test])
        fig.savefig(out_dir / name, dpi=110)
        files["figures"]["hysteresis"] = name
    results = dict(results, files=files)
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
    """Write ``report.md`` joining the results of several benchmarks."""
    out = ["# sindybench: the study's three benchmarks, ours vs published", ""]
    out.append(f"Total wall time {wall_time_s:.0f} s ({wall_time_s / 60:.1f} min). "
               + _fit_time_shares(all_results, wall_time_s))
    for results in all_results:
        out += ["", results_markdown(results, heading_level=2).rstrip()]
    Path(path).write_text("\n".join(out) + "\n")

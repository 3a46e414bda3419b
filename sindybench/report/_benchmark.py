"""The HTML pages of ``sindybench run all``: one per benchmark, and the index linking them."""

import math

import numpy as np

from .._version import __version__
from ._html import esc, figure, fmt, key_values, new_figure, page, table, write_text_atomic
from ._maths import equations_html

__all__ = ["benchmark_figure", "benchmark_index", "benchmark_report", "error_figure"]


def error_figure(u, y, simulations, *, dt, n_init, output_label="output", title=None):
    """One figure: the measured output and every model's error (full record and zoom), and the error spectra in dB.

    Parameters
    ----------
    u : ndarray of shape (n_samples, n_inputs) or None
    y : ndarray of shape (n_samples, n_outputs)
    simulations : dict
        ``{label: simulated outputs shaped like y}`` (None entries are left out).
    dt : float or None
    n_init : int
        Start samples (given, not simulated): the errors and RMSE skip them.
    output_label : str, default="output"
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> y = np.sin(np.linspace(0, 20, 3000))[:, None]
    >>> fig = error_figure(None, y, {"a": y + 0.01, "b": None}, dt=0.01, n_init=5)
    >>> len(fig.axes)  # full, zoom (with the output on its own right-hand axis), spectra
    4
    """
    from ..plotting import plot_error_spectrum, plot_output_error

    sims = {k: v for k, v in simulations.items() if v is not None}
    # the worst model first, so that the best one's error is drawn on top
    y2 = np.asarray(y, dtype=float).reshape(len(y), -1)

    def _rms(pred):
        e = (y2 - np.asarray(pred, dtype=float).reshape(y2.shape))[n_init:]
        return math.inf if not np.all(np.isfinite(e)) else float(np.sqrt(np.mean(e ** 2)))

    sims = dict(sorted(sims.items(), key=lambda kv: -_rms(kv[1])))
    fig, axes = new_figure(3, figsize=(11, 9.5), height_ratios=[3, 3, 2.6])
    plot_output_error(u, y2, sims, n_init=n_init, dt=dt, output_label=output_label, ax=axes[:2])
    if sims:
        plot_error_spectrum(u, y2, sims, n_init=n_init, dt=dt, ax=axes[2])
    else:
        axes[2].set_visible(False)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def benchmark_figure(results, name, test, simulations):
    """:func:`error_figure` of one test set of a benchmark run (``simulations``: ``{model key: y_pred or None}``)."""
    labels = {m["key"]: m["label"] for m in results["models"]}
    sims = {labels.get(k, k): v for k, v in simulations.items() if v is not None}
    n_init = int(results.get("test_sets", {}).get(name, {}).get("n_init", 1))
    dt = float(test.get("dt", results["dt"])) if hasattr(test, "get") else float(results["dt"])
    return error_figure(test["u"], test["y"], sims, dt=dt, n_init=n_init,
                        output_label=results.get("output_label", "output"),
                        title=f"{results.get('title', results.get('benchmark'))}: open-loop simulation errors, "
                              f"test set '{name}'")


def _score_rows(results, name):
    rows = []
    for m in results["models"]:
        s = m.get("scores", {}).get(name) or {}
        p = (m.get("published") or {}).get(name) or {}
        # times in a span of their own: two runs of the same seed differ only there
        rows.append([m["label"], s.get("rmse"), p.get("rmse"), s.get("r2"), s.get("fit_index"),
                     f"<span class=time>{esc(fmt(m.get('fit_time_s')))}</span>",
                     s.get("status") if s.get("status") not in (None, "ok") else m.get("status", "ok")])
    return rows


def _best_model(best):
    if not best:
        return "<p class=note>The benchmark designates no model for the uncertainty reports.</p>"
    html = f"<p>{esc(best.get('label'))}: {esc(best.get('choice', ''))}.</p>"
    resid = best.get("residual_analysis") or {}
    if resid:
        html += f"<h3>Residual analysis (validation block)</h3><p>{esc(resid.get('message', resid.get('status')))}</p>"
    status = best.get("standard_errors_status")
    if status and str(status).startswith("warning"):
        html += f"<div class=warn>{esc(status)}</div>"
    errors = best.get("standard_errors") or {}
    if isinstance(errors, dict) and errors:
        html += "<h3>Parameters' standard errors</h3>" + table(["parameter", "standard error"],
                                                               sorted(errors.items()), sortable=True)
    band = best.get("conformal_band") or {}
    if band:
        rows = [(k, fmt(v)) for k, v in band.items() if not isinstance(v, dict)]
        rows += [(f"{k}: {kk}", fmt(vv)) for k, v in band.items() if isinstance(v, dict) for kk, vv in v.items()
                 if not isinstance(vv, dict)]
        html += "<h3>Calibrated band</h3>" + key_values(rows)
    return html


def benchmark_report(results, simulations, tests, *, path=None, images=None):
    """One benchmark's page: per test set the scores, the output and every model's error, the spectra; equations.

    Parameters
    ----------
    results : dict
        As returned by :func:`sindybench.experiments.run_benchmark`.
    simulations : dict
        ``{test name: {model key: simulated outputs or None}}``.
    tests : dict
        ``{test name: Bunch}`` with ``u``, ``y`` (and ``dt``).
    path : path-like, optional
        Write the page there (atomically).
    images : dict, optional
        ``{test name: PNG bytes}`` of :func:`error_figure` already drawn (the
        run's PNG files), embedded instead of drawing them again; under
        ``"hysteresis"``, the run's hysteresis loops (a section of their own).

    Returns
    -------
    str
        The HTML text.
    """
    images = images or {}
    sections = []
    cards = []
    for name, test in tests.items():
        info = results["test_sets"].get(name, {})
        n_init = int(info.get("n_init", 1))
        rows = _score_rows(results, name)
        finite = [r for r in rows if isinstance(r[1], (int, float)) and math.isfinite(r[1])]
        if finite:
            best = min(finite, key=lambda r: r[1])
            cards.append(f"<div class=card><span>{esc(name)}: best RMSE</span><b>{esc(fmt(best[1], 3))}</b>"
                         f"<span>{esc(best[0])}</span></div>")
        html = f"<p class=note>{esc(info.get('protocol', ''))}; {esc(info.get('n_samples', ''))} samples.</p>"
        html += table(["model", "RMSE", "RMSE (study)", "R^2", "fit %", "fit time [s]", "status"], rows, sortable=True,
                      raw=("fit time [s]",))
        fig = images.get(name)
        if fig is None:
            fig = benchmark_figure(results, name, test, simulations.get(name) or {})
        html += figure(fig, f"Test set '{name}': the measured output (black) and each model's simulation error on "
                            "one axis, a zoomed window (shaded above), and the spectra in dB", dpi=80)
        sections.append((f"test-{name}", f"Test set '{name}'", html))
    if images.get("hysteresis") is not None:
        sections.append(("hysteresis", "Hysteresis loops", figure(images["hysteresis"], "Force-displacement loops "
                                                                  "(input against output) of the models")))
    eq = "".join(f"<h3>{esc(m['label'])}</h3>" + (equations_html(m["equations"]) if m.get("equations") else
                                                  f"<p class=note>{esc(m.get('status', 'no equations'))}</p>")
                 for m in results["models"])
    sections.append(("equations", "Equations", eq))
    sections.append(("best", "Uncertainty of the designated model", _best_model(results.get("best_model"))))
    about = [("sindybench", results.get("sindybench_version", __version__)), ("seed", results.get("seed")),
             ("quick", results.get("quick")), ("training samples", results.get("n_train")),
             ("validation samples", results.get("n_validation")), ("dt [s]", results.get("dt"))]
    wall = results.get("wall_time_s")
    sections.append(("about", "Run", key_values([(k, fmt(v)) for k, v in about])
                     + (f"<p class=note>The benchmark's wall time {wall:.1f} s.</p>" if wall is not None else "")
                     + '<p><a href="../index.html">all benchmarks</a></p>'))
    body_top = '<div class="cards">' + "".join(cards) + "</div>"
    first_id, first_head, first_html = sections[0]
    sections[0] = (first_id, first_head, body_top + first_html)
    text = page(f"{results.get('title', results.get('benchmark'))}: sindybench run",
                "open-loop simulation errors on the official test sets", sections)
    if path is not None:
        write_text_atomic(path, text)
    return text


def benchmark_index(all_results, *, path=None, wall_time_s=None):
    """The index of a ``run all``: one row per benchmark and test set with its best model, linking each page.

    Parameters
    ----------
    all_results : list of dict
        The results of each benchmark (:func:`sindybench.experiments.run_benchmark`).
    path : path-like, optional
        Write the page there (atomically); the pages are ``<benchmark>/report.html`` beside it.
    wall_time_s : float, optional

    Returns
    -------
    str

    Examples
    --------
    >>> runs = [{"benchmark": "toy", "title": "Toy", "test_sets": {"t": {}}, "models": [
    ...     {"label": "ARX", "scores": {"t": {"rmse": 2.0}}}, {"label": "SINDy", "scores": {"t": {"rmse": 1.0}}}]}]
    >>> "toy/report.html" in benchmark_index(runs)
    True
    """
    rows = []
    for results in all_results:
        title = results.get("title", results["benchmark"])
        link = f'<a href="{esc(results["benchmark"])}/report.html">{esc(title)}</a>'
        for name in results.get("test_sets", {}):
            scored = [(m["scores"][name]["rmse"], m["label"]) for m in results["models"]
                      if (m.get("scores", {}).get(name) or {}).get("rmse") is not None]
            best = min(scored) if scored else (None, "")
            rows.append([link, name, best[1], best[0], len(results["models"])])
    html = table(["benchmark", "test set", "best model", "its RMSE", "models"], rows, sortable=True,
                 raw=("benchmark",))
    if wall_time_s is not None:
        html += f"<p class=note>Total wall time {wall_time_s:.0f} s.</p>"
    text = page("sindybench: the benchmarks", f"sindybench {__version__}; report.md has the same tables as text",
                [("benchmarks", "Benchmarks", html)])
    if path is not None:
        write_text_atomic(path, text)
    return text

"""``identification_report``: one HTML page on an identified model, its selection, its errors and its uncertainty."""

import platform
import time
import warnings

import numpy as np
from sklearn.utils.validation import check_is_fitted

from .._validation import check_inputs_outputs, check_integer, is_records
from .._version import __version__
from ..metrics import fit_index, r2, rmse
from ._html import esc, figure, fmt, key_values, new_figure, page, table, write_text_atomic
from ._maths import equations_html

__all__ = ["identification_report"]

_N_INIT = 20  # identify's default start samples, when the record does not say
_MAX_OUTPUTS = 4  # outputs drawn one figure each at most
_CV_COLUMNS = ("family", "library", "derivative", "input_hold", "input_delay", "threshold", "refine", "stage",
               "n_terms", "max_row_terms")


def _record(model):
    record = getattr(model, "identification_", None)
    return record if isinstance(record, dict) and "cv_results" in record else None


def _check(model, X, y, test):
    if not hasattr(model, "predict"):
        raise TypeError(f"model must be a fitted sindybench estimator (with predict); got {type(model).__name__}.")
    check_is_fitted(model)
    if is_records(y):
        raise ValueError(f"y is a list of {len(y)} records; expected one record (the page simulates one record: "
                         "pass the one to report, e.g. the last).")
    X, y = check_inputs_outputs(X, y)
    if test is not None:
        if not isinstance(test, (tuple, list)) or len(test) != 2:
            raise ValueError(f"test must be a pair (X_test, y_test); got {type(test).__name__}.")
        X_t, y_t = check_inputs_outputs(*test, x_name="X_test", y_name="y_test")
        if X_t.shape[1] != X.shape[1] or y_t.shape[1] != y.shape[1]:
            raise ValueError(f"test has {X_t.shape[1]} input(s) and {y_t.shape[1]} output(s); expected "
                             f"{X.shape[1]} and {y.shape[1]}, as X and y.")
        test = (X_t, y_t)
    return X, y, test


def _inputs(X):
    return None if X.shape[1] == 0 else X


def _free_run(model, X, y, n_init):
    """The model's free run of ``(X, y)`` started from ``y[:n_init]`` (NaN where it diverged), and the failure."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pred = np.asarray(model.predict(_inputs(X), y_init=y[:n_init]), dtype=float).reshape(y.shape)
        return pred, None
    except Exception as exc:  # a report shows a failed simulation, it does not stop at it
        return np.full(y.shape, np.nan), f"{type(exc).__name__}: {exc}"


def _scores(y, pred, n_init):
    if not np.all(np.isfinite(pred[n_init:])):
        return {"RMSE": None, "R^2": None, "fit %": None}
    return {"RMSE": rmse(y, pred, skip=n_init), "R^2": r2(y, pred, skip=n_init),
            "fit %": fit_index(y, pred, skip=n_init)}


def _labels(model, y):
    names = list(getattr(model, "output_names_", None) or [])
    return names if len(names) == y.shape[1] else [f"y{j}" for j in range(y.shape[1])]


def _error_figures(y, pred, n_init, dt, labels, what):
    """Per output one figure: output and error (full and zoomed), and the spectra in dB."""
    from ._benchmark import error_figure

    out = []
    for j in range(min(y.shape[1], _MAX_OUTPUTS)):
        fig = error_figure(None, y[:, j:j + 1], {"model": pred[:, j:j + 1]}, dt=dt, n_init=n_init,
                           output_label=labels[j])
        out.append(figure(fig, f"{what}: the measured {labels[j]} (black) and the model's simulation error "
                               "(measured minus simulated) on one axis, a zoomed window (shaded above), and the "
                               "spectra in dB of the output and of the error"))
    if y.shape[1] > _MAX_OUTPUTS:
        out.append(f"<p class=note>The first {_MAX_OUTPUTS} of {y.shape[1]} outputs are drawn.</p>")
    return "".join(out)


# ---------------------------------------------------------------- sections
def _summary(model, record, equations, test_scores, test_figs, resid, timings):
    cards = [("model", type(model).__name__)]
    if record is not None:
        chosen = record["settings"]
        criterion = (record.get("criterion") or {}).get("name", "free_run")
        cards += [("family", chosen.get("family")), ("terms", chosen.get("n_terms")),
                  ("ranked by", "free run" if criterion == "free_run" else "k-step prediction"),
                  ("validation error", fmt(record["cv_results"]["mean_validation_error"][record["best_index"]], 3))]
    if test_scores is not None:
        cards += [("test fit", f"{fmt(test_scores['fit %'], 3)} %"), ("test RMSE", fmt(test_scores["RMSE"], 3))]
    if resid is not None:
        cards.append(("residuals", "white and independent" if resid.white and resid.independent else "model error"))
    html = '<div class="cards">' + "".join(f"<div class=card><span>{esc(k)}</span><b>{esc(fmt(v))}</b></div>"
                                          for k, v in cards) + "</div>"
    if record is not None:
        criterion = record.get("criterion") or {"name": "free_run"}
        scored = ("its free run" if criterion["name"] == "free_run" else
                  f"its {criterion['horizon']}-step predictions (windows restarted from the measured output every "
                  f"{criterion['horizon']} samples: {criterion.get('reason', '')})")
        html += ("<p class=note>The validation error is the chosen candidate's mean over the validation blocks of "
                 f"the RMSE of {esc(scored)} over the output's standard deviation (lower is better).</p>")
    html += "<h3>The chosen model's equations</h3>" + equations
    if test_figs:
        html += "<h3>Test record</h3>" + test_figs
    return html


def _feedback_text(advice):
    """The advice's feedback finding (records written before the innovations test have no effect size)."""
    if advice.feedback is None:
        return f"cannot tell ({getattr(advice, 'feedback_note', None) or 'no residual noise'})"
    effect = getattr(advice, "feedback_effect", None)
    if effect is None:
        return f"p = {advice.feedback:.2g} that future inputs do not predict the output"
    return (f"p = {advice.feedback:.2g} that the inputs' innovations do not predict the output; they explain "
            f"{100 * effect:.2g} % of an ARX residual: " + ("closed loop" if advice.closed_loop else "open loop"))


def _advice_rows(advice):
    rows = [("input delay", f"{advice.input_delay} sample(s) ({advice.input_delay * advice.dt:.4g} s)"
             + ("" if advice.delay_resolved else ", not resolved (lags score alike)")),
            ("input hold", advice.input_hold + (f" (per input: {advice.input_holds})"
                                                if len(set(advice.input_holds)) > 1 else "")),
            ("offsets (mean above the standard deviation)", ", ".join(advice.offsets) or "none"),
            ("drift (trend no input has)", ", ".join(advice.drift) or "none"),
            ("saturation", "; ".join(f"y{j} {side} level {level:.6g} ({100 * frac:.1f} % of the samples)"
                                     for j, side, level, frac in advice.saturation) or "none"),
            ("feedback", _feedback_text(advice)),
            ("open-loop unstable outputs (ARX poles)", ", ".join(f"y{j}" for j in getattr(advice, "unstable", []))
             or "none"),
            ("integrating outputs (a pole slower than half the record)",
             ", ".join(f"y{j}" for j in getattr(advice, "integrating", [])) or "none"),
            ("persistent excitation order of the inputs", fmt(list(advice.excitation))),
            ("outputs' 95 % bandwidth [Hz]", fmt(list(np.ravel(advice.bandwidth)))),
            ("samples per period", fmt(list(np.ravel(advice.samples_per_period)))),
            ("proposed terms", "; ".join(str(p) for p in advice.proposed_terms) or "none")]
    return rows


def _data(model, X, y, dt, record, n_init):
    n = y.shape[0]
    rows = [("samples", n), ("sampling interval dt [s]", dt), ("duration [s]", None if dt is None else n * dt),
            ("inputs", X.shape[1]), ("outputs", y.shape[1]), ("samples that start a free run (n_init)", n_init)]
    html = key_values(rows)
    if record is None:
        return html + "<p class=note>The model carries no identification record (identification_): the data advice " \
                      "is not shown.</p>"
    settings = record.get("data") or {}
    advice = settings.get("advice")
    html += "<h3>What the data advice found</h3>"
    if advice is None:
        html += "<p class=note>The record was too short for the data advice (or the model file does not keep it).</p>"
    elif isinstance(advice, str):
        html += f"<pre>{esc(advice)}</pre>"
    elif isinstance(advice, dict):
        html += key_values(sorted((k, fmt(v)) for k, v in advice.items()))
    else:
        html += key_values(_advice_rows(advice))
        html += "".join(f"<div class=warn>{esc(w)}</div>" for w in advice.warnings)
    extra = [("derivative bandwidth [Hz]", settings.get("bandwidth")),
             ("derivative methods", ", ".join(settings.get("derivatives") or {}))]
    html += "<h3>What the search derived from it</h3>" + key_values([(k, fmt(v)) for k, v in extra])
    return html


def _choice(record):
    from ..plotting import plot_pareto_front

    chosen, table_ = record["settings"], record["cv_results"]
    best = record["best_index"]
    html = "<h3>Chosen settings</h3>" + key_values([(k, fmt(v)) for k, v in chosen.items()])
    html += ("<p class=note>The parsimony rule: the sparsest candidate whose mean validation error is within one "
             "standard error of the best one; the chosen settings are then refitted on the whole record.</p>")
    try:
        fig, (ax,) = new_figure(1, figsize=(7, 4))
        plot_pareto_front(record, ax=ax)
        html += figure(fig, "Every candidate scored on all validation blocks: number of terms against validation "
                            "error; the Pareto front and the chosen model (star)")
    except ValueError as exc:
        html += f"<p class=note>No Pareto front to draw: {esc(exc)}</p>"
    eqs = table_.get("equations")
    headers = ["row", "terms", "validation error", "family", "library", "derivative", "input hold", "input delay",
               "threshold", "refined", "equations"]
    rows, classes = [], {}
    for k, point in enumerate(record["pareto_front"]):
        i = point["index"]
        lines = eqs[i] if eqs is not None and eqs[i] else None
        text = "<br>".join(esc(line) for line in lines) if lines else "<span class=note>not recorded</span>"
        rows.append([i, point["n_terms"], point["validation_error"], table_["family"][i], table_["library"][i],
                     table_["derivative"][i], table_["input_hold"][i], table_["input_delay"][i],
                     table_["threshold"][i], table_["refine"][i], text])
        if i == best:
            classes[k] = "chosen"
    html += "<h3>The Pareto front</h3>" + table(headers, rows, row_classes=classes, raw=("equations",))
    html += ("<p class=note>Each point's equations are those of its fit on the last validation fold's training "
             "part (the chosen row, highlighted, is refitted on the whole record: its final equations are above).</p>")
    return html


def _blocks(model, X, y, dt, record, n_init, labels):
    """The validation blocks: the candidates' out-of-sample errors, and the final model's free run of each block."""
    table_, best = record["cv_results"], record["best_index"]
    splits = record.get("splits") or []
    n_folds = sum(1 for k in table_ if k.startswith("split") and k.endswith("_validation_error"))
    rows = [[k, (splits[k]["train"] if k < len(splits) else ""), (splits[k]["validation"] if k < len(splits) else ""),
             table_[f"split{k}_validation_error"][best]] for k in range(n_folds)]
    html = table(["fold", "trained on", "validated on", "chosen candidate's error"], rows)
    html += ("<p class=note>These errors are out of sample: the chosen candidate fitted on each fold's training part. "
             "The figures below simulate the final model, refitted on the whole record (blocks included), from the "
             "start of each block: in sample.</p>")
    blocks = record.get("blocks") or []
    if not blocks or not all(len(b) == 2 for b in blocks):
        return html + "<p class=note>Several records: the blocks are listed above, not drawn.</p>"
    from ..plotting import plot_output_error

    drawn = [(k, int(a), int(b)) for k, (a, b) in enumerate(blocks) if int(b) <= y.shape[0] and b - a > n_init + 1]
    if not drawn:
        return html
    fig, axes = new_figure(len(drawn), figsize=(11, 0.6 + 2.4 * len(drawn)))
    for ax, (k, a, b) in zip(axes, drawn):
        pred, failure = _free_run(model, X[a:b], y[a:b], n_init)
        if failure:
            html += f"<div class=warn>Block {k}: the free run failed: {esc(failure)}</div>"
        t0 = a * (dt or 1.0)
        plot_output_error(None, y[a:b], {"final model": pred}, n_init=n_init, dt=dt, output_label=labels[0],
                          zoom=False, ax=ax)
        ax.set_title(f"validation block {k}: samples {a} to {b}", fontsize=9)
        ax.set_xlabel(("time [s]" if dt else "sample") + f" from the block's start ({t0:.4g})")
    return html + figure(fig, "Each validation block: the measured output (black) and the final model's "
                              "simulation error, simulated from the block's first n_init samples")


def _residuals(model, X_val, y_val, n_init):
    from ..plotting import plot_residual_analysis
    from ..uncertainty import residual_analysis

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            analysis = residual_analysis(model, _inputs(X_val), y_val, kind="free_run", n_init=n_init)
    except Exception as exc:
        return None, f"<p class=note>No residual analysis: {esc(type(exc).__name__)}: {esc(exc)}</p>"
    n_panels = y_val.shape[1] * (1 + X_val.shape[1])
    fig, axes = new_figure(n_panels, figsize=(9, 1.2 + 1.9 * n_panels))
    plot_residual_analysis(analysis, ax=axes)
    verdict = "passed" if analysis.white and analysis.independent else "failed"
    html = (f"<p>The free-run residuals of the last validation block: {esc(analysis.message())} "
            f"(tests {verdict}).</p>")
    html += figure(fig, "Autocorrelation of the residuals and their cross-correlation with the inputs, with the "
                        f"{round(100 * (1 - analysis.test.alpha))} % bounds of white, independent residuals")
    return analysis, html


def _band(model, X_val, y_val, n_init, test, test_pred, dt, labels):
    from ..uncertainty import conformal_calibration

    try:
        cal = conformal_calibration(model, _inputs(X_val), y_val, n_init=n_init)
    except Exception as exc:
        return f"<p class=note>No calibrated band: {esc(type(exc).__name__)}: {esc(exc)}</p>"
    rows = [("band", cal.name), ("half-width per output", fmt(list(cal.half_width))),
            ("calibration errors per output", cal.n_scores)]
    html = ""
    if test is None or test_pred is None or not np.all(np.isfinite(test_pred)):
        rows.append(("coverage", "no test record (or its free run diverged): no coverage to check"))
        return key_values(rows)
    X_t, y_t = test
    band = cal.around(test_pred)
    coverage = band.coverage(y_t, first=n_init)
    rows.append((f"coverage on the test record (from sample {n_init})", f"{100 * coverage:.1f} %"))
    html += key_values(rows)
    from ..plotting import zoom_window

    a, b = zoom_window(y_t - test_pred, min(len(y_t), max(200, len(y_t) // 20)))
    fig, axes = new_figure(min(y_t.shape[1], _MAX_OUTPUTS), figsize=(10, 3.4 * min(y_t.shape[1], _MAX_OUTPUTS)))
    t = np.arange(a, b) * (dt or 1.0)
    for j, ax in enumerate(axes):
        ax.fill_between(t, band.lower[a:b, j], band.upper[a:b, j], color="tab:blue", alpha=0.25, label=cal.name)
        ax.plot(t, band.prediction[a:b, j], color="tab:blue", lw=1.0, label="free run")
        ax.plot(t, y_t[a:b, j], color="black", lw=0.8, label="measured")
        ax.set_ylabel(labels[j])
        ax.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("time [s]" if dt else "sample")
    html += figure(fig, "The calibrated band around the test free run, on the window where the error is largest")
    html += ("<p class=note>Calibrated on the last validation block (split conformal, absolute free-run errors); "
             "the final model was refitted on that block too, so the band may be narrow: the test coverage says.</p>")
    return html


def _parameters(model):
    if not getattr(model, "refinement_", None):
        return "<p class=note>The model was not refined by its simulation error: no parameter covariance.</p>"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            errors = model.standard_errors()
        except Exception as exc:
            return f"<p class=note>No standard errors: {esc(exc)}</p>"
    html = "".join(f"<div class=warn>{esc(w.message)}</div>" for w in caught
                   if type(w.message).__name__ == "ModelErrorWarning")
    return html + table(["parameter", "standard error"], sorted(errors.items()), sortable=True)


def _candidates(record):
    table_, best = record["cv_results"], record["best_index"]
    n_folds = sum(1 for k in table_ if k.startswith("split") and k.endswith("_validation_error"))
    cols = list(_CV_COLUMNS) + [f"split{k}_validation_error" for k in range(n_folds)] + [
        "mean_validation_error", "std_validation_error", "fit_time", "status"]
    n = len(table_["family"])
    rows, classes = [], {}
    for i in range(n):
        rows.append([i] + [table_[c][i] for c in cols])
        if i == best:
            classes[i] = "chosen"
        elif table_["status"][i] != "ok":
            classes[i] = "failed"
    n_failed = sum(1 for s in table_["status"] if s != "ok")
    html = (f"<p>{n} candidates, {n_failed} failed (their reasons in the status column); the chosen row is "
            "highlighted. Click a column's heading to sort.</p>")
    headers = ["row"] + [c.replace("_validation_error", "").replace("_", " ") for c in cols]
    return html + '<div class=scroll>' + table(headers, rows, sortable=True, row_classes=classes) + "</div>"


def _about(model, record, timings):
    import matplotlib
    import scipy

    versions = [("sindybench", __version__), ("python", platform.python_version()), ("numpy", np.__version__),
                ("scipy", scipy.__version__), ("matplotlib", matplotlib.__version__)]
    html = "<h3>Versions</h3>" + key_values(versions)
    params = model.get_params(deep=False) if hasattr(model, "get_params") else {}
    html += "<h3>Estimator settings</h3>" + key_values([(k, fmt(v) if not hasattr(v, "get_params") else repr(v))
                                                      for k, v in sorted(params.items())])
    rows = list(timings.items())
    if record is not None:
        fit_times = np.asarray(record["cv_results"].get("fit_time") or [], dtype=float)
        rows.insert(0, ("candidates' fit time (sum) [s]", float(np.nansum(fit_times))))
        rows += [("validation", record.get("validation")), ("n_init", record.get("n_init", _N_INIT))]
    return html + "<h3>Timings and settings of the search</h3>" + key_values([(k, fmt(v)) for k, v in rows])


# -------------------------------------------------------------------- public
def identification_report(model, X, y, *, test=None, path=None, title=None):
    """One self-contained HTML page on an identified model: why it was chosen and how good it is.

    The page opens with what a person wants first: the chosen model's
    equations (MathML, typeset by the browser), its validation and test
    scores, and the test record's measured output with the simulation error
    on the same axis and a zoomed window. Then the data advice's findings
    (offsets, delay, hold, saturation, feedback, proposed terms), the chosen
    settings and the Pareto front (each point's equations in a table), the
    validation blocks, the error spectrum in dB, the residual analysis with
    its bands, the calibrated band and its coverage of the test record, the
    parameters' standard errors (with the residual test's warning), every
    candidate (a sortable table, failures with their reasons), and the
    versions, settings and timings. Figures are inline PNG drawn by
    :mod:`sindybench.plotting` (long records decimated for drawing only);
    nothing is fetched from the network.

    Parameters
    ----------
    model : fitted estimator
        What :func:`sindybench.identify` returns (with ``identification_``),
        or any fitted sindybench estimator (the selection's sections are then
        left out, with a note).
    X : array-like of shape (n_samples, n_inputs) or None
        The estimation record's inputs (the record ``identify`` was given).
    y : array-like of shape (n_samples, n_outputs) or (n_samples,)
        Its measured outputs.
    test : (X_test, y_test), optional
        A test record, never used for any choice: simulated from its first
        ``n_init`` samples and scored from there on.
    path : path-like, optional
        Write the page there (through a temporary file renamed into place; an
        existing file is replaced).
    title : str, optional
        The page's title (default: the model's class and family).

    Returns
    -------
    str
        The HTML text.

    Examples
    --------
    >>> from sindybench import identify
    >>> from sindybench.simulate import simulate
    >>> t = np.arange(1500) * 0.01
    >>> u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    >>> y = simulate(lambda x, u: np.array([-2.0 * x[0] + u[0]]), [0.0], u, dt=0.01)
    >>> model = identify(u[:1000], y[:1000], dt=0.01, families=["first_order"], libraries=["linear"],
    ...                  derivatives=["finite_difference"], n_refine=0, show_progress_bar=False)
    >>> html = identification_report(model, u[:1000], y[:1000], test=(u[1000:], y[1000:]))
    >>> html.startswith("<!DOCTYPE html>"), "Pareto front" in html, "http://" in html
    (True, True, False)
    """
    start = time.perf_counter()
    X, y, test = _check(model, X, y, test)
    if title is not None and not isinstance(title, str):
        raise TypeError(f"title must be a str or None; got {type(title).__name__}.")
    record = _record(model)
    n_init = check_integer((record or {}).get("n_init", getattr(model, "n_lags_", None) or _N_INIT), "n_init",
                           low=1)
    dt = getattr(model, "dt_", None)
    dt = float(dt) if isinstance(dt, (int, float)) and dt > 0 else None
    labels = _labels(model, y)
    try:
        eq_lines = list(model.equations())
    except Exception as exc:
        eq_lines = [f"(no equations: {type(exc).__name__}: {exc})"]
    equations = equations_html(eq_lines)

    test_scores = test_figs = test_pred = None
    timings = {}
    if test is not None:
        t0 = time.perf_counter()
        test_pred, failure = _free_run(model, *test, n_init)
        timings["test free run [s]"] = time.perf_counter() - t0
        test_scores = _scores(test[1], test_pred, n_init)
        test_figs = key_values([(k, fmt(v)) for k, v in test_scores.items()] + [
            ("samples", test[1].shape[0]), ("scored from sample", n_init)])
        if failure or not np.all(np.isfinite(test_pred[n_init:])):
            test_figs += f"<div class=warn>The free run of the test record failed or diverged: {esc(failure)}</div>"
        else:
            test_figs += _error_figures(test[1], test_pred, n_init, dt, labels, "test record")

    # the last validation block (one record), else the last 15 % of the record: residuals and band
    blocks = (record or {}).get("blocks") or []
    if blocks and len(blocks[-1]) == 2 and int(blocks[-1][1]) <= y.shape[0]:
        a, b = int(blocks[-1][0]), int(blocks[-1][1])
    else:
        a, b = int(0.85 * y.shape[0]), y.shape[0]
    resid, resid_html = _residuals(model, X[a:b], y[a:b], n_init)
    sections = [("summary", "Summary", _summary(model, record, equations, test_scores, test_figs, resid, timings)),
                ("data", "The record and the data advice", _data(model, X, y, dt, record, n_init))]
    if record is not None:
        sections += [("choice", "Why this model: the chosen settings and the Pareto front", _choice(record)),
                     ("validation", "Validation blocks", _blocks(model, X, y, dt, record, n_init, labels))]
    else:
        sections.append(("choice", "Why this model", "<p class=note>The model carries no identification record "
                                                      "(identification_): no candidates, front or advice to show.</p>"))
    sections += [("residuals", "Residual analysis", resid_html),
                 ("band", "Calibrated band", _band(model, X[a:b], y[a:b], n_init, test, test_pred, dt, labels)),
                 ("parameters", "Parameters' standard errors", _parameters(model))]
    if record is not None:
        sections.append(("candidates", "Every candidate", _candidates(record)))
    timings["report [s]"] = time.perf_counter() - start
    sections.append(("about", "Versions, settings, timings", _about(model, record, timings)))
    kind = type(model).__name__ + (f", {record['settings'].get('family')}" if record else "")
    text = page(title or f"Identified model: {kind}",
                f"{y.shape[0]} samples, {X.shape[1]} input(s), {y.shape[1]} output(s)"
                + (f", dt = {dt:g} s" if dt else "") + f"; sindybench {__version__}", sections)
    if path is not None:
        write_text_atomic(path, text)
    return text

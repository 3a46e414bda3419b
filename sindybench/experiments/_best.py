"""Extra reports for one designated row per benchmark: k-step prediction, a smoothed start, uncertainty.

The row is declared in the benchmark's module (``Benchmark.reported_model``),
fixed by its structure (the richest physical model, refined) before any test
score is seen: never chosen on the test set. For that row the runner adds,
each under its own protocol name:

- the k-step-ahead RMSE for a few horizons (the extended Kalman filter on the
  test record's own outputs, :func:`sindybench.estimation.k_step_rmse`);
- the free-run score from the initial state the RTS smoother gives over the
  first ``n_init`` test samples only
  (:func:`sindybench.estimation.smooth_initial_state`);
- the standard errors of its refined parameters (``model.standard_errors()``);
- the residual analysis of its free run on the validation block (whiteness and
  independence from past inputs, :func:`sindybench.uncertainty.residual_analysis`);
- the coverage and mean width, on every test set, of its conformal 95 %
  free-run band, calibrated on the validation block (the last ``n_val``
  samples of the estimation record) as the test is run: started from the
  block's first ``n_init`` samples, scored from ``score_from``
  (:func:`sindybench.uncertainty.conformal_calibration`; no refit), and the same
  band with its half-width from the row refitted without the validation block
  (one more fit: the validation block then is held out, as split conformal
  prediction asks; the band is drawn around the row's own simulation);
- the coverage of the test outputs by the 95 % band of a small block-bootstrap
  ensemble (:class:`sindybench.uncertainty.BootstrapEnsemble`).

The noise covariances ``Q`` and ``R`` of the filter and smoother are estimated
on the first training samples (:func:`sindybench.estimation.estimate_noise`).
"""

import logging
import time
import warnings

import numpy as np
from sklearn.base import clone

from ..uncertainty import ModelErrorWarning
from ..metrics import fit_index, r2, rmse

__all__ = ["HORIZONS", "K_STEP_SAMPLES", "free_run_scores", "k_step_scores", "report_best_model",
           "smoothed_start_scores", "test_record"]

logger = logging.getLogger(__name__)

HORIZONS = (1, 10, 100)
"""The k-step-ahead horizons reported (in samples)."""

K_STEP_SAMPLES = 20000
"""The k-step scores cover at most the first this many samples of a test record (Bouc-Wen's sine sweep has 153,000)."""

NOISE_SAMPLES = 2000
"""Training samples on which ``Q`` and ``R`` are estimated (the likelihood search runs the filter many times)."""

NOISE_ITER = 120
"""Nelder-Mead iterations of the noise estimate."""


def k_step_protocol(k):
    """The protocol name of the k-step-ahead score."""
    return (f"k-step ahead, k={k}: extended Kalman filter on the test record's own outputs up to t, "
            f"free run of k samples; RMSE over y[k:], on the first {K_STEP_SAMPLES} samples of longer records")


SMOOTHED_PROTOCOL = ("free run from the smoothed initial state: RTS smoother over the first n_init test samples "
                     "only, scored as the free run")


def test_record(test):
    """``(u, y)`` of a test set as float arrays of shape (n_samples, n_inputs) and (n_samples, n_outputs)."""
    u = np.asarray(test["u"], float)
    u = u.reshape(len(u), -1)
    return u, np.asarray(test["y"], float).reshape(len(u), -1)


def free_run_scores(y, y_pred, first=0):
    """``rmse``, ``r2``, ``fit_index`` of a simulation over the samples from ``first`` on, and ``status``.

    A simulation with a non-finite value anywhere has no scores (status
    ``"diverged (non-finite simulation)"``).
    """
    if not np.all(np.isfinite(y_pred)):
        return {"rmse": None, "r2": None, "fit_index": None, "status": "diverged (non-finite simulation)"}
    return {"rmse": rmse(y[first:], y_pred[first:]), "r2": r2(y[first:], y_pred[first:]),
            "fit_index": fit_index(y[first:], y_pred[first:]), "status": "ok"}


def _failed(exc):
    return f"failed: {type(exc).__name__}: {exc}"


def smoothed_start_scores(estimator, test, n_init, *, Q, R, score_from=0):
    """Free run from the RTS-smoothed initial state of the first ``n_init`` samples; scores and the state.

    Only ``test["u"][:n_init]`` and ``test["y"][:n_init]`` reach the smoother.

    Returns
    -------
    scores : dict
        ``rmse``, ``r2``, ``fit_index`` over the samples from ``score_from`` on,
        ``status``.
    x0 : ndarray of shape (n_states,) or None
    """
    from ..estimation import model_step, smooth_initial_state

    u, y = test_record(test)
    try:
        x0 = smooth_initial_state(estimator, u[:n_init], y[:n_init], Q=Q, R=R)
        states = estimator.simulate(u, x0=x0, on_divergence="nan")
        y_pred = np.asarray(states, float)[:, list(model_step(estimator).output_index)]
    except Exception as exc:  # a diverging filter is a result, not a crash
        return {"rmse": None, "r2": None, "fit_index": None, "status": _failed(exc)}, None
    return free_run_scores(y, y_pred, score_from), x0


def _noise(estimator, X, y):
    from ..estimation import estimate_noise

    start = time.perf_counter()
    Q, R = estimate_noise(estimator, X, y, max_samples=NOISE_SAMPLES, max_iter=NOISE_ITER)
    return Q, R, {"method": f"estimation.estimate_noise on the first {min(NOISE_SAMPLES, len(y))} training samples "
                            f"({NOISE_ITER} Nelder-Mead iterations): diagonal Q and R of the largest innovation "
                            "likelihood",
                  "Q_diag": np.diag(Q).tolist(), "R_diag": np.diag(R).tolist(),
                  "time_s": time.perf_counter() - start}


def k_step_scores(estimator, X, y, tests):
    """``{"noise": ..., "k_step": {test: {k: ...}}}``: a row's k-step scores (``X, y``: its training samples).

    The protocol of the designated row's k-step scores: ``Q`` and ``R``
    estimated on the first training samples, then the filter on each test
    record's own outputs.
    """
    try:
        Q, R, noise = _noise(estimator, X, y)
    except Exception as exc:
        return {"noise": {"status": _failed(exc)}, "k_step": {}}
    return {"noise": noise, "k_step": {name: _k_step(estimator, test, Q, R, HORIZONS) for name, test in tests.items()}}


def _k_step(estimator, test, Q, R, horizons):
    from ..estimation import k_step_rmse

    u, y = (a[:K_STEP_SAMPLES] for a in test_record(test))
    out = {}
    for k in horizons:
        try:
            value = float(k_step_rmse(estimator, u, y, k, Q=Q, R=R))
            out[str(k)] = {"rmse": value, "status": "ok", "protocol": k_step_protocol(k)}
        except Exception as exc:
            out[str(k)] = {"rmse": None, "status": _failed(exc), "protocol": k_step_protocol(k)}
    return out


def _standard_errors(estimator):
    method = getattr(estimator, "standard_errors", None)
    if method is None or getattr(estimator, "refinement_", None) is None:
        return None, "not a refined row: no covariance at a simulation-error optimum"
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            errors = {k: float(v) for k, v in method().items()}
    except Exception as exc:
        return None, _failed(exc)
    warned = [str(w.message) for w in caught if issubclass(w.category, ModelErrorWarning)]
    return errors, ("ok" if not warned else f"warning: {warned[0]}")


def _band(estimator, X, y, tests, test_info, *, n_members, seed):
    start = time.perf_counter()
    info = {"n_members": n_members, "alpha": 0.05, "coverage": {},
            "protocol": (f"95 % band of a {n_members}-member circular-block bootstrap ensemble of the row (refit on "
                         "the estimation record, refinement included), each member started from the first n_init "
                         "test samples; coverage = fraction of the scored test outputs inside the band of the model's output; "
                         "measurement_coverage: inside the band with block-resampled training residuals added "
                         "(prediction_band(noise=True), a band for new measurements)")}
    try:
        from ..uncertainty import BootstrapEnsemble, prediction_band

        ens = BootstrapEnsemble(clone(estimator), n_members=n_members, random_state=seed).fit(X, y)
    except Exception as exc:
        info.update(status=_failed(exc), time_s=time.perf_counter() - start)
        return info
    info.update(n_failed=int(ens.n_failed_), block_length=int(ens.block_length_))
    from ..uncertainty._conformal import calibration_ranges, extrapolation

    ranges = calibration_ranges(X, y)  # the members were fitted on resamples of the estimation record
    for name, test in tests.items():
        u, yt = test_record(test)
        n_init, first = test_info[name]["n_init"], test_info[name]["score_from"]
        try:
            band = prediction_band(ens, u, y_init=yt[:n_init])
            noisy = band.with_noise(ens, random_state=seed)
        except Exception as exc:
            info["coverage"][name] = {"coverage": None, "status": _failed(exc)}
            continue
        entry = {"n_diverged": band.n_diverged, "status": "ok",
                 "extrapolation": extrapolation(ranges, u, band.median[:, band.outputs])}
        for tag, b in (("", band), ("measurement_", noisy)):
            lo, hi = b.lower[first:, b.outputs], b.upper[first:, b.outputs]
            entry[tag + "coverage"] = float(np.mean((yt[first:] >= lo) & (yt[first:] <= hi)))
            entry[tag + "mean_width"] = float(np.mean(hi - lo))
        info["coverage"][name] = entry
    info.update(status="ok", time_s=time.perf_counter() - start)
    return info


CONFORMAL_PROTOCOL = ("split conformal band of the free run, calibrated on the validation block (the last n_val "
                      "samples of the estimation record, which the refined row was also fitted on; never the test set): the "
                      "block simulated from its first n_init samples as the test is, the 95 % half-width the "
                      "ceil((n + 1) 0.95)-th smallest of its absolute errors from score_from on; coverage = fraction "
                      "of the scored test outputs inside prediction +- half-width")

HELD_OUT_PROTOCOL = ("the same band with its half-width from the errors on the validation block of the row refitted "
                     "on the training block only (the validation block held out of the fit, as split conformal "
                     "prediction asks; one more fit of the row), drawn around the row's own test simulation")

HELD_OUT_NAME = "conformal 95 % free-run band, held-out refit"


def _held_out(estimator, X, y, n_val, tests, test_info, simulations):
    """The conformal band, its half-width from the row refitted without the validation block (``HELD_OUT_PROTOCOL``)."""
    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the fit's own warnings are the row's, reported with it
            held = clone(estimator).fit(X[:-n_val], y[:-n_val])
    except Exception as exc:
        return {"alpha": 0.05, "protocol": HELD_OUT_PROTOCOL, "name": HELD_OUT_NAME, "coverage": {},
                "status": _failed(exc), "time_s": time.perf_counter() - start}
    out = _conformal(estimator, X[-n_val:], y[-n_val:], tests, test_info, simulations, calibrated=held)
    out.update(name=HELD_OUT_NAME, time_s=time.perf_counter() - start)
    return out


def _residuals(estimator, X_val, y_val, n_init):
    from ..uncertainty import residual_analysis

    try:
        ra = residual_analysis(estimator, X_val, y_val, kind="free_run", n_init=n_init)
    except Exception as exc:
        return {"status": _failed(exc)}
    return {"status": "ok", "kind": "free_run", "n_init": n_init, "white": ra.white, "independent": ra.independent,
            "message": ra.message(), "test": ra.test.to_dict()}


def _conformal(estimator, X_val, y_val, tests, test_info, simulations=None, *, calibrated=None):
    """The conformal band of each test set; ``simulations`` (``{test: y_pred}``) are the runner's, not redone.

    ``calibrated``: the model whose validation errors set the half-width
    (default ``estimator``); the band is drawn around ``estimator``'s prediction.
    """
    from ..uncertainty import ExtrapolationWarning, conformal_calibration

    start = time.perf_counter()
    out = {"alpha": 0.05, "protocol": CONFORMAL_PROTOCOL if calibrated is None else HELD_OUT_PROTOCOL,
           "coverage": {}}
    calibrated = estimator if calibrated is None else calibrated
    calibrations = {}
    for name, test in tests.items():
        u, yt = test_record(test)
        n_init, first = test_info[name]["n_init"], test_info[name]["score_from"]
        try:
            if (n_init, first) not in calibrations:  # one calibration per test protocol
                calibrations[n_init, first] = conformal_calibration(calibrated, X_val, y_val, alpha=0.05,
                                                                    n_init=n_init, score_from=first)
            cal = calibrations[n_init, first]
            y_pred = (simulations or {}).get(name)
            with warnings.catch_warnings():  # an extrapolating band is recorded below, not printed
                warnings.simplefilter("ignore", ExtrapolationWarning)
                band = cal.band(estimator, u, y_init=yt[:n_init]) if y_pred is None else cal.around(y_pred, X=u)
        except Exception as exc:
            out["coverage"][name] = {"coverage": None, "status": _failed(exc)}
            continue
        out["name"] = cal.name if calibrated is estimator else HELD_OUT_NAME
        out["coverage"][name] = {"coverage": band.coverage(yt, first), "mean_width": band.mean_width(first),
                                 "half_width": cal.half_width.tolist(), "n_scores": cal.n_scores, "status": "ok",
                                 "extrapolation": band.extrapolation}
    out.update(status="ok", time_s=time.perf_counter() - start)
    return out


def _extrapolation_note(found):
    """``"; extrapolates: ..."`` when the test left the band's calibration range (``ConformalBand.extrapolation``)."""
    if not found or not found.get("fraction"):
        return ""
    return (f"; **extrapolates**: {100 * found['fraction']:.1f} % of the test samples outside the calibration "
            f"range (inputs {100 * found['fraction_inputs']:.1f} %, predicted outputs "
            f"{100 * found['fraction_outputs']:.1f} %; calibration record: {found['calibration']}), not calibrated there")


def report_best_model(benchmark, results, fitted, X, y, n_train, tests, *, quick, seed=0, simulations=None):
    """The extra reports of the benchmark's designated row (see the module docstring).

    Parameters
    ----------
    benchmark : Benchmark
    results : dict
        The runner's results (its ``test_sets`` and ``models``).
    fitted : dict
        ``{model key: fitted estimator or None}``.
    X, y : ndarray
        The estimation record (training + validation block); the first
        ``n_train`` samples are the training block.
    tests : dict
        ``{test name: Bunch}`` as evaluated.
    quick : bool
    seed : int
    simulations : dict, optional
        The runner's ``{test name: {model key: y_pred or None}}``; the conformal
        band is drawn around the row's simulation instead of simulating again.

    Returns
    -------
    dict or None
        ``None`` when the benchmark designates no row.
    """
    key = benchmark.reported_model
    if key is None:
        return None
    spec = benchmark.model(key)
    out = {"key": key, "label": spec.label,
           "choice": "designated in the benchmark's module (Benchmark.reported_model) by its structure, not by "
                     "any test score",
           "horizons": list(HORIZONS), "smoothed_protocol": SMOOTHED_PROTOCOL}
    estimator = fitted.get(key)
    if estimator is None:
        out["status"] = "not fitted"
        return out
    start = time.perf_counter()
    try:
        Q, R, out["noise"] = _noise(estimator, X[:n_train], y[:n_train])
    except Exception as exc:
        out["noise"] = {"status": _failed(exc)}
        Q = R = None
    out["k_step"], out["smoothed_start"] = {}, {}
    if Q is not None:  # without Q and R neither the filter nor the smoother runs
        for name, test in tests.items():
            info = results["test_sets"][name]
            out["k_step"][name] = _k_step(estimator, test, Q, R, HORIZONS)
            out["smoothed_start"][name] = smoothed_start_scores(
                estimator, test, info["n_init"], Q=Q, R=R, score_from=info["score_from"])[0]
    out["standard_errors"], out["standard_errors_status"] = _standard_errors(estimator)
    n_val = results.get("n_validation") or 0
    if n_val:  # the validation block: the last n_val samples of the estimation record
        n_init = min(info["n_init"] for info in results["test_sets"].values())
        out["residual_analysis"] = _residuals(estimator, X[-n_val:], y[-n_val:], n_init)
        runs = {name: sims.get(key) for name, sims in (simulations or {}).items()}
        out["conformal_band"] = _conformal(estimator, X[-n_val:], y[-n_val:], tests, results["test_sets"], runs)
        keep = spec.train_rows(quick=quick, n_train=n_train, n_samples=len(y))  # the rows the row was fitted on
        out["conformal_band_held_out"] = _held_out(estimator, X[keep], y[keep], n_val, tests, results["test_sets"],
                                                   runs)
    n_members = benchmark.band_members_quick if quick else benchmark.band_members
    if n_members:
        keep = spec.train_rows(quick=quick, n_train=n_train, n_samples=len(y))  # the rows the row was fitted on
        out["band"] = _band(estimator, X[keep], y[keep], tests, results["test_sets"], n_members=n_members, seed=seed)
    else:
        out["band"] = {"n_members": 0, "status": "skipped: " + (benchmark.band_skip_reason or "no band members")}
    out["time_s"] = time.perf_counter() - start
    out["status"] = "ok"
    return out


def _num(value, fmt=".4g"):
    return "-" if value is None else format(value, fmt)


def best_model_markdown(best, h="##"):
    """Markdown lines of the designated row's extra reports (empty without one)."""
    if not best:
        return []
    out = ["", f"{h} Designated row `{best['key']}`: prediction modes and uncertainty", "",
           f"{best['label']}; {best['choice']}."]
    if best.get("status") != "ok":
        return out + ["", f"Not reported: {best.get('status')}."]
    noise = best.get("noise", {})
    out.append("Noise covariances: " + (noise["method"] + f"; Q diagonal {[float(f'{q:.3g}') for q in noise['Q_diag']]}, "
                                         f"R diagonal {[float(f'{r:.3g}') for r in noise['R_diag']]}."
                                         if "method" in noise else noise.get("status", "-")))
    if best["k_step"]:
        ks = best["horizons"]
        out += ["", "Protocols: " + "; ".join(f"`k={k}`: {k_step_protocol(k)}" for k in ks)
                + f"; `smoothed start`: {best['smoothed_protocol']}.", "",
                "| test set | " + " | ".join(f"RMSE k={k}" for k in ks) + " | smoothed start RMSE | fit index |",
                "|" + "---|" * (len(ks) + 3)]
        for name, rows in best["k_step"].items():
            sm = best["smoothed_start"][name]
            cells = [_num(rows[str(k)]["rmse"]) for k in ks]
            out.append(f"| {name} | " + " | ".join(cells) + f" | {_num(sm['rmse'])} | {_num(sm['fit_index'], '.2f')} |")
    se = best.get("standard_errors")
    status = best.get("standard_errors_status", "-")
    out += ["", "Standard errors of the refined parameters (Jacobian at the optimum, white residuals): "
            + (", ".join(f"{k} {v:.3g}" for k, v in se.items()) if se else status) + "."
            + (f" **Warning**: {status[len('warning: '):]}" if se and status.startswith("warning: ") else "")]
    ra = best.get("residual_analysis")
    if ra:
        out.append("Residual analysis of the free run on the validation block (Ljung-Box whiteness, cross-correlation "
                   "with past inputs): " + (f"residuals {ra['message']}." if ra["status"] == "ok" else ra["status"]))
    for conformal in (best.get("conformal_band"), best.get("conformal_band_held_out")):
        if not conformal:
            continue
        if conformal.get("status") != "ok":
            out.append(f"{conformal['name']}: {conformal.get('status')}.")
            continue
        cells = ", ".join(f"`{k}` " + (f"{v['coverage']:.3f} (mean width {v['mean_width']:.3g}"
                                        f"{_extrapolation_note(v.get('extrapolation'))})" if v["status"] == "ok"
                                        else v["status"]) for k, v in conformal["coverage"].items())
        out.append(f"{conformal.get('name', 'conformal 95 % free-run band')} ({conformal['protocol']}; "
                   f"{conformal['time_s']:.2f} s): coverage {cells}.")
    band = best.get("band", {})
    if band.get("status") == "ok":
        cov = ", ".join(f"`{k}` {_num(v['coverage'], '.3f')} (with the residuals: "
                        f"{_num(v.get('measurement_coverage'), '.3f')}{_extrapolation_note(v.get('extrapolation'))})"
                        for k, v in band["coverage"].items())
        out.append(f"95 % prediction band ({band['protocol']}; {band['n_failed']} failed fits): coverage {cov}.")
    else:
        out.append(f"95 % prediction band: {band.get('status', '-')}.")
    return out

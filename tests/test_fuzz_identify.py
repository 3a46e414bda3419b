"""Property-based tests of the newer surfaces (Hypothesis): ``identify`` / ``IdentifyCV``, the data advice,
the prediction-error refinement, the conformal bands and the residual analysis.

Every generated case -- parameters drawn from valid values and from values of the wrong
type, sign, size or kind, and records with bad shapes or values (NaN, inf, huge, constant,
short, 1-D, strings, several records that disagree) -- must end in either a correct result
(a model that predicts the record's shape, a report of the record, finite statistics) or a
``ValueError`` / ``TypeError`` whose message names the argument that was wrong, within a
second or so. Any other exception (an ``IndexError``, ``ZeroDivisionError``, an internal
``max()`` or joblib message, a NaN statistic) is a failure.

By default each property runs a small, derandomized set of examples on records of at most
160 samples with tiny search budgets; ``pytest --runslow`` runs many more, freshly drawn.
"""

import math
import re
import time
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is missing")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from _fuzz import nan_index, spoil  # noqa: E402

from sindybench.baselines import ARX  # noqa: E402
from sindybench.dynamics import Dynamics  # noqa: E402
from sindybench.identify import (IdentifyCV, advice, detect_input_hold, detect_saturation, estimate_delay,  # noqa: E402
                                 excitation_order, identify)
from sindybench.libraries import POW  # noqa: E402
from sindybench.refine import refine_prediction_error  # noqa: E402
from sindybench.uncertainty import (conformal_calibration, conformal_quantile, residual_analysis,  # noqa: E402
                                    residual_test)

QUICK_EXAMPLES, SLOW_EXAMPLES = 12, 300
TIME_LIMIT = 30.0  # seconds per case on a busy 2-core machine (a case takes well under a second alone)
DT = 0.05

# Values of the wrong kind that any parameter may receive.
ODD = st.sampled_from([None, True, 0, -1, 2, 0.0, -0.5, 0.5, 1e-300, 1e300, math.nan, math.inf, "a", "", [], (3,),
                       2**70])
# Arguments (besides the parameters) that an error message may name.
ARGUMENTS = {"X", "y", "u", "dt", "y_init", "x0", "inputs", "outputs", "residuals", "scores", "model", "records",
             "record", "samples", "n_samples", "input", "output", "column", "dynamics", "gain", "noise", "free",
             "horizon", "alpha"}


def _params(pools):
    """Up to three of the parameters, each from its pool of plausible values (2 in 3) or from ODD."""
    @st.composite
    def draw_params(draw):
        if not pools:
            return {}
        names = draw(st.lists(st.sampled_from(sorted(pools)), max_size=3, unique=True))
        return {name: draw(st.one_of(st.sampled_from(pools[name]), st.sampled_from(pools[name]), ODD))
                for name in names}
    return draw_params()


def _signals(n, n_in, n_out, freqs):
    t = np.arange(n) * DT
    sig = [np.sin(f * t + k) + 0.3 * np.sin(2.7 * f * t) for k, f in enumerate(freqs)]
    X = np.column_stack(sig[:n_in]) if n_in else np.empty((n, 0))
    return X, np.column_stack(sig[n_in:n_in + n_out])


@st.composite
def records(draw, *, several=True, min_inputs=0):
    """``(X, y)`` of one record (sometimes several), sometimes spoiled."""
    n = draw(st.one_of(st.integers(0, 12), st.integers(100, 160), st.integers(100, 160)))
    n_in, n_out = draw(st.integers(min_inputs, 2)), draw(st.integers(1, 2))
    freqs = draw(st.lists(st.floats(0.5, 4.0), min_size=n_in + n_out, max_size=n_in + n_out))
    X, y = _signals(n, n_in, n_out, freqs)
    which = draw(st.sampled_from(["X", "y"]))
    a = X if which == "X" else y
    kind = draw(st.one_of(st.just("none"), st.just("none"), st.sampled_from(
        ["nan", "inf", "huge", "large", "tiny", "strings", "3d", "1d", "none-value", "short", "empty", "constant",
         "offset"])))
    huge = {"huge": 1e200, "large": 1e120}.get(kind, 1.0)
    a = spoil(a, "huge" if kind == "large" else kind, index=nan_index(draw, a, kind, st.integers), huge=huge)
    X, y = (a, y) if which == "X" else (X, a)
    if several and draw(st.integers(0, 3)) == 0:  # several records: the same one twice, the second maybe cut
        cut = draw(st.sampled_from([None, None, 5]))
        sl = slice(None, cut)
        X = [X, X[sl] if hasattr(X, "shape") and np.ndim(X) >= 1 else X]
        y = [y, y[sl] if hasattr(y, "shape") and np.ndim(y) >= 1 else y]
    return X, y


def _names_an_argument(message, names):
    words = set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*", message))
    return bool(words & (set(names) | ARGUMENTS))


def _check_case(what, call, names, check_result):
    """``call()`` ends in a result that ``check_result`` accepts, or in a named ValueError / TypeError."""
    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with np.errstate(all="ignore"):
                result = call()
    except (ValueError, TypeError) as exc:
        message = str(exc)
        for internal in ("max() arg", "min() arg", "n_jobs == 0 in Parallel", "operands could not be broadcast"):
            assert internal not in message, f"{what}: an internal message: {message}"
        assert _names_an_argument(message, names), f"{what}: the error names no argument: {message}"
    else:
        check_result(result)
    elapsed = time.perf_counter() - start
    assert elapsed < TIME_LIMIT, f"{what} took {elapsed:.0f} s"


def _run(runslow, strategy, check, n_quick=QUICK_EXAMPLES):
    @settings(max_examples=SLOW_EXAMPLES if runslow else n_quick, derandomize=not runslow, deadline=None,
              database=None, suppress_health_check=list(HealthCheck))
    @given(case=strategy)
    def prop(case):
        check(*case)

    prop()


def _n_samples(y):
    return sum(np.shape(r)[0] for r in y) if isinstance(y, list) else np.shape(y)[0]


# ----------------------------------------------------------------------------- identify and IdentifyCV
IDENTIFY_PARAMS = {
    "n_blocks": [2, 3, 1], "block_size": [0.1, 0.2, 0.5], "max_path": [1, 2], "screen_keep": [0.5, 1.0, 1.5],
    "max_terms": [1, 4], "n_init": [3, 10, 200], "time_budget": [5.0, 1e-9], "max_candidates": [1, 3],
    "input_delay": [0, 2, 10**6], "input_hold": ["zoh", "linear", "cubic"], "n_jobs": [1, 0, -1, -3],
    "validation": ["blocks", "records", "x"], "study_name": ["s", 3], "random_state": [0, 1],
    "families": [["first_order"], ["order2"], [], "first_order", ["latent9"]],
    "libraries": [["linear"], ["poly2"], ["cubic"]], "storage": [None, 3, "", "sqlite:///"],
}
# the tiny search every case starts from
IDENTIFY_BASE = dict(families=["first_order"], libraries=["linear"], derivatives=["finite_difference"], n_refine=0,
                     max_candidates=4, max_path=2, show_progress_bar=False)


def _identify_case(params, data, dt, as_function):
    X, y = data
    kwargs = {**IDENTIFY_BASE, **params}
    if as_function:
        call = lambda: identify(X, y, dt=dt, **kwargs)  # noqa: E731
    else:
        call = lambda: IdentifyCV(dt=dt, **kwargs).fit(X, y).best_estimator_  # noqa: E731

    def ok(model):
        X0 = X[0] if isinstance(X, list) else X
        y0 = y[0] if isinstance(y, list) else y
        pred = model.predict(X0, y_init=y0)
        assert np.shape(pred)[0] == np.shape(y0)[0], f"identify({params}): prediction of shape {np.shape(pred)}"

    _check_case(f"identify({params}, dt={dt})", call, set(IDENTIFY_PARAMS) | {"dt", "derivatives"}, ok)


@st.composite
def identify_cases(draw):
    return (draw(_params(IDENTIFY_PARAMS)), draw(records(min_inputs=0)),
            draw(st.sampled_from([DT, DT, 0.0, -1.0, math.nan, "0.1", None])), draw(st.booleans()))


def test_identify_ends_in_a_model_or_a_named_error(runslow):
    _run(runslow, identify_cases(), _identify_case, n_quick=25)


# ----------------------------------------------------------------------------- the data advice
ADVICE_FUNCS = {
    "advice": (lambda X, y, dt, p: advice(X, y, dt=dt, **p), {"max_delay": [0, 3, 20, 10**6], "max_order": [1, 5, 0]}),
    "estimate_delay": (lambda X, y, dt, p: estimate_delay(X, y, dt, **p),
                       {"max_delay": [0, 3, 10**6], "hold": ["zoh", "linear", "x"], "na": [0, 2, -1],
                        "nb": [1, 3, 0], "rtol": [0.01, -1.0]}),
    "detect_input_hold": (lambda X, y, dt, p: detect_input_hold(X), {}),
    "excitation_order": (lambda X, y, dt, p: excitation_order(X, **p), {"max_order": [1, 5, 0], "tol": [1e-9, -1.0]}),
    "detect_saturation": (lambda X, y, dt, p: detect_saturation(y, **p),
                          {"min_fraction": [0.005, 0.5, -1.0, 2.0], "ratio": [4.0, 0.0, -1.0]}),
}


@st.composite
def advice_cases(draw):
    name = draw(st.sampled_from(sorted(ADVICE_FUNCS)))
    X, y = draw(records(several=False, min_inputs=1))
    return name, draw(_params(ADVICE_FUNCS[name][1])), X, y, draw(st.sampled_from([DT, DT, 0.0, -1.0, math.inf]))


def _advice_case(name, params, X, y, dt):
    func, pools = ADVICE_FUNCS[name]

    def ok(result):
        if name == "advice":
            assert result.n_samples == np.shape(y)[0] and np.all(np.isfinite(result.output_std)), str(result)
        elif name == "estimate_delay":
            assert isinstance(result, (int, np.integer)) and result >= 0, result

    _check_case(f"{name}({params}, dt={dt})", lambda: func(X, y, dt, params), set(pools) | {"hold"}, ok)


def test_advice_ends_in_a_report_or_a_named_error(runslow):
    _run(runslow, advice_cases(), _advice_case, n_quick=30)


# ----------------------------------------------------------------------------- prediction-error refinement
_TERMS = [((0, POW, 1, 0),), ((1, POW, 1, 0),)]
PE_PARAMS = {"horizon": [1, 3, 10**6, 0], "gain": [[[0.5]], [[0.5, 0.1]], [[math.nan]]],
             "free_gain": [True, False], "noise": [(1e-3, 1e-2), ([1e-3], [1e-2]), (-1.0, 1.0)],
             "prune": [0.0, 0.1, -1.0], "free": [None, [], [(0, 0)]]}


@st.composite
def pe_cases(draw):
    X, y = draw(records(several=False, min_inputs=1))
    x0 = draw(st.sampled_from([[0.0], [0.0, 1.0], [math.nan], "a"]))
    return draw(_params(PE_PARAMS)), X, y, x0


def _pe_case(params, X, y, x0):
    start = Dynamics.from_terms(_TERMS, [[-1.2], [0.8]], dt=DT)

    def call():
        u = X[:, :1] if isinstance(X, np.ndarray) and X.ndim == 2 else X
        yy = y[:, :1] if isinstance(y, np.ndarray) and y.ndim == 2 else y
        return refine_prediction_error(start, u, yy, x0=x0, **params)

    def ok(result):
        assert np.all(np.isfinite(result.coef)), f"refine_prediction_error({params}): coefficients {result.coef}"

    _check_case(f"refine_prediction_error({params}, x0={x0})", call, set(PE_PARAMS) | {"u", "x0"}, ok)


def test_prediction_error_refinement_ends_in_a_result_or_a_named_error(runslow):
    _run(runslow, pe_cases(), _pe_case, n_quick=15)


# ----------------------------------------------------------------------------- conformal bands, residual tests
_U = np.sin(np.arange(300) * 0.13)[:, None] + 0.5 * np.sin(np.arange(300) * 0.41)[:, None]
_Y = np.convolve(_U[:, 0], [0.0, 0.3, 0.2], "full")[:300, None] + 0.01 * np.random.default_rng(0).normal(size=(300, 1))
_MODEL = ARX(na=1, nb=2).fit(_U, _Y)
UNCERTAINTY_FUNCS = {
    "conformal_calibration": (lambda X, y, p: conformal_calibration(_MODEL, X, y, **p),
                              {"alpha": [0.05, 0.5, 0.0, 1.0], "horizon": [None, 1, 5, 0, 10**6],
                               "block_length": [None, 20, 1, 10**6], "n_init": [None, 2, 10**6],
                               "score_from": [0, 5, -1]}),
    "residual_analysis": (lambda X, y, p: residual_analysis(_MODEL, X, y, **p),
                          {"kind": ["free_run", "one_step", "x"], "n_init": [None, 2, 10**6],
                           "max_lag": [5, 25, 0, 10**6], "alpha": [0.05, 0.0, 1.5]}),
    "residual_test": (lambda X, y, p: residual_test(y, X, **p),
                      {"max_lag": [3, 5, 0, 10**6], "alpha": [0.05, 0.0, 1.5]}),
    "conformal_quantile": (lambda X, y, p: conformal_quantile(y, **p), {"alpha": [0.05, 0.5, 0.0, 1.0]}),
}


@st.composite
def uncertainty_cases(draw):
    name = draw(st.sampled_from(sorted(UNCERTAINTY_FUNCS)))
    n = draw(st.one_of(st.integers(0, 10), st.integers(60, 300)))
    X, y = _U[:n], _Y[:n]
    kind = draw(st.sampled_from(["none", "none", "nan", "inf", "huge", "1d", "short", "2 inputs", "strings"]))
    if kind in ("nan", "inf") and n:
        y = y.copy()
        y[draw(st.integers(0, n - 1))] = np.nan if kind == "nan" else np.inf
    elif kind == "huge":
        y = y * 1e200
    elif kind == "1d":
        y = y[:, 0]
    elif kind == "short":
        X = X[: max(0, n - 3)]
    elif kind == "2 inputs":
        X = np.hstack([X, X])
    elif kind == "strings":
        y = y.astype(str)
    params = draw(_params(UNCERTAINTY_FUNCS[name][1]))
    if name == "conformal_quantile" and "alpha" not in params:
        params["alpha"] = 0.1
    return name, params, X, y


def _uncertainty_case(name, params, X, y):
    func, pools = UNCERTAINTY_FUNCS[name]

    def ok(result):
        if name == "conformal_quantile":
            assert not np.any(np.isnan(result)), f"conformal_quantile({params}): {result}"
        elif name == "conformal_calibration":
            band = result.band(_MODEL, X, y_init=y, y=y)
            assert np.shape(band.lower)[0] == np.shape(X)[0]
        else:
            text = result.message()
            assert "nan" not in text.lower().replace("nan ", ""), f"{name}({params}): {text}"

    _check_case(f"{name}({params})", lambda: func(X, y, params), set(pools) | {"kind", "block_length"}, ok)


def test_uncertainty_functions_end_in_a_result_or_a_named_error(runslow):
    _run(runslow, uncertainty_cases(), _uncertainty_case, n_quick=30)


# ----------------------------------------------------------------------------- what the properties found
@pytest.mark.parametrize("call, match", [
    # each was an unnamed "could not convert string to float" or a numpy ufunc message before
    (lambda: refine_prediction_error(Dynamics.from_terms(_TERMS, [[-1.2], [0.8]], dt=DT), _U[:60], _Y[:60], x0="a"),
     r"x0 must be 1 real number\(s\) \(the initial state\); got 'a'"),
    (lambda: conformal_quantile(np.array([["a"], ["b"]]), 0.1), "scores must be an array of real numbers"),
    (lambda: conformal_quantile(np.array([[1.0], [np.nan]] * 20), 0.1), r"scores \(the calibration errors\) contain"),
    (lambda: detect_saturation(np.empty((0, 1))), "y has 0 samples"),  # was: cannot reshape array of size 0
    (lambda: detect_input_hold([["a"]]), "X could not be converted to a float array"),
    (lambda: excitation_order(np.array([[np.nan]] * 5)), "X contains NaN or inf"),
    # issue 37 item 2
    (lambda: identify(_U * 1e200, _Y * 1e200, dt=DT, **IDENTIFY_BASE), r"X reaches .* beyond 1e\+100.*rescale it"),
    (lambda: identify(_U, _Y, dt=DT, input_delay=10**6, **IDENTIFY_BASE), "input_delay=1000000 samples is not shorter"),
    (lambda: identify(_U, _Y, dt=DT, n_jobs=0, **IDENTIFY_BASE), "n_jobs must be None .*, an integer >= 1, or -1"),
])
def test_cases_the_properties_found(call, match):
    with pytest.raises(ValueError, match=match):
        call()

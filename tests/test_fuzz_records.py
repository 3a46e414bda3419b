"""Property-based tests of fitting on several records (Hypothesis).

Every generated case -- one to three records of random lengths (some too short to
differentiate), then (about every other time) one corruption: a record with other columns
in ``X`` or ``y``, ``X[i]`` and ``y[i]`` of different lengths, NaN or inf in a record, a
list ``X`` of the wrong length or an array instead of a list, the records in a tuple, a 3-D
array, nested lists or an object array, an empty list, 1-D inputs -- must end in either a
fitted model whose ``predict`` on the same lists returns one finite array of the right shape
per record (NaN only after a divergence, which warns), or a ``ValueError`` whose message
names what was wrong: the corrupted record by its index when the other records are sound.
A ``TypeError``, ``IndexError`` or any other exception is a failure.

By default each property runs a fixed, derandomized set of examples; ``pytest --runslow``
runs forty times as many, freshly drawn.
"""

import re
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is missing")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from sindybench import HiddenStateSINDy, SINDy  # noqa: E402
from sindybench._divergence import DivergenceWarning  # noqa: E402
from sindybench.hidden import DerivativeHiddenState  # noqa: E402
from sindybench.libraries import PolynomialLibrary  # noqa: E402
from sindybench.refine import OutputErrorRefinement  # noqa: E402

QUICK_EXAMPLES, SLOW_EXAMPLES = 25, 1000
ESTIMATORS = {
    "SINDy": lambda: SINDy(dt=0.01, library=PolynomialLibrary(degree=1)),
    "HiddenStateSINDy": lambda: HiddenStateSINDy(dt=0.01, library=PolynomialLibrary(degree=1),
                                                 hidden=DerivativeHiddenState(order=2), show_progress_bar=False),
    # the refinement with one initial state per record, and the search with a validation block per record
    "SINDy-refine": lambda: SINDy(dt=0.01, library=PolynomialLibrary(degree=1),
                                  refine=OutputErrorRefinement(max_nfev=2)),
    "HiddenStateSINDy-search": lambda: HiddenStateSINDy(
        dt=0.01, library=PolynomialLibrary(degree=1), hidden=DerivativeHiddenState(order=2), validation_size=0.25,
        search_params={"optimizer__threshold": (1e-3, 0.1, True)}, n_trials=2, show_progress_bar=False),
}
# corruptions of one record (index drawn), of the lists, or of the container
PER_RECORD = ("x-columns", "y-columns", "length", "nan", "inf", "x-1d")
CONTAINER = ("x-list-short", "x-array", "tuple", "3d", "nested", "object", "empty")
# words that name an argument in a message ("parameters": the searched ones, when no candidate simulates)
ARGUMENTS = {"X", "y", "y_init", "x0", "record", "records", "samples", "library", "dt", "differentiation",
             "parameters"}


@st.composite
def record_lists(draw):
    """``(X, y, bad)``: lists of smooth records, ``bad`` the index of the corrupted record (or None)."""
    n_records = draw(st.integers(1, 3))
    n_in, n_out = draw(st.integers(0, 2)), draw(st.integers(1, 2))
    X, y = [], []
    for r in range(n_records):
        n = draw(st.one_of(st.integers(0, 8), st.integers(20, 60), st.integers(20, 60)))
        t = np.arange(n) * 0.01
        freq = draw(st.lists(st.floats(0.5, 5.0), min_size=n_in + n_out, max_size=n_in + n_out))
        signals = [np.sin(f * t * 10 + k + r) for k, f in enumerate(freq)]
        X.append(np.column_stack(signals[:n_in]) if n_in else np.empty((n, 0)))
        y.append(np.column_stack(signals[n_in:]))
    kind = draw(st.one_of(st.just("none"), st.sampled_from(("none",) + PER_RECORD + CONTAINER)))
    bad = draw(st.integers(0, n_records - 1)) if kind in PER_RECORD else None
    if kind in ("x-columns", "y-columns") and n_records == 1:  # other columns than what? one record is sound
        kind, bad = "none", None
    if kind == "x-columns":
        X[bad] = np.hstack([X[bad], np.ones((len(X[bad]), 1))])
    elif kind == "y-columns":
        y[bad] = np.hstack([y[bad], np.ones((len(y[bad]), 1))])
    elif kind == "length":
        X[bad] = np.vstack([X[bad], np.zeros((1, n_in))])
    elif kind in ("nan", "inf"):
        if y[bad].size:
            y[bad] = y[bad].copy()
            y[bad].flat[draw(st.integers(0, y[bad].size - 1))] = np.nan if kind == "nan" else np.inf
        else:
            bad = None
    elif kind == "x-1d":
        X[bad] = X[bad][:, 0] if n_in else X[bad].reshape(-1)
    elif kind == "x-list-short":
        X = X[:-1]
    elif kind == "x-array":
        X = X[0]
    elif kind == "tuple":
        X, y = tuple(X), tuple(y)
    elif kind == "3d":
        n_min = min(len(r) for r in y)
        X, y = np.stack([r[:n_min] for r in X]), np.stack([r[:n_min] for r in y])
    elif kind == "nested":
        y = [r.tolist() for r in y]
    elif kind == "object":
        records, y = y, np.empty(n_records, dtype=object)
        for i, r in enumerate(records):
            y[i] = r
    elif kind == "empty":
        X, y = [], []
    return X, y, bad


def _names_what_was_wrong(message, X, y, bad):
    """The corrupted record by index (when every record is long enough to fit), else some argument."""
    sound = isinstance(y, list) and all(len(r) >= 20 for r in y)
    if bad is not None and sound:
        return f"record {bad}" in message or f"[{bad}]" in message
    return bool(set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*", message)) & ARGUMENTS)


def _check_case(name, X, y, bad):
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with np.errstate(all="ignore"):
                model = ESTIMATORS[name]().fit(X, y)
                pred = model.predict(X, y_init=y)
    except ValueError as exc:
        assert _names_what_was_wrong(str(exc), X, y, bad), f"{name}: the error names nothing wrong: {exc}"
        return
    assert isinstance(y, list), f"{name} fitted y of type {type(y).__name__}; expected a ValueError"
    assert bad is None, f"{name} fitted a list whose record {bad} is corrupted"
    assert isinstance(pred, list) and len(pred) == len(y)
    diverged = any(issubclass(w.category, DivergenceWarning) for w in caught)
    for p, r in zip(pred, y):
        assert np.shape(p) == np.shape(r), f"{name}.predict gave shape {np.shape(p)} for a record {np.shape(r)}"
        assert diverged or np.all(np.isfinite(p)), f"{name}.predict returned NaN or inf without a DivergenceWarning"


def _run(name, n_examples, derandomize):
    @settings(max_examples=n_examples, derandomize=derandomize, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(data=record_lists())
    def check(data):
        _check_case(name, *data)

    check()


@pytest.mark.parametrize("name", sorted(ESTIMATORS))
def test_record_lists_end_in_a_model_or_a_named_value_error(name):
    _run(name, QUICK_EXAMPLES, derandomize=True)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(ESTIMATORS))
def test_record_lists_end_in_a_model_or_a_named_value_error_at_length(name):
    _run(name, SLOW_EXAMPLES, derandomize=False)

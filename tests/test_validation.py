"""Tests of the shared argument checks in sindybench/_validation.py."""

import numpy as np
import pytest
import scipy.sparse as sp

from sindybench._validation import (
    check_array_like,
    check_bool,
    check_integer,
    check_model_inputs,
    check_option,
    check_positive,
)


@pytest.mark.parametrize("value", [1, 7, np.int64(3)])
def test_check_integer_accepts_integers(value):
    out = check_integer(value, "n")
    assert out == int(value) and type(out) is int


@pytest.mark.parametrize(
    ("value", "kwargs", "match"),
    [
        (0, {}, r"n must be an integer >= 1; got 0\."),
        (2.0, {}, r"n must be an integer >= 1; got 2\.0\."),
        (True, {}, r"n must be an integer >= 1; got True\."),
        ("3", {}, r"n must be an integer >= 1; got '3'\."),
        (-1, {"low": 0}, r"n must be an integer >= 0; got -1\."),
        (3, {"low": 1, "high": 2}, r"n must be an integer in \[1, 2\]; got 3\."),
        (1.5, {"low": None}, r"n must be an integer; got 1\.5\."),
        (3, {"low": None, "high": 2}, r"n must be an integer <= 2; got 3\."),
    ],
)
def test_check_integer_rejects(value, kwargs, match):
    with pytest.raises(ValueError, match=match):
        check_integer(value, "n", **kwargs)


def test_check_bool():
    assert check_bool(np.bool_(True), "flag") is True
    with pytest.raises(ValueError, match=r"flag must be True or False; got 0\."):
        check_bool(0, "flag")


def test_check_option():
    assert check_option("zoh", "input_hold", ("zoh", "linear")) == "zoh"
    with pytest.raises(ValueError, match=r"input_hold must be one of \('zoh', 'linear'\); got 'foh'\."):
        check_option("foh", "input_hold", ("zoh", "linear"))
    with pytest.raises(ValueError, match="must be one of"):
        check_option([1], "metric", {"r2": None})  # unhashable value, dict options


@pytest.mark.parametrize(
    ("value", "kwargs", "expected"),
    [(2, {}, 2.0), (0, {"strict": False}, 0.0), (np.inf, {"allow_inf": True}, np.inf)],
)
def test_check_positive_accepts(value, kwargs, expected):
    assert check_positive(value, "x", **kwargs) == expected


@pytest.mark.parametrize(
    ("value", "kwargs", "match"),
    [
        (np.inf, {}, r"x must be a finite number > 0; got inf\."),
        (np.nan, {"allow_inf": True}, r"x must be a number > 0 \(inf allowed\); got nan\."),
        (0.0, {"allow_inf": True}, r"x must be a number > 0 \(inf allowed\)"),
        (-1.0, {"strict": False}, r"x must be a finite number >= 0"),
        (True, {}, r"x must be a finite number > 0; got True\."),
        (None, {}, r"x must be a finite number > 0; got None\."),
    ],
)
def test_check_positive_rejects(value, kwargs, match):
    with pytest.raises(ValueError, match=match):
        check_positive(value, "x", **kwargs)


@pytest.mark.parametrize(
    ("value", "name", "match"),
    [
        (sp.csr_matrix(np.ones((3, 1))), "X", r"X is a sparse matrix"),
        (np.ones((3, 1)) * 1j, "y", r"y is complex"),
        (np.ones(3), "X", r"X is 1-D \(shape \(3,\)\)"),
    ],
)
def test_check_array_like_rejects(value, name, match):
    with pytest.raises(ValueError, match=match):
        check_array_like(value, name)


def test_check_array_like_accepts():
    for value, name in [(None, "X"), (np.ones(3), "y"), ([[1.0], [2.0]], "X")]:
        assert check_array_like(value, name) is None


def test_check_model_inputs():
    assert check_model_inputs(None, 0, "M", n_samples=4).shape == (4, 0)
    assert check_model_inputs([[1.0, 2.0]], 2, "M").shape == (1, 2)
    with pytest.raises(ValueError, match="X is None; expected inputs"):
        check_model_inputs(None, 0, "M")
    with pytest.raises(ValueError, match=r"X has 0 features, but M is expecting 1 features"):
        check_model_inputs(None, 1, "M", n_samples=4)
    with pytest.raises(ValueError, match="X is 1-D"):
        check_model_inputs(np.ones(4), 1, "M")


# --------------------------------------------------------------------------- issue 30: quotes and scalars
def test_shown_cuts_a_long_value_and_says_how_long_it_was():
    from sindybench._validation import shown

    assert shown("tanks") == "'tanks'" and shown([1, 2]) == "[1, 2]"
    text = shown("x" * 10**7)
    assert len(text) < 200 and text.endswith("... (10,000,002 characters)")
    assert shown(list(range(10**5))).endswith(" characters)")


@pytest.mark.parametrize("check, args", [
    (check_option, ("method", ("rk4", "euler"))),
    (check_integer, ("n_substeps",)),
    (check_bool, ("unbias",)),
    (check_positive, ("dt",)),
])
def test_messages_quote_at_most_a_readable_part_of_a_huge_value(check, args):
    # issue 30, item 19: a 10 MB value was echoed into a 10,000,116-character message
    with pytest.raises(ValueError) as info:
        check("A" * 10**7, *args)
    assert len(str(info.value)) < 400 and "10,000,002 characters" in str(info.value)


@pytest.mark.parametrize("dt", [np.array(0.1), np.float32(0.25), np.float64(0.1), np.array(2), np.int32(3),
                                np.array([0.1]).reshape(())])
def test_any_real_scalar_is_a_dt(dt):
    # issue 30, item 21: a 0-d array (what np.load gives for a number) was refused
    from sindybench import SINDy
    from sindybench._validation import check_dt
    from sindybench.libraries import PolynomialLibrary
    from sindybench.simulate import TermsRHS, simulate

    assert check_dt(dt) == float(dt) and type(check_dt(dt)) is float
    rng = np.random.default_rng(0)
    u = rng.standard_normal((60, 1))
    y = np.cumsum(u, axis=0) * 0.01
    fitted = SINDy(library=PolynomialLibrary(degree=1), dt=dt).fit(u, y)
    assert fitted.dt_ == float(dt)
    rhs = TermsRHS.from_equations([{((0, 0, 1, 0),): -1.0}])
    assert np.array_equal(simulate(rhs, [1.0], np.zeros((3, 0)), dt), simulate(rhs, [1.0], np.zeros((3, 0)), float(dt)))


@pytest.mark.parametrize("dt", [np.array([0.1]), np.array(True), np.array(1j), np.array(-0.1), np.array(np.nan),
                                np.array("0.1")])
def test_a_dt_that_is_no_positive_real_scalar_is_refused(dt):
    from sindybench._validation import check_dt

    with pytest.raises(ValueError, match="dt must be a finite number > 0; got"):
        check_dt(dt)

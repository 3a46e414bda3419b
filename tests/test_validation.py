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

import pytest

from sindybench._equations import format_coef, format_equation


@pytest.mark.parametrize(
    "c, precision, expected",
    [
        (-4.8216, 3, "4.822"),
        (0.25, 2, "0.25"),
        (0.96, 1, "1.0"),  # >= 0.1: fixed-point at any precision
        (0.05234, 1, "0.05"),
        (0.0052341, 3, "0.00523"),  # 0.005 in fixed-point
        (0.0123, 3, "0.012"),
        (2.5e7, 3, "2.5e+07"),
        (-123456.7, 2, "123456.70"),
        (0.0, 3, "0.000"),
    ],
)
def test_format_coef(c, precision, expected):
    assert format_coef(c, precision) == expected


def test_format_equation_signs_and_constant():
    line = format_equation("y0", [2.117, -11.929, 0.0, 1e-5], ["1", "y0", "u0", "y0^2"])
    assert line == "y0' = 2.117 - 11.929 y0 + 1e-05 y0^2"
    assert format_equation("y0''", [-698.2, 0.0], ["y0", "u0"], precision=0) == "y0''' = -698 y0"
    assert format_equation("x", [0.0, 0.0], ["1", "x"]) == "x' = 0"


@pytest.mark.parametrize("precision", [-1, 2.0, True, "3"])
def test_bad_precision(precision):
    with pytest.raises(ValueError, match="precision must be an integer >= 0"):
        format_equation("y", [1.0], ["y"], precision=precision)

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


# ----------------------------------------------------------------- LaTeX, display, SymPy
import numpy as np  # noqa: E402

from sindybench import STLS, HiddenStateSINDy, SINDy  # noqa: E402
from sindybench._equations import EquationRow, format_equations  # noqa: E402
from sindybench.hidden import DerivativeHiddenState  # noqa: E402
from sindybench.libraries import (  # noqa: E402
    ABS_POW,
    POW,
    SIGN,
    SQRT,
    AbsProductLibrary,
    CustomLibrary,
    PolynomialLibrary,
    SqrtLibrary,
    symbol_latex,
    term_latex,
)
from sindybench.simulate import TermsRHS, simulate  # noqa: E402


@pytest.mark.parametrize(
    "name, dot, expected",
    [
        ("y0", False, "y_0"),
        ("x12", False, "x_{12}"),
        ("v", True, r"\dot{v}"),
        ("y0'", False, r"\dot{y}_0"),  # a prime is a time derivative
        ("y0'", True, r"\ddot{y}_0"),
        ("y0''", True, r"\dddot{y}_0"),
        ("y0'''", True, "y_0''''"),
        ("alpha", False, r"\alpha"),
        ("h_1", False, "h_1"),
        ("tank_level", False, r"\mathrm{tank\_level}"),
    ],
)
def test_symbol_latex(name, dot, expected):
    assert symbol_latex(name, dot=dot) == expected


@pytest.mark.parametrize(
    "term, expected",
    [
        ((), "1"),
        (((0, SQRT, 0.0, np.inf),), r"\sqrt{x_1}"),
        (((1, ABS_POW, 1, 0), (2, POW, 1, 0)), "|v| z"),
        (((2, ABS_POW, 1.5, 0),), "|z|^{1.5}"),
        (((1, SIGN, 0, 0),), r"\operatorname{sign}(v)"),
        (((3, POW, 2, 0),), r"\dot{y}_0^{2}"),
        (((0, POW, 3, 0), (1, POW, 1, 0)), "x_1^{3} v"),
    ],
)
def test_term_latex(term, expected):
    assert term_latex(term, ["x1", "v", "z", "y0'"]) == expected


def test_format_equation_latex_coefficients():
    line = format_equation("z", [1e-9, -3.5e7, 0.25], ["1", "|v| z", "v"], latex=True)
    assert line == r"\dot{z} = 10^{-9} - 3.5 \times 10^{7} \, |v| z + 0.250 \, v"


def test_rows_without_terms_are_upright_text():
    row = EquationRow("y0", [0.5, 0.0, 2.0], ["1", "tanh(y0)", "y0*u0"], None, ["y0", "u0"])
    assert format_equations([row], latex=True) == [r"\dot{y}_0 = 0.500 + 2.000 \, \mathrm{y0*u0}"]
    fixed = EquationRow("h0", None, [], None, ["y0", "h0"], learned=False, fixed="MyStrategy")
    assert format_equations([fixed]) == ["h0' = (fixed: MyStrategy)"]
    assert format_equations([fixed], latex=True) == [r"\dot{h}_0 = \text{(fixed: MyStrategy)}"]


@pytest.fixture(scope="module")
def tanks_like():
    """A SINDy model with square roots: y' = -0.5 sqrt(y) + u."""
    u = (1.0 + 0.5 * np.sin(np.arange(3000) * 0.01))[:, None]
    y = simulate(lambda x, u: np.array([-0.5 * np.sqrt(max(x[0], 0.0)) + u[0]]), [1.0], u, dt=0.01)
    lib = PolynomialLibrary(degree=1) + SqrtLibrary(variables=[0])
    return SINDy(library=lib, optimizer=STLS(threshold=0.05), dt=0.01, output_names=["x1"]).fit(u, y), u, y


@pytest.fixture(scope="module")
def oscillator_model():
    """A HiddenStateSINDy model of y'' = -4 y - 0.5 y' + 2 u with |y'| products in its library."""
    t = np.arange(2000) * 0.01
    u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    truth = TermsRHS.from_equations([{((1, 0, 1, 0),): 1.0},
                                     {((0, 0, 1, 0),): -4.0, ((1, 0, 1, 0),): -0.5, ((2, 0, 1, 0),): 2.0}])
    y = simulate(truth, [0.0, 0.0], u, dt=0.01, n_substeps=4)[:, :1]
    lib = PolynomialLibrary(degree=1) + AbsProductLibrary(pairs=[(1, 0)])
    return HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=lib, dt=0.01).fit(u, y)


def test_sindy_latex_equations_come_from_the_terms(tanks_like):
    model = tanks_like[0]
    (line,) = model.equations(precision=2, latex=True)
    assert line.startswith(r"\dot{x}_1 = ") and r"\sqrt{x_1}" in line and r"\, u_0" in line
    assert r"- 0.50 \, \sqrt{x_1}" in line


def test_hidden_latex_equations(oscillator_model):
    lines = oscillator_model.equations(precision=2, latex=True)
    assert lines[0] == r"\dot{y}_0 = 1.00 \, \dot{y}_0"  # the fixed row y0' = y0' (derivative coordinates)
    assert lines[1].startswith(r"\ddot{y}_0 = ") and r"|\dot{y}_0| y_0" in lines[1]
    assert len(lines) == len(oscillator_model.equations())


def test_notebook_display_of_fitted_and_unfitted_models(oscillator_model):
    formatters = pytest.importorskip("IPython.core.formatters", reason="IPython comes with the test extra (ipykernel)")
    DisplayFormatter = formatters.DisplayFormatter

    formatter = DisplayFormatter()
    unfitted = HiddenStateSINDy(dt=0.01)
    bundle, _ = formatter.format(unfitted)
    assert "text/latex" not in bundle and unfitted._repr_latex_() is None
    assert bundle["text/html"].startswith("<style>") and "sk-top-container" in bundle["text/html"]  # the diagram
    bundle, _ = formatter.format(oscillator_model)
    latex = bundle["text/latex"]
    assert latex.startswith("$$\\begin{aligned}\n\\dot{y}_0 &= ") and latex.endswith("\\end{aligned}$$")
    assert latex.count(" &= ") == 2 and r"|\dot{y}_0| y_0" in latex
    html = bundle["text/html"]
    assert html.startswith('<div class="sindybench-equations') and "\\ddot{y}_0 &amp;= " in html
    assert html.index("</div>") < html.index("sk-top-container")  # the diagram stays, below the equations


def _sympy_rhs(equations, symbols, point):
    return np.array([float(eq.rhs.subs(dict(zip(symbols, point)))) for eq in equations])


def test_to_sympy_evaluates_like_the_model(oscillator_model, tanks_like):
    sympy = pytest.importorskip("sympy")
    eqs = oscillator_model.to_sympy()
    assert [str(eq.lhs) for eq in eqs] == ["dy0/dt", "dy0'/dt"]
    symbols = sympy.symbols(["y0", "y0'", "u0"], real=True)
    x, u = np.array([0.3, -0.7]), np.array([0.4])
    np.testing.assert_allclose(_sympy_rhs(eqs, symbols, [*x, *u]), oscillator_model.rhs_(x, u), rtol=1e-10)
    model = tanks_like[0]
    (eq,) = model.to_sympy()
    theta = model.library_.transform([[2.0, 0.7]])
    np.testing.assert_allclose(_sympy_rhs([eq], sympy.symbols(["x1", "u0"], real=True), [2.0, 0.7]),
                               (theta @ model.coef_.T)[0], rtol=1e-10)
    assert eq.rhs.has(sympy.sqrt(sympy.Symbol("x1", real=True)))


def test_to_sympy_needs_symbolic_terms_and_sympy(tanks_like, monkeypatch):
    pytest.importorskip("sympy")
    _, u, y = tanks_like
    custom = SINDy(library=CustomLibrary(functions=[np.tanh], compile=False), dt=0.01).fit(u, y)
    with pytest.raises(ValueError, match=r"features without symbolic terms \['f0\(y0\)', 'f0\(u0\)'\]"):
        custom.to_sympy()
    monkeypatch.setitem(__import__("sys").modules, "sympy", None)
    with pytest.raises(ImportError, match=r"pip install sindybench\[sympy\]"):
        tanks_like[0].to_sympy()

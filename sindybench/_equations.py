"""Readable model equations, shared by every estimator's ``equations()``, notebook display and ``to_sympy()``.

An estimator describes its equations as :class:`EquationRow` objects (its
``_equation_rows()`` method); :func:`format_equations` writes them as text or
LaTeX, :func:`equations_to_sympy` as SymPy, and :class:`EquationsDisplayMixin`
shows them in notebooks.
"""

import html
from typing import NamedTuple

from ._validation import check_integer
from .libraries._terms import symbol_latex, term_latex, term_sympy

__all__ = ["EquationRow", "EquationsDisplayMixin", "equations_to_sympy", "format_coef", "format_equation",
           "format_equations"]

# Magnitude from which coefficients switch from fixed-point to exponent notation.
LARGE = 1e6


def format_coef(c, precision=3):
    """Magnitude of ``c`` as text: ``precision`` decimals, or significant digits if unreadable.

    Fixed-point is unreadable for a small coefficient that it would show
    with fewer than two significant digits (``|c| < min(0.1, 10**(1 - precision))``)
    and for ``|c| >= 1e6``; such coefficients use ``%.{precision}g``.

    Examples
    --------
    >>> format_coef(-4.8216), format_coef(0.0052341), format_coef(2.5e7), format_coef(3e-9, 2)
    ('4.822', '0.00523', '2.5e+07', '3e-09')
    """
    a = abs(float(c))
    if a != 0 and (a < min(0.1, 10.0 ** (1 - precision)) or a >= LARGE):
        return f"{a:.{max(precision, 1)}g}"
    return f"{a:.{precision}f}"


def _coef_latex(text):
    """``2.5e+07`` -> ``2.5 \\times 10^{7}``; fixed-point text is kept."""
    if "e" not in text:
        return text
    mantissa, exponent = text.split("e")
    power = f"10^{{{int(exponent)}}}"
    return power if mantissa == "1" else rf"{mantissa} \times {power}"


def format_equation(name, coef, features, *, precision=3, latex=False, errors=None):
    r"""One equation ``name' = a + b x - c y``, skipping zero coefficients.

    Parameters
    ----------
    name : str
        The differentiated variable (``'`` is appended; in LaTeX a dot, see
        :func:`~sindybench.libraries.symbol_latex`).
    coef : sequence of float
        One coefficient per feature.
    features : sequence of str
        Feature names (LaTeX when ``latex``); the feature ``"1"`` (the
        constant) shows as its number.
    precision : int, default=3
        Decimals of the coefficients (see :func:`format_coef`).
    latex : bool, default=False
        Write LaTeX: ``\dot{y}_0 = -4.822 \, y_0``, exponents as ``\times 10^{k}``.
    errors : sequence of float, optional
        A standard error per coefficient (NaN: none); a coefficient with one
        is written ``(4.822 ± 0.012)`` (LaTeX ``\pm``), the error with
        the coefficient's format.

    Returns
    -------
    str
        ``name' = 0`` when every coefficient is zero.

    Examples
    --------
    >>> format_equation("y0", [0.0, -4.8216, 0.74, 1.7421], ["1", "y0", "y0 u0", "u0^2"])
    "y0' = -4.822 y0 + 0.740 y0 u0 + 1.742 u0^2"
    >>> format_equation("y", [2.0, -0.5], ["1", "y"], precision=1)
    "y' = 2.0 - 0.5 y"
    >>> format_equation("y", [0.0], ["y"])
    "y' = 0"
    >>> print(format_equation("x1", [-2.5e7, 0.5], [r"\sqrt{x_1}", "u_0"], latex=True))
    \dot{x}_1 = -2.5 \times 10^{7} \, \sqrt{x_1} + 0.500 \, u_0
    >>> format_equation("y", [2.0, -0.5], ["1", "y"], errors=[0.013, float("nan")])
    "y' = (2.000 ± 0.013) - 0.500 y"
    """
    precision = check_integer(precision, "precision", low=0)
    parts = []
    errors = [float("nan")] * len(features) if errors is None else errors
    for c, feature, err in zip(coef, features, errors):
        if c == 0:
            continue
        text = format_coef(c, precision)
        if latex:
            text = _coef_latex(text)
        if err == err:  # not NaN
            spread = format_coef(err, precision)
            text = (rf"({text} \pm {_coef_latex(spread)})" if latex else f"({text} ± {spread})")
        if parts:
            text = f"- {text}" if c < 0 else f"+ {text}"
        elif c < 0:
            text = f"-{text}"
        parts.append(text if feature == "1" else f"{text} \\, {feature}" if latex else f"{text} {feature}")
    lhs = symbol_latex(name, dot=True) if latex else f"{name}'"
    return f"{lhs} = " + (" ".join(parts) if parts else "0")


class EquationRow(NamedTuple):
    """One equation of a model, as its estimator describes it (internal).

    ``terms`` are the symbolic terms behind ``features`` (None for libraries
    without terms); ``variables`` name the columns of ``Z`` the terms refer
    to. A row that a Python function fixes has ``coef=None`` and ``fixed``
    naming that function's owner.
    """

    name: str
    coef: object
    features: list
    terms: object
    variables: list
    learned: bool = True
    fixed: object = None


def _latex_text(feature):
    return feature if feature == "1" else r"\mathrm{" + feature.replace("_", r"\_").replace(" ", r"\ ") + "}"


def format_equations(rows, *, precision=3, latex=False, errors=None):
    """The rows as text (``y0' = ...``) or LaTeX lines, one per row.

    LaTeX features come from the rows' symbolic terms
    (:func:`~sindybench.libraries.term_latex`); features without terms are
    written as upright text. ``errors``: one sequence of standard errors per
    row (see :func:`format_equation`), or None.
    """
    lines = []
    errors = [None] * len(rows) if errors is None else errors
    for row, err in zip(rows, errors):
        if row.fixed is not None:
            lines.append(rf"{symbol_latex(row.name, dot=True)} = \text{{(fixed: {row.fixed})}}" if latex
                         else f"{row.name}' = (fixed: {row.fixed})")
            continue
        features = row.features
        if latex:
            if row.terms is not None and len(row.terms) == len(row.features):
                features = [term_latex(t, row.variables) for t in row.terms]
            else:
                features = [_latex_text(f) for f in row.features]
        lines.append(format_equation(row.name, row.coef, features, precision=precision, latex=latex, errors=err))
    return lines


def _import_sympy():
    try:
        import sympy
    except ImportError as exc:
        raise ImportError("to_sympy needs SymPy: pip install sindybench[sympy] (or pip install sympy).") from exc
    return sympy


def equations_to_sympy(rows):
    """The rows as SymPy equations ``Eq(Symbol("dy0/dt"), expression)``.

    A row fixed by a Python function becomes an undefined function
    ``fixed_<name>(variables...)``. Needs the library's symbolic terms.
    """
    sympy = _import_sympy()
    out = []
    for row in rows:
        symbols = sympy.symbols(list(row.variables), real=True)
        if row.fixed is not None:
            rhs = sympy.Function(f"fixed_{row.name}")(*symbols)
        elif row.terms is None or len(row.terms) != len(row.features):
            raise ValueError(
                f"the equation of {row.name} uses features without symbolic terms {list(row.features)}; "
                "to_sympy expects a built-in library (PolynomialLibrary, SqrtLibrary, ... and their sums/products)."
            )
        else:
            rhs = sum((sympy.Float(float(c)) * term_sympy(t, symbols) for c, t in zip(row.coef, row.terms) if c != 0),
                      sympy.Integer(0))
        out.append(sympy.Eq(sympy.Symbol(f"d{row.name}/dt", real=True), rhs, evaluate=False))
    return out


def _fitted(estimator):
    from sklearn.exceptions import NotFittedError
    from sklearn.utils.validation import check_is_fitted

    try:
        check_is_fitted(estimator)
    except NotFittedError:
        return False
    return True


class EquationsDisplayMixin:
    """Notebook display and SymPy export of a fitted model's equations.

    For estimators with ``equations(precision, *, latex)`` and
    ``_equation_rows()``. A fitted model shows its equations (LaTeX, and HTML
    that MathJax typesets) above scikit-learn's diagram; an unfitted one
    shows the diagram alone.
    """

    def _repr_latex_(self):
        if not _fitted(self):
            return None
        lines = [line.replace(" = ", " &= ", 1) for line in self.equations(latex=True)]
        return "$$\\begin{aligned}\n" + " \\\\\n".join(lines) + "\n\\end{aligned}$$"

    def _repr_mimebundle_(self, **kwargs):
        bundle = super()._repr_mimebundle_(**kwargs)
        latex = self._repr_latex_()
        if latex is not None:
            bundle["text/latex"] = latex
            equations = f'<div class="sindybench-equations tex2jax_process mathjax_process">{html.escape(latex)}</div>'
            bundle["text/html"] = equations + bundle.get("text/html", "")
        return bundle

    def to_sympy(self):
        """The fitted equations as SymPy ``Eq`` objects (needs ``pip install sindybench[sympy]``).

        Returns
        -------
        list of sympy.Eq
            ``Eq(Symbol("dy0/dt"), expression)``, one per state, in the variables
            named as in :meth:`equations`; square roots drop their clip. A row
            fixed by a Python function is an undefined function ``fixed_<name>(...)``.
        """
        return equations_to_sympy(self._equation_rows())

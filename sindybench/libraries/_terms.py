"""Symbolic terms: the one description of a built-in library feature.

A *term* is a product of *factors*; a factor applies one elementary operation to
one column of the library input ``Z = [states, inputs]``. Built-in libraries
produce their terms at ``fit``; ``transform`` evaluates them with
:func:`evaluate_terms`, the compiled simulator (:mod:`sindybench.simulate`)
evaluates the very same terms, and ``to_json`` stores them. One description,
three uses, so the fitted features and the simulated ones cannot disagree.

A factor is a tuple ``(col, op, a, b)``:

========  =================================  ==========
op        value                              name
========  =================================  ==========
POW       ``z ** a``                         ``z^a``
ABS_POW   ``|z| ** a``                       ``|z|^a``
SQRT      ``sqrt(clip(z, a, b))``            ``sqrt(z)``
SIGN      ``sign(z)``                        ``sign(z)``
STEP      ``1`` if ``a <= z <= b``, else 0   ``[z>=a]``, ``[z<=b]``, ``[a<=z<=b]``
HINGE     ``max(z - a, 0)`` (``b >= 0``)     ``max(z-a, 0)`` (``max(a-z, 0)`` for ``b < 0``)
LOGISTIC  ``1 / (1 + exp(-b (z - a)))``      ``logistic(b*(z-a))`` (``[z>=a]`` smoothed, width ``1/b``)
========  =================================  ==========

``STEP`` marks a regime, e.g. an overflowing tank (``[x1>=10]``: the level at
the top of its bounded range) or a saturated actuator.

Every form of an operation (value, derivative, name, LaTeX, SymPy, CasADi) is one entry of
the table in :mod:`sindybench.dynamics` (``dynamics._optable``); this module writes terms
with those forms (:func:`sindybench.dynamics._user.operation` gives the entry of a code) and
adds the JSON form. The op codes, :func:`check_terms`, :func:`terms_to_arrays`,
:func:`evaluate_terms` and :func:`evaluate_terms_jacobian` are importable here and
exported from :mod:`sindybench.dynamics`. A user operation
(:func:`sindybench.dynamics.register_op`, made by
:class:`~sindybench.libraries.CustomLibrary`) is written with its own name and
cannot be stored as JSON.

An empty term ``()`` is the constant 1. :func:`term_name` writes a term as
text, :func:`term_latex` as LaTeX (``\\sqrt{x_1}``, ``|v| z``) and
:func:`term_sympy` as a SymPy expression, all from the same factors.
"""

import re

import numpy as np

from ..dynamics._ops import ABS_POW, HINGE, LOGISTIC, POW, SIGN, SQRT, STEP, USER
from ..dynamics._terms import check_terms, evaluate_terms, evaluate_terms_jacobian, terms_to_arrays
from ..dynamics._user import operation, user_op

__all__ = [
    "ABS_POW",
    "HINGE",
    "LOGISTIC",
    "POW",
    "SIGN",
    "SQRT",
    "STEP",
    "check_terms",
    "evaluate_terms",
    "evaluate_terms_jacobian",
    "symbol_latex",
    "term_latex",
    "term_name",
    "term_sympy",
    "terms_from_json",
    "terms_to_arrays",
    "terms_to_json",
]


def _factor_name(factor, names):
    col, op, a, b = factor
    return operation(op).text(names[col], a, b)


def term_name(term, names):
    """Readable name of a term.

    Examples
    --------
    >>> term_name(((0, POW, 2, 0), (1, ABS_POW, 1, 0)), ["y", "v"])
    'y^2 |v|'
    >>> term_name((), ["y"])
    '1'
    """
    if not term:
        return "1"
    return " ".join(_factor_name(f, names) for f in term)


_GREEK = {"alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "kappa", "lambda", "mu", "nu",
          "xi", "pi", "rho", "sigma", "tau", "phi", "chi", "psi", "omega"}
_DOTS = {1: r"\dot", 2: r"\ddot", 3: r"\dddot"}


def symbol_latex(name, *, dot=False):
    r"""LaTeX of a variable name: ``y0`` -> ``y_0``, ``x12`` -> ``x_{12}``, ``y0'`` -> ``y_0'``.

    A trailing number becomes a subscript, trailing primes are derivatives,
    Greek letter names become letters and other names upright text.

    Parameters
    ----------
    name : str
    dot : bool, default=False
        The time derivative of the variable (``\dot{y}_0``; primes and the dot
        add up, ``y0'`` gives ``\ddot{y}_0``).

    Examples
    --------
    >>> symbol_latex("x1"), symbol_latex("z", dot=True), symbol_latex("y0'", dot=True), symbol_latex("pos_a")
    ('x_1', '\\dot{z}', '\\ddot{y}_0', '\\mathrm{pos\\_a}')
    """
    base = name.rstrip("'")
    order = len(name) - len(base) + bool(dot)
    m = re.fullmatch(r"([A-Za-z]+?)_?(\d+)", base)
    base, sub = (m.group(1), m.group(2)) if m else (base, "")
    if base in _GREEK:
        base = "\\" + base
    elif not (len(base) == 1 and base.isalpha()):
        base = r"\mathrm{" + re.sub(r"([_&%$#{}])", r"\\\1", base) + "}"
    if order in _DOTS:
        base, primes = f"{_DOTS[order]}{{{base}}}", ""
    else:
        primes = "'" * order
    if sub:
        base += f"_{sub}" if len(sub) == 1 else f"_{{{sub}}}"
    return base + primes


def _factor_latex(factor, symbols):
    col, op, a, b = factor
    return operation(op).latex(symbols[col], a, b)


def term_latex(term, names):
    r"""LaTeX of a term, the names converted by :func:`symbol_latex`.

    Examples
    --------
    >>> term_latex(((0, SQRT, 0.0, float("inf")),), ["x1"])
    '\\sqrt{x_1}'
    >>> term_latex(((1, ABS_POW, 1, 0), (2, POW, 1, 0)), ["y", "v", "z"])
    '|v| z'
    >>> term_latex(((0, POW, 2, 0),), ["y0"]), term_latex((), ["y"])
    ('y_0^{2}', '1')
    >>> term_latex(((0, STEP, 10.0, float("inf")), (1, POW, 1, 0)), ["x1", "u0"])
    '[x_1 \\geq 10] u_0'
    """
    if not term:
        return "1"
    symbols = [symbol_latex(n) for n in names]
    return " ".join(_factor_latex(f, symbols) for f in term)


def term_sympy(term, symbols):
    """The term as a SymPy expression of ``symbols`` (one per column of ``Z``; sympy imported by the caller).

    ``SQRT`` factors drop their clip: ``sqrt(z)``; a ``STEP`` factor is the
    ``Piecewise`` indicator of its interval.

    Examples
    --------
    >>> import sympy
    >>> y, v = sympy.symbols("y v")
    >>> term_sympy(((0, POW, 2, 0), (1, ABS_POW, 1, 0)), [y, v])
    y**2*Abs(v)
    """
    import sympy

    expr = sympy.Integer(1)
    for col, op, a, b in term:
        expr *= operation(op).sympy(sympy, symbols[col], a, b)
    return expr


def _json_float(v):
    return v if np.isfinite(v) else ("inf" if v > 0 else "-inf")


def terms_to_json(terms):
    """Plain JSON-able form of ``terms`` (lists; infinite values as strings).

    Examples
    --------
    >>> terms_to_json([(), ((0, SQRT, 0.0, float("inf")),)])
    [[], [[0, 2, 0.0, 'inf']]]
    """
    for j, term in enumerate(terms):
        for factor in term:
            if int(factor[1]) >= USER:
                raise ValueError(
                    f"terms[{j}] uses the user operation {user_op(factor[1]).label('z')!r}, which cannot be "
                    "saved as JSON (a Python function); use built-in terms to save models."
                )
    return [[[int(c), int(o), _json_float(float(a)), _json_float(float(b))] for c, o, a, b in t] for t in terms]


def terms_from_json(obj):
    """Inverse of :func:`terms_to_json`.

    Examples
    --------
    >>> t = [(), ((0, SQRT, 0.0, float("inf")),)]
    >>> terms_from_json(terms_to_json(t)) == t
    True
    """
    return check_terms(obj)

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
========  =================================  ==========

``STEP`` marks a regime, e.g. an overflowing tank (``[x1>=10]``: the level at
the top of its bounded range) or a saturated actuator.

Each operation has its derivative with respect to its column
(:func:`evaluate_terms_jacobian`): ``a z^(a-1)``, ``a |z|^(a-1) sign(z)``,
``1 / (2 sqrt(z))`` strictly inside ``(a, b)`` and 0 where the clip is active,
and 0 for ``sign`` and ``STEP``. At ``z = 0`` the derivative of ``|z|^a`` is taken as 0
(``sign(0) = 0``, also for ``a < 1``), so that a product such as ``z |z|^0.5``, whose
derivative is 0 there, gets 0 by the product rule rather than ``0 * inf``. The compiled sensitivity kernel
(:mod:`sindybench.refine`) uses the same rules.

An empty term ``()`` is the constant 1. :func:`term_name` writes a term as
text, :func:`term_latex` as LaTeX (``\\sqrt{x_1}``, ``|v| z``) and
:func:`term_sympy` as a SymPy expression, all from the same factors.
"""

import re

import numpy as np

__all__ = [
    "ABS_POW",
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

POW, ABS_POW, SQRT, SIGN, STEP = 0, 1, 2, 3, 4
_OPS = (POW, ABS_POW, SQRT, SIGN, STEP)


def _fmt_power(base, a):
    return base if a == 1 else f"{base}^{a:g}"


def _factor_name(factor, names):
    col, op, a, b = factor
    z = names[col]
    if op == POW:
        return _fmt_power(z, a)
    if op == ABS_POW:
        return _fmt_power(f"|{z}|", a)
    if op == SQRT:
        return f"sqrt({z})"
    if op == SIGN:
        return f"sign({z})"
    if op == STEP:
        return _interval(z, a, b, ">=", "<=")
    raise ValueError(f"unknown factor operation {op!r}; expected one of {_OPS}.")


def _interval(z, a, b, ge, le):
    """``[z>=a]``, ``[z<=b]`` or ``[a<=z<=b]`` with the given comparison signs."""
    if np.isinf(b):
        return f"[{z}{ge}{a:g}]"
    if np.isinf(a):
        return f"[{z}{le}{b:g}]"
    return f"[{a:g}{le}{z}{le}{b:g}]"


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
    z = symbols[col]
    power = "" if a == 1 else f"^{{{a:g}}}"
    if op == POW:
        return f"{{{z}}}{power}" if power and "'" in z else z + power  # y_0'^2 would be a double superscript
    if op == ABS_POW:
        return f"|{z}|{power}"
    if op == SQRT:
        return rf"\sqrt{{{z}}}"
    if op == SIGN:
        return rf"\operatorname{{sign}}({z})"
    if op == STEP:
        return _interval(z, a, b, r" \geq ", r" \leq ")
    raise ValueError(f"unknown factor operation {op!r}; expected one of {_OPS}.")


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
        z = symbols[col]
        power = sympy.Integer(int(a)) if float(a).is_integer() else sympy.Float(a)
        if op == POW:
            expr *= z**power
        elif op == ABS_POW:
            expr *= sympy.Abs(z) ** power
        elif op == SQRT:
            expr *= sympy.sqrt(z)
        elif op == SIGN:
            expr *= sympy.sign(z)
        elif op == STEP:
            inside = sympy.And(*([z >= a] if np.isfinite(a) else []) + ([z <= b] if np.isfinite(b) else []))
            expr *= sympy.Piecewise((1, inside), (0, True))
        else:
            raise ValueError(f"unknown factor operation {op!r}; expected one of {_OPS}.")
    return expr


def _eval_factor(factor, Z):
    col, op, a, b = factor
    z = Z[:, col]
    if op == POW:
        return z**a if a != 1 else z
    if op == ABS_POW:
        return np.abs(z) ** a
    if op == SQRT:
        return np.sqrt(np.clip(z, a, b))
    if op == SIGN:
        return np.sign(z)
    if op == STEP:
        return ((z >= a) & (z <= b)).astype(float)
    raise ValueError(f"unknown factor operation {op!r}; expected one of {_OPS}.")


def evaluate_terms(terms, Z):
    """Evaluate ``terms`` on the rows of ``Z``.

    Parameters
    ----------
    terms : sequence of tuple of (col, op, a, b)
    Z : ndarray of shape (n_samples, n_variables)

    Returns
    -------
    ndarray of shape (n_samples, len(terms))

    Examples
    --------
    >>> Z = np.array([[2.0, -3.0]])
    >>> evaluate_terms([(), ((0, POW, 2, 0),), ((0, POW, 1, 0), (1, ABS_POW, 1, 0))], Z)
    array([[1., 4., 6.]])
    """
    Z = np.asarray(Z, dtype=float)
    out = np.ones((Z.shape[0], len(terms)))
    for j, term in enumerate(terms):
        for factor in term:
            out[:, j] *= _eval_factor(factor, Z)
    return out


def _factor_derivative(factor, Z):
    col, op, a, b = factor
    z = Z[:, col]
    if op == POW:
        return np.ones_like(z) if a == 1 else (a * z ** (a - 1) if a != 0 else np.zeros_like(z))
    if op == ABS_POW:  # at z = 0 the derivative is taken as 0 (sign(0) = 0, also for a < 1)
        if a == 0:
            return np.zeros_like(z)
        nonzero = z != 0
        return np.where(nonzero, a * np.abs(np.where(nonzero, z, 1.0)) ** (a - 1) * np.sign(z), 0.0)
    if op == SQRT:
        inside = (z > a) & (z < b)
        return np.where(inside, 0.5 / np.sqrt(np.where(inside, z, 1.0)), 0.0)
    if op in (SIGN, STEP):
        return np.zeros_like(z)
    raise ValueError(f"unknown factor operation {op!r}; expected one of {_OPS}.")


def evaluate_terms_jacobian(terms, Z):
    """Derivatives of ``terms`` with respect to the columns of ``Z``.

    Parameters
    ----------
    terms : sequence of tuple of (col, op, a, b)
    Z : ndarray of shape (n_samples, n_variables)

    Returns
    -------
    ndarray of shape (n_samples, len(terms), n_variables)
        ``out[k, j, c]`` is the derivative of term ``j`` with respect to
        ``Z[:, c]`` at sample ``k`` (product rule over the term's factors).

    Examples
    --------
    >>> Z = np.array([[2.0, -3.0]])
    >>> evaluate_terms_jacobian([((0, POW, 2, 0), (1, ABS_POW, 1, 0))], Z)[0]
    array([[12., -4.]])
    >>> evaluate_terms_jacobian([((0, SQRT, 0.0, 1.0),)], np.array([[0.25], [4.0]]))[:, 0, 0]
    array([1., 0.])
    """
    Z = np.asarray(Z, dtype=float)
    out = np.zeros((Z.shape[0], len(terms), Z.shape[1]))
    for j, term in enumerate(terms):
        values = [_eval_factor(f, Z) for f in term]
        for i, factor in enumerate(term):
            d = _factor_derivative(factor, Z)
            for k, v in enumerate(values):
                if k != i:
                    d = d * v
            out[:, j, factor[0]] += d
    return out


def terms_to_arrays(terms):
    """Flatten terms into arrays for compiled evaluation.

    Returns
    -------
    ptr : ndarray of int64, shape (n_terms + 1,)
        Factors of term ``j`` are ``ptr[j]:ptr[j + 1]``.
    col, op : ndarray of int64
    a, b : ndarray of float64

    Examples
    --------
    >>> ptr, col, op, a, b = terms_to_arrays([(), ((1, POW, 2, 0),)])
    >>> ptr.tolist(), col.tolist()
    ([0, 0, 1], [1])
    """
    flat = [f for term in terms for f in term]
    ptr = np.zeros(len(terms) + 1, dtype=np.int64)
    ptr[1:] = np.cumsum([len(term) for term in terms])
    col = np.array([f[0] for f in flat], dtype=np.int64)
    op = np.array([f[1] for f in flat], dtype=np.int64)
    a = np.array([f[2] for f in flat], dtype=float)
    b = np.array([f[3] for f in flat], dtype=float)
    return ptr, col, op, a, b


def check_terms(terms, n_variables=None, *, name="terms"):
    """Return ``terms`` as a list of tuples of ``(int, int, float, float)`` factors.

    Accepts the JSON form too (lists; ``"inf"`` / ``"-inf"`` strings for
    infinite clip values).

    Parameters
    ----------
    terms : sequence of sequence of (col, op, a, b)
    n_variables : int, optional
        Number of columns of ``Z``; every ``col`` must be below it.

    Examples
    --------
    >>> check_terms([[], [[1, 2, 0, "inf"]]])
    [(), ((1, 2, 0.0, inf),)]
    >>> check_terms([[[2, 0, 1, 0]]], 2)
    Traceback (most recent call last):
    ...
    ValueError: terms[0] uses column 2 of Z; expected columns in [0, 1].
    """
    if isinstance(terms, (str, bytes)) or not hasattr(terms, "__iter__"):
        raise ValueError(f"{name} must be a sequence of terms; got {terms!r}.")
    out = []
    for j, term in enumerate(terms):
        factors = []
        try:
            for col, op, a, b in term:
                factors.append((int(col), int(op), float(a), float(b)))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}[{j}] = {term!r} is not a sequence of (col, op, a, b) factors.") from exc
        for col, op, a, b in factors:
            if op not in _OPS:
                raise ValueError(f"{name}[{j}] has unknown operation {op}; expected one of {_OPS}.")
            if col < 0 or (n_variables is not None and col >= n_variables):
                hi = "" if n_variables is None else f" in [0, {n_variables - 1}]"
                raise ValueError(f"{name}[{j}] uses column {col} of Z; expected columns{hi}.")
            if np.isnan(a) or np.isnan(b):
                raise ValueError(f"{name}[{j}] has a NaN parameter; expected numbers.")
        out.append(tuple(factors))
    return out


def _json_float(v):
    return v if np.isfinite(v) else ("inf" if v > 0 else "-inf")


def terms_to_json(terms):
    """Plain JSON-able form of ``terms`` (lists; infinite values as strings).

    Examples
    --------
    >>> terms_to_json([(), ((0, SQRT, 0.0, float("inf")),)])
    [[], [[0, 2, 0.0, 'inf']]]
    """
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

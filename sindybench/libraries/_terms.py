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
and 0 for ``sign`` and ``STEP``. The compiled sensitivity kernel
(:mod:`sindybench.refine`) uses the same rules.

An empty term ``()`` is the constant 1.
"""

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
    "term_name",
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
        if np.isinf(b):
            return f"[{z}>={a:g}]"
        if np.isinf(a):
            return f"[{z}<={b:g}]"
        return f"[{a:g}<={z}<={b:g}]"
    raise ValueError(f"unknown factor operation {op!r}; expected one of {_OPS}.")


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
    if op == ABS_POW:
        return np.sign(z) if a == 1 else (a * np.abs(z) ** (a - 1) * np.sign(z) if a != 0 else np.zeros_like(z))
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

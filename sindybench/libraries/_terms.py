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
========  =================================  ==========

An empty term ``()`` is the constant 1.
"""

import numpy as np

__all__ = ["ABS_POW", "POW", "SIGN", "SQRT", "evaluate_terms", "term_name", "terms_to_arrays"]

POW, ABS_POW, SQRT, SIGN = 0, 1, 2, 3
_OPS = (POW, ABS_POW, SQRT, SIGN)


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

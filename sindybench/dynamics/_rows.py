"""Compiled rows: a right-hand side written with NumPy, joined to the terms in the compiled simulator.

A hidden-state model may give some rows of ``dx/dt`` as a Python function,
``rhs(x_h, y, u, **params)`` (``ParametricHiddenState``). :func:`compile_rows`
compiles such a function with numba into a C callback
``rows(z, params) -> out`` over ``Z = [states, inputs]`` (its arguments are
slices of ``Z``, its keyword parameters an array), which the simulator's kernel
adds to the rows ``first, first + 1, ...`` after the terms. :class:`RowsRHS`
is such a model: it simulates on the compiled path and, called from Python,
evaluates the original function. Sensitivities are not compiled for it (it is
not a :class:`~sindybench.simulate.TermsRHS`): the refinement treats it as a
Python right-hand side.
"""

import inspect
import types as pytypes
import warnings

import numpy as np
from numba import carray, cfunc, njit, types

from ._ops import call_rows
from ._simulate import TermsRHS
from ._user import OpCompileError

__all__ = ["ParametricRows", "ROWS_SIGNATURE", "RowsRHS", "compile_rows", "compiled_rows"]

_P = types.CPointer(types.float64)
ROWS_SIGNATURE = types.void(_P, types.int64, _P, types.int64, _P, types.int64)
"""``rows(z, n_z, params, n_params, out, n_out)``."""

_CACHE = {}


def _positional(function, names):
    """``function`` with its keyword-only parameters (in ``names``' order) made positional."""
    sig = inspect.signature(function)
    kinds = [p.kind for p in sig.parameters.values()]
    positional = [p for p in sig.parameters.values() if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    keywords = [p.name for p in sig.parameters.values() if p.kind == p.KEYWORD_ONLY]
    if inspect.Parameter.VAR_KEYWORD in kinds or inspect.Parameter.VAR_POSITIONAL in kinds:
        raise OpCompileError(f"{function.__name__} takes *args or **kwargs; expected named parameters.")
    if len(positional) != 3 or sorted(keywords + [p.name for p in positional[3:]]) != sorted(names):
        raise OpCompileError(f"{function.__name__}{sig} does not take (x_h, y, u) and the parameters {names}.")
    code = function.__code__
    flat = pytypes.FunctionType(code.replace(co_argcount=code.co_argcount + code.co_kwonlyargcount,
                                             co_kwonlyargcount=0), function.__globals__, function.__name__, None,
                                function.__closure__)
    return flat, keywords


def compile_rows(function, names, layout):
    """Compile ``function(x_h, y, u, **params)`` into a rows callback; return it (a numba ``cfunc``).

    Parameters
    ----------
    function : callable
        ``(x_h, y, u, **params) -> dx_h/dt`` written with NumPy.
    names : sequence of str
        Its keyword parameters, in the order of the ``params`` array.
    layout : tuple of three (start, stop)
        Where ``x_h``, ``y`` and ``u`` are in ``Z``.

    Raises
    ------
    OpCompileError
        If numba cannot compile it (the caller keeps the Python path).
    """
    key = (function, tuple(names), tuple(layout))
    if key not in _CACHE:
        _CACHE[key] = _compile_rows(function, names, layout)
    if isinstance(_CACHE[key], Exception):
        raise _CACHE[key]
    return _CACHE[key]


def _compile_rows(function, names, layout):
    """The cfunc, or the OpCompileError saying why there is none."""
    try:
        flat, keywords = _positional(function, list(names))
        order = [list(names).index(k) for k in keywords]
        call = ", ".join([f"z[{a}:{b}]" for a, b in layout] + [f"par[{i}]" for i in order])
        namespace = {"R": njit(flat), "carray": carray, "np": np}
        exec(  # noqa: S102 - generated from a fixed template
            "def rows(zp, nz, pp, npar, op, nout):\n"
            "    z = carray(zp, (nz,))\n    par = carray(pp, (npar,))\n    out = carray(op, (nout,))\n"
            f"    r = np.atleast_1d(R({call}))\n"
            "    for i in range(nout):\n        out[i] = r[i]\n", namespace)
        compiled = cfunc(ROWS_SIGNATURE)(namespace["rows"])
    except OpCompileError as exc:
        compiled = exc
    except Exception as exc:  # numba raises several error types; the message says which
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        compiled = OpCompileError(f"{getattr(function, '__name__', function)!r} cannot be compiled by numba "
                                  f"({type(exc).__name__}: {first})")
    return compiled


@njit(cache=True)
def _rows_once(address, z, par, out):
    call_rows(address, z, par, out)


class RowsRHS:
    """``dx/dt = terms([x, u]) @ coef``, plus compiled rows ``first, first + 1, ...`` from a NumPy function.

    Parameters
    ----------
    coef, terms, n_states
        As in :class:`~sindybench.simulate.TermsRHS`.
    function : callable
        ``function(x_h, y, u, **params)``.
    params : dict
        Its keyword parameters (numbers).
    layout : tuple of three (start, stop)
        Where ``x_h``, ``y`` and ``u`` are in ``Z = [x, u]``.
    first : int
        The first state whose derivative the function gives.

    Raises
    ------
    OpCompileError
        If the function cannot be compiled, or its compiled value differs from
        the Python one at a test point.

    Examples
    --------
    ``h' = -a h + u`` (one state, one input) from a NumPy function:

    >>> from sindybench.simulate import simulate
    >>> def lag(xh, y, u, *, a):
    ...     return -a * xh + u
    >>> rhs = RowsRHS(np.zeros((0, 1)), [], 1, lag, {"a": 2.0}, ((0, 1), (1, 1), (1, 2)), 0)
    >>> x = simulate(rhs, [0.0], np.ones((11, 1)), 0.1)
    >>> round(float(x[-1, 0]), 4), round(float(0.5 * (1 - np.exp(-2.0))), 4)
    (0.4323, 0.4323)
    """

    _compiled = True

    def __init__(self, coef, terms, n_states, function, params, layout, first):
        self.base = TermsRHS(coef, terms, n_states)
        self.coef, self.terms, self.n_states = self.base.coef, self.base.terms, n_states
        self.function, self.params, self.layout, self.first = function, dict(params), tuple(layout), int(first)
        self.n_rows = layout[0][1] - layout[0][0]
        self.n_variables = max(self.base.n_variables, max(b for _, b in layout))
        self.n_active = self.base.n_active
        self._rows = compile_rows(function, list(self.params), self.layout)
        par = np.array([float(v) for v in self.params.values()])
        self._arrays = (*self.base._arrays[:8], self._rows.address, par, np.zeros(self.n_rows), self.first)
        z = np.linspace(0.3, 0.7, self.n_variables)
        compiled = np.zeros(self.n_rows)
        _rows_once(self._rows.address, z, par, compiled)
        expected = self._python_rows(z)
        if not np.allclose(compiled, expected, rtol=1e-9, atol=1e-12, equal_nan=True):
            raise OpCompileError(f"the compiled {getattr(function, '__name__', function)!r} gives {compiled} where "
                                 f"the Python function gives {expected}.")

    def _python_rows(self, z):
        (a, b), (c, d), (e, f) = self.layout
        return np.asarray(self.function(z[a:b], z[c:d], z[e:f], **self.params), dtype=float).reshape(self.n_rows)

    @property
    def user(self):
        """The user-operation table of the terms (as :attr:`TermsRHS.user`)."""
        return self.base.user

    def __reduce__(self):
        return (type(self), (self.coef, self.terms, self.n_states, self.function, self.params, self.layout,
                             self.first))

    def __call__(self, x, u):
        z = np.concatenate([np.asarray(x, dtype=float), np.asarray(u, dtype=float)])
        dx = self.base(x, u)
        dx[self.first : self.first + self.n_rows] += self._python_rows(z)
        return dx

    def __repr__(self):
        return (f"RowsRHS(n_terms={len(self.terms)}, n_states={self.n_states}, "
                f"rows={getattr(self.function, '__name__', 'f')} -> states {self.first}..{self.first + self.n_rows - 1})")


def compiled_rows(coef, terms, n_states, rhs, params, layout, first):
    """A :class:`RowsRHS`, or None with a warning when numba cannot compile ``rhs``."""
    n_variables = max([n_states] + [f[0] + 1 for t in terms for f in t])
    layout = tuple((a, n_variables if b is None else b) for a, b in layout)
    try:
        return RowsRHS(coef, terms, n_states, rhs, params, layout, first)
    except OpCompileError as exc:
        warnings.warn(f"ParametricHiddenState: {exc}; the model runs on the Python path (about 100x slower).",
                      UserWarning, stacklevel=3)
        return None


class ParametricRows:
    """Fixed rows ``[0, ..., 0, rhs(x_h, y, u, **params)]`` of the full state ``(y, x_h)`` (picklable if ``rhs`` is).

    The Python fixed rows of a ``ParametricHiddenState`` model: ``n_outputs``
    measured states, then ``n_hidden`` states whose derivative is ``rhs``.
    :meth:`with_params` gives the rows for other parameter values (a
    refinement of the physical parameters on the Python path calls it, not
    the strategy).

    Examples
    --------
    >>> def lag(xh, y, u, *, a):
    ...     return -a * xh + u
    >>> rows = ParametricRows(lag, {"a": 2.0}, 1, 1)
    >>> rows(np.array([0.0, 1.0]), np.array([1.0])).tolist(), rows.with_params({"a": 1.0}).params
    ([0.0, -1.0], {'a': 1.0})
    """

    def __init__(self, rhs, params, n_outputs, n_hidden):
        self.rhs, self.params, self.p, self.q = rhs, params, n_outputs, n_hidden

    def with_params(self, values):
        """These rows with the parameters ``values`` (a dict) replacing theirs."""
        return ParametricRows(self.rhs, {**self.params, **values}, self.p, self.q)

    def compiled(self, coef, terms, n_states):
        """The whole model, terms plus these rows, as a compiled :class:`RowsRHS` (None if ``rhs`` does not compile)."""
        p, q = self.p, self.q
        return compiled_rows(coef, terms, n_states, self.rhs, self.params, ((p, p + q), (0, p), (p + q, None)), p)

    def __call__(self, x, u):
        dx = np.zeros(self.p + self.q)
        dx[self.p :] = np.asarray(self.rhs(x[self.p :], x[: self.p], u, **self.params), dtype=float).reshape(self.q)
        return dx

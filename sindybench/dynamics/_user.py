"""User operations: Python functions compiled by numba, joining the built-in term operations.

:func:`register_op` compiles a scalar function ``f(z) -> float`` (``np.sign``,
``lambda v: np.tanh(v / 0.02)``) with numba and gives it an operation code
(a :class:`UserOp`, an ``int`` from :data:`~sindybench.dynamics.USER` on).
A factor ``(col, code, 0.0, 0.0)`` then behaves as a built-in one: fitted
features, the simulator and the sensitivity kernel all evaluate the same
compiled function. The derivative is the ``derivative`` given, else a known
rule (NumPy's ``sign``, ``tanh``, ``sin``, ``cos``, ``exp``, ``arctan``, ``abs``),
else a central difference.

The compiled kernels reach the user functions through one table,
:func:`user_table` (its address), a numba ``cfunc`` of signature
``user(code, which, z) -> float64`` (``which = 0`` value, ``1`` derivative),
rebuilt when an operation is added. Codes are valid in this process only: a
``UserOp`` pickles as its function and is registered again on unpickling;
model files cannot store user operations.

:func:`operation` gives the :class:`~._optable.Operation` of any code, built-in or user: a
user operation is written with its ``name`` (text and LaTeX), as an undefined SymPy function
of its Python name, and in CasADi when it is one of NumPy's ``sign``, ``tanh``, ``sin``,
``cos``, ``exp``, ``arctan``, ``abs``; another function has no CasADi form, and
:func:`~sindybench.export.to_casadi` says so by name.
"""

import numpy as np
from numba import cfunc, njit

from ._ops import BUILTIN_OPS, USER, USER_SIGNATURE, no_user_ops
from ._optable import Operation, builtin_operation

__all__ = ["OpCompileError", "UserOp", "operation", "register_op", "user_op", "user_table"]


class OpCompileError(ValueError):
    """A user function that numba cannot compile as a scalar function ``f(z) -> float``."""


class UserOp(int):
    """Operation code of a registered user function (an ``int``; pickles as its function).

    Attributes
    ----------
    function, derivative : callable or None
    name : str or callable or None
        Display: a format string with one ``{}`` or a callable of the column name.
    """

    def __new__(cls, code, function, derivative, name):
        self = super().__new__(cls, code)
        self.function, self.derivative, self.name = function, derivative, name
        return self

    def __reduce__(self):
        return (register_op, (self.function, self.derivative, self.name))

    def operation(self):
        """This operation's :class:`~._optable.Operation` (its compiled value and derivative: the user table)."""
        return Operation(int(self), self.label("z"), None, None, text=lambda z, a, b: self.label(z),
                         latex=lambda z, a, b: self.label(z), sympy=lambda sp, z, a, b: self._sympy(sp, z),
                         casadi=lambda ca, v, a, b: self._casadi(ca, v))

    def _sympy(self, sp, z):
        return sp.Function(getattr(self.function, "__name__", "f").strip("<>"))(z)

    def _casadi(self, ca, v):
        known = _CASADI.get(self.function) if isinstance(self.function, np.ufunc) else None
        if known is None:
            raise ValueError(
                f"the user operation {self.label('z')!r} (code {int(self)}) has no CasADi form: only NumPy's "
                f"{', '.join(sorted(f.__name__ for f in _CASADI))} have one; write the term with built-in "
                "operations (POW, ABS_POW, SQRT, SIGN, STEP) to export the model."
            )
        return getattr(ca, known)(v)

    def label(self, argument):
        """The factor written with ``argument`` (a column name), e.g. ``"tanh(v)"``."""
        if callable(self.name):
            return str(self.name(argument))
        if self.name is not None:
            return str(self.name).format(argument)
        return f"{getattr(self.function, '__name__', 'f')}({argument})"


_OPS = {}  # (function, derivative, name) -> UserOp
_BY_CODE = []  # UserOp by code - USER
_COMPILED = []  # (value, derivative) compiled, by code - USER
_TABLE = [no_user_ops, 0, None]  # the table's address, how many ops it covers, the cfunc (kept alive)

_CASADI = {np.sign: "sign", np.tanh: "tanh", np.sin: "sin", np.cos: "cos", np.exp: "exp", np.arctan: "atan",
           np.abs: "fabs", np.absolute: "fabs"}

_RULES = {np.sign: "0.0 * v", np.tanh: "1.0 - np.tanh(v) ** 2", np.sin: "np.cos(v)", np.cos: "-np.sin(v)",
          np.exp: "np.exp(v)", np.arctan: "1.0 / (1.0 + v * v)", np.abs: "np.sign(v)",
          np.absolute: "np.sign(v)"}


def _jit(source, **names):
    namespace = {"np": np, **names}
    exec(source, namespace)  # noqa: S102 - generated from fixed templates
    return njit(namespace["f"])


def _compile_scalar(function, what):
    if isinstance(function, np.ufunc):
        jitted = _jit("def f(v):\n    return F(v)\n", F=function)
    elif hasattr(function, "py_func"):  # already a numba function
        jitted = function
    else:
        jitted = njit(function)
    try:
        value = jitted(0.5)
        rtype = jitted.nopython_signatures[-1].return_type
    except Exception as exc:  # numba raises several error types; the message says which
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise OpCompileError(
            f"{what} {getattr(function, '__name__', function)!r} cannot be compiled by numba as a scalar "
            f"function f(z) -> float ({type(exc).__name__}: {first})"
        ) from exc
    if not (np.isscalar(value) and str(rtype).startswith(("float", "int", "uint", "bool"))):
        raise OpCompileError(
            f"{what} {getattr(function, '__name__', function)!r} returns {rtype} for a scalar argument; "
            "expected a number (a function of one value)"
        )
    return jitted


def register_op(function, derivative=None, name=None):
    """Compile ``function`` (and ``derivative``) for the compiled path; return its :class:`UserOp`.

    Parameters
    ----------
    function : callable
        Scalar function ``f(z)`` that numba can compile (NumPy ufuncs such as
        ``np.sign`` and functions of them such as ``lambda v: np.tanh(v / 0.02)``).
    derivative : callable, optional
        ``f'(z)``, also compiled. Default: a known rule for NumPy ufuncs, else a
        central difference with step ``6e-6 max(1, |z|)``.
    name : str or callable, optional
        Display of the factor (``"tanh({})"``).

    Returns
    -------
    UserOp
        The same one for the same ``(function, derivative, name)``.

    Raises
    ------
    OpCompileError
        If numba cannot compile the function or the derivative.

    Examples
    --------
    >>> from sindybench.dynamics import evaluate_terms, evaluate_terms_jacobian
    >>> op = register_op(lambda v: np.tanh(v / 0.5), name="tanh({}/0.5)")
    >>> op >= USER, op.label("v")
    (True, 'tanh(v/0.5)')
    >>> evaluate_terms([((0, op, 0.0, 0.0),)], [[0.5]]).round(6).tolist()
    [[0.761594]]
    >>> round(float(evaluate_terms_jacobian([((0, op, 0.0, 0.0),)], [[0.5]])[0, 0, 0]), 5)  # (1 - tanh(1)^2) / 0.5
    0.83995
    """
    try:
        key = (function, derivative, name)
        hash(key)
    except TypeError:
        key = None
    if key is not None and key in _OPS:
        return _OPS[key]
    if not callable(function):
        raise ValueError(f"function must be callable; got {function!r}.")
    value = _compile_scalar(function, "function")
    if derivative is not None:
        slope = _compile_scalar(derivative, "derivative")
    elif isinstance(function, np.ufunc) and function in _RULES:
        slope = _jit(f"def f(v):\n    return {_RULES[function]}\n")
    else:
        slope = _jit("def f(v):\n    h = 6e-6 * max(1.0, abs(v))\n    return (F(v + h) - F(v - h)) / (2.0 * h)\n",
                     F=value)
    op = UserOp(USER + len(_BY_CODE), function, derivative, name)
    _BY_CODE.append(op)
    _COMPILED.append((value, slope))
    if key is not None:
        _OPS[key] = op
    return op


def user_op(code):
    """The registered :class:`UserOp` of ``code``.

    Raises
    ------
    ValueError
        If no user operation has that code in this process.
    """
    i = int(code) - USER
    if not 0 <= i < len(_BY_CODE):
        raise ValueError(f"operation {int(code)} is not a built-in operation (0-4) nor a user operation "
                         f"registered in this process ({USER}-{USER + len(_BY_CODE) - 1}).")
    return _BY_CODE[i]


def operation(code):
    """The :class:`~._optable.Operation` of ``code``: a built-in one, or a registered user operation's.

    Raises
    ------
    ValueError
        If ``code`` is neither.

    Examples
    --------
    >>> operation(2).text("x1", 0.0, float("inf")), operation(register_op(np.tanh)).text("v", 0.0, 0.0)
    ('sqrt(x1)', 'tanh(v)')
    """
    op = builtin_operation(code)
    if op is not None:
        return op
    if int(code) < USER:
        raise ValueError(f"unknown factor operation {int(code)!r}; expected one of {BUILTIN_OPS} or a user "
                         f"operation (from {USER} on).")
    return user_op(code).operation()


def user_table():
    """The address of the compiled table of every registered user operation (a numba ``cfunc``).

    Passed as the ``user`` argument (an int) of the compiled kernels; calling it
    from numba is an indirect call (a few ns) plus the function itself.
    """
    if _TABLE[1] == len(_COMPILED):
        return _TABLE[0]
    lines = ["def table(code, which, v):"]
    names = {"np": np}
    for i, (value, slope) in enumerate(_COMPILED):
        names[f"F{i}"], names[f"D{i}"] = value, slope
        lines.append(f"    if code == {USER + i}:")
        lines.append("        if which == 0:")
        lines.append(f"            return 1.0 * F{i}(v)")
        lines.append(f"        return 1.0 * D{i}(v)")
    lines.append("    return np.nan")
    exec("\n".join(lines), names)  # noqa: S102 - generated from fixed templates
    table = cfunc(USER_SIGNATURE)(names["table"])
    _TABLE[:] = [table.address, len(_COMPILED), table]
    return _TABLE[0]

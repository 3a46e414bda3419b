"""Libraries of Python functions and adapters for external libraries.

A :class:`CustomLibrary` of functions of one column that numba can compile
(``np.sign``, ``lambda v: np.tanh(v / 0.02)``) gets symbolic terms made of user
operations (:func:`sindybench.dynamics.register_op`): it fits, simulates,
refines and predicts on the compiled path like a built-in library. Other
functions, and :class:`ExternalLibrary`, have ``terms_ = None`` and run on the
Python path (about 100-1000x slower; see the docs' architecture page).
"""

import inspect
import warnings
from itertools import combinations

import numpy as np

from ..dynamics._terms import evaluate_terms
from ..dynamics._user import OpCompileError, register_op
from ._base import BaseLibrary, ExternalLibrary, as_component, check_variables
from ._builtin import PolynomialLibrary

__all__ = ["CustomLibrary", "ExternalLibrary", "as_library"]


def _arity(f, i):
    if not callable(f):
        raise ValueError(f"functions[{i}] is not callable; got {f!r}.")
    try:
        params = inspect.signature(f).parameters.values()
    except (TypeError, ValueError):
        return 1
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    n = sum(1 for p in params if p.kind in kinds and p.default is inspect.Parameter.empty)
    if n < 1:
        raise ValueError(f"functions[{i}] takes no positional argument; expected a function of columns.")
    return n


class CustomLibrary(BaseLibrary):
    """Features from Python functions of the columns of ``Z``.

    A function of ``k`` positional arguments is applied to every combination
    of ``k`` distinct selected columns (one column at a time for ``k = 1``);
    it receives 1-D arrays and returns an array of the same length.

    Parameters
    ----------
    functions : sequence of callable
        Vectorised functions, e.g. ``np.sin`` or ``lambda x, y: x * np.tanh(y)``.
    names : sequence of (str or callable), optional
        One per function: a format string with one ``{}`` per argument
        (``"sin({})"``) or a callable taking the argument names. Default
        ``"f0(x0)"``-style names.
    variables : sequence of int, optional
        Columns of ``Z`` to use; default all.
    derivatives : sequence of (callable or None), optional
        One per function: its derivative, used by the sensitivities of the
        refinement. Default: a known rule for NumPy ufuncs (``np.tanh``,
        ``np.sign``, ...), else central differences.
    compile : bool, default=True
        Compile functions of one column with numba (a warning says why when
        one cannot be); False keeps every function on the Python path.

    Attributes
    ----------
    terms_ : list of tuple or None
        One user-operation factor per feature when every function compiled
        (then the model runs on the compiled path), else None.
    n_output_features_ : int

    Examples
    --------
    >>> import numpy as np
    >>> lib = CustomLibrary(functions=[np.tanh, lambda a, b: a * b], names=["tanh({})", "{}*{}"])
    >>> lib.fit(np.zeros((1, 2))).get_feature_names_out(["y", "u"]).tolist()
    ['tanh(y)', 'tanh(u)', 'y*u']
    >>> lib.transform([[0.0, 2.0]]).round(4).tolist()
    [[0.0, 0.964, 0.0]]
    """

    def __init__(self, *, functions=None, names=None, variables=None, derivatives=None, compile=True):
        self.functions = functions
        self.names = names
        self.variables = variables
        self.derivatives = derivatives
        self.compile = compile

    def fit(self, Z, y=None):
        """Check the functions and list the (function, columns) pairs."""
        self._validate_Z(Z, reset=True)
        functions = self.functions
        if functions is None or callable(functions) or len(functions) == 0:
            raise ValueError(f"functions must be a non-empty sequence of callables; got {functions!r}.")
        if self.names is not None and (isinstance(self.names, str) or len(self.names) != len(functions)):
            raise ValueError(
                f"names must be None or hold one name per function ({len(functions)}); got {self.names!r}."
            )
        cols = check_variables(self.variables, self.n_features_in_)
        self.combinations_ = [
            (i, combo) for i, f in enumerate(functions) for combo in combinations(cols, _arity(f, i))
        ]
        if not self.combinations_:
            raise ValueError("CustomLibrary has no features: every function takes more arguments than variables.")
        if self.derivatives is not None and (callable(self.derivatives) or len(self.derivatives) != len(functions)):
            raise ValueError(f"derivatives must be None or hold one entry (callable or None) per function "
                             f"({len(functions)}); got {self.derivatives!r}.")
        self.terms_ = None
        self.n_output_features_ = len(self.combinations_)
        if self.compile:
            self.terms_ = self._compiled_terms(np.asarray(Z, dtype=float))
        return self

    def _compiled_terms(self, Z):
        """User-operation terms of the features, or None (with a warning saying why)."""
        ops = []
        for i, f in enumerate(self.functions):
            if _arity(f, i) != 1:
                return _python_path(f"functions[{i}] takes {_arity(f, i)} arguments; only functions of one "
                                    "column are compiled")
            derivative = None if self.derivatives is None else self.derivatives[i]
            if derivative is not None and not callable(derivative):
                raise ValueError(f"derivatives[{i}] is not callable; got {derivative!r}.")
            name = f"f{i}({{}})" if self.names is None else self.names[i]
            try:
                ops.append(register_op(f, derivative, name))
            except OpCompileError as exc:
                return _python_path(f"functions[{i}]: {exc}")
        terms = [((combo[0], ops[i], 0.0, 0.0),) for i, combo in self.combinations_]
        reference = self._python_transform(Z)
        compiled = evaluate_terms(terms, Z)
        if not np.allclose(compiled, reference, rtol=1e-9, atol=1e-12, equal_nan=True):
            k = int(np.argmax(np.any(~np.isclose(compiled, reference, rtol=1e-9, atol=1e-12, equal_nan=True),
                                     axis=0)))
            return _python_path(f"functions[{self.combinations_[k][0]}] compiled for one value differs from the "
                                "function applied to arrays")
        return terms

    def _transform(self, Z):
        if self.terms_ is not None:
            return evaluate_terms(self.terms_, Z)
        return self._python_transform(Z)

    def _python_transform(self, Z):
        out = np.empty((Z.shape[0], len(self.combinations_)))
        for k, (i, combo) in enumerate(self.combinations_):
            value = np.asarray(self.functions[i](*(Z[:, c] for c in combo)), dtype=float)
            try:
                out[:, k] = np.broadcast_to(value, (Z.shape[0],))
            except ValueError as exc:
                raise ValueError(
                    f"functions[{i}] returned shape {value.shape}; expected ({Z.shape[0]},) (one value per sample)."
                ) from exc
        return out

    def _feature_names(self, names):
        out = []
        for i, combo in self.combinations_:
            args = [names[c] for c in combo]
            fmt = None if self.names is None else self.names[i]
            if fmt is None:
                out.append(f"f{i}({', '.join(args)})")
            elif callable(fmt):
                out.append(str(fmt(*args)))
            else:
                out.append(str(fmt).format(*args))
        return out


def _python_path(reason):
    warnings.warn(f"CustomLibrary: {reason}; the library runs on the Python path (about 100-1000x slower to "
                  "simulate and refine; compile=False silences this).", UserWarning, stacklevel=4)


def as_library(obj):
    """Return ``obj`` as a sindybench library.

    Parameters
    ----------
    obj : library, pysindy feature library, scikit-learn transformer or None
        ``None`` gives ``PolynomialLibrary()`` (degree 2 with bias); a
        sindybench library is returned as is; anything else with ``fit`` and
        ``transform`` is wrapped in :class:`ExternalLibrary`.

    Examples
    --------
    >>> import pysindy as ps
    >>> type(as_library(ps.FourierLibrary())).__name__
    'ExternalLibrary'
    >>> as_library(None)
    PolynomialLibrary()
    """
    if obj is None:
        return PolynomialLibrary()
    return as_component(obj)
